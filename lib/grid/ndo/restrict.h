/* ndo/restrict.h — the grid one level coarser: the levels are nested
 * (DESIGN.md, "The regular grid"), level n−1 is every other node of level
 * n, so restriction is sampling, the exact inverse of interpolating
 * subdivision (ndo/subdivide.h): restrict(subdivide(g)) == g bit for bit.
 *
 * Level n node (2i, 2j) is level n−1 node (i, j).  Sampling keeps the
 * stored duplicates consistent: the ghost map of level n−1 is the level-n
 * map restricted to even indices (column seam 0 ≡ 2N, the row folds at
 * B and D), so duplicates of level n−1 sample duplicates of level n. */
#ifndef NDO_RESTRICT_H
#define NDO_RESTRICT_H

#include <stddef.h>

#include "ndo/grid.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Sample one channel: `in` holds a level-`level` array of node_bytes per
 * node (W × H nodes), `out` receives the level−1 array (level ≥ 1). */
void ndo_restrict_nodes(int level, size_t node_bytes, const void *in, void *out);

/* The grid k ≥ 0 levels coarser (k = 0: a copy), every channel sampled;
 * time, step and history are copied.  NDO_ERANGE when k > g->level. */
int ndo_restrict(const ndo_grid *g, int k, ndo_grid **out);

#ifdef __cplusplus
}
#endif
#endif
