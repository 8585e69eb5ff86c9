/* The world: creation, materials, particles, colliders, the step driver and diagnostics.
 *
 * One step (thesis Algorithm 1, DESIGN §3), each stage timed:
 *   dt (chosen by the caller through sm_world_next_dt / sm_world_advance: min of max_dt,
 *   CFL dx / max particle speed, elastic_cfl dx / wave speed, landing exactly on the target time),
 *   sort (bin by grid block), P2G (with force), grid update + collisions + friction, G2P,
 *   plasticity and hardening (which also prepares the next step's stress). */
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#ifdef _OPENMP
#include <omp.h>
#endif

#include "core/hash.h"
#include "core/timer.h"
#include "material/material.h"
#include "world_internal.h"

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
    static const char *names[SM_STAGE_COUNT] = {"dt", "sort", "p2g", "grid", "g2p", "plasticity", "checks"};
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

void sm_implicit_ws_free(sm_implicit_ws *ws) {
    free(ws->partial);
    free(ws->mass);
    free(ws->vn);
    free(ws->z);
    free(ws->y);
    free(ws->dz);
    free(ws->tmp);
    free(ws->force);
    free(ws->krylov);
    free(ws->rec);
    free(ws->pp);
    free(ws->G);
    memset(ws, 0, sizeof *ws);
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
    d.elastic_cfl = 0.5;
    d.wall_mode = SM_COLLIDE_SEPARATE;
    d.wall_friction = 0;
    d.newton_tolerance = 1e-3;
    d.newton_max_iterations = 20;
    d.gmres_max_iterations = 15;
    d.gmres_tolerance = 1e-2;
    d.static_friction_sticks = 1;
    d.particle_projection = 1;
    d.threads = 0;
    d.max_particles = 0;
    return d;
}

static int finite3(const double v[3]) { return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]); }

static int resolve_threads(int t) {
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
    else if (!finite3(def->domain_min) || !finite3(def->domain_max)) snprintf(msg, sizeof msg, "domain: must be finite");
    else if (!finite3(def->gravity)) snprintf(msg, sizeof msg, "gravity: must be finite");
    else if (def->kernel != SM_KERNEL_QUADRATIC && def->kernel != SM_KERNEL_CUBIC) snprintf(msg, sizeof msg, "kernel: unknown value %d", (int)def->kernel);
    else if (def->transfer != SM_TRANSFER_APIC && def->transfer != SM_TRANSFER_PIC && def->transfer != SM_TRANSFER_FLIP) snprintf(msg, sizeof msg, "transfer: unknown value %d", (int)def->transfer);
    else if (!(def->flip_ratio >= 0 && def->flip_ratio <= 1)) snprintf(msg, sizeof msg, "flip_ratio: must be in [0, 1], got %g", def->flip_ratio);
    else if (def->integrator != SM_INTEGRATOR_EXPLICIT && def->integrator != SM_INTEGRATOR_IMPLICIT) snprintf(msg, sizeof msg, "integrator: unknown value %d", (int)def->integrator);
    else if (!(def->newton_tolerance > 0) || !isfinite(def->newton_tolerance)) snprintf(msg, sizeof msg, "newton_tolerance: must be > 0, got %g", def->newton_tolerance);
    else if (def->newton_max_iterations < 1 || def->newton_max_iterations > 1000) snprintf(msg, sizeof msg, "newton_max_iterations: must be in 1..1000, got %d", def->newton_max_iterations);
    else if (def->gmres_max_iterations < 1 || def->gmres_max_iterations > 200) snprintf(msg, sizeof msg, "gmres_max_iterations: must be in 1..200, got %d", def->gmres_max_iterations);
    else if (!(def->gmres_tolerance > 0 && def->gmres_tolerance < 1)) snprintf(msg, sizeof msg, "gmres_tolerance: must be in (0, 1), got %g", def->gmres_tolerance);
    else if (!(def->cfl > 0 && def->cfl <= 1)) snprintf(msg, sizeof msg, "cfl: must be in (0, 1], got %g", def->cfl);
    else if (!(def->max_dt > 0) || !isfinite(def->max_dt)) snprintf(msg, sizeof msg, "max_dt: must be > 0, got %g", def->max_dt);
    else if (!(def->elastic_cfl >= 0) || !isfinite(def->elastic_cfl)) snprintf(msg, sizeof msg, "elastic_cfl: must be >= 0, got %g", def->elastic_cfl);
    else if (def->wall_mode != SM_COLLIDE_STICKY && def->wall_mode != SM_COLLIDE_SLIP && def->wall_mode != SM_COLLIDE_SEPARATE) snprintf(msg, sizeof msg, "wall_mode: unknown value %d", (int)def->wall_mode);
    else if (!(def->wall_friction >= 0) || !isfinite(def->wall_friction)) snprintf(msg, sizeof msg, "wall_friction: must be >= 0, got %g", def->wall_friction);
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
    w->ops = def->dim == 2 ? &sm_dim_ops_2d : &sm_dim_ops_3d;
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
    w->threads = resolve_threads(def->threads);
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
    size_t side = def->dim == 2 ? SM_CACHE_SIDE * SM_CACHE_SIDE : SM_CACHE_SIDE * SM_CACHE_SIDE * SM_CACHE_SIDE;
    return (size_t)resolve_threads(def->threads) * side * SM_LANES * sizeof(sm_real) + sizeof(sm_world);
}

size_t sm_world_memory_bytes(const sm_world *w) {
    const sm_particles *P = &w->p;
    const size_t d = (size_t)w->dim, dd = d * d;
    size_t b = sizeof *w;
    b += P->cap * (sizeof(sm_real) * (2 * d + 2 * dd + SM_NTAU(d) + 3) + sizeof(uint16_t));
    b += w->perm_cap * sizeof(uint32_t);
    b += sm_grid_bytes(&w->grid);
    b += w->pb_cap * sizeof(sm_pblock) + w->pb_hash.cap * (sizeof(uint64_t) + sizeof(uint32_t));
    b += w->pb_scratch_cap * sizeof(uint32_t) + w->sort_keys_cap * sizeof(uint64_t) + w->color_cap * sizeof(uint32_t);
    b += w->cache_cap * sizeof(sm_real);
    b += (size_t)w->mats_cap * sizeof(sm_material_rt) + (size_t)w->colliders_cap * sizeof(sm_collider);
    b += (size_t)w->emitters_cap * sizeof(sm_emitter) + w->emit_cap * 6 * sizeof(double);
    const sm_implicit_ws *ws = &w->imp;
    b += ws->ncap * sizeof(sm_real) * (1 + 6 * d) + (size_t)ws->kcap * ws->ncap * d * sizeof(sm_real);
    b += ws->ncap * sizeof(sm_node_contact) + ws->pcap * (sizeof(sm_implicit_particle) + dd * sizeof(sm_real));
    b += ws->partial_cap * sizeof(double);
    return b;
}

void sm_world_destroy(sm_world *w) {
    if (!w) return;
    sm_particles_free(&w->p);
    sm_grid_free(&w->grid);
    free(w->mats);
    free(w->colliders);
    free(w->emitters);
    free(w->emit_buf);
    sm_implicit_ws_free(&w->imp);
    free(w->perm);
    free(w->pb);
    sm_block_hash_free(&w->pb_hash);
    free(w->pb_scratch);
    free(w->sort_keys);
    free(w->color_blocks);
    free(w->cache);
    free(w);
}

void sm_world_set_threads(sm_world *w, int threads) {
    w->def.threads = threads;
    w->threads = resolve_threads(threads);
}

const sm_world_def *sm_world_get_def(const sm_world *w) { return &w->def; }

void sm_world_grid_size(const sm_world *w, int n[3]) {
    for (int a = 0; a < 3; a++) n[a] = w->grid.nodes[a];
}

/* ------------------------------------------------------------------------------------------ */
/* Materials                                                                                    */

sm_material_def sm_material_def_sand(void) {
    sm_material_def m;
    memset(&m, 0, sizeof m);
    m.kind = SM_MATERIAL_SAND;
    m.density = 2200;
    m.youngs_modulus = 3.537e5;
    m.poisson_ratio = 0.3;
    m.hardening = 1;
    m.friction_angle = 30;
    m.h0 = 35;
    m.h1 = 9;
    m.h2 = 0.2;
    m.h3 = 10;
    return m;
}

sm_material_def sm_material_def_elastic(void) {
    sm_material_def m;
    memset(&m, 0, sizeof m);
    m.kind = SM_MATERIAL_ELASTIC;
    m.density = 1000;
    m.youngs_modulus = 1e5;
    m.poisson_ratio = 0.3;
    return m;
}

static const double DEG = SM_PI / 180.0;

double sm_hardening_friction_angle(const sm_material_def *m, double q) {
    if (m->kind != SM_MATERIAL_SAND) return 0;
    if (!m->hardening) return m->friction_angle;
    return sm_hardening_phi(q, m->h0 * DEG, m->h1 * DEG, m->h2, m->h3 * DEG) / DEG;
}

double sm_alpha_from_friction_angle(double degrees) { return sm_dp_alpha(degrees * DEG); }

/* Writes a message into err (if not NULL) and returns SM_ERR_INVALID: the definition checks. */
static sm_status check_fail(char *err, size_t errlen, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;
static sm_status check_fail(char *err, size_t errlen, const char *fmt, ...) {
    if (err && errlen) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, errlen, fmt, ap);
        va_end(ap);
    }
    return SM_ERR_INVALID;
}

sm_status sm_material_def_check(const sm_material_def *m, char *err, size_t errlen) {
    if (!m) return check_fail(err, errlen, "material definition is NULL");
    if (m->kind != SM_MATERIAL_SAND && m->kind != SM_MATERIAL_ELASTIC)
        return check_fail(err, errlen, "material kind: unknown value %d", (int)m->kind);
    if (!(m->density > 0) || !isfinite(m->density))
        return check_fail(err, errlen, "density: must be > 0, got %g", m->density);
    if (!(m->youngs_modulus > 0) || !isfinite(m->youngs_modulus))
        return check_fail(err, errlen, "E: must be > 0, got %g", m->youngs_modulus);
    if (!(m->poisson_ratio > -1 && m->poisson_ratio < 0.5))
        return check_fail(err, errlen, "nu: must be in (-1, 0.5), got %g", m->poisson_ratio);
    if (m->kind == SM_MATERIAL_SAND) {
        if ((unsigned)m->cone_fit > (unsigned)SM_CONE_SIMPLE_SHEAR)
            return check_fail(err, errlen, "cone_fit: unknown value %d", (int)m->cone_fit);
        if (m->hardening) {
            const double h[4] = {m->h0, m->h1, m->h2, m->h3};
            for (int i = 0; i < 4; i++)
                if (!isfinite(h[i]) || h[i] < 0)
                    return check_fail(err, errlen, "h%d: must be finite and >= 0, got %g", i, h[i]);
            if (!(m->h0 > m->h3))
                return check_fail(err, errlen, "hardening: need h0 > h3 (thesis §3.5.3), got h0 = %g, h3 = %g", m->h0, m->h3);
            if (!(m->h0 < 90) || !(m->h0 + m->h1 < 90 * 4))
                return check_fail(err, errlen, "h0: must be < 90 degrees, got %g", m->h0);
        } else if (!(m->friction_angle >= 0 && m->friction_angle < 90)) {
            return check_fail(err, errlen, "friction_angle: must be in [0, 90) degrees, got %g", m->friction_angle);
        }
    }
    return SM_OK;
}

sm_status sm_world_add_material(sm_world *w, const sm_material_def *m, int *id) {
    if (id) *id = -1;
    if (sm_material_def_check(m, w->err, sizeof w->err) != SM_OK) return SM_ERR_INVALID;
    if (w->nmats >= 65535) return sm_world_fail(w, SM_ERR_INVALID, "too many materials (65535)");
    if (w->nmats == w->mats_cap) {
        int cap = w->mats_cap ? 2 * w->mats_cap : 4;
        sm_material_rt *q = sm_realloc(w->mats, (size_t)cap * sizeof *q);
        if (!q) return sm_world_fail(w, SM_ERR_NOMEM, "out of memory");
        w->mats = q;
        w->mats_cap = cap;
    }
    sm_material_rt *r = &w->mats[w->nmats];
    memset(r, 0, sizeof *r);
    r->def = *m;
    double mu, lambda;
    sm_lame(m->youngs_modulus, m->poisson_ratio, &mu, &lambda);
    r->mu = (sm_real)mu;
    r->lambda = (sm_real)lambda;
    r->density = (sm_real)m->density;
    r->plastic = (m->kind == SM_MATERIAL_SAND);
    r->hardening = r->plastic && m->hardening;
    r->h0 = m->h0 * DEG;
    r->h1 = m->h1 * DEG;
    r->h2 = m->h2;
    r->h3 = m->h3 * DEG;
    if (r->plastic)
        r->alpha0 = (sm_real)sm_dp_alpha_fit(r->hardening ? sm_hardening_phi(0, r->h0, r->h1, r->h2, r->h3)
                                                          : m->friction_angle * DEG, (int)m->cone_fit, w->dim);
    r->wave_speed = sqrt((lambda + 2 * mu) / m->density);
    if (id) *id = w->nmats;
    w->nmats++;
    return SM_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* Particles                                                                                    */

static sm_status reserve_particles(sm_world *w, size_t n) {
    if (w->def.max_particles && n > w->def.max_particles)
        return sm_world_fail(w, SM_ERR_INVALID, "particles: %zu would exceed max_particles = %zu", n, w->def.max_particles);
    if (n > 0x7fffffffu) return sm_world_fail(w, SM_ERR_INVALID, "particles: at most %u supported", 0x7fffffffu);
    if (sm_particles_reserve(&w->p, w->dim, n) != SM_OK)
        return sm_world_fail(w, SM_ERR_NOMEM, "out of memory for %zu particles", n);
    if (n > w->perm_cap) {
        size_t cap = w->p.cap;
        uint32_t *pm = sm_realloc(w->perm, cap * sizeof(uint32_t));
        if (!pm) return sm_world_fail(w, SM_ERR_NOMEM, "out of memory");
        w->perm = pm;
        w->perm_cap = cap;
    }
    return SM_OK;
}

void sm_world_init_stress(sm_world *w, size_t first) {
    sm_step_ctx c;
    memset(&c, 0, sizeof c);
    c.threads = w->threads;
    w->ops->plasticity(w, &c, first);
}

sm_status sm_world_add_particles(sm_world *w, size_t n, const double *positions, const double *velocities,
                                 int material, double ppc) {
    if (material < 0 || material >= w->nmats)
        return sm_world_fail(w, SM_ERR_INVALID, "material: unknown id %d (%d defined)", material, w->nmats);
    if (!(ppc > 0) || !isfinite(ppc)) return sm_world_fail(w, SM_ERR_INVALID, "ppc: must be > 0, got %g", ppc);
    if (n == 0) return SM_OK;
    const int d = w->dim;
    const double lo_margin = 2.0 * w->def.dx;
    for (size_t i = 0; i < n; i++) {
        for (int a = 0; a < d; a++) {
            double x = positions[i * 3 + a];
            double lo = w->def.domain_min[a] + lo_margin, hi = w->def.domain_max[a] - lo_margin;
            if (!isfinite(x) || x < lo || x > hi)
                return sm_world_fail(w, SM_ERR_INVALID,
                                     "particle %zu: position %c = %g is outside the usable domain [%g, %g] (2 cells inside the walls)",
                                     i, "xyz"[a], x, lo, hi);
            if (velocities && !isfinite(velocities[i * 3 + a]))
                return sm_world_fail(w, SM_ERR_INVALID, "particle %zu: velocity is not finite", i);
        }
    }
    size_t first = w->p.n;
    sm_status st = reserve_particles(w, first + n);
    if (st != SM_OK) return st;
    const sm_material_rt *m = &w->mats[material];
    double vol0 = pow(w->def.dx, d) / ppc;
    sm_particles *P = &w->p;
    for (size_t i = 0; i < n; i++) {
        size_t p = first + i;
        for (int a = 0; a < d; a++) {
            P->x[p * d + a] = (sm_real)positions[i * 3 + a];
            P->v[p * d + a] = velocities ? (sm_real)velocities[i * 3 + a] : 0;
        }
        for (int k = 0; k < d * d; k++) {
            P->B[p * d * d + k] = 0;
            P->F[p * d * d + k] = (k % (d + 1) == 0) ? 1 : 0;
        }
        for (int k = 0; k < SM_NTAU(d); k++) P->tau[p * SM_NTAU(d) + k] = 0;
        P->vol0[p] = (sm_real)vol0;
        P->q[p] = 0;
        P->alpha[p] = m->alpha0;
        P->mat[p] = (uint16_t)material;
    }
    P->n = first + n;
    w->dirty = 1;
    return SM_OK;
}

double sm_world_particle_mass(const sm_world *w, size_t i) {
    if (i >= w->p.n) return 0;
    return (double)sm_particle_mass(w->mats, &w->p, i);
}

void sm_world_particles(const sm_world *w, sm_particles_view *o) {
    o->n = w->p.n;
    o->dim = w->dim;
    o->x = w->p.x;
    o->v = w->p.v;
    o->B = w->p.B;
    o->F = w->p.F;
    o->vol0 = w->p.vol0;
    o->q = w->p.q;
    o->alpha = w->p.alpha;
    o->material = w->p.mat;
}

sm_real *sm_world_particle_velocities(sm_world *w) {
    w->dirty = 1; /* the caller may change them: the next step checks every particle */
    return w->p.v;
}

double sm_world_particle_friction_angle(const sm_world *w, size_t i) {
    if (i >= w->p.n) return 0;
    return sm_hardening_friction_angle(&w->mats[w->p.mat[i]].def, (double)w->p.q[i]);
}

/* ------------------------------------------------------------------------------------------ */
/* Colliders                                                                                    */

static int check_shape(const sm_shape *s, int dim, int idx, char *err, size_t errlen) {
    double c3[3] = {s->center[0], s->center[1], s->center[2]};
    if (!finite3(c3)) return (check_fail(err, errlen, "shapes[%d].center: must be finite", idx), 0);
    switch (s->kind) {
    case SM_SHAPE_HALFSPACE: {
        double nn = s->normal[0] * s->normal[0] + s->normal[1] * s->normal[1] + (dim == 3 ? s->normal[2] * s->normal[2] : 0);
        if (!(nn > 0) || !isfinite(nn)) return (check_fail(err, errlen, "shapes[%d].normal: must be a finite non-zero vector", idx), 0);
        break;
    }
    case SM_SHAPE_BOX:
        for (int a = 0; a < dim; a++)
            if (!(s->half_extent[a] > 0) || !isfinite(s->half_extent[a]))
                return (check_fail(err, errlen, "shapes[%d].half_extent: must be > 0, got %g", idx, s->half_extent[a]), 0);
        break;
    case SM_SHAPE_SPHERE:
        if (!(s->radius > 0) || !isfinite(s->radius)) return (check_fail(err, errlen, "shapes[%d].radius: must be > 0, got %g", idx, s->radius), 0);
        break;
    case SM_SHAPE_CYLINDER:
        if (!(s->radius > 0) || !isfinite(s->radius)) return (check_fail(err, errlen, "shapes[%d].radius: must be > 0, got %g", idx, s->radius), 0);
        if (!(s->half_height > 0) || !isfinite(s->half_height)) return (check_fail(err, errlen, "shapes[%d].half_height: must be > 0, got %g", idx, s->half_height), 0);
        break;
    default: return (check_fail(err, errlen, "shapes[%d].kind: unknown value %d", idx, (int)s->kind), 0);
    }
    double qn = 0;
    for (int k = 0; k < 4; k++) qn += s->rotation[k] * s->rotation[k];
    if (!(fabs(qn - 1) < 1e-6)) return (check_fail(err, errlen, "shapes[%d].rotation: must be a unit quaternion (|q|^2 = %g)", idx, qn), 0);
    return 1;
}

sm_status sm_collider_def_check(const sm_collider_def *c, int dim, char *err, size_t errlen) {
    if (!c) return check_fail(err, errlen, "collider definition is NULL");
    if (dim != 2 && dim != 3) return check_fail(err, errlen, "collider check: dim must be 2 or 3, got %d", dim);
    if (c->shape_count < 1 || c->shape_count > SM_MAX_COLLIDER_SHAPES)
        return check_fail(err, errlen, "collider shapes: need 1 to %d, got %d", SM_MAX_COLLIDER_SHAPES, c->shape_count);
    for (int i = 0; i < c->shape_count; i++)
        if (!check_shape(&c->shapes[i], dim, i, err, errlen)) return SM_ERR_INVALID;
    if (c->mode != SM_COLLIDE_STICKY && c->mode != SM_COLLIDE_SLIP && c->mode != SM_COLLIDE_SEPARATE)
        return check_fail(err, errlen, "collider mode: unknown value %d", (int)c->mode);
    if (!(c->friction >= 0) || !isfinite(c->friction))
        return check_fail(err, errlen, "collider friction: must be >= 0, got %g", c->friction);
    if (!finite3(c->velocity) || !finite3(c->angular_velocity) || !finite3(c->pose.position))
        return check_fail(err, errlen, "collider motion: velocity, angular velocity and position must be finite");
    double qn = 0;
    for (int k = 0; k < 4; k++) qn += c->pose.rotation[k] * c->pose.rotation[k];
    if (!(fabs(qn - 1) < 1e-6)) return check_fail(err, errlen, "collider pose.rotation: must be a unit quaternion");
    return SM_OK;
}

sm_status sm_world_add_collider(sm_world *w, const sm_collider_def *c, int *id) {
    if (id) *id = -1;
    if (sm_collider_def_check(c, w->dim, w->err, sizeof w->err) != SM_OK) return SM_ERR_INVALID;
    if (w->ncolliders + w->nwalls + 1 > w->colliders_cap) {
        int cap = 2 * (w->ncolliders + w->nwalls + 1);
        sm_collider *q = sm_realloc(w->colliders, (size_t)cap * sizeof *q);
        if (!q) return sm_world_fail(w, SM_ERR_NOMEM, "out of memory");
        w->colliders = q;
        w->colliders_cap = cap;
    }
    /* The walls live after the user colliders: move them up one place. */
    memmove(&w->colliders[w->ncolliders + 1], &w->colliders[w->ncolliders], (size_t)w->nwalls * sizeof *w->colliders);
    sm_collider_init(&w->colliders[w->ncolliders], c);
    if (w->time != 0) {
        /* Added mid-run: evaluate a scripted pose at the current time. */
        if (c->motion) {
            c->motion(c->motion_user, w->time, &w->colliders[w->ncolliders].pose0);
            w->colliders[w->ncolliders].pose1 = w->colliders[w->ncolliders].pose0;
            sm_quat_to_mat(w->colliders[w->ncolliders].pose0.rotation, w->colliders[w->ncolliders].R0);
            memcpy(w->colliders[w->ncolliders].R1, w->colliders[w->ncolliders].R0, sizeof(double) * 9);
        }
    }
    if (id) *id = w->ncolliders;
    w->ncolliders++;
    return SM_OK;
}

double sm_world_collider_distance(const sm_world *w, int id, const double x[3], double grad[3]) {
    if (id < 0 || id >= w->ncolliders) return INFINITY;
    return sm_collider_phi(&w->colliders[id], w->dim, 0, x, grad);
}

int sm_world_collider_count(const sm_world *w) { return w->ncolliders; }

const sm_collider_def *sm_world_collider_def(const sm_world *w, int id) {
    return (id >= 0 && id < w->ncolliders) ? &w->colliders[id].def : NULL;
}

void sm_world_collider_pose(const sm_world *w, int id, sm_pose *pose) {
    if (id < 0 || id >= w->ncolliders) return;
    *pose = w->colliders[id].pose0;
}

/* ------------------------------------------------------------------------------------------ */
/* Time stepping                                                                                */

double sm_world_time(const sm_world *w) { return w->time; }

static double max_particle_speed(const sm_world *w) {
    if (!w->dirty) return sqrt(w->step_vmax2); /* measured by the last G2P */
    const int d = w->dim;
    const long n = (long)w->p.n;
    const sm_real *v = w->p.v;
    double m2 = 0;
#pragma omp parallel for schedule(static) reduction(max : m2) num_threads(w->threads)
    for (long p = 0; p < n; p++) {
        double s = 0;
        for (int a = 0; a < d; a++) s += (double)v[p * d + a] * (double)v[p * d + a];
        if (s > m2) m2 = s;
    }
    return sqrt(m2);
}

double sm_world_next_dt(sm_world *w, double t_end) {
    double t0 = sm_seconds();
    double dt = w->def.max_dt;
    double vmax = max_particle_speed(w);
    if (vmax > 0) dt = fmin(dt, w->def.cfl * w->def.dx / vmax);
    if (w->def.elastic_cfl > 0 && w->def.integrator == SM_INTEGRATOR_EXPLICIT) {
        double c = 0;
        for (int i = 0; i < w->nmats; i++) c = fmax(c, w->mats[i].wave_speed);
        if (c > 0) dt = fmin(dt, w->def.elastic_cfl * w->def.dx / c);
    }
    double remaining = t_end - w->time;
    if (remaining > 0) {
        if (dt >= remaining * (1 - 1e-12)) dt = remaining;
        else if (dt > 0.5 * remaining) dt = 0.5 * remaining; /* no sliver step at the frame end */
    }
    w->stage_seconds[SM_STAGE_DT] += sm_seconds() - t0;
    return dt;
}

static void fill_ctx(const sm_world *w, double dt, sm_step_ctx *c) {
    memset(c, 0, sizeof *c);
    c->dt = dt;
    c->dx = (sm_real)w->def.dx;
    c->inv_dx = (sm_real)w->inv_dx;
    for (int a = 0; a < 3; a++) {
        c->lo[a] = (sm_real)w->def.domain_min[a];
        c->gravity[a] = (sm_real)w->def.gravity[a];
    }
    c->threads = w->threads;
}

/* First particle with non-finite state, or (if dt > 0) one that would move more than one cell in
 * dt (the CFL bound that the stencil and the colour schedule rely on). *fast says which. */
static long first_bad_particle(const sm_world *w, double dt, int *fast) {
    const int d = w->dim, dd = d * d;
    const sm_particles *P = &w->p;
    const double lim2 = dt > 0 ? (w->def.dx / dt) * (w->def.dx / dt) : INFINITY;
    *fast = 0;
    for (size_t p = 0; p < P->n; p++) {
        int ok = 1;
        double s2 = 0;
        for (int a = 0; a < d; a++) {
            ok &= isfinite(P->x[p * d + a]) && isfinite(P->v[p * d + a]);
            s2 += (double)P->v[p * d + a] * (double)P->v[p * d + a];
        }
        for (int k = 0; k < dd; k++) ok &= isfinite(P->F[p * dd + k]);
        for (int k = 0; k < SM_NTAU(d); k++) ok &= isfinite(P->tau[p * SM_NTAU(d) + k]);
        if (!ok) return (long)p;
        if (s2 > lim2) {
            *fast = 1;
            return (long)p;
        }
    }
    return -1;
}

sm_status sm_world_step(sm_world *w, double dt) {
    if (w->failed)
        return sm_world_fail(w, SM_ERR_NUMERICAL, "the world stopped after a numerical failure at step %llu; create a new one",
                             (unsigned long long)w->steps);
    if (!(dt > 0) || !isfinite(dt)) return sm_world_fail(w, SM_ERR_INVALID, "step: dt must be > 0, got %g", dt);
    sm_step_ctx c;
    fill_ctx(w, dt, &c);
    for (int i = 0; i < w->ncolliders; i++) sm_collider_begin_step(&w->colliders[i], w->time, dt);
    if (w->p.n > 0) {
        double t0 = sm_seconds(), t1;
        int fast = 0;
        /* Particles changed since the last step (added, velocities handed out) are all checked;
         * otherwise the last step's G2P and plasticity checked them (step_bad) and measured the
         * largest speed, and only a CFL violation needs a scan (to name the particle). */
        long pre = -1;
        if (w->dirty || w->step_vmax2 * dt * dt > w->def.dx * w->def.dx) pre = first_bad_particle(w, dt, &fast);
        t1 = sm_seconds();
        w->stage_seconds[SM_STAGE_CHECKS] += t1 - t0;
        t0 = t1;
        if (pre >= 0) {
            w->failed = 1;
            if (fast) {
                const int d = w->dim;
                double vm = 0, s2 = 0; /* speed without overflow */
                for (int a = 0; a < d; a++) vm = fmax(vm, fabs((double)w->p.v[pre * d + a]));
                for (int a = 0; a < d; a++) s2 += ((double)w->p.v[pre * d + a] / vm) * ((double)w->p.v[pre * d + a] / vm);
                s2 *= vm * vm;
                if (!isfinite(s2)) s2 = vm * vm * (double)d;
                return sm_world_fail(w, SM_ERR_NUMERICAL,
                                     "step %llu (t = %.6g s): particle %ld (material %d) moves at %.3g m/s, %.3g cells in "
                                     "dt = %.3g s; more than one cell per step breaks the method (CFL): use a smaller dt "
                                     "or sm_world_advance",
                                     (unsigned long long)w->steps + 1, w->time, pre, (int)w->p.mat[pre],
                                     isfinite(s2) ? sqrt(s2) : vm, (isfinite(s2) ? sqrt(s2) : vm) * dt / w->def.dx, dt);
            }
            return sm_world_fail(w, SM_ERR_NUMERICAL,
                                 "step %llu (t = %.6g s): particle %ld (material %d) enters the step with a non-finite "
                                 "position, velocity or deformation gradient",
                                 (unsigned long long)w->steps + 1, w->time, pre, (int)w->p.mat[pre]);
        }
        if (w->ops->sort(w, &c) != SM_OK) {
            w->failed = 1;
            return sm_world_fail(w, SM_ERR_NOMEM, "step %llu: out of memory for the grid and the particle sort",
                                 (unsigned long long)w->steps + 1);
        }
        t1 = sm_seconds();
        w->stage_seconds[SM_STAGE_SORT] += t1 - t0;
        const int implicit = (w->def.integrator == SM_INTEGRATOR_IMPLICIT);
        w->ops->p2g(w, &c, !implicit);
        t0 = sm_seconds();
        w->stage_seconds[SM_STAGE_P2G] += t0 - t1;
        if (implicit) {
            sm_status ist = w->ops->implicit_grid(w, &c);
            if (ist != SM_OK) {
                w->failed = 1;
                return ist;
            }
        } else {
            w->ops->grid_update(w, &c);
        }
        t1 = sm_seconds();
        w->stage_seconds[SM_STAGE_GRID] += t1 - t0;
        long bad = w->ops->grid_check(w);
        t0 = sm_seconds();
        w->stage_seconds[SM_STAGE_CHECKS] += t0 - t1;
        t1 = t0;
        if (bad >= 0) {
            int ijk[3];
            sm_grid_node_coords(&w->grid, (size_t)bad, ijk);
            /* Name the particle nearest to that node: the likely source. */
            const int d = w->dim;
            double best = INFINITY, speed = 0;
            long bp = -1;
            for (size_t p = 0; p < w->p.n; p++) {
                double r2 = 0, s2 = 0;
                for (int a = 0; a < d; a++) {
                    double xa = w->def.domain_min[a] + ijk[a] * w->def.dx - (double)w->p.x[p * d + a];
                    r2 += xa * xa;
                    s2 += (double)w->p.v[p * d + a] * (double)w->p.v[p * d + a];
                }
                if (r2 < best) {
                    best = r2;
                    bp = (long)p;
                    speed = sqrt(s2);
                }
            }
            w->failed = 1;
            return sm_world_fail(w, SM_ERR_NUMERICAL,
                                 "step %llu (t = %.6g s, dt = %.3g s): grid node (%d, %d, %d) got a non-finite velocity; "
                                 "nearest particle %ld (material %d, speed %.3g m/s); particle state is that of the last good step",
                                 (unsigned long long)w->steps + 1, w->time, dt, ijk[0], ijk[1], ijk[2], bp,
                                 bp >= 0 ? (int)w->p.mat[bp] : -1, speed);
        }
        t0 = sm_seconds();
        w->ops->g2p(w, &c);
        t1 = sm_seconds();
        w->stage_seconds[SM_STAGE_G2P] += t1 - t0;
        w->ops->plasticity(w, &c, 0);
        t0 = sm_seconds();
        w->stage_seconds[SM_STAGE_PLASTICITY] += t0 - t1;
        long badp = -1;
        if (w->step_bad) {
            badp = first_bad_particle(w, 0, &fast);
            if (badp < 0) badp = 0; /* cannot happen: the flag comes from a non-finite value */
        }
        w->dirty = 0;
        w->stage_seconds[SM_STAGE_CHECKS] += sm_seconds() - t0;
        if (badp >= 0) {
            w->failed = 1;
            return sm_world_fail(w, SM_ERR_NUMERICAL,
                                 "step %llu (t = %.6g s, dt = %.3g s): particle %ld (material %d) has a non-finite position, "
                                 "velocity or deformation gradient",
                                 (unsigned long long)w->steps + 1, w->time, dt, badp, (int)w->p.mat[badp]);
        }
    }
    for (int i = 0; i < w->ncolliders; i++) sm_collider_end_step(&w->colliders[i]);
    if (w->nemitters > 0) {
        sm_status est = sm_world_run_emitters(w, w->time, w->time + dt);
        if (est != SM_OK) return est;
    }
    w->time += dt;
    w->steps++;
    w->last_dt = dt;
    if (dt < w->min_dt) w->min_dt = dt;
    if (dt > w->max_dt) w->max_dt = dt;
    return SM_OK;
}

sm_status sm_world_advance(sm_world *w, double t_end) {
    if (!isfinite(t_end)) return sm_world_fail(w, SM_ERR_INVALID, "advance: end time must be finite");
    while (w->time < t_end) {
        double dt = sm_world_next_dt(w, t_end);
        int last = (dt == t_end - w->time);
        sm_status st = sm_world_step(w, dt);
        if (st != SM_OK) return st;
        if (last) w->time = t_end;
    }
    return SM_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* Diagnostics                                                                                  */

void sm_world_particle_totals(const sm_world *w, double *mass, double mom[3], double ang[3]) {
    const int d = w->dim, dd = d * d;
    const sm_particles *P = &w->p;
    *mass = 0;
    for (int a = 0; a < 3; a++) mom[a] = ang[a] = 0;
    const int apic = (w->def.transfer == SM_TRANSFER_APIC);
    for (size_t p = 0; p < P->n; p++) {
        double m = (double)sm_particle_mass(w->mats, P, p);
        double x[3] = {0, 0, 0}, v[3] = {0, 0, 0}, B[9] = {0};
        for (int a = 0; a < d; a++) {
            x[a] = (double)P->x[p * d + a];
            v[a] = (double)P->v[p * d + a];
        }
        if (apic)
            for (int a = 0; a < d; a++)
                for (int e = 0; e < d; e++) B[a * 3 + e] = (double)P->B[p * dd + a * d + e];
        *mass += m;
        for (int a = 0; a < 3; a++) mom[a] += m * v[a];
        /* L_p = m (x x v) + m eps_abc B_cb (APIC's affine part, derived from P2G of (3.87)). */
        ang[0] += m * (x[1] * v[2] - x[2] * v[1] + B[2 * 3 + 1] - B[1 * 3 + 2]);
        ang[1] += m * (x[2] * v[0] - x[0] * v[2] + B[0 * 3 + 2] - B[2 * 3 + 0]);
        ang[2] += m * (x[0] * v[1] - x[1] * v[0] + B[1 * 3 + 0] - B[0 * 3 + 1]);
    }
}

void sm_world_diagnostics(const sm_world *w, sm_diagnostics *o) {
    memset(o, 0, sizeof *o);
    const int d = w->dim;
    const sm_particles *P = &w->p;
    o->particles = P->n;
    sm_world_particle_totals(w, &o->total_mass, o->momentum, o->angular_momentum);
    double ke = 0, vmax2 = 0, com[3] = {0, 0, 0};
    for (size_t p = 0; p < P->n; p++) {
        double s = 0;
        for (int a = 0; a < d; a++) {
            double va = (double)P->v[p * d + a];
            s += va * va;
            com[a] += (double)sm_particle_mass(w->mats, P, p) * (double)P->x[p * d + a];
        }
        ke += 0.5 * (double)sm_particle_mass(w->mats, P, p) * s;
        if (s > vmax2) vmax2 = s;
    }
    o->kinetic_energy = ke;
    o->max_speed = sqrt(vmax2);
    for (int a = 0; a < 3; a++) o->center_of_mass[a] = o->total_mass > 0 ? com[a] / o->total_mass : 0;
    o->elastic_energy = P->n ? w->ops->elastic_energy(w) : 0;
    o->steps = w->steps;
    o->time = w->time;
    o->last_dt = w->last_dt;
    o->min_dt = isfinite(w->min_dt) ? w->min_dt : 0;
    o->max_dt = w->max_dt;
    for (int s = 0; s < SM_STAGE_COUNT; s++) o->stage_seconds[s] = w->stage_seconds[s];
    o->clamped_particles = w->clamped;
    o->projected_particles = w->projected;
    o->newton_iterations = w->newton_total;
    o->gmres_iterations = w->gmres_total;
    o->last_newton_iterations = w->newton_last;
    o->last_newton_residual = w->newton_last_residual;
    o->newton_unconverged = w->newton_unconverged;
}

void sm_world_reset_step_stats(sm_world *w) {
    w->min_dt = INFINITY;
    w->max_dt = 0;
}

uint64_t sm_world_state_hash(const sm_world *w) {
    const sm_particles *P = &w->p;
    const size_t n = P->n, d = (size_t)w->dim, dd = d * d;
    uint64_t h = SM_HASH_INIT;
    h = sm_hash64(&n, sizeof n, h);
    h = sm_hash64(P->x, n * d * sizeof(sm_real), h);
    h = sm_hash64(P->v, n * d * sizeof(sm_real), h);
    h = sm_hash64(P->B, n * dd * sizeof(sm_real), h);
    h = sm_hash64(P->F, n * dd * sizeof(sm_real), h);
    h = sm_hash64(P->q, n * sizeof(sm_real), h);
    h = sm_hash64(P->alpha, n * sizeof(sm_real), h);
    return h;
}

double sm_world_debug_implicit_jvp(sm_world *w, double dt, uint64_t seed, double vscale, double h) {
    sm_step_ctx c;
    fill_ctx(w, dt, &c);
    if (w->ops->sort(w, &c) != SM_OK) return INFINITY;
    w->ops->p2g(w, &c, 0);
    return w->ops->implicit_jvp_check(w, &c, seed, vscale, h);
}

void sm_world_debug_transfer_roundtrip(sm_world *w, sm_transfer_totals *t) {
    sm_step_ctx c;
    fill_ctx(w, 0.0, &c);
    for (int a = 0; a < 3; a++) c.gravity[a] = 0;
    sm_world_particle_totals(w, &t->mass[0], t->mom[0], t->ang[0]);
    if (w->ops->sort(w, &c) != SM_OK) return;
    w->ops->p2g(w, &c, 0);
    /* v^n = mv/m, and v-bar = v-tilde = v^n: no force, no gravity, no collision. */
    sm_grid *g = &w->grid;
    const size_t bn = (size_t)g->block_nodes, d = (size_t)w->dim;
    for (size_t b = 0; b < g->nactive; b++) {
        for (size_t ni = b * bn; ni < (b + 1) * bn; ni++)
            for (size_t a = 0; a < d; a++) {
                sm_real v = g->m[ni] > 0 ? g->v[ni * d + a] / g->m[ni] : 0;
                g->v[ni * d + a] = g->f[ni * d + a] = g->vt[ni * d + a] = v;
            }
    }
    w->ops->grid_totals(w, 0, &t->mass[1], t->mom[1], t->ang[1]);
    w->ops->g2p(w, &c);
    sm_world_particle_totals(w, &t->mass[2], t->mom[2], t->ang[2]);
}
