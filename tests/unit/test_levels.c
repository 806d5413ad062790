/* test_levels.c — a state at a send level and back (ndo/levels.h): the
 * fast sampling against ndo_restrict() one level at a time, the fast
 * refinement against ndo_subdivide_levels() on whole grids, and the
 * round trip's error against a plain loop over every node. */
#include "check.h"
#include "ndo/ndo.h"

#include <stdlib.h>
#include <string.h>

static void sampling_is_restriction(void)
{
	const char *shapes[] = {"wavy", "sphere"};
	for (int s = 0; s < 2; s++)
		for (int level = 0; level <= 6; level++)
			for (int k = 0; k <= level; k++) {
				ndo_grid *g, *r;
				ndo_shape_make(shapes[s], level, NULL, &g);
				CHECK(ndo_restrict(g, k, &r) == NDO_OK, "restrict");
				double *out = malloc(3 * r->count * sizeof *out);
				ndo_sample_nodes(level, k, 3 * sizeof(double), g->ch[0].data, out);
				CHECK(memcmp(out, r->ch[0].data, 3 * r->count * sizeof *out) == 0,
				      "%s level %d, k %d: sampling differs from restriction", shapes[s], level, k);
				int32_t *ids = malloc(g->count * sizeof *ids), *cid = malloc(r->count * sizeof *cid);
				for (size_t n = 0; n < g->count; n++)
					ids[n] = (int32_t)n;
				ndo_sample_nodes(level, k, sizeof *ids, ids, cid);
				int wc = (2 << (level - k)) + 1, ok = 1;
				for (size_t n = 0; n < r->count; n++) /* node (i, j) is (2^k i, 2^k j) */
					ok &= (size_t)cid[n] == ndo_node(g->w, (int)(n % (size_t)wc) << k,
					                                   (int)(n / (size_t)wc) << k);
				CHECK(ok, "level %d, k %d: a sampled node is not every 2^k-th", level, k);
				free(ids), free(cid), free(out);
				ndo_grid_destroy(g), ndo_grid_destroy(r);
			}
}

static void refinement_is_subdivision(void)
{
	for (int level = 0; level <= 5; level++)
		for (int k = 0; k <= 3 && level + k <= 7; k++) {
			ndo_grid *g, *up;
			ndo_shape_make("wavy", level, NULL, &g);
			CHECK(ndo_subdivide_levels(g, k, NDO_CORNERS_ZORIN, &up) == NDO_OK, "subdivide");
			ndo_refiner *r;
			CHECK(ndo_refiner_create(level, k, 3, &r) == 0, "refiner");
			for (int again = 0; again < 2; again++) { /* buffers reused */
				const double *out = ndo_refine(r, g->ch[0].data);
				CHECK(memcmp(out, up->ch[0].data, 3 * up->count * sizeof *out) == 0,
				      "level %d + %d: the refiner differs from ndo_subdivide_levels", level, k);
			}
			ndo_refiner_destroy(r);
			ndo_grid_destroy(g), ndo_grid_destroy(up);
		}
	ndo_refiner *r;
	CHECK(ndo_refiner_create(8, 3, 3, &r) == NDO_ERANGE && !r, "beyond the largest level");
}

/* The round trip of a level-7 state through level 4, and its error against
 * a loop over every stored node (duplicates agree, so the canonical ones
 * give the same largest distance). */
static void round_trip_error(void)
{
	const int n = 7, L = 4;
	ndo_grid *g;
	ndo_shape_make("wavy", n, NULL, &g);
	double *x = ndo_grid_f64(g, NDO_CH_POSITION, 3);
	size_t cc = (size_t)((2 << L) + 1) * (size_t)((1 << L) + 1);
	double *c = malloc(3 * cc * sizeof *c);
	ndo_sample_nodes(n, n - L, 3 * sizeof *c, x, c);
	ndo_refiner *r;
	ndo_refiner_create(L, n - L, 3, &r);
	const double *f = ndo_refine(r, c);
	double max, sum2, slow_max = 0, slow_sum = 0;
	size_t count, slow_n = 0;
	ndo_level_error(n, f, x, NULL, &max, &sum2, &count);
	for (int j = 0; j < g->h; j++)
		for (int i = 0; i < g->w; i++) {
			size_t k = ndo_node(g->w, i, j);
			double d2 = 0;
			for (int d = 0; d < 3; d++)
				d2 += (f[3 * k + d] - x[3 * k + d]) * (f[3 * k + d] - x[3 * k + d]);
			if (sqrt(d2) > slow_max)
				slow_max = sqrt(d2);
			if (ndo_canonical(n, i, j) == k)
				slow_sum += d2, slow_n++;
		}
	CHECK(count == slow_n && count == (size_t)2 * (1u << (2 * n)) + 2,
	      "canonical nodes: %zu, the slow loop's %zu, a closed level-%d surface has 2·4^n + 2", count,
	      slow_n, n);
	CHECK(max == slow_max && fabs(sum2 - slow_sum) <= 1e-12 * slow_sum,
	      "max %.17g against %.17g, sum %.17g against %.17g", max, slow_max, sum2, slow_sum);
	CHECK(max > 0, "a wavy surface is not reproduced exactly from level 4");
	/* the coarse nodes themselves come back exactly (the butterfly interpolates) */
	int ok = 1;
	for (int j = 0; j <= (1 << L); j++)
		for (int i = 0; i <= (2 << L); i++)
			ok &= memcmp(&f[3 * ndo_node(g->w, i << (n - L), j << (n - L))],
			             &c[3 * ndo_node((2 << L) + 1, i, j)], 3 * sizeof *c) == 0;
	CHECK(ok, "a coarse node moved in the refinement");
	/* a mask: none selected, nothing counted; a NaN: infinitely far */
	uint8_t *mask = calloc(g->count, 1);
	ndo_level_error(n, f, x, mask, &max, &sum2, &count);
	CHECK(count == 0 && max == 0 && sum2 == 0, "an empty mask counts nothing");
	double *y = malloc(3 * g->count * sizeof *y);
	memcpy(y, x, 3 * g->count * sizeof *y);
	y[3 * 5] = NAN;
	ndo_level_error(n, y, x, NULL, &max, &sum2, &count);
	CHECK(isinf(max), "a NaN node must count as infinitely far, got %g", max);
	free(y), free(mask), free(c);
	ndo_refiner_destroy(r);
	ndo_grid_destroy(g);
}

int main(void)
{
	ck_program = "levels";
	RUN(sampling_is_restriction);
	RUN(refinement_is_subdivision);
	RUN(round_trip_error);
	return ck_failed_cases != 0;
}
