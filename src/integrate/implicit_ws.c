/* The implicit solve's workspace (implicit_solver.h): storage only. */
#include <string.h>

#include "integrate/implicit_solver.h"

sm_status sm_implicit_ws_reserve(sm_implicit_ws *ws, int dim, size_t nodes, size_t nblocks, size_t np, int K) {
    const size_t d = (size_t)dim;
    if (ws->partial_cap < nblocks) {
        double *pa = sm_realloc(ws->partial, nblocks * sizeof *pa);
        if (!pa) return SM_ERR_NOMEM;
        ws->partial = pa;
        ws->partial_cap = nblocks;
    }
    if (ws->ncap < nodes || ws->kcap < K + 1) {
        size_t cap = nodes + nodes / 4 + 64;
        int kc = K + 1;
        sm_real **vecs[9] = {&ws->mass, &ws->vn, &ws->z, &ws->y, &ws->dz, &ws->aux, &ws->force, &ws->pz, &ws->pinv};
        for (int k = 0; k < 9; k++) {
            sm_real *q = sm_realloc(*vecs[k], cap * (k == 0 ? 1 : k == 8 ? d * d : d) * sizeof(sm_real));
            if (!q) return SM_ERR_NOMEM;
            *vecs[k] = q;
        }
        sm_real *kr = sm_realloc(ws->krylov, (size_t)kc * cap * d * sizeof(sm_real));
        sm_node_contact *rc = sm_realloc(ws->contact, cap * sizeof *rc);
        if (kr) ws->krylov = kr;
        if (rc) ws->contact = rc;
        if (!kr || !rc) return SM_ERR_NOMEM;
        ws->ncap = cap;
        ws->kcap = kc;
    }
    if (ws->pcap < np) {
        size_t cap = np + np / 4 + 64;
        sm_implicit_particle *pp = sm_realloc(ws->pp, cap * sizeof *pp);
        if (!pp) return SM_ERR_NOMEM;
        ws->pp = pp;
        ws->pcap = cap;
    }
    return SM_OK;
}

void sm_implicit_ws_free(sm_implicit_ws *ws) {
    void *arrays[] = {ws->partial, ws->mass, ws->vn, ws->z, ws->y, ws->dz, ws->aux, ws->force, ws->pz, ws->pinv, ws->krylov,
                      ws->contact, ws->pp};
    for (size_t i = 0; i < sizeof arrays / sizeof arrays[0]; i++) free(arrays[i]);
    memset(ws, 0, sizeof *ws);
}

size_t sm_implicit_ws_bytes(const sm_implicit_ws *ws, int dim) {
    const size_t d = (size_t)dim;
    return ws->ncap * sizeof(sm_real) * (1 + 7 * d + d * d) + (size_t)ws->kcap * ws->ncap * d * sizeof(sm_real) +
           ws->ncap * sizeof(sm_node_contact) + ws->pcap * sizeof(sm_implicit_particle) +
           ws->partial_cap * sizeof(double);
}
