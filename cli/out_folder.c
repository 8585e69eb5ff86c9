/* The output folder of `sandmpm run`, claimed for one run: app/run_folder.h's rules, worded for
 * the command line (what was removed and why; a refusal names --overwrite, --resume and --out);
 *   --resume   nothing is removed; the manifest goes on listing the frames before the checkpoint */
#define _POSIX_C_SOURCE 200809L
#include <string.h>

#include "app/io/files.h"
#include "app/run_folder.h"
#include "cli/cli.h"

/* The old manifest's frames and files carried into a resumed run's. */
static void carry(sm_run_manifest *start, const sm_run_manifest *old) {
    memcpy(start->first, old->first, sizeof start->first);
    memcpy(start->last, old->last, sizeof start->last);
    start->files |= old->files;
}

/* What was removed, and why. */
static void say_removed(const char *out, const sm_folder_claim *c) {
    const char *why = c->outcome == SM_CLAIM_SAME_SCENE ? "replacing the earlier run of the same scene"
                      : c->outcome == SM_CLAIM_NO_FRAMES ? "an earlier run without frames"
                      : c->unlisted                      ? "--overwrite"
                                                         : "--overwrite: the earlier run's files";
    char what[64];
    sm_run_manifest_frames_text(&c->old, what, sizeof what);
    if (c->removed > 0)
        fprintf(stderr, "sandmpm run: %s: removed %d file%s (%s) from %s/\n", why, c->removed, c->removed == 1 ? "" : "s",
                what, out);
}

/* Why the folder was refused. */
static void say_refused(const char *out, const sm_folder_claim *c, const sm_run_manifest *start, const char *err) {
    char what[64];
    if (c->outcome == SM_CLAIM_REFUSED_UNLISTED) {
        fprintf(stderr,
                "sandmpm run: %s/ holds %d frame files (frame_NNNN.ply/.vtp/.png) but no %s: a run of an older sandmpm, "
                "or files of another program; refusing to mix them with this run. Use --overwrite to remove them (the "
                "frame files, frames.pvd, diagnostics.csv, render.txt, poses.csv, video.mp4, checkpoints/ckpt_*.smc), "
                "or --out to choose another folder\n",
                out, c->found_files, SM_RUN_MANIFEST_NAME);
    } else if (c->outcome == SM_CLAIM_REFUSED_MANIFEST) {
        fprintf(stderr, "sandmpm run: %s; use --overwrite to remove the files of the run it belonged to, or --out "
                        "to choose another folder\n", err);
    } else {
        sm_run_manifest_frames_text(&c->old, what, sizeof what);
        fprintf(stderr,
                "sandmpm run: %s/ holds %s of another run (%s, quality %s, scene hash %016llx; this run: %s, quality "
                "%s, hash %016llx); refusing to mix the two runs. Use --overwrite to remove that run's files (those "
                "listed in %s/%s, and only those), --resume to continue it, or --out to choose another folder\n",
                out, what, c->old.scene, c->old.quality, (unsigned long long)c->old.scene_hash, start->scene,
                start->quality, (unsigned long long)start->scene_hash, out, SM_RUN_MANIFEST_NAME);
    }
}

sm_status cli_claim_folder(const char *out, const cli_claim *c, sm_run_manifest *start) {
    char err[SM_MSG_MAX];
    if (c->resume) {
        sm_run_manifest old;
        int found = 0;
        sm_status st = sm_run_manifest_read(out, &old, &found, err, sizeof err);
        if (st == SM_OK) carry(start, &old);
        else if (!found && sm_run_manifest_scan(out, &old, &found, err, sizeof err) == SM_OK) carry(start, &old);
        return SM_OK; /* resume_world checks the checkpoint's hash */
    }
    sm_folder_claim fc;
    sm_status st = sm_claim_folder(out, start, c->overwrite, &fc, err, sizeof err);
    if (fc.outcome == SM_CLAIM_FAILED) fprintf(stderr, "sandmpm run: %s\n", err);
    else if (st != SM_OK) say_refused(out, &fc, start, err);
    else say_removed(out, &fc);
    return st;
}
