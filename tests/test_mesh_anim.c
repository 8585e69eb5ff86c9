/* Animated mesh colliders (issue 15 item 3): a sequence of OBJ files (written here, one per frame,
 * the same box plate with its vertices moved 0.5/30 m in x per frame at 30 frames/s) read with the
 * mesh loader and made into one animated field (sm_mesh_field_create_animated):
 * (1) a sticky collider with that field and no rigid motion pushes a sand block: the sand within
 *     2 dx in front of the plate moves at the plate's 0.5 m/s within 5% (thesis §3.6.3: the
 *     collider velocity here comes only from the vertex motion);
 * (2) a plate whose vertices do not move (every frame the same file) leaves the sand in front at
 *     rest (its mean |vx| below 2% of 0.5 m/s), so the push in (1) is the vertex motion's;
 * (3) the same state hash with 1, 2 and 3 threads;
 * (4) a frame with a different topology is refused naming the frame; an animated field reports
 *     its frame count and fps; fewer than 2 frames or fps <= 0 are refused. */
#define _POSIX_C_SOURCE 200809L
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "app/io/mesh_load.h"
#include "sandmpm/sandmpm.h"
#include "test_util.h"

#define FPS 30.0
#define NFRAMES 13 /* 0.4 s */
#define SPEED 0.5
static const double HE[3] = {0.03, 0.1, 0.15}; /* the plate's half sizes */
static char dir[256];

/* Writes frame f of the plate (moved speed f / fps in x; speed 0: at rest) as OBJ. */
static void write_frame(int f, double speed, const char *name) {
    char path[512];
    snprintf(path, sizeof path, "%s/%s_%04d.obj", dir, name, f);
    FILE *o = fopen(path, "w");
    CHECK(o != NULL);
    if (!o) return;
    for (int i = 0; i < 8; i++)
        fprintf(o, "v %.17g %.17g %.17g\n", ((i & 1) ? HE[0] : -HE[0]) + speed * f / FPS, (i & 2) ? HE[1] : -HE[1],
                (i & 4) ? HE[2] : -HE[2]);
    static const int tri[36] = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
                                2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5};
    for (int t = 0; t < 12; t++) fprintf(o, "f %d %d %d\n", tri[3 * t] + 1, tri[3 * t + 1] + 1, tri[3 * t + 2] + 1);
    fclose(o);
}

/* The animated field of frames name_0000.obj .. (NFRAMES of them). */
static sm_mesh_field *load_anim(const char *name, double dx, int threads) {
    sm_mesh_data md[NFRAMES];
    sm_mesh_field_def d[NFRAMES];
    sm_mesh_load_opts o = sm_mesh_load_opts_default();
    int ok = 1;
    for (int f = 0; f < NFRAMES; f++) {
        char path[512], msg[512];
        snprintf(path, sizeof path, "%s/%s_%04d.obj", dir, name, f);
        if (sm_mesh_load(path, &o, &md[f], msg, sizeof msg) != SM_OK) {
            fprintf(stderr, "%s\n", msg);
            ok = 0;
            memset(&md[f], 0, sizeof md[f]);
        }
        d[f] = sm_mesh_field_def_default();
        d[f].vertices = md[f].vertices, d[f].vertex_count = md[f].vertex_count;
        d[f].elements = md[f].elements, d[f].element_count = md[f].element_count;
        d[f].spacing = dx, d[f].band = 6 * dx, d[f].threads = threads;
    }
    CHECK(ok);
    sm_mesh_field *m = NULL;
    char err[512];
    if (ok && sm_mesh_field_create_animated(d, NFRAMES, FPS, &m, err, sizeof err) != SM_OK) fprintf(stderr, "%s\n", err);
    for (int f = 0; f < NFRAMES; f++) sm_mesh_data_free(&md[f]);
    return m;
}

/* The plate (frames `name`) pushes a block across a slip ground; the mean x velocity of the sand
 * within 2 dx in front of the plate at 0.3 s (or the state hash at 0.05 s). */
static double plate_push(const char *name, double speed, int threads, uint64_t *hash) {
    const double dx = 0.02;
    sm_world_def def = sm_world_def_default();
    def.dx = dx;
    def.threads = threads;
    def.domain_max[0] = 1.0, def.domain_max[1] = 0.5, def.domain_max[2] = 0.4;
    sm_world *w = NULL;
    char err[256];
    CHECK(sm_world_create(&def, &w, err, sizeof err) == SM_OK);
    if (!w) return 0;
    sm_material_def m = sm_material_def_sand();
    int mat = 0;
    CHECK(sm_world_add_material(w, &m, &mat) == SM_OK);
    sm_collider_def g = sm_test_ground(0.1);
    g.mode = SM_COLLIDE_SLIP;
    g.friction = 0.3;
    CHECK(sm_world_add_collider(w, &g, NULL) == SM_OK);
    sm_mesh_field *f = load_anim(name, dx, threads);
    CHECK(f != NULL);
    sm_collider_def p = sm_collider_def_default();
    p.shape_count = 1;
    p.shapes[0] = sm_shape_default(SM_SHAPE_MESH);
    p.shapes[0].mesh = f;
    p.shapes[0].center[0] = 0.27, p.shapes[0].center[1] = 0.2, p.shapes[0].center[2] = 0.2;
    p.mode = SM_COLLIDE_STICKY; /* at rest: only the vertices move */
    CHECK(f && sm_world_add_collider(w, &p, NULL) == SM_OK);
    sm_mesh_field_release(f);
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
    const double front = 0.27 + speed * 0.3 + HE[0];
    double sum = 0;
    size_t cnt = 0;
    for (size_t i = 0; i < pv.n; i++) {
        const double x = pv.x[3 * i], y = pv.x[3 * i + 1], z = pv.x[3 * i + 2];
        if (x > front && x < front + 2 * dx && fabs(z - 0.2) < 0.08 && y < 0.25) {
            sum += (double)pv.v[3 * i];
            cnt++;
        }
    }
    sm_world_destroy(w);
    printf("animated plate (%s, vertices at %g m/s, %d threads): %zu particles in front, mean vx %.4f m/s\n", name, speed,
           threads, cnt, cnt ? sum / (double)cnt : 0.0);
    CHECK(cnt > 50);
    return cnt ? sum / (double)cnt : 0;
}

static void test_push(void) {
    for (int f = 0; f < NFRAMES; f++) write_frame(f, SPEED, "plate"), write_frame(f, 0.0, "still");
    CHECK_REL(plate_push("plate", SPEED, 1, NULL), SPEED, 0.05, 0);
    CHECK(fabs(plate_push("still", 0.0, 1, NULL)) < 0.02 * SPEED);
    uint64_t h[3];
    for (int t = 1; t <= 3; t++) plate_push("plate", SPEED, t, &h[t - 1]);
    printf("state hash after 0.05 s: %016llx (1 thread) %016llx (2) %016llx (3)\n", (unsigned long long)h[0],
           (unsigned long long)h[1], (unsigned long long)h[2]);
    CHECK(h[0] == h[1] && h[1] == h[2]);
}

static void test_refusals(void) {
    double v0[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0}, v1[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    uint32_t e0[3] = {0, 1, 2}, e1[12] = {0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2}, e2[3] = {0, 2, 1};
    sm_mesh_field_def d[3];
    for (int i = 0; i < 3; i++) {
        d[i] = sm_mesh_field_def_default();
        d[i].sign = SM_MESH_SIGN_ONE_SIDED;
        d[i].vertices = v0, d[i].vertex_count = 3, d[i].elements = e0, d[i].element_count = 1;
        d[i].spacing = 0.05, d[i].band = 0.2;
    }
    sm_mesh_field *m = NULL;
    char err[512];
    CHECK(sm_mesh_field_create_animated(d, 3, 30, &m, err, sizeof err) == SM_OK && m);
    double fps = 0;
    CHECK(m && sm_mesh_field_frame_count(m, &fps) == 3 && fps == 30);
    sm_mesh_field_release(m);
    CHECK(sm_mesh_field_create_animated(d, 1, 30, &m, err, sizeof err) == SM_ERR_INVALID && !m);
    CHECK(sm_mesh_field_create_animated(d, 3, 0, &m, err, sizeof err) == SM_ERR_INVALID && !m);
    d[2].vertices = v1, d[2].vertex_count = 4, d[2].elements = e1, d[2].element_count = 4;
    CHECK(sm_mesh_field_create_animated(d, 3, 30, &m, err, sizeof err) == SM_ERR_INVALID && !m && strstr(err, "frame 2") != NULL);
    printf("%s\n", err);
    d[2] = d[1];
    d[1].elements = e2;
    CHECK(sm_mesh_field_create_animated(d, 3, 30, &m, err, sizeof err) == SM_ERR_INVALID && !m && strstr(err, "frame 1") != NULL);
    printf("%s\n", err);
}

int main(void) {
    snprintf(dir, sizeof dir, "/tmp/test_mesh_anim.XXXXXX");
    if (!mkdtemp(dir)) return 1;
    test_refusals();
    test_push();
    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    if (system(cmd) != 0) fprintf(stderr, "could not remove %s\n", dir);
    return sm_test_summary("test_mesh_anim");
}
