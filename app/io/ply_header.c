/* PLY header parser; see ply_header.h. Reads the first 64 KiB, finds the end_header line, checks
 * that the header is text, then parses it line by line ("format", "element", "property",
 * "comment dim", "comment domain"; "obj_info" and other comments are skipped). */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

#include "app/io/ply_header.h"

const char *const ply_field_names[F_COUNT] = {"x", "y", "z", "vx", "vy", "vz", "material", "q", "volume", "id"};

static const int type_size[] = {0, 1, 1, 2, 2, 4, 4, 4, 8};

int ply_type_size(ply_type t) { return type_size[t]; }

static ply_type parse_type(const char *s) {
    static const struct {
        const char *name;
        ply_type t;
    } names[] = {{"char", PT_I8},    {"int8", PT_I8},     {"uchar", PT_U8},   {"uint8", PT_U8},
                 {"short", PT_I16},  {"int16", PT_I16},   {"ushort", PT_U16}, {"uint16", PT_U16},
                 {"int", PT_I32},    {"int32", PT_I32},   {"uint", PT_U32},   {"uint32", PT_U32},
                 {"float", PT_F32},  {"float32", PT_F32}, {"double", PT_F64}, {"float64", PT_F64}};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        if (!strcmp(s, names[i].name)) return names[i].t;
    return PT_NONE;
}

/* Splits a header line into whitespace-separated tokens in place. Returns the count (max + 1 if
 * there are more than max). */
static int tokenize(char *line, char **tok, int max) {
    int n = 0;
    char *p = line;
    while (*p) {
        while (*p == ' ' || *p == '\t' || *p == '\r') p++;
        if (!*p) break;
        if (n == max) return max + 1;
        tok[n++] = p;
        while (*p && *p != ' ' && *p != '\t' && *p != '\r') p++;
        if (*p) *p++ = 0;
    }
    return n;
}

static int parse_count(const char *s, unsigned long long *out) {
    if (!*s || *s == '-' || *s == '+') return 0;
    char *end;
    errno = 0;
    unsigned long long v = strtoull(s, &end, 10);
    if (errno || *end) return 0;
    *out = v;
    return 1;
}

/* ------------------------------------------------------------------------------------------ */
/* The header's text                                                                            */

/* Reads up to PLY_HEADER_MAX bytes into buf (PLY_HEADER_MAX + 1 long, NUL-terminated) and checks
 * the "ply" line. */
static sm_status read_text(FILE *fp, const char *path, char *buf, size_t *got, char *err, size_t errlen) {
    *got = fread(buf, 1, PLY_HEADER_MAX, fp);
    if (ferror(fp)) {
        snprintf(err, errlen, "%s: read error: %s", path, strerror(errno));
        return SM_ERR_IO;
    }
    buf[*got] = 0;
    if (*got == 0) {
        snprintf(err, errlen, "%s: empty file, not a PLY frame", path);
        return SM_ERR_INVALID;
    }
    if (!(*got >= 4 && (!memcmp(buf, "ply\n", 4) || (*got >= 5 && !memcmp(buf, "ply\r\n", 5))))) {
        snprintf(err, errlen, "%s: not a PLY file (it does not start with a \"ply\" line)", path);
        return SM_ERR_INVALID;
    }
    return SM_OK;
}

/* Length of the header up to and including the end_header line; 0 if there is none. */
static size_t end_of_header(const char *buf, size_t got) {
    for (size_t i = 0; i + 10 <= got; i++) {
        if (buf[i] == '\n' && i + 11 <= got && !memcmp(buf + i + 1, "end_header", 10)) {
            size_t j = i + 11;
            if (j < got && buf[j] == '\r') j++;
            if (j < got && buf[j] == '\n') return j + 1;
            if (j == got) return j; /* end_header at the very end without newline: no data follows */
        }
    }
    return 0;
}

/* The header text must be text. */
static sm_status check_text(const char *buf, size_t len, const char *path, char *err, size_t errlen) {
    for (size_t i = 0; i < len; i++) {
        unsigned char c = (unsigned char)buf[i];
        if (c == 0 || (c < 32 && c != '\n' && c != '\r' && c != '\t')) {
            snprintf(err, errlen, "%s: corrupt header: binary byte 0x%02x at offset %zu", path, c, i);
            return SM_ERR_INVALID;
        }
    }
    return SM_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* Header lines                                                                                 */

/* Where a line's message goes: the file, the line number and the caller's buffer. */
typedef struct line_ctx {
    const char *path;
    int line_no;
    char *err;
    size_t errlen;
} line_ctx;

/* "PATH: header line N: " and the problem. */
static sm_status line_error(const line_ctx *c, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static sm_status line_error(const line_ctx *c, const char *fmt, ...) {
    int k = snprintf(c->err, c->errlen, "%s: header line %d: ", c->path, c->line_no);
    if (k >= 0 && (size_t)k < c->errlen) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(c->err + k, c->errlen - (size_t)k, fmt, ap);
        va_end(ap);
    }
    return SM_ERR_INVALID;
}

static sm_status malformed(const line_ctx *c, const char *keyword) {
    return line_error(c, "malformed \"%.60s\" line", keyword);
}

/* "comment dim 2|3", "comment domain x0 y0 z0 x1 y1 z1" and "comment up y|z" are ours; other
 * comments are skipped. */
static void parse_comment(ply_header *h, const char *rest) {
    int d;
    double a[6];
    char extra;
    if (sscanf(rest, " dim %d %c", &d, &extra) == 1 && (d == 2 || d == 3)) h->comment_dim = d;
    char up[2];
    if (sscanf(rest, " up %1[yz] %c", up, &extra) == 1) h->z_up = up[0] == 'z';
    if (sscanf(rest, " domain %lf %lf %lf %lf %lf %lf", &a[0], &a[1], &a[2], &a[3], &a[4], &a[5]) == 6) {
        int ok = 1;
        for (int k = 0; k < 6; k++) ok = ok && isfinite(a[k]);
        if (ok) {
            h->has_domain = 1;
            memcpy(h->domain, a, sizeof h->domain);
        }
    }
}

static sm_status parse_format(ply_header *h, char **tok, int nt, const line_ctx *c) {
    if (nt != 3) return malformed(c, tok[0]);
    if (!strcmp(tok[1], "ascii")) h->format = PLY_ASCII;
    else if (!strcmp(tok[1], "binary_little_endian")) h->format = PLY_LE;
    else if (!strcmp(tok[1], "binary_big_endian")) h->format = PLY_BE;
    else return line_error(c, "unsupported format \"%s\"", tok[1]);
    if (strncmp(tok[2], "1.", 2) && strcmp(tok[2], "1")) return line_error(c, "unsupported PLY version \"%s\"", tok[2]);
    return SM_OK;
}

static sm_status parse_element(ply_header *h, char **tok, int nt, const line_ctx *c) {
    if (nt != 3) return malformed(c, tok[0]);
    if (h->nel == PLY_MAX_ELEMS) return line_error(c, "more than %d elements", PLY_MAX_ELEMS);
    ply_elem *e = &h->el[h->nel++];
    snprintf(e->name, sizeof e->name, "%s", tok[1]);
    if (!parse_count(tok[2], &e->count)) return line_error(c, "bad element count \"%s\"", tok[2]);
    e->fixed = 1;
    return SM_OK;
}

/* "property TYPE NAME" or "property list COUNT_TYPE TYPE NAME". */
static sm_status parse_property(ply_header *h, char **tok, int nt, const line_ctx *c) {
    if (h->nel == 0) return line_error(c, "property before any element");
    ply_elem *e = &h->el[h->nel - 1];
    if (e->nprops == PLY_MAX_PROPS) return line_error(c, "more than %d properties", PLY_MAX_PROPS);
    ply_prop *p = &e->props[e->nprops];
    if (nt == 5 && !strcmp(tok[1], "list")) {
        p->is_list = 1;
        p->count_type = parse_type(tok[2]);
        p->type = parse_type(tok[3]);
        if (p->count_type == PT_NONE || p->type == PT_NONE || p->count_type == PT_F32 || p->count_type == PT_F64)
            return line_error(c, "bad list types \"%s %s\"", tok[2], tok[3]);
        snprintf(p->name, sizeof p->name, "%s", tok[4]);
        e->fixed = 0;
    } else if (nt == 3) {
        p->type = parse_type(tok[1]);
        if (p->type == PT_NONE) return line_error(c, "unknown property type \"%s\"", tok[1]);
        snprintf(p->name, sizeof p->name, "%s", tok[2]);
        p->offset = e->stride;
        e->stride += (size_t)ply_type_size(p->type);
    } else {
        return malformed(c, tok[0]);
    }
    e->nprops++;
    return SM_OK;
}

/* One header line (not the first). *done = 1 at end_header. */
static sm_status parse_line(ply_header *h, char *line, const line_ctx *c, int *done) {
    if (!strncmp(line, "comment", 7) && (line[7] == ' ' || line[7] == '\t' || line[7] == 0 || line[7] == '\r')) {
        parse_comment(h, line + 7);
        return SM_OK;
    }
    char *tok[8];
    int nt = tokenize(line, tok, 7);
    if (nt == 0 || !strcmp(tok[0], "obj_info")) return SM_OK;
    if (!strcmp(tok[0], "end_header")) {
        *done = 1;
        return SM_OK;
    }
    if (!strcmp(tok[0], "format")) return parse_format(h, tok, nt, c);
    if (!strcmp(tok[0], "element")) return parse_element(h, tok, nt, c);
    if (!strcmp(tok[0], "property")) return parse_property(h, tok, nt, c);
    return line_error(c, "unknown keyword \"%.40s\"", tok[0]);
}

static sm_status parse_lines(ply_header *h, char *text, const char *path, char *err, size_t errlen) {
    line_ctx c = {path, 0, err, errlen};
    int done = 0;
    for (char *line = text; line && *line && !done;) {
        char *nl = strchr(line, '\n');
        if (nl) *nl = 0;
        c.line_no++;
        if (c.line_no > 1) { /* the first is "ply" */
            sm_status st = parse_line(h, line, &c, &done);
            if (st != SM_OK) return st;
        }
        line = nl ? nl + 1 : NULL;
    }
    return SM_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* What the header must hold                                                                    */

/* The vertex element, its kept fields, a format and a vertex count this reader supports. */
static sm_status find_fields(ply_header *h, const char *path, char *err, size_t errlen) {
    if (!h->format) {
        snprintf(err, errlen, "%s: corrupt header: no format line", path);
        return SM_ERR_INVALID;
    }
    h->vertex = -1;
    for (int i = 0; i < h->nel && h->vertex < 0; i++)
        if (!strcmp(h->el[i].name, "vertex")) h->vertex = i;
    if (h->vertex < 0) {
        snprintf(err, errlen, "%s: no \"element vertex\" in the header", path);
        return SM_ERR_INVALID;
    }
    const ply_elem *ve = &h->el[h->vertex];
    for (int k = 0; k < F_COUNT; k++) {
        h->field[k] = -1;
        for (int p = 0; p < ve->nprops && h->field[k] < 0; p++)
            if (!strcmp(ve->props[p].name, ply_field_names[k])) h->field[k] = p;
        if (h->field[k] >= 0 && ve->props[h->field[k]].is_list) {
            snprintf(err, errlen, "%s: vertex property \"%s\" is a list, expected a scalar", path, ply_field_names[k]);
            return SM_ERR_INVALID;
        }
    }
    if (h->field[F_X] < 0 || h->field[F_Y] < 0) {
        snprintf(err, errlen, "%s: the vertex element has no \"%s\" property", path, h->field[F_X] < 0 ? "x" : "y");
        return SM_ERR_INVALID;
    }
    if (ve->count > 0xFFFFFFFEull) {
        snprintf(err, errlen, "%s: %llu vertices: more than this reader supports (2^32 - 2)", path, ve->count);
        return SM_ERR_INVALID;
    }
    return SM_OK;
}

sm_status ply_header_read(FILE *fp, const char *path, ply_header *h, char *err, size_t errlen) {
    memset(h, 0, sizeof *h);
    char *buf = malloc(PLY_HEADER_MAX + 1);
    if (!buf) {
        snprintf(err, errlen, "%s: out of memory", path);
        return SM_ERR_NOMEM;
    }
    size_t got = 0;
    sm_status st = read_text(fp, path, buf, &got, err, errlen);
    if (st == SM_OK) {
        h->length = end_of_header(buf, got);
        if (h->length == 0) {
            snprintf(err, errlen,
                     got < PLY_HEADER_MAX ? "%s: corrupt header: no end_header line (truncated or not a PLY file)"
                                          : "%s: corrupt header: no end_header line in the first 64 KiB",
                     path);
            st = SM_ERR_INVALID;
        }
    }
    if (st == SM_OK) st = check_text(buf, h->length, path, err, errlen);
    if (st == SM_OK) {
        buf[h->length] = 0;
        st = parse_lines(h, buf, path, err, errlen);
    }
    if (st == SM_OK) st = find_fields(h, path, err, errlen);
    free(buf);
    return st;
}
