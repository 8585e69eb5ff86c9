/* PLY frames: the reader (any PLY the renderer can draw) and the writer (sandmpm's frame files). */
#ifndef SM_APP_IO_PLY_H
#define SM_APP_IO_PLY_H

#include <stddef.h>

#include "app/frame.h"
#include "app/io/part_file.h"
#include "sandmpm/sandmpm.h"

/* Reads a PLY frame. Properties are found by name in the header, in any order, with any extra
 * properties and elements (fixed-size elements before the vertex element are skipped):
 * x y [z] [vx vy vz] [material] [q] [volume] [id], any PLY scalar type; formats
 * binary_little_endian, binary_big_endian and ascii. dim: from a "comment dim 2|3" line, else 2
 * if there is no z property or every z and vz is 0, else 3. Optional "comment domain x0 y0 z0 x1
 * y1 z1" fills has_domain/domain_*.
 * Returns SM_OK; SM_ERR_IO if the file cannot be opened or read; SM_ERR_INVALID if it is not a
 * PLY file, the header is malformed or unsupported, or the data is truncated; SM_ERR_NOMEM.
 * On failure *f is empty (n = 0, NULL arrays) and err holds "PATH: problem". */
sm_status sm_ply_read(const char *path, sm_frame *f, char *err, size_t errlen);

/* Writes the world's particles as a binary little-endian PLY (atomically, app/io/files.h): float
 * x y z, vx vy vz, ushort material, float q, friction_angle (degrees), Je (det F^E), volume (V0,
 * m^3; m^2 in 2D), uint id (the stable particle id); vertices in increasing id order
 * (app/io/fields.h), so vertex k is the same grain in every frame; header comments "sandmpm
 * VERSION", "dim D", "domain x0 y0 z0 x1 y1 z1" (sandmpm's y-up axes) and "up y|z"; z_up: positions
 * and velocities z-up (app/io/fields.h, sm_out_to_z_up). Returns SM_OK, SM_ERR_NOMEM or SM_ERR_IO
 * with a message in err. */
sm_status sm_write_ply(const sm_world *w, const char *path, int z_up, char *err, size_t errlen);

/* The same file written by every rank of a run at once (app/io/part_file.h), each its slice's
 * records at their places: the bytes sm_write_ply of the whole run in id order gives. Collective. */
sm_status sm_write_ply_part(const sm_world *slice, const sm_part_io *io, const char *path, int z_up, char *err,
                            size_t errlen);

#endif
