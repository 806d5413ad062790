/* test_membrane — the membrane's stiffness K and mass M (lib/sim/membrane.c):
 * the stencil against the triangle-by-triangle CSR reference, symmetry,
 * positive semi-definiteness, constants in the null space, scale
 * invariance, and the sphere's spectrum σ l(l+1)/(ρR²) with its
 * multiplicities and O(h²) convergence (LAPACK's dense eigensolver). */
#include "check.h"
#include "ndo/ndo.h"

#include <stdint.h>
#include <stdlib.h>

/* LAPACK: generalized symmetric-definite eigenproblem A x = λ B x. */
void dsygvd_(int *itype, char *jobz, char *uplo, int *n, double *a, int *lda, double *b,
             int *ldb, double *w, double *work, int *lwork, int *iwork, int *liwork,
             int *info);

static const char *const shapes[] = {"tetra", "sphere", "ellipsoid", "wavy"};

static ndo_grid *shape(const char *name, int level, double scale)
{
	ndo_grid *g;
	if (ndo_shape_make(name, level, NULL, &g))
		return NULL;
	double *x = g->ch[0].data;
	for (size_t k = 0; k < 3 * g->count; k++)
		x[k] *= scale;
	return g;
}

static uint64_t rng = 12345;
static double uniform(void)
{
	rng = rng * 6364136223846793005ULL + 1442695040888963407ULL;
	return (double)(rng >> 11) / 9007199254740992.0 * 2 - 1;
}

static double max_abs_diag(const ndo_csr *K)
{
	double m = 0;
	for (int32_t i = 0; i < K->n; i++)
		for (int64_t k = K->ptr[i]; k < K->ptr[i + 1]; k++)
			if (K->col[k] == i)
				m = fmax(m, fabs(K->val[k]));
	return m;
}

/* K(i, j) of a CSR matrix (0 when absent). */
static double entry(const ndo_csr *K, int32_t i, int32_t j)
{
	for (int64_t k = K->ptr[i]; k < K->ptr[i + 1]; k++)
		if (K->col[k] == j)
			return K->val[k];
	return 0;
}

static void cotan_weights_known_triangles(void)
{
	/* Equilateral: every angle 60°, ½ cot 60° = 1/(2√3). */
	double a[3] = {0, 0, 0}, b[3] = {1, 0, 0}, c[3] = {0.5, sqrt(3) / 2, 0}, w[3];
	double area = ndo_cotan_weights(a, b, c, w);
	CHECK_NEAR(area, sqrt(3) / 4, 1e-15, "equilateral area");
	for (int k = 0; k < 3; k++)
		CHECK_NEAR(w[k], 1 / (2 * sqrt(3)), 1e-15, "equilateral weight");
	/* Right angle at a: cot 90° = 0 for edge bc; 45° at b and c. */
	double b2[3] = {1, 0, 0}, c2[3] = {0, 1, 0};
	ndo_cotan_weights(a, b2, c2, w);
	CHECK_NEAR(w[0], 0, 1e-15, "right angle weight");
	CHECK_NEAR(w[1], 0.5, 1e-15, "45 degree weight");
	CHECK_NEAR(w[2], 0.5, 1e-15, "45 degree weight");
	/* Degenerate: zero area, no weights. */
	double d[3] = {2, 0, 0};
	CHECK(ndo_cotan_weights(a, b, d, w) == 0 && w[0] == 0, "degenerate triangle has no area");
}

/* On every shape and level 1..4: the stencil equals the reference entry by
 * entry and in products; K is symmetric with zero row sums; constants
 * are in the null space exactly. */
static void stencil_matches_reference_csr(void)
{
	for (int s = 0; s < 4; s++)
		for (int level = 1; level <= 4; level++) {
			ndo_grid *g = shape(shapes[s], level, 1);
			const double *x = g->ch[0].data;
			ndo_csr K, Ks;
			ndo_stencil st = {0};
			CHECK(ndo_membrane_csr(level, x, 2.5, &K) == 0, "reference assembly");
			CHECK(ndo_stencil_build(level, x, 2.5, &st) == 0, "stencil");
			CHECK(ndo_stencil_csr(&st, &Ks) == 0, "stencil as CSR");
			double scale = max_abs_diag(&K), worst = 0, asym = 0, rows = 0;
			CHECK(K.n == (int32_t)ndo_vertex_count(level), "%s level %d: %d rows", shapes[s],
			      level, K.n);
			CHECK(K.ptr[K.n] == Ks.ptr[Ks.n], "%s level %d: %lld vs %lld nonzeros", shapes[s],
			      level, (long long)K.ptr[K.n], (long long)Ks.ptr[Ks.n]);
			for (int32_t i = 0; i < K.n; i++) {
				double sum = 0;
				for (int64_t k = K.ptr[i]; k < K.ptr[i + 1]; k++) {
					sum += K.val[k];
					asym = fmax(asym, fabs(K.val[k] - entry(&K, K.col[k], i)));
					worst = fmax(worst, fabs(K.val[k] - entry(&Ks, i, K.col[k])));
				}
				rows = fmax(rows, fabs(sum));
			}
			/* Cotangents from different vertex orders differ in the last
			 * bits: equal to a few ulps of the largest entry, not bitwise. */
			CHECK(worst <= 1e-13 * scale, "%s level %d: stencil vs CSR differ by %g", shapes[s],
			      level, worst);
			CHECK(asym == 0, "%s level %d: reference not symmetric (%g)", shapes[s], level, asym);
			CHECK(rows <= 1e-13 * scale, "%s level %d: row sum %g", shapes[s], level, rows);
			/* Products: a random field on the stored nodes (duplicates
			 * equal), the stencil vs the CSR over vertices. */
			size_t cnt = g->count;
			int32_t *vid = malloc(cnt * sizeof *vid), *rep = malloc((size_t)K.n * sizeof *rep);
			double *u = malloc(cnt * sizeof *u), *ku = malloc(cnt * sizeof *ku);
			double *uv = malloc((size_t)K.n * sizeof *uv), *kv = malloc((size_t)K.n * sizeof *kv);
			ndo_vertex_ids(level, vid, rep);
			for (int32_t i = 0; i < K.n; i++)
				uv[i] = uniform();
			for (size_t p = 0; p < cnt; p++)
				u[p] = uv[vid[p]];
			ndo_stencil_apply(&st, u, ku);
			ndo_csr_apply(&K, uv, kv, 1);
			double diff = 0, mag = 0, dup = 0;
			for (size_t p = 0; p < cnt; p++) {
				diff = fmax(diff, fabs(ku[p] - kv[vid[p]]));
				mag = fmax(mag, fabs(kv[vid[p]]));
				dup = fmax(dup, fabs(ku[p] - ku[rep[vid[p]]]));
			}
			CHECK(diff <= 1e-12 * mag, "%s level %d: K u stencil vs CSR %g (|Ku| %g)", shapes[s],
			      level, diff, mag);
			CHECK(dup == 0, "%s level %d: a duplicate's K u differs from its vertex's",
			      shapes[s], level);
			/* Constants: exactly zero, each term is c (u_p − u_q) = 0. */
			for (size_t p = 0; p < cnt; p++)
				u[p] = 3.25;
			ndo_stencil_apply(&st, u, ku);
			double cmax = 0;
			for (size_t p = 0; p < cnt; p++)
				cmax = fmax(cmax, fabs(ku[p]));
			CHECK(cmax == 0, "%s level %d: K 1 = %g, not 0", shapes[s], level, cmax);
			free(vid), free(rep), free(u), free(ku), free(uv), free(kv);
			ndo_csr_free(&K);
			ndo_csr_free(&Ks);
			ndo_stencil_free(&st);
			ndo_grid_destroy(g);
		}
}

/* libigl's test: the cotangent weights are scale invariant and rows sum
 * to zero at scales 1e-8 and 1e8; the mass scales as the area. */
static void row_sums_vanish_at_extreme_scales(void)
{
	const double scales[] = {1e-8, 1, 1e8};
	ndo_csr K[3];
	double mass[3];
	for (int k = 0; k < 3; k++) {
		ndo_grid *g = shape("wavy", 4, scales[k]);
		CHECK(ndo_membrane_csr(4, g->ch[0].data, 1, &K[k]) == 0, "assembly at scale %g",
		      scales[k]);
		double *m = malloc(g->count * sizeof *m), area;
		CHECK(ndo_lumped_mass(4, g->ch[0].data, 1, m, &area) == 0, "mass at scale %g",
		      scales[k]);
		mass[k] = area;
		double scale = max_abs_diag(&K[k]), rows = 0;
		for (int32_t i = 0; i < K[k].n; i++) {
			double sum = 0;
			for (int64_t q = K[k].ptr[i]; q < K[k].ptr[i + 1]; q++)
				sum += K[k].val[q];
			rows = fmax(rows, fabs(sum));
		}
		CHECK(rows <= 1e-13 * scale, "scale %g: row sum %g of diagonal %g", scales[k], rows,
		      scale);
		free(m);
		ndo_grid_destroy(g);
	}
	for (int k = 0; k < 3; k += 2) {
		double d = 0;
		for (int64_t q = 0; q < K[1].ptr[K[1].n]; q++)
			d = fmax(d, fabs(K[k].val[q] - K[1].val[q]));
		CHECK(d <= 1e-12 * max_abs_diag(&K[1]), "K at scale %g differs from scale 1 by %g",
		      scales[k], d);
		CHECK_NEAR(mass[k] / (scales[k] * scales[k]), mass[1], 1e-12 * mass[1],
		           "area scales as the square");
	}
	for (int k = 0; k < 3; k++)
		ndo_csr_free(&K[k]);
}

/* Dense generalized eigenvalues of (K, M) (M = identity when m is NULL). */
static double *eigenvalues(const ndo_csr *K, const double *mv)
{
	int n = K->n, itype = 1, lwork = -1, liwork = -1, info;
	double *A = calloc((size_t)n * (size_t)n, sizeof *A), *B = calloc((size_t)n * (size_t)n, sizeof *B);
	double *w = malloc((size_t)n * sizeof *w), wq;
	int iwq;
	char jobz = 'N', uplo = 'U';
	for (int i = 0; i < n; i++) {
		for (int64_t k = K->ptr[i]; k < K->ptr[i + 1]; k++)
			A[(size_t)i * (size_t)n + (size_t)K->col[k]] = K->val[k];
		B[(size_t)i * (size_t)n + (size_t)i] = mv ? mv[i] : 1;
	}
	dsygvd_(&itype, &jobz, &uplo, &n, A, &n, B, &n, w, &wq, &lwork, &iwq, &liwork, &info);
	lwork = (int)wq;
	liwork = iwq;
	double *work = malloc((size_t)lwork * sizeof *work);
	int *iwork = malloc((size_t)liwork * sizeof *iwork);
	dsygvd_(&itype, &jobz, &uplo, &n, A, &n, B, &n, w, work, &lwork, iwork, &liwork, &info);
	CHECK(info == 0, "LAPACK dsygvd info %d", info);
	free(A), free(B), free(work), free(iwork);
	return w;
}

/* K is positive semi-definite with a one-dimensional null space (per
 * coordinate): the constants. */
static void stiffness_is_positive_semidefinite(void)
{
	for (int s = 0; s < 4; s++) {
		ndo_grid *g = shape(shapes[s], 3, 1);
		ndo_csr K;
		ndo_membrane_csr(3, g->ch[0].data, 1, &K);
		double *w = eigenvalues(&K, NULL);
		double top = w[K.n - 1];
		CHECK(w[0] >= -1e-12 * top, "%s: smallest eigenvalue %g (largest %g)", shapes[s], w[0],
		      top);
		CHECK(fabs(w[0]) <= 1e-12 * top, "%s: the constants' eigenvalue %g is not 0", shapes[s],
		      w[0]);
		CHECK(w[1] > 1e-3 * top / K.n, "%s: a second zero eigenvalue %g: null space larger "
		      "than the constants", shapes[s], w[1]);
		free(w);
		ndo_csr_free(&K);
		ndo_grid_destroy(g);
	}
}

static void lumped_mass_is_the_area(void)
{
	/* Sphere: the inscribed polyhedron's area approaches 4π as O(h²);
	 * masses are ρ × area / 3 per triangle, positive, duplicates equal. */
	double err[6] = {0};
	for (int level = 2; level <= 5; level++) {
		ndo_grid *g = shape("sphere", level, 1);
		double *m = malloc(g->count * sizeof *m), area, total = 0;
		CHECK(ndo_lumped_mass(level, g->ch[0].data, 2.0, m, &area) == 0, "mass");
		for (size_t p = 0; p < g->count; p++) {
			CHECK(m[p] > 0, "mass at node %zu is %g", p, m[p]);
			if (ndo_canonical(level, (int)(p % (size_t)g->w), (int)(p / (size_t)g->w)) == p)
				total += m[p];
		}
		CHECK_NEAR(total, 2.0 * area, 1e-12 * total, "total mass = ρ × area");
		err[level] = 4 * M_PI - area;
		free(m);
		ndo_grid_destroy(g);
	}
	for (int level = 3; level <= 5; level++)
		CHECK(err[level] > 0 && err[level] < err[level - 1] / 3.5,
		      "area error level %d: %g, level %d: %g (want O(h²))", level - 1, err[level - 1],
		      level, err[level]);
}

/* On the unit sphere with σ = ρ = 1 the generalized eigenvalues of
 * (K, M) approach l(l+1), multiplicity 2l + 1, with O(h²) errors. */
static void sphere_spectrum_converges(void)
{
	double err[6][5] = {{0}};
	for (int level = 2; level <= 4; level++) {
		ndo_grid *g = shape("sphere", level, 1);
		ndo_csr K;
		ndo_membrane_csr(level, g->ch[0].data, 1, &K);
		double *m = malloc(g->count * sizeof *m), *mv = malloc((size_t)K.n * sizeof *mv);
		int32_t *rep = malloc((size_t)K.n * sizeof *rep), *vid = malloc(g->count * sizeof *vid);
		ndo_lumped_mass(level, g->ch[0].data, 1, m, NULL);
		ndo_vertex_ids(level, vid, rep);
		for (int32_t i = 0; i < K.n; i++)
			mv[i] = m[rep[i]];
		double *w = eigenvalues(&K, mv);
		CHECK(fabs(w[0]) < 1e-10, "level %d: λ0 = %g, not 0", level, w[0]);
		int first = 1;
		/* Level L resolves l ≤ L − 1 (level 2 has 34 vertices). */
		for (int l = 1; l <= level - 1 && first + 2 * l + 1 < K.n; l++) {
			double exact = l * (l + 1), e = 0;
			for (int k = first; k < first + 2 * l + 1; k++)
				e = fmax(e, fabs(w[k] - exact));
			err[level][l] = e;
			/* The group is closer to l(l+1) than to the next group. */
			double next = w[first + 2 * l + 1];
			CHECK(next - exact > 3 * e, "level %d, l = %d: %d eigenvalues within %g of %g, but "
			      "the next one is %g: wrong multiplicity", level, l, 2 * l + 1, e, exact, next);
			first += 2 * l + 1;
		}
		free(w), free(m), free(mv), free(rep), free(vid);
		ndo_csr_free(&K);
		ndo_grid_destroy(g);
	}
	for (int l = 1; l <= 3; l++)
		CHECK(err[4][l] < 0.025 * l * (l + 1), "level 4, l = %d: error %g", l, err[4][l]);
	for (int l = 1; l <= 2; l++) {
		/* Halving h divides the error by 4 (O(h²)); 3 leaves room for
		 * the grid's non-uniformity. */
		CHECK(err[4][l] < err[3][l] / 3, "l = %d: error %g at level 3, %g at level 4: not "
		      "O(h²)", l, err[3][l], err[4][l]);
	}
}

int main(void)
{
	ck_program = "test_membrane";
	RUN(cotan_weights_known_triangles);
	RUN(stencil_matches_reference_csr);
	RUN(row_sums_vanish_at_extreme_scales);
	RUN(stiffness_is_positive_semidefinite);
	RUN(lumped_mass_is_the_area);
	RUN(sphere_spectrum_converges);
	return ck_failed_cases != 0;
}
