/* Exact point-simplex geometry for mesh signed distances.
 *
 * Closest point on a triangle abc (Ericson, Real-Time Collision Detection, 2005, §5.1.5): with
 * ab = b - a, ac = c - a and the dot products
 *   d1 = ab.(p-a), d2 = ac.(p-a), d3 = ab.(p-b), d4 = ac.(p-b), d5 = ab.(p-c), d6 = ac.(p-c),
 * p lies in the Voronoi region of
 *   vertex a  if d1 <= 0 and d2 <= 0;           vertex b  if d3 >= 0 and d4 <= d3;
 *   vertex c  if d6 >= 0 and d5 <= d6;
 *   edge ab   if vc = d1 d4 - d3 d2 <= 0, d1 >= 0, d3 <= 0:  q = a + ab d1/(d1 - d3);
 *   edge ca   if vb = d5 d2 - d1 d6 <= 0, d2 >= 0, d6 <= 0:  q = a + ac d2/(d2 - d6);
 *   edge bc   if va = d3 d6 - d5 d4 <= 0, d4 - d3 >= 0, d5 - d6 >= 0:
 *                                                q = b + (c - b) (d4-d3)/((d4-d3) + (d5-d6));
 *   the face  otherwise: q = a + ab vb/(va+vb+vc) + ac vc/(va+vb+vc)
 * (va, vb, vc are the scaled barycentric coordinates: va + vb + vc = |ab x ac|^2). The tests are
 * taken in this order, so every p gets exactly one region. A triangle with |ab x ac| <= 1e-12 times
 * its longest edge squared has no face (the formulas divide by zero on coincident vertices): its
 * closest point is the nearest of its three edges'.
 *
 * Closest point on a segment ab: t = clamp(ab.(p-a) / |ab|^2, 0, 1), q = a + t ab.
 *
 * Solid angle of a triangle seen from p (Van Oosterom & Strackee, IEEE Trans. Biomed. Eng. 30,
 * 1983), with a, b, c now relative to p:
 *   tan(Omega/2) = a.(b x c) / (|a||b||c| + (a.b)|c| + (b.c)|a| + (c.a)|b|),
 * evaluated as Omega = 2 atan2(num, den), which is right in every quadrant. Summed over a closed
 * outward-oriented surface it is 4 pi inside and 0 outside (the generalised winding number of
 * Jacobson et al. 2013 is that sum / 4 pi).
 * Angle of a segment seen from p in 2D: theta = atan2(a x b, a.b) with a, b relative to p; the sum
 * over a closed counter-clockwise outline is 2 pi inside, 0 outside. */
#include "collide/mesh_geom.h"

#include <math.h>

static double dot3(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

static void sub3(const double a[3], const double b[3], double r[3]) {
    r[0] = a[0] - b[0];
    r[1] = a[1] - b[1];
    r[2] = a[2] - b[2];
}

static void cross3(const double a[3], const double b[3], double r[3]) {
    r[0] = a[1] * b[2] - a[2] * b[1];
    r[1] = a[2] * b[0] - a[0] * b[2];
    r[2] = a[0] * b[1] - a[1] * b[0];
}

static double dist2(const double a[3], const double b[3]) {
    double d[3];
    sub3(a, b, d);
    return dot3(d, d);
}

double sm_closest_on_segment(const double p[3], const double a[3], const double b[3], double q[3],
                             double bary[2], sm_simplex_region *region) {
    double ab[3], ap[3];
    sub3(b, a, ab);
    sub3(p, a, ap);
    double l2 = dot3(ab, ab), s = dot3(ab, ap), t;
    if (!(l2 > 0.0) || s <= 0.0) {
        t = 0.0;
        *region = SM_REGION_V0;
    } else if (s >= l2) {
        t = 1.0;
        *region = SM_REGION_V1;
    } else {
        t = s / l2;
        *region = SM_REGION_E0;
    }
    for (int k = 0; k < 3; k++) q[k] = t == 1.0 ? b[k] : a[k] + t * ab[k];
    bary[0] = 1.0 - t;
    bary[1] = t;
    return dist2(p, q);
}

/* Writes the point bary-weighted over (a, b, c) into q. */
static void bary_point(const double a[3], const double b[3], const double c[3], const double bary[3], double q[3]) {
    for (int k = 0; k < 3; k++) q[k] = bary[0] * a[k] + bary[1] * b[k] + bary[2] * c[k];
}

/* The nearest of the three edges of a triangle without a face; bary and region as for the face. */
static double closest_on_edges(const double p[3], const double *v[3], double q[3], double bary[3],
                               sm_simplex_region *region) {
    double best = HUGE_VAL;
    for (int e = 0; e < 3; e++) {
        double qe[3], be[2];
        sm_simplex_region re;
        double d2 = sm_closest_on_segment(p, v[e], v[(e + 1) % 3], qe, be, &re);
        if (d2 < best) {
            best = d2;
            q[0] = qe[0];
            q[1] = qe[1];
            q[2] = qe[2];
            bary[e] = be[0];
            bary[(e + 1) % 3] = be[1];
            bary[(e + 2) % 3] = 0.0;
            *region = re == SM_REGION_E0 ? (sm_simplex_region)(SM_REGION_E0 + e)
                      : re == SM_REGION_V0 ? (sm_simplex_region)e
                                           : (sm_simplex_region)((e + 1) % 3);
        }
    }
    return best;
}

/* Sets bary to a vertex (k) and returns the region. */
static sm_simplex_region at_vertex(int k, double bary[3]) {
    bary[0] = bary[1] = bary[2] = 0.0;
    bary[k] = 1.0;
    return (sm_simplex_region)k;
}

int sm_triangle_is_flat(const double a[3], const double b[3], const double c[3]) {
    double ab[3], ac[3], n[3];
    sub3(b, a, ab);
    sub3(c, a, ac);
    cross3(ab, ac, n);
    double l2 = fmax(dot3(ab, ab), fmax(dot3(ac, ac), dist2(b, c)));
    return !(dot3(n, n) > 1e-24 * l2 * l2);
}

double sm_closest_on_triangle(const double p[3], const double a[3], const double b[3], const double c[3],
                              double q[3], double bary[3], sm_simplex_region *region) {
    if (sm_triangle_is_flat(a, b, c)) {
        const double *v[3] = {a, b, c};
        return closest_on_edges(p, v, q, bary, region);
    }
    return sm_closest_on_proper_triangle(p, a, b, c, q, bary, region);
}

double sm_closest_on_proper_triangle(const double p[3], const double a[3], const double b[3], const double c[3],
                                     double q[3], double bary[3], sm_simplex_region *region) {
    double ab[3], ac[3], ap[3], bp[3], cp[3];
    sub3(b, a, ab);
    sub3(c, a, ac);
    sub3(p, a, ap);
    double d1 = dot3(ab, ap), d2 = dot3(ac, ap);
    if (d1 <= 0.0 && d2 <= 0.0) {
        *region = at_vertex(0, bary);
    } else {
        sub3(p, b, bp);
        double d3 = dot3(ab, bp), d4 = dot3(ac, bp);
        sub3(p, c, cp);
        double d5 = dot3(ab, cp), d6 = dot3(ac, cp);
        double vc = d1 * d4 - d3 * d2, vb = d5 * d2 - d1 * d6, va = d3 * d6 - d5 * d4;
        if (d3 >= 0.0 && d4 <= d3) {
            *region = at_vertex(1, bary);
        } else if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
            double v = d1 / (d1 - d3);
            bary[0] = 1.0 - v, bary[1] = v, bary[2] = 0.0;
            *region = SM_REGION_E0;
        } else if (d6 >= 0.0 && d5 <= d6) {
            *region = at_vertex(2, bary);
        } else if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
            double w = d2 / (d2 - d6);
            bary[0] = 1.0 - w, bary[1] = 0.0, bary[2] = w;
            *region = SM_REGION_E2;
        } else if (va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0) {
            double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
            bary[0] = 0.0, bary[1] = 1.0 - w, bary[2] = w;
            *region = SM_REGION_E1;
        } else {
            double inv = 1.0 / (va + vb + vc);
            bary[1] = vb * inv, bary[2] = vc * inv, bary[0] = 1.0 - bary[1] - bary[2];
            *region = SM_REGION_FACE;
        }
    }
    bary_point(a, b, c, bary, q);
    return dist2(p, q);
}

double sm_solid_angle(const double p[3], const double a[3], const double b[3], const double c[3]) {
    double u[3], v[3], w[3], vw[3];
    sub3(a, p, u);
    sub3(b, p, v);
    sub3(c, p, w);
    cross3(v, w, vw);
    double lu = sqrt(dot3(u, u)), lv = sqrt(dot3(v, v)), lw = sqrt(dot3(w, w));
    double num = dot3(u, vw);
    double den = lu * lv * lw + dot3(u, v) * lw + dot3(v, w) * lu + dot3(w, u) * lv;
    return 2.0 * atan2(num, den);
}

double sm_segment_angle(const double p[3], const double a[3], const double b[3]) {
    double ux = a[0] - p[0], uy = a[1] - p[1], vx = b[0] - p[0], vy = b[1] - p[1];
    return atan2(ux * vy - uy * vx, ux * vx + uy * vy);
}
