/* ndo/quadtree.h — the quad tree over the grid's cells (thesis §4.5,
 * figure 4.15) and the cell graph the partitions work on.
 *
 * Cells: a level-n grid has 2N × N cells, cell (i, j) spanning nodes
 * (i, j)–(i+1, j+1), 0 ≤ i < 2N, 0 ≤ j < N, index j*2N + i.  Triangle
 * ("face") f lies in cell f/2 (ndo_triangles() order).
 *
 * The tree: depth 0 is the whole 2N × N rectangle; depth 1 its two N × N
 * squares (the "minimal tree" of figure 4.15a: two faces of the
 * tetrahedron each); below that every node splits into four squares, down
 * to single cells at depth n+1.  A node (depth d, column qi, row qj) with
 * side s = N >> (d−1) covers cells [qi·s, (qi+1)·s) × [qj·s, (qj+1)·s) and
 * the nodes (i, j) with qi·s ≤ i ≤ (qi+1)·s, qj·s ≤ j ≤ (qj+1)·s: a tile
 * carries its border, so neighbouring tiles share a row of nodes (the
 * thesis' "4n wasted space" that keeps boundaries in every tile).
 */
#ifndef NDO_QUADTREE_H
#define NDO_QUADTREE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ndo_quad {
	int depth;  /* 0..level+1 */
	int qi, qj; /* column, row among the nodes of this depth */
} ndo_quad;

/* Deepest depth: single cells, level+1. */
static inline int ndo_quad_max_depth(int level) { return level + 1; }

/* Nodes of the tree at `depth`: columns × rows (1 × 1 at depth 0,
 * 2^d × 2^(d−1) below). */
void ndo_quad_dims(int depth, int *cols, int *rows);

/* Cells per side: 2N × N at depth 0 (*w = 2N, *h = N), s × s below. */
void ndo_quad_cells(int level, int depth, int *w, int *h);

/* The node index range, inclusive: columns i0..i1, rows j0..j1. */
void ndo_quad_range(int level, ndo_quad q, int *i0, int *j0, int *i1, int *j1);

/* Stored nodes in the range: (i1−i0+1)(j1−j0+1). */
size_t ndo_quad_node_count(int level, int depth);

/* The tree node whose range is exactly i0..i1 × j0..j1 at `depth`:
 * 0, or NDO_ERANGE when no such node exists at this level. */
int ndo_quad_from_range(int level, int depth, int i0, int j0, int i1, int j1,
                        ndo_quad *q);

/* A unique code ≥ 0 for a tree node (depth by depth, row-major inside a
 * depth), and back.  ndo_quad_decode() returns NDO_ERANGE for a code that
 * names no node at this level. */
int32_t ndo_quad_code(ndo_quad q);
int ndo_quad_decode(int level, int32_t code, ndo_quad *q);

/* The node at `depth` that contains cell (ci, cj). */
ndo_quad ndo_quad_at(int level, int depth, int ci, int cj);

/* Cells: 2N × N.  The four edge-neighbours of cell (i, j) through the
 * seams (left, right, below, above), as cell indices.  Across the bottom
 * row, cell (i, 0) borders cell (2N−1−i, 0) (the fold at B); across the
 * top row likewise (the fold at D); columns wrap. */
static inline size_t ndo_cell_count(int level) { return (size_t)2 << (2 * level); }
void ndo_cell_neighbors(int level, int i, int j, int32_t nb[4]);

/* The cell of face (triangle) f. */
static inline int32_t ndo_face_cell(int32_t face) { return face / 2; }

/* Cut length of a cell labelling: the number of cell edges (seams
 * included) whose two cells have different labels, in lattice units. */
long ndo_cells_cut(int level, const int32_t *cell_label);

/* The maximal tree nodes over which `cell_label` (2N × N ints) is
 * constant and ≥ 0: the leaves of the labelling.  Nodes are emitted in
 * depth-first order (children in row-major order), never shallower than
 * `min_depth` (so a caller can cap the size of each node).  *codes and
 * *labels are malloc'd arrays of *count entries (free() them); cells
 * labelled < 0 belong to no leaf.  Returns 0 or NDO_ENOMEM. */
int ndo_quad_leaves(int level, const int32_t *cell_label, int min_depth,
                    int32_t **codes, int32_t **labels, size_t *count);

/* Tree nodes, none shallower than `min_depth`, that cover every cell
 * labelled `label`: a node is taken whole when at least `fill` (0..1) of
 * its cells carry the label, else split (single cells are always taken).
 * fill 1 gives the label's leaves (ndo_quad_leaves()); less gives fewer,
 * larger nodes that also cover some cells of other labels — fewer
 * messages for a region with a ragged edge, at the price of some bytes.
 * Depth-first order; *codes is malloc'd.  0 or NDO_ENOMEM. */
int ndo_quad_cover(int level, const int32_t *cell_label, int32_t label, int min_depth,
                   double fill, int32_t **codes, size_t *count);

#ifdef __cplusplus
}
#endif
#endif
