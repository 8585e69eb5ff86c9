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

/* How the inside is told from the outside. */
typedef enum sm_mesh_sign {
    /* Generalised winding number w >= 1/2 is inside (closed or nearly closed surfaces, several
     * overlapping closed parts, non-manifold edges). A surface whose normals all point inwards
     * (negative signed volume) is a container: solid outside, free inside. */
    SM_MESH_SIGN_WINDING = 0,
    /* The side of the nearest feature's angle-weighted pseudo-normal: an open surface (a terrain,
     * a sheet) is a one-sided collider, solid behind its normals. */
    SM_MESH_SIGN_ONE_SIDED = 1
} sm_mesh_sign;

typedef struct sm_mesh_sdf_def {
    int dim;                  /* 3: triangles; 2: segments of an outline in the xy plane */
    const double *vertices;   /* vertex_count x 3 doubles (z ignored in 2D) */
    size_t vertex_count;
    const uint32_t *elements; /* element_count x dim vertex indices (triangles / segments) */
    size_t element_count;
    double spacing;           /* node spacing h of the field (the simulation dx or finer), > 0 */
    double band;              /* half width of the stored band (>= spacing; 3 dx is a good choice) */
    sm_mesh_sign sign;
    int threads;              /* OpenMP threads for the build; 0: the default. Results do not depend on it. */
} sm_mesh_sdf_def;

sm_mesh_sdf_def sm_mesh_sdf_def_default(void);

/* What a build made and what it cost. */
typedef struct sm_mesh_sdf_stats {
    int dim;
    size_t elements;        /* triangles (3D) / segments (2D) */
    size_t vertices;
    double spacing, band;
    int table[3];           /* bricks per axis of the coarse table (1 in z for 2D) */
    size_t candidate_bricks; /* bricks whose centre is within band + half diagonal of the surface */
    size_t bricks;          /* bricks stored: those with a node within the band */
    size_t band_nodes;      /* stored nodes with |phi| < band */
    size_t bytes;           /* memory of the field (table, coarse nodes, bricks, header) */
    double lipschitz;       /* bound on |grad phi| of the interpolant over all stored cells */
    double volume;          /* signed volume (3D) / area (2D) enclosed; < 0: inside out */
    int container;          /* 1: winding rule with a negative volume: solid outside the surface */
    double seconds;         /* wall time of the build (0 for a field read back from bytes) */
} sm_mesh_sdf_stats;

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
