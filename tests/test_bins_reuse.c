/* A step keeps the last particle binning when no particle has left its block, and brings it up to
 * date by moving the particles that did (grid/rebin_dim.c), and that changes no bits:
 *  - 2D and 3D sand blocks seeded just above the ground, released under gravity (they drop a few
 *    millimetres, ring and settle: steps that keep the binning and steps that cannot), advanced on
 *    2 threads beside the same world whose binning is forgotten before every step (every step
 *    bins afresh): the same state hash after every 25 steps; the first kept the binning in some
 *    steps and moved particles in others, the second did neither;
 *  - then, in both, ten particles moved by hand by a whole block (as a caller writing positions
 *    could): the binning is not kept for that step but brought up to date, and the hashes stay
 *    equal;
 *  - particles added between steps (a different count) bin afresh, equal hashes again. */
#include "test_util.h"
#include "sandmpm/sandmpm.h"
#include "world/world.h"

static sm_world *build(int dim) {
    sm_world_def def = sm_world_def_default();
    def.dim = dim;
    def.dx = dim == 2 ? 0.02 : 0.05;
    def.threads = 2;
    const double c[3] = {0.5, 0.32, 0.5}, h[3] = {0.15, 0.1, 0.15};
    return sm_test_sand_box(&def, 0.2, c, h);
}

static void step(sm_world *w, int forget) {
    if (forget) w->bins.basis.valid = 0;
    CHECK(sm_world_step(w, sm_world_next_dt(w, 1.0)) == SM_OK);
}

/* Steps both worlds `steps` times; 1 if their hashes agreed after every 25th step and the last. */
static int advance_pair(sm_world *keep, sm_world *fresh, int steps) {
    int same = 1;
    for (int s = 1; s <= steps; s++) {
        step(keep, 0);
        step(fresh, 1);
        if (s % 25 == 0 || s == steps) same &= sm_world_state_hash(keep) == sm_world_state_hash(fresh);
    }
    return same;
}

/* Moves storage particles 0..9 by one block (4 cells) along x. */
static void teleport(sm_world *w) {
    for (size_t i = 0; i < 10 && i < w->p.n; i++) w->p.x[i * (size_t)w->dim] += 4.0 * w->def.dx;
}

static void add_row(sm_world *w) {
    double x[3 * 4] = {0}, v[3 * 4] = {0};
    for (int k = 0; k < 4; k++) {
        x[3 * k] = 0.4 + 0.05 * k; /* 3 values per particle in 2D too */
        x[3 * k + 1] = 0.6;
        x[3 * k + 2] = w->dim == 3 ? 0.5 : 0.0;
    }
    CHECK(sm_world_add_particles(w, 4, x, v, 0, 8.0) == SM_OK);
}

static void run_case(int dim) {
    sm_world *keep = build(dim), *fresh = build(dim);
    if (!keep || !fresh) return;
    const int steps = 300;
    CHECK(advance_pair(keep, fresh, steps));
    const uint64_t kept = keep->bins.reuses, moved = keep->bins.rebins;
    printf("%dD, %zu particles: %d steps, the binning kept in %llu, brought up to date by moves in %llu, afresh in "
           "every step of the other (kept %llu, moved %llu); hashes %016llx / %016llx\n",
           dim, keep->p.n, steps, (unsigned long long)kept, (unsigned long long)moved,
           (unsigned long long)fresh->bins.reuses, (unsigned long long)fresh->bins.rebins,
           (unsigned long long)sm_world_state_hash(keep), (unsigned long long)sm_world_state_hash(fresh));
    CHECK(kept > 0 && kept < (uint64_t)steps);
    CHECK(moved > 0 && kept + moved <= (uint64_t)steps);
    CHECK(fresh->bins.reuses == 0 && fresh->bins.rebins == 0);

    teleport(keep), teleport(fresh);
    const uint64_t before = keep->bins.reuses, moved_before = keep->bins.rebins;
    step(keep, 0), step(fresh, 1);
    CHECK(keep->bins.reuses == before); /* ten particles in other blocks: not kept as it was */
    CHECK(keep->bins.rebins == moved_before + 1); /* but brought up to date by moving them */
    CHECK(sm_world_state_hash(keep) == sm_world_state_hash(fresh));
    CHECK(advance_pair(keep, fresh, 50));

    add_row(keep), add_row(fresh);
    const uint64_t before_add = keep->bins.reuses;
    step(keep, 0), step(fresh, 1);
    CHECK(keep->bins.reuses == before_add);
    CHECK(advance_pair(keep, fresh, 50));
    sm_world_destroy(keep);
    sm_world_destroy(fresh);
}

int main(void) {
    run_case(2);
    run_case(3);
    return sm_test_summary("test_bins_reuse");
}
