/* The plasticity stage (thesis Algorithm 2, stage 7 of the step): for every particle, the SVD of
 * the trial F^E-hat, the Drucker-Prager projection, the hardening update (3.78)-(3.80), then the
 * Kirchhoff stress tau of the projected F^E for the next step's P2G (material/plastic_batch.h
 * does the arithmetic, SM_PLASTIC_LANES particles at a time). */
#ifndef SM_MATERIAL_PLASTICITY_H
#define SM_MATERIAL_PLASTICITY_H

#include "material/material_rt.h"

/* What the stage reads and writes: particles [first, n). */
typedef struct sm_plasticity_io {
    size_t first, n;
    sm_real *F;                  /* in: trial F^E-hat (after G2P); out: projected F^E */
    sm_real *alpha, *q;          /* in/out: Drucker-Prager alpha, hardening state */
    sm_real *tau;                /* out: Kirchhoff stress of F^E, SM_NSYM(d) values */
    const uint16_t *mat;         /* material ids */
    const sm_material_rt *mats;  /* their parameters (law) */
    int threads;
} sm_plasticity_io;

#ifdef SM_DIM
/* Returns 1 if a particle's new F^E or tau is not finite, else 0. */
int SM_FN(sm_plasticity)(const sm_plasticity_io *io);
#endif

#endif
