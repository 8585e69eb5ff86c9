/* Singular value decompositions of 2x2 and 3x3 matrices (row-major).
 *
 * F = U diag(sigma) V^T with U and V proper rotations (det = +1). sigma is sorted by decreasing
 * absolute value; all entries are >= 0 except that the last one carries the sign of det(F)
 * (a "signed" SVD, as MPM needs for inverted elements). Works in sm_real. */
#ifndef SM_MATH_SVD_H
#define SM_MATH_SVD_H

#include "core/common.h"

void sm_svd2(const sm_real F[4], sm_real U[4], sm_real sigma[2], sm_real V[4]);
void sm_svd3(const sm_real F[9], sm_real U[9], sm_real sigma[3], sm_real V[9]);

#endif
