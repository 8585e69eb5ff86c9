/* VTK XML writers; see vtk.h. Raw appended data: after "_", each array is a UInt64 byte count and
 * the bytes; the XML header names each array with its offset into that block. A vertex cell per
 * particle, so that every VTK reader shows the points. */
#define _POSIX_C_SOURCE 200809L
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "app/io/files.h"
#include "app/io/fields.h"
#include "app/io/vtk.h"

/* The arrays of a frame, in float (and Int64 cells), gathered before writing, in id order
 * (app/io/fields.h). */
typedef struct vtp_arrays {
    float *xyz, *vel, *q, *phi, *je, *vol;
    uint16_t *material;
    uint32_t *id;
    int64_t *conn, *offs;
} vtp_arrays;

static void arrays_free(vtp_arrays *a) {
    free(a->xyz);
    free(a->vel);
    free(a->q);
    free(a->phi);
    free(a->je);
    free(a->vol);
    free(a->material);
    free(a->id);
    free(a->conn);
    free(a->offs);
}

/* first: the position of the first of these particles in the whole run's id order (the
 * connectivity counts from the whole run's first point). */
static int arrays_fill(vtp_arrays *a, const sm_world *w, const sm_particles_view *pv, uint64_t first, int z_up) {
    const size_t n = pv->n, m = n ? n : 1;
    a->xyz = malloc(m * 3 * sizeof(float));
    a->vel = malloc(m * 3 * sizeof(float));
    a->q = malloc(m * sizeof(float));
    a->phi = malloc(m * sizeof(float));
    a->je = malloc(m * sizeof(float));
    a->vol = malloc(m * sizeof(float));
    a->material = malloc(m * sizeof(uint16_t));
    a->id = malloc(m * sizeof(uint32_t));
    a->conn = malloc(m * sizeof(int64_t));
    a->offs = malloc(m * sizeof(int64_t));
    size_t *order = sm_out_id_order(pv);
    if (!a->xyz || !a->vel || !a->q || !a->phi || !a->je || !a->vol || !a->material || !a->id || !a->conn ||
        !a->offs || !order) {
        free(order);
        return 0;
    }
    for (size_t i = 0; i < n; i++) {
        sm_out_particle r;
        sm_out_particle_get(w, pv, order[i], &r);
        if (z_up) sm_out_to_z_up(&r);
        memcpy(a->xyz + 3 * i, r.x, sizeof r.x);
        memcpy(a->vel + 3 * i, r.v, sizeof r.v);
        a->q[i] = r.q;
        a->phi[i] = r.friction_angle;
        a->je[i] = r.Je;
        a->vol[i] = r.volume;
        a->material[i] = r.material;
        a->id[i] = r.id;
        a->conn[i] = (int64_t)(first + i);
        a->offs[i] = (int64_t)(first + i) + 1;
    }
    free(order);
    return 1;
}

static void write_block(FILE *f, const void *data, uint64_t bytes) {
    fwrite(&bytes, sizeof bytes, 1, f);
    if (bytes) fwrite(data, 1, (size_t)bytes, f);
}

/* One appended DataArray's XML line; *off moves past its block (8-byte header + bytes). */
static void array_line(FILE *f, const char *type, const char *name, int comps, uint64_t *off, uint64_t bytes) {
    fprintf(f, "<DataArray type=\"%s\" Name=\"%s\"%s format=\"appended\" offset=\"%llu\"/>\n", type, name,
            comps == 3 ? " NumberOfComponents=\"3\"" : "", (unsigned long long)*off);
    *off += 8 + bytes;
}

/* The appended blocks, in file order: their arrays and bytes per point. */
#define VTP_BLOCKS 10
static const int block_bytes[VTP_BLOCKS] = {12, 2, 4, 4, 4, 4, 4, 12, 8, 8};
static void blocks_of(const vtp_arrays *a, const void *data[VTP_BLOCKS]) {
    const void *d[VTP_BLOCKS] = {a->vel, a->material, a->q, a->phi, a->je, a->vol, a->id, a->xyz, a->conn, a->offs};
    memcpy(data, d, sizeof d);
}
static const char vtp_tail[] = "\n</AppendedData>\n</VTKFile>\n";

/* The XML of a frame of n points, up to and including the "_" that starts the appended data. */
static void write_vtp_header(FILE *f, uint64_t n) {
    const uint64_t b3 = 12 * n, b1 = 4 * n, b2 = 2 * n, b8 = 8 * n;
    uint64_t off = 0;
    fprintf(f, "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" "
               "header_type=\"UInt64\">\n<PolyData>\n<Piece NumberOfPoints=\"%llu\" NumberOfVerts=\"%llu\" NumberOfLines=\"0\" "
               "NumberOfStrips=\"0\" NumberOfPolys=\"0\">\n<PointData Scalars=\"q\" Vectors=\"velocity\">\n",
            (unsigned long long)n, (unsigned long long)n);
    array_line(f, "Float32", "velocity", 3, &off, b3);
    array_line(f, "UInt16", "material", 1, &off, b2);
    array_line(f, "Float32", "q", 1, &off, b1);
    array_line(f, "Float32", "friction_angle", 1, &off, b1);
    array_line(f, "Float32", "Je", 1, &off, b1);
    array_line(f, "Float32", "volume", 1, &off, b1);
    array_line(f, "UInt32", "id", 1, &off, b1);
    fprintf(f, "</PointData>\n<Points>\n");
    array_line(f, "Float32", "Points", 3, &off, b3);
    fprintf(f, "</Points>\n<Verts>\n");
    array_line(f, "Int64", "connectivity", 1, &off, b8);
    array_line(f, "Int64", "offsets", 1, &off, b8);
    fprintf(f, "</Verts>\n</Piece>\n</PolyData>\n<AppendedData encoding=\"raw\">\n_");
}

static void write_vtp(FILE *f, const vtp_arrays *a, size_t n) {
    write_vtp_header(f, n);
    const void *data[VTP_BLOCKS];
    blocks_of(a, data);
    for (int b = 0; b < VTP_BLOCKS; b++) write_block(f, data[b], (uint64_t)block_bytes[b] * n);
    fputs(vtp_tail, f);
}

sm_status sm_write_vtp(const sm_world *w, const char *path, int z_up, char *err, size_t errlen) {
    sm_particles_view pv;
    sm_world_particles(w, &pv);
    vtp_arrays arr;
    memset(&arr, 0, sizeof arr);
    sm_status st = SM_OK;
    if (!arrays_fill(&arr, w, &pv, 0, z_up)) {
        snprintf(err, errlen, "%s: out of memory", path);
        st = SM_ERR_NOMEM;
    }
    sm_atomic_file a;
    if (st == SM_OK) st = sm_atomic_open(&a, path, err, errlen);
    if (st == SM_OK) {
        write_vtp(a.f, &arr, pv.n);
        st = sm_atomic_commit(&a, err, errlen);
    }
    arrays_free(&arr);
    return st;
}

/* This rank's parts: its points' piece of every block (the writer: the XML, the blocks' byte
 * counts and the tail too). 0 on success. */
static int write_vtp_parts(const sm_part_io *io, void *file, const char *header, size_t hlen, const vtp_arrays *a,
                           size_t n) {
    if (io->writer && io->write_at(file, 0, header, hlen)) return 1;
    const void *data[VTP_BLOCKS];
    blocks_of(a, data);
    uint64_t off = hlen;
    for (int b = 0; b < VTP_BLOCKS; b++) {
        const uint64_t bytes = (uint64_t)block_bytes[b] * io->total;
        if (io->writer && io->write_at(file, off, &bytes, sizeof bytes)) return 1;
        if (n && io->write_at(file, off + 8 + (uint64_t)block_bytes[b] * io->first, data[b], (size_t)block_bytes[b] * n))
            return 1;
        off += 8 + bytes;
    }
    return io->writer && io->write_at(file, off, vtp_tail, sizeof vtp_tail - 1);
}

sm_status sm_write_vtp_part(const sm_world *slice, const sm_part_io *io, const char *path, int z_up, char *err,
                            size_t errlen) {
    sm_particles_view pv;
    sm_world_particles(slice, &pv);
    vtp_arrays arr;
    memset(&arr, 0, sizeof arr);
    char *header = NULL;
    size_t hlen = 0;
    FILE *h = open_memstream(&header, &hlen);
    if (h) {
        write_vtp_header(h, io->total);
        if (fclose(h) != 0) header = NULL;
    }
    sm_status st = header && arrays_fill(&arr, slice, &pv, io->first, z_up) ? SM_OK : SM_ERR_NOMEM;
    if (st != SM_OK) snprintf(err, errlen, "%s: out of memory", path);
    st = io->agree(io->ctx, st, err, errlen);
    void *file = NULL;
    if (st == SM_OK) st = io->open(io->ctx, path, &file, err, errlen);
    if (st == SM_OK) {
        write_vtp_parts(io, file, header, hlen, &arr, pv.n); /* a failed write: close reports it */
        st = io->close(file, 1, err, errlen);
    }
    free(header);
    arrays_free(&arr);
    return st;
}

sm_status sm_write_pvd(const char *path, const char *const *files, const double *times, int count, char *err,
                       size_t errlen) {
    sm_atomic_file a;
    sm_status st = sm_atomic_open(&a, path, err, errlen);
    if (st != SM_OK) return st;
    fprintf(a.f, "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"1.0\" byte_order=\"LittleEndian\">\n<Collection>\n");
    for (int i = 0; i < count; i++)
        fprintf(a.f, "<DataSet timestep=\"%.9g\" group=\"\" part=\"0\" file=\"%s\"/>\n", times[i], files[i]);
    fprintf(a.f, "</Collection>\n</VTKFile>\n");
    return sm_atomic_commit(&a, err, errlen);
}
