/* ndo/levels.h — a state at a coarser level and back: the nodes of level
 * L are every 2^k-th node of level L + k (the levels are nested:
 * ndo/restrict.h), and the butterfly (ndo/subdivide.h) refines them again.
 * What travels at a send level (docs/protocol.md, "Send level") and how a
 * receiver gets the simulated level back; the error of the round trip is
 * ndo_level_error().  These are the fast paths, on flat arrays with
 * buffers reused; ndo_restrict() and ndo_subdivide_levels() on whole grids
 * are their slow references (tests/unit/test_levels.c). */
#ifndef NDO_LEVELS_H
#define NDO_LEVELS_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Sample every 2^k-th node: `in` holds a level-`level` array of
 * node_bytes per node (W × H), `out` receives the level − k array
 * (0 ≤ k ≤ level).  Stored duplicates stay in agreement. */
void ndo_sample_nodes(int level, int k, size_t node_bytes, const void *in, void *out);

/* Refinement by k levels of a level-`level` array of `comps` doubles per
 * node, with its buffers kept from call to call. */
typedef struct ndo_refiner ndo_refiner;
int ndo_refiner_create(int level, int k, int comps, ndo_refiner **out); /* 0 or NDO_ENOMEM */
void ndo_refiner_destroy(ndo_refiner *r);                               /* accepts NULL */
/* The level + k array (butterfly, Zorin's corners, as ndo_subdivide), valid
 * until the next call; `coarse` itself when k is 0.  `coarse` must have
 * agreeing duplicates. */
const double *ndo_refine(ndo_refiner *r, const double *coarse);

/* The distance between two level-`level` arrays of 3 doubles a node (a
 * refined state against the exact one), over the canonical nodes where
 * mask is nonzero (mask NULL: all): the largest, the sum of squares and
 * the count.  NaN in `a` counts as an infinite distance. */
void ndo_level_error(int level, const double *a, const double *b, const uint8_t *mask,
                     double *max, double *sum2, size_t *count);

#ifdef __cplusplus
}
#endif
#endif
