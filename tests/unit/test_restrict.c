/* test_restrict.c — restriction (ndo/restrict.h): the inverse of
 * interpolating subdivision bit for bit, stored duplicates agreeing, the
 * procedural shapes nested across levels, every channel sampled, limits. */
#include "check.h"
#include "ndo/ndo.h"

#include <stdlib.h>
#include <string.h>

/* Every stored duplicate holds its canonical node's value. */
static int duplicates_agree(const ndo_grid *g, const char *name, size_t nb)
{
	const ndo_channel *c = ndo_grid_find(g, name);
	size_t nd = ndo_duplicate_count(g->level), *pairs = malloc(2 * nd * sizeof *pairs);
	ndo_duplicates(g->level, pairs);
	int ok = 1;
	for (size_t k = 0; k < nd; k++)
		ok &= memcmp((const char *)c->data + pairs[2 * k] * nb,
		             (const char *)c->data + pairs[2 * k + 1] * nb, nb) == 0;
	free(pairs);
	return ok;
}

static void inverts_subdivision_bit_for_bit(void)
{
	const char *shapes[] = {"sphere", "wavy", "tetra"};
	for (int s = 0; s < 3; s++)
		for (int level = 0; level <= 4; level++) {
			ndo_grid *g, *up, *down, *down2, *up2;
			ndo_shape_make(shapes[s], level, NULL, &g);
			ndo_channel *pin;
			ndo_grid_add(g, NDO_CH_PIN, NDO_U8, 1, &pin);
			for (size_t p = 0; p < g->count; p++)
				((unsigned char *)pin->data)[p] = (unsigned char)(p % 3 == 0);
			ndo_grid_sync(g);
			CHECK(ndo_subdivide(g, NDO_CORNERS_ZORIN, &up) == NDO_OK, "subdivide");
			CHECK(ndo_restrict(up, 1, &down) == NDO_OK, "restrict");
			CHECK(down->level == level && down->nchannels == g->nchannels, "%s level %d: level %d, "
			      "%d channels", shapes[s], level, down->level, down->nchannels);
			for (int q = 0; q < g->nchannels; q++) {
				const ndo_channel *a = &g->ch[q], *b = ndo_grid_find(down, a->name);
				CHECK(b && memcmp(a->data, b->data,
				                  g->count * (size_t)a->comps * ndo_type_size(a->type)) == 0,
				      "%s level %d: channel %s differs after subdivide + restrict", shapes[s],
				      level, a->name);
			}
			/* Two levels at once = one level twice. */
			ndo_subdivide(up, NDO_CORNERS_ZORIN, &up2);
			ndo_restrict(up2, 2, &down2);
			CHECK(memcmp(down2->ch[0].data, g->ch[0].data, 3 * g->count * sizeof(double)) == 0,
			      "%s level %d: restrict by 2 does not give the level back", shapes[s], level);
			ndo_grid_destroy(g), ndo_grid_destroy(up), ndo_grid_destroy(down);
			ndo_grid_destroy(up2), ndo_grid_destroy(down2);
		}
}

/* The procedural shapes are evaluated at nested parameters: level n
 * restricted is level n−1, and the sample's duplicates agree. */
static void shapes_are_nested_and_duplicates_agree(void)
{
	const char *shapes[] = {"sphere", "wavy", "tetra", "ellipsoid"};
	for (int s = 0; s < 4; s++)
		for (int level = 1; level <= 5; level++) {
			ndo_grid *fine, *coarse, *r;
			ndo_shape_make(shapes[s], level, NULL, &fine);
			ndo_shape_make(shapes[s], level - 1, NULL, &coarse);
			ndo_restrict(fine, 1, &r);
			double d = 0;
			const double *a = r->ch[0].data, *b = coarse->ch[0].data;
			for (size_t q = 0; q < 3 * coarse->count; q++)
				d = fmax(d, fabs(a[q] - b[q]));
			CHECK(d < 1e-12, "%s level %d restricted differs from level %d by %g", shapes[s],
			      level, level - 1, d);
			CHECK(duplicates_agree(r, NDO_CH_POSITION, 3 * sizeof(double)),
			      "%s level %d: duplicates disagree after restriction", shapes[s], level);
			ndo_grid_destroy(fine), ndo_grid_destroy(coarse), ndo_grid_destroy(r);
		}
}

static void limits_and_metadata(void)
{
	ndo_grid *g, *r;
	ndo_shape_make("sphere", 2, NULL, &g);
	g->time = 1.5, g->step = 7;
	ndo_grid_add_history(g, 1, (char *[]){"remesh", NULL});
	CHECK(ndo_restrict(g, 3, &r) == NDO_ERANGE && r == NULL, "restricting below level 0 must fail");
	CHECK(ndo_restrict(g, 2, &r) == NDO_OK && r->level == 0 && r->time == 1.5 && r->step == 7 &&
	      strcmp(r->history, g->history) == 0, "time, step and history are kept");
	ndo_grid_destroy(r);
	CHECK(ndo_restrict(g, 0, &r) == NDO_OK && r->level == 2 &&
	      memcmp(r->ch[0].data, g->ch[0].data, 3 * g->count * sizeof(double)) == 0,
	      "k = 0 is a copy");
	ndo_grid_destroy(r);
	ndo_grid_destroy(g);
}

int main(void)
{
	ck_program = "restrict";
	RUN(inverts_subdivision_bit_for_bit);
	RUN(shapes_are_nested_and_duplicates_agree);
	RUN(limits_and_metadata);
	return ck_failed_cases != 0;
}
