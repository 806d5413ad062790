/* stability.c — the critical step: λ_max(M⁻¹K) by power iteration and each
 * method's stability on a damped mode (ndo/sim.h).
 *
 * A mode of M u'' + B u' + K u = 0 with M⁻¹K φ = ω² φ and damping rate γ
 * (exactly φᵀBφ / φᵀMφ for mass-proportional damping) is the 2 × 2 system
 * y' = A y, A = [0 1; −ω² −γ], whose eigenvalues are −γ/2 ± √(γ²/4 − ω²).
 * One step of a method maps y to G(h) y; the method is stable on the mode
 * while the spectral radius ρ(G) ≤ 1.  For a Runge–Kutta method
 * G = R(hA) with R its stability polynomial (computed from the tableau
 * the integrator uses, integrate.c); symplectic Euler has its own G; the
 * implicit methods are A-stable.
 *
 * Which bound applies (DESIGN.md asks for c/ω_max with c the imaginary-
 * axis interval):
 *   - light damping (γ ≪ ω): the eigenvalues hug the imaginary axis, so a
 *     method whose stability region holds a segment |y| ≤ c_imag of it is
 *     limited by h ≤ c_imag/ω_max (RK4: 2√2 = 2.83, rkf45 as propagated:
 *     3.4, symplectic Euler: 2);
 *   - forward Euler and midpoint hold no such segment (|R(iy)| > 1 for all
 *     y > 0): without damping they are unstable at every step, and with
 *     damping their bound comes from how far damping pulls the eigenvalues
 *     into the left half-plane — Euler h ≤ γ/ω², midpoint h ≈ (4γ/ω⁴)^⅓ —
 *     slopes 1/k and k^(−2/3) against the stiffness (ω² ∝ k);
 *   - heavy damping (γ > 2ω, overdamped): the eigenvalues are real, near
 *     −γ, and the negative real-axis interval c_real applies: h ≤ c_real/γ.
 * ndo_stable_step finds the exact limit for every case numerically and
 * names the bound that binds.
 */
#include "sim_private.h"
#include "ndo/status.h"
#include "ndo/topology.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct m2 {
	double a, b, c, d; /* [a b; c d] */
} m2;

static m2 mul(m2 x, m2 y)
{
	return (m2){x.a * y.a + x.b * y.c, x.a * y.b + x.b * y.d, x.c * y.a + x.d * y.c,
	            x.c * y.b + x.d * y.d};
}

/* The spectral radius of a 2 × 2 matrix.  The discriminant is taken as
 * ((a − d)/2)² + bc, not tr²/4 − det: near a double eigenvalue 1 the
 * latter cancels catastrophically and invents growth of order √ε. */
static double radius(m2 g)
{
	double half = 0.5 * (g.a - g.d), disc = half * half + g.b * g.c, mid = 0.5 * (g.a + g.d);
	if (disc >= 0) {
		double r = sqrt(disc);
		return fmax(fabs(mid + r), fabs(mid - r));
	}
	return sqrt(fabs(g.a * g.d - g.b * g.c));
}

/* A method's stability polynomial R (explicit Runge–Kutta: deg ≥ 0),
 * computed once per scan, not per trial step: the tableau's product made
 * RK4's scans (mode_limit) 12 times slower than symplectic Euler's, 20–40
 * ms per critical step (issue 18: the error estimate's fixed cost). */
typedef struct poly {
	int deg;
	double r[7];
} poly;

static poly poly_of(ndo_method m)
{
	poly P = {-1, {0}};
	if (m != NDO_SYMPLECTIC_EULER && !ndo_method_is_implicit(m))
		P.deg = ndo__stability_poly(m, P.r);
	return P;
}

/* The one-step matrix of method m (R: poly_of(m)) with step h on the mode
 * (ω, γ). */
static m2 one_step(ndo_method m, const poly *R, double omega, double gamma, double h)
{
	m2 A = {0, h, -h * omega * omega, -h * gamma}; /* hA */
	switch (m) {
	case NDO_SYMPLECTIC_EULER:
		/* v' = v + h(−ω²u − γv), u' = u + h v'. */
		return (m2){1 - h * h * omega * omega, h * (1 - h * gamma), -h * omega * omega,
		            1 - h * gamma};
	case NDO_BACKWARD_EULER:
	case NDO_TRAPEZOID: {
		double s = m == NDO_TRAPEZOID ? 0.5 : 1;
		m2 L = {1 - s * A.a, -s * A.b, -s * A.c, 1 - s * A.d};
		double det = L.a * L.d - L.b * L.c;
		m2 Li = {L.d / det, -L.b / det, -L.c / det, L.a / det};
		if (m == NDO_BACKWARD_EULER)
			return Li;
		m2 Rm = {1 + 0.5 * A.a, 0.5 * A.b, 0.5 * A.c, 1 + 0.5 * A.d};
		return mul(Li, Rm);
	}
	default: {
		const double *r = R->r;
		int deg = R->deg;
		/* Horner: G = r0 I + hA (r1 I + hA (r2 I + ...)). */
		m2 G = {r[deg], 0, 0, r[deg]};
		for (int k = deg - 1; k >= 0; k--) {
			G = mul(A, G);
			G.a += r[k];
			G.d += r[k];
		}
		return G;
	}
	}
}

double ndo_amplification(ndo_method m, double omega, double gamma, double h)
{
	poly R = poly_of(m);
	return radius(one_step(m, &R, omega, gamma, h));
}

/* A growth of 1e-12 per step doubles the state only after 7·10¹¹ steps:
 * below it a method counts as stable. */
#define UNSTABLE 1e-12

static int unstable(ndo_method m, const poly *R, double omega, double gamma, double h)
{
	return radius(one_step(m, R, omega, gamma, h)) > 1 + UNSTABLE;
}

/* A mode's trial steps: h_k = h_(k−1) · 1.02 from 10⁻⁹/ref (ref = max(ω,
 * γ)) while below 10⁴/ref, about 1,150 of them.  The scan (strided 1)
 * tries every STRIDE-th of them and, past the first that is unstable, the
 * ones of the stride before it one by one: the same
 * first unstable trial step as trying them all, unless a run of unstable
 * steps shorter than a stride (an 88 % range of h) lay between two stable
 * trial steps — and then all of them (strided 0) would still miss one
 * shorter than 2 %.  For Euler, midpoint, RK4 and symplectic Euler the
 * stable steps of a mode are one interval [0, limit): the two scans gave
 * the same step, bit for bit, at 13 ω from 0.01 to 10⁴ × 62 damping rates
 * from 0 to 1.7·10⁴ ω (806 cases a method; test_sim's
 * the_stable_step_is_its_full_scan compares 39 more).  Not for rkf45 as
 * propagated: its growth on the imaginary axis comes and goes, so on a
 * lightly damped mode (γ/ω ≈ 0.004) a run of unstable steps lies between
 * stable ones, and strided it missed that in 26 of the 806 (a step 2-3
 * times too large).  About 100 trial steps instead of 1,150, with the
 * bisection below. */
#define STRIDE 32

/* Whether a method's scans may be strided (above). */
static int strides(ndo_method m)
{
	return m != NDO_RKF45;
}

/* The smallest h > 0 at which the method turns unstable on one mode (R:
 * poly_of(m)); or, once every step up to `above` or beyond is stable, a
 * step at least that large (the limit is then not below it).  strided 0:
 * every trial step tried (the reference). */
static double mode_limit_above(ndo_method m, const poly *R, double omega, double gamma,
                               double above, int strided)
{
	double ref = fmax(omega, gamma);
	if (!(ref > 0))
		return INFINITY;
	const double end = 1e4 / ref;
	double h = 1e-9 / ref, prev = 0;
	if (strided && !unstable(m, R, omega, gamma, h)) {
		/* Every STRIDE-th trial step until one is unstable (or past
		 * `above`, or the end); then back to the stable one before it. */
		double base = h, at;
		for (;;) {
			at = base;
			int k = 0;
			for (; k < STRIDE && at < end; k++)
				at *= 1.02;
			if (at >= end || base >= above || unstable(m, R, omega, gamma, at))
				break;
			base = at;
		}
		if (base >= above)
			return base; /* stable, and not below `above` */
		/* The trial steps after base one by one, as below, from the
		 * stable base: base is h_k for some k, so the sequence and its
		 * rounding are the unstrided scan's. */
		prev = base;
		h = base * 1.02;
	}
	while (h < end) {
		if (prev >= above)
			return prev; /* the limit is at least prev: not below `above` */
		if (unstable(m, R, omega, gamma, h))
			break;
		prev = h;
		h *= 1.02;
	}
	if (h >= end)
		return INFINITY;
	if (prev == 0)
		return 0;
	double lo = prev, hi = h;
	for (int k = 0; k < 100 && hi - lo > 1e-15 * hi; k++) {
		double mid = 0.5 * (lo + hi);
		if (unstable(m, R, omega, gamma, mid))
			hi = mid;
		else
			lo = mid;
	}
	return lo;
}

/* The smallest h > 0 at which the method turns unstable on one mode. */
static double mode_limit(ndo_method m, double omega, double gamma, int strided)
{
	poly R = poly_of(m);
	return mode_limit_above(m, &R, omega, gamma, INFINITY, strided);
}

double ndo_stability_interval(ndo_method m, int imaginary)
{
	if (ndo_method_is_implicit(m))
		return INFINITY;
	if (imaginary)
		return mode_limit(m, 1, 0, strides(m)); /* hω on an undamped mode */
	/* The negative real axis: a pure decay u' = −λu is the mode ω → 0 of
	 * u'' + γu' = 0, whose nonzero eigenvalue is −γ. */
	return mode_limit(m, 0, 1, strides(m));
}

/* ndo_stable_step, its modes' limits found in full, every trial step
 * tried (`fast` 0), or each mode's scan strided (mode_limit_above) and
 * stopped once its steps pass the least limit so far, which it then cannot
 * undercut (1): the same minimum, the same mode, the same bits (test_sim:
 * the_stable_step_is_its_full_scan).  A mode's scan is about a thousand
 * steps of 2 %; RK4's 201 modes at level 6 (ω 134, γ 0.1) took 5.4 ms a
 * call in full and 4.0 stopped early (symplectic Euler 2.6 and 1.8), the
 * scans half of choosing an accuracy (ndo/accuracy.h); strided as well
 * (not rkf45), at ω 268, γ 0.1: RK4 2.65 → 0.33 ms, symplectic Euler 1.35
 * → 0.30, Euler 0.69 → 0.17, midpoint 1.38 → 0.26 (2026-11-30, load 1). */
double ndo__stable_step_scan(ndo_method m, double omega, double gamma, int *bound, int fast)
{
	if (ndo_method_is_implicit(m)) {
		if (bound)
			*bound = NDO_BOUND_NONE;
		return INFINITY;
	}
	const poly R = poly_of(m);
	const int strided = fast && strides(m);
	/* The modes lie anywhere in (0, ω]; lower ones can bind when damping
	 * is heavy.  Scan ω geometrically down to 10⁻⁴ ω_max. */
	double best = INFINITY, at = omega;
	for (int k = 0; k <= 200; k++) {
		double w = omega * pow(1e-4, k / 200.0);
		double hm = mode_limit_above(m, &R, w, gamma, fast ? best : INFINITY, strided);
		if (hm < best) {
			best = hm;
			at = w;
		}
	}
	/* ω → 0: the pure decay −γ. */
	if (gamma > 0) {
		double hm = mode_limit(m, 0, gamma, strided);
		if (hm < best) {
			best = hm;
			at = 0;
		}
	}
	/* Overdamped limiting mode: the real axis.  Otherwise the limit is the
	 * oscillation when the step spans more than a radian of the top mode
	 * (damping only shifts it), and the damping when the step is stable
	 * only because damping outweighs a growth on the imaginary axis
	 * (Euler, midpoint, and rkf45 as propagated, which grows by up to
	 * 6·10⁻⁴ per step there). */
	int b = gamma > 2 * at ? NDO_BOUND_REAL
	        : best * omega > 1 ? NDO_BOUND_OSCILLATION
	                           : NDO_BOUND_DAMPING;
	if (bound)
		*bound = b;
	if (gamma == 0 && ndo_stability_interval(m, 1) < 0.5) {
		/* No damping and no imaginary interval: unstable at every step. */
		if (bound)
			*bound = NDO_BOUND_DAMPING;
		return 0;
	}
	return best;
}

double ndo_stable_step(ndo_method m, double omega, double gamma, int *bound)
{
	return ndo__stable_step_scan(m, omega, gamma, bound, 1);
}

/* ---- λ_max(M⁻¹K) by power iteration ---------------------------------------- */

static uint64_t splitmix(uint64_t *x)
{
	uint64_t z = (*x += 0x9e3779b97f4a7c15ULL);
	z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
	z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
	return z ^ (z >> 31);
}

/* The power iteration runs scale-free: with the masses divided by the
 * largest, m̂ = m / m_ref, and every iterate scaled to a largest entry of
 * 1 before its norm is taken, no product leaves the range of doubles at
 * any density or stiffness the tools accept (ρ = 1e-160 made x ~ 1e81
 * and its square overflow; σ = 1e-200 made |y|² ~ 1e-400 underflow).
 * λ̂ = λ_max(M̂⁻¹K) = m_ref · λ_max(M⁻¹K), and ω_max = √λ̂ / √m_ref. */
typedef struct scaled {
	ndo_sim *s;
	double *mhat; /* m / m_ref per stored node */
} scaled;

/* y = M̂⁻¹(K + P) x on the active nodes, 0 on the held ones (the held
 * nodes are fixed: Dirichlet conditions). */
static void apply_mk(const scaled *sc, const double *x, double *y)
{
	ndo_sim *s = sc->s;
	ndo_stencil_apply(&s->st, x, y);
	for (size_t p = 0; p < s->count; p++)
		y[p] = s->active[p] ? y[p] / sc->mhat[p] : 0;
	for (size_t k = 0; k < s->npen; k++) {
		size_t p = (size_t)s->pen[k];
		if (s->active[p])
			y[p] += s->alpha / sc->mhat[p] * x[p];
	}
	ndo_sync(s->level, y, sizeof *y);
}

/* ‖x‖²_M̂ over the canonical nodes. */
static double mnorm2(const scaled *sc, const double *x, const double *y)
{
	double sum = 0;
	for (size_t p = 0; p < sc->s->count; p++)
		if (sc->s->canon[p] == (int32_t)p)
			sum += sc->mhat[p] * x[p] * y[p];
	return sum;
}

/* Divide x by its largest magnitude (when it has one) and return that. */
static double unit_max(double *x, size_t n)
{
	double m = 0;
	for (size_t p = 0; p < n; p++)
		m = fmax(m, fabs(x[p]));
	if (m > 0 && isfinite(m))
		for (size_t p = 0; p < n; p++)
			x[p] /= m;
	return m;
}

/* One power iteration's passes after y = M̂⁻¹(K + P) x, fused: the
 * Rayleigh quotient and |y|'s largest entry in one pass, ‖y/m‖_M̂ in a
 * second, x = (y/m)/‖y/m‖ in a third — the same operations on the same
 * values, in the same order, as mnorm2, unit_max, mnorm2 and the division
 * one after the other (5 passes, and a libm fmax call an entry), so the
 * same bits (test_sim: the_critical_step_is_its_reference).  Returns 0 where
 * those would have ended the iteration (no largest entry, or no norm). */
static int power_passes(const scaled *sc, double *x, const double *y, double *lambda)
{
	const ndo_sim *s = sc->s;
	const size_t cnt = s->count;
	const double *mhat = sc->mhat;
	const int32_t *canon = s->canon;
	double sum = 0, m = 0;
	for (size_t p = 0; p < cnt; p++) {
		if (canon[p] == (int32_t)p)
			sum += mhat[p] * x[p] * y[p];
		const double a = fabs(y[p]);
		m = a > m ? a : m; /* fmax's: a NaN entry is passed over */
	}
	*lambda = sum;
	if (!(m > 0))
		return 0;
	const int div = isfinite(m); /* unit_max divides by a finite largest entry only */
	double n2 = 0;
	for (size_t p = 0; p < cnt; p++)
		if (canon[p] == (int32_t)p) {
			const double t = div ? y[p] / m : y[p];
			n2 += mhat[p] * t * t;
		}
	const double ny = sqrt(n2);
	if (!(ny > 0))
		return 0;
	for (size_t p = 0; p < cnt; p++)
		x[p] = (div ? y[p] / m : y[p]) / ny;
	return 1;
}

/* ndo_sim_critical with the power iteration's passes fused (fast 1) or one
 * after the other as before (0: the reference test_sim compares it with). */
int ndo__sim_critical(ndo_sim *s, ndo_critical *c, int fast)
{
	ndo__clear_error();
	memset(c, 0, sizeof *c);
	size_t cnt = s->count;
	double *x = malloc(cnt * sizeof *x), *y = malloc(cnt * sizeof *y),
	       *mhat = malloc(cnt * sizeof *mhat);
	if (!x || !y || !mhat) {
		free(x), free(y), free(mhat);
		return ndo__fail(NDO_ENOMEM, "out of memory for the critical step");
	}
	double mref = 0;
	for (size_t p = 0; p < cnt; p++)
		mref = fmax(mref, s->mass[p]);
	for (size_t p = 0; p < cnt; p++)
		mhat[p] = s->mass[p] / mref;
	scaled sc = {s, mhat};
	/* A seeded random start has a component along the top mode almost
	 * surely; alternating signs favour the high frequencies from the
	 * first iteration on. */
	uint64_t seed = 0x6e646f;
	for (size_t p = 0; p < cnt; p++) {
		double r = (double)(splitmix(&seed) >> 11) / 9007199254740992.0;
		int i = (int)(p % (size_t)s->w), j = (int)(p / (size_t)s->w);
		x[p] = s->active[p] ? (0.5 + r) * (((i + j) & 1) ? 1 : -1) : 0;
	}
	ndo_sync(s->level, x, sizeof *x);
	double nx = sqrt(mnorm2(&sc, x, x));
	if (!(nx > 0)) {
		/* Nothing is integrated: no constraint on the step. */
		free(x), free(y), free(mhat);
		c->h_crit = INFINITY;
		c->bound = NDO_BOUND_NONE;
		return NDO_OK;
	}
	for (size_t p = 0; p < cnt; p++)
		x[p] /= nx;
	double lambda = 0, hist[10] = {0};
	int it;
	const int max_it = 20000;
	for (it = 1; it <= max_it; it++) {
		apply_mk(&sc, x, y);
		/* Rayleigh quotient in the M̂ inner product (M̂⁻¹K is self-adjoint
		 * there): xᵀK x / xᵀM̂ x with ‖x‖_M̂ = 1. */
		if (fast) {
			if (!power_passes(&sc, x, y, &lambda))
				break;
		} else {
			lambda = mnorm2(&sc, x, y);
			if (!(unit_max(y, cnt) > 0))
				break;
			double ny = sqrt(mnorm2(&sc, y, y));
			if (!(ny > 0))
				break;
			for (size_t p = 0; p < cnt; p++)
				x[p] = y[p] / ny;
		}
		double old = hist[it % 10];
		hist[it % 10] = lambda;
		if (it >= 100) {
			c->converged = fabs(lambda - old) / lambda;
			if (c->converged < 1e-7)
				break;
		}
	}
	c->iterations = it > max_it ? max_it : it;
	/* The damping rate of the mode found: φᵀBφ / φᵀMφ, B_ii = m_i γ_i. */
	double num = 0, den = 0;
	for (size_t p = 0; p < cnt; p++)
		if (s->canon[p] == (int32_t)p && s->active[p]) {
			num += mhat[p] * s->gam[p] * x[p] * x[p];
			den += mhat[p] * x[p] * x[p];
		}
	free(x), free(y), free(mhat);
	c->lambda_max = lambda / mref;
	c->omega_max = sqrt(lambda) / sqrt(mref);
	c->gamma = den > 0 ? num / den : 0;
	c->c_imag = ndo_stability_interval(s->p.method, 1);
	c->c_real = ndo_stability_interval(s->p.method, 0);
	c->h_crit = ndo_stable_step(s->p.method, c->omega_max, c->gamma, &c->bound);
	return NDO_OK;
}

int ndo_sim_critical(ndo_sim *s, ndo_critical *c) { return ndo__sim_critical(s, c, 1); }
