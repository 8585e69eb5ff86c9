/* The binner's second batch (grid/bin.h, sm_bin_more; a distributed step bins its arrivals with
 * it after scattering its inner blocks, dist/overlap.c): binning particles [0, first) and then
 * adding [first, n) leaves the bins and the grid exactly as one binning of all n would (blocks,
 * their perm stretches in id order, `ascending`, grid slots, colour lists; the live grid blocks),
 * and the P2G sums of the grid blocks live before the second batch are kept, at their new slots,
 * while the new ones are zero. 2D and 3D, quadratic and cubic kernels, a collapsing block after
 * some steps; storage in block order (the first batch is whole blocks and one partial one) and
 * shuffled (most blocks get particles from both batches); several split points. */
#include "test_util.h"
#include "sandmpm/sandmpm.h"
#include "world/world.h"

#include <string.h>

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

/* The binner's view of the step context. */
static sm_step_ctx ctx_of(const sm_world *w) {
    sm_step_ctx c;
    memset(&c, 0, sizeof c);
    c.pos_dx = w->def.dx;
    c.pos_inv_dx = w->inv_dx;
    for (int a = 0; a < 3; a++) c.pos_lo[a] = w->def.domain_min[a];
    c.stencil = w->def.kernel == SM_KERNEL_CUBIC ? 4 : 3;
    c.threads = 2;
    return c;
}

typedef struct binning {
    sm_bins b;
    sm_grid g;
} binning;

static void binning_init(binning *x, const sm_world *w) {
    memset(&x->b, 0, sizeof x->b);
    x->b.keep_storage = 1;
    CHECK(sm_bins_reserve_perm(&x->b, w->p.n) == SM_OK);
    sm_grid_init(&x->g, w->dim, w->grid.nodes, 0);
}

static void binning_free(binning *x) {
    sm_bins_free(&x->b);
    sm_grid_free(&x->g);
}

/* A value for node l of the grid block with key k (what P2G had added there). */
static sm_real mark(uint64_t k, size_t l) { return (sm_real)((double)(k % 9973) + 0.001 * (double)l + 1.0); }

/* 1 if the two binnings are equal, field by field. */
static int same_binning(const binning *x, const binning *y, int dim) {
    const sm_bins *a = &x->b, *b = &y->b;
    int same = a->npb == b->npb && x->g.nactive == y->g.nactive;
    for (size_t r = 0; same && r < a->npb; r++) {
        const sm_pblock *p = &a->pb[r], *q = &b->pb[r];
        same &= p->key == q->key && p->start == q->start && p->end == q->end && p->ascending == q->ascending;
        same &= memcmp(p->gslot, q->gslot, sizeof p->gslot) == 0;
        same &= memcmp(a->perm + p->start, b->perm + p->start, (p->end - p->start) * sizeof *a->perm) == 0;
    }
    for (int c = 0; same && c <= (1 << dim); c++) same &= a->color_offset[c] == b->color_offset[c];
    if (same) same &= memcmp(a->color_blocks, b->color_blocks, a->npb * sizeof *a->color_blocks) == 0;
    if (same) same &= memcmp(x->g.key, y->g.key, x->g.nactive * sizeof *x->g.key) == 0;
    return same;
}

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

static void shuffle(sm_world *w) {
    const size_t n = w->p.n;
    uint32_t *perm = malloc(n * sizeof *perm);
    for (size_t i = 0; i < n; i++) perm[i] = (uint32_t)i;
    uint64_t s = 12345;
    for (size_t i = n; i-- > 1;) {
        s = s * 6364136223846793005ULL + 1442695040888963407ULL;
        const size_t j = (size_t)(s >> 33) % (i + 1);
        const uint32_t t = perm[i];
        perm[i] = perm[j];
        perm[j] = t;
    }
    sm_particles_permute(&w->p, w->dim, perm);
    free(perm);
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
