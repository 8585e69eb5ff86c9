/* Views: the camera (perspective, or orthographic in 2D and on request) and the light's
 * orthographic view for shadow maps; the fitted default camera. See internal.h.
 *
 * A view maps a point p to the screen: d = p - eye, x = d.r, y = d.u, z = d.f; perspective
 * (sx, sy) = (cx + focal x / z, cy - focal y / z), orthographic (cx + focal x, cy - focal y). */
#include <stdlib.h>
#include <string.h>

#include "app/render/internal.h"

int render_view_basis(view *v, const double eye[3], const double target[3], const double up[3]) {
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

void render_view_project(const view *v, const double p[3], double *sx, double *sy, double *z) {
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

void render_view_ray(const view *v, double px, double py, double o[3], double d[3]) {
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

/* Corner m (bits: x, y, z from hi) of the box [lo, hi]. */
static void box_corner(const double lo[3], const double hi[3], int m, double p[3]) {
    p[0] = (m & 1) ? hi[0] : lo[0];
    p[1] = (m & 2) ? hi[1] : lo[1];
    p[2] = (m & 4) ? hi[2] : lo[2];
}

/* The eye distance at which the 8 corners of [lo, hi] fit the view's half-angles (tangents th,
 * tv) around target tgt, looking along -e (basis v). */
static double fit_distance(const view *v, const double lo[3], const double hi[3], const double tgt[3], double th,
                           double tv) {
    double dist = 0;
    for (int m = 0; m < 8; m++) {
        double p[3];
        box_corner(lo, hi, m, p);
        double q[3] = {p[0] - tgt[0], p[1] - tgt[1], p[2] - tgt[2]};
        double cr = fabs(dot3(q, v->r)), cu = fabs(dot3(q, v->u)), cf = dot3(q, v->f);
        dist = fmax(dist, cr / th - cf);
        dist = fmax(dist, cu / tv - cf);
    }
    return dist;
}

/* Moves tgt so that the corners' screen box is centred, seen from distance dist. */
static void centre_target(const view *v, const double lo[3], const double hi[3], double dist, double tgt[3]) {
    double x0 = HUGE_VAL, x1 = -HUGE_VAL, y0 = HUGE_VAL, y1 = -HUGE_VAL;
    for (int m = 0; m < 8; m++) {
        double p[3];
        box_corner(lo, hi, m, p);
        double q[3] = {p[0] - tgt[0], p[1] - tgt[1], p[2] - tgt[2]};
        double z = dist + dot3(q, v->f);
        double xs = dot3(q, v->r) / z, ys = dot3(q, v->u) / z;
        x0 = fmin(x0, xs);
        x1 = fmax(x1, xs);
        y0 = fmin(y0, ys);
        y1 = fmax(y1, ys);
    }
    double mx = 0.5 * (x0 + x1) * dist, my = 0.5 * (y0 + y1) * dist;
    for (int k = 0; k < 3; k++) tgt[k] += mx * v->r[k] + my * v->u[k];
}

sm_camera render_fit_camera(int dim, const double lo[3], const double hi[3], int W, int H) {
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
    render_view_basis(&v, ctr, far_pt, c.up); /* only the basis (r, u, f) is used */
    for (int round = 0; round < 6; round++) {
        dist = fmax(fit_distance(&v, lo, hi, tgt, th, tv), 0.05 * diag);
        centre_target(&v, lo, hi, dist, tgt);
    }
    memcpy(c.target, tgt, sizeof tgt);
    for (int k = 0; k < 3; k++) c.eye[k] = tgt[k] + dist * e[k];
    return c;
}

void render_setup_view(rctx *R, const sm_camera *c) {
    view *v = &R->cam;
    v->cx = 0.5 * R->W;
    v->cy = 0.5 * R->H;
    if (R->dim == 2) {
        double e[3] = {c->target[0], c->target[1], 1.0}, t[3] = {c->target[0], c->target[1], 0.0}, up[3] = {0, 1, 0};
        render_view_basis(v, e, t, up);
        v->ortho = 1;
        v->focal = R->H / c->ortho_height;
        return;
    }
    render_view_basis(v, c->eye, c->target, c->up);
    if (c->fov_deg > 0) {
        v->ortho = 0;
        v->focal = 0.5 * R->H / tan(0.5 * c->fov_deg * PI_D / 180.0);
    } else {
        v->ortho = 1;
        v->focal = R->H / c->ortho_height;
        /* Move the eye back so the whole clip box is in front of it. */
        double back = 0;
        for (int m = 0; m < 8; m++) {
            double p[3];
            box_corner(R->lo, R->hi, m, p);
            double q[3] = {p[0] - v->eye[0], p[1] - v->eye[1], p[2] - v->eye[2]};
            back = fmax(back, -dot3(q, v->f));
        }
        for (int k = 0; k < 3; k++) v->eye[k] -= (back + 0.01 * R->diag) * v->f[k];
    }
}

sm_status render_setup_light_map(rctx *R, shadow_map *m, int size) {
    double ctr[3], up[3] = {0, 1, 0};
    for (int k = 0; k < 3; k++) ctr[k] = 0.5 * (R->lo[k] + R->hi[k]);
    if (fabs(R->L[1]) > 0.99) {
        up[1] = 0;
        up[2] = 1;
    }
    double eye[3];
    for (int k = 0; k < 3; k++) eye[k] = ctr[k] + R->L[k] * R->diag;
    view *v = &m->v;
    render_view_basis(v, eye, ctr, up);
    v->ortho = 1;
    double ur0 = HUGE_VAL, ur1 = -HUGE_VAL, uu0 = HUGE_VAL, uu1 = -HUGE_VAL;
    for (int c = 0; c < 8; c++) {
        double p[3];
        box_corner(R->lo, R->hi, c, p);
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
    if (!m->z) return SM_ERR_NOMEM;
    const long nt = (long)m->w * m->h;
    float *z = m->z;
OMP(omp parallel for schedule(static) num_threads(R->threads))
    for (long i = 0; i < nt; i++) z[i] = INFINITY;
    return SM_OK;
}
