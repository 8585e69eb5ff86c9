// Compares sandmpm's mesh signed distance field with OpenVDB's tools::meshToLevelSet (issue 15):
// on the same meshes, spacing and band half-width, at OpenVDB's active voxels (the lattices
// coincide: both put nodes at integer multiples of h) and at random points (trilinear sampling on
// both sides), the largest difference in units of h, the sign agreement, and both build times.
// Optional: built only when OpenVDB is found (bench/CMakeLists.txt).
//
//   vdb_compare [spacing]     (default 0.01; meshes about 0.4 m across)
#include <openvdb/openvdb.h>
#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/MeshToVolume.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <vector>

extern "C" {
#include "collide/mesh_sdf.h"
#include "mesh_gen.h"
}

static double now() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

static void compare(const char *name, const test_mesh &m, double h) {
    const double band = 3 * h;
    sm_mesh_sdf_def d = sm_mesh_sdf_def_default();
    d.vertices = m.v;
    d.vertex_count = m.nv;
    d.elements = m.e;
    d.element_count = m.ne;
    d.spacing = h;
    d.band = band;
    sm_mesh_sdf *f = nullptr;
    char err[256];
    if (sm_mesh_sdf_build(&d, &f, err, sizeof err) != SM_OK) {
        std::fprintf(stderr, "%s: %s\n", name, err);
        std::exit(1);
    }
    std::vector<openvdb::Vec3s> pts(m.nv);
    std::vector<openvdb::Vec3I> tris(m.ne);
    for (size_t i = 0; i < m.nv; i++) pts[i] = openvdb::Vec3s((float)m.v[3 * i], (float)m.v[3 * i + 1], (float)m.v[3 * i + 2]);
    for (size_t t = 0; t < m.ne; t++) tris[t] = openvdb::Vec3I(m.e[3 * t], m.e[3 * t + 1], m.e[3 * t + 2]);
    auto xform = openvdb::math::Transform::createLinearTransform(h);
    double t0 = now();
    openvdb::FloatGrid::Ptr g = openvdb::tools::meshToLevelSet<openvdb::FloatGrid>(*xform, pts, tris, 3.0f);
    double t_vdb = now() - t0;

    double worst_node = 0, worst_near = 0; // near: |phi| < h, where a collider acts
    size_t nodes = 0, sign_diff = 0;
    for (auto it = g->cbeginValueOn(); it; ++it) {
        float v = *it;
        if (std::fabs(v) >= 0.99 * band) continue;
        openvdb::Vec3d w = xform->indexToWorld(it.getCoord());
        double x[3] = {w.x(), w.y(), w.z()};
        double s = sm_mesh_sdf_distance(f, x, nullptr);
        worst_node = std::fmax(worst_node, std::fabs(s - v));
        if (std::fabs(s) < h) worst_near = std::fmax(worst_near, std::fabs(s - v));
        sign_diff += std::fabs(v) > 0.01 * h && (s < 0) != (v < 0);
        nodes++;
    }
    // Random points where both fields are inside the accurate band (|phi| < band - sqrt(3) h).
    std::mt19937_64 rng(7);
    openvdb::tools::GridSampler<openvdb::FloatGrid, openvdb::tools::BoxSampler> sampler(*g);
    const sm_mesh_sdf_stats *st = sm_mesh_sdf_stats_get(f);
    double lo[3], hi[3], worst_pt = 0;
    for (int k = 0; k < 3; k++) {
        lo[k] = HUGE_VAL, hi[k] = -HUGE_VAL;
        for (size_t i = 0; i < m.nv; i++) lo[k] = std::fmin(lo[k], m.v[3 * i + k]), hi[k] = std::fmax(hi[k], m.v[3 * i + k]);
    }
    size_t npts = 0;
    for (int i = 0; i < 200000 && npts < 20000; i++) {
        double x[3];
        for (int k = 0; k < 3; k++) x[k] = std::uniform_real_distribution<double>(lo[k] - band, hi[k] + band)(rng);
        double s = sm_mesh_sdf_distance(f, x, nullptr);
        double v = sampler.wsSample(openvdb::Vec3d(x[0], x[1], x[2]));
        if (std::fabs(s) >= band - std::sqrt(3.0) * h || std::fabs(v) >= band - std::sqrt(3.0) * h) continue;
        worst_pt = std::fmax(worst_pt, std::fabs(s - v));
        npts++;
    }
    std::printf("| %s | %zu | %.4g | %zu | %.2g | %.2g | %zu | %zu | %.2g | %.3f | %.3f |\n", name, m.ne, h, nodes,
                worst_near / h, worst_node / h, sign_diff, npts, worst_pt / h, st->seconds, t_vdb);
    sm_mesh_sdf_destroy(f);
}

int main(int argc, char **argv) {
    double h = argc > 1 ? std::atof(argv[1]) : 0.01;
    openvdb::initialize();
    const double c[3] = {0.0, 0.0, 0.0}, lc[3] = {-0.2, -0.2, -0.1};
    test_mesh sphere = mesh_uv_sphere(c, 0.2, 64, 128), torus = mesh_torus(0.15, 0.06, 128, 64),
              bumpy = mesh_bumpy_sphere(0.2, 0.2, 64, 128), L = mesh_l_prism(lc, 0.2);
    std::printf("| mesh | triangles | h | VDB band nodes | worst node diff / h, abs(phi) < h | worst node diff / h | sign "
                "differences | random points | worst point diff / h | sandmpm build s | OpenVDB build s |\n"
                "|---|---|---|---|---|---|---|---|---|---|---|\n");
    compare("sphere", sphere, h);
    compare("torus", torus, h);
    compare("bumpy sphere", bumpy, h);
    compare("L prism", L, h);
    mesh_free(&sphere);
    mesh_free(&torus);
    mesh_free(&bumpy);
    mesh_free(&L);
    return 0;
}
