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

int ndo_sim_implicit_begin(ndo_sim *s, double h, const int32_t *rows, size_t nrows, double *b,
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

void ndo_sim_implicit_apply(const ndo_sim *s, double h, const int32_t *rows, size_t nrows,
                            const double *x, double *y)
{
	const size_t cnt = s->count;
	double cb, ck;
	coefs(s, h, &cb, &ck);
	for (size_t r = 0; r < nrows; r++) {
		size_t p = (size_t)rows[r];
		if (!(s->active[p] && unknown(s, p))) {
			for (int c = 0; c < 3; c++)
				y[(size_t)c * cnt + p] = 0;
			continue;
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
}

int ndo_sim_implicit_rigid(const ndo_sim *s, double h, const int32_t *rows, size_t nrows,
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

int ndo_sim_implicit_end(ndo_sim *s, double h, const double *x)
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
	s->pend_h = h;
	s->pend_power = s->last_power;
	s->stats.substeps++;
	s->t += h;
	s->step++;
	s->stats.steps++;
	return NDO_OK;
}
