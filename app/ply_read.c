/* PLY frame reader and frames from a world; see render.h.
 *
 * The header is read (at most 64 KiB) and parsed line by line; properties are looked up by name in
 * the vertex element. Binary data is checked against the file size before anything is allocated
 * for it, so a corrupt count cannot make us allocate or read past the end. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "app/render.h"

enum { RC_OK = 0, RC_BAD = 2, RC_IO = 4, RC_NOMEM = 5 };

#define HEADER_MAX 65536
#define MAX_ELEMS 16
#define MAX_PROPS 64

typedef enum ptype { PT_NONE = 0, PT_I8, PT_U8, PT_I16, PT_U16, PT_I32, PT_U32, PT_F32, PT_F64 } ptype;

static const int ptype_size[] = {0, 1, 1, 2, 2, 4, 4, 4, 8};

static ptype parse_type(const char *s) {
    static const struct {
        const char *name;
        ptype t;
    } names[] = {{"char", PT_I8},    {"int8", PT_I8},     {"uchar", PT_U8},   {"uint8", PT_U8},
                 {"short", PT_I16},  {"int16", PT_I16},   {"ushort", PT_U16}, {"uint16", PT_U16},
                 {"int", PT_I32},    {"int32", PT_I32},   {"uint", PT_U32},   {"uint32", PT_U32},
                 {"float", PT_F32},  {"float32", PT_F32}, {"double", PT_F64}, {"float64", PT_F64}};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        if (!strcmp(s, names[i].name)) return names[i].t;
    return PT_NONE;
}

typedef struct prop {
    char name[64];
    ptype type;
    int is_list;
    ptype count_type;
    size_t offset; /* byte offset in a binary record (fixed-size elements only) */
} prop;

typedef struct elem {
    char name[64];
    unsigned long long count;
    int nprops;
    prop props[MAX_PROPS];
    size_t stride; /* bytes per record if fixed */
    int fixed;     /* no list properties */
} elem;

enum { FMT_ASCII = 1, FMT_LE = 2, FMT_BE = 3 };

/* Fields we read, in the order of this table. */
enum { F_X, F_Y, F_Z, F_VX, F_VY, F_VZ, F_MAT, F_Q, F_VOL, F_ID, F_COUNT };
static const char *const field_names[F_COUNT] = {"x", "y", "z", "vx", "vy", "vz", "material", "q", "volume", "id"};

static double decode(const unsigned char *p, ptype t, int big_endian) {
    unsigned char b[8];
    int n = ptype_size[t];
    if (big_endian)
        for (int i = 0; i < n; i++) b[i] = p[n - 1 - i];
    else
        memcpy(b, p, (size_t)n);
    switch (t) {
    case PT_I8: { int8_t v; memcpy(&v, b, 1); return v; }
    case PT_U8: return b[0];
    case PT_I16: { int16_t v; memcpy(&v, b, 2); return v; }
    case PT_U16: { uint16_t v; memcpy(&v, b, 2); return v; }
    case PT_I32: { int32_t v; memcpy(&v, b, 4); return v; }
    case PT_U32: { uint32_t v; memcpy(&v, b, 4); return v; }
    case PT_F32: { float v; memcpy(&v, b, 4); return v; }
    case PT_F64: { double v; memcpy(&v, b, 8); return v; }
    default: return 0.0;
    }
}

/* Little-endian host check (the decode above assumes the host is little-endian for memcpy; on a
 * big-endian host the flags are flipped). */
static int host_is_big_endian(void) {
    const uint16_t one = 1;
    unsigned char c;
    memcpy(&c, &one, 1);
    return c == 0;
}

static uint16_t to_u16(double v) {
    if (!(v >= 0)) return 0; /* NaN too */
    if (v > 65535) return 65535;
    return (uint16_t)v;
}

static uint32_t to_u32(double v) {
    if (!(v >= 0)) return 0;
    if (v > 4294967295.0) return 4294967295u;
    return (uint32_t)v;
}

void sm_frame_free(sm_frame *f) {
    if (!f) return;
    free(f->x);
    free(f->v);
    free(f->q);
    free(f->volume);
    free(f->material);
    free(f->id);
    memset(f, 0, sizeof *f);
}

/* Allocates the arrays of n particles (volume/id only if asked). */
static int frame_alloc(sm_frame *f, size_t n, int want_volume, int want_id) {
    size_t m = n ? n : 1;
    if (m > SIZE_MAX / (3 * sizeof(float))) return -1;
    f->n = n;
    f->x = calloc(3 * m, sizeof(float));
    f->v = calloc(3 * m, sizeof(float));
    f->q = calloc(m, sizeof(float));
    f->material = calloc(m, sizeof(uint16_t));
    if (want_volume) f->volume = calloc(m, sizeof(float));
    if (want_id) f->id = calloc(m, sizeof(uint32_t));
    if (!f->x || !f->v || !f->q || !f->material || (want_volume && !f->volume) || (want_id && !f->id)) return -1;
    return 0;
}

/* Stores one decoded field value of particle i. */
static void store(sm_frame *f, int field, size_t i, double v) {
    switch (field) {
    case F_X: case F_Y: case F_Z: f->x[3 * i + (size_t)(field - F_X)] = (float)v; break;
    case F_VX: case F_VY: case F_VZ: f->v[3 * i + (size_t)(field - F_VX)] = (float)v; break;
    case F_MAT: f->material[i] = to_u16(v); break;
    case F_Q: f->q[i] = (float)v; break;
    case F_VOL: f->volume[i] = (float)v; break;
    case F_ID: f->id[i] = to_u32(v); break;
    default: break;
    }
}

/* Splits a header line into whitespace-separated tokens in place. Returns the count. */
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

/* Skips n lines of ASCII data starting at *p (within [*p, end)). 0 if the data ends first. */
static int skip_lines(const char **p, const char *end, unsigned long long n) {
    const char *s = *p;
    for (unsigned long long k = 0; k < n; k++) {
        const char *nl = memchr(s, '\n', (size_t)(end - s));
        if (!nl) {
            /* the last line may lack its newline */
            if (k + 1 == n && s < end) {
                s = end;
                break;
            }
            return 0;
        }
        s = nl + 1;
    }
    *p = s;
    return 1;
}

/* Next number token in ASCII data; 0 at the end or on a token that is not a number. */
static int next_number(const char **p, const char *end, double *out, int *garbage) {
    const char *s = *p;
    while (s < end && (*s == ' ' || *s == '\t' || *s == '\r' || *s == '\n')) s++;
    if (s >= end) return 0;
    char buf[64];
    size_t k = 0;
    while (s < end && !(*s == ' ' || *s == '\t' || *s == '\r' || *s == '\n')) {
        if (k + 1 >= sizeof buf) {
            *garbage = 1;
            return 0;
        }
        buf[k++] = *s++;
    }
    buf[k] = 0;
    char *e;
    double v = strtod(buf, &e);
    if (*e) {
        *garbage = 1;
        return 0;
    }
    *out = v;
    *p = s;
    return 1;
}

int sm_ply_read(const char *path, sm_frame *f, char *err, size_t errlen) {
    memset(f, 0, sizeof *f);
    char dummy[8];
    if (!err || errlen == 0) {
        err = dummy;
        errlen = sizeof dummy;
    }
    err[0] = 0;
    FILE *fp = fopen(path, "rb");
    if (!fp) {
        snprintf(err, errlen, "%s: cannot open: %s", path, strerror(errno));
        return RC_IO;
    }
    int rc = RC_OK;
    char *hdr = NULL, *data = NULL;
    elem *el = NULL;
    struct stat st;
    if (fstat(fileno(fp), &st) != 0) {
        snprintf(err, errlen, "%s: cannot stat: %s", path, strerror(errno));
        rc = RC_IO;
        goto done;
    }
    if (S_ISDIR(st.st_mode)) {
        snprintf(err, errlen, "%s: is a directory, not a PLY file", path);
        rc = RC_IO;
        goto done;
    }
    const unsigned long long fsize = (unsigned long long)st.st_size;
    hdr = malloc(HEADER_MAX + 1);
    el = calloc(MAX_ELEMS, sizeof *el);
    if (!hdr || !el) {
        snprintf(err, errlen, "%s: out of memory", path);
        rc = RC_NOMEM;
        goto done;
    }
    size_t got = fread(hdr, 1, HEADER_MAX, fp);
    if (ferror(fp)) {
        snprintf(err, errlen, "%s: read error: %s", path, strerror(errno));
        rc = RC_IO;
        goto done;
    }
    hdr[got] = 0;
    if (got == 0) {
        snprintf(err, errlen, "%s: empty file, not a PLY frame", path);
        rc = RC_BAD;
        goto done;
    }
    if (!(got >= 4 && (!memcmp(hdr, "ply\n", 4) || (got >= 5 && !memcmp(hdr, "ply\r\n", 5))))) {
        snprintf(err, errlen, "%s: not a PLY file (it does not start with a \"ply\" line)", path);
        rc = RC_BAD;
        goto done;
    }
    /* Find the end_header line. */
    size_t hlen = 0;
    for (size_t i = 0; i + 10 <= got; i++) {
        if (hdr[i] == '\n' && i + 11 <= got && !memcmp(hdr + i + 1, "end_header", 10)) {
            size_t j = i + 11;
            if (j < got && hdr[j] == '\r') j++;
            if (j < got && hdr[j] == '\n') {
                hlen = j + 1;
                break;
            }
            if (j == got) { /* end_header at the very end without newline: no data follows */
                hlen = j;
                break;
            }
        }
    }
    if (hlen == 0) {
        snprintf(err, errlen,
                 got < HEADER_MAX ? "%s: corrupt header: no end_header line (truncated or not a PLY file)"
                                  : "%s: corrupt header: no end_header line in the first 64 KiB",
                 path);
        rc = RC_BAD;
        goto done;
    }
    /* The header text must be text. */
    for (size_t i = 0; i < hlen; i++) {
        unsigned char c = (unsigned char)hdr[i];
        if (c == 0 || (c < 32 && c != '\n' && c != '\r' && c != '\t')) {
            snprintf(err, errlen, "%s: corrupt header: binary byte 0x%02x at offset %zu", path, c, i);
            rc = RC_BAD;
            goto done;
        }
    }
    hdr[hlen] = 0;

    /* Parse the header lines. */
    int fmt = 0, nel = 0, line_no = 0, comment_dim = 0;
    int has_domain = 0;
    double dom[6] = {0, 0, 0, 0, 0, 0};
    char *line = hdr;
    while (line && *line) {
        char *nl = strchr(line, '\n');
        if (nl) *nl = 0;
        line_no++;
        char *next = nl ? nl + 1 : NULL;
        if (line_no == 1) { /* "ply" */
            line = next;
            continue;
        }
        if (!strncmp(line, "comment", 7) && (line[7] == ' ' || line[7] == '\t' || line[7] == 0 || line[7] == '\r')) {
            int d;
            double a[6];
            char extra;
            if (sscanf(line + 7, " dim %d %c", &d, &extra) == 1 && (d == 2 || d == 3)) comment_dim = d;
            if (sscanf(line + 7, " domain %lf %lf %lf %lf %lf %lf", &a[0], &a[1], &a[2], &a[3], &a[4], &a[5]) == 6) {
                int ok = 1;
                for (int k = 0; k < 6; k++) ok = ok && isfinite(a[k]);
                if (ok) {
                    has_domain = 1;
                    memcpy(dom, a, sizeof dom);
                }
            }
            line = next;
            continue;
        }
        char *tok[8];
        int nt = tokenize(line, tok, 7);
        if (nt == 0 || !strcmp(tok[0], "obj_info")) {
            line = next;
            continue;
        }
        if (!strcmp(tok[0], "end_header")) break;
        if (!strcmp(tok[0], "format")) {
            if (nt != 3) goto bad_line;
            if (!strcmp(tok[1], "ascii")) fmt = FMT_ASCII;
            else if (!strcmp(tok[1], "binary_little_endian")) fmt = FMT_LE;
            else if (!strcmp(tok[1], "binary_big_endian")) fmt = FMT_BE;
            else {
                snprintf(err, errlen, "%s: header line %d: unsupported format \"%s\"", path, line_no, tok[1]);
                rc = RC_BAD;
                goto done;
            }
            if (strncmp(tok[2], "1.", 2) && strcmp(tok[2], "1")) {
                snprintf(err, errlen, "%s: header line %d: unsupported PLY version \"%s\"", path, line_no, tok[2]);
                rc = RC_BAD;
                goto done;
            }
        } else if (!strcmp(tok[0], "element")) {
            if (nt != 3) goto bad_line;
            if (nel == MAX_ELEMS) {
                snprintf(err, errlen, "%s: header line %d: more than %d elements", path, line_no, MAX_ELEMS);
                rc = RC_BAD;
                goto done;
            }
            elem *e = &el[nel++];
            snprintf(e->name, sizeof e->name, "%s", tok[1]);
            if (!parse_count(tok[2], &e->count)) {
                snprintf(err, errlen, "%s: header line %d: bad element count \"%s\"", path, line_no, tok[2]);
                rc = RC_BAD;
                goto done;
            }
            e->fixed = 1;
        } else if (!strcmp(tok[0], "property")) {
            if (nel == 0) {
                snprintf(err, errlen, "%s: header line %d: property before any element", path, line_no);
                rc = RC_BAD;
                goto done;
            }
            elem *e = &el[nel - 1];
            if (e->nprops == MAX_PROPS) {
                snprintf(err, errlen, "%s: header line %d: more than %d properties", path, line_no, MAX_PROPS);
                rc = RC_BAD;
                goto done;
            }
            prop *p = &e->props[e->nprops];
            if (nt == 5 && !strcmp(tok[1], "list")) {
                p->is_list = 1;
                p->count_type = parse_type(tok[2]);
                p->type = parse_type(tok[3]);
                if (p->count_type == PT_NONE || p->type == PT_NONE || p->count_type == PT_F32 ||
                    p->count_type == PT_F64) {
                    snprintf(err, errlen, "%s: header line %d: bad list types \"%s %s\"", path, line_no, tok[2], tok[3]);
                    rc = RC_BAD;
                    goto done;
                }
                snprintf(p->name, sizeof p->name, "%s", tok[4]);
                e->fixed = 0;
            } else if (nt == 3) {
                p->type = parse_type(tok[1]);
                if (p->type == PT_NONE) {
                    snprintf(err, errlen, "%s: header line %d: unknown property type \"%s\"", path, line_no, tok[1]);
                    rc = RC_BAD;
                    goto done;
                }
                snprintf(p->name, sizeof p->name, "%s", tok[2]);
                p->offset = e->stride;
                e->stride += (size_t)ptype_size[p->type];
            } else {
                goto bad_line;
            }
            e->nprops++;
        } else {
            snprintf(err, errlen, "%s: header line %d: unknown keyword \"%.40s\"", path, line_no, tok[0]);
            rc = RC_BAD;
            goto done;
        }
        line = next;
        continue;
    bad_line:
        snprintf(err, errlen, "%s: header line %d: malformed \"%.60s\" line", path, line_no, tok[0]);
        rc = RC_BAD;
        goto done;
    }
    if (!fmt) {
        snprintf(err, errlen, "%s: corrupt header: no format line", path);
        rc = RC_BAD;
        goto done;
    }
    int vi = -1;
    for (int i = 0; i < nel; i++)
        if (!strcmp(el[i].name, "vertex")) {
            vi = i;
            break;
        }
    if (vi < 0) {
        snprintf(err, errlen, "%s: no \"element vertex\" in the header", path);
        rc = RC_BAD;
        goto done;
    }
    const elem *ve = &el[vi];
    int fidx[F_COUNT];
    for (int k = 0; k < F_COUNT; k++) {
        fidx[k] = -1;
        for (int p = 0; p < ve->nprops; p++)
            if (!strcmp(ve->props[p].name, field_names[k])) {
                fidx[k] = p;
                break;
            }
        if (fidx[k] >= 0 && ve->props[fidx[k]].is_list) {
            snprintf(err, errlen, "%s: vertex property \"%s\" is a list, expected a scalar", path, field_names[k]);
            rc = RC_BAD;
            goto done;
        }
    }
    if (fidx[F_X] < 0 || fidx[F_Y] < 0) {
        snprintf(err, errlen, "%s: the vertex element has no \"%s\" property", path, fidx[F_X] < 0 ? "x" : "y");
        rc = RC_BAD;
        goto done;
    }
    const unsigned long long n = ve->count;
    if (n > 0xFFFFFFFEull) {
        snprintf(err, errlen, "%s: %llu vertices: more than this reader supports (2^32 - 2)", path, n);
        rc = RC_BAD;
        goto done;
    }

    if (fmt != FMT_ASCII) {
        /* Offset of the vertex data: skip fixed-size elements before it. */
        unsigned long long off = hlen;
        for (int i = 0; i <= vi; i++) {
            if (!el[i].fixed) {
                snprintf(err, errlen, "%s: element \"%s\" has list properties; binary files with lists in or before "
                                      "the vertex element are not supported", path, el[i].name);
                rc = RC_BAD;
                goto done;
            }
            if (i == vi) break;
            if (el[i].stride && el[i].count > (ULLONG_MAX - off) / el[i].stride) {
                snprintf(err, errlen, "%s: corrupt header: element \"%s\" is too large", path, el[i].name);
                rc = RC_BAD;
                goto done;
            }
            off += el[i].count * el[i].stride;
        }
        const size_t stride = ve->stride;
        if (stride == 0 || n > (ULLONG_MAX - off) / stride || off + n * stride > fsize) {
            unsigned long long have = fsize > off ? fsize - off : 0;
            snprintf(err, errlen, "%s: truncated: %llu vertices of %zu bytes need %llu bytes of data, the file has %llu",
                     path, n, stride, stride ? n * stride : 0ull, have);
            rc = RC_BAD;
            goto done;
        }
        if (frame_alloc(f, (size_t)n, fidx[F_VOL] >= 0, fidx[F_ID] >= 0) != 0) {
            snprintf(err, errlen, "%s: out of memory for %llu particles", path, n);
            rc = RC_NOMEM;
            goto done;
        }
        if (off > (unsigned long long)LONG_MAX || fseek(fp, (long)off, SEEK_SET) != 0) {
            snprintf(err, errlen, "%s: seek failed: %s", path, strerror(errno));
            rc = RC_IO;
            goto done;
        }
        const int be = (fmt == FMT_BE) != host_is_big_endian();
        size_t per = (4u << 20) / stride;
        if (per == 0) per = 1;
        data = malloc(per * stride);
        if (!data) {
            snprintf(err, errlen, "%s: out of memory", path);
            rc = RC_NOMEM;
            goto done;
        }
        for (size_t i0 = 0; i0 < (size_t)n; i0 += per) {
            size_t cnt = (size_t)n - i0 < per ? (size_t)n - i0 : per;
            if (fread(data, stride, cnt, fp) != cnt) {
                snprintf(err, errlen, "%s: %s at vertex %zu", path, ferror(fp) ? strerror(errno) : "unexpected end of file",
                         i0);
                rc = ferror(fp) ? RC_IO : RC_BAD;
                goto done;
            }
            for (int k = 0; k < F_COUNT; k++) {
                if (fidx[k] < 0) continue;
                const prop *p = &ve->props[fidx[k]];
                const unsigned char *src = (const unsigned char *)data + p->offset;
                for (size_t j = 0; j < cnt; j++) store(f, k, i0 + j, decode(src + j * stride, p->type, be));
            }
        }
    } else {
        /* ASCII: read the rest of the file and parse numbers. */
        unsigned long long rest = fsize > hlen ? fsize - hlen : 0;
        if (rest > (unsigned long long)(SIZE_MAX - 1)) {
            snprintf(err, errlen, "%s: file too large", path);
            rc = RC_BAD;
            goto done;
        }
        data = malloc((size_t)rest + 1);
        if (!data) {
            snprintf(err, errlen, "%s: out of memory", path);
            rc = RC_NOMEM;
            goto done;
        }
        if (fseek(fp, (long)hlen, SEEK_SET) != 0 || fread(data, 1, (size_t)rest, fp) != (size_t)rest) {
            snprintf(err, errlen, "%s: read error", path);
            rc = RC_IO;
            goto done;
        }
        data[rest] = 0;
        const char *p = data, *end = data + rest;
        for (int i = 0; i < vi; i++)
            if (!skip_lines(&p, end, el[i].count)) {
                snprintf(err, errlen, "%s: truncated: ascii element \"%s\" ends early", path, el[i].name);
                rc = RC_BAD;
                goto done;
            }
        /* Every vertex needs at least one number per property: bound n before allocating. */
        if (n > (unsigned long long)rest / 2 + 1) {
            snprintf(err, errlen, "%s: truncated: %llu vertices cannot fit in %llu bytes of ascii data", path, n, rest);
            rc = RC_BAD;
            goto done;
        }
        if (frame_alloc(f, (size_t)n, fidx[F_VOL] >= 0, fidx[F_ID] >= 0) != 0) {
            snprintf(err, errlen, "%s: out of memory for %llu particles", path, n);
            rc = RC_NOMEM;
            goto done;
        }
        int field_of[MAX_PROPS];
        for (int q = 0; q < ve->nprops; q++) field_of[q] = -1;
        for (int k = 0; k < F_COUNT; k++)
            if (fidx[k] >= 0) field_of[fidx[k]] = k;
        for (size_t i = 0; i < (size_t)n; i++) {
            for (int q = 0; q < ve->nprops; q++) {
                double v;
                int garbage = 0;
                if (!next_number(&p, end, &v, &garbage)) {
                    snprintf(err, errlen, garbage ? "%s: corrupt ascii data at vertex %zu" : "%s: truncated: ascii data ends at vertex %zu",
                             path, i);
                    rc = RC_BAD;
                    goto done;
                }
                if (ve->props[q].is_list) {
                    if (!(v >= 0 && v <= 1e6)) {
                        snprintf(err, errlen, "%s: corrupt ascii list length at vertex %zu", path, i);
                        rc = RC_BAD;
                        goto done;
                    }
                    for (long c = 0; c < (long)v; c++) {
                        double skipped;
                        if (!next_number(&p, end, &skipped, &garbage)) {
                            snprintf(err, errlen, "%s: truncated or corrupt ascii list at vertex %zu", path, i);
                            rc = RC_BAD;
                            goto done;
                        }
                    }
                } else if (field_of[q] >= 0) {
                    store(f, field_of[q], i, v);
                }
            }
        }
    }

    f->has_velocity = fidx[F_VX] >= 0 || fidx[F_VY] >= 0 || fidx[F_VZ] >= 0;
    f->has_q = fidx[F_Q] >= 0;
    f->has_material = fidx[F_MAT] >= 0;
    if (comment_dim) {
        f->dim = comment_dim;
    } else if (fidx[F_Z] < 0) {
        f->dim = 2;
    } else {
        int flat = 1;
        for (size_t i = 0; i < f->n && flat; i++) flat = f->x[3 * i + 2] == 0.0f && f->v[3 * i + 2] == 0.0f;
        f->dim = (flat && f->n > 0) ? 2 : 3;
    }
    if (has_domain) {
        f->has_domain = 1;
        for (int k = 0; k < 3; k++) {
            f->domain_min[k] = dom[k];
            f->domain_max[k] = dom[3 + k];
        }
    }

done:
    if (rc != RC_OK) sm_frame_free(f);
    free(data);
    free(hdr);
    free(el);
    fclose(fp);
    return rc;
}

int sm_frame_from_world(const sm_world *w, sm_frame *f, char *err, size_t errlen) {
    memset(f, 0, sizeof *f);
    sm_particles_view pv;
    sm_world_particles(w, &pv);
    if (frame_alloc(f, pv.n, 1, 0) != 0) {
        sm_frame_free(f);
        if (err && errlen) snprintf(err, errlen, "out of memory for a frame of %zu particles", pv.n);
        return RC_NOMEM;
    }
    const int d = pv.dim;
    f->dim = d;
    for (size_t i = 0; i < pv.n; i++) {
        for (int a = 0; a < d; a++) {
            f->x[3 * i + (size_t)a] = (float)pv.x[i * (size_t)d + (size_t)a];
            f->v[3 * i + (size_t)a] = (float)pv.v[i * (size_t)d + (size_t)a];
        }
        f->q[i] = (float)pv.q[i];
        f->volume[i] = (float)pv.vol0[i];
        f->material[i] = pv.material[i];
    }
    f->has_velocity = f->has_q = f->has_material = 1;
    const sm_world_def *def = sm_world_get_def(w);
    f->has_domain = 1;
    for (int k = 0; k < 3; k++) {
        f->domain_min[k] = def->domain_min[k];
        f->domain_max[k] = def->domain_max[k];
    }
    if (d == 2) f->domain_min[2] = f->domain_max[2] = 0;
    return RC_OK;
}
