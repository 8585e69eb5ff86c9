/* Mesh files through assimp's C API (see mesh_load.h).
 *
 * Node transforms: a vertex of a mesh referenced by node n is mapped by M = T_root ... T_n (the
 * product of the 4x4 node matrices from the root down, column vectors), then placed:
 *   x' = R (s * (u x)) + t,  R v = v + 2 w (q x v) + 2 q x (q x v) for the unit quaternion (w, q).
 * Welding: vertices with bitwise equal placed coordinates become one (assimp keeps a vertex per
 * face corner in STL and per normal/uv in OBJ and glTF; topology needs shared vertices).
 * Degenerate triangle: two equal indices, or |ab x ac| <= 1e-12 (longest edge)^2 (the library's
 * rule for a triangle without a face).
 * Topology from the directed edges of all triangles, grouped by undirected edge: an edge of one
 * triangle is open, of three or more non-manifold; an edge of an even number of triangles is
 * consistently oriented iff as many use it forwards as backwards.
 * Signed volume V = (1/6) sum_t a . (b x c) (divergence theorem); V < 0: normals point inwards. */
#define _POSIX_C_SOURCE 200809L
#include "app/io/mesh_load.h"

#include <assimp/cimport.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

sm_mesh_load_opts sm_mesh_load_opts_default(void) {
    sm_mesh_load_opts o;
    memset(&o, 0, sizeof o);
    o.dim = 3;
    o.placement.unit = 1.0;
    o.placement.scale[0] = o.placement.scale[1] = o.placement.scale[2] = 1.0;
    o.placement.rotation[0] = 1.0;
    return o;
}

void sm_mesh_data_free(sm_mesh_data *m) {
    free(m->vertices);
    free(m->elements);
    memset(m, 0, sizeof *m);
}

void sm_mesh_warn(char *msg, size_t msglen, const char *fmt, ...) {
    size_t used = strlen(msg);
    if (used + 3 >= msglen) return;
    if (used) {
        memcpy(msg + used, "; ", 3);
        used += 2;
    }
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg + used, msglen - used, fmt, ap);
    va_end(ap);
}

/* ------------------------------------------------------------------------------------------ */
/* Gathering the scene graph                                                                   */

typedef struct gather {
    double *v;
    uint32_t *tri, *lin;
    size_t nv, nt, nl, capv, capt, capl, meshes;
    int nomem;
} gather;

/* Grows *p (elements of size sz) to hold need, doubling. */
static int grow(void **p, size_t *cap, size_t need, size_t sz) {
    if (need <= *cap) return 1;
    size_t c = *cap ? *cap : 1024;
    while (c < need) c *= 2;
    void *q = realloc(*p, c * sz);
    if (!q) return 0;
    *p = q;
    *cap = c;
    return 1;
}

static void add_mesh(gather *g, const struct aiMesh *m, const double M[16]) {
    if (!grow((void **)&g->v, &g->capv, 3 * (g->nv + m->mNumVertices), sizeof(double))) {
        g->nomem = 1;
        return;
    }
    const size_t base = g->nv;
    for (unsigned i = 0; i < m->mNumVertices; i++) {
        const double x[3] = {m->mVertices[i].x, m->mVertices[i].y, m->mVertices[i].z};
        for (int r = 0; r < 3; r++) g->v[3 * (base + i) + (size_t)r] = M[4 * r] * x[0] + M[4 * r + 1] * x[1] + M[4 * r + 2] * x[2] + M[4 * r + 3];
    }
    g->nv += m->mNumVertices;
    for (unsigned f = 0; f < m->mNumFaces; f++) {
        const struct aiFace *fc = &m->mFaces[f];
        uint32_t **dst = fc->mNumIndices == 3 ? &g->tri : fc->mNumIndices == 2 ? &g->lin : NULL;
        if (!dst) continue; /* points (polygons do not survive aiProcess_Triangulate) */
        size_t *n = fc->mNumIndices == 3 ? &g->nt : &g->nl, *cap = fc->mNumIndices == 3 ? &g->capt : &g->capl;
        if (!grow((void **)dst, cap, (*n + 1) * fc->mNumIndices, sizeof(uint32_t))) {
            g->nomem = 1;
            return;
        }
        for (unsigned k = 0; k < fc->mNumIndices; k++) (*dst)[*n * fc->mNumIndices + k] = (uint32_t)(base + fc->mIndices[k]);
        (*n)++;
    }
    g->meshes++;
}

static void walk(const struct aiScene *s, const struct aiNode *nd, const double parent[16], gather *g, int depth) {
    const struct aiMatrix4x4 *t = &nd->mTransformation;
    const double T[16] = {t->a1, t->a2, t->a3, t->a4, t->b1, t->b2, t->b3, t->b4,
                          t->c1, t->c2, t->c3, t->c4, t->d1, t->d2, t->d3, t->d4};
    double M[16];
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 4; c++)
            M[4 * r + c] = parent[4 * r] * T[c] + parent[4 * r + 1] * T[4 + c] + parent[4 * r + 2] * T[8 + c] + parent[4 * r + 3] * T[12 + c];
    for (unsigned i = 0; i < nd->mNumMeshes && !g->nomem; i++) add_mesh(g, s->mMeshes[nd->mMeshes[i]], M);
    for (unsigned i = 0; i < nd->mNumChildren && !g->nomem && depth < 256; i++) walk(s, nd->mChildren[i], M, g, depth + 1);
}

/* Reads the file into g. SM_OK, or SM_ERR_IO with the reason in msg. */
static sm_status read_scene(const char *path, gather *g, char *msg, size_t msglen) {
    FILE *fp = fopen(path, "rb");
    if (!fp) {
        if (errno == ENOENT) snprintf(msg, msglen, "mesh file not found");
        else snprintf(msg, msglen, "cannot open mesh file: %s", strerror(errno));
        return SM_ERR_IO;
    }
    fclose(fp);
    const struct aiScene *s = aiImportFile(path, aiProcess_Triangulate | aiProcess_JoinIdenticalVertices |
                                                     aiProcess_ValidateDataStructure);
    if (!s || !s->mRootNode) {
        snprintf(msg, msglen, "cannot read mesh: %s", aiGetErrorString());
        if (s) aiReleaseImport(s);
        return SM_ERR_IO;
    }
    const double I[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    walk(s, s->mRootNode, I, g, 0);
    aiReleaseImport(s);
    if (g->nomem) {
        snprintf(msg, msglen, "out of memory reading the mesh");
        return SM_ERR_NOMEM;
    }
    return SM_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* Placement, welding                                                                          */

static void place(const sm_mesh_placement *pl, double *v, size_t n) {
    double q[4], qn = 0;
    for (int k = 0; k < 4; k++) qn += pl->rotation[k] * pl->rotation[k];
    for (int k = 0; k < 4; k++) q[k] = qn > 0 ? pl->rotation[k] / sqrt(qn) : (k == 0);
    for (size_t i = 0; i < n; i++) {
        double *x = v + 3 * i, p[3], c1[3], c2[3];
        for (int k = 0; k < 3; k++) p[k] = pl->scale[k] * (pl->unit * x[k]);
        /* c1 = q x p + w p, then p + 2 q x c1 (the same as p + 2w (q x p) + 2 q x (q x p)) */
        c1[0] = q[2] * p[2] - q[3] * p[1] + q[0] * p[0];
        c1[1] = q[3] * p[0] - q[1] * p[2] + q[0] * p[1];
        c1[2] = q[1] * p[1] - q[2] * p[0] + q[0] * p[2];
        c2[0] = q[2] * c1[2] - q[3] * c1[1];
        c2[1] = q[3] * c1[0] - q[1] * c1[2];
        c2[2] = q[1] * c1[1] - q[2] * c1[0];
        for (int k = 0; k < 3; k++) x[k] = p[k] + 2.0 * c2[k] + pl->translation[k];
    }
}

static uint64_t point_key(const double *p, int dims) {
    uint64_t h = 0x9ae16a3b2f90404fULL;
    for (int k = 0; k < dims; k++) {
        uint64_t b;
        double x = p[k] == 0.0 ? 0.0 : p[k]; /* -0 and +0 weld */
        memcpy(&b, &x, sizeof b);
        h = (h ^ b) * 0xff51afd7ed558ccdULL;
        h ^= h >> 29;
    }
    return h;
}

size_t sm_mesh_weld(const double *pts, size_t n, int dims, uint32_t *remap, double *uniq) {
    size_t cap = 16;
    while (cap < 2 * n) cap *= 2;
    uint32_t *slot = malloc(cap * sizeof *slot);
    if (!slot) return 0;
    memset(slot, 0xff, cap * sizeof *slot);
    size_t nu = 0;
    for (size_t i = 0; i < n; i++) {
        const double *p = pts + 3 * i;
        size_t s = (size_t)point_key(p, dims) & (cap - 1);
        for (;; s = (s + 1) & (cap - 1)) {
            uint32_t u = slot[s];
            if (u == UINT32_MAX) { /* new point */
                memmove(uniq + 3 * nu, p, 3 * sizeof(double));
                if (dims == 2) uniq[3 * nu + 2] = 0.0;
                slot[s] = (uint32_t)nu;
                remap[i] = (uint32_t)nu++;
                break;
            }
            const double *q = uniq + 3 * (size_t)u;
            if (q[0] == p[0] && q[1] == p[1] && (dims == 2 || q[2] == p[2])) {
                remap[i] = u;
                break;
            }
        }
    }
    free(slot);
    return nu;
}

/* ------------------------------------------------------------------------------------------ */
/* Triangle checks                                                                             */

static double dist2(const double *a, const double *b) {
    return (a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]);
}

static int tri_degenerate(const double *v, const uint32_t *t) {
    if (t[0] == t[1] || t[1] == t[2] || t[2] == t[0]) return 1;
    const double *a = v + 3 * (size_t)t[0], *b = v + 3 * (size_t)t[1], *c = v + 3 * (size_t)t[2];
    double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    double n[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
    double l2 = fmax(dist2(a, b), fmax(dist2(a, c), dist2(b, c)));
    return !(n[0] * n[0] + n[1] * n[1] + n[2] * n[2] > 1e-24 * l2 * l2);
}

typedef struct dedge {
    uint64_t key; /* (min << 32) | max */
    uint32_t forward, tri;
} dedge;

static int dedge_cmp(const void *pa, const void *pb) {
    const dedge *a = pa, *b = pb;
    if (a->key != b->key) return a->key < b->key ? -1 : 1;
    return a->tri < b->tri ? -1 : a->tri > b->tri;
}

/* Counts open, non-manifold and misoriented edges; first[k] receives a point of the first edge
 * of each kind (midpoint). Returns 0 on allocation failure. */
static int tri_topology(sm_mesh_data *m, double first[3][3]) {
    const size_t nt = m->element_count;
    dedge *e = malloc(3 * nt * sizeof *e);
    if (!e) return 0;
    for (size_t t = 0; t < nt; t++)
        for (int k = 0; k < 3; k++) {
            uint32_t a = m->elements[3 * t + (size_t)k], b = m->elements[3 * t + (size_t)(k + 1) % 3];
            e[3 * t + (size_t)k] = (dedge){a < b ? ((uint64_t)a << 32 | b) : ((uint64_t)b << 32 | a), a < b, (uint32_t)t};
        }
    qsort(e, 3 * nt, sizeof *e, dedge_cmp);
    sm_mesh_report *r = &m->report;
    for (size_t g = 0; g < 3 * nt;) {
        size_t end = g, fwd = 0;
        for (; end < 3 * nt && e[end].key == e[g].key; end++) fwd += e[end].forward;
        size_t n = end - g;
        int kind = -1; /* 0 open, 1 non-manifold, 2 misoriented */
        if (n == 1)
            kind = 0;
        else if (n % 2 == 0 && 2 * fwd != n)
            kind = 2;
        else if (n > 2)
            kind = 1;
        size_t *count = kind == 0 ? &r->open_edges : kind == 1 ? &r->nonmanifold_edges : kind == 2 ? &r->misoriented_edges : NULL;
        if (count && (*count)++ == 0) {
            const double *a = m->vertices + 3 * (size_t)(e[g].key >> 32), *b = m->vertices + 3 * (size_t)(e[g].key & 0xffffffffu);
            for (int k = 0; k < 3; k++) first[kind][k] = 0.5 * (a[k] + b[k]);
        }
        g = end;
    }
    free(e);
    return 1;
}

static double tri_volume(const sm_mesh_data *m) {
    double v = 0;
    for (size_t t = 0; t < m->element_count; t++) {
        const uint32_t *e = m->elements + 3 * t;
        const double *a = m->vertices + 3 * (size_t)e[0], *b = m->vertices + 3 * (size_t)e[1], *c = m->vertices + 3 * (size_t)e[2];
        v += (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0])) / 6.0;
    }
    return v;
}

/* Removes degenerate triangles (warning), then checks the topology and orientation. Problems go
 * to err (an error) or warn (warnings). */
static sm_status check_3d(const sm_mesh_load_opts *o, sm_mesh_data *m, char *err, size_t errlen, char *warn, size_t wlen) {
    size_t kept = 0, first_bad = 0;
    for (size_t t = 0; t < m->element_count; t++) {
        if (tri_degenerate(m->vertices, m->elements + 3 * t)) {
            if (m->report.degenerate++ == 0) first_bad = t;
            continue;
        }
        memmove(m->elements + 3 * kept++, m->elements + 3 * t, 3 * sizeof(uint32_t));
    }
    m->element_count = kept;
    if (m->report.degenerate)
        sm_mesh_warn(warn, wlen, "%zu degenerate (zero-area) triangles removed (the first is triangle %zu)",
                     m->report.degenerate, first_bad);
    if (kept == 0) {
        snprintf(err, errlen, "no triangles with an area (%zu read, all degenerate)", m->report.elements_read);
        return SM_ERR_INVALID;
    }
    double at[3][3] = {{0}};
    if (!tri_topology(m, at)) return SM_ERR_NOMEM;
    const sm_mesh_report *r = &m->report;
    if (r->misoriented_edges) {
        snprintf(err, errlen, "inconsistent winding: %zu edges where neighbouring triangles face opposite ways (the "
                 "first near (%.6g, %.6g, %.6g)); recalculate the normals in the modelling tool (Blender: Mesh > "
                 "Normals > Recalculate Outside)", r->misoriented_edges, at[2][0], at[2][1], at[2][2]);
        return SM_ERR_INVALID;
    }
    if (o->require_closed && (r->open_edges || r->nonmanifold_edges)) {
        snprintf(err, errlen, "not a closed surface: %zu open and %zu non-manifold edges (the first near (%.6g, %.6g, "
                 "%.6g)); a solid needs a closed, manifold mesh", r->open_edges, r->nonmanifold_edges,
                 r->open_edges ? at[0][0] : at[1][0], r->open_edges ? at[0][1] : at[1][1], r->open_edges ? at[0][2] : at[1][2]);
        return SM_ERR_INVALID;
    }
    if (r->open_edges)
        sm_mesh_warn(warn, wlen, "open surface: %zu boundary edges (the first near (%.6g, %.6g, %.6g)); usable as a "
                     "one-sided collider, not as a solid", r->open_edges, at[0][0], at[0][1], at[0][2]);
    if (r->nonmanifold_edges)
        sm_mesh_warn(warn, wlen, "%zu non-manifold edges (shared by more than two triangles, the first near (%.6g, "
                     "%.6g, %.6g)); the inside is taken by winding number", r->nonmanifold_edges, at[1][0], at[1][1], at[1][2]);
    m->report.volume = tri_volume(m);
    if (m->report.volume < 0 && !r->open_edges)
        sm_mesh_warn(warn, wlen, "the normals point inwards (signed volume %.6g m^3): the mesh acts as a container, "
                     "solid outside", m->report.volume);
    return SM_OK;
}

/* Keeps only referenced vertices (in first-use order); bounds; hash. 0 on allocation failure. */
static int finish(sm_mesh_data *m) {
    uint32_t *map = malloc((m->vertex_count ? m->vertex_count : 1) * sizeof *map);
    if (!map) return 0;
    memset(map, 0xff, m->vertex_count * sizeof *map);
    double *v = malloc(3 * (m->vertex_count ? m->vertex_count : 1) * sizeof(double));
    if (!v) {
        free(map);
        return 0;
    }
    size_t nu = 0, ni = m->element_count * (size_t)m->dim;
    for (size_t i = 0; i < ni; i++) {
        uint32_t *e = &m->elements[i];
        if (map[*e] == UINT32_MAX) {
            memcpy(v + 3 * nu, m->vertices + 3 * (size_t)*e, 3 * sizeof(double));
            map[*e] = (uint32_t)nu++;
        }
        *e = map[*e];
    }
    free(map);
    free(m->vertices);
    m->vertices = v;
    m->vertex_count = nu;
    for (int k = 0; k < 3; k++) {
        m->lo[k] = HUGE_VAL;
        m->hi[k] = -HUGE_VAL;
    }
    for (size_t i = 0; i < nu; i++)
        for (int k = 0; k < 3; k++) {
            m->lo[k] = fmin(m->lo[k], v[3 * i + (size_t)k]);
            m->hi[k] = fmax(m->hi[k], v[3 * i + (size_t)k]);
        }
    uint64_t h = 0xcbf29ce484222325ULL;
    const unsigned char *parts[3] = {(const unsigned char *)&m->dim, (const unsigned char *)v, (const unsigned char *)m->elements};
    const size_t sizes[3] = {sizeof m->dim, 3 * nu * sizeof(double), ni * sizeof(uint32_t)};
    for (int p = 0; p < 3; p++)
        for (size_t i = 0; i < sizes[p]; i++) h = (h ^ parts[p][i]) * 0x100000001b3ULL;
    m->hash = h;
    return 1;
}

/* Turns the gathered, placed, welded scene into out (3D). */
static sm_status take_triangles(gather *g, size_t nu, const sm_mesh_load_opts *o, sm_mesh_data *out, char *err,
                                size_t errlen, char *warn, size_t wlen) {
    if (g->nt == 0) {
        snprintf(err, errlen, "no triangles (%zu line elements; a 3D scene needs a surface)", g->nl);
        return SM_ERR_INVALID;
    }
    out->dim = 3;
    out->vertices = g->v;
    out->vertex_count = nu;
    out->elements = g->tri;
    out->element_count = g->nt;
    g->v = NULL;
    g->tri = NULL;
    out->report.elements_read = out->element_count;
    out->report.source = "triangles";
    return check_3d(o, out, err, errlen, warn, wlen);
}

sm_status sm_mesh_load(const char *path, const sm_mesh_load_opts *opts, sm_mesh_data *out, char *msg, size_t msglen) {
    memset(out, 0, sizeof *out);
    char err[512] = "", warn[1024] = "";
    gather g;
    memset(&g, 0, sizeof g);
    sm_status st = read_scene(path, &g, err, sizeof err);
    uint32_t *remap = st == SM_OK ? malloc((g.nv ? g.nv : 1) * sizeof *remap) : NULL;
    size_t nu = 0;
    if (st == SM_OK && (!remap || (g.nv && (nu = sm_mesh_weld(g.v, g.nv, 3, remap, g.v)) == 0))) st = SM_ERR_NOMEM;
    if (st == SM_OK) {
        place(&opts->placement, g.v, nu);
        for (size_t i = 0; i < 3 * g.nt; i++) g.tri[i] = remap[g.tri[i]];
        for (size_t i = 0; i < 2 * g.nl; i++) g.lin[i] = remap[g.lin[i]];
        if (opts->dim == 2)
            st = sm_mesh_outline(g.v, nu, g.lin, g.nl, g.tri, g.nt, opts, out, err, sizeof err, warn, sizeof warn);
        else
            st = take_triangles(&g, nu, opts, out, err, sizeof err, warn, sizeof warn);
        out->report.meshes = g.meshes;
        out->report.welded = g.nv - nu;
    }
    if (st == SM_OK && !finish(out)) st = SM_ERR_NOMEM;
    if (st == SM_ERR_NOMEM && !err[0]) snprintf(err, sizeof err, "out of memory");
    free(remap);
    free(g.v);
    free(g.tri);
    free(g.lin);
    if (st != SM_OK) {
        sm_mesh_data_free(out);
        if (msglen) snprintf(msg, msglen, "%s: %s", path, err);
        return st;
    }
    if (msglen) snprintf(msg, msglen, "%s%s%s", warn[0] ? path : "", warn[0] ? ": " : "", warn);
    return SM_OK;
}
