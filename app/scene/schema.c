/* The scene schema's helpers: key paths and messages ("file:line: key.path: problem", with
 * did-you-mean suggestions), typed fields with their ranges, the one list parser, and the mapping
 * of the library's check messages onto scene keys. The parsers (parse_scene.c, parse_items.c)
 * run inside lua_pcall: sc_fail raises a Lua error with the finished message, so nothing is
 * allocated outside the scene struct (which sm_scene_destroy frees). */
#define _POSIX_C_SOURCE 200809L
#include <ctype.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include <lua5.4/lauxlib.h>
#include <lua5.4/lua.h>

#include "app/scene/scene_internal.h"

void sc_copy_str(char *dst, size_t n, const char *src) {
    if (!dst || n == 0) return;
    snprintf(dst, n, "%s", src ? src : "");
}

char *sc_dup_str(const char *s) {
    size_t n = strlen(s) + 1;
    char *p = malloc(n);
    if (p) memcpy(p, s, n);
    return p;
}

/* A number for a message: %g, with NaN and infinities spelled out. */
const char *sc_fmt_num(char buf[32], double x) {
    if (isnan(x)) return "NaN";
    if (isinf(x)) return x > 0 ? "inf" : "-inf";
    snprintf(buf, 32, "%g", x);
    return buf;
}

/* Optimal string alignment distance, case-insensitive (strings up to 63 characters). */
static int edit_distance(const char *a, const char *b) {
    size_t n = strlen(a), m = strlen(b);
    if (n > 63 || m > 63) return 1000;
    int d[64][64];
    for (size_t i = 0; i <= n; i++) d[i][0] = (int)i;
    for (size_t j = 0; j <= m; j++) d[0][j] = (int)j;
    for (size_t i = 1; i <= n; i++)
        for (size_t j = 1; j <= m; j++) {
            int ca = tolower((unsigned char)a[i - 1]), cb = tolower((unsigned char)b[j - 1]);
            int cost = ca != cb;
            int v = d[i - 1][j] + 1;
            if (d[i][j - 1] + 1 < v) v = d[i][j - 1] + 1;
            if (d[i - 1][j - 1] + cost < v) v = d[i - 1][j - 1] + cost;
            if (i > 1 && j > 1 && ca == tolower((unsigned char)b[j - 2]) && tolower((unsigned char)a[i - 2]) == cb &&
                d[i - 2][j - 2] + 1 < v)
                v = d[i - 2][j - 2] + 1;
            d[i][j] = v;
        }
    return d[n][m];
}

/* The candidate closest to word, or NULL if none is close enough to be a likely typo. */
const char *sc_closest(const char *word, const char *const *cands, int n) {
    size_t len = strlen(word);
    int limit = len <= 3 ? 1 : len <= 6 ? 2 : 3, best = 1000;
    const char *pick = NULL;
    for (int i = 0; i < n; i++) {
        int d = edit_distance(word, cands[i]);
        if (d < best) {
            best = d;
            pick = cands[i];
        }
    }
    return best <= limit ? pick : NULL;
}

static int is_ident_char(int c) { return isalnum((unsigned char)c) || c == '_'; }

int sc_is_identifier(const char *s) {
    if (!s[0] || isdigit((unsigned char)s[0])) return 0;
    for (; *s; s++)
        if (!is_ident_char(*s)) return 0;
    return 1;
}

/* The line of `key =` in the source if it occurs on exactly one line (outside comments), else 0.
 * Only a hint for messages: table fields carry no line numbers once the chunk has run. */
static int key_line(const char *src, const char *key) {
    if (!src || !key[0]) return 0;
    size_t kl = strlen(key);
    int line = 1, found = 0, nfound = 0, in_comment = 0;
    const char *p = src;
    for (;;) {
        const char *nl = strchr(p, '\n');
        const char *end = nl ? nl : p + strlen(p);
        const char *q = p;
        int hit = 0;
        while (q < end) {
            if (in_comment) {
                if (q + 1 < end && q[0] == ']' && q[1] == ']') {
                    in_comment = 0;
                    q += 2;
                } else {
                    q++;
                }
                continue;
            }
            if (q + 1 < end && q[0] == '-' && q[1] == '-') {
                if (q + 3 < end && q[2] == '[' && q[3] == '[') {
                    in_comment = 1;
                    q += 4;
                    continue;
                }
                break; /* line comment */
            }
            if ((size_t)(end - q) >= kl && memcmp(q, key, kl) == 0 && (q == p || !is_ident_char(q[-1])) &&
                (q + kl == end || !is_ident_char(q[kl]))) {
                const char *r = q + kl;
                while (r < end && (*r == ' ' || *r == '\t')) r++;
                if (r < end && *r == '=' && (r + 1 == end || r[1] != '=')) hit = 1;
            }
            q++;
        }
        if (hit) {
            nfound++;
            found = line;
        }
        if (!nl) break;
        p = nl + 1;
        line++;
    }
    return nfound == 1 ? found : 0;
}

sm_status sc_fail_msg(char *err, size_t errlen, sm_status code, const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    if (err && errlen) vsnprintf(err, errlen, fmt, ap);
    va_end(ap);
    return code;
}

size_t sc_push_key(vctx *v, const char *key) {
    size_t old = v->plen;
    if (sc_is_identifier(key)) snprintf(v->path + old, sizeof v->path - old, old ? ".%s" : "%s", key);
    else snprintf(v->path + old, sizeof v->path - old, "[\"%s\"]", key);
    v->plen = strlen(v->path);
    return old;
}

size_t sc_push_index(vctx *v, long long i) {
    size_t old = v->plen;
    snprintf(v->path + old, sizeof v->path - old, "[%lld]", i);
    v->plen = strlen(v->path);
    return old;
}

void sc_pop_key(vctx *v, size_t old) {
    v->plen = old;
    v->path[old] = 0;
}

/* The last named component of the current key path ("colliders[2].shapes[1].center[3]" -> "center"). */
static void last_name(const vctx *v, char *out, size_t n) {
    size_t e = v->plen;
    while (e > 0 && v->path[e - 1] == ']') { /* strip [..] suffixes */
        size_t b = e - 1;
        while (b > 0 && v->path[b] != '[') b--;
        if (b + 1 < e && v->path[b + 1] == '"') { /* ["name"] */
            size_t len = e - b - 4 < n - 1 ? e - b - 4 : n - 1;
            memcpy(out, v->path + b + 2, len);
            out[len] = 0;
            return;
        }
        e = b;
    }
    size_t b = e;
    while (b > 0 && v->path[b - 1] != '.' && v->path[b - 1] != ']') b--;
    size_t len = e - b < n - 1 ? e - b : n - 1;
    memcpy(out, v->path + b, len);
    out[len] = 0;
}

/* "PATH:LINE: key.path: msg" for the current key (the line found by the constructors' walk, or the
 * one line with `name =`). */
static void located(vctx *v, const char *msg, char *out, size_t n) {
    char name[128];
    int line = v->plen ? sc_locate(v->s->source, v->s->source_len, v->path) : 0;
    if (line <= 0) {
        last_name(v, name, sizeof name);
        line = key_line(v->s->source, name);
    }
    char where[1100];
    if (line > 0) snprintf(where, sizeof where, "%s:%d", v->s->path, line);
    else snprintf(where, sizeof where, "%s", v->s->path);
    if (v->plen) snprintf(out, n, "%s: %s: %s", where, v->path, msg);
    else snprintf(out, n, "%s: %s", where, msg);
}

void sc_fail(vctx *v, const char *fmt, ...) {
    char msg[768], out[2400];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    located(v, msg, out, sizeof out);
    lua_pushstring(v->L, out);
    lua_error(v->L);
    abort(); /* not reached */
}

void sc_warn(vctx *v, const char *fmt, ...) {
    char msg[512], out[2400];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    located(v, msg, out, sizeof out);
    sc_warn_msg(v->s, "%s", out);
}

void sc_warn_msg(sm_scene *s, const char *fmt, ...) {
    if (s->nwarn < SC_MAX_WARN) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(s->warn[s->nwarn], SC_WARN_LEN, fmt, ap);
        va_end(ap);
    }
    s->nwarn++;
}

/* Describes the value at idx for "got ...". */
const char *sc_got(lua_State *L, int idx, char *buf, size_t n) {
    if (lua_type(L, idx) == LUA_TSTRING) {
        const char *str = lua_tostring(L, idx);
        if (strlen(str) <= 40) snprintf(buf, n, "string \"%s\"", str);
        else snprintf(buf, n, "string");
        return buf;
    }
    return luaL_typename(L, idx);
}

/* Pushes t[key] (raw access: scene tables are plain data) and returns its type. */
int sc_get(vctx *v, int t, const char *key) {
    lua_pushstring(v->L, key);
    return lua_rawget(v->L, t);
}

void sc_check_keys(vctx *v, int t, const char *const *allowed, int n, const char *what) {
    lua_State *L = v->L;
    lua_pushnil(L);
    while (lua_next(L, t)) {
        lua_pop(L, 1);
        if (lua_type(L, -1) != LUA_TSTRING) {
            char kb[64];
            if (lua_isinteger(L, -1)) snprintf(kb, sizeof kb, "[%lld]", (long long)lua_tointeger(L, -1));
            else snprintf(kb, sizeof kb, "a %s key", luaL_typename(L, -1));
            sc_fail(v, "unexpected entry %s: %s has named keys (key = value), not a list", kb, what);
        }
        const char *k = lua_tostring(L, -1);
        int ok = 0;
        for (int i = 0; i < n && !ok; i++) ok = !strcmp(k, allowed[i]);
        if (ok) continue;
        sc_push_key(v, k);
        if (v->plen == strlen(k) && !strcmp(k, "threads"))
            sc_fail(v, "not a scene key: the number of threads is a command-line option (--threads)");
        const char *sug = sc_closest(k, allowed, n);
        if (sug) sc_fail(v, "unknown key (did you mean \"%s\"?)", sug);
        char list[512] = "";
        size_t len = 0;
        for (int i = 0; i < n && len < sizeof list - 64; i++)
            len += (size_t)snprintf(list + len, sizeof list - len, "%s%s", i ? ", " : "", allowed[i]);
        sc_fail(v, "unknown key (%s takes: %s)", what, list);
    }
}

/* The number of entries of the list at t, which must be a sequence 1..n. */
int sc_list_len(vctx *v, int t, const char *example) {
    lua_State *L = v->L;
    lua_Unsigned n = lua_rawlen(L, t);
    lua_Unsigned count = 0;
    lua_pushnil(L);
    while (lua_next(L, t)) {
        lua_pop(L, 1);
        int isnum;
        lua_Integer i = lua_tointegerx(L, -1, &isnum);
        if (lua_type(L, -1) != LUA_TNUMBER || !isnum || i < 1 || (lua_Unsigned)i > n) {
            char buf[96];
            sc_fail(v, "expected a list %s, found key %s", example,
                  lua_type(L, -1) == LUA_TSTRING ? (snprintf(buf, sizeof buf, "\"%s\"", lua_tostring(L, -1)), buf)
                                                 : luaL_typename(L, -1));
        }
        count++;
    }
    if (count != n) sc_fail(v, "expected a list %s without holes", example);
    if (n > SCENE_MAX_LIST) sc_fail(v, "too many entries (%llu)", (unsigned long long)n);
    return (int)n;
}

/* The value on top must be a finite number. */
double sc_num_top(vctx *v) {
    char b[64], nb[32];
    if (lua_type(v->L, -1) != LUA_TNUMBER) sc_fail(v, "expected a number, got %s", sc_got(v->L, -1, b, sizeof b));
    double x = (double)lua_tonumber(v->L, -1);
    if (!isfinite(x)) sc_fail(v, "must be a finite number, got %s", sc_fmt_num(nb, x));
    return x;
}

/* x in the interval (lo, hi), each end open or closed (an infinite end is no bound). */
void sc_range(vctx *v, double x, double lo, int lo_closed, double hi, int hi_closed) {
    char a[32], b[32], c[32];
    int ok_lo = isinf(lo) || (lo_closed ? x >= lo : x > lo);
    int ok_hi = isinf(hi) || (hi_closed ? x <= hi : x < hi);
    if (ok_lo && ok_hi) return;
    if (isinf(hi)) sc_fail(v, "must be %s %s, got %s", lo_closed ? ">=" : ">", sc_fmt_num(a, lo), sc_fmt_num(c, x));
    if (isinf(lo)) sc_fail(v, "must be %s %s, got %s", hi_closed ? "<=" : "<", sc_fmt_num(b, hi), sc_fmt_num(c, x));
    sc_fail(v, "must be in %c%s, %s%c, got %s", lo_closed ? '[' : '(', sc_fmt_num(a, lo), sc_fmt_num(b, hi),
          hi_closed ? ']' : ')', sc_fmt_num(c, x));
}

/* Opens t[key]: returns LUA_TNIL (nothing pushed) if it is absent, else pushes the value and the
 * key onto the path (its old length in *old) and returns the value's type; field_close undoes both. */
static int field_open(vctx *v, int t, const char *key, size_t *old) {
    int ty = sc_get(v, t, key);
    if (ty == LUA_TNIL) lua_pop(v->L, 1);
    else *old = sc_push_key(v, key);
    return ty;
}

static void field_close(vctx *v, size_t old) {
    sc_pop_key(v, old);
    lua_pop(v->L, 1);
}

/* t[key] as a number in a range; def if absent (*present = 0). */
double sc_num_field(vctx *v, int t, const char *key, double def, int *present, double lo, int lo_closed, double hi,
                    int hi_closed) {
    size_t old = 0;
    int ty = field_open(v, t, key, &old);
    if (present) *present = ty != LUA_TNIL;
    if (ty == LUA_TNIL) return def;
    double x = sc_num_top(v);
    sc_range(v, x, lo, lo_closed, hi, hi_closed);
    field_close(v, old);
    return x;
}

long long sc_int_field(vctx *v, int t, const char *key, long long def, int *present, long long lo, long long hi) {
    char b[64];
    size_t old = 0;
    int ty = field_open(v, t, key, &old);
    if (present) *present = ty != LUA_TNIL;
    if (ty == LUA_TNIL) return def;
    if (ty != LUA_TNUMBER) sc_fail(v, "expected a whole number, got %s", sc_got(v->L, -1, b, sizeof b));
    int isint;
    lua_Integer i = lua_tointegerx(v->L, -1, &isint);
    if (!isint) {
        char nb[32];
        sc_fail(v, "expected a whole number, got %s", sc_fmt_num(nb, (double)lua_tonumber(v->L, -1)));
    }
    if (i < lo || i > hi) sc_fail(v, "must be in %lld .. %lld, got %lld", lo, hi, (long long)i);
    field_close(v, old);
    return (long long)i;
}

int sc_bool_field(vctx *v, int t, const char *key, int def) {
    char b[64];
    size_t old = 0;
    int ty = field_open(v, t, key, &old);
    if (ty == LUA_TNIL) return def;
    if (ty != LUA_TBOOLEAN) sc_fail(v, "expected true or false, got %s", sc_got(v->L, -1, b, sizeof b));
    int r = lua_toboolean(v->L, -1);
    field_close(v, old);
    return r;
}

/* Other words for the enum values ({word, value} pairs), for suggestions: "plane" -> "halfspace". */
static const char *const enum_aliases[] = {
    "plane", "halfspace", "half_space", "halfspace", "half-space", "halfspace", "ground", "halfspace",
    "floor", "halfspace", "wall", "halfspace", "cube", "box", "cuboid", "box", "rectangle", "box", "rect", "box",
    "square", "box", "ball", "sphere", "disk", "sphere", "disc", "sphere", "circle", "sphere", "tube", "cylinder",
    "rod", "cylinder", "noslip", "sticky", "no-slip", "sticky", "no_slip", "sticky", "stick", "sticky",
    "slide", "slip", "free", "separate", "rigid", "elastic", "solid", "elastic", "granular", "sand", NULL};

/* A likely meant value among names for word: a close spelling or another word for it; NULL if none. */
static const char *enum_suggestion(const char *word, const char *const *names, int n) {
    const char *sug = sc_closest(word, names, n);
    for (int i = 0; !sug && enum_aliases[i]; i += 2)
        if (!strcasecmp(word, enum_aliases[i]))
            for (int k = 0; k < n; k++)
                if (!strcmp(enum_aliases[i + 1], names[k])) sug = names[k];
    return sug;
}

int sc_enum_field(vctx *v, int t, const char *key, const char *const *names, int n, int def) {
    char b[64], list[256] = "";
    size_t old = 0;
    int ty = field_open(v, t, key, &old);
    if (ty == LUA_TNIL) return def;
    size_t len = 0;
    for (int i = 0; i < n; i++)
        len += (size_t)snprintf(list + len, sizeof list - len, "%s\"%s\"", i == 0 ? "" : i == n - 1 ? " or " : ", ",
                                names[i]);
    if (ty != LUA_TSTRING) sc_fail(v, "expected %s, got %s", list, sc_got(v->L, -1, b, sizeof b));
    const char *str = lua_tostring(v->L, -1);
    for (int i = 0; i < n; i++)
        if (!strcmp(str, names[i])) {
            field_close(v, old);
            return i;
        }
    const char *sug = enum_suggestion(str, names, n);
    if (sug) sc_fail(v, "expected %s, got \"%s\" (did you mean \"%s\"?)", list, str, sug);
    sc_fail(v, "expected %s, got \"%s\"", list, str);
}

/* The value on top as a vector of exactly n finite numbers; label like "{x, y, z}". */
void sc_vec_top(vctx *v, int n, const char *label, double *out) {
    lua_State *L = v->L;
    char b[64];
    int t = lua_gettop(L);
    if (lua_type(L, t) != LUA_TTABLE) sc_fail(v, "expected %s, got %s", label, sc_got(L, t, b, sizeof b));
    lua_pushnil(L);
    while (lua_next(L, t)) {
        lua_pop(L, 1);
        int isnum;
        lua_Integer i = lua_tointegerx(L, -1, &isnum);
        if (lua_type(L, -1) != LUA_TNUMBER || !isnum || i < 1 || i > n) {
            if (lua_type(L, -1) == LUA_TSTRING)
                sc_fail(v, "expected %s (%d numbers), found key \"%s\"", label, n, lua_tostring(L, -1));
            sc_fail(v, "expected %s: %d numbers, got %llu", label, n, (unsigned long long)lua_rawlen(L, t));
        }
    }
    if (lua_rawlen(L, t) != (lua_Unsigned)n)
        sc_fail(v, "expected %s: %d numbers, got %llu", label, n, (unsigned long long)lua_rawlen(L, t));
    for (int i = 0; i < n; i++) {
        size_t old = sc_push_index(v, i + 1);
        lua_rawgeti(L, t, i + 1);
        out[i] = sc_num_top(v);
        lua_pop(L, 1);
        sc_pop_key(v, old);
    }
}

const char *sc_vec_label(int dim) { return dim == 2 ? "{x, y}" : "{x, y, z}"; }

/* t[key] as a dim-vector (z = 0 in 2D); returns whether present (out untouched if absent). */
int sc_vec_field(vctx *v, int t, const char *key, double out[3]) {
    int dim = v->s->def.dim;
    size_t old = 0;
    if (field_open(v, t, key, &old) == LUA_TNIL) return 0;
    double tmp[3] = {0, 0, 0};
    sc_vec_top(v, dim, sc_vec_label(dim), tmp);
    memcpy(out, tmp, sizeof tmp);
    field_close(v, old);
    return 1;
}

/* angular_velocity: a number (about z) in 2D, a 3-vector in 3D. */
int sc_angvel_field(vctx *v, int t, const char *key, double out[3]) {
    if (v->s->def.dim == 3) return sc_vec_field(v, t, key, out);
    size_t old = 0;
    if (field_open(v, t, key, &old) == LUA_TNIL) return 0;
    int ty = lua_type(v->L, -1);
    char b[64];
    if (ty != LUA_TNUMBER) sc_fail(v, "expected a number (rad/s about z, in 2D), got %s", sc_got(v->L, -1, b, sizeof b));
    out[0] = out[1] = 0;
    out[2] = sc_num_top(v);
    field_close(v, old);
    return 1;
}

static void check_rotation_2d(vctx *v, const double q[4]) {
    if (v->s->def.dim == 2 && (fabs(q[1]) > 1e-9 || fabs(q[2]) > 1e-9))
        sc_fail(v, "in 2D a rotation must be about z (use axis_angle = {0, 0, 1, degrees})");
}

/* rotation = {w,x,y,z} | axis_angle = {ax, ay, az, degrees} in table t; identity if neither. */
/* rotation | axis_angle; in 2D about z only if plane_only. */
static int rotation_fields(vctx *v, int t, double q[4], int plane_only) {
    int has_q = sc_get(v, t, "rotation") != LUA_TNIL;
    lua_pop(v->L, 1);
    int has_aa = sc_get(v, t, "axis_angle") != LUA_TNIL;
    lua_pop(v->L, 1);
    sc_quat_identity(q);
    if (has_q && has_aa) {
        size_t old = sc_push_key(v, "axis_angle");
        sc_fail(v, "give rotation or axis_angle, not both");
        sc_pop_key(v, old);
    }
    if (has_q) {
        size_t old = sc_push_key(v, "rotation");
        sc_get(v, t, "rotation");
        sc_vec_top(v, 4, "{w, x, y, z} (a unit quaternion)", q);
        lua_pop(v->L, 1);
        double n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
        if (!(fabs(n - 1) < 1e-3)) {
            char nb[32];
            sc_fail(v,
                  "must be a unit quaternion {w, x, y, z}, |q| = %s (for an axis and an angle use "
                  "axis_angle = {ax, ay, az, degrees})",
                  sc_fmt_num(nb, n));
        }
        for (int k = 0; k < 4; k++) q[k] /= n;
        if (plane_only) check_rotation_2d(v, q);
        sc_pop_key(v, old);
    } else if (has_aa) {
        size_t old = sc_push_key(v, "axis_angle");
        double aa[4];
        sc_get(v, t, "axis_angle");
        sc_vec_top(v, 4, "{ax, ay, az, degrees}", aa);
        lua_pop(v->L, 1);
        if (!sc_quat_axis_angle(aa[0], aa[1], aa[2], aa[3], q)) sc_fail(v, "the axis must be non-zero");
        if (plane_only) check_rotation_2d(v, q);
        sc_pop_key(v, old);
    }
    return has_q || has_aa;
}

int sc_rotation_fields(vctx *v, int t, double q[4]) { return rotation_fields(v, t, q, 1); }
int sc_rotation_fields_any(vctx *v, int t, double q[4]) { return rotation_fields(v, t, q, 0); }

/* Checks that t[key] is a table and pushes it (returns 0 and pushes nothing if absent). */
int sc_table_field(vctx *v, int t, const char *key) {
    char b[64];
    int ty = sc_get(v, t, key);
    if (ty == LUA_TNIL) {
        lua_pop(v->L, 1);
        return 0;
    }
    if (ty != LUA_TTABLE) {
        size_t old = sc_push_key(v, key);
        sc_fail(v, "expected a table, got %s", sc_got(v->L, -1, b, sizeof b));
        sc_pop_key(v, old);
    }
    return 1;
}

void sc_require_table_top(vctx *v) {
    char b[64];
    if (lua_type(v->L, -1) != LUA_TTABLE) sc_fail(v, "expected a table, got %s", sc_got(v->L, -1, b, sizeof b));
}


/* "KEY: required WHAT" when !present. */
void sc_require(vctx *v, int present, const char *key, const char *what) {
    if (present) return;
    sc_push_key(v, key);
    sc_fail(v, "required%s%s", what[0] ? " " : "", what);
}


int sc_parse_list(vctx *v, int top, const char *key, const char *example, size_t size, void **items, int *count,
                  sc_item_parser parse, void *ctx) {
    lua_State *L = v->L;
    if (!sc_table_field(v, top, key)) return 0;
    size_t old = sc_push_key(v, key);
    int lt = lua_gettop(L);
    int n = sc_list_len(v, lt, example);
    char *arr = calloc((size_t)n + 1, size);
    if (!arr) luaL_error(L, "out of memory");
    memcpy(items, &arr, sizeof arr); /* *items is a typed pointer (scene_object *, ...): stored bytewise */
    for (int i = 0; i < n; i++) {
        size_t o2 = sc_push_index(v, i + 1);
        lua_rawgeti(L, lt, i + 1);
        sc_require_table_top(v);
        (*count)++;
        parse(v, lua_gettop(L), i, arr + (size_t)i * size, ctx);
        lua_pop(L, 1);
        sc_pop_key(v, o2);
    }
    lua_pop(L, 1);
    sc_pop_key(v, old);
    return 1;
}

void sc_fail_library(vctx *v, const char *libmsg, const char *const *map) {
    /* "field: problem" or "field[i]...: problem": the field is the leading identifier */
    char field[64];
    size_t n = 0;
    while (n < sizeof field - 1 && (isalnum((unsigned char)libmsg[n]) || libmsg[n] == '_')) {
        field[n] = libmsg[n];
        n++;
    }
    field[n] = 0;
    const char *rest = libmsg[n] == ':' && libmsg[n + 1] == ' ' ? libmsg + n + 2 : NULL;
    for (int i = 0; rest && map && map[i]; i += 2)
        if (!strcmp(field, map[i])) {
            const char *key = map[i + 1];
            /* a dotted scene key ("domain.walls", "hardening.1"): each part in turn, numbers as [i] */
            char part[64];
            while (*key) {
                size_t k = strcspn(key, ".");
                snprintf(part, sizeof part, "%.*s", (int)k, key);
                if (isdigit((unsigned char)part[0])) sc_push_index(v, atoll(part));
                else sc_push_key(v, part);
                key += k + (key[k] == '.');
            }
            sc_fail(v, "%s", rest);
        }
    sc_fail(v, "%s", libmsg);
}
