/* sandmpm bench: particle-steps/s per stage in this program's precision, in process, and in the
 * other precision by running the sibling program (sandmpm-float / sandmpm-double, CMake
 * SM_SIBLING) and reading its results back through a pipe. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "app/bench.h"
#include "app/io/files.h"
#include "app/io/spawn.h"
#include "cli/bench_load.h"
#include "cli/cli.h"

#define BENCH_MAX_THREADS 16

typedef struct bench_opts {
    int dim_mask;  /* bit d: dimension d */
    int prec_mask; /* bit 0 float, bit 1 double */
    int prec_given;
    int threads[BENCH_MAX_THREADS];
    int nthreads;
    sm_bench_case c; /* particles, warmup, steps */
    int csv, header;
    int raw;      /* hidden: the sibling's mode, lossless rows (app/bench.h) and only this precision */
    int progress; /* a progress line on stderr */
    int load;     /* busy processes beside each case (--load) */
} bench_opts;

/* Splits a comma list into at most max items of at most 31 characters. Returns the count or -1. */
static int split_list(const char *s, char items[][32], int max) {
    int n = 0;
    const char *p = s;
    for (;;) {
        const char *e = strchr(p, ',');
        size_t len = e ? (size_t)(e - p) : strlen(p);
        if (len == 0 || len >= 32 || n >= max) return -1;
        memcpy(items[n], p, len);
        items[n][len] = 0;
        n++;
        if (!e) return n;
        p = e + 1;
    }
}

/* --dim, --precision, --threads: a comma list in v. 1 if a was one of them, 0 if not, -1 on error
 * (message printed). */
static int parse_list_option(const char *a, const char *v, bench_opts *o) {
    char items[BENCH_MAX_THREADS][32];
    if (!strcmp(a, "--dim")) {
        int n = split_list(v, items, BENCH_MAX_THREADS);
        o->dim_mask = 0;
        for (int k = 0; k < n; k++) {
            if (strcmp(items[k], "2") && strcmp(items[k], "3")) n = -1;
            else o->dim_mask |= 1 << (items[k][0] - '0');
        }
        if (n < 1) fprintf(stderr, "sandmpm bench: --dim: expected 2, 3 or 2,3, got \"%s\"\n", v);
        return n < 1 ? -1 : 1;
    }
    if (!strcmp(a, "--precision")) {
        int n = split_list(v, items, BENCH_MAX_THREADS);
        o->prec_mask = 0;
        o->prec_given = 1;
        for (int k = 0; k < n; k++) {
            if (!strcmp(items[k], "float")) o->prec_mask |= 1;
            else if (!strcmp(items[k], "double")) o->prec_mask |= 2;
            else n = -1;
        }
        if (n < 1) fprintf(stderr, "sandmpm bench: --precision: expected float, double or float,double, got \"%s\"\n", v);
        return n < 1 ? -1 : 1;
    }
    if (!strcmp(a, "--threads")) {
        int n = split_list(v, items, BENCH_MAX_THREADS);
        for (int k = 0; k < n; k++) {
            if (!strcmp(items[k], "auto")) o->threads[k] = 0; /* the library's choice (governor.h) */
            else if (!cli_parse_int(items[k], 1, 1024, &o->threads[k])) n = -1;
            for (int j = 0; j < k && n > 0; j++)
                if (o->threads[j] == o->threads[k]) n = -1;
        }
        if (n < 1) {
            fprintf(stderr,
                    "sandmpm bench: --threads: expected a comma list of different thread counts 1..1024 or auto "
                    "(at most %d), got \"%s\"\n",
                    BENCH_MAX_THREADS, v);
            return -1;
        }
        o->nthreads = n;
        return 1;
    }
    return 0;
}

/* --particles, --steps, --warmup with value v. 1, 0 or -1 as parse_list_option. */
static int parse_number_option(const char *a, const char *v, bench_opts *o) {
    if (!strcmp(a, "--particles")) {
        if (cli_parse_double(v, &o->c.particles) && o->c.particles >= 100 && o->c.particles <= 1e9) return 1;
        fprintf(stderr, "sandmpm bench: --particles: expected a number from 100 to 1e9, got \"%s\"\n", v);
        return -1;
    }
    if (!strcmp(a, "--steps")) {
        if (cli_parse_int(v, 1, 1000000, &o->c.steps)) return 1;
        fprintf(stderr, "sandmpm bench: --steps: expected a whole number >= 1, got \"%s\"\n", v);
        return -1;
    }
    if (!strcmp(a, "--load")) {
        if (cli_parse_int(v, 0, BENCH_MAX_LOAD, &o->load)) return 1;
        fprintf(stderr, "sandmpm bench: --load: expected a whole number of busy processes 0..%d, got \"%s\"\n",
                BENCH_MAX_LOAD, v);
        return -1;
    }
    if (!strcmp(a, "--warmup")) {
        if (cli_parse_int(v, 0, 1000000, &o->c.warmup)) return 1;
        fprintf(stderr, "sandmpm bench: --warmup: expected a whole number >= 0, got \"%s\"\n", v);
        return -1;
    }
    return 0;
}

/* The flags without a value; 0 if a is none of them. */
static int parse_flag(const char *a, bench_opts *o) {
    if (!strcmp(a, "--csv")) o->csv = 1;
    else if (!strcmp(a, "--no-header")) o->header = 0;
    else if (!strcmp(a, "--sibling-rows")) o->raw = 1;
    else if (!strcmp(a, "--sibling-progress")) o->progress = 1;
    else return 0;
    return 1;
}

static sm_status bench_parse(int argc, char **argv, bench_opts *o) {
    memset(o, 0, sizeof *o);
    o->dim_mask = 1 << 2 | 1 << 3;
    o->prec_mask = 3;
    o->threads[0] = 1;
    o->threads[1] = 2;
    o->nthreads = 2;
    o->c.particles = 1e6;
    o->c.steps = 20;
    o->c.warmup = 10;
    o->header = 1;
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        int takes = !strcmp(a, "--dim") || !strcmp(a, "--precision") || !strcmp(a, "--threads") ||
                    !strcmp(a, "--particles") || !strcmp(a, "--steps") || !strcmp(a, "--warmup") ||
                    !strcmp(a, "--load");
        if (takes && i + 1 >= argc) {
            fprintf(stderr, "sandmpm bench: %s needs a value (see sandmpm bench --help)\n", a);
            return SM_ERR_INVALID;
        }
        int r = takes ? parse_list_option(a, argv[i + 1], o) : parse_flag(a, o);
        if (takes && r == 0) r = parse_number_option(a, argv[i + 1], o);
        if (r < 0) return SM_ERR_INVALID;
        if (r == 0) {
            fprintf(stderr, "sandmpm bench: unknown option \"%s\" (see sandmpm bench --help)\n", a);
            return SM_ERR_INVALID;
        }
        i += takes;
    }
    if (!o->header && !o->csv && !o->raw) {
        fprintf(stderr, "sandmpm bench: --no-header goes with --csv\n");
        return SM_ERR_INVALID;
    }
    if (!o->raw && !o->csv) o->progress = 1;
    if (o->progress && !isatty(fileno(stderr))) o->progress = 0;
    return SM_OK;
}

static void bench_emit(const bench_opts *o, const sm_bench_result *r) {
    if (o->raw) sm_bench_raw_row(stdout, r);
    else if (o->csv) sm_bench_csv_row(stdout, r);
    else sm_bench_table_row(stdout, r);
    fflush(stdout);
}

/* The cases of this program's precision, in process. */
static sm_status bench_local(const bench_opts *o) {
    for (int dim = 2; dim <= 3; dim++) {
        if (!(o->dim_mask & (1 << dim))) continue;
        for (int t = 0; t < o->nthreads; t++) {
            sm_bench_case c = o->c;
            c.dim = dim;
            c.threads = o->threads[t];
            const char *prec = sm_bench_precision_name(sm_real_is_double());
            char who[32];
            if (c.threads == 0) snprintf(who, sizeof who, "threads auto");
            else snprintf(who, sizeof who, "%d thread%s", c.threads, c.threads == 1 ? "" : "s");
            int len = 0;
            if (o->progress)
                len = fprintf(stderr, "running %dD %s, %s, about %.0f particles, %d + %d steps ...", dim, prec, who,
                              c.particles, c.warmup, c.steps);
            sm_bench_result r;
            char err[1024];
            pid_t busy[BENCH_MAX_LOAD];
            sm_status rc = bench_load_start(o->load, busy, err, sizeof err) ? SM_OK : SM_ERR_IO;
            if (rc == SM_OK) {
                rc = sm_bench_run(&c, &r, err, sizeof err);
                bench_load_stop(o->load, busy);
            }
            if (o->progress && len > 0) fprintf(stderr, "\r%*s\r", len, "");
            if (rc != SM_OK) {
                fprintf(stderr, "sandmpm bench: %dD %s, %s: %s\n", dim, prec, who, err);
                return rc;
            }
            bench_emit(o, &r);
        }
    }
    return SM_OK;
}

/* Path of the sibling program (the other precision) next to this one, via /proc/self/exe.
 * Returns 1 if it exists and is executable, 0 if not (path still filled when it can be). */
static int bench_sibling(char *path, size_t len) {
    path[0] = 0;
    if (!SM_BENCH_SIBLING[0]) return 0;
    char self[4096];
    ssize_t n = readlink("/proc/self/exe", self, sizeof self - 1);
    if (n <= 0) return 0;
    self[n] = 0;
    char *slash = strrchr(self, '/');
    if (!slash) return 0;
    *slash = 0;
    if ((size_t)snprintf(path, len, "%s/%s", self, SM_BENCH_SIBLING) >= len) {
        path[0] = 0;
        return 0;
    }
    return access(path, X_OK) == 0;
}

/* The sibling's arguments for this run's cases of the other precision (strings in bufs). */
typedef struct sibling_args {
    char dims[8], threads[BENCH_MAX_THREADS * 6], particles[32], steps[16], warmup[16], load[16];
    char *argv[22];
} sibling_args;

static void sibling_argv(const bench_opts *o, const char *path, const char *prec, sibling_args *sa) {
    size_t k = 0;
    sa->dims[0] = sa->threads[0] = 0;
    for (int d = 2; d <= 3; d++)
        if (o->dim_mask & (1 << d)) k += (size_t)snprintf(sa->dims + k, sizeof sa->dims - k, "%s%d", k ? "," : "", d);
    k = 0;
    for (int t = 0; t < o->nthreads; t++)
        k += o->threads[t] ? (size_t)snprintf(sa->threads + k, sizeof sa->threads - k, "%s%d", t ? "," : "", o->threads[t])
                           : (size_t)snprintf(sa->threads + k, sizeof sa->threads - k, "%sauto", t ? "," : "");
    snprintf(sa->particles, sizeof sa->particles, "%.17g", o->c.particles);
    snprintf(sa->steps, sizeof sa->steps, "%d", o->c.steps);
    snprintf(sa->warmup, sizeof sa->warmup, "%d", o->c.warmup);
    snprintf(sa->load, sizeof sa->load, "%d", o->load);
    char *args[] = {(char *)path, "bench",     "--sibling-rows", "--precision", (char *)prec,  "--dim",
                    sa->dims,     "--threads", sa->threads,      "--particles", sa->particles, "--steps",
                    sa->steps,    "--warmup",  sa->warmup,       "--load",      sa->load,
                    o->progress ? "--sibling-progress" : NULL, NULL};
    memcpy(sa->argv, args, sizeof args);
}

/* Reads the sibling's rows and emits them; drains the pipe after an error, so that the sibling is
 * not stopped by a broken pipe. */
static sm_status read_rows(const bench_opts *o, FILE *in, const char *path, int is_double) {
    sm_status rc = SM_OK;
    char *line = NULL;
    size_t cap = 0;
    while (getline(&line, &cap, in) > 0) {
        if (rc != SM_OK) continue;
        sm_bench_result r;
        char err[256];
        if (sm_bench_parse_raw(line, &r, err, sizeof err) != SM_OK) {
            fprintf(stderr, "sandmpm bench: %s: %s\n", path, err);
            rc = SM_ERR_IO;
        } else if (r.is_double != is_double) {
            fprintf(stderr, "sandmpm bench: %s measured %s, not %s\n", path, sm_bench_precision_name(r.is_double),
                    sm_bench_precision_name(is_double));
            rc = SM_ERR_IO;
        } else {
            bench_emit(o, &r);
        }
    }
    free(line);
    return rc;
}

/* Runs the cases of the other precision in the sibling program and emits its rows as they come. */
static sm_status bench_remote(const bench_opts *o, const char *path, int is_double) {
    const char *prec = sm_bench_precision_name(is_double);
    sibling_args sa;
    sibling_argv(o, path, prec, &sa);
    sm_child child;
    char err[SM_MSG_MAX];
    if (sm_spawn(sa.argv, 1, &child, NULL, err, sizeof err) != SM_OK) {
        fprintf(stderr, "sandmpm bench: %s\n", err);
        return SM_ERR_IO;
    }
    FILE *in = fdopen(child.out_fd, "r");
    sm_status rc = SM_OK;
    if (!in) {
        fprintf(stderr, "sandmpm bench: %s\n", strerror(errno));
        close(child.out_fd);
        rc = SM_ERR_IO;
    } else {
        rc = read_rows(o, in, path, is_double);
        fclose(in);
    }
    int code, sig;
    if (sm_child_wait(&child, &code, &sig) == 0) return rc;
    if (sig) {
        fprintf(stderr, "sandmpm bench: %s (the %s cases) was killed by signal %d%s\n", path, prec, sig,
                sig == SIGKILL ? " (out of memory?)" : "");
        return sig == SIGKILL ? SM_ERR_NOMEM : SM_ERR_NUMERICAL;
    }
    if (code < 0) {
        fprintf(stderr, "sandmpm bench: waitpid: %s\n", strerror(errno));
        return SM_ERR_IO;
    }
    fprintf(stderr, "sandmpm bench: %s (the %s cases) failed with exit code %d\n", path, prec, code);
    return cli_status_of_exit_code(code);
}

static sm_status bench_command(int argc, char **argv) {
    if (cli_help_requested(argc, argv)) {
        cli_usage_bench(stdout);
        return SM_OK;
    }
    bench_opts o;
    sm_status rc = bench_parse(argc, argv, &o);
    if (rc != SM_OK) return rc;
    const int own = sm_real_is_double() ? 2 : 1, other = 3 - own;
    const char *own_name = sm_bench_precision_name(own == 2), *other_name = sm_bench_precision_name(other == 2);
    char sib[4096] = "";
    if (o.raw) {
        /* The sibling's side: only this precision, never another sibling. */
        if (o.prec_mask != own) {
            fprintf(stderr, "sandmpm bench: --sibling-rows: this program measures %s only\n", own_name);
            return SM_ERR_INVALID;
        }
    } else if ((o.prec_mask & other) && !bench_sibling(sib, sizeof sib)) {
        char why[4200];
        if (!SM_BENCH_SIBLING[0])
            snprintf(why, sizeof why, "this build has no %s program (CMake option SM_SIBLING=OFF)", other_name);
        else
            snprintf(why, sizeof why, "%s is missing (it is built with the CMake option SM_SIBLING=ON, the default)",
                     sib[0] ? sib : SM_BENCH_SIBLING);
        if (o.prec_given) {
            fprintf(stderr, "sandmpm bench: this program is %s; %s cannot be measured: %s\n", own_name, other_name, why);
            return SM_ERR_INVALID;
        }
        fprintf(stderr, "sandmpm bench: note: %s; measuring %s only\n", why, own_name);
        o.prec_mask = own;
    }
    if (o.csv && o.header) sm_bench_csv_header(stdout);
    if (!o.csv && !o.raw) {
        if (o.load) printf("each case beside %d busy process%s (--load)\n", o.load, o.load == 1 ? "" : "es");
        sm_bench_table_header(stdout, &o.c);
    }
    fflush(stdout);
    for (int p = 1; p <= 2 && rc == SM_OK; p++) { /* float, then double */
        if (!(o.prec_mask & p)) continue;
        rc = p == own ? bench_local(&o) : bench_remote(&o, sib, p == 2);
    }
    return rc;
}

int cli_bench(int argc, char **argv) { return cli_exit_code(bench_command(argc, argv)); }
