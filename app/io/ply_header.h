/* The PLY reader's header parser (internal to app/io: ply_header.c parses, ply_read.c reads the
 * body). The header is at most 64 KiB of text, "ply" first and "end_header" last; it declares
 * elements in file order, each with scalar or list properties. */
#ifndef SM_APP_IO_PLY_HEADER_H
#define SM_APP_IO_PLY_HEADER_H

#include <stddef.h>
#include <stdio.h>

#include "sandmpm/sandmpm.h"

#define PLY_HEADER_MAX 65536
#define PLY_MAX_ELEMS 16
#define PLY_MAX_PROPS 64

typedef enum ply_type { PT_NONE = 0, PT_I8, PT_U8, PT_I16, PT_U16, PT_I32, PT_U32, PT_F32, PT_F64 } ply_type;

/* Bytes of a scalar of type t (0 for PT_NONE). */
int ply_type_size(ply_type t);

typedef struct ply_prop {
    char name[64];
    ply_type type;
    int is_list;
    ply_type count_type;
    size_t offset; /* byte offset in a binary record (fixed-size elements only) */
} ply_prop;

typedef struct ply_elem {
    char name[64];
    unsigned long long count;
    int nprops;
    ply_prop props[PLY_MAX_PROPS];
    size_t stride; /* bytes per record if fixed */
    int fixed;     /* no list properties */
} ply_elem;

enum { PLY_ASCII = 1, PLY_LE = 2, PLY_BE = 3 };

/* The vertex properties the reader keeps, in the order of ply_field_names. */
enum { F_X, F_Y, F_Z, F_VX, F_VY, F_VZ, F_MAT, F_Q, F_VOL, F_ID, F_COUNT };
extern const char *const ply_field_names[F_COUNT];

typedef struct ply_header {
    size_t length;          /* bytes of the header, end_header's line included: the body starts here */
    int format;             /* PLY_ASCII, PLY_LE or PLY_BE */
    int nel;
    ply_elem el[PLY_MAX_ELEMS];
    int vertex;             /* index of the vertex element */
    int field[F_COUNT];     /* index of each kept field among the vertex properties, or -1 */
    int comment_dim;        /* from "comment dim 2|3", else 0 */
    int has_domain;         /* from "comment domain x0 y0 z0 x1 y1 z1" */
    int z_up;               /* "comment up z": positions and velocities written z-up */
    double domain[6];
} ply_header;

/* Reads and parses the header from the start of fp. Returns SM_OK, SM_ERR_IO (read error) or
 * SM_ERR_INVALID (not PLY, malformed, unsupported, no vertex x/y), with "PATH: problem" in err. */
sm_status ply_header_read(FILE *fp, const char *path, ply_header *h, char *err, size_t errlen);

#endif
