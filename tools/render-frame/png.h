/* png.h — an image to a PNG file through libpng. */
#ifndef RF_PNG_H
#define RF_PNG_H

#include <stdint.h>

/* Write width × height RGBA pixels, bottom row first (OpenGL's order), as
 * an 8-bit RGB PNG at `path` ("-" or NULL: standard output), through a
 * temporary file renamed on success (ndo/io.h).  `compression` is zlib's
 * level, 0..9; `description` (may be NULL) goes into a tEXt chunk (where
 * the picture came from).  NDO_EIO with a detail on failure; nothing is
 * left at `path` then. */
int rf_png_write(const char *path, const uint8_t *rgba, int width, int height, int compression,
                 const char *description);

#endif
