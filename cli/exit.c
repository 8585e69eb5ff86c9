/* The one place the program's exit codes are chosen: a table from sm_status to exit code, and
 * 128 + the signal for a command stopped by SIGINT or SIGTERM. */
#include <signal.h>

#include "cli/cli.h"

static const struct {
    sm_status status;
    int code;
    const char *meaning;
} exit_table[] = {
    {SM_OK, 0, "done"},
    {SM_ERR_INVALID, 2, "bad input"},
    {SM_ERR_NUMERICAL, 3, "numerical failure"},
    {SM_ERR_IO, 4, "I/O failure"},
    {SM_ERR_NOMEM, 5, "out of memory"},
};
enum { EXIT_TABLE_SIZE = sizeof exit_table / sizeof exit_table[0] };

/* A status outside the table (a bug): the code of bad input is not right, so another. */
#define EXIT_UNKNOWN_STATUS 1

int cli_exit_code(sm_status s) {
    for (int i = 0; i < EXIT_TABLE_SIZE; i++)
        if (exit_table[i].status == s) return exit_table[i].code;
    return EXIT_UNKNOWN_STATUS;
}

int cli_exit_code_signal(int sig) { return 128 + sig; }

sm_status cli_status_of_exit_code(int code) {
    for (int i = 0; i < EXIT_TABLE_SIZE; i++)
        if (exit_table[i].code == code) return exit_table[i].status;
    return SM_ERR_IO; /* not ours: the other program failed in a way we cannot name */
}

void cli_print_exit_codes(FILE *f) {
    fprintf(f, "exit codes:");
    for (int i = 0; i < EXIT_TABLE_SIZE; i++)
        fprintf(f, "%s %d %s", i ? "," : "", exit_table[i].code, exit_table[i].meaning);
    fprintf(f, ", %d stopped by SIGINT (Ctrl-C), %d by SIGTERM\n", cli_exit_code_signal(SIGINT),
            cli_exit_code_signal(SIGTERM));
}
