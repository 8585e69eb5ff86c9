/* sandmpm: the command-line program (DESIGN §2: thin — arguments, progress, exit codes).
 *
 *   sandmpm run [SCENE] [--out DIR] [--frames N | --end SECONDS] [--set KEY=VALUE]...
 *               [--threads N] [--quality preview|paper|test] [--render] [--video]
 *   sandmpm info SCENE [--set KEY=VALUE]... [--quality Q]
 *   sandmpm render OUTDIR [--color sand|speed|material|q] [--size WxH] [--threads N] [--video]
 *   sandmpm bench [--dim 2,3] [--precision float,double] [--threads 1,2] [--particles N] [--steps S]
 *                 [--warmup W] [--csv [--no-header]]
 *   sandmpm --help | COMMAND --help | --version
 *
 * Exit codes (cli/exit.c): 0 done, 2 bad input, 3 numerical failure, 4 I/O failure, 5 out of
 * memory. The commands are in cli/cmd_*.c. */
#include <errno.h>
#include <stdio.h>
#include <string.h>

#include "cli/cli.h"

static const struct {
    const char *name;
    int (*run)(int argc, char **argv);
} commands[] = {{"run", cli_run}, {"info", cli_info}, {"render", cli_render}, {"bench", cli_bench}};

static int dispatch(int argc, char **argv) {
    if (argc < 2) {
        cli_usage(stderr);
        return cli_exit_code(SM_ERR_INVALID);
    }
    const char *c = argv[1];
    if (!strcmp(c, "--help") || !strcmp(c, "-h") || !strcmp(c, "help")) {
        cli_usage(stdout);
        return cli_exit_code(SM_OK);
    }
    if (!strcmp(c, "--version")) {
        printf("sandmpm %s (%s precision)\n", sm_version(), sm_real_is_double() ? "double" : "float");
        return cli_exit_code(SM_OK);
    }
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        if (!strcmp(c, commands[i].name)) return commands[i].run(argc - 2, argv + 2);
    fprintf(stderr, "sandmpm: unknown command \"%s\" (see sandmpm --help)\n", c);
    return cli_exit_code(SM_ERR_INVALID);
}

/* What went to stdout (info, bench's table, help) is checked too: a full disk or a closed pipe is
 * an I/O failure, not success. */
int main(int argc, char **argv) {
    int code = dispatch(argc, argv);
    if (fflush(stdout) != 0 || ferror(stdout)) {
        fprintf(stderr, "sandmpm: writing to the standard output failed: %s\n", strerror(errno));
        if (code == cli_exit_code(SM_OK)) code = cli_exit_code(SM_ERR_IO);
    }
    return code;
}
