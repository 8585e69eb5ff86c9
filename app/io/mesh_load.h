/* Mesh files for colliders and mesh-shaped sand: read through the Open Asset Import Library's C
 * API (OBJ, STL, PLY, glTF, FBX and the other formats it knows), every mesh of the scene graph
 * merged with its node transform into one triangle list, identical vertices welded, then the
 * user's placement applied; checked for what makes a signed distance ill defined.
 *
 * 2D scenes take an outline in the xy plane: a file's line elements (OBJ `l` lines, in their
 * order: counter-clockwise encloses solid), or else the z = 0 slice of its triangles after the
 * placement (the cross-section of a 3D tool: rotate or move the mesh to choose it; the slice is
 * oriented by the triangles' normals).
 *
 * Errors (sm_status and a message naming the file): not found, unreadable, no triangles (no
 * outline), inconsistent winding (an edge used twice in the same direction), and with
 * require_closed an open or non-manifold surface. Warnings (the result is still well defined; the
 * message holds them, separated by "; "): degenerate (zero-area) triangles, removed; an open
 * surface (usable as a one-sided collider, not as a solid); non-manifold edges (the inside is
 * taken by winding number); normals pointing inwards (the mesh acts as a container). */
#ifndef SM_APP_IO_MESH_LOAD_H
#define SM_APP_IO_MESH_LOAD_H

#include <stddef.h>
#include <stdint.h>

#include "sandmpm/sandmpm.h"

/* Placement, applied in this order to the file's coordinates (after its node transforms):
 * x' = R (scale * (unit * x)) + translation. */
typedef struct sm_mesh_placement {
    double unit;           /* metres per file unit (1: metres, 0.001: millimetres, 0.0254: inches) */
    double scale[3];       /* per axis */
    double rotation[4];    /* quaternion (w, x, y, z); normalised on use; all zero = identity */
    double translation[3]; /* m */
} sm_mesh_placement;

typedef struct sm_mesh_load_opts {
    int dim;                     /* 3: triangles; 2: an outline in the xy plane */
    sm_mesh_placement placement;
    int require_closed;          /* 1: open or non-manifold is an error (a solid to fill with sand) */
} sm_mesh_load_opts;

sm_mesh_load_opts sm_mesh_load_opts_default(void);

/* What the checks found. */
typedef struct sm_mesh_report {
    size_t meshes;             /* meshes of the file's scene graph merged (instances counted) */
    size_t elements_read;      /* triangles (2D: lines or sliced triangles) before removals */
    size_t welded;             /* vertices merged with an identical one */
    size_t degenerate;         /* zero-area triangles (zero-length segments) removed */
    size_t open_edges;         /* edges of one triangle (2D: outline ends) */
    size_t nonmanifold_edges;  /* edges of three or more triangles (2D: branching vertices) */
    size_t misoriented_edges;  /* edges whose triangles disagree in orientation */
    double volume;             /* signed enclosed volume (2D: area), m^3 (m^2) */
    const char *source;        /* "triangles", "lines" or "slice" */
} sm_mesh_report;

typedef struct sm_mesh_data {
    int dim;
    size_t vertex_count;
    double *vertices;          /* vertex_count x 3 (z = 0 in 2D), m */
    size_t element_count;
    uint32_t *elements;        /* element_count x dim vertex indices */
    double lo[3], hi[3];       /* bounds */
    uint64_t hash;             /* FNV-1a of dim, vertices and elements: with the field's spacing and
                                  band, the key of a cached field */
    sm_mesh_report report;
} sm_mesh_data;

/* Reads and checks a mesh file. SM_OK (msg: warnings, or ""), SM_ERR_IO (not found, unreadable),
 * SM_ERR_INVALID (the checks above) or SM_ERR_NOMEM; msg names the file. On failure *out is
 * empty. */
sm_status sm_mesh_load(const char *path, const sm_mesh_load_opts *opts, sm_mesh_data *out, char *msg, size_t msglen);

void sm_mesh_data_free(sm_mesh_data *m);

/* Internal steps, shared by mesh_load.c and mesh_outline.c. */

/* Welds identical points (bitwise equal coordinates, dims components each): remap[i] receives the
 * index of point i among the unique points, written in first-seen order to uniq (3 doubles each,
 * may alias pts). Returns the number of unique points, or 0 on allocation failure. */
size_t sm_mesh_weld(const double *pts, size_t n, int dims, uint32_t *remap, double *uniq);

/* Appends a formatted warning to msg ("; " between warnings). */
void sm_mesh_warn(char *msg, size_t msglen, const char *fmt, ...);

/* 2D: builds out (dim 2) from line elements, or else the z = 0 slice of the triangles (placed,
 * welded vertices, 3 doubles each), and checks the outline: SM_OK (warnings appended to warn),
 * SM_ERR_INVALID (reason in err) or SM_ERR_NOMEM. */
sm_status sm_mesh_outline(const double *verts, size_t nverts, const uint32_t *lines, size_t nlines, const uint32_t *tris,
                          size_t ntris, const sm_mesh_load_opts *opts, sm_mesh_data *out, char *err, size_t errlen,
                          char *warn, size_t wlen);

#endif
