/* test_shapes.c — the procedural grids: what each shape promises, seams
 * that close without help from ndo_sync, outward orientation, nesting
 * across levels, and the measured reason equal-area is the default map. */
#include "check.h"
#include "ndo/ndo.h"

#include <stdint.h>
#include <stdlib.h>

static double norm3(const double *p)
{
	return sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
}

static void sphere_ellipsoid_wavy_tetra(void)
{
	for (int map = 0; map <= 1; map++) {
		ndo_shape_params sp;
		ndo_shape_defaults(&sp);
		sp.map = (ndo_sphere_map)map;
		ndo_grid *s, *e, *w, *t;
		ndo_shape_make("sphere", 5, &sp, &s);
		ndo_shape_make("ellipsoid", 5, &sp, &e);
		ndo_shape_make("wavy", 5, &sp, &w);
		ndo_shape_make("tetra", 5, &sp, &t);
		const double *xs = s->ch[0].data, *xe = e->ch[0].data, *xw = w->ch[0].data,
		             *xt = t->ch[0].data;
		double worst_r = 0, worst_wave = 0, worst_plane = 0;
		int scaled = 1;
		for (size_t k = 0; k < s->count; k++) {
			const double *p = xs + 3 * k;
			worst_r = fmax(worst_r, fabs(norm3(p) - 1));
			for (int c = 0; c < 3; c++)
				scaled &= xe[3 * k + c] == p[c] * sp.axes[c];
			double r = 1 + sp.amplitude * sin(sp.frequency * p[0]) * sin(sp.frequency * p[1]) *
			                   sin(sp.frequency * p[2]);
			worst_wave = fmax(worst_wave, fabs(norm3(xw + 3 * k) - r));
			/* a tetrahedron node lies on one of the four face planes,
			 * n·x = −1/3 for the face opposite vertex n */
			double best = 1e9;
			for (int v = 0; v < 4; v++) {
				const double *n = ndo_tetra_vertex[v];
				best = fmin(best, fabs(n[0] * xt[3 * k] + n[1] * xt[3 * k + 1] +
				                       n[2] * xt[3 * k + 2] + 1.0 / 3));
			}
			worst_plane = fmax(worst_plane, best);
		}
		CHECK(worst_r < 1e-15, "map %d: sphere radius off by %.3g", map, worst_r);
		CHECK(scaled, "map %d: the ellipsoid is not exactly the scaled sphere", map);
		CHECK(worst_wave < 1e-15, "map %d: wavy radius off by %.3g", map, worst_wave);
		CHECK(worst_plane < 1e-15, "tetra node off its face by %.3g", worst_plane);
		int n = s->n;
		int cc[4][2] = {{0, 0}, {n, 0}, {0, n}, {n, n}};
		for (int c = 0; c < 4; c++)
			for (int q = 0; q < 3; q++)
				CHECK_NEAR(xt[3 * ndo_node(t->w, cc[c][0], cc[c][1]) + q], ndo_tetra_vertex[c][q],
				           1e-15, "tetra corner");
		ndo_grid_destroy(s);
		ndo_grid_destroy(e);
		ndo_grid_destroy(w);
		ndo_grid_destroy(t);
	}
}

/* Both maps agree with themselves across every seam and face boundary
 * before any ndo_sync: duplicates computed independently coincide, and a
 * node on an edge between faces maps to the same point from either face. */
static void maps_close_the_seams(void)
{
	for (int map = 0; map <= 1; map++)
		for (int level = 0; level <= 6; level++) {
			int n = 1 << level, w = 2 * n + 1;
			size_t count = (size_t)w * (n + 1);
			double *x = malloc(3 * count * sizeof *x);
			for (int j = 0; j <= n; j++)
				for (int i = 0; i <= 2 * n; i++) {
					int f;
					double b[3];
					ndo_domain_locate(level, i, j, &f, b);
					ndo_domain_sphere((ndo_sphere_map)map, f, b, x + 3 * ndo_node(w, i, j));
				}
			size_t nd = ndo_duplicate_count(level), *pairs = malloc(2 * nd * sizeof *pairs);
			ndo_duplicates(level, pairs);
			double worst = 0;
			for (size_t k = 0; k < nd; k++)
				for (int c = 0; c < 3; c++)
					worst = fmax(worst, fabs(x[3 * pairs[2 * k] + c] - x[3 * pairs[2 * k + 1] + c]));
			/* nodes on the diagonals i + j = N, (i − N) + j = N and on the
			 * column i = N, seen from the other face */
			for (int j = 0; j <= n; j++) {
				int i = n - j;
				double b[3] = {0, (double)j / n, (double)i / n}, y[3];
				/* in BDC, (1−v, u+v−1, 1−u) with u = i/N, v = j/N */
				b[0] = 1 - (double)j / n;
				b[1] = 0;
				b[2] = 1 - (double)i / n;
				ndo_domain_sphere((ndo_sphere_map)map, 1, b, y);
				for (int c = 0; c < 3; c++)
					worst = fmax(worst, fabs(y[c] - x[3 * ndo_node(w, i, j) + c]));
				/* column i = N as the edge B–D of face BAD: (1−v, 0, v) */
				double b2[3] = {1 - (double)j / n, 0, (double)j / n};
				ndo_domain_sphere((ndo_sphere_map)map, 2, b2, y);
				for (int c = 0; c < 3; c++)
					worst = fmax(worst, fabs(y[c] - x[3 * ndo_node(w, n, j) + c]));
			}
			CHECK(worst < 1e-15, "map %d level %d: seams open by %.3g", map, level, worst);
			free(pairs);
			free(x);
		}
}

static void outward_and_nested(void)
{
	const char *names[] = {"tetra", "sphere", "ellipsoid", "wavy"};
	for (int s = 0; s < 4; s++)
		for (int level = 0; level <= 6; level++) {
			ndo_grid *g, *g2;
			ndo_shape_make(names[s], level, NULL, &g);
			ndo_shape_make(names[s], level + 1, NULL, &g2);
			size_t nt = ndo_triangle_count(level);
			int32_t *tri = malloc(3 * nt * sizeof *tri);
			ndo_triangles(level, tri);
			const double *x = g->ch[0].data;
			int inward = 0;
			double volume = 0;
			for (size_t t = 0; t < nt; t++) {
				const double *a = x + 3 * tri[3 * t], *b = x + 3 * tri[3 * t + 1],
				             *c = x + 3 * tri[3 * t + 2];
				double u[3], v[3], nrm[3];
				for (int q = 0; q < 3; q++)
					u[q] = b[q] - a[q], v[q] = c[q] - a[q];
				nrm[0] = u[1] * v[2] - u[2] * v[1];
				nrm[1] = u[2] * v[0] - u[0] * v[2];
				nrm[2] = u[0] * v[1] - u[1] * v[0];
				inward += nrm[0] * (a[0] + b[0] + c[0]) + nrm[1] * (a[1] + b[1] + c[1]) +
				              nrm[2] * (a[2] + b[2] + c[2]) <= 0;
				volume += (a[0] * nrm[0] + a[1] * nrm[1] + a[2] * nrm[2]) / 6;
			}
			if (s != 3) /* star-shaped about the origin: every face looks out */
				CHECK(inward == 0, "%s level %d: %d triangles face inwards", names[s], level, inward);
			CHECK(volume > 0, "%s level %d: negative volume", names[s], level);
			int moved = 0;
			for (int j = 0; j < g->h; j++)
				for (int i = 0; i < g->w; i++)
					moved += memcmp(x + 3 * ndo_node(g->w, i, j),
					                (double *)g2->ch[0].data + 3 * ndo_node(g2->w, 2 * i, 2 * j), 24) != 0;
			CHECK(moved == 0, "%s level %d: %d nodes differ at level %d", names[s], level, moved, level + 1);
			free(tri);
			ndo_grid_destroy(g);
			ndo_grid_destroy(g2);
		}
}

/* λ_max of M⁻¹L (σ = ρ = 1: the cotangent Laplacian over the lumped
 * mass), from the library's power iteration, and the largest over the
 * smallest triangle area. */
static double lambda_max(ndo_grid *g, double *area_ratio)
{
	size_t nt = ndo_triangle_count(g->level);
	int32_t *tri = malloc(3 * nt * sizeof *tri);
	ndo_triangles(g->level, tri);
	const double *x = g->ch[0].data;
	double amin = 1e300, amax = 0;
	for (size_t t = 0; t < nt; t++) {
		const double *a = x + 3 * tri[3 * t], *b = x + 3 * tri[3 * t + 1], *c = x + 3 * tri[3 * t + 2];
		double u[3], v[3], n[3];
		for (int d = 0; d < 3; d++)
			u[d] = b[d] - a[d], v[d] = c[d] - a[d];
		n[0] = u[1] * v[2] - u[2] * v[1], n[1] = u[2] * v[0] - u[0] * v[2], n[2] = u[0] * v[1] - u[1] * v[0];
		amin = fmin(amin, norm3(n)), amax = fmax(amax, norm3(n));
	}
	free(tri);
	*area_ratio = amax / amin;
	ndo_sim_params p;
	ndo_sim_defaults(&p);
	p.material.stiffness = p.material.density = 1;
	ndo_sim *s;
	ndo_critical c = {0};
	if (ndo_sim_from_grid(g, &p, &s) == NDO_OK)
		ndo_sim_critical(s, &c);
	ndo_sim_destroy(s);
	return c.lambda_max;
}

/* The measurement behind NDO_MAP_DEFAULT (docs/shapes.md): on the sphere
 * at level 5 the equal-area map's triangles vary in area ~4× against the
 * gnomonic map's ~25×, and its λ_max — so the stable explicit step, which
 * goes as 1/√λ_max — is about 4× better. */
static void equal_area_is_the_better_default(void)
{
	ndo_shape_params sp;
	ndo_shape_defaults(&sp);
	CHECK(sp.map == NDO_MAP_EQUAL_AREA, "the default map changed");
	ndo_grid *ea, *gn;
	ndo_shape_make("sphere", 5, &sp, &ea);
	sp.map = NDO_MAP_GNOMONIC;
	ndo_shape_make("sphere", 5, &sp, &gn);
	double ra, rg;
	double la = lambda_max(ea, &ra), lg = lambda_max(gn, &rg);
	printf("    level 5 sphere: equal-area λmax %.0f, area max/min %.2f; gnomonic λmax %.0f, %.2f\n",
	       la, ra, lg, rg);
	CHECK(ra < 4.5 && rg > 20, "area ratios %.2f (equal-area), %.2f (gnomonic)", ra, rg);
	CHECK(lg > 3 * la, "λmax %.0f (gnomonic) should exceed 3 × %.0f (equal-area)", lg, la);
	ndo_grid_destroy(ea);
	ndo_grid_destroy(gn);
}

static void bad_parameters(void)
{
	ndo_grid *g;
	ndo_shape_params sp;
	ndo_shape_defaults(&sp);
	CHECK(ndo_shape_make("cube", 3, NULL, &g) == NDO_ENOTFOUND && !g, "unknown shape");
	CHECK(ndo_shape_make("sphere", 11, NULL, &g) == NDO_ERANGE, "level 11");
	CHECK(ndo_shape_make("sphere", -1, NULL, &g) == NDO_ERANGE, "level -1");
	sp.axes[1] = 0;
	CHECK(ndo_shape_make("ellipsoid", 2, &sp, &g) == NDO_ERANGE, "zero axis");
	sp.axes[1] = NAN;
	CHECK(ndo_shape_make("ellipsoid", 2, &sp, &g) == NDO_ERANGE, "NaN axis");
	ndo_shape_defaults(&sp);
	sp.amplitude = 1;
	CHECK(ndo_shape_make("wavy", 2, &sp, &g) == NDO_ERANGE, "amplitude 1 would pinch the sphere");
}

int main(void)
{
	ck_program = "shapes";
	RUN(sphere_ellipsoid_wavy_tetra);
	RUN(maps_close_the_seams);
	RUN(outward_and_nested);
	RUN(equal_area_is_the_better_default);
	RUN(bad_parameters);
	return ck_failed_cases != 0;
}
