/* Volume (area in 2D) of a shape inside an axis-aligned box, for the particle estimate
 * (particles = volume ppc / dx^d, as the library seeds ppc points per cell of the shape).
 *
 * Exact where it is practical, in closed form or by quadrature of a closed form:
 *   half-space:  the box cut by a plane, by inclusion-exclusion over the box's corners: with the
 *                box as [0, L1] x .. x [0, Lk] and the solid a.u <= b (all a_i > 0 after
 *                mirroring axes), V = (1 / (k! prod a_i)) sum over corner sets S of
 *                (-1)^|S| max(0, b - sum_{i in S} a_i L_i)^k; an axis whose a_i L_i is below
 *                1e-4 of the largest is taken as parallel to the plane (b moved by a_i L_i / 2),
 *                which bounds the cancellation in the sum;
 *   disk in a rectangle: the quadrant areas F(u, v) = |disk and {x <= u, y <= v}| in closed form
 *                (the primitive of sqrt(r^2 - t^2) is (t sqrt(r^2 - t^2) + r^2 asin(t / r)) / 2),
 *                combined as F(x1, y1) - F(x0, y1) - F(x1, y0) + F(x0, y0);
 *   ball in a box: the integral over z of the disk-in-rectangle area of the cross-section, by
 *                Gauss-Legendre quadrature on the pieces between the heights where the
 *                cross-section's radius reaches an edge or a corner of the rectangle (the area is
 *                smooth inside each piece but for (z - z_end)^(3/2) at its ends, which a cosine
 *                change of variable smooths);
 *   boxes and cylinders whose axes are the coordinate axes (any rotation by multiples of 90
 *                degrees): products of interval overlaps (and a disk-in-rectangle area);
 *   any bounded shape entirely inside the box, or disjoint from it; inside-out shapes as the box
 *                less the shape.
 * Sampled otherwise (a rotated box or cylinder cut by the box; a mesh; a shape with a clip): the fraction
 * of a lattice of cell midpoints inside, with at most 64 points per axis and no finer than half a
 * grid cell (small shapes cost little). */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "app/scene/scene_internal.h"

#define PI 3.14159265358979323846
#define GL_N 16 /* Gauss-Legendre points per piece */

static double box_volume(const double lo[3], const double hi[3], int dim) {
    double v = 1;
    for (int a = 0; a < dim; a++) v *= fmax(0, hi[a] - lo[a]);
    return v;
}

/* The rotation matrix of a unit quaternion (w, x, y, z): columns are the local axes in the world. */
static void rotation_matrix(const double q[4], double R[3][3]) {
    double w = q[0], x = q[1], y = q[2], z = q[3];
    double M[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
                      {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
                      {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}};
    memcpy(R, M, sizeof M);
}

/* If every local axis of the rotation is a world axis: perm[l] = the world axis of local axis l. */
static int axis_aligned(const double q[4], int dim, int perm[3]) {
    double R[3][3];
    rotation_matrix(q, R);
    for (int l = 0; l < dim; l++) {
        perm[l] = -1;
        for (int a = 0; a < dim; a++)
            if (fabs(fabs(R[a][l]) - 1) < 1e-12) perm[l] = a;
        if (perm[l] < 0) return 0;
    }
    return 1;
}

/* A mesh field's table box (in the mesh frame, placed at the shape's centre; the rotation is
 * already in the vertices when the scene made it, applied here in any case). */
static int mesh_bbox(const sm_shape *sh, int dim, double lo[3], double hi[3]) {
    const sm_mesh_field_stats *st = sm_mesh_field_get_stats(sh->mesh);
    if (st->container) return 0;
    double R[3][3];
    rotation_matrix(sh->rotation, R);
    for (int a = 0; a < 3; a++) lo[a] = hi[a] = a < dim ? sh->center[a] : 0;
    for (int a = 0; a < dim; a++) {
        double r0 = 0, r1 = 0;
        for (int b = 0; b < dim; b++) {
            r0 += fmin(R[a][b] * st->lo[b], R[a][b] * st->hi[b]);
            r1 += fmax(R[a][b] * st->lo[b], R[a][b] * st->hi[b]);
        }
        lo[a] += r0;
        hi[a] += r1;
    }
    return 1;
}

int sc_shape_bbox(const sm_shape *sh, int dim, double lo[3], double hi[3]) {
    if (sh->inside_out || sh->kind == SM_SHAPE_HALFSPACE) return 0;
    if (sh->kind == SM_SHAPE_MESH) return sh->mesh ? mesh_bbox(sh, dim, lo, hi) : 0;
    double r[3] = {0, 0, 0};
    if (sh->kind == SM_SHAPE_SPHERE) {
        r[0] = r[1] = r[2] = sh->radius;
    } else { /* rotated extents: |R| h */
        double h[3], R[3][3];
        if (sh->kind == SM_SHAPE_BOX) memcpy(h, sh->half_extent, sizeof h);
        else h[0] = h[2] = sh->radius, h[1] = sh->half_height;
        if (dim == 2) h[2] = 0;
        rotation_matrix(sh->rotation, R);
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++) r[a] += fabs(R[a][b]) * h[b];
    }
    for (int a = 0; a < 3; a++) {
        lo[a] = a < dim ? sh->center[a] - r[a] : 0;
        hi[a] = a < dim ? sh->center[a] + r[a] : 0;
    }
    return 1;
}

/* {x : n.(x - c) <= 0} inside the box. */
static double halfspace_volume(const double n[3], const double c[3], int dim, const double lo[3], const double hi[3]) {
    double a[3], L[3], b = 0, scale = 0, factor = 1;
    for (int i = 0; i < dim; i++) {
        L[i] = hi[i] - lo[i];
        b += n[i] * (c[i] - lo[i]);
        a[i] = fabs(n[i]);
        if (n[i] < 0) b -= n[i] * L[i]; /* mirror the axis: u -> L - u */
        scale = fmax(scale, a[i] * L[i]);
    }
    if (!(scale > 0)) return b >= 0 ? box_volume(lo, hi, dim) : 0;
    int k = 0;
    double ak[3], Lk[3];
    for (int i = 0; i < dim; i++) {
        if (a[i] * L[i] < 1e-4 * scale) { /* parallel to the plane: its mean offset */
            b -= 0.5 * a[i] * L[i];
            factor *= L[i];
        } else {
            ak[k] = a[i];
            Lk[k++] = L[i];
        }
    }
    double sum = 0, denom = 1;
    for (int i = 0; i < k; i++) denom *= ak[i] * (i + 1);
    for (int S = 0; S < (1 << k); S++) {
        double t = b;
        int sign = 1;
        for (int i = 0; i < k; i++)
            if (S >> i & 1) {
                t -= ak[i] * Lk[i];
                sign = -sign;
            }
        if (t > 0) sum += sign * pow(t, k);
    }
    double full = 1;
    for (int i = 0; i < k; i++) full *= Lk[i];
    return factor * fmin(full, fmax(0, sum / denom));
}

/* The primitive of sqrt(r^2 - t^2) from 0, t clamped to [-r, r]. */
static double circle_primitive(double t, double r) {
    t = fmax(-r, fmin(r, t));
    return 0.5 * (t * sqrt(fmax(0, r * r - t * t)) + r * r * asin(t / r));
}

/* |disk(0, r) and {x <= u, y <= v}|. */
static double quadrant_area(double u, double v, double r) {
    if (u <= -r || v <= -r) return 0;
    double U = fmin(u, r);
    if (v >= r) return 2 * (circle_primitive(U, r) - circle_primitive(-r, r));
    double w = sqrt(r * r - v * v), area = 0, b = fmin(U, w);
    if (b > -w) area += v * (b + w) + circle_primitive(b, r) - circle_primitive(-w, r); /* chord from -g to v */
    if (v >= 0) { /* where the disk lies below v: the whole chord 2 g */
        b = fmin(U, -w);
        if (b > -r) area += 2 * (circle_primitive(b, r) - circle_primitive(-r, r));
        if (U > w) area += 2 * (circle_primitive(U, r) - circle_primitive(w, r));
    }
    return area;
}

/* |disk(c, r) and [x0, x1] x [y0, y1]|. */
static double disk_rect_area(double cx, double cy, double r, double x0, double x1, double y0, double y1) {
    if (!(r > 0) || !(x1 > x0) || !(y1 > y0)) return 0;
    x0 -= cx, x1 -= cx, y0 -= cy, y1 -= cy;
    double A = quadrant_area(x1, y1, r) - quadrant_area(x0, y1, r) - quadrant_area(x1, y0, r) + quadrant_area(x0, y0, r);
    return fmax(0, fmin(A, PI * r * r));
}

/* Gauss-Legendre nodes and weights on [-1, 1] (Newton on the Legendre polynomial). */
static void gauss_legendre(double x[GL_N], double w[GL_N]) {
    for (int i = 0; i < GL_N; i++) {
        double z = cos(PI * (i + 0.75) / (GL_N + 0.5)), dp = 1;
        for (int it = 0; it < 100; it++) {
            double p0 = 1, p1 = z;
            for (int k = 2; k <= GL_N; k++) {
                double p2 = ((2 * k - 1) * z * p1 - (k - 1) * p0) / k;
                p0 = p1;
                p1 = p2;
            }
            dp = GL_N * (z * p1 - p0) / (z * z - 1);
            double dz = p1 / dp;
            z -= dz;
            if (fabs(dz) < 1e-15) break;
        }
        x[i] = z;
        w[i] = 2 / ((1 - z * z) * dp * dp);
    }
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* |ball(c, r) and box| in 3D: the cross-sections' areas integrated over z. */
static double ball_box_volume(const double c[3], double r, const double lo[3], const double hi[3]) {
    double z0 = fmax(lo[2], c[2] - r), z1 = fmin(hi[2], c[2] + r);
    if (!(z1 > z0)) return 0;
    double cut[32];
    int n = 0;
    cut[n++] = z0;
    cut[n++] = z1;
    double ex[2] = {fabs(lo[0] - c[0]), fabs(hi[0] - c[0])}, ey[2] = {fabs(lo[1] - c[1]), fabs(hi[1] - c[1])};
    double d[8] = {ex[0], ex[1], ey[0], ey[1], hypot(ex[0], ey[0]), hypot(ex[0], ey[1]), hypot(ex[1], ey[0]),
                   hypot(ex[1], ey[1])};
    for (int i = 0; i < 8; i++)
        if (d[i] < r)
            for (int sgn = -1; sgn <= 1; sgn += 2) {
                double z = c[2] + sgn * sqrt(r * r - d[i] * d[i]);
                if (z > z0 && z < z1) cut[n++] = z;
            }
    qsort(cut, (size_t)n, sizeof cut[0], cmp_double);
    double gx[GL_N], gw[GL_N], v = 0;
    gauss_legendre(gx, gw);
    for (int i = 0; i + 1 < n; i++) {
        /* z = a + (b - a)(1 - cos(pi u)) / 2 crowds the points to the piece's ends, where the area
           behaves like (z - a)^(3/2): smooth in u, so Gauss-Legendre converges fast */
        double a = cut[i], b = cut[i + 1];
        for (int k = 0; k < GL_N && b > a; k++) {
            double u = 0.5 * (gx[k] + 1), z = a + (b - a) * 0.5 * (1 - cos(PI * u));
            double rho = sqrt(fmax(0, r * r - (z - c[2]) * (z - c[2])));
            v += 0.5 * gw[k] * (b - a) * 0.5 * PI * sin(PI * u) * disk_rect_area(c[0], c[1], rho, lo[0], hi[0], lo[1], hi[1]);
        }
    }
    return v;
}

/* A box (half sizes h) or a 3D cylinder (radius, half height; axis local y) whose local axes are
 * world axes (perm), inside the box. */
static double aligned_volume(const sm_shape *s, int dim, const int perm[3], const double lo[3], const double hi[3]) {
    double h[3] = {s->half_extent[0], s->half_extent[1], s->half_extent[2]};
    int cyl3 = s->kind == SM_SHAPE_CYLINDER && dim == 3;
    if (s->kind == SM_SHAPE_CYLINDER) h[0] = h[2] = s->radius, h[1] = s->half_height;
    double v = 1;
    for (int l = 0; l < dim; l++) {
        if (cyl3 && l != 1) continue;
        int a = perm[l];
        v *= fmax(0, fmin(hi[a], s->center[a] + h[l]) - fmax(lo[a], s->center[a] - h[l]));
    }
    if (cyl3) { /* the disk in the plane of the other two world axes */
        int a0 = perm[0], a2 = perm[2];
        v *= disk_rect_area(s->center[a0], s->center[a2], s->radius, lo[a0], hi[a0], lo[a2], hi[a2]);
    }
    return v;
}

/* The full volume of a bounded shape. */
static double own_volume(const sm_shape *s, int dim) {
    switch (s->kind) {
    case SM_SHAPE_SPHERE: return dim == 3 ? 4.0 / 3.0 * PI * pow(s->radius, 3) : PI * s->radius * s->radius;
    case SM_SHAPE_CYLINDER:
        return dim == 3 ? PI * s->radius * s->radius * 2 * s->half_height : 4 * s->radius * s->half_height;
    case SM_SHAPE_BOX: return dim == 3 ? 8 * s->half_extent[0] * s->half_extent[1] * s->half_extent[2]
                                       : 4 * s->half_extent[0] * s->half_extent[1];
    default: return 0;
    }
}

/* |shape and box| where exact (see the top), else -1. */
static double exact_volume(const sm_shape *s, int dim, const double lo[3], const double hi[3]) {
    if (s->inside_out) {
        sm_shape in = *s;
        in.inside_out = 0;
        double v = exact_volume(&in, dim, lo, hi);
        return v < 0 ? -1 : fmax(0, box_volume(lo, hi, dim) - v);
    }
    if (s->kind == SM_SHAPE_HALFSPACE) return halfspace_volume(s->normal, s->center, dim, lo, hi);
    if (s->kind == SM_SHAPE_MESH) return -1; /* sampled */
    double blo[3], bhi[3];
    sc_shape_bbox(s, dim, blo, bhi);
    int inside = 1;
    for (int a = 0; a < dim; a++) {
        if (!(bhi[a] > lo[a] && blo[a] < hi[a])) return 0;
        inside = inside && blo[a] >= lo[a] && bhi[a] <= hi[a];
    }
    if (inside) return own_volume(s, dim);
    if (s->kind == SM_SHAPE_SPHERE)
        return dim == 3 ? ball_box_volume(s->center, s->radius, lo, hi)
                        : disk_rect_area(s->center[0], s->center[1], s->radius, lo[0], hi[0], lo[1], hi[1]);
    int perm[3];
    if (axis_aligned(s->rotation, dim, perm)) return aligned_volume(s, dim, perm, lo, hi);
    return -1;
}

/* The sampled |shape and clip and box|: midpoints of a lattice over the shapes' common bounding box. */
static double sampled_volume(const sm_shape *s, const sm_shape *clip, int dim, const double lo[3], const double hi[3],
                             double dx) {
    double slo[3], shi[3], blo[3], bhi[3];
    memcpy(slo, lo, sizeof slo);
    memcpy(shi, hi, sizeof shi);
    for (int k = 0; k < 1 + (clip != NULL); k++)
        if (sc_shape_bbox(k ? clip : s, dim, blo, bhi))
            for (int a = 0; a < dim; a++) {
                slo[a] = fmax(slo[a], blo[a]);
                shi[a] = fmin(shi[a], bhi[a]);
            }
    int n[3] = {1, 1, 1};
    for (int a = 0; a < dim; a++) {
        if (!(shi[a] > slo[a])) return 0;
        n[a] = (int)fmin(64, fmax(2, ceil((shi[a] - slo[a]) / (0.5 * dx))));
    }
    long inside = 0;
    double x[3] = {0, 0, 0};
    for (int i = 0; i < n[0]; i++)
        for (int j = 0; j < n[1]; j++)
            for (int k = 0; k < n[2]; k++) {
                int ijk[3] = {i, j, k};
                for (int a = 0; a < dim; a++) x[a] = slo[a] + (ijk[a] + 0.5) * (shi[a] - slo[a]) / n[a];
                if (sm_shape_distance(s, dim, x, NULL) < 0 && (!clip || sm_shape_distance(clip, dim, x, NULL) < 0))
                    inside++;
            }
    return box_volume(slo, shi, dim) * (double)inside / ((double)n[0] * n[1] * n[2]);
}

double sc_volume_in_box(const sm_shape *shape, const sm_shape *clip, int dim, const double lo[3], const double hi[3],
                        double dx) {
    if (!clip) {
        double v = exact_volume(shape, dim, lo, hi);
        if (v >= 0) return v;
    }
    return sampled_volume(shape, clip, dim, lo, hi, dx);
}
