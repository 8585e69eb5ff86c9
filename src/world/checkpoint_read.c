/* Reading a checkpoint stream (sandmpm.h: sm_world_load, sm_world_restore, sm_world_restore_read;
 * sandmpm_mpi.h: sm_world_restore_share through a filter). What is saved, derived and scratch:
 * checkpoint.c. */
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "world/checkpoint_format.h"
#include "world/world.h"

/* The stream is read at offsets through an sm_pread_fn: from memory (sm_world_load,
 * sm_world_restore) or from a file (sm_world_restore_read), so a reader never needs the whole
 * stream in memory. A read past the end, or a failed read, makes every later get fail. */
typedef struct reader {
    sm_pread_fn fn;
    void *user;
    uint64_t at, len;
    int short_read, io_error;
    const sm_restore_filter *filter; /* NULL: every particle */
    int cut_done;                    /* the filter's cut was called */
} reader;

static int memory_read(void *user, uint64_t offset, void *dst, size_t n) {
    memcpy(dst, (const unsigned char *)user + offset, n);
    return 0;
}

static uint64_t rest(const reader *r) { return r->len - r->at; }

static int get(reader *r, void *dst, size_t n) {
    if (n == 0) return !r->short_read; /* dst may be NULL (an empty array) */
    if (r->short_read || n > rest(r)) {
        r->short_read = 1;
        memset(dst, 0, n);
        return 0;
    }
    if (r->fn(r->user, r->at, dst, n) != 0) {
        r->short_read = r->io_error = 1;
        memset(dst, 0, n);
        return 0;
    }
    r->at += n;
    return 1;
}

/* n bytes at stream offset off, r's position unchanged. */
static int get_at(reader *r, uint64_t off, void *dst, size_t n) {
    const uint64_t at = r->at;
    r->at = off;
    const int ok = get(r, dst, n);
    r->at = at;
    return ok;
}
static uint32_t get_u32(reader *r) {
    uint32_t v;
    get(r, &v, sizeof v);
    return v;
}
static uint64_t get_u64(reader *r) {
    uint64_t v;
    get(r, &v, sizeof v);
    return v;
}
static double get_f64(reader *r) {
    double v;
    get(r, &v, sizeof v);
    return v;
}

static sm_status bad(char *err, size_t errlen, const char *what) {
    if (err && errlen) snprintf(err, errlen, "checkpoint: %s", what);
    return SM_ERR_INVALID;
}

/* The header and the world definition; checks them. */
static sm_status read_header(reader *r, sm_world_def *def, char *err, size_t errlen) {
    char magic[8];
    get(r, magic, 8);
    if (r->short_read || memcmp(magic, CKPT_MAGIC, 8) != 0) return bad(err, errlen, "not a sandmpm checkpoint (wrong magic)");
    const uint32_t version = get_u32(r), endian = get_u32(r), real = get_u32(r), dim = get_u32(r);
    char msg[160];
    if (r->short_read) return bad(err, errlen, "truncated in the header");
    if (version < CKPT_VERSION_OLDEST || version > CKPT_VERSION) {
        snprintf(msg, sizeof msg, "format version %u, this build reads %u to %u", version, CKPT_VERSION_OLDEST, CKPT_VERSION);
        return bad(err, errlen, msg);
    }
    if (endian != CKPT_ENDIAN) return bad(err, errlen, "written on a machine of another byte order");
    if (real != sizeof(sm_real)) {
        snprintf(msg, sizeof msg, "written by a %s build, this is a %s build", real == 8 ? "double" : real == 4 ? "float" : "unknown",
                 sizeof(sm_real) == 8 ? "double" : "float");
        return bad(err, errlen, msg);
    }
    get(r, def, version == 3 ? offsetof(sm_world_def, contact_gap) : sizeof *def);
    if (version == 3) def->contact_gap = INFINITY;
    if (r->short_read) return bad(err, errlen, "truncated in the world definition");
    if (dim != 2 && dim != 3) return bad(err, errlen, "dimension is not 2 or 3");
    if ((uint32_t)def->dim != dim) return bad(err, errlen, "dimension of the header and the definition differ");
    def->threads = 0;
    char e2[256];
    if (sm_world_def_check(def, e2, sizeof e2) != SM_OK) {
        snprintf(msg, sizeof msg, "world definition: %.120s", e2);
        return bad(err, errlen, msg);
    }
    return SM_OK;
}

/* The definitions: materials, colliders (with their step state) and emitters (with their
 * counters). build = 1 adds them to w (sm_world_load); build = 0 checks that w has the same
 * numbers of each and keeps w's definitions, e.g. its motion functions (sm_world_restore). */
static sm_status read_defs(reader *r, sm_world *w, int build) {
    const uint32_t nm = get_u32(r);
    if (r->short_read) return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: truncated before the materials");
    if (nm > 65536 || nm * sizeof(sm_material_def) > rest(r)) return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: %u materials do not fit the data", nm);
    if (!build && nm != (uint32_t)w->nmats)
        return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: %u materials, the world has %d", nm, w->nmats);
    for (uint32_t i = 0; i < nm; i++) {
        sm_material_def m;
        get(r, &m, sizeof m);
        if (build && sm_world_add_material(w, &m, NULL) != SM_OK) return SM_ERR_INVALID;
    }
    const uint32_t nc = get_u32(r);
    if (r->short_read || nc > 1u << 20) return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: truncated or bad collider count");
    if (!build && nc != (uint32_t)w->ncolliders)
        return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: %u colliders, the world has %d", nc, w->ncolliders);
    for (uint32_t i = 0; i < nc && !r->short_read; i++) {
        sm_collider_def c;
        get(r, &c, sizeof c);
        (void)get_u32(r); /* had a motion function: the caller re-attaches it (restore keeps it) */
        c.motion = NULL;
        c.motion_user = NULL;
        if (r->short_read) break;
        for (int k = 0; build && k < c.shape_count && k < SM_MAX_COLLIDER_SHAPES; k++)
            if (c.shapes[k].kind == SM_SHAPE_MESH)
                return sm_world_fail(w, SM_ERR_INVALID,
                                     "checkpoint: collider %u has a mesh shape, whose field a checkpoint does not hold: "
                                     "restore it into a world built with its colliders (sm_world_restore)", i);
        if (build && sm_world_add_collider(w, &c, NULL) != SM_OK) return SM_ERR_INVALID;
        sm_collider *s = &w->colliders[i];
        s->t0 = get_f64(r);
        s->dt = get_f64(r);
        get(r, &s->pose0, sizeof s->pose0);
        get(r, &s->pose1, sizeof s->pose1);
        get(r, s->R0, sizeof s->R0);
        get(r, s->R1, sizeof s->R1);
        get(r, s->v, sizeof s->v);
        get(r, s->w, sizeof s->w);
    }
    const uint32_t ne = get_u32(r);
    if (r->short_read || ne > 1u << 20) return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: truncated or bad emitter count");
    if (!build && ne != (uint32_t)w->nemitters)
        return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: %u emitters, the world has %d", ne, w->nemitters);
    for (uint32_t i = 0; i < ne && !r->short_read; i++) {
        sm_emitter_def e;
        get(r, &e, sizeof e);
        if (r->short_read) break;
        if (build && e.shape.kind == SM_SHAPE_MESH)
            return sm_world_fail(w, SM_ERR_INVALID,
                                 "checkpoint: emitter %u has a mesh shape, whose field a checkpoint does not hold: "
                                 "restore it into a world built with its emitters (sm_world_restore)", i);
        if (build && sm_world_add_emitter(w, &e, NULL) != SM_OK) return SM_ERR_INVALID;
        w->emitters[i].owed = get_f64(r);
        w->emitters[i].emitted = get_u64(r);
    }
    if (r->short_read) return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: truncated in the colliders or emitters");
    return SM_OK;
}

static void read_clock(reader *r, sm_world *w) {
    w->time = get_f64(r);
    w->steps = get_u64(r);
    w->last_dt = get_f64(r);
    w->min_dt = get_f64(r);
    w->max_dt = get_f64(r);
    get(r, w->stage_seconds, sizeof w->stage_seconds);
    w->clamped = get_u64(r);
    w->projected = get_u64(r);
    get(r, &w->newton, sizeof w->newton);
    w->step_vmax2 = get_f64(r);
    w->step_bad = get_u32(r) != 0;
    w->dirty = get_u32(r) != 0;
    w->failed = get_u32(r) != 0;
    w->next_id = get_u64(r);
    w->bins.reorders = get_u64(r);
}

/* The particle fields' table, checked against this build's descriptor table (same names, element
 * sizes and counts in the same order); data_at[k] the stream offset of field k's n values. r ends
 * after the last field's values. */
static sm_status read_field_table(reader *r, sm_world *w, uint64_t n, uint64_t data_at[SM_PARTICLE_NFIELDS]) {
    for (int k = 0; k < SM_PARTICLE_NFIELDS; k++) {
        const sm_particle_field f = sm_particle_field_info(w->dim, k);
        char name[CKPT_MAX_NAME];
        get(r, name, sizeof name);
        name[CKPT_MAX_NAME - 1] = 0;
        const uint32_t es = get_u32(r), count = get_u32(r);
        if (r->short_read) return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: truncated in the particle fields");
        if (strcmp(name, f.name) != 0 || es != f.elem_size || count != (uint32_t)f.count)
            return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: particle field %d is '%s' (%u x %u bytes), this build has '%s' (%d x %zu)",
                                 k, name, count, es, f.name, f.count, f.elem_size);
        const uint64_t bytes = n * count * es;
        if (bytes > rest(r)) return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: truncated in particle field '%s'", f.name);
        data_at[k] = r->at;
        r->at += bytes;
    }
    return SM_OK;
}

static sm_status reserve_particles(sm_world *w, size_t n) {
    if (sm_particles_reserve(&w->p, w->dim, n) != SM_OK || sm_bins_reserve_perm(&w->bins, w->p.cap) != SM_OK)
        return sm_world_fail(w, SM_ERR_NOMEM, "checkpoint: out of memory for %zu particles", n);
    return SM_OK;
}

/* Every particle: each field's values read straight into its array. */
static sm_status read_all(reader *r, sm_world *w, size_t n, const uint64_t *data_at) {
    sm_status st = reserve_particles(w, n);
    for (int k = 0; k < SM_PARTICLE_NFIELDS && st == SM_OK; k++) {
        const sm_particle_field f = sm_particle_field_info(w->dim, k);
        if (!get_at(r, data_at[k], sm_particles_field_data(&w->p, k), n * (size_t)f.count * f.elem_size))
            st = sm_world_fail(w, SM_ERR_INVALID, "checkpoint: truncated in particle field '%s'", f.name);
    }
    if (st == SM_OK) w->p.n = n;
    return st;
}

#define READ_CHUNK ((size_t)1 << 16) /* particles per read of a field in a filtered read */

/* The filter's two passes over the positions (field 0, double): census(x) of every particle, the
 * cut, then keep(x): the indices of the kept particles, ascending, into *kept (malloc'd). */
static sm_status choose_kept(reader *r, sm_world *w, size_t n, uint64_t x_at, uint32_t **kept, size_t *nkept) {
    const sm_restore_filter *flt = r->filter;
    const size_t each = (size_t)w->dim * sizeof(double);
    double *x = malloc(READ_CHUNK * each);
    size_t cap = 0, nk = 0;
    uint32_t *idx = NULL;
    sm_status st = x ? SM_OK : sm_world_fail(w, SM_ERR_NOMEM, "checkpoint: out of memory");
    for (int pass = 0; pass < 2; pass++) {
        if (pass == 1) {
            char msg[256] = "";
            r->cut_done = 1;
            const sm_status cs = flt->cut(flt->user, st, msg, sizeof msg); /* collective */
            if (st == SM_OK && cs != SM_OK) st = sm_world_fail(w, cs, "%s", msg);
        }
        for (size_t c = 0; c < n && st == SM_OK; c += READ_CHUNK) {
            const size_t m = n - c < READ_CHUNK ? n - c : READ_CHUNK;
            if (!get_at(r, x_at + c * each, x, m * each)) st = sm_world_fail(w, SM_ERR_INVALID, "checkpoint: truncated in the positions");
            for (size_t i = 0; i < m && st == SM_OK; i++) {
                double p[3] = {0, 0, 0};
                memcpy(p, x + i * (size_t)w->dim, each);
                if (pass == 0) flt->census(flt->user, p);
                else if (flt->keep(flt->user, p)) {
                    if (nk == cap) {
                        cap = cap ? 2 * cap : 4096;
                        uint32_t *q = realloc(idx, cap * sizeof *q);
                        if (!q) st = sm_world_fail(w, SM_ERR_NOMEM, "checkpoint: out of memory for the kept particles");
                        else idx = q;
                    }
                    if (st == SM_OK) idx[nk++] = (uint32_t)(c + i);
                }
            }
        }
    }
    free(x);
    if (st != SM_OK) free(idx), idx = NULL, nk = 0;
    *kept = idx;
    *nkept = nk;
    return st;
}

/* The kept particles only: each field read a chunk at a time (chunks without a kept particle
 * skipped), its kept values packed into the field's array in stream order. */
static sm_status read_kept(reader *r, sm_world *w, size_t n, const uint64_t *data_at) {
    uint32_t *kept;
    size_t nk;
    sm_status st = choose_kept(r, w, n, data_at[0], &kept, &nk);
    if (st == SM_OK) st = reserve_particles(w, nk);
    size_t widest = 0;
    for (int k = 0; k < SM_PARTICLE_NFIELDS; k++) {
        const sm_particle_field f = sm_particle_field_info(w->dim, k);
        if ((size_t)f.count * f.elem_size > widest) widest = (size_t)f.count * f.elem_size;
    }
    unsigned char *buf = st == SM_OK ? malloc(READ_CHUNK * widest) : NULL;
    if (st == SM_OK && !buf) st = sm_world_fail(w, SM_ERR_NOMEM, "checkpoint: out of memory");
    for (int k = 0; k < SM_PARTICLE_NFIELDS && st == SM_OK; k++) {
        const sm_particle_field f = sm_particle_field_info(w->dim, k);
        const size_t each = (size_t)f.count * f.elem_size;
        unsigned char *dst = sm_particles_field_data(&w->p, k);
        for (size_t j = 0; j < nk && st == SM_OK;) {
            const size_t c = kept[j] / READ_CHUNK * READ_CHUNK, m = n - c < READ_CHUNK ? n - c : READ_CHUNK;
            if (!get_at(r, data_at[k] + c * each, buf, m * each))
                st = sm_world_fail(w, SM_ERR_INVALID, "checkpoint: truncated in particle field '%s'", f.name);
            for (; st == SM_OK && j < nk && kept[j] < c + m; j++) memcpy(dst + j * each, buf + (kept[j] - c) * each, each);
        }
    }
    free(buf);
    free(kept);
    if (st == SM_OK) w->p.n = nk;
    return st;
}

/* The particles (every one, or the filter's), their materials checked against the world's. */
static sm_status read_particles(reader *r, sm_world *w) {
    const uint64_t n = get_u64(r);
    const uint32_t nf = get_u32(r);
    if (r->short_read) return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: truncated before the particles");
    if (nf != SM_PARTICLE_NFIELDS)
        return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: %u particle fields, this build has %d", nf, SM_PARTICLE_NFIELDS);
    if (n > rest(r) / sm_particles_packed_size(w->dim))
        return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: %llu particles do not fit the %llu bytes left", (unsigned long long)n,
                             (unsigned long long)rest(r));
    if (n > 0x7fffffffu) return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: %llu particles is too many", (unsigned long long)n);
    uint64_t data_at[SM_PARTICLE_NFIELDS];
    sm_status st = read_field_table(r, w, n, data_at);
    if (st == SM_OK) st = r->filter ? read_kept(r, w, (size_t)n, data_at) : read_all(r, w, (size_t)n, data_at);
    if (st != SM_OK) return st;
    for (size_t i = 0; i < w->p.n; i++)
        if (w->p.mat[i] >= w->nmats)
            return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: particle %zu has material %u of %d", i, w->p.mat[i], w->nmats);
    return SM_OK;
}

/* Clock, particles and the end marker, into w. */
static sm_status read_state(reader *r, sm_world *w) {
    read_clock(r, w);
    if (r->short_read) return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: truncated in the clock");
    if (!isfinite(w->time) || w->time < 0) return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: time %g is not a valid time", w->time);
    const sm_status st = read_particles(r, w);
    if (st != SM_OK) return st;
    char end[4];
    get(r, end, 4);
    if (r->short_read || memcmp(end, "END.", 4) != 0) return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: no end marker (truncated?)");
    if (rest(r) != 0)
        return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: %llu bytes after the end marker", (unsigned long long)rest(r));
    return SM_OK;
}

sm_status sm_world_load(const void *data, size_t len, sm_world **out, char *err, size_t errlen) {
    *out = NULL;
    if (!data && len) return bad(err, errlen, "no data");
    reader r = {memory_read, (void *)(uintptr_t)data, 0, len, 0, 0, NULL, 0};
    sm_world_def def;
    sm_status st = read_header(&r, &def, err, errlen);
    if (st != SM_OK) return st;
    sm_world *w;
    st = sm_world_create(&def, &w, err, errlen);
    if (st != SM_OK) return st;
    st = read_defs(&r, w, 1);
    if (st == SM_OK) st = read_state(&r, w);
    if (st != SM_OK && r.io_error) st = sm_world_fail(w, SM_ERR_IO, "checkpoint: reading failed");
    if (st != SM_OK) {
        if (err && errlen) snprintf(err, errlen, "%s", w->err);
        sm_world_destroy(w);
        return st;
    }
    *out = w;
    return SM_OK;
}

/* The evolving state read into tmp, which shares w's definitions (read_defs checks them). */
static sm_status read_into_copy(reader *r, sm_world *w, sm_world *tmp, sm_collider *cols, sm_emitter *ems) {
    tmp->nmats = w->nmats; /* shared read-only during the read: checks only */
    tmp->mats = w->mats;
    tmp->ncolliders = w->ncolliders;
    tmp->nemitters = w->nemitters;
    if (w->ncolliders > 0) memcpy(cols, w->colliders, (size_t)w->ncolliders * sizeof *cols);
    if (w->nemitters > 0) memcpy(ems, w->emitters, (size_t)w->nemitters * sizeof *ems); /* NULL if none */
    tmp->colliders = cols;
    tmp->emitters = ems;
    sm_status st = read_defs(r, tmp, 0);
    if (st == SM_OK) st = read_state(r, tmp);
    if (st != SM_OK && r->io_error) st = sm_world_fail(tmp, SM_ERR_IO, "checkpoint: reading failed at byte %llu", (unsigned long long)r->at);
    return st;
}

/* The filter's cut, owed when reading stopped before it (collective: every rank calls it once). */
static sm_status settle_cut(reader *r, sm_status st) {
    if (!r->filter || r->cut_done) return st;
    r->cut_done = 1;
    (void)r->filter->cut(r->filter->user, st, NULL, 0);
    return st;
}

sm_status sm_world_restore(sm_world *w, const void *data, size_t len) {
    if (!data && len) return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: no data");
    return sm_world_restore_from(w, memory_read, (void *)(uintptr_t)data, len, NULL);
}

sm_status sm_world_restore_read(sm_world *w, sm_pread_fn read, void *user, uint64_t len) {
    if (!read) return sm_world_fail(w, SM_ERR_INVALID, "sm_world_restore_read: no read function");
    return sm_world_restore_from(w, read, user, len, NULL);
}

/* tmp's evolving state moved into w (the particles swapped), the emitters' counters copied. */
static void adopt_state(sm_world *w, sm_world *tmp, const sm_collider *cols, const sm_emitter *ems) {
    memcpy(w->colliders, cols, (size_t)w->ncolliders * sizeof *cols);
    for (int i = 0; i < w->nemitters; i++) {
        w->emitters[i].owed = ems[i].owed;
        w->emitters[i].emitted = ems[i].emitted;
    }
    sm_particles swap = w->p;
    w->p = tmp->p;
    tmp->p = swap;
    sm_bins_free(&w->bins);
    w->bins = tmp->bins;
    memset(&tmp->bins, 0, sizeof tmp->bins);
    w->time = tmp->time;
    w->steps = tmp->steps;
    w->last_dt = tmp->last_dt;
    w->min_dt = tmp->min_dt;
    w->max_dt = tmp->max_dt;
    memcpy(w->stage_seconds, tmp->stage_seconds, sizeof w->stage_seconds);
    w->clamped = tmp->clamped;
    w->projected = tmp->projected;
    w->newton = tmp->newton;
    w->step_vmax2 = tmp->step_vmax2;
    w->step_bad = tmp->step_bad;
    w->dirty = tmp->dirty;
    w->failed = tmp->failed;
    w->next_id = tmp->next_id;
}

static sm_status restore(reader *r, sm_world *w) {
    sm_world_def def;
    char e[256];
    sm_status st = read_header(r, &def, e, sizeof e);
    if (st != SM_OK) return sm_world_fail(w, st, "%s", e);
    if (def.dim != w->dim || def.dx != w->def.dx || def.integrator != w->def.integrator || def.transfer != w->def.transfer ||
        def.kernel != w->def.kernel)
        return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: its world (dim %d, dx %g) differs from this one (dim %d, dx %g)", def.dim,
                             def.dx, w->dim, w->def.dx);
    /* Into a copy of the evolving part, so that a bad stream leaves w as it was. */
    sm_world *tmp;
    st = sm_world_create(&w->def, &tmp, e, sizeof e);
    if (st != SM_OK) return sm_world_fail(w, st, "%s", e);
    sm_collider *cols = sm_calloc((size_t)w->ncolliders + 1, sizeof *cols);
    sm_emitter *ems = sm_calloc((size_t)w->nemitters + 1, sizeof *ems);
    sm_collider *tcols = tmp->colliders;
    sm_emitter *tems = tmp->emitters;
    if (!cols || !ems) st = sm_world_fail(w, SM_ERR_NOMEM, "checkpoint: out of memory");
    else if ((st = read_into_copy(r, w, tmp, cols, ems)) != SM_OK) sm_world_fail(w, st, "%s", tmp->err);
    if (st == SM_OK) adopt_state(w, tmp, cols, ems);
    /* The user colliders' defs in cols are w's (with motion pointers): keep them. */
    tmp->colliders = tcols;
    tmp->emitters = tems;
    tmp->mats = NULL;
    tmp->nmats = tmp->ncolliders = tmp->nemitters = 0;
    free(cols);
    free(ems);
    sm_world_destroy(tmp);
    return st;
}

sm_status sm_world_restore_from(sm_world *w, sm_pread_fn read, void *user, uint64_t len, const sm_restore_filter *filter) {
    reader r = {read, user, 0, len, 0, 0, filter, 0};
    return settle_cut(&r, restore(&r, w));
}
