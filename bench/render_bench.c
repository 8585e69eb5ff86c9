/* render_bench: preview-renderer throughput. Renders 1 million random particles (a box of sand
 * on the ground, random brown tones, shadows) at 1280x720 with 1 and 2 threads and prints
 * particles per second (best of 5 runs each), plus the PNG encoding time. Not a test.
 *
 *   render_bench [PARTICLES] [--colliders] [--out FILE.png]
 *
 * --colliders adds a container (inside-out box), a sphere and a cylinder, to time the sphere
 * tracing; --out writes the last image. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "app/io/png.h"
#include "app/render.h"

static double now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static double uniform(uint64_t *s) {
    uint64_t z = (*s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return (double)(z >> 11) * (1.0 / 9007199254740992.0);
}

int main(int argc, char **argv) {
    size_t n = 1000000;
    int colliders = 0;
    const char *out = NULL;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--colliders")) colliders = 1;
        else if (!strcmp(argv[i], "--out") && i + 1 < argc) out = argv[++i];
        else if (atol(argv[i]) > 0) n = (size_t)atol(argv[i]);
        else {
            fprintf(stderr, "usage: render_bench [PARTICLES] [--colliders] [--out FILE.png]\n");
            return 2;
        }
    }
    sm_frame f;
    memset(&f, 0, sizeof f);
    f.n = n;
    f.dim = 3;
    f.x = malloc(3 * n * sizeof(float));
    f.v = calloc(3 * n, sizeof(float));
    f.q = calloc(n, sizeof(float));
    f.material = calloc(n, sizeof(uint16_t));
    f.volume = malloc(n * sizeof(float));
    if (!f.x || !f.v || !f.q || !f.material || !f.volume) {
        fprintf(stderr, "render_bench: out of memory\n");
        return 5;
    }
    /* A 0.6 x 0.3 x 0.6 m box of sand: V0 = box volume / n (radius about 3 mm for 1M). */
    const double V0 = 0.6 * 0.3 * 0.6 / (double)n;
    uint64_t s = 12345;
    for (size_t i = 0; i < n; i++) {
        f.x[3 * i] = (float)(-0.3 + 0.6 * uniform(&s));
        f.x[3 * i + 1] = (float)(0.3 * uniform(&s));
        f.x[3 * i + 2] = (float)(-0.3 + 0.6 * uniform(&s));
        f.volume[i] = (float)V0;
    }
    sm_render_opts o = sm_render_opts_default();
    o.width = 1280;
    o.height = 720;
    o.has_domain = 1;
    const double lo[3] = {-0.5, 0, -0.5}, hi[3] = {0.5, 0.5, 0.5};
    memcpy(o.domain_min, lo, sizeof lo);
    memcpy(o.domain_max, hi, sizeof hi);
    sm_collider_def cd[3];
    if (colliders) {
        cd[0] = sm_collider_def_default();
        cd[0].shape_count = 1;
        cd[0].inside_out = 1;
        cd[0].shapes[0] = sm_shape_default(SM_SHAPE_BOX);
        cd[0].shapes[0].center[1] = 0.25;
        cd[0].shapes[0].half_extent[0] = cd[0].shapes[0].half_extent[2] = 0.45;
        cd[0].shapes[0].half_extent[1] = 0.25;
        cd[1] = sm_collider_def_default();
        cd[1].shape_count = 1;
        cd[1].shapes[0] = sm_shape_default(SM_SHAPE_SPHERE);
        cd[1].shapes[0].radius = 0.07;
        cd[1].shapes[0].center[0] = 0.1;
        cd[1].shapes[0].center[1] = 0.4;
        cd[2] = sm_collider_def_default();
        cd[2].shape_count = 1;
        cd[2].shapes[0] = sm_shape_default(SM_SHAPE_CYLINDER);
        cd[2].shapes[0].radius = 0.02;
        cd[2].shapes[0].half_height = 0.1;
        cd[2].shapes[0].center[0] = -0.2;
        cd[2].shapes[0].center[1] = 0.35;
        o.colliders = cd;
        o.ncolliders = 3;
    }
    uint8_t *img = malloc((size_t)o.width * (size_t)o.height * 3);
    if (!img) return 5;
    char err[512];
    printf("render_bench: %zu particles, %dx%d, shadows, %s\n", n, o.width, o.height,
           colliders ? "3 colliders (container, sphere, cylinder)" : "no colliders");
    for (int threads = 1; threads <= 2; threads++) {
        o.threads = threads;
        double best = HUGE_VAL;
        for (int rep = 0; rep < 5; rep++) {
            double t0 = now();
            if (sm_render(&f, &o, img, err, sizeof err) != 0) {
                fprintf(stderr, "render_bench: %s\n", err);
                return 1;
            }
            double t = now() - t0;
            if (t < best) best = t;
        }
        printf("  threads %d: %.3f s per frame, %.3g particles/s (%.3g per thread)\n", threads, best, (double)n / best,
               (double)n / best / threads);
    }
    const char *png = out ? out : "render_bench.png";
    double t0 = now();
    if (sm_png_write(png, o.width, o.height, img, err, sizeof err) != 0) {
        fprintf(stderr, "render_bench: %s\n", err);
        return 4;
    }
    printf("  PNG encoding: %.3f s (%s)\n", now() - t0, png);
    if (!out) remove(png);
    free(img);
    sm_frame_free(&f);
    return 0;
}
