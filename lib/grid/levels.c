/* levels.c — a state at a coarser level and back (ndo/levels.h). */
#include "ndo/levels.h"

#include "ndo/grid.h"
#include "ndo/status.h"
#include "ndo/subdivide.h"
#include "ndo/topology.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void ndo_sample_nodes(int level, int k, size_t node_bytes, const void *in, void *out)
{
	const int w = (2 << level) + 1, c = level - k, wc = (2 << c) + 1, hc = (1 << c) + 1;
	const size_t s = (size_t)1 << k;
	const unsigned char *src = in;
	unsigned char *dst = out;
	for (int j = 0; j < hc; j++)
		for (int i = 0; i < wc; i++)
			memcpy(dst + ndo_node(wc, i, j) * node_bytes,
			       src + ((size_t)j * s * (size_t)w + (size_t)i * s) * node_bytes, node_bytes);
}

struct ndo_refiner {
	int level, k, comps;
	double *a, *b, *scratch;
};

static size_t nodes_of(int level)
{
	return (size_t)((2 << level) + 1) * (size_t)((1 << level) + 1);
}

int ndo_refiner_create(int level, int k, int comps, ndo_refiner **out)
{
	*out = NULL;
	if (level < 0 || k < 0 || level + k > NDO_MAX_LEVEL || comps < 1)
		return ndo__fail(NDO_ERANGE, "refine level %d by %d", level, k);
	ndo_refiner *r = calloc(1, sizeof *r);
	if (!r)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	*r = (ndo_refiner){level, k, comps, NULL, NULL, NULL};
	if (k > 0) {
		size_t n = nodes_of(level + k) * (size_t)comps;
		r->a = malloc(n * sizeof *r->a);
		r->b = malloc(n * sizeof *r->b);
		r->scratch = malloc(ndo_butterfly_scratch(level + k - 1, comps) * sizeof *r->scratch);
		if (!r->a || !r->b || !r->scratch) {
			ndo_refiner_destroy(r);
			return ndo__fail(NDO_ENOMEM, "out of memory");
		}
	}
	*out = r;
	return 0;
}

void ndo_refiner_destroy(ndo_refiner *r)
{
	if (!r)
		return;
	free(r->a), free(r->b), free(r->scratch);
	free(r);
}

const double *ndo_refine(ndo_refiner *r, const double *coarse)
{
	const double *from = coarse;
	for (int l = r->level; l < r->level + r->k; l++) {
		/* the last level lands in a: (k − 1 − (l − level)) even */
		double *to = ((r->level + r->k - 1 - l) & 1) ? r->b : r->a;
		ndo_butterfly_f64(l, r->comps, from, to, r->scratch, NDO_CORNERS_ZORIN);
		from = to;
	}
	return from;
}

void ndo_level_error(int level, const double *a, const double *b, const uint8_t *mask,
                     double *max, double *sum2, size_t *count)
{
	const int w = (2 << level) + 1, h = (1 << level) + 1;
	double m2 = 0, s = 0;
	size_t n = 0;
	for (int j = 0; j < h; j++)
		for (int i = 0; i < w; i++) {
			size_t k = ndo_node(w, i, j);
			/* inside the border every node is its own canonical one */
			int inner = i > 0 && i < w - 1 && j > 0 && j < h - 1;
			if ((mask && !mask[k]) || (!inner && ndo_canonical(level, i, j) != k))
				continue;
			double d0 = a[3 * k] - b[3 * k], d1 = a[3 * k + 1] - b[3 * k + 1],
			       d2 = a[3 * k + 2] - b[3 * k + 2];
			double d = d0 * d0 + d1 * d1 + d2 * d2;
			if (d != d)
				d = INFINITY;
			if (d > m2)
				m2 = d;
			s += d;
			n++;
		}
	*max = sqrt(m2);
	*sum2 = s;
	*count = n;
}
