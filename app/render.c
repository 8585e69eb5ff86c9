/* Preview renderer and PNG I/O; see render.h.
 *
 * Pipeline of sm_render (3D):
 *   1. scene box C = (domain or particle box) grown by 5%: ground footprint, collider clip box,
 *      shadow-map extent; camera given or fitted to C;
 *   2. particle shadow map: particles projected orthographically along the light and splatted as
 *      sphere impostors (min depth per texel); collider shadow map (coarser): sphere tracing of
 *      each collider per texel;
 *   3. camera z-buffer: particles projected and splatted (depth, then particle index);
 *   4. per pixel: the nearest of the z-buffer particle, the colliders (sphere tracing up to that
 *      depth) and the ground plane; Lambert + ambient, shadows by 2x2 percentage-closer lookups;
 *      sRGB encoding by a table.
 * Splatting is parallel over bands of rows: particles are binned into bands in index order (fixed
 * chunking, independent of the thread count), and each band is written by one thread, so every
 * pixel sees the same sequence of particles whatever the threads. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <float.h>
#include <limits.h>
#include <math.h>
#include <png.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#ifdef _OPENMP
#include <omp.h>
#define OMP(x) _Pragma(#x)
#else
#define OMP(x)
#endif

#include "app/render.h"

enum { RC_OK = 0, RC_BAD = 2, RC_IO = 4, RC_NOMEM = 5 };

#define PI_D 3.14159265358979323846
#define NO_PARTICLE UINT32_MAX
#define BAND_ROWS 8

/* ------------------------------------------------------------------------------------------ */
/* Small vector helpers                                                                         */

static double dot3(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

static void cross3(const double a[3], const double b[3], double r[3]) {
    r[0] = a[1] * b[2] - a[2] * b[1];
    r[1] = a[2] * b[0] - a[0] * b[2];
    r[2] = a[0] * b[1] - a[1] * b[0];
}

static double norm3(const double a[3]) { return sqrt(dot3(a, a)); }

static int normalize3(double a[3]) {
    double n = norm3(a);
    if (!(n > 0) || !isfinite(n)) return 0;
    a[0] /= n;
    a[1] /= n;
    a[2] /= n;
    return 1;
}

static int finite3(const double a[3]) { return isfinite(a[0]) && isfinite(a[1]) && isfinite(a[2]); }

/* Unit quaternion (w,x,y,z) to a row-major rotation matrix. */
static void quat_mat(const double q[4], double R[9]) {
    double w = q[0], x = q[1], y = q[2], z = q[3];
    R[0] = 1 - 2 * (y * y + z * z);
    R[1] = 2 * (x * y - w * z);
    R[2] = 2 * (x * z + w * y);
    R[3] = 2 * (x * y + w * z);
    R[4] = 1 - 2 * (x * x + z * z);
    R[5] = 2 * (y * z - w * x);
    R[6] = 2 * (x * z - w * y);
    R[7] = 2 * (y * z + w * x);
    R[8] = 1 - 2 * (x * x + y * y);
}

/* Normalised copy; an all-zero (or non-finite) quaternion is the identity. */
static void quat_norm(const double q[4], double r[4]) {
    double n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (!(n > 0) || !isfinite(n)) {
        r[0] = 1;
        r[1] = r[2] = r[3] = 0;
        return;
    }
    for (int k = 0; k < 4; k++) r[k] = q[k] / n;
}

static void quat_mul(const double a[4], const double b[4], double r[4]) {
    r[0] = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3];
    r[1] = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2];
    r[2] = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1];
    r[3] = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0];
}

static void mat_vec(const double R[9], const double v[3], double r[3]) {
    for (int i = 0; i < 3; i++) r[i] = R[3 * i] * v[0] + R[3 * i + 1] * v[1] + R[3 * i + 2] * v[2];
}

/* ------------------------------------------------------------------------------------------ */
/* Hashing and colours                                                                          */

static uint64_t mix64(uint64_t z) {
    z += 0x9E3779B97F4A7C15ull;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

static double srgb_to_linear(double c) { return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4); }
static double linear_to_srgb(double c) { return c <= 0.0031308 ? 12.92 * c : 1.055 * pow(c, 1.0 / 2.4) - 0.055; }

/* Sand tones (sRGB): light to dark browns. */
static const float sand_palette[8][3] = {
    {0.80f, 0.66f, 0.46f}, {0.74f, 0.58f, 0.39f}, {0.68f, 0.52f, 0.34f}, {0.62f, 0.47f, 0.30f},
    {0.85f, 0.71f, 0.51f}, {0.57f, 0.42f, 0.27f}, {0.72f, 0.60f, 0.44f}, {0.65f, 0.50f, 0.35f},
};
/* Material hues (sRGB), id mod 8. */
static const float material_palette[8][3] = {
    {0.76f, 0.60f, 0.40f}, {0.32f, 0.52f, 0.80f}, {0.78f, 0.30f, 0.25f}, {0.42f, 0.66f, 0.34f},
    {0.60f, 0.40f, 0.72f}, {0.24f, 0.66f, 0.66f}, {0.93f, 0.62f, 0.20f}, {0.60f, 0.60f, 0.60f},
};
/* Viridis-like colour map stops (sRGB). */
static const float cmap_stops[9][3] = {
    {0.267f, 0.005f, 0.329f}, {0.283f, 0.141f, 0.458f}, {0.254f, 0.265f, 0.530f},
    {0.207f, 0.372f, 0.553f}, {0.164f, 0.471f, 0.558f}, {0.128f, 0.567f, 0.551f},
    {0.135f, 0.659f, 0.518f}, {0.478f, 0.821f, 0.318f}, {0.993f, 0.906f, 0.144f},
};

/* Tone index and brightness jitter of particle id. */
static void tone_pick(uint64_t seed, uint64_t id, int *k, float *jitter) {
    uint64_t h = mix64(seed ^ mix64(id));
    *k = (int)(h & 7u);
    *jitter = 0.90f + 0.20f * (float)((h >> 11) & 0xffffu) / 65535.0f;
}

void sm_render_tone(uint64_t seed, uint64_t id, float rgb[3]) {
    int k;
    float j;
    tone_pick(seed, id, &k, &j);
    for (int c = 0; c < 3; c++) {
        double lin = srgb_to_linear(sand_palette[k][c]) * j;
        rgb[c] = (float)linear_to_srgb(lin > 1 ? 1 : lin);
    }
}

/* ------------------------------------------------------------------------------------------ */
/* Views: perspective or orthographic cameras (also the light's view)                          */

typedef struct view {
    double eye[3], r[3], u[3], f[3]; /* position; right, up, forward unit vectors */
    int ortho;
    double focal;  /* perspective: pixels per unit of (lateral / depth); ortho: pixels per metre */
    double cx, cy; /* principal point, pixels */
} view;

/* Builds the basis from eye, target, up. 0 if degenerate. */
static int view_basis(view *v, const double eye[3], const double target[3], const double up[3]) {
    for (int k = 0; k < 3; k++) {
        v->eye[k] = eye[k];
        v->f[k] = target[k] - eye[k];
    }
    if (!normalize3(v->f)) return 0;
    double upv[3] = {up[0], up[1], up[2]};
    cross3(v->f, upv, v->r);
    if (!normalize3(v->r)) return 0;
    cross3(v->r, v->f, v->u);
    return normalize3(v->u);
}

/* Screen position (pixels) and depth along f. */
static void view_project(const view *v, const double p[3], double *sx, double *sy, double *z) {
    double d[3] = {p[0] - v->eye[0], p[1] - v->eye[1], p[2] - v->eye[2]};
    double x = dot3(d, v->r), y = dot3(d, v->u);
    *z = dot3(d, v->f);
    if (v->ortho) {
        *sx = v->cx + v->focal * x;
        *sy = v->cy - v->focal * y;
    } else {
        double iz = 1.0 / *z;
        *sx = v->cx + v->focal * x * iz;
        *sy = v->cy - v->focal * y * iz;
    }
}

/* Ray through pixel coordinates (px, py) (continuous). Perspective: d has forward component 1, so
 * the ray parameter is the depth along f; orthographic: d = f. */
static void view_ray(const view *v, double px, double py, double o[3], double d[3]) {
    double a = (px - v->cx) / v->focal, b = (v->cy - py) / v->focal;
    for (int k = 0; k < 3; k++) {
        if (v->ortho) {
            o[k] = v->eye[k] + a * v->r[k] + b * v->u[k];
            d[k] = v->f[k];
        } else {
            o[k] = v->eye[k];
            d[k] = v->f[k] + a * v->r[k] + b * v->u[k];
        }
    }
}

/* ------------------------------------------------------------------------------------------ */
/* Colliders                                                                                    */

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

static double coll_phi(const rcoll *c, int dim, const double x[3]) {
    if (c->plane) {
        double p = 0;
        for (int k = 0; k < dim; k++) p += c->pn[k] * (x[k] - c->pc[k]);
        return p;
    }
    double best = HUGE_VAL;
    for (int s = 0; s < c->ns; s++) {
        double d = sm_shape_distance(&c->s[s], dim, x, NULL);
        if (d < best) best = d;
    }
    return c->inside_out ? -best : best;
}

static void coll_grad(const rcoll *c, int dim, const double x[3], double g[3]) {
    if (c->plane) {
        g[0] = c->pn[0];
        g[1] = c->pn[1];
        g[2] = dim == 3 ? c->pn[2] : 0;
        return;
    }
    double best = HUGE_VAL;
    g[0] = 0;
    g[1] = 1;
    g[2] = 0;
    for (int s = 0; s < c->ns; s++) {
        double gs[3];
        double d = sm_shape_distance(&c->s[s], dim, x, gs);
        if (d < best) {
            best = d;
            memcpy(g, gs, sizeof gs);
        }
    }
    if (c->inside_out)
        for (int k = 0; k < 3; k++) g[k] = -g[k];
}

/* Slab test of the ray o + t d against [lo, hi]; narrows [*t0, *t1]. 0 if it misses. */
static int ray_box(const double o[3], const double d[3], const double lo[3], const double hi[3], double *t0,
                   double *t1) {
    for (int k = 0; k < 3; k++) {
        if (d[k] == 0.0) {
            if (o[k] < lo[k] || o[k] > hi[k]) return 0;
            continue;
        }
        double inv = 1.0 / d[k];
        double a = (lo[k] - o[k]) * inv, b = (hi[k] - o[k]) * inv;
        if (a > b) {
            double t = a;
            a = b;
            b = t;
        }
        if (a > *t0) *t0 = a;
        if (b < *t1) *t1 = b;
        if (*t0 > *t1) return 0;
    }
    return 1;
}

/* First surface of collider c along o + t d (|d| = 1) in [t0, t1], entering the solid from free
 * space. A ray that starts inside the solid first marches out of it (so containers are seen from
 * the inside). eps(t) = e0 + e1 t is the hit tolerance (a fraction of the pixel footprint). */
static int coll_hit(const rcoll *c, const double o[3], const double d[3], double t0, double t1, double e0, double e1,
                    double *thit) {
    if (!c->visible || !ray_box(o, d, c->lo, c->hi, &t0, &t1)) return 0;
    if (c->plane) {
        double p0 = c->pn[0] * (o[0] + t0 * d[0] - c->pc[0]) + c->pn[1] * (o[1] + t0 * d[1] - c->pc[1]) +
                    c->pn[2] * (o[2] + t0 * d[2] - c->pc[2]);
        double s = dot3(c->pn, d);
        if (p0 < 0 || s >= 0) return 0; /* starts inside, or moves away */
        double t = t0 - p0 / s;
        if (t > t1) return 0;
        *thit = t;
        return 1;
    }
    double t = t0, x[3];
    for (int k = 0; k < 3; k++) x[k] = o[k] + t * d[k];
    double phi = coll_phi(c, 3, x);
    int it = 0;
    /* Starting inside the solid, or on its surface where the ray enters the search box (which
     * would otherwise report a hit on the box face): march out until clear of the surface. */
    if (phi < e0 + e1 * t) {
        while (phi < e0 + e1 * t) {
            if (++it > 160) return 0;
            double step = fabs(phi);
            double e = e0 + e1 * t;
            t += step > e ? step : e;
            if (t > t1) return 0;
            for (int k = 0; k < 3; k++) x[k] = o[k] + t * d[k];
            phi = coll_phi(c, 3, x);
        }
    }
    for (; it < 320; it++) {
        double e = e0 + e1 * t;
        if (phi < e) {
            *thit = t;
            return 1;
        }
        t += phi;
        if (t > t1) return 0;
        for (int k = 0; k < 3; k++) x[k] = o[k] + t * d[k];
        phi = coll_phi(c, 3, x);
    }
    return 0;
}

/* ------------------------------------------------------------------------------------------ */
/* Splatting                                                                                    */

/* A particle on a target: centre (pixels), radius (pixels; < 0: not drawn), centre depth and
 * world radius (depth units). */
typedef struct proj {
    float sx, sy, sr, z, rw;
} proj;

typedef struct binned {
    proj p;
    uint32_t idx;
} binned;

static void proj_rows(const proj *p, int *r0, int *r1) {
    if (p->sr < 1.0f) {
        *r0 = *r1 = (int)floorf(p->sy);
    } else {
        *r0 = (int)ceilf(p->sy - p->sr - 0.5f);
        *r1 = (int)floorf(p->sy + p->sr - 0.5f);
    }
}

static inline void zput(float *zb, uint32_t *zi, size_t k, float d, uint32_t idx) {
    if (d < zb[k] || (zi && d == zb[k] && idx < zi[k])) {
        zb[k] = d;
        if (zi) zi[k] = idx;
    }
}

/* Draws particle idx into rows [y0, y1) of a w-wide target. */
static void splat_one(const proj *p, uint32_t idx, int y0, int y1, int w, float *zb, uint32_t *zi) {
    if (p->sr < 1.0f) { /* sub-pixel: the pixel holding the centre */
        int px = (int)floorf(p->sx), py = (int)floorf(p->sy);
        if (py < y0 || py >= y1 || px < 0 || px >= w) return;
        float dx = ((float)px + 0.5f - p->sx), dy = ((float)py + 0.5f - p->sy);
        float rr = p->sr > 0.25f ? (dx * dx + dy * dy) / (p->sr * p->sr) : 0.0f;
        float dz = rr < 1.0f ? p->rw * sqrtf(1.0f - rr) : 0.0f;
        zput(zb, zi, (size_t)py * (size_t)w + (size_t)px, p->z - dz, idx);
        return;
    }
    int r0, r1;
    proj_rows(p, &r0, &r1);
    if (r0 < y0) r0 = y0;
    if (r1 > y1 - 1) r1 = y1 - 1;
    const float sr2 = p->sr * p->sr, inv2 = 1.0f / sr2;
    const float zfront = p->z - p->rw; /* nothing of this particle is nearer */
    for (int y = r0; y <= r1; y++) {
        float dy = (float)y + 0.5f - p->sy;
        float h2 = sr2 - dy * dy;
        if (h2 < 0.0f) continue;
        float hx = sqrtf(h2);
        int x0 = (int)ceilf(p->sx - hx - 0.5f), x1 = (int)floorf(p->sx + hx - 0.5f);
        if (x0 < 0) x0 = 0;
        if (x1 > w - 1) x1 = w - 1;
        size_t row = (size_t)y * (size_t)w;
        for (int x = x0; x <= x1; x++) {
            if (zfront > zb[row + (size_t)x]) continue; /* hidden: skip the square root */
            float dx = (float)x + 0.5f - p->sx;
            float rr = (dx * dx + dy * dy) * inv2;
            float dz = rr < 1.0f ? p->rw * sqrtf(1.0f - rr) : 0.0f;
            zput(zb, zi, row + (size_t)x, p->z - dz, idx);
        }
    }
}

/* Bands (of BAND_ROWS rows) that particle p covers in an image of h rows: [*b0, *b1]; 0 if none
 * (hidden, or above / below the image). */
static int proj_bands(const proj *p, int h, int *b0, int *b1) {
    if (!(p->sr >= 0.0f)) return 0;
    int r0, r1;
    proj_rows(p, &r0, &r1);
    if (r0 < 0) r0 = 0;
    if (r1 > h - 1) r1 = h - 1;
    if (r0 > r1) return 0;
    *b0 = r0 / BAND_ROWS;
    *b1 = r1 / BAND_ROWS;
    return 1;
}

/* Splats all particles into a w x h target (zb = +inf, zi = NO_PARTICLE initially). */
static int splat_all(const proj *P, size_t n, int w, int h, float *zb, uint32_t *zi, int threads) {
    (void)threads; /* without OpenMP */
    const int nb = (h + BAND_ROWS - 1) / BAND_ROWS;
    size_t nch = n / 16384 + 1;
    if (nch > 256) nch = 256;
    const size_t per = (n + nch - 1) / nch;
    size_t *cnt = calloc(nch * (size_t)nb, sizeof *cnt);
    size_t *start = calloc((size_t)nb + 1, sizeof *start);
    if (!cnt || !start) {
        free(cnt);
        free(start);
        return RC_NOMEM;
    }
    const long nchl = (long)nch;
OMP(omp parallel for schedule(static) num_threads(threads))
    for (long c = 0; c < nchl; c++) {
        size_t i0 = (size_t)c * per, i1 = i0 + per < n ? i0 + per : n;
        size_t *cc = cnt + (size_t)c * (size_t)nb;
        for (size_t i = i0; i < i1; i++) {
            int b0, b1;
            if (!proj_bands(&P[i], h, &b0, &b1)) continue;
            for (int b = b0; b <= b1; b++) cc[b]++;
        }
    }
    size_t total = 0;
    for (int b = 0; b < nb; b++) {
        start[b] = total;
        for (size_t c = 0; c < nch; c++) {
            size_t k = cnt[c * (size_t)nb + (size_t)b];
            cnt[c * (size_t)nb + (size_t)b] = total; /* now the write cursor */
            total += k;
        }
    }
    start[nb] = total;
    /* The band lists hold copies of the projections: each band then reads its particles
     * sequentially instead of gathering them from the whole array (a cache miss each). */
    binned *list = malloc((total ? total : 1) * sizeof *list);
    if (!list) {
        free(cnt);
        free(start);
        return RC_NOMEM;
    }
OMP(omp parallel for schedule(static) num_threads(threads))
    for (long c = 0; c < nchl; c++) {
        size_t i0 = (size_t)c * per, i1 = i0 + per < n ? i0 + per : n;
        size_t *cc = cnt + (size_t)c * (size_t)nb;
        for (size_t i = i0; i < i1; i++) {
            int b0, b1;
            if (!proj_bands(&P[i], h, &b0, &b1)) continue;
            for (int b = b0; b <= b1; b++) {
                binned *e = &list[cc[b]++];
                e->p = P[i];
                e->idx = (uint32_t)i;
            }
        }
    }
OMP(omp parallel for schedule(dynamic, 1) num_threads(threads))
    for (int b = 0; b < nb; b++) {
        int y0 = b * BAND_ROWS, y1 = y0 + BAND_ROWS < h ? y0 + BAND_ROWS : h;
        for (size_t k = start[b]; k < start[b + 1]; k++) splat_one(&list[k].p, list[k].idx, y0, y1, w, zb, zi);
    }
    free(list);
    free(cnt);
    free(start);
    return RC_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* Render context                                                                               */

typedef struct shadow_map {
    view v;
    int w, h;
    double texel; /* metres per texel */
    float *z;     /* depth along the light (+inf: nothing) */
} shadow_map;

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

static float prad(const rctx *R, size_t i) { return R->rad ? R->rad[i] : R->rconst; }

/* Albedo (linear) of particle i. */
static void particle_albedo(const rctx *R, size_t i, float a[3]) {
    const sm_frame *f = R->f;
    const uint64_t id = f->id ? (uint64_t)f->id[i] : (uint64_t)i;
    int k;
    float j;
    tone_pick(R->o->seed, id, &k, &j);
    switch (R->o->color) {
    case SM_COLOR_SPEED:
    case SM_COLOR_Q: {
        double val;
        if (R->o->color == SM_COLOR_SPEED) {
            const float *v = f->v + 3 * i;
            val = sqrt((double)v[0] * v[0] + (double)v[1] * v[1] + (double)v[2] * v[2]);
        } else {
            val = f->q[i];
        }
        double t = (val - R->cmin) / (R->cmax - R->cmin);
        if (!(t >= 0)) t = 0; /* NaN too */
        if (t > 1) t = 1;
        int c = (int)(t * 255.0 + 0.5);
        for (int m = 0; m < 3; m++) a[m] = R->cmap_lin[c][m];
        return;
    }
    case SM_COLOR_MATERIAL: {
        int m = f->material[i] & 7;
        float jj = 0.94f + (j - 0.90f) * 0.6f; /* +-6% */
        for (int c = 0; c < 3; c++) a[c] = R->pal_lin[m][c] * jj;
        return;
    }
    default:
        for (int c = 0; c < 3; c++) a[c] = R->pal_lin[k][c] * j;
        return;
    }
}

static uint8_t encode(const rctx *R, float lin) {
    if (!(lin > 0.0f)) return R->enc[0];
    if (lin >= 1.0f) return R->enc[4095];
    return R->enc[(int)(lin * 4095.0f + 0.5f)];
}

/* Sky colour (sRGB bytes) of row y. */
static void sky(int y, int H, uint8_t out[3]) {
    static const float top[3] = {0.47f, 0.63f, 0.84f}, bot[3] = {0.88f, 0.91f, 0.94f};
    float t = H > 1 ? (float)y / (float)(H - 1) : 0.0f;
    for (int c = 0; c < 3; c++) out[c] = (uint8_t)((top[c] + (bot[c] - top[c]) * t) * 255.0f + 0.5f);
}

/* Percentage-closer lookup: the fraction of the 2x2 texels around p (bilinear weights) whose
 * occluder depth is not nearer to the light than p's depth minus zbias. */
static float pcf(const shadow_map *m, const double p[3], double zbias) {
    double sx, sy, z;
    view_project(&m->v, p, &sx, &sy, &z);
    double zr = z - zbias;
    double fu = sx - 0.5, fv = sy - 0.5;
    if (!(fu > -2 && fv > -2 && fu < m->w + 1 && fv < m->h + 1)) return 1.0f;
    int i0 = (int)floor(fu), j0 = (int)floor(fv);
    double a = fu - i0, b = fv - j0;
    float lit[4];
    for (int q = 0; q < 4; q++) {
        int i = i0 + (q & 1), j = j0 + (q >> 1);
        lit[q] = (i < 0 || j < 0 || i >= m->w || j >= m->h) ? 1.0f
                 : (zr <= (double)m->z[(size_t)j * (size_t)m->w + (size_t)i]) ? 1.0f
                                                                            : 0.0f;
    }
    return (float)((1 - a) * (1 - b) * lit[0] + a * (1 - b) * lit[1] + (1 - a) * b * lit[2] + a * b * lit[3]);
}

/* Light reaching point p with unit normal n (ndl = n . L > 0): normal-offset lookups (the point
 * moved along n by about a texel, more at grazing light) plus a small depth bias, so surfaces do not
 * shadow themselves ("acne") at any angle. */
static float shadow_at(const rctx *R, const double p[3], const double n[3], double ndl, double extra_bias) {
    if (!R->shadows) return 1.0f;
    const double sn = sqrt(fmax(0.0, 1.0 - ndl * ndl));
    float s = 1.0f;
    const shadow_map *maps[2] = {&R->sp, &R->sc};
    for (int m = 0; m < 2 && s > 0.0f; m++) {
        const shadow_map *sm = maps[m];
        if (!sm->z) continue;
        double off = sm->texel * (0.5 + 2.0 * sn), q[3];
        for (int k = 0; k < 3; k++) q[k] = p[k] + off * n[k];
        s *= pcf(sm, q, sm->texel + extra_bias);
    }
    return s;
}

/* Lambert + hemispheric ambient, shadowed. n unit, albedo linear. */
static void shade(const rctx *R, const float alb[3], const double n[3], const double p[3], double extra_bias,
                  float out[3]) {
    double ndl = dot3(n, R->L);
    double direct = 0;
    if (ndl > 0) direct = ndl * shadow_at(R, p, n, ndl, extra_bias);
    double amb = R->ambient * (0.8 + 0.2 * n[1]);
    double k = amb + (1.0 - R->ambient) * direct;
    for (int c = 0; c < 3; c++) out[c] = (float)(alb[c] * k);
}

/* Ground checker tones and the collider colour (sRGB). */
static const float ground_srgb[2][3] = {{0.80f, 0.79f, 0.76f}, {0.70f, 0.69f, 0.66f}};
static const float collider_srgb[3] = {0.56f, 0.62f, 0.70f};

static void ground_albedo(const rctx *R, const double p[3], float a[3]) {
    double cx = floor(p[0] / R->checker), cz = floor(p[2] / R->checker);
    int odd = (int)(((long long)cx + (long long)cz) & 1);
    memcpy(a, R->ground_lin[odd], 3 * sizeof(float));
}

/* ------------------------------------------------------------------------------------------ */
/* Setup                                                                                        */

sm_render_opts sm_render_opts_default(void) {
    sm_render_opts o;
    memset(&o, 0, sizeof o);
    o.width = 1280;
    o.height = 720;
    o.color = SM_COLOR_SAND;
    o.radius_scale = 1.0;
    o.light_dir[0] = -0.75;
    o.light_dir[1] = 0.8;
    o.light_dir[2] = 0.05;
    o.ambient = 0.3;
    o.shadows = 1;
    o.seed = 1;
    o.camera.up[1] = 1.0;
    o.camera.eye[2] = 3.0;
    o.camera.fov_deg = 40.0;
    o.ground = SM_GROUND_AUTO;
    return o;
}

/* Particle position box (finite positions only); 0 if none. */
static int particle_box(const sm_frame *f, int threads, double lo[3], double hi[3]) {
    (void)threads;
    double l0 = HUGE_VAL, l1 = HUGE_VAL, l2 = HUGE_VAL, h0 = -HUGE_VAL, h1 = -HUGE_VAL, h2 = -HUGE_VAL;
    const long n = (long)f->n;
    const float *x = f->x;
OMP(omp parallel for schedule(static) num_threads(threads) reduction(min : l0, l1, l2) reduction(max : h0, h1, h2))
    for (long i = 0; i < n; i++) {
        double a = x[3 * i], b = x[3 * i + 1], c = x[3 * i + 2];
        if (!(isfinite(a) && isfinite(b) && isfinite(c))) continue;
        if (a < l0) l0 = a;
        if (b < l1) l1 = b;
        if (c < l2) l2 = c;
        if (a > h0) h0 = a;
        if (b > h1) h1 = b;
        if (c > h2) h2 = c;
    }
    lo[0] = l0;
    lo[1] = l1;
    lo[2] = l2;
    hi[0] = h0;
    hi[1] = h1;
    hi[2] = h2;
    return l0 <= h0;
}

static int validate(const sm_frame *f, const sm_render_opts *o, char *err, size_t errlen) {
#define BAD(...)                                 \
    do {                                         \
        snprintf(err, errlen, __VA_ARGS__);      \
        return RC_BAD;                           \
    } while (0)
    if (!f) BAD("render: no frame");
    if (f->dim != 2 && f->dim != 3) BAD("render: frame dim must be 2 or 3, got %d", f->dim);
    if (f->n > 0 && !f->x) BAD("render: frame has no positions");
    if (f->n >= (size_t)NO_PARTICLE) BAD("render: too many particles (%zu)", f->n);
    if (o->width < 1 || o->width > 16384) BAD("render: width must be 1..16384, got %d", o->width);
    if (o->height < 1 || o->height > 16384) BAD("render: height must be 1..16384, got %d", o->height);
    if ((int)o->color < 0 || (int)o->color > SM_COLOR_Q) BAD("render: unknown color mode %d", (int)o->color);
    if (o->color == SM_COLOR_SPEED && f->n > 0 && !f->v) BAD("render: color by speed needs velocities");
    if (o->color == SM_COLOR_Q && f->n > 0 && !f->q) BAD("render: color by q needs q");
    if (o->color == SM_COLOR_MATERIAL && f->n > 0 && !f->material) BAD("render: color by material needs materials");
    if (!isfinite(o->color_range[0]) || !isfinite(o->color_range[1])) BAD("render: color_range must be finite");
    if (!(o->radius >= 0) || !isfinite(o->radius)) BAD("render: radius must be >= 0, got %g", o->radius);
    if (!(o->radius_scale > 0) || !isfinite(o->radius_scale))
        BAD("render: radius_scale must be > 0, got %g", o->radius_scale);
    if (!finite3(o->light_dir) || norm3(o->light_dir) == 0) BAD("render: light_dir must be a finite non-zero vector");
    if (!(o->ambient >= 0 && o->ambient <= 1)) BAD("render: ambient must be in [0, 1], got %g", o->ambient);
    if (o->shadow_size != 0 && (o->shadow_size < 16 || o->shadow_size > 8192))
        BAD("render: shadow_size must be 0 (auto) or 16..8192, got %d", o->shadow_size);
    if (o->threads < 0) BAD("render: threads must be >= 0, got %d", o->threads);
    if (o->has_camera) {
        const sm_camera *c = &o->camera;
        if (!finite3(c->eye) || !finite3(c->target) || !finite3(c->up) || !isfinite(c->fov_deg) ||
            !isfinite(c->ortho_height) || c->ortho_height < 0)
            BAD("render: camera values must be finite (ortho_height >= 0)");
        if (f->dim == 3) {
            view v;
            if (!view_basis(&v, c->eye, c->target, c->up))
                BAD("render: camera: eye and target must differ and up must not be parallel to the view direction");
            if (c->fov_deg >= 179) BAD("render: camera fov_deg must be < 179, got %g", c->fov_deg);
            if (c->fov_deg <= 0 && !(c->ortho_height > 0))
                BAD("render: camera: an orthographic 3D camera (fov_deg <= 0) needs ortho_height > 0");
        }
    }
    if (o->has_domain) {
        for (int k = 0; k < f->dim; k++)
            if (!isfinite(o->domain_min[k]) || !isfinite(o->domain_max[k]) || !(o->domain_min[k] < o->domain_max[k]))
                BAD("render: domain_min[%d] must be < domain_max[%d]", k, k);
    }
    if ((int)o->ground < 0 || (int)o->ground > SM_GROUND_AT) BAD("render: unknown ground mode %d", (int)o->ground);
    if (o->ground == SM_GROUND_AT && !isfinite(o->ground_y)) BAD("render: ground_y must be finite");
    if (o->ncolliders < 0 || (o->ncolliders > 0 && !o->colliders)) BAD("render: ncolliders %d without colliders", o->ncolliders);
    for (int c = 0; c < o->ncolliders; c++) {
        const sm_collider_def *d = &o->colliders[c];
        if (d->shape_count < 1 || d->shape_count > SM_MAX_COLLIDER_SHAPES)
            BAD("render: colliders[%d].shape_count must be 1..%d, got %d", c, SM_MAX_COLLIDER_SHAPES, d->shape_count);
        for (int s = 0; s < d->shape_count; s++) {
            const sm_shape *sh = &d->shapes[s];
            if ((int)sh->kind < 0 || (int)sh->kind > SM_SHAPE_CYLINDER)
                BAD("render: colliders[%d].shapes[%d]: unknown kind %d", c, s, (int)sh->kind);
            if (sh->kind == SM_SHAPE_HALFSPACE && !(norm3(sh->normal) > 0))
                BAD("render: colliders[%d].shapes[%d]: half-space normal is zero", c, s);
            if (!finite3(sh->center) || !finite3(sh->half_extent) || !isfinite(sh->radius) || !isfinite(sh->half_height))
                BAD("render: colliders[%d].shapes[%d]: non-finite geometry", c, s);
        }
    }
#undef BAD
    return RC_OK;
}

/* Colliders in world space, bounded by the clip box. */
static void setup_colliders(rctx *R) {
    const sm_render_opts *o = R->o;
    for (int c = 0; c < o->ncolliders; c++) {
        const sm_collider_def *d = &o->colliders[c];
        rcoll *rc = &R->col[c];
        memset(rc, 0, sizeof *rc);
        sm_pose pose = o->poses ? o->poses[c] : d->pose;
        double qp[4], Rp[9];
        quat_norm(pose.rotation, qp);
        quat_mat(qp, Rp);
        rc->ns = d->shape_count;
        rc->inside_out = d->inside_out != 0;
        int bounded = !rc->inside_out;
        double blo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, bhi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
        for (int s = 0; s < d->shape_count; s++) {
            sm_shape ws = d->shapes[s];
            double cw[3], qs[4], qw[4], Rw[9];
            mat_vec(Rp, ws.center, cw);
            for (int k = 0; k < 3; k++) ws.center[k] = cw[k] + pose.position[k];
            quat_norm(d->shapes[s].rotation, qs);
            quat_mul(qp, qs, qw);
            memcpy(ws.rotation, qw, sizeof qw);
            if (R->dim == 2) { /* rotation about z only: keep the z-rotation part */
                ws.center[2] = 0;
            }
            rc->s[s] = ws;
            quat_mat(qw, Rw);
            double ext[3] = {0, 0, 0};
            int finite_shape = !ws.inside_out;
            switch (ws.kind) {
            case SM_SHAPE_HALFSPACE: finite_shape = 0; break;
            case SM_SHAPE_SPHERE: ext[0] = ext[1] = ext[2] = fabs(ws.radius); break;
            case SM_SHAPE_BOX:
                for (int i = 0; i < 3; i++)
                    for (int j = 0; j < 3; j++) ext[i] += fabs(Rw[3 * i + j]) * fabs(ws.half_extent[j]);
                break;
            case SM_SHAPE_CYLINDER: {
                double h[3] = {fabs(ws.radius), fabs(ws.half_height), fabs(ws.radius)};
                for (int i = 0; i < 3; i++)
                    for (int j = 0; j < 3; j++) ext[i] += fabs(Rw[3 * i + j]) * h[j];
                break;
            }
            }
            if (!finite_shape) bounded = 0;
            for (int k = 0; k < 3; k++) {
                if (ws.center[k] - ext[k] < blo[k]) blo[k] = ws.center[k] - ext[k];
                if (ws.center[k] + ext[k] > bhi[k]) bhi[k] = ws.center[k] + ext[k];
            }
        }
        if (rc->ns == 1 && rc->s[0].kind == SM_SHAPE_HALFSPACE) {
            double Rw[9], nl[3], nn = norm3(rc->s[0].normal);
            quat_mat(rc->s[0].rotation, Rw);
            for (int k = 0; k < 3; k++) nl[k] = rc->s[0].normal[k] / nn;
            mat_vec(Rw, nl, rc->pn);
            double sg = (rc->s[0].inside_out != 0) != rc->inside_out ? -1.0 : 1.0;
            for (int k = 0; k < 3; k++) {
                rc->pn[k] *= sg;
                rc->pc[k] = rc->s[0].center[k];
            }
            if (R->dim == 2) rc->pn[2] = 0;
            rc->plane = 1;
            rc->ground_like = rc->pn[1] > 0.97 * norm3(rc->pn);
        }
        rc->container = !bounded && !rc->plane;
        /* A ray entering the search box close to the surface is treated as leaving the solid (see
         * coll_hit), so the box of a bounded collider keeps a margin around it. */
        double pad = 0.02 * R->diag;
        rc->visible = 1;
        for (int k = 0; k < 3; k++) {
            rc->lo[k] = bounded ? fmax(blo[k] - pad, R->lo[k]) : R->lo[k];
            rc->hi[k] = bounded ? fmin(bhi[k] + pad, R->hi[k]) : R->hi[k];
            if (rc->lo[k] > rc->hi[k]) rc->visible = 0;
        }
    }
}

/* Scene box: the domain (options, else the frame's), else the particles' box; plus particles. */
/* Whether the options' or else the frame's domain is used (a frame's must be a proper box). */
static int use_domain(const sm_frame *f, const sm_render_opts *o) {
    if (o->has_domain) return 1;
    if (!f->has_domain) return 0;
    for (int k = 0; k < f->dim; k++)
        if (!isfinite(f->domain_min[k]) || !isfinite(f->domain_max[k]) || !(f->domain_min[k] < f->domain_max[k])) return 0;
    return 1;
}

/* Boxes of the scene: b = the domain (options, else the frame's), else the particles' box (with
 * radius); fit = b grown by 5% per axis (the fitted camera looks at it: stable from frame to frame
 * when there is a domain); clip (lo, hi) = fit and the particles' box, but at most 50% beyond b
 * (ground footprint, collider clipping, shadow-map extent). */
static void scene_box(const sm_frame *f, const sm_render_opts *o, int threads, double rmax, double lo[3], double hi[3],
                      double flo[3], double fhi[3], double blo[3], double bhi[3]) {
    double plo[3], phi[3];
    int hp = f->n > 0 && particle_box(f, threads, plo, phi);
    int dom = use_domain(f, o);
    if (dom) {
        double dd = 0;
        for (int k = 0; k < 3; k++) {
            blo[k] = o->has_domain ? o->domain_min[k] : f->domain_min[k];
            bhi[k] = o->has_domain ? o->domain_max[k] : f->domain_max[k];
            if (k < f->dim) dd += (bhi[k] - blo[k]) * (bhi[k] - blo[k]);
        }
        /* a few absurd radii (corrupt volumes) must not blow up the scene box */
        if (rmax > 0.05 * sqrt(dd)) rmax = 0.05 * sqrt(dd);
    } else if (hp) {
        for (int k = 0; k < 3; k++) {
            blo[k] = plo[k] - rmax;
            bhi[k] = phi[k] + rmax;
        }
    } else {
        for (int k = 0; k < 3; k++) {
            blo[k] = -0.5;
            bhi[k] = 0.5;
        }
    }
    if (f->dim == 2) blo[2] = bhi[2] = 0;
    double ext = 0;
    for (int k = 0; k < f->dim; k++) ext = fmax(ext, bhi[k] - blo[k]);
    if (!(ext > 0) || !isfinite(ext)) ext = 1;
    for (int k = 0; k < 3; k++) {
        double e = bhi[k] - blo[k];
        double m = k < f->dim ? 0.05 * (e > 1e-3 * ext ? e : ext) : 0.0;
        flo[k] = lo[k] = blo[k] - m;
        fhi[k] = hi[k] = bhi[k] + m;
        if (hp && dom && k < f->dim) {
            double a = fmax(plo[k] - rmax, blo[k] - 0.5 * e), b = fmin(phi[k] + rmax, bhi[k] + 0.5 * e);
            if (a < lo[k]) lo[k] = a;
            if (b > hi[k]) hi[k] = b;
        }
    }
}

/* Radius setup: per-particle from volume, constant, or estimated. Returns the largest radius. */
static int setup_radii(rctx *R, float **owned, double *rmax_out) {
    const sm_frame *f = R->f;
    const sm_render_opts *o = R->o;
    const double scale = o->radius_scale;
    *owned = NULL;
    R->rad = NULL;
    if (o->radius > 0) {
        R->rconst = (float)(o->radius * scale);
        *rmax_out = R->rconst;
        return RC_OK;
    }
    if (f->volume && f->n > 0) {
        float *r = malloc(f->n * sizeof *r);
        if (!r) return RC_NOMEM;
        double rmax = 0;
        const long n = (long)f->n;
        const int d3 = f->dim == 3;
OMP(omp parallel for schedule(static) num_threads(R->threads) reduction(max : rmax))
        for (long i = 0; i < n; i++) {
            double V = f->volume[i];
            double rr = V > 0 && isfinite(V) ? (d3 ? cbrt(3.0 * V / (4.0 * PI_D)) : sqrt(V / PI_D)) * scale : NAN;
            r[i] = (float)rr;
            if (rr > rmax) rmax = rr;
        }
        *owned = r;
        R->rad = r;
        *rmax_out = rmax;
        return RC_OK;
    }
    double plo[3], phi[3], est = 0.01;
    if (f->n > 0 && particle_box(f, R->threads, plo, phi)) {
        double vol = 1, ext = 0;
        for (int k = 0; k < f->dim; k++) ext = fmax(ext, phi[k] - plo[k]);
        if (!(ext > 0)) ext = 1;
        for (int k = 0; k < f->dim; k++) vol *= fmax(phi[k] - plo[k], 1e-3 * ext);
        est = 0.5 * (f->dim == 3 ? cbrt(vol / (double)f->n) : sqrt(vol / (double)f->n));
    }
    R->rconst = (float)(est * scale);
    *rmax_out = R->rconst;
    return RC_OK;
}

/* The fitted camera for box [lo, hi] and an aspect. */
static sm_camera fit_camera(int dim, const double lo[3], const double hi[3], int W, int H) {
    sm_camera c;
    memset(&c, 0, sizeof c);
    double ctr[3];
    for (int k = 0; k < 3; k++) ctr[k] = 0.5 * (lo[k] + hi[k]);
    c.up[1] = 1;
    if (dim == 2) {
        double hgt = hi[1] - lo[1], wid = hi[0] - lo[0];
        c.ortho_height = fmax(hgt, wid * (double)H / (double)W);
        memcpy(c.target, ctr, sizeof ctr);
        memcpy(c.eye, ctr, sizeof ctr);
        c.eye[2] += 1;
        c.fov_deg = 0;
        return c;
    }
    const double az = -35.0 * PI_D / 180.0, el = 28.0 * PI_D / 180.0;
    double e[3] = {sin(az) * cos(el), sin(el), cos(az) * cos(el)};
    c.fov_deg = 35.0;
    const double tv = tan(0.5 * c.fov_deg * PI_D / 180.0) * 0.94, th = tv * (double)W / (double)H;
    double diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                       (hi[2] - lo[2]) * (hi[2] - lo[2]));
    /* Distance that fits the 8 corners for the current target, then move the target so the
     * corners' screen box is centred; a few rounds converge. */
    double tgt[3] = {ctr[0], ctr[1], ctr[2]}, dist = 0;
    view v;
    double far_pt[3] = {ctr[0] - e[0], ctr[1] - e[1], ctr[2] - e[2]};
    view_basis(&v, ctr, far_pt, c.up); /* only the basis (r, u, f) is used */
    for (int round = 0; round < 6; round++) {
        dist = 0;
        for (int m = 0; m < 8; m++) {
            double p[3] = {(m & 1) ? hi[0] : lo[0], (m & 2) ? hi[1] : lo[1], (m & 4) ? hi[2] : lo[2]};
            double q[3] = {p[0] - tgt[0], p[1] - tgt[1], p[2] - tgt[2]};
            double cr = fabs(dot3(q, v.r)), cu = fabs(dot3(q, v.u)), cf = dot3(q, v.f);
            dist = fmax(dist, cr / th - cf);
            dist = fmax(dist, cu / tv - cf);
        }
        dist = fmax(dist, 0.05 * diag);
        double x0 = HUGE_VAL, x1 = -HUGE_VAL, y0 = HUGE_VAL, y1 = -HUGE_VAL;
        for (int m = 0; m < 8; m++) {
            double p[3] = {(m & 1) ? hi[0] : lo[0], (m & 2) ? hi[1] : lo[1], (m & 4) ? hi[2] : lo[2]};
            double q[3] = {p[0] - tgt[0], p[1] - tgt[1], p[2] - tgt[2]};
            double z = dist + dot3(q, v.f);
            double xs = dot3(q, v.r) / z, ys = dot3(q, v.u) / z;
            x0 = fmin(x0, xs);
            x1 = fmax(x1, xs);
            y0 = fmin(y0, ys);
            y1 = fmax(y1, ys);
        }
        double mx = 0.5 * (x0 + x1) * dist, my = 0.5 * (y0 + y1) * dist;
        for (int k = 0; k < 3; k++) tgt[k] += mx * v.r[k] + my * v.u[k];
    }
    memcpy(c.target, tgt, sizeof tgt);
    for (int k = 0; k < 3; k++) c.eye[k] = tgt[k] + dist * e[k];
    return c;
}

sm_camera sm_render_fit_camera(const sm_frame *f, const sm_render_opts *o) {
    double lo[3], hi[3], flo[3], fhi[3], blo[3], bhi[3];
    int threads = o->threads > 0 ? o->threads : 1;
    rctx R;
    memset(&R, 0, sizeof R);
    R.f = f;
    R.o = o;
    R.dim = f->dim;
    R.threads = threads;
    float *owned = NULL;
    double rmax = 0;
    if (setup_radii(&R, &owned, &rmax) != RC_OK) rmax = 0;
    free(owned);
    scene_box(f, o, threads, rmax, lo, hi, flo, fhi, blo, bhi);
    return fit_camera(f->dim, flo, fhi, o->width, o->height);
}

/* Camera view from sm_camera. */
static void setup_view(rctx *R, const sm_camera *c) {
    view *v = &R->cam;
    v->cx = 0.5 * R->W;
    v->cy = 0.5 * R->H;
    if (R->dim == 2) {
        double e[3] = {c->target[0], c->target[1], 1.0}, t[3] = {c->target[0], c->target[1], 0.0}, up[3] = {0, 1, 0};
        view_basis(v, e, t, up);
        v->ortho = 1;
        v->focal = R->H / c->ortho_height;
        return;
    }
    view_basis(v, c->eye, c->target, c->up);
    if (c->fov_deg > 0) {
        v->ortho = 0;
        v->focal = 0.5 * R->H / tan(0.5 * c->fov_deg * PI_D / 180.0);
    } else {
        v->ortho = 1;
        v->focal = R->H / c->ortho_height;
        /* Move the eye back so the whole clip box is in front of it. */
        double back = 0;
        for (int m = 0; m < 8; m++) {
            double p[3] = {(m & 1) ? R->hi[0] : R->lo[0], (m & 2) ? R->hi[1] : R->lo[1], (m & 4) ? R->hi[2] : R->lo[2]};
            double q[3] = {p[0] - v->eye[0], p[1] - v->eye[1], p[2] - v->eye[2]};
            back = fmax(back, -dot3(q, v->f));
        }
        for (int k = 0; k < 3; k++) v->eye[k] -= (back + 0.01 * R->diag) * v->f[k];
    }
}

/* Orthographic light view covering the clip box with about `size` texels on the longer side. */
static int setup_light_map(rctx *R, shadow_map *m, int size) {
    double ctr[3], up[3] = {0, 1, 0};
    for (int k = 0; k < 3; k++) ctr[k] = 0.5 * (R->lo[k] + R->hi[k]);
    if (fabs(R->L[1]) > 0.99) {
        up[1] = 0;
        up[2] = 1;
    }
    double eye[3];
    for (int k = 0; k < 3; k++) eye[k] = ctr[k] + R->L[k] * R->diag;
    view *v = &m->v;
    view_basis(v, eye, ctr, up);
    v->ortho = 1;
    double ur0 = HUGE_VAL, ur1 = -HUGE_VAL, uu0 = HUGE_VAL, uu1 = -HUGE_VAL;
    for (int c = 0; c < 8; c++) {
        double p[3] = {(c & 1) ? R->hi[0] : R->lo[0], (c & 2) ? R->hi[1] : R->lo[1], (c & 4) ? R->hi[2] : R->lo[2]};
        double q[3] = {p[0] - ctr[0], p[1] - ctr[1], p[2] - ctr[2]};
        double a = dot3(q, v->r), b = dot3(q, v->u);
        ur0 = fmin(ur0, a);
        ur1 = fmax(ur1, a);
        uu0 = fmin(uu0, b);
        uu1 = fmax(uu1, b);
    }
    double ext = fmax(ur1 - ur0, uu1 - uu0);
    m->texel = ext / size;
    m->w = (int)ceil((ur1 - ur0) / m->texel);
    m->h = (int)ceil((uu1 - uu0) / m->texel);
    if (m->w < 1) m->w = 1;
    if (m->h < 1) m->h = 1;
    if (m->w > size) m->w = size;
    if (m->h > size) m->h = size;
    v->focal = 1.0 / m->texel;
    v->cx = -ur0 * v->focal;
    v->cy = uu1 * v->focal;
    m->z = malloc((size_t)m->w * (size_t)m->h * sizeof(float));
    if (!m->z) return RC_NOMEM;
    const long nt = (long)m->w * m->h;
    float *z = m->z;
OMP(omp parallel for schedule(static) num_threads(R->threads))
    for (long i = 0; i < nt; i++) z[i] = INFINITY;
    return RC_OK;
}

/* Projects the particles onto a view of w x h pixels. */
static void project_all(const rctx *R, const view *v, int w, int h, int depth_shape) {
    const sm_frame *f = R->f;
    const long n = (long)f->n;
    proj *P = R->P;
    const double near = 1e-4 * R->diag;
    const double maxr = 4.0 * (double)(w + h);
OMP(omp parallel for schedule(static) num_threads(R->threads))
    for (long i = 0; i < n; i++) {
        proj *p = &P[i];
        double x[3] = {f->x[3 * i], f->x[3 * i + 1], f->x[3 * i + 2]};
        double r = prad(R, (size_t)i);
        p->sr = -1.0f;
        if (!finite3(x) || !(r > 0) || !isfinite(r)) continue;
        double sx, sy, z;
        view_project(v, x, &sx, &sy, &z);
        if (!(fabs(z) < 1e30) || (!v->ortho && !(z > r + near))) continue;
        double sr = v->ortho ? r * v->focal : r * v->focal / z;
        if (!(sr < maxr) || sx + sr < 0 || sy + sr < 0 || sx - sr > w || sy - sr > h) continue;
        p->sx = (float)sx;
        p->sy = (float)sy;
        p->sr = (float)sr;
        p->z = (float)z;
        p->rw = depth_shape ? (float)r : 0.0f;
    }
}

/* Collider shadow map: first collider surface along the light per texel. */
static void collider_shadow(rctx *R) {
    shadow_map *m = &R->sc;
    const long nt = (long)m->w * m->h;
    const double e0 = 1e-6 * R->diag, e1 = 0.0;
    const double ee = 0.5 * m->texel + e0;
OMP(omp parallel for schedule(dynamic, 64) num_threads(R->threads))
    for (long k = 0; k < nt; k++) {
        int i = (int)(k % m->w), j = (int)(k / m->w);
        double o[3], d[3];
        view_ray(&m->v, i + 0.5, j + 0.5, o, d);
        double best = HUGE_VAL;
        for (int c = 0; c < R->ncol; c++) {
            double t;
            if (coll_hit(&R->col[c], o, d, 0.0, best < HUGE_VAL ? best : 4.0 * R->diag, ee, e1, &t) && t < best) best = t;
        }
        if (best < HUGE_VAL) m->z[k] = (float)best;
    }
}

/* ------------------------------------------------------------------------------------------ */
/* Per-pixel shading                                                                            */

static void shade_3d(const rctx *R, uint8_t *rgb) {
    const int W = R->W, H = R->H;
    const view *v = &R->cam;
    const double e0 = 1e-6 * R->diag;
OMP(omp parallel for schedule(dynamic, 4) num_threads(R->threads))
    for (int y = 0; y < H; y++) {
        uint8_t skyc[3];
        sky(y, H, skyc);
        for (int x = 0; x < W; x++) {
            size_t k = (size_t)y * (size_t)W + (size_t)x;
            uint8_t *out = rgb + 3 * k;
            double o[3], d[3];
            view_ray(v, x + 0.5, y + 0.5, o, d);
            uint32_t pi = R->zi[k];
            double tbest = pi != NO_PARTICLE ? (double)R->zb[k] : HUGE_VAL;
            int kind = pi != NO_PARTICLE ? 1 : 0; /* 0 sky, 1 particle, 2 collider, 3 ground */
            int which = -1;
            /* colliders: march along the unit ray up to the nearest particle */
            if (R->ncol > 0) {
                double dl = norm3(d), du[3] = {d[0] / dl, d[1] / dl, d[2] / dl};
                double e1 = v->ortho ? 0.0 : 0.5 / v->focal;
                double eo = v->ortho ? 0.5 / v->focal : 0.0;
                double tmax = (tbest < HUGE_VAL ? tbest * dl : 4.0 * R->diag + norm3(o));
                for (int c = 0; c < R->ncol; c++) {
                    double t;
                    if (coll_hit(&R->col[c], o, du, 0.0, tmax, e0 + eo, e1, &t)) {
                        tmax = t;
                        tbest = t / dl;
                        kind = 2;
                        which = c;
                    }
                }
            }
            if (R->has_ground && d[1] < 0) {
                double t = (R->gy - o[1]) / d[1];
                if (t > 0 && t < tbest) {
                    double px = o[0] + t * d[0], pz = o[2] + t * d[2];
                    if (px >= R->glo[0] && px <= R->ghi[0] && pz >= R->glo[2] && pz <= R->ghi[2]) {
                        tbest = t;
                        kind = 3;
                    }
                }
            }
            if (kind == 0) {
                memcpy(out, skyc, 3);
                continue;
            }
            float alb[3], col[3];
            double n[3], p[3];
            if (kind == 1) {
                const proj *pp = &R->P[pi];
                double r = prad(R, pi);
                double dx = (x + 0.5 - pp->sx) / pp->sr, dy = -(y + 0.5 - pp->sy) / pp->sr;
                double rr = dx * dx + dy * dy;
                if (rr > 1) {
                    dx /= sqrt(rr);
                    dy /= sqrt(rr);
                    rr = 1;
                }
                double nz = sqrt(1 - rr);
                for (int a = 0; a < 3; a++) n[a] = dx * v->r[a] + dy * v->u[a] - nz * v->f[a];
                normalize3(n);
                for (int a = 0; a < 3; a++) p[a] = R->f->x[3 * (size_t)pi + (size_t)a] + r * n[a];
                particle_albedo(R, pi, alb);
                shade(R, alb, n, p, 0.3 * r, col);
            } else {
                for (int a = 0; a < 3; a++) p[a] = o[a] + tbest * d[a];
                if (kind == 2) {
                    coll_grad(&R->col[which], 3, p, n);
                    if (!normalize3(n)) n[1] = 1;
                    if (dot3(n, d) > 0)
                        for (int a = 0; a < 3; a++) n[a] = -n[a];
                    if (R->col[which].ground_like) {
                        ground_albedo(R, p, alb);
                    } else {
                        memcpy(alb, R->coll_lin, sizeof alb);
                    }
                } else {
                    n[0] = n[2] = 0;
                    n[1] = 1;
                    ground_albedo(R, p, alb);
                }
                shade(R, alb, n, p, 0.0, col);
            }
            for (int a = 0; a < 3; a++) out[a] = encode(R, col[a]);
        }
    }
}

static void shade_2d(const rctx *R, uint8_t *rgb) {
    const int W = R->W, H = R->H;
    const view *v = &R->cam;
    double L[3] = {R->o->light_dir[0], R->o->light_dir[1], 1.0};
    normalize3(L);
    const double px_size = 1.0 / v->focal;
    const double wall = fmax(4.0 * px_size, 0.01 * R->H * px_size); /* containers: walls this thick */
    float coll_lin[3], coll_edge[3], gr[3], gr_edge[3];
    for (int a = 0; a < 3; a++) {
        coll_lin[a] = (float)srgb_to_linear(collider_srgb[a]);
        coll_edge[a] = coll_lin[a] * 0.55f;
    }
    {
        double p0[3] = {0.5 * R->checker, 0, 0.5 * R->checker};
        ground_albedo(R, p0, gr);
        for (int a = 0; a < 3; a++) gr_edge[a] = gr[a] * 0.6f;
    }
OMP(omp parallel for schedule(dynamic, 4) num_threads(R->threads))
    for (int y = 0; y < H; y++) {
        uint8_t skyc[3];
        sky(y, H, skyc);
        for (int x = 0; x < W; x++) {
            size_t k = (size_t)y * (size_t)W + (size_t)x;
            uint8_t *out = rgb + 3 * k;
            uint32_t pi = R->zi[k];
            float col[3];
            if (pi != NO_PARTICLE) {
                const proj *pp = &R->P[pi];
                double dx = (x + 0.5 - pp->sx) / pp->sr, dy = -(y + 0.5 - pp->sy) / pp->sr;
                double rr = dx * dx + dy * dy;
                if (rr > 1) {
                    dx /= sqrt(rr);
                    dy /= sqrt(rr);
                    rr = 1;
                }
                double n[3] = {dx, dy, sqrt(1 - rr)};
                float alb[3];
                particle_albedo(R, pi, alb);
                double ndl = dot3(n, L);
                double kk = R->ambient * (0.8 + 0.2 * n[2]) + (1 - R->ambient) * (ndl > 0 ? ndl : 0);
                for (int a = 0; a < 3; a++) col[a] = (float)(alb[a] * kk);
            } else {
                double o[3], d[3];
                view_ray(v, x + 0.5, y + 0.5, o, d);
                o[2] = 0;
                int done = 0;
                for (int c = 0; c < R->ncol && !done; c++) {
                    const rcoll *rc = &R->col[c];
                    double phi = coll_phi(rc, 2, o);
                    if (!(phi < 0) || (rc->container && phi < -wall)) continue;
                    int edge = phi > -1.5 * px_size || (rc->container && phi < -wall + 1.5 * px_size);
                    const float *s = rc->ground_like ? (edge ? gr_edge : gr) : (edge ? coll_edge : coll_lin);
                    memcpy(col, s, sizeof col);
                    done = 1;
                }
                if (!done && R->has_ground && o[1] < R->gy) {
                    memcpy(col, o[1] > R->gy - 1.5 * px_size ? gr_edge : gr, sizeof col);
                    done = 1;
                }
                if (!done) {
                    memcpy(out, skyc, 3);
                    continue;
                }
            }
            for (int a = 0; a < 3; a++) out[a] = encode(R, col[a]);
        }
    }
}

/* ------------------------------------------------------------------------------------------ */
/* sm_render                                                                                    */

static double nice_step(double x) {
    double p = pow(10.0, floor(log10(x)));
    double m = x / p;
    return (m < 1.5 ? 1 : m < 3.5 ? 2 : m < 7.5 ? 5 : 10) * p;
}

int sm_render(const sm_frame *f, const sm_render_opts *o, uint8_t *rgb, char *err, size_t errlen) {
    char dummy[8];
    if (!err || errlen == 0) {
        err = dummy;
        errlen = sizeof dummy;
    }
    err[0] = 0;
    if (!o) {
        snprintf(err, errlen, "render: no options");
        return RC_BAD;
    }
    if (!rgb) {
        snprintf(err, errlen, "render: no output buffer");
        return RC_BAD;
    }
    int rc = validate(f, o, err, errlen);
    if (rc) return rc;
    rctx R;
    memset(&R, 0, sizeof R);
    R.f = f;
    R.o = o;
    R.W = o->width;
    R.H = o->height;
    R.dim = f->dim;
#ifdef _OPENMP
    R.threads = o->threads > 0 ? o->threads : omp_get_max_threads();
#else
    R.threads = 1;
#endif
    float *owned_rad = NULL;
    double rmax = 0;
    if ((rc = setup_radii(&R, &owned_rad, &rmax)) != RC_OK) {
        snprintf(err, errlen, "render: out of memory");
        return rc;
    }
    double blo[3], bhi[3], flo[3], fhi[3];
    scene_box(f, o, R.threads, rmax, R.lo, R.hi, flo, fhi, blo, bhi);
    memcpy(R.glo, flo, sizeof flo);
    memcpy(R.ghi, fhi, sizeof fhi);
    R.diag = sqrt((R.hi[0] - R.lo[0]) * (R.hi[0] - R.lo[0]) + (R.hi[1] - R.lo[1]) * (R.hi[1] - R.lo[1]) +
                  (R.hi[2] - R.lo[2]) * (R.hi[2] - R.lo[2]));
    if (f->dim == 2) {
        R.lo[2] = -1e-9 * R.diag;
        R.hi[2] = 1e-9 * R.diag;
    }
    /* ground */
    R.has_ground = o->ground != SM_GROUND_NONE;
    if (o->ground == SM_GROUND_AT) {
        R.gy = o->ground_y;
    } else if (use_domain(f, o)) {
        R.gy = blo[1];
    } else {
        double plo[3], phi[3];
        R.gy = (f->n > 0 && particle_box(f, R.threads, plo, phi)) ? plo[1] - rmax : blo[1];
    }
    R.checker = nice_step(fmax(R.ghi[0] - R.glo[0], R.ghi[2] - R.glo[2]) / 12.0);
    if (f->dim == 2) R.checker = nice_step(R.ghi[0] - R.glo[0]);
    /* light */
    memcpy(R.L, o->light_dir, sizeof R.L);
    normalize3(R.L);
    R.ambient = o->ambient;
    R.shadows = o->shadows && f->dim == 3;
    /* colours */
    for (int i = 0; i < 4096; i++) {
        double s = linear_to_srgb(i / 4095.0);
        R.enc[i] = (uint8_t)(s * 255.0 + 0.5);
    }
    for (int i = 0; i < 256; i++) {
        double t = i / 255.0 * 8.0;
        int a = (int)t;
        if (a > 7) a = 7;
        double w = t - a;
        for (int c = 0; c < 3; c++)
            R.cmap_lin[i][c] = (float)srgb_to_linear(cmap_stops[a][c] * (1 - w) + cmap_stops[a + 1][c] * w);
    }
    for (int c = 0; c < 3; c++) {
        R.ground_lin[0][c] = (float)srgb_to_linear(ground_srgb[0][c]);
        R.ground_lin[1][c] = (float)srgb_to_linear(ground_srgb[1][c]);
        R.coll_lin[c] = (float)srgb_to_linear(collider_srgb[c]);
    }
    for (int i = 0; i < 8; i++)
        for (int c = 0; c < 3; c++)
            R.pal_lin[i][c] = (float)srgb_to_linear(o->color == SM_COLOR_MATERIAL ? material_palette[i][c] : sand_palette[i][c]);
    if (o->color == SM_COLOR_SPEED || o->color == SM_COLOR_Q) {
        R.cmin = o->color_range[0];
        R.cmax = o->color_range[1];
        if (!(R.cmax > R.cmin)) {
            double mx = 0;
            const long n = (long)f->n;
            const int sp = o->color == SM_COLOR_SPEED;
OMP(omp parallel for schedule(static) num_threads(R.threads) reduction(max : mx))
            for (long i = 0; i < n; i++) {
                double val = sp ? sqrt((double)f->v[3 * i] * f->v[3 * i] + (double)f->v[3 * i + 1] * f->v[3 * i + 1] +
                                       (double)f->v[3 * i + 2] * f->v[3 * i + 2])
                                : (double)f->q[i];
                if (isfinite(val) && val > mx) mx = val;
            }
            R.cmin = 0;
            R.cmax = mx > 0 ? mx : 1;
        }
    }
    /* camera */
    sm_camera cam = o->has_camera ? o->camera : fit_camera(f->dim, flo, fhi, R.W, R.H);
    if (f->dim == 2 && !(cam.ortho_height > 0)) {
        sm_camera fc = fit_camera(2, flo, fhi, R.W, R.H);
        cam.ortho_height = fc.ortho_height;
    }
    setup_view(&R, &cam);

    const size_t npix = (size_t)R.W * (size_t)R.H;
    R.col = o->ncolliders > 0 ? calloc((size_t)o->ncolliders, sizeof *R.col) : NULL;
    R.ncol = o->ncolliders;
    R.P = malloc((f->n ? f->n : 1) * sizeof *R.P);
    R.zb = malloc(npix * sizeof *R.zb);
    R.zi = malloc(npix * sizeof *R.zi);
    if (!R.P || !R.zb || !R.zi || (o->ncolliders > 0 && !R.col)) {
        rc = RC_NOMEM;
        goto out;
    }
    if (R.ncol) setup_colliders(&R);
    if (o->ground == SM_GROUND_AUTO) /* a ground-like half-space collider is the ground */
        for (int c = 0; c < R.ncol; c++)
            if (R.col[c].visible && R.col[c].ground_like) R.has_ground = 0;

    if (R.shadows) {
        int S = o->shadow_size;
        if (S == 0) {
            S = R.W > R.H ? R.W : R.H;
            if (S < 512) S = 512;
            if (S > 4096) S = 4096;
        }
        if (f->n > 0) {
            if ((rc = setup_light_map(&R, &R.sp, S)) != RC_OK) goto out;
            project_all(&R, &R.sp.v, R.sp.w, R.sp.h, 1);
            if ((rc = splat_all(R.P, f->n, R.sp.w, R.sp.h, R.sp.z, NULL, R.threads)) != RC_OK) goto out;
        }
        int any = 0;
        for (int c = 0; c < R.ncol; c++) any |= R.col[c].visible && !R.col[c].ground_like;
        if (any) {
            int Sc = S / 4;
            if (Sc < 256) Sc = 256;
            if (Sc > 512) Sc = 512;
            if ((rc = setup_light_map(&R, &R.sc, Sc)) != RC_OK) goto out;
            collider_shadow(&R);
        }
    }

    {
        float *zb = R.zb;
        uint32_t *zi = R.zi;
        const long np = (long)npix;
OMP(omp parallel for schedule(static) num_threads(R.threads))
        for (long i = 0; i < np; i++) {
            zb[i] = INFINITY;
            zi[i] = NO_PARTICLE;
        }
    }
    if (f->n > 0) {
        project_all(&R, &R.cam, R.W, R.H, f->dim == 3);
        if ((rc = splat_all(R.P, f->n, R.W, R.H, R.zb, R.zi, R.threads)) != RC_OK) goto out;
    }
    if (f->dim == 3)
        shade_3d(&R, rgb);
    else
        shade_2d(&R, rgb);

out:
    if (rc == RC_NOMEM) snprintf(err, errlen, "render: out of memory (%zu particles, %d x %d)", f->n, R.W, R.H);
    free(R.sp.z);
    free(R.sc.z);
    free(R.P);
    free(R.zb);
    free(R.zi);
    free(R.col);
    free(owned_rad);
    return rc;
}

/* ------------------------------------------------------------------------------------------ */
/* PNG                                                                                          */

typedef struct png_err {
    char msg[200];
} png_err;

static void png_error_fn(png_structp png, png_const_charp msg) {
    png_err *e = png_get_error_ptr(png);
    if (e) snprintf(e->msg, sizeof e->msg, "%s", msg);
    png_longjmp(png, 1);
}

static void png_warn_fn(png_structp png, png_const_charp msg) {
    (void)png;
    (void)msg;
}

/* The libpng part of a write: 0, or -1 with a message in pe (RC_NOMEM as -2). */
static int png_write_core(FILE *fp, int w, int h, const uint8_t *rgb, png_err *pe) {
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, pe, png_error_fn, png_warn_fn);
    if (!png) return -2;
    png_infop info = png_create_info_struct(png);
    if (!info) {
        png_destroy_write_struct(&png, NULL);
        return -2;
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        return -1;
    }
    png_init_io(png, fp);
    png_set_IHDR(png, info, (png_uint_32)w, (png_uint_32)h, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_set_compression_level(png, 3);
    png_write_info(png, info);
    for (int y = 0; y < h; y++) png_write_row(png, (png_const_bytep)(rgb + (size_t)y * (size_t)w * 3));
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &info);
    return 0;
}

int sm_png_write(const char *path, int w, int h, const uint8_t *rgb, char *err, size_t errlen) {
    char dummy[8];
    if (!err || errlen == 0) {
        err = dummy;
        errlen = sizeof dummy;
    }
    err[0] = 0;
    if (w < 1 || h < 1 || w > 65535 || h > 65535 || !rgb) {
        snprintf(err, errlen, "%s: bad image size %d x %d", path, w, h);
        return RC_BAD;
    }
    char tmp[4096];
    if (snprintf(tmp, sizeof tmp, "%s.tmp", path) >= (int)sizeof tmp) {
        snprintf(err, errlen, "%s: path too long", path);
        return RC_IO;
    }
    FILE *fp = fopen(tmp, "wb");
    if (!fp) {
        snprintf(err, errlen, "%s: cannot create: %s", tmp, strerror(errno));
        return RC_IO;
    }
    png_err pe;
    pe.msg[0] = 0;
    errno = 0;
    int r = png_write_core(fp, w, h, rgb, &pe);
    if (r != 0) {
        int e = errno;
        fclose(fp);
        remove(tmp);
        if (r == -2) {
            snprintf(err, errlen, "%s: out of memory", path);
            return RC_NOMEM;
        }
        snprintf(err, errlen, "%s: PNG write failed: %s", path, pe.msg[0] ? pe.msg : strerror(e));
        return RC_IO;
    }
    if (fflush(fp) != 0 || ferror(fp)) {
        snprintf(err, errlen, "%s: write failed: %s", tmp, strerror(errno));
        fclose(fp);
        remove(tmp);
        return RC_IO;
    }
    if (fclose(fp) != 0) {
        snprintf(err, errlen, "%s: write failed: %s", tmp, strerror(errno));
        remove(tmp);
        return RC_IO;
    }
    if (rename(tmp, path) != 0) {
        snprintf(err, errlen, "%s: cannot rename from %s: %s", path, tmp, strerror(errno));
        remove(tmp);
        return RC_IO;
    }
    return RC_OK;
}

/* The libpng part of a read (after the signature): 0 with *out malloc'ed, -1 (message in pe), -2. */
static int png_read_core(FILE *fp, png_uint_32 *pw_out, png_uint_32 *ph_out, uint8_t **out, png_err *pe) {
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, pe, png_error_fn, png_warn_fn);
    if (!png) return -2;
    png_infop info = png_create_info_struct(png);
    if (!info) {
        png_destroy_read_struct(&png, NULL, NULL);
        return -2;
    }
    uint8_t *volatile buf = NULL;
    png_bytep *volatile rows = NULL;
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_read_struct(&png, &info, NULL);
        free(buf);
        free(rows);
        return -1;
    }
    png_init_io(png, fp);
    png_set_sig_bytes(png, 8);
    png_set_user_limits(png, 65535, 65535);
    png_read_info(png, info);
    png_uint_32 pw = png_get_image_width(png, info), ph = png_get_image_height(png, info);
    int ct = png_get_color_type(png, info), bd = png_get_bit_depth(png, info);
    if (bd == 16) png_set_strip_16(png);
    if (ct == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
    if ((ct == PNG_COLOR_TYPE_GRAY || ct == PNG_COLOR_TYPE_GRAY_ALPHA) && bd < 8) png_set_expand_gray_1_2_4_to_8(png);
    if (ct == PNG_COLOR_TYPE_GRAY || ct == PNG_COLOR_TYPE_GRAY_ALPHA) png_set_gray_to_rgb(png);
    if (ct & PNG_COLOR_MASK_ALPHA) png_set_strip_alpha(png);
    if (png_get_valid(png, info, PNG_INFO_tRNS)) png_set_strip_alpha(png);
    png_set_interlace_handling(png);
    png_read_update_info(png, info);
    if (png_get_rowbytes(png, info) != (size_t)pw * 3) png_error(png, "unexpected row size after conversion to RGB");
    buf = malloc((size_t)pw * ph * 3);
    if (!buf) png_error(png, "out of memory");
    rows = malloc(ph * sizeof *rows);
    if (!rows) png_error(png, "out of memory");
    for (png_uint_32 y = 0; y < ph; y++) rows[y] = buf + (size_t)y * pw * 3;
    png_read_image(png, rows);
    png_read_end(png, NULL);
    png_destroy_read_struct(&png, &info, NULL);
    free(rows);
    *pw_out = pw;
    *ph_out = ph;
    *out = buf;
    return 0;
}

int sm_png_read(const char *path, int *w, int *h, uint8_t **rgb, char *err, size_t errlen) {
    char dummy[8];
    if (!err || errlen == 0) {
        err = dummy;
        errlen = sizeof dummy;
    }
    err[0] = 0;
    *rgb = NULL;
    *w = *h = 0;
    FILE *fp = fopen(path, "rb");
    if (!fp) {
        snprintf(err, errlen, "%s: cannot open: %s", path, strerror(errno));
        return RC_IO;
    }
    unsigned char sig[8];
    if (fread(sig, 1, 8, fp) != 8 || png_sig_cmp(sig, 0, 8)) {
        fclose(fp);
        snprintf(err, errlen, "%s: not a PNG file", path);
        return RC_BAD;
    }
    png_err pe;
    pe.msg[0] = 0;
    png_uint_32 pw = 0, ph = 0;
    int r = png_read_core(fp, &pw, &ph, rgb, &pe);
    fclose(fp);
    if (r == -2) {
        snprintf(err, errlen, "%s: out of memory", path);
        return RC_NOMEM;
    }
    if (r != 0) {
        snprintf(err, errlen, "%s: corrupt PNG: %s", path, pe.msg);
        return RC_BAD;
    }
    *w = (int)pw;
    *h = (int)ph;
    return RC_OK;
}

int sm_render_ply_to_png(const char *ply_path, const char *png_path, const sm_render_opts *o, char *err,
                         size_t errlen) {
    sm_frame f;
    int rc = sm_ply_read(ply_path, &f, err, errlen);
    if (rc) return rc;
    size_t bytes = (size_t)(o->width > 0 ? o->width : 1) * (size_t)(o->height > 0 ? o->height : 1) * 3;
    uint8_t *img = malloc(bytes);
    if (!img) {
        sm_frame_free(&f);
        snprintf(err, errlen, "%s: out of memory for the image", png_path);
        return RC_NOMEM;
    }
    rc = sm_render(&f, o, img, err, errlen);
    if (rc == RC_OK) rc = sm_png_write(png_path, o->width, o->height, img, err, errlen);
    free(img);
    sm_frame_free(&f);
    return rc;
}
