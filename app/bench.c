/* The benchmark behind `sandmpm bench` (app/bench.h). */
#define _POSIX_C_SOURCE 200809L
#include "app/bench.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static double wall(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* The scene: a block of side L resting 3 dx above a sticky ground, L chosen so that
 * (L/dx)^d * ppc is about the target count; the domain leaves room for the collapse. */
static sm_status build(const sm_bench_case *c, sm_world **out, char *err, size_t errlen) {
    const int dim = c->dim;
    const double ppc = dim == 3 ? 8 : 4;
    const double dx = dim == 3 ? 0.01 : 0.004;
    const double L = pow(c->particles / ppc, 1.0 / dim) * dx;
    sm_world_def def = sm_world_def_default();
    def.dim = dim;
    def.dx = dx;
    def.threads = c->threads;
    def.max_dt = 1e-3;
    for (int a = 0; a < dim; a++) {
        def.domain_min[a] = 0;
        def.domain_max[a] = (a == 1 ? 1.6 * L : 3.0 * L) + 8 * dx;
    }
    sm_world *w = NULL;
    char cerr[256];
    sm_status s = sm_world_create(&def, &w, cerr, sizeof cerr);
    if (s != SM_OK) {
        snprintf(err, errlen, "%dD world: %s", dim, cerr);
        return s;
    }
    sm_material_def m = sm_material_def_sand(); /* hardening 35/9/0.2/10 */
    int mat = -1;
    sm_world_add_material(w, &m, &mat);
    sm_collider_def g = sm_collider_def_default();
    g.shape_count = 1;
    g.shapes[0] = sm_shape_default(SM_SHAPE_HALFSPACE);
    g.shapes[0].center[1] = 3 * dx;
    g.shapes[0].normal[1] = 1;
    g.mode = SM_COLLIDE_STICKY;
    if (mat < 0 || sm_world_add_collider(w, &g, NULL) != SM_OK) {
        snprintf(err, errlen, "%dD scene: %s", dim, sm_world_errmsg(w));
        sm_world_destroy(w);
        return SM_ERR_INVALID;
    }
    sm_shape box = sm_shape_default(SM_SHAPE_BOX);
    for (int a = 0; a < dim; a++) {
        box.center[a] = a == 1 ? 3 * dx + 0.5 * L : 0.5 * def.domain_max[a];
        box.half_extent[a] = 0.5 * L;
    }
    sm_seed_def sd = sm_seed_def_default();
    sd.material = mat;
    sd.ppc = ppc;
    size_t added = 0;
    s = sm_world_seed_shape(w, &box, &sd, &added);
    if (s != SM_OK || added == 0) {
        snprintf(err, errlen, "%dD scene: %s", dim, s != SM_OK ? sm_world_errmsg(w) : "no particles seeded");
        sm_world_destroy(w);
        return s != SM_OK ? s : SM_ERR_INVALID;
    }
    *out = w;
    return SM_OK;
}

static sm_status steps(sm_world *w, int n, const char *what, char *err, size_t errlen) {
    for (int i = 0; i < n; i++) {
        /* one adaptive step (a refused dt is covered in smaller steps, as in a run) */
        sm_status s = sm_world_advance(w, sm_world_time(w) + sm_world_next_dt(w, 1e9));
        if (s != SM_OK) {
            snprintf(err, errlen, "%s step %d: %s", what, i + 1, sm_world_errmsg(w));
            return s;
        }
    }
    return SM_OK;
}

sm_status sm_bench_run(const sm_bench_case *c, sm_bench_result *r, char *err, size_t errlen) {
    memset(r, 0, sizeof *r);
    if ((c->dim != 2 && c->dim != 3) || c->threads < 0 || !(c->particles >= 1) || c->warmup < 0 || c->steps < 1) {
        snprintf(err, errlen, "bad benchmark case (dim %d, threads %d, particles %g, warmup %d, steps %d)", c->dim,
                 c->threads, c->particles, c->warmup, c->steps);
        return SM_ERR_INVALID;
    }
    sm_world *w = NULL;
    sm_status rc = build(c, &w, err, errlen);
    if (rc != SM_OK) return rc;
    /* Warm up into the collapse (sand moving, plasticity active), then measure. */
    rc = steps(w, c->warmup, "warm-up", err, errlen);
    sm_diagnostics d0, d1;
    sm_world_diagnostics(w, &d0);
    uint64_t a0 = sm_allocation_count();
    double t0 = wall();
    if (rc == SM_OK) rc = steps(w, c->steps, "measured", err, errlen);
    double t1 = wall();
    uint64_t a1 = sm_allocation_count();
    if (rc != SM_OK) {
        sm_world_destroy(w);
        return rc;
    }
    sm_world_diagnostics(w, &d1);
    r->dim = c->dim;
    r->threads = c->threads;
    r->is_double = sm_real_is_double();
    r->particles = d1.particles;
    r->steps = c->steps;
    r->seconds = t1 - t0;
    for (int s = 0; s < SM_STAGE_COUNT; s++) r->stage_seconds[s] = d1.stage_seconds[s] - d0.stage_seconds[s];
    r->bytes_per_particle = d1.particles ? (double)sm_world_memory_bytes(w) / (double)d1.particles : 0;
    r->allocations_per_step = (double)(a1 - a0) / c->steps;
    sm_world_destroy(w);
    return SM_OK;
}

double sm_bench_rate(const sm_bench_result *r) {
    return r->seconds > 0 ? (double)r->particles * r->steps / r->seconds : 0;
}

double sm_bench_stage_rate(const sm_bench_result *r, int stage) {
    if (stage < 0 || stage >= SM_STAGE_COUNT || !(r->stage_seconds[stage] > 0)) return 0;
    return (double)r->particles * r->steps / r->stage_seconds[stage];
}

const char *sm_bench_precision_name(int is_double) { return is_double ? "double" : "float"; }

void sm_bench_csv_header(FILE *f) { fprintf(f, "dim,precision,threads,particles,particle_steps_per_s,bytes_per_particle\n"); }

void sm_bench_csv_row(FILE *f, const sm_bench_result *r) {
    fprintf(f, "%d,%s,%d,%zu,%.0f,%.1f\n", r->dim, sm_bench_precision_name(r->is_double), r->threads, r->particles,
            sm_bench_rate(r), r->bytes_per_particle);
}

static int stage_width(int s) {
    int n = (int)strlen(sm_stage_name((sm_stage)s)) + 2;
    return n > 10 ? n : 10;
}

void sm_bench_table_header(FILE *f, const sm_bench_case *c) {
    fprintf(f,
            "sand block collapsing onto a sticky ground (hardening, quadratic kernel, APIC, explicit; 8 particles per\n"
            "cell in 3D, 4 in 2D); %d warm-up + %d measured steps; particle-steps/s in total and per stage\n\n",
            c->warmup, c->steps);
    fprintf(f, "dim  precision  threads  particles      total");
    for (int s = 0; s < SM_STAGE_COUNT; s++) fprintf(f, "%*s", stage_width(s), sm_stage_name((sm_stage)s));
    fprintf(f, "  bytes/particle  allocs/step\n");
}

void sm_bench_table_row(FILE *f, const sm_bench_result *r) {
    char threads[16];
    if (r->threads) snprintf(threads, sizeof threads, "%d", r->threads);
    else snprintf(threads, sizeof threads, "auto");
    fprintf(f, "%2dD  %-9s  %7s  %9zu  %9.3g", r->dim, sm_bench_precision_name(r->is_double), threads, r->particles,
            sm_bench_rate(r));
    for (int s = 0; s < SM_STAGE_COUNT; s++) {
        double v = sm_bench_stage_rate(r, s);
        if (v > 0) fprintf(f, "%*.3g", stage_width(s), v);
        else fprintf(f, "%*s", stage_width(s), "-");
    }
    fprintf(f, "  %14.1f  %11.3g\n", r->bytes_per_particle, r->allocations_per_step);
}

#define RAW_TAG "sm_bench_raw/1"

void sm_bench_raw_row(FILE *f, const sm_bench_result *r) {
    fprintf(f, RAW_TAG " %d %d %d %zu %d %.17g %.17g %.17g %d", r->dim, r->threads, r->is_double, r->particles,
            r->steps, r->seconds, r->bytes_per_particle, r->allocations_per_step, (int)SM_STAGE_COUNT);
    for (int s = 0; s < SM_STAGE_COUNT; s++) fprintf(f, " %.17g", r->stage_seconds[s]);
    fprintf(f, "\n");
}

/* Next whitespace-separated number of a raw row. */
static int next_num(const char **p, double *v) {
    char *end;
    errno = 0;
    *v = strtod(*p, &end);
    if (end == *p || errno || !isfinite(*v)) return 0;
    *p = end;
    return 1;
}

sm_status sm_bench_parse_raw(const char *line, sm_bench_result *r, char *err, size_t errlen) {
    memset(r, 0, sizeof *r);
    int shown = (int)strcspn(line, "\r\n");
    if (shown > 60) shown = 60;
    size_t tl = strlen(RAW_TAG);
    if (strncmp(line, RAW_TAG " ", tl + 1) != 0) {
        snprintf(err, errlen, "not a benchmark result: \"%.*s\"", shown, line);
        return SM_ERR_INVALID;
    }
    const char *p = line + tl;
    double v[9];
    for (int i = 0; i < 9; i++)
        if (!next_num(&p, &v[i])) {
            snprintf(err, errlen, "malformed benchmark result: \"%.*s\"", shown, line);
            return SM_ERR_INVALID;
        }
    if ((int)v[8] != SM_STAGE_COUNT) {
        snprintf(err, errlen, "benchmark result with %d stages, this program has %d (built from other sources?)",
                 (int)v[8], (int)SM_STAGE_COUNT);
        return SM_ERR_INVALID;
    }
    for (int s = 0; s < SM_STAGE_COUNT; s++)
        if (!next_num(&p, &r->stage_seconds[s])) {
            snprintf(err, errlen, "malformed benchmark result: \"%.*s\"", shown, line);
            return SM_ERR_INVALID;
        }
    while (*p == ' ' || *p == '\n' || *p == '\r') p++;
    if (*p || (v[0] != 2 && v[0] != 3) || v[1] < 0 || (v[2] != 0 && v[2] != 1) || v[3] < 1 || v[4] < 1) {
        snprintf(err, errlen, "malformed benchmark result: \"%.*s\"", shown, line);
        return SM_ERR_INVALID;
    }
    r->dim = (int)v[0];
    r->threads = (int)v[1];
    r->is_double = (int)v[2];
    r->particles = (size_t)v[3];
    r->steps = (int)v[4];
    r->seconds = v[5];
    r->bytes_per_particle = v[6];
    r->allocations_per_step = v[7];
    return SM_OK;
}
