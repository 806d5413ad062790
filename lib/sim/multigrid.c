/* multigrid.c — conjugate gradients with a geometric multigrid V-cycle on
 * the grid's level hierarchy (multigrid.h).
 *
 * Vectors are n × 3 doubles, row-major: the three coordinates share every
 * pass over a matrix.  Matrices are CHOLMOD's (compressed columns; the
 * symmetric operators are read as rows, P's transpose gives P's rows).
 */
#include "multigrid.h"

#include "ndo/grid.h"
#include "ndo/simd.h"
#include "ndo/status.h"
#include "ndo/topology.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The loops are compiled for x86-64 and x86-64-v3 (AVX2, FMA), as the
 * stencil kernels are (sim_private.h). */
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && \
    !defined(__SANITIZE_THREAD__)
#define NDO_MG_HOT __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define NDO_MG_HOT
#endif

/* Rows per chunk of a loop: fixed, so partial sums add up in the same order
 * on any thread count. */
#define CHUNK 4096
/* Partial sums a chunk (NSUM used). */
#define NSUM 9
#define PART 12
/* Where the stiffness part of every row's diagonal is at most THETA ×
 * its mass part, the operator's condition number is below about
 * 2 (1 + THETA) and conjugate gradients with Jacobi alone beat a V-cycle
 * (measured at level 8: 12.6 Jacobi iterations at ρ ≈ 4 cost 0.6× of 3.8
 * V-cycle iterations, and about the same at ρ ≈ 16).  Above it the
 * hierarchy coarsens down to DIRECT_ROWS rows (level 4, 514 vertices, or
 * fewer where nodes are held), where CHOLMOD factors. */
#define THETA 12.0
#define DIRECT_ROWS 600
/* The Chebyshev smoother's degree (the same before and after the coarse
 * correction). */
#define SMOOTH_DEG 2
/* The smoother targets D⁻¹A's eigenvalues in [hi·SMOOTH_FRAC, hi]; the
 * coarse-grid correction takes the rest. */
#define SMOOTH_FRAC 0.2

/* The operator's regular rows without their indices: a row r whose columns
 * are r − sd, r − sd + 1, r − 1, r, r + 1, r + su − 1, r + su (a 7-point
 * stencil in the rows' order) keeps its diagonal and its three entries
 * towards later rows (right, up-left, up); the other three are the same
 * values (A is symmetric) kept by the rows before.  44 bytes a row (with
 * the run length) against CSR's 88, read in the same order: the same
 * products, the same sums.
 * run[r] = 0: the row is read from CSR (a border, a seam, a held
 * neighbour). */
typedef struct mg_stencil {
	int32_t *run;  /* the regular rows from r on with r's su and sd */
	int32_t *su, *sd;
	double *d, *fr, *ful, *fu;
} mg_stencil;

typedef struct mg_level {
	int level;            /* the grid level */
	size_t n;             /* rows */
	int32_t *nodes;       /* canonical stored node of every row (level > 0: owned) */
	cholmod_sparse *A;    /* the operator (level 0: the caller's) */
	mg_stencil st;        /* its regular rows */
	cholmod_sparse *P;    /* prolongation to this level from the next (n × n_next) */
	cholmod_sparse *Pt;   /* its transpose: P's rows */
	double *dinv;         /* 1 / diag(A) */
	double *mdiag;        /* the mass part of the diagonal (finest level) */
	double lo, hi;        /* the Chebyshev interval for D⁻¹A */
	double rho;           /* max (stiffness part / mass part) of the diagonal
	                         (finest level) */
	double *b, *x, *r, *d; /* n × 3 each (level 0: b and x are the caller's) */
} mg_level;

struct ndo__mg {
	cholmod_common *cm;
	ndo_pool *pool;
	int nl;
	mg_level lv[NDO_MAX_LEVEL + 1];
	cholmod_factor *L;    /* the coarsest level's factor, or NULL */
	double *r, *z, *p, *q; /* conjugate gradients, n × 3 each */
	int r_true;           /* r is b − A x computed from x (not the recurrence's) */
	double *part;         /* PART partial sums per chunk */
};

/* ---- loops over chunks of rows ----------------------------------------- */

enum op {
	OP_RESID,    /* o1 = i2 − A i1; part: |o1|², |i2|²; with dinv (Jacobi,
	              * CG's start fused) also o2 (p) = dinv∘o1 and part 6..8:
	              * r·z (z = p), as OP_START computes them */
	OP_START,    /* Jacobi: o1 (p) = dinv∘i1 (r); part: r·z (z = p is
	              * not stored: OP_DIR computes it again) */
	OP_AP,       /* o1 = A i1; part: i1·o1 */
	OP_ABS,      /* part: |A||i1| squared */
	OP_CHEB,     /* o1 (d) = c0·o1 + c1·dinv∘i1; o2 (x) += o1; c2 ≠ 0: x = d */
	OP_UPDATE,   /* o1 (x) += c·i1 (p); o2 (r) −= c·i2 (q); part: |r|²;
	              * with dinv also part 3..5: r·z, z = dinv∘r (not stored:
	              * OP_DIR computes it again) */
	OP_DOT,      /* part: i1·i2 */
	OP_DIR,      /* o1 (p) = i1 (z) + c·o1; with dinv z = dinv∘i1 (i1: r) */
	OP_PROLONG,  /* o1 += P i1 (rows of the fine level: Pt's columns) */
	OP_MUL,      /* o1 = M i1 (restriction: M = P's columns, Pᵀ's rows) */
};

typedef struct job {
	enum op op;
	const cholmod_sparse *M;
	const mg_stencil *S;  /* M's regular rows, when M is a level's operator */
	const double *dinv;
	const double *i1, *i2;
	double *o1, *o2;
	double c[3], c0, c1;
	int fresh;
	double *part;
	size_t n;
} job;

typedef double mg_v4 __attribute__((vector_size(32)));

/* y = row r of M (CSR) times x (n × 3, row-major); inlined into each
 * loop. */
static inline void row_product(const int *Mp, const int *Mi, const double *Mx, const double *x,
                               size_t r, double y[3])
{
	double y0 = 0, y1 = 0, y2 = 0;
	for (int k = Mp[r]; k < Mp[r + 1]; k++) {
		const double m = Mx[k], *v = x + 3 * (size_t)Mi[k];
		y0 += m * v[0], y1 += m * v[1], y2 += m * v[2];
	}
	y[0] = y0, y[1] = y1, y[2] = y2;
}

/* y (rows r0..r1 − 1) = those rows of the operator times x, for a run of
 * regular rows with the same su and sd (S->run), with the pass's own work
 * on each row done as it is computed: the same products added in the same
 * order as row_product, and the same sums in the same order as the loops
 * over single rows.  A row's left, own and right values of x, its lower
 * pair's second and its upper pair's second are the next row's own, left,
 * (right), lower first and upper first, and its right coefficient the next
 * row's left one: 3 loads of x and 6 coefficients a row instead of 7, 7
 * and the row's flag and offsets.  OP_AP: y = A x, s += x·y; OP_RESID:
 * y = b − A x, s += |y|², |b|², and with p (not NULL) p = dinv∘y,
 * s[6..8] += y·p.  y and p must not overlap x. */
static inline __attribute__((always_inline)) void
stencil_rows(const mg_stencil *S, enum op op, const double *x, const double *b, size_t r0,
             size_t r1, double *y, double s[NSUM], const double *dinv, double *p)
{
	const size_t u = (size_t)S->su[r0], dn = (size_t)S->sd[r0];
	const double *fu = S->fu, *ful = S->ful, *fr = S->fr, *dg = S->d;
	mg_v4 xm, x0, xp, xd0, xd1, xu0, xu1;
	memcpy(&xm, x + 3 * (r0 - 1), sizeof xm);
	memcpy(&x0, x + 3 * r0, sizeof x0);
	memcpy(&xd0, x + 3 * (r0 - dn), sizeof xd0);
	memcpy(&xu0, x + 3 * (r0 + u - 1), sizeof xu0);
	double fl = fr[r0 - 1];
	double s0 = s[0], s1 = s[1], s2 = s[2], s3 = s[3], s4 = s[4], s5 = s[5];
	double s6 = s[6], s7 = s[7], s8 = s[8];
	for (size_t r = r0; r < r1; r++) {
		memcpy(&xp, x + 3 * (r + 1), sizeof xp);
		memcpy(&xd1, x + 3 * (r - dn + 1), sizeof xd1);
		memcpy(&xu1, x + 3 * (r + u), sizeof xu1);
		const double fri = fr[r];
		mg_v4 y4 = {0, 0, 0, 0};
		y4 += fu[r - dn] * xd0;
		y4 += ful[r - dn + 1] * xd1;
		y4 += fl * xm;
		y4 += dg[r] * x0;
		y4 += fri * xp;
		y4 += ful[r] * xu0;
		y4 += fu[r] * xu1;
		double *yr = y + 3 * r;
		if (op == OP_AP) {
			yr[0] = y4[0], yr[1] = y4[1], yr[2] = y4[2];
			s0 += x0[0] * y4[0], s1 += x0[1] * y4[1], s2 += x0[2] * y4[2];
		} else {
			const double *bb = b + 3 * r;
			const double o0 = bb[0] - y4[0], o1 = bb[1] - y4[1], o2 = bb[2] - y4[2];
			yr[0] = o0, yr[1] = o1, yr[2] = o2;
			s0 += o0 * o0, s1 += o1 * o1, s2 += o2 * o2;
			s3 += bb[0] * bb[0], s4 += bb[1] * bb[1], s5 += bb[2] * bb[2];
			if (p) {
				const double dv = dinv[r], z0 = dv * o0, z1 = dv * o1, z2 = dv * o2;
				double *pr = p + 3 * r;
				pr[0] = z0, pr[1] = z1, pr[2] = z2;
				s6 += o0 * z0, s7 += o1 * z1, s8 += o2 * z2;
			}
		}
		xm = x0, x0 = xp, xd0 = xd1, xu0 = xu1, fl = fri;
	}
	s[0] = s0, s[1] = s1, s[2] = s2, s[3] = s3, s[4] = s4, s[5] = s5;
	s[6] = s6, s[7] = s7, s[8] = s8;
}

/* OP_UPDATE over rows a..e − 1: x += c∘p, r −= c∘q, s[0..2] += |r|² and
 * (with dinv) s[3..5] += r·(dinv∘r), per column.  Four rows at a time as
 * three vectors of four doubles (the columns repeat as 0 1 2 0 | 1 2 0 1 |
 * 2 0 1 2, and so do the coefficients), the sums in lanes: every value
 * the same bits as a row at a time, the sums in another (fixed) order —
 * the scalar sums were three chains of dependent additions that set the
 * pace of the pass.  dv: J->dinv, or NULL (a constant where inlined). */
static inline void update_rows(const job *J, size_t a, size_t e, double s[6], const double *dv)
{
	const double a0 = J->c[0], a1 = J->c[1], a2 = J->c[2];
	const double *i1 = J->i1, *i2 = J->i2;
	double *o1 = J->o1, *o2 = J->o2;
	const ndo__v4 A0 = {a0, a1, a2, a0}, A1 = {a1, a2, a0, a1}, A2 = {a2, a0, a1, a2};
	ndo__v4 s0 = {0, 0, 0, 0}, s1 = s0, s2 = s0, t0 = s0, t1 = s0, t2 = s0;
	size_t r = a;
	for (; r + 4 <= e; r += 4) {
		const double *pr = i1 + 3 * r, *qr = i2 + 3 * r;
		double *xr = o1 + 3 * r, *rr = o2 + 3 * r;
		V4_ST(xr, V4_LD(xr) + A0 * V4_LD(pr));
		V4_ST(xr + 4, V4_LD(xr + 4) + A1 * V4_LD(pr + 4));
		V4_ST(xr + 8, V4_LD(xr + 8) + A2 * V4_LD(pr + 8));
		const ndo__v4 r0 = V4_LD(rr) - A0 * V4_LD(qr), r1 = V4_LD(rr + 4) - A1 * V4_LD(qr + 4),
		              r2 = V4_LD(rr + 8) - A2 * V4_LD(qr + 8);
		V4_ST(rr, r0), V4_ST(rr + 4, r1), V4_ST(rr + 8, r2);
		s0 += r0 * r0, s1 += r1 * r1, s2 += r2 * r2;
		if (dv) {
			const double d0 = dv[r], d1 = dv[r + 1], d2 = dv[r + 2], d3 = dv[r + 3];
			const ndo__v4 D0 = {d0, d0, d0, d1}, D1 = {d1, d1, d2, d2}, D2 = {d2, d3, d3, d3};
			t0 += r0 * (D0 * r0);
			t1 += r1 * (D1 * r1);
			t2 += r2 * (D2 * r2);
		}
	}
	/* each column's lanes: 0 in s0[0], s0[3], s1[2], s2[1]; 1 in s0[1],
	 * s1[0], s1[3], s2[2]; 2 in s0[2], s1[1], s2[0], s2[3] */
	s[0] += (s0[0] + s0[3]) + (s1[2] + s2[1]);
	s[1] += (s0[1] + s1[0]) + (s1[3] + s2[2]);
	s[2] += (s0[2] + s1[1]) + (s2[0] + s2[3]);
	s[3] += (t0[0] + t0[3]) + (t1[2] + t2[1]);
	s[4] += (t0[1] + t1[0]) + (t1[3] + t2[2]);
	s[5] += (t0[2] + t1[1]) + (t2[0] + t2[3]);
	for (; r < e; r++) {
		const double *pr = i1 + 3 * r, *qr = i2 + 3 * r;
		double *xr = o1 + 3 * r, *rr = o2 + 3 * r;
		xr[0] += a0 * pr[0], xr[1] += a1 * pr[1], xr[2] += a2 * pr[2];
		const double r0 = rr[0] - a0 * qr[0], r1 = rr[1] - a1 * qr[1], r2 = rr[2] - a2 * qr[2];
		rr[0] = r0, rr[1] = r1, rr[2] = r2;
		s[0] += r0 * r0, s[1] += r1 * r1, s[2] += r2 * r2;
		if (dv) {
			const double z0 = dv[r] * r0, z1 = dv[r] * r1, z2 = dv[r] * r2;
			s[3] += r0 * z0, s[4] += r1 * z1, s[5] += r2 * z2;
		}
	}
}

NDO_MG_HOT static void run_chunk(void *ctx, int k)
{
	const job *J = ctx;
	size_t a = (size_t)k * CHUNK, e = a + CHUNK < J->n ? a + CHUNK : J->n;
	const int *Mp = J->M ? J->M->p : NULL, *Mi = J->M ? J->M->i : NULL;
	const double *Mx = J->M ? J->M->x : NULL;
	const double *i1 = J->i1, *i2 = J->i2;
	double *o1 = J->o1, *o2 = J->o2;
	double s[PART] = {0};
	switch (J->op) {
	case OP_RESID:
	case OP_AP:
		for (size_t r = a, r1; r < e; r = r1) {
			r1 = r + 1;
			if (J->S && J->S->run[r]) {
				r1 = r + (size_t)J->S->run[r] < e ? r + (size_t)J->S->run[r] : e;
				if (J->op == OP_AP)
					stencil_rows(J->S, OP_AP, i1, NULL, r, r1, o1, s, NULL, NULL);
				else if (J->dinv)
					stencil_rows(J->S, OP_RESID, i1, i2, r, r1, o1, s, J->dinv, o2);
				else
					stencil_rows(J->S, OP_RESID, i1, i2, r, r1, o1, s, NULL, NULL);
				continue;
			}
			double y[3];
			row_product(Mp, Mi, Mx, i1, r, y);
			double *o = o1 + 3 * r;
			if (J->op == OP_AP) {
				const double *v = i1 + 3 * r;
				o[0] = y[0], o[1] = y[1], o[2] = y[2];
				s[0] += v[0] * y[0], s[1] += v[1] * y[1], s[2] += v[2] * y[2];
				continue;
			}
			const double *bb = i2 + 3 * r;
			o[0] = bb[0] - y[0], o[1] = bb[1] - y[1], o[2] = bb[2] - y[2];
			s[0] += o[0] * o[0], s[1] += o[1] * o[1], s[2] += o[2] * o[2];
			s[3] += bb[0] * bb[0], s[4] += bb[1] * bb[1], s[5] += bb[2] * bb[2];
			if (J->dinv) {
				const double dv = J->dinv[r];
				double *pr = o2 + 3 * r;
				for (int c = 0; c < 3; c++) {
					pr[c] = dv * o[c];
					s[6 + c] += o[c] * pr[c];
				}
			}
		}
		break;
	case OP_START:
		for (size_t r = a; r < e; r++)
			for (int c = 0; c < 3; c++) {
				size_t q = 3 * r + (size_t)c;
				double zz = J->dinv[r] * i1[q];
				o1[q] = zz;
				s[c] += i1[q] * zz;
			}
		break;
	case OP_MUL:
		for (size_t r = a; r < e; r++) {
			double y[3];
			row_product(Mp, Mi, Mx, i1, r, y);
			const double y0 = y[0], y1 = y[1], y2 = y[2];
			o1[3 * r] = y0, o1[3 * r + 1] = y1, o1[3 * r + 2] = y2;
		}
		break;
	case OP_ABS:
		for (size_t r = a; r < e; r++) {
			double y0 = 0, y1 = 0, y2 = 0;
			for (int k2 = Mp[r]; k2 < Mp[r + 1]; k2++) {
				const double m = fabs(Mx[k2]), *v = i1 + 3 * (size_t)Mi[k2];
				y0 += m * fabs(v[0]), y1 += m * fabs(v[1]), y2 += m * fabs(v[2]);
			}
			s[0] += y0 * y0, s[1] += y1 * y1, s[2] += y2 * y2;
		}
		break;
	case OP_PROLONG:
		for (size_t r = a; r < e; r++) {
			double y[3];
			row_product(Mp, Mi, Mx, i1, r, y);
			const double y0 = y[0], y1 = y[1], y2 = y[2];
			o1[3 * r] += y0, o1[3 * r + 1] += y1, o1[3 * r + 2] += y2;
		}
		break;
	case OP_CHEB:
		for (size_t r = a; r < e; r++)
			for (int c = 0; c < 3; c++) {
				size_t q = 3 * r + (size_t)c;
				/* c0 = 0 on the first step: d is not read (it may hold
				 * anything). */
				double d = (J->c0 != 0 ? J->c0 * o1[q] : 0) + J->c1 * J->dinv[r] * i1[q];
				o1[q] = d;
				o2[q] = J->fresh ? d : o2[q] + d;
			}
		break;
	case OP_UPDATE:
		if (J->dinv)
			update_rows(J, a, e, s, J->dinv);
		else
			update_rows(J, a, e, s, NULL);
		break;
	case OP_DOT:
		for (size_t r = a; r < e; r++)
			for (int c = 0; c < 3; c++)
				s[c] += i1[3 * r + c] * i2[3 * r + c];
		break;
	case OP_DIR: {
		const double b0 = J->c[0], b1 = J->c[1], b2 = J->c[2];
		if (J->dinv) /* Jacobi: z = dinv∘r, not stored (i1: r) */
			for (size_t r = a; r < e; r++) {
				const double *rr = i1 + 3 * r, dv = J->dinv[r];
				double *pr = o1 + 3 * r;
				const double z0 = dv * rr[0], z1 = dv * rr[1], z2 = dv * rr[2];
				pr[0] = z0 + b0 * pr[0], pr[1] = z1 + b1 * pr[1], pr[2] = z2 + b2 * pr[2];
			}
		else
			for (size_t r = a; r < e; r++) {
				const double *zr = i1 + 3 * r;
				double *pr = o1 + 3 * r;
				pr[0] = zr[0] + b0 * pr[0], pr[1] = zr[1] + b1 * pr[1], pr[2] = zr[2] + b2 * pr[2];
			}
		break;
	}
	}
	if (J->part)
		memcpy(J->part + PART * (size_t)k, s, NSUM * sizeof *s);
}

/* Run a job over n rows; sums (may be NULL) receives the NSUM partial
 * sums added in chunk order. */
static void run(ndo__mg *mg, job *J, size_t n, double sums[NSUM])
{
	int nch = (int)((n + CHUNK - 1) / CHUNK);
	J->n = n;
	J->S = NULL;
	for (int l = 0; l < mg->nl && J->M; l++)
		if (J->M == mg->lv[l].A && mg->lv[l].st.run)
			J->S = &mg->lv[l].st;
	J->part = sums ? mg->part : NULL;
	if (nch > 1 && mg->pool)
		ndo_pool_run(mg->pool, nch, run_chunk, J);
	else
		for (int k = 0; k < nch; k++)
			run_chunk(J, k);
	if (sums) {
		for (int c = 0; c < NSUM; c++)
			sums[c] = 0;
		for (int k = 0; k < nch; k++)
			for (int c = 0; c < NSUM; c++)
				sums[c] += mg->part[PART * (size_t)k + c];
	}
}

/* ---- the hierarchy ------------------------------------------------------ */

/* n × 3 doubles and one more (row_product reads it, unused, with the last
 * row). */
static double *vec(size_t n)
{
	double *v = malloc((3 * n + 1) * sizeof(double));
	if (v)
		v[3 * n] = 0;
	return v;
}

/* P: linear interpolation from the coarse rows (nodes of level l−1 whose
 * fine copy is a row) to the fine rows. */
static cholmod_sparse *prolongation(const mg_level *f, mg_level *c, cholmod_common *cm)
{
	int lf = f->level, lc = lf - 1, nf = 1 << lf, wf = 2 * nf + 1;
	int wc = nf + 1, hc = nf / 2 + 1;
	size_t cntc = (size_t)wc * (size_t)hc, cntf = (size_t)wf * (size_t)(nf + 1);
	int32_t *fidx = malloc(cntf * sizeof *fidx), *cidx = malloc(cntc * sizeof *cidx);
	cholmod_sparse *P = NULL;
	cholmod_triplet *T = NULL;
	if (!fidx || !cidx)
		goto out;
	for (size_t p = 0; p < cntf; p++)
		fidx[p] = -1;
	for (size_t r = 0; r < f->n; r++)
		fidx[f->nodes[r]] = (int32_t)r;
	/* Coarse rows: canonical coarse nodes whose fine copy is a row. */
	c->n = 0;
	for (size_t p = 0; p < cntc; p++) {
		int i = (int)(p % (size_t)wc), j = (int)(p / (size_t)wc);
		cidx[p] = -1;
		if (ndo_canonical(lc, i, j) == p && fidx[ndo_canonical(lf, 2 * i, 2 * j)] >= 0)
			cidx[p] = (int32_t)c->n++;
	}
	c->nodes = malloc((c->n + 1) * sizeof *c->nodes);
	if (!c->nodes)
		goto out;
	for (size_t p = 0; p < cntc; p++)
		if (cidx[p] >= 0)
			c->nodes[cidx[p]] = (int32_t)p;
	T = cholmod_allocate_triplet(f->n, c->n, 2 * f->n + 1, 0, CHOLMOD_REAL, cm);
	if (!T)
		goto out;
	int *Ti = T->i, *Tj = T->j;
	double *Tx = T->x;
	size_t nz = 0;
	for (size_t r = 0; r < f->n; r++) {
		int i = f->nodes[r] % wf, j = f->nodes[r] / wf;
		/* The coarse ends of the lattice edge whose midpoint this is: the
		 * cells split along (i+1, j)–(i, j+1), so an odd-odd node sits on
		 * the coarse diagonal from (i+1, j−1) to (i−1, j+1).  All ends lie
		 * inside the rectangle. */
		int e[2][2], ne;
		if (i % 2 == 0 && j % 2 == 0)
			e[0][0] = i, e[0][1] = j, ne = 1;
		else if (j % 2 == 0)
			e[0][0] = i - 1, e[0][1] = j, e[1][0] = i + 1, e[1][1] = j, ne = 2;
		else if (i % 2 == 0)
			e[0][0] = i, e[0][1] = j - 1, e[1][0] = i, e[1][1] = j + 1, ne = 2;
		else
			e[0][0] = i + 1, e[0][1] = j - 1, e[1][0] = i - 1, e[1][1] = j + 1, ne = 2;
		for (int k = 0; k < ne; k++) {
			int32_t col = cidx[ndo_canonical(lc, e[k][0] / 2, e[k][1] / 2)];
			if (col < 0)
				continue; /* a held end: no correction from it */
			Ti[nz] = (int)r, Tj[nz] = col, Tx[nz] = ne == 1 ? 1.0 : 0.5;
			nz++;
		}
	}
	T->nnz = nz;
	P = cholmod_triplet_to_sparse(T, nz, cm);
out:
	cholmod_free_triplet(&T, cm);
	free(fidx);
	free(cidx);
	return P;
}

/* Power iteration for λmax(D⁻¹A) from a fixed start: deterministic. */
static double lambda_max(ndo__mg *mg, mg_level *L)
{
	size_t n = L->n;
	double *x = L->r, *y = L->d, lam = 0;
	for (size_t q = 0; q < 3 * n; q++)
		x[q] = (double)((q * 2654435761u) % 1000) / 1000 - 0.5;
	for (int it = 0; it < 12; it++) {
		job J = {.op = OP_AP, .M = L->A, .i1 = x, .o1 = y};
		run(mg, &J, n, NULL);
		double num = 0, den = 0;
		for (size_t q = 0; q < 3 * n; q++) {
			y[q] *= L->dinv[q / 3];
			num += y[q] * y[q];
			den += x[q] * x[q];
		}
		lam = den > 0 ? sqrt(num / den) : 0;
		double s = num > 0 ? 1 / sqrt(num) : 0;
		for (size_t q = 0; q < 3 * n; q++)
			x[q] = y[q] * s;
	}
	return lam;
}

/* The regular rows of L's operator (mg_stencil): a row whose 7 columns
 * have the stencil's shape, and whose three entries towards earlier rows
 * are, bit for bit, the later entries those rows keep. */
static int stencil_build(mg_level *L)
{
	const size_t n = L->n;
	const int *Ap = L->A->p, *Ai = L->A->i;
	const double *Ax = L->A->x;
	mg_stencil *S = &L->st;
	uint8_t *reg = calloc(n + 1, 1); /* bit 1: the shape; bit 2: regular */
	S->run = calloc(n + 1, sizeof *S->run);
	S->su = calloc(n + 1, sizeof *S->su), S->sd = calloc(n + 1, sizeof *S->sd);
	S->d = calloc(n + 1, sizeof *S->d), S->fr = calloc(n + 1, sizeof *S->fr);
	S->ful = calloc(n + 1, sizeof *S->ful), S->fu = calloc(n + 1, sizeof *S->fu);
	if (!reg || !S->run || !S->su || !S->sd || !S->d || !S->fr || !S->ful || !S->fu) {
		free(reg);
		return ndo__fail(NDO_ENOMEM, "out of memory for the multigrid solver");
	}
	for (size_t r = 0; r < n; r++) {
		const int k = Ap[r], *c = Ai + k, ri = (int)r;
		if (Ap[r + 1] - k != 7 || c[3] != ri || c[2] != ri - 1 || c[4] != ri + 1 ||
		    c[1] != c[0] + 1 || c[5] != c[6] - 1 || ri - c[0] < 3 || c[6] - ri < 3)
			continue;
		reg[r] = 1; /* the shape; the values are checked below */
		S->sd[r] = ri - c[0], S->su[r] = c[6] - ri;
		S->d[r] = Ax[k + 3], S->fr[r] = Ax[k + 4], S->ful[r] = Ax[k + 5], S->fu[r] = Ax[k + 6];
	}
	for (size_t r = 0; r < n; r++) {
		if (!(reg[r] & 1))
			continue;
		const size_t dn = (size_t)S->sd[r], j1 = r - 1, j2 = r - dn, j3 = r - dn + 1;
		const double *x = Ax + Ap[r];
		if ((reg[j1] & 1) && (reg[j2] & 1) && (reg[j3] & 1) &&
		    (size_t)S->su[j2] == dn && (size_t)S->su[j3] == dn &&
		    memcmp(&S->fu[j2], &x[0], sizeof *x) == 0 &&
		    memcmp(&S->ful[j3], &x[1], sizeof *x) == 0 &&
		    memcmp(&S->fr[j1], &x[2], sizeof *x) == 0)
			reg[r] |= 2;
	}
	for (size_t r = n; r-- > 0;)
		if (reg[r] & 2)
			S->run[r] = r + 1 < n && (reg[r + 1] & 2) && S->su[r + 1] == S->su[r] &&
			                    S->sd[r + 1] == S->sd[r]
			                ? S->run[r + 1] + 1
			                : 1;
	free(reg);
	return NDO_OK;
}

static void stencil_free(mg_stencil *S)
{
	free(S->run), free(S->su), free(S->sd);
	free(S->d), free(S->fr), free(S->ful), free(S->fu);
	memset(S, 0, sizeof *S);
}

static int level_setup(ndo__mg *mg, mg_level *L)
{
	size_t n = L->n;
	const int *Ap = L->A->p, *Ai = L->A->i;
	const double *Ax = L->A->x;
	L->dinv = malloc((n + 1) * sizeof *L->dinv);
	L->r = vec(n), L->d = vec(n);
	int fine = L == &mg->lv[0];
	if (!fine)
		L->b = vec(n), L->x = vec(n);
	if (!L->dinv || !L->r || !L->d || (!fine && (!L->b || !L->x)))
		return ndo__fail(NDO_ENOMEM, "out of memory for the multigrid solver");
	int rc = stencil_build(L);
	if (rc)
		return rc;
	L->rho = 0;
	double gersh = 0;
	for (size_t r = 0; r < n; r++) {
		double dg = 0, off = 0;
		for (int k = Ap[r]; k < Ap[r + 1]; k++)
			if ((size_t)Ai[k] == r)
				dg += Ax[k];
			else
				off += fabs(Ax[k]);
		gersh = fmax(gersh, 1 + off / dg);
		if (!(dg > 0))
			return ndo__fail(NDO_EDIVERGED, "the implicit system is not positive definite "
			                 "(diagonal %g at a level-%d node)", dg, L->level);
		L->dinv[r] = 1 / dg;
		if (L->mdiag)
			L->rho = fmax(L->rho, (dg - L->mdiag[r]) / L->mdiag[r]);
	}
	/* The top of D⁻¹A's spectrum: a smoother whose interval stops short of
	 * it amplifies the modes above, and the V-cycle is no longer positive
	 * definite (CG stalled at 1e-9 on stiff systems with 12 steps of power
	 * iteration × 1.1).  Gershgorin's bound is safe, and tight (≈ 2) for
	 * the stiffness-dominated levels that are smoothed. */
	L->hi = fmin(gersh, fmax(1.5 * lambda_max(mg, L), 1.0));
	L->lo = L->hi * SMOOTH_FRAC;
	return NDO_OK;
}

void ndo__mg_free(ndo__mg *mg)
{
	if (!mg)
		return;
	for (int l = 0; l < mg->nl; l++) {
		mg_level *L = &mg->lv[l];
		if (l > 0) {
			cholmod_free_sparse(&L->A, mg->cm);
			free(L->nodes);
			free(L->b);
			free(L->x);
		}
		cholmod_free_sparse(&L->P, mg->cm);
		cholmod_free_sparse(&L->Pt, mg->cm);
		stencil_free(&L->st);
		free(L->dinv);
		free(L->mdiag);
		free(L->r);
		free(L->d);
	}
	if (mg->L)
		cholmod_free_factor(&mg->L, mg->cm);
	free(mg->r);
	free(mg->z);
	free(mg->p);
	free(mg->q);
	free(mg->part);
	free(mg);
}

void ndo__mg_set_pool(ndo__mg *mg, ndo_pool *pool)
{
	mg->pool = pool;
}

void ndo__mg_apply(ndo__mg *mg, const double *x, double *y)
{
	job J = {.op = OP_AP, .M = mg->lv[0].A, .i1 = x, .o1 = y};
	run(mg, &J, mg->lv[0].n, NULL);
}

const double *ndo__mg_residual(const ndo__mg *mg)
{
	return mg->r_true ? mg->r : NULL;
}

int ndo__mg_levels(const ndo__mg *mg, int *direct)
{
	if (direct)
		*direct = mg->L != NULL;
	return mg->nl;
}

double ndo__mg_bytes(size_t n)
{
	/* Per fine row: the operator (7 values and indices, a column start),
	 * its regular rows again without indices (mg_stencil: 4 values, 2
	 * offsets, a run length), P and Pᵀ (1.75 entries a row each), the diagonal,
	 * its mass part, the V-cycle's r, d (n × 3) and CG's r, z, p, q;
	 * coarse levels add a third (with their own b, x); the setup's largest transient is Pᵀ(A P) and
	 * A P besides the levels (about 2 × 7 entries a row of the level below
	 * the finest). */
	double fine = 7 * 12 + 8 + 4 * 8 + 3 * 4 + 2 * 1.75 * 12 + 8 + 8 + 2 * 24 + 4 * 24;
	double coarse = (fine - 4 * 24 + 2 * 24 + 4) / 3;
	return (double)n * (fine + coarse + 2 * 7 * 12 / 4.0) + 65536;
}

int ndo__mg_create(int level, const int32_t *nodes, size_t n, cholmod_sparse *A,
                   const double *mass, cholmod_common *cm, ndo_pool *pool, ndo__mg **out)
{
	*out = NULL;
	ndo__mg *mg = calloc(1, sizeof *mg);
	if (!mg)
		return ndo__fail(NDO_ENOMEM, "out of memory for the multigrid solver");
	mg->cm = cm;
	mg->pool = pool;
	int rc = NDO_OK;
	mg_level *L = &mg->lv[0];
	L->level = level;
	L->n = n;
	L->nodes = (int32_t *)nodes;
	L->A = A;
	L->mdiag = malloc((n + 1) * sizeof *L->mdiag);
	mg->part = malloc(PART * ((n + CHUNK - 1) / CHUNK + 1) * sizeof *mg->part);
	mg->r = vec(n), mg->z = vec(n), mg->p = vec(n), mg->q = vec(n);
	mg->nl = 1;
	if (!L->mdiag || !mg->part || !mg->r || !mg->z || !mg->p || !mg->q) {
		rc = ndo__fail(NDO_ENOMEM, "out of memory for the multigrid solver");
		goto fail;
	}
	memcpy(L->mdiag, mass, n * sizeof *mass);
	for (;;) {
		if ((rc = level_setup(mg, L)))
			goto fail;
		/* A level small enough to factor ends the hierarchy; Jacobi
		 * alone where the mass dominates a larger finest level. */
		if (L->level <= 2 || L->n <= DIRECT_ROWS || (mg->nl == 1 && L->rho <= THETA))
			break;
		mg_level *C = &mg->lv[mg->nl];
		C->level = L->level - 1;
		if (!(L->P = prolongation(L, C, cm)) || !(L->Pt = cholmod_transpose(L->P, 1, cm))) {
			rc = ndo__fail(NDO_ENOMEM, "out of memory for the multigrid solver");
			goto fail;
		}
		mg->nl++;
		cholmod_sparse *AP = cholmod_ssmult(L->A, L->P, 0, 1, 0, cm);
		C->A = AP ? cholmod_ssmult(L->Pt, AP, 0, 1, 1, cm) : NULL;
		cholmod_free_sparse(&AP, cm);
		if (!C->A) {
			rc = ndo__fail(NDO_ENOMEM, "out of memory for the multigrid solver");
			goto fail;
		}
		L = C;
	}
	/* The coarsest level of a hierarchy, or a finest level small enough
	 * (Jacobi took 22 iterations at level 4, h = 0.1 s): factored. */
	if (mg->nl > 1 || L->n <= DIRECT_ROWS || L->level <= 2) {
		cholmod_sparse *U = cholmod_copy(L->A, 1, 1, cm);
		if (!U) {
			rc = ndo__fail(NDO_ENOMEM, "out of memory for the multigrid solver");
			goto fail;
		}
		mg->L = cholmod_analyze(U, cm);
		int ok = mg->L && cholmod_factorize(U, mg->L, cm);
		cholmod_free_sparse(&U, cm);
		if (!ok || cm->status == CHOLMOD_NOT_POSDEF) {
			rc = ndo__fail(NDO_EDIVERGED, "the implicit system is not positive definite "
			               "(CHOLMOD status %d on the coarsest level)", cm->status);
			goto fail;
		}
	}
	*out = mg;
	return NDO_OK;
fail:
	ndo__mg_free(mg);
	return rc;
}

/* ---- the cycle ---------------------------------------------------------- */

/* x ← x + p(D⁻¹A)(b − A x), the Chebyshev polynomial of degree deg on
 * [lo, hi] (Saad, "Iterative methods for sparse linear systems", alg. 12.1);
 * fresh: x starts at 0. */
static void chebyshev(ndo__mg *mg, mg_level *L, int deg, int fresh)
{
	size_t n = L->n;
	double theta = (L->hi + L->lo) / 2, delta = (L->hi - L->lo) / 2;
	double sigma = theta / delta, rho = 1 / sigma;
	job J;
	if (fresh) {
		J = (job){.op = OP_CHEB, .dinv = L->dinv, .i1 = L->b, .o1 = L->d, .o2 = L->x,
		          .c0 = 0, .c1 = 1 / theta, .fresh = 1};
	} else {
		J = (job){.op = OP_RESID, .M = L->A, .i1 = L->x, .i2 = L->b, .o1 = L->r};
		run(mg, &J, n, NULL);
		J = (job){.op = OP_CHEB, .dinv = L->dinv, .i1 = L->r, .o1 = L->d, .o2 = L->x,
		          .c0 = 0, .c1 = 1 / theta};
	}
	run(mg, &J, n, NULL);
	for (int k = 1; k < deg; k++) {
		J = (job){.op = OP_RESID, .M = L->A, .i1 = L->x, .i2 = L->b, .o1 = L->r};
		run(mg, &J, n, NULL);
		double rn = 1 / (2 * sigma - rho);
		J = (job){.op = OP_CHEB, .dinv = L->dinv, .i1 = L->r, .o1 = L->d, .o2 = L->x,
		          .c0 = rn * rho, .c1 = 2 * rn / delta};
		run(mg, &J, n, NULL);
		rho = rn;
	}
}

static int vcycle(ndo__mg *mg, int l)
{
	mg_level *L = &mg->lv[l];
	if (l == mg->nl - 1) {
		if (!mg->L) { /* Jacobi, as ndo__mg_solve fuses it */
			job J = {.op = OP_CHEB, .dinv = L->dinv, .i1 = L->b, .o1 = L->d, .o2 = L->x,
			         .c0 = 0, .c1 = 1, .fresh = 1};
			run(mg, &J, L->n, NULL);
			return NDO_OK;
		}
		cholmod_dense *B = cholmod_allocate_dense(L->n, 3, L->n, CHOLMOD_REAL, mg->cm);
		if (!B)
			return ndo__fail(NDO_ENOMEM, "out of memory for the multigrid solver");
		double *bx = B->x;
		for (size_t r = 0; r < L->n; r++)
			for (int c = 0; c < 3; c++)
				bx[(size_t)c * L->n + r] = L->b[3 * r + (size_t)c];
		cholmod_dense *X = cholmod_solve(CHOLMOD_A, mg->L, B, mg->cm);
		cholmod_free_dense(&B, mg->cm);
		if (!X)
			return ndo__fail(NDO_ENOMEM, "out of memory for the multigrid solver");
		double *xx = X->x;
		for (size_t r = 0; r < L->n; r++)
			for (int c = 0; c < 3; c++)
				L->x[3 * r + (size_t)c] = xx[(size_t)c * L->n + r];
		cholmod_free_dense(&X, mg->cm);
		return NDO_OK;
	}
	mg_level *C = &mg->lv[l + 1];
	chebyshev(mg, L, SMOOTH_DEG, 1);
	job J = {.op = OP_RESID, .M = L->A, .i1 = L->x, .i2 = L->b, .o1 = L->r};
	run(mg, &J, L->n, NULL);
	J = (job){.op = OP_MUL, .M = L->P, .i1 = L->r, .o1 = C->b};
	run(mg, &J, C->n, NULL);
	int rc = vcycle(mg, l + 1);
	if (rc)
		return rc;
	J = (job){.op = OP_PROLONG, .M = L->Pt, .i1 = C->x, .o1 = L->x};
	run(mg, &J, L->n, NULL);
	chebyshev(mg, L, SMOOTH_DEG, 0);
	return NDO_OK;
}

/* z ← V-cycle(r) */
static int precondition(ndo__mg *mg, double *r, double *z)
{
	mg->lv[0].b = r;
	mg->lv[0].x = z;
	return vcycle(mg, 0);
}

/* The stopping bound of each column at x: max(tol‖b‖, 16 ε ‖|A||x|‖),
 * the second the rounding floor of the product A x, which a very stiff
 * system reaches before the tolerance. */
static void bounds(ndo__mg *mg, const double *x, double tol, const double bn[3], double bnd[3])
{
	double s[NSUM];
	job J = {.op = OP_ABS, .M = mg->lv[0].A, .i1 = x};
	run(mg, &J, mg->lv[0].n, s);
	for (int c = 0; c < 3; c++)
		bnd[c] = fmax(tol * bn[c], 16 * DBL_EPSILON * sqrt(s[c]));
}

/* The preconditioner is Jacobi alone (one level, smoothed): it fuses with
 * the update of the residual. */
static int jacobi_only(const ndo__mg *mg)
{
	return mg->nl == 1 && !mg->L;
}

/* Conjugate gradients' first direction from the residual r: z = M⁻¹ r,
 * p = z, rz = (r, z) per column (Jacobi alone: fused in one pass; a
 * solve's first residual pass computes them itself, this is for the
 * restarts). */
static int cg_start(ndo__mg *mg, int jac, double *r, double *z, double *p, double rz[3])
{
	const size_t n = mg->lv[0].n;
	double s[NSUM];
	job J;
	if (jac) {
		J = (job){.op = OP_START, .dinv = mg->lv[0].dinv, .i1 = r, .o1 = p};
		run(mg, &J, n, s);
	} else {
		int rc = precondition(mg, r, z);
		if (rc)
			return rc;
		J = (job){.op = OP_DOT, .i1 = r, .i2 = z};
		run(mg, &J, n, s);
		memcpy(p, z, 3 * n * sizeof *p);
	}
	memcpy(rz, s, 3 * sizeof *rz);
	return NDO_OK;
}

int ndo__mg_solve(ndo__mg *mg, const double *b, double *x, double tol, double stall, int max_iter,
                  int *iters, double *relres)
{
	const size_t n = mg->lv[0].n;
	const cholmod_sparse *A = mg->lv[0].A;
	const int jac = jacobi_only(mg);
	double *r = mg->r, *z = mg->z, *p = mg->p, *q = mg->q;
	double s[NSUM], bnd[3], bn[3], rn[3], rz[3] = {0, 0, 0}, best = INFINITY;
	int done[3], it = 0, rc, stalls = 0;
	/* Jacobi alone: the first direction p = z = D⁻¹r and r·z in the same
	 * pass (the bits of cg_start's) */
	job J = {.op = OP_RESID, .M = A, .i1 = x, .i2 = b, .o1 = r};
	if (jac)
		J.dinv = mg->lv[0].dinv, J.o2 = p;
	run(mg, &J, n, s);
	mg->r_true = 1;
	for (int c = 0; c < 3; c++) {
		rn[c] = sqrt(s[c]);
		bn[c] = sqrt(s[3 + c]);
		bnd[c] = tol * bn[c];
		done[c] = rn[c] <= bnd[c];
	}
	if (!(done[0] && done[1] && done[2])) {
		if (jac)
			memcpy(rz, s + 6, 3 * sizeof *rz);
		else if ((rc = cg_start(mg, jac, r, z, p, rz)))
			return rc;
	}
	while (!(done[0] && done[1] && done[2])) {
		if (it == max_iter) {
			double worst = 0;
			for (int c = 0; c < 3; c++)
				worst = fmax(worst, bn[c] > 0 ? rn[c] / bn[c] : 0);
			if (worst <= stall)
				break; /* stalled within the looser bound: as above */
			int c = rn[0] / fmax(bn[0], DBL_MIN) > rn[1] / fmax(bn[1], DBL_MIN) ? 0 : 1;
			c = rn[c] / fmax(bn[c], DBL_MIN) > rn[2] / fmax(bn[2], DBL_MIN) ? c : 2;
			return ndo__fail(NDO_EDIVERGED, "multigrid did not reach a relative residual of "
			                 "%g in %d iterations (%.3g; floor %.3g)", tol, max_iter,
			                 rn[c] / fmax(bn[c], DBL_MIN), bnd[c] / fmax(bn[c], DBL_MIN));
		}
		it++;
		/* A very stiff system may stall at its rounding floor above tol. */
		if (it % 25 == 0)
			bounds(mg, x, tol, bn, bnd);
		J = (job){.op = OP_AP, .M = A, .i1 = p, .o1 = q};
		run(mg, &J, n, s);
		J = (job){.op = OP_UPDATE, .i1 = p, .i2 = q, .o1 = x, .o2 = r};
		if (jac)
			J.dinv = mg->lv[0].dinv; /* r·z; z itself is not stored */
		for (int c = 0; c < 3; c++)
			J.c[c] = done[c] || !(s[c] > 0) ? 0 : rz[c] / s[c];
		run(mg, &J, n, s);
		mg->r_true = 0;
		int all = 1;
		for (int c = 0; c < 3; c++) {
			if (!done[c])
				rn[c] = sqrt(s[c]);
			all &= done[c] || rn[c] <= bnd[c];
		}
		int restart = 0;
		if (all) {
			/* The updated residual drifts from the true one: check it, and
			 * where it is above the tolerance whether it has reached the
			 * rounding floor. */
			J = (job){.op = OP_RESID, .M = A, .i1 = x, .i2 = b, .o1 = r};
			run(mg, &J, n, s);
			mg->r_true = 1;
			int floor = 0;
			double worst = 0;
			for (int c = 0; c < 3; c++) {
				rn[c] = sqrt(s[c]);
				floor |= rn[c] > tol * bn[c];
				worst = fmax(worst, bn[c] > 0 ? rn[c] / bn[c] : 0);
			}
			if (floor)
				bounds(mg, x, tol, bn, bnd);
			for (int c = 0; c < 3; c++)
				done[c] = rn[c] <= bnd[c];
			if (done[0] && done[1] && done[2])
				break;
			/* Not there: the iteration starts again from the true
			 * residual.  One that stalls where rounding leaves it (the
			 * true residual no better than at the last two checks) ends
			 * there if it is within stall. */
			if (!(worst < 0.5 * best)) {
				if (++stalls >= 2 && worst <= stall)
					break;
			} else {
				best = worst;
				stalls = 0;
			}
			restart = 1;
		}
		if (restart) {
			if ((rc = cg_start(mg, jac, r, z, p, rz)))
				return rc;
			continue;
		}
		if (!jac || all) {
			if ((rc = precondition(mg, r, z)))
				return rc;
			J = (job){.op = OP_DOT, .i1 = r, .i2 = z};
			run(mg, &J, n, s);
		} else {
			memmove(s, s + 3, 3 * sizeof *s);
		}
		J = (job){.op = OP_DIR, .i1 = z, .o1 = p};
		if (jac)
			J.i1 = r, J.dinv = mg->lv[0].dinv;
		for (int c = 0; c < 3; c++) {
			J.c[c] = done[c] || !(rz[c] > 0) ? 0 : s[c] / rz[c];
			rz[c] = s[c];
		}
		run(mg, &J, n, NULL);
	}
	double worst = 0;
	for (int c = 0; c < 3; c++)
		worst = fmax(worst, bn[c] > 0 ? rn[c] / bn[c] : 0);
	*iters = it;
	*relres = worst;
	return NDO_OK;
}
