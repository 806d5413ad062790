/* colorbar.c — colour map, labels and the colour bar (colorbar.h). */
#include "colorbar.h"

#include "ndo/status.h"

#include <fontconfig/fontconfig.h>
#include <ft2build.h>
#include FT_FREETYPE_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void rf_viridis(float out[256][3])
{
	/* A degree-6 polynomial fit of matplotlib's viridis table by Matt
	 * Zucker (public domain, shadertoy.com/view/WlfXRN): within 3.3/255
	 * of the table everywhere, which no reader can see. */
	static const double c[7][3] = {
		{0.2777273272234177, 0.005407344544966578, 0.3340998053353061},
		{0.1050930431085774, 1.404613529898575, 1.384590162594685},
		{-0.3308618287255563, 0.214847559468213, 0.09509516302823659},
		{-4.634230498983486, -5.799100973351585, -19.33244095627987},
		{6.228269936347081, 14.17993336680509, 56.69055260068105},
		{4.776384997670288, -13.74514537774601, -65.35303263337234},
		{-5.435455855934631, 4.645852612178535, 26.3124352495832}};
	for (int k = 0; k < 256; k++) {
		double t = k / 255.0;
		for (int ch = 0; ch < 3; ch++) {
			double v = c[6][ch];
			for (int d = 5; d >= 0; d--)
				v = v * t + c[d][ch];
			out[k][ch] = (float)(v < 0 ? 0 : v > 1 ? 1 : v);
		}
	}
}

struct rf_font {
	FT_Library lib;
	FT_Face face;
	int size; /* pixels, as last set */
};

int rf_font_open(const char *path, rf_font **out)
{
	*out = NULL;
	char *found = NULL;
	if (!path) {
		FcConfig *cfg = FcInitLoadConfigAndFonts();
		FcPattern *pat = cfg ? FcNameParse((const FcChar8 *)"sans-serif") : NULL;
		if (pat) {
			FcConfigSubstitute(cfg, pat, FcMatchPattern);
			FcDefaultSubstitute(pat);
			FcResult res;
			FcPattern *match = FcFontMatch(cfg, pat, &res);
			FcChar8 *file;
			if (match && FcPatternGetString(match, FC_FILE, 0, &file) == FcResultMatch)
				found = strdup((const char *)file);
			FcPatternDestroy(match);
			FcPatternDestroy(pat);
		}
		FcConfigDestroy(cfg);
		FcFini();
		if (!found)
			return ndo__fail(NDO_ENOTFOUND, "no sans-serif font for the colour bar's labels "
			                 "(install fonts-dejavu-core, or give --font)");
		path = found;
	}
	rf_font *f = calloc(1, sizeof *f);
	if (!f) {
		free(found);
		return ndo__fail(NDO_ENOMEM, "out of memory");
	}
	int rc = NDO_OK;
	if (FT_Init_FreeType(&f->lib))
		rc = ndo__fail(NDO_ENOMEM, "cannot start FreeType");
	else if (FT_New_Face(f->lib, path, 0, &f->face))
		rc = ndo__fail(NDO_EFORMAT, "font %s: not a font FreeType reads", path);
	free(found);
	if (rc != NDO_OK) {
		rf_font_close(f);
		return rc;
	}
	*out = f;
	return NDO_OK;
}

void rf_font_close(rf_font *f)
{
	if (!f)
		return;
	if (f->face)
		FT_Done_Face(f->face);
	if (f->lib)
		FT_Done_FreeType(f->lib);
	free(f);
}

/* The image is stored bottom row first; y here counts from the top. */
static uint8_t *pixel(uint8_t *rgba, int width, int height, int x, int y)
{
	return rgba + ((size_t)(height - 1 - y) * (size_t)width + (size_t)x) * 4;
}

static void blend(uint8_t *p, const uint8_t color[3], int alpha)
{
	for (int c = 0; c < 3; c++)
		p[c] = (uint8_t)((p[c] * (255 - alpha) + color[c] * alpha + 127) / 255);
}

/* Width in pixels of `text` at the font's size. */
static int text_width(rf_font *f, const char *text)
{
	int w = 0;
	for (const char *s = text; *s; s++)
		if (!FT_Load_Char(f->face, (unsigned char)*s, FT_LOAD_DEFAULT))
			w += (int)(f->face->glyph->advance.x >> 6);
	return w;
}

/* Draw `text` with its baseline at y (from the top), starting at x. */
static void draw_text(uint8_t *rgba, int width, int height, rf_font *f, int x, int y,
                      const char *text, const uint8_t color[3])
{
	for (const char *s = text; *s; s++) {
		if (FT_Load_Char(f->face, (unsigned char)*s, FT_LOAD_RENDER))
			continue;
		FT_GlyphSlot g = f->face->glyph;
		for (unsigned r = 0; r < g->bitmap.rows; r++)
			for (unsigned c = 0; c < g->bitmap.width; c++) {
				int px = x + g->bitmap_left + (int)c, py = y - g->bitmap_top + (int)r;
				if (px < 0 || py < 0 || px >= width || py >= height)
					continue;
				int a = g->bitmap.buffer[r * (unsigned)g->bitmap.pitch + c];
				if (a)
					blend(pixel(rgba, width, height, px, py), color, a);
			}
		x += (int)(g->advance.x >> 6);
	}
}

void rf_colorbar_draw(uint8_t *rgba, int width, int height, const float cmap[256][3], double lo,
                      double hi, const char *name, const float background[3], rf_font *font)
{
	int size = height / 40 > 9 ? height / 40 : 9;
	FT_Set_Pixel_Sizes(font->face, 0, (FT_UInt)size);
	double lum = 0.2126 * background[0] + 0.7152 * background[1] + 0.0722 * background[2];
	uint8_t ink[3] = {0, 0, 0};
	if (lum < 0.5)
		ink[0] = ink[1] = ink[2] = 255;

	char labels[3][32];
	double values[3] = {hi, 0.5 * (lo + hi), lo};
	int label_w = 0;
	for (int k = 0; k < 3; k++) {
		snprintf(labels[k], sizeof labels[k], "%.4g", values[k]);
		int w = text_width(font, labels[k]);
		label_w = w > label_w ? w : label_w;
	}
	int bar_w = size, gap = size / 2, margin = size;
	int bar_h = height * 3 / 5;
	int x1 = width - margin - label_w - gap; /* bar's right edge */
	int x0 = x1 - bar_w;
	int y0 = (height - bar_h) / 2, y1 = y0 + bar_h; /* top, bottom (from the top) */
	if (x0 < 0 || y0 < size * 2)
		return; /* too small a picture for a bar */
	for (int y = y0; y < y1; y++) {
		double t = (double)(y1 - 1 - y) / (bar_h - 1);
		const float *c = cmap[(int)lround(t * 255)];
		uint8_t col[3] = {(uint8_t)lroundf(c[0] * 255), (uint8_t)lroundf(c[1] * 255),
		                  (uint8_t)lroundf(c[2] * 255)};
		for (int x = x0; x < x1; x++)
			memcpy(pixel(rgba, width, height, x, y), col, 3);
	}
	/* A thin frame, and ticks at the labelled values. */
	for (int x = x0 - 1; x <= x1; x++) {
		blend(pixel(rgba, width, height, x, y0 - 1), ink, 255);
		blend(pixel(rgba, width, height, x, y1), ink, 255);
	}
	for (int y = y0; y < y1; y++) {
		blend(pixel(rgba, width, height, x0 - 1, y), ink, 255);
		blend(pixel(rgba, width, height, x1, y), ink, 255);
	}
	for (int k = 0; k < 3; k++) {
		int y = y0 + (y1 - 1 - y0) * k / 2;
		for (int x = x1; x < x1 + gap / 2 + 1 && x < width; x++)
			blend(pixel(rgba, width, height, x, y), ink, 255);
		draw_text(rgba, width, height, font, x1 + gap, y + size * 3 / 8, labels[k], ink);
	}
	int name_w = text_width(font, name);
	int nx = x0 + bar_w / 2 - name_w / 2;
	if (nx + name_w > width - 2)
		nx = width - 2 - name_w;
	draw_text(rgba, width, height, font, nx < 0 ? 0 : nx, y0 - size, name, ink);
}
