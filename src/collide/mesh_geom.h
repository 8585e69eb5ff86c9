/* Exact point-simplex geometry for mesh signed distances (see mesh_geom.c for the equations):
 * closest points on a triangle / segment with the Voronoi region they fall in, the solid angle a
 * triangle subtends (3D winding number) and the angle a segment subtends (2D winding number).
 * Points are 3 doubles; 2D callers pass z = 0. */
#ifndef SM_COLLIDE_MESH_GEOM_H
#define SM_COLLIDE_MESH_GEOM_H

/* Voronoi region of the closest point. Vertices are 0, 1, 2 (a, b, c); edges are numbered by
 * their first vertex in the cyclic order a->b->c->a: edge 0 = ab, edge 1 = bc, edge 2 = ca. */
typedef enum sm_simplex_region {
    SM_REGION_V0 = 0,
    SM_REGION_V1 = 1,
    SM_REGION_V2 = 2,
    SM_REGION_E0 = 3, /* ab (for a segment: its interior) */
    SM_REGION_E1 = 4, /* bc */
    SM_REGION_E2 = 5, /* ca */
    SM_REGION_FACE = 6
} sm_simplex_region;

/* Closest point q on triangle abc to p, its barycentric coordinates bary (q = sum bary_k v_k) and
 * region. A degenerate (zero-area) triangle is treated as its three edges. Returns |p - q|^2. */
double sm_closest_on_triangle(const double p[3], const double a[3], const double b[3], const double c[3],
                              double q[3], double bary[3], sm_simplex_region *region);

/* 1 if triangle abc has no face: |ab x ac| <= 1e-12 times its longest edge squared. */
int sm_triangle_is_flat(const double a[3], const double b[3], const double c[3]);

/* sm_closest_on_triangle for a triangle known not to be flat (skips the test). */
double sm_closest_on_proper_triangle(const double p[3], const double a[3], const double b[3], const double c[3],
                                     double q[3], double bary[3], sm_simplex_region *region);

/* Closest point q on segment ab to p; bary = (1 - t, t); region V0, V1 or E0. Returns |p - q|^2. */
double sm_closest_on_segment(const double p[3], const double a[3], const double b[3], double q[3],
                             double bary[2], sm_simplex_region *region);

/* Signed solid angle (steradians, in (-2 pi, 2 pi]) that triangle abc subtends at p: positive
 * when p sees the triangle's vertices counter-clockwise (p on the side opposite to the normal
 * (b - a) x (c - a)), so an outward-oriented closed surface gives 4 pi inside. */
double sm_solid_angle(const double p[3], const double a[3], const double b[3], const double c[3]);

/* Signed angle (radians, in (-pi, pi]) that segment ab subtends at p in the xy plane: positive
 * when a -> b turns counter-clockwise around p, so a counter-clockwise closed outline gives 2 pi
 * inside. */
double sm_segment_angle(const double p[3], const double a[3], const double b[3]);

#endif
