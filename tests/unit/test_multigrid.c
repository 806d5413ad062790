/* test_multigrid — the implicit methods' multigrid solver (lib/sim/multigrid.c)
 * against CHOLMOD, the reference: the same steps to the residual tolerance
 * on a catalogue of systems (both methods; small and large steps, so that
 * the solver runs as Jacobi-preconditioned CG, as a V-cycle with a smoothed
 * coarsest level and with a factored one; projected and penalty pins, a
 * region with held nodes, forces), the same bits on any thread count,
 * iterations that do not grow with the level, the memory estimate, and the
 * operator's index-free rows against the CSR product (bit for bit).
 *
 * Why not bitwise: CG stops at a relative residual of 1e-10, CHOLMOD is
 * exact to rounding; the steps then differ by up to about κ(A)·1e-10 of
 * the solution, and κ(A) ≤ 1 + h²λ_max(M⁻¹K) — so the tolerance below is
 * scaled by that bound. */
#include "check.h"
#include "ndo/ndo.h"
#include "multigrid.h"
#include "sim_private.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

static uint64_t rng = 7;
static double uniform(void)
{
	rng = rng * 6364136223846793005ULL + 1442695040888963407ULL;
	return (double)(rng >> 11) / 9007199254740992.0 * 2 - 1;
}

static ndo_grid *shape(const char *name, int level)
{
	ndo_grid *g = NULL;
	ndo_shape_make(name, level, NULL, &g);
	return g;
}

static ndo_sim *make(const ndo_grid *g, const double *x, const uint8_t *pin,
                     const ndo_sim_params *p)
{
	ndo_sim *s = NULL;
	if (ndo_sim_create(g->level, x, NULL, g->ch[0].data, pin, p, &s)) {
		printf("    ndo_sim_create: %s\nFAIL test_multigrid: a simulation could not be "
		       "created\n", ndo_errdetail());
		exit(1);
	}
	return s;
}

/* A wavy surface displaced by a seeded random amount (duplicates equal). */
static double *displaced(const ndo_grid *g, double amp)
{
	double *x = malloc(3 * g->count * sizeof *x);
	memcpy(x, g->ch[0].data, 3 * g->count * sizeof *x);
	for (size_t q = 0; q < 3 * g->count; q++)
		x[q] += amp * uniform();
	ndo_sync(g->level, x, 3 * sizeof *x);
	return x;
}

/* The wavy surface at level 6, displaced (*x), and the default
 * parameters with damping 0.1 (*p). */
static ndo_grid *damped_wavy(double **x, ndo_sim_params *p)
{
	ndo_grid *g = shape("wavy", 6);
	*x = displaced(g, 0.01);
	ndo_sim_defaults(p);
	p->material.damping = 0.1;
	return g;
}

typedef struct variant {
	const char *name;
	int pins;      /* 0 none, 1 projected, 2 penalty */
	int region;    /* integrate only the lower half of the rows */
	int force;     /* a sinusoidal face force */
} variant;

/* Steps with both solvers from the same state; returns the largest
 * difference of the velocities relative to the largest velocity. */
static double compare(const ndo_grid *g, const double *x, ndo_method m, double h,
                      const variant *v, int steps, int *levels, int *direct, double *res)
{
	ndo_sim_params p;
	ndo_sim_defaults(&p);
	p.method = m;
	p.material.damping = 0.1;
	ndo_force f = {.kind = NDO_FORCE_FACE, .amplitude = 2.4, .frequency = 1, .dir = {0, 0, 1}};
	int32_t faces[] = {10, 11, 12, 40};
	if (v->force) {
		f.items = faces;
		f.count = 4;
		p.forces = &f;
		p.nforces = 1;
	}
	uint8_t *pin = calloc(g->count, 1);
	if (v->pins) {
		pin[ndo_node(g->w, 3, 2)] = pin[ndo_node(g->w, g->w / 2, g->h / 2)] = pin[0] = 1;
		p.pin_mode = v->pins == 2 ? NDO_PINS_PENALTY : NDO_PINS_PROJECT;
	}
	uint8_t *mask = NULL;
	if (v->region) {
		mask = calloc(g->count, 1);
		for (size_t q = 0; q < g->count / 2; q++)
			mask[q] = 1;
	}
	ndo_sim *s[2];
	for (int k = 0; k < 2; k++) {
		p.solver = k ? NDO_SOLVER_CHOLMOD : NDO_SOLVER_MULTIGRID;
		s[k] = make(g, x, pin, &p);
		if (mask)
			ndo_sim_set_active(s[k], mask);
		for (int q = 0; q < steps; q++)
			CHECK(ndo_sim_step(s[k], h) == 0, "%s %s step %d: %s", ndo_method_names[m],
			      v->name, q, ndo_errdetail());
	}
	ndo_sim_solver_info(s[0], levels, direct);
	ndo_sim_stats st;
	ndo_sim_stats_get(s[0], &st);
	*res = st.last_residual;
	size_t n = 3 * g->count;
	double *va = malloc(n * sizeof *va), *vb = malloc(n * sizeof *vb), d = 0, big = 0;
	ndo_sim_get(s[0], NULL, va);
	ndo_sim_get(s[1], NULL, vb);
	for (size_t q = 0; q < n; q++) {
		d = fmax(d, fabs(va[q] - vb[q]));
		big = fmax(big, fabs(vb[q]));
	}
	free(va), free(vb), free(pin), free(mask);
	ndo_sim_destroy(s[0]), ndo_sim_destroy(s[1]);
	return big > 0 ? d / big : d;
}

static void steps_equal_cholmods(void)
{
	static const variant vs[] = {{"plain", 0, 0, 0},
	                             {"with a face force", 0, 0, 1},
	                             {"projected pins", 1, 0, 1},
	                             {"penalty pins", 2, 0, 0},
	                             {"a region (held nodes)", 0, 1, 1}};
	int seen[2] = {0, 0};
	for (int level = 5; level <= 6; level++) {
		ndo_grid *g = shape("wavy", level);
		double *x = displaced(g, 0.01);
		ndo_sim_params p;
		ndo_sim_defaults(&p);
		ndo_sim *probe = make(g, x, NULL, &p);
		ndo_critical c;
		ndo_sim_critical(probe, &c);
		ndo_sim_destroy(probe);
		/* Half RK4's limit (mass-dominated: CG with Jacobi), 10× and
		 * 1000× it (V-cycles down to a factored level 4). */
		const double fac[] = {0.5, 10, 1000};
		for (int m = NDO_BACKWARD_EULER; m <= NDO_TRAPEZOID; m++)
			for (int k = 0; k < 3; k++)
				for (size_t q = 0; q < sizeof vs / sizeof vs[0]; q++) {
					double h = fac[k] * c.h_crit, hw = h * c.omega_max;
					int levels, direct;
					double res;
					double d = compare(g, x, (ndo_method)m, h, &vs[q], 3, &levels, &direct,
					                   &res);
					double tol = 1e-9 * (1 + hw * hw);
					CHECK(d <= tol, "level %d %s h = %.3g (%s): differs from CHOLMOD by %.3g "
					      "(tolerance %.3g; %d levels%s)", level, ndo_method_names[m], h,
					      vs[q].name, d, tol, levels, direct ? ", factored" : "");
					/* NDO_SOLVER_TOL, or the rounding floor just above it
					 * (2.7e-12 at most here): at 1000× the step the true
					 * residual stalled at 2.6e-10 until CG restarted from it */
					CHECK(res <= 1e-11, "level %d %s h = %.3g (%s): relative residual %.3g",
					      level, ndo_method_names[m], h, vs[q].name, res);
					seen[levels > 1 && direct]++;
				}
		free(x);
		ndo_grid_destroy(g);
	}
	CHECK(seen[0] && seen[1], "the catalogue covers Jacobi alone (%d) and V-cycles down to a "
	      "factored level (%d)", seen[0], seen[1]);
}

/* The trapezoid takes A v from the last solve (b − r plus the rigid shift
 * times A's row sums) while v is what the solve left: the same steps as
 * CHOLMOD's with v unchanged, after velocities set from outside between
 * steps (found changed: the full product), and across a new step size. */
static void trapezoid_reuses_a_v(void)
{
	double *x;
	ndo_sim_params p;
	ndo_grid *g = damped_wavy(&x, &p);
	ndo_sim *probe = make(g, x, NULL, &p); /* RK4's limit */
	ndo_critical c;
	ndo_sim_critical(probe, &c);
	ndo_sim_destroy(probe);
	p.method = NDO_TRAPEZOID;
	const double h = 0.5 * c.h_crit, hw = 2 * h * c.omega_max, tol = 1e-9 * (1 + hw * hw);
	const int32_t nodes[3] = {ndo_node(g->w, 3, 2), ndo_node(g->w, g->w / 2, g->h / 2),
	                          ndo_node(g->w, g->w / 3, g->h / 3)};
	const double vset[9] = {0.3, -0.2, 0.1, 0, 0, 0.5, -0.4, 0.2, 0};
	const size_t n = 3 * g->count;
	double *va = malloc(n * sizeof *va), *vb = malloc(n * sizeof *vb);
	for (int cs = 0; cs < 3; cs++) { /* 0: untouched, 1: v set after step 4, 2: 2h from step 6 */
		ndo_sim *s[2];
		for (int k = 0; k < 2; k++) {
			p.solver = k ? NDO_SOLVER_CHOLMOD : NDO_SOLVER_MULTIGRID;
			s[k] = make(g, x, NULL, &p);
			for (int q = 0; q < 16; q++) {
				if (cs == 1 && q == 4)
					ndo_sim_set(s[k], 3, nodes, NULL, vset);
				CHECK(ndo_sim_step(s[k], cs == 2 && q >= 6 ? 2 * h : h) == 0,
				      "case %d step %d: %s", cs, q, ndo_errdetail());
			}
		}
		ndo_sim_stats st;
		ndo_sim_stats_get(s[0], &st);
		/* the first step, and after a miss 7 without trying (AV_SKIP); a
		 * new step size rebuilds the hierarchy */
		const int64_t reused[3] = {15, 3 + 4, 5 + 9}, misses[3] = {0, 1, 0};
		CHECK(st.av_reused == reused[cs] && st.av_misses == misses[cs],
		      "case %d: A v reused %lld times (want %lld), found changed %lld (want %lld)", cs,
		      (long long)st.av_reused, (long long)reused[cs], (long long)st.av_misses,
		      (long long)misses[cs]);
		ndo_sim_get(s[0], NULL, va);
		ndo_sim_get(s[1], NULL, vb);
		double d = 0, big = 0;
		for (size_t q = 0; q < n; q++) {
			d = fmax(d, fabs(va[q] - vb[q]));
			big = fmax(big, fabs(vb[q]));
		}
		printf("    case %d: differs from CHOLMOD by %.3g of the largest velocity\n", cs, d / big);
		CHECK(d <= tol * big, "case %d: differs from CHOLMOD by %.3g of the largest velocity "
		      "(tolerance %.3g)", cs, d / big, tol);
		ndo_sim_destroy(s[0]), ndo_sim_destroy(s[1]);
	}
	free(va), free(vb), free(x);
	ndo_grid_destroy(g);
}

/* A peer's solver changing hands: a whole step on a region (what a peer
 * whose neighbour died takes alone) builds the multigrid for that region's
 * rows; a larger region's block solve (ndo_sim_implicit_precondition) then
 * needs CHOLMOD's rows and analysis.  It wrote the new rows past the
 * multigrid's arrays (ASan: heap-buffer-overflow in assemble), and on the
 * same region factored without an analysis.  The block solve must equal a
 * fresh simulation's, bit for bit. */
static void block_solve_after_a_multigrid_step(void)
{
	double *x;
	ndo_sim_params p;
	ndo_grid *g = damped_wavy(&x, &p);
	p.solver = NDO_SOLVER_MULTIGRID;
	const size_t n = 3 * g->count;
	uint8_t *small = calloc(g->count, 1), *large = calloc(g->count, 1);
	double *r = malloc(n * sizeof *r), *z[2] = {calloc(n, sizeof(double)), calloc(n, sizeof(double))};
	for (size_t q = 0; q < g->count; q++) {
		small[q] = (int)(q / (size_t)g->w) < g->h / 4;
		large[q] = (int)(q / (size_t)g->w) < 3 * g->h / 4;
	}
	for (size_t q = 0; q < n; q++)
		r[q] = uniform();
	for (int m = 0; m < 4; m++) { /* the step on the smaller region, then on the same */
		p.method = m & 1 ? NDO_TRAPEZOID : NDO_BACKWARD_EULER;
		const double h = 0.01;
		ndo_sim *s[2];
		for (int k = 0; k < 2; k++) {
			s[k] = make(g, x, NULL, &p);
			if (k == 0) {
				CHECK(ndo_sim_set_active(s[k], m < 2 ? small : large) == 0, "active: %s",
				      ndo_errdetail());
				CHECK(ndo_sim_step(s[k], h) == 0, "%s: the region's step: %s",
				      ndo_method_names[p.method], ndo_errdetail());
			}
			if (k == 1 || m < 2)
				CHECK(ndo_sim_set_active(s[k], large) == 0, "active: %s", ndo_errdetail());
			CHECK(ndo_sim_implicit_precondition(s[k], h, r, z[k]) == 0, "%s: block solve: %s",
			      ndo_method_names[p.method], ndo_errdetail());
		}
		CHECK(memcmp(z[0], z[1], n * sizeof *z[0]) == 0, "%s: the block solve after a "
		      "multigrid step on %s region differs from a fresh one's",
		      ndo_method_names[p.method], m < 2 ? "a smaller" : "the same");
		ndo_sim_destroy(s[0]), ndo_sim_destroy(s[1]);
	}
	free(small), free(large), free(r), free(z[0]), free(z[1]), free(x);
	ndo_grid_destroy(g);
}

/* The rigid modes and the extremes: a stiff membrane (σ = 1e12) at a 1 s
 * step still solves (to the rounding floor of A x) and keeps the centre
 * of mass where CHOLMOD does. */
static void stiff_membrane_solves(void)
{
	ndo_grid *g = shape("wavy", 6);
	double *x = displaced(g, 0.01);
	ndo_sim_params p;
	ndo_sim_defaults(&p);
	p.method = NDO_TRAPEZOID;
	p.material.stiffness = 1e12;
	ndo_sim *s[2];
	for (int k = 0; k < 2; k++) {
		p.solver = k ? NDO_SOLVER_CHOLMOD : NDO_SOLVER_MULTIGRID;
		s[k] = make(g, x, NULL, &p);
		for (int q = 0; q < 5; q++)
			CHECK(ndo_sim_step(s[k], 1.0) == 0, "σ = 1e12, h = 1 s, %s: %s",
			      k ? "cholmod" : "multigrid", ndo_errdetail());
	}
	size_t n = g->count;
	double *xa = malloc(3 * n * sizeof *xa), *xb = malloc(3 * n * sizeof *xb);
	ndo_sim_get(s[0], xa, NULL);
	ndo_sim_get(s[1], xb, NULL);
	double ca[3] = {0, 0, 0}, cb[3] = {0, 0, 0}, d = 0;
	for (size_t q = 0; q < n; q++)
		for (int c = 0; c < 3; c++) {
			ca[c] += xa[3 * q + c] / (double)n, cb[c] += xb[3 * q + c] / (double)n;
			d = fmax(d, fabs(xa[3 * q + c] - xb[3 * q + c]));
		}
	CHECK(d < 1e-6, "σ = 1e12: positions differ from CHOLMOD's by %g m", d);
	for (int c = 0; c < 3; c++)
		CHECK_NEAR(ca[c], cb[c], 1e-9, "σ = 1e12: the centre of the stored nodes");
	free(xa), free(xb), free(x);
	ndo_sim_destroy(s[0]), ndo_sim_destroy(s[1]);
	ndo_grid_destroy(g);
}

/* Chunks fixed by the rows, sums added in chunk order: 1, 2 and 3 threads
 * give the same bits (level 7: the smallest grid that gets threads). */
static void threads_give_the_same_bits(void)
{
	ndo_grid *g = shape("wavy", 7);
	double *x = displaced(g, 0.01);
	size_t n = 3 * g->count;
	ndo_sim_params p0;
	ndo_sim_defaults(&p0);
	ndo_sim *probe = make(g, x, NULL, &p0);
	ndo_critical c;
	ndo_sim_critical(probe, &c);
	ndo_sim_destroy(probe);
	/* h = 0.05 s: the V-cycle; half RK4's limit: no hierarchy, Jacobi's
	 * fused passes (both methods) */
	const struct {
		ndo_method m;
		double h;
		int hier;
	} cs[] = {{NDO_BACKWARD_EULER, 0.05, 1},
	          {NDO_BACKWARD_EULER, 0.5 * c.h_crit, 0},
	          {NDO_TRAPEZOID, 0.5 * c.h_crit, 0}};
	for (size_t k = 0; k < sizeof cs / sizeof cs[0]; k++) {
		double *out[3];
		for (int t = 1; t <= 3; t++) {
			ndo_sim_params p;
			ndo_sim_defaults(&p);
			p.method = cs[k].m;
			p.solver = NDO_SOLVER_MULTIGRID;
			p.threads = t;
			ndo_sim *s = make(g, x, NULL, &p);
			for (int q = 0; q < 3; q++)
				CHECK(ndo_sim_step(s, cs[k].h) == 0, "%d threads: %s", t, ndo_errdetail());
			out[t - 1] = malloc(n * sizeof(double));
			ndo_sim_get(s, NULL, out[t - 1]);
			int levels;
			ndo_sim_solver_info(s, &levels, NULL);
			CHECK((levels > 1) == cs[k].hier, "%s h = %.3g s at level 7: %d levels",
			      ndo_method_names[cs[k].m], cs[k].h, levels);
			ndo_sim_destroy(s);
		}
		CHECK(memcmp(out[0], out[1], n * sizeof(double)) == 0, "%s h = %.3g s: 1 and 2 "
		      "threads differ", ndo_method_names[cs[k].m], cs[k].h);
		CHECK(memcmp(out[0], out[2], n * sizeof(double)) == 0, "%s h = %.3g s: 1 and 3 "
		      "threads differ", ndo_method_names[cs[k].m], cs[k].h);
		for (int t = 0; t < 3; t++)
			free(out[t]);
	}
	free(x);
	ndo_grid_destroy(g);
}

/* A fixed step at levels 5–8 (the stiffness relative to the mass grows 4×
 * a level, so Jacobi's iterations would double a level): the V-cycle's
 * grow by a few at most (measured 7, 10, 11, 13 from a rough start; the
 * finest levels' counts level off, docs/bench/multigrid.md). */
static void iterations_do_not_grow_with_the_level(void)
{
	int prev = 0;
	for (int level = 5; level <= 8; level++) {
		ndo_grid *g = shape("wavy", level);
		double *x = displaced(g, 0.001);
		ndo_sim_params p;
		ndo_sim_defaults(&p);
		p.method = NDO_BACKWARD_EULER;
		p.solver = NDO_SOLVER_MULTIGRID;
		ndo_sim *s = make(g, x, NULL, &p);
		for (int q = 0; q < 4; q++)
			CHECK(ndo_sim_step(s, 0.1) == 0, "level %d: %s", level, ndo_errdetail());
		ndo_sim_stats st;
		ndo_sim_stats_get(s, &st);
		int it = (int)((st.iterations + st.solves - 1) / st.solves);
		CHECK(level == 5 || it <= prev + 3, "level %d: %d iterations per solve after %d one "
		      "level coarser", level, it, prev);
		prev = it;
		printf("    level %d, h = 0.1 s: %d iterations per solve\n", level, it);
		CHECK(it <= 15, "level %d, h = 0.1 s: %d iterations per solve", level, it);
		ndo_sim_destroy(s);
		free(x);
		ndo_grid_destroy(g);
	}
}

/* The estimate covers the hierarchy, and a limit below it refuses the run
 * before anything is allocated; CHOLMOD's estimate has no hierarchy. */
static void memory_estimate_includes_the_hierarchy(void)
{
	ndo_sim_params p;
	ndo_sim_defaults(&p);
	p.method = NDO_BACKWARD_EULER;
	p.solver = NDO_SOLVER_CHOLMOD;
	size_t chol = ndo_sim_memory(8, &p);
	p.solver = NDO_SOLVER_MULTIGRID;
	size_t mg = ndo_sim_memory(8, &p);
	CHECK(mg > chol + 131074 * 300, "the multigrid estimate %zu adds its hierarchy to %zu", mg,
	      chol);
	p.solver = NDO_SOLVER_AUTO;
	CHECK(ndo_sim_memory(8, &p) == mg && ndo_sim_memory(4, &p) < mg / 16,
	      "auto: multigrid at level 8, CHOLMOD at level 4");
	ndo_grid *g = shape("wavy", 6);
	p.solver = NDO_SOLVER_MULTIGRID;
	p.max_memory = ndo_sim_memory(6, &p) - 1;
	ndo_sim *s = NULL;
	CHECK(ndo_sim_create(6, g->ch[0].data, NULL, NULL, NULL, &p, &s) == NDO_ENOMEM && !s,
	      "a limit one byte below the estimate is refused");
	CHECK(strstr(ndo_errdetail(), "needs about"), "the refusal states the estimate: %s",
	      ndo_errdetail());
	ndo_grid_destroy(g);
}

static void solver_names_parse(void)
{
	ndo_solver sv;
	CHECK(ndo_solver_parse("multigrid", &sv) == 0 && sv == NDO_SOLVER_MULTIGRID, "multigrid");
	CHECK(ndo_solver_parse("cholmod", &sv) == 0 && sv == NDO_SOLVER_CHOLMOD, "cholmod");
	CHECK(ndo_solver_parse("auto", &sv) == 0 && sv == NDO_SOLVER_AUTO, "auto");
	CHECK(ndo_solver_parse("lu", &sv) == NDO_ENOTFOUND, "an unknown name is refused");
	CHECK(ndo_solver_at(NDO_SOLVER_AUTO, NDO_MULTIGRID_MIN_LEVEL) == NDO_SOLVER_MULTIGRID &&
	      ndo_solver_at(NDO_SOLVER_AUTO, NDO_MULTIGRID_MIN_LEVEL - 1) == NDO_SOLVER_CHOLMOD,
	      "auto switches at level %d", NDO_MULTIGRID_MIN_LEVEL);
}

/* The operator's regular rows, read without indices (multigrid.c,
 * mg_stencil) with one vector load a neighbour, against the plain CSR
 * product, their reference: the same bits.  A raster of W × H rows with
 * the 7-point stencil (right, up, up-left and their transposes), random
 * symmetric values, and edges left out around a few rows (as held
 * neighbours leave them out) besides the border: regular and irregular
 * rows both. */
enum { W = 40, H = 30, N = W * H };

/* That raster's operator, both triangles: diagonal mass[r] + extra + the
 * off-diagonal sum (an M-matrix); T and mass (N, 100 ± 1: with extra = 0
 * the mass dominates) are the caller's to free. */
static cholmod_sparse *raster(double extra, int use_mass, double *mass, cholmod_triplet **Tout,
                              cholmod_common *cm)
{
	cholmod_triplet *T = cholmod_allocate_triplet(N, N, 7 * N, 0, CHOLMOD_REAL, cm);
	int *Ti = T->i, *Tj = T->j;
	double *Tx = T->x, diag[N];
	size_t nz = 0;
	for (int r = 0; r < N; r++)
		mass[r] = 100 + uniform(), diag[r] = (use_mass ? mass[r] : 0) + extra;
	for (int r = 0; r < N; r++) {
		int i = r % W, j = r / W;
		const int di[3] = {1, 0, -1}, dj[3] = {0, 1, 1};
		for (int k = 0; k < 3; k++) {
			int i2 = i + di[k], j2 = j + dj[k], c = j2 * W + i2;
			if (i2 < 0 || i2 >= W || j2 >= H || (i * 7 + j * 3) % 23 == 0 ||
			    (i2 * 7 + j2 * 3) % 23 == 0)
				continue;
			double v = -0.5 - 0.4 * uniform();
			Ti[nz] = r, Tj[nz] = c, Tx[nz++] = v;
			Ti[nz] = c, Tj[nz] = r, Tx[nz++] = v;
			diag[r] -= v, diag[c] -= v;
		}
	}
	for (int r = 0; r < N; r++)
		Ti[nz] = r, Tj[nz] = r, Tx[nz++] = diag[r];
	T->nnz = nz;
	*Tout = T;
	return cholmod_triplet_to_sparse(T, nz, cm);
}

/* CHOLMOD's workspace, the raster's mass (N) and its rows' nodes (N,
 * r → r), for the tests below (theirs to free). */
static void raster_start(cholmod_common *cm, double **mass, int32_t **nodes)
{
	cholmod_start(cm);
	cm->print = 0;
	*mass = malloc(N * sizeof **mass);
	*nodes = malloc(N * sizeof **nodes);
	for (int r = 0; r < N; r++)
		(*nodes)[r] = r;
}

static void stencil_rows_equal_csr(void)
{
	cholmod_common cm;
	double *mass;
	int32_t *nodes;
	raster_start(&cm, &mass, &nodes);
	cholmod_triplet *T;
	cholmod_sparse *A = raster(0, 1, mass, &T, &cm);
	ndo__mg *mg = NULL;
	int rc = ndo__mg_create(6, nodes, N, A, mass, &cm, NULL, &mg);
	CHECK(rc == NDO_OK && mg, "the hierarchy of a %d-row raster: %s", N, ndo_errdetail());
	if (mg) {
		double *x = malloc((3 * N + 1) * sizeof *x), *y = malloc(3 * N * sizeof *y);
		for (int q = 0; q < 3 * N; q++)
			x[q] = uniform();
		x[3 * N] = 0;
		ndo__mg_apply(mg, x, y);
		const int *Ap = A->p, *Ai = A->i;
		const double *Ax = A->x;
		int differ = 0, seven = 0;
		for (int r = 0; r < N; r++) {
			double ref[3] = {0, 0, 0};
			for (int k = Ap[r]; k < Ap[r + 1]; k++)
				for (int c = 0; c < 3; c++)
					ref[c] += Ax[k] * x[3 * Ai[k] + c];
			differ += memcmp(ref, y + 3 * r, sizeof ref) != 0;
			seven += Ap[r + 1] - Ap[r] == 7;
		}
		printf("    %d rows, %d of them 7-point; %d differ from CSR\n", N, seven, differ);
		CHECK(seven > N / 2 && seven < N, "regular and irregular rows both (%d of %d)", seven, N);
		CHECK(differ == 0, "%d rows of the product differ from CSR's", differ);
		free(x), free(y);
		ndo__mg_free(mg);
	}
	cholmod_free_sparse(&A, &cm);
	cholmod_free_triplet(&T, &cm);
	cholmod_finish(&cm);
	free(mass), free(nodes);
}

/* Without a hierarchy (the mass part of the diagonal dominates: no
 * V-cycle), CG preconditioned by the diagonal alone on two systems: mass
 * 100 ± 1 beside off-diagonal sums of at most 5.4 (the benchmark's
 * regime, κ ≈ 1.1), and a diagonal of 0.2 + the off-diagonal sums with
 * the mass part given as 100 (κ up to 55): both reach the tolerance (the
 * true residual, computed here from CSR) and CHOLMOD's solution, the slow
 * reference, within κ × the tolerance. */
static void jacobi_solves_equal_cholmods(void)
{
	cholmod_common cm;
	double *mass;
	int32_t *nodes;
	raster_start(&cm, &mass, &nodes);
	const struct {
		double extra;
		int use_mass;
		const char *name;
	} cs[] = {{0, 1, "mass-dominated"}, {0.2, 0, "weakly dominant"}};
	for (size_t k = 0; k < sizeof cs / sizeof cs[0]; k++) {
		cholmod_triplet *T;
		cholmod_sparse *A = raster(cs[k].extra, cs[k].use_mass, mass, &T, &cm);
		ndo__mg *mg = NULL;
		const char *pc = cs[k].name;
		CHECK(ndo__mg_create(6, nodes, N, A, mass, &cm, NULL, &mg) == NDO_OK && mg, "%s: %s",
		      pc, ndo_errdetail());
		if (!mg)
			continue;
		int levels, direct;
		levels = ndo__mg_levels(mg, &direct);
		CHECK(levels == 1 && !direct, "%s: Jacobi alone (%d levels%s)", pc, levels,
		      direct ? ", factored" : "");
		double *b = malloc(3 * N * sizeof *b), *x = calloc(3 * N + 1, sizeof *x);
		for (int q = 0; q < 3 * N; q++)
			b[q] = uniform();
		int it = 0;
		double res = 1;
		CHECK(ndo__mg_solve(mg, b, x, 1e-12, 1e-10, 500, &it, &res) == NDO_OK, "%s: %s", pc,
		      ndo_errdetail());
		/* the true residual, from CSR */
		const int *Ap = A->p, *Ai = A->i;
		const double *Ax = A->x;
		double rr[3] = {0, 0, 0}, bb[3] = {0, 0, 0};
		for (int r = 0; r < N; r++)
			for (int c = 0; c < 3; c++) {
				double y = 0;
				for (int q = Ap[r]; q < Ap[r + 1]; q++)
					y += Ax[q] * x[3 * Ai[q] + c];
				rr[c] += (b[3 * r + c] - y) * (b[3 * r + c] - y);
				bb[c] += b[3 * r + c] * b[3 * r + c];
			}
		double worst = 0;
		for (int c = 0; c < 3; c++)
			worst = fmax(worst, sqrt(rr[c] / bb[c]));
		printf("    %s: %d iterations, relative residual %.3g (reported %.3g)\n", pc, it, worst,
		       res);
		CHECK(worst <= 1e-11, "%s: true relative residual %.3g", pc, worst);
		/* CHOLMOD's solution */
		cholmod_sparse *U = cholmod_copy(A, 1, 1, &cm);
		cholmod_factor *L = cholmod_analyze(U, &cm);
		cholmod_factorize(U, L, &cm);
		cholmod_dense *B = cholmod_allocate_dense(N, 3, N, CHOLMOD_REAL, &cm);
		double *bx = B->x;
		for (int r = 0; r < N; r++)
			for (int c = 0; c < 3; c++)
				bx[c * N + r] = b[3 * r + c];
		cholmod_dense *X = cholmod_solve(CHOLMOD_A, L, B, &cm);
		const double *xx = X->x;
		double d = 0, xn = 0;
		for (int r = 0; r < N; r++)
			for (int c = 0; c < 3; c++) {
				d = fmax(d, fabs(x[3 * r + c] - xx[c * N + r]));
				xn += xx[c * N + r] * xx[c * N + r];
			}
		/* ‖e‖ ≤ κ(A) · relative residual · ‖x‖ (2-norms, per column; the
		 * largest |e| is below each), κ(A) ≤ Gershgorin's (diag + 2 × 5.4) /
		 * diag: 1.11 and 55 */
		const double kappa = cs[k].use_mass ? 1.11 : 55;
		CHECK(d <= kappa * 1e-11 * sqrt(xn), "%s: differs from CHOLMOD's solution by %.3g "
		      "(bound %.3g)", pc, d, kappa * 1e-11 * sqrt(xn));
		printf("    %s: differs from CHOLMOD's by %.3g (bound %.3g)\n", pc, d,
		       kappa * 1e-11 * sqrt(xn));
		cholmod_free_dense(&X, &cm), cholmod_free_dense(&B, &cm);
		cholmod_free_factor(&L, &cm), cholmod_free_sparse(&U, &cm);
		free(b), free(x);
		ndo__mg_free(mg);
		cholmod_free_sparse(&A, &cm);
		cholmod_free_triplet(&T, &cm);
	}
	cholmod_finish(&cm);
	free(mass), free(nodes);
}

int main(void)
{
	ck_program = "test_multigrid";
	RUN(solver_names_parse);
	RUN(stencil_rows_equal_csr);
	RUN(jacobi_solves_equal_cholmods);
	RUN(steps_equal_cholmods);
	RUN(trapezoid_reuses_a_v);
	RUN(block_solve_after_a_multigrid_step);
	RUN(stiff_membrane_solves);
	RUN(threads_give_the_same_bits);
	RUN(iterations_do_not_grow_with_the_level);
	RUN(memory_estimate_includes_the_hierarchy);
	return ck_failed_cases != 0;
}
