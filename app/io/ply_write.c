/* The PLY frame writer; see ply.h. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "app/io/files.h"
#include "app/io/fields.h"
#include "app/io/ply.h"

static void put_f32(unsigned char *b, float f) {
    uint32_t u;
    memcpy(&u, &f, 4);
    b[0] = (unsigned char)(u & 0xff);
    b[1] = (unsigned char)((u >> 8) & 0xff);
    b[2] = (unsigned char)((u >> 16) & 0xff);
    b[3] = (unsigned char)((u >> 24) & 0xff);
}

static void put_u32(unsigned char *b, uint32_t u) {
    for (int k = 0; k < 4; k++) b[k] = (unsigned char)((u >> (8 * k)) & 0xff);
}

/* One vertex record, little-endian, in the header's property order. */
#define PLY_RECORD_BYTES (4 * 6 + 2 + 4 * 4 + 4)
static void put_record(unsigned char *rec, const sm_out_particle *r) {
    for (int a = 0; a < 3; a++) {
        put_f32(rec + 4 * a, r->x[a]);
        put_f32(rec + 12 + 4 * a, r->v[a]);
    }
    rec[24] = (unsigned char)(r->material & 0xff);
    rec[25] = (unsigned char)(r->material >> 8);
    put_f32(rec + 26, r->q);
    put_f32(rec + 30, r->friction_angle);
    put_f32(rec + 34, r->Je);
    put_f32(rec + 38, r->volume);
    put_u32(rec + 42, r->id);
}

/* The header of a frame of n particles into buf (at most len bytes); its length, or 0 if it does
 * not fit. */
static size_t ply_header(char *buf, size_t len, const sm_world *w, int dim, int z_up, uint64_t n) {
    const sm_world_def *def = sm_world_get_def(w);
    int k = snprintf(buf, len,
                     "ply\nformat binary_little_endian 1.0\ncomment sandmpm %s\ncomment dim %d\n"
                     "comment domain %.9g %.9g %.9g %.9g %.9g %.9g\ncomment up %c\nelement vertex %llu\n"
                     "property float x\nproperty float y\nproperty float z\n"
                     "property float vx\nproperty float vy\nproperty float vz\n"
                     "property ushort material\nproperty float q\nproperty float friction_angle\nproperty float Je\n"
                     "property float volume\nproperty uint id\nend_header\n",
                     sm_version(), dim, def->domain_min[0], def->domain_min[1], def->domain_min[2], def->domain_max[0],
                     def->domain_max[1], def->domain_max[2], z_up ? 'z' : 'y', (unsigned long long)n);
    return k > 0 && (size_t)k < len ? (size_t)k : 0;
}

#define PLY_HEADER_MAX 2048

sm_status sm_write_ply(const sm_world *w, const char *path, int z_up, char *err, size_t errlen) {
    sm_particles_view pv;
    sm_world_particles(w, &pv);
    size_t *order = sm_out_id_order(&pv);
    if (!order) {
        snprintf(err, errlen, "%s: out of memory", path);
        return SM_ERR_NOMEM;
    }
    sm_atomic_file a;
    sm_status st = sm_atomic_open(&a, path, err, errlen);
    if (st != SM_OK) {
        free(order);
        return st;
    }
    char header[PLY_HEADER_MAX];
    fputs(ply_header(header, sizeof header, w, pv.dim, z_up, pv.n) ? header : "", a.f);
    unsigned char rec[PLY_RECORD_BYTES];
    for (size_t k = 0; k < pv.n && !ferror(a.f); k++) {
        sm_out_particle r;
        sm_out_particle_get(w, &pv, order[k], &r);
        if (z_up) sm_out_to_z_up(&r);
        put_record(rec, &r);
        fwrite(rec, sizeof rec, 1, a.f);
    }
    free(order);
    return sm_atomic_commit(&a, err, errlen);
}

/* This rank's records, 4096 at a time, at their places after the header. */
static int write_records(const sm_world *slice, const sm_part_io *io, void *file, size_t at, int z_up,
                         unsigned char *buf) {
    sm_particles_view pv;
    sm_world_particles(slice, &pv);
    const size_t chunk = 4096;
    for (size_t k0 = 0; k0 < pv.n; k0 += chunk) {
        const size_t m = pv.n - k0 < chunk ? pv.n - k0 : chunk;
        for (size_t k = 0; k < m; k++) { /* the slice holds its particles in id order */
            sm_out_particle r;
            sm_out_particle_get(slice, &pv, k0 + k, &r);
            if (z_up) sm_out_to_z_up(&r);
            put_record(buf + k * PLY_RECORD_BYTES, &r);
        }
        const uint64_t off = at + (io->first + k0) * (uint64_t)PLY_RECORD_BYTES;
        if (io->write_at(file, off, buf, m * PLY_RECORD_BYTES)) return 1;
    }
    return 0;
}

sm_status sm_write_ply_part(const sm_world *slice, const sm_part_io *io, const char *path, int z_up, char *err,
                            size_t errlen) {
    sm_particles_view pv;
    sm_world_particles(slice, &pv);
    char header[PLY_HEADER_MAX];
    const size_t hlen = ply_header(header, sizeof header, slice, pv.dim, z_up, io->total);
    unsigned char *buf = malloc(4096 * PLY_RECORD_BYTES);
    sm_status st = buf ? SM_OK : SM_ERR_NOMEM;
    if (!buf) snprintf(err, errlen, "%s: out of memory", path);
    void *file = NULL;
    st = io->agree(io->ctx, st, err, errlen);
    if (st == SM_OK) st = io->open(io->ctx, path, &file, err, errlen);
    if (st == SM_OK) {
        if (!(io->writer && io->write_at(file, 0, header, hlen))) write_records(slice, io, file, hlen, z_up, buf);
        st = io->close(file, 1, err, errlen); /* a failed write is the file's own: close reports it */
    }
    free(buf);
    return st;
}
