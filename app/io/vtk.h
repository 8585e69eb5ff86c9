/* VTK frames for ParaView: one XML PolyData file (.vtp) per frame and a collection (.pvd) that
 * lists them with their times. */
#ifndef SM_APP_IO_VTK_H
#define SM_APP_IO_VTK_H

#include <stddef.h>

#include "app/io/part_file.h"
#include "sandmpm/sandmpm.h"

/* Writes the particles as VTK XML PolyData (.vtp, raw appended little-endian, UInt64 headers),
 * atomically: points, a vertex cell per particle, and point arrays velocity, material, q,
 * friction_angle, Je, volume, id (UInt32, the stable particle id) in that order in the appended
 * block (then Points, connectivity, offsets); points in increasing id order (app/io/fields.h);
 * z_up: points and velocities z-up (sm_out_to_z_up). Returns SM_OK, SM_ERR_NOMEM or SM_ERR_IO, with
 * a message in err. */
sm_status sm_write_vtp(const sm_world *w, const char *path, int z_up, char *err, size_t errlen);

/* The same file written by every rank of a run at once (app/io/part_file.h), each its slice's
 * points at their places in every array: the bytes sm_write_vtp of the whole run gives. Collective. */
sm_status sm_write_vtp_part(const sm_world *slice, const sm_part_io *io, const char *path, int z_up, char *err,
                            size_t errlen);

/* Writes a ParaView collection (.pvd) atomically, listing count files (relative names) with their
 * times. SM_OK or SM_ERR_IO with a message. */
sm_status sm_write_pvd(const char *path, const char *const *files, const double *times, int count, char *err,
                       size_t errlen);

#endif
