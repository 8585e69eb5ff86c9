/* PLY and CSV writers; see output.h. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
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
    fprintf(f,
            "ply\nformat binary_little_endian 1.0\ncomment sandmpm %s\nelement vertex %zu\n"
            "property float x\nproperty float y\nproperty float z\n"
            "property float vx\nproperty float vy\nproperty float vz\n"
            "property ushort material\nproperty float q\nproperty float friction_angle\nproperty float Je\nend_header\n",
            sm_version(), pv.n);
    unsigned char rec[4 * 6 + 2 + 4 * 3];
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
