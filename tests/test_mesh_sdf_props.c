/* Mesh signed distance field, properties: the same bytes for 1, 2 and 3 threads; serialisation
 * round trip and rejection of damaged bytes; inside-out meshes as containers; the one-sided rule
 * (equal to the winding rule on a closed mesh, a half-space-like side on an open sheet); a sphere
 * with a hole and two overlapping spheres under the winding rule; 2D outlines; the clamped value
 * and fallback normal far from the surface; invalid definitions. */
#include <string.h>

#include "collide/mesh_sdf_internal.h"
#include "mesh_brute.h"
#include "test_util.h"

static unsigned long long rng = 777;

static sm_mesh_sdf *build(const test_mesh *m, double h, double band, sm_mesh_sign sign, int threads) {
    sm_mesh_sdf *f = mesh_field_build(m, h, band, sign, threads);
    CHECK(f != NULL);
    return f;
}

static unsigned char *bytes_of(const sm_mesh_sdf *f, size_t *n) {
    *n = sm_mesh_sdf_serialize(f, NULL, 0);
    unsigned char *b = malloc(*n);
    CHECK(b && sm_mesh_sdf_serialize(f, b, *n) == *n);
    return b;
}

static void random_point(int dim, double span, double x[3]) {
    x[2] = 0;
    for (int k = 0; k < dim; k++) x[k] = sm_test_uniform(&rng, -span, span);
}

/* 1, 2 and 3 threads give the same bytes; a round trip through bytes gives the same values. */
static void test_determinism_and_bytes(const test_mesh *m, sm_mesh_sign sign, const char *name) {
    sm_mesh_sdf *f[3];
    unsigned char *b[3];
    size_t n[3];
    for (int t = 0; t < 3; t++) {
        f[t] = build(m, 0.03, 0.09, sign, t + 1);
        if (!f[t]) return;
        b[t] = bytes_of(f[t], &n[t]);
    }
    CHECK(n[0] == n[1] && n[0] == n[2]);
    CHECK(!memcmp(b[0], b[1], n[0]) && !memcmp(b[0], b[2], n[0]));
    sm_mesh_sdf *g = NULL;
    char err[256] = "";
    CHECK(sm_mesh_sdf_deserialize(b[0], n[0], &g, err, sizeof err) == SM_OK && g);
    int same = 1;
    for (int i = 0; i < 2000 && g; i++) {
        double x[3], g0[3], g1[3];
        random_point(m->dim, 0.8, x);
        double a = sm_mesh_sdf_distance(f[0], x, g0), c = sm_mesh_sdf_distance(g, x, g1);
        same &= a == c && !memcmp(g0, g1, sizeof g0);
    }
    CHECK(same);
    CHECK(g && sm_mesh_sdf_stats_get(g)->bricks == sm_mesh_sdf_stats_get(f[0])->bricks);
    CHECK(g && sm_mesh_sdf_bytes(g) == sm_mesh_sdf_bytes(f[0]));
    printf("%s: %zu bytes serialised, identical for 1, 2, 3 threads; round trip exact\n", name, n[0]);
    /* Damaged bytes are refused with a reason. */
    unsigned char *bad = malloc(n[0]);
    memcpy(bad, b[0], n[0]);
    bad[n[0] / 2] ^= 1;
    sm_mesh_sdf *h = NULL;
    CHECK(sm_mesh_sdf_deserialize(bad, n[0], &h, err, sizeof err) == SM_ERR_INVALID && !h);
    CHECK(strstr(err, "checksum") != NULL);
    CHECK(sm_mesh_sdf_deserialize(b[0], n[0] - 4, &h, err, sizeof err) == SM_ERR_INVALID && strstr(err, "size"));
    CHECK(sm_mesh_sdf_deserialize(b[0], 20, &h, err, sizeof err) == SM_ERR_INVALID && strstr(err, "truncated"));
    memcpy(bad, b[0], n[0]);
    bad[0] = 'X';
    CHECK(sm_mesh_sdf_deserialize(bad, n[0], &h, err, sizeof err) == SM_ERR_INVALID && strstr(err, "magic"));
    free(bad);
    sm_mesh_sdf_destroy(g);
    for (int t = 0; t < 3; t++) {
        sm_mesh_sdf_destroy(f[t]);
        free(b[t]);
    }
}

/* Flipped orientation: a container, phi_flipped = -phi (up to rounding of the reordered
 * vertices), the far value is -band, and the far normal points back towards the mesh. */
static void test_container(void) {
    const double c[3] = {0, 0, 0};
    test_mesh m = mesh_uv_sphere(c, 0.3, 16, 32), mf = mesh_uv_sphere(c, 0.3, 16, 32);
    mesh_flip(&mf);
    sm_mesh_sdf *f = build(&m, 0.03, 0.09, SM_MESH_SIGN_WINDING, 0);
    sm_mesh_sdf *g = build(&mf, 0.03, 0.09, SM_MESH_SIGN_WINDING, 0);
    if (!f || !g) return;
    CHECK(!sm_mesh_sdf_stats_get(f)->container && sm_mesh_sdf_stats_get(g)->container);
    CHECK(sm_mesh_sdf_stats_get(g)->volume < 0);
    double worst = 0;
    for (int i = 0; i < 3000; i++) {
        double x[3];
        random_point(3, 0.7, x);
        worst = fmax(worst, fabs(sm_mesh_sdf_distance(f, x, NULL) + sm_mesh_sdf_distance(g, x, NULL)));
    }
    CHECK(worst <= 1e-6 * 0.03);
    const double far[3] = {5, 0, 0};
    double gr[3];
    CHECK(sm_mesh_sdf_distance(g, far, gr) == -(double)(float)0.09);
    CHECK(gr[0] == -1.0 && gr[1] == 0.0 && gr[2] == 0.0);
    CHECK(sm_mesh_sdf_distance(f, far, gr) == (double)(float)0.09 && gr[0] == 1.0);
    printf("container: |phi_flipped + phi| <= %.2g\n", worst);
    sm_mesh_sdf_destroy(f);
    sm_mesh_sdf_destroy(g);
    mesh_free(&m);
    mesh_free(&mf);
}

static int phi_in_table(const sm_mesh_sdf *f, const double x[3]) {
    for (int k = 0; k < f->dim; k++)
        if (!(x[k] >= f->origin[k] && x[k] < f->origin[k] + f->ncells[k] * f->h)) return 0;
    return 1;
}

/* Values beyond the band: clamped with the right sign; the fallback normal (from the coarse
 * field) points away from the surface. */
static void test_far_field(void) {
    const double c[3] = {0, 0, 0};
    const double R = 0.5, h = 0.02, band = 0.04;
    test_mesh m = mesh_uv_sphere(c, R, 24, 48);
    sm_mesh_sdf *f = build(&m, h, band, SM_MESH_SIGN_WINDING, 0);
    if (!f) return;
    double worst_cos = 1;
    int n = 0;
    for (int i = 0; i < 4000; i++) {
        double x[3], g[3];
        random_point(3, 0.75, x);
        double r = sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
        /* beyond a cell diagonal outside the band; not within 1.5 coarse cells (8 h) of the centre,
         * where the distance has its cone point */
        if (fabs(r - R) < band + sqrt(3.0) * h || r < 12 * h) continue;
        double phi = sm_mesh_sdf_distance(f, x, g);
        CHECK(phi == (r > R ? 1 : -1) * (double)(float)band);
        if (!phi_in_table(f, x)) { /* beyond the table: away from the table's box */
            double a = 0;
            for (int k = 0; k < 3; k++) a += g[k] * (x[k] - (f->origin[k] + 0.5 * f->ncells[k] * f->h));
            CHECK(a > 0);
            continue;
        }
        double cosang = (g[0] * x[0] + g[1] * x[1] + g[2] * x[2]) / r;
        worst_cos = fmin(worst_cos, cosang);
        CHECK(cosang > 0.9); /* within about 25 degrees of the radial direction */
        n++;
    }
    printf("far field: %d points clamped with the right sign; fallback normal within %.1f deg of radial\n", n,
           acos(worst_cos) * 180 / SM_PI);
    sm_mesh_sdf_destroy(f);
    mesh_free(&m);
}

/* On a closed manifold mesh the pseudo-normal rule and the winding rule give the same signs. */
static void test_one_sided_closed(void) {
    const double c[3] = {0.05, -0.02, 0.01};
    test_mesh L = mesh_l_prism(c, 0.2);
    sm_mesh_sdf *f = build(&L, 0.02, 0.06, SM_MESH_SIGN_WINDING, 0);
    sm_mesh_sdf *g = build(&L, 0.02, 0.06, SM_MESH_SIGN_ONE_SIDED, 0);
    if (!f || !g) return;
    CHECK(f->nbricks == g->nbricks);
    size_t differ = 0, on_surface = 0; /* nodes on a face (|d| ~ 1e-17) may take either sign */
    for (size_t i = 0; i < f->nbricks * f->brick_nodes; i++) {
        int tiny = fabsf(f->bricks[i]) < 1e-12f;
        on_surface += tiny;
        differ += !tiny && f->bricks[i] != g->bricks[i];
    }
    CHECK(differ == 0 && on_surface > 0);
    CHECK(!memcmp(f->table, g->table, sm_sdf_table_size(f) * sizeof(int32_t)));
    printf("one-sided rule on a closed prism: %zu of %zu node values differ from the winding rule (%zu nodes on "
           "the surface)\n", differ, f->nbricks * f->brick_nodes, on_surface);
    sm_mesh_sdf_destroy(f);
    sm_mesh_sdf_destroy(g);
    mesh_free(&L);
}

/* An open square sheet z = 0 over [-0.3, 0.3]^2, normal +z: solid below, free above. */
static void test_one_sided_sheet(void) {
    test_mesh s = {3, 4, 2, calloc(12, sizeof(double)), calloc(6, sizeof(uint32_t))};
    const double xy[4][2] = {{-0.3, -0.3}, {0.3, -0.3}, {0.3, 0.3}, {-0.3, 0.3}};
    for (int i = 0; i < 4; i++) s.v[3 * i] = xy[i][0], s.v[3 * i + 1] = xy[i][1];
    const uint32_t tri[6] = {0, 1, 2, 0, 2, 3};
    memcpy(s.e, tri, sizeof tri);
    sm_mesh_sdf *f = build(&s, 0.02, 0.06, SM_MESH_SIGN_ONE_SIDED, 0);
    if (!f) return;
    double worst = 0;
    for (int i = 0; i < 2000; i++) {
        double x[3] = {sm_test_uniform(&rng, -0.25, 0.25), sm_test_uniform(&rng, -0.25, 0.25),
                       sm_test_uniform(&rng, -0.03, 0.03)};
        double g[3], phi = sm_mesh_sdf_distance(f, x, g);
        worst = fmax(worst, fabs(phi - x[2]));
        CHECK(fabs(g[2] - 1.0) < 1e-6);
    }
    CHECK(worst < 1e-6);
    printf("one-sided sheet: phi = z over the sheet within %.2g\n", worst);
    sm_mesh_sdf_destroy(f);
    mesh_free(&s);
}

/* Winding rule: a sphere missing a few triangles keeps its inside; two overlapping spheres are
 * their union (points inside both, near the hidden inner surfaces, are inside). */
static void test_hole_and_overlap(void) {
    const double c0[3] = {0, 0, 0}, c1[3] = {0.25, 0, 0};
    test_mesh m = mesh_uv_sphere(c0, 0.3, 24, 48);
    m.ne -= 3; /* the last three triangles of the last ring: a small hole near the south pole */
    sm_mesh_sdf *f = build(&m, 0.02, 0.06, SM_MESH_SIGN_WINDING, 0);
    test_mesh u = mesh_uv_sphere(c0, 0.3, 24, 48), b = mesh_uv_sphere(c1, 0.3, 24, 48);
    mesh_append(&u, &b);
    sm_mesh_sdf *g = build(&u, 0.02, 0.06, SM_MESH_SIGN_WINDING, 0);
    if (!f || !g) return;
    int wrong_hole = 0, wrong_union = 0;
    for (int i = 0; i < 3000; i++) {
        double x[3];
        random_point(3, 0.6, x);
        double r0 = sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
        double r1 = sqrt((x[0] - 0.25) * (x[0] - 0.25) + x[1] * x[1] + x[2] * x[2]);
        if (fabs(r0 - 0.3) > 0.03 && x[2] > -0.2) wrong_hole += (sm_mesh_sdf_distance(f, x, NULL) < 0) != (r0 < 0.3);
        double du = fmin(r0, r1) - 0.3; /* the union's sign */
        if (fabs(r0 - 0.3) > 0.03 && fabs(r1 - 0.3) > 0.03) wrong_union += (sm_mesh_sdf_distance(g, x, NULL) < 0) != (du < 0);
    }
    CHECK(wrong_hole == 0);
    CHECK(wrong_union == 0);
    const double mid[3] = {0.125, 0, 0}, near_inner[3] = {0.27, 0.0, 0.05}; /* inside both */
    CHECK(sm_mesh_sdf_distance(g, mid, NULL) < 0 && sm_mesh_sdf_distance(g, near_inner, NULL) < 0);
    printf("winding rule: sphere with a hole and overlapping spheres: %d + %d wrong signs\n", wrong_hole, wrong_union);
    sm_mesh_sdf_destroy(f);
    sm_mesh_sdf_destroy(g);
    mesh_free(&m);
    mesh_free(&u);
    mesh_free(&b);
}

/* 2D outlines: nodes against brute force, the circle against the analytic disk, an L outline,
 * a clockwise outline as a container. */
static void test_2d(void) {
    const double c[2] = {0.01, -0.02}, h = 0.01, band = 0.03;
    test_mesh circ = outline_circle(c, 0.3, 256), L = outline_l(c, 0.2);
    const test_mesh *ms[2] = {&circ, &L};
    for (int k = 0; k < 2; k++) {
        sm_mesh_sdf *f = build(ms[k], h, band, SM_MESH_SIGN_WINDING, 0);
        if (!f) return;
        double worst_node = 0, worst_pt = 0;
        for (size_t i = 0; i < f->nbricks * f->brick_nodes; i += 7) {
            size_t b = i / f->brick_nodes, l = i % f->brick_nodes, pos = 0;
            while (f->table[pos] != (int32_t)b) pos++;
            double x[3] = {f->origin[0] + (double)((pos % (size_t)f->nb[0]) * SM_SDF_BRICK + l % SM_SDF_BN) * h,
                           f->origin[1] + (double)((pos / (size_t)f->nb[0]) * SM_SDF_BRICK + l / SM_SDF_BN) * h, 0};
            double d = brute_sdf(ms[k], x), ref = fmax(-(double)(float)band, fmin((double)(float)band, d));
            worst_node = fmax(worst_node, fabs((double)f->bricks[i] - ref));
        }
        CHECK(worst_node <= 1e-3 * h);
        for (int i = 0; i < 2000 && k == 0; i++) { /* disk: interpolation error (h^2/8) 2 / r */
            double x[3];
            random_point(2, 0.4, x);
            double r = hypot(x[0] - c[0], x[1] - c[1]);
            if (fabs(r - 0.3) > band - sqrt(2.0) * h) continue;
            worst_pt = fmax(worst_pt, fabs(sm_mesh_sdf_distance(f, x, NULL) - (r - 0.3)));
        }
        double sag = 0.3 * (1 - cos(SM_PI / 256));
        if (k == 0) CHECK(worst_pt <= 2 * sag + h * h / (4 * (0.3 - band - h)) + 1e-6 * h);
        printf("2D %s: %zu bricks, nodes within %.2g h%s", k ? "L outline" : "circle", f->nbricks, worst_node / h,
               k ? "\n" : "");
        if (!k) printf(", points within %.4f h of the analytic circle\n", worst_pt / h);
        sm_mesh_sdf_destroy(f);
    }
    mesh_flip(&L);
    sm_mesh_sdf *g = build(&L, h, band, SM_MESH_SIGN_WINDING, 0);
    const double inside[3] = {c[0] + 0.1, c[1] + 0.1, 0}, outside[3] = {c[0] + 0.7, c[1], 0};
    CHECK(g && sm_mesh_sdf_stats_get(g)->container);
    CHECK(g && sm_mesh_sdf_distance(g, inside, NULL) > 0 && sm_mesh_sdf_distance(g, outside, NULL) < 0);
    sm_mesh_sdf_destroy(g);
    mesh_free(&circ);
    mesh_free(&L);
}

static void expect_invalid(const sm_mesh_sdf_def *d, const char *what) {
    sm_mesh_sdf *f = (sm_mesh_sdf *)1;
    char err[256] = "";
    CHECK(sm_mesh_sdf_build(d, &f, err, sizeof err) == SM_ERR_INVALID && f == NULL);
    CHECK(strstr(err, what) != NULL);
    if (!strstr(err, what)) fprintf(stderr, "expected '%s' in '%s'\n", what, err);
}

static void test_invalid(void) {
    const double c[3] = {0, 0, 0};
    test_mesh m = mesh_l_prism(c, 1.0);
    sm_mesh_sdf_def d = mesh_field_def(&m, 0.1, 0.3, SM_MESH_SIGN_WINDING, 0);
    d.spacing = 0;
    expect_invalid(&d, "spacing");
    d.spacing = 0.1, d.band = 0.05;
    expect_invalid(&d, "band");
    d.band = 0.3, d.element_count = 0;
    expect_invalid(&d, "no elements");
    d.element_count = m.ne, m.e[7] = 99;
    expect_invalid(&d, "element 2 uses vertex 99");
    m.e[7] = 1, m.v[4] = NAN;
    expect_invalid(&d, "not finite");
    m.v[4] = 0, d.spacing = 1e-5, d.band = 3e-5;
    expect_invalid(&d, "too many bricks");
    d.spacing = 0.1, d.dim = 4;
    expect_invalid(&d, "dim");
    mesh_free(&m);
}

int main(void) {
    const double c[3] = {0.013, -0.021, 0.007};
    test_mesh t = mesh_torus(0.35, 0.12, 48, 24), s = outline_circle(c, 0.4, 100);
    test_determinism_and_bytes(&t, SM_MESH_SIGN_WINDING, "torus, winding");
    test_determinism_and_bytes(&t, SM_MESH_SIGN_ONE_SIDED, "torus, one-sided");
    test_determinism_and_bytes(&s, SM_MESH_SIGN_WINDING, "2D circle");
    mesh_free(&t);
    mesh_free(&s);
    test_container();
    test_far_field();
    test_one_sided_closed();
    test_one_sided_sheet();
    test_hole_and_overlap();
    test_2d();
    test_invalid();
    return sm_test_summary("test_mesh_sdf_props");
}
