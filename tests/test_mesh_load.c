/* Mesh files through assimp (app/io/mesh_load.c): small OBJ, STL, PLY and glTF files written
 * here -- a closed cube (the same after welding in every format), an open box, a non-manifold fin,
 * a flipped triangle, a degenerate triangle, an inside-out cube, a missing and an unreadable file
 * -- and the messages; placement; node transforms (glTF instances); 2D outlines from OBJ lines and
 * from the z = 0 slice; a loaded cube through the library's field. */
#define _POSIX_C_SOURCE 200809L
#include <stdarg.h>
#include <string.h>
#include <unistd.h>

#include "app/io/mesh_load.h"
#include "collide/mesh_sdf.h"
#include "test_util.h"

static char dir[64];

static const double CUBE_V[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
/* Outward, counter-clockwise; faces -z, +z, -y, +x, +y, -x, two triangles each. */
static const int CUBE_T[12][3] = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
                                  {1, 2, 6}, {1, 6, 5}, {2, 3, 7}, {2, 7, 6}, {3, 0, 4}, {3, 4, 7}};

static const char *path_of(const char *name) {
    static char p[128];
    snprintf(p, sizeof p, "%s/%s", dir, name);
    return p;
}

static void write_file(const char *name, const char *fmt, ...) {
    FILE *f = fopen(path_of(name), "wb");
    if (!f) abort();
    va_list ap;
    va_start(ap, fmt);
    vfprintf(f, fmt, ap);
    va_end(ap);
    fclose(f);
}

/* An OBJ of the cube's first ntri triangles (flip: triangle index to reverse, -1 none) plus
 * extra text. */
static void write_cube_obj(const char *name, int ntri, int flip, int reverse_all, const char *extra) {
    FILE *f = fopen(path_of(name), "wb");
    if (!f) abort();
    for (int i = 0; i < 8; i++) fprintf(f, "v %g %g %g\n", CUBE_V[i][0], CUBE_V[i][1], CUBE_V[i][2]);
    for (int t = 0; t < ntri; t++) {
        int a = CUBE_T[t][0], b = CUBE_T[t][1], c = CUBE_T[t][2];
        if (t == flip || reverse_all) fprintf(f, "f %d %d %d\n", a + 1, c + 1, b + 1);
        else fprintf(f, "f %d %d %d\n", a + 1, b + 1, c + 1);
    }
    fputs(extra, f);
    fclose(f);
}

static void write_cube_stl(const char *name) {
    FILE *f = fopen(path_of(name), "wb");
    if (!f) abort();
    fprintf(f, "solid cube\n");
    for (int t = 0; t < 12; t++) {
        fprintf(f, " facet normal 0 0 0\n  outer loop\n");
        for (int k = 0; k < 3; k++) {
            const double *v = CUBE_V[CUBE_T[t][k]];
            fprintf(f, "   vertex %g %g %g\n", v[0], v[1], v[2]);
        }
        fprintf(f, "  endloop\n endfacet\n");
    }
    fprintf(f, "endsolid cube\n");
    fclose(f);
}

static void write_cube_ply(const char *name) {
    FILE *f = fopen(path_of(name), "wb");
    if (!f) abort();
    fprintf(f, "ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\nproperty float z\n"
               "element face 12\nproperty list uchar int vertex_indices\nend_header\n");
    for (int i = 0; i < 8; i++) fprintf(f, "%g %g %g\n", CUBE_V[i][0], CUBE_V[i][1], CUBE_V[i][2]);
    for (int t = 0; t < 12; t++) fprintf(f, "3 %d %d %d\n", CUBE_T[t][0], CUBE_T[t][1], CUBE_T[t][2]);
    fclose(f);
}

static void b64(const unsigned char *in, size_t n, char *out) {
    static const char tab[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    size_t o = 0;
    for (size_t i = 0; i < n; i += 3) {
        unsigned v = (unsigned)in[i] << 16 | (i + 1 < n ? (unsigned)in[i + 1] << 8 : 0) | (i + 2 < n ? in[i + 2] : 0);
        out[o++] = tab[v >> 18 & 63];
        out[o++] = tab[v >> 12 & 63];
        out[o++] = i + 1 < n ? tab[v >> 6 & 63] : '=';
        out[o++] = i + 2 < n ? tab[v & 63] : '=';
    }
    out[o] = 0;
}

/* glTF 2.0 with the cube mesh used by two nodes: one at the origin, one translated by (3, 0, 0)
 * under a parent scaled by 2 (so the instance spans x in [6, 8], y and z in [0, 2]). */
static void write_cube_gltf(const char *name) {
    unsigned char buf[8 * 12 + 36 * 2];
    for (int i = 0; i < 8; i++)
        for (int k = 0; k < 3; k++) {
            float x = (float)CUBE_V[i][k];
            memcpy(buf + 12 * i + 4 * k, &x, 4);
        }
    for (int t = 0; t < 12; t++)
        for (int k = 0; k < 3; k++) {
            uint16_t s = (uint16_t)CUBE_T[t][k];
            memcpy(buf + 96 + 2 * (3 * t + k), &s, 2);
        }
    char enc[256];
    b64(buf, sizeof buf, enc);
    write_file(name,
               "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0,1]}],"
               "\"nodes\":[{\"mesh\":0},{\"scale\":[2,2,2],\"children\":[2]},{\"mesh\":0,\"translation\":[3,0,0]}],"
               "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1}]}],"
               "\"buffers\":[{\"byteLength\":%zu,\"uri\":\"data:application/octet-stream;base64,%s\"}],"
               "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":96},"
               "{\"buffer\":0,\"byteOffset\":96,\"byteLength\":72}],"
               "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":8,\"type\":\"VEC3\","
               "\"min\":[0,0,0],\"max\":[1,1,1]},{\"bufferView\":1,\"componentType\":5123,\"count\":36,\"type\":\"SCALAR\"}]}\n",
               sizeof buf, enc);
}

static sm_status load(const char *name, const sm_mesh_load_opts *o, sm_mesh_data *m, char *msg, size_t n) {
    sm_status st = sm_mesh_load(path_of(name), o, m, msg, n);
    printf("  %-16s -> %s%s%s\n", name, sm_status_string(st), msg[0] ? ": " : "", msg);
    return st;
}

static void test_cube_formats(void) {
    const char *names[4] = {"cube.obj", "cube.stl", "cube.ply", "cube.gltf"};
    write_cube_obj(names[0], 12, -1, 0, "");
    write_cube_stl(names[1]);
    write_cube_ply(names[2]);
    write_cube_gltf(names[3]);
    sm_mesh_load_opts o = sm_mesh_load_opts_default();
    o.require_closed = 1;
    uint64_t hash0 = 0;
    for (int i = 0; i < 4; i++) {
        sm_mesh_data m;
        char msg[512];
        CHECK(load(names[i], &o, &m, msg, sizeof msg) == SM_OK);
        CHECK(msg[0] == 0);
        size_t copies = i == 3 ? 2 : 1;
        CHECK(m.dim == 3 && m.element_count == 12 * copies && m.vertex_count == 8 * copies);
        CHECK(m.report.open_edges == 0 && m.report.nonmanifold_edges == 0 && m.report.misoriented_edges == 0);
        CHECK_NEAR(m.report.volume, i == 3 ? 1.0 + 8.0 : 1.0, 1e-12);
        if (i == 0) hash0 = m.hash;
        if (i < 3) CHECK(m.hash == hash0);             /* same triangles once welded */
        if (i == 3) CHECK(m.report.meshes == 2 && m.hi[0] == 8.0 && m.lo[0] == 0.0 && m.hi[2] == 2.0);
        sm_mesh_data_free(&m);
    }
}

/* The cube as two objects: assimp gives two meshes with their own vertices; welding closes it. */
static void test_weld_across_meshes(void) {
    write_cube_obj("split.obj", 6, -1, 0, "o second\n");
    FILE *f = fopen(path_of("split.obj"), "ab");
    if (!f) abort();
    for (int t = 6; t < 12; t++) fprintf(f, "f %d %d %d\n", CUBE_T[t][0] + 1, CUBE_T[t][1] + 1, CUBE_T[t][2] + 1);
    fclose(f);
    sm_mesh_load_opts o = sm_mesh_load_opts_default();
    o.require_closed = 1;
    sm_mesh_data m;
    char msg[256];
    CHECK(load("split.obj", &o, &m, msg, sizeof msg) == SM_OK);
    CHECK(m.report.meshes == 2 && m.report.welded > 0 && m.vertex_count == 8 && m.element_count == 12);
    sm_mesh_data_free(&m);
}

static void expect(const char *name, const sm_mesh_load_opts *o, sm_status want, const char *text) {
    sm_mesh_data m;
    char msg[512];
    sm_status st = load(name, o, &m, msg, sizeof msg);
    CHECK(st == want);
    CHECK(strstr(msg, text) != NULL);
    CHECK(strstr(msg, name) != NULL); /* the file is named */
    if (st != SM_OK) CHECK(m.vertices == NULL && m.element_count == 0);
    sm_mesh_data_free(&m);
}

static void test_bad_files(void) {
    sm_mesh_load_opts o = sm_mesh_load_opts_default(), closed = o;
    closed.require_closed = 1;
    write_cube_obj("open.obj", 10, -1, 0, ""); /* no +y face */
    expect("open.obj", &o, SM_OK, "open surface: 4 boundary edges");
    expect("open.obj", &closed, SM_ERR_INVALID, "not a closed surface: 4 open");
    write_cube_obj("fin.obj", 12, -1, 0, "v 0.5 -1 0\nf 1 2 9\n"); /* a fin on the edge 0-1 */
    expect("fin.obj", &o, SM_OK, "1 non-manifold edges");
    expect("fin.obj", &closed, SM_ERR_INVALID, "non-manifold");
    write_cube_obj("flipped.obj", 12, 5, 0, "");
    expect("flipped.obj", &o, SM_ERR_INVALID, "inconsistent winding: 3 edges");
    write_cube_obj("degenerate.obj", 12, -1, 0, "v 0.5 0 0\nf 1 2 9\n"); /* collinear with the edge 0-1 */
    expect("degenerate.obj", &closed, SM_OK, "1 degenerate (zero-area) triangles removed");
    write_cube_obj("inverted.obj", 12, -1, 1, "");
    expect("inverted.obj", &closed, SM_OK, "acts as a container");
    write_cube_obj("lines.obj", 0, -1, 0, "l 1 2\n");
    expect("lines.obj", &o, SM_ERR_INVALID, "no triangles");
    expect("missing.obj", &o, SM_ERR_IO, "mesh file not found");
    write_file("junk.xyz", "\x01\x02 this is not a mesh \x7f\n");
    expect("junk.xyz", &o, SM_ERR_IO, "cannot read mesh");
}

/* unit, per-axis scale, rotation and translation in that order. */
static void test_placement(void) {
    sm_mesh_load_opts o = sm_mesh_load_opts_default();
    o.placement.unit = 0.001; /* the cube file in millimetres */
    o.placement.scale[0] = 2.0;
    const double s = sqrt(0.5);
    o.placement.rotation[0] = s, o.placement.rotation[3] = s; /* 90 degrees about z: x -> y */
    o.placement.translation[2] = 1.0;
    sm_mesh_data m;
    char msg[256];
    CHECK(load("cube.obj", &o, &m, msg, sizeof msg) == SM_OK);
    CHECK_NEAR(m.lo[0], -0.001, 1e-15);
    CHECK_NEAR(m.hi[0], 0.0, 1e-15);
    CHECK_NEAR(m.hi[1], 0.002, 1e-15);
    CHECK_NEAR(m.lo[2], 1.0, 1e-15);
    CHECK_NEAR(m.hi[2], 1.001, 1e-15);
    CHECK_NEAR(m.report.volume, 2e-9, 1e-20);
    sm_mesh_data_free(&m);
}

static void test_outlines(void) {
    sm_mesh_load_opts o = sm_mesh_load_opts_default();
    o.dim = 2;
    o.require_closed = 1;
    sm_mesh_data m;
    char msg[256];
    write_file("square.obj", "v 0 0 0\nv 2 0 0\nv 2 1 0\nv 0 1 0\nl 1 2 3 4 1\n");
    CHECK(load("square.obj", &o, &m, msg, sizeof msg) == SM_OK && msg[0] == 0);
    CHECK(m.dim == 2 && m.element_count == 4 && m.vertex_count == 4 && !strcmp(m.report.source, "lines"));
    CHECK_NEAR(m.report.volume, 2.0, 1e-15);
    sm_mesh_data_free(&m);
    write_file("cw.obj", "v 0 0 0\nv 0 1 0\nv 2 1 0\nv 2 0 0\nl 1 2 3 4 1\n");
    expect("cw.obj", &o, SM_OK, "clockwise");
    write_file("polyline.obj", "v 0 0 0\nv 2 0 0\nv 2 1 0\nl 1 2 3\n");
    expect("polyline.obj", &o, SM_ERR_INVALID, "not a closed outline: 2 open ends");
    /* The cube moved to z in [-0.25, 0.75] and sliced at z = 0: the unit square, counter-clockwise. */
    o.placement.translation[2] = -0.25;
    CHECK(load("cube.stl", &o, &m, msg, sizeof msg) == SM_OK && msg[0] == 0);
    CHECK(!strcmp(m.report.source, "slice") && m.report.misoriented_edges == 0 && m.report.open_edges == 0);
    CHECK_NEAR(m.report.volume, 1.0, 1e-15);
    CHECK(m.lo[0] == 0.0 && m.hi[0] == 1.0 && m.lo[1] == 0.0 && m.hi[1] == 1.0);
    sm_mesh_data_free(&m);
    o.placement.translation[2] = 0.0; /* the bottom face on the plane: a vertex at z = 0 is above */
    CHECK(load("cube.obj", &o, &m, msg, sizeof msg) == SM_ERR_INVALID && strstr(msg, "does not cut"));
    o.placement.translation[2] = -1.0; /* the top face on the plane: the section is the top square */
    CHECK(load("cube.obj", &o, &m, msg, sizeof msg) == SM_OK && m.report.open_edges == 0 && msg[0] == 0);
    CHECK_NEAR(m.report.volume, 1.0, 1e-15);
    sm_mesh_data_free(&m);
}

/* A loaded cube through the library's field: phi at the centre is -1/2, outside +distance. */
static void test_field_of_file(void) {
    sm_mesh_load_opts o = sm_mesh_load_opts_default();
    sm_mesh_data m;
    char msg[256];
    CHECK(load("cube.ply", &o, &m, msg, sizeof msg) == SM_OK);
    sm_mesh_sdf_def d = sm_mesh_sdf_def_default();
    d.vertices = m.vertices, d.vertex_count = m.vertex_count, d.elements = m.elements, d.element_count = m.element_count;
    d.spacing = 0.05, d.band = 0.15;
    sm_mesh_sdf *f = NULL;
    CHECK(sm_mesh_sdf_build(&d, &f, msg, sizeof msg) == SM_OK);
    const double near_face[3] = {0.5, 0.5, 0.93}, outside[3] = {0.5, 1.04, 0.5}, centre[3] = {0.5, 0.5, 0.5};
    if (f) {
        CHECK_NEAR(sm_mesh_sdf_distance(f, near_face, NULL), -0.07, 1e-6);
        CHECK_NEAR(sm_mesh_sdf_distance(f, outside, NULL), 0.04, 1e-6);
        CHECK(sm_mesh_sdf_distance(f, centre, NULL) == -(double)(float)0.15);
    }
    sm_mesh_sdf_destroy(f);
    sm_mesh_data_free(&m);
}

/* The tool meshes shipped in scenes/meshes/ load closed, without warnings, outward, and give a
 * field whose volume (counted on the field's inside nodes) is near the mesh's. */
static void test_shipped_meshes(void) {
    const char *names[4] = {"shovel.obj", "rake.obj", "bowl.obj", "plough.obj"};
    sm_mesh_load_opts o = sm_mesh_load_opts_default();
    o.require_closed = 1;
    for (int i = 0; i < 4; i++) {
        char path[512], msg[512];
        snprintf(path, sizeof path, "%s/scenes/meshes/%s", SM_SOURCE_DIR, names[i]);
        sm_mesh_data m;
        sm_status st = sm_mesh_load(path, &o, &m, msg, sizeof msg);
        CHECK(st == SM_OK && msg[0] == 0);
        if (st != SM_OK) {
            fprintf(stderr, "%s\n", msg);
            continue;
        }
        CHECK(m.report.volume > 0 && m.report.open_edges == 0 && m.report.nonmanifold_edges == 0);
        sm_mesh_sdf_def d = sm_mesh_sdf_def_default();
        d.vertices = m.vertices, d.vertex_count = m.vertex_count, d.elements = m.elements, d.element_count = m.element_count;
        d.spacing = 0.004, d.band = 0.012;
        sm_mesh_sdf *f = NULL;
        CHECK(sm_mesh_sdf_build(&d, &f, msg, sizeof msg) == SM_OK);
        double inside = 0, cell = d.spacing * d.spacing * d.spacing;
        for (double x = m.lo[0] + 0.5 * d.spacing; f && x < m.hi[0]; x += d.spacing)
            for (double y = m.lo[1] + 0.5 * d.spacing; y < m.hi[1]; y += d.spacing)
                for (double z = m.lo[2] + 0.5 * d.spacing; z < m.hi[2]; z += d.spacing) {
                    const double p[3] = {x, y, z};
                    inside += sm_mesh_sdf_distance(f, p, NULL) < 0 ? cell : 0;
                }
        printf("  %s: %zu triangles, volume %.4g m^3, counted inside the field %.4g m^3\n", names[i],
               m.element_count, m.report.volume, inside);
        CHECK(fabs(inside - m.report.volume) < 0.1 * m.report.volume);
        sm_mesh_sdf_destroy(f);
        sm_mesh_data_free(&m);
    }
}

int main(void) {
    snprintf(dir, sizeof dir, "/tmp/sm_mesh_load_XXXXXX");
    if (!mkdtemp(dir)) return 1;
    test_cube_formats();
    test_weld_across_meshes();
    test_bad_files();
    test_placement();
    test_outlines();
    test_field_of_file();
    test_shipped_meshes();
    const char *files[] = {"cube.obj", "cube.stl", "cube.ply", "cube.gltf", "open.obj", "fin.obj", "flipped.obj",
                           "degenerate.obj", "inverted.obj", "lines.obj", "junk.xyz", "square.obj", "cw.obj", "polyline.obj", "split.obj"};
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) unlink(path_of(files[i]));
    rmdir(dir);
    return sm_test_summary("test_mesh_load");
}
