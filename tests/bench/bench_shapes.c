/* bench_shapes.c — how the two tetrahedron→sphere maps grid the sphere:
 * triangle areas (max/min and the 1st..99th percentile spread), angles,
 * and λ_max of M⁻¹L (cotangent Laplacian, lumped mass; the library's power
 * iteration, ndo_sim_critical), which bounds the
 * stable step of every explicit integrator as 1/√λ_max.  A Markdown table
 * on stdout (docs/shapes.md explains it). */
#include "ndo/ndo.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

static int cmpd(const void *a, const void *b)
{
	double x = *(const double *)a, y = *(const double *)b;
	return x < y ? -1 : x > y;
}

int main(void)
{
	printf("| level | map | area max/min | area p99/p1 | smallest angle | largest angle | λ_max(M⁻¹L) |\n");
	printf("|---:|---|---:|---:|---:|---:|---:|\n");
	for (int level = 3; level <= 7; level++)
		for (int map = 0; map <= 1; map++) {
			ndo_shape_params sp;
			ndo_shape_defaults(&sp);
			sp.map = (ndo_sphere_map)map;
			ndo_grid *g;
			ndo_shape_make("sphere", level, &sp, &g);
			size_t nt = ndo_triangle_count(level);
			int32_t *tri = malloc(3 * nt * sizeof *tri);
			ndo_triangles(level, tri);
			const double *x = g->ch[0].data;
			double *area = malloc(nt * sizeof *area), amin = 180, amax = 0;
			for (size_t t = 0; t < nt; t++) {
				const double *p[3] = {x + 3 * tri[3 * t], x + 3 * tri[3 * t + 1], x + 3 * tri[3 * t + 2]};
				double u[3], v[3];
				for (int d = 0; d < 3; d++)
					u[d] = p[1][d] - p[0][d], v[d] = p[2][d] - p[0][d];
				double c0 = u[1] * v[2] - u[2] * v[1], c1 = u[2] * v[0] - u[0] * v[2],
				       c2 = u[0] * v[1] - u[1] * v[0];
				double A = 0.5 * sqrt(c0 * c0 + c1 * c1 + c2 * c2);
				area[t] = A;
				for (int q = 0; q < 3; q++) {
					double a[3], b[3];
					for (int d = 0; d < 3; d++)
						a[d] = p[(q + 1) % 3][d] - p[q][d], b[d] = p[(q + 2) % 3][d] - p[q][d];
					double dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
					double ang = acos(dot / sqrt((a[0] * a[0] + a[1] * a[1] + a[2] * a[2]) *
					                             (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]))) * 180 / M_PI;
					amin = fmin(amin, ang), amax = fmax(amax, ang);
				}
			}
			/* λ_max(M⁻¹K) with σ = ρ = 1, the library's power iteration */
			ndo_sim_params sp2;
			ndo_sim_defaults(&sp2);
			sp2.material.stiffness = sp2.material.density = 1;
			ndo_sim *sim;
			ndo_critical crit = {0};
			if (ndo_sim_from_grid(g, &sp2, &sim) == NDO_OK)
				ndo_sim_critical(sim, &crit);
			ndo_sim_destroy(sim);
			double lam = crit.lambda_max;
			qsort(area, nt, sizeof *area, cmpd);
			printf("| %d | %s | %.2f | %.2f | %.1f° | %.1f° | %.0f |\n", level,
			       map ? "equal-area" : "gnomonic", area[nt - 1] / area[0],
			       area[nt * 99 / 100] / area[nt / 100], amin, amax, lam);
			free(tri), free(area);
			ndo_grid_destroy(g);
		}
	return 0;
}
