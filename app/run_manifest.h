/* The run manifest, OUT/run_manifest.txt (docs/outputs.md): which run an output folder holds and
 * which of its files that run wrote, so that two runs' files cannot be mixed up. `sandmpm run`
 * writes it before frame 0 and rewrites it (atomically, app/io/files.h) after every frame, so
 * that it always lists what is on disk; `render` reads only the frames it lists; a run into a
 * folder holding another run's files removes exactly the files listed (--overwrite).
 *
 * Plain text, "KEY VALUE" a line, in this order (unknown keys are skipped by the reader):
 *   sandmpm-run 1                  the format
 *   version VERSION                sm_version() of the program that wrote it
 *   scene PATH                     the scene file ("(built in) scenes/default.lua" for the default)
 *   scene_hash HEX16               FNV-1a of the scene file, the --set pairs and the quality (the
 *                                  checkpoints' hash, docs/checkpoints.md)
 *   quality NAME
 *   fps FPS
 *   frames N                       the frames asked for: 0..N
 *   state running|complete|stopped|failed
 *   frame_files EXT FIRST LAST     frame_FIRST.EXT .. frame_LAST.EXT were written (EXT ply, vtp, png)
 *   file NAME                      a file of the run (frames.pvd, diagnostics.csv, render.txt,
 *                                  poses.csv, video.mp4), and "checkpoints" for checkpoints/ckpt_*.smc
 *   ranks N                        only for a run across N > 1 MPI ranks: N,
 *   threads_per_rank T|auto        the threads in each (auto: chosen per step),
 *   rank_particles N0 N1 ...       and each rank's particles at the last frame written */
#ifndef SM_APP_RUN_MANIFEST_H
#define SM_APP_RUN_MANIFEST_H

#include <stdint.h>

#include "app/run.h"

#define SM_RUN_MANIFEST_NAME "run_manifest.txt"

/* The frame files of a run, by extension. */
typedef enum sm_frame_kind { SM_FRAME_PLY, SM_FRAME_VTP, SM_FRAME_PNG, SM_FRAME_KINDS } sm_frame_kind;
/* The other files, as bits of sm_run_manifest.files. */
enum {
    SM_RUNFILE_PVD = 1,
    SM_RUNFILE_CSV = 2,
    SM_RUNFILE_RENDER = 4,
    SM_RUNFILE_POSES = 8,
    SM_RUNFILE_VIDEO = 16,
    SM_RUNFILE_CHECKPOINTS = 32,
    SM_RUNFILE_COUNT = 6
};

typedef struct sm_run_manifest {
    char scene[1024];
    uint64_t scene_hash;
    char quality[32];
    double fps;
    int frames;
    char state[16];
    int first[SM_FRAME_KINDS], last[SM_FRAME_KINDS]; /* frames written; last < first: none */
    unsigned files;                                  /* SM_RUNFILE_* */
    /* A run across MPI ranks (written when ranks > 1, not read back): the ranks, the threads per
     * rank (0: chosen per step) and each rank's particles at the last frame (the caller's array of
     * ranks counts, alive while the manifest is written). */
    int ranks, threads;
    const unsigned long long *rank_particles;
} sm_run_manifest;

/* "ply", "vtp", "png"; the name of file bit b (one of SM_RUNFILE_*). */
const char *sm_frame_kind_ext(sm_frame_kind k);
const char *sm_runfile_name(unsigned bit);

/* An empty manifest (no frames, no files). */
void sm_run_manifest_init(sm_run_manifest *m);
/* Frames of kind k written (0 if none). */
int sm_run_manifest_count(const sm_run_manifest *m, sm_frame_kind k);

/* Reads dir/run_manifest.txt. SM_OK; SM_ERR_IO if there is none (*found = 0) or it cannot be
 * read; SM_ERR_INVALID if it is malformed (the message names the line). */
sm_status sm_run_manifest_read(const char *dir, sm_run_manifest *m, int *found, char *err, size_t errlen);
/* Writes dir/run_manifest.txt atomically. SM_OK or SM_ERR_IO with a message. */
sm_status sm_run_manifest_write(const char *dir, const sm_run_manifest *m, char *err, size_t errlen);

/* A manifest for a folder without one (an older version's run): the frame_NNNN.ply/.vtp/.png
 * files found (each kind's smallest to largest number) and every other file name. *nfound: the
 * frame files. SM_OK or SM_ERR_IO (the folder cannot be read). */
sm_status sm_run_manifest_scan(const char *dir, sm_run_manifest *m, int *nfound, char *err, size_t errlen);

/* Removes the files m lists from dir (absent ones are skipped), checkpoints/ckpt_*.smc if listed
 * and checkpoints/ once empty, then run_manifest.txt. *removed: files removed. SM_OK or SM_ERR_IO
 * naming the file that could not be removed. */
sm_status sm_run_manifest_remove(const char *dir, const sm_run_manifest *m, int *removed, char *err, size_t errlen);

/* The sink that keeps dir/run_manifest.txt up to date (app/run.h): written at begin with state
 * "running", after each frame with that frame added to the kinds in *written, at the end with
 * the final state. config: the manifest to start from (a resume's carries the frames before it),
 * alive through the run; *written is a bit mask of 1 << sm_frame_kind. It must come after the
 * sinks that write the files of a frame. */
typedef struct sm_run_manifest_config {
    sm_run_manifest start;
    unsigned written;
} sm_run_manifest_config;
sm_sink sm_sink_run_manifest(const sm_run_manifest_config *config);

#endif
