/* fuzz_gridfile.c — libFuzzer target for the grid file reader.
 *
 * Feeds arbitrary bytes to ndo_grid_read as a stream of grids.  Whatever
 * it accepts must survive a write/read round trip unchanged; anything else
 * must be rejected with a status, never a crash or an out-of-bounds read
 * (the target is built with ASan and UBSan).  Run by tests/e2e/fuzz.sh
 * for a bounded time; seeds are real grid files. */
#include "ndo/ndo.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void round_trip(const ndo_grid *g)
{
	char *buf = NULL;
	size_t len = 0;
	FILE *w = open_memstream(&buf, &len);
	if (ndo_grid_write(w, g) != NDO_OK)
		abort();
	fclose(w);
	FILE *r = fmemopen(buf, len, "rb");
	ndo_grid *h;
	if (ndo_grid_read(r, &h) != NDO_OK || h->nchannels != g->nchannels ||
	    strcmp(h->history, g->history) != 0)
		abort();
	for (int c = 0; c < g->nchannels; c++)
		if (memcmp(g->ch[c].data, h->ch[c].data,
		           g->count * (size_t)g->ch[c].comps * ndo_type_size(g->ch[c].type)))
			abort();
	ndo_grid_destroy(h);
	fclose(r);
	free(buf);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	if (size == 0)
		return 0;
	FILE *f = fmemopen((void *)data, size, "rb");
	if (!f)
		return 0;
	for (int k = 0; k < 8; k++) {
		ndo_grid *g;
		int rc = ndo_grid_read(f, &g);
		if (rc != NDO_OK) {
			if (g != NULL || ndo_errdetail()[0] == '\0')
				abort(); /* a failure must leave no grid and say why */
			break;
		}
		round_trip(g);
		ndo_grid_destroy(g);
	}
	fclose(f);
	return 0;
}
