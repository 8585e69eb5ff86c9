/* Meshes made in code (see mesh_gen.h). The uv-sphere family: vertex 0 is the north pole, then
 * nlat - 1 rings of nlon vertices, then the south pole; ring quads are split into two triangles
 * and the caps are fans, all counter-clockwise seen from outside. */
#include "mesh_gen.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846

void mesh_free(test_mesh *m) {
    free(m->v);
    free(m->e);
    memset(m, 0, sizeof *m);
}

static test_mesh mesh_alloc(int dim, size_t nv, size_t ne) {
    test_mesh m = {dim, nv, ne, calloc(3 * nv, sizeof(double)), calloc((size_t)dim * ne, sizeof(uint32_t))};
    if (!m.v || !m.e) abort();
    return m;
}

static void put_tri(test_mesh *m, size_t *k, uint32_t a, uint32_t b, uint32_t c) {
    m->e[3 * *k] = a;
    m->e[3 * *k + 1] = b;
    m->e[3 * *k + 2] = c;
    (*k)++;
}

/* Sphere-topology mesh with vertex radius rad(theta, phi) (theta from +z, phi about z). */
static test_mesh radial_mesh(const double c[3], double r, double a, int nlat, int nlon) {
    size_t nv = 2 + (size_t)(nlat - 1) * (size_t)nlon, ne = 2 * (size_t)nlon * (size_t)(nlat - 1);
    test_mesh m = mesh_alloc(3, nv, ne);
    for (int i = 0; i <= nlat; i++) {
        int count = (i == 0 || i == nlat) ? 1 : nlon;
        for (int j = 0; j < count; j++) {
            double th = PI * i / nlat, ph = 2 * PI * j / nlon;
            double rad = r * (1.0 + a * sin(3 * th) * cos(4 * ph));
            size_t idx = i == 0 ? 0 : i == nlat ? nv - 1 : 1 + (size_t)(i - 1) * (size_t)nlon + (size_t)j;
            m.v[3 * idx] = c[0] + rad * sin(th) * cos(ph);
            m.v[3 * idx + 1] = c[1] + rad * sin(th) * sin(ph);
            m.v[3 * idx + 2] = c[2] + rad * cos(th);
        }
    }
    size_t k = 0;
#define RING(i, j) ((uint32_t)(1 + (size_t)((i) - 1) * (size_t)nlon + (size_t)(((j) % nlon))))
    for (int j = 0; j < nlon; j++) {
        put_tri(&m, &k, 0, RING(1, j), RING(1, j + 1));
        put_tri(&m, &k, (uint32_t)(nv - 1), RING(nlat - 1, j + 1), RING(nlat - 1, j));
    }
    for (int i = 1; i < nlat - 1; i++)
        for (int j = 0; j < nlon; j++) {
            put_tri(&m, &k, RING(i, j), RING(i + 1, j), RING(i + 1, j + 1));
            put_tri(&m, &k, RING(i, j), RING(i + 1, j + 1), RING(i, j + 1));
        }
#undef RING
    return m;
}

test_mesh mesh_uv_sphere(const double c[3], double r, int nlat, int nlon) { return radial_mesh(c, r, 0.0, nlat, nlon); }

test_mesh mesh_bumpy_sphere(double r, double a, int nlat, int nlon) {
    const double c[3] = {0, 0, 0};
    return radial_mesh(c, r, a, nlat, nlon);
}

test_mesh mesh_torus(double R, double r, int nu, int nv) {
    test_mesh m = mesh_alloc(3, (size_t)nu * (size_t)nv, 2 * (size_t)nu * (size_t)nv);
    for (int i = 0; i < nu; i++)
        for (int j = 0; j < nv; j++) {
            double u = 2 * PI * i / nu, w = 2 * PI * j / nv;
            double *p = m.v + 3 * ((size_t)i * (size_t)nv + (size_t)j);
            p[0] = (R + r * cos(w)) * cos(u);
            p[1] = (R + r * cos(w)) * sin(u);
            p[2] = r * sin(w);
        }
    size_t k = 0;
#define V(i, j) ((uint32_t)((size_t)((i) % nu) * (size_t)nv + (size_t)((j) % nv)))
    for (int i = 0; i < nu; i++)
        for (int j = 0; j < nv; j++) {
            put_tri(&m, &k, V(i, j), V(i + 1, j), V(i + 1, j + 1));
            put_tri(&m, &k, V(i, j), V(i + 1, j + 1), V(i, j + 1));
        }
#undef V
    return m;
}

static const double L_OUTLINE[6][2] = {{0, 0}, {2, 0}, {2, 1}, {1, 1}, {1, 2}, {0, 2}};

test_mesh mesh_l_prism(const double c[3], double s) {
    test_mesh m = mesh_alloc(3, 12, 20);
    for (int i = 0; i < 6; i++)
        for (int z = 0; z < 2; z++) {
            double *p = m.v + 3 * (size_t)(i + 6 * z);
            p[0] = c[0] + s * L_OUTLINE[i][0];
            p[1] = c[1] + s * L_OUTLINE[i][1];
            p[2] = c[2] + s * z;
        }
    size_t k = 0;
    for (uint32_t i = 1; i < 5; i++) { /* caps: fans from vertex 0, which sees the whole L */
        put_tri(&m, &k, 0, i + 1, i);      /* bottom, normal -z */
        put_tri(&m, &k, 6, 6 + i, 6 + i + 1); /* top, normal +z */
    }
    for (uint32_t i = 0; i < 6; i++) { /* sides: outline counter-clockwise, normals outward */
        uint32_t j = (i + 1) % 6;
        put_tri(&m, &k, i, j, 6 + j);
        put_tri(&m, &k, i, 6 + j, 6 + i);
    }
    return m;
}

void mesh_flip(test_mesh *m) {
    for (size_t t = 0; t < m->ne; t++) {
        uint32_t *e = m->e + (size_t)m->dim * t, s = e[0];
        e[0] = e[1];
        e[1] = s;
    }
}

void mesh_append(test_mesh *a, const test_mesh *b) {
    a->v = realloc(a->v, 3 * (a->nv + b->nv) * sizeof(double));
    a->e = realloc(a->e, (size_t)a->dim * (a->ne + b->ne) * sizeof(uint32_t));
    if (!a->v || !a->e) abort();
    memcpy(a->v + 3 * a->nv, b->v, 3 * b->nv * sizeof(double));
    for (size_t i = 0; i < (size_t)b->dim * b->ne; i++) a->e[(size_t)a->dim * a->ne + i] = b->e[i] + (uint32_t)a->nv;
    a->nv += b->nv;
    a->ne += b->ne;
}

static test_mesh closed_outline(size_t n) {
    test_mesh m = mesh_alloc(2, n, n);
    for (size_t i = 0; i < n; i++) {
        m.e[2 * i] = (uint32_t)i;
        m.e[2 * i + 1] = (uint32_t)((i + 1) % n);
    }
    return m;
}

test_mesh outline_circle(const double c[2], double r, int n) {
    test_mesh m = closed_outline((size_t)n);
    for (int i = 0; i < n; i++) {
        m.v[3 * i] = c[0] + r * cos(2 * PI * i / n);
        m.v[3 * i + 1] = c[1] + r * sin(2 * PI * i / n);
    }
    return m;
}

test_mesh outline_l(const double c[2], double s) {
    test_mesh m = closed_outline(6);
    for (int i = 0; i < 6; i++) {
        m.v[3 * i] = c[0] + s * L_OUTLINE[i][0];
        m.v[3 * i + 1] = c[1] + s * L_OUTLINE[i][1];
    }
    return m;
}
