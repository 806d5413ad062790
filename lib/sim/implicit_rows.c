/* implicit_rows.c — backward Euler's and the trapezoid's system row by
 * row, for a solver that is not this simulation's (ndo/sim.h,
 * "The implicit system by rows": peers that solve it together, ndo/peer.h).
 *
 * The system is implicit.c's, A v' = b on the unknowns (every node but
 * the pins held in project mode):
 *   A = M + cb·B + ck·(K + P)   cb, ck = h, h² (backward Euler), h/2, h²/4
 *   b = M v + h M (a + γ v) [+ the trapezoid's and the forces' terms]
 * written here for the rows a caller names, from the state of those rows
 * and of their 1-ring (the stencil's reach).  Nothing is factored. */
#include "sim_private.h"
#include "ndo/status.h"

#include <stdlib.h>
#include <string.h>

/* Is stored node q an unknown of the whole object's system? */
static int unknown(const ndo_sim *s, size_t q)
{
	return !(s->pin[q] && s->p.pin_mode == NDO_PINS_PROJECT);
}

/* The penalty spring at p (0 if none). */
static double penalty_at(const ndo_sim *s, size_t p)
{
	for (size_t k = 0; k < s->npen; k++)
		if ((size_t)s->pen[k] == p)
			return s->alpha;
	return 0;
}

static void coefs(const ndo_sim *s, double h, double *cb, double *ck)
{
	int trap = s->p.method == NDO_TRAPEZOID;
	*cb = trap ? h / 2 : h;
	*ck = trap ? h * h / 4 : h * h;
}

static int sim_implicit_begin(ndo_sim *s, double h, const int32_t *rows, size_t nrows, double *b,
                              double *dinv)
{
	ndo__clear_error();
	if (!ndo_method_is_implicit(s->p.method))
		return ndo__fail(NDO_EINVAL, "ndo_sim_implicit_begin: %s is not implicit",
		                 ndo_method_names[s->p.method]);
	if (!(h > 0) || !isfinite(h))
		return ndo__fail(NDO_EINVAL, "step size %g: must be positive and finite", h);
	int rc = ndo__restiffen_due(s);
	if (rc)
		return rc;
	const size_t cnt = s->count;
	const int trap = s->p.method == NDO_TRAPEZOID;
	double cb, ck;
	coefs(s, h, &cb, &ck);
	double *a, *df;
	if ((rc = ndo__implicit_prepare(s, h, &a, &df)))
		return rc;
	s->imp_df = df != NULL;
	for (size_t r = 0; r < nrows; r++) {
		size_t p = (size_t)rows[r];
		int row = s->active[p] && unknown(s, p);
		int32_t nb[6];
		double cf[6];
		ndo__row_stencil(s, p, nb, cf);
		double pen = penalty_at(s, p), diag = s->mass[p] * (1 + cb * s->gam[p]) + ck * pen;
		for (int k = 0; k < 6; k++)
			diag += ck * cf[k];
		dinv[p] = row ? 1 / diag : 0;
		double m = s->mass[p], g = s->gam[p];
		for (int c = 0; c < 3; c++) {
			size_t o = (size_t)c * cnt, q = o + p;
			if (!row) {
				b[q] = 0;
				continue;
			}
			double rhs = m * s->v[q] + h * m * (a[q] + g * s->v[q]);
			if (trap) {
				/* K v over the unknowns (pins' velocities do not enter) */
				double kv = 0, vp = s->v[q];
				for (int k = 0; k < 6; k++) {
					size_t n = (size_t)nb[k];
					kv += cf[k] * (vp - (unknown(s, n) ? s->v[o + n] : 0));
				}
				kv += pen * vp;
				rhs += -0.5 * h * m * g * vp - 0.25 * h * h * kv + (df ? 0.5 * h * df[q] : 0);
			} else if (df) {
				rhs += h * df[q];
			}
			b[q] = rhs;
		}
	}
	return NDO_OK;
}

int ndo_sim_implicit_begin(ndo_sim *s, double h, const int32_t *rows, size_t nrows, double *b,
                           double *dinv)
{
	const unsigned fp = ndo_fp_flush();
	int rc = sim_implicit_begin(s, h, rows, nrows, b, dinv);
	ndo_fp_set(fp);
	return rc;
}

/* Row p of y = A x (ndo_sim_implicit_apply's reference loop). */
static void apply_row(const ndo_sim *s, double cb, double ck, size_t p, const double *x, double *y)
{
	const size_t cnt = s->count;
	if (!(s->active[p] && unknown(s, p))) {
		for (int c = 0; c < 3; c++)
			y[(size_t)c * cnt + p] = 0;
		return;
	}
	int32_t nb[6];
	double cf[6];
	ndo__row_stencil(s, p, nb, cf);
	int un[6];
	for (int k = 0; k < 6; k++)
		un[k] = unknown(s, (size_t)nb[k]);
	const double dm = s->mass[p] * (1 + cb * s->gam[p]), pen = penalty_at(s, p);
	for (int c = 0; c < 3; c++) {
		const size_t o = (size_t)c * cnt;
		const double xp = x[o + p];
		double kx = pen * xp;
		for (int k = 0; k < 6; k++)
			kx += cf[k] * (xp - (un[k] ? x[o + (size_t)s->canon[nb[k]]] : 0));
		y[o + p] = dm * xp + ck * kx;
	}
}

static void sim_implicit_apply(const ndo_sim *s, double h, const int32_t *rows, size_t nrows,
                               const double *x, double *y)
{
	double cb, ck;
	coefs(s, h, &cb, &ck);
	for (size_t r = 0; r < nrows; r++)
		apply_row(s, cb, ck, (size_t)rows[r], x, y);
}

void ndo_sim_implicit_apply(const ndo_sim *s, double h, const int32_t *rows, size_t nrows,
                            const double *x, double *y)
{
	const unsigned fp = ndo_fp_flush();
	sim_implicit_apply(s, h, rows, nrows, x, y);
	ndo_fp_set(fp);
}

/* ---- one set of rows, many products ----------------------------------------- */
struct ndo_sim_rows {
	double cb, ck;
	int32_t *run;  /* nrun runs [run[2k], run[2k+1]) of regular rows (below) */
	int32_t *rest; /* the other rows (apply_rest, from the stencils below) */
	double *dm;    /* per stored node: mass (1 + cb γ) of the runs' rows */
	/* the other rows' stencils as apply_row reads them: per rest row, 6
	 * neighbours (the canonical node, −1 where it is not an unknown; −2 in
	 * the first for a row that is not an unknown: its y is 0) and their
	 * coefficients, the mass term and the penalty */
	int32_t *rnb;
	double *rcf, *rdm, *rpen;
	size_t nrun, nrest, cap, ndm;
	int sorted; /* the rows were given in ascending order */
};

/* Does row p read what the grid's interior stencil reads, as apply_row
 * would: integrated, an unknown, no penalty spring, and its six
 * neighbours the interior ones (ndo__row_stencil's first case), canonical
 * and unknowns? */
static int regular(const ndo_sim *s, size_t p)
{
	const size_t w = (size_t)s->w;
	const int i = (int)(p % w), j = (int)(p / w);
	if (!(i >= 1 && i <= 2 * s->n - 1 && j >= 1 && j <= s->n - 1) || !s->active[p] ||
	    !unknown(s, p) || penalty_at(s, p) != 0)
		return 0;
	const size_t q[6] = {p + 1, p + w, p + w - 1, p - 1, p - w, p - w + 1};
	for (int k = 0; k < 6; k++)
		if ((size_t)s->canon[q[k]] != q[k] || !unknown(s, q[k]))
			return 0;
	return 1;
}

size_t ndo__rows_regular(const ndo_sim_rows *r)
{
	size_t n = 0;
	for (size_t k = 0; k < r->nrun; k++)
		n += (size_t)(r->run[2 * k + 1] - r->run[2 * k]);
	return n;
}

void ndo_sim_rows_free(ndo_sim_rows *r)
{
	if (r)
		free(r->run), free(r->rest), free(r->dm), free(r->rnb), free(r->rcf), free(r->rdm),
		        free(r->rpen), free(r);
}

int ndo_sim_implicit_rows(const ndo_sim *s, double h, const int32_t *rows, size_t nrows,
                          ndo_sim_rows **out)
{
	ndo__clear_error();
	ndo_sim_rows *r = *out;
	if (!r && !(r = *out = calloc(1, sizeof *r)))
		return ndo__fail(NDO_ENOMEM, "out of memory");
	if (nrows > r->cap) {
		int32_t *run = realloc(r->run, 2 * nrows * sizeof *run), *rest = NULL, *rnb = NULL;
		double *rcf = NULL, *rdm = NULL, *rpen = NULL;
		if (run)
			r->run = run;
		if (run && (rest = realloc(r->rest, nrows * sizeof *rest)))
			r->rest = rest;
		if (rest && (rnb = realloc(r->rnb, 6 * nrows * sizeof *rnb)))
			r->rnb = rnb;
		if (rnb && (rcf = realloc(r->rcf, 6 * nrows * sizeof *rcf)))
			r->rcf = rcf;
		if (rcf && (rdm = realloc(r->rdm, nrows * sizeof *rdm)))
			r->rdm = rdm;
		if (rdm && (rpen = realloc(r->rpen, nrows * sizeof *rpen)))
			r->rpen = rpen;
		if (!rpen)
			return ndo__fail(NDO_ENOMEM, "out of memory");
		r->cap = nrows;
	}
	if (r->ndm < s->count) {
		double *dm = realloc(r->dm, s->count * sizeof *dm);
		if (!dm)
			return ndo__fail(NDO_ENOMEM, "out of memory");
		r->dm = dm, r->ndm = s->count;
	}
	coefs(s, h, &r->cb, &r->ck);
	r->nrun = r->nrest = 0;
	r->sorted = 1;
	for (size_t k = 1; k < nrows; k++)
		r->sorted &= rows[k - 1] < rows[k];
	for (size_t k = 0; k < nrows; k++) {
		const int32_t p = rows[k];
		if (!regular(s, (size_t)p))
			r->rest[r->nrest++] = p;
		else if (r->nrun && r->run[2 * r->nrun - 1] == p)
			r->run[2 * r->nrun - 1] = p + 1;
		else
			r->run[2 * r->nrun] = p, r->run[2 * r->nrun + 1] = p + 1, r->nrun++;
	}
	for (size_t k = 0; k < r->nrun; k++)
		for (int32_t p = r->run[2 * k]; p < r->run[2 * k + 1]; p++)
			r->dm[p] = s->mass[p] * (1 + r->cb * s->gam[p]);
	for (size_t k = 0; k < r->nrest; k++) {
		const size_t p = (size_t)r->rest[k];
		if (!(s->active[p] && unknown(s, p))) {
			r->rnb[6 * k] = -2;
			continue;
		}
		int32_t nb[6];
		ndo__row_stencil(s, p, nb, r->rcf + 6 * k);
		for (int j = 0; j < 6; j++)
			r->rnb[6 * k + j] = unknown(s, (size_t)nb[j]) ? s->canon[nb[j]] : -1;
		r->rdm[k] = s->mass[p] * (1 + r->cb * s->gam[p]);
		r->rpen[k] = penalty_at(s, p);
	}
	return NDO_OK;
}

/* apply_row's arithmetic, in its order, on a run of regular rows: their
 * neighbours at fixed offsets and the coefficients as ndo__row_stencil
 * reads them, so that the compiler can take several rows at once (the
 * penalty's 0 · x kept: a zero's sign is apply_row's too).  The three
 * planes in one pass, so that a row's coefficients and mass term are
 * read once, not once a plane. */
#define RUN_PLANE(T, LD, ST, X, Y)                                                     \
	do {                                                                               \
		const T xp = LD(X + p);                                                        \
		T kx = 0 * xp;                                                                 \
		kx += a0 * (xp - LD(X + p + 1));                                               \
		kx += a1 * (xp - LD(X + p + w));                                               \
		kx += a2 * (xp - LD(X + p + w - 1));                                           \
		kx += a3 * (xp - LD(X + p - 1));                                               \
		kx += a4 * (xp - LD(X + p - w));                                               \
		kx += a5 * (xp - LD(X + p - w + 1));                                           \
		ST(Y + (p - lo), dm * xp + ck * kx);                                           \
	} while (0)
#define RUN_ROWS(T, LD, ST)                                                                \
	do {                                                                               \
		const T a0 = LD(e0 + p), a1 = LD(e1 + p), a2 = LD(e2 + p), a3 = LD(e0 + p - 1),  \
		        a4 = LD(e1 + p - w), a5 = LD(e2 + p - w + 1), dm = LD(dmr + p);        \
		RUN_PLANE(T, LD, ST, X0, Y0);                                                  \
		RUN_PLANE(T, LD, ST, X1, Y1);                                                  \
		RUN_PLANE(T, LD, ST, X2, Y2);                                                  \
	} while (0)
NDO_HOT static void apply_runs(const ndo_sim *s, const ndo_sim_rows *r, size_t k0,
                               const double *x, double *y, size_t stride, size_t lo, size_t hi)
{
	const size_t cnt = s->count, w = (size_t)s->w;
	const double *const e0 = s->st.e[0], *const e1 = s->st.e[1], *const e2 = s->st.e[2];
	const double *const dmr = r->dm, ck = r->ck;
	const double *X0 = x, *X1 = x + cnt, *X2 = x + 2 * cnt;
	/* Y_c[p] is y[c·stride + p − lo]: the offset is taken from p, not from
	 * the pointers, which stay within y */
	double *Y0 = y, *Y1 = y + stride, *Y2 = y + 2 * stride;
	for (size_t k = k0; k < r->nrun && (size_t)r->run[2 * k] < hi; k++) {
		const size_t p1 = (size_t)r->run[2 * k + 1] < hi ? (size_t)r->run[2 * k + 1] : hi;
		size_t p = (size_t)r->run[2 * k] > lo ? (size_t)r->run[2 * k] : lo;
		for (; p + 4 <= p1; p += 4)
			RUN_ROWS(ndo__v4, V4_LD, V4_ST);
		for (; p < p1; p++)
			RUN_ROWS(double, V1_LD, V1_ST);
	}
}
#undef RUN_ROWS
#undef RUN_PLANE

/* The rest rows k0.. below hi, apply_row's arithmetic from the stencils
 * gathered once, at y[c·stride + p − lo]. */
static void apply_rest(const ndo_sim *s, const ndo_sim_rows *r, size_t k0, const double *x,
                       double *y, size_t stride, size_t lo, size_t hi)
{
	const size_t cnt = s->count;
	for (size_t k = k0; k < r->nrest && (size_t)r->rest[k] < hi; k++) {
		const size_t p = (size_t)r->rest[k];
		const int32_t *nb = r->rnb + 6 * k;
		const double *cf = r->rcf + 6 * k, dm = r->rdm[k], pen = r->rpen[k];
		for (int c = 0; c < 3; c++) {
			const size_t o = (size_t)c * cnt, out = (size_t)c * stride + p - lo;
			if (nb[0] == -2) {
				y[out] = 0;
				continue;
			}
			const double xp = x[o + p];
			double kx = pen * xp;
			for (int j = 0; j < 6; j++)
				kx += cf[j] * (xp - (nb[j] >= 0 ? x[o + (size_t)nb[j]] : 0));
			y[out] = dm * xp + r->ck * kx;
		}
	}
}

static void sim_implicit_apply_rows(const ndo_sim *s, const ndo_sim_rows *r, const double *x,
                                    double *y)
{
	apply_runs(s, r, 0, x, y, s->count, 0, s->count);
	apply_rest(s, r, 0, x, y, s->count, 0, s->count);
}

void ndo_sim_implicit_apply_rows(const ndo_sim *s, const ndo_sim_rows *r, const double *x,
                                 double *y)
{
	const unsigned fp = ndo_fp_flush();
	sim_implicit_apply_rows(s, r, x, y);
	ndo_fp_set(fp);
}

int ndo_sim_rows_sorted(const ndo_sim_rows *r)
{
	return r->sorted;
}

static void sim_implicit_apply_range(const ndo_sim *s, const ndo_sim_rows *r, const double *x,
                                     double *y, size_t stride, size_t lo, size_t hi)
{
	if (!r->sorted || lo >= hi)
		return;
	/* the first run that ends after lo, the first rest row from lo */
	size_t a = 0, b = r->nrun;
	while (a < b) {
		size_t mid = a + (b - a) / 2;
		if ((size_t)r->run[2 * mid + 1] <= lo)
			a = mid + 1;
		else
			b = mid;
	}
	apply_runs(s, r, a, x, y, stride, lo, hi);
	a = 0, b = r->nrest;
	while (a < b) {
		size_t mid = a + (b - a) / 2;
		if ((size_t)r->rest[mid] < lo)
			a = mid + 1;
		else
			b = mid;
	}
	apply_rest(s, r, a, x, y, stride, lo, hi);
}

void ndo_sim_implicit_apply_range(const ndo_sim *s, const ndo_sim_rows *r, const double *x,
                                  double *y, size_t stride, size_t lo, size_t hi)
{
	const unsigned fp = ndo_fp_flush();
	sim_implicit_apply_range(s, r, x, y, stride, lo, hi);
	ndo_fp_set(fp);
}

static int sim_implicit_rigid(const ndo_sim *s, double h, const int32_t *rows, size_t nrows,
                              const double *x, double sums[7], double *gamma)
{
	for (size_t q = 0; q < s->count; q++)
		if (s->pin[q])
			return 0; /* implicit.c corrects only a free object */
	if (s->npen)
		return 0;
	const size_t cnt = s->count;
	const int trap = s->p.method == NDO_TRAPEZOID;
	const double *df = s->imp_df ? s->vs : NULL;
	*gamma = s->gam[s->canon[0]];
	memset(sums, 0, 7 * sizeof *sums);
	for (size_t r = 0; r < nrows; r++) {
		size_t p = (size_t)rows[r];
		if (!s->active[p])
			continue;
		double m = s->mass[p], g = *gamma;
		for (int k = 0; k < 3; k++) {
			size_t q = (size_t)k * cnt + p;
			double v = s->v[q];
			double f1 = s->f ? s->f[q] : 0, f0 = df ? f1 - df[q] : f1;
			sums[k] += trap ? m * v - 0.5 * h * m * g * v + 0.5 * h * (f0 + f1) : m * v + h * f1;
			sums[3 + k] += m * x[q];
		}
		sums[6] += m;
	}
	return 1;
}

int ndo_sim_implicit_rigid(const ndo_sim *s, double h, const int32_t *rows, size_t nrows,
                           const double *x, double sums[7], double *gamma)
{
	const unsigned fp = ndo_fp_flush();
	int rc = sim_implicit_rigid(s, h, rows, nrows, x, sums, gamma);
	ndo_fp_set(fp);
	return rc;
}

static int sim_implicit_end(ndo_sim *s, double h, const double *x)
{
	const size_t cnt = s->count;
	const int trap = s->p.method == NDO_TRAPEZOID;
	for (size_t k = 0; k < s->nespan; k++)
		for (size_t p = (size_t)s->espan[k].a; p < (size_t)s->espan[k].b; p++)
			for (int c = 0; c < 3; c++) {
				size_t q = (size_t)c * cnt + p;
				double vn = x[q];
				s->u[q] += trap ? 0.5 * h * (s->v[q] + vn) : h * vn;
				s->v[q] = vn;
			}
	ndo__sync_planes(s, s->u, 3);
	ndo__sync_planes(s, s->v, 3);
	ndo__implicit_account(s, h);
	s->stats.substeps++;
	s->t += h;
	s->step++;
	s->stats.steps++;
	return NDO_OK;
}

int ndo_sim_implicit_end(ndo_sim *s, double h, const double *x)
{
	const unsigned fp = ndo_fp_flush();
	int rc = sim_implicit_end(s, h, x);
	ndo_fp_set(fp);
	return rc;
}
