/* Serialisation of a mesh signed distance field to bytes (for a cache file the app layer writes,
 * keyed by the mesh's hash and the field's spacing and band).
 *
 * Layout (native byte order; a marker word rejects a file from a machine of the other order):
 *   header (HEADER_BYTES): magic "SMMSDF01", u32 0x01020304, u32 version, u32 dim,
 *     u32 container, i32 nb[3], u32 0, f64 h, band, origin[3], u64 nbricks, elements, vertices,
 *     candidate_bricks, band_nodes, f64 lipschitz, volume, u64 checksum
 *   payload: i32 table[nb0 nb1 nb2], f32 coarse[(nb0+1)(nb1+1)(nb2+1 | 1)], f32 bricks[nbricks 9^dim]
 * checksum = FNV-1a 64 over the header (with the checksum field zero) and the payload. Nothing in
 * it depends on time or threads, so equal definitions give equal bytes. */
#include <stdio.h>
#include <string.h>

#include "collide/mesh_sdf_internal.h"
#include "core/hash.h"

#define MAGIC "SMMSDF01"
#define VERSION 1u
#define ENDIAN_MARK 0x01020304u
#define HEADER_BYTES 144

typedef struct cursor {
    unsigned char *w;       /* writing: destination (NULL: only count) */
    const unsigned char *r; /* reading: source */
    size_t at, cap;
} cursor;

static void put(cursor *c, const void *src, size_t n) {
    if (n == 0) return;
    if (c->w && c->at + n <= c->cap) memcpy(c->w + c->at, src, n);
    c->at += n;
}

static int get(cursor *c, void *dst, size_t n) {
    if (n == 0) return 1;
    if (c->at + n > c->cap || c->at + n < c->at) return 0;
    memcpy(dst, c->r + c->at, n);
    c->at += n;
    return 1;
}

/* The header's fields in order, written through put (header only). */
static void put_header(cursor *c, const struct sm_mesh_sdf *f, uint64_t checksum) {
    uint32_t u[4] = {ENDIAN_MARK, VERSION, (uint32_t)f->dim, (uint32_t)f->stats.container};
    int32_t nb[4] = {f->nb[0], f->nb[1], f->nb[2], 0};
    double d[5] = {f->h, f->band, f->origin[0], f->origin[1], f->origin[2]};
    uint64_t n[5] = {f->nbricks, f->stats.elements, f->stats.vertices, f->stats.candidate_bricks, f->stats.band_nodes};
    double s[2] = {f->stats.lipschitz, f->stats.volume};
    put(c, MAGIC, 8);
    put(c, u, sizeof u);
    put(c, nb, sizeof nb);
    put(c, d, sizeof d);
    put(c, n, sizeof n);
    put(c, s, sizeof s);
    put(c, &checksum, sizeof checksum);
}

static uint64_t payload_hash(const struct sm_mesh_sdf *f, uint64_t h) {
    h = sm_hash64(f->table, sm_sdf_table_size(f) * sizeof(int32_t), h);
    h = sm_hash64(f->coarse, sm_sdf_coarse_size(f) * sizeof(float), h);
    return sm_hash64(f->bricks, f->nbricks * f->brick_nodes * sizeof(float), h);
}

static uint64_t field_checksum(const struct sm_mesh_sdf *f) {
    unsigned char head[HEADER_BYTES];
    cursor c = {head, NULL, 0, sizeof head};
    put_header(&c, f, 0);
    return payload_hash(f, sm_hash64(head, sizeof head, SM_HASH_INIT));
}

size_t sm_mesh_sdf_serialize(const sm_mesh_sdf *f, void *buf, size_t cap) {
    cursor c = {buf, NULL, 0, cap};
    put_header(&c, f, field_checksum(f));
    put(&c, f->table, sm_sdf_table_size(f) * sizeof(int32_t));
    put(&c, f->coarse, sm_sdf_coarse_size(f) * sizeof(float));
    put(&c, f->bricks, f->nbricks * f->brick_nodes * sizeof(float));
    return c.at;
}

static sm_status bad(char *err, size_t errlen, const char *why) {
    if (err && errlen) snprintf(err, errlen, "mesh field cache: %s", why);
    return SM_ERR_INVALID;
}

/* Reads and checks the header into f (layout fields and stats); returns NULL or a reason. */
static const char *read_header(cursor *c, struct sm_mesh_sdf *f, uint64_t *checksum) {
    char magic[8];
    uint32_t u[4];
    int32_t nb[4];
    double d[5], s[2];
    uint64_t n[5];
    if (!get(c, magic, 8) || !get(c, u, sizeof u) || !get(c, nb, sizeof nb) || !get(c, d, sizeof d) ||
        !get(c, n, sizeof n) || !get(c, s, sizeof s) || !get(c, checksum, sizeof *checksum))
        return "truncated header";
    if (memcmp(magic, MAGIC, 8)) return "not a mesh field (bad magic)";
    if (u[0] != ENDIAN_MARK) return "written on a machine of the other byte order";
    if (u[1] != VERSION) return "other format version";
    if ((u[2] != 2 && u[2] != 3) || u[3] > 1) return "bad dimension or flags";
    f->dim = (int)u[2];
    f->stats.container = (int)u[3];
    double cells = 1.0;
    for (int k = 0; k < 3; k++) {
        if (nb[k] < 1 || (k == 2 && f->dim == 2 && nb[k] != 1)) return "bad table size";
        f->nb[k] = nb[k];
        cells *= nb[k];
    }
    if (cells > (double)SM_SDF_MAX_TABLE) return "table too large";
    if (!(d[0] > 0.0) || !(d[1] >= d[0]) || !isfinite(d[1])) return "bad spacing or band";
    f->h = d[0];
    f->band = d[1];
    memcpy(f->origin, d + 2, sizeof f->origin);
    f->nbricks = (size_t)n[0];
    f->stats.elements = (size_t)n[1];
    f->stats.vertices = (size_t)n[2];
    f->stats.candidate_bricks = (size_t)n[3];
    f->stats.band_nodes = (size_t)n[4];
    f->stats.lipschitz = s[0];
    f->stats.volume = s[1];
    sm_mesh_sdf_finish_layout(f);
    if (n[0] > sm_sdf_table_size(f)) return "more bricks than table entries";
    return NULL;
}

/* Every table entry is a brick index in range or one of the two flags. */
static int table_ok(const struct sm_mesh_sdf *f) {
    for (size_t i = 0; i < sm_sdf_table_size(f); i++) {
        int32_t v = f->table[i];
        if (v != SM_SDF_INSIDE && v != SM_SDF_OUTSIDE && (v < 0 || (size_t)v >= f->nbricks)) return 0;
    }
    return 1;
}

sm_status sm_mesh_sdf_deserialize(const void *buf, size_t n, sm_mesh_sdf **out, char *err, size_t errlen) {
    *out = NULL;
    struct sm_mesh_sdf *f = sm_calloc(1, sizeof *f);
    if (!f) return SM_ERR_NOMEM;
    cursor c = {NULL, buf, 0, n};
    uint64_t checksum = 0;
    const char *why = read_header(&c, f, &checksum);
    size_t nt = sm_sdf_table_size(f), nc = sm_sdf_coarse_size(f), nbv = f->nbricks * f->brick_nodes;
    if (!why && n - c.at != (nt + nc + nbv) * 4) why = "size does not match the header (truncated?)";
    if (why) {
        sm_mesh_sdf_destroy(f);
        return bad(err, errlen, why);
    }
    f->table = sm_malloc(nt * sizeof(int32_t));
    f->coarse = sm_malloc(nc * sizeof(float));
    f->bricks = nbv ? sm_malloc(nbv * sizeof(float)) : NULL;
    if (!f->table || !f->coarse || (nbv && !f->bricks)) {
        sm_mesh_sdf_destroy(f);
        return SM_ERR_NOMEM;
    }
    get(&c, f->table, nt * sizeof(int32_t));
    get(&c, f->coarse, nc * sizeof(float));
    if (nbv) get(&c, f->bricks, nbv * sizeof(float));
    if (field_checksum(f) != checksum) why = "checksum mismatch (corrupt file)";
    else if (!table_ok(f)) why = "table entry out of range";
    if (why) {
        sm_mesh_sdf_destroy(f);
        return bad(err, errlen, why);
    }
    f->stats.bricks = f->nbricks;
    f->stats.seconds = 0.0;
    *out = f;
    return SM_OK;
}
