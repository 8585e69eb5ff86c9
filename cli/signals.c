/* SIGINT and SIGTERM during `run` and `render`. The first asks to stop after the frame in
 * progress: the loop (app/run.h) checks cli_stop before computing the next frame, so every file
 * under its final name is whole and the command says what was written (across MPI ranks it stops
 * at the next step instead, keeping the last frame: cli_signals_stop_at_step). The second stops at once:
 * the handler removes the temporaries being written (app/io/files.h), prints the note of what is
 * complete so far, and exits. */
#define _POSIX_C_SOURCE 200809L
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "app/io/files.h"
#include "cli/cli.h"

volatile sig_atomic_t cli_stop = 0;

/* Two note buffers: the one being written is never the one the handler may read. */
static char notes[2][SM_MSG_MAX + 2];
static volatile sig_atomic_t note_current = 0;

static void say(const char *s) {
    size_t n = strlen(s);
    while (n > 0) {
        ssize_t w = write(STDERR_FILENO, s, n);
        if (w <= 0) return;
        s += w;
        n -= (size_t)w;
    }
}

/* Where the first signal stops: after the frame in progress, or (across ranks) at the next step. */
static volatile sig_atomic_t stop_at_step = 0;

void cli_signals_stop_at_step(void) { stop_at_step = 1; }

static void on_signal(int sig) {
    if (!cli_stop) {
        cli_stop = sig;
        say(sig == SIGINT ? "\nsandmpm: SIGINT: " : "\nsandmpm: SIGTERM: ");
        say(stop_at_step ? "stopping at the next step, keeping the last frame (again to stop at once)\n"
                         : "stopping after the frame in progress (again to stop at once)\n");
        return;
    }
    sm_remove_open_temporaries();
    say(notes[note_current]);
    _exit(cli_exit_code_signal(sig));
}

void cli_signals_install(void) {
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESTART;
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
}

void cli_signals_note(const char *note) {
    int next = 1 - note_current;
    size_t n = strlen(note);
    if (n > SM_MSG_MAX) n = SM_MSG_MAX;
    memcpy(notes[next], note, n);
    notes[next][n] = '\n';
    notes[next][n + 1] = 0;
    atomic_signal_fence(memory_order_seq_cst);
    note_current = next;
}

const char *cli_signal_name(int sig) { return sig == SIGINT ? "SIGINT" : sig == SIGTERM ? "SIGTERM" : "a signal"; }

static sm_status note_begin(sm_sink *s, const sm_run_info *run, char *err, size_t errlen) {
    (void)s, (void)err, (void)errlen;
    char note[SM_MSG_MAX];
    snprintf(note, sizeof note, "sandmpm run: stopped at once; no frame was completed in %s/", run->out_dir);
    cli_signals_note(note);
    return SM_OK;
}

static sm_status note_frame(sm_sink *s, const sm_run_frame *fr, char *err, size_t errlen) {
    (void)s, (void)err, (void)errlen;
    char note[SM_MSG_MAX];
    snprintf(note, sizeof note, "sandmpm run: stopped at once; frames 0..%d are complete in %s/", fr->frame, fr->out_dir);
    cli_signals_note(note);
    return SM_OK;
}

sm_sink cli_interrupt_note_sink(void) {
    sm_sink s = {"note", NULL, NULL, note_begin, note_frame, NULL, SM_SINK_STATE, 0};
    return s;
}
