/* ndo/export.h — writing a grid where the output path says: a mesh file
 * through assimp, or a grid file.
 *
 *   .obj  Wavefront OBJ (no .mtl)        .ply  binary PLY
 *   .stl  binary STL                     .glb  binary glTF 2
 *   .gltf glTF 2 (with its .bin beside)  .tgrid, anything else, "-": grid file
 *
 * A mesh holds each distinct vertex once (2·4^n + 2 of them) with an
 * area-weighted normal, and the 4^(n+1) triangles, wound so that their
 * normals point out of the enclosed volume (flipped if the grid is inside
 * out), so any viewer shows a closed surface.  Positions are single
 * precision in these formats (assimp's); the grid file keeps everything.
 * Every file is written to a temporary name and renamed on success.
 */
#ifndef NDO_EXPORT_H
#define NDO_EXPORT_H

#include "ndo/grid.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The assimp format id for the path's extension, or NULL for a grid file
 * (no extension, ".tgrid", "-" or NULL). */
const char *ndo_mesh_format(const char *path);

/* 1 if the extension is one ndo neither exports nor treats as a grid
 * file (".png", ".txt", ...): callers reject such a path. */
int ndo_unknown_extension(const char *path);

/* Write the grid's surface as a mesh in assimp format `format` (an id
 * from ndo_mesh_format()). */
int ndo_export_mesh(const char *path, const char *format, const ndo_grid *g);

/* Write `g` to `path` as the extension says (table above). */
int ndo_grid_export(const char *path, const ndo_grid *g);

#ifdef __cplusplus
}
#endif
#endif
