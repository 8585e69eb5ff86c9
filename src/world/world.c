/* The world: creation and destruction, its definition and the library's limits on it, threads,
 * messages, memory accounting. The rest of the world's API is split by reason to change:
 * materials.c, particle_api.c, collider_api.c, diagnostics.c (the step is integrate/step.c). */
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#ifdef _OPENMP
#include <omp.h>
#endif

#include "world/world.h"

const char *sm_status_string(sm_status s) {
    switch (s) {
    case SM_OK: return "ok";
    case SM_ERR_INVALID: return "invalid input";
    case SM_ERR_NUMERICAL: return "numerical failure";
    case SM_ERR_IO: return "I/O failure";
    case SM_ERR_NOMEM: return "out of memory";
    }
    return "unknown status";
}

const char *sm_version(void) { return SM_VERSION_STRING; }
int sm_real_is_double(void) { return SM_DOUBLE; }

const char *sm_stage_name(sm_stage s) {
    static const char *names[SM_STAGE_COUNT] = {"dt", "sort", "p2g", "grid", "g2p", "plasticity", "checks", "exchange"};
    return (s >= 0 && s < SM_STAGE_COUNT) ? names[s] : "?";
}

sm_status sm_world_fail(sm_world *w, sm_status status, const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(w->err, sizeof w->err, fmt, ap);
    va_end(ap);
    return status;
}

const char *sm_world_errmsg(const sm_world *w) { return w ? w->err : "no world"; }

sm_status sm_check_fail(char *err, size_t errlen, const char *fmt, ...) {
    if (err && errlen) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, errlen, fmt, ap);
        va_end(ap);
    }
    return SM_ERR_INVALID;
}

sm_world_def sm_world_def_default(void) {
    sm_world_def d;
    memset(&d, 0, sizeof d);
    d.dim = 3;
    d.dx = 0.02;
    for (int a = 0; a < 3; a++) {
        d.domain_min[a] = 0;
        d.domain_max[a] = 1;
    }
    d.gravity[1] = -9.81;
    d.kernel = SM_KERNEL_QUADRATIC;
    d.transfer = SM_TRANSFER_APIC;
    d.flip_ratio = 0.95;
    d.integrator = SM_INTEGRATOR_EXPLICIT;
    d.cfl = 1.0;
    d.max_dt = 1e-3;
    d.elastic_cfl = 0.6; /* 0.65 of the smallest measured limit, 0.92 (bench/elastic_limit.c); a block released on an incline creeps more above it (docs/benchmarks.md, "Time-step limit") */
    d.wall_mode = SM_COLLIDE_SEPARATE;
    d.wall_friction = 0;
    d.contact_gap = INFINITY; /* no gate: 0.35 passes the incline at fine steps, but not a resting block at the elastic dt (sandmpm.h) */
    d.newton_tolerance = 1e-3;
    d.newton_max_iterations = 20;
    d.gmres_max_iterations = 15;
    d.gmres_tolerance = 1e-2;
    d.gmres_preconditioner = 0; /* block Jacobi did not pay in general: docs/benchmarks.md */
    d.static_friction_sticks = 1;
    d.particle_projection = 1;
    d.threads = 0;
    d.max_particles = 0;
    return d;
}

int sm_resolve_threads(int t) {
#ifdef _OPENMP
    if (t <= 0) t = omp_get_max_threads();
#else
    t = 1;
#endif
    return t < 1 ? 1 : t;
}

sm_status sm_world_def_check(const sm_world_def *def, char *err, size_t errlen) {
    char msg[256] = "";
    if (!def) snprintf(msg, sizeof msg, "world definition is NULL");
    else if (def->dim != 2 && def->dim != 3) snprintf(msg, sizeof msg, "dim: must be 2 or 3, got %d", def->dim);
    else if (!(def->dx > 0) || !isfinite(def->dx)) snprintf(msg, sizeof msg, "dx: must be > 0, got %g", def->dx);
    else if (!sm_finite3(def->domain_min) || !sm_finite3(def->domain_max)) snprintf(msg, sizeof msg, "domain: must be finite");
    else if (!sm_finite3(def->gravity)) snprintf(msg, sizeof msg, "gravity: must be finite");
    else if (def->kernel != SM_KERNEL_QUADRATIC && def->kernel != SM_KERNEL_CUBIC) snprintf(msg, sizeof msg, "kernel: unknown value %d", (int)def->kernel);
    else if (def->transfer != SM_TRANSFER_APIC && def->transfer != SM_TRANSFER_PIC && def->transfer != SM_TRANSFER_FLIP) snprintf(msg, sizeof msg, "transfer: unknown value %d", (int)def->transfer);
    else if (!(def->flip_ratio >= 0 && def->flip_ratio <= 1)) snprintf(msg, sizeof msg, "flip_ratio: must be in [0, 1], got %g", def->flip_ratio);
    else if (def->integrator != SM_INTEGRATOR_EXPLICIT && def->integrator != SM_INTEGRATOR_IMPLICIT) snprintf(msg, sizeof msg, "integrator: unknown value %d", (int)def->integrator);
    else if (!(def->newton_tolerance > 0) || !isfinite(def->newton_tolerance)) snprintf(msg, sizeof msg, "newton_tolerance: must be > 0, got %g", def->newton_tolerance);
    else if (def->newton_max_iterations < 1 || def->newton_max_iterations > 1000) snprintf(msg, sizeof msg, "newton_max_iterations: must be in 1..1000, got %d", def->newton_max_iterations);
    else if (def->gmres_max_iterations < 1 || def->gmres_max_iterations > 200) snprintf(msg, sizeof msg, "gmres_max_iterations: must be in 1..200, got %d", def->gmres_max_iterations);
    else if (!(def->gmres_tolerance > 0 && def->gmres_tolerance < 1)) snprintf(msg, sizeof msg, "gmres_tolerance: must be in (0, 1), got %g", def->gmres_tolerance);
    else if (def->gmres_preconditioner != 0 && def->gmres_preconditioner != 1) snprintf(msg, sizeof msg, "gmres_preconditioner: must be 0 (none) or 1 (block Jacobi), got %d", def->gmres_preconditioner);
    else if (!(def->cfl > 0 && def->cfl <= 1)) snprintf(msg, sizeof msg, "cfl: must be in (0, 1], got %g", def->cfl);
    else if (!(def->max_dt > 0) || !isfinite(def->max_dt)) snprintf(msg, sizeof msg, "max_dt: must be > 0, got %g", def->max_dt);
    else if (!(def->elastic_cfl >= 0) || !isfinite(def->elastic_cfl)) snprintf(msg, sizeof msg, "elastic_cfl: must be >= 0, got %g", def->elastic_cfl);
    else if (def->wall_mode != SM_COLLIDE_STICKY && def->wall_mode != SM_COLLIDE_SLIP && def->wall_mode != SM_COLLIDE_SEPARATE) snprintf(msg, sizeof msg, "wall_mode: unknown value %d", (int)def->wall_mode);
    else if (!(def->wall_friction >= 0) || !isfinite(def->wall_friction)) snprintf(msg, sizeof msg, "wall_friction: must be >= 0, got %g", def->wall_friction);
    else if (!(def->contact_gap > 0)) snprintf(msg, sizeof msg, "contact_gap: must be > 0 (cells; inf: no gate), got %g", def->contact_gap);
    if (!msg[0]) {
        for (int a = 0; a < def->dim; a++) {
            double len = def->domain_max[a] - def->domain_min[a];
            double cells = ceil(len / def->dx - 1e-9);
            if (!(len > 0)) {
                snprintf(msg, sizeof msg, "domain: max must exceed min along axis %c (got %g .. %g)", "xyz"[a], def->domain_min[a], def->domain_max[a]);
                break;
            }
            if (cells < 6) {
                snprintf(msg, sizeof msg, "domain: at least 6 cells needed along axis %c, got %.0f (length %g, dx %g)", "xyz"[a], cells, len, def->dx);
                break;
            }
            if (cells > SM_MAX_CELLS_PER_AXIS) {
                snprintf(msg, sizeof msg, "domain: %.0f cells along axis %c is more than %d", cells, "xyz"[a], SM_MAX_CELLS_PER_AXIS);
                break;
            }
        }
    }
    if (msg[0]) {
        if (err && errlen) snprintf(err, errlen, "%s", msg);
        return SM_ERR_INVALID;
    }
    return SM_OK;
}

sm_status sm_world_create(const sm_world_def *def, sm_world **out, char *err, size_t errlen) {
    *out = NULL;
    sm_status st = sm_world_def_check(def, err, errlen);
    if (st != SM_OK) return st;
    sm_world *w = sm_calloc(1, sizeof *w);
    if (!w) {
        if (err && errlen) snprintf(err, errlen, "out of memory");
        return SM_ERR_NOMEM;
    }
    w->def = *def;
    w->dim = def->dim;
    w->stages = def->dim == 2 ? &sm_stages_2d : &sm_stages_3d;
    w->inv_dx = 1.0 / def->dx;
    int nodes[3] = {1, 1, 1};
    for (int a = 0; a < 3; a++) {
        if (a < def->dim) {
            double len = def->domain_max[a] - def->domain_min[a];
            w->cells[a] = (int)ceil(len / def->dx - 1e-9);
            w->def.domain_max[a] = def->domain_min[a] + w->cells[a] * def->dx;
            nodes[a] = w->cells[a] + 1;
        } else {
            w->cells[a] = 1;
            w->def.domain_min[a] = w->def.domain_max[a] = 0;
            w->def.gravity[a] = 0;
        }
    }
    sm_grid_init(&w->grid, def->dim, nodes, def->transfer == SM_TRANSFER_FLIP);
    sm_world_set_threads(w, def->threads);
    /* Domain walls: half-spaces 2 cells inside each face, behaving as def->wall_mode. */
    w->colliders = sm_calloc((size_t)(2 * def->dim + 4), sizeof *w->colliders);
    if (!w->colliders) {
        sm_world_destroy(w);
        if (err && errlen) snprintf(err, errlen, "out of memory");
        return SM_ERR_NOMEM;
    }
    w->colliders_cap = 2 * def->dim + 4;
    for (int a = 0; a < def->dim; a++)
        for (int side = 0; side < 2; side++) {
            sm_collider_def wc = sm_collider_def_default();
            wc.shape_count = 1;
            wc.shapes[0] = sm_shape_default(SM_SHAPE_HALFSPACE);
            wc.shapes[0].center[a] = side ? w->def.domain_max[a] - 2 * def->dx : w->def.domain_min[a] + 2 * def->dx;
            wc.shapes[0].normal[a] = side ? -1 : 1;
            wc.mode = def->wall_mode;
            wc.friction = def->wall_friction;
            sm_collider_init(&w->colliders[w->nwalls++], &wc);
        }
    w->min_dt = INFINITY;
    w->dt_cap = INFINITY;
    w->dirty = 1;
    w->max_dt = 0;
    *out = w;
    return SM_OK;
}

size_t sm_world_def_grid_bytes(const sm_world_def *def) {
    /* The grid is sparse: its blocks follow the particles (counted in sm_particle_bytes); what
     * does not depend on the particles is the per-thread transfer caches. */
    if (!def || (def->dim != 2 && def->dim != 3) || !(def->dx > 0)) return 0;
    for (int a = 0; a < def->dim; a++)
        if (!(def->domain_max[a] > def->domain_min[a])) return 0;
    return sm_transfer_cache_bytes_for(def->dim, sm_resolve_threads(def->threads)) + sizeof(sm_world);
}

size_t sm_world_memory_bytes(const sm_world *w) {
    size_t b = sizeof *w;
    b += w->p.cap * sm_particles_packed_size(w->dim);
    b += sm_bins_bytes(&w->bins);
    b += sm_grid_bytes(&w->grid);
    b += w->cache.cap * sizeof(sm_real);
    b += (size_t)w->mats_cap * sizeof(sm_material_rt) + (size_t)w->colliders_cap * sizeof(sm_collider);
    b += (size_t)w->emitters_cap * sizeof(sm_emitter) + w->emit_cap * 6 * sizeof(double);
    b += sm_implicit_ws_bytes(&w->imp, w->dim);
    b += w->gate_cap;
    return b;
}

void sm_world_destroy(sm_world *w) {
    if (!w) return;
    sm_particles_free(&w->p);
    sm_bins_free(&w->bins);
    sm_grid_free(&w->grid);
    sm_transfer_cache_free(&w->cache);
    sm_implicit_ws_free(&w->imp);
    free(w->gate);
    sm_dist_free(w->dist);
    free(w->mats);
    for (int i = 0; i < w->ncolliders; i++) sm_collider_release_meshes(&w->colliders[i]);
    free(w->colliders);
    for (int i = 0; i < w->nemitters; i++)
        if (w->emitters[i].def.shape.kind == SM_SHAPE_MESH) sm_mesh_field_release((sm_mesh_field *)w->emitters[i].def.shape.mesh);
    free(w->emitters);
    free(w->emit_buf);
    free(w);
}

void sm_world_set_threads(sm_world *w, int threads) {
    w->def.threads = threads;
    w->threads = sm_resolve_threads(threads);
    w->governed = threads <= 0;
    sm_governor_init(&w->gov, w->threads);
}

const sm_world_def *sm_world_get_def(const sm_world *w) { return &w->def; }

void sm_world_grid_size(const sm_world *w, int n[3]) {
    for (int a = 0; a < 3; a++) n[a] = w->grid.nodes[a];
}

