/* Checkpoints: the world's complete evolving state to a byte stream and back (sandmpm.h,
 * sm_world_save and sm_world_save_part here; reading back, sm_world_load / sm_world_restore /
 * sm_world_restore_read, in checkpoint_read.c; docs/checkpoints.md has the layout).
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

#include "world/checkpoint_format.h"
#include "world/world.h"


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

