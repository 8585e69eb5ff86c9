/* sandmpm: the command-line program (DESIGN §2: thin — arguments, progress, exit codes).
 *
 *   sandmpm run [SCENE] [--out DIR] [--frames N | --end SECONDS] [--set KEY=VALUE]...
 *               [--threads N] [--quality preview|paper|test] [--render] [--video]
 *   sandmpm info SCENE [--set KEY=VALUE]... [--quality Q]
 *   sandmpm render OUTDIR [--color sand|speed|material|q] [--size WxH] [--threads N] [--video]
 *   sandmpm bench [--dim 2,3] [--precision float,double] [--threads 1,2] [--particles N] [--steps S]
 *                 [--warmup W] [--csv [--no-header]]
 *   sandmpm --help | help [COMMAND] | COMMAND --help | --version | -V
 *
 * Exit codes (cli/exit.c): 0 done, 2 bad input, 3 numerical failure, 4 I/O failure, 5 out of
 * memory. The commands are in cli/cmd_*.c. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/cli.h"
#include "sandmpm/config.h"

static const struct {
    const char *name;
    int (*run)(int argc, char **argv);
} commands[] = {{"run", cli_run}, {"info", cli_info}, {"render", cli_render}, {"bench", cli_bench}};

#define NCOMMANDS (sizeof commands / sizeof commands[0])

/* Levenshtein distance of two short words (commands), capped at 9. */
static int edit_distance(const char *a, const char *b) {
    size_t la = strlen(a), lb = strlen(b);
    if (la > 16 || lb > 16) return 9;
    int row[17];
    for (size_t j = 0; j <= lb; j++) row[j] = (int)j;
    for (size_t i = 1; i <= la; i++) {
        int diag = row[0];
        row[0] = (int)i;
        for (size_t j = 1; j <= lb; j++) {
            int up = row[j];
            int best = diag + (a[i - 1] != b[j - 1]);
            if (up + 1 < best) best = up + 1;
            if (row[j - 1] + 1 < best) best = row[j - 1] + 1;
            row[j] = best;
            diag = up;
        }
    }
    return row[lb] < 9 ? row[lb] : 9;
}

/* The command closest to a mistyped one (at most 2 edits away), or NULL. */
static const char *closest_command(const char *c) {
    const char *best = NULL;
    int bd = 3;
    for (size_t i = 0; i < NCOMMANDS; i++) {
        int d = edit_distance(c, commands[i].name);
        if (d < bd) bd = d, best = commands[i].name;
    }
    return best;
}

static int find_command(const char *c) {
    for (size_t i = 0; i < NCOMMANDS; i++)
        if (!strcmp(c, commands[i].name)) return (int)i;
    return -1;
}

static int unknown_command(const char *c) {
    const char *guess = closest_command(c);
    if (guess) fprintf(stderr, "sandmpm: unknown command \"%s\"; did you mean \"%s\"? (see sandmpm --help)\n", c, guess);
    else fprintf(stderr, "sandmpm: unknown command \"%s\" (see sandmpm --help)\n", c);
    return cli_exit_code(SM_ERR_INVALID);
}

/* `sandmpm help [COMMAND]`: the program's usage, or COMMAND --help. */
static int help(int argc, char **argv) {
    if (argc < 3) {
        cli_usage(stdout);
        return cli_exit_code(SM_OK);
    }
    int k = find_command(argv[2]);
    if (k < 0) return unknown_command(argv[2]);
    char *args[] = {"--help", NULL};
    return commands[k].run(1, args);
}

static int dispatch(int argc, char **argv) {
    if (argc < 2) {
        cli_usage(stderr);
        return cli_exit_code(SM_ERR_INVALID);
    }
    const char *c = argv[1];
    if (!strcmp(c, "--help") || !strcmp(c, "-h") || !strcmp(c, "help")) return help(argc, argv);
    if (!strcmp(c, "--version") || !strcmp(c, "-V")) {
        printf("sandmpm %s (%s precision)\n", sm_version(), sm_real_is_double() ? "double" : "float");
        return cli_exit_code(SM_OK);
    }
    int k = find_command(c);
    if (k >= 0) return commands[k].run(argc - 2, argv + 2);
    return unknown_command(c);
}

/* Under mpirun with several ranks only `run` runs (across the ranks, cli/ranks.c); a build
 * without MPI refuses rather than write one folder N times. */
static int refuse_ranks(int argc, char **argv, int ranks) {
    const int is_run = argc > 1 && !strcmp(argv[1], "run") && !cli_help_requested(argc - 2, argv + 2);
    if (!SM_HAVE_MPI)
        fprintf(stderr, "sandmpm: started as %d MPI ranks, but this build has no MPI (configure with SM_MPI=ON and "
                        "OpenMPI installed: libopenmpi-dev); run it without mpirun\n", ranks);
    else if (!is_run)
        fprintf(stderr, "sandmpm: started as %d MPI ranks; only `sandmpm run` runs across ranks, run the others "
                        "without mpirun\n", ranks);
    return !SM_HAVE_MPI || !is_run;
}

/* What went to stdout (info, bench's table, help) is checked too: a full disk or a closed pipe is
 * an I/O failure, not success. */
int main(int argc, char **argv) {
    const int ranks = cli_ranks_launched();
    if (ranks > 1 && refuse_ranks(argc, argv, ranks)) return cli_exit_code(SM_ERR_INVALID);
    if (!cli_ranks_init(&argc, &argv)) {
        fprintf(stderr, "sandmpm: MPI could not be started for %d ranks\n", ranks);
        return cli_exit_code(SM_ERR_INVALID);
    }
    int code = dispatch(argc, argv);
    if (fflush(stdout) != 0 || ferror(stdout)) {
        fprintf(stderr, "sandmpm: writing to the standard output failed: %s\n", strerror(errno));
        if (code == cli_exit_code(SM_OK)) code = cli_exit_code(SM_ERR_IO);
    }
    cli_ranks_finalize();
    return code;
}
