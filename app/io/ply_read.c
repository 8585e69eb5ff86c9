/* PLY frame reader; see ply.h. The header is parsed by ply_header.c; this file reads the vertex
 * data: binary (either byte order) in chunks, checked against the file size before anything is
 * allocated for it, so that a corrupt count cannot make us allocate or read past the end; or ascii,
 * number by number, with list properties skipped. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <limits.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "app/errbuf.h"
#include "app/io/files.h"
#include "app/io/ply.h"
#include "app/io/ply_header.h"

/* A scalar of type t at p, in the file's byte order (swap: reverse the bytes first). */
static double decode(const unsigned char *p, ply_type t, int swap) {
    unsigned char b[8];
    int n = ply_type_size(t);
    if (swap)
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

static sm_status alloc_vertices(sm_frame *f, const ply_header *h, const char *path, char *err, size_t errlen) {
    const unsigned long long n = h->el[h->vertex].count;
    if (sm_frame_alloc(f, (size_t)n, h->field[F_VOL] >= 0, h->field[F_ID] >= 0) != SM_OK) {
        snprintf(err, errlen, "%s: out of memory for %llu particles", path, n);
        return SM_ERR_NOMEM;
    }
    return SM_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* Binary body                                                                                  */

/* Byte offset of the vertex data: the header and the fixed-size elements before the vertices. */
static sm_status binary_offset(const ply_header *h, const char *path, unsigned long long *off, char *err,
                               size_t errlen) {
    *off = h->length;
    for (int i = 0; i <= h->vertex; i++) {
        const ply_elem *e = &h->el[i];
        if (!e->fixed) {
            snprintf(err, errlen, "%s: element \"%s\" has list properties; binary files with lists in or before "
                                  "the vertex element are not supported", path, e->name);
            return SM_ERR_INVALID;
        }
        if (i == h->vertex) break;
        if (e->stride && e->count > (ULLONG_MAX - *off) / e->stride) {
            snprintf(err, errlen, "%s: corrupt header: element \"%s\" is too large", path, e->name);
            return SM_ERR_INVALID;
        }
        *off += e->count * e->stride;
    }
    return SM_OK;
}

static sm_status read_binary(FILE *fp, unsigned long long fsize, const char *path, const ply_header *h, sm_frame *f,
                             char *err, size_t errlen) {
    unsigned long long off;
    sm_status st = binary_offset(h, path, &off, err, errlen);
    if (st != SM_OK) return st;
    const ply_elem *ve = &h->el[h->vertex];
    const unsigned long long n = ve->count;
    const size_t stride = ve->stride;
    if (stride == 0 || n > (ULLONG_MAX - off) / stride || off + n * stride > fsize) {
        unsigned long long have = fsize > off ? fsize - off : 0;
        snprintf(err, errlen, "%s: truncated: %llu vertices of %zu bytes need %llu bytes of data, the file has %llu",
                 path, n, stride, stride ? n * stride : 0ull, have);
        return SM_ERR_INVALID;
    }
    if ((st = alloc_vertices(f, h, path, err, errlen)) != SM_OK) return st;
    if (off > (unsigned long long)LONG_MAX || fseek(fp, (long)off, SEEK_SET) != 0) {
        snprintf(err, errlen, "%s: seek failed: %s", path, strerror(errno));
        return SM_ERR_IO;
    }
    const int swap = (h->format == PLY_BE) != host_is_big_endian();
    size_t per = (4u << 20) / stride; /* records per chunk of about 4 MiB (no more than the file has) */
    if (per == 0) per = 1;
    if (n > 0 && (unsigned long long)per > n) per = (size_t)n;
    unsigned char *data = malloc(per * stride);
    if (!data) {
        snprintf(err, errlen, "%s: out of memory", path);
        return SM_ERR_NOMEM;
    }
    for (size_t i0 = 0; i0 < (size_t)n && st == SM_OK; i0 += per) {
        size_t cnt = (size_t)n - i0 < per ? (size_t)n - i0 : per;
        if (fread(data, stride, cnt, fp) != cnt) {
            snprintf(err, errlen, "%s: %s at vertex %zu", path, ferror(fp) ? strerror(errno) : "unexpected end of file", i0);
            st = ferror(fp) ? SM_ERR_IO : SM_ERR_INVALID;
            break;
        }
        for (int k = 0; k < F_COUNT; k++) {
            if (h->field[k] < 0) continue;
            const ply_prop *p = &ve->props[h->field[k]];
            for (size_t j = 0; j < cnt; j++) store(f, k, i0 + j, decode(data + p->offset + j * stride, p->type, swap));
        }
    }
    free(data);
    return st;
}

/* ------------------------------------------------------------------------------------------ */
/* ASCII body                                                                                   */

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

/* Next number token in ASCII data; 0 at the end or on a token that is not a number (*garbage). */
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

/* The properties of vertex i from *p; field_of[q]: the kept field of property q, or -1. */
static sm_status ascii_vertex(const char **p, const char *end, const ply_elem *ve, const int *field_of, size_t i,
                              sm_frame *f, const char *path, char *err, size_t errlen) {
    for (int q = 0; q < ve->nprops; q++) {
        double v;
        int garbage = 0;
        if (!next_number(p, end, &v, &garbage)) {
            snprintf(err, errlen, garbage ? "%s: corrupt ascii data at vertex %zu" : "%s: truncated: ascii data ends at vertex %zu",
                     path, i);
            return SM_ERR_INVALID;
        }
        if (ve->props[q].is_list) {
            if (!(v >= 0 && v <= 1e6)) {
                snprintf(err, errlen, "%s: corrupt ascii list length at vertex %zu", path, i);
                return SM_ERR_INVALID;
            }
            for (long c = 0; c < (long)v; c++) {
                double skipped;
                if (!next_number(p, end, &skipped, &garbage)) {
                    snprintf(err, errlen, "%s: truncated or corrupt ascii list at vertex %zu", path, i);
                    return SM_ERR_INVALID;
                }
            }
        } else if (field_of[q] >= 0) {
            store(f, field_of[q], i, v);
        }
    }
    return SM_OK;
}

/* Parses the vertices from the body text [p, end) (the elements before them are skipped). */
static sm_status parse_ascii(const char *p, const char *end, const ply_header *h, sm_frame *f, const char *path,
                             char *err, size_t errlen) {
    const unsigned long long rest = (unsigned long long)(end - p);
    for (int i = 0; i < h->vertex; i++)
        if (!skip_lines(&p, end, h->el[i].count)) {
            snprintf(err, errlen, "%s: truncated: ascii element \"%s\" ends early", path, h->el[i].name);
            return SM_ERR_INVALID;
        }
    const ply_elem *ve = &h->el[h->vertex];
    const unsigned long long n = ve->count;
    /* Every vertex needs at least one number per property: bound n before allocating. */
    if (n > rest / 2 + 1) {
        snprintf(err, errlen, "%s: truncated: %llu vertices cannot fit in %llu bytes of ascii data", path, n, rest);
        return SM_ERR_INVALID;
    }
    sm_status st = alloc_vertices(f, h, path, err, errlen);
    int field_of[PLY_MAX_PROPS];
    for (int q = 0; q < ve->nprops; q++) field_of[q] = -1;
    for (int k = 0; k < F_COUNT; k++)
        if (h->field[k] >= 0) field_of[h->field[k]] = k;
    for (size_t i = 0; i < (size_t)n && st == SM_OK; i++) st = ascii_vertex(&p, end, ve, field_of, i, f, path, err, errlen);
    return st;
}

static sm_status read_ascii(FILE *fp, unsigned long long fsize, const char *path, const ply_header *h, sm_frame *f,
                            char *err, size_t errlen) {
    unsigned long long rest = fsize > h->length ? fsize - h->length : 0;
    if (rest > (unsigned long long)(SIZE_MAX - 1)) {
        snprintf(err, errlen, "%s: file too large", path);
        return SM_ERR_INVALID;
    }
    char *data = malloc((size_t)rest + 1);
    if (!data) {
        snprintf(err, errlen, "%s: out of memory", path);
        return SM_ERR_NOMEM;
    }
    sm_status st;
    if (fseek(fp, (long)h->length, SEEK_SET) != 0 || fread(data, 1, (size_t)rest, fp) != (size_t)rest) {
        snprintf(err, errlen, "%s: read error", path);
        st = SM_ERR_IO;
    } else {
        data[rest] = 0;
        st = parse_ascii(data, data + rest, h, f, path, err, errlen);
    }
    free(data);
    return st;
}

/* ------------------------------------------------------------------------------------------ */
/* The frame                                                                                    */

/* has_*, the dimension (from the header, else from z) and the domain; a z-up file's positions and
 * velocities turned back to sandmpm's y-up axes, (X, Y, Z) -> (X, Z, -Y) (app/io/fields.h). */
static void finish_frame(const ply_header *h, sm_frame *f) {
    for (size_t i = 0; h->z_up && i < f->n; i++) {
        float *x = f->x + 3 * i, *v = f->v + 3 * i, y = x[1], vy = v[1];
        x[1] = x[2], x[2] = -y;
        v[1] = v[2], v[2] = -vy;
    }
    f->has_velocity = h->field[F_VX] >= 0 || h->field[F_VY] >= 0 || h->field[F_VZ] >= 0;
    f->has_q = h->field[F_Q] >= 0;
    f->has_material = h->field[F_MAT] >= 0;
    if (h->comment_dim) {
        f->dim = h->comment_dim;
    } else if (h->field[F_Z] < 0) {
        f->dim = 2;
    } else {
        int flat = 1;
        for (size_t i = 0; i < f->n && flat; i++) flat = f->x[3 * i + 2] == 0.0f && f->v[3 * i + 2] == 0.0f;
        f->dim = (flat && f->n > 0) ? 2 : 3;
    }
    if (h->has_domain) {
        f->has_domain = 1;
        for (int k = 0; k < 3; k++) {
            f->domain_min[k] = h->domain[k];
            f->domain_max[k] = h->domain[3 + k];
        }
    }
}

/* The file's size; a directory is refused. */
static sm_status file_size(FILE *fp, const char *path, unsigned long long *size, char *err, size_t errlen) {
    struct stat st;
    if (fstat(fileno(fp), &st) != 0) {
        snprintf(err, errlen, "%s: cannot stat: %s", path, strerror(errno));
        return SM_ERR_IO;
    }
    if (S_ISDIR(st.st_mode)) {
        snprintf(err, errlen, "%s: is a directory, not a PLY file", path);
        return SM_ERR_IO;
    }
    *size = (unsigned long long)st.st_size;
    return SM_OK;
}

sm_status sm_ply_read(const char *path, sm_frame *f, char *err, size_t errlen) {
    memset(f, 0, sizeof *f);
    char own_err[8];
    sm_errbuf_or_own(&err, &errlen, own_err, sizeof own_err);
    FILE *fp = sm_open_read(path, err, errlen);
    if (!fp) return SM_ERR_IO;
    unsigned long long fsize = 0;
    sm_status st = file_size(fp, path, &fsize, err, errlen);
    ply_header *h = NULL;
    if (st == SM_OK && !(h = malloc(sizeof *h))) {
        snprintf(err, errlen, "%s: out of memory", path);
        st = SM_ERR_NOMEM;
    }
    if (st == SM_OK) st = ply_header_read(fp, path, h, err, errlen);
    if (st == SM_OK)
        st = h->format == PLY_ASCII ? read_ascii(fp, fsize, path, h, f, err, errlen)
                                    : read_binary(fp, fsize, path, h, f, err, errlen);
    if (st == SM_OK) finish_frame(h, f);
    else sm_frame_free(f);
    free(h);
    fclose(fp);
    return st;
}
