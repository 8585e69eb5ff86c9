/* The line of a key path (e.g. colliders[2].shape.center[3]) in the scene's source, for messages.
 *
 * Table fields carry no line numbers once the chunk has run, so the source is read again: a small
 * Lua tokenizer (names, strings, long strings, numbers, comments, punctuation) and a walk through
 * the table constructors. The path's first key is looked for as a field `key = value` inside any
 * constructor; from its value each further component is followed: a name into `name = value` or
 * `["name"] = value` of a constructor, an index into its i-th positional item, and a plain name
 * (`colliders = { ground, box }`) into the constructor that the one assignment `ground = {`
 * gives it. The line is that of the deepest component found (where the walk stopped: a scene
 * that builds a list in a loop gets the line of the list). Of several candidates the one that
 * goes deepest wins, then the shallowest constructor, then the last in the file (the returned
 * table usually ends a scene). 0 if the first key is nowhere. */
#define _POSIX_C_SOURCE 200809L
#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "app/scene/scene_internal.h"

enum { T_NAME, T_STRING, T_NUMBER, T_PUNCT };

typedef struct token {
    int kind;
    const char *text; /* names and strings: the text (a string without its quotes) */
    size_t len;
    int line, depth; /* depth: constructors open around the token */
} token;

typedef struct tokens {
    token *t;
    int n, cap;
} tokens;

static int add(tokens *ts, int kind, const char *text, size_t len, int line, int depth) {
    if (ts->n == ts->cap) {
        int cap = ts->cap ? 2 * ts->cap : 256;
        token *q = realloc(ts->t, (size_t)cap * sizeof *q);
        if (!q) return 0;
        ts->t = q;
        ts->cap = cap;
    }
    ts->t[ts->n++] = (token){kind, text, len, line, depth};
    return 1;
}

/* The length of a long bracket [[ / [=[ at p (0 if none); its level in *level. */
static size_t long_open(const char *p, const char *end, int *level) {
    if (p >= end || *p != '[') return 0;
    const char *q = p + 1;
    while (q < end && *q == '=') q++;
    if (q >= end || *q != '[') return 0;
    *level = (int)(q - p - 1);
    return (size_t)(q - p + 1);
}

/* Skips to after the closing bracket of the given level; counts lines. */
static const char *long_close(const char *p, const char *end, int level, int *line) {
    for (; p < end; p++) {
        if (*p == '\n') (*line)++;
        if (*p != ']') continue;
        const char *q = p + 1;
        while (q < end && *q == '=') q++;
        if (q < end && *q == ']' && q - p - 1 == level) return q + 1;
    }
    return end;
}

/* Skips a quoted string at p (its quote char); returns after the closing quote. */
static const char *quoted(const char *p, const char *end, int *line) {
    char quote = *p++;
    for (; p < end && *p != quote; p++) {
        if (*p == '\n') (*line)++;
        if (*p == '\\' && p + 1 < end) {
            p++;
            if (*p == '\n') (*line)++;
        }
    }
    return p < end ? p + 1 : end;
}

/* Tokenizes src; 0 if out of memory. Only what the walk needs: names, strings (as keys),
 * numbers, and the punctuation { } [ ] = , ; (other operators are one-character tokens). */
static int tokenize(const char *src, size_t n, tokens *ts) {
    const char *p = src, *end = src + n;
    int line = 1, depth = 0, level;
    while (p < end) {
        size_t k;
        if (*p == '\n') {
            line++;
            p++;
        } else if (isspace((unsigned char)*p)) {
            p++;
        } else if (p + 1 < end && p[0] == '-' && p[1] == '-') {
            p += 2;
            if ((k = long_open(p, end, &level)) != 0) p = long_close(p + k, end, level, &line);
            else
                while (p < end && *p != '\n') p++;
        } else if ((k = long_open(p, end, &level)) != 0) {
            const char *s = p + k;
            p = long_close(s, end, level, &line);
            if (!add(ts, T_STRING, s, 0, line, depth)) return 0;
        } else if (*p == '"' || *p == '\'') {
            int l0 = line;
            const char *s = p + 1;
            p = quoted(p, end, &line);
            if (!add(ts, T_STRING, s, (size_t)(p - s - 1), l0, depth)) return 0;
        } else if (isalpha((unsigned char)*p) || *p == '_') {
            const char *s = p;
            while (p < end && (isalnum((unsigned char)*p) || *p == '_')) p++;
            if (!add(ts, T_NAME, s, (size_t)(p - s), line, depth)) return 0;
        } else if (isdigit((unsigned char)*p) || (*p == '.' && p + 1 < end && isdigit((unsigned char)p[1]))) {
            const char *s = p;
            while (p < end && (isalnum((unsigned char)*p) || *p == '.' ||
                               ((*p == '-' || *p == '+') && (p[-1] == 'e' || p[-1] == 'E' || p[-1] == 'p' || p[-1] == 'P'))))
                p++;
            if (!add(ts, T_NUMBER, s, (size_t)(p - s), line, depth)) return 0;
        } else {
            if (*p == '}') depth--;
            /* "==" is one token, so that `a == b` is no field */
            size_t len = (*p == '=' && p + 1 < end && p[1] == '=') ? 2 : 1;
            if (!add(ts, T_PUNCT, p, len, line, depth)) return 0;
            if (*p == '{') depth++;
            p += len;
        }
    }
    return 1;
}

static int is_punct(const token *t, char c) { return t->kind == T_PUNCT && t->len == 1 && t->text[0] == c; }
static int is_name(const token *t, const char *s, size_t n) {
    return t->kind == T_NAME && t->len == n && !memcmp(t->text, s, n);
}

/* After the value that starts at token i (inside a constructor): the index of the ',' ';' or '}'
 * that ends it. */
static int value_end(const tokens *ts, int i) {
    int d = 0;
    for (; i < ts->n; i++) {
        const token *t = &ts->t[i];
        if (t->kind != T_PUNCT) continue;
        char c = t->text[0];
        if (c == '{' || c == '(' || c == '[') d++;
        else if ((c == '}' || c == ')' || c == ']') && d > 0) d--;
        else if (d == 0 && (c == ',' || c == ';' || c == '}')) return i;
    }
    return ts->n;
}

/* In the constructor opening at token open: the value of field name (len n) or, if name is NULL,
 * of positional item idx (from 1); -1 if absent. */
static int field_value(const tokens *ts, int open, const char *name, size_t n, long long idx) {
    long long pos = 0;
    int i = open + 1;
    while (i < ts->n && !is_punct(&ts->t[i], '}')) {
        const token *t = &ts->t[i];
        int keyed = 0, value = i;
        if (t->kind == T_NAME && i + 1 < ts->n && is_punct(&ts->t[i + 1], '=')) {
            keyed = 1;
            value = i + 2;
            if (name && is_name(t, name, n)) return value;
        } else if (is_punct(t, '[') && i + 3 < ts->n && is_punct(&ts->t[i + 2], ']') && is_punct(&ts->t[i + 3], '=')) {
            keyed = 1;
            value = i + 4;
            const token *k = &ts->t[i + 1];
            if (name && k->kind == T_STRING && k->len == n && !memcmp(k->text, name, n)) return value;
        }
        if (!keyed && !name && ++pos == idx) return value;
        i = value_end(ts, value);
        if (i < ts->n && !is_punct(&ts->t[i], '}')) i++;
    }
    return -1;
}

/* The constructor that a plain name at token i stands for: the one `name = {` in the source. */
static int name_table(const tokens *ts, int i) {
    const token *t = &ts->t[i];
    int found = -1;
    for (int j = 0; j + 2 < ts->n; j++)
        if (j != i && is_name(&ts->t[j], t->text, t->len) && is_punct(&ts->t[j + 1], '=') &&
            is_punct(&ts->t[j + 2], '{')) {
            if (found >= 0) return -1;
            found = j + 2;
        }
    return found;
}

typedef struct component {
    const char *name; /* NULL: an index */
    size_t len;
    long long idx;
} component;

/* Splits a path into components; their number (at most max). */
static int split(const char *path, component *c, int max) {
    int n = 0;
    const char *p = path;
    while (*p && n < max) {
        if (*p == '.') p++;
        if (*p == '[') {
            if (p[1] == '"') {
                const char *e = strchr(p + 2, '"');
                if (!e) break;
                c[n++] = (component){p + 2, (size_t)(e - p - 2), 0};
                p = e + 2;
            } else {
                c[n++] = (component){NULL, 0, atoll(p + 1)};
                p = strchr(p, ']');
                if (!p) break;
                p++;
            }
        } else {
            size_t k = strcspn(p, ".[");
            if (k == 0) break;
            c[n++] = (component){p, k, 0};
            p += k;
        }
    }
    return n;
}

/* Follows components from k on from the value at token v; the line of the deepest one found and
 * how many were found (in *found). */
static int walk(const tokens *ts, int v, const component *c, int nc, int k, int *found, int line) {
    *found = k;
    for (int hops = 0; k < nc && v >= 0 && v < ts->n && hops < 64; hops++) {
        if (ts->t[v].kind == T_NAME && v + 1 < ts->n && !is_punct(&ts->t[v + 1], '.') &&
            !is_punct(&ts->t[v + 1], '(')) {
            v = name_table(ts, v);
            continue;
        }
        if (!is_punct(&ts->t[v], '{')) break;
        int next = field_value(ts, v, c[k].name, c[k].len, c[k].idx);
        if (next < 0 || next >= ts->n) break;
        line = ts->t[next].line;
        *found = ++k;
        v = next;
    }
    return line;
}

int sc_locate(const char *src, size_t n, const char *path) {
    component c[24];
    int nc = split(path, c, 24);
    if (!src || nc == 0 || !c[0].name) return 0;
    tokens ts = {NULL, 0, 0};
    if (!tokenize(src, n, &ts)) {
        free(ts.t);
        return 0;
    }
    int best_line = 0, best_found = 0, best_depth = 1 << 30;
    for (int i = 0; i + 2 < ts.n; i++) {
        token *t = &ts.t[i];
        if (t->depth < 1 || !is_name(t, c[0].name, c[0].len) || !is_punct(&ts.t[i + 1], '=')) continue;
        if (i > 0 && !is_punct(&ts.t[i - 1], '{') && !is_punct(&ts.t[i - 1], ',') && !is_punct(&ts.t[i - 1], ';'))
            continue; /* not a field of a constructor */
        int found;
        int line = walk(&ts, i + 2, c, nc, 1, &found, t->line);
        if (found > best_found || (found == best_found && t->depth <= best_depth)) {
            best_found = found;
            best_depth = t->depth;
            best_line = line;
        }
    }
    free(ts.t);
    return best_line;
}

const char *sc_where(const sm_scene *s, const char *keys, char *buf, size_t n) {
    int line = sc_locate(s->source, s->source_len, keys);
    if (line > 0) snprintf(buf, n, "%s:%d", s->path, line);
    else snprintf(buf, n, "%s", s->path);
    return buf;
}
