/* Seeding particles inside shapes.
 *
 * Jittered lattice: points on a lattice of spacing h = dx / ppc^(1/d), aligned with the domain
 * corner, each moved uniformly within its lattice cell by a counter-based RNG of (seed, lattice
 * index), so the result does not depend on the order of generation or on the thread count.
 * Poisson disk: Bridson's algorithm (SIGGRAPH 2007 sketch "Fast Poisson disk sampling in
 * arbitrary dimensions"): k = 30 candidates in the annulus [r, 2r] around active samples, a
 * background grid of cell size r / sqrt(d); r is set so that the sample density is about ppc per
 * grid cell (constants measured, see SM_POISSON_K2/K3).
 * Each particle gets V0 = dx^d / ppc and mass rho V0 (thesis §3.4.4 mass lumping; DESIGN). */
#include <string.h>

#include "collide/mesh_field.h"
#include "core/hash.h"
#include "world/world.h"

/* Density of maximal Bridson samples: about K / r^d points per unit volume (measured on
 * boxes of 10 cells a side with this implementation, boundary layer included: tests/test_seed.c). */
#define SM_POISSON_K2 0.63
#define SM_POISSON_K3 0.60

sm_seed_def sm_seed_def_default(void) {
    sm_seed_def s;
    memset(&s, 0, sizeof s);
    s.material = 0;
    s.ppc = 8;
    s.method = SM_SEED_JITTERED;
    s.seed = 1;
    return s;
}

typedef struct ptbuf {
    double *x;
    size_t n, cap;
} ptbuf;

static int ptbuf_push(ptbuf *b, const double x[3]) {
    if (b->n == b->cap) {
        size_t cap = b->cap ? 2 * b->cap : 4096;
        double *q = sm_realloc(b->x, cap * 3 * sizeof(double));
        if (!q) return 0;
        b->x = q;
        b->cap = cap;
    }
    memcpy(b->x + 3 * b->n, x, 3 * sizeof(double));
    b->n++;
    return 1;
}

/* Conservative bounding box of a shape, clipped to [lo, hi]. */
static void shape_bounds(const sm_shape *s, int dim, const double lo[3], const double hi[3], double bmin[3],
                         double bmax[3]) {
    for (int a = 0; a < 3; a++) {
        bmin[a] = lo[a];
        bmax[a] = hi[a];
    }
    if (s->inside_out || s->kind == SM_SHAPE_HALFSPACE) return;
    double ext[3] = {0, 0, 0};
    switch (s->kind) {
    case SM_SHAPE_SPHERE: ext[0] = ext[1] = ext[2] = s->radius; break;
    case SM_SHAPE_BOX: {
        double r = sqrt(s->half_extent[0] * s->half_extent[0] + s->half_extent[1] * s->half_extent[1] +
                        (dim == 3 ? s->half_extent[2] * s->half_extent[2] : 0));
        ext[0] = ext[1] = ext[2] = r;
        break;
    }
    case SM_SHAPE_CYLINDER: {
        double r = sqrt(s->radius * s->radius + s->half_height * s->half_height);
        ext[0] = ext[1] = ext[2] = r;
        break;
    }
    case SM_SHAPE_MESH: /* the field's box about the mesh frame's origin (a container: everywhere) */
        ext[0] = ext[1] = ext[2] = sm_mesh_field_extent(s->mesh);
        if (!isfinite(ext[0])) return;
        break;
    default: return;
    }
    for (int a = 0; a < dim; a++) {
        bmin[a] = fmax(lo[a], s->center[a] - ext[a]);
        bmax[a] = fmin(hi[a], s->center[a] + ext[a]);
    }
}

static int keep_point(const sm_shape *shape, const sm_shape *clip, int dim, const double x[3]) {
    if (sm_shape_distance(shape, dim, x, NULL) >= 0) return 0;
    if (clip && sm_shape_distance(clip, dim, x, NULL) >= 0) return 0;
    return 1;
}

/* Where a seeding's points go, pass after pass (sm_world_seed_shape): counted, then summed into
 * their centroid (for the angular velocity), then added to the world SEED_CHUNK at a time, so
 * that no more than a chunk of a shape's points is held at once (a rank of a distributed world
 * keeps only its share of them). */
#define SEED_CHUNK ((size_t)1 << 16)
enum { SINK_COUNT, SINK_CENTRE, SINK_ADD };
typedef struct seed_sink {
    sm_world *w;
    const sm_seed_def *sd;
    int pass;
    size_t n;      /* the shape's points (SINK_COUNT) */
    double cen[3]; /* their centroid (SINK_CENTRE) */
    ptbuf chunk;   /* points not yet added (SINK_ADD) */
    sm_status st;  /* the first failure of an add */
} seed_sink;

static int sink_flush(seed_sink *k);

/* 0 when out of memory or an add failed (k->st). */
static int sink_point(seed_sink *k, const double x[3]) {
    switch (k->pass) {
    case SINK_COUNT: k->n++; return 1;
    case SINK_CENTRE:
        for (int a = 0; a < 3; a++) k->cen[a] += x[a] / (double)k->n;
        return 1;
    default:
        if (!ptbuf_push(&k->chunk, x)) return 0;
        return k->chunk.n < SEED_CHUNK || sink_flush(k);
    }
}

static int seed_jittered(const sm_world *w, const sm_shape *shape, const sm_seed_def *sd, const double bmin[3],
                         const double bmax[3], seed_sink *out) {
    const int d = w->dim;
    const double h = w->def.dx / pow(sd->ppc, 1.0 / d);
    const double *lo = w->def.domain_min;
    long i0[3] = {0, 0, 0}, i1[3] = {0, 0, 0};
    for (int a = 0; a < d; a++) {
        i0[a] = (long)floor((bmin[a] - lo[a]) / h);
        i1[a] = (long)ceil((bmax[a] - lo[a]) / h);
    }
    for (long i = i0[0]; i <= i1[0]; i++)
        for (long j = i0[1]; j <= i1[1]; j++)
            for (long k = i0[2]; k <= i1[2]; k++) {
                long idx[3] = {i, j, k};
                double x[3] = {0, 0, 0};
                uint64_t key = sm_mix64(sd->seed ^ sm_mix64((uint64_t)i * 0x9E3779B1u ^
                                                             sm_mix64((uint64_t)j * 0x85EBCA77u ^ sm_mix64((uint64_t)k))));
                int inside = 1;
                for (int a = 0; a < d; a++) {
                    key = sm_mix64(key + (uint64_t)a);
                    x[a] = lo[a] + ((double)idx[a] + sm_u01(key)) * h;
                    if (x[a] < bmin[a] || x[a] > bmax[a]) inside = 0;
                }
                if (!inside || !keep_point(shape, sd->clip, d, x)) continue;
                if (!sink_point(out, x)) return 0;
            }
    return 1;
}

/* The background grid of the Poisson-disk sampler: cells of side r / sqrt(d) over the box, each
 * holding at most one sample (its index, or -1). */
typedef struct pgrid {
    int32_t *cell;
    long nc[3];
    double cs, bmin[3];
    int d;
} pgrid;

static void pgrid_cell_of(const pgrid *g, const double x[3], long ci[3]) {
    for (int a = 0; a < 3; a++) ci[a] = (a < g->d) ? (long)((x[a] - g->bmin[a]) / g->cs) : 0;
}

static size_t pgrid_index(const pgrid *g, const long ci[3]) {
    return ((size_t)ci[0] * (size_t)g->nc[1] + (size_t)ci[1]) * (size_t)g->nc[2] + (size_t)ci[2];
}

/* 1 if no sample lies within r of y: the samples of the 5^d cells around y's cell yc. */
static int pgrid_clear(const pgrid *g, const ptbuf *all, const double y[3], const long yc[3], double r) {
    const int d = g->d;
    for (long di = -2; di <= 2; di++)
        for (long dj = -2; dj <= 2; dj++)
            for (long dk = (d == 3 ? -2 : 0); dk <= (d == 3 ? 2 : 0); dk++) {
                long nb[3] = {yc[0] + di, yc[1] + dj, yc[2] + dk};
                if (nb[0] < 0 || nb[1] < 0 || nb[2] < 0 || nb[0] >= g->nc[0] || nb[1] >= g->nc[1] || nb[2] >= g->nc[2])
                    continue;
                int32_t q = g->cell[pgrid_index(g, nb)];
                if (q < 0) continue;
                double dd2 = 0;
                for (int a = 0; a < d; a++) dd2 += (all->x[3 * q + a] - y[a]) * (all->x[3 * q + a] - y[a]);
                if (dd2 < r * r) return 0;
            }
    return 1;
}

/* A candidate around sample c at distance r .. 2r in a uniform direction; 0 if outside the box. */
static int poisson_candidate(int d, const double *c, double r, const double bmin[3], const double bmax[3],
                             uint64_t *rng, double y[3]) {
    double dir[3] = {0, 0, 0}, n2 = 0;
    do { /* uniform direction by rejection in the unit ball */
        n2 = 0;
        for (int a = 0; a < d; a++) {
            *rng = sm_mix64(*rng);
            dir[a] = 2 * sm_u01(*rng) - 1;
            n2 += dir[a] * dir[a];
        }
    } while (n2 > 1 || n2 < 1e-12);
    *rng = sm_mix64(*rng);
    double rad = r * (1 + sm_u01(*rng));
    int in = 1;
    y[0] = y[1] = y[2] = 0;
    for (int a = 0; a < d; a++) {
        y[a] = c[a] + rad * dir[a] / sqrt(n2);
        if (y[a] < bmin[a] || y[a] >= bmax[a]) in = 0;
    }
    return in;
}

static int seed_poisson(const sm_world *w, const sm_shape *shape, const sm_seed_def *sd, const double bmin[3],
                        const double bmax[3], ptbuf *out) {
    const int d = w->dim;
    const double K = d == 2 ? SM_POISSON_K2 : SM_POISSON_K3;
    const double r = pow(K * pow(w->def.dx, d) / sd->ppc, 1.0 / d);
    pgrid g = {NULL, {1, 1, 1}, r / sqrt((double)d), {bmin[0], bmin[1], bmin[2]}, d};
    size_t ncell = 1;
    for (int a = 0; a < d; a++) {
        g.nc[a] = (long)ceil((bmax[a] - bmin[a]) / g.cs) + 1;
        ncell *= (size_t)g.nc[a];
    }
    if (ncell > ((size_t)1 << 31)) return 0;
    g.cell = sm_malloc(ncell * sizeof(int32_t));
    ptbuf all = {0};
    size_t *active = NULL, nact = 0, capact = 0;
    if (!g.cell) return 0;
    for (size_t c = 0; c < ncell; c++) g.cell[c] = -1;
    uint64_t rng = sd->seed * 0x2545F4914F6CDD1DULL + 1;
    double x0[3] = {0, 0, 0};
    for (int a = 0; a < d; a++) {
        rng = sm_mix64(rng);
        x0[a] = bmin[a] + sm_u01(rng) * (bmax[a] - bmin[a]);
    }
    int ok = ptbuf_push(&all, x0);
    long ci[3];
    pgrid_cell_of(&g, x0, ci);
    g.cell[pgrid_index(&g, ci)] = 0;
    active = sm_malloc(1024 * sizeof(size_t));
    capact = 1024;
    if (!active) ok = 0;
    else active[nact++] = 0;
    while (ok && nact > 0) { /* Bridson: 30 tries around a random active sample */
        rng = sm_mix64(rng);
        size_t ai = (size_t)(sm_u01(rng) * (double)nact);
        if (ai >= nact) ai = nact - 1;
        const double *c = all.x + 3 * active[ai];
        int found = 0;
        for (int t = 0; t < 30 && !found; t++) {
            double y[3];
            if (!poisson_candidate(d, c, r, bmin, bmax, &rng, y)) continue;
            long yc[3];
            pgrid_cell_of(&g, y, yc);
            if (!pgrid_clear(&g, &all, y, yc, r)) continue;
            if (all.n >= INT32_MAX || !ptbuf_push(&all, y)) {
                ok = 0;
                break;
            }
            g.cell[pgrid_index(&g, yc)] = (int32_t)(all.n - 1);
            if (nact == capact) {
                size_t *q2 = sm_realloc(active, 2 * capact * sizeof(size_t));
                if (!q2) {
                    ok = 0;
                    break;
                }
                active = q2;
                capact *= 2;
            }
            active[nact++] = all.n - 1;
            found = 1;
        }
        if (!found) active[ai] = active[--nact];
    }
    for (size_t i = 0; ok && i < all.n; i++)
        if (keep_point(shape, sd->clip, d, all.x + 3 * i) && !ptbuf_push(out, all.x + 3 * i)) ok = 0;
    free(g.cell);
    free(active);
    free(all.x);
    return ok;
}

/* The points of the chunk added with their velocities, v + omega x (x - centroid) (the centroid
 * is 0 when omega is: no spin); the chunk emptied. */
static int sink_flush(seed_sink *k) {
    const int d = k->w->dim;
    const double *om = k->sd->angular_velocity, *cen = k->cen, *x = k->chunk.x;
    const size_t n = k->chunk.n;
    if (n == 0) return 1;
    double *vel = sm_malloc(n * 3 * sizeof(double));
    if (!vel) return 0;
    for (size_t i = 0; i < n; i++) {
        double r[3] = {x[3 * i] - cen[0], x[3 * i + 1] - cen[1], x[3 * i + 2] - cen[2]};
        if (d == 2) r[2] = 0;
        double wx = d == 2 ? 0 : om[0], wy = d == 2 ? 0 : om[1], wz = om[2];
        vel[3 * i + 0] = k->sd->velocity[0] + wy * r[2] - wz * r[1];
        vel[3 * i + 1] = k->sd->velocity[1] + wz * r[0] - wx * r[2];
        vel[3 * i + 2] = d == 2 ? 0 : k->sd->velocity[2] + wx * r[1] - wy * r[0];
    }
    k->st = sm_world_add_particles(k->w, n, x, vel, k->sd->material, k->sd->ppc);
    free(vel);
    k->chunk.n = 0;
    return k->st == SM_OK;
}

/* One pass of the shape's points into k: the jittered lattice generated again, or Poisson's
 * samples (made once, into *pts, on the first pass). */
static int seed_points(seed_sink *k, const sm_shape *shape, const double bmin[3], const double bmax[3], ptbuf *pts) {
    if (k->sd->method == SM_SEED_JITTERED) return seed_jittered(k->w, shape, k->sd, bmin, bmax, k);
    if (k->pass == SINK_COUNT && !seed_poisson(k->w, shape, k->sd, bmin, bmax, pts)) return 0;
    for (size_t i = 0; i < pts->n; i++)
        if (!sink_point(k, pts->x + 3 * i)) return 0;
    return 1;
}

sm_status sm_world_seed_shape(sm_world *w, const sm_shape *shape, const sm_seed_def *sd, size_t *added) {
    if (added) *added = 0;
    if (!shape || !sd) return sm_world_fail(w, SM_ERR_INVALID, "seed: shape and seed definition are required");
    if (sd->material < 0 || sd->material >= w->nmats)
        return sm_world_fail(w, SM_ERR_INVALID, "material: unknown id %d (%d defined)", sd->material, w->nmats);
    if (!(sd->ppc > 0) || !isfinite(sd->ppc) || sd->ppc > 4096)
        return sm_world_fail(w, SM_ERR_INVALID, "ppc: must be in (0, 4096], got %g", sd->ppc);
    if (sd->method != SM_SEED_JITTERED && sd->method != SM_SEED_POISSON)
        return sm_world_fail(w, SM_ERR_INVALID, "seed method: unknown value %d", (int)sd->method);
    for (int a = 0; a < 3; a++)
        if (!isfinite(sd->velocity[a]) || !isfinite(sd->angular_velocity[a]))
            return sm_world_fail(w, SM_ERR_INVALID, "seed velocity: must be finite");
    char msg[256]; /* sm_shape_check also refuses a mesh shape without a field of the world's dimension */
    if (!sm_shape_check(shape, w->dim, "seed shape", msg, sizeof msg) ||
        (sd->clip && !sm_shape_check(sd->clip, w->dim, "seed clip", msg, sizeof msg)))
        return sm_world_fail(w, SM_ERR_INVALID, "%s", msg);
    const int d = w->dim;
    double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0}, bmin[3], bmax[3];
    for (int a = 0; a < d; a++) {
        /* Half a lattice step inside the usable region so clamping never moves a seeded point. */
        lo[a] = w->def.domain_min[a] + 2.0 * w->def.dx;
        hi[a] = w->def.domain_max[a] - 2.0 * w->def.dx;
    }
    shape_bounds(shape, d, lo, hi, bmin, bmax);
    for (int a = 0; a < d; a++)
        if (!(bmax[a] > bmin[a])) return SM_OK; /* nothing of the shape inside the domain */
    seed_sink k = {w, sd, SINK_COUNT, 0, {0, 0, 0}, {0}, SM_OK};
    ptbuf pts = {0}; /* Poisson's samples: the sampler needs them all at once */
    int ok = seed_points(&k, shape, bmin, bmax, &pts);
    if (ok && k.n > 0 && !w->keep && !w->dist) { /* one process: the storage at its exact size, as one add made it */
        k.st = sm_world_reserve_particles(w, w->p.n + k.n);
        ok = k.st == SM_OK;
    }
    const double *om = sd->angular_velocity;
    const int spins = om[2] != 0 || (w->dim == 3 && (om[0] != 0 || om[1] != 0));
    for (int pass = spins ? SINK_CENTRE : SINK_ADD; ok && k.n > 0 && pass <= SINK_ADD; pass++) {
        k.pass = pass;
        ok = seed_points(&k, shape, bmin, bmax, &pts) && (pass != SINK_ADD || sink_flush(&k));
    }
    free(pts.x);
    free(k.chunk.x);
    if (!ok) return k.st != SM_OK ? k.st : sm_world_fail(w, SM_ERR_NOMEM, "seed: out of memory");
    if (added) *added = k.n;
    return SM_OK;
}
