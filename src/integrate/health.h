/* Numerical health of the step (DESIGN §5, tier 3): the checks between the stages and their
 * messages, which name the step, the time, the particle (and its material) or grid node. A
 * failed check leaves the particles as they were after the last good stage; the step then stops
 * the world. */
#ifndef SM_INTEGRATE_HEALTH_H
#define SM_INTEGRATE_HEALTH_H

#include "world/world.h"

/* Before the step: every particle finite and none moving more than one cell in dt (the CFL bound
 * that the stencil and the colour schedule rely on). Scans the particles only when they changed
 * outside a step (w->dirty) or the last G2P's largest speed breaks the bound; otherwise the last
 * step's checks cover them. */
sm_status sm_health_check_start(sm_world *w, double dt);
/* After the grid update: every node's v-bar and v-tilde finite; else names the nearest particle. */
sm_status sm_health_check_grid(sm_world *w, double dt);
/* After plasticity: G2P and plasticity flagged no non-finite value (w->step_bad); names the first
 * bad particle. The particles are clean again (w->dirty = 0). */
sm_status sm_health_check_end(sm_world *w, double dt);

#endif
