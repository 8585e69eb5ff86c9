/* A frame of particles as the renderer and the readers see it: float positions and attributes,
 * owned arrays. Filled from a PLY file (app/io/ply.h: sm_ply_read) or from a world in memory
 * (sm_frame_from_world). */
#ifndef SM_APP_FRAME_H
#define SM_APP_FRAME_H

#include <stddef.h>
#include <stdint.h>

#include "sandmpm/sandmpm.h"

#ifdef __cplusplus
extern "C" {
#endif

/* One frame of particles. Arrays are owned by the frame (sm_frame_free). */
typedef struct sm_frame {
    size_t n;           /* particles */
    int dim;            /* 2 or 3 */
    float *x;           /* positions, 3n (z = 0 in 2D) */
    float *v;           /* velocities, 3n (zeros if the source has none) */
    float *q;           /* hardening state, n (zeros if absent) */
    float *volume;      /* V0, n (m^3; m^2 in 2D), or NULL if the source has no volume */
    uint16_t *material; /* material id, n (zeros if absent) */
    uint32_t *id;       /* stable particle ids, n, or NULL (tones then hash the index) */
    int has_velocity, has_q, has_material;
    int has_domain;     /* from a "comment domain x0 y0 z0 x1 y1 z1" header line, or the world */
    double domain_min[3], domain_max[3];
} sm_frame;

/* Allocates the zeroed arrays of n particles into an empty frame (volume and id only if asked).
 * Returns SM_OK, or SM_ERR_NOMEM (the frame then holds what was allocated: sm_frame_free it). */
sm_status sm_frame_alloc(sm_frame *f, size_t n, int want_volume, int want_id);

/* Fills a frame from a world's particles in id order, as the frame files hold them (volume from
 * V0, ids, domain from the world's definition).
 * Returns SM_OK or SM_ERR_NOMEM (message in err; the frame is then empty). */
sm_status sm_frame_from_world(const sm_world *w, sm_frame *f, char *err, size_t errlen);

/* Frees the arrays and zeroes the frame. Accepts an already-freed or zeroed frame. */
void sm_frame_free(sm_frame *f);

#ifdef __cplusplus
}
#endif
#endif
