/* The preview renderer and the PLY reader.
 *
 * Scene: a 0.2 m cube of 20^3 particles (spacing 1 cm, V0 = 1e-6 m^3, radius 6.2 mm) standing on
 * the ground y = 0 in the domain [-0.5, 0.5] x [0, 0.5] x [-0.5, 0.5]; light from +x at 63.4 deg
 * elevation (direction (1, 2, 0)), so the cube's shadow covers -0.2 < x < -0.1, |z| < 0.1 on the
 * ground; camera at (0, 0.6, 1) looking at (0, 0.05, 0), fov 45 deg, 320 x 240.
 * Checks: image size; the non-background fraction agrees with a ray cast of the same geometry
 * (ground quad = domain footprint grown by 5%, cube = particle box + radius) to within 0.02
 * absolute (cube alone: within 10% relative); ground in the shadow is darker than lit ground of the
 * same checker colour (< 0.75 of it); bytes identical for 1, 2 and 3 threads and across runs;
 * colliders drawn, casting shadows; a container does not hide the sand inside it; 2D disks cover
 * their area; colour modes; tones depend only on (seed, id); the PNG round trip; the PLY reader:
 * round trip with sm_write_ply (3D and 2D), properties in any order and types, ascii and
 * big-endian, and clear errors with codes 4 (missing) and 2 (truncated, garbage, bad header). */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "app/io/files.h"
#include "app/io/ply.h"
#include "app/io/png.h"
#include "app/render.h"
#include "test_util.h"

#define W 320
#define H 240
#define PI_T 3.14159265358979323846

#define CHECK_MSG(msg, sub)                                                                       \
    do {                                                                                          \
        int ok_ = strstr((msg), (sub)) != NULL;                                                   \
        if (!ok_) fprintf(stderr, "message \"%s\" lacks \"%s\"\n", (msg), (sub));                 \
        CHECK(ok_);                                                                               \
    } while (0)

static char tmpdir[256];

static void tmp_path(char *buf, size_t n, const char *name) { snprintf(buf, n, "%s/%s", tmpdir, name); }

/* A frame of m^3 particles: a cube of side m*h, bottom at y = 0, centred on x = z = 0. */
static void make_cube(sm_frame *f, int m, double h) {
    memset(f, 0, sizeof *f);
    size_t n = (size_t)m * m * m;
    f->n = n;
    f->dim = 3;
    f->x = calloc(3 * n, sizeof(float));
    f->v = calloc(3 * n, sizeof(float));
    f->q = calloc(n, sizeof(float));
    f->material = calloc(n, sizeof(uint16_t));
    f->volume = calloc(n, sizeof(float));
    size_t k = 0;
    for (int i = 0; i < m; i++)
        for (int j = 0; j < m; j++)
            for (int l = 0; l < m; l++, k++) {
                f->x[3 * k] = (float)(-0.5 * m * h + (i + 0.5) * h);
                f->x[3 * k + 1] = (float)((j + 0.5) * h);
                f->x[3 * k + 2] = (float)(-0.5 * m * h + (l + 0.5) * h);
                f->v[3 * k] = (float)(0.1 * j);
                f->q[k] = (float)(0.01 * i);
                f->volume[k] = (float)(h * h * h);
            }
    f->has_velocity = f->has_q = f->has_material = 1;
}

static sm_render_opts scene_opts(void) {
    sm_render_opts o = sm_render_opts_default();
    o.width = W;
    o.height = H;
    o.has_domain = 1;
    o.domain_min[0] = o.domain_min[2] = -0.5;
    o.domain_max[0] = o.domain_max[2] = 0.5;
    o.domain_min[1] = 0;
    o.domain_max[1] = 0.5;
    o.ground = SM_GROUND_AT;
    o.ground_y = 0;
    o.light_dir[0] = 1;
    o.light_dir[1] = 2;
    o.light_dir[2] = 0;
    o.has_camera = 1;
    o.camera.eye[0] = 0;
    o.camera.eye[1] = 0.6;
    o.camera.eye[2] = 1.0;
    o.camera.target[0] = 0;
    o.camera.target[1] = 0.05;
    o.camera.target[2] = 0;
    o.camera.up[0] = 0;
    o.camera.up[1] = 1;
    o.camera.up[2] = 0;
    o.camera.fov_deg = 45;
    o.threads = 1;
    return o;
}

/* The test's own camera model: the documented perspective convention. */
typedef struct tcam {
    double eye[3], r[3], u[3], f[3], focal;
} tcam;

static void norm(double a[3]) {
    double n = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    a[0] /= n;
    a[1] /= n;
    a[2] /= n;
}

static tcam make_cam(const sm_camera *c) {
    tcam t;
    for (int k = 0; k < 3; k++) {
        t.eye[k] = c->eye[k];
        t.f[k] = c->target[k] - c->eye[k];
    }
    norm(t.f);
    t.r[0] = t.f[1] * c->up[2] - t.f[2] * c->up[1];
    t.r[1] = t.f[2] * c->up[0] - t.f[0] * c->up[2];
    t.r[2] = t.f[0] * c->up[1] - t.f[1] * c->up[0];
    norm(t.r);
    t.u[0] = t.r[1] * t.f[2] - t.r[2] * t.f[1];
    t.u[1] = t.r[2] * t.f[0] - t.r[0] * t.f[2];
    t.u[2] = t.r[0] * t.f[1] - t.r[1] * t.f[0];
    t.focal = 0.5 * H / tan(0.5 * c->fov_deg * PI_T / 180);
    return t;
}

static void project(const tcam *c, const double p[3], int *px, int *py) {
    double d[3] = {p[0] - c->eye[0], p[1] - c->eye[1], p[2] - c->eye[2]};
    double x = d[0] * c->r[0] + d[1] * c->r[1] + d[2] * c->r[2];
    double y = d[0] * c->u[0] + d[1] * c->u[1] + d[2] * c->u[2];
    double z = d[0] * c->f[0] + d[1] * c->f[1] + d[2] * c->f[2];
    *px = (int)floor(0.5 * W + c->focal * x / z);
    *py = (int)floor(0.5 * H - c->focal * y / z);
}

/* Does the ray through pixel (x, y) hit the box [lo, hi]? */
static int ray_hits_box(const tcam *c, int x, int y, const double lo[3], const double hi[3]) {
    double a = (x + 0.5 - 0.5 * W) / c->focal, b = (0.5 * H - (y + 0.5)) / c->focal;
    double d[3], t0 = 0, t1 = 1e30;
    for (int k = 0; k < 3; k++) d[k] = c->f[k] + a * c->r[k] + b * c->u[k];
    for (int k = 0; k < 3; k++) {
        if (d[k] == 0) {
            if (c->eye[k] < lo[k] || c->eye[k] > hi[k]) return 0;
            continue;
        }
        double ta = (lo[k] - c->eye[k]) / d[k], tb = (hi[k] - c->eye[k]) / d[k];
        if (ta > tb) {
            double t = ta;
            ta = tb;
            tb = t;
        }
        if (ta > t0) t0 = ta;
        if (tb < t1) t1 = tb;
    }
    return t0 <= t1;
}

/* Mean of r+g+b over the 5x5 pixels around (px, py). */
static double mean_bright(const uint8_t *img, int px, int py) {
    double s = 0;
    int n = 0;
    for (int y = py - 2; y <= py + 2; y++)
        for (int x = px - 2; x <= px + 2; x++) {
            if (x < 0 || y < 0 || x >= W || y >= H) continue;
            const uint8_t *p = img + 3 * ((size_t)y * W + (size_t)x);
            s += p[0] + p[1] + p[2];
            n++;
        }
    return n ? s / n : -1;
}

static double foreground_fraction(const uint8_t *img, const uint8_t *bg, int w, int h) {
    size_t c = 0, n = (size_t)w * (size_t)h;
    for (size_t i = 0; i < n; i++) c += memcmp(img + 3 * i, bg + 3 * i, 3) != 0;
    return (double)c / (double)n;
}

static sm_status render(const sm_frame *f, const sm_render_opts *o, uint8_t *img) {
    char err[256];
    sm_status rc = sm_render(f, o, img, err, sizeof err);
    if (rc != SM_OK) fprintf(stderr, "render: %s\n", err);
    return rc;
}

static void test_scene(void) {
    sm_frame f;
    make_cube(&f, 20, 0.01);
    sm_render_opts o = scene_opts();
    uint8_t *img = malloc(W * H * 3), *img2 = malloc(W * H * 3), *bg = malloc(W * H * 3);
    char err[256];
    /* background: no particles, no ground */
    sm_frame empty;
    memset(&empty, 0, sizeof empty);
    empty.dim = 3;
    sm_render_opts ob = o;
    ob.ground = SM_GROUND_NONE;
    CHECK(render(&empty, &ob, bg) == SM_OK);
    /* the background is a vertical gradient: rows differ, columns do not */
    CHECK(memcmp(bg, bg + 3 * (W - 1), 3) == 0);
    CHECK(memcmp(bg, bg + 3 * (size_t)W * (H - 1), 3) != 0);

    tcam cam = make_cam(&o.camera);
    const double r = cbrt(3e-6 / (4 * PI_T));
    /* particle centres span [-0.095, 0.095] x [0.005, 0.195] x [-0.095, 0.095] */
    const double clo[3] = {-0.095 - r, 0.005 - r, -0.095 - r}, chi[3] = {0.095 + r, 0.195 + r, 0.095 + r};
    const double glo[3] = {-0.55, -1e-9, -0.55}, ghi[3] = {0.55, 1e-9, 0.55};

    /* cube alone */
    CHECK(render(&f, &ob, img) == SM_OK);
    size_t expect_cube = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) expect_cube += ray_hits_box(&cam, x, y, clo, chi);
    double fc = foreground_fraction(img, bg, W, H), ec = (double)expect_cube / (W * H);
    printf("cube only: non-background %.4f, ray-cast box %.4f\n", fc, ec);
    CHECK(ec > 0.03 && ec < 0.3);
    CHECK_REL(fc, ec, 0.10, 0.0);

    /* cube and ground */
    CHECK(render(&f, &o, img) == SM_OK);
    size_t expect = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) expect += ray_hits_box(&cam, x, y, clo, chi) || ray_hits_box(&cam, x, y, glo, ghi);
    double fg = foreground_fraction(img, bg, W, H), eg = (double)expect / (W * H);
    printf("cube and ground: non-background %.4f, ray-cast %.4f\n", fg, eg);
    CHECK(eg > 0.3 && eg < 0.8);
    CHECK_NEAR(fg, eg, 0.02);

    /* shadow: ground at x = -0.15 (in the cube's shadow) vs x = -0.35 and x = 0.25 (lit); all
     * three are centres of light checker cells (0.1 m cells, even index sum) */
    const double ps[3] = {-0.15, 0, 0.05}, pl1[3] = {-0.35, 0, 0.05}, pl2[3] = {0.25, 0, 0.05};
    int sx, sy, l1x, l1y, l2x, l2y;
    project(&cam, ps, &sx, &sy);
    project(&cam, pl1, &l1x, &l1y);
    project(&cam, pl2, &l2x, &l2y);
    double bs = mean_bright(img, sx, sy), b1 = mean_bright(img, l1x, l1y), b2 = mean_bright(img, l2x, l2y);
    printf("ground brightness: shadow %.1f, lit %.1f and %.1f (of 765)\n", bs, b1, b2);
    CHECK(bs > 0);
    CHECK(bs < 0.75 * b1);
    CHECK(bs < 0.75 * b2);
    CHECK_REL(b1, b2, 0.02, 1);
    /* without shadows the same spot is lit */
    sm_render_opts ons = o;
    ons.shadows = 0;
    CHECK(render(&f, &ons, img2) == SM_OK);
    CHECK_REL(mean_bright(img2, sx, sy), b1, 0.02, 1);

    /* the cube's top is sand-brown: r > g > b */
    int tx, ty;
    const double top[3] = {0, 0.2, 0};
    project(&cam, top, &tx, &ty);
    const uint8_t *pt = img + 3 * ((size_t)ty * W + (size_t)tx);
    CHECK(pt[0] > pt[1] && pt[1] > pt[2]);

    /* determinism: threads and runs */
    for (int t = 2; t <= 3; t++) {
        sm_render_opts ot = o;
        ot.threads = t;
        CHECK(render(&f, &ot, img2) == SM_OK);
        CHECK(memcmp(img, img2, W * H * 3) == 0);
    }
    CHECK(render(&f, &o, img2) == SM_OK);
    CHECK(memcmp(img, img2, W * H * 3) == 0);
    sm_render_opts o0 = o;
    o0.threads = 0; /* OpenMP's default */
    CHECK(render(&f, &o0, img2) == SM_OK);
    CHECK(memcmp(img, img2, W * H * 3) == 0);

    /* the image size: a non-square size renders, and writes exactly width*height*3 bytes */
    {
        sm_render_opts os = o;
        os.width = 97;
        os.height = 31;
        uint8_t *small = malloc(97 * 31 * 3 + 16);
        memset(small, 0xAB, 97 * 31 * 3 + 16);
        CHECK(sm_render(&f, &os, small, err, sizeof err) == SM_OK);
        int tail_ok = 1;
        for (int i = 0; i < 16; i++) tail_ok &= small[97 * 31 * 3 + i] == 0xAB;
        CHECK(tail_ok);
        free(small);
    }

    /* PNG round trip */
    char path[512];
    tmp_path(path, sizeof path, "scene.png");
    CHECK(sm_png_write(path, W, H, img, err, sizeof err) == SM_OK);
    int rw = 0, rh = 0;
    uint8_t *back = NULL;
    CHECK(sm_png_read(path, &rw, &rh, &back, err, sizeof err) == SM_OK);
    CHECK(rw == W && rh == H);
    CHECK(back && memcmp(back, img, W * H * 3) == 0);
    free(back);
    char tmpname[600];
    CHECK(sm_temp_name(tmpname, sizeof tmpname, path, (long)getpid()) == 0);
    CHECK(access(tmpname, F_OK) != 0); /* atomic: no temporary left */
    CHECK(sm_png_write("/nonexistent-dir/x.png", W, H, img, err, sizeof err) == SM_ERR_IO);
    CHECK_MSG(err, "/nonexistent-dir/x.png");
    CHECK(sm_png_read("/nonexistent-dir/x.png", &rw, &rh, &back, err, sizeof err) == SM_ERR_IO);
    /* a PLY is not a PNG */
    {
        char p2[512];
        tmp_path(p2, sizeof p2, "notpng.png");
        FILE *fp = fopen(p2, "wb");
        fputs("ply\nformat ascii 1.0\n", fp);
        fclose(fp);
        CHECK(sm_png_read(p2, &rw, &rh, &back, err, sizeof err) == SM_ERR_INVALID);
        /* a truncated PNG */
        FILE *in = fopen(path, "rb");
        unsigned char buf[300];
        size_t got = fread(buf, 1, sizeof buf, in);
        fclose(in);
        fp = fopen(p2, "wb");
        fwrite(buf, 1, got, fp);
        fclose(fp);
        CHECK(sm_png_read(p2, &rw, &rh, &back, err, sizeof err) == SM_ERR_INVALID);
        CHECK(back == NULL);
    }

    /* colour modes: all render, differ from the sand tones; material 1 is blue */
    for (size_t i = 0; i < f.n; i++) f.material[i] = 1;
    sm_render_opts om = o;
    om.color = SM_COLOR_MATERIAL;
    CHECK(render(&f, &om, img2) == SM_OK);
    pt = img2 + 3 * ((size_t)ty * W + (size_t)tx);
    CHECK(pt[2] > pt[0]);
    om.color = SM_COLOR_SPEED;
    CHECK(render(&f, &om, img2) == SM_OK);
    CHECK(memcmp(img, img2, W * H * 3) != 0);
    om.color_range[0] = 0;
    om.color_range[1] = 10;
    CHECK(render(&f, &om, img2) == SM_OK);
    om.color = SM_COLOR_Q;
    CHECK(render(&f, &om, img2) == SM_OK);
    CHECK(memcmp(img, img2, W * H * 3) != 0);

    /* tones: a function of (seed, id) only, brown (r > g > b), vary with the seed */
    int brown = 1, differ = 0;
    for (uint64_t id = 0; id < 200; id++) {
        float a[3], b[3], c[3];
        sm_render_tone(7, id, a);
        sm_render_tone(7, id, b);
        sm_render_tone(8, id, c);
        brown &= a[0] > a[1] && a[1] > a[2] && memcmp(a, b, sizeof a) == 0;
        differ += memcmp(a, c, sizeof a) != 0;
    }
    CHECK(brown);
    CHECK(differ > 150);
    /* with ids, a permuted frame looks the same (up to depth ties between particles) */
    {
        for (size_t i = 0; i < f.n; i++) f.material[i] = 0;
        sm_frame g;
        make_cube(&g, 20, 0.01);
        g.id = malloc(g.n * sizeof(uint32_t));
        f.id = malloc(f.n * sizeof(uint32_t));
        for (size_t i = 0; i < f.n; i++) {
            size_t j = f.n - 1 - i;
            f.id[i] = (uint32_t)i;
            g.id[j] = (uint32_t)i;
            memcpy(g.x + 3 * j, f.x + 3 * i, 3 * sizeof(float));
        }
        CHECK(render(&f, &o, img) == SM_OK);
        CHECK(render(&g, &o, img2) == SM_OK);
        size_t diff = 0;
        for (size_t i = 0; i < (size_t)W * H; i++) diff += memcmp(img + 3 * i, img2 + 3 * i, 3) != 0;
        printf("permuted frame with ids: %zu of %d pixels differ\n", diff, W * H);
        CHECK(diff < (size_t)W * H / 200);
        sm_frame_free(&g);
    }

    /* invalid options */
    sm_render_opts bad = o;
    bad.width = 0;
    CHECK(sm_render(&f, &bad, img, err, sizeof err) == SM_ERR_INVALID);
    CHECK_MSG(err, "width");
    bad = o;
    bad.ambient = 2;
    CHECK(sm_render(&f, &bad, img, err, sizeof err) == SM_ERR_INVALID);
    CHECK_MSG(err, "ambient");
    bad = o;
    sm_collider_def c0 = sm_collider_def_default();
    bad.colliders = &c0;
    bad.ncolliders = 1; /* shape_count 0 */
    CHECK(sm_render(&f, &bad, img, err, sizeof err) == SM_ERR_INVALID);
    CHECK_MSG(err, "colliders[0].shape_count");
    bad = o;
    bad.camera.target[1] = bad.camera.eye[1];
    bad.camera.target[2] = bad.camera.eye[2];
    CHECK(sm_render(&f, &bad, img, err, sizeof err) == SM_ERR_INVALID);
    CHECK_MSG(err, "camera");

    /* non-finite particles are skipped, a fitted camera and the auto ground work */
    f.x[0] = NAN;
    f.x[4] = INFINITY;
    f.volume[7] = -1;
    sm_render_opts oa = o;
    oa.has_camera = 0;
    oa.ground = SM_GROUND_AUTO;
    CHECK(render(&f, &oa, img) == SM_OK);
    double fa = foreground_fraction(img, bg, W, H);
    CHECK(fa > 0.1 && fa < 0.95);
    sm_camera fit = sm_render_fit_camera(&f, &oa);
    CHECK(fit.fov_deg > 0 && fit.eye[1] > fit.target[1]);
    /* no volumes: the radius option, or an estimate from the spacing */
    free(f.volume);
    f.volume = NULL;
    sm_render_opts orad = o;
    orad.radius = cbrt(3e-6 / (4 * PI_T));
    CHECK(render(&f, &orad, img) == SM_OK);
    CHECK(render(&f, &o, img2) == SM_OK);
    double fr = foreground_fraction(img, bg, W, H), fe = foreground_fraction(img2, bg, W, H);
    printf("no volumes: radius option %.4f, estimated radius %.4f\n", fr, fe);
    CHECK_NEAR(fr, eg, 0.02);
    CHECK_NEAR(fe, eg, 0.03);

    sm_frame_free(&f);
    sm_frame_free(&f); /* twice is fine */
    free(img);
    free(img2);
    free(bg);
}

/* Colliders: a sphere above the ground casts a shadow; a container does not hide the sand. */
static void test_colliders(void) {
    sm_frame f;
    make_cube(&f, 20, 0.01);
    sm_render_opts o = scene_opts();
    uint8_t *img = malloc(W * H * 3), *img2 = malloc(W * H * 3);
    tcam cam = make_cam(&o.camera);
    sm_collider_def c[2];
    c[0] = sm_collider_def_default();
    c[0].shape_count = 1;
    c[0].shapes[0] = sm_shape_default(SM_SHAPE_SPHERE);
    c[0].shapes[0].radius = 0.08;
    /* the sphere is placed by the pose: centre (0.3, 0.15, 0) */
    c[0].pose.position[0] = 0.3;
    c[0].pose.position[1] = 0.15;
    c[1] = sm_collider_def_default();
    c[1].shape_count = 1;
    c[1].inside_out = 1;
    c[1].shapes[0] = sm_shape_default(SM_SHAPE_BOX);
    c[1].shapes[0].center[1] = 0.3;
    c[1].shapes[0].half_extent[0] = c[1].shapes[0].half_extent[2] = 0.45;
    c[1].shapes[0].half_extent[1] = 0.3;
    o.colliders = c;
    o.ncolliders = 1;
    CHECK(render(&f, &o, img) == SM_OK);
    int x, y;
    const double ctr[3] = {0.3, 0.15, 0};
    project(&cam, ctr, &x, &y);
    const uint8_t *p = img + 3 * ((size_t)y * W + (size_t)x);
    CHECK(p[2] > p[0]); /* the collider's blue-grey, not sand or sky-free ground */
    const double ps[3] = {0.225, 0, 0.03}, pl[3] = {0.45, 0, 0.05};
    int sx, sy, lx, ly;
    project(&cam, ps, &sx, &sy);
    project(&cam, pl, &lx, &ly);
    double bs = mean_bright(img, sx, sy), bl = mean_bright(img, lx, ly);
    printf("sphere collider: ground in its shadow %.1f, lit %.1f\n", bs, bl);
    CHECK(bs < 0.75 * bl);
    /* a rotated pose moves the sphere: pose rotation applies to the shape centre */
    sm_collider_def cr = c[0];
    cr.pose.position[0] = 0;
    cr.pose.position[1] = 0.15;
    cr.shapes[0].center[0] = 0.3;             /* local offset along x ... */
    cr.pose.rotation[0] = cos(PI_T / 4);      /* ... turned 90 degrees about y: world (0, 0.15, -0.3) */
    cr.pose.rotation[2] = sin(PI_T / 4);
    o.colliders = &cr;
    CHECK(render(&f, &o, img2) == SM_OK);
    const double ctr2[3] = {0, 0.15, -0.3};
    project(&cam, ctr2, &x, &y);
    p = img2 + 3 * ((size_t)y * W + (size_t)x);
    CHECK(p[2] > p[0]);

    /* container: the sand inside stays visible, and so does its floor */
    o.colliders = &c[1];
    o.ncolliders = 1;
    CHECK(render(&f, &o, img2) == SM_OK);
    const double top[3] = {0, 0.2, 0};
    project(&cam, top, &x, &y);
    p = img2 + 3 * ((size_t)y * W + (size_t)x);
    CHECK(p[0] > p[1] && p[1] > p[2]);
    const double fl[3] = {0.3, 0, 0.2};
    project(&cam, fl, &x, &y);
    p = img2 + 3 * ((size_t)y * W + (size_t)x);
    CHECK(p[2] > p[0]); /* the container's floor (blue-grey) */
    /* deterministic with colliders too */
    o.colliders = c;
    o.ncolliders = 2;
    CHECK(render(&f, &o, img) == SM_OK);
    o.threads = 2;
    CHECK(render(&f, &o, img2) == SM_OK);
    CHECK(memcmp(img, img2, W * H * 3) == 0);
    sm_frame_free(&f);
    free(img);
    free(img2);
}

/* A block of 2D sand, 0.4 x 0.2 m on a square lattice of spacing s (V = s^2; 5 mm: 4 particles per
 * 1 cm cell, 1.5 pixels apart; 2 cm: 5.8 pixels apart): no background pixel inside it (its outline
 * less a pixel and a half). */
static void test_2d_packed(sm_render_opts *o, const uint8_t *bg, uint8_t *img, double s) {
    const double x0 = 0.3, y0 = 0.1;
    const int nx = (int)lround(0.4 / s), ny = (int)lround(0.2 / s);
    sm_frame f;
    memset(&f, 0, sizeof f);
    f.dim = 2;
    f.n = (size_t)(nx * ny);
    f.x = calloc(3 * f.n, sizeof(float));
    f.v = calloc(3 * f.n, sizeof(float));
    f.q = calloc(f.n, sizeof(float));
    f.material = calloc(f.n, sizeof(uint16_t));
    f.volume = calloc(f.n, sizeof(float));
    for (int j = 0; j < ny; j++)
        for (int i = 0; i < nx; i++) {
            const size_t k = (size_t)(j * nx + i);
            f.x[3 * k] = (float)(x0 + (i + 0.5) * s);
            f.x[3 * k + 1] = (float)(y0 + (j + 0.5) * s);
            f.volume[k] = (float)(s * s);
        }
    o->colliders = NULL;
    o->ncolliders = 0;
    o->ground = SM_GROUND_NONE;
    CHECK(render(&f, o, img) == SM_OK);
    /* the view as in test_2d: x in [-0.05, 1.05], y in [-0.1625, 0.6625] (0.825 m high) */
    const double px = H / 0.825, m = 1.5 / px;
    long inside = 0, sky = 0;
    for (int py = 0; py < H; py++)
        for (int pxl = 0; pxl < W; pxl++) {
            const double x = -0.05 + (pxl + 0.5) / px, y = 0.6625 - (py + 0.5) / px;
            if (x < x0 + m || x > x0 + nx * s - m || y < y0 + m || y > y0 + ny * s - m) continue;
            inside++;
            sky += !memcmp(img + 3 * (py * W + pxl), bg + 3 * (py * W + pxl), 3);
        }
    printf("2D packed sand, spacing %g m: %ld of %ld pixels inside the block show the background\n", s, sky, inside);
    CHECK(inside > 1000);
    CHECK(sky == 0);
    sm_frame_free(&f);
}

/* 2D: a particle of area V is a disk of radius sqrt(V / 2) (the circle around its square); ten
 * apart cover that area; packed sand (a square lattice of spacing s, V = s^2) leaves no background
 * inside the block; colliders and ground drawn. */
static void test_2d(void) {
    sm_frame f;
    memset(&f, 0, sizeof f);
    f.dim = 2;
    f.n = 10;
    f.x = calloc(30, sizeof(float));
    f.v = calloc(30, sizeof(float));
    f.q = calloc(10, sizeof(float));
    f.material = calloc(10, sizeof(uint16_t));
    f.volume = calloc(10, sizeof(float));
    const double r = 0.02;
    for (int i = 0; i < 10; i++) {
        f.x[3 * i] = (float)(0.05 + 0.1 * i);
        f.x[3 * i + 1] = (float)(0.1 + 0.03 * i);
        f.volume[i] = (float)(2 * r * r);
    }
    sm_render_opts o = sm_render_opts_default();
    o.width = W;
    o.height = H;
    o.threads = 1;
    o.has_domain = 1;
    o.domain_max[0] = 1;
    o.domain_max[1] = 0.5;
    o.ground = SM_GROUND_NONE;
    uint8_t *img = malloc(W * H * 3), *bg = malloc(W * H * 3), *img2 = malloc(W * H * 3);
    sm_frame empty = f;
    empty.n = 0;
    CHECK(render(&empty, &o, bg) == SM_OK);
    CHECK(render(&f, &o, img) == SM_OK);
    /* view: the domain grown by 5% (1.1 x 0.55 m) fitted to 4:3 -> 0.825 m high */
    const double px = H / 0.825;
    double expect = 10 * PI_T * (r * px) * (r * px) / (W * H);
    double got = foreground_fraction(img, bg, W, H);
    printf("2D disks: non-background %.5f, expected %.5f\n", got, expect);
    CHECK_REL(got, expect, 0.08, 0);
    o.threads = 2;
    CHECK(render(&f, &o, img2) == SM_OK);
    CHECK(memcmp(img, img2, W * H * 3) == 0);
    /* the ground and a container */
    sm_collider_def c = sm_collider_def_default();
    c.shape_count = 1;
    c.inside_out = 1;
    c.shapes[0] = sm_shape_default(SM_SHAPE_BOX);
    c.shapes[0].center[0] = 0.5;
    c.shapes[0].center[1] = 0.3;
    c.shapes[0].half_extent[0] = 0.45;
    c.shapes[0].half_extent[1] = 0.3;
    o.colliders = &c;
    o.ncolliders = 1;
    o.ground = SM_GROUND_AUTO;
    CHECK(render(&f, &o, img2) == SM_OK);
    double g2 = foreground_fraction(img2, bg, W, H);
    CHECK(g2 > got + 0.02 && g2 < 0.6); /* walls and ground added, the inside stays free */
    sm_frame_free(&f);
    test_2d_packed(&o, bg, img, 0.005);
    test_2d_packed(&o, bg, img, 0.02);
    free(img);
    free(img2);
    free(bg);
}

/* ------------------------------------------------------------------------------------------ */
/* PLY reader                                                                                   */

static void write_file(const char *path, const void *data, size_t n) {
    FILE *fp = fopen(path, "wb");
    if (!fp) return;
    fwrite(data, 1, n, fp);
    fclose(fp);
}

static sm_world *make_world(int dim) {
    sm_world_def def = sm_world_def_default();
    def.dim = dim;
    def.dx = 0.05;
    sm_world *w = NULL;
    char err[256];
    if (sm_world_create(&def, &w, err, sizeof err) != SM_OK) return NULL;
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
    sd.ppc = 4;
    sd.velocity[0] = 0.3;
    sd.velocity[1] = -1;
    sm_world_seed_shape(w, &b, &sd, NULL);
    sm_shape s = sm_shape_default(SM_SHAPE_SPHERE);
    s.center[0] = 0.5;
    s.center[1] = 0.7;
    s.center[2] = 0.5;
    s.radius = 0.08;
    sd.material = el;
    sd.velocity[0] = 0;
    sm_world_seed_shape(w, &s, &sd, NULL);
    for (int k = 1; k <= 10; k++) sm_world_advance(w, k * 0.002); /* non-trivial v, q */
    return w;
}

static void test_ply_roundtrip(int dim) {
    sm_world *w = make_world(dim);
    CHECK(w != NULL);
    if (!w) return;
    char path[512], err[512];
    tmp_path(path, sizeof path, dim == 3 ? "rt3.ply" : "rt2.ply");
    CHECK(sm_write_ply(w, path, 0, err, sizeof err) == SM_OK);
    sm_frame f;
    CHECK(sm_ply_read(path, &f, err, sizeof err) == SM_OK);
    sm_particles_view pv;
    sm_world_particles(w, &pv);
    CHECK(f.n == pv.n && pv.n > 100);
    CHECK(f.dim == dim);
    CHECK(f.has_velocity && f.has_q && f.has_material);
    CHECK(f.volume != NULL);
    int ok = f.n == pv.n && f.id != NULL, q_nonzero = 0, mat1 = 0;
    size_t *at = malloc((pv.n ? pv.n : 1) * sizeof *at); /* at[id]: storage index; frames are in id order */
    for (size_t i = 0; at && i < pv.n; i++) ok &= pv.id[i] < pv.n && ((at[pv.id[i]] = i), 1);
    for (size_t k = 0; ok && at && k < pv.n; k++) {
        const size_t i = at[k];
        ok &= f.id[k] == (uint32_t)k;
        for (int a = 0; a < 3; a++) {
            float xe = a < dim ? (float)pv.x[i * (size_t)dim + (size_t)a] : 0.0f;
            float ve = a < dim ? (float)pv.v[i * (size_t)dim + (size_t)a] : 0.0f;
            ok &= f.x[3 * k + (size_t)a] == xe && f.v[3 * k + (size_t)a] == ve;
        }
        ok &= f.material[k] == pv.material[i];
        ok &= f.q[k] == (float)pv.q[i];
        ok &= f.volume[k] == (float)pv.vol0[i];
        q_nonzero += pv.q[i] != 0;
        mat1 += pv.material[i] == 1;
    }
    free(at);
    CHECK(ok);
    CHECK(mat1 > 0);
    printf("PLY round trip %dD: %zu particles, %d with q != 0\n", dim, f.n, q_nonzero);
    /* the frame's domain comes from the header, if the writer records it */
    if (f.has_domain) {
        const sm_world_def *d = sm_world_get_def(w);
        CHECK(f.domain_min[0] == d->domain_min[0] && f.domain_max[1] == d->domain_max[1]);
    }
    /* and from the world directly */
    sm_frame g;
    CHECK(sm_frame_from_world(w, &g, err, sizeof err) == SM_OK);
    CHECK(g.n == f.n && g.dim == dim && g.has_domain);
    CHECK(g.n > 0 && memcmp(g.x, f.x, 3 * f.n * sizeof(float)) == 0);
    CHECK(g.n > 0 && memcmp(g.volume, f.volume, f.n * sizeof(float)) == 0);
    /* a frame read from the file renders */
    sm_render_opts o = sm_render_opts_default();
    o.width = 64;
    o.height = 48;
    uint8_t img[64 * 48 * 3];
    CHECK(sm_render(&f, &o, img, err, sizeof err) == SM_OK);
    char png[512];
    tmp_path(png, sizeof png, "rt.png");
    CHECK(sm_render_ply_to_png(path, png, &o, err, sizeof err) == SM_OK);
    /* truncated: the header and half the data */
    FILE *fp = fopen(path, "rb");
    fseek(fp, 0, SEEK_END);
    long len = ftell(fp);
    fseek(fp, 0, SEEK_SET);
    unsigned char *buf = malloc((size_t)len);
    CHECK(fread(buf, 1, (size_t)len, fp) == (size_t)len);
    fclose(fp);
    char tpath[512];
    tmp_path(tpath, sizeof tpath, "trunc.ply");
    write_file(tpath, buf, (size_t)len / 2);
    sm_frame t;
    CHECK(sm_ply_read(tpath, &t, err, sizeof err) == SM_ERR_INVALID);
    CHECK_MSG(err, tpath);
    CHECK_MSG(err, "truncated");
    CHECK(t.n == 0 && t.x == NULL);
    CHECK(sm_render_ply_to_png(tpath, png, &o, err, sizeof err) == SM_ERR_INVALID);
    /* one byte short */
    write_file(tpath, buf, (size_t)len - 1);
    CHECK(sm_ply_read(tpath, &t, err, sizeof err) == SM_ERR_INVALID);
    /* header cut in the middle */
    write_file(tpath, buf, 60);
    CHECK(sm_ply_read(tpath, &t, err, sizeof err) == SM_ERR_INVALID);
    CHECK_MSG(err, "end_header");
    free(buf);
    sm_frame_free(&f);
    sm_frame_free(&g);
    sm_world_destroy(w);
}

static void put_be_f64(unsigned char *p, double v) {
    uint64_t u;
    memcpy(&u, &v, 8);
    for (int i = 0; i < 8; i++) p[i] = (unsigned char)(u >> (56 - 8 * i));
}

static void test_ply_formats(void) {
    char path[512], err[512];
    sm_frame f;
    /* ascii, properties in another order, extra properties and elements, int material, volume */
    tmp_path(path, sizeof path, "ascii.ply");
    const char *a = "ply\r\nformat ascii 1.0\ncomment hello\nelement camera 1\nproperty float fov\n"
                    "element vertex 3\nproperty double volume\nproperty float z\nproperty uchar red\n"
                    "property float y\nproperty int material\nproperty float x\nproperty float q\n"
                    "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
                    "45\n"
                    "1e-6 0.5 255 0.25 3 0.125 0.5\n"
                    "2e-6 -1 0 2 0 4 0\n"
                    "3e-6 7 10 8 65535 9 1.5\n"
                    "3 0 1 2\n";
    write_file(path, a, strlen(a));
    CHECK(sm_ply_read(path, &f, err, sizeof err) == SM_OK);
    if (f.n == 3) {
        CHECK(f.x[0] == 0.125f && f.x[1] == 0.25f && f.x[2] == 0.5f);
        CHECK(f.x[6] == 9.0f && f.x[7] == 8.0f && f.x[8] == 7.0f);
        CHECK(f.material[0] == 3 && f.material[2] == 65535);
        CHECK(f.q[2] == 1.5f);
        CHECK(f.volume && f.volume[1] == 2e-6f);
        CHECK(f.dim == 3);
        CHECK(!f.has_velocity && f.v[0] == 0);
    } else {
        CHECK(f.n == 3);
        fprintf(stderr, "%s\n", err);
    }
    sm_frame_free(&f);
    /* big-endian doubles, no z: 2D; an id property */
    tmp_path(path, sizeof path, "be.ply");
    const char *hb = "ply\nformat binary_big_endian 1.0\nelement vertex 2\nproperty double x\nproperty double y\n"
                     "property uint id\nend_header\n";
    unsigned char data[512];
    size_t hl = strlen(hb);
    memcpy(data, hb, hl);
    unsigned char *p = data + hl;
    put_be_f64(p, 1.5);
    put_be_f64(p + 8, -2.25);
    p[16] = 0;
    p[17] = 0;
    p[18] = 1;
    p[19] = 2;
    put_be_f64(p + 20, 3.0);
    put_be_f64(p + 28, 4.0);
    p[36] = p[37] = p[38] = 0;
    p[39] = 9;
    write_file(path, data, hl + 40);
    CHECK(sm_ply_read(path, &f, err, sizeof err) == SM_OK);
    CHECK(f.n == 2 && f.dim == 2);
    if (f.n == 2) {
        CHECK(f.x[0] == 1.5f && f.x[1] == -2.25f && f.x[2] == 0 && f.x[3] == 3.0f);
        CHECK(f.id && f.id[0] == 258 && f.id[1] == 9);
        CHECK(f.volume == NULL);
    }
    /* no volume: renders with the radius option or an estimate */
    sm_render_opts o = sm_render_opts_default();
    o.width = 32;
    o.height = 24;
    uint8_t img[32 * 24 * 3];
    CHECK(sm_render(&f, &o, img, err, sizeof err) == SM_OK);
    o.radius = 0.1;
    CHECK(sm_render(&f, &o, img, err, sizeof err) == SM_OK);
    sm_frame_free(&f);
    /* "comment dim 2" wins, an empty vertex element reads as an empty frame */
    tmp_path(path, sizeof path, "empty.ply");
    const char *e = "ply\nformat binary_little_endian 1.0\ncomment dim 2\nelement vertex 0\nproperty float x\n"
                    "property float y\nproperty float z\nend_header\n";
    write_file(path, e, strlen(e));
    CHECK(sm_ply_read(path, &f, err, sizeof err) == SM_OK);
    CHECK(f.n == 0 && f.dim == 2);
    o.radius = 0;
    CHECK(sm_render(&f, &o, img, err, sizeof err) == SM_OK);
    sm_frame_free(&f);
}

static void test_ply_errors(void) {
    char path[512], err[512];
    sm_frame f;
    /* missing */
    tmp_path(path, sizeof path, "does_not_exist.ply");
    CHECK(sm_ply_read(path, &f, err, sizeof err) == SM_ERR_IO);
    CHECK_MSG(err, path);
    CHECK(f.n == 0 && f.x == NULL);
    /* a directory */
    CHECK(sm_ply_read(tmpdir, &f, err, sizeof err) == SM_ERR_IO);
    /* NULL err is allowed */
    CHECK(sm_ply_read(path, &f, NULL, 0) == SM_ERR_IO);
    struct {
        const char *name, *text, *msg;
    } cases[] = {
        {"empty.bad", "", "empty"},
        {"garbage.bad", "hello world, this is not a ply file\n\x01\x02\x03", "not a PLY"},
        {"noend.bad", "ply\nformat binary_little_endian 1.0\nelement vertex 10\nproperty float x\n", "end_header"},
        {"format.bad", "ply\nformat binary_middle_endian 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n",
         "format"},
        {"noformat.bad", "ply\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n", "format"},
        {"type.bad", "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float128 x\nend_header\n", "type"},
        {"count.bad", "ply\nformat binary_little_endian 1.0\nelement vertex -5\nproperty float x\nend_header\n", "count"},
        {"noxy.bad", "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\nproperty float q\nend_header\n",
         "\"y\""},
        {"novertex.bad", "ply\nformat binary_little_endian 1.0\nelement face 1\nproperty float x\nend_header\n", "vertex"},
        {"huge.bad", "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\nproperty float x\nproperty float y\nend_header\n",
         "truncated"},
        {"huge2.bad", "ply\nformat binary_little_endian 1.0\nelement vertex 18446744073709551615\nproperty double x\nproperty double y\nend_header\n",
         "vertices"},
        {"keyword.bad", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nbogus line\nend_header\n1 2\n",
         "unknown keyword"},
        {"ascii.bad", "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nend_header\n1 2\n3 x\n",
         "corrupt"},
        {"ascii_short.bad", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nend_header\n1 2\n3 4\n",
         "truncated"},
        {"list.bad", "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty list uchar float x\nproperty float y\nend_header\n",
         "list"},
        {"prop.bad", "ply\nformat binary_little_endian 1.0\nproperty float x\nelement vertex 1\nend_header\n", "property before"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        tmp_path(path, sizeof path, cases[i].name);
        write_file(path, cases[i].text, strlen(cases[i].text));
        err[0] = 0;
        sm_status rc = sm_ply_read(path, &f, err, sizeof err);
        if (rc != SM_ERR_INVALID) fprintf(stderr, "%s: rc %d (%s)\n", cases[i].name, (int)rc, err);
        CHECK(rc == SM_ERR_INVALID);
        CHECK_MSG(err, path);
        CHECK_MSG(err, cases[i].msg);
        CHECK(f.n == 0 && f.x == NULL);
    }
    /* random bytes after a valid start of header never crash */
    unsigned long long s = 99;
    for (int trial = 0; trial < 200; trial++) {
        unsigned char buf[400];
        const char *h = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n";
        size_t hl = strlen(h);
        memcpy(buf, h, hl);
        size_t n = hl + (size_t)(sm_test_rng_next(&s) % (sizeof buf - hl));
        for (size_t k = hl; k < n; k++) buf[k] = (unsigned char)(sm_test_rng_next(&s) & 0xff);
        if (trial % 2) memcpy(buf + hl, "end_header\n", n - hl < 11 ? n - hl : 11);
        tmp_path(path, sizeof path, "fuzz.ply");
        write_file(path, buf, n);
        sm_status rc = sm_ply_read(path, &f, err, sizeof err);
        CHECK(rc == SM_OK || rc == SM_ERR_INVALID);
        if (rc == SM_OK) { /* whatever garbage it holds renders without crashing */
            sm_render_opts o = sm_render_opts_default();
            o.width = 32;
            o.height = 24;
            o.threads = 1;
            uint8_t img[32 * 24 * 3];
            CHECK(sm_render(&f, &o, img, err, sizeof err) == SM_OK);
        }
        sm_frame_free(&f);
    }
}

/* The colour legend: drawn in the bottom-left quarter only (the rest of the image unchanged), with
 * white text and the colour map's two ends (dark blue-violet to yellow) for speed; none for the
 * sand tones; a swatch per material present. */
static size_t white_pixels(const uint8_t *img) {
    size_t n = 0;
    for (size_t i = 0; i < (size_t)W * H; i++) n += img[3 * i] == 240 && img[3 * i + 1] == 240 && img[3 * i + 2] == 240;
    return n;
}

static void test_legend(void) {
    sm_frame f;
    make_cube(&f, 12, 0.015);
    sm_render_opts o = scene_opts();
    uint8_t *a = malloc(W * H * 3), *b = malloc(W * H * 3);
    const sm_color_mode modes[4] = {SM_COLOR_SPEED, SM_COLOR_Q, SM_COLOR_MATERIAL, SM_COLOR_SAND};
    for (size_t i = 0; i < f.n; i++) f.material[i] = (uint16_t)(f.x[3 * i] > 0 ? 2 : 0);
    for (int k = 0; k < 4; k++) {
        o.color = modes[k];
        o.legend = 0;
        CHECK(render(&f, &o, a) == SM_OK);
        o.legend = 1;
        CHECK(render(&f, &o, b) == SM_OK);
        size_t outside = 0, inside = 0, violet = 0, yellow = 0;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                const uint8_t *p = a + 3 * ((size_t)y * W + x), *q = b + 3 * ((size_t)y * W + x);
                const int diff = memcmp(p, q, 3) != 0;
                if (x < W / 2 && y >= H / 2) inside += diff;
                else outside += diff;
                violet += diff && q[2] > q[1] + 40 && q[0] > q[1];
                yellow += diff && q[0] > 180 && q[1] > 160 && q[2] < 100;
            }
        CHECK(outside == 0);
        if (modes[k] == SM_COLOR_SAND) {
            CHECK(inside == 0);
            continue;
        }
        CHECK(inside > 200);
        CHECK(white_pixels(b) > white_pixels(a) + 20); /* the title and the range */
        if (modes[k] == SM_COLOR_SPEED) CHECK(violet > 0 && yellow > 0);
        printf("legend (colour mode %d): %zu pixels in the bottom-left quarter, %zu outside it\n", (int)modes[k], inside,
               outside);
    }
    free(a);
    free(b);
    sm_frame_free(&f);
}

int main(void) {
    snprintf(tmpdir, sizeof tmpdir, "%s/sm_test_render_XXXXXX", getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp");
    if (!mkdtemp(tmpdir)) {
        perror("mkdtemp");
        return 1;
    }
    test_scene();
    test_colliders();
    test_2d();
    test_legend();
    test_ply_roundtrip(3);
    test_ply_roundtrip(2);
    test_ply_formats();
    test_ply_errors();
    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", tmpdir);
    if (system(cmd) != 0) fprintf(stderr, "could not remove %s\n", tmpdir);
    return sm_test_summary("test_render");
}
