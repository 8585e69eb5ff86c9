/* Collider cost per grid node (issue 15 item 6): the grid update stage (SM_STAGE_GRID: velocity
 * update, colliders, friction, domain walls) of a sand bed with one sticky collider half buried
 * in it -- none, an analytic box, an analytic sphere, a 12-triangle mesh box and a ~100k-triangle
 * mesh sphere of the same size (field spacing dx, band 6 dx) -- as seconds per live grid node
 * per step, and the collider's share (minus the run without one); each figure is the minimum of
 * REPEATS runs. Also the field build time of the 100k-triangle sphere at 1 and 2 threads.
 *
 *   collide_bench [threads] [steps]      (default 1 thread, 20 steps of 1e-4 s) */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/timer.h"
#include "mesh_gen.h"
#include "sandmpm/sandmpm.h"
#include "world/world.h"

#define DX 0.01
#define R 0.15
#define REPEATS 3 /* the minimum of 3 runs: the machine is shared */

enum { NONE, BOX, SPHERE, MESH_BOX, MESH_SPHERE, NKINDS };
static const char *const NAMES[NKINDS] = {"none", "analytic box", "analytic sphere", "mesh box (12 triangles)",
                                          "mesh sphere"};

static sm_mesh_field *field(const test_mesh *m, int threads, double *seconds) {
    sm_mesh_field_def d = sm_mesh_field_def_default();
    d.vertices = m->v, d.vertex_count = m->nv, d.elements = m->e, d.element_count = m->ne;
    d.spacing = DX, d.band = 6 * DX, d.threads = threads;
    sm_mesh_field *f = NULL;
    char err[256];
    const double t0 = sm_seconds();
    if (sm_mesh_field_create(&d, &f, err, sizeof err) != SM_OK) {
        fprintf(stderr, "field: %s\n", err);
        exit(1);
    }
    if (seconds) *seconds = sm_seconds() - t0;
    return f;
}

static test_mesh box_mesh(double he) {
    test_mesh m;
    m.dim = 3, m.nv = 8, m.ne = 12;
    m.v = malloc(24 * sizeof(double));
    m.e = malloc(36 * sizeof(uint32_t));
    for (int i = 0; i < 8; i++)
        for (int a = 0; a < 3; a++) m.v[3 * i + a] = ((i >> a) & 1) ? he : -he;
    static const uint32_t tri[36] = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
                                     2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5};
    memcpy(m.e, tri, sizeof tri);
    return m;
}

/* Grid-stage seconds per live node per step of the bed with collider kind k. */
static double run(int k, const sm_mesh_field *mbox, const sm_mesh_field *msph, int threads, int steps, size_t *nodes) {
    sm_world_def def = sm_world_def_default();
    def.dx = DX;
    def.threads = threads;
    sm_world *w = NULL;
    char err[256];
    if (sm_world_create(&def, &w, err, sizeof err) != SM_OK) exit(1);
    sm_material_def mat = sm_material_def_sand();
    int id = -1;
    sm_world_add_material(w, &mat, &id);
    sm_shape bed = sm_shape_default(SM_SHAPE_BOX);
    bed.center[0] = bed.center[2] = 0.5, bed.center[1] = 0.16;
    bed.half_extent[0] = bed.half_extent[2] = 0.25, bed.half_extent[1] = 0.1;
    sm_seed_def sd = sm_seed_def_default();
    sd.material = id;
    sd.ppc = 4;
    sm_world_seed_shape(w, &bed, &sd, NULL);
    if (k != NONE) {
        sm_collider_def c = sm_collider_def_default();
        c.shape_count = 1;
        sm_shape *s = &c.shapes[0];
        *s = sm_shape_default(k == BOX ? SM_SHAPE_BOX : k == SPHERE ? SM_SHAPE_SPHERE : SM_SHAPE_MESH);
        s->half_extent[0] = s->half_extent[1] = s->half_extent[2] = R;
        s->radius = R;
        s->mesh = k == MESH_BOX ? mbox : k == MESH_SPHERE ? msph : NULL;
        s->center[0] = s->center[2] = 0.5, s->center[1] = 0.26 + 0.5 * R; /* half buried */
        c.mode = SM_COLLIDE_STICKY;
        c.velocity[0] = 0.2;
        if (sm_world_add_collider(w, &c, NULL) != SM_OK) {
            fprintf(stderr, "collider: %s\n", sm_world_errmsg(w));
            exit(1);
        }
    }
    sm_world_step(w, 1e-4); /* warm-up: storage grown */
    sm_diagnostics d0, d1;
    sm_world_diagnostics(w, &d0);
    *nodes = 0;
    for (int i = 0; i < steps; i++) {
        sm_world_step(w, 1e-4);
        *nodes += w->grid.nactive * (size_t)w->grid.block_nodes;
    }
    sm_world_diagnostics(w, &d1);
    sm_world_destroy(w);
    return (d1.stage_seconds[SM_STAGE_GRID] - d0.stage_seconds[SM_STAGE_GRID]) / (double)*nodes;
}

int main(int argc, char **argv) {
    const int threads = argc > 1 ? atoi(argv[1]) : 1, steps = argc > 2 ? atoi(argv[2]) : 20;
    const double c[3] = {0, 0, 0};
    test_mesh sph = mesh_uv_sphere(c, R, 224, 224), bx = box_mesh(R);
    double t1 = INFINITY, t2 = INFINITY;
    for (int rep = 0; rep < REPEATS; rep++) {
        double a, b;
        sm_mesh_field_release(field(&sph, 1, &a));
        sm_mesh_field_release(field(&sph, 2, &b));
        t1 = fmin(t1, a), t2 = fmin(t2, b);
    }
    sm_mesh_field *msph = field(&sph, 0, NULL);
    sm_mesh_field *mbox = field(&bx, 1, NULL);
    const sm_mesh_field_stats *st = sm_mesh_field_get_stats(msph);
    printf("mesh sphere R = %g m: %zu triangles, spacing %g m, band %g m: %zu bricks, %.2f MB; field build %.3f s "
           "(1 thread), %.3f s (2 threads) (minimum of %d)\n",
           R, st->elements, st->spacing, st->band, st->bricks, st->bytes / 1e6, t1, t2, REPEATS);
    printf("grid stage, %d thread(s), %d steps of 1e-4 s, dx = %g m, a 0.5 x 0.2 x 0.5 m bed (ppc 4), sticky collider "
           "moving at 0.2 m/s, half buried\n",
           threads, steps, DX);
    double ns[NKINDS];
    for (int k = 0; k < NKINDS; k++) {
        size_t nodes = 0;
        ns[k] = INFINITY;
        for (int rep = 0; rep < REPEATS; rep++) ns[k] = fmin(ns[k], 1e9 * run(k, mbox, msph, threads, steps, &nodes));
        printf("  %-26s %7.2f ns per node per step (%zu node-steps)", NAMES[k], ns[k], nodes);
        if (k != NONE) printf(", collider %+7.2f ns", ns[k] - ns[NONE]);
        printf("\n");
    }
    sm_mesh_field_release(msph);
    sm_mesh_field_release(mbox);
    mesh_free(&sph);
    mesh_free(&bx);
    return 0;
}
