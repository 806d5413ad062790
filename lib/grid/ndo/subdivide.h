/* ndo/subdivide.h — modified butterfly refinement of grids, as
 * convolutions over the ghost-padded grid (thesis §4.2.3, figures
 * 4.10–4.12; Zorin, Schröder, Sweldens 1996).
 *
 * Level n → n+1: node (i, j) keeps its values at (2i, 2j) (the scheme
 * interpolates); the new nodes on horizontal, vertical and diagonal edges,
 * (2i+1, 2j), (2i, 2j+1) and (2i+1, 2j+1), come from three rotations of
 * the regular 8-point mask
 *
 *        -1/16     1/8    -1/16
 *            1/2   (o)   1/2
 *        -1/16     1/8    -1/16
 *
 * applied to the grid padded with one ring of ghost cells (ndo_pad()).
 * Every channel is refined: float channels by the mask, integer channels
 * (pin masks, owner labels) by the minimum of the edge's two ends, so no
 * value is invented.
 */
#ifndef NDO_SUBDIVIDE_H
#define NDO_SUBDIVIDE_H

#include "ndo/grid.h"

#ifdef __cplusplus
extern "C" {
#endif

/* What happens at the four valence-3 corners of the tetrahedron. */
typedef enum ndo_corner_rule {
	/* Zorin et al.'s rule for an edge with a valence-3 end e and other
	 * end o: 3/4 e + 5/12 o − 1/12 (n1 + n2), n1, n2 the other
	 * neighbours of e; the average of both ends' rules when both are
	 * extraordinary (level 0).  The default; it is what OpenMesh's
	 * ModifiedButterflyT computes. */
	NDO_CORNERS_ZORIN = 0,
	/* The thesis' "duplicated edges": the corner is treated as a regular
	 * vertex of valence 3×2, i.e. the regular mask everywhere. */
	NDO_CORNERS_THESIS = 1
} ndo_corner_rule;

/* The weights (the rules, apart from the data layout). */
#define NDO_BF_EDGE (1.0 / 2)    /* the edge's two ends */
#define NDO_BF_WING (1.0 / 8)    /* the two opposite vertices */
#define NDO_BF_FAR (-1.0 / 16)   /* the four outer vertices */
#define NDO_BF3_SELF (3.0 / 4)   /* valence 3: the extraordinary vertex */
#define NDO_BF3_S0 (5.0 / 12)    /* valence 3: the edge's other end (the
                                    thesis prints 1/12, a typo) */
#define NDO_BF3_S12 (-1.0 / 12)  /* valence 3: the other two neighbours */

/* Refine a grid by one level.  Fails with NDO_ERANGE at NDO_MAX_LEVEL.
 * Time, step and history are copied. */
int ndo_subdivide(const ndo_grid *in, ndo_corner_rule rule, ndo_grid **out);

/* Refine by k ≥ 0 levels (k = 0 gives a copy). */
int ndo_subdivide_levels(const ndo_grid *in, int k, ndo_corner_rule rule,
                         ndo_grid **out);

/* The kernel on one array of doubles, for callers that reuse buffers:
 * `in` holds a level-`level` channel (W·H·comps), `out` receives the
 * level+1 channel ((2W−1)(2H−1)·comps), `scratch` holds at least
 * ndo_butterfly_scratch(level, comps) doubles.  `in` must have agreeing
 * duplicates; `out` will too. */
size_t ndo_butterfly_scratch(int level, int comps);
void ndo_butterfly_f64(int level, int comps, const double *in, double *out,
                       double *scratch, ndo_corner_rule rule);

#ifdef __cplusplus
}
#endif
#endif
