/* Particles on a target (the camera's image or a shadow map): projection of each particle's
 * sphere, then splatting into a z-buffer that keeps the nearest surface (ties: the lowest particle
 * index). Splatting is parallel over bands of BAND_ROWS rows: particles are binned into bands in
 * index order (fixed chunking, independent of the thread count), and each band is written by one
 * thread, so every pixel sees the same sequence of particles whatever the threads. See internal.h. */
#include <stdlib.h>

#include "app/render/internal.h"

/* A particle's stored copy in a band's list. */
typedef struct binned {
    proj p;
    uint32_t idx;
} binned;

void render_project_all(const rctx *R, const view *v, int w, int h, int depth_shape) {
    const sm_frame *f = R->f;
    const long n = (long)f->n;
    proj *P = R->P;
    const double near = 1e-4 * R->diag;
    const double maxr = 4.0 * (double)(w + h);
OMP(omp parallel for schedule(static) num_threads(R->threads))
    for (long i = 0; i < n; i++) {
        proj *p = &P[i];
        double x[3] = {f->x[3 * i], f->x[3 * i + 1], f->x[3 * i + 2]};
        double r = prad(R, (size_t)i);
        p->sr = -1.0f;
        if (!finite3(x) || !(r > 0) || !isfinite(r)) continue;
        double sx, sy, z;
        render_view_project(v, x, &sx, &sy, &z);
        if (!(fabs(z) < 1e30) || (!v->ortho && !(z > r + near))) continue;
        double sr = v->ortho ? r * v->focal : r * v->focal / z;
        if (!(sr < maxr) || sx + sr < 0 || sy + sr < 0 || sx - sr > w || sy - sr > h) continue;
        p->sx = (float)sx;
        p->sy = (float)sy;
        p->sr = (float)sr;
        p->z = (float)z;
        p->rw = depth_shape ? (float)r : 0.0f;
    }
}

static void proj_rows(const proj *p, int *r0, int *r1) {
    if (p->sr < 1.0f) {
        *r0 = *r1 = (int)floorf(p->sy);
    } else {
        *r0 = (int)ceilf(p->sy - p->sr - 0.5f);
        *r1 = (int)floorf(p->sy + p->sr - 0.5f);
    }
}

static inline void zput(float *zb, uint32_t *zi, size_t k, float d, uint32_t idx) {
    if (d < zb[k] || (zi && d == zb[k] && idx < zi[k])) {
        zb[k] = d;
        if (zi) zi[k] = idx;
    }
}

/* Draws particle idx into rows [y0, y1) of a w-wide target. */
static void splat_one(const proj *p, uint32_t idx, int y0, int y1, int w, float *zb, uint32_t *zi) {
    if (p->sr < 1.0f) { /* sub-pixel: the pixel holding the centre */
        int px = (int)floorf(p->sx), py = (int)floorf(p->sy);
        if (py < y0 || py >= y1 || px < 0 || px >= w) return;
        float dx = ((float)px + 0.5f - p->sx), dy = ((float)py + 0.5f - p->sy);
        float rr = p->sr > 0.25f ? (dx * dx + dy * dy) / (p->sr * p->sr) : 0.0f;
        float dz = rr < 1.0f ? p->rw * sqrtf(1.0f - rr) : 0.0f;
        zput(zb, zi, (size_t)py * (size_t)w + (size_t)px, p->z - dz, idx);
        return;
    }
    int r0, r1;
    proj_rows(p, &r0, &r1);
    if (r0 < y0) r0 = y0;
    if (r1 > y1 - 1) r1 = y1 - 1;
    const float sr2 = p->sr * p->sr, inv2 = 1.0f / sr2;
    const float zfront = p->z - p->rw; /* nothing of this particle is nearer */
    for (int y = r0; y <= r1; y++) {
        float dy = (float)y + 0.5f - p->sy;
        float h2 = sr2 - dy * dy;
        if (h2 < 0.0f) continue;
        float hx = sqrtf(h2);
        int x0 = (int)ceilf(p->sx - hx - 0.5f), x1 = (int)floorf(p->sx + hx - 0.5f);
        if (x0 < 0) x0 = 0;
        if (x1 > w - 1) x1 = w - 1;
        size_t row = (size_t)y * (size_t)w;
        for (int x = x0; x <= x1; x++) {
            if (zfront > zb[row + (size_t)x]) continue; /* hidden: skip the square root */
            float dx = (float)x + 0.5f - p->sx;
            float rr = (dx * dx + dy * dy) * inv2;
            float dz = rr < 1.0f ? p->rw * sqrtf(1.0f - rr) : 0.0f;
            zput(zb, zi, row + (size_t)x, p->z - dz, idx);
        }
    }
}

/* Bands (of BAND_ROWS rows) that particle p covers in an image of h rows: [*b0, *b1]; 0 if none
 * (hidden, or above / below the image). */
static int proj_bands(const proj *p, int h, int *b0, int *b1) {
    if (!(p->sr >= 0.0f)) return 0;
    int r0, r1;
    proj_rows(p, &r0, &r1);
    if (r0 < 0) r0 = 0;
    if (r1 > h - 1) r1 = h - 1;
    if (r0 > r1) return 0;
    *b0 = r0 / BAND_ROWS;
    *b1 = r1 / BAND_ROWS;
    return 1;
}

/* The fixed chunking of n particles for binning: nch chunks of per particles. */
typedef struct chunking {
    size_t n, nch, per;
    int nb; /* bands */
} chunking;

/* One pass over the particles by chunks: without list, counts per (chunk, band) into cnt; with
 * list, copies each particle's projection into the lists of the bands it covers at the cursors
 * cnt (advancing them). */
static void bin_pass(const chunking *ch, const proj *P, int h, size_t *cnt, binned *list, int threads) {
    (void)threads; /* without OpenMP */
    const long nchl = (long)ch->nch;
    const int nb = ch->nb;
OMP(omp parallel for schedule(static) num_threads(threads))
    for (long c = 0; c < nchl; c++) {
        size_t i0 = (size_t)c * ch->per, i1 = i0 + ch->per < ch->n ? i0 + ch->per : ch->n;
        size_t *cc = cnt + (size_t)c * (size_t)nb;
        for (size_t i = i0; i < i1; i++) {
            int b0, b1;
            if (!proj_bands(&P[i], h, &b0, &b1)) continue;
            for (int b = b0; b <= b1; b++) {
                if (!list) {
                    cc[b]++;
                    continue;
                }
                binned *e = &list[cc[b]++];
                e->p = P[i];
                e->idx = (uint32_t)i;
            }
        }
    }
}

/* Turns the counts into write cursors of one list ordered by band, then chunk, then index;
 * start[b] is band b's first entry, start[nb] the total. */
static void band_starts(const chunking *ch, size_t *cnt, size_t *start) {
    const int nb = ch->nb;
    size_t total = 0;
    for (int b = 0; b < nb; b++) {
        start[b] = total;
        for (size_t c = 0; c < ch->nch; c++) {
            size_t k = cnt[c * (size_t)nb + (size_t)b];
            cnt[c * (size_t)nb + (size_t)b] = total; /* now the write cursor */
            total += k;
        }
    }
    start[nb] = total;
}

sm_status render_splat_all(const proj *P, size_t n, int w, int h, float *zb, uint32_t *zi, int threads) {
    (void)threads; /* without OpenMP */
    chunking ch;
    ch.n = n;
    ch.nb = (h + BAND_ROWS - 1) / BAND_ROWS;
    ch.nch = n / 16384 + 1;
    if (ch.nch > 256) ch.nch = 256;
    ch.per = (n + ch.nch - 1) / ch.nch;
    size_t *cnt = calloc(ch.nch * (size_t)ch.nb, sizeof *cnt);
    size_t *start = calloc((size_t)ch.nb + 1, sizeof *start);
    binned *list = NULL;
    sm_status st = SM_ERR_NOMEM;
    if (cnt && start) {
        bin_pass(&ch, P, h, cnt, NULL, threads);
        band_starts(&ch, cnt, start);
        /* The band lists hold copies of the projections: each band then reads its particles
         * sequentially instead of gathering them from the whole array (a cache miss each). */
        list = malloc((start[ch.nb] ? start[ch.nb] : 1) * sizeof *list);
    }
    if (list) {
        bin_pass(&ch, P, h, cnt, list, threads);
        const int nb = ch.nb;
OMP(omp parallel for schedule(dynamic, 1) num_threads(threads))
        for (int b = 0; b < nb; b++) {
            int y0 = b * BAND_ROWS, y1 = y0 + BAND_ROWS < h ? y0 + BAND_ROWS : h;
            for (size_t k = start[b]; k < start[b + 1]; k++) splat_one(&list[k].p, list[k].idx, y0, y1, w, zb, zi);
        }
        st = SM_OK;
    }
    free(list);
    free(cnt);
    free(start);
    return st;
}
