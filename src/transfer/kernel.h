/* 1D B-spline weights for the MPM interpolation functions (thesis 3.18-3.21).
 *
 * The extracted thesis text swaps the names at (3.20)/(3.21): the spline with support |x| < 3/2
 * (3 nodes per axis) is the quadratic one, N(x) = 3/4 - x^2 (|x| < 1/2), (3/2 - |x|)^2 / 2
 * (1/2 <= |x| < 3/2); the one with support |x| < 2 (4 nodes) is the cubic one,
 * N(x) = |x|^3/2 - x^2 + 2/3 (|x| < 1), (2 - |x|)^3 / 6 (1 <= |x| < 2).
 * In d dimensions the weight is the product of the 1D weights (3.18), (3.19).
 *
 * X is the position in grid units (node i at X = i). Nodes base .. base+S-1 get weights w[k]
 * = N(X - (base + k)) and derivatives dw[k] = dN/dX (multiply by 1/dx for physical units). */
#ifndef SM_TRANSFER_KERNEL_H
#define SM_TRANSFER_KERNEL_H

#include "core/common.h"

/* Weights and derivatives for the stencil starting at node b, given fx = X - b (in [0.5, 1.5)
 * for S = 3, [1, 2) for S = 4). */
static inline __attribute__((always_inline)) void sm_kernel_1d_at(int S, sm_real fx, sm_real w[4], sm_real dw[4]) {
    if (S == 3) {
        sm_real t0 = SM_R(1.5) - fx, t1 = fx - SM_R(1.0), t2 = fx - SM_R(0.5);
        w[0] = SM_R(0.5) * t0 * t0;
        w[1] = SM_R(0.75) - t1 * t1;
        w[2] = SM_R(0.5) * t2 * t2;
        w[3] = 0;
        dw[0] = -t0;
        dw[1] = SM_R(-2.0) * t1;
        dw[2] = t2;
        dw[3] = 0;
    } else {
        sm_real r1 = fx - SM_R(1.0), r2 = SM_R(2.0) - fx;
        sm_real u0 = SM_R(2.0) - fx, u3 = fx - SM_R(1.0); /* 2 - r for the outer nodes */
        w[0] = u0 * u0 * u0 / SM_R(6.0);
        w[1] = SM_R(0.5) * r1 * r1 * r1 - r1 * r1 + SM_R(2.0) / SM_R(3.0);
        w[2] = SM_R(0.5) * r2 * r2 * r2 - r2 * r2 + SM_R(2.0) / SM_R(3.0);
        w[3] = u3 * u3 * u3 / SM_R(6.0);
        dw[0] = SM_R(-0.5) * u0 * u0;
        dw[1] = SM_R(1.5) * r1 * r1 - SM_R(2.0) * r1;
        dw[2] = -(SM_R(1.5) * r2 * r2 - SM_R(2.0) * r2);
        dw[3] = SM_R(0.5) * u3 * u3;
    }
}

static inline __attribute__((always_inline)) int sm_kernel_1d(int S, sm_real X, sm_real w[4], sm_real dw[4]) {
    int b = S == 3 ? (int)sm_floor(X - SM_R(0.5)) : (int)sm_floor(X) - 1;
    sm_kernel_1d_at(S, X - (sm_real)b, w, dw);
    return b;
}

/* Stencil base node for position X in grid units (double: positions are double, particles.h). */
static inline int sm_kernel_base(int S, double X) {
    return S == 3 ? (int)floor(X - 0.5) : (int)floor(X) - 1;
}

/* sm_kernel_1d for a position in grid units given in double: the base and the fractional offset
 * are formed in double, the weights from the offset rounded to sm_real. */
static inline __attribute__((always_inline)) int sm_kernel_1d_pos(int S, double X, sm_real w[4], sm_real dw[4]) {
    int b = sm_kernel_base(S, X);
    sm_kernel_1d_at(S, (sm_real)(X - (double)b), w, dw);
    return b;
}

#endif
