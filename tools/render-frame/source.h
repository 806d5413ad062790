/* source.h — where the grids to draw come from, one after another.
 *
 * A source yields grids until it ends; render-frame draws each.  Two
 * sources: a list of grid files, each holding one grid or a stream of
 * grids back to back (standard input for "-"); and the peers' LCM traffic,
 * live or from a log (source_lcm.c). */
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
	/* The last grid's frame number (the simulation step for LCM), or −1:
	 * number frames in order. */
	long number;
};

/* The grid files at paths[0..n−1] ("-": standard input), each read as a
 * stream of one or more grids.  The array must outlive the source.  A file
 * that cannot be opened or holds no grid is an error when it is reached. */
int rf_source_files(int n, char *const paths[], rf_source **out);

/* The peers' state over LCM (ndo/watch.h): url udpm://… (NULL: as LCM's
 * default) or file://PATH, a log of lcm-logger, read as fast as frames
 * are drawn; channels PREFIX_*; frames of the steps that are multiples of
 * `every`; a live source ends when the owner quits or after `timeout`
 * seconds of silence. */
typedef struct rf_lcm_options {
	const char *url;
	const char *prefix;
	long every;
	double timeout;
	int64_t object_id;
	const char *key;   /* --key FILE, NULL: $NDO_KEY or none */
	int hold_lost;     /* --hold-lost: draw frames with lost tiles, held */
	int passive;       /* --passive: ask for no keyframe (a log never does) */
} rf_lcm_options;
int rf_source_lcm(const rf_lcm_options *o, rf_source **out);
/* "12 frames of object …, 0 skipped incomplete (lost tiles); the owner quit" */
void rf_source_lcm_report(rf_source *s, char *buf, size_t size);

static inline int rf_source_next(rf_source *s, ndo_grid **out) { return s->next(s, out); }
static inline void rf_source_destroy(rf_source *s) { if (s) s->destroy(s); }

#endif
