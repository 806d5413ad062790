/* bench_study — the studies behind docs/simulate-peer.md: what each
 * integrator and level costs and buys.  Each mode prints CSV on stdout.
 *
 *   stability LEVEL   the divergence step against the stiffness k, measured
 *                     (the protocol below) and predicted, every explicit
 *                     method (thesis figure 5.2)
 *   accuracy LEVEL    error against CPU time of every method on the thesis
 *                     scene (work-precision)
 *   levels FINE L...  simulate at level L, subdivide to FINE, compare with
 *                     simulating at FINE
 *   restiffen LEVEL   the cost and the effect of re-assembling K every S steps
 *   penalty LEVEL     the stable step and the pins' drift against α
 *
 * The thesis scene (figure 5.3): the wavy surface, k = 1 N/m, b = 0.1, a
 * 2.4 N force at 1 Hz along the normals of the faces within 0.2 m of
 * (0, 0, 1), simulated for 1 s. */
#include "ndo/ndo.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static double cpu(void)
{
	struct timespec t;
	clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
	return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static void die(const char *what)
{
	fprintf(stderr, "bench_study: %s: %s\n", what, ndo_errdetail());
	exit(1);
}

typedef struct scene {
	ndo_grid *g;
	ndo_sim_params p;
	ndo_force *forces;
	int nforces;
	uint8_t *pin;
} scene;

/* A shape at a level with the settings in `lines` (scene-file syntax,
 * ';'-separated). */
static scene make_scene(const char *shape, int level, const char *lines)
{
	scene s;
	if (ndo_shape_make(shape, level, NULL, &s.g))
		die(shape);
	ndo_scene sc;
	ndo_scene_init(&sc);
	char *copy = strdup(lines), *save = NULL;
	for (char *l = strtok_r(copy, ";", &save); l; l = strtok_r(NULL, ";", &save)) {
		while (*l == ' ')
			l++;
		char *sp = strchr(l, ' ');
		*sp = '\0';
		if (ndo_scene_set(&sc, l, sp + 1))
			die(l);
	}
	free(copy);
	s.pin = calloc(s.g->count, 1);
	if (ndo_scene_resolve(&sc, level, s.g->ch[0].data, &s.forces, s.pin))
		die("resolve");
	s.p = sc.sim;
	s.p.forces = s.forces;
	s.p.nforces = s.nforces = sc.nforces;
	ndo_scene_free(&sc);
	return s;
}

static void free_scene(scene *s)
{
	ndo_scene_forces_free(s->forces, s->nforces);
	free(s->pin);
	ndo_grid_destroy(s->g);
}

static ndo_sim *start(scene *s, const double *x)
{
	ndo_sim *sim;
	if (ndo_sim_create(s->g->level, x ? x : s->g->ch[0].data, NULL, s->g->ch[0].data, s->pin,
	                   &s->p, &sim))
		die("create");
	return sim;
}

#define THESIS "stiffness 1;damping 0.1;force face at=0,0,1 radius=0.2 amplitude=2.4 frequency=1"

/* ---- stability ------------------------------------------------------------ */

/* The protocol (also test_sim.c): a seeded random displacement of 1e-6 m
 * per coordinate; divergence as ndo_sim_step reports it with the energy
 * bound at 1e6 (the amplitude × 1000); N = 20 / ln ρ(1.05 h_pred) steps,
 * at least 1000 and at most 2·10⁶, so that 5% above the prediction the top
 * mode grows by e²⁰; bisection between 0.5 and 2 × the prediction to 0.3%. */
static int diverges(scene *s, const double *x0, double h, long n)
{
	ndo_sim *sim = start(s, x0);
	int bad = 0;
	for (long k = 0; k < n && !bad; k++)
		bad = ndo_sim_step(sim, h) == NDO_EDIVERGED;
	bad |= ndo_sim_check(sim) == NDO_EDIVERGED;
	ndo_sim_destroy(sim);
	return bad;
}

static void stability(int level)
{
	const ndo_method ms[] = {NDO_EULER, NDO_SYMPLECTIC_EULER, NDO_MIDPOINT, NDO_RK4, NDO_RKF45};
	const double ks[] = {0.01, 0.03, 0.1, 0.3, 1, 3, 10};
	printf("method,k,predicted,measured,steps,bound\n");
	for (int mi = 0; mi < 5; mi++)
		for (int ki = 0; ki < 7; ki++) {
			char set[256];
			/* Damping 1 N s/m³ (γ = 1/s): light for the stiff end, heavy
			 * enough that the damping-bound methods diverge within 2·10⁶
			 * steps when 5% over their limit. */
			snprintf(set, sizeof set, "stiffness %g;damping 1;energy-bound 1e6", ks[ki]);
			scene s = make_scene("wavy", level, set);
			s.p.method = ms[mi];
			s.p.tol = 0.99; /* rkf45: no error control, the formula's own stability */
			size_t nn = 3 * s.g->count;
			double *x0 = malloc(nn * sizeof *x0);
			memcpy(x0, s.g->ch[0].data, nn * sizeof *x0);
			uint64_t z = 7;
			for (size_t q = 0; q < nn; q++) {
				z = z * 6364136223846793005ULL + 1442695040888963407ULL;
				x0[q] += 1e-6 * ((double)(z >> 11) / 9007199254740992.0 * 2 - 1);
			}
			ndo_sync(level, x0, 3 * sizeof *x0);
			ndo_sim *sim = start(&s, x0);
			ndo_critical c;
			ndo_sim_critical(sim, &c);
			ndo_sim_destroy(sim);
			double rho = ndo_amplification(ms[mi], c.omega_max, c.gamma, 1.05 * c.h_crit);
			double nf = fmin(2e6, fmax(1000, ceil(20 / log(rho))));
			long n = (long)nf;
			double lo = 0.5 * c.h_crit, hi = 2 * c.h_crit;
			if (diverges(&s, x0, lo, n))
				hi = lo, lo = 0;
			else if (!diverges(&s, x0, hi, n))
				lo = hi, hi = INFINITY;
			while (isfinite(hi) && hi - lo > 0.003 * c.h_crit) {
				double mid = 0.5 * (lo + hi);
				if (diverges(&s, x0, mid, n))
					hi = mid;
				else
					lo = mid;
			}
			printf("%s,%g,%.6g,%.6g,%ld,%d\n", ndo_method_names[ms[mi]], ks[ki], c.h_crit, hi, n,
			       c.bound);
			fflush(stdout);
			free(x0);
			free_scene(&s);
		}
}

/* ---- work-precision -------------------------------------------------------- */

/* Run to T and return the CPU seconds; the final positions in x. */
static double run_to(scene *s, double h, int steps, double *x)
{
	ndo_sim *sim = start(s, NULL);
	double t0 = cpu();
	for (int k = 0; k < steps; k++)
		if (ndo_sim_step(sim, h)) {
			ndo_sim_destroy(sim);
			return NAN;
		}
	double t = cpu() - t0;
	ndo_sim_get(sim, x, NULL);
	ndo_sim_destroy(sim);
	return t;
}

static void accuracy(int level)
{
	const double T = 1;
	scene s = make_scene("wavy", level, THESIS);
	size_t nn = 3 * s.g->count;
	double *ref = malloc(nn * sizeof *ref), *x = malloc(nn * sizeof *x);
	/* The reference: rkf45 at a tolerance of 1e-11. */
	s.p.method = NDO_RKF45;
	s.p.tol = 1e-11;
	run_to(&s, T / 50, 50, ref);
	double umax = 0;
	const double *X = s.g->ch[0].data;
	for (size_t q = 0; q < nn; q += 3)
		umax = fmax(umax, sqrt(pow(ref[q] - X[q], 2) + pow(ref[q + 1] - X[q + 1], 2) +
		                       pow(ref[q + 2] - X[q + 2], 2)));
	printf("method,level,step,tol,cpu_s,error_m,relative\n");
	ndo_sim *probe;
	s.p.method = NDO_RK4;
	probe = start(&s, NULL);
	ndo_critical crk4;
	ndo_sim_critical(probe, &crk4);
	ndo_sim_destroy(probe);
	for (int m = 0; m < NDO_METHOD_COUNT; m++) {
		s.p.method = (ndo_method)m;
		s.p.tol = 1e-6;
		probe = start(&s, NULL);
		ndo_critical c;
		ndo_sim_critical(probe, &c);
		ndo_sim_destroy(probe);
		int runs = m == NDO_RKF45 ? 7 : 6;
		for (int r = 0; r < runs; r++) {
			double h, tol = 0;
			if (m == NDO_RKF45) {
				tol = pow(10, -3 - r);
				s.p.tol = tol;
				h = T / 20; /* output interval: the controller picks its steps */
			} else if (ndo_method_is_implicit((ndo_method)m)) {
				h = 0.1 / pow(2, r);
			} else {
				h = 0.9 * c.h_crit / pow(2, r);
			}
			int steps = (int)ceil(T / h - 1e-9);
			/* A budget of 2·10⁹ node-steps per run: forward Euler needs
			 * 700,000 steps per second at level 7 (h ≤ γ/ω²). */
			if ((double)steps * (double)ndo_vertex_count(level) > 2e9)
				continue;
			h = T / steps;
			double t = run_to(&s, h, steps, x);
			double e = 0;
			for (size_t q = 0; q < nn; q += 3)
				e = fmax(e, sqrt(pow(x[q] - ref[q], 2) + pow(x[q + 1] - ref[q + 1], 2) +
				                 pow(x[q + 2] - ref[q + 2], 2)));
			printf("%s,%d,%.6g,%.3g,%.6g,%.6g,%.6g\n", ndo_method_names[m], level, h, tol, t, e,
			       e / umax);
			fflush(stdout);
		}
	}
	(void)crk4;
	free(ref), free(x);
	free_scene(&s);
}

/* ---- coarse and fine -------------------------------------------------------- */

/* Simulate the thesis scene at `level` with RK4 at half its critical step
 * for 1 s; the result as a grid with "position" and "disp" (x − X). */
static ndo_grid *simulate_level(int level, double *cpu_s)
{
	scene s = make_scene("wavy", level, THESIS);
	s.p.method = NDO_RK4;
	ndo_sim *sim = start(&s, NULL);
	ndo_critical c;
	ndo_sim_critical(sim, &c);
	int steps = (int)ceil(1.0 / (0.5 * c.h_crit));
	double t0 = cpu();
	for (int k = 0; k < steps; k++)
		if (ndo_sim_step(sim, 1.0 / steps))
			die("simulate");
	*cpu_s = cpu() - t0;
	ndo_grid *g;
	ndo_channel *d;
	ndo_grid_copy(s.g, &g);
	ndo_sim_get(sim, g->ch[0].data, NULL);
	ndo_grid_add(g, "disp", NDO_F64, 3, &d);
	double *x = ndo_grid_find(g, NDO_CH_POSITION)->data, *u = ndo_grid_find(g, "disp")->data;
	const double *X = s.g->ch[0].data;
	for (size_t q = 0; q < 3 * g->count; q++)
		u[q] = x[q] - X[q];
	ndo_sim_destroy(sim);
	free_scene(&s);
	return g;
}

static void levels(int fine, int argc, char **argv)
{
	double tf;
	ndo_grid *ref = simulate_level(fine, &tf);
	const double *rx = ndo_grid_find(ref, NDO_CH_POSITION)->data,
	             *ru = ndo_grid_find(ref, "disp")->data;
	double umax = 0;
	for (size_t q = 0; q < 3 * ref->count; q += 3)
		umax = fmax(umax, sqrt(ru[q] * ru[q] + ru[q + 1] * ru[q + 1] + ru[q + 2] * ru[q + 2]));
	printf("level,vertices,cpu_s,position_max_m,position_rms_m,displacement_max_m,"
	       "displacement_rms_m,relative_displacement_max\n");
	printf("%d,%zu,%.6g,0,0,0,0,0\n", fine, ndo_vertex_count(fine), tf);
	for (int a = 0; a < argc; a++) {
		int level = atoi(argv[a]);
		double t;
		ndo_grid *g = simulate_level(level, &t), *up;
		if (ndo_subdivide_levels(g, fine - level, NDO_CORNERS_ZORIN, &up))
			die("subdivide");
		const double *x = ndo_grid_find(up, NDO_CH_POSITION)->data,
		             *u = ndo_grid_find(up, "disp")->data;
		double pm = 0, ps = 0, dm = 0, ds = 0;
		for (size_t q = 0; q < 3 * up->count; q += 3) {
			double p2 = 0, d2 = 0;
			for (int c = 0; c < 3; c++) {
				p2 += pow(x[q + c] - rx[q + c], 2);
				d2 += pow(u[q + c] - ru[q + c], 2);
			}
			pm = fmax(pm, sqrt(p2));
			dm = fmax(dm, sqrt(d2));
			ps += p2;
			ds += d2;
		}
		printf("%d,%zu,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g\n", level, ndo_vertex_count(level), t, pm,
		       sqrt(ps / (double)up->count), dm, sqrt(ds / (double)up->count), dm / umax);
		fflush(stdout);
		ndo_grid_destroy(g);
		ndo_grid_destroy(up);
	}
	ndo_grid_destroy(ref);
}

/* ---- restiffening ----------------------------------------------------------- */

static void restiffen(int level)
{
	const int every[] = {0, 100, 10, 1};
	scene s = make_scene("wavy", level, THESIS);
	s.p.method = NDO_RK4;
	ndo_sim *sim = start(&s, NULL);
	ndo_critical c0;
	ndo_sim_critical(sim, &c0);
	ndo_sim_destroy(sim);
	int steps = (int)ceil(2.0 / (0.5 * c0.h_crit));
	double h = 2.0 / steps;
	size_t nn = 3 * s.g->count;
	double *x0 = malloc(nn * sizeof *x0), *x = malloc(nn * sizeof *x);
	printf("every,steps,cpu_s,cpu_per_step_s,restiffen_s,max_disp_m,diff_from_never_m,"
	       "lambda_max_end\n");
	for (int k = 0; k < 4; k++) {
		s.p.restiffen = every[k];
		sim = start(&s, NULL);
		double t0 = cpu();
		for (int q = 0; q < steps; q++)
			if (ndo_sim_step(sim, h))
				die("restiffen run");
		double t = cpu() - t0;
		ndo_sim_get(sim, k ? x : x0, NULL);
		ndo_sim_stats st;
		ndo_sim_stats_get(sim, &st);
		ndo_sim_energy e;
		ndo_sim_energy_get(sim, &e);
		ndo_critical c;
		ndo_sim_critical(sim, &c);
		double d = 0;
		if (k)
			for (size_t q = 0; q < nn; q += 3)
				d = fmax(d, sqrt(pow(x[q] - x0[q], 2) + pow(x[q + 1] - x0[q + 1], 2) +
				                 pow(x[q + 2] - x0[q + 2], 2)));
		printf("%d,%d,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g\n", every[k], steps, t, t / steps,
		       st.restiffen_seconds, e.max_displacement, d, c.lambda_max);
		fflush(stdout);
		ndo_sim_destroy(sim);
	}
	free(x0), free(x);
	free_scene(&s);
}

/* ---- penalty pins -------------------------------------------------------------- */

static void penalty(int level)
{
	printf("alpha,lambda_max,h_crit_rk4,pin_drift_m,max_disp_m\n");
	for (double alpha = 1; alpha <= 1e6; alpha *= 10) {
		char set[256];
		snprintf(set, sizeof set, THESIS ";pins penalty;penalty %g;pin at=0,0.45,0.89 radius=0.15",
		         alpha);
		scene s = make_scene("wavy", level, set);
		s.p.method = NDO_RK4;
		ndo_sim *sim = start(&s, NULL);
		ndo_critical c;
		ndo_sim_critical(sim, &c);
		int steps = (int)ceil(1.0 / (0.5 * c.h_crit));
		for (int q = 0; q < steps; q++)
			if (ndo_sim_step(sim, 1.0 / steps))
				die("penalty run");
		size_t nn = 3 * s.g->count;
		double *x = malloc(nn * sizeof *x), drift = 0;
		const double *X = s.g->ch[0].data;
		ndo_sim_get(sim, x, NULL);
		for (size_t p = 0; p < s.g->count; p++)
			if (s.pin[p])
				drift = fmax(drift, sqrt(pow(x[3 * p] - X[3 * p], 2) +
				                         pow(x[3 * p + 1] - X[3 * p + 1], 2) +
				                         pow(x[3 * p + 2] - X[3 * p + 2], 2)));
		ndo_sim_energy e;
		ndo_sim_energy_get(sim, &e);
		printf("%g,%.6g,%.6g,%.6g,%.6g\n", alpha, c.lambda_max, c.h_crit, drift,
		       e.max_displacement);
		fflush(stdout);
		free(x);
		ndo_sim_destroy(sim);
		free_scene(&s);
	}
}

int main(int argc, char **argv)
{
	if (argc >= 3 && strcmp(argv[1], "stability") == 0)
		stability(atoi(argv[2]));
	else if (argc >= 3 && strcmp(argv[1], "accuracy") == 0)
		accuracy(atoi(argv[2]));
	else if (argc >= 4 && strcmp(argv[1], "levels") == 0)
		levels(atoi(argv[2]), argc - 3, argv + 3);
	else if (argc >= 3 && strcmp(argv[1], "restiffen") == 0)
		restiffen(atoi(argv[2]));
	else if (argc >= 3 && strcmp(argv[1], "penalty") == 0)
		penalty(atoi(argv[2]));
	else {
		fprintf(stderr, "usage: bench_study stability|accuracy|restiffen|penalty LEVEL | "
		                "levels FINE LEVEL...\n");
		return 2;
	}
	return 0;
}
