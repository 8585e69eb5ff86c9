/* Signed distance field of a triangle mesh (3D) or a closed polyline (2D), sampled on a narrow
 * band and stored sparsely; the collider and seeding side of mesh shapes. Pure data in: the
 * library never reads mesh files (app/io/mesh_load.c does). See mesh_sdf.c for the equations.
 *
 *   sm_mesh_sdf_def d = sm_mesh_sdf_def_default();
 *   d.dim = 3; d.vertices = xyz; d.vertex_count = nv; d.elements = tri; d.element_count = nt;
 *   d.spacing = dx; d.band = 3 * dx;
 *   sm_mesh_sdf *f; if (sm_mesh_sdf_build(&d, &f, err, sizeof err) != SM_OK) ...
 *   double g[3], phi = sm_mesh_sdf_distance(f, x, g);   // x in the mesh's own frame
 *   sm_mesh_sdf_destroy(f);
 *
 * phi < 0 inside. |phi| <= band everywhere: beyond the band the value is clamped to +-band with
 * the right sign, so a collider or a seeding test behaves at any distance. */
#ifndef SM_COLLIDE_MESH_SDF_H
#define SM_COLLIDE_MESH_SDF_H

#include "core/common.h"

/* The definition and the statistics are the public API's (sandmpm.h: sm_mesh_field_def,
 * sm_mesh_field_stats, sm_mesh_sign); sm_mesh_field (mesh_field.c) is the reference-counted
 * handle around an sm_mesh_sdf. */
typedef sm_mesh_field_def sm_mesh_sdf_def;
typedef sm_mesh_field_stats sm_mesh_sdf_stats;

sm_mesh_sdf_def sm_mesh_sdf_def_default(void);

typedef struct sm_mesh_sdf sm_mesh_sdf;

/* Builds the field. SM_ERR_INVALID (bad definition: no elements, an index out of range, a
 * non-finite vertex, spacing or band out of range, a table too large for the spacing) or
 * SM_ERR_NOMEM, with the reason in err (if not NULL); *out is NULL then. */
sm_status sm_mesh_sdf_build(const sm_mesh_sdf_def *def, sm_mesh_sdf **out, char *err, size_t errlen);

void sm_mesh_sdf_destroy(sm_mesh_sdf *f); /* NULL is fine */

/* Signed distance at x (the mesh's frame; 2D: x, y used), trilinearly (bilinearly) interpolated.
 * grad (if not NULL) receives a unit normal: the normalised gradient of the interpolant inside the
 * band, and beyond it the normalised gradient of a coarse field (one node per brick corner, exact
 * distances) -- a direction away from the surface, while the value stays clamped. */
double sm_mesh_sdf_distance(const sm_mesh_sdf *f, const double x[3], double grad[3]);

const sm_mesh_sdf_stats *sm_mesh_sdf_stats_get(const sm_mesh_sdf *f);

/* Bytes of memory the field holds. */
size_t sm_mesh_sdf_bytes(const sm_mesh_sdf *f);

/* Serialisation for a cache file (mesh_sdf_io.c): the bytes are a function of the definition
 * alone (no timing, no thread count). sm_mesh_sdf_serialize writes at most cap bytes to buf
 * (buf may be NULL with cap 0) and returns the size it needs. */
size_t sm_mesh_sdf_serialize(const sm_mesh_sdf *f, void *buf, size_t cap);

/* Rebuilds a field from serialised bytes. SM_ERR_INVALID with a reason (bad magic, other version
 * or byte order, truncated, checksum mismatch, inconsistent sizes) or SM_ERR_NOMEM. */
sm_status sm_mesh_sdf_deserialize(const void *buf, size_t n, sm_mesh_sdf **out, char *err, size_t errlen);

#endif
