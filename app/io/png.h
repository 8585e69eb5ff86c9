/* 8-bit RGB PNG files (libpng). */
#ifndef SM_APP_IO_PNG_H
#define SM_APP_IO_PNG_H

#include <stddef.h>
#include <stdint.h>

#include "sandmpm/sandmpm.h"

/* Writes a w x h RGB image (rows from the top) atomically (app/io/files.h). Returns SM_OK,
 * SM_ERR_IO (message with the path and the reason), SM_ERR_NOMEM or SM_ERR_INVALID (bad size). */
sm_status sm_png_write(const char *path, int w, int h, const uint8_t *rgb, char *err, size_t errlen);

/* Reads a PNG as 8-bit RGB (converting palette, grey, 16-bit and alpha). *rgb is malloc'ed.
 * Returns SM_OK, SM_ERR_IO (cannot open), SM_ERR_INVALID (not a PNG / corrupt) or SM_ERR_NOMEM. */
sm_status sm_png_read(const char *path, int *w, int *h, uint8_t **rgb, char *err, size_t errlen);

#endif
