/* Colours and shading. Particle albedo from a seeded per-particle tone (or speed / q through a
 * viridis-like map, or a hue per material); colours are mixed in linear light and encoded to sRGB
 * by a table. 3D: Lambert + a hemispheric ambient term, direct light shadowed by 2x2
 * percentage-closer lookups in the particle and collider shadow maps; per pixel the nearest of the
 * z-buffer particle, the colliders (sphere tracing up to that depth) and the ground plane. 2D:
 * disks shaded as hemispheres, colliders filled with darker edges, no shadows. The background is
 * a vertical sky gradient (a pure function of the row). See internal.h. */
#include <string.h>

#include "app/render/internal.h"

/* ------------------------------------------------------------------------------------------ */
/* Colours                                                                                      */

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
/* Ground checker tones and the collider colour (sRGB). */
static const float ground_srgb[2][3] = {{0.80f, 0.79f, 0.76f}, {0.70f, 0.69f, 0.66f}};
static const float collider_srgb[3] = {0.56f, 0.62f, 0.70f};

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

/* |v| of particle i, or its q: the colour-mapped value. */
static double mapped_value(const sm_frame *f, int by_speed, size_t i) {
    if (!by_speed) return (double)f->q[i];
    const float *v = f->v + 3 * i;
    return sqrt((double)v[0] * v[0] + (double)v[1] * v[1] + (double)v[2] * v[2]);
}

/* Range of the colour map: the options', or 0 .. this frame's largest finite value. */
static void colour_range(rctx *R) {
    const sm_render_opts *o = R->o;
    const sm_frame *f = R->f;
    R->cmin = o->color_range[0];
    R->cmax = o->color_range[1];
    if (R->cmax > R->cmin) return;
    double mx = 0;
    const long n = (long)f->n;
    const int sp = o->color == SM_COLOR_SPEED;
OMP(omp parallel for schedule(static) num_threads(R->threads) reduction(max : mx))
    for (long i = 0; i < n; i++) {
        double val = mapped_value(f, sp, (size_t)i);
        if (isfinite(val) && val > mx) mx = val;
    }
    R->cmin = 0;
    R->cmax = mx > 0 ? mx : 1;
}

void render_setup_colours(rctx *R) {
    const sm_render_opts *o = R->o;
    for (int i = 0; i < 4096; i++) {
        double s = linear_to_srgb(i / 4095.0);
        R->enc[i] = (uint8_t)(s * 255.0 + 0.5);
    }
    for (int i = 0; i < 256; i++) {
        double t = i / 255.0 * 8.0;
        int a = (int)t;
        if (a > 7) a = 7;
        double w = t - a;
        for (int c = 0; c < 3; c++)
            R->cmap_lin[i][c] = (float)srgb_to_linear(cmap_stops[a][c] * (1 - w) + cmap_stops[a + 1][c] * w);
    }
    for (int c = 0; c < 3; c++) {
        R->ground_lin[0][c] = (float)srgb_to_linear(ground_srgb[0][c]);
        R->ground_lin[1][c] = (float)srgb_to_linear(ground_srgb[1][c]);
        R->coll_lin[c] = (float)srgb_to_linear(collider_srgb[c]);
    }
    for (int i = 0; i < 8; i++)
        for (int c = 0; c < 3; c++)
            R->pal_lin[i][c] = (float)srgb_to_linear(o->color == SM_COLOR_MATERIAL ? material_palette[i][c] : sand_palette[i][c]);
    if (o->color == SM_COLOR_SPEED || o->color == SM_COLOR_Q) colour_range(R);
}

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
        double val = mapped_value(f, R->o->color == SM_COLOR_SPEED, i);
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

static void ground_albedo(const rctx *R, const double p[3], float a[3]) {
    double cx = floor(p[0] / R->checker), cz = floor(p[2] / R->checker);
    int odd = (int)(((long long)cx + (long long)cz) & 1);
    memcpy(a, R->ground_lin[odd], 3 * sizeof(float));
}

/* ------------------------------------------------------------------------------------------ */
/* Light and shadows                                                                            */

/* Percentage-closer lookup: the fraction of the 2x2 texels around p (bilinear weights) whose
 * occluder depth is not nearer to the light than p's depth minus zbias. */
static float pcf(const shadow_map *m, const double p[3], double zbias) {
    double sx, sy, z;
    render_view_project(&m->v, p, &sx, &sy, &z);
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

/* ------------------------------------------------------------------------------------------ */
/* The image                                                                                    */

/* Fills col with pixel (x, y)'s linear colour and returns 1, or returns 0 for the sky. */
typedef int (*pixel_fn)(const rctx *R, const void *ctx, int x, int y, size_t k, float col[3]);

/* Every pixel of the image, rows in parallel (each pixel independent of the others). */
static void shade_rows(const rctx *R, uint8_t *rgb, pixel_fn pixel, const void *ctx) {
    const int W = R->W, H = R->H;
OMP(omp parallel for schedule(dynamic, 4) num_threads(R->threads))
    for (int y = 0; y < H; y++) {
        uint8_t skyc[3];
        sky(y, H, skyc);
        for (int x = 0; x < W; x++) {
            size_t k = (size_t)y * (size_t)W + (size_t)x;
            uint8_t *out = rgb + 3 * k;
            float col[3];
            if (!pixel(R, ctx, x, y, k, col)) {
                memcpy(out, skyc, 3);
                continue;
            }
            for (int a = 0; a < 3; a++) out[a] = encode(R, col[a]);
        }
    }
}

/* ------------------------------------------------------------------------------------------ */
/* 3D                                                                                           */

enum { HIT_SKY = 0, HIT_PARTICLE = 1, HIT_COLLIDER = 2, HIT_GROUND = 3 };

/* What the ray (o, d) through pixel k sees first: the z-buffer's particle, a collider (sphere
 * tracing along the unit ray up to the particle), or the ground. *t: the ray parameter of d. */
static int first_hit_3d(const rctx *R, size_t k, const double o[3], const double d[3], double *t_out, int *which) {
    const view *v = &R->cam;
    uint32_t pi = R->zi[k];
    double tbest = pi != NO_PARTICLE ? (double)R->zb[k] : HUGE_VAL;
    int kind = pi != NO_PARTICLE ? HIT_PARTICLE : HIT_SKY;
    *which = -1;
    if (R->ncol > 0) {
        const double e0 = 1e-6 * R->diag;
        double dl = norm3(d), du[3] = {d[0] / dl, d[1] / dl, d[2] / dl};
        double e1 = v->ortho ? 0.0 : 0.5 / v->focal;
        double eo = v->ortho ? 0.5 / v->focal : 0.0;
        double tmax = (tbest < HUGE_VAL ? tbest * dl : 4.0 * R->diag + norm3(o));
        for (int c = 0; c < R->ncol; c++) {
            double t;
            if (render_collider_hit(&R->col[c], o, du, 0.0, tmax, e0 + eo, e1, &t)) {
                tmax = t;
                tbest = t / dl;
                kind = HIT_COLLIDER;
                *which = c;
            }
        }
    }
    if (R->has_ground && d[1] < 0) {
        double t = (R->gy - o[1]) / d[1];
        if (t > 0 && t < tbest) {
            double px = o[0] + t * d[0], pz = o[2] + t * d[2];
            if (px >= R->glo[0] && px <= R->ghi[0] && pz >= R->glo[2] && pz <= R->ghi[2]) {
                tbest = t;
                kind = HIT_GROUND;
            }
        }
    }
    *t_out = tbest;
    return kind;
}

/* Unit normal of a projected disk at pixel centre (x, y): (dx, dy) in [-1, 1]^2 towards the rim,
 * clamped to the rim; returns the component towards the viewer. */
static double disk_normal(const proj *pp, int x, int y, double *dx_out, double *dy_out) {
    double dx = (x + 0.5 - pp->sx) / pp->sr, dy = -(y + 0.5 - pp->sy) / pp->sr;
    double rr = dx * dx + dy * dy;
    if (rr > 1) {
        dx /= sqrt(rr);
        dy /= sqrt(rr);
        rr = 1;
    }
    *dx_out = dx;
    *dy_out = dy;
    return sqrt(1 - rr);
}

/* The lit colour of particle pi's sphere at pixel (x, y). */
static void shade_particle_3d(const rctx *R, uint32_t pi, int x, int y, float col[3]) {
    const view *v = &R->cam;
    const proj *pp = &R->P[pi];
    double r = prad(R, pi), dx, dy, n[3], p[3];
    double nz = disk_normal(pp, x, y, &dx, &dy);
    for (int a = 0; a < 3; a++) n[a] = dx * v->r[a] + dy * v->u[a] - nz * v->f[a];
    normalize3(n);
    for (int a = 0; a < 3; a++) p[a] = R->f->x[3 * (size_t)pi + (size_t)a] + r * n[a];
    float alb[3];
    particle_albedo(R, pi, alb);
    shade(R, alb, n, p, 0.3 * r, col);
}

/* The lit colour of a collider (which) or the ground at o + t d. */
static void shade_surface_3d(const rctx *R, int kind, int which, const double o[3], const double d[3], double t,
                             float col[3]) {
    float alb[3];
    double n[3], p[3];
    for (int a = 0; a < 3; a++) p[a] = o[a] + t * d[a];
    if (kind == HIT_COLLIDER) {
        render_collider_grad(&R->col[which], 3, p, n);
        if (!normalize3(n)) n[1] = 1;
        if (dot3(n, d) > 0)
            for (int a = 0; a < 3; a++) n[a] = -n[a];
        if (R->col[which].ground_like) ground_albedo(R, p, alb);
        else memcpy(alb, R->coll_lin, sizeof alb);
    } else {
        n[0] = n[2] = 0;
        n[1] = 1;
        ground_albedo(R, p, alb);
    }
    shade(R, alb, n, p, 0.0, col);
}

/* Pixel (x, y) (index k) of the 3D image into col; 0 if it shows the sky. */
static int pixel_3d(const rctx *R, const void *ctx, int x, int y, size_t k, float col[3]) {
    (void)ctx;
    double o[3], d[3], t;
    render_view_ray(&R->cam, x + 0.5, y + 0.5, o, d);
    int which, kind = first_hit_3d(R, k, o, d, &t, &which);
    if (kind == HIT_SKY) return 0;
    if (kind == HIT_PARTICLE) shade_particle_3d(R, R->zi[k], x, y, col);
    else shade_surface_3d(R, kind, which, o, d, t, col);
    return 1;
}

void render_shade_3d(const rctx *R, uint8_t *rgb) { shade_rows(R, rgb, pixel_3d, NULL); }

/* ------------------------------------------------------------------------------------------ */
/* 2D                                                                                           */

/* The flat colours of 2D: colliders and the ground, each with a darker edge. */
typedef struct flat2d {
    float coll[3], coll_edge[3], gr[3], gr_edge[3];
    double px_size, wall; /* metres per pixel; containers are drawn as walls this thick */
} flat2d;

/* A disk's pixel: shaded as a hemisphere facing the viewer. */
static void shade_particle_2d(const rctx *R, const double L[3], uint32_t pi, int x, int y, float col[3]) {
    double dx, dy;
    double nz = disk_normal(&R->P[pi], x, y, &dx, &dy);
    double n[3] = {dx, dy, nz};
    float alb[3];
    particle_albedo(R, pi, alb);
    double ndl = dot3(n, L);
    double kk = R->ambient * (0.8 + 0.2 * n[2]) + (1 - R->ambient) * (ndl > 0 ? ndl : 0);
    for (int a = 0; a < 3; a++) col[a] = (float)(alb[a] * kk);
}

/* A pixel without a particle: a collider, the ground or (0) the sky. */
static int shade_background_2d(const rctx *R, const flat2d *fl, int x, int y, float col[3]) {
    double o[3], d[3];
    render_view_ray(&R->cam, x + 0.5, y + 0.5, o, d);
    o[2] = 0;
    for (int c = 0; c < R->ncol; c++) {
        const rcoll *rc = &R->col[c];
        double phi = render_collider_phi(rc, 2, o);
        if (!(phi < 0) || (rc->container && phi < -fl->wall)) continue;
        int edge = phi > -1.5 * fl->px_size || (rc->container && phi < -fl->wall + 1.5 * fl->px_size);
        const float *s = rc->ground_like ? (edge ? fl->gr_edge : fl->gr) : (edge ? fl->coll_edge : fl->coll);
        memcpy(col, s, 3 * sizeof(float));
        return 1;
    }
    if (R->has_ground && o[1] < R->gy) {
        memcpy(col, o[1] > R->gy - 1.5 * fl->px_size ? fl->gr_edge : fl->gr, 3 * sizeof(float));
        return 1;
    }
    return 0;
}

/* What the 2D pixels share: the light and the flat colours. */
typedef struct ctx2d {
    double L[3];
    flat2d fl;
} ctx2d;

/* Pixel (x, y) (index k) of the 2D image into col; 0 if it shows the sky. */
static int pixel_2d(const rctx *R, const void *ctx, int x, int y, size_t k, float col[3]) {
    const ctx2d *c = ctx;
    uint32_t pi = R->zi[k];
    if (pi == NO_PARTICLE) return shade_background_2d(R, &c->fl, x, y, col);
    shade_particle_2d(R, c->L, pi, x, y, col);
    return 1;
}

void render_shade_2d(const rctx *R, uint8_t *rgb) {
    ctx2d c;
    c.L[0] = R->o->light_dir[0];
    c.L[1] = R->o->light_dir[1];
    c.L[2] = 1.0;
    normalize3(c.L);
    flat2d *fl = &c.fl;
    fl->px_size = 1.0 / R->cam.focal;
    fl->wall = fmax(4.0 * fl->px_size, 0.01 * R->H * fl->px_size);
    for (int a = 0; a < 3; a++) {
        fl->coll[a] = (float)srgb_to_linear(collider_srgb[a]);
        fl->coll_edge[a] = fl->coll[a] * 0.55f;
    }
    double p0[3] = {0.5 * R->checker, 0, 0.5 * R->checker};
    ground_albedo(R, p0, fl->gr);
    for (int a = 0; a < 3; a++) fl->gr_edge[a] = fl->gr[a] * 0.6f;
    shade_rows(R, rgb, pixel_2d, &c);
}
