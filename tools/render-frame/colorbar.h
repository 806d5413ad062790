/* colorbar.h — the colour map and the colour bar drawn over a picture
 * coloured by a scalar. */
#ifndef RF_COLORBAR_H
#define RF_COLORBAR_H

#include <stdint.h>

/* Matplotlib's viridis (perceptually uniform, readable in grey and by
 * colour-blind readers) at 256 points, 0..1 per channel. */
void rf_viridis(float out[256][3]);

typedef struct rf_font rf_font;

/* Load a font for labels: `path`, or when NULL the system's sans-serif
 * through fontconfig.  Fails with a detail when there is none. */
int rf_font_open(const char *path, rf_font **out);
void rf_font_close(rf_font *f);

/* Draw a vertical colour bar at the right of a width × height RGBA image
 * (bottom row first): the map from `lo` (bottom) to `hi` (top), three
 * value labels and the scalar's name above.  Text is black or white,
 * whichever stands out from `background`. */
void rf_colorbar_draw(uint8_t *rgba, int width, int height, const float cmap[256][3], double lo,
                      double hi, const char *name, const float background[3], rf_font *font);

#endif
