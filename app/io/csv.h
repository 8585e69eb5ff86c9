/* diagnostics.csv: one row of world diagnostics per frame. */
#ifndef SM_APP_IO_CSV_H
#define SM_APP_IO_CSV_H

#include <stddef.h>

#include "sandmpm/sandmpm.h"

#define SM_CSV_LINE_MAX 512 /* bytes of a header or row line, with room to spare */

/* The header line: frame, time, steps, min/max dt, particles, energies, momentum, max speed, wall
 * seconds. Returns its length (snprintf's: what it needs). */
int sm_csv_header(char *buf, size_t len);

/* One row for a frame (its diagnostics, wall seconds since the run started). */
int sm_csv_row(char *buf, size_t len, int frame, const sm_diagnostics *d, double wall_seconds);

/* The frame rate of a run from its diagnostics.csv (1 / the time of frame 1), or fallback if the
 * file cannot be read or has no such row. */
double sm_csv_read_fps(const char *path, double fallback);

#endif
