/* The frame loop of `sandmpm run`: advance a world frame by frame and hand every frame to a list
 * of sinks, the writers of a run's outputs (app/sinks.h: PLY, VTK, diagnostics CSV, the render
 * manifest, PNG renders; cli/: the progress line). A sink sees a run begin, each frame (0 is the
 * initial state, then every 1/fps s), and the end with the run's status; a checkpoint writer or a
 * gather of distributed particles is one more sink, and the loop does not change.
 *
 *   begin  in list order, before frame 0; a failure stops the run before any frame
 *   frame  in list order, for frames 0..frames; a failure stops the run after that frame
 *   end    for every sink whose begin succeeded, in list order, with the run's status (SM_OK if
 *          all frames were written); it closes what the sink holds, and may itself fail
 * begin and end may be NULL (a sink that holds nothing between frames). */
#ifndef SM_APP_RUN_H
#define SM_APP_RUN_H

#include <signal.h>
#include <stddef.h>

#include "app/io/part_file.h"
#include "sandmpm/sandmpm.h"

/* What every sink knows of the run. */
typedef struct sm_run_info {
    const char *out_dir; /* the output folder (exists) */
    sm_world *w;         /* the world, built */
    int frames;          /* frames after frame 0 */
    double fps;          /* frames per second of simulated time */
    int first_frame;     /* the first frame the loop hands to the sinks: 0, or after a resume from a
                            checkpoint of frame F, F + 1 (the world is then at F's time) */
    const sm_diagnostics *d; /* the world's diagnostics as the loop starts (across ranks: all of them) */
    int writer;          /* 1 on the rank that writes whole files (one process: 1) */
} sm_run_info;

/* One frame as the sinks see it. */
typedef struct sm_run_frame {
    const char *out_dir;      /* the output folder */
    int frame;                /* 0 .. frames */
    const sm_world *w;        /* the world at the frame's time */
    const sm_diagnostics *d;  /* its diagnostics (min/max dt: the steps since the previous frame) */
    double start_wall;        /* monotonic wall clock (sm_run_wall) when the loop started */
    const sm_part_io *part;   /* for a part sink across ranks: how to write this rank's parts of a
                                 file, w being this rank's id slice; NULL on one process (and for
                                 the other scopes), w the whole world */
} sm_run_frame;

/* Which world a sink needs across MPI ranks (on one process every sink runs with the world):
 *   WHOLE  runs on the writer rank with every particle gathered there (PNG renders, a caller's
 *          frame hook): the default, and the only scope that holds the whole run on one rank
 *   STATE  runs on the writer rank with its own part of the world: it reads only what every rank
 *          holds alike (the clock, colliders, definitions) and the diagnostics in sm_run_frame
 *   PART   runs on every rank with its slice of the run in id order (sm_run_frame.part), and
 *          writes its parts of one file (PLY, VTP, checkpoints) */
typedef enum sm_sink_scope { SM_SINK_WHOLE = 0, SM_SINK_STATE = 1, SM_SINK_PART = 2 } sm_sink_scope;

typedef struct sm_sink sm_sink;
struct sm_sink {
    const char *name;   /* for messages: "ply", "vtk", ... */
    const void *config; /* the sink's settings (the caller's, alive through the run), or NULL */
    void *state;        /* the sink's own, from begin to end */
    sm_status (*begin)(sm_sink *s, const sm_run_info *run, char *err, size_t errlen);
    sm_status (*frame)(sm_sink *s, const sm_run_frame *fr, char *err, size_t errlen);
    sm_status (*end)(sm_sink *s, sm_status run_status, char *err, size_t errlen);
    sm_sink_scope scope;
    int stopped; /* set by the loop before end: 1 if the stop flag ended the run early */
};

/* A run across MPI ranks (cli/ranks.c): every rank runs the frame loop and advances its part of
 * the world; the sinks run where their scope says. The whole world is gathered on the writer only
 * at frames when some WHOLE sink runs. NULL in sm_run_config.ranks for a run on one process. Each
 * call is collective (every rank, in step). */
typedef struct sm_run_ranks {
    void *ctx;
    int writer; /* 1 on the rank that runs the sinks (rank 0) */
    /* The world the sinks see at this frame on the writer: every rank's particles in id order
     * (NULL elsewhere); a failure's status with its message in err, on every rank. */
    sm_status (*gather)(void *ctx, const sm_world *w, sm_world **view, char *err, size_t errlen);
    /* The writer's status (and message) on every rank. */
    sm_status (*agree)(void *ctx, sm_status st, char *err, size_t errlen);
    /* Non-zero on every rank if flag is non-zero on any. */
    int (*any)(void *ctx, int flag);
    /* This rank's id slice of w (valid until the next call) and how its part sinks write; a
     * failure's status with its message, on every rank. */
    sm_status (*slice)(void *ctx, const sm_world *w, const sm_world **slice, const sm_part_io **part, char *err,
                       size_t errlen);
} sm_run_ranks;

/* The run's settings beyond the sinks. */
typedef struct sm_run_config {
    sm_run_info info;
    /* NULL, or a check after each advance: a message (e.g. a scene's motion-function error) stops
     * the run with SM_ERR_INVALID. */
    const char *(*world_error)(void *ctx);
    void *world_error_ctx;
    /* NULL, or a flag that, once non-zero, stops the run before the next frame is computed (a
     * signal handler sets it). With stop_at_step it stops the run at the next step instead
     * (sm_world_set_interrupt), the world in the middle of a frame: for a writer that still holds
     * the last frame (across ranks the writer's gathered view; on one process the checkpoint
     * sink's copy, which its end then writes). A frame can take minutes, longer than a launcher
     * waits after a signal (mpirun: 1 s, a batch system's grace time). */
    volatile sig_atomic_t *stop;
    int stop_at_step;
    const sm_run_ranks *ranks; /* NULL, or a run across MPI ranks */
} sm_run_config;

typedef struct sm_run_result {
    int frames_written; /* frames every sink wrote: frames 0 .. frames_written - 1 */
    int stopped;        /* 1 if *stop ended the run early */
    const char *failed_sink; /* the sink whose begin, frame or end failed, or NULL */
} sm_run_result;

/* Runs frames info.first_frame..info.frames through the sinks. Returns SM_OK, or the first failure's status
 * with its message in err (a world's failure: the frame, the times and its sm_world_errmsg). */
sm_status sm_run_frames(const sm_run_config *cfg, sm_sink *sinks, int nsinks, sm_run_result *res, char *err,
                        size_t errlen);

/* Monotonic wall clock, s. */
double sm_run_wall(void);

/* Seconds since the loop started, for a frame. */
double sm_run_elapsed(const sm_run_frame *fr);

#endif
