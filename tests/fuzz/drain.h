/* drain.h — the fuzz targets' end of a message: the receiver reads what
 * the bus holds and frees every message and tile it decoded; the sender
 * reads its own copies, so the bus can free them. */
#ifndef NDO_FUZZ_DRAIN_H
#define NDO_FUZZ_DRAIN_H

#include "ndo/link.h"
#include "ndo/msg.h"
#include "ndo/net.h"

#include <stdlib.h>

static void fuzz_discard(void *u, const char *c, const void *d, size_t n)
{
	(void)u, (void)c, (void)d, (void)n;
}

static void fuzz_drain(ndo_net *rx, ndo_link *tx)
{
	ndo_net_poll(rx, 0);
	ndo_link_poll(tx, 0, fuzz_discard, NULL);
	ndo_msg q;
	while (ndo_net_next(rx, &q))
		ndo_msg_free(&q);
	ndo_msg *tiles;
	size_t n;
	if (ndo_net_take_tiles(rx, &tiles, &n) == 0) {
		for (size_t k = 0; k < n; k++)
			ndo_msg_free(&tiles[k]);
		free(tiles);
	}
}

#endif
