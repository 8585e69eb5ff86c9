/* Preview renderer: particle frames to RGB images (app/render/: camera.c, splat.c, shade.c,
 * colliders.c, render.c; PNG files through app/io/png.h).
 *
 * A frame (app/frame.h) comes from a PLY file (app/io/ply.h: sm_ply_read) or from a world in
 * memory (sm_frame_from_world). sm_render draws it into an 8-bit RGB buffer:
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

#include "app/frame.h"
#include "sandmpm/sandmpm.h"

#ifdef __cplusplus
extern "C" {
#endif

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
    int legend;                 /* 1: a colour legend in the bottom-left corner (speed and q: the map and
                                   its range; material: a swatch per material); 0 (default): none */
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
 * Particles with non-finite position or radius are skipped. Returns SM_OK, SM_ERR_INVALID (invalid
 * options, message naming the field) or SM_ERR_NOMEM. */
sm_status sm_render(const sm_frame *f, const sm_render_opts *o, uint8_t *rgb, char *err, size_t errlen);

/* The camera sm_render uses when o->has_camera is 0 (fitted to the domain/particle box of frame f,
 * looking from the front-left and above). */
sm_camera sm_render_fit_camera(const sm_frame *f, const sm_render_opts *o);

/* The sand tone (sRGB in [0,1]) of the particle with id (or index) `id` for a seed. */
void sm_render_tone(uint64_t seed, uint64_t id, float rgb[3]);

/* Convenience: reads a PLY frame, renders it and writes the PNG. Returns SM_OK or the status of
 * the step that failed (sm_ply_read, sm_render, sm_png_write), with its message. */
sm_status sm_render_ply_to_png(const char *ply_path, const char *png_path, const sm_render_opts *o, char *err,
                               size_t errlen);

#ifdef __cplusplus
}
#endif
#endif
