/* diagnostics.csv: one row of world diagnostics per frame. */
#ifndef SM_APP_IO_CSV_H
#define SM_APP_IO_CSV_H

#include <stdio.h>

#include "sandmpm/sandmpm.h"

/* The header line: frame, time, steps, min/max dt, particles, energies, momentum, max speed, wall
 * seconds. SM_OK, or SM_ERR_IO if the stream has a write error. */
sm_status sm_csv_header(FILE *f);

/* One row, flushed. SM_OK, or SM_ERR_IO if writing or flushing failed (errno says why). */
sm_status sm_csv_row(FILE *f, int frame, const sm_diagnostics *d, double wall_seconds);

/* The frame rate of a run from its diagnostics.csv (1 / the time of frame 1), or fallback if the
 * file cannot be read or has no such row. */
double sm_csv_read_fps(const char *path, double fallback);

#endif
