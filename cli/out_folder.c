/* The output folder of `sandmpm run`, claimed for one run (app/run_manifest.h, docs/outputs.md):
 *   empty, or holding nothing of a run        the run starts
 *   an earlier run of the same scene (hash)   its listed files are removed, then the run starts
 *   another run, or frames without a manifest refused (exit 2) unless --overwrite, which removes
 *                                             the listed files (only those) first
 *   --resume                                  nothing is removed; the manifest goes on listing
 *                                             the frames before the checkpoint */
#define _POSIX_C_SOURCE 200809L
#include <string.h>

#include "app/io/files.h"
#include "cli/cli.h"

/* "frames 0..N" or "no frames" of a manifest (its longest frame list). */
static void frames_text(const sm_run_manifest *m, char *buf, size_t len) {
    int best = -1;
    for (int k = 0; k < SM_FRAME_KINDS; k++)
        if (sm_run_manifest_count(m, (sm_frame_kind)k) > 0 && (best < 0 || m->last[k] > m->last[best])) best = k;
    if (best < 0) snprintf(buf, len, "no frames");
    else snprintf(buf, len, "frames %d..%d", m->first[best], m->last[best]);
}

static int has_frames(const sm_run_manifest *m) {
    for (int k = 0; k < SM_FRAME_KINDS; k++)
        if (sm_run_manifest_count(m, (sm_frame_kind)k) > 0) return 1;
    return 0;
}

/* Removes what old lists, saying why. */
/* A killed run may have written the frame after the last one its manifest lists (the manifest
 * follows each frame): that frame file, of each kind, goes too. */
static void remove_unlisted_next(const char *out, const sm_run_manifest *old, int *removed) {
    for (int k = 0; k < SM_FRAME_KINDS; k++) {
        const int next = sm_run_manifest_count(old, (sm_frame_kind)k) > 0 ? old->last[k] + 1 : 0;
        char path[4096];
        if (snprintf(path, sizeof path, "%s/frame_%04d.%s", out, next, sm_frame_kind_ext((sm_frame_kind)k)) <
                (int)sizeof path &&
            remove(path) == 0)
            (*removed)++;
    }
}

static sm_status remove_old(const char *out, const sm_run_manifest *old, const char *why) {
    char err[SM_MSG_MAX], what[64];
    int removed = 0;
    frames_text(old, what, sizeof what);
    sm_status st = sm_run_manifest_remove(out, old, &removed, err, sizeof err);
    if (st == SM_OK) remove_unlisted_next(out, old, &removed);
    if (st != SM_OK) fprintf(stderr, "sandmpm run: %s\n", err);
    else if (removed > 0)
        fprintf(stderr, "sandmpm run: %s: removed %d file%s (%s) from %s/\n", why, removed, removed == 1 ? "" : "s", what,
                out);
    return st;
}

/* A folder without a manifest: refused if it holds frame files, unless overwrite. */
static sm_status claim_unlisted(const char *out, int overwrite) {
    sm_run_manifest old;
    char err[SM_MSG_MAX];
    int nfound = 0;
    sm_status st = sm_run_manifest_scan(out, &old, &nfound, err, sizeof err);
    if (st != SM_OK) {
        fprintf(stderr, "sandmpm run: %s\n", err);
        return st;
    }
    if (nfound == 0) return SM_OK;
    if (overwrite) return remove_old(out, &old, "--overwrite");
    fprintf(stderr,
            "sandmpm run: %s/ holds %d frame files (frame_NNNN.ply/.vtp/.png) but no %s: a run of an older sandmpm, "
            "or files of another program; refusing to mix them with this run. Use --overwrite to remove them (the frame "
            "files, frames.pvd, diagnostics.csv, render.txt, poses.csv, video.mp4, checkpoints/ckpt_*.smc), or --out "
            "to choose another folder\n",
            out, nfound, SM_RUN_MANIFEST_NAME);
    return SM_ERR_INVALID;
}

/* The old manifest's frames and files carried into a resumed run's. */
static void carry(sm_run_manifest *start, const sm_run_manifest *old) {
    memcpy(start->first, old->first, sizeof start->first);
    memcpy(start->last, old->last, sizeof start->last);
    start->files |= old->files;
}

sm_status cli_claim_folder(const char *out, const cli_claim *c, sm_run_manifest *start) {
    sm_run_manifest old;
    char err[SM_MSG_MAX], what[64];
    int found = 0;
    sm_status st = sm_run_manifest_read(out, &old, &found, err, sizeof err);
    if (c->resume) {
        if (st == SM_OK) carry(start, &old);
        else if (!found && sm_run_manifest_scan(out, &old, &found, err, sizeof err) == SM_OK) carry(start, &old);
        return SM_OK; /* resume_world checks the checkpoint's hash */
    }
    if (!found) return claim_unlisted(out, c->overwrite);
    if (st == SM_ERR_IO) { /* there, but unreadable */
        fprintf(stderr, "sandmpm run: %s\n", err);
        return st;
    }
    if (st != SM_OK) {
        if (c->overwrite) return claim_unlisted(out, 1);
        fprintf(stderr, "sandmpm run: %s; use --overwrite to remove the files of the run it belonged to, or --out "
                        "to choose another folder\n", err);
        return SM_ERR_INVALID;
    }
    if (old.scene_hash == start->scene_hash) return remove_old(out, &old, "replacing the earlier run of the same scene");
    if (c->overwrite || !has_frames(&old))
        return remove_old(out, &old, c->overwrite ? "--overwrite: the earlier run's files" : "an earlier run without frames");
    frames_text(&old, what, sizeof what);
    fprintf(stderr,
            "sandmpm run: %s/ holds %s of another run (%s, quality %s, scene hash %016llx; this run: %s, quality %s, "
            "hash %016llx); refusing to mix the two runs. Use --overwrite to remove that run's files (those listed in "
            "%s/%s, and only those), --resume to continue it, or --out to choose another folder\n",
            out, what, old.scene, old.quality, (unsigned long long)old.scene_hash, start->scene, start->quality,
            (unsigned long long)start->scene_hash, out, SM_RUN_MANIFEST_NAME);
    return SM_ERR_INVALID;
}
