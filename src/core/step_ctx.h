/* The step context (DESIGN §3, Box2D's b2StepContext): the numbers every stage of one step
 * reads, filled once per step from the world's definition (integrate/step.c). The arrays a stage
 * reads and writes come in the stage's own argument struct, never through the world. */
#ifndef SM_CORE_STEP_CTX_H
#define SM_CORE_STEP_CTX_H

#include "core/common.h"

typedef struct sm_step_ctx {
    double dt;            /* time step, s */
    sm_real dx, inv_dx;   /* grid spacing, m, and its inverse */
    sm_real lo[3];        /* domain_min, m: node (i, j, k) sits at lo + (i, j, k) dx */
    double pos_lo[3];     /* the same in double, for positions (particles.h) */
    double pos_dx, pos_inv_dx; /* dx and 1/dx in double, for positions */
    sm_real gravity[3];   /* m/s^2 */
    int cells[3];         /* cells per axis (1 along z in 2D) */
    int stencil;          /* kernel support in nodes per axis: 3 (quadratic) or 4 (cubic) */
    int transfer;         /* sm_transfer: APIC, PIC or FLIP */
    sm_real flip_ratio;   /* FLIP blend (3.111) */
    int threads;          /* OpenMP threads of every parallel loop */
} sm_step_ctx;

#endif
