/* PNG files through libpng; see png.h. libpng reports errors by longjmp to the setjmp in the
 * *_core functions, which own nothing that a longjmp would leak. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <png.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "app/errbuf.h"
#include "app/io/files.h"
#include "app/io/png.h"

typedef struct png_err {
    char msg[200];
} png_err;

static void png_error_fn(png_structp png, png_const_charp msg) {
    png_err *e = png_get_error_ptr(png);
    if (e) snprintf(e->msg, sizeof e->msg, "%s", msg);
    png_longjmp(png, 1);
}

static void png_warn_fn(png_structp png, png_const_charp msg) {
    (void)png;
    (void)msg;
}

/* The libpng part of a write: 0, or -1 with a message in pe (out of memory: -2). */
static int png_write_core(FILE *fp, int w, int h, const uint8_t *rgb, png_err *pe) {
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, pe, png_error_fn, png_warn_fn);
    if (!png) return -2;
    png_infop info = png_create_info_struct(png);
    if (!info) {
        png_destroy_write_struct(&png, NULL);
        return -2;
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        return -1;
    }
    png_init_io(png, fp);
    png_set_IHDR(png, info, (png_uint_32)w, (png_uint_32)h, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_set_compression_level(png, 3);
    png_write_info(png, info);
    for (int y = 0; y < h; y++) png_write_row(png, (png_const_bytep)(rgb + (size_t)y * (size_t)w * 3));
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &info);
    return 0;
}

sm_status sm_png_write(const char *path, int w, int h, const uint8_t *rgb, char *err, size_t errlen) {
    char own_err[8];
    sm_errbuf_or_own(&err, &errlen, own_err, sizeof own_err);
    if (w < 1 || h < 1 || w > 65535 || h > 65535 || !rgb) {
        snprintf(err, errlen, "%s: bad image size %d x %d", path, w, h);
        return SM_ERR_INVALID;
    }
    sm_atomic_file a;
    sm_status st = sm_atomic_open(&a, path, err, errlen);
    if (st != SM_OK) return st;
    png_err pe;
    pe.msg[0] = 0;
    errno = 0;
    int r = png_write_core(a.f, w, h, rgb, &pe);
    if (r != 0) {
        int e = sm_atomic_error(&a) ? sm_atomic_error(&a) : errno;
        sm_atomic_abort(&a);
        if (r == -2) {
            snprintf(err, errlen, "%s: out of memory", path);
            return SM_ERR_NOMEM;
        }
        snprintf(err, errlen, "%s: %s", path, e ? strerror(e) : pe.msg[0] ? pe.msg : "PNG write failed");
        return SM_ERR_IO;
    }
    return sm_atomic_commit(&a, err, errlen);
}

/* The libpng part of a read (after the signature): 0 with *out malloc'ed, -1 (message in pe), -2. */
static int png_read_core(FILE *fp, png_uint_32 *pw_out, png_uint_32 *ph_out, uint8_t **out, png_err *pe) {
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, pe, png_error_fn, png_warn_fn);
    if (!png) return -2;
    png_infop info = png_create_info_struct(png);
    if (!info) {
        png_destroy_read_struct(&png, NULL, NULL);
        return -2;
    }
    uint8_t *volatile buf = NULL;
    png_bytep *volatile rows = NULL;
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_read_struct(&png, &info, NULL);
        free(buf);
        free(rows);
        return -1;
    }
    png_init_io(png, fp);
    png_set_sig_bytes(png, 8);
    png_set_user_limits(png, 65535, 65535);
    png_read_info(png, info);
    png_uint_32 pw = png_get_image_width(png, info), ph = png_get_image_height(png, info);
    int ct = png_get_color_type(png, info), bd = png_get_bit_depth(png, info);
    if (bd == 16) png_set_strip_16(png);
    if (ct == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
    if ((ct == PNG_COLOR_TYPE_GRAY || ct == PNG_COLOR_TYPE_GRAY_ALPHA) && bd < 8) png_set_expand_gray_1_2_4_to_8(png);
    if (ct == PNG_COLOR_TYPE_GRAY || ct == PNG_COLOR_TYPE_GRAY_ALPHA) png_set_gray_to_rgb(png);
    if (ct & PNG_COLOR_MASK_ALPHA) png_set_strip_alpha(png);
    if (png_get_valid(png, info, PNG_INFO_tRNS)) png_set_strip_alpha(png);
    png_set_interlace_handling(png);
    png_read_update_info(png, info);
    if (png_get_rowbytes(png, info) != (size_t)pw * 3) png_error(png, "unexpected row size after conversion to RGB");
    buf = malloc((size_t)pw * ph * 3);
    if (!buf) png_error(png, "out of memory");
    rows = malloc(ph * sizeof *rows);
    if (!rows) png_error(png, "out of memory");
    for (png_uint_32 y = 0; y < ph; y++) rows[y] = buf + (size_t)y * pw * 3;
    png_read_image(png, rows);
    png_read_end(png, NULL);
    png_destroy_read_struct(&png, &info, NULL);
    free(rows);
    *pw_out = pw;
    *ph_out = ph;
    *out = buf;
    return 0;
}

sm_status sm_png_read(const char *path, int *w, int *h, uint8_t **rgb, char *err, size_t errlen) {
    char own_err[8];
    sm_errbuf_or_own(&err, &errlen, own_err, sizeof own_err);
    *rgb = NULL;
    *w = *h = 0;
    FILE *fp = sm_open_read(path, err, errlen);
    if (!fp) return SM_ERR_IO;
    unsigned char sig[8];
    if (fread(sig, 1, 8, fp) != 8 || png_sig_cmp(sig, 0, 8)) {
        fclose(fp);
        snprintf(err, errlen, "%s: not a PNG file", path);
        return SM_ERR_INVALID;
    }
    png_err pe;
    pe.msg[0] = 0;
    png_uint_32 pw = 0, ph = 0;
    int r = png_read_core(fp, &pw, &ph, rgb, &pe);
    fclose(fp);
    if (r == -2) {
        snprintf(err, errlen, "%s: out of memory", path);
        return SM_ERR_NOMEM;
    }
    if (r != 0) {
        snprintf(err, errlen, "%s: corrupt PNG: %s", path, pe.msg);
        return SM_ERR_INVALID;
    }
    *w = (int)pw;
    *h = (int)ph;
    return SM_OK;
}
