/* Messages of any size between ranks (dist_internal.h). MPI counts are int, so a buffer of more
 * than INT_MAX bytes (about 14 million particles in 3D float) cannot go in one call: it goes in
 * pieces of at most d->piece bytes, posted in order with one tag. MPI keeps messages between two
 * ranks with one tag and communicator in the order they were posted (non-overtaking), so the
 * receiver's pieces of the same sizes match the sender's one for one. */
#include <limits.h>
#include <stdlib.h>

#include "dist/dist_internal.h"
#include "world/world.h"

int sm_dist_reserve_requests(sm_dist *d, size_t n) {
    if (n <= d->req_cap) return 1;
    MPI_Request *r = realloc(d->req, n * sizeof *r);
    if (!r) return 0;
    d->req = r;
    d->req_cap = n;
    return 1;
}

/* Pieces of `bytes` bytes at d->piece bytes each (0 for an empty buffer). */
size_t sm_dist_request_count(const sm_dist *d, size_t bytes) { return (bytes + d->piece - 1) / d->piece; }

/* One piece after another: `send` 1 posts sends of buf to peer, 0 receives into it. Returns the
 * requests posted, written from d->req + at. */
static size_t post(sm_dist *d, int send, unsigned char *buf, size_t bytes, int peer, int tag, size_t at) {
    size_t k = 0;
    for (size_t off = 0; off < bytes; off += d->piece, k++) {
        const int len = (int)(bytes - off < d->piece ? bytes - off : d->piece);
        if (send) MPI_Isend(buf + off, len, MPI_BYTE, peer, tag, d->comm, &d->req[at + k]);
        else MPI_Irecv(buf + off, len, MPI_BYTE, peer, tag, d->comm, &d->req[at + k]);
    }
    return k;
}

size_t sm_dist_isend(sm_dist *d, const unsigned char *buf, size_t bytes, int peer, int tag, size_t at) {
    return post(d, 1, (unsigned char *)buf, bytes, peer, tag, at);
}

size_t sm_dist_irecv(sm_dist *d, unsigned char *buf, size_t bytes, int peer, int tag, size_t at) {
    return post(d, 0, buf, bytes, peer, tag, at);
}

void sm_dist_wait(sm_dist *d, size_t n) {
    for (size_t at = 0; at < n;) { /* MPI_Waitall's count is int too */
        const int k = (int)(n - at < (size_t)INT_MAX ? n - at : (size_t)INT_MAX);
        MPI_Waitall(k, d->req + at, MPI_STATUSES_IGNORE);
        at += (size_t)k;
    }
}

void sm_dist_set_piece_bytes(struct sm_world *w, size_t bytes) {
    if (w->dist) w->dist->piece = bytes > 0 && bytes <= SM_DIST_PIECE ? bytes : SM_DIST_PIECE;
}
