/* source.h — where the grids to draw come from, one after another.
 *
 * A source yields grids until it ends; render-frame draws each.  Today's
 * source is a list of grid files, each holding one grid or a stream of
 * grids back to back (standard input for "-"); live LCM state and LCM log
 * files are further sources behind the same two calls. */
#ifndef RF_SOURCE_H
#define RF_SOURCE_H

#include "ndo/grid.h"

typedef struct rf_source rf_source;
struct rf_source {
	/* The next grid (the caller owns it): NDO_OK, NDO_EEOF at the end,
	 * or another status with a detail that names the input. */
	int (*next)(rf_source *s, ndo_grid **out);
	void (*destroy)(rf_source *s);
	/* Where the last grid came from, for messages and PNG metadata:
	 * "a.tgrid", "standard input, grid 3". */
	char where[320];
};

/* The grid files at paths[0..n−1] ("-": standard input), each read as a
 * stream of one or more grids.  The array must outlive the source.  A file
 * that cannot be opened or holds no grid is an error when it is reached. */
int rf_source_files(int n, char *const paths[], rf_source **out);

static inline int rf_source_next(rf_source *s, ndo_grid **out) { return s->next(s, out); }
static inline void rf_source_destroy(rf_source *s) { if (s) s->destroy(s); }

#endif
