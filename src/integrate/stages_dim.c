/* The dimension table (stages.h) for SM_DIM: each entry is the stage's function compiled for
 * this dimension, from the file named in stages.h. */
#include "core/dim.h"

#include "integrate/stages.h"

const sm_stages SM_FN(sm_stages) = {
    .dim = D,
    .bin = SM_FN(sm_bin_particles),
    .bin_more = SM_FN(sm_bin_more),
    .p2g = SM_FN(sm_p2g),
    .contact_gate = SM_FN(sm_contact_gate),
    .grid_update = SM_FN(sm_grid_update),
    .implicit_solve = SM_FN(sm_implicit_solve),
    .implicit_jvp_check = SM_FN(sm_implicit_jvp_check),
    .g2p = SM_FN(sm_g2p),
    .plasticity = SM_FN(sm_plasticity),
};
