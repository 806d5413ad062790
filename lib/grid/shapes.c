/* shapes.c — procedural grids (ndo/shapes.h). */
#include "ndo/shapes.h"
#include "ndo/status.h"
#include "ndo/topology.h"

#include <math.h>
#include <string.h>

const char *const ndo_shape_names[] = {"tetra", "sphere", "ellipsoid", "wavy", NULL};

void ndo_shape_defaults(ndo_shape_params *p)
{
	p->map = NDO_MAP_DEFAULT;
	p->axes[0] = 1.5;
	p->axes[1] = 1.0;
	p->axes[2] = 0.75;
	p->amplitude = 0.08;
	p->frequency = 5.0;
}

int ndo_shape_make(const char *name, int level, const ndo_shape_params *p,
                   ndo_grid **out)
{
	ndo_shape_params def;
	if (!p) {
		ndo_shape_defaults(&def);
		p = &def;
	}
	*out = NULL;
	int kind = -1;
	for (int k = 0; ndo_shape_names[k]; k++)
		if (strcmp(name, ndo_shape_names[k]) == 0)
			kind = k;
	if (kind < 0)
		return ndo__fail(NDO_ENOTFOUND,
		                 "unknown shape '%s' (tetra, sphere, ellipsoid, wavy)", name);
	if (kind == 2 && !(p->axes[0] > 0 && p->axes[1] > 0 && p->axes[2] > 0 &&
	                   isfinite(p->axes[0] + p->axes[1] + p->axes[2])))
		return ndo__fail(NDO_ERANGE, "ellipsoid axes must be positive and finite");
	if (kind == 3 && !(fabs(p->amplitude) < 1 && isfinite(p->frequency)))
		return ndo__fail(NDO_ERANGE, "wave amplitude must lie in (-1, 1)");
	ndo_grid *g;
	int rc = ndo_grid_create(level, &g);
	if (rc)
		return rc;
	double *x = g->ch[0].data;
	for (int j = 0; j < g->h; j++)
		for (int i = 0; i < g->w; i++) {
			int face;
			double b[3], *q = x + 3 * ndo_node(g->w, i, j);
			ndo_domain_locate(level, i, j, &face, b);
			if (kind == 0) {
				ndo_domain_tetra(face, b, q);
				continue;
			}
			ndo_domain_sphere(p->map, face, b, q);
			if (kind == 2) {
				for (int c = 0; c < 3; c++)
					q[c] *= p->axes[c];
			} else if (kind == 3) {
				double f = p->frequency,
				       r = 1 + p->amplitude * sin(f * q[0]) * sin(f * q[1]) * sin(f * q[2]);
				for (int c = 0; c < 3; c++)
					q[c] *= r;
			}
		}
	ndo_grid_sync(g);
	*out = g;
	return NDO_OK;
}
