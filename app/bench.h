/* The benchmark behind `sandmpm bench`: a block of sand collapsing under gravity onto a sticky
 * ground (hardening 35/9/0.2/10, quadratic kernel, APIC, explicit, every stage of the step), 8
 * particles per cell in 3D (dx = 1 cm) and 4 in 2D (dx = 4 mm). One case is one dimension and
 * thread count in this build's precision (sm_real): warm-up steps into the collapse, then measured
 * steps, timed in total and per stage (sm_diagnostics.stage_seconds), with the world's heap bytes
 * per particle and the library's heap allocations per measured step. */
#ifndef SM_APP_BENCH_H
#define SM_APP_BENCH_H

#include <stddef.h>
#include <stdio.h>

#include "sandmpm/sandmpm.h"

typedef struct sm_bench_case {
    int dim;          /* 2 or 3 */
    int threads;      /* >= 1, or 0: the library's choice per step (the default of a run; governor.h) */
    double particles; /* target particle count (the block is sized to it; the seeded count is close) */
    int warmup;       /* unmeasured steps first (>= 0) */
    int steps;        /* measured steps (>= 1) */
} sm_bench_case;

typedef struct sm_bench_result {
    int dim, threads;
    int is_double;                        /* precision of the build that ran the case */
    size_t particles;                     /* seeded particles */
    int steps;                            /* measured steps */
    double seconds;                       /* wall time of the measured steps */
    double stage_seconds[SM_STAGE_COUNT]; /* per stage, during the measured steps */
    double bytes_per_particle;            /* sm_world_memory_bytes / particles after the measured steps */
    double allocations_per_step;          /* library heap allocations per measured step */
} sm_bench_result;

/* Runs one case. Returns SM_OK, or SM_ERR_INVALID (bad case), SM_ERR_NUMERICAL (a step failed),
 * SM_ERR_NOMEM, with a message. */
sm_status sm_bench_run(const sm_bench_case *c, sm_bench_result *r, char *err, size_t errlen);

/* Particle-steps per second in total (wall time) and in one stage (0 if the stage took no time). */
double sm_bench_rate(const sm_bench_result *r);
double sm_bench_stage_rate(const sm_bench_result *r, int stage);

/* "float" or "double". */
const char *sm_bench_precision_name(int is_double);

/* CSV: dim,precision,threads,particles,particle_steps_per_s,bytes_per_particle */
void sm_bench_csv_header(FILE *f);
void sm_bench_csv_row(FILE *f, const sm_bench_result *r);

/* The human-readable table: one row per case, total and per-stage particle-steps/s. */
void sm_bench_table_header(FILE *f, const sm_bench_case *c);
void sm_bench_table_row(FILE *f, const sm_bench_result *r);

/* A lossless one-line form of a result, for passing results between the float and the double
 * program (`sandmpm bench` runs the other precision's program and reads these back). */
void sm_bench_raw_row(FILE *f, const sm_bench_result *r);
/* Parses a line written by sm_bench_raw_row. Returns SM_OK, or SM_ERR_INVALID with a message. */
sm_status sm_bench_parse_raw(const char *line, sm_bench_result *r, char *err, size_t errlen);

#endif
