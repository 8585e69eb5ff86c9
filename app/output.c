/* PLY and CSV writers; see output.h. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "app/output.h"

static void put_f32(unsigned char *b, float f) {
    uint32_t u;
    memcpy(&u, &f, 4);
    b[0] = (unsigned char)(u & 0xff);
    b[1] = (unsigned char)((u >> 8) & 0xff);
    b[2] = (unsigned char)((u >> 16) & 0xff);
    b[3] = (unsigned char)((u >> 24) & 0xff);
}

static double det(const sm_real *F, int d) {
    if (d == 2) return (double)F[0] * F[3] - (double)F[1] * F[2];
    return (double)F[0] * ((double)F[4] * F[8] - (double)F[5] * F[7]) - (double)F[1] * ((double)F[3] * F[8] - (double)F[5] * F[6]) +
           (double)F[2] * ((double)F[3] * F[7] - (double)F[4] * F[6]);
}

int sm_write_ply(const sm_world *w, const char *path, char *err, size_t errlen) {
    char tmp[4096];
    if (snprintf(tmp, sizeof tmp, "%s.tmp", path) >= (int)sizeof tmp) {
        snprintf(err, errlen, "%s: path too long", path);
        return -1;
    }
    FILE *f = fopen(tmp, "wb");
    if (!f) {
        snprintf(err, errlen, "%s: %s", tmp, strerror(errno));
        return -1;
    }
    sm_particles_view pv;
    sm_world_particles(w, &pv);
    const int d = pv.dim;
    const sm_world_def *def = sm_world_get_def(w);
    fprintf(f,
            "ply\nformat binary_little_endian 1.0\ncomment sandmpm %s\ncomment dim %d\n"
            "comment domain %.9g %.9g %.9g %.9g %.9g %.9g\nelement vertex %zu\n"
            "property float x\nproperty float y\nproperty float z\n"
            "property float vx\nproperty float vy\nproperty float vz\n"
            "property ushort material\nproperty float q\nproperty float friction_angle\nproperty float Je\n"
            "property float volume\nend_header\n",
            sm_version(), d, def->domain_min[0], def->domain_min[1], def->domain_min[2], def->domain_max[0],
            def->domain_max[1], def->domain_max[2], pv.n);
    unsigned char rec[4 * 6 + 2 + 4 * 4];
    int ok = 1;
    for (size_t i = 0; i < pv.n && ok; i++) {
        for (int a = 0; a < 3; a++) {
            put_f32(rec + 4 * a, a < d ? (float)pv.x[i * d + a] : 0.0f);
            put_f32(rec + 12 + 4 * a, a < d ? (float)pv.v[i * d + a] : 0.0f);
        }
        rec[24] = (unsigned char)(pv.material[i] & 0xff);
        rec[25] = (unsigned char)(pv.material[i] >> 8);
        put_f32(rec + 26, (float)pv.q[i]);
        put_f32(rec + 30, (float)sm_world_particle_friction_angle(w, i));
        put_f32(rec + 34, (float)det(pv.F + i * (size_t)d * d, d));
        put_f32(rec + 38, (float)pv.vol0[i]);
        ok = fwrite(rec, sizeof rec, 1, f) == 1;
    }
    if (fclose(f) != 0) ok = 0;
    if (!ok || rename(tmp, path) != 0) {
        snprintf(err, errlen, "%s: %s", path, strerror(errno));
        remove(tmp);
        return -1;
    }
    return 0;
}

void sm_csv_header(FILE *f) {
    fprintf(f, "frame,time,steps,min_dt,max_dt,particles,kinetic_energy,elastic_energy,momentum_x,momentum_y,"
               "momentum_z,max_speed,wall_seconds\n");
}

void sm_csv_row(FILE *f, int frame, const sm_diagnostics *d, double wall) {
    fprintf(f, "%d,%.9g,%llu,%.6g,%.6g,%zu,%.9g,%.9g,%.9g,%.9g,%.9g,%.6g,%.4f\n", frame, d->time,
            (unsigned long long)d->steps, d->min_dt, d->max_dt, d->particles, d->kinetic_energy, d->elastic_energy,
            d->momentum[0], d->momentum[1], d->momentum[2], d->max_speed, wall);
    fflush(f);
}

/* ------------------------------------------------------------------------------------------ */
/* VTK XML PolyData (.vtp), raw appended little-endian data, UInt64 headers; a vertex cell per
 * particle so that every VTK reader shows the points. */

static int write_block(FILE *f, const void *data, uint64_t bytes) {
    return fwrite(&bytes, sizeof bytes, 1, f) == 1 && (bytes == 0 || fwrite(data, 1, (size_t)bytes, f) == (size_t)bytes);
}

int sm_write_vtp(const sm_world *w, const char *path, char *err, size_t errlen) {
    char tmp[4096];
    if (snprintf(tmp, sizeof tmp, "%s.tmp", path) >= (int)sizeof tmp) {
        snprintf(err, errlen, "%s: path too long", path);
        return -1;
    }
    sm_particles_view pv;
    sm_world_particles(w, &pv);
    const size_t n = pv.n;
    const int d = pv.dim;
    float *xyz = malloc((n ? n : 1) * 3 * sizeof(float)), *vel = malloc((n ? n : 1) * 3 * sizeof(float));
    float *q = malloc((n ? n : 1) * sizeof(float)), *phi = malloc((n ? n : 1) * sizeof(float));
    float *je = malloc((n ? n : 1) * sizeof(float)), *vol = malloc((n ? n : 1) * sizeof(float));
    int64_t *conn = malloc((n ? n : 1) * sizeof(int64_t)), *offs = malloc((n ? n : 1) * sizeof(int64_t));
    FILE *f = NULL;
    int ok = xyz && vel && q && phi && je && vol && conn && offs;
    if (!ok) {
        snprintf(err, errlen, "%s: out of memory", path);
        goto done;
    }
    for (size_t i = 0; i < n; i++) {
        for (int a = 0; a < 3; a++) {
            xyz[3 * i + a] = a < d ? (float)pv.x[i * d + a] : 0.0f;
            vel[3 * i + a] = a < d ? (float)pv.v[i * d + a] : 0.0f;
        }
        q[i] = (float)pv.q[i];
        phi[i] = (float)sm_world_particle_friction_angle(w, i);
        je[i] = (float)det(pv.F + i * (size_t)d * d, d);
        vol[i] = (float)pv.vol0[i];
        conn[i] = (int64_t)i;
        offs[i] = (int64_t)i + 1;
    }
    f = fopen(tmp, "wb");
    if (!f) {
        snprintf(err, errlen, "%s: %s", tmp, strerror(errno));
        ok = 0;
        goto done;
    }
    const uint64_t H = 8, b3 = 12 * (uint64_t)n, b1 = 4 * (uint64_t)n, b2 = 2 * (uint64_t)n, b8 = 8 * (uint64_t)n;
    uint64_t off = 0;
    fprintf(f, "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" "
               "header_type=\"UInt64\">\n<PolyData>\n<Piece NumberOfPoints=\"%zu\" NumberOfVerts=\"%zu\" NumberOfLines=\"0\" "
               "NumberOfStrips=\"0\" NumberOfPolys=\"0\">\n<PointData Scalars=\"q\" Vectors=\"velocity\">\n", n, n);
    fprintf(f, "<DataArray type=\"Float32\" Name=\"velocity\" NumberOfComponents=\"3\" format=\"appended\" offset=\"%llu\"/>\n", (unsigned long long)off);
    off += H + b3;
    fprintf(f, "<DataArray type=\"UInt16\" Name=\"material\" format=\"appended\" offset=\"%llu\"/>\n", (unsigned long long)off);
    off += H + b2;
    fprintf(f, "<DataArray type=\"Float32\" Name=\"q\" format=\"appended\" offset=\"%llu\"/>\n", (unsigned long long)off);
    off += H + b1;
    fprintf(f, "<DataArray type=\"Float32\" Name=\"friction_angle\" format=\"appended\" offset=\"%llu\"/>\n", (unsigned long long)off);
    off += H + b1;
    fprintf(f, "<DataArray type=\"Float32\" Name=\"Je\" format=\"appended\" offset=\"%llu\"/>\n", (unsigned long long)off);
    off += H + b1;
    fprintf(f, "<DataArray type=\"Float32\" Name=\"volume\" format=\"appended\" offset=\"%llu\"/>\n", (unsigned long long)off);
    off += H + b1;
    fprintf(f, "</PointData>\n<Points>\n<DataArray type=\"Float32\" Name=\"Points\" NumberOfComponents=\"3\" format=\"appended\" offset=\"%llu\"/>\n</Points>\n", (unsigned long long)off);
    off += H + b3;
    fprintf(f, "<Verts>\n<DataArray type=\"Int64\" Name=\"connectivity\" format=\"appended\" offset=\"%llu\"/>\n", (unsigned long long)off);
    off += H + b8;
    fprintf(f, "<DataArray type=\"Int64\" Name=\"offsets\" format=\"appended\" offset=\"%llu\"/>\n</Verts>\n", (unsigned long long)off);
    fprintf(f, "</Piece>\n</PolyData>\n<AppendedData encoding=\"raw\">\n_");
    ok = write_block(f, vel, b3) && write_block(f, pv.material, b2) && write_block(f, q, b1) && write_block(f, phi, b1) &&
         write_block(f, je, b1) && write_block(f, vol, b1) && write_block(f, xyz, b3) && write_block(f, conn, b8) &&
         write_block(f, offs, b8);
    ok = ok && fprintf(f, "\n</AppendedData>\n</VTKFile>\n") > 0;
    if (fclose(f) != 0) ok = 0;
    f = NULL;
    if (!ok || rename(tmp, path) != 0) {
        snprintf(err, errlen, "%s: %s", path, strerror(errno ? errno : EIO));
        remove(tmp);
        ok = 0;
    }
done:
    free(xyz);
    free(vel);
    free(q);
    free(phi);
    free(je);
    free(vol);
    free(conn);
    free(offs);
    return ok ? 0 : -1;
}

int sm_write_pvd(const char *path, const char *const *files, const double *times, int count, char *err, size_t errlen) {
    char tmp[4096];
    if (snprintf(tmp, sizeof tmp, "%s.tmp", path) >= (int)sizeof tmp) {
        snprintf(err, errlen, "%s: path too long", path);
        return -1;
    }
    FILE *f = fopen(tmp, "w");
    if (!f) {
        snprintf(err, errlen, "%s: %s", tmp, strerror(errno));
        return -1;
    }
    fprintf(f, "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"1.0\" byte_order=\"LittleEndian\">\n<Collection>\n");
    for (int i = 0; i < count; i++)
        fprintf(f, "<DataSet timestep=\"%.9g\" group=\"\" part=\"0\" file=\"%s\"/>\n", times[i], files[i]);
    fprintf(f, "</Collection>\n</VTKFile>\n");
    if (fclose(f) != 0 || rename(tmp, path) != 0) {
        snprintf(err, errlen, "%s: %s", path, strerror(errno));
        remove(tmp);
        return -1;
    }
    return 0;
}
