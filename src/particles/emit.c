/* Emitters: particle sources with a mass flow rate (thesis §4.1.2, pile from spout).
 *
 * At the end of each step an active emitter owes rate * (overlap of the step with [start, stop])
 * kilograms; it adds floor(owed / m_p) particles, each at a uniformly random point of its shape
 * (rejection sampling in the shape's bounding box), and carries the remainder to the next step, so
 * the emitted mass follows rate * t to within one particle. Points come from a counter-based RNG of
 * (seed, emitted count): the result does not depend on step sizes' history or thread count.
 *
 * A mesh region (SM_SHAPE_MESH, issue 15) is sampled the same way: inside is phi < 0 of its
 * field, the box is the world box of the field's table box (stats lo/hi, placed by the shape's
 * rotation and centre), clipped to the usable domain and shrunk to the lattice cells that may hold
 * an inside point (shrink_to_inside); a mesh filling less than 2% of that box is
 * refused (1000 misses in a row would then be likely enough to matter). The emitter keeps a
 * reference on the field (released by sm_world_destroy). Containers (unbounded solids) are refused. */
#include <string.h>

#include "collide/collide.h"
#include "collide/mesh_field.h"
#include "core/hash.h"
#include "world/world.h"

sm_emitter_def sm_emitter_def_default(void) {
    sm_emitter_def e;
    memset(&e, 0, sizeof e);
    e.shape = sm_shape_default(SM_SHAPE_SPHERE);
    e.ppc = 8;
    e.rate = 1;
    e.start = 0;
    e.stop = INFINITY;
    e.seed = 1;
    return e;
}

/* Clips [bmin, bmax] to [lo, hi]; 0 if that leaves nothing. */
static int clip_box(int dim, const double lo[3], const double hi[3], double bmin[3], double bmax[3]) {
    for (int a = 0; a < 3; a++) {
        bmin[a] = a < dim ? fmax(lo[a], bmin[a]) : 0;
        bmax[a] = a < dim ? fmin(hi[a], bmax[a]) : 0;
    }
    for (int a = 0; a < dim; a++)
        if (!(bmax[a] > bmin[a])) return 0;
    return 1;
}

/* Shrinks [bmin, bmax] to the cells of a 64^dim lattice that may hold a point with phi < 0: the
 * field's interpolant satisfies phi(x) >= phi(y) - |x - y| - sqrt(d) h (docs/mesh-fields.md,
 * "Lipschitz"), so a cell whose centre y has phi(y) > (half diagonal) + sqrt(d) h holds none.
 * 0 if no cell may. */
static int shrink_to_inside(const sm_shape *s, int dim, double bmin[3], double bmax[3]) {
    enum { N = 64 };
    double c[3] = {0, 0, 0}, half2 = 0, nlo[3] = {INFINITY, INFINITY, 0}, nhi[3] = {-INFINITY, -INFINITY, 0};
    for (int a = 0; a < dim; a++) {
        c[a] = (bmax[a] - bmin[a]) / N;
        half2 += 0.25 * c[a] * c[a];
    }
    if (dim == 3) nlo[2] = INFINITY, nhi[2] = -INFINITY;
    const double margin = sqrt(half2) + sqrt((double)dim) * sm_mesh_field_get_stats(s->mesh)->spacing;
    for (int i = 0; i < N; i++)
        for (int j = 0; j < N; j++)
            for (int k = 0; k < (dim == 3 ? N : 1); k++) {
                const int ijk[3] = {i, j, k};
                double y[3] = {0, 0, 0};
                for (int a = 0; a < dim; a++) y[a] = bmin[a] + (ijk[a] + 0.5) * c[a];
                if (sm_shape_distance(s, dim, y, NULL) > margin) continue;
                for (int a = 0; a < dim; a++) {
                    nlo[a] = fmin(nlo[a], y[a] - 0.5 * c[a]);
                    nhi[a] = fmax(nhi[a], y[a] + 0.5 * c[a]);
                }
            }
    for (int a = 0; a < dim; a++) {
        if (!(nhi[a] > nlo[a])) return 0;
        bmin[a] = fmax(bmin[a], nlo[a]);
        bmax[a] = fmin(bmax[a], nhi[a]);
    }
    return 1;
}

/* A mesh: the world box of the field's table box (mesh frame) placed by the shape's rotation and
 * centre (its 2^dim corners), clipped, then shrunk about the inside; 0 for a container (solid
 * everywhere outside). */
static int mesh_bounds(const sm_shape *s, int dim, const double lo[3], const double hi[3], double bmin[3],
                       double bmax[3]) {
    if (!s->mesh || s->inside_out || !isfinite(sm_mesh_field_extent(s->mesh))) return 0;
    const sm_mesh_field_stats *st = sm_mesh_field_get_stats(s->mesh);
    double R[9];
    sm_quat_to_mat(s->rotation, R);
    for (int a = 0; a < 3; a++) bmin[a] = INFINITY, bmax[a] = -INFINITY;
    for (int c = 0; c < (1 << dim); c++) {
        double p[3] = {0, 0, 0};
        for (int a = 0; a < dim; a++) p[a] = (c >> a) & 1 ? st->hi[a] : st->lo[a];
        for (int a = 0; a < 3; a++) {
            const double x = s->center[a] + R[3 * a] * p[0] + R[3 * a + 1] * p[1] + R[3 * a + 2] * p[2];
            bmin[a] = fmin(bmin[a], x);
            bmax[a] = fmax(bmax[a], x);
        }
    }
    if (!clip_box(dim, lo, hi, bmin, bmax)) return 0;
    return shrink_to_inside(s, dim, bmin, bmax);
}

/* Bounding box of a finite shape (conservative), clipped to [lo, hi]. Returns 0 for unbounded. */
static int emitter_bounds(const sm_shape *s, int dim, const double lo[3], const double hi[3], double bmin[3],
                          double bmax[3]) {
    double r = 0;
    switch (s->kind) {
    case SM_SHAPE_SPHERE: r = s->radius; break;
    case SM_SHAPE_BOX:
        r = sqrt(s->half_extent[0] * s->half_extent[0] + s->half_extent[1] * s->half_extent[1] +
                 (dim == 3 ? s->half_extent[2] * s->half_extent[2] : 0));
        break;
    case SM_SHAPE_CYLINDER: r = sqrt(s->radius * s->radius + s->half_height * s->half_height); break;
    case SM_SHAPE_MESH: return mesh_bounds(s, dim, lo, hi, bmin, bmax);
    default: return 0;
    }
    if (s->inside_out) return 0;
    for (int a = 0; a < 3; a++) {
        bmin[a] = a < dim ? fmax(lo[a], s->center[a] - r) : 0;
        bmax[a] = a < dim ? fmin(hi[a], s->center[a] + r) : 0;
    }
    for (int a = 0; a < dim; a++)
        if (!(bmax[a] > bmin[a])) return 0;
    return 1;
}

/* Point n of a (2^bits)^dim block in coarse-to-fine order: n's bits * dim bits reversed and
 * de-interleaved into the axes, so points 0 .. 2^dim - 1 are the block's coarsest corners, the next
 * ones halve that spacing, and so on; n -> (i, j, k) is a bijection. */
static void coarse_to_fine(unsigned n, int bits, int dim, int idx[3]) {
    const int total = bits * dim;
    unsigned r = 0;
    for (int b = 0; b < total; b++) r |= ((n >> b) & 1u) << (total - 1 - b);
    idx[0] = idx[1] = idx[2] = 0;
    for (int b = 0; b < bits; b++)
        for (int a = 0; a < dim; a++) idx[a] |= (int)((r >> (b * dim + a)) & 1u) << b;
}

/* sm_shape_volume_estimate(shape, NULL, dim, lo, hi) > 0, stopping at the first inside point of
 * the same 64^dim lattice, and visiting only its points inside the shape's box [bmin, bmax] (which
 * holds every inside point: the emitter samples there), coarse to fine: a shape is found after a
 * few evaluations, a shape with no lattice point inside is refused after its box's points, instead
 * of up to 262,144 evaluations either way (a checkpoint's load adds its emitters again). */
static int shape_has_volume(const sm_shape *shape, int dim, const double lo[3], const double hi[3],
                            const double bmin[3], const double bmax[3]) {
    const int N = 64;
    double h[3] = {0, 0, 0};
    int first[3] = {0, 0, 0}, count[3] = {1, 1, 1}, bits = 0;
    for (int a = 0; a < dim; a++) {
        if (!(hi[a] > lo[a])) return 0;
        h[a] = (hi[a] - lo[a]) / N; /* point i at lo + (i + 0.5) h */
        const double i0 = floor((bmin[a] - lo[a]) / h[a] - 0.5), i1 = ceil((bmax[a] - lo[a]) / h[a] - 0.5);
        first[a] = (int)fmax(0, i0);
        count[a] = (int)fmin(N - 1, i1) - first[a] + 1;
        if (count[a] <= 0) return 0;
        while ((1 << bits) < count[a]) bits++;
    }
    const unsigned total = 1u << (bits * dim);
    for (unsigned n = 0; n < total; n++) {
        int idx[3];
        coarse_to_fine(n, bits, dim, idx);
        if (idx[0] >= count[0] || idx[1] >= count[1] || idx[2] >= count[2]) continue;
        double x[3] = {0, 0, 0};
        for (int a = 0; a < dim; a++) x[a] = lo[a] + (first[a] + idx[a] + 0.5) * h[a];
        if (sm_shape_distance(shape, dim, x, NULL) < 0) return 1;
    }
    return 0;
}

sm_status sm_world_add_emitter(sm_world *w, const sm_emitter_def *e, int *id) {
    if (id) *id = -1;
    if (!e) return sm_world_fail(w, SM_ERR_INVALID, "emitter definition is NULL");
    if (e->material < 0 || e->material >= w->nmats)
        return sm_world_fail(w, SM_ERR_INVALID, "emitter material: unknown id %d (%d defined)", e->material, w->nmats);
    if (!(e->ppc > 0) || !isfinite(e->ppc)) return sm_world_fail(w, SM_ERR_INVALID, "emitter ppc: must be > 0, got %g", e->ppc);
    if (!(e->rate > 0) || !isfinite(e->rate)) return sm_world_fail(w, SM_ERR_INVALID, "emitter rate: must be > 0, got %g", e->rate);
    if (!isfinite(e->start) || !(e->stop > e->start))
        return sm_world_fail(w, SM_ERR_INVALID, "emitter: need a finite start and stop > start, got %g .. %g", e->start, e->stop);
    for (int a = 0; a < 3; a++)
        if (!isfinite(e->velocity[a])) return sm_world_fail(w, SM_ERR_INVALID, "emitter velocity: must be finite");
    double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0}, bmin[3], bmax[3];
    for (int a = 0; a < w->dim; a++) {
        lo[a] = w->def.domain_min[a] + 2 * w->def.dx;
        hi[a] = w->def.domain_max[a] - 2 * w->def.dx;
    }
    char msg[256]; /* sm_shape_check also refuses a mesh shape without a field of the world's dimension */
    if (!sm_shape_check(&e->shape, w->dim, "emitter shape", msg, sizeof msg))
        return sm_world_fail(w, SM_ERR_INVALID, "%s", msg);
    if (!emitter_bounds(&e->shape, w->dim, lo, hi, bmin, bmax))
        return sm_world_fail(w, SM_ERR_INVALID,
                             "emitter shape: must be a sphere, box, cylinder or closed mesh (not inside-out, not a "
                             "container) inside the domain");
    if (!shape_has_volume(&e->shape, w->dim, lo, hi, bmin, bmax))
        return sm_world_fail(w, SM_ERR_INVALID, "emitter shape: has no volume inside the usable domain");
    if (e->shape.kind == SM_SHAPE_MESH) { /* rejection sampling gives up after 1000 tries: P < 2e-9 */
        double box = 1;
        for (int a = 0; a < w->dim; a++) box *= bmax[a] - bmin[a];
        const double fill = sm_shape_volume_estimate(&e->shape, NULL, w->dim, bmin, bmax) / box;
        if (!(fill >= 0.02))
            return sm_world_fail(w, SM_ERR_INVALID,
                                 "emitter shape: the mesh fills %.2g%% of its bounding box in the usable domain "
                                 "(at least 2%% needed for sampling): use a more compact mesh",
                                 100 * fill);
    }
    if (w->nemitters == w->emitters_cap) {
        int cap = w->emitters_cap ? 2 * w->emitters_cap : 4;
        sm_emitter *q = sm_realloc(w->emitters, (size_t)cap * sizeof *q);
        if (!q) return sm_world_fail(w, SM_ERR_NOMEM, "out of memory");
        w->emitters = q;
        w->emitters_cap = cap;
    }
    sm_emitter *em = &w->emitters[w->nemitters];
    memset(em, 0, sizeof *em);
    em->def = *e;
    memcpy(em->bmin, bmin, sizeof bmin);
    memcpy(em->bmax, bmax, sizeof bmax);
    em->particle_mass = pow(w->def.dx, w->dim) / e->ppc * w->mats[e->material].def.density;
    if (e->shape.kind == SM_SHAPE_MESH) sm_mesh_field_retain((sm_mesh_field *)e->shape.mesh);
    if (id) *id = w->nemitters;
    w->nemitters++;
    return SM_OK;
}

double sm_world_emitted_mass(const sm_world *w, int id) {
    if (id < 0 || id >= w->nemitters) return 0;
    return (double)w->emitters[id].emitted * w->emitters[id].particle_mass;
}

sm_status sm_world_run_emitters(sm_world *w, double t0, double t1) {
    for (int k = 0; k < w->nemitters; k++) {
        sm_emitter *em = &w->emitters[k];
        const sm_emitter_def *e = &em->def;
        double a = fmax(t0, e->start), b = fmin(t1, e->stop);
        if (!(b > a)) continue;
        em->owed += e->rate * (b - a);
        size_t count = (size_t)floor(em->owed / em->particle_mass);
        if (count == 0) continue;
        em->owed -= (double)count * em->particle_mass;
        if (count > w->emit_cap) { /* scratch kept by the world: steady emission allocates nothing */
            size_t cap = count + count / 2;
            double *q = sm_realloc(w->emit_buf, cap * 6 * sizeof(double));
            if (!q) return sm_world_fail(w, SM_ERR_NOMEM, "emitter %d: out of memory", k);
            w->emit_buf = q;
            w->emit_cap = cap;
        }
        double *pos = w->emit_buf, *vel = w->emit_buf + 3 * count;
        for (size_t i = 0; i < count; i++) {
            double x[3] = {0, 0, 0};
            for (int tries = 0;; tries++) {
                uint64_t key = sm_mix64(e->seed ^ sm_mix64(em->emitted * 1024 + (uint64_t)tries));
                for (int d = 0; d < w->dim; d++) {
                    key = sm_mix64(key + (uint64_t)d + 1);
                    x[d] = em->bmin[d] + sm_u01(key) * (em->bmax[d] - em->bmin[d]);
                }
                if (sm_shape_distance(&e->shape, w->dim, x, NULL) < 0 || tries > 1000) break;
            }
            em->emitted++;
            memcpy(pos + 3 * i, x, sizeof x);
            memcpy(vel + 3 * i, e->velocity, 3 * sizeof(double));
        }
        size_t first = w->p.n;
        sm_status st = sm_world_add_particles(w, count, pos, vel, e->material, e->ppc);
        if (st != SM_OK) return st;
        sm_world_init_stress(w, first);
    }
    return SM_OK;
}

double sm_shape_volume_estimate(const sm_shape *shape, const sm_shape *clip, int dim, const double lo[3],
                                const double hi[3]) {
    const int N = 64;
    double h[3] = {0, 0, 0}, cell = 1;
    for (int a = 0; a < dim; a++) {
        if (!(hi[a] > lo[a])) return 0;
        h[a] = (hi[a] - lo[a]) / N;
        cell *= h[a];
    }
    size_t inside = 0;
    for (int i = 0; i < N; i++)
        for (int j = 0; j < N; j++)
            for (int k = 0; k < (dim == 3 ? N : 1); k++) {
                double x[3] = {lo[0] + (i + 0.5) * h[0], lo[1] + (j + 0.5) * h[1], dim == 3 ? lo[2] + (k + 0.5) * h[2] : 0};
                if (sm_shape_distance(shape, dim, x, NULL) < 0 && (!clip || sm_shape_distance(clip, dim, x, NULL) < 0))
                    inside++;
            }
    return (double)inside * cell;
}
