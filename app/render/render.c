/* sm_render: the pipeline, options and their validation; see app/render.h and internal.h.
 *
 * Pipeline (3D):
 *   1. scene box C = (domain or particle box) grown by 5%: ground footprint, collider clip box,
 *      shadow-map extent; camera given or fitted to C;
 *   2. particle shadow map: particles projected orthographically along the light and splatted as
 *      sphere impostors (min depth per texel); collider shadow map (coarser): sphere tracing of
 *      each collider per texel;
 *   3. camera z-buffer: particles projected and splatted (depth, then particle index);
 *   4. per pixel: the nearest of the z-buffer particle, the colliders and the ground plane, shaded.
 * 2D: the same without shadows, orthographic along -z. */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "app/errbuf.h"
#include "app/io/ply.h"
#include "app/io/png.h"
#include "app/render/internal.h"

sm_render_opts sm_render_opts_default(void) {
    sm_render_opts o = {
        .width = 1280,
        .height = 720,
        .color = SM_COLOR_SAND,
        .radius_scale = 1.0,
        .light_dir = {-0.75, 0.8, 0.05},
        .ambient = 0.3,
        .shadows = 1,
        .seed = 1,
        .camera = {.up = {0, 1.0, 0}, .eye = {0, 0, 3.0}, .fov_deg = 40.0},
        .ground = SM_GROUND_AUTO,
    };
    return o;
}

/* ------------------------------------------------------------------------------------------ */
/* Validation                                                                                   */

#define BAD(...)                                 \
    do {                                         \
        snprintf(err, errlen, __VA_ARGS__);      \
        return SM_ERR_INVALID;                   \
    } while (0)

static sm_status validate_basics(const sm_frame *f, const sm_render_opts *o, char *err, size_t errlen) {
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
    return SM_OK;
}

static sm_status validate_view(const sm_frame *f, const sm_render_opts *o, char *err, size_t errlen) {
    if (o->has_camera) {
        const sm_camera *c = &o->camera;
        if (!finite3(c->eye) || !finite3(c->target) || !finite3(c->up) || !isfinite(c->fov_deg) ||
            !isfinite(c->ortho_height) || c->ortho_height < 0)
            BAD("render: camera values must be finite (ortho_height >= 0)");
        if (f->dim == 3) {
            view v;
            if (!render_view_basis(&v, c->eye, c->target, c->up))
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
    return SM_OK;
}

static sm_status validate_colliders(const sm_render_opts *o, char *err, size_t errlen) {
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
    return SM_OK;
}
#undef BAD

static sm_status validate(const sm_frame *f, const sm_render_opts *o, char *err, size_t errlen) {
    sm_status st = validate_basics(f, o, err, errlen);
    if (st == SM_OK) st = validate_view(f, o, err, errlen);
    if (st == SM_OK) st = validate_colliders(o, err, errlen);
    return st;
}

/* ------------------------------------------------------------------------------------------ */
/* The scene box and the radii                                                                  */

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

/* Whether the options' or else the frame's domain is used (a frame's must be a proper box). */
static int use_domain(const sm_frame *f, const sm_render_opts *o) {
    if (o->has_domain) return 1;
    if (!f->has_domain) return 0;
    for (int k = 0; k < f->dim; k++)
        if (!isfinite(f->domain_min[k]) || !isfinite(f->domain_max[k]) || !(f->domain_min[k] < f->domain_max[k])) return 0;
    return 1;
}

/* The boxes of a frame's scene (see scene_box). */
typedef struct scene_boxes {
    double clip_lo[3], clip_hi[3]; /* C: ground footprint bounds, collider clipping, shadow-map extent */
    double fit_lo[3], fit_hi[3];   /* b grown by 5%: what the fitted camera looks at */
    double b_lo[3], b_hi[3];       /* the domain, else the particles' box with radius */
} scene_boxes;

/* b = the domain (options, else the frame's), else the particles' box (with radius rmax); 0 if it
 * is the particles' box. A few absurd radii (corrupt volumes) must not blow up a domain's box. */
static int base_box(const sm_frame *f, const sm_render_opts *o, int hp, const double plo[3], const double phi[3],
                    double *rmax, scene_boxes *B) {
    int dom = use_domain(f, o);
    if (dom) {
        double dd = 0;
        for (int k = 0; k < 3; k++) {
            B->b_lo[k] = o->has_domain ? o->domain_min[k] : f->domain_min[k];
            B->b_hi[k] = o->has_domain ? o->domain_max[k] : f->domain_max[k];
            if (k < f->dim) dd += (B->b_hi[k] - B->b_lo[k]) * (B->b_hi[k] - B->b_lo[k]);
        }
        if (*rmax > 0.05 * sqrt(dd)) *rmax = 0.05 * sqrt(dd);
    } else if (hp) {
        for (int k = 0; k < 3; k++) {
            B->b_lo[k] = plo[k] - *rmax;
            B->b_hi[k] = phi[k] + *rmax;
        }
    } else {
        for (int k = 0; k < 3; k++) {
            B->b_lo[k] = -0.5;
            B->b_hi[k] = 0.5;
        }
    }
    if (f->dim == 2) B->b_lo[2] = B->b_hi[2] = 0;
    return dom;
}

/* fit = b grown by 5% per axis (stable from frame to frame when there is a domain); clip = fit and
 * the particles' box, but at most 50% beyond b. */
static void scene_box(const sm_frame *f, const sm_render_opts *o, int threads, double rmax, scene_boxes *B) {
    double plo[3], phi[3];
    int hp = f->n > 0 && particle_box(f, threads, plo, phi);
    int dom = base_box(f, o, hp, plo, phi, &rmax, B);
    double ext = 0;
    for (int k = 0; k < f->dim; k++) ext = fmax(ext, B->b_hi[k] - B->b_lo[k]);
    if (!(ext > 0) || !isfinite(ext)) ext = 1;
    for (int k = 0; k < 3; k++) {
        double e = B->b_hi[k] - B->b_lo[k];
        double m = k < f->dim ? 0.05 * (e > 1e-3 * ext ? e : ext) : 0.0;
        B->fit_lo[k] = B->clip_lo[k] = B->b_lo[k] - m;
        B->fit_hi[k] = B->clip_hi[k] = B->b_hi[k] + m;
        if (hp && dom && k < f->dim) {
            double a = fmax(plo[k] - rmax, B->b_lo[k] - 0.5 * e), b = fmin(phi[k] + rmax, B->b_hi[k] + 0.5 * e);
            if (a < B->clip_lo[k]) B->clip_lo[k] = a;
            if (b > B->clip_hi[k]) B->clip_hi[k] = b;
        }
    }
}

/* Radius setup: per-particle from volume, constant, or estimated. *rmax_out: the largest radius.
 * 3D: the sphere of the particle's volume, r = (3V / 4 pi)^(1/3) (the layers behind fill the gaps).
 * 2D: the disk circumscribing the particle's square of area V, r = sqrt(V / 2): disks of the
 * equal area (r = sqrt(V / pi)) leave sky between packed grains (at the centre of each square of
 * four neighbours, 0.354 spacing from each, beyond their 0.282). */
static sm_status setup_radii(rctx *R, float **owned, double *rmax_out) {
    const sm_frame *f = R->f;
    const sm_render_opts *o = R->o;
    const double scale = o->radius_scale;
    *owned = NULL;
    R->rad = NULL;
    if (o->radius > 0) {
        R->rconst = (float)(o->radius * scale);
        *rmax_out = R->rconst;
        return SM_OK;
    }
    if (f->volume && f->n > 0) {
        float *r = malloc(f->n * sizeof *r);
        if (!r) return SM_ERR_NOMEM;
        double rmax = 0;
        const long n = (long)f->n;
        const int d3 = f->dim == 3;
OMP(omp parallel for schedule(static) num_threads(R->threads) reduction(max : rmax))
        for (long i = 0; i < n; i++) {
            double V = f->volume[i];
            double rr = V > 0 && isfinite(V) ? (d3 ? cbrt(3.0 * V / (4.0 * PI_D)) : sqrt(0.5 * V)) * scale : NAN;
            r[i] = (float)rr;
            if (rr > rmax) rmax = rr;
        }
        *owned = r;
        R->rad = r;
        *rmax_out = rmax;
        return SM_OK;
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
    return SM_OK;
}

sm_camera sm_render_fit_camera(const sm_frame *f, const sm_render_opts *o) {
    int threads = o->threads > 0 ? o->threads : 1;
    rctx R;
    memset(&R, 0, sizeof R);
    R.f = f;
    R.o = o;
    R.dim = f->dim;
    R.threads = threads;
    float *owned = NULL;
    double rmax = 0;
    if (setup_radii(&R, &owned, &rmax) != SM_OK) rmax = 0;
    free(owned);
    scene_boxes B;
    scene_box(f, o, threads, rmax, &B);
    return render_fit_camera(f->dim, B.fit_lo, B.fit_hi, o->width, o->height);
}

/* ------------------------------------------------------------------------------------------ */
/* sm_render                                                                                    */

static double nice_step(double x) {
    double p = pow(10.0, floor(log10(x)));
    double m = x / p;
    return (m < 1.5 ? 1 : m < 3.5 ? 2 : m < 7.5 ? 5 : 10) * p;
}

/* Boxes, diagonal, ground height and checker size, light. */
static void setup_scene(rctx *R, double rmax, scene_boxes *B) {
    const sm_frame *f = R->f;
    const sm_render_opts *o = R->o;
    scene_box(f, o, R->threads, rmax, B);
    memcpy(R->lo, B->clip_lo, sizeof R->lo);
    memcpy(R->hi, B->clip_hi, sizeof R->hi);
    memcpy(R->glo, B->fit_lo, sizeof R->glo);
    memcpy(R->ghi, B->fit_hi, sizeof R->ghi);
    R->diag = sqrt((R->hi[0] - R->lo[0]) * (R->hi[0] - R->lo[0]) + (R->hi[1] - R->lo[1]) * (R->hi[1] - R->lo[1]) +
                   (R->hi[2] - R->lo[2]) * (R->hi[2] - R->lo[2]));
    if (f->dim == 2) {
        R->lo[2] = -1e-9 * R->diag;
        R->hi[2] = 1e-9 * R->diag;
    }
    R->has_ground = o->ground != SM_GROUND_NONE;
    if (o->ground == SM_GROUND_AT) {
        R->gy = o->ground_y;
    } else if (use_domain(f, o)) {
        R->gy = B->b_lo[1];
    } else {
        double plo[3], phi[3];
        R->gy = (f->n > 0 && particle_box(f, R->threads, plo, phi)) ? plo[1] - rmax : B->b_lo[1];
    }
    R->checker = nice_step(fmax(R->ghi[0] - R->glo[0], R->ghi[2] - R->glo[2]) / 12.0);
    if (f->dim == 2) R->checker = nice_step(R->ghi[0] - R->glo[0]);
    memcpy(R->L, o->light_dir, sizeof R->L);
    normalize3(R->L);
    R->ambient = o->ambient;
    R->shadows = o->shadows && f->dim == 3;
}

/* The particle and collider shadow maps (3D with shadows). */
static sm_status render_shadows(rctx *R) {
    const sm_render_opts *o = R->o;
    int S = o->shadow_size;
    if (S == 0) {
        S = R->W > R->H ? R->W : R->H;
        if (S < 512) S = 512;
        if (S > 4096) S = 4096;
    }
    sm_status st;
    if (R->f->n > 0) {
        if ((st = render_setup_light_map(R, &R->sp, S)) != SM_OK) return st;
        render_project_all(R, &R->sp.v, R->sp.w, R->sp.h, 1);
        if ((st = render_splat_all(R->P, R->f->n, R->sp.w, R->sp.h, R->sp.z, NULL, R->threads)) != SM_OK) return st;
    }
    int any = 0;
    for (int c = 0; c < R->ncol; c++) any |= R->col[c].visible && !R->col[c].ground_like;
    if (any) {
        int Sc = S / 4;
        if (Sc < 256) Sc = 256;
        if (Sc > 512) Sc = 512;
        if ((st = render_setup_light_map(R, &R->sc, Sc)) != SM_OK) return st;
        render_collider_shadow(R);
    }
    return SM_OK;
}

/* The camera's z-buffer and the shaded image. */
static sm_status render_image(rctx *R, uint8_t *rgb) {
    const sm_frame *f = R->f;
    float *zb = R->zb;
    uint32_t *zi = R->zi;
    const long np = (long)R->W * R->H;
OMP(omp parallel for schedule(static) num_threads(R->threads))
    for (long i = 0; i < np; i++) {
        zb[i] = INFINITY;
        zi[i] = NO_PARTICLE;
    }
    if (f->n > 0) {
        render_project_all(R, &R->cam, R->W, R->H, f->dim == 3);
        sm_status st = render_splat_all(R->P, f->n, R->W, R->H, R->zb, R->zi, R->threads);
        if (st != SM_OK) return st;
    }
    if (f->dim == 3) render_shade_3d(R, rgb);
    else render_shade_2d(R, rgb);
    if (R->o->legend) render_draw_legend(R, rgb);
    return SM_OK;
}

/* Buffers, colliders, shadows and the image, once R is set up. */
static sm_status render_with(rctx *R, uint8_t *rgb) {
    const sm_render_opts *o = R->o;
    const size_t npix = (size_t)R->W * (size_t)R->H;
    R->col = o->ncolliders > 0 ? calloc((size_t)o->ncolliders, sizeof *R->col) : NULL;
    R->ncol = o->ncolliders;
    R->P = malloc((R->f->n ? R->f->n : 1) * sizeof *R->P);
    R->zb = malloc(npix * sizeof *R->zb);
    R->zi = malloc(npix * sizeof *R->zi);
    if (!R->P || !R->zb || !R->zi || (o->ncolliders > 0 && !R->col)) return SM_ERR_NOMEM;
    if (R->ncol) render_setup_colliders(R);
    if (o->ground == SM_GROUND_AUTO) /* a ground-like half-space collider is the ground */
        for (int c = 0; c < R->ncol; c++)
            if (R->col[c].visible && R->col[c].ground_like) R->has_ground = 0;
    sm_status st = R->shadows ? render_shadows(R) : SM_OK;
    if (st == SM_OK) st = render_image(R, rgb);
    return st;
}

sm_status sm_render(const sm_frame *f, const sm_render_opts *o, uint8_t *rgb, char *err, size_t errlen) {
    char own_err[8];
    sm_errbuf_or_own(&err, &errlen, own_err, sizeof own_err);
    if (!o) {
        snprintf(err, errlen, "render: no options");
        return SM_ERR_INVALID;
    }
    if (!rgb) {
        snprintf(err, errlen, "render: no output buffer");
        return SM_ERR_INVALID;
    }
    sm_status st = validate(f, o, err, errlen);
    if (st != SM_OK) return st;
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
    if ((st = setup_radii(&R, &owned_rad, &rmax)) != SM_OK) {
        snprintf(err, errlen, "render: out of memory");
        return st;
    }
    scene_boxes B;
    setup_scene(&R, rmax, &B);
    render_setup_colours(&R);
    sm_camera cam = o->has_camera ? o->camera : render_fit_camera(f->dim, B.fit_lo, B.fit_hi, R.W, R.H);
    if (f->dim == 2 && !(cam.ortho_height > 0)) {
        sm_camera fc = render_fit_camera(2, B.fit_lo, B.fit_hi, R.W, R.H);
        cam.ortho_height = fc.ortho_height;
    }
    render_setup_view(&R, &cam);
    st = render_with(&R, rgb);
    if (st == SM_ERR_NOMEM) snprintf(err, errlen, "render: out of memory (%zu particles, %d x %d)", f->n, R.W, R.H);
    free(R.sp.z);
    free(R.sc.z);
    free(R.P);
    free(R.zb);
    free(R.zi);
    free(R.col);
    free(owned_rad);
    return st;
}

sm_status sm_render_ply_to_png(const char *ply_path, const char *png_path, const sm_render_opts *o, char *err,
                               size_t errlen) {
    sm_frame f;
    sm_status st = sm_ply_read(ply_path, &f, err, errlen);
    if (st != SM_OK) return st;
    size_t bytes = (size_t)(o->width > 0 ? o->width : 1) * (size_t)(o->height > 0 ? o->height : 1) * 3;
    uint8_t *img = malloc(bytes);
    if (!img) {
        sm_frame_free(&f);
        snprintf(err, errlen, "%s: out of memory for the image", png_path);
        return SM_ERR_NOMEM;
    }
    st = sm_render(&f, o, img, err, errlen);
    if (st == SM_OK) st = sm_png_write(png_path, o->width, o->height, img, err, errlen);
    free(img);
    sm_frame_free(&f);
    return st;
}
