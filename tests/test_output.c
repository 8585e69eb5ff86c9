/* Output files read back byte-exactly to the particle data they were written from: binary PLY
 * (header and every property of every particle) and VTK XML PolyData (every appended array, the
 * vertex cells), in 2D and 3D, after some steps so that velocities, F and q are not trivial, and
 * in id order (vertex k is the particle with id k, though storage is reordered by the steps). The
 * write is atomic: no temporary file is left behind. Ids followed across frames: a grain's vertex
 * moves no more than the largest speed times the frame's time; an emitter's grains come after. */
#define _POSIX_C_SOURCE 200809L
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "app/io/files.h"
#include "app/io/ply.h"
#include "app/io/vtk.h"
#include "app/run_manifest.h"
#include "test_util.h"

/* Coordinate a of particle i (positions may be float, double or another type than sm_real). */
#define XPOS(pv, i, a) ((double)(pv).x[(size_t)(i) * (size_t)(pv).dim + (size_t)(a)])

static unsigned char *slurp(const char *path, size_t *len) {
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *b = malloc((size_t)n + 1);
    if (b && fread(b, 1, (size_t)n, f) != (size_t)n) {
        free(b);
        b = NULL;
    }
    fclose(f);
    if (b) b[n] = 0;
    *len = (size_t)n;
    return b;
}

static float f32(const unsigned char *p) {
    float f;
    memcpy(&f, p, 4); /* the test machine is little-endian, as the files are */
    return f;
}

static double det(const sm_real *F, int d) {
    if (d == 2) return (double)F[0] * F[3] - (double)F[1] * F[2];
    return (double)F[0] * ((double)F[4] * F[8] - (double)F[5] * F[7]) - (double)F[1] * ((double)F[3] * F[8] - (double)F[5] * F[6]) +
           (double)F[2] * ((double)F[3] * F[7] - (double)F[4] * F[6]);
}

static sm_world *make(int dim) {
    sm_world_def def = sm_world_def_default();
    def.dim = dim;
    def.dx = 0.05;
    sm_world *w = NULL;
    char err[256];
    sm_world_create(&def, &w, err, sizeof err);
    sm_material_def m = sm_material_def_sand();
    int sand = -1;
    CHECK(sm_world_add_material(w, &m, &sand) == SM_OK);
    sm_material_def e = sm_material_def_elastic();
    int el = -1;
    CHECK(sm_world_add_material(w, &e, &el) == SM_OK);
    sm_collider_def g = sm_test_ground(0.2);
    CHECK(sm_world_add_collider(w, &g, NULL) == SM_OK);
    sm_shape b = sm_shape_default(SM_SHAPE_BOX);
    b.center[0] = b.center[2] = 0.5;
    b.center[1] = 0.35;
    b.half_extent[0] = b.half_extent[1] = b.half_extent[2] = 0.15;
    sm_seed_def sd = sm_seed_def_default();
    sd.material = sand;
    sm_world_seed_shape(w, &b, &sd, NULL);
    b.center[1] = 0.7;
    b.half_extent[0] = b.half_extent[1] = b.half_extent[2] = 0.08;
    sd.material = el;
    sd.velocity[1] = -2;
    sm_world_seed_shape(w, &b, &sd, NULL);
    sm_world_advance(w, 0.15);
    return w;
}

/* Reads a PLY frame written from w into f. */
static void write_read(const sm_world *w, const char *path, sm_frame *f) {
    char err[512];
    CHECK(sm_write_ply(w, path, 0, err, sizeof err) == SM_OK);
    CHECK(sm_ply_read(path, f, err, sizeof err) == SM_OK);
}

/* Frames 1/24 s apart: vertex k has id k in both, and moves at most v_max * dt_frame (v_max the
 * largest particle speed over the frame's steps); then an emitter adds grains: the frame before
 * is a prefix of the frame after (same ids at the same vertices), the new ids follow. */
static void follow_ids(sm_world *w, int dim) {
    sm_frame a, b;
    write_read(w, "test_output_ids_a.ply", &a);
    const double t0 = sm_world_time(w), t1 = t0 + 1.0 / 24;
    double vmax = 0;
    sm_diagnostics d;
    sm_world_diagnostics(w, &d);
    vmax = d.max_speed;
    while (sm_world_time(w) < t1) {
        CHECK(sm_world_step(w, sm_world_next_dt(w, t1)) == SM_OK);
        sm_world_diagnostics(w, &d);
        vmax = fmax(vmax, d.max_speed);
    }
    write_read(w, "test_output_ids_b.ply", &b);
    CHECK(a.id && b.id && a.n == b.n);
    size_t wrong_id = 0, too_far = 0;
    double worst = 0, bound = vmax * (t1 - t0) * (1 + 1e-4) + 1e-6;
    for (size_t k = 0; a.id && b.id && k < a.n && k < b.n; k++) {
        wrong_id += a.id[k] != k || b.id[k] != k;
        double dd = 0;
        for (int c = 0; c < 3; c++) dd += (double)(b.x[3 * k + c] - a.x[3 * k + c]) * (b.x[3 * k + c] - a.x[3 * k + c]);
        worst = fmax(worst, sqrt(dd));
        too_far += sqrt(dd) > bound;
    }
    CHECK(wrong_id == 0);
    CHECK(too_far == 0);
    printf("%dD: ids followed over a frame: largest move %.4g m, bound v_max dt_frame %.4g m\n", dim, worst, bound);
    /* An emitter: its grains come after the seeded ones. */
    sm_emitter_def e = sm_emitter_def_default();
    e.shape = sm_shape_default(SM_SHAPE_BOX);
    e.shape.center[0] = e.shape.center[2] = 0.5;
    e.shape.center[1] = 0.85;
    e.shape.half_extent[0] = e.shape.half_extent[1] = e.shape.half_extent[2] = 0.05;
    e.material = 0;
    e.ppc = dim == 2 ? 4 : 8;
    e.rate = dim == 2 ? 1000 : 50; /* kg/(m s) in 2D, kg/s in 3D */
    e.start = sm_world_time(w);
    e.stop = e.start + 1;
    CHECK(sm_world_add_emitter(w, &e, NULL) == SM_OK);
    CHECK(sm_world_advance(w, sm_world_time(w) + 0.05) == SM_OK);
    sm_frame c;
    write_read(w, "test_output_ids_c.ply", &c);
    CHECK(c.n > b.n);
    size_t wrong = 0;
    for (size_t k = 0; c.id && k < c.n; k++) wrong += c.id[k] != k;
    CHECK(wrong == 0);
    printf("%dD: an emitter added %zu grains after the %zu seeded ones\n", dim, c.n - b.n, b.n);
    sm_frame_free(&a);
    sm_frame_free(&b);
    sm_frame_free(&c);
}

/* The run manifest: written and read back field by field; a malformed line named; removal takes
 * the listed files and the manifest, and leaves the others. */
static void touch(const char *dir, const char *name) {
    char p[512];
    snprintf(p, sizeof p, "%s/%s", dir, name);
    FILE *f = fopen(p, "w");
    if (f) fclose(f);
}

static int exists(const char *dir, const char *name) {
    char p[512];
    snprintf(p, sizeof p, "%s/%s", dir, name);
    return access(p, F_OK) == 0;
}

static void test_run_manifest(void) {
    char dir[] = "test_output_manifest_XXXXXX", err[SM_MSG_MAX];
    CHECK(mkdtemp(dir) != NULL);
    sm_run_manifest m, r;
    sm_run_manifest_init(&m);
    snprintf(m.scene, sizeof m.scene, "scenes/a b.lua");
    m.scene_hash = 0x0123456789abcdefull;
    snprintf(m.quality, sizeof m.quality, "test");
    m.fps = 24;
    m.frames = 9;
    snprintf(m.state, sizeof m.state, "stopped");
    m.first[SM_FRAME_PLY] = 0, m.last[SM_FRAME_PLY] = 2;
    m.first[SM_FRAME_PNG] = 1, m.last[SM_FRAME_PNG] = 1;
    m.files = SM_RUNFILE_PVD | SM_RUNFILE_CHECKPOINTS;
    CHECK(sm_run_manifest_write(dir, &m, err, sizeof err) == SM_OK);
    int found = 0;
    CHECK(sm_run_manifest_read(dir, &r, &found, err, sizeof err) == SM_OK && found);
    CHECK(!strcmp(r.scene, m.scene) && r.scene_hash == m.scene_hash && !strcmp(r.quality, "test") && r.fps == 24 &&
          r.frames == 9 && !strcmp(r.state, "stopped") && r.files == m.files);
    CHECK(sm_run_manifest_count(&r, SM_FRAME_PLY) == 3 && sm_run_manifest_count(&r, SM_FRAME_VTP) == 0 &&
          r.first[SM_FRAME_PNG] == 1 && r.last[SM_FRAME_PNG] == 1);
    for (int f = 0; f < 3; f++) {
        char name[32];
        snprintf(name, sizeof name, "frame_%04d.ply", f);
        touch(dir, name);
    }
    touch(dir, "frame_0001.png");
    touch(dir, "frames.pvd");
    touch(dir, "frame_0003.ply"); /* not listed */
    touch(dir, "diagnostics.csv"); /* not listed */
    int removed = 0;
    CHECK(sm_run_manifest_remove(dir, &r, &removed, err, sizeof err) == SM_OK);
    CHECK(removed == 6); /* 3 PLY, 1 PNG, frames.pvd, the manifest */
    CHECK(!exists(dir, "frame_0000.ply") && !exists(dir, "frame_0001.png") && !exists(dir, "frames.pvd") &&
          !exists(dir, SM_RUN_MANIFEST_NAME));
    CHECK(exists(dir, "frame_0003.ply") && exists(dir, "diagnostics.csv"));
    /* a folder without one: the frame files found */
    int nfound = 0;
    CHECK(sm_run_manifest_scan(dir, &r, &nfound, err, sizeof err) == SM_OK && nfound == 1 &&
          r.first[SM_FRAME_PLY] == 3 && r.last[SM_FRAME_PLY] == 3);
    CHECK(sm_run_manifest_read(dir, &r, &found, err, sizeof err) == SM_ERR_IO && !found);
    char path[512];
    snprintf(path, sizeof path, "%s/%s", dir, SM_RUN_MANIFEST_NAME);
    FILE *f = fopen(path, "w");
    if (f) {
        fputs("sandmpm-run 1\nscene x\nframe_files ply 5 2\n", f);
        fclose(f);
    }
    CHECK(sm_run_manifest_read(dir, &r, &found, err, sizeof err) == SM_ERR_INVALID && found && strstr(err, ":3:"));
    printf("run manifest: written, read back, %d listed files removed, a malformed line named (%s)\n", removed, err);
    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    CHECK(system(cmd) == 0);
}

/* outputs.up = "z": the same file but "comment up z" and positions and velocities (x, -z, y); the
 * frame reader turns them back: the frame read equals the y-up file's. */
static void check_z_up(const sm_world *w, const char *yup, int dim) {
    char err[512];
    const char *zup = dim == 2 ? "test_output_zup_2d.ply" : "test_output_zup_3d.ply";
    CHECK(sm_write_ply(w, zup, 1, err, sizeof err) == SM_OK);
    size_t ly = 0, lz = 0;
    unsigned char *by = slurp(yup, &ly), *bz = slurp(zup, &lz);
    CHECK(by && bz && ly == lz);
    if (!by || !bz || ly != lz) {
        free(by), free(bz);
        return;
    }
    const char *hy = strstr((const char *)by, "comment up y\n"), *hz = strstr((const char *)bz, "comment up z\n");
    CHECK(hy != NULL && hz != NULL && hy - (const char *)by == hz - (const char *)bz);
    const size_t hl = (size_t)(strstr((const char *)by, "end_header\n") - (const char *)by) + strlen("end_header\n");
    size_t bad = 0, n = (ly - hl) / 46;
    for (size_t k = 0; k < n; k++) {
        const unsigned char *ry = by + hl + 46 * k, *rz = bz + hl + 46 * k;
        for (int o = 0; o < 24; o += 12) { /* position, velocity */
            bad += f32(rz + o) != f32(ry + o);
            bad += f32(rz + o + 4) != -f32(ry + o + 8);
            bad += f32(rz + o + 8) != f32(ry + o + 4);
        }
        bad += memcmp(rz + 24, ry + 24, 22) != 0;
    }
    printf("%dD z-up PLY: %zu records, %zu differences from (x, -z, y)\n", dim, n, bad);
    CHECK(n > 0 && bad == 0);
    sm_frame fy, fz;
    CHECK(sm_ply_read(yup, &fy, err, sizeof err) == SM_OK);
    CHECK(sm_ply_read(zup, &fz, err, sizeof err) == SM_OK);
    CHECK(fy.n == fz.n && fy.dim == fz.dim && fz.dim == dim);
    for (size_t i = 0; i < fy.n && fy.n == fz.n; i++)
        for (int a = 0; a < 3; a++) {
            bad += fy.x[3 * i + a] != fz.x[3 * i + a];
            bad += fy.v[3 * i + a] != fz.v[3 * i + a];
        }
    CHECK(bad == 0);
    sm_frame_free(&fy);
    sm_frame_free(&fz);
    free(by);
    free(bz);
    remove(zup);
}

int main(void) {
    for (int dim = 2; dim <= 3; dim++) {
        sm_world *w = make(dim);
        sm_particles_view pv;
        sm_world_particles(w, &pv);
        CHECK(pv.n > 100);
        double qmax = 0;
        for (size_t i = 0; i < pv.n; i++) qmax = fmax(qmax, pv.q[i]);
        CHECK(qmax > 0); /* plasticity happened: q is worth checking */
        /* by_id[k]: the storage index of the particle with id k; the steps have reordered storage
         * (else the id order would not be tested). */
        size_t *by_id = malloc(pv.n * sizeof *by_id), moved = 0;
        for (size_t k = 0; k < pv.n; k++) by_id[k] = SIZE_MAX;
        for (size_t i = 0; i < pv.n; i++) {
            CHECK(pv.id[i] < pv.n && by_id[pv.id[i]] == SIZE_MAX);
            if (pv.id[i] < pv.n) by_id[pv.id[i]] = i;
            moved += pv.id[i] != i;
        }
        CHECK(moved > pv.n / 10);
        char err[512];
        const char *ply = dim == 2 ? "test_output_2d.ply" : "test_output_3d.ply";
        const char *vtp = dim == 2 ? "test_output_2d.vtp" : "test_output_3d.vtp";
        CHECK(sm_write_ply(w, ply, 0, err, sizeof err) == SM_OK);
        CHECK(sm_write_vtp(w, vtp, 0, err, sizeof err) == SM_OK);
        char tmpname[256];
        CHECK(sm_temp_name(tmpname, sizeof tmpname, ply, (long)getpid()) == 0);
        FILE *t = fopen(tmpname, "rb");
        CHECK(t == NULL);
        if (t) fclose(t);

        /* --- PLY --- */
        size_t len = 0;
        unsigned char *b = slurp(ply, &len);
        CHECK(b != NULL);
        if (!b) continue;
        const char *hdr_end = strstr((const char *)b, "end_header\n");
        CHECK(hdr_end != NULL);
        char expect_hdr[1024];
        snprintf(expect_hdr, sizeof expect_hdr,
                 "ply\nformat binary_little_endian 1.0\ncomment sandmpm %s\ncomment dim %d\n"
                 "comment domain %.9g %.9g %.9g %.9g %.9g %.9g\ncomment up y\nelement vertex %zu\n"
                 "property float x\nproperty float y\nproperty float z\n"
                 "property float vx\nproperty float vy\nproperty float vz\n"
                 "property ushort material\nproperty float q\nproperty float friction_angle\nproperty float Je\n"
                 "property float volume\nproperty uint id\nend_header\n",
                 sm_version(), dim, sm_world_get_def(w)->domain_min[0], sm_world_get_def(w)->domain_min[1],
                 sm_world_get_def(w)->domain_min[2], sm_world_get_def(w)->domain_max[0], sm_world_get_def(w)->domain_max[1],
                 sm_world_get_def(w)->domain_max[2], pv.n);
        size_t hl = (size_t)(hdr_end - (const char *)b) + strlen("end_header\n");
        CHECK(hl == strlen(expect_hdr) && memcmp(b, expect_hdr, hl) == 0);
        const size_t rec = 42 + 4;
        CHECK(len == hl + rec * pv.n);
        size_t bad = 0;
        for (size_t k = 0; k < pv.n && len == hl + rec * pv.n; k++) {
            const unsigned char *r = b + hl + rec * k;
            const size_t i = by_id[k];
            uint32_t id;
            memcpy(&id, r + 42, 4);
            bad += id != (uint32_t)k;
            for (int a = 0; a < 3; a++) {
                float ex = a < dim ? (float)XPOS(pv, i, a) : 0.0f, ev = a < dim ? (float)pv.v[i * dim + a] : 0.0f;
                bad += memcmp(r + 4 * a, &ex, 4) != 0;
                bad += memcmp(r + 12 + 4 * a, &ev, 4) != 0;
            }
            bad += (uint16_t)(r[24] | (r[25] << 8)) != pv.material[i];
            bad += f32(r + 26) != (float)pv.q[i];
            bad += f32(r + 30) != (float)sm_world_particle_friction_angle(w, i);
            bad += f32(r + 34) != (float)det(pv.F + i * dim * dim, dim);
            bad += f32(r + 38) != (float)pv.vol0[i];
        }
        CHECK(bad == 0);
        free(b);
        check_z_up(w, ply, dim);

        /* --- VTP --- */
        b = slurp(vtp, &len);
        CHECK(b != NULL);
        if (!b) continue;
        const char *names[10] = {"velocity", "material", "q", "friction_angle", "Je", "volume", "id", "Points", "connectivity", "offsets"};
        const size_t sizes[10] = {12, 2, 4, 4, 4, 4, 4, 12, 8, 8};
        unsigned char *data = (unsigned char *)strstr((char *)b, "<AppendedData encoding=\"raw\">\n_");
        CHECK(data != NULL);
        if (!data) continue;
        data += strlen("<AppendedData encoding=\"raw\">\n_");
        for (int k = 0; k < 10; k++) {
            char key[128];
            snprintf(key, sizeof key, "Name=\"%s\"", names[k]);
            char *at = strstr((char *)b, key);
            CHECK(at != NULL && at < (char *)data);
            if (!at) continue;
            char *o = strstr(at, "offset=\"");
            unsigned long long off = strtoull(o + 8, NULL, 10);
            uint64_t blen;
            memcpy(&blen, data + off, 8);
            CHECK(blen == sizes[k] * pv.n);
            const unsigned char *arr = data + off + 8;
            size_t mism = 0;
            for (size_t j = 0; j < pv.n; j++) { /* j: the vertex, i: the particle with id j */
                const size_t i = by_id[j];
                switch (k) {
                case 0:
                case 7:
                    for (int a = 0; a < 3; a++) {
                        float e = a >= dim ? 0.0f : k == 0 ? (float)pv.v[i * dim + a] : (float)XPOS(pv, i, a);
                        mism += memcmp(arr + 12 * j + 4 * a, &e, 4) != 0;
                    }
                    break;
                case 1: mism += memcmp(arr + 2 * j, &pv.material[i], 2) != 0; break;
                case 2: mism += f32(arr + 4 * j) != (float)pv.q[i]; break;
                case 3: mism += f32(arr + 4 * j) != (float)sm_world_particle_friction_angle(w, i); break;
                case 4: mism += f32(arr + 4 * j) != (float)det(pv.F + i * dim * dim, dim); break;
                case 5: mism += f32(arr + 4 * j) != (float)pv.vol0[i]; break;
                case 6: {
                    uint32_t v;
                    memcpy(&v, arr + 4 * j, 4);
                    mism += v != (uint32_t)j;
                    break;
                }
                case 8:
                case 9: {
                    int64_t v;
                    memcpy(&v, arr + 8 * j, 8);
                    mism += v != (int64_t)j + (k == 9);
                    break;
                }
                }
            }
            if (mism) fprintf(stderr, "array %s: %zu mismatches\n", names[k], mism);
            CHECK(mism == 0);
        }
        CHECK(strstr((char *)b, "NumberOfPoints=") != NULL);
        free(b);
        /* A .pvd collection lists the files with times. */
        const char *files[2] = {"a.vtp", "b.vtp"};
        const double times[2] = {0, 0.5};
        CHECK(sm_write_pvd("test_output.pvd", files, times, 2, err, sizeof err) == SM_OK);
        b = slurp("test_output.pvd", &len);
        CHECK(b && strstr((char *)b, "timestep=\"0.5\"") && strstr((char *)b, "file=\"b.vtp\""));
        free(b);
        /* Unwritable path: an error message, no crash. */
        CHECK(sm_write_ply(w, "/nonexistent-dir/x.ply", 0, err, sizeof err) == SM_ERR_IO);
        CHECK(strstr(err, "No such file or directory") != NULL); /* the reason */
        CHECK(strstr(err, "/nonexistent-dir/x.ply") != NULL);
        printf("%dD: %zu particles written and read back in id order (%zu not at their id's index in storage; PLY %zu "
               "bytes per particle)\n", dim, pv.n, moved, rec);
        free(by_id);
        follow_ids(w, dim);
        sm_world_destroy(w);
    }
    test_run_manifest();
    return sm_test_summary("test_output");
}
