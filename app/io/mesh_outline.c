/* 2D outlines from mesh files (see mesh_load.h): line elements, or the z = 0 slice of triangles.
 *
 * Slice: a vertex is above the plane if z >= 0 (a vertex exactly on the plane counts as above, a
 * symbolic perturbation that gives every triangle either no crossing or exactly two crossing
 * edges). On an edge from u (below) to w (above) the crossing is
 *   P = u + t (w - u), t = z_u / (z_u - z_w) in (0, 1]  (P = w exactly when t = 1),
 * computed from the edge's endpoints in that order whichever triangle asks, so the two triangles
 * of an edge produce the same bits and the segments weld into a chain. The segment is oriented
 * counter-clockwise around the solid: direction d with (d_y, -d_x) along the triangle normal's
 * xy part (the section's outward normal).
 * Checks: at every vertex of a closed, consistently oriented outline one segment ends and one
 * starts; one segment in all is an open end, three or more a branch, two that both end (or both
 * start) there disagree in orientation. Signed area A = (1/2) sum a x b; A < 0: clockwise, the
 * outline acts as a container. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "app/io/mesh_load.h"

/* Appends the z = 0 crossing segment of triangle t (if any) to seg/pts. */
static void slice_triangle(const double *v, const uint32_t *t, double *pts, size_t *np, uint32_t *seg, size_t *ns) {
    const double *p[3] = {v + 3 * (size_t)t[0], v + 3 * (size_t)t[1], v + 3 * (size_t)t[2]};
    int above = (p[0][2] >= 0) + (p[1][2] >= 0) + (p[2][2] >= 0);
    if (above == 0 || above == 3) return;
    double cross[2][2] = {{0, 0}, {0, 0}};
    int n = 0;
    for (int e = 0; e < 3 && n < 2; e++) { /* exactly two edges cross the plane */
        const double *a = p[e], *b = p[(e + 1) % 3];
        if ((a[2] >= 0) == (b[2] >= 0)) continue;
        const double *u = a[2] < 0 ? a : b, *w = a[2] < 0 ? b : a;
        double s = u[2] / (u[2] - w[2]);
        for (int k = 0; k < 2; k++) cross[n][k] = s == 1.0 ? w[k] : u[k] + s * (w[k] - u[k]);
        n++;
    }
    double e1[3], e2[3];
    for (int k = 0; k < 3; k++) {
        e1[k] = p[1][k] - p[0][k];
        e2[k] = p[2][k] - p[0][k];
    }
    double nx = e1[1] * e2[2] - e1[2] * e2[1], ny = e1[2] * e2[0] - e1[0] * e2[2];
    double dx = cross[1][0] - cross[0][0], dy = cross[1][1] - cross[0][1];
    int flip = dx * -ny + dy * nx < 0;
    for (int k = 0; k < 2; k++) {
        double *q = pts + 3 * (*np + (size_t)k);
        q[0] = cross[flip ? 1 - k : k][0];
        q[1] = cross[flip ? 1 - k : k][1];
        q[2] = 0.0;
    }
    seg[2 * *ns] = (uint32_t)*np;
    seg[2 * *ns + 1] = (uint32_t)*np + 1;
    *np += 2;
    (*ns)++;
}

/* Counts open ends, branches and misoriented vertices; at[k] a point of the first of each. */
static int outline_topology(sm_mesh_data *m, double at[3][2]) {
    uint32_t *deg = calloc(2 * (m->vertex_count ? m->vertex_count : 1), sizeof *deg); /* out, in */
    if (!deg) return 0;
    for (size_t s = 0; s < m->element_count; s++) {
        deg[2 * (size_t)m->elements[2 * s]]++;
        deg[2 * (size_t)m->elements[2 * s + 1] + 1]++;
    }
    sm_mesh_report *r = &m->report;
    for (size_t i = 0; i < m->vertex_count; i++) {
        uint32_t out = deg[2 * i], in = deg[2 * i + 1];
        int kind = out + in == 0 ? -1 : out + in == 1 ? 0 : in != out ? 2 : out + in > 2 ? 1 : -1;
        size_t *count = kind == 0 ? &r->open_edges : kind == 1 ? &r->nonmanifold_edges : kind == 2 ? &r->misoriented_edges : NULL;
        if (count && (*count)++ == 0) memcpy(at[kind], m->vertices + 3 * i, 2 * sizeof(double));
    }
    free(deg);
    return 1;
}

/* The segments into out (welded in 2D, zero-length ones removed). */
static sm_status take_segments(double *pts, size_t np, uint32_t *seg, size_t ns, sm_mesh_data *out) {
    uint32_t *remap = malloc((np ? np : 1) * sizeof *remap);
    size_t nu = remap && np ? sm_mesh_weld(pts, np, 2, remap, pts) : 0;
    if (!remap || (np && !nu)) {
        free(remap);
        return SM_ERR_NOMEM;
    }
    size_t kept = 0;
    for (size_t s = 0; s < ns; s++) {
        uint32_t a = remap[seg[2 * s]], b = remap[seg[2 * s + 1]];
        if (a == b) {
            out->report.degenerate++;
            continue;
        }
        seg[2 * kept] = a;
        seg[2 * kept++ + 1] = b;
    }
    free(remap);
    out->dim = 2;
    out->vertices = pts;
    out->vertex_count = nu;
    out->elements = seg;
    out->element_count = kept;
    return SM_OK;
}

/* Errors and warnings of a built outline. */
static sm_status check_outline(const sm_mesh_load_opts *o, sm_mesh_data *m, char *err, size_t errlen, char *warn, size_t wlen) {
    double at[3][2] = {{0}};
    if (!outline_topology(m, at)) return SM_ERR_NOMEM;
    const sm_mesh_report *r = &m->report;
    /* (a slice makes zero-length pieces wherever a triangle touches the plane at one vertex: no news) */
    if (r->degenerate && !strcmp(r->source, "lines"))
        sm_mesh_warn(warn, wlen, "%zu zero-length segments removed", r->degenerate);
    if (r->misoriented_edges) {
        snprintf(err, errlen, "inconsistent outline direction at %zu vertices (the first at (%.6g, %.6g)): every "
                 "segment must continue the previous one", r->misoriented_edges, at[2][0], at[2][1]);
        return SM_ERR_INVALID;
    }
    if (o->require_closed && (r->open_edges || r->nonmanifold_edges)) {
        snprintf(err, errlen, "not a closed outline: %zu open ends and %zu branching vertices (the first at (%.6g, "
                 "%.6g)); a solid needs closed loops", r->open_edges, r->nonmanifold_edges,
                 r->open_edges ? at[0][0] : at[1][0], r->open_edges ? at[0][1] : at[1][1]);
        return SM_ERR_INVALID;
    }
    if (r->open_edges)
        sm_mesh_warn(warn, wlen, "open outline: %zu ends (the first at (%.6g, %.6g)); usable as a one-sided collider, "
                     "not as a solid", r->open_edges, at[0][0], at[0][1]);
    if (r->nonmanifold_edges)
        sm_mesh_warn(warn, wlen, "%zu branching vertices (the first at (%.6g, %.6g)); the inside is taken by winding "
                     "number", r->nonmanifold_edges, at[1][0], at[1][1]);
    double area = 0;
    for (size_t s = 0; s < m->element_count; s++) {
        const double *a = m->vertices + 3 * (size_t)m->elements[2 * s], *b = m->vertices + 3 * (size_t)m->elements[2 * s + 1];
        area += 0.5 * (a[0] * b[1] - a[1] * b[0]);
    }
    m->report.volume = area;
    if (area < 0 && !r->open_edges)
        sm_mesh_warn(warn, wlen, "the outline runs clockwise (signed area %.6g m^2): it acts as a container, solid "
                     "outside", area);
    return SM_OK;
}

sm_status sm_mesh_outline(const double *verts, size_t nverts, const uint32_t *lines, size_t nlines, const uint32_t *tris,
                          size_t ntris, const sm_mesh_load_opts *opts, sm_mesh_data *out, char *err, size_t errlen,
                          char *warn, size_t wlen) {
    if (nlines == 0 && ntris == 0) {
        snprintf(err, errlen, "no lines and no triangles: nothing to make an outline of");
        return SM_ERR_INVALID;
    }
    size_t ne = nlines ? nlines : ntris, np = 0, ns = 0;
    double *pts = malloc(3 * 2 * ne * sizeof(double));
    uint32_t *seg = malloc(2 * ne * sizeof(uint32_t));
    if (!pts || !seg) {
        free(pts), free(seg);
        return SM_ERR_NOMEM;
    }
    if (nlines) {
        for (size_t s = 0; s < nlines; s++, ns++, np += 2)
            for (int k = 0; k < 2; k++) {
                memcpy(pts + 3 * (np + (size_t)k), verts + 3 * (size_t)lines[2 * s + (size_t)k], 2 * sizeof(double));
                pts[3 * (np + (size_t)k) + 2] = 0.0;
                seg[2 * ns + (size_t)k] = (uint32_t)(np + (size_t)k);
            }
    } else {
        for (size_t t = 0; t < ntris; t++) slice_triangle(verts, tris + 3 * t, pts, &np, seg, &ns);
    }
    out->report.source = nlines ? "lines" : "slice";
    out->report.elements_read = ne;
    sm_status st = take_segments(pts, np, seg, ns, out);
    if (st != SM_OK) {
        free(pts), free(seg);
        return st;
    }
    if (out->element_count == 0) {
        double zlo = HUGE_VAL, zhi = -HUGE_VAL;
        for (size_t i = 0; i < nverts; i++) zlo = fmin(zlo, verts[3 * i + 2]), zhi = fmax(zhi, verts[3 * i + 2]);
        if (nlines) snprintf(err, errlen, "no outline: all %zu lines have zero length", nlines);
        else snprintf(err, errlen, "the plane z = 0 does not cut the mesh (z from %.6g to %.6g after placement); "
                      "move or rotate the mesh to choose the section", zlo, zhi);
        return SM_ERR_INVALID;
    }
    return check_outline(opts, out, err, errlen, warn, wlen);
}
