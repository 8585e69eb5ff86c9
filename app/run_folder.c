/* The output folder claimed for a run (app/run_folder.h). */
#define _POSIX_C_SOURCE 200809L
#include "app/run_folder.h"

#include <stdio.h>
#include <string.h>

#include "app/io/files.h"

void sm_run_manifest_frames_text(const sm_run_manifest *m, char *buf, size_t len) {
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

/* Removes what c->old lists, and the frame after its last of each kind. */
static sm_status remove_old(const char *out, sm_folder_claim *c, sm_claim_outcome outcome, char *err, size_t errlen) {
    sm_status st = sm_run_manifest_remove(out, &c->old, &c->removed, err, errlen);
    for (int k = 0; st == SM_OK && k < SM_FRAME_KINDS; k++) {
        const int next = sm_run_manifest_count(&c->old, (sm_frame_kind)k) > 0 ? c->old.last[k] + 1 : 0;
        char path[SM_PATH_MAX];
        if (snprintf(path, sizeof path, "%s/frame_%04d.%s", out, next, sm_frame_kind_ext((sm_frame_kind)k)) <
                (int)sizeof path &&
            remove(path) == 0)
            c->removed++;
    }
    c->outcome = st == SM_OK ? outcome : SM_CLAIM_FAILED;
    return st;
}

/* The folder without a (readable) manifest: refused if it holds frame files, unless overwrite. */
static sm_status claim_unlisted(const char *out, int overwrite, sm_folder_claim *c, char *err, size_t errlen) {
    c->unlisted = 1;
    sm_status st = sm_run_manifest_scan(out, &c->old, &c->found_files, err, errlen);
    if (st != SM_OK) {
        c->outcome = SM_CLAIM_FAILED;
        return st;
    }
    if (c->found_files == 0) return SM_OK;
    if (overwrite) return remove_old(out, c, SM_CLAIM_OVERWRITTEN, err, errlen);
    c->outcome = SM_CLAIM_REFUSED_UNLISTED;
    return SM_ERR_INVALID;
}

sm_status sm_claim_folder(const char *out, const sm_run_manifest *start, int overwrite, sm_folder_claim *c, char *err,
                          size_t errlen) {
    memset(c, 0, sizeof *c);
    c->outcome = SM_CLAIM_EMPTY;
    if (errlen) err[0] = 0;
    int found = 0;
    sm_status st = sm_run_manifest_read(out, &c->old, &found, err, errlen);
    if (!found) return claim_unlisted(out, overwrite, c, err, errlen);
    if (st == SM_ERR_IO) { /* there, but unreadable */
        c->outcome = SM_CLAIM_FAILED;
        return st;
    }
    if (st != SM_OK) {
        if (overwrite) return claim_unlisted(out, 1, c, err, errlen);
        c->outcome = SM_CLAIM_REFUSED_MANIFEST;
        return SM_ERR_INVALID;
    }
    if (c->old.scene_hash == start->scene_hash) return remove_old(out, c, SM_CLAIM_SAME_SCENE, err, errlen);
    if (overwrite) return remove_old(out, c, SM_CLAIM_OVERWRITTEN, err, errlen);
    if (!has_frames(&c->old)) return remove_old(out, c, SM_CLAIM_NO_FRAMES, err, errlen);
    c->outcome = SM_CLAIM_REFUSED_OTHER;
    return SM_ERR_INVALID;
}
