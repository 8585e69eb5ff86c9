/* Querying the narrow-band signed distance field of a mesh (built in mesh_sdf_build.c, layout in
 * mesh_sdf_internal.h).
 *
 * With u = (x - origin) / h, cell i = floor(u) and t = u - i in [0, 1)^d, the value is the
 * trilinear (2D: bilinear) interpolant of the cell's corner nodes
 *   phi_h(x) = sum_{c in {0,1}^d} prod_k (c_k t_k + (1 - c_k)(1 - t_k)) phi_{i+c},
 * evaluated as nested linear blends along x, then y, then z; its gradient is
 *   d phi_h / d x_k = (1/h) (blend over the other axes of the differences phi_{i+e_k+.} - phi_{i+.}),
 * returned normalised (a unit normal, as the analytic shapes give). Brick positions that are not
 * stored give the clamped constant +-b (exactly the float value the bricks store for clamped
 * nodes, so the field is continuous); their gradient, and that of a stored cell whose corners are
 * all clamped (zero gradient), comes from the same interpolation over the coarse nodes (spacing
 * 8 h, exact distances). Beyond the table the value is the field's far value
 * (+b, or -b for a container) and the gradient points away from (container: towards) the table. */
#include <string.h>

#include "collide/mesh_sdf_internal.h"

void sm_mesh_sdf_finish_layout(struct sm_mesh_sdf *f) {
    f->inv_h = 1.0 / f->h;
    f->brick_nodes = f->dim == 3 ? SM_SDF_BN * SM_SDF_BN * SM_SDF_BN : SM_SDF_BN * SM_SDF_BN;
    for (int k = 0; k < 3; k++) {
        f->ncells[k] = k < f->dim ? f->nb[k] * SM_SDF_BRICK : 0;
        f->stats.table[k] = f->nb[k];
    }
    f->far_value = f->stats.container ? -(float)f->band : (float)f->band;
    f->stats.dim = f->dim;
    f->stats.spacing = f->h;
    f->stats.band = f->band;
    f->stats.bytes = sizeof *f + sm_sdf_table_size(f) * sizeof(int32_t) + sm_sdf_coarse_size(f) * sizeof(float) +
                     f->nbricks * f->brick_nodes * sizeof(float);
}

void sm_mesh_sdf_destroy(sm_mesh_sdf *f) {
    if (!f) return;
    free(f->table);
    free(f->coarse);
    free(f->bricks);
    free(f);
}

const sm_mesh_sdf_stats *sm_mesh_sdf_stats_get(const sm_mesh_sdf *f) { return &f->stats; }

size_t sm_mesh_sdf_bytes(const sm_mesh_sdf *f) { return f->stats.bytes; }

/* Trilinear blend of corner values v[cx + 2 cy + 4 cz] at t; gradient per unit cell into g. */
static double trilinear(const double v[8], const double t[3], double g[3]) {
    double x00 = v[0] + t[0] * (v[1] - v[0]), x10 = v[2] + t[0] * (v[3] - v[2]);
    double x01 = v[4] + t[0] * (v[5] - v[4]), x11 = v[6] + t[0] * (v[7] - v[6]);
    double y0 = x00 + t[1] * (x10 - x00), y1 = x01 + t[1] * (x11 - x01);
    double d0 = (v[1] - v[0]) + t[1] * ((v[3] - v[2]) - (v[1] - v[0]));
    double d1 = (v[5] - v[4]) + t[1] * ((v[7] - v[6]) - (v[5] - v[4]));
    g[0] = d0 + t[2] * (d1 - d0);
    g[1] = (x10 - x00) + t[2] * ((x11 - x01) - (x10 - x00));
    g[2] = y1 - y0;
    return y0 + t[2] * (y1 - y0);
}

/* Bilinear blend of v[cx + 2 cy] at t; gradient into g (g[2] = 0). */
static double bilinear(const double v[4], const double t[3], double g[3]) {
    double x0 = v[0] + t[0] * (v[1] - v[0]), x1 = v[2] + t[0] * (v[3] - v[2]);
    g[0] = (v[1] - v[0]) + t[1] * ((v[3] - v[2]) - (v[1] - v[0]));
    g[1] = x1 - x0;
    g[2] = 0.0;
    return x0 + t[1] * (x1 - x0);
}

/* Gathers the cell's corners from a float array with strides sx, sy, sz and interpolates. */
static double interp(const float *c, size_t sy, size_t sz, int dim, const double t[3], double g[3]) {
    double v[8];
    v[0] = c[0], v[1] = c[1], v[2] = c[sy], v[3] = c[sy + 1];
    if (dim == 2) return bilinear(v, t, g);
    v[4] = c[sz], v[5] = c[sz + 1], v[6] = c[sz + sy], v[7] = c[sz + sy + 1];
    return trilinear(v, t, g);
}

static void normalize_or_up(double g[3]) {
    double n = sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
    if (n > 0.0) {
        g[0] /= n, g[1] /= n, g[2] /= n;
    } else {
        g[0] = 0.0, g[1] = 1.0, g[2] = 0.0; /* no direction is preferred: pick +y as the shapes do */
    }
}

/* Gradient of the coarse field in lattice cell i at fraction t. */
static void coarse_gradient(const sm_mesh_sdf *f, const int i[3], const double t[3], double g[3]) {
    const size_t sy = (size_t)f->nb[0] + 1, sz = sy * ((size_t)f->nb[1] + 1);
    double tc[3] = {0, 0, 0};
    size_t ci = 0;
    for (int k = 0; k < f->dim; k++) {
        tc[k] = ((double)(i[k] & (SM_SDF_BRICK - 1)) + t[k]) / SM_SDF_BRICK;
        ci += (size_t)(i[k] >> SM_SDF_BRICK_BITS) * (k == 0 ? 1 : k == 1 ? sy : sz);
    }
    interp(f->coarse + ci, sy, sz, f->dim, tc, g);
    normalize_or_up(g);
}

/* Beyond the table: the far value, the gradient pointing away from the table's box. */
static double far_field(const sm_mesh_sdf *f, const double x[3], double grad[3]) {
    if (grad) {
        for (int k = 0; k < 3; k++) {
            double lo = f->origin[k], hi = lo + f->ncells[k] * f->h;
            grad[k] = k < f->dim ? x[k] - fmin(fmax(x[k], lo), hi) : 0.0;
            if (f->stats.container) grad[k] = -grad[k];
        }
        normalize_or_up(grad);
    }
    return (double)f->far_value;
}

double sm_mesh_sdf_distance(const sm_mesh_sdf *f, const double x[3], double grad[3]) {
    const int dim = f->dim;
    double t[3] = {0.0, 0.0, 0.0};
    int i[3] = {0, 0, 0};
    for (int k = 0; k < dim; k++) {
        double u = (x[k] - f->origin[k]) * f->inv_h;
        if (!(u >= 0.0 && u < (double)f->ncells[k])) return far_field(f, x, grad);
        i[k] = (int)u;
        t[k] = u - (double)i[k];
    }
    size_t cell = (size_t)(i[0] >> SM_SDF_BRICK_BITS) +
                  (size_t)f->nb[0] * ((size_t)(i[1] >> SM_SDF_BRICK_BITS) + (size_t)f->nb[1] * (size_t)(i[2] >> SM_SDF_BRICK_BITS));
    int32_t b = f->table[cell];
    if (b < 0) {
        if (grad) coarse_gradient(f, i, t, grad);
        return b == SM_SDF_INSIDE ? -(double)(float)f->band : (double)(float)f->band;
    }
    const int m = SM_SDF_BRICK - 1;
    const float *c = f->bricks + (size_t)b * f->brick_nodes +
                     (size_t)((i[0] & m) + SM_SDF_BN * ((i[1] & m) + SM_SDF_BN * (i[2] & m)));
    double g[3];
    double phi = interp(c, SM_SDF_BN, SM_SDF_BN * SM_SDF_BN, dim, t, g);
    if (grad) {
        if (g[0] == 0.0 && g[1] == 0.0 && g[2] == 0.0) {
            coarse_gradient(f, i, t, grad); /* a cell of clamped nodes in a stored brick */
        } else {
            memcpy(grad, g, sizeof g);
            normalize_or_up(grad);
        }
    }
    return phi;
}
