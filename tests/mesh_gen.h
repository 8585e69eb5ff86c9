/* Triangle meshes and outlines made in code, for the mesh field's tests and benchmark. Every mesh
 * is closed, manifold and outward oriented (counter-clockwise outlines in 2D) unless said. */
#ifndef SM_TESTS_MESH_GEN_H
#define SM_TESTS_MESH_GEN_H

#include <stddef.h>
#include <stdint.h>

typedef struct test_mesh {
    int dim;     /* 3: triangles; 2: segments */
    size_t nv;   /* vertices (3 doubles each; z = 0 in 2D) */
    size_t ne;   /* elements (dim indices each) */
    double *v;
    uint32_t *e;
} test_mesh;

void mesh_free(test_mesh *m);

/* Latitude-longitude sphere of radius r about c: nlat bands (>= 2), nlon sectors (>= 3);
 * 2 nlon (nlat - 1) triangles. */
test_mesh mesh_uv_sphere(const double c[3], double r, int nlat, int nlon);

/* Torus about the z axis: tube centre radius R, tube radius r; 2 nu nv triangles. */
test_mesh mesh_torus(double R, double r, int nu, int nv);

/* Star-shaped bumpy sphere: the uv sphere with radius r (1 + a sin(3 theta) cos(4 phi))
 * (theta from the pole, phi about z) -- non-convex. */
test_mesh mesh_bumpy_sphere(double r, double a, int nlat, int nlon);

/* L-shaped prism: the outline (0,0) (2,0) (2,1) (1,1) (1,2) (0,2) scaled by s, extruded over
 * z in [0, s], shifted by c: a non-convex polyhedron with a concave edge. 20 triangles. */
test_mesh mesh_l_prism(const double c[3], double s);

/* Flips every element's orientation (inside out). */
void mesh_flip(test_mesh *m);

/* Appends b to a (vertices and elements; no welding). */
void mesh_append(test_mesh *a, const test_mesh *b);

/* 2D: regular n-gon of radius r about c (counter-clockwise). */
test_mesh outline_circle(const double c[2], double r, int n);

/* 2D: the L outline above, scaled by s, shifted by c (counter-clockwise). */
test_mesh outline_l(const double c[2], double s);

#endif
