/* Checkpoints: the world's complete evolving state to a byte stream and back (sandmpm.h,
 * sm_world_save / sm_world_load / sm_world_restore; docs/checkpoints.md has the layout).
 *
 * Every field of struct sm_world (world.h) is accounted for here:
 *   saved      def; materials' defs; user colliders' defs (motion pointers as a flag) and their
 *              step state t0, dt, pose0/1, R0/1, v, w; emitters' defs (mesh pointers as NULL), owed, emitted (their
 *              counter-based RNG's whole state is (seed, emitted)); every particle field from the
 *              descriptor table (particles.h), so a field added or retyped there is saved with
 *              no change here; time, steps, last_dt, min_dt, max_dt, stage_seconds, clamped,
 *              projected, newton (the implicit statistics), step_vmax2 (what the dt controller
 *              reads when not dirty), step_bad, dirty, failed, next_id, bins.reorders.
 *   derived    dim, stages, inv_dx, cells (from def); threads, governed, gov (the loader's own
 *              choice: results do not depend on it); mats[].law/density/alpha0/wave_speed (sm_world_add_material);
 *              the domain walls (from def; they never move); emitters' bmin/bmax/particle_mass
 *              (sm_world_add_emitter); the capacities (*_cap).
 *   scratch    emit_buf, grid, bins (but reorders), cache, imp: rebuilt by the next step from the
 *              particles alone (the binning's previous blocks are only a guess for speed), err.
 * The stream is native-endian with a marker; a reader on another byte order refuses it. */
#include <stdio.h>
#include <string.h>

#include "world/world.h"

#define CKPT_MAGIC "SANDMPMC"
#define CKPT_VERSION 3u /* 2: positions are double in both builds (particles.h); 3: gmres_preconditioner, implicit stats */
#define CKPT_ENDIAN 0x01020304u
#define CKPT_MAX_NAME 32

/* ---- Writing ---------------------------------------------------------------------------- */

/* Bytes in stream order: to a sequential sm_write_fn, or to offsets through an sm_pwrite_fn
 * (an id slice's share of the whole stream, sm_world_save_slice); `at` is the stream offset of the
 * next byte, and with `skip` set a part only moves it (a part another rank writes). */
typedef struct writer {
    sm_write_fn fn;
    sm_pwrite_fn pfn;
    void *user;
    sm_status st;
    uint64_t at;
    int skip;
} writer;

static void put(writer *o, const void *p, size_t n) {
    if (o->st == SM_OK && n > 0 && !o->skip && (o->pfn ? o->pfn(o->user, o->at, p, n) : o->fn(o->user, p, n)) != 0)
        o->st = SM_ERR_IO;
    o->at += n;
}
static void put_u32(writer *o, uint32_t v) { put(o, &v, sizeof v); }
static void put_u64(writer *o, uint64_t v) { put(o, &v, sizeof v); }
static void put_f64(writer *o, double v) { put(o, &v, sizeof v); }

/* A definition struct with its pointers zeroed (and padding zeroed: a struct copied field by
 * field into a zeroed buffer), so the same world writes the same bytes. */
static void put_collider_def(writer *o, const sm_collider_def *c) {
    sm_collider_def z;
    memset(&z, 0, sizeof z);
    z.shape_count = c->shape_count;
    memcpy(z.shapes, c->shapes, sizeof z.shapes);
    for (int k = 0; k < SM_MAX_COLLIDER_SHAPES; k++) z.shapes[k].mesh = NULL; /* a pointer: not state */
    z.inside_out = c->inside_out;
    z.mode = c->mode;
    z.friction = c->friction;
    z.pose = c->pose;
    memcpy(z.velocity, c->velocity, sizeof z.velocity);
    memcpy(z.angular_velocity, c->angular_velocity, sizeof z.angular_velocity);
    put(o, &z, sizeof z);
    put_u32(o, c->motion != NULL);
}

static void put_collider_state(writer *o, const sm_collider *c) {
    put_f64(o, c->t0);
    put_f64(o, c->dt);
    put(o, &c->pose0, sizeof c->pose0);
    put(o, &c->pose1, sizeof c->pose1);
    put(o, c->R0, sizeof c->R0);
    put(o, c->R1, sizeof c->R1);
    put(o, c->v, sizeof c->v);
    put(o, c->w, sizeof c->w);
}

static void put_clock(writer *o, const sm_world *w) {
    put_f64(o, w->time);
    put_u64(o, w->steps);
    put_f64(o, w->last_dt);
    put_f64(o, w->min_dt);
    put_f64(o, w->max_dt);
    put(o, w->stage_seconds, sizeof w->stage_seconds);
    put_u64(o, w->clamped);
    put_u64(o, w->projected);
    put(o, &w->newton, sizeof w->newton);
    put_f64(o, w->step_vmax2);
    put_u32(o, (uint32_t)w->step_bad);
    put_u32(o, (uint32_t)w->dirty);
    put_u32(o, (uint32_t)w->failed);
    put_u64(o, w->next_id);
    put_u64(o, w->bins.reorders);
}

/* The particle section of a stream of `total` particles, of which w holds those from index
 * `first` on in stream order (the whole world: 0 and n). head: this writer also writes the
 * section's own bytes (count, field names and sizes, the end marker); only the particle data
 * otherwise. */
static void put_particles(writer *o, const sm_world *w, uint64_t first, uint64_t total, int head) {
    const int skip = o->skip;
    o->skip = !head;
    put_u64(o, total);
    put_u32(o, SM_PARTICLE_NFIELDS);
    for (int k = 0; k < SM_PARTICLE_NFIELDS; k++) {
        const sm_particle_field f = sm_particle_field_info(w->dim, k);
        const uint64_t each = (uint64_t)f.count * f.elem_size;
        char name[CKPT_MAX_NAME] = {0};
        snprintf(name, sizeof name, "%s", f.name);
        o->skip = !head;
        put(o, name, sizeof name);
        put_u32(o, (uint32_t)f.elem_size);
        put_u32(o, (uint32_t)f.count);
        const uint64_t data = o->at;
        o->at = data + first * each;
        o->skip = 0;
        put(o, sm_particles_field_data(&w->p, k), w->p.n * (size_t)each);
        o->at = data + total * each;
    }
    o->skip = !head;
    put(o, "END.", 4);
    o->skip = skip;
}

/* Everything before the particles: header, definitions, colliders, emitters, clock. */
static void put_world(writer *o, const sm_world *w) {
    put(o, CKPT_MAGIC, 8);
    put_u32(o, CKPT_VERSION);
    put_u32(o, CKPT_ENDIAN);
    put_u32(o, (uint32_t)sizeof(sm_real));
    put_u32(o, (uint32_t)w->dim);
    sm_world_def def = w->def;
    def.threads = 0;
    put(o, &def, sizeof def);
    put_u32(o, (uint32_t)w->nmats);
    for (int i = 0; i < w->nmats; i++) put(o, &w->mats[i].def, sizeof w->mats[i].def);
    put_u32(o, (uint32_t)w->ncolliders);
    for (int i = 0; i < w->ncolliders; i++) {
        put_collider_def(o, &w->colliders[i].def);
        put_collider_state(o, &w->colliders[i]);
    }
    put_u32(o, (uint32_t)w->nemitters);
    for (int i = 0; i < w->nemitters; i++) {
        sm_emitter_def e = w->emitters[i].def;
        e.shape.mesh = NULL; /* a pointer: not state */
        put(o, &e, sizeof e);
        put_f64(o, w->emitters[i].owed);
        put_u64(o, w->emitters[i].emitted);
    }
    put_clock(o, w);
}

sm_status sm_world_save(const sm_world *w, sm_write_fn write, void *user) {
    if (w->dist) return sm_dist_save(w, write, user); /* gathered on rank 0 (dist.c) */
    writer o = {write, NULL, user, SM_OK, 0, 0};
    put_world(&o, w);
    put_particles(&o, w, 0, w->p.n, 1);
    return o.st;
}

sm_status sm_world_save_part(const sm_world *w, uint64_t first, uint64_t total, int head, sm_pwrite_fn write, void *user,
                             uint64_t *bytes) {
    writer o = {NULL, write, user, SM_OK, 0, !head};
    put_world(&o, w);
    put_particles(&o, w, first, total, head);
    *bytes = o.at;
    return o.st;
}

/* ---- Reading ---------------------------------------------------------------------------- */

typedef struct reader {
    const unsigned char *p;
    size_t left;
    int short_read;
} reader;

static int get(reader *r, void *dst, size_t n) {
    if (n == 0) return !r->short_read; /* dst may be NULL (an empty array) */
    if (r->short_read || n > r->left) {
        r->short_read = 1;
        memset(dst, 0, n);
        return 0;
    }
    memcpy(dst, r->p, n);
    r->p += n;
    r->left -= n;
    return 1;
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
    if (version != CKPT_VERSION) {
        snprintf(msg, sizeof msg, "format version %u, this build reads %u", version, CKPT_VERSION);
        return bad(err, errlen, msg);
    }
    if (endian != CKPT_ENDIAN) return bad(err, errlen, "written on a machine of another byte order");
    if (real != sizeof(sm_real)) {
        snprintf(msg, sizeof msg, "written by a %s build, this is a %s build", real == 8 ? "double" : real == 4 ? "float" : "unknown",
                 sizeof(sm_real) == 8 ? "double" : "float");
        return bad(err, errlen, msg);
    }
    get(r, def, sizeof *def);
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
    if (nm > 65536 || nm * sizeof(sm_material_def) > r->left) return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: %u materials do not fit the data", nm);
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

/* Every particle field, checked against this build's descriptor table: same names, element
 * sizes and counts in the same order. Material ids are checked against the materials. */
static sm_status read_particles(reader *r, sm_world *w) {
    const uint64_t n = get_u64(r);
    const uint32_t nf = get_u32(r);
    if (r->short_read) return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: truncated before the particles");
    if (nf != SM_PARTICLE_NFIELDS)
        return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: %u particle fields, this build has %d", nf, SM_PARTICLE_NFIELDS);
    if (n > r->left / sm_particles_packed_size(w->dim))
        return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: %llu particles do not fit the %zu bytes left", (unsigned long long)n, r->left);
    if (n > 0x7fffffffu) return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: %llu particles is too many", (unsigned long long)n);
    if (sm_particles_reserve(&w->p, w->dim, (size_t)n) != SM_OK || sm_bins_reserve_perm(&w->bins, w->p.cap) != SM_OK)
        return sm_world_fail(w, SM_ERR_NOMEM, "checkpoint: out of memory for %llu particles", (unsigned long long)n);
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
        if (!get(r, sm_particles_field_data(&w->p, k), (size_t)n * count * es))
            return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: truncated in particle field '%s'", f.name);
    }
    for (uint64_t i = 0; i < n; i++)
        if (w->p.mat[i] >= w->nmats)
            return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: particle %llu has material %u of %d", (unsigned long long)i, w->p.mat[i], w->nmats);
    w->p.n = (size_t)n;
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
    if (r->left != 0) return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: %zu bytes after the end marker", r->left);
    return SM_OK;
}

sm_status sm_world_load(const void *data, size_t len, sm_world **out, char *err, size_t errlen) {
    *out = NULL;
    if (!data && len) return bad(err, errlen, "no data");
    reader r = {data, len, 0};
    sm_world_def def;
    sm_status st = read_header(&r, &def, err, errlen);
    if (st != SM_OK) return st;
    sm_world *w;
    st = sm_world_create(&def, &w, err, errlen);
    if (st != SM_OK) return st;
    st = read_defs(&r, w, 1);
    if (st == SM_OK) st = read_state(&r, w);
    if (st != SM_OK) {
        if (err && errlen) snprintf(err, errlen, "%s", w->err);
        sm_world_destroy(w);
        return st;
    }
    *out = w;
    return SM_OK;
}

sm_status sm_world_restore(sm_world *w, const void *data, size_t len) {
    if (!data && len) return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: no data");
    reader r = {data, len, 0};
    sm_world_def def;
    char e[256];
    sm_status st = read_header(&r, &def, e, sizeof e);
    if (st != SM_OK) return sm_world_fail(w, st, "%s", e);
    if (def.dim != w->dim || def.dx != w->def.dx || def.integrator != w->def.integrator || def.transfer != w->def.transfer ||
        def.kernel != w->def.kernel)
        return sm_world_fail(w, SM_ERR_INVALID, "checkpoint: its world (dim %d, dx %g) differs from this one (dim %d, dx %g)", def.dim,
                             def.dx, w->dim, w->def.dx);
    /* Into a copy of the evolving part, so that a bad stream leaves w as it was. */
    sm_world *tmp;
    st = sm_world_create(&w->def, &tmp, e, sizeof e);
    if (st != SM_OK) return sm_world_fail(w, st, "%s", e);
    const sm_world_def keep = tmp->def;
    (void)keep;
    tmp->nmats = w->nmats; /* shared read-only during the read: checks only */
    tmp->mats = w->mats;
    tmp->ncolliders = w->ncolliders;
    tmp->nemitters = w->nemitters;
    sm_collider *cols = sm_calloc((size_t)w->ncolliders + 1, sizeof *cols);
    sm_emitter *ems = sm_calloc((size_t)w->nemitters + 1, sizeof *ems);
    sm_collider *tcols = tmp->colliders;
    sm_emitter *tems = tmp->emitters;
    if (!cols || !ems) st = sm_world_fail(w, SM_ERR_NOMEM, "checkpoint: out of memory");
    if (st == SM_OK) {
        if (w->ncolliders > 0) memcpy(cols, w->colliders, (size_t)w->ncolliders * sizeof *cols);
        if (w->nemitters > 0) memcpy(ems, w->emitters, (size_t)w->nemitters * sizeof *ems); /* NULL if none */
        tmp->colliders = cols;
        tmp->emitters = ems;
        st = read_defs(&r, tmp, 0);
        if (st == SM_OK) st = read_state(&r, tmp);
        if (st != SM_OK) sm_world_fail(w, st, "%s", tmp->err);
    }
    if (st == SM_OK) {
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
