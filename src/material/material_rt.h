/* A material as the step uses it: the user's definition and everything the hot loops need,
 * precomputed once by sm_world_add_material (world/materials.c). */
#ifndef SM_MATERIAL_RT_H
#define SM_MATERIAL_RT_H

#include "material/plastic_batch.h"

typedef struct sm_material_rt {
    sm_material_def def;
    sm_plastic_params law;  /* Lame parameters (Pa), Drucker-Prager and hardening (radians) */
    sm_real density;        /* kg/m^3: a particle's mass is density * vol0 */
    sm_real alpha0;         /* alpha at q = 0 (fixed angle or hardening start) */
    double wave_speed;      /* sqrt((lambda + 2 mu)/rho), m/s */
} sm_material_rt;

/* Mass of particle p, kg (density of its material times its initial volume). */
static inline sm_real sm_particle_mass_of(const sm_material_rt *mats, const uint16_t *mat, const sm_real *vol0, size_t p) {
    return mats[mat[p]].density * vol0[p];
}

#endif
