/* domain_spring.c — the thesis' stretch-optimized gnomonic projection of
 * the tetrahedral domain (ndo/domain.h, thesis §4.2.2.1, eqs. 4.3–4.6,
 * figure 4.5b). */
#include "ndo/domain.h"
#include "ndo/topology.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ndo/status.h"

static void unit3(double a[3])
{
	double r = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
	a[0] /= r, a[1] /= r, a[2] /= r;
}

static double tri_area(const double *a, const double *b, const double *c)
{
	double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
	double v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
	double x = u[1] * v[2] - u[2] * v[1], y = u[2] * v[0] - u[0] * v[2],
	       z = u[0] * v[1] - u[1] * v[0];
	return 0.5 * sqrt(x * x + y * y + z * z);
}

/* Relax one level: every canonical node moves to the stiffness-weighted
 * mean of its six lattice neighbours (the equilibrium of tension springs,
 * eq. 4.4's scaling, held on the sphere by eq. 4.3's field), damped by
 * half; stiffness per edge from the standardized areas of its two
 * triangles (eqs. 4.5–4.6), recomputed every iteration. */
static void relax(int level, int iters, double *s, double *area, double *next)
{
	int n = 1 << level, w = 2 * n + 1, h = n + 1;
	size_t count = (size_t)w * h;
	for (int it = 0; it < iters; it++) {
		/* area of triangle k around node (i,j): node, dir k, dir k+1;
		 * each cell's two triangles, indexed by their lower-left node */
		double mean = 0, var = 0;
		size_t nt = 0;
		for (int j = 0; j < n; j++)
			for (int i = 0; i < 2 * n; i++) {
				size_t a = ndo_node(w, i, j), b = ndo_node(w, i + 1, j),
				       c = ndo_node(w, i, j + 1), d = ndo_node(w, i + 1, j + 1);
				area[2 * a] = tri_area(s + 3 * a, s + 3 * b, s + 3 * c);
				area[2 * a + 1] = tri_area(s + 3 * b, s + 3 * d, s + 3 * c);
				mean += area[2 * a] + area[2 * a + 1];
				nt += 2;
			}
		mean /= nt;
		for (int j = 0; j < n; j++)
			for (int i = 0; i < 2 * n; i++) {
				size_t a = ndo_node(w, i, j);
				var += (area[2 * a] - mean) * (area[2 * a] - mean) +
				       (area[2 * a + 1] - mean) * (area[2 * a + 1] - mean);
			}
		double sd = sqrt(var / nt);
		if (!(sd > 0))
			sd = 1;
		memcpy(next, s, count * 3 * sizeof(double));
		for (int j = 0; j <= n; j++)
			for (int i = 0; i <= 2 * n; i++) {
				size_t me = ndo_node(w, i, j);
				if (ndo_canonical(level, i, j) != me)
					continue;
				double acc[3] = {0, 0, 0}, wsum = 0;
				for (int k = 0; k < 6; k++) {
					int ii = i + ndo_dirs[k][0], jj = j + ndo_dirs[k][1];
					int gi = ii, gj = jj;
					ndo_ghost(level, &gi, &gj);
					size_t nb = ndo_node(w, gi, gj);
					/* the edge's two triangles: (me, k−1, k) and (me, k, k+1);
					 * triangle (p, p+d_m, p+d_{m+1}) is a lower (d_m = (1,0))
					 * or upper cell triangle; find its area by its nodes */
					double ak[2];
					for (int t = 0; t < 2; t++) {
						int m0 = (k + 5 + t) % 6, m1 = (m0 + 1) % 6;
						int ai = i + ndo_dirs[m0][0], aj = j + ndo_dirs[m0][1];
						int bi = i + ndo_dirs[m1][0], bj = j + ndo_dirs[m1][1];
						ndo_ghost(level, &ai, &aj);
						ndo_ghost(level, &bi, &bj);
						ak[t] = tri_area(s + 3 * me, s + 3 * ndo_node(w, ai, aj),
						                 s + 3 * ndo_node(w, bi, bj));
					}
					double z = 0.5 * ((ak[0] - mean) + (ak[1] - mean)) / sd;
					double kk = z + 1 > 0.05 ? z + 1 : 0.05;
					acc[0] += kk * s[3 * nb];
					acc[1] += kk * s[3 * nb + 1];
					acc[2] += kk * s[3 * nb + 2];
					wsum += kk;
				}
				double *p = next + 3 * me;
				for (int c = 0; c < 3; c++)
					p[c] = 0.5 * p[c] + 0.5 * acc[c] / wsum;
				unit3(p);
			}
		ndo_sync(level, next, 3 * sizeof(double));
		memcpy(s, next, count * 3 * sizeof(double));
	}
	(void)h;
}

int ndo_domain_spring(int level, int iterations, double *s)
{
	if (level < 0 || level > NDO_MAX_LEVEL || iterations < 0)
		return ndo__fail(NDO_ERANGE, "spring domain: level %d or iterations %d out of range",
		                 level, iterations);
	/* Coarse to fine: relax at level 1, carry to the next level (new nodes
	 * at the normalized midpoints of their edges), relax again — a
	 * relaxation converges across a grid of N nodes in ~N² sweeps, a
	 * level at a time in a constant number. */
	int top = level;
	int n = 1 << top, w = 2 * n + 1, h = n + 1;
	size_t count = (size_t)w * h;
	double *cur = malloc(count * 3 * sizeof(double));
	double *tmp = malloc(count * 3 * sizeof(double));
	double *area = malloc(count * 2 * sizeof(double));
	if (!cur || !tmp || !area) {
		free(cur), free(tmp), free(area);
		return ndo__fail(NDO_ENOMEM, "spring domain: out of memory");
	}
	int l0 = top < 1 ? top : 1;
	{
		int nn = 1 << l0, ww = 2 * nn + 1;
		for (int j = 0; j <= nn; j++)
			for (int i = 0; i <= 2 * nn; i++) {
				int face;
				double b[3];
				ndo_domain_locate(l0, i, j, &face, b);
				ndo_domain_sphere(NDO_MAP_GNOMONIC, face, b, cur + 3 * ndo_node(ww, i, j));
			}
	}
	for (int l = l0;; l++) {
		relax(l, l <= 2 ? iterations : 0, cur, area, tmp); /* see the header */
		if (l == top)
			break;
		int nn = 1 << l, ww = 2 * nn + 1, n2 = 2 * nn, w2 = 2 * n2 + 1;
		for (int j = 0; j <= n2; j++)
			for (int i = 0; i <= 2 * n2; i++) {
				/* parents: the lattice points (i/2, j/2) rounded both ways
				 * along the edge the new node sits on */
				int i0 = i / 2, j0 = j / 2, i1 = (i + 1) / 2, j1 = (j + 1) / 2;
				if ((i & 1) && (j & 1)) /* diagonal edge (i0+1, j0)–(i0, j0+1) */
					i0 = i / 2 + 1, j0 = j / 2, i1 = i / 2, j1 = j / 2 + 1;
				const double *a = cur + 3 * ndo_node(ww, i0, j0),
				             *b = cur + 3 * ndo_node(ww, i1, j1);
				double *p = tmp + 3 * ndo_node(w2, i, j);
				for (int c = 0; c < 3; c++)
					p[c] = a[c] + b[c];
				unit3(p);
			}
		memcpy(cur, tmp, (size_t)w2 * (n2 + 1) * 3 * sizeof(double));
		ndo_sync(l + 1, cur, 3 * sizeof(double));
	}
	memcpy(s, cur, count * 3 * sizeof(double));
	free(cur), free(tmp), free(area);
	return NDO_OK;
}
