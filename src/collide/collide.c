/* Level-set colliders: grid-node collision and Coulomb friction (thesis §3.6.3, eqs. 3.99-3.108,
 * and Algorithm 7, GRID_COLLISIONS / FRICTION; the approach of Gast et al. 2015).
 *
 * Collision acts on the deformed grid node x-hat = x_i + dt v (3.99):
 *   sticky    (no-slip, 3.100): a node inside at t^n takes the collider velocity v_b(x-hat);
 *   slip      (3.102):          a node inside at t^n keeps its depth, phi(x-hat) = phi(x_i^n);
 *                               "inside" includes phi(x_i^n) = 0: a wall on a grid line holds the
 *                               nodes on it (docs/validation.md, the elastic column);
 *   separate  (3.108):          phi(x-hat) >= max(0, phi(x_i^n)).
 * The unsatisfied constraint phi(x) = a (or >= a) is enforced by x <- x - (phi(x) - a) grad phi(x)
 * (3.105), i.e. v <- v - phi-hat grad phi(x-hat) / dt with phi-hat = phi(x-hat) - min(phi(x_i^n), 0).
 * Friction then removes min(|v_t|, mu |dv|) of the tangential velocity relative to the collider.
 *
 * Signed distances (negative inside), in the shape's own frame p = R_s^T (x - center):
 *   half-space : phi = n.p with n = normal/|normal|, grad = n.
 *   sphere     : phi = |p| - r, grad = p/|p|.
 *   box        : q = |p| - h (per axis); phi = |max(q, 0)| + min(max_k q_k, 0) (exact Euclidean).
 *                Outside: grad = sign(p) max(q,0)/|max(q,0)|; inside: +-e_k of the largest q_k.
 *   cylinder   : (axis y) d = (sqrt(p_x^2 + p_z^2) - r, |p_y| - h);
 *                phi = |max(d, 0)| + min(max(d_0, d_1), 0) (exact capped-cylinder distance),
 *                the box formula in the (radial, axial) half plane.
 *   mesh       : the interpolated field of sm_mesh_field (mesh_sdf.c), grad its normalised gradient;
 *                it is Lipschitz with constant L = stats.lipschitz (>= 1, up to sqrt(d) at sharp
 *                corners) rather than 1, and a collider's `lip` is the largest L of its shapes.
 *   In 2D the box/cylinder are their xy cross-sections (rectangles), the sphere a disk.
 * inside_out negates phi and grad. A collider is the union (min) of its shapes, optionally
 * negated as a whole, placed in the world by its pose: phi_w(x) = phi_l(R^T (x - p)),
 * grad_w = R grad_l. Everything here is computed in double. */
#include "collide/collide.h"

#include <string.h>

#include "collide/mesh_field.h"

/* ------------------------------------------------------------------------------------------ */
/* Small vector / quaternion helpers                                                            */

static double dot3(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

static double norm_n(const double *a, int n) {
    double s = 0.0;
    for (int k = 0; k < n; k++) s += a[k] * a[k];
    return sqrt(s);
}

/* Hamilton product r = a (x) b, quaternions (w, x, y, z). r may alias neither a nor b. */
static void quat_mul(const double a[4], const double b[4], double r[4]) {
    r[0] = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3];
    r[1] = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2];
    r[2] = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1];
    r[3] = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0];
}

/* Normalises q in place; an all-zero quaternion becomes the identity. */
static void quat_normalize(double q[4]) {
    double n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (n > 0.0) {
        for (int k = 0; k < 4; k++) q[k] /= n;
    } else {
        q[0] = 1.0;
        q[1] = q[2] = q[3] = 0.0;
    }
}

static int quat_is_identity(const double q[4]) {
    return q[1] == 0.0 && q[2] == 0.0 && q[3] == 0.0 && q[0] > 0.0;
}

/* The rotation of q / |q| (so a slightly non-unit q still gives an orthogonal matrix); the
 * all-zero quaternion is treated as the identity. */
void sm_quat_to_mat(const double q[4], double R[9]) {
    double w = q[0], x = q[1], y = q[2], z = q[3];
    double n2 = w * w + x * x + y * y + z * z;
    double s = n2 > 0.0 ? 2.0 / n2 : 0.0;
    R[0] = 1.0 - s * (y * y + z * z);
    R[1] = s * (x * y - w * z);
    R[2] = s * (x * z + w * y);
    R[3] = s * (x * y + w * z);
    R[4] = 1.0 - s * (x * x + z * z);
    R[5] = s * (y * z - w * x);
    R[6] = s * (x * z - w * y);
    R[7] = s * (y * z + w * x);
    R[8] = 1.0 - s * (x * x + y * y);
}

/* out = R^T a (world -> local), over dim components (2D: the upper-left 2x2 block). */
static void mat_t_vec(const double R[9], int dim, const double a[3], double out[3]) {
    if (dim == 2) {
        out[0] = R[0] * a[0] + R[3] * a[1];
        out[1] = R[1] * a[0] + R[4] * a[1];
        out[2] = 0.0;
    } else {
        out[0] = R[0] * a[0] + R[3] * a[1] + R[6] * a[2];
        out[1] = R[1] * a[0] + R[4] * a[1] + R[7] * a[2];
        out[2] = R[2] * a[0] + R[5] * a[1] + R[8] * a[2];
    }
}

/* out = R a (local -> world), over dim components. */
static void mat_vec(const double R[9], int dim, const double a[3], double out[3]) {
    if (dim == 2) {
        out[0] = R[0] * a[0] + R[1] * a[1];
        out[1] = R[3] * a[0] + R[4] * a[1];
        out[2] = 0.0;
    } else {
        out[0] = R[0] * a[0] + R[1] * a[1] + R[2] * a[2];
        out[1] = R[3] * a[0] + R[4] * a[1] + R[5] * a[2];
        out[2] = R[6] * a[0] + R[7] * a[1] + R[8] * a[2];
    }
}

/* ------------------------------------------------------------------------------------------ */
/* Shapes                                                                                       */

sm_shape sm_shape_default(sm_shape_kind kind) {
    sm_shape s;
    memset(&s, 0, sizeof s);
    s.kind = kind;
    s.rotation[0] = 1.0;
    return s;
}

static double sign_pos(double a) { return a < 0.0 ? -1.0 : 1.0; }

/* Exact distance to an axis-aligned box of half sizes h centred at the origin, over n = 2 or 3
 * axes; gradient g (n components). */
static double box_sdf(const double *p, const double *h, int n, double *g) {
    double q[3], outside2 = 0.0, qmax = -HUGE_VAL;
    int kmax = 0;
    for (int k = 0; k < n; k++) {
        q[k] = fabs(p[k]) - h[k];
        if (q[k] > 0.0) outside2 += q[k] * q[k];
        if (q[k] > qmax) {
            qmax = q[k];
            kmax = k;
        }
    }
    if (outside2 > 0.0) {
        double d = sqrt(outside2);
        for (int k = 0; k < n; k++) g[k] = q[k] > 0.0 ? sign_pos(p[k]) * q[k] / d : 0.0;
        return d;
    }
    /* Inside or on the surface: the nearest face is the one with the largest q (first on ties). */
    for (int k = 0; k < n; k++) g[k] = 0.0;
    g[kmax] = sign_pos(p[kmax]);
    return qmax;
}

/* Distance in the shape's own frame (p relative to the centre, already unrotated); g in that
 * frame. The half-space normal is taken in the shape frame too (rotated with the shape). */
static double shape_local_sdf(const sm_shape *s, int dim, const double p[3], double g[3], double t) {
    g[0] = g[1] = g[2] = 0.0;
    switch (s->kind) {
    case SM_SHAPE_HALFSPACE: {
        double nn = norm_n(s->normal, dim);
        SM_ASSERT(nn > 0.0);
        double phi = 0.0;
        for (int k = 0; k < dim; k++) {
            g[k] = s->normal[k] / nn;
            phi += g[k] * p[k];
        }
        return phi;
    }
    case SM_SHAPE_SPHERE: {
        double r = norm_n(p, dim);
        if (r > 0.0) {
            for (int k = 0; k < dim; k++) g[k] = p[k] / r;
        } else {
            g[1] = 1.0; /* centre: every direction is nearest; pick +y */
        }
        return r - s->radius;
    }
    case SM_SHAPE_BOX:
        return box_sdf(p, s->half_extent, dim, g);
    case SM_SHAPE_CYLINDER: {
        if (dim == 2) {
            double h[2] = {s->radius, s->half_height};
            return box_sdf(p, h, 2, g);
        }
        /* The (radial, axial) half plane: a 2D box of half sizes (r, h) with the radial
         * coordinate rho >= 0; map its gradient back through e_rho and e_y. */
        double rho = sqrt(p[0] * p[0] + p[2] * p[2]);
        double er[2];
        if (rho > 0.0) {
            er[0] = p[0] / rho;
            er[1] = p[2] / rho;
        } else {
            er[0] = 1.0; /* on the axis: every radial direction is nearest; pick +x */
            er[1] = 0.0;
        }
        double pp[2] = {rho, p[1]}, h[2] = {s->radius, s->half_height}, g2[2];
        double phi = box_sdf(pp, h, 2, g2);
        g[0] = g2[0] * er[0];
        g[1] = g2[1];
        g[2] = g2[0] * er[1];
        return phi;
    }
    case SM_SHAPE_MESH: /* an animated field at time t (t only matters for one) */
        return s->mesh->anim ? sm_mesh_anim_local(s->mesh, t, p, g) : sm_mesh_field_local(s->mesh, p, g);
    }
    SM_ASSERT(0 && "unknown shape kind");
    return HUGE_VAL;
}

/* sm_shape_distance at time t (animated mesh fields; every other shape ignores t). */
static double shape_distance_at(const sm_shape *s, int dim, const double x[3], double grad[3], double t) {
    SM_ASSERT(dim == 2 || dim == 3);
    double d[3], p[3], g[3], phi;
    d[0] = x[0] - s->center[0];
    d[1] = x[1] - s->center[1];
    d[2] = dim == 3 ? x[2] - s->center[2] : 0.0;
    if (quat_is_identity(s->rotation)) {
        phi = shape_local_sdf(s, dim, d, g, t);
    } else {
        double R[9], gl[3];
        sm_quat_to_mat(s->rotation, R);
        mat_t_vec(R, dim, d, p);
        phi = shape_local_sdf(s, dim, p, gl, t);
        mat_vec(R, dim, gl, g);
    }
    if (s->inside_out) {
        phi = -phi;
        g[0] = -g[0];
        g[1] = -g[1];
        g[2] = -g[2];
    }
    if (grad) {
        grad[0] = g[0];
        grad[1] = g[1];
        grad[2] = dim == 3 ? g[2] : 0.0;
    }
    return phi;
}

double sm_shape_distance(const sm_shape *s, int dim, const double x[3], double grad[3]) {
    return shape_distance_at(s, dim, x, grad, 0.0);
}

/* ------------------------------------------------------------------------------------------ */
/* Colliders                                                                                    */

sm_collider_def sm_collider_def_default(void) {
    sm_collider_def d;
    memset(&d, 0, sizeof d);
    d.shape_count = 0;
    d.mode = SM_COLLIDE_STICKY;
    d.friction = 0.0;
    d.pose.rotation[0] = 1.0;
    /* Unused shape slots get the default identity rotation so a caller filling in a slot
     * field by field gets a well-formed shape. */
    for (int k = 0; k < SM_MAX_COLLIDER_SHAPES; k++) d.shapes[k] = sm_shape_default(SM_SHAPE_HALFSPACE);
    d.motion = NULL;
    d.motion_user = NULL;
    return d;
}

void sm_collider_init(sm_collider *c, const sm_collider_def *def) {
    SM_ASSERT(def->shape_count >= 1 && def->shape_count <= SM_MAX_COLLIDER_SHAPES);
    memset(c, 0, sizeof *c);
    c->def = *def;
    c->lip = 1.0;
    for (int s = 0; s < def->shape_count; s++)
        if (def->shapes[s].kind == SM_SHAPE_MESH) {
            c->lip = fmax(c->lip, sm_mesh_field_get_stats(def->shapes[s].mesh)->lipschitz);
            if (def->shapes[s].mesh->anim) c->animated = 1;
        }
    const sm_shape *s0 = &def->shapes[0];
    c->halfspace = def->shape_count == 1 && s0->kind == SM_SHAPE_HALFSPACE && quat_is_identity(s0->rotation);
    for (int dim = 2; c->halfspace && dim <= 3; dim++) {
        double nn = norm_n(s0->normal, dim);
        for (int k = 0; k < dim; k++) c->hs_g[dim - 2][k] = s0->normal[k] / nn;
    }
    c->t0 = 0.0;
    c->dt = 0.0;
    c->pose0 = def->pose;
    if (def->motion) def->motion(def->motion_user, 0.0, &c->pose0);
    quat_normalize(c->pose0.rotation);
    c->pose1 = c->pose0;
    sm_quat_to_mat(c->pose0.rotation, c->R0);
    memcpy(c->R1, c->R0, sizeof c->R1);
    for (int k = 0; k < 3; k++) {
        c->v[k] = def->velocity[k];
        c->w[k] = def->angular_velocity[k];
    }
}

void sm_collider_retain_meshes(sm_collider *c) {
    for (int s = 0; s < c->def.shape_count; s++)
        if (c->def.shapes[s].kind == SM_SHAPE_MESH) sm_mesh_field_retain((sm_mesh_field *)c->def.shapes[s].mesh);
}

void sm_collider_release_meshes(sm_collider *c) {
    for (int s = 0; s < c->def.shape_count; s++)
        if (c->def.shapes[s].kind == SM_SHAPE_MESH) sm_mesh_field_release((sm_mesh_field *)c->def.shapes[s].mesh);
}

void sm_collider_begin_step(sm_collider *c, double t0, double dt) {
    SM_ASSERT(dt > 0.0);
    c->t0 = t0;
    c->dt = dt;
    const double *q0 = c->pose0.rotation;
    if (c->def.motion) {
        c->def.motion(c->def.motion_user, t0 + dt, &c->pose1);
        quat_normalize(c->pose1.rotation);
        for (int k = 0; k < 3; k++) c->v[k] = (c->pose1.position[k] - c->pose0.position[k]) / dt;
        /* Relative rotation dq = q1 q0^-1 (q0 unit: inverse = conjugate), shortest way round. */
        double q0c[4] = {q0[0], -q0[1], -q0[2], -q0[3]}, dq[4];
        quat_mul(c->pose1.rotation, q0c, dq);
        if (dq[0] < 0.0) {
            for (int k = 0; k < 4; k++) dq[k] = -dq[k];
        }
        double s = sqrt(dq[1] * dq[1] + dq[2] * dq[2] + dq[3] * dq[3]);
        /* angle = 2 atan2(s, c); w = axis angle / dt = (dq_vec / s) angle / dt. */
        double f = s > 0.0 ? 2.0 * atan2(s, dq[0]) / s : 2.0 / dq[0];
        for (int k = 0; k < 3; k++) c->w[k] = dq[k + 1] * f / dt;
    } else {
        for (int k = 0; k < 3; k++) {
            c->v[k] = c->def.velocity[k];
            c->w[k] = c->def.angular_velocity[k];
            c->pose1.position[k] = c->pose0.position[k] + c->v[k] * dt;
        }
        /* exp(w dt / 2) = (cos(|w| dt/2), sin(|w| dt/2) w/|w|). */
        double wn = norm_n(c->w, 3);
        double half = 0.5 * wn * dt;
        double e[4] = {1.0, 0.0, 0.0, 0.0};
        if (wn > 0.0) {
            double sh = sin(half) / wn;
            e[0] = cos(half);
            e[1] = c->w[0] * sh;
            e[2] = c->w[1] * sh;
            e[3] = c->w[2] * sh;
        }
        quat_mul(e, q0, c->pose1.rotation);
        quat_normalize(c->pose1.rotation);
    }
    sm_quat_to_mat(c->pose1.rotation, c->R1);
}

void sm_collider_end_step(sm_collider *c) {
    c->pose0 = c->pose1;
    memcpy(c->R0, c->R1, sizeof c->R0);
    c->t0 += c->dt;
}

/* sm_collider_phi for a collider of one half-space with the identity rotation (c->halfspace):
 * the operations of the general path below (mat_t_vec, shape_distance_at, shape_local_sdf, the
 * signs, mat_vec) in the same order, so the same bits, in scalars that stay in registers (through
 * arrays, the vector load of the frame's point after its scalar stores stalled), with the normal's
 * square root and divisions taken once (sm_collider_init). A ground plane is tested at every node
 * near it, twice a step. */
static double halfspace_phi(const sm_collider *c, int dim, int which, const double x[3], double grad[3]) {
    const sm_pose *pose = which ? &c->pose1 : &c->pose0;
    const double *R = which ? c->R1 : c->R0, *ctr = c->def.shapes[0].center, *n = c->hs_g[dim - 2];
    const double d0 = x[0] - pose->position[0], d1 = x[1] - pose->position[1];
    double phi = 0.0, g0 = n[0], g1 = n[1], g2 = dim == 3 ? n[2] : 0.0;
    if (dim == 2) {
        const double p0 = (R[0] * d0 + R[3] * d1) - ctr[0], p1 = (R[1] * d0 + R[4] * d1) - ctr[1];
        phi += g0 * p0;
        phi += g1 * p1;
    } else {
        const double d2 = x[2] - pose->position[2];
        const double p0 = (R[0] * d0 + R[3] * d1 + R[6] * d2) - ctr[0];
        const double p1 = (R[1] * d0 + R[4] * d1 + R[7] * d2) - ctr[1];
        const double p2 = (R[2] * d0 + R[5] * d1 + R[8] * d2) - ctr[2];
        phi += g0 * p0;
        phi += g1 * p1;
        phi += g2 * p2;
    }
    if (c->def.shapes[0].inside_out) phi = -phi, g0 = -g0, g1 = -g1, g2 = -g2;
    if (!(phi < HUGE_VAL)) phi = HUGE_VAL, g0 = g1 = g2 = 0.0; /* as the general loop: a NaN is no minimiser */
    if (c->def.inside_out) phi = -phi, g0 = -g0, g1 = -g1, g2 = -g2;
    if (grad && dim == 2) {
        grad[0] = R[0] * g0 + R[1] * g1;
        grad[1] = R[3] * g0 + R[4] * g1;
        grad[2] = 0.0;
    } else if (grad) {
        grad[0] = R[0] * g0 + R[1] * g1 + R[2] * g2;
        grad[1] = R[3] * g0 + R[4] * g1 + R[5] * g2;
        grad[2] = R[6] * g0 + R[7] * g1 + R[8] * g2;
    }
    return phi;
}

double sm_collider_phi(const sm_collider *c, int dim, int which, const double x[3], double grad[3]) {
    SM_ASSERT(dim == 2 || dim == 3);
    if (c->halfspace) return halfspace_phi(c, dim, which, x, grad);
    const sm_pose *pose = which ? &c->pose1 : &c->pose0;
    const double *R = which ? c->R1 : c->R0;
    double d[3] = {x[0] - pose->position[0], x[1] - pose->position[1],
                   dim == 3 ? x[2] - pose->position[2] : 0.0};
    double xl[3], best = HUGE_VAL, gbest[3] = {0.0, 0.0, 0.0};
    const double t = which ? c->t0 + c->dt : c->t0;
    mat_t_vec(R, dim, d, xl);
    for (int s = 0; s < c->def.shape_count; s++) {
        double g[3];
        double phi = shape_distance_at(&c->def.shapes[s], dim, xl, g, t);
        if (phi < best) { /* strict: the first minimiser wins ties */
            best = phi;
            gbest[0] = g[0];
            gbest[1] = g[1];
            gbest[2] = g[2];
        }
    }
    if (c->def.inside_out) {
        best = -best;
        gbest[0] = -gbest[0];
        gbest[1] = -gbest[1];
        gbest[2] = -gbest[2];
    }
    if (grad) mat_vec(R, dim, gbest, grad);
    return best;
}

double sm_collider_phi_box(const sm_collider *c, int dim, int which, const double ctr[3], const double half[3]) {
    double g[3], r2 = 0, slack = 0;
    const double phi = sm_collider_phi(c, dim, which, ctr, g);
    const int linear = c->def.shape_count == 1 && c->def.shapes[0].kind == SM_SHAPE_HALFSPACE;
    for (int a = 0; a < dim; a++) {
        r2 += half[a] * half[a];
        slack += fabs(g[a]) * half[a];
    }
    return phi - (linear ? slack : c->lip * sqrt(r2));
}

/* The deformation velocity (world frame) an animated mesh adds at world point x at t^{n+1}: that
 * of the shape nearest x (smallest phi) if it is an animated mesh, else 0. */
static void animated_velocity(const sm_collider *c, int dim, const double x[3], double add[3]) {
    const double t = c->t0 + c->dt, *p = c->pose1.position;
    double d[3] = {x[0] - p[0], x[1] - p[1], dim == 3 ? x[2] - p[2] : 0.0}, xl[3], best = HUGE_VAL;
    int sb = 0;
    mat_t_vec(c->R1, dim, d, xl);
    for (int s = 0; s < c->def.shape_count; s++) {
        double phi = shape_distance_at(&c->def.shapes[s], dim, xl, NULL, t);
        if (phi < best) best = phi, sb = s;
    }
    const sm_shape *s = &c->def.shapes[sb];
    add[0] = add[1] = add[2] = 0.0;
    if (s->kind != SM_SHAPE_MESH || !s->mesh->anim) return;
    double R[9], q[3], ps[3] = {xl[0] - s->center[0], xl[1] - s->center[1], dim == 3 ? xl[2] - s->center[2] : 0.0};
    double vm[3], vl[3];
    sm_quat_to_mat(s->rotation, R);
    mat_t_vec(R, dim, ps, q);
    sm_mesh_anim_velocity(s->mesh, t, q, vm);
    mat_vec(R, dim, vm, vl);
    mat_vec(c->R1, dim, vl, add);
}

void sm_collider_velocity(const sm_collider *c, int dim, const double x[3], double vel[3]) {
    const double *p = c->pose1.position, *w = c->w;
    if (dim == 2) {
        double rx = x[0] - p[0], ry = x[1] - p[1];
        vel[0] = c->v[0] - w[2] * ry;
        vel[1] = c->v[1] + w[2] * rx;
        vel[2] = 0.0;
    } else {
        double r[3] = {x[0] - p[0], x[1] - p[1], x[2] - p[2]};
        vel[0] = c->v[0] + w[1] * r[2] - w[2] * r[1];
        vel[1] = c->v[1] + w[2] * r[0] - w[0] * r[2];
        vel[2] = c->v[2] + w[0] * r[1] - w[1] * r[0];
    }
    if (c->animated) {
        double add[3];
        animated_velocity(c, dim, x, add);
        for (int k = 0; k < dim; k++) vel[k] += add[k];
    }
}

/* ------------------------------------------------------------------------------------------ */
/* Algorithm 7                                                                                  */

void sm_collide_node(const sm_collider *cs, int nc, int dim, const double xi[3], double dt,
                     double v[3], sm_node_contact *rec) {
    (void)sm_collide_node_among(cs, NULL, nc, dim, xi, dt, INFINITY, SM_GATE_OPEN, v, rec);
}

/* |v|^2 > vcap2 (dim components). */
static int faster_than(const double v[3], int dim, double vcap2) {
    double s = 0;
    for (int k = 0; k < dim; k++) s += v[k] * v[k];
    return s > vcap2;
}

int sm_collide_node_among(const sm_collider *cs, const int *which, int count, int dim, const double xi[3], double dt,
                          double vcap2, unsigned gate, double v[3], sm_node_contact *rec) {
    SM_ASSERT(dt > 0.0);
    rec->sticky = -1;
    rec->count = 0;
    for (int i = 0; i < count; i++) {
        const int b = which ? which[i] : i;
        const sm_collider *c = &cs[b];
        if (c->def.mode == SM_COLLIDE_SEPARATE && !(gate & sm_gate_bit(b))) continue; /* no material near */
        double xhat[3];
        for (int k = 0; k < 3; k++) xhat[k] = xi[k] + dt * v[k];
        double phi0 = sm_collider_phi(c, dim, 0, xi, NULL);
        sm_collide_mode mode = c->def.mode;
        if (mode == SM_COLLIDE_STICKY && phi0 < 0.0) {
            rec->sticky = b;
            sm_collider_velocity(c, dim, xhat, v);
            if (faster_than(v, dim, vcap2)) return 1;
            continue;
        }
        double n[3];
        double phihat = sm_collider_phi(c, dim, 1, xhat, n) - SM_MIN(phi0, 0.0);
        /* A node arriving at a sticky collider (outside at t^n, inside at t^{n+1}) is projected onto
         * the surface like a separating contact and marked `stick`: FRICTION then stops it relative
         * to the collider (infinite friction). Continuous in v, so Newton's constraint set does not
         * jump (a plain stick would), and the node never enters the collider. */
        /* A node that a previous projection left exactly on the surface stays in contact: phi-hat is
         * compared with a rounding-level tolerance, not with 0. Otherwise the contact set of the
         * implicit solve flickers between Newton steps (a node 1e-17 m outside is not "in contact"
         * and its normal residual, the contact force, suddenly counts). */
        /* Within the tolerance, outside (0 < phi-hat < ctol), the node is a contact but is not
         * pulled onto the surface: a separating or arriving contact only pushes. Pulled, it lost
         * every outward normal speed below ctol / dt (1.4 mm/s at dt 5e-6 s, 6 m from the origin), and
         * FRICTION took mu times that pull as well: a block sliding on a plane at mu = 0.5 slowed
         * 7.4% below g (sin - mu cos) at dt 5e-6 s (docs/validation.md section 6). A slip contact
         * removes the normal velocity both ways (phi-hat = the change of depth). */
        const double ctol = 1e-9 * (1.0 + fabs(xi[0]) + fabs(xi[1]) + fabs(xi[2]));
        int arriving = (mode == SM_COLLIDE_STICKY && phihat < ctol);
        if ((mode == SM_COLLIDE_SEPARATE && phihat < ctol) || (mode == SM_COLLIDE_SLIP && phi0 <= 0.0) || arriving) {
            /* Beyond SM_MAX_NODE_CONTACTS the projection is still applied; only the record (and
             * so the friction of that contact) is dropped. */
            if (rec->count < SM_MAX_NODE_CONTACTS) {
                rec->body[rec->count] = b;
                rec->stick[rec->count] = arriving;
                for (int k = 0; k < 3; k++) rec->n[rec->count][k] = n[k];
                rec->count++;
            }
            const double depth = mode == SM_COLLIDE_SLIP ? phihat : SM_MIN(phihat, 0.0);
            for (int k = 0; k < dim; k++) v[k] -= depth * n[k] / dt;
            if (faster_than(v, dim, vcap2)) return 1;
        }
    }
    return 0;
}

void sm_friction_node(const sm_collider *cs, int dim, const double xi[3], const sm_node_contact *rec,
                     const double dv[3], double v[3]) {
    if (rec->sticky >= 0) return;
    double dvn = norm_n(dv, dim);
    for (int j = 0; j < rec->count; j++) {
        const sm_collider *c = &cs[rec->body[j]];
        double limit = rec->stick[j] ? INFINITY : c->def.friction * dvn;
        if (!(limit > 0.0)) continue;
        const double *n = rec->n[j];
        double vb[3], vr[3] = {0.0, 0.0, 0.0}, vt[3] = {0.0, 0.0, 0.0};
        sm_collider_velocity(c, dim, xi, vb);
        for (int k = 0; k < dim; k++) vr[k] = v[k] - vb[k];
        double vrn = dot3(n, vr);
        for (int k = 0; k < dim; k++) vt[k] = vr[k] - n[k] * vrn;
        double vtn = norm_n(vt, dim);
        if (!(vtn > 0.0)) continue;
        if (vtn <= limit) {
            for (int k = 0; k < dim; k++) v[k] -= vt[k]; /* stick (relative to the collider) */
        } else {
            double f = limit / vtn;
            for (int k = 0; k < dim; k++) v[k] -= f * vt[k];
        }
    }
}
