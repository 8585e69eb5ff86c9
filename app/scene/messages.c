/* The scene schema's messages: the key path being read (vctx.path) and where it is in the source
 * ("file:line: key.path: problem"), raised (sc_fail, and sc_fail_library for the library's check
 * messages mapped onto scene keys) or recorded as warnings, and their words: numbers, values,
 * did-you-mean suggestions, the allowed keys and values listed. sc_fail raises a Lua error with the
 * finished message (the parsers run inside lua_pcall). */
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

/* The key k of the table being checked is not one of allowed: "unknown key" at path.k, with the
 * likely meant key or else the keys what takes. */
void sc_fail_unknown_key(vctx *v, const char *k, const char *const *allowed, int n, const char *what) {
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

/* The value on top is not one of names (or not a string): "expected "a", "b" or "c", got ...", with
 * the likely meant value if there is one. */
void sc_fail_enum(vctx *v, const char *const *names, int n) {
    char b[64], list[256] = "";
    size_t len = 0;
    for (int i = 0; i < n; i++)
        len += (size_t)snprintf(list + len, sizeof list - len, "%s\"%s\"", i == 0 ? "" : i == n - 1 ? " or " : ", ",
                                names[i]);
    if (lua_type(v->L, -1) != LUA_TSTRING) sc_fail(v, "expected %s, got %s", list, sc_got(v->L, -1, b, sizeof b));
    const char *str = lua_tostring(v->L, -1);
    const char *sug = enum_suggestion(str, names, n);
    if (sug) sc_fail(v, "expected %s, got \"%s\" (did you mean \"%s\"?)", list, str, sug);
    sc_fail(v, "expected %s, got \"%s\"", list, str);
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
