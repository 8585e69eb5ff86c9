/* Output writers on top of the public API: binary little-endian PLY per frame and a diagnostics
 * CSV. Each file is written to a temporary name and renamed, so a reader never sees half a file. */
#ifndef SM_APP_OUTPUT_H
#define SM_APP_OUTPUT_H

#include <stdio.h>

#include "sandmpm/sandmpm.h"

/* Writes the world's particles as a binary little-endian PLY: float x y z, vx vy vz, uchar/ushort
 * material, float q, friction_angle (degrees), Je (det F^E), volume (V0, m^3; m^2 in 2D). Returns 0
 * or -1 with a message in err. */
int sm_write_ply(const sm_world *w, const char *path, char *err, size_t errlen);

/* Writes the particles as VTK XML PolyData (.vtp, raw appended little-endian, UInt64 headers): points,
 * a vertex cell per particle, and point arrays velocity, material, q, friction_angle, Je, volume in
 * that order in the appended block (then Points, connectivity, offsets). 0 or -1 with a message. */
int sm_write_vtp(const sm_world *w, const char *path, char *err, size_t errlen);

/* Writes a ParaView collection (.pvd) listing count files (relative names) with their times. */
int sm_write_pvd(const char *path, const char *const *files, const double *times, int count, char *err, size_t errlen);

/* CSV header and one row of diagnostics (frame, time, steps, min/max dt, particles, energies,
 * momentum, max speed, wall seconds). */
void sm_csv_header(FILE *f);
void sm_csv_row(FILE *f, int frame, const sm_diagnostics *d, double wall_seconds);

#endif
