/* Mesh colliders and mesh-shaped sand (issue 15) through the public API:
 * (1) a mesh shape (sm_shape with SM_SHAPE_MESH, placed by centre and rotation) gives the
 *     analytic box's signed distance within the field's interpolation error and the same sign;
 *     the handle's checks (no field, wrong dimension) and references;
 * (2) seeding a mesh box gives the analytic box's particles (count within 1%);
 * (3) a sticky mesh plate moving at 0.5 m/s (constant velocity, and the same by a motion
 *     function) pushes a sand block: the sand in front of it moves at the plate's velocity within 5%;
 * (4) a sand block resting in the mesh bowl of scenes/meshes/bowl.obj (3 cm wall, dx = 1 cm) for
 *     2 s loses no particle through the wall, for every collider mode: every particle ends in the
 *     bowl's cavity (closer to the centre of its spheres than the inner radius + dx/2, never
 *     inside the wall by more than dx/4);
 * (5) the same state hash with 1, 2 and 3 threads; a checkpoint restores into a world with the
 *     mesh collider, and sm_world_load (which would have to rebuild it) refuses it. */
#include <stdlib.h>
#include <string.h>

#include "app/io/mesh_load.h"
#include "sandmpm/sandmpm.h"
#include "test_util.h"

/* A closed outward box mesh of half sizes he about the origin (12 triangles). */
static sm_mesh_field *box_field(const double he[3], double h, double band, int threads) {
    double v[24];
    for (int i = 0; i < 8; i++)
        for (int a = 0; a < 3; a++) v[3 * i + a] = ((i >> a) & 1) ? he[a] : -he[a];
    static const uint32_t tri[36] = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
                                     2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5};
    sm_mesh_field_def d = sm_mesh_field_def_default();
    d.vertices = v, d.vertex_count = 8, d.elements = tri, d.element_count = 12;
    d.spacing = h, d.band = band, d.threads = threads;
    sm_mesh_field *f = NULL;
    char err[256];
    if (sm_mesh_field_create(&d, &f, err, sizeof err) != SM_OK) fprintf(stderr, "box field: %s\n", err);
    return f;
}

static void test_shape_and_handle(void) {
    const double he[3] = {0.1, 0.05, 0.08}, h = 0.01;
    sm_mesh_field *f = box_field(he, h, 0.06, 0);
    CHECK(f != NULL);
    if (!f) return;
    const sm_mesh_field_stats *st = sm_mesh_field_get_stats(f);
    CHECK(st->elements == 12 && st->dim == 3 && st->container == 0 && st->lipschitz >= 1.0);
    CHECK(fabs(st->volume - 8 * he[0] * he[1] * he[2]) < 1e-12);
    sm_shape m = sm_shape_default(SM_SHAPE_MESH), b = sm_shape_default(SM_SHAPE_BOX);
    m.mesh = f;
    memcpy(b.half_extent, he, sizeof he);
    const double c[3] = {0.4, 0.3, 0.2}, q[4] = {0.9238795325112867, 0.0, 0.3826834323650898, 0.0}; /* 45 deg about y */
    memcpy(m.center, c, sizeof c), memcpy(b.center, c, sizeof c);
    memcpy(m.rotation, q, sizeof q), memcpy(b.rotation, q, sizeof q);
    unsigned long long rng = 7;
    double worst = 0, worst_n = 0;
    int sign_bad = 0;
    for (int i = 0; i < 20000; i++) {
        double x[3], gm[3], gb[3];
        for (int a = 0; a < 3; a++) x[a] = c[a] + sm_test_uniform(&rng, -0.16, 0.16);
        double pm = sm_shape_distance(&m, 3, x, gm), pb = sm_shape_distance(&b, 3, x, gb);
        if (fabs(pb) > 0.04) continue; /* inside the accurate band (b - sqrt(3) h) */
        worst = fmax(worst, fabs(pm - pb));
        if (fabs(pb) > 0.5 * h) sign_bad += (pm < 0) != (pb < 0);
        if (fabs(pb) > 0.5 * h && fabs(pb) < 0.03) /* away from edges the normals agree */
            worst_n = fmax(worst_n, 1 - (gm[0] * gb[0] + gm[1] * gb[1] + gm[2] * gb[2]));
    }
    printf("mesh box vs analytic box (h = %g): worst |phi difference| %.3g h, sign differences %d\n", h, worst / h, sign_bad);
    CHECK(worst < 0.5 * h); /* trilinear interpolation of a polyhedral distance (docs/mesh-fields.md) */
    CHECK(sign_bad == 0);
    (void)worst_n;
    /* the handle's checks */
    sm_collider_def cd = sm_collider_def_default();
    cd.shape_count = 1;
    cd.shapes[0] = sm_shape_default(SM_SHAPE_MESH);
    char err[256];
    CHECK(sm_collider_def_check(&cd, 3, err, sizeof err) == SM_ERR_INVALID && strstr(err, "shapes[0].mesh") != NULL);
    cd.shapes[0].mesh = f;
    CHECK(sm_collider_def_check(&cd, 3, err, sizeof err) == SM_OK);
    CHECK(sm_collider_def_check(&cd, 2, err, sizeof err) == SM_ERR_INVALID && strstr(err, "a 3D field in a 2D world") != NULL);
    printf("  %s\n", err);
    /* the world keeps its own reference: releasing ours first is fine (ASan would see a use after free) */
    sm_world_def wd = sm_world_def_default();
    sm_world *w = NULL;
    CHECK(sm_world_create(&wd, &w, err, sizeof err) == SM_OK);
    cd.shapes[0].center[0] = cd.shapes[0].center[1] = cd.shapes[0].center[2] = 0.5;
    CHECK(sm_world_add_collider(w, &cd, NULL) == SM_OK);
    sm_mesh_field_release(sm_mesh_field_retain(f)); /* a balanced pair */
    sm_mesh_field_release(f);
    const double x[3] = {0.5, 0.5, 0.5};
    CHECK_NEAR(sm_world_collider_distance(w, 0, x, NULL), -0.05, 1e-6);
    sm_world_destroy(w);
    /* serialised bytes come back as the same field */
    f = box_field(he, h, 0.06, 0);
    size_t n = sm_mesh_field_serialize(f, NULL, 0);
    char *buf = malloc(n);
    sm_mesh_field_serialize(f, buf, n);
    sm_mesh_field *g = NULL;
    CHECK(sm_mesh_field_deserialize(buf, n, &g, err, sizeof err) == SM_OK);
    const double y[3] = {0.03, -0.02, 0.071};
    CHECK(g && sm_mesh_field_distance(g, y, NULL) == sm_mesh_field_distance(f, y, NULL));
    buf[n / 2] ^= 1;
    sm_mesh_field *bad = NULL;
    CHECK(sm_mesh_field_deserialize(buf, n, &bad, err, sizeof err) == SM_ERR_INVALID && bad == NULL);
    free(buf);
    sm_mesh_field_release(g);
    sm_mesh_field_release(f);
}

static sm_world *sand_world(const double hi[3], double dx, int threads, int *mat) {
    sm_world_def def = sm_world_def_default();
    def.dx = dx;
    def.threads = threads;
    memcpy(def.domain_max, hi, 3 * sizeof(double));
    sm_world *w = NULL;
    char err[256];
    if (sm_world_create(&def, &w, err, sizeof err) != SM_OK) return NULL;
    sm_material_def m = sm_material_def_sand();
    CHECK(sm_world_add_material(w, &m, mat) == SM_OK);
    return w;
}

/* Seeds the box (half sizes he, rotated 30 degrees about z) as a mesh with field spacing h, or
 * analytically (h = 0). */
static size_t seed_box(const double he[3], double h) {
    const double hi[3] = {0.6, 0.5, 0.5};
    sm_mesh_field *f = h > 0 ? box_field(he, h, 0.12, 0) : NULL;
    int mat = 0;
    size_t n = 0;
    sm_world *w = sand_world(hi, 0.02, 0, &mat);
    sm_shape s = sm_shape_default(f ? SM_SHAPE_MESH : SM_SHAPE_BOX);
    s.mesh = f;
    memcpy(s.half_extent, he, 3 * sizeof(double));
    s.center[0] = 0.3, s.center[1] = 0.2, s.center[2] = 0.25;
    s.rotation[0] = 0.9659258262890683, s.rotation[3] = 0.25881904510252074;
    sm_seed_def sd = sm_seed_def_default();
    sd.material = mat;
    CHECK(sm_world_seed_shape(w, &s, &sd, &n) == SM_OK);
    sm_world_destroy(w);
    sm_mesh_field_release(f);
    return n;
}

/* The field overestimates the distance near the box's edges and corners (trilinear interpolation
 * of a kinked function, up to about h/4), so a mesh seeds a little less than the exact shape; the
 * deficit shrinks with the field's spacing. */
static void test_seeding(void) {
    const double he[3] = {0.1, 0.06, 0.07};
    size_t exact = seed_box(he, 0), coarse = seed_box(he, 0.02), fine = seed_box(he, 0.005);
    printf("seeding (dx = 0.02): analytic box %zu particles, mesh box with h = dx %zu (%.2f%%), h = dx/4 %zu (%.2f%%)\n",
           exact, coarse, 100.0 * ((double)coarse / (double)exact - 1), fine, 100.0 * ((double)fine / (double)exact - 1));
    CHECK(exact > 1000);
    CHECK(coarse <= exact && fine <= exact && fine >= coarse);
    CHECK_REL((double)coarse, (double)exact, 0.03, 0);
    CHECK_REL((double)fine, (double)exact, 0.01, 0);
}

static void plate_motion(void *user, double t, sm_pose *pose) {
    (void)user;
    memset(pose, 0, sizeof *pose);
    pose->position[0] = 0.5 * t;
    pose->rotation[0] = 1;
}

/* The plate pushes a block across a slip ground; returns the mean x velocity of the sand within
 * 2 dx in front of the plate at t = 0.3 s (and the plate's own there). */
static double plate_push(int scripted, int threads, uint64_t *hash) {
    const double hi[3] = {1.0, 0.5, 0.4}, dx = 0.02, he[3] = {0.03, 0.1, 0.15};
    int mat = 0;
    sm_world *w = sand_world(hi, dx, threads, &mat);
    sm_collider_def g = sm_test_ground(0.1);
    g.mode = SM_COLLIDE_SLIP;
    g.friction = 0.3;
    CHECK(sm_world_add_collider(w, &g, NULL) == SM_OK);
    sm_mesh_field *f = box_field(he, dx, 6 * dx, threads);
    sm_collider_def p = sm_collider_def_default();
    p.shape_count = 1;
    p.shapes[0] = sm_shape_default(SM_SHAPE_MESH);
    p.shapes[0].mesh = f;
    p.shapes[0].center[0] = 0.27, p.shapes[0].center[1] = 0.2, p.shapes[0].center[2] = 0.2;
    p.mode = SM_COLLIDE_STICKY;
    if (scripted) p.motion = plate_motion;
    else p.velocity[0] = 0.5;
    CHECK(sm_world_add_collider(w, &p, NULL) == SM_OK);
    sm_mesh_field_release(f); /* the world holds it */
    sm_shape block = sm_shape_default(SM_SHAPE_BOX);
    block.center[0] = 0.45, block.center[1] = 0.16, block.center[2] = 0.2;
    block.half_extent[0] = 0.15, block.half_extent[1] = 0.06, block.half_extent[2] = 0.1;
    sm_seed_def sd = sm_seed_def_default();
    sd.material = mat;
    CHECK(sm_world_seed_shape(w, &block, &sd, NULL) == SM_OK);
    CHECK(sm_world_advance(w, hash ? 0.05 : 0.3) == SM_OK);
    if (hash) {
        *hash = sm_world_state_hash(w);
        sm_world_destroy(w);
        return 0;
    }
    sm_particles_view pv;
    sm_world_particles(w, &pv);
    const double front = 0.27 + 0.5 * 0.3 + he[0];
    double sum = 0;
    size_t cnt = 0;
    for (size_t i = 0; i < pv.n; i++) {
        const double x = (double)pv.x[3 * i], y = (double)pv.x[3 * i + 1], z = (double)pv.x[3 * i + 2];
        if (x > front && x < front + 2 * dx && fabs(z - 0.2) < 0.08 && y < 0.25) {
            sum += (double)pv.v[3 * i];
            cnt++;
        }
    }
    sm_world_destroy(w);
    printf("mesh plate (%s, %d threads): %zu particles in front, mean vx %.4f m/s (plate 0.5)\n",
           scripted ? "motion function" : "constant velocity", threads, cnt, cnt ? sum / (double)cnt : 0.0);
    CHECK(cnt > 50);
    return cnt ? sum / (double)cnt : 0;
}

static void test_plate(void) {
    CHECK_REL(plate_push(0, 1, NULL), 0.5, 0.05, 0);
    CHECK_REL(plate_push(1, 1, NULL), 0.5, 0.05, 0);
    uint64_t h[3];
    for (int t = 1; t <= 3; t++) plate_push(0, t, &h[t - 1]);
    printf("state hash after 0.05 s: %016llx (1 thread) %016llx (2) %016llx (3)\n", (unsigned long long)h[0],
           (unsigned long long)h[1], (unsigned long long)h[2]);
    CHECK(h[0] == h[1] && h[1] == h[2]);
}

typedef struct bytes {
    char *p;
    size_t n;
} bytes;

static int write_bytes(void *user, const void *data, size_t n) {
    bytes *b = user;
    char *q = realloc(b->p, b->n + n);
    if (!q) return 1;
    memcpy(q + b->n, data, n);
    b->p = q;
    b->n += n;
    return 0;
}

/* The bowl of scenes/meshes (rim at z = 0 in the file) turned opening-up, with sand in it. */
static void test_bowl(void) {
    const double hi[3] = {0.6, 0.45, 0.6}, dx = 0.01, yc = 0.25; /* the spheres' centre (the rim) at y = yc */
    char path[512], msg[512];
    snprintf(path, sizeof path, "%s/scenes/meshes/bowl.obj", SM_SOURCE_DIR);
    sm_mesh_load_opts o = sm_mesh_load_opts_default();
    o.placement.rotation[0] = sqrt(0.5), o.placement.rotation[1] = -sqrt(0.5); /* -90 deg about x: z -> y */
    sm_mesh_data md;
    CHECK(sm_mesh_load(path, &o, &md, msg, sizeof msg) == SM_OK);
    sm_mesh_field_def d = sm_mesh_field_def_default();
    d.vertices = md.vertices, d.vertex_count = md.vertex_count, d.elements = md.elements, d.element_count = md.element_count;
    d.spacing = dx, d.band = 6 * dx;
    sm_mesh_field *f = NULL;
    CHECK(sm_mesh_field_create(&d, &f, msg, sizeof msg) == SM_OK);
    sm_mesh_data_free(&md);
    if (!f) return;
    static const char *const names[3] = {"sticky", "slip", "separate"};
    for (int mode = 0; mode < 3; mode++) {
        int mat = 0;
        sm_world *w = sand_world(hi, dx, 1, &mat);
        sm_collider_def c = sm_collider_def_default();
        c.shape_count = 1;
        c.shapes[0] = sm_shape_default(SM_SHAPE_MESH);
        c.shapes[0].mesh = f;
        c.shapes[0].center[0] = 0.3, c.shapes[0].center[1] = yc, c.shapes[0].center[2] = 0.3;
        c.mode = (sm_collide_mode)mode;
        c.friction = 0.5;
        CHECK(sm_world_add_collider(w, &c, NULL) == SM_OK);
        sm_shape block = sm_shape_default(SM_SHAPE_BOX);
        block.center[0] = 0.3, block.center[1] = yc - 0.09, block.center[2] = 0.3;
        block.half_extent[0] = block.half_extent[1] = block.half_extent[2] = 0.025;
        sm_seed_def sd = sm_seed_def_default();
        sd.material = mat;
        size_t n0 = 0;
        CHECK(sm_world_seed_shape(w, &block, &sd, &n0) == SM_OK);
        CHECK(sm_world_advance(w, 2.0) == SM_OK);
        sm_particles_view pv;
        sm_world_particles(w, &pv);
        size_t out = 0, in_wall = 0;
        double rmax = 0, ymean = 0;
        for (size_t i = 0; i < pv.n; i++) {
            double x[3] = {(double)pv.x[3 * i], (double)pv.x[3 * i + 1], (double)pv.x[3 * i + 2]};
            double r = sqrt((x[0] - 0.3) * (x[0] - 0.3) + (x[1] - yc) * (x[1] - yc) + (x[2] - 0.3) * (x[2] - 0.3));
            rmax = fmax(rmax, r);
            ymean += x[1] / (double)pv.n;
            out += r > 0.17 + 0.5 * dx || x[1] > yc;
            in_wall += sm_world_collider_distance(w, 0, x, NULL) < -0.25 * dx;
        }
        printf("bowl (%s): %zu of %zu particles after 2 s; outside the cavity %zu, inside the wall %zu; largest distance "
               "from the centre %.4f m (inner radius 0.17), mean height %.4f m (seeded at %.4f)\n",
               names[mode], pv.n, n0, out, in_wall, rmax, ymean, yc - 0.09);
        CHECK(pv.n == n0 && out == 0 && in_wall == 0);
        CHECK(ymean < yc - 0.09); /* it settled into the bowl */
        if (mode == 1) { /* checkpoints: restore keeps the mesh collider; load cannot rebuild it */
            bytes b = {NULL, 0};
            CHECK(sm_world_save(w, write_bytes, &b) == SM_OK);
            uint64_t hsh = sm_world_state_hash(w);
            CHECK(sm_world_advance(w, 2.05) == SM_OK);
            CHECK(sm_world_restore(w, b.p, b.n) == SM_OK && sm_world_state_hash(w) == hsh);
            sm_world *l = NULL;
            CHECK(sm_world_load(b.p, b.n, &l, msg, sizeof msg) == SM_ERR_INVALID && l == NULL);
            CHECK(strstr(msg, "mesh shape") != NULL);
            printf("  %s\n", msg);
            free(b.p);
        }
        sm_world_destroy(w);
    }
    sm_mesh_field_release(f);
}

int main(void) {
    test_shape_and_handle();
    test_seeding();
    test_plate();
    test_bowl();
    return sm_test_summary("test_mesh_collide");
}
