/* Mesh signed distance field, accuracy: the exact point-triangle distance and solid angle, the
 * BVH's queries against brute force, and the field of a sphere (also against the analytic
 * sphere), a torus, a bumpy (non-convex, star-shaped) sphere and an L-shaped prism (a concave
 * edge) against brute force: node values within 1e-3 h, interpolated values within the
 * interpolation error, signs, normals, and the Lipschitz bound the step's collider culling needs. */
#include <string.h>

#include "collide/bvh.h"
#include "collide/mesh_sdf_internal.h"
#include "mesh_brute.h"
#include "test_util.h"

static unsigned long long rng = 12345;

static void rand_in(const double lo[3], const double hi[3], int dim, double x[3]) {
    x[2] = 0;
    for (int k = 0; k < dim; k++) x[k] = sm_test_uniform(&rng, lo[k], hi[k]);
}

/* The closest point on a triangle against the projection-or-edges reference, on random and on
 * degenerate triangles; the closest point lies on the triangle and is at the returned distance. */
static void test_closest_point(void) {
    double worst = 0;
    for (int trial = 0; trial < 20000; trial++) {
        double v[3][3], p[3], q[3], bary[3];
        for (int i = 0; i < 3; i++)
            for (int k = 0; k < 3; k++) v[i][k] = sm_test_uniform(&rng, -1, 1);
        if (trial % 10 == 1) memcpy(v[2], v[1], sizeof v[1]); /* coincident vertices */
        if (trial % 10 == 2)
            for (int k = 0; k < 3; k++) v[2][k] = 0.3 * v[0][k] + 0.7 * v[1][k]; /* collinear */
        for (int k = 0; k < 3; k++) p[k] = sm_test_uniform(&rng, -2, 2);
        sm_simplex_region reg;
        double d = sqrt(sm_closest_on_triangle(p, v[0], v[1], v[2], q, bary, &reg));
        double ref = brute_tri_dist(p, v[0], v[1], v[2]);
        worst = fmax(worst, fabs(d - ref));
        CHECK_NEAR(d, ref, 1e-12);
        CHECK(bary[0] >= -1e-15 && bary[1] >= -1e-15 && bary[2] >= -1e-15);
        CHECK_NEAR(bary[0] + bary[1] + bary[2], 1.0, 1e-14);
        for (int k = 0; k < 3; k++) CHECK_NEAR(q[k], bary[0] * v[0][k] + bary[1] * v[1][k] + bary[2] * v[2][k], 1e-14);
        if (reg == SM_REGION_FACE) CHECK(bary[0] > 0 && bary[1] > 0 && bary[2] > 0);
        if (reg <= SM_REGION_V2) CHECK(bary[reg] == 1.0);
    }
    printf("closest point on triangle: worst |d - reference| = %.3g over 20000 pairs\n", worst);
}

static void test_angles(void) {
    const double o[3] = {0, 0, 0}, a[3] = {1, 0, 0}, b[3] = {0, 1, 0}, c[3] = {0, 0, 1};
    CHECK_NEAR(sm_solid_angle(o, a, b, c), SM_PI / 2, 1e-15); /* an octant */
    CHECK_NEAR(sm_solid_angle(o, a, c, b), -SM_PI / 2, 1e-15);
    const double p[3] = {0.5, 0.5, 0};
    CHECK_NEAR(sm_segment_angle(o, a, b), SM_PI / 2, 1e-15);
    CHECK_NEAR(sm_segment_angle(p, a, b), SM_PI, 1e-15); /* p on the segment, seen from its side */
    const double c0[3] = {0, 0, 0};
    test_mesh L = mesh_l_prism(c0, 1.0);
    const double in[3] = {0.5, 1.5, 0.5}, notch[3] = {1.5, 1.5, 0.5}, out[3] = {3, 0.5, 0.5};
    CHECK_NEAR(brute_winding(&L, in), 1.0, 1e-14);
    CHECK_NEAR(brute_winding(&L, notch), 0.0, 1e-14);
    CHECK_NEAR(brute_winding(&L, out), 0.0, 1e-14);
    mesh_free(&L);
}

/* The BVH's closest primitive is the brute-force minimum (same bits), with and without bound and
 * warm start; its hierarchical winding number is close to the exact one. */
static void test_bvh(void) {
    test_mesh m = mesh_bumpy_sphere(0.4, 0.25, 24, 40);
    sm_bvh t;
    CHECK(sm_bvh_build(&t, 3, m.v, m.nv, m.e, m.ne) == SM_OK);
    const double lo[3] = {-0.7, -0.7, -0.7}, hi[3] = {0.7, 0.7, 0.7};
    double worst_w = 0;
    long warm = -1;
    for (int i = 0; i < 3000; i++) {
        double p[3], q[3], bary[3];
        rand_in(lo, hi, 3, p);
        double best = HUGE_VAL;
        sm_simplex_region reg;
        for (size_t e = 0; e < m.ne; e++) {
            const uint32_t *v = m.e + 3 * e;
            best = fmin(best, sm_closest_on_triangle(p, m.v + 3 * v[0], m.v + 3 * v[1], m.v + 3 * v[2], q, bary, &reg));
        }
        sm_bvh_hit hit;
        sm_bvh_closest(&t, p, HUGE_VAL, warm, &hit);
        CHECK(hit.d2 == best && hit.slot >= 0);
        warm = hit.slot;
        sm_bvh_closest(&t, p, 0.01, -1, &hit); /* bound 0.1 */
        CHECK(best < 0.01 ? hit.d2 == best : hit.slot < 0);
        double w = sm_bvh_winding(&t, p), we = brute_winding(&m, p);
        worst_w = fmax(worst_w, fabs(w - we));
        if (sqrt(best) > 1e-3) CHECK((w >= 0.5) == (we >= 0.5));
    }
    printf("bvh: %zu nodes; hierarchical winding number: worst |w - exact| = %.3g (beta = %.1f)\n", t.nnodes, worst_w,
           t.beta);
    CHECK(worst_w < 0.05);
    sm_bvh_free(&t);
    mesh_free(&m);
}

static sm_mesh_sdf *build(const test_mesh *m, double h, double band, sm_mesh_sign sign, int threads) {
    sm_mesh_sdf *f = mesh_field_build(m, h, band, sign, threads);
    CHECK(f != NULL);
    return f;
}

static double clampb(double d, double b) { return d < -b ? -b : d > b ? b : d; }

/* Every k-th stored node against brute force: |phi_i - clamp(s d)| <= 1e-3 h (float storage is
 * ~1e-7 h); the sign is the brute-force winding number's wherever |d| > 1e-6 h. */
static void check_nodes(const sm_mesh_sdf *f, const test_mesh *m, size_t samples, double *worst) {
    const size_t total = f->nbricks * f->brick_nodes;
    const size_t stride = total / samples + 1;
    const int nz = f->dim == 3 ? SM_SDF_BN : 1;
    for (size_t n = stride / 2; n < total; n += stride) {
        size_t b = n / f->brick_nodes, l = n % f->brick_nodes;
        size_t pos = 0; /* the table position of brick b */
        while (f->table[pos] != (int32_t)b) pos++;
        size_t bc[3] = {pos % (size_t)f->nb[0], pos / (size_t)f->nb[0] % (size_t)f->nb[1],
                        pos / ((size_t)f->nb[0] * (size_t)f->nb[1])};
        size_t lc[3] = {l % SM_SDF_BN, l / SM_SDF_BN % SM_SDF_BN, l / (SM_SDF_BN * SM_SDF_BN)};
        CHECK((int)lc[2] < nz);
        double x[3] = {0, 0, 0};
        for (int k = 0; k < f->dim; k++) x[k] = f->origin[k] + (double)(bc[k] * SM_SDF_BRICK + lc[k]) * f->h;
        double d = brute_sdf(m, x), ref = clampb(d, (double)(float)f->band);
        double v = (double)f->bricks[n];
        *worst = fmax(*worst, fabs(v - ref) / f->h);
        CHECK(fabs(v - ref) <= 1e-3 * f->h);
        if (fabs(d) > 1e-6 * f->h) CHECK((v < 0) == (d < 0));
    }
}

typedef struct field_case {
    const char *name;
    test_mesh m;
    double h, band;
    double interp_bound; /* bound on |phi_h - d| at points in the band, m (see each case) */
    double sphere_r;     /* > 0: also compare with the analytic sphere of this radius about 0 */
    double sphere_delta; /* its tessellation gap: 0 <= d_mesh - d_sphere <= delta */
} field_case;

/* Random points in the band: interpolation error, sign, and (sphere) the analytic distance and
 * normal; random pairs: |phi(x) - phi(y)| <= |x - y| + 2 interp_bound. */
static void check_points(const sm_mesh_sdf *f, const field_case *c) {
    double lo[3], hi[3], worst = 0, worst_an = 0, worst_deg = 0, worst_lip = 0;
    for (int k = 0; k < 3; k++) {
        lo[k] = f->origin[k];
        hi[k] = f->origin[k] + f->ncells[k] * f->h;
    }
    int in_band = 0;
    for (int i = 0; i < 1500 && in_band < 300; i++) {
        double x[3], g[3];
        rand_in(lo, hi, 3, x);
        double d = brute_sdf(&c->m, x), phi = sm_mesh_sdf_distance(f, x, g);
        if (fabs(d) > sqrt(3.0) * f->h) CHECK((phi < 0) == (d < 0)); /* all 8 corners share d's sign */
        CHECK(fabs(phi) <= (double)(float)f->band);
        if (fabs(d) > f->band + sqrt(3.0) * f->h) CHECK(fabs(phi) == (double)(float)f->band);
        /* Where a cell corner may be clamped, the interpolant is below |d|: the accurate band is
         * |d| < band - sqrt(3) h (a cell diagonal inside the stored band). */
        if (fabs(d) >= f->band - sqrt(3.0) * f->h) continue;
        in_band++;
        worst = fmax(worst, fabs(phi - d));
        CHECK(fabs(phi - d) <= c->interp_bound);
        if (c->sphere_r > 0) {
            double r = sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
            worst_an = fmax(worst_an, fabs(phi - (r - c->sphere_r)));
            CHECK(fabs(phi - (r - c->sphere_r)) <= c->interp_bound - c->sphere_delta);
            if (fabs(d) < f->h) {
                double cosang = (g[0] * x[0] + g[1] * x[1] + g[2] * x[2]) / r;
                worst_deg = fmax(worst_deg, acos(fmin(1.0, cosang)) * 180 / SM_PI);
            }
        }
        for (int j = 0; j < 4; j++) {
            double y[3], r2 = 0;
            for (int k = 0; k < 3; k++) {
                y[k] = x[k] + sm_test_uniform(&rng, -2 * f->h, 2 * f->h);
                r2 += (y[k] - x[k]) * (y[k] - x[k]);
            }
            double dphi = fabs(sm_mesh_sdf_distance(f, y, NULL) - phi);
            worst_lip = fmax(worst_lip, dphi / sqrt(r2));
            CHECK(dphi <= sqrt(r2) + 2 * c->interp_bound);
        }
    }
    CHECK(in_band >= 100);
    printf("  %d points in the band: worst |phi - d| = %.4f h (bound %.4f h)", in_band, worst / f->h,
           c->interp_bound / f->h);
    if (c->sphere_r > 0) printf(", vs the analytic sphere %.4f h, normal within %.2f deg", worst_an / f->h, worst_deg);
    printf("; pairs: worst |dphi|/|dx| = %.4f\n", worst_lip);
    if (c->sphere_r > 0) CHECK(worst_deg < 3.0);
}

static void check_case(field_case *c) {
    sm_mesh_sdf *f = build(&c->m, c->h, c->band, SM_MESH_SIGN_WINDING, 0);
    if (!f) return;
    const sm_mesh_sdf_stats *s = sm_mesh_sdf_stats_get(f);
    printf("%s: %zu triangles, h = %g, band = %g: %zu of %zu candidate bricks, %zu band nodes, %.2f MB, %.3f s, "
           "Lipschitz bound %.4f\n",
           c->name, s->elements, c->h, c->band, s->bricks, s->candidate_bricks, s->band_nodes, s->bytes / 1e6,
           s->seconds, s->lipschitz);
    double worst = 0;
    check_nodes(f, &c->m, 1500, &worst);
    printf("  nodes: worst |phi_i - brute force| = %.2g h\n", worst);
    check_points(f, c);
    CHECK(s->band_nodes > 0 && s->bricks <= s->candidate_bricks && !s->container && s->volume > 0);
    sm_mesh_sdf_destroy(f);
    mesh_free(&c->m);
}

/* The uv sphere's faces are at least r cos(pi/nlat) cos(pi/nlon)... from the centre: compute the
 * smallest distance from the centre to a face exactly instead. */
static double inner_radius(const test_mesh *m) {
    const double o[3] = {0, 0, 0};
    double r = HUGE_VAL;
    for (size_t t = 0; t < m->ne; t++) {
        const uint32_t *e = m->e + 3 * t;
        r = fmin(r, brute_tri_dist(o, m->v + 3 * e[0], m->v + 3 * e[1], m->v + 3 * e[2]));
    }
    return r;
}

static void test_fields(void) {
    const double o[3] = {0, 0, 0}, lc[3] = {-0.23, -0.27, -0.11};
    const double h = 0.02, band = 3 * h;
    /* Sphere: 0 <= d_mesh - d_sphere <= delta (the mesh lies between the balls of radius R - delta
     * and R); trilinear interpolation of d_sphere errs by at most (h^2/8) sum_k max |d_kk| with
     * |d_kk| <= 1/|x| and |x| >= R - band - sqrt(3) h in a band cell; so |phi_h - d_mesh| <=
     * 2 delta + 3 h^2 / (8 (R - band - sqrt(3) h)) (+ float storage). */
    const double R = 0.37;
    field_case sph = {"sphere", mesh_uv_sphere(o, R, 48, 96), h, band, 0, R, 0};
    sph.sphere_delta = R - inner_radius(&sph.m);
    sph.interp_bound = 2 * sph.sphere_delta + 3 * h * h / (8 * (R - band - sqrt(3.0) * h)) + 1e-6 * h;
    check_case(&sph);
    /* Torus, bumpy sphere, L prism: kinks of the polyhedral distance (bisector planes of convex
     * edges inside, the concave edge outside) limit what interpolation can do; the rigorous bound
     * for any 1-Lipschitz function is sum_c w_c |x_c - x| <= sqrt(3) h / 2. The node test above
     * is the strict one; the measured errors are printed. */
    const double generic = sqrt(3.0) * h / 2;
    field_case tor = {"torus", mesh_torus(0.3, 0.12, 96, 48), h, band, generic, 0, 0};
    check_case(&tor);
    field_case bump = {"bumpy sphere", mesh_bumpy_sphere(0.4, 0.2, 48, 96), h, band, generic, 0, 0};
    check_case(&bump);
    field_case L = {"L prism", mesh_l_prism(lc, 0.25), h, band, generic, 0, 0};
    check_case(&L);
}

int main(void) {
    test_closest_point();
    test_angles();
    test_bvh();
    test_fields();
    return sm_test_summary("test_mesh_sdf");
}
