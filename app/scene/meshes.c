/* Mesh shapes of a scene (issue 15; docs/mesh-fields.md, docs/scene-format.md "Mesh shapes"):
 *
 *   { type = "mesh", file = "meshes/bowl.obj", unit = 1, scale = 1 | {sx, sy, sz},
 *     rotation = {w, x, y, z} | axis_angle = {ax, ay, az, degrees}, position = {..},
 *     sign = "auto" | "winding" | "one_sided", resolution = 1, band = 6, inside_out = false }
 *
 * The parser records what the table says (sc_parse_mesh_shape); after validation sc_build_meshes
 * loads each file (relative paths from the scene file's folder) with placement
 * x' = R (scale (unit x)) + position, but builds the field of the mesh moved so that its bounding
 * box is centred on the field's origin (the shape's centre is then position + that centre, so a
 * field is as small as it can be and does not depend on where the mesh is put), and builds the signed distance field with
 * spacing dx / resolution and half width band dx -- or reads it back from
 * <scene dir>/.sandmpm-cache/<mesh hash>-<spacing>-<band>-<sign>.sdf (SANDMPM_MESH_CACHE names
 * another folder; an empty value turns the cache off). Shapes of the same geometry share one field.
 *
 * An animated mesh (a collider's shape only): frames = N, first = 0, fps = F and a file pattern
 * with one %d / %04d; files first .. first + N - 1, each placed the same way and moved by the
 * first frame's bounding box centre, must share the first frame's topology (an error names the
 * frame and its file); sm_mesh_field_create_animated builds every frame (no cache, no sharing).
 *
 * Why band = 6 dx: a grid block (4^d nodes, half diagonal R = 1.5 sqrt(d) dx) is skipped by the
 * collision pass when phi(centre) > L (R + reach), L being the field's Lipschitz bound (up to
 * sqrt(d) at sharp corners); beyond the band phi is clamped to the band, so the band must exceed
 * L R = 4.5 dx for blocks far from a sharp mesh to be skipped at all. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include <lua5.4/lua.h>

#include "app/io/mesh_load.h"
#include "app/scene/scene_internal.h"

static const char *const keys_mesh[] = {"type",   "file",       "unit", "scale", "rotation", "axis_angle",
                                        "position", "sign", "resolution", "band", "inside_out",
                                        "frames", "first", "fps"};
static const char *const sign_names[] = {"auto", "winding", "one_sided"};

/* A string field (required). */
static void file_field(vctx *v, int t, char *out, size_t n) {
    char b[64];
    size_t old = sc_push_key(v, "file");
    int ty = sc_get(v, t, "file");
    if (ty == LUA_TNIL) sc_fail(v, "required: the mesh file (OBJ, STL, PLY, glTF, FBX, ...; relative to the scene file)");
    if (ty != LUA_TSTRING) sc_fail(v, "expected a file name, got %s", sc_got(v->L, -1, b, sizeof b));
    size_t len = 0;
    const char *str = lua_tolstring(v->L, -1, &len);
    if (len == 0 || len >= n || strlen(str) != len) sc_fail(v, "expected a file name (1 to %zu bytes, no NUL)", n - 1);
    memcpy(out, str, len + 1);
    lua_pop(v->L, 1);
    sc_pop_key(v, old);
}

/* The frame-number conversion of an animated mesh's file: one %d or %0Nd (N < 10); its position
 * (-1 if none or malformed), length, width and zero flag. */
static int frame_pattern(const char *file, int *len, int *width, int *zero) {
    const char *p = strchr(file, '%');
    if (!p || strchr(p + 1, '%')) return -1;
    const char *q = p + 1;
    *zero = *q == '0';
    if (*zero) q++;
    *width = 0;
    if (*q >= '1' && *q <= '9') *width = *q++ - '0';
    if (*q != 'd') return -1;
    *len = (int)(q + 1 - p);
    return (int)(p - file);
}

/* The file name of frame number n of an animated mesh's pattern (checked by frame_pattern). */
static void frame_file(const char *pattern, int n, char *out, size_t size) {
    int len = 0, width = 0, zero = 0;
    const int at = frame_pattern(pattern, &len, &width, &zero);
    if (zero) snprintf(out, size, "%.*s%0*d%s", at, pattern, width, n, pattern + at + len);
    else snprintf(out, size, "%.*s%*d%s", at, pattern, width, n, pattern + at + len);
}

/* frames = N (>= 2), first = number of the first file (0), fps (required with frames): a mesh
 * given as N files, file being a pattern with one %d / %04d; only a collider's shape. */
static void parse_animation(vctx *v, int t, scene_mesh *m) {
    int has = 0, len, width, zero;
    const double n = sc_num_field(v, t, "frames", 0, &has, 2.0, 1, 100000.0, 1);
    if (!has) {
        if (sc_get(v, t, "fps") != LUA_TNIL || sc_get(v, t, "first") != LUA_TNIL)
            sc_fail(v, "fps and first belong to an animated mesh: give frames = N (the number of frame files) too");
        lua_pop(v->L, 2);
        return;
    }
    size_t old = sc_push_key(v, "frames");
    if (n != floor(n)) sc_fail(v, "expected a whole number of frame files, got %g", n);
    if (strncmp(v->path, "colliders", 9)) sc_fail(v, "an animated mesh can only be a collider's shape");
    sc_pop_key(v, old);
    m->frames = (int)n;
    m->first = (int)sc_num_field(v, t, "first", 0, NULL, 0.0, 1, 1e8, 1);
    int has_fps = 0;
    m->fps = sc_num_field(v, t, "fps", 0, &has_fps, SC_GT0);
    sc_require(v, has_fps, "fps", "(frames per second of the mesh's file sequence)");
    if (frame_pattern(m->file, &len, &width, &zero) < 0) {
        sc_push_key(v, "file");
        sc_fail(v, "an animated mesh's file must hold one frame number pattern, %%d or %%04d (e.g. \"blob_%%04d.obj\")");
    }
}

void sc_parse_mesh_shape(vctx *v, int t, sm_shape *s) {
    sm_scene *sc = v->s;
    sc_check_keys(v, t, keys_mesh, SC_NKEYS(keys_mesh), "a mesh");
    if (sc->nmesh == sc->mesh_cap) {
        int cap = sc->mesh_cap ? 2 * sc->mesh_cap : 4;
        scene_mesh *q = realloc(sc->meshes, (size_t)cap * sizeof *q);
        if (!q) sc_fail(v, "out of memory");
        sc->meshes = q;
        sc->mesh_cap = cap;
    }
    scene_mesh m;
    memset(&m, 0, sizeof m);
    sc_copy_str(m.key, sizeof m.key, v->path);
    file_field(v, t, m.file, sizeof m.file);
    m.unit = sc_num_field(v, t, "unit", 1.0, NULL, SC_GT0);
    m.scale[0] = m.scale[1] = m.scale[2] = 1.0;
    int ty = sc_get(v, t, "scale");
    lua_pop(v->L, 1);
    if (ty == LUA_TNUMBER) {
        m.scale[0] = m.scale[1] = m.scale[2] = sc_num_field(v, t, "scale", 1.0, NULL, SC_GT0);
    } else if (ty != LUA_TNIL) {
        double sc3[3] = {1, 1, 1};
        sc_vec_field(v, t, "scale", sc3);
        size_t old = sc_push_key(v, "scale");
        for (int a = 0; a < sc->def.dim; a++) sc_range(v, sc3[a], SC_GT0);
        sc_pop_key(v, old);
        for (int a = 0; a < sc->def.dim; a++) m.scale[a] = sc3[a];
    }
    sc_quat_identity(m.rotation);
    sc_rotation_fields_any(v, t, m.rotation); /* 2D: any rotation, to choose the z = 0 slice */
    sc_vec_field(v, t, "position", m.position);
    m.sign = sc_enum_field(v, t, "sign", sign_names, 3, 0) - 1;
    m.resolution = sc_num_field(v, t, "resolution", 1.0, NULL, 0.25, 1, 8.0, 1);
    m.band = sc_num_field(v, t, "band", 6.0, NULL, 2.0, 1, 64.0, 1);
    m.solid = !strncmp(v->path, "objects", 7) || !strncmp(v->path, "emitters", 8);
    parse_animation(v, t, &m);
    sc->meshes[sc->nmesh++] = m;
    s->kind = SM_SHAPE_MESH;
    s->mesh = NULL;
    memcpy(s->center, m.position, sizeof s->center);
}

/* The shape a mesh key names ("objects[i].shape", "objects[i].clip", "emitters[i].shape",
 * "colliders[i].shape", "colliders[i].shapes[j]"), or NULL. */
static sm_shape *shape_at(sm_scene *s, const char *key) {
    int i = 0, j = 0, n = 0;
    if (sscanf(key, "objects[%d].shape%n", &i, &n) == 1 && key[n] == 0 && i >= 1 && i <= s->nobj) return &s->objs[i - 1].shape;
    if (sscanf(key, "objects[%d].clip%n", &i, &n) == 1 && key[n] == 0 && i >= 1 && i <= s->nobj) return &s->objs[i - 1].clip;
    if (sscanf(key, "emitters[%d].shape%n", &i, &n) == 1 && key[n] == 0 && i >= 1 && i <= s->nemit) return &s->emits[i - 1].shape;
    if (sscanf(key, "colliders[%d].shapes[%d]%n", &i, &j, &n) == 2 && key[n] == 0 && i >= 1 && i <= s->ncol && j >= 1 &&
        j <= s->cols[i - 1].def.shape_count)
        return &s->cols[i - 1].def.shapes[j - 1];
    if (sscanf(key, "colliders[%d].shape%n", &i, &n) == 1 && key[n] == 0 && i >= 1 && i <= s->ncol)
        return &s->cols[i - 1].def.shapes[0];
    return NULL;
}

/* The file's path: as written if absolute, else next to the scene file. */
static void resolve_path(const sm_scene *s, const char *file, char *out, size_t n) {
    const char *slash = strrchr(s->path, '/');
    if (file[0] == '/' || !slash) snprintf(out, n, "%s", file);
    else snprintf(out, n, "%.*s/%s", (int)(slash - s->path), s->path, file);
}

/* The cache file of a field, "" if the cache is off. */
static void cache_path(const sm_scene *s, uint64_t hash, double h, double band, int sign, char *out, size_t n) {
    const char *env = getenv("SANDMPM_MESH_CACHE");
    char dir[1100];
    if (env) snprintf(dir, sizeof dir, "%s", env);
    else resolve_path(s, ".sandmpm-cache", dir, sizeof dir);
    if (!dir[0]) {
        out[0] = 0;
        return;
    }
    snprintf(out, n, "%s/%016llx-%.9g-%.9g-%s.sdf", dir, (unsigned long long)hash, h, band,
             sign == SM_MESH_SIGN_WINDING ? "winding" : "one_sided");
}

/* A field from the cache file, checked against what it must be; NULL if absent or unusable. */
static sm_mesh_field *cache_read(const char *path, const sm_mesh_data *md, double h, double band) {
    if (!path[0]) return NULL;
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    sm_mesh_field *field = NULL;
    char *buf = NULL;
    long len = -1;
    if (fseek(f, 0, SEEK_END) == 0 && (len = ftell(f)) > 0 && fseek(f, 0, SEEK_SET) == 0 && (buf = malloc((size_t)len)) &&
        fread(buf, 1, (size_t)len, f) == (size_t)len)
        sm_mesh_field_deserialize(buf, (size_t)len, &field, NULL, 0);
    free(buf);
    fclose(f);
    if (field) {
        const sm_mesh_field_stats *st = sm_mesh_field_get_stats(field);
        if (st->dim != md->dim || st->elements != md->element_count || st->vertices != md->vertex_count ||
            st->spacing != h || st->band != band) {
            sm_mesh_field_release(field);
            field = NULL;
        }
    }
    return field;
}

/* Writes the field to the cache (best effort: a temporary file renamed into place). */
static void cache_write(const char *path, const sm_mesh_field *field) {
    if (!path[0]) return;
    char dir[1100];
    snprintf(dir, sizeof dir, "%s", path);
    char *slash = strrchr(dir, '/');
    if (slash) {
        *slash = 0;
        if (mkdir(dir, 0777) != 0 && errno != EEXIST) return;
    }
    size_t n = sm_mesh_field_serialize(field, NULL, 0);
    char *buf = malloc(n);
    if (!buf) return;
    sm_mesh_field_serialize(field, buf, n);
    char tmp[1200];
    snprintf(tmp, sizeof tmp, "%s.tmp%ld", path, (long)getpid());
    FILE *f = fopen(tmp, "wb");
    int ok = f && fwrite(buf, 1, n, f) == n;
    if (f && fclose(f) != 0) ok = 0;
    if (ok) ok = rename(tmp, path) == 0;
    if (!ok) remove(tmp);
    free(buf);
}

static double now_seconds(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Moves md's vertices so that their bounding box is centred on the origin; the centre in c. */
static void centre_mesh(sm_mesh_data *md, double c[3]) {
    for (int a = 0; a < 3; a++) c[a] = 0.5 * (md->lo[a] + md->hi[a]);
    if (md->dim == 2) c[2] = 0;
    for (size_t i = 0; i < md->vertex_count; i++)
        for (int a = 0; a < 3; a++) md->vertices[3 * i + a] -= c[a];
}

/* An earlier mesh of the scene with the same field, or NULL. */
static sm_mesh_field *shared_field(const sm_scene *s, int upto, uint64_t hash, double h, double band, int sign,
                                   const double c[3]);

/* Frame f's topology against frame 0's: "" if the same, else why not. */
static void same_topology(const sm_mesh_data *a, const sm_mesh_data *b, char *msg, size_t n) {
    msg[0] = 0;
    if (a->vertex_count != b->vertex_count || a->element_count != b->element_count)
        snprintf(msg, n, "%zu vertices and %zu elements, the first frame %zu and %zu", b->vertex_count, b->element_count,
                 a->vertex_count, a->element_count);
    else if (memcmp(a->elements, b->elements, a->element_count * (size_t)a->dim * sizeof(uint32_t)))
        snprintf(msg, n, "its elements use other vertices than the first frame's");
}

/* Loads the frame files of animated mesh m (placed like a static one; every frame moved by the
 * first frame's bounding box centre) and makes the animated field (not cached, not shared). */
static sm_status make_anim_field(sm_scene *s, scene_mesh *m, sm_shape *sh, const char *at, const char *key,
                                 const sm_mesh_load_opts *o, char *err, size_t errlen) {
    sm_mesh_data *md = calloc((size_t)m->frames, sizeof *md);
    sm_mesh_field_def *d = calloc((size_t)m->frames, sizeof *d);
    char name[1100], path[2300], msg[1024];
    double c[3] = {0, 0, 0}, t0 = now_seconds();
    sm_status st = md && d ? SM_OK : sc_fail_msg(err, errlen, SM_ERR_NOMEM, "out of memory");
    for (int f = 0; f < m->frames && st == SM_OK; f++) {
        frame_file(m->file, m->first + f, name, sizeof name);
        resolve_path(s, name, path, sizeof path);
        st = sm_mesh_load(path, o, &md[f], msg, sizeof msg);
        if (st != SM_OK) {
            st = sc_fail_msg(err, errlen, st == SM_ERR_NOMEM ? SM_ERR_NOMEM : SM_ERR_INVALID, "%s: %s: frame %d: %s", at, key,
                             m->first + f, msg);
            break;
        }
        if (msg[0] && f == 0) sc_warn_msg(s, "%s: %s: %s", at, key, msg);
        if (f == 0) centre_mesh(&md[0], c);
        else {
            for (size_t i = 0; i < md[f].vertex_count; i++)
                for (int a = 0; a < 3; a++) md[f].vertices[3 * i + a] -= c[a];
            same_topology(&md[0], &md[f], msg, sizeof msg);
            if (msg[0])
                st = sc_fail_msg(err, errlen, SM_ERR_INVALID, "%s: %s: frame %d (%s): not the first frame's topology: %s", at,
                                 key, m->first + f, path, msg);
        }
    }
    const int sign = st == SM_OK && m->sign < 0 ? (md[0].report.open_edges > 0 ? SM_MESH_SIGN_ONE_SIDED : SM_MESH_SIGN_WINDING)
                                                : m->sign;
    for (int f = 0; f < m->frames && st == SM_OK; f++) {
        d[f] = sm_mesh_field_def_default();
        d[f].dim = md[f].dim;
        d[f].vertices = md[f].vertices, d[f].vertex_count = md[f].vertex_count;
        d[f].elements = md[f].elements, d[f].element_count = md[f].element_count;
        d[f].spacing = s->def.dx / m->resolution, d[f].band = m->band * s->def.dx;
        d[f].sign = (sm_mesh_sign)sign;
        d[f].threads = s->def.threads;
    }
    sm_mesh_field *field = NULL;
    if (st == SM_OK && (st = sm_mesh_field_create_animated(d, m->frames, m->fps, &field, msg, sizeof msg)) != SM_OK)
        st = sc_fail_msg(err, errlen, st == SM_ERR_NOMEM ? SM_ERR_NOMEM : SM_ERR_INVALID, "%s: %s: %s: %s", at, key, m->file, msg);
    if (st == SM_OK) {
        m->triangles = md[0].element_count;
        m->hash = md[0].hash;
        m->sign_used = sign;
        memcpy(m->centre, c, sizeof c);
        m->field = field;
        m->seconds = now_seconds() - t0;
        for (int a = 0; a < 3; a++) sh->center[a] = m->position[a] + c[a];
        sh->mesh = field;
    }
    for (int f = 0; md && f < m->frames; f++) sm_mesh_data_free(&md[f]);
    free(md);
    free(d);
    return st;
}

/* Loads mesh m (the shape sh) and makes its field. */
static sm_status make_field(sm_scene *s, int idx, sm_shape *sh, char *err, size_t errlen) {
    scene_mesh *m = &s->meshes[idx];
    char path[1100], key[128], at[1200], msg[1024];
    resolve_path(s, m->file, path, sizeof path);
    snprintf(key, sizeof key, "%s.file", m->key);
    sc_where(s, key, at, sizeof at);
    sm_mesh_load_opts o = sm_mesh_load_opts_default();
    o.dim = s->def.dim;
    o.require_closed = m->solid;
    o.placement.unit = m->unit;
    memcpy(o.placement.scale, m->scale, sizeof m->scale);
    memcpy(o.placement.rotation, m->rotation, sizeof m->rotation);
    if (m->frames > 0) return make_anim_field(s, m, sh, at, key, &o, err, errlen);
    sm_mesh_data md;
    double t0 = now_seconds();
    sm_status st = sm_mesh_load(path, &o, &md, msg, sizeof msg);
    if (st != SM_OK)
        return sc_fail_msg(err, errlen, st == SM_ERR_NOMEM ? SM_ERR_NOMEM : SM_ERR_INVALID, "%s: %s: %s", at, key, msg);
    if (msg[0]) sc_warn_msg(s, "%s: %s: %s", at, key, msg);
    int sign = m->sign >= 0 ? m->sign : (md.report.open_edges > 0 ? SM_MESH_SIGN_ONE_SIDED : SM_MESH_SIGN_WINDING);
    double c[3], h = s->def.dx / m->resolution, band = m->band * s->def.dx;
    centre_mesh(&md, c);
    m->triangles = md.element_count;
    m->hash = md.hash;
    m->sign_used = sign;
    memcpy(m->centre, c, sizeof c);
    sm_mesh_field *f = shared_field(s, idx, md.hash, h, band, sign, c);
    char cpath[1300];
    cache_path(s, md.hash, h, band, sign, cpath, sizeof cpath);
    if (f) m->cached = 2;
    else if ((f = cache_read(cpath, &md, h, band)) != NULL) m->cached = 1;
    if (!f) {
        sm_mesh_field_def d = sm_mesh_field_def_default();
        d.dim = md.dim;
        d.vertices = md.vertices;
        d.vertex_count = md.vertex_count;
        d.elements = md.elements;
        d.element_count = md.element_count;
        d.spacing = h;
        d.band = band;
        d.sign = (sm_mesh_sign)sign;
        d.threads = s->def.threads;
        st = sm_mesh_field_create(&d, &f, msg, sizeof msg);
        if (st != SM_OK) {
            sm_mesh_data_free(&md);
            return sc_fail_msg(err, errlen, st == SM_ERR_NOMEM ? SM_ERR_NOMEM : SM_ERR_INVALID, "%s: %s: %s: %s", at, key,
                               path, msg);
        }
        cache_write(cpath, f);
    }
    sm_mesh_data_free(&md);
    m->field = f;
    m->seconds = now_seconds() - t0;
    /* The mesh frame's origin is the bounding box centre, rotated with the mesh: the placement's
     * rotation is already in the vertices, so the shape's own rotation stays the identity. */
    for (int a = 0; a < 3; a++) sh->center[a] = m->position[a] + c[a];
    sh->mesh = f;
    return SM_OK;
}

static sm_mesh_field *shared_field(const sm_scene *s, int upto, uint64_t hash, double h, double band, int sign,
                                   const double c[3]) {
    for (int i = 0; i < upto; i++) {
        const scene_mesh *o = &s->meshes[i];
        if (!o->field || o->frames || o->hash != hash || o->sign_used != sign) continue;
        const sm_mesh_field_stats *st = sm_mesh_field_get_stats(o->field);
        if (st->spacing != h || st->band != band || memcmp(o->centre, c, sizeof o->centre)) continue;
        return sm_mesh_field_retain(o->field);
    }
    return NULL;
}

sm_status sc_build_meshes(sm_scene *s, char *err, size_t errlen) {
    for (int i = 0; i < s->nmesh; i++) {
        sm_shape *sh = shape_at(s, s->meshes[i].key);
        if (!sh) return sc_fail_msg(err, errlen, SM_ERR_INVALID, "%s: %s: a mesh shape here is not supported", s->path,
                                    s->meshes[i].key);
        sm_status st = make_field(s, i, sh, err, errlen);
        if (st != SM_OK) return st;
    }
    return SM_OK;
}

void sc_free_meshes(sm_scene *s) {
    for (int i = 0; i < s->nmesh; i++) sm_mesh_field_release(s->meshes[i].field);
    free(s->meshes);
    s->meshes = NULL;
    s->nmesh = s->mesh_cap = 0;
}

int sm_scene_mesh_count(const sm_scene *s) { return s ? s->nmesh : 0; }

int sm_scene_mesh(const sm_scene *s, int i, sm_scene_mesh_info *out) {
    if (!s || i < 0 || i >= s->nmesh || !s->meshes[i].field) return 0;
    const scene_mesh *m = &s->meshes[i];
    out->key = m->key;
    out->file = m->file;
    out->triangles = m->triangles;
    out->field = sm_mesh_field_get_stats(m->field);
    out->sign = m->sign_used == SM_MESH_SIGN_WINDING ? "winding" : "one_sided";
    out->source = m->cached == 2 ? "shared" : m->cached ? "cache" : "built";
    out->seconds = m->seconds;
    out->frames = m->frames;
    out->fps = m->fps;
    return 1;
}
