/* Mesh signed distance field benchmark (issue 15): build time and memory for ~100k-triangle
 * meshes (a sphere and a torus) at two spacings and 1 / all threads, and the cost of one query
 * (distance + unit gradient) against an analytic box (sm_shape_distance) and a rigid collider
 * made of a union of four analytic shapes (sm_collider_phi), on the same points near the surface.
 *
 *   mesh_bench [threads]      (default: OpenMP's default for the "all threads" rows) */
#include <stdio.h>
#include <stdlib.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "collide/collide.h"
#include "collide/mesh_sdf.h"
#include "core/timer.h"
#include "mesh_gen.h"

static unsigned long long rng = 99;

static double uniform(double lo, double hi) {
    rng += 0x9E3779B97F4A7C15ULL;
    unsigned long long z = rng;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    z ^= z >> 31;
    return lo + (hi - lo) * (double)(z >> 11) * (1.0 / 9007199254740992.0);
}

static sm_mesh_sdf *build(const test_mesh *m, double h, int threads) {
    sm_mesh_sdf_def d = sm_mesh_sdf_def_default();
    d.vertices = m->v;
    d.vertex_count = m->nv;
    d.elements = m->e;
    d.element_count = m->ne;
    d.spacing = h;
    d.band = 3 * h;
    d.threads = threads;
    sm_mesh_sdf *f = NULL;
    char err[256];
    if (sm_mesh_sdf_build(&d, &f, err, sizeof err) != SM_OK) {
        fprintf(stderr, "mesh_bench: %s\n", err);
        exit(1);
    }
    return f;
}

/* Points within 2 h of a sphere of radius R (the nodes a collider actually sees). */
static double *shell_points(size_t n, double R, double h) {
    double *p = malloc(3 * n * sizeof(double));
    for (size_t i = 0; i < n; i++) {
        double v[3], r2;
        do {
            for (int k = 0; k < 3; k++) v[k] = uniform(-1, 1);
            r2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
        } while (r2 > 1 || r2 < 1e-4);
        double s = (R + uniform(-2 * h, 2 * h)) / sqrt(r2);
        for (int k = 0; k < 3; k++) p[3 * i + k] = s * v[k];
    }
    return p;
}

/* Lattice points (spacing h/2, x fastest) within 2 h of the sphere: the order a grid visits nodes. */
static double *shell_lattice(size_t *n, double R, double h) {
    size_t cap = 1 << 20, k = 0;
    double *p = malloc(3 * cap * sizeof(double));
    const double s = 0.5 * h, lim = R + 2 * h;
    for (double z = -lim; z <= lim; z += s)
        for (double y = -lim; y <= lim; y += s)
            for (double x = -lim; x <= lim && k < cap; x += s) {
                double r = sqrt(x * x + y * y + z * z);
                if (fabs(r - R) > 2 * h) continue;
                p[3 * k] = x, p[3 * k + 1] = y, p[3 * k + 2] = z;
                k++;
            }
    *n = k;
    return p;
}

typedef double (*query_fn)(const void *obj, const double x[3], double g[3]);

static double q_mesh(const void *o, const double x[3], double g[3]) { return sm_mesh_sdf_distance(o, x, g); }
static double q_box(const void *o, const double x[3], double g[3]) { return sm_shape_distance(o, 3, x, g); }
static double q_collider(const void *o, const double x[3], double g[3]) { return sm_collider_phi(o, 3, 0, x, g); }

/* ns per query over n points, best of 5 passes; sink keeps the compiler honest. */
static double time_queries(query_fn q, const void *obj, const double *p, size_t n, double *sink) {
    double best = HUGE_VAL;
    for (int rep = 0; rep < 5; rep++) {
        double t0 = sm_seconds(), s = 0, g[3];
        for (size_t i = 0; i < n; i++) s += q(obj, p + 3 * i, g) + g[0];
        double t = sm_seconds() - t0;
        *sink += s;
        if (t < best) best = t;
    }
    return best / (double)n * 1e9;
}

static void report_build(const char *name, const test_mesh *m, double R, double h, int threads, double *sink) {
    sm_mesh_sdf *f = build(m, h, threads);
    const sm_mesh_sdf_stats *s = sm_mesh_sdf_stats_get(f);
    size_t nbytes = sm_mesh_sdf_serialize(f, NULL, 0);
    printf("| %s | %zu | %.4f (R/%.0f) | %d | %.3f | %zu | %zu | %.1f | %.1f | %.4f |\n", name, s->elements, h, R / h,
           threads, s->seconds, s->bricks, s->band_nodes, (double)s->bytes / 1e6, (double)nbytes / 1e6, s->lipschitz);
    double x[3] = {R, 0, 0}, g[3];
    *sink += sm_mesh_sdf_distance(f, x, g);
    sm_mesh_sdf_destroy(f);
}

static void query_costs(const test_mesh *sphere, double R, double h, double *sink) {
    const size_t n = 1000000;
    double *p = shell_points(n, R, h);
    sm_mesh_sdf *f = build(sphere, h, 0);
    sm_shape box = sm_shape_default(SM_SHAPE_BOX);
    box.half_extent[0] = box.half_extent[1] = box.half_extent[2] = R;
    sm_collider_def cd = sm_collider_def_default();
    cd.shape_count = 4;
    for (int k = 0; k < 4; k++) {
        cd.shapes[k] = sm_shape_default((sm_shape_kind)(k % 3 + 1));
        cd.shapes[k].center[k % 3] = 0.1 * k;
        cd.shapes[k].half_extent[0] = cd.shapes[k].half_extent[1] = cd.shapes[k].half_extent[2] = R * 0.8;
        cd.shapes[k].radius = R;
        cd.shapes[k].half_height = R;
        cd.shapes[k].rotation[0] = 0.9;
        cd.shapes[k].rotation[1 + k % 3] = 0.3; /* not unit: the shape normalises */
    }
    sm_collider c;
    sm_collider_init(&c, &cd);
    double t_mesh = time_queries(q_mesh, f, p, n, sink);
    double t_box = time_queries(q_box, &box, p, n, sink);
    double t_col = time_queries(q_collider, &c, p, n, sink);
    printf("\nquery cost (distance + unit gradient, 1 thread, %zu points within 2 h of the surface):\n", n);
    printf("  mesh field (%zu triangles, h = R/%.0f): %.1f ns\n", sphere->ne, R / h, t_mesh);
    printf("  analytic box (sm_shape_distance):     %.1f ns\n", t_box);
    printf("  collider, union of 4 rotated shapes:  %.1f ns\n", t_col);
    size_t nl;
    double *lat = shell_lattice(&nl, R, h);
    printf("in grid order (%zu lattice points, spacing h/2): mesh field %.1f ns, box %.1f ns, collider %.1f ns\n", nl,
           time_queries(q_mesh, f, lat, nl, sink), time_queries(q_box, &box, lat, nl, sink),
           time_queries(q_collider, &c, lat, nl, sink));
    free(lat);
    sm_mesh_sdf_destroy(f);
    free(p);
}

int main(int argc, char **argv) {
    int all = argc > 1 ? atoi(argv[1]) : 0;
#ifdef _OPENMP
    if (all <= 0) all = omp_get_max_threads();
#else
    all = 1;
#endif
    double sink = 0;
    const double c[3] = {0, 0, 0}, R = 0.5;
    test_mesh sphere = mesh_uv_sphere(c, R, 224, 224), torus = mesh_torus(R, 0.2, 250, 200);
    printf("| mesh | triangles | spacing h | threads | build s | bricks | band nodes | field MB | cache MB | "
           "Lipschitz bound |\n|---|---|---|---|---|---|---|---|---|---|\n");
    const double hs[2] = {R / 50, R / 100};
    for (int i = 0; i < 2; i++) {
        report_build("sphere", &sphere, R, hs[i], 1, &sink);
        if (all > 1) report_build("sphere", &sphere, R, hs[i], all, &sink);
        report_build("torus", &torus, R, hs[i], 1, &sink);
        if (all > 1) report_build("torus", &torus, R, hs[i], all, &sink);
    }
    query_costs(&sphere, R, R / 50, &sink);
    mesh_free(&sphere);
    mesh_free(&torus);
    return sink == 12345.678 ? 1 : 0;
}
