/* ndo/tile.h — grid ⇄ state tiles (ndo/msg.h tile_t, raw f64 encoding).
 * Values are node-major over the range, row by row; each node carries
 * its channels in bit order: position (3), velocity (3), rest (3), pin
 * (1, as 0.0/1.0). */
#ifndef NDO_TILE_H
#define NDO_TILE_H

#include "ndo/grid.h"
#include "ndo/msg.h"
#include "ndo/quadtree.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Fill t's range, depth, channels, encoding and values (malloc'd: free
 * t->values) from g for quad-tree node q.  The grid's channels must be
 * f64 (pin u8); a missing channel sends zeros; NDO_TILE_COARSE in
 * `channels` is kept as given (g is then the send level's grid).  0 or
 * NDO_ENOMEM. */
int ndo_tile_pack(const ndo_grid *g, ndo_quad q, int channels, ndo_msg_tile_t *t);

/* Write a validated tile into g: every node of its range where `owner` is
 * NULL or owner[node] == `only` (the tile's sender normally).  A vector
 * whose first component is NaN is not written: a decoded tile
 * (ndo_codec_decode_tile) marks so what it does not carry.  Returns the
 * nodes taken.  Stored duplicates are made equal afterwards by the
 * caller (ndo_grid_sync) once all tiles are in. */
size_t ndo_tile_apply(ndo_grid *g, const ndo_msg_tile_t *t, const int32_t *owner,
                      int32_t only);

/* A deep copy of a raw tile (values malloc'd: free out->values; the
 * header is copied as is).  0 or NDO_ENOMEM. */
int ndo_tile_copy(const ndo_msg_tile_t *t, ndo_msg_tile_t *out);

#ifdef __cplusplus
}
#endif
#endif
