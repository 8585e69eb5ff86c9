/* Colliders as the renderer draws them: shapes moved into world space by their collider's pose,
 * their signed distance phi (sm_shape_distance; the union of a collider's shapes is the minimum,
 * an inside-out collider negates it), and the first surface along a ray by sphere tracing (a lone
 * half-space analytically). See internal.h. */
#include <string.h>

#include "app/render/internal.h"

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

double render_collider_phi(const rcoll *c, int dim, const double x[3]) {
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

void render_collider_grad(const rcoll *c, int dim, const double x[3], double g[3]) {
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

/* A lone half-space: the ray's crossing of the plane, entering from outside. */
static int plane_hit(const rcoll *c, const double o[3], const double d[3], double t0, double t1, double *thit) {
    double p0 = c->pn[0] * (o[0] + t0 * d[0] - c->pc[0]) + c->pn[1] * (o[1] + t0 * d[1] - c->pc[1]) +
                c->pn[2] * (o[2] + t0 * d[2] - c->pc[2]);
    double s = dot3(c->pn, d);
    if (p0 < 0 || s >= 0) return 0; /* starts inside, or moves away */
    double t = t0 - p0 / s;
    if (t > t1) return 0;
    *thit = t;
    return 1;
}

/* phi at o + t d. */
static double phi_along(const rcoll *c, const double o[3], const double d[3], double t) {
    double x[3];
    for (int k = 0; k < 3; k++) x[k] = o[k] + t * d[k];
    return render_collider_phi(c, 3, x);
}

/* A ray that starts inside the solid first marches out of it (so containers are seen from the
 * inside). eps(t) = e0 + e1 t is the hit tolerance (a fraction of the pixel footprint). */
int render_collider_hit(const rcoll *c, const double o[3], const double d[3], double t0, double t1, double e0,
                        double e1, double *thit) {
    if (!c->visible || !ray_box(o, d, c->lo, c->hi, &t0, &t1)) return 0;
    if (c->plane) return plane_hit(c, o, d, t0, t1, thit);
    double t = t0;
    double phi = phi_along(c, o, d, t);
    int it = 0;
    /* Starting inside the solid, or on its surface where the ray enters the search box (which
     * would otherwise report a hit on the box face): march out until clear of the surface. */
    while (phi < e0 + e1 * t) {
        if (++it > 160) return 0;
        double step = fabs(phi);
        double e = e0 + e1 * t;
        t += step > e ? step : e;
        if (t > t1) return 0;
        phi = phi_along(c, o, d, t);
    }
    for (; it < 320; it++) {
        double e = e0 + e1 * t;
        if (phi < e) {
            *thit = t;
            return 1;
        }
        t += phi;
        if (t > t1) return 0;
        phi = phi_along(c, o, d, t);
    }
    return 0;
}

/* Half-extents of the box around shape ws (rotation matrix Rw); 0 if it is unbounded. */
static int shape_extent(const sm_shape *ws, const double Rw[9], double ext[3]) {
    ext[0] = ext[1] = ext[2] = 0;
    int finite_shape = !ws->inside_out;
    switch (ws->kind) {
    case SM_SHAPE_HALFSPACE: finite_shape = 0; break;
    case SM_SHAPE_SPHERE: ext[0] = ext[1] = ext[2] = fabs(ws->radius); break;
    case SM_SHAPE_BOX:
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++) ext[i] += fabs(Rw[3 * i + j]) * fabs(ws->half_extent[j]);
        break;
    case SM_SHAPE_CYLINDER: {
        double h[3] = {fabs(ws->radius), fabs(ws->half_height), fabs(ws->radius)};
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++) ext[i] += fabs(Rw[3 * i + j]) * h[j];
        break;
    }
    case SM_SHAPE_MESH: { /* a ball about the mesh frame's origin holding the field's box */
        const sm_mesh_field_stats *st = sm_mesh_field_get_stats(ws->mesh);
        double r2 = 0;
        for (int k = 0; k < 3; k++) r2 += fmax(fabs(st->lo[k]), fabs(st->hi[k])) * fmax(fabs(st->lo[k]), fabs(st->hi[k]));
        ext[0] = ext[1] = ext[2] = sqrt(r2);
        if (st->container) finite_shape = 0;
        break;
    }
    }
    return finite_shape;
}

/* A lone half-space: its world normal and point. */
static void setup_plane(rcoll *rc, int dim) {
    double Rw[9], nl[3], nn = norm3(rc->s[0].normal);
    quat_mat(rc->s[0].rotation, Rw);
    for (int k = 0; k < 3; k++) nl[k] = rc->s[0].normal[k] / nn;
    mat_vec(Rw, nl, rc->pn);
    double sg = (rc->s[0].inside_out != 0) != rc->inside_out ? -1.0 : 1.0;
    for (int k = 0; k < 3; k++) {
        rc->pn[k] *= sg;
        rc->pc[k] = rc->s[0].center[k];
    }
    if (dim == 2) rc->pn[2] = 0;
    rc->plane = 1;
    rc->ground_like = rc->pn[1] > 0.97 * norm3(rc->pn);
}

/* Collider d at pose in world space, its bounds clipped to R's box. */
static void setup_one(const rctx *R, const sm_collider_def *d, const sm_pose *pose, rcoll *rc) {
    memset(rc, 0, sizeof *rc);
    double qp[4], Rp[9];
    quat_norm(pose->rotation, qp);
    quat_mat(qp, Rp);
    rc->ns = d->shape_count;
    rc->inside_out = d->inside_out != 0;
    int bounded = !rc->inside_out;
    double blo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, bhi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    for (int s = 0; s < d->shape_count; s++) {
        sm_shape ws = d->shapes[s];
        double cw[3], qs[4], qw[4], Rw[9];
        mat_vec(Rp, ws.center, cw);
        for (int k = 0; k < 3; k++) ws.center[k] = cw[k] + pose->position[k];
        quat_norm(d->shapes[s].rotation, qs);
        quat_mul(qp, qs, qw);
        memcpy(ws.rotation, qw, sizeof qw);
        if (R->dim == 2) ws.center[2] = 0; /* rotation about z only */
        rc->s[s] = ws;
        quat_mat(qw, Rw);
        double ext[3];
        if (!shape_extent(&ws, Rw, ext)) bounded = 0;
        for (int k = 0; k < 3; k++) {
            if (ws.center[k] - ext[k] < blo[k]) blo[k] = ws.center[k] - ext[k];
            if (ws.center[k] + ext[k] > bhi[k]) bhi[k] = ws.center[k] + ext[k];
        }
    }
    if (rc->ns == 1 && rc->s[0].kind == SM_SHAPE_HALFSPACE) setup_plane(rc, R->dim);
    rc->container = !bounded && !rc->plane;
    /* A ray entering the search box close to the surface is treated as leaving the solid (see
     * render_collider_hit), so the box of a bounded collider keeps a margin around it. */
    double pad = 0.02 * R->diag;
    rc->visible = 1;
    for (int k = 0; k < 3; k++) {
        rc->lo[k] = bounded ? fmax(blo[k] - pad, R->lo[k]) : R->lo[k];
        rc->hi[k] = bounded ? fmin(bhi[k] + pad, R->hi[k]) : R->hi[k];
        if (rc->lo[k] > rc->hi[k]) rc->visible = 0;
    }
}

void render_setup_colliders(rctx *R) {
    const sm_render_opts *o = R->o;
    for (int c = 0; c < o->ncolliders; c++) {
        sm_pose pose = o->poses ? o->poses[c] : o->colliders[c].pose;
        setup_one(R, &o->colliders[c], &pose, &R->col[c]);
    }
}

void render_collider_shadow(rctx *R) {
    shadow_map *m = &R->sc;
    const long nt = (long)m->w * m->h;
    const double e0 = 1e-6 * R->diag, e1 = 0.0;
    const double ee = 0.5 * m->texel + e0;
OMP(omp parallel for schedule(dynamic, 64) num_threads(R->threads))
    for (long k = 0; k < nt; k++) {
        int i = (int)(k % m->w), j = (int)(k / m->w);
        double o[3], d[3];
        render_view_ray(&m->v, i + 0.5, j + 0.5, o, d);
        double best = HUGE_VAL;
        for (int c = 0; c < R->ncol; c++) {
            double t;
            if (render_collider_hit(&R->col[c], o, d, 0.0, best < HUGE_VAL ? best : 4.0 * R->diag, ee, e1, &t) &&
                t < best)
                best = t;
        }
        if (best < HUGE_VAL) m->z[k] = (float)best;
    }
}
