/* What the binning tests share (test_bin_more.c, test_rebin.c): a binning of a world's particles
 * kept apart from the world's own, the step context the binner reads, the comparison of two
 * binnings and a shuffle of the storage. */
#ifndef SM_TEST_BINNING_H
#define SM_TEST_BINNING_H

#include <string.h>

#include "test_util.h"
#include "world/world.h"

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

/* A binning that never reorders the world's storage. */
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

/* 1 if the two binnings are equal, field by field: blocks (key, range, `ascending`, grid slots),
 * their stretches of perm, colour lists, live grid blocks. */
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

/* The world's storage in a fixed pseudo-random order. */
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

#endif
