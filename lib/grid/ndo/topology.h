/* ndo/topology.h — seams, ghost map, neighbours, triangles and distinct
 * vertices of the level-n grid (DESIGN.md, "The regular grid").
 *
 * The H × W rectangle is the unfolded tetrahedron: corners A = (0,0) =
 * (2N,0), B = (N,0), C = (0,N) = (2N,N), D = (N,N).  Stored nodes that are
 * one vertex:
 *   columns      (0, j) ≡ (2N, j)
 *   bottom row   (i, 0) ≡ (2N−i, 0)   (folds at B)
 *   top row      (i, N) ≡ (2N−i, N)   (folds at D)
 * Each cell (i, j)–(i+1, j+1) splits along (i+1, j)–(i, j+1) into the
 * triangles (i,j) (i+1,j) (i,j+1) and (i+1,j) (i+1,j+1) (i,j+1), both
 * counter-clockwise seen from outside for the shapes ndo builds.
 *
 * Of each set of stored duplicates, the one with the lowest index is
 * canonical: it is the value the others copy in ndo_sync().
 */
#ifndef NDO_TOPOLOGY_H
#define NDO_TOPOLOGY_H

#include <stddef.h>
#include <stdint.h>

#include "ndo/grid.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The six lattice directions (di, dj) in counter-clockwise order:
 * (1,0) (0,1) (-1,1) (-1,0) (0,-1) (1,-1).  Consecutive directions span a
 * triangle of the grid: node, node + dir[k], node + dir[k+1]. */
extern const int ndo_dirs[6][2];

/* Map any lattice point (i, j) to the stored node it stands for, in place
 * (DESIGN.md's ghost map): j < 0 → (2N−i, −j); j > N → (2N−i, 2N−j),
 * repeated until 0 ≤ j ≤ N; then i mod 2N.  The six neighbours of a node
 * taken through this map are exactly its mesh neighbours; each neighbour
 * of a corner comes out twice. */
void ndo_ghost(int level, int *i, int *j);

/* The canonical stored index of the vertex at lattice point (i, j) (which
 * may lie outside the rectangle: it is ghost-mapped first). */
size_t ndo_canonical(int level, int i, int j);

/* 1 if the stored node (i, j) is one of the four valence-3 corners. */
int ndo_is_corner(int level, int i, int j);

/* The stored indices of the six lattice neighbours of (i, j), in the
 * order of ndo_dirs, through the ghost map (not canonicalized). */
void ndo_neighbors(int level, int i, int j, size_t nb[6]);

/* Distinct vertices: 2·4^n + 2.  Triangles: 4^(n+1).  Stored duplicates
 * (stored nodes that are not canonical): 3N − 1. */
size_t ndo_vertex_count(int level);
size_t ndo_triangle_count(int level);
size_t ndo_duplicate_count(int level);

/* Number the distinct vertices 0..V−1 in increasing order of their
 * canonical stored index.  vid: W*H ints, the vertex id of every stored
 * node.  rep (may be NULL): V ints, the canonical stored index of every
 * vertex. */
void ndo_vertex_ids(int level, int32_t *vid, int32_t *rep);

/* The triangles as stored-node indices, 3 per triangle, 4^(n+1)
 * triangles, cell by cell in row-major order (cell (i,j) gives triangles
 * 2(j*2N+i) and 2(j*2N+i)+1).  Map through ndo_vertex_ids() for distinct
 * vertices. */
void ndo_triangles(int level, int32_t *tri);

/* The (duplicate, canonical) stored-index pairs: ndo_duplicate_count()
 * pairs, 2 size_t each. */
void ndo_duplicates(int level, size_t *pairs);

/* The stored duplicate of canonical stored node k, or −1 when it has none:
 * every canonical node has at most one (the folds of rows 0 and N, the
 * column seam), and these are ndo_duplicates()'s pairs. */
long ndo_duplicate_of(int level, size_t k);

/* Make stored duplicates agree: copy each canonical node's `node_bytes`
 * bytes (one node's values) over its duplicates in `data` (W*H nodes). */
void ndo_sync(int level, void *data, size_t node_bytes);

/* ndo_sync() on every channel of a grid. */
void ndo_grid_sync(ndo_grid *g);

/* Stored duplicates whose bytes differ from their canonical node's, over
 * every channel (0 for a grid every ndo tool wrote).  The first one found:
 * its channel name and stored node (i, j), when those pointers are not
 * NULL. */
size_t ndo_grid_unsynced(const ndo_grid *g, const char **channel, int *i, int *j);

/* Copy `src` (W*H nodes of node_bytes each) into `dst`, a
 * (W+2·pad) × (H+2·pad) array whose border of width `pad` holds the
 * ghost cells (node (i, j) of the grid at dst[(j+pad)*(W+2pad) + i+pad]). */
void ndo_pad(int level, int pad, const void *src, size_t node_bytes, void *dst);

#ifdef __cplusplus
}
#endif
#endif
