/* Preview renderer: particle frames to RGB images and PNG files (libpng).
 *
 * A frame (sm_frame) comes from a PLY file (sm_ply_read) or from a world in memory
 * (sm_frame_from_world). sm_render draws it into an 8-bit RGB buffer:
 *   3D: every particle is a sphere impostor (exact per-pixel depth and normal of the sphere,
 *       orthographic approximation per particle) in a z-buffer; a ground plane (checker, lighter
 *       than the sand) over the domain footprint; colliders by sphere tracing their signed distance
 *       (sm_shape_distance with the pose applied; a lone half-space analytically). A directional
 *       light with shadows from two orthographic shadow maps (particles at full resolution,
 *       colliders coarser), Lambert + a hemispheric ambient term, sRGB output. Containers
 *       (inside-out colliders) are drawn from the inside: the walls between the camera and the
 *       interior are not drawn and cast no shadow, so the sand inside stays visible.
 *   2D: disks in an orthographic xy view, shaded as hemispheres, no shadows; colliders filled,
 *       unclipped (containers as walls 1% of the image height thick), the ground as everything
 *       below ground_y.
 * The background is a vertical sky gradient (a pure function of the row).
 *
 * Conventions: y up; pixel (0,0) is the top-left; pixel centres at integer + 0.5. A perspective
 * camera has a vertical field of view fov_deg over the image height. Results are bitwise identical
 * for any thread count and across runs (per-pixel work is independent; the z-buffer keeps the
 * nearest surface, ties to the lowest particle index). */
#ifndef SM_APP_RENDER_H
#define SM_APP_RENDER_H

#include <stddef.h>
#include <stdint.h>

#include "sandmpm/sandmpm.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ------------------------------------------------------------------------------------------ */
/* Frames                                                                                       */

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

/* Reads a PLY frame. Properties are found by name in the header, in any order, with any extra
 * properties and elements (fixed-size elements before the vertex element are skipped):
 * x y [z] [vx vy vz] [material] [q] [volume] [id], any PLY scalar type; formats
 * binary_little_endian, binary_big_endian and ascii. dim: from a "comment dim 2|3" line, else 2
 * if there is no z property or every z and vz is 0, else 3. Optional "comment domain x0 y0 z0 x1
 * y1 z1" fills has_domain/domain_*.
 * Returns 0; 4 (SM_ERR_IO) if the file cannot be opened or read; 2 (SM_ERR_INVALID) if it is not a
 * PLY file, the header is malformed or unsupported, or the data is truncated; 5 (SM_ERR_NOMEM).
 * On failure *f is empty (n = 0, NULL arrays) and err holds "PATH: problem". */
int sm_ply_read(const char *path, sm_frame *f, char *err, size_t errlen);

/* Fills a frame from a world's particles (volume from V0, domain from the world's definition).
 * Returns 0 or 5 (out of memory, message in err). */
int sm_frame_from_world(const sm_world *w, sm_frame *f, char *err, size_t errlen);

/* Frees the arrays and zeroes the frame. Accepts an already-freed or zeroed frame. */
void sm_frame_free(sm_frame *f);

/* ------------------------------------------------------------------------------------------ */
/* Rendering                                                                                    */

typedef enum sm_color_mode {
    SM_COLOR_SAND = 0,     /* random brown tone per particle (seeded hash of its id or index) */
    SM_COLOR_SPEED = 1,    /* |v| through a viridis-like map over color_range (m/s) */
    SM_COLOR_MATERIAL = 2, /* a distinct hue per material id (id mod 8), slight per-particle jitter */
    SM_COLOR_Q = 3         /* hardening state q through the same map over color_range */
} sm_color_mode;

typedef enum sm_ground_mode {
    SM_GROUND_AUTO = 0, /* at the domain's bottom (domain_min[1]), else below the lowest particle */
    SM_GROUND_NONE = 1,
    SM_GROUND_AT = 2    /* at ground_y */
} sm_ground_mode;

/* A camera. 3D: looks from eye at target, up roughly up. 2D: always orthographic along -z, centred
 * on target (x, y); eye, up and fov_deg are ignored. */
typedef struct sm_camera {
    double eye[3], target[3], up[3];
    double fov_deg;      /* vertical field of view; <= 0: orthographic 3D view (ortho_height) */
    double ortho_height; /* orthographic view height, m (3D with fov_deg <= 0, and 2D; 0 = fit) */
} sm_camera;

typedef struct sm_render_opts {
    int width, height;          /* pixels, 1..16384 each. Default 1280 x 720. */
    sm_color_mode color;        /* default SM_COLOR_SAND */
    double color_range[2];      /* speed (m/s) or q range of the colour map; hi <= lo: 0 .. this frame's max
                                   (which changes from frame to frame: give a range for animations) */
    double radius;              /* particle radius, m; 0 (default): from the volume (sphere, or disk in 2D, of
                                   volume V0), or, without volumes, half the mean spacing of the particles'
                                   bounding box (sqrt/cbrt of box volume / n) */
    double radius_scale;        /* multiplies the radius. Default 1. */
    double light_dir[3];        /* direction towards the light (need not be unit). Default (-0.75, 0.8, 0.05). */
    double ambient;             /* ambient share in [0, 1]. Default 0.3. */
    int shadows;                /* 1 (default): shadow maps; 0: none */
    int shadow_size;            /* particle shadow map texels along its longer side; 0 (default): auto,
                                   max(width, height) clamped to [512, 4096] */
    uint64_t seed;              /* seed of the per-particle tones. Default 1. */
    int threads;                /* OpenMP threads; 0 = OpenMP's default. Output does not depend on it. */
    int has_camera;             /* 0 (default): fitted to the domain grown by 5% (or the particles' box):
                                   3D from the front-left (azimuth -35 deg) and above (28 deg), fov 35 deg,
                                   every box corner in the image; 2D the box fitted to the image */
    sm_camera camera;
    int has_domain;             /* domain box: camera fit, ground footprint, shadow and collider bounds;
                                   0: the frame's domain if it has one, else the particles' bounding box */
    double domain_min[3], domain_max[3];
    sm_ground_mode ground;      /* default SM_GROUND_AUTO */
    double ground_y;            /* m, for SM_GROUND_AT */
    /* Colliders to draw: their definitions (shapes, inside_out) and current poses (poses == NULL:
     * each definition's pose). 3D: clipped to the domain box grown by 5% (and the particles).
     * With SM_GROUND_AUTO, a lone upward half-space collider replaces the ground plane. */
    const sm_collider_def *colliders;
    const sm_pose *poses;
    int ncolliders;
} sm_render_opts;

/* Defaults as documented on each field. */
sm_render_opts sm_render_opts_default(void);

/* Renders frame f into rgb (width*height*3 bytes, row-major from the top-left). f may have n = 0.
 * Particles with non-finite position or radius are skipped. Returns 0, 2 (invalid options, message
 * naming the field) or 5 (out of memory). */
int sm_render(const sm_frame *f, const sm_render_opts *o, uint8_t *rgb, char *err, size_t errlen);

/* The camera sm_render uses when o->has_camera is 0 (fitted to the domain/particle box of frame f,
 * looking from the front-left and above). */
sm_camera sm_render_fit_camera(const sm_frame *f, const sm_render_opts *o);

/* The sand tone (sRGB in [0,1]) of the particle with id (or index) `id` for a seed. */
void sm_render_tone(uint64_t seed, uint64_t id, float rgb[3]);

/* Writes an 8-bit RGB PNG atomically (PATH.tmp, then rename). Returns 0, 4 (I/O, message with the
 * path) or 2 (bad size). */
int sm_png_write(const char *path, int w, int h, const uint8_t *rgb, char *err, size_t errlen);

/* Reads a PNG as 8-bit RGB (converting palette, grey, 16-bit and alpha). *rgb is malloc'ed.
 * Returns 0, 4 (cannot open) or 2 (not a PNG / corrupt). */
int sm_png_read(const char *path, int *w, int *h, uint8_t **rgb, char *err, size_t errlen);

/* Convenience: reads a PLY frame, renders it and writes the PNG. Returns 0, 2, 4 or 5 as above. */
int sm_render_ply_to_png(const char *ply_path, const char *png_path, const sm_render_opts *o, char *err,
                         size_t errlen);

#ifdef __cplusplus
}
#endif
#endif
