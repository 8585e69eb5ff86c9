/* The binner's second batch (grid/bin.h, sm_bin_more; a distributed step bins its arrivals with
 * it after scattering its inner blocks, dist/overlap.c): binning particles [0, first) and then
 * adding [first, n) leaves the bins and the grid exactly as one binning of all n would (blocks,
 * their perm stretches in id order, `ascending`, grid slots, colour lists; the live grid blocks),
 * and the P2G sums of the grid blocks live before the second batch are kept, at their new slots,
 * while the new ones are zero. 2D and 3D, quadratic and cubic kernels, a collapsing block after
 * some steps; storage in block order (the first batch is whole blocks and one partial one) and
 * shuffled (most blocks get particles from both batches); several split points. */
#include "sandmpm/sandmpm.h"
#include "test_binning.h"

static sm_world *build(int dim, sm_kernel kernel) {
    sm_world_def def = sm_world_def_default();
    def.dim = dim;
    def.dx = dim == 2 ? 0.01 : 0.03;
    def.kernel = kernel;
    def.threads = 2;
    const double c[3] = {0.5, 0.3, 0.5}, h[3] = {0.15, 0.15, 0.12};
    sm_world *w = sm_test_sand_box(&def, 0.1, c, h);
    if (!w) return NULL;
    for (int s = 0; s < 40; s++) CHECK(sm_world_step(w, sm_world_next_dt(w, 1.0)) == SM_OK);
    return w;
}

/* A value for node l of the grid block with key k (what P2G had added there). */
static sm_real mark(uint64_t k, size_t l) { return (sm_real)((double)(k % 9973) + 0.001 * (double)l + 1.0); }

/* Bins [0, first) into y, marks its live grid blocks' masses and momenta, adds [first, n); then y
 * against the one binning x of all n. Returns 1 if everything matched. */
static int check_split(sm_world *w, const binning *x, size_t first, size_t *kept_blocks) {
    const sm_step_ctx c = ctx_of(w);
    const size_t n = w->p.n, bn = (size_t)w->grid.block_nodes, d = (size_t)w->dim;
    binning y;
    binning_init(&y, w);
    w->p.n = first;
    int ok = w->stages->bin(&y.b, &w->p, &y.g, &c) == SM_OK;
    w->p.n = n;
    const size_t before = y.g.nactive;
    for (size_t s = 0; s < before; s++)
        for (size_t l = 0; l < bn; l++) {
            y.g.mass[s * bn + l] = mark(y.g.key[s], l);
            for (size_t a = 0; a < d; a++) y.g.vec[0][(s * bn + l) * d + a] = -mark(y.g.key[s], l + a);
        }
    ok &= w->stages->bin_more(&y.b, &w->p, &y.g, &c, first) == SM_OK;
    ok &= same_binning(x, &y, w->dim);
    size_t kept = 0;
    for (size_t s = 0; ok && s < y.g.nactive; s++) {
        const int was_live = sm_block_hash_find(&y.g.hash, y.g.key[s]) == (uint32_t)s; /* the hash follows */
        ok &= was_live;
        for (size_t l = 0; l < bn; l++) {
            const sm_real m = y.g.mass[s * bn + l], v = y.g.vec[0][(s * bn + l) * d];
            if (m != 0) {
                ok &= m == mark(y.g.key[s], l) && v == -mark(y.g.key[s], l);
                kept += l == 0;
            } else {
                ok &= v == 0;
            }
        }
    }
    ok &= kept == before; /* every block live before kept its values, every new one is zero */
    *kept_blocks = kept;
    binning_free(&y);
    return ok;
}

static void run_case(int dim, sm_kernel kernel) {
    sm_world *w = build(dim, kernel);
    if (!w) return;
    for (int shuffled = 0; shuffled <= 1; shuffled++) {
        if (shuffled) shuffle(w);
        const sm_step_ctx c = ctx_of(w);
        binning x;
        binning_init(&x, w);
        CHECK(w->stages->bin(&x.b, &w->p, &x.g, &c) == SM_OK);
        const size_t n = w->p.n, splits[] = {1, n / 3, n / 2, n - 7, n};
        for (int k = 0; k < 5; k++) {
            size_t kept = 0;
            const int ok = check_split(w, &x, splits[k], &kept);
            printf("%dD %s kernel, %s storage, %zu particles: first batch %zu: %s (%zu of %zu grid blocks live before)\n",
                   dim, kernel == SM_KERNEL_CUBIC ? "cubic" : "quadratic", shuffled ? "shuffled" : "block-ordered", n,
                   splits[k], ok ? "the full binning's" : "DIFFERENT", kept, x.g.nactive);
            CHECK(ok);
        }
        binning_free(&x);
    }
    sm_world_destroy(w);
}

int main(void) {
    run_case(2, SM_KERNEL_QUADRATIC);
    run_case(2, SM_KERNEL_CUBIC);
    run_case(3, SM_KERNEL_QUADRATIC);
    run_case(3, SM_KERNEL_CUBIC);
    return sm_test_failures ? 1 : 0;
}
