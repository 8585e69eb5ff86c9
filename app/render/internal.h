/* The renderer's insides, shared by its files (app/render/):
 *   camera.c     views (perspective, orthographic, the light's), the fitted camera;
 *   colliders.c  colliders in world space, their signed distance, sphere tracing, their shadow map;
 *   splat.c      particles projected onto a view and splatted into a z-buffer by bands of rows;
 *   shade.c      colours (tones, palettes, colour maps, sRGB), shadows, per-pixel shading 2D and 3D;
 *   legend.c     the colour legend drawn over the image;
 *   render.c     options, validation, the scene box and radii, and sm_render putting them together.
 * Not a public header: app/render.h is. */
#ifndef SM_APP_RENDER_INTERNAL_H
#define SM_APP_RENDER_INTERNAL_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>

#include "app/render.h"

#ifdef _OPENMP
#include <omp.h>
#define OMP(x) _Pragma(#x)
#else
#define OMP(x)
#endif

#define PI_D 3.14159265358979323846
#define NO_PARTICLE UINT32_MAX /* z-buffer index of a pixel no particle covers */
#define BAND_ROWS 8            /* rows per band of the parallel splatting */

/* ------------------------------------------------------------------------------------------ */
/* Small vector helpers                                                                         */

static inline double dot3(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

static inline void cross3(const double a[3], const double b[3], double r[3]) {
    r[0] = a[1] * b[2] - a[2] * b[1];
    r[1] = a[2] * b[0] - a[0] * b[2];
    r[2] = a[0] * b[1] - a[1] * b[0];
}

static inline double norm3(const double a[3]) { return sqrt(dot3(a, a)); }

/* Scales a to unit length; 0 (a unchanged) if it is zero or not finite. */
static inline int normalize3(double a[3]) {
    double n = norm3(a);
    if (!(n > 0) || !isfinite(n)) return 0;
    a[0] /= n;
    a[1] /= n;
    a[2] /= n;
    return 1;
}

static inline int finite3(const double a[3]) { return isfinite(a[0]) && isfinite(a[1]) && isfinite(a[2]); }

/* ------------------------------------------------------------------------------------------ */
/* Types                                                                                        */

/* A perspective or orthographic view (the camera, or the light's for a shadow map). */
typedef struct view {
    double eye[3], r[3], u[3], f[3]; /* position; right, up, forward unit vectors */
    int ortho;
    double focal;  /* perspective: pixels per unit of (lateral / depth); ortho: pixels per metre */
    double cx, cy; /* principal point, pixels */
} view;

/* A collider as drawn: its shapes in world space. */
typedef struct rcoll {
    sm_shape s[SM_MAX_COLLIDER_SHAPES]; /* in world space (pose composed in) */
    int ns;
    int inside_out;
    int plane;            /* a lone half-space: phi = pn . (x - pc) */
    double pn[3], pc[3];
    int ground_like;      /* a plane facing up: drawn like the ground */
    int container;        /* unbounded solid (inside-out): drawn as walls in 2D */
    int visible;          /* bounds intersect the clip box */
    double lo[3], hi[3];  /* where to look for its surface (within the clip box) */
} rcoll;

/* A particle on a target: centre (pixels), radius (pixels; < 0: not drawn), centre depth and
 * world radius (depth units). */
typedef struct proj {
    float sx, sy, sr, z, rw;
} proj;

typedef struct shadow_map {
    view v;
    int w, h;
    double texel; /* metres per texel */
    float *z;     /* depth along the light (+inf: nothing) */
} shadow_map;

/* Everything one sm_render call sets up and the shading reads. */
typedef struct rctx {
    const sm_frame *f;
    const sm_render_opts *o;
    int W, H, dim, threads;
    const float *rad; /* per-particle radius, or NULL: rconst */
    float rconst;
    double lo[3], hi[3]; /* clip box C */
    double glo[3], ghi[3]; /* ground footprint (x, z): the domain grown by 5% */
    double diag;
    view cam;
    double L[3];
    double ambient;
    int has_ground;
    double gy, checker;
    rcoll *col;
    int ncol;
    shadow_map sp, sc; /* particles, colliders */
    int shadows;
    float *zb;
    uint32_t *zi;
    proj *P;
    double cmin, cmax;
    float cmap_lin[256][3];
    float pal_lin[8][3];
    float ground_lin[2][3], coll_lin[3];
    uint8_t enc[4096];
} rctx;

static inline float prad(const rctx *R, size_t i) { return R->rad ? R->rad[i] : R->rconst; }

/* ------------------------------------------------------------------------------------------ */
/* legend.c                                                                                     */

/* Draws the colour legend of R's colour mode into the shaded image. */
void render_draw_legend(const rctx *R, uint8_t *rgb);

/* ------------------------------------------------------------------------------------------ */
/* camera.c                                                                                     */

/* Builds the basis from eye, target, up. 0 if degenerate. */
int render_view_basis(view *v, const double eye[3], const double target[3], const double up[3]);
/* Screen position (pixels) and depth along f. */
void render_view_project(const view *v, const double p[3], double *sx, double *sy, double *z);
/* Ray through pixel coordinates (px, py) (continuous). Perspective: d has forward component 1, so
 * the ray parameter is the depth along f; orthographic: d = f. */
void render_view_ray(const view *v, double px, double py, double o[3], double d[3]);
/* The fitted camera for box [lo, hi] and a W x H image. */
sm_camera render_fit_camera(int dim, const double lo[3], const double hi[3], int W, int H);
/* R->cam from camera c (R->W, R->H, R->lo/hi, R->diag set). */
void render_setup_view(rctx *R, const sm_camera *c);
/* Orthographic light view covering the clip box with about `size` texels on the longer side;
 * m->z allocated and cleared. SM_OK or SM_ERR_NOMEM. */
sm_status render_setup_light_map(rctx *R, shadow_map *m, int size);

/* ------------------------------------------------------------------------------------------ */
/* colliders.c                                                                                  */

/* Signed distance of collider c at x (negative inside the solid) and its gradient. */
double render_collider_phi(const rcoll *c, int dim, const double x[3]);
void render_collider_grad(const rcoll *c, int dim, const double x[3], double g[3]);
/* First surface of collider c along o + t d (|d| = 1) in [t0, t1]; eps(t) = e0 + e1 t. */
int render_collider_hit(const rcoll *c, const double o[3], const double d[3], double t0, double t1, double e0,
                        double e1, double *thit);
/* R->col[0..ncol) from the options' colliders and poses, bounded by the clip box. */
void render_setup_colliders(rctx *R);
/* R->sc: first collider surface along the light per texel. */
void render_collider_shadow(rctx *R);

/* ------------------------------------------------------------------------------------------ */
/* splat.c                                                                                      */

/* Projects the particles onto a view of w x h pixels into R->P (depth_shape: sphere depth). */
void render_project_all(const rctx *R, const view *v, int w, int h, int depth_shape);
/* Splats n projections into a w x h target (zb = +inf, zi = NO_PARTICLE or NULL initially).
 * SM_OK or SM_ERR_NOMEM. */
sm_status render_splat_all(const proj *P, size_t n, int w, int h, float *zb, uint32_t *zi, int threads);

/* ------------------------------------------------------------------------------------------ */
/* shade.c                                                                                      */

/* The colour tables of R (sRGB encoding, colour map, palettes, ground and collider colours) and
 * the colour map's range (R->f, R->o, R->threads set). */
void render_setup_colours(rctx *R);
void render_shade_3d(const rctx *R, uint8_t *rgb);
void render_shade_2d(const rctx *R, uint8_t *rgb);

#endif
