/* The binning by movers (grid/rebin_dim.c): a binning kept from step to step and brought up to
 * date by moving only the particles that left their blocks is, entry for entry, the full binning
 * made afresh (perm, blocks with their ranges, `ascending` and grid slots, colour lists, live grid
 * blocks):
 *  - 2D and 3D, quadratic and cubic kernels, a block of sand collapsing over 120 steps; the world's
 *    own steps reorder its storage now and then beneath the kept binning;
 *  - particles moved by hand: ten by one block, then every particle of one block by two blocks
 *    along x (a block empties and one appears), then those of another by minus two (the blocks
 *    between move up in perm);
 *  - storage shuffled: the kept binning's stretches are out of id order, so the full binning runs,
 *    and the result is again the fresh one.
 * It also checks that the kept binning did use the moves (counted in sm_bins.rebins). */
#include "sandmpm/sandmpm.h"
#include "test_binning.h"

static sm_world *build(int dim, sm_kernel kernel) {
    sm_world_def def = sm_world_def_default();
    def.dim = dim;
    def.dx = dim == 2 ? 0.01 : 0.03;
    def.kernel = kernel;
    def.threads = 2;
    const double c[3] = {0.5, 0.3, 0.5}, h[3] = {0.15, 0.15, 0.12};
    return sm_test_sand_box(&def, 0.1, c, h);
}

/* same_binning, and the blocks' more, early and side (0 after either binning) and both hashes
 * (every live grid block and particle block found at its index). */
static int same_kept_binning(const binning *x, const binning *y, int dim) {
    const sm_bins *a = &x->b, *b = &y->b;
    int same = same_binning(x, y, dim);
    for (size_t r = 0; same && r < a->npb; r++)
        same &= a->pb[r].more == b->pb[r].more && a->pb[r].early == b->pb[r].early && a->pb[r].side == b->pb[r].side;
    for (size_t s = 0; same && s < y->g.nactive; s++) same &= sm_block_hash_find(&y->g.hash, y->g.key[s]) == (uint32_t)s;
    for (size_t r = 0; same && r < b->npb; r++) same &= sm_block_hash_find(&b->pb_hash, b->pb[r].key) == (uint32_t)r;
    return same;
}

/* Bins the world's particles into the kept binning and into a fresh one; 1 if they are equal. */
static int kept_is_fresh(sm_world *w, binning *kept) {
    const sm_step_ctx c = ctx_of(w);
    binning fresh;
    binning_init(&fresh, w);
    int ok = w->stages->bin(&fresh.b, &w->p, &fresh.g, &c) == SM_OK;
    ok &= w->stages->bin(&kept->b, &w->p, &kept->g, &c) == SM_OK;
    ok &= fresh.b.rebins == 0 && fresh.b.reuses == 0;
    ok &= same_kept_binning(&fresh, kept, w->dim);
    binning_free(&fresh);
    return ok;
}

/* Moves every particle of the kept binning's block r by `blocks` blocks along x. */
static void move_block(sm_world *w, const binning *kept, size_t r, double blocks) {
    const sm_pblock *pb = &kept->b.pb[r];
    for (uint32_t j = pb->start; j < pb->end; j++) w->p.x[(size_t)kept->b.perm[j] * (size_t)w->dim] += blocks * 4.0 * w->def.dx;
}

/* The kept binning's largest block of at most n / 20 particles (the binning by movers takes up to
 * n / 16 movers). */
static size_t block_to_move(const binning *kept, size_t n) {
    size_t best = 0, best_len = 0;
    for (size_t r = 0; r < kept->b.npb; r++) {
        const size_t len = kept->b.pb[r].end - kept->b.pb[r].start;
        if (len <= n / 20 && len > best_len) best = r, best_len = len;
    }
    return best;
}

static int total_grew, total_shrank; /* over all cases: the moves did add and drop blocks */

static void run_case(int dim, sm_kernel kernel) {
    sm_world *w = build(dim, kernel);
    if (!w) return;
    const char *name = kernel == SM_KERNEL_CUBIC ? "cubic" : "quadratic";
    binning kept;
    binning_init(&kept, w);
    int ok = kept_is_fresh(w, &kept);
    const uint64_t reorders0 = w->bins.reorders;
    int grew = 0, shrank = 0; /* steps whose binning by movers added blocks, dropped blocks */
    for (int s = 0; s < 120; s++) {
        CHECK(sm_world_step(w, sm_world_next_dt(w, 1.0)) == SM_OK);
        const size_t npb = kept.b.npb;
        const uint64_t moved = kept.b.rebins;
        ok &= kept_is_fresh(w, &kept);
        if (kept.b.rebins > moved) grew += kept.b.npb > npb, shrank += kept.b.npb < npb;
    }
    printf("%dD %s, %zu particles, 120 steps: the kept binning %s (moved %llu, with more blocks %d, with fewer %d; "
           "held %llu; the world's storage reordered %llu times)\n",
           dim, name, w->p.n, ok ? "is the fresh one after each" : "DIFFERS", (unsigned long long)kept.b.rebins, grew,
           shrank, (unsigned long long)kept.b.reuses, (unsigned long long)(w->bins.reorders - reorders0));
    CHECK(ok);
    CHECK(kept.b.rebins > 0);
    total_grew += grew, total_shrank += shrank;

    const uint64_t rebins = kept.b.rebins;
    for (size_t i = 0; i < 10; i++) w->p.x[i * 37 % w->p.n * (size_t)w->dim] += 4.0 * w->def.dx;
    ok = kept_is_fresh(w, &kept);
    size_t r1 = block_to_move(&kept, w->p.n);
    const uint32_t n1 = kept.b.pb[r1].end - kept.b.pb[r1].start;
    move_block(w, &kept, r1, 2.0);
    ok &= kept_is_fresh(w, &kept);
    size_t r2 = block_to_move(&kept, w->p.n);
    const uint32_t n2 = kept.b.pb[r2].end - kept.b.pb[r2].start;
    move_block(w, &kept, r2, -2.0);
    ok &= kept_is_fresh(w, &kept);
    printf("%dD %s: ten particles moved by a block, then the %u of one block by two blocks, then the %u of another "
           "by minus two: %s (moved %llu more)\n",
           dim, name, n1, n2, ok ? "the fresh binning" : "DIFFERENT", (unsigned long long)(kept.b.rebins - rebins));
    CHECK(ok);
    CHECK(kept.b.rebins == rebins + 3);

    shuffle(w);
    const uint64_t rebins_before = kept.b.rebins;
    ok = kept_is_fresh(w, &kept);
    printf("%dD %s: storage shuffled: %s (by the full binning: %s)\n", dim, name, ok ? "the fresh binning" : "DIFFERENT",
           kept.b.rebins == rebins_before ? "yes" : "NO");
    CHECK(ok);
    CHECK(kept.b.rebins == rebins_before);
    binning_free(&kept);
    sm_world_destroy(w);
}

int main(void) {
    run_case(2, SM_KERNEL_QUADRATIC);
    run_case(2, SM_KERNEL_CUBIC);
    run_case(3, SM_KERNEL_QUADRATIC);
    run_case(3, SM_KERNEL_CUBIC);
    CHECK(total_grew > 0 && total_shrank > 0);
    return sm_test_summary("test_rebin");
}
