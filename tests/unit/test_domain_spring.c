/* ndo_domain_spring(): the thesis' stretch-optimized gnomonic domain —
 * unit vectors, seams exact, no flipped triangle, and more uniform
 * triangle areas than the gnomonic projection it starts from. */
#include "check.h"
#include "ndo/ndo.h"

#include <stdlib.h>

static double tri_area(const double *a, const double *b, const double *c, double *orient)
{
	double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
	double v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
	double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
	*orient = n[0] * (a[0] + b[0] + c[0]) + n[1] * (a[1] + b[1] + c[1]) + n[2] * (a[2] + b[2] + c[2]);
	return 0.5 * sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
}

/* min/max chord-triangle area and the number of flipped triangles */
static double area_ratio(int level, const double *s, int *flipped)
{
	size_t nt = ndo_triangle_count(level);
	int32_t *tri = malloc(3 * nt * sizeof *tri);
	ndo_triangles(level, tri);
	double lo = INFINITY, hi = 0;
	*flipped = 0;
	for (size_t t = 0; t < nt; t++) {
		double o, a = tri_area(s + 3 * tri[3 * t], s + 3 * tri[3 * t + 1], s + 3 * tri[3 * t + 2], &o);
		lo = fmin(lo, a), hi = fmax(hi, a);
		*flipped += !(o > 0);
	}
	free(tri);
	return lo / hi;
}

static void spring_domain_is_a_closed_unflipped_sphere(void)
{
	for (int level = 0; level <= 5; level++) {
		int n = 1 << level, w = 2 * n + 1;
		size_t count = (size_t)w * (n + 1);
		double *s = malloc(count * 3 * sizeof *s), *g = malloc(count * 3 * sizeof *g);
		CHECK(ndo_domain_spring(level, 30, s) == NDO_OK, "level %d: %s", level, ndo_errdetail());
		for (size_t k = 0; k < count; k++) {
			double r = sqrt(s[3 * k] * s[3 * k] + s[3 * k + 1] * s[3 * k + 1] + s[3 * k + 2] * s[3 * k + 2]);
			CHECK_NEAR(r, 1.0, 1e-12, "node on the unit sphere");
		}
		for (int j = 0; j <= n; j++)
			for (int i = 0; i <= 2 * n; i++) {
				size_t k = ndo_node(w, i, j), c = ndo_canonical(level, i, j);
				CHECK(memcmp(s + 3 * k, s + 3 * c, 3 * sizeof *s) == 0,
				      "level %d: node (%d,%d) differs from its canonical copy", level, i, j);
			}
		int flipped, gflipped;
		double ratio = area_ratio(level, s, &flipped);
		CHECK(flipped == 0, "level %d: %d flipped triangles", level, flipped);
		/* the gnomonic projection it improves on */
		for (int j = 0; j <= n; j++)
			for (int i = 0; i <= 2 * n; i++) {
				int face;
				double b[3];
				ndo_domain_locate(level, i, j, &face, b);
				ndo_domain_sphere(NDO_MAP_GNOMONIC, face, b, g + 3 * ndo_node(w, i, j));
			}
		double gratio = area_ratio(level, g, &gflipped);
		if (level >= 2)
			CHECK(ratio > 1.5 * gratio, "level %d: area ratio %g, gnomonic %g", level, ratio, gratio);
		free(s), free(g);
	}
}

static void spring_domain_rejects_bad_arguments(void)
{
	double s[3];
	CHECK(ndo_domain_spring(-1, 10, s) == NDO_ERANGE, "level -1 accepted");
	CHECK(ndo_domain_spring(NDO_MAX_LEVEL + 1, 10, s) == NDO_ERANGE, "level 11 accepted");
	CHECK(ndo_domain_spring(2, -1, s) == NDO_ERANGE, "negative iterations accepted");
}

int main(void)
{
	ck_program = "test_domain_spring";
	RUN(spring_domain_is_a_closed_unflipped_sphere);
	RUN(spring_domain_rejects_bad_arguments);
	return ck_failed_cases != 0;
}
