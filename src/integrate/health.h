/* Numerical health of the step (DESIGN §5, tier 3): the checks between the stages and their
 * messages, which name the step, the time, the particle (and its material) or grid node. A
 * failed check leaves the particles as they were after the last good stage; the step then stops
 * the world, except for a CFL violation found before the step (nothing has moved: a smaller dt
 * may be tried). */
#ifndef SM_INTEGRATE_HEALTH_H
#define SM_INTEGRATE_HEALTH_H

#include "world/world.h"

/* Before the step: every particle finite and none moving more than one cell in dt (the CFL bound
 * that the stencil and the colour schedule rely on, with a relative slack of 1e-5 on |v|^2 so
 * that the controller's own dt passes). Scans the particles only when they changed outside a
 * step (w->dirty) or the last G2P's largest speed breaks the bound; otherwise the last step's
 * checks cover them. *too_fast = 1 says the failure is the CFL bound alone: nothing was changed,
 * the step may be retried with a smaller dt. */
sm_status sm_health_check_start(sm_world *w, double dt, int *too_fast);
/* After the grid update: every node's v-bar and v-tilde finite; else names the nearest particle.
 * Scans the grid only when the update did not test what it wrote (w->grid_finite: the implicit
 * solve) or found a non-finite value. */
sm_status sm_health_check_grid(sm_world *w, double dt);
/* After plasticity: G2P and plasticity flagged no non-finite value (w->step_bad); names the first
 * bad particle. The particles are clean again (w->dirty = 0). */
sm_status sm_health_check_end(sm_world *w, double dt);

#endif
