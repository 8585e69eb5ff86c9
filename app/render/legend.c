/* The colour legend (sm_render_opts.legend): in the bottom-left corner of the image, over a
 * darkened box, for SM_COLOR_SPEED and SM_COLOR_Q a bar of the colour map with its range written
 * under its ends and the quantity above ("speed m/s", "q"); for SM_COLOR_MATERIAL a swatch per
 * material present in the frame (ids 0..7) with its id. Text in a 3x5 pixel font scaled with the
 * image height. Drawn after shading, so it does not depend on the scene. See internal.h. */
#include <stdio.h>
#include <string.h>

#include "app/render/internal.h"

/* 3x5 glyphs, a row a string of 3 ("#" set). */
static const struct {
    char c;
    const char *rows[5];
} font[] = {
    {'0', {"###", "#.#", "#.#", "#.#", "###"}}, {'1', {".#.", "##.", ".#.", ".#.", "###"}},
    {'2', {"##.", "..#", ".#.", "#..", "###"}}, {'3', {"##.", "..#", ".#.", "..#", "##."}},
    {'4', {"#.#", "#.#", "###", "..#", "..#"}}, {'5', {"###", "#..", "##.", "..#", "##."}},
    {'6', {".##", "#..", "###", "#.#", "###"}}, {'7', {"###", "..#", ".#.", ".#.", ".#."}},
    {'8', {"###", "#.#", "###", "#.#", "###"}}, {'9', {"###", "#.#", "###", "..#", "##."}},
    {'.', {"...", "...", "...", "...", ".#."}}, {'-', {"...", "...", "###", "...", "..."}},
    {'+', {"...", ".#.", "###", ".#.", "..."}}, {'/', {"..#", "..#", ".#.", "#..", "#.."}},
    {'e', {"...", "##.", "###", "#..", ".##"}}, {'s', {"...", ".##", ".#.", "..#", "##."}},
    {'p', {"...", "##.", "#.#", "##.", "#.."}}, {'d', {"..#", ".##", "#.#", "#.#", ".##"}},
    {'m', {"...", "###", "###", "#.#", "#.#"}}, {'q', {"...", ".##", "#.#", ".##", "..#"}},
    {'a', {"...", ".##", "#.#", "#.#", ".##"}}, {'t', {".#.", "###", ".#.", ".#.", ".##"}},
    {'r', {"...", "#.#", "##.", "#..", "#.."}}, {'i', {".#.", "...", ".#.", ".#.", ".#."}},
    {'l', {".#.", ".#.", ".#.", ".#.", ".##"}},
};

/* The legend's pixel scale and geometry. */
typedef struct legend {
    uint8_t *rgb;
    int W, H, s; /* s: pixels per font pixel */
} legend;

static void put(const legend *L, int x, int y, const uint8_t c[3]) {
    if (x < 0 || y < 0 || x >= L->W || y >= L->H) return;
    memcpy(L->rgb + 3 * ((size_t)y * (size_t)L->W + (size_t)x), c, 3);
}

static void fill(const legend *L, int x0, int y0, int w, int h, const uint8_t c[3]) {
    for (int y = y0; y < y0 + h; y++)
        for (int x = x0; x < x0 + w; x++) put(L, x, y, c);
}

/* Halves the brightness of a box (the text's background). */
static void darken(const legend *L, int x0, int y0, int w, int h) {
    for (int y = y0 < 0 ? 0 : y0; y < y0 + h && y < L->H; y++)
        for (int x = x0 < 0 ? 0 : x0; x < x0 + w && x < L->W; x++)
            for (int c = 0; c < 3; c++) L->rgb[3 * ((size_t)y * (size_t)L->W + (size_t)x) + (size_t)c] /= 2;
}

/* Width in pixels of text. */
static int text_width(const legend *L, const char *t) { return (int)strlen(t) * 4 * L->s; }

/* Text with its top-left at (x, y), white; unknown characters are spaces. */
static void text(const legend *L, int x, int y, const char *t) {
    static const uint8_t white[3] = {240, 240, 240};
    for (; *t; t++, x += 4 * L->s) {
        int g = -1;
        for (int k = 0; k < (int)(sizeof font / sizeof font[0]); k++)
            if (font[k].c == *t) g = k;
        if (g < 0) continue;
        for (int r = 0; r < 5; r++)
            for (int c = 0; c < 3; c++)
                if (font[g].rows[r][c] == '#') fill(L, x + c * L->s, y + r * L->s, L->s, L->s, white);
    }
}

static void encode(const rctx *R, const float lin[3], uint8_t out[3]) {
    for (int c = 0; c < 3; c++) {
        float v = lin[c] < 0 ? 0 : lin[c] > 1 ? 1 : lin[c];
        out[c] = R->enc[(int)(v * 4095.0f + 0.5f)];
    }
}

/* The colour map bar, its range and its quantity. */
static void bar_legend(const rctx *R, const legend *L) {
    const int s = L->s, m = 3 * s, bw = 64 * s < L->W / 3 ? 64 * s : L->W / 3, bh = 3 * s;
    char lo[32], hi[32];
    snprintf(lo, sizeof lo, "%.3g", R->cmin);
    snprintf(hi, sizeof hi, "%.3g", R->cmax);
    const char *title = R->o->color == SM_COLOR_SPEED ? "speed m/s" : "q";
    const int boxw = bw + 2 * m, boxh = 5 * s + s + bh + s + 5 * s + 2 * m;
    const int x0 = m, y0 = L->H - m - boxh;
    darken(L, x0, y0, boxw, boxh);
    text(L, x0 + m, y0 + m, title);
    const int by = y0 + m + 6 * s;
    for (int x = 0; x < bw; x++) {
        uint8_t c[3];
        encode(R, R->cmap_lin[bw > 1 ? x * 255 / (bw - 1) : 0], c);
        fill(L, x0 + m + x, by, 1, bh, c);
    }
    text(L, x0 + m, by + bh + s, lo);
    text(L, x0 + m + bw - text_width(L, hi) + s, by + bh + s, hi);
}

/* A swatch per material present, with its id. */
static void material_legend(const rctx *R, const legend *L) {
    int present[8] = {0}, n = 0;
    for (size_t i = 0; i < R->f->n; i++) present[R->f->material[i] & 7] = 1;
    for (int k = 0; k < 8; k++) n += present[k];
    if (n == 0) return;
    const int s = L->s, m = 3 * s, sw = 5 * s, step = sw + 3 * s;
    const int boxw = (text_width(L, "material") > n * step ? text_width(L, "material") : n * step) + 2 * m;
    const int boxh = 5 * s + s + sw + s + 5 * s + 2 * m;
    const int x0 = m, y0 = L->H - m - boxh;
    darken(L, x0, y0, boxw, boxh);
    text(L, x0 + m, y0 + m, "material");
    int x = x0 + m;
    for (int k = 0; k < 8; k++) {
        if (!present[k]) continue;
        uint8_t c[3];
        encode(R, R->pal_lin[k], c);
        fill(L, x, y0 + m + 6 * s, sw, sw, c);
        char id[2] = {(char)('0' + k), 0};
        text(L, x + s, y0 + m + 7 * s + sw, id);
        x += step;
    }
}

void render_draw_legend(const rctx *R, uint8_t *rgb) {
    legend L = {rgb, R->W, R->H, R->H / 180 > 1 ? R->H / 180 : 1};
    if (R->o->color == SM_COLOR_SPEED || R->o->color == SM_COLOR_Q) bar_legend(R, &L);
    else if (R->o->color == SM_COLOR_MATERIAL) material_legend(R, &L);
}
