/* diagnostics.csv: one row of world diagnostics per frame (docs/outputs.md has every column).
 * Column names carry their units (SI; in 2D mass, energies and momentum are per metre of depth)
 * and say whether a value is the frame's (_frame: the steps since the previous frame) or
 * cumulative (_total: since the world was created, or for wall_s_total since the run started). */
#ifndef SM_APP_IO_CSV_H
#define SM_APP_IO_CSV_H

#include <stddef.h>

#include "sandmpm/sandmpm.h"

#define SM_CSV_LINE_MAX 768 /* bytes of a header or row line, with room to spare */

/* The header line. Returns its length (snprintf's: what it needs). */
int sm_csv_header(char *buf, size_t len);

/* One row for a frame: its diagnostics d, those of the previous frame prev (for frame 0, or the
 * first frame after a resume, the world's state before it: then the frame columns are 0 and dt
 * empty), the wall seconds of the frame and since the run started. */
int sm_csv_row(char *buf, size_t len, int frame, const sm_diagnostics *d, const sm_diagnostics *prev, double wall_frame,
               double wall_total);

/* The frame rate of a run from its diagnostics.csv (1 / the time of frame 1), or fallback if the
 * file cannot be read or has no such row. */
double sm_csv_read_fps(const char *path, double fallback);

#endif
