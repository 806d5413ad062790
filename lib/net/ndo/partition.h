/* ndo/partition.h — splitting the grid among the simulating peers
 * (thesis §4.5, Table 4.1, figure 4.16; docs/bench/partition.md).
 *
 * A partition labels each of the 2N × N cells (ndo/quadtree.h) with a slot
 * 0..k−1, one per peer; slot p's region contains the cell of its point of
 * interest (except with METIS, which does not know about POIs).  From the
 * cell labels come the quad-tree leaves of each region (the tiles it
 * publishes) and the owner of every stored node (the "owner" channel).
 *
 * Methods (ndo_part_method in ndo/msg.h):
 *   NDO_PART_TABLE41   the thesis' Table 4.1 as written: every peer starts
 *                      at the leaf of its POI and climbs the tree, the
 *                      smallest region first, taking its empty siblings;
 *                      what is left goes to the smallest neighbour.
 *   NDO_PART_QUADTREE  the improvement (default): regions grow cell by cell
 *                      from their POIs, the smallest region first, each
 *                      taking the free cell with most neighbours already in
 *                      it (squares: the shortest boundary for an area on
 *                      this lattice), until each has its share; then
 *                      boundary cells move where that shortens the
 *                      boundary within ±2 % of equal shares.  Its leaves
 *                      are quad-tree nodes as in the thesis.
 *   NDO_PART_METIS     METIS k-way (libmetis) on the same cell graph,
 *                      1.05 load imbalance allowed, fixed seed; part p goes
 *                      to the peer whose POI it holds where possible.
 *   NDO_PART_BANDS     k bands of whole cell rows (all 2N cells of a row,
 *                      so a region's stored rows are whole rows), cut at
 *                      row boundaries (2N cell edges each) balanced by the
 *                      stored nodes each row owns; a band goes to the peer
 *                      whose POI it holds where possible.  Needs k <= N.
 */
#ifndef NDO_PARTITION_H
#define NDO_PARTITION_H

#include <stdint.h>

#include "ndo/msg.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Partition a level-`level` grid among k peers (1..NDO_MAX_PEERS) with
 * points of interest poi[k] (faces, 0..4^(n+1)−1, or −1: "anywhere" — such
 * a peer gets the cell farthest from the others' POIs).  cell: 2N × N
 * ints, written with slots 0..k−1.  pois_used (may be NULL): k faces, the
 * POIs after defaults were chosen.  Returns 0, NDO_EINVAL, NDO_ENOMEM. */
int ndo_partition(int level, ndo_part_method method, int k, const int32_t *poi,
                  int32_t *cell, int32_t *pois_used);

/* Largest region's share over the mean (1 = perfect), and the cut length
 * (ndo_cells_cut()). */
double ndo_partition_imbalance(int level, const int32_t *cell, int k);

/* The owner channel from cell slots: node_owner (W × H ints) gets
 * ids[slot] of the cell (min(i, 2N−1), min(j, N−1)) for the node's
 * canonical stored index, so stored duplicates agree and every node lies
 * in a tile of its owner's region. */
void ndo_partition_node_owner(int level, const int32_t *cell, const int32_t *ids,
                              int32_t *node_owner);

/* The cell slots (2N × N ints) of a partition message: each leaf's slot
 * over its cells.  The message must be validated (ndo_msg_validate: its
 * leaves cover every cell exactly once). */
void ndo_partition_cells(int level, const ndo_msg_partition_t *p, int32_t *cell);

/* Name and parse ("quadtree", "table41", "metis", "bands"); parse: −1 if unknown. */
const char *ndo_part_method_name(ndo_part_method m);
int ndo_part_method_parse(const char *s);

/* METIS alone (used by ndo_partition): parts 0..k−1 of the cell graph.
 * Returns 0, or NDO_EINVAL when METIS fails. */
int ndo_partition_metis(int level, int k, int32_t *cell);

#ifdef __cplusplus
}
#endif
#endif
