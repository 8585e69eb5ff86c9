/* What the commands share: option parsing; loading, checking and building a scene; the video. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <unistd.h>

#include "app/io/files.h"
#include "app/io/video.h"
#include "cli/cli.h"

int cli_help_requested(int argc, char **argv) {
    for (int i = 0; i < argc; i++)
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) return 1;
    return 0;
}

int cli_parse_int(const char *s, long lo, long hi, int *out) {
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || *end || end == s || v < lo || v > hi) return 0;
    *out = (int)v;
    return 1;
}

int cli_parse_double(const char *s, double *out) {
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (errno || *end || end == s || !isfinite(v)) return 0;
    *out = v;
    return 1;
}

double cli_machine_bytes(void) {
    long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    return (pages > 0 && page > 0) ? (double)pages * (double)page : 0;
}

double cli_peak_memory_bytes(void) {
    struct rusage u;
    return getrusage(RUSAGE_SELF, &u) == 0 ? (double)u.ru_maxrss * 1024.0 : 0; /* ru_maxrss: KiB on Linux */
}

/* --set KEY=VALUE: the key copied into so->keybuf, the value pointing into argv. */
static int parse_set(const char *cmd, const char *kv, cli_scene_opts *so) {
    const char *eq = strchr(kv, '=');
    if (!eq || eq == kv) {
        fprintf(stderr, "sandmpm %s: --set: expected KEY=VALUE, got \"%s\"\n", cmd, kv);
        return -1;
    }
    if (so->nparams >= CLI_MAX_PARAMS) {
        fprintf(stderr, "sandmpm %s: --set: at most %d parameters\n", cmd, CLI_MAX_PARAMS);
        return -1;
    }
    size_t kl = (size_t)(eq - kv);
    if (so->keybuf_used + kl + 1 > sizeof so->keybuf) {
        fprintf(stderr, "sandmpm %s: --set: keys too long\n", cmd);
        return -1;
    }
    char *k = so->keybuf + so->keybuf_used;
    memcpy(k, kv, kl);
    k[kl] = 0;
    so->keybuf_used += kl + 1;
    so->params[so->nparams].key = k;
    so->params[so->nparams].value = eq + 1;
    so->nparams++;
    return 1;
}

int cli_parse_scene_opt(const char *cmd, int argc, char **argv, int *i, cli_scene_opts *so) {
    const char *a = argv[*i];
    if (!strcmp(a, "--set")) {
        if (*i + 1 >= argc) {
            fprintf(stderr, "sandmpm %s: --set needs KEY=VALUE\n", cmd);
            return -1;
        }
        return parse_set(cmd, argv[++*i], so);
    }
    if (!strcmp(a, "--quality")) {
        if (*i + 1 >= argc) {
            fprintf(stderr, "sandmpm %s: --quality needs preview, paper or test\n", cmd);
            return -1;
        }
        so->quality = argv[++*i];
        if (strcmp(so->quality, "preview") && strcmp(so->quality, "paper") && strcmp(so->quality, "test")) {
            fprintf(stderr, "sandmpm %s: --quality: expected \"preview\", \"paper\" or \"test\", got \"%s\"\n", cmd,
                    so->quality);
            return -1;
        }
        return 1;
    }
    if (!strcmp(a, "--threads")) {
        if (*i + 1 >= argc || !cli_parse_int(argv[*i + 1], 1, 1024, &so->threads)) {
            fprintf(stderr, "sandmpm %s: --threads: expected a number 1..1024, got \"%s\"\n", cmd,
                    *i + 1 < argc ? argv[*i + 1] : "");
            return -1;
        }
        ++*i;
        cli_warn_threads(cmd, so->threads);
        return 1;
    }
    return 0;
}

/* Prints the scene's warnings from the first'th on. */
static void print_warnings(const char *cmd, const sm_scene *sc, int first) {
    int n = sm_scene_warning_count(sc);
    for (int i = first; i < n; i++) {
        const char *w = sm_scene_warning(sc, i);
        if (w) fprintf(stderr, "sandmpm %s: warning: %s\n", cmd, w);
    }
    if (n > first && !sm_scene_warning(sc, n - 1))
        fprintf(stderr, "sandmpm %s: %d warnings in all\n", cmd, n);
}

/* The scene loader's result codes (2 bad input, 5 out of memory) as a status. */
static sm_status scene_status(int rc) { return rc == (int)SM_ERR_NOMEM ? SM_ERR_NOMEM : SM_ERR_INVALID; }

/* so's scene loaded (the file or the embedded default); the loader's result code. */
static int load_scene(const cli_scene_opts *so, sm_scene **sc, char *err, size_t errlen) {
    /* The built-in scene is named for the file it was compiled from (messages say scenes/default.lua:LINE). */
    const char *path = so->scene ? so->scene : "(built in) scenes/default.lua";
    const char *source = so->scene ? NULL : sm_default_scene;
    return (int)sm_scene_load(path, source, so->params, so->nparams, so->quality, so->threads, sc, err, errlen);
}

sm_status cli_load_scene(const char *cmd, const cli_scene_opts *so, sm_scene **sc) {
    char err[1024];
    int rc = load_scene(so, sc, err, sizeof err);
    if (rc != 0) {
        fprintf(stderr, "sandmpm %s: %s\n", cmd, err);
        return scene_status(rc);
    }
    print_warnings(cmd, *sc, 0);
    return SM_OK;
}

sm_status cli_build_again(const char *cmd, const cli_scene_opts *so, sm_scene_world_hook hook, void *user,
                          sm_scene **sc) {
    char err[1024];
    *sc = NULL;
    int rc = load_scene(so, sc, err, sizeof err);
    if (rc == 0) {
        sm_scene_on_world(*sc, hook, user);
        rc = (int)sm_scene_build(*sc, err, sizeof err);
    }
    if (rc == 0) return SM_OK;
    fprintf(stderr, "sandmpm %s: %s\n", cmd, err);
    sm_scene_destroy(*sc);
    *sc = NULL;
    return scene_status(rc);
}

sm_status cli_check_memory(const char *cmd, const sm_scene_settings *st) {
    double have = cli_machine_bytes();
    if (have > 0 && (double)st->estimated_bytes > 0.9 * have) {
        fprintf(stderr,
                "sandmpm %s: the scene needs about %.1f GB (%zu particles, grid included) but this machine has %.1f GB; "
                "use a coarser quality or a larger dx\n",
                cmd, (double)st->estimated_bytes / 1e9, st->estimated_particles + st->estimated_emitted, have / 1e9);
        return SM_ERR_INVALID;
    }
    return SM_OK;
}

sm_status cli_build_scene(const char *cmd, sm_scene *sc) {
    char err[1024];
    int before = sm_scene_warning_count(sc);
    int rc = (int)sm_scene_build(sc, err, sizeof err);
    if (rc != 0) {
        fprintf(stderr, "sandmpm %s: %s\n", cmd, err);
        return scene_status(rc);
    }
    print_warnings(cmd, sc, before);
    return SM_OK;
}

sm_status cli_make_video(const char *dir, double fps) {
    char err[SM_PATH_MAX + 256];
    sm_status st = sm_video_make(dir, fps, err, sizeof err);
    if (st != SM_OK) fprintf(stderr, "sandmpm: %s\n", err);
    else fprintf(stderr, "sandmpm: wrote %s/video.mp4\n", dir);
    return st;
}

sm_status cli_remove_stale(const char *cmd, const char *dir) {
    char err[SM_MSG_MAX], first[256];
    int removed = 0;
    sm_status st = sm_remove_stale_temporaries(dir, &removed, first, sizeof first, err, sizeof err);
    if (st != SM_OK) fprintf(stderr, "sandmpm %s: %s\n", cmd, err);
    else if (removed)
        fprintf(stderr, "sandmpm %s: removed %d temporary file%s (%s%s) that a killed process left in %s/\n", cmd, removed,
                removed == 1 ? "" : "s", first, removed > 1 ? ", ..." : "", dir);
    return st;
}

void cli_warn_threads(const char *cmd, int threads) {
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    if (cores > 0 && threads > cores)
        fprintf(stderr,
                "sandmpm %s: warning: --threads %d on %ld cores: more threads than cores only slow the run down "
                "(the results are the same for any thread count)\n",
                cmd, threads, cores);
}
