/* The sandmpm program's parts (DESIGN §2: thin — arguments, progress, exit codes):
 *   main.c      dispatch to a command
 *   exit.c      the one table from sm_status to exit code
 *   usage.c     the help texts
 *   options.c   what the commands share: option parsing, loading and building a scene, the video
 *   cmd_run.c   `sandmpm run`: the frame loop (app/run.h) with the sinks app/run_outputs.h chooses
 *               (as for Python's Scene.run), and the progress line (progress.c);
 *               out_folder.c: the output folder claimed for the run (no two runs' files mixed)
 *   cmd_info.c, cmd_render.c, cmd_bench.c: the other commands; signals.c: SIGINT and SIGTERM */
#ifndef SM_CLI_H
#define SM_CLI_H

#include <signal.h>
#include <stddef.h>
#include <stdio.h>

#include "app/run.h"
#include "app/run_manifest.h"
#include "app/run_outputs.h"
#include "app/scene.h"
#include "sandmpm/sandmpm.h"

extern const char sm_default_scene[]; /* scenes/default.lua, embedded at build time */

/* ------------------------------------------------------------------------------------------ */
/* exit.c                                                                                       */

/* The program's exit code for a command's status. */
int cli_exit_code(sm_status s);
/* The exit code of a command stopped by signal sig (the shell's convention, 128 + sig). */
int cli_exit_code_signal(int sig);
/* The status an exit code of this program (e.g. the bench sibling's) stands for. */
sm_status cli_status_of_exit_code(int code);
/* "exit codes: 0 done, 2 bad input, ..." and a newline. */
void cli_print_exit_codes(FILE *f);

/* ------------------------------------------------------------------------------------------ */
/* usage.c                                                                                      */

void cli_usage(FILE *f);
void cli_usage_run(FILE *f);
void cli_usage_info(FILE *f);
void cli_usage_render(FILE *f);
void cli_usage_bench(FILE *f);

/* The program of the other precision, in this program's directory (CMake: SM_SIBLING); "" if
 * the build has none. */
#ifndef SM_BENCH_SIBLING
#define SM_BENCH_SIBLING ""
#endif

/* ------------------------------------------------------------------------------------------ */
/* options.c                                                                                    */

#define CLI_MAX_PARAMS 64
#define CLI_MAX_FRAMES 10000000 /* frames of a run */

/* 1 if any argument is --help or -h: the command then prints its usage and does nothing else. */
int cli_help_requested(int argc, char **argv);
/* A whole number in [lo, hi] (1), or 0. */
int cli_parse_int(const char *s, long lo, long hi, int *out);
/* Warns on stderr when `threads` exceeds the cores online (a mistake, not an error). */
void cli_warn_threads(const char *cmd, int threads);
/* A finite number (1), or 0. */
int cli_parse_double(const char *s, double *out);

/* Options shared by run and info. */
typedef struct cli_scene_opts {
    const char *scene; /* the scene file, or NULL: the built-in default */
    sm_scene_param params[CLI_MAX_PARAMS];
    int nparams;
    const char *quality;
    int threads;
    char keybuf[4096]; /* the --set keys */
    size_t keybuf_used;
} cli_scene_opts;

/* Parses --set/--quality/--threads at argv[*i] (moving *i past its value); 1 if it was one of
 * them, 0 if not, -1 on error (message printed). */
int cli_parse_scene_opt(const char *cmd, int argc, char **argv, int *i, cli_scene_opts *so);
/* Loads the scene (file or the embedded default); message printed on failure. */
sm_status cli_load_scene(const char *cmd, const cli_scene_opts *so, sm_scene **sc);
/* Refuses a scene whose memory estimate exceeds 90% of this machine's memory. */
sm_status cli_check_memory(const char *cmd, const sm_scene_settings *st);
/* Builds the scene's world; message printed on failure. */
sm_status cli_build_scene(const char *cmd, sm_scene *sc);
/* so's scene loaded and built once more with hook on its world (sm_scene_on_world), its
 * warnings not printed again (errors are); *sc NULL on failure. */
sm_status cli_build_again(const char *cmd, const cli_scene_opts *so, sm_scene_world_hook hook, void *user,
                          sm_scene **sc);
/* Physical memory of this machine, bytes (0 if unknown). */
double cli_machine_bytes(void);

/* Default --checkpoint-every and --keep-checkpoints: the run's defaults (app/run_outputs.h). */
#define CLI_CHECKPOINT_EVERY SM_RUN_CHECKPOINT_EVERY
#define CLI_KEEP_CHECKPOINTS SM_RUN_KEEP_CHECKPOINTS

/* sandmpm info's estimates of a run (time, disk, memory) from a short probe of the built world;
 * the probe steps the world. SM_OK or the failing step's status (said on stderr). */
sm_status cli_info_estimates(sm_scene *sc);
/* The process's peak resident memory so far (getrusage), bytes; 0 if unknown. */
double cli_peak_memory_bytes(void);
/* Removes from dir the temporaries that a killed run or render left (app/io/files.h), saying so. */
sm_status cli_remove_stale(const char *cmd, const char *dir);
/* dir/video.mp4 from dir's PNG frames at fps (app/io/video.h); the outcome printed. */
sm_status cli_make_video(const char *dir, double fps);

/* ------------------------------------------------------------------------------------------ */
/* out_folder.c                                                                                 */

typedef struct cli_claim {
    int resume, overwrite; /* --resume, --overwrite */
} cli_claim;
/* Claims the (existing) folder out for a run described by *start (scene, hash, ...): refuses (exit
 * code 2, SM_ERR_INVALID, message printed) a folder holding another run's frames or frames
 * without a manifest unless overwrite; removes the listed files of an earlier run of the same
 * scene, or of any run with overwrite; with resume removes nothing and carries the earlier
 * manifest's frame lists and files into *start. SM_OK, SM_ERR_INVALID or SM_ERR_IO. */
sm_status cli_claim_folder(const char *out, const cli_claim *c, sm_run_manifest *start);

/* ------------------------------------------------------------------------------------------ */
/* signals.c                                                                                    */

/* 0, or the signal (SIGINT, SIGTERM) that asked the command to stop (after the frame in progress, or
 * at the next step: cli_signals_stop_at_step). */
extern volatile sig_atomic_t cli_stop;
/* Handles SIGINT and SIGTERM: the first sets cli_stop; the second removes the temporaries being
 * written, prints the last note and exits. */
void cli_signals_install(void);
/* What an immediate stop leaves complete, e.g. "sandmpm run: ...; frames 0..4 are complete in DIR/". */
void cli_signals_note(const char *note);
/* The first signal's message says the run stops at the next step (a run across ranks: app/run.h). */
void cli_signals_stop_at_step(void);
/* "SIGINT", "SIGTERM". */
const char *cli_signal_name(int sig);
/* A sink (app/run.h) that keeps the note up to date: the frames complete in the run's folder. */
sm_sink cli_interrupt_note_sink(void);

/* ------------------------------------------------------------------------------------------ */
/* The commands: argv after the command's name. Each prints its messages and returns its exit
 * code (exit.c). */

int cli_run(int argc, char **argv);
int cli_info(int argc, char **argv);
int cli_render(int argc, char **argv);
int cli_bench(int argc, char **argv);

/* progress.c: the run's banner and progress line on stderr, as a sink (app/run.h). */
typedef struct cli_progress_config {
    const char *scene_label; /* "scenes/castle.lua" or "default scene" */
    const char *quality;     /* "preview", ... */
    const char *out_dir;     /* the output folder, for the summary */
    int quiet, verbose;      /* -q: no banner, progress or summary; -v: a detailed line per frame */
    int ranks, threads;      /* MPI ranks (1: one process) and --threads (0: chosen per step) */
} cli_progress_config;
sm_sink cli_progress_sink(const cli_progress_config *config);

/* ------------------------------------------------------------------------------------------ */
/* ranks.c: `sandmpm run` under mpirun with several ranks (a build with MPI). Rank 0 writes, every
 * rank computes its share; on one process every call is the one-process answer. */

/* The ranks mpirun started (OpenMPI's or PMI's environment), 1 outside mpirun. */
int cli_ranks_launched(void);
/* MPI started if launched with several ranks (then the other ranks' stdout and stderr go to
 * /dev/null); 0 if that failed, or if several ranks were launched and the build has no MPI. */
int cli_ranks_init(int *argc, char ***argv);
void cli_ranks_finalize(void);
int cli_rank(void);        /* 0 on one process */
int cli_ranks_count(void); /* 1 on one process */
/* Rank 0's status, ints, bytes on every rank (collective; *data malloc'd on the others; 0 if out
 * of memory on any rank). */
sm_status cli_ranks_share_status(sm_status st);
/* A failure on any rank on every rank (the largest status code). */
sm_status cli_ranks_worst(sm_status st);
int cli_ranks_share_ints(int *v, int n);
int cli_ranks_share_bytes(unsigned char **data, size_t *len);

/* A distributed seeding (sandmpm_mpi.h's sm_dist_seeding) of the run's world and rank 0's view. */
typedef struct cli_seeding cli_seeding;
/* sc built for the run: over several ranks, from a census build of the scene loaded again (errors
 * printed, not warnings), then sc with only this rank's share of the particles; for a resume
 * (whose checkpoint holds the particles) sc as a census, with none stored (cli_resume restores and
 * distributes it). *seeding is set, for cli_ranks_open. On one process cli_build_scene(sc)
 * (*seeding NULL). Collective over the ranks. */
sm_status cli_ranks_build(const char *cmd, const cli_scene_opts *so, sm_scene *sc, int resume, cli_seeding **seeding);
/* The checkpoint at path restored into w (collective; the same status on every rank, rank 0's
 * message in err): on one process sm_world_restore_read, on several sm_world_restore_share (w then
 * distributed), each rank reading the file itself. */
sm_status cli_ranks_restore(sm_world *w, const char *path, char *err, size_t errlen);
/* resume.c: --resume, the newest valid checkpoint in out/checkpoints restored into w (collective);
 * *first = its frame + 1. Messages printed. */
sm_status cli_resume(sm_world *w, const char *out, uint64_t hash, int force, int *first);
/* Rank 0's view (see cli_ranks_open): the scene built again, without its particles when seeding
 * is not NULL (each frame's gathered world replaces them). */
sm_status cli_ranks_build_view(const char *cmd, const cli_scene_opts *so, cli_seeding *seeding, sm_scene **view);
void cli_seeding_free(cli_seeding *s);

typedef struct cli_ranks {
    int count, rank;
    sm_run_ranks hooks;           /* for sm_run_config.ranks when count > 1 */
    sm_world *view;               /* rank 0: the whole world at the last frame gathered (the
                                     caller's, built like the run's world) */
    unsigned long long *shares;   /* rank 0: each rank's particles at the last frame gathered or sliced */
    unsigned char *stream;        /* the gathered checkpoint stream's buffer */
    size_t stream_cap;
    struct sm_id_slice *slice;    /* this rank's id slice of the last frame (ranks_files.c) */
    sm_part_io part;              /* how the part sinks write with it */
} cli_ranks;
/* ranks_files.c, with MPI: the hooks' agreement (the worst status, the first failing rank's
 * message), the id slice hook (which counts the shares too), and the shares' count on rank 0. */
sm_status cli_ranks_agree(void *ctx, sm_status st, char *err, size_t errlen);
sm_status cli_ranks_slice(void *ctx, const sm_world *w, const sm_world **slice, const sm_part_io **part, char *err,
                          size_t errlen);
void cli_ranks_count_shares(cli_ranks *r, const sm_world *w);
/* With several ranks: w distributed over them (collective: sm_world_distribute_share when
 * cli_ranks_build gave a seeding, else sm_world_distribute) and the hooks set; view (rank 0;
 * NULL elsewhere): a world built like w, which each frame is gathered into. SM_OK, or the
 * failure with its message. */
sm_status cli_ranks_open(cli_ranks *r, sm_world *w, sm_world *view, cli_seeding *seeding, char *err, size_t errlen);
void cli_ranks_close(cli_ranks *r);

#endif
