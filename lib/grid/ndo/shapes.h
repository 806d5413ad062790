/* ndo/shapes.h — procedural grids for tests and samples.
 *
 *   tetra      the regular tetrahedron itself (unit circumradius)
 *   sphere     the unit sphere, through the tetrahedron→sphere map
 *   ellipsoid  exactly the sphere grid scaled by (a, b, c) along x, y, z
 *   wavy       the sphere with waves, radius 1 + A sin(F x) sin(F y) sin(F z)
 *              at the sphere point (x, y, z) (thesis figures 5.3, 5.6)
 */
#ifndef NDO_SHAPES_H
#define NDO_SHAPES_H

#include "ndo/domain.h"
#include "ndo/grid.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ndo_shape_params {
	ndo_sphere_map map; /* sphere, ellipsoid, wavy; NDO_MAP_DEFAULT */
	double axes[3];     /* ellipsoid semi-axes; default 1.5, 1, 0.75 */
	double amplitude;   /* wavy; default 0.08 */
	double frequency;   /* wavy; default 5 */
} ndo_shape_params;

/* The default map, chosen by measurement (docs/shapes.md): equal-area. */
#define NDO_MAP_DEFAULT NDO_MAP_EQUAL_AREA

/* Fill *p with the defaults above. */
void ndo_shape_defaults(ndo_shape_params *p);

/* The names this build knows, NULL-terminated. */
extern const char *const ndo_shape_names[];

/* Make the shape `name` at `level` (p may be NULL for the defaults).
 * NDO_ENOTFOUND for an unknown name, NDO_ERANGE for a bad level or a
 * non-positive axis. */
int ndo_shape_make(const char *name, int level, const ndo_shape_params *p,
                   ndo_grid **out);

#ifdef __cplusplus
}
#endif
#endif
