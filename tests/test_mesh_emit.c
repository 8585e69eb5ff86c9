/* Mesh emitters (issue 15 item 4): an emitter whose region is a closed mesh (an L prism, concave,
 * rotated 30 degrees about z, field spacing dx/2):
 * (1) every particle appears inside the mesh (phi < 0 at its emission position, checked after
 *     each step: emitters run at the step's end);
 * (2) the emitted mass follows rate * t to within one particle;
 * (3) the region sampled is the mesh's volume: the emitted points are uniform over it (each of
 *     the L's three unit cubes holds a third of them within 4 standard deviations, their mean is
 *     the L's centroid within 0.03 s), and sm_shape_volume_estimate of the mesh shape is the L's
 *     analytic volume 3 s^3 within 3%;
 * (4) the same state hash for 1 and 2 threads;
 * (5) refusals: a mesh shape without a field, a container (inside-out mesh), a 2D field in a 3D
 *     world; a checkpoint restores into a world with the emitter, sm_world_load refuses it. */
#include <stdlib.h>
#include <string.h>

#include "mesh_gen.h"
#include "sandmpm/sandmpm.h"
#include "test_util.h"

#define S 0.1 /* the L's unit: 2s x 2s x s */

static const double CENTER[3] = {0.5, 0.5, 0.5};
static const double QZ30[4] = {0.9659258262890683, 0.0, 0.0, 0.25881904510252074}; /* 30 deg about z */

/* The L prism with its bounding box centred on the mesh frame's origin (flipped: a container). */
static sm_mesh_field *l_field(double h, int flip, int threads) {
    const double c[3] = {-S, -S, -0.5 * S};
    test_mesh m = mesh_l_prism(c, S);
    if (flip) mesh_flip(&m);
    sm_mesh_field_def d = sm_mesh_field_def_default();
    d.vertices = m.v, d.vertex_count = m.nv, d.elements = m.e, d.element_count = m.ne;
    d.spacing = h, d.band = 6 * h, d.threads = threads;
    sm_mesh_field *f = NULL;
    char err[256];
    if (sm_mesh_field_create(&d, &f, err, sizeof err) != SM_OK) fprintf(stderr, "L field: %s\n", err);
    mesh_free(&m);
    return f;
}

static sm_shape l_shape(const sm_mesh_field *f) {
    sm_shape s = sm_shape_default(SM_SHAPE_MESH);
    s.mesh = f;
    memcpy(s.center, CENTER, sizeof CENTER);
    memcpy(s.rotation, QZ30, sizeof QZ30);
    return s;
}

/* x in the L's own frame (lower corner at the origin, 0 <= x, y <= 2s, 0 <= z <= s). */
static void to_l_frame(const double x[3], double out[3]) {
    const double d[3] = {x[0] - CENTER[0], x[1] - CENTER[1], x[2] - CENTER[2]};
    const double cz = 2 * QZ30[0] * QZ30[0] - 1, sz = 2 * QZ30[0] * QZ30[3]; /* cos, sin 30 deg */
    out[0] = cz * d[0] + sz * d[1] + S;
    out[1] = -sz * d[0] + cz * d[1] + S;
    out[2] = d[2] + 0.5 * S;
}

static sm_world *world(int threads, int *mat) {
    sm_world_def def = sm_world_def_default();
    def.threads = threads;
    def.gravity[1] = 0;
    sm_world *w = NULL;
    char err[256];
    if (sm_world_create(&def, &w, err, sizeof err) != SM_OK) return NULL;
    sm_material_def m = sm_material_def_sand();
    CHECK(sm_world_add_material(w, &m, mat) == SM_OK);
    return w;
}

typedef struct emit_stats {
    size_t n, outside, cube[3];
    double mean[3], worst_phi;
    double emitted, expected, pmass;
    uint64_t hash;
} emit_stats;

/* Runs the emitter for 40 steps of 2e-4 s; the statistics of the points at their emission. */
static emit_stats run(int threads) {
    emit_stats r;
    memset(&r, 0, sizeof r);
    r.worst_phi = -INFINITY;
    int mat = -1;
    sm_world *w = world(threads, &mat);
    CHECK(w != NULL);
    if (!w) return r;
    sm_mesh_field *f = l_field(0.01, 0, threads);
    CHECK(f != NULL);
    if (!f) {
        sm_world_destroy(w);
        return r;
    }
    sm_emitter_def e = sm_emitter_def_default();
    e.shape = l_shape(f);
    e.material = mat;
    e.rate = 500.0; /* 2e-4 s a step: 0.1 kg, 45 particles of 2.2 g a step */
    e.seed = 11;
    int id = -1;
    CHECK(sm_world_add_emitter(w, &e, &id) == SM_OK);
    const sm_shape probe = l_shape(f);
    sm_mesh_field_release(f); /* the emitter holds its own reference */
    const double dt = 2e-4;
    size_t before = 0;
    for (int k = 0; k < 40; k++) {
        CHECK(sm_world_step(w, dt) == SM_OK);
        sm_particles_view p;
        sm_world_particles(w, &p);
        for (size_t i = 0; i < p.n; i++) {
            if (p.id[i] < before) continue; /* emitted in an earlier step: it may have moved */
            const double *x = p.x + 3 * i;
            const double phi = sm_shape_distance(&probe, 3, x, NULL);
            r.worst_phi = fmax(r.worst_phi, phi);
            r.outside += !(phi < 0);
            double y[3];
            to_l_frame(x, y);
            r.cube[y[1] >= S ? 2 : y[0] >= S ? 1 : 0]++;
            for (int a = 0; a < 3; a++) r.mean[a] += y[a];
            r.n++;
        }
        before = p.n;
    }
    for (int a = 0; a < 3; a++) r.mean[a] /= (double)(r.n ? r.n : 1);
    r.emitted = sm_world_emitted_mass(w, id);
    r.expected = e.rate * 40 * dt;
    r.pmass = sm_world_particle_mass(w, 0);
    r.hash = sm_world_state_hash(w);
    sm_world_destroy(w);
    return r;
}

static void test_emission(void) {
    emit_stats a = run(1), b = run(2);
    printf("L-prism emitter: %zu particles (%.4f kg, rate * t = %.4f kg, one particle %.2e kg), %zu outside, "
           "largest phi at emission %.3g m\n",
           a.n, a.emitted, a.expected, a.pmass, a.outside, a.worst_phi);
    CHECK(a.n > 1500);
    CHECK(a.outside == 0 && a.worst_phi < 0);
    CHECK(fabs(a.emitted - a.expected) <= a.pmass * 1.0000001);
    CHECK_REL((double)a.n * a.pmass, a.emitted, 1e-6, 0); /* the particle mass is rho * V0, V0 an sm_real */
    /* uniform over the L: a third in each cube, binomial standard deviation sqrt(n p (1 - p)) */
    const double sd = sqrt(a.n * (1.0 / 3) * (2.0 / 3));
    for (int c = 0; c < 3; c++) {
        printf("  cube %d: %zu (expected %.1f +- %.1f)\n", c, a.cube[c], a.n / 3.0, sd);
        CHECK(fabs((double)a.cube[c] - a.n / 3.0) < 4 * sd);
    }
    const double centroid[3] = {2.5 / 3 * S, 2.5 / 3 * S, 0.5 * S}; /* the 3 cubes' centres' mean */
    printf("  mean position in the L's frame (%.4f, %.4f, %.4f), centroid (%.4f, %.4f, %.4f)\n", a.mean[0], a.mean[1],
           a.mean[2], centroid[0], centroid[1], centroid[2]);
    for (int k = 0; k < 3; k++) CHECK_NEAR(a.mean[k], centroid[k], 0.03 * S);
    printf("  state hash 1 thread %016llx, 2 threads %016llx\n", (unsigned long long)a.hash, (unsigned long long)b.hash);
    CHECK(a.hash == b.hash && a.n == b.n);
    /* the sampled region's volume */
    sm_mesh_field *f = l_field(0.01, 0, 0);
    const sm_shape s = l_shape(f);
    const double lo[3] = {0.34, 0.34, 0.44}, hi[3] = {0.66, 0.66, 0.56}; /* holds the L (half diagonal 0.141) */
    const double vol = sm_shape_volume_estimate(&s, NULL, 3, lo, hi), exact = 3 * S * S * S;
    printf("  volume estimate of the mesh shape %.6f m^3, analytic %.6f m^3 (%.2f%%)\n", vol, exact, 100 * (vol / exact - 1));
    CHECK(fabs(vol / exact - 1) < 0.03);
    sm_mesh_field_release(f);
}

static int write_bytes(void *user, const void *data, size_t n) {
    FILE *f = user;
    return fwrite(data, 1, n, f) == n ? 0 : -1;
}

static void test_refusals(void) {
    int mat = -1;
    sm_world *w = world(0, &mat);
    CHECK(w != NULL);
    if (!w) return;
    sm_emitter_def e = sm_emitter_def_default();
    e.material = mat;
    e.shape = sm_shape_default(SM_SHAPE_MESH);
    memcpy(e.shape.center, CENTER, sizeof CENTER);
    CHECK(sm_world_add_emitter(w, &e, NULL) == SM_ERR_INVALID && strstr(sm_world_errmsg(w), "mesh") != NULL);
    printf("no field: %s\n", sm_world_errmsg(w));
    sm_mesh_field *inv = l_field(0.01, 1, 0);
    e.shape.mesh = inv;
    CHECK(inv && sm_mesh_field_get_stats(inv)->container == 1);
    CHECK(sm_world_add_emitter(w, &e, NULL) == SM_ERR_INVALID && strstr(sm_world_errmsg(w), "container") != NULL);
    printf("container: %s\n", sm_world_errmsg(w));
    sm_mesh_field_release(inv);
    const double c2[2] = {0, 0};
    test_mesh circle = outline_circle(c2, 0.1, 64);
    sm_mesh_field_def d = sm_mesh_field_def_default();
    d.dim = 2;
    d.vertices = circle.v, d.vertex_count = circle.nv, d.elements = circle.e, d.element_count = circle.ne;
    d.spacing = 0.01, d.band = 0.06;
    sm_mesh_field *f2 = NULL;
    CHECK(sm_mesh_field_create(&d, &f2, NULL, 0) == SM_OK);
    mesh_free(&circle);
    e.shape.mesh = f2;
    CHECK(sm_world_add_emitter(w, &e, NULL) == SM_ERR_INVALID && strstr(sm_world_errmsg(w), "dimension") != NULL);
    sm_mesh_field_release(f2);
    /* a checkpoint of a world with a mesh emitter */
    sm_mesh_field *f = l_field(0.01, 0, 0);
    e.shape = l_shape(f);
    e.rate = 50;
    CHECK(sm_world_add_emitter(w, &e, NULL) == SM_OK);
    for (int k = 0; k < 5; k++) CHECK(sm_world_step(w, 2e-4) == SM_OK);
    FILE *tf = tmpfile();
    CHECK(tf && sm_world_save(w, write_bytes, tf) == SM_OK);
    long len = tf ? ftell(tf) : 0;
    char *buf = malloc((size_t)len + 1);
    if (tf) {
        rewind(tf);
        CHECK(fread(buf, 1, (size_t)len, tf) == (size_t)len);
        fclose(tf);
    }
    const uint64_t h0 = sm_world_state_hash(w);
    for (int k = 0; k < 5; k++) CHECK(sm_world_step(w, 2e-4) == SM_OK);
    const uint64_t h1 = sm_world_state_hash(w);
    sm_world *w2 = world(0, &mat);
    CHECK(w2 && sm_world_add_emitter(w2, &e, NULL) == SM_OK);
    sm_mesh_field_release(f);
    CHECK(w2 && sm_world_restore(w2, buf, (size_t)len) == SM_OK);
    CHECK(w2 && sm_world_state_hash(w2) == h0);
    for (int k = 0; k < 5 && w2; k++) CHECK(sm_world_step(w2, 2e-4) == SM_OK);
    CHECK(w2 && sm_world_state_hash(w2) == h1);
    sm_world *w3 = NULL;
    char err[512];
    CHECK(sm_world_load(buf, (size_t)len, &w3, err, sizeof err) == SM_ERR_INVALID && strstr(err, "emitter") != NULL);
    printf("load: %s\n", err);
    free(buf);
    sm_world_destroy(w2);
    sm_world_destroy(w);
}

int main(void) {
    test_emission();
    test_refusals();
    return sm_test_summary("test_mesh_emit");
}
