/* bench_accuracy — simulate-peer's error estimates and --accuracy against
 * a fine reference (issue 18; docs/simulate-peer.md, "Asking for an
 * accuracy").  CSV on stdout.
 *
 * T: simulated seconds (0: the scene file's time).
 *
 *   estimates N T SCENE...  every scene at input level N, run as simulate-peer
 *                         runs it by default (rk4, and symplectic Euler, at
 *                         0.9 × the critical step): the estimated time and
 *                         space errors against the true ones
 *   choose N T SCENE...   for E = 1e-1, 1e-2, 1e-3: the configuration
 *                         ndo_acc_choose picks, its predicted and achieved
 *                         error and its cost, and the cheapest configuration
 *                         that meets E in an exhaustive sweep (levels 2..N,
 *                         rk4 and symplectic Euler at 0.9 × the critical step
 *                         and halvings)
 *
 *   cost N T SCENE...     the cost model's constants (ndo_acc_choose counts
 *                         work, it times nothing): each scene at levels
 *                         2..N, symplectic Euler and RK4 at 0.9 × the
 *                         critical step, CPU time per step (median of 3
 *                         trials of at least 20 ms each) against the
 *                         model's prediction (ndo_acc_work)
 *
 *   pilot N T SCENE...    what a pilot at the input level would tell of level
 *                         N − 1 (the cost misses' candidate), at t = T/8,
 *                         T/4, T/2, T: the true errors of levels N − 1 and N
 *                         (symplectic Euler at 0.9 × critical), the pilots'
 *                         prediction for level N − 1 (D/3 from levels N − 2
 *                         and N − 1) and its difference from a pilot at N
 *                         (RK4 at half its critical step), all relative to
 *                         the reference's largest displacement up to t
 *   predictors N T SCENE... the chooser's space-error measures against the
 *                         truth: the pilots (RK4 at half the critical step)
 *                         at levels 2..N; for every top pilot level and
 *                         every level up to it, the error against the top
 *                         pair's extrapolation u* over all of top's nodes
 *                         (ndo_acc_choose's) and over level top − 1's nodes
 *                         only (as a run's estimate measures its space
 *                         error), the pilot's true error, and the top
 *                         pair's differences both ways
 *   timeorder N T SCENE... the time error's convergence and growth: levels
 *                         N − 1 and N, RK4 and symplectic Euler at 0.9 × the
 *                         critical step and its halvings against RK4 at
 *                         0.05 ×, at T/8 and T, the order observed between a
 *                         step and its half, and the run's estimate (its two
 *                         parts on stderr); no reference run
 *   loads N T SCENE...    each face force selected at a point, at levels
 *                         2..N + 2: the faces it takes, their area and how
 *                         far their nodes reach from the point
 *
 * SCENE is NAME=INPUT:SCENEFILE[:REST], INPUT a shape name (remesh
 * --shape) or a .tgrid at level N + 2, REST a shape name for the rest shape
 * (the ellipsoid released to its sphere).  The reference: the scene at
 * level N + 2, RK4 at 0.2 × its critical step; the inputs at level N are
 * its restriction (every fourth node), so all levels are nested.  Errors:
 * the largest node distance at the end, at level N (coarser results
 * subdivided), relative to the reference's largest displacement over the
 * run.  True time error: against the same level at RK4, 0.1 × critical;
 * true space error: that run against the reference. */
#include "ndo/ndo.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static void die(const char *what)
{
	fprintf(stderr, "bench_accuracy: %s: %s\n", what, ndo_errdetail());
	exit(1);
}

static double cpu(void)
{
	struct timespec t;
	clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
	return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static double T_override; /* the T argument: simulated seconds */
static int no_reference;  /* cost: no reference run (setup) */

typedef struct bscene {
	char name[64];
	ndo_scene sc;
	double T;
	ndo_acc *fine;   /* level N + 2 */
	ndo_acc *in;     /* level N, restricted */
	double *ref;     /* reference displacement at level N */
	double umax;     /* the reference's largest displacement */
	int n;
} bscene;

static ndo_grid *load(const char *what, int level)
{
	ndo_grid *g;
	if (strstr(what, ".tgrid")) {
		g = ndo_cli_load(what);
		if (g->level != level) {
			fprintf(stderr, "bench_accuracy: %s is level %d, want %d\n", what, g->level, level);
			exit(1);
		}
		ndo_grid_f64(g, NDO_CH_POSITION, 3);
		return g;
	}
	if (ndo_shape_make(what, level, NULL, &g))
		die(what);
	return g;
}

static void setup(bscene *b, const char *spec, int n)
{
	char buf[1024];
	snprintf(buf, sizeof buf, "%s", spec);
	char *eq = strchr(buf, '='), *c1 = eq ? strchr(eq + 1, ':') : NULL;
	if (!eq || !c1) {
		fprintf(stderr, "bench_accuracy: bad scene '%s'\n", spec);
		exit(2);
	}
	*eq = *c1 = '\0';
	char *c2 = strchr(c1 + 1, ':');
	if (c2)
		*c2 = '\0';
	snprintf(b->name, sizeof b->name, "%.63s", buf);
	b->n = n;
	ndo_scene_init(&b->sc);
	if (ndo_scene_load(&b->sc, c1 + 1))
		die(c1 + 1);
	b->T = T_override > 0 ? T_override : b->sc.duration > 0 ? b->sc.duration : 1;
	int nf = n + 2;
	ndo_grid *g = load(eq + 1, nf), *rest = c2 ? load(c2 + 1, nf) : NULL;
	const double *X = rest ? rest->ch[0].data : g->ch[0].data;
	uint8_t *pin = calloc(g->count, 1);
	ndo_force *f;
	if (ndo_scene_resolve(&b->sc, nf, X, &f, pin))
		die("resolve");
	ndo_scene_forces_free(f, b->sc.nforces);
	if (ndo_acc_create(&b->sc, nf, g->ch[0].data, NULL, X, pin, 0, &b->fine))
		die("create");
	/* The level-N input: the fine one restricted twice. */
	double *x = malloc(3 * g->count * sizeof *x), *xr = malloc(3 * g->count * sizeof *xr);
	uint8_t *p1 = malloc(g->count), *p2 = malloc(g->count);
	ndo_restrict_nodes(nf, 3 * sizeof(double), g->ch[0].data, xr);
	ndo_restrict_nodes(nf - 1, 3 * sizeof(double), xr, x);
	ndo_restrict_nodes(nf, 1, pin, p1);
	ndo_restrict_nodes(nf - 1, 1, p1, p2);
	if (ndo_acc_create(&b->sc, n, x, NULL, ndo_acc_rest(b->fine, n), p2, 0, &b->in))
		die("create");
	free(x), free(xr), free(p1), free(p2), free(pin);
	ndo_grid_destroy(g);
	ndo_grid_destroy(rest);
	b->ref = NULL;
	b->umax = NAN;
	if (no_reference)
		return;
	/* The reference. */
	ndo_sim *s;
	ndo_critical cr;
	if (ndo_acc_sim(b->fine, nf, NDO_RK4, 0, &s) || ndo_sim_critical(s, &cr))
		die("reference");
	ndo_sim_destroy(s);
	ndo_acc_config c = {nf, NDO_RK4, 0, (int64_t)ceil(b->T / (0.2 * cr.h_crit)), 0};
	c.h = b->T / (double)c.steps;
	ndo_acc_result r;
	if (ndo_acc_run(b->fine, &c, &r))
		die("reference run");
	double *t1 = malloc(3 * sizeof(double) * (size_t)((2 << nf) + 1) * (size_t)((1 << nf) + 1));
	b->ref = malloc(3 * sizeof(double) * (size_t)((2 << n) + 1) * (size_t)((1 << n) + 1));
	ndo_restrict_nodes(nf, 3 * sizeof(double), r.u, t1);
	ndo_restrict_nodes(nf - 1, 3 * sizeof(double), t1, b->ref);
	b->umax = r.umax;
	fprintf(stderr, "bench_accuracy: %s: reference level %d, %lld rk4 steps, %.3g s CPU, largest "
	        "displacement %.4g m\n", b->name, nf, (long long)c.steps, r.cpu, r.umax);
	free(t1);
	ndo_acc_result_free(&r);
}

static void teardown(bscene *b)
{
	ndo_acc_destroy(b->in);
	ndo_acc_destroy(b->fine);
	free(b->ref);
	ndo_scene_free(&b->sc);
}

/* The true error of a level-m result, at level N. */
static double true_error(bscene *b, int m, const double *u)
{
	double *up;
	if (ndo_acc_prolong(m, b->n, u, &up))
		die("prolong");
	double e = ndo_acc_distance(b->n, up, b->ref);
	free(up);
	return e;
}

static ndo_acc_config at_fraction(ndo_acc *a, int level, ndo_method m, double frac, double T)
{
	ndo_sim *s;
	ndo_critical cr;
	if (ndo_acc_sim(a, level, m, 0, &s) || ndo_sim_critical(s, &cr))
		die("critical");
	ndo_sim_destroy(s);
	ndo_acc_config c = {level, m, 0, (int64_t)ceil(T / (frac * cr.h_crit) - 1e-9), 1e-6};
	if (c.steps < 1)
		c.steps = 1;
	c.h = T / (double)c.steps;
	return c;
}

static void estimates(int n, int argc, char **argv)
{
	printf("scene,level,method,step_s,largest_m,time_est,time_true,space_est,space_true,"
	       "total_est,total_true,time_ratio,space_ratio,total_ratio,run_cpu_s,estimate_cpu_s,rate\n");
	for (int k = 0; k < argc; k++) {
		bscene b;
		setup(&b, argv[k], n);
		ndo_acc_config fine_t = at_fraction(b.in, n, NDO_RK4, 0.1, b.T);
		ndo_acc_result rt;
		if (ndo_acc_run(b.in, &fine_t, &rt))
			die("time reference");
		const ndo_method ms[2] = {NDO_RK4, NDO_SYMPLECTIC_EULER};
		for (int q = 0; q < 2; q++) {
			ndo_acc_config c = at_fraction(b.in, n, ms[q], 0.9, b.T);
			ndo_acc_result r;
			ndo_acc_estimate e;
			if (ndo_acc_run(b.in, &c, &r) || ndo_acc_estimate_run(b.in, &c, r.u, r.umax, &e))
				die("run");
			double tt = ndo_acc_distance(n, r.u, rt.u), ts = ndo_acc_distance(n, rt.u, b.ref),
			       tot = ndo_acc_distance(n, r.u, b.ref), U = b.umax;
			double te = e.total_m;
			printf("%s,%d,%s,%.5g,%.5g,%.3g,%.3g,%.3g,%.3g,%.3g,%.3g,%.3g,%.3g,%.3g,%.4g,%.4g,%.3g\n",
			       b.name, n, ndo_method_names[ms[q]], c.h, U, e.time_m / U, tt / U, e.space_m / U,
			       ts / U, te / U, tot / U, e.time_m / tt, e.space_m / ts, te / tot, r.cpu, e.cpu, e.rate);
			fflush(stdout);
			ndo_acc_result_free(&r);
		}
		ndo_acc_result_free(&rt);
		teardown(&b);
	}
}

static double median3(double a, double b, double c)
{
	return fmax(fmin(a, b), fmin(fmax(a, b), c));
}

/* A configuration's CPU time: the median of three trials, each repeating
 * the run until it has taken MIN_TRIAL CPU seconds (a level-2 run takes
 * 1e-5 s: alone, a clock's noise), divided by the repetitions. */
#define MIN_TRIAL 0.02
static double timed(bscene *b, const ndo_acc_config *c, double *err)
{
	double t[3];
	ndo_acc_result r;
	if (ndo_acc_run(b->in, c, &r)) {
		*err = INFINITY;
		return INFINITY;
	}
	*err = b->ref ? true_error(b, c->level, r.u) / b->umax : NAN;
	int reps = r.cpu > 0 ? (int)fmin(1000, ceil(MIN_TRIAL / r.cpu)) : 1000;
	ndo_acc_result_free(&r);
	for (int k = 0; k < 3; k++) {
		t[k] = 0;
		for (int j = 0; j < reps; j++) {
			if (ndo_acc_run(b->in, c, &r))
				die("a repeated run diverged");
			t[k] += r.cpu;
			ndo_acc_result_free(&r);
		}
		t[k] /= reps;
	}
	return median3(t[0], t[1], t[2]);
}

static void choose(int n, int argc, char **argv)
{
	const double Es[3] = {1e-1, 1e-2, 1e-3};
	printf("scene,E,reachable,level,method,step_s,steps,predicted,estimated,achieved,met,"
	       "run_cpu_s,choose_cpu_s,estimate_cpu_s,cheapest_cpu_s,cheapest,ratio,"
	       "ratio_with_overhead,best_possible\n");
	for (int k = 0; k < argc; k++) {
		bscene b;
		setup(&b, argv[k], n);
		/* The sweep. */
		typedef struct pt { ndo_acc_config c; double err, cpu; } pt;
		pt pts[256];
		int np = 0;
		const ndo_method ms[2] = {NDO_SYMPLECTIC_EULER, NDO_RK4};
		for (int l = 2; l <= n; l++)
			for (int q = 0; q < 2; q++)
				for (int h = 0; h < 8 && np < 256; h++) {
					ndo_acc_config c = at_fraction(b.in, l, ms[q], 0.9 / pow(2, h), b.T);
					double err;
					double t = timed(&b, &c, &err);
					pts[np++] = (pt){c, err, t};
					fprintf(stderr, "sweep %s level %d %s h %.4g: error %.3g, %.3g s\n", b.name, l,
					        ndo_method_names[ms[q]], c.h, err, t);
					if (h > 0 && err > 0.9 * pts[np - 2].err)
						break; /* the time error is gone: smaller steps only cost */
				}
		double best = INFINITY;
		for (int q = 0; q < np; q++)
			best = fmin(best, pts[q].err);
		ndo_acc_choice most = {0}; /* the choice whose pilots went furthest */
		most.pilot_top = -1;
		for (int e = 0; e < 3; e++) {
			double E = Es[e];
			double cheapest = INFINITY;
			int ci = -1;
			for (int q = 0; q < np; q++)
				if (pts[q].err <= E && pts[q].cpu < cheapest)
					cheapest = pts[q].cpu, ci = q;
			char cname[96] = "none";
			if (ci >= 0)
				snprintf(cname, sizeof cname, "level %d %s %.4g s", pts[ci].c.level,
				         ndo_method_names[pts[ci].c.method], pts[ci].c.h);
			ndo_acc_choice ch;
			double t0 = cpu();
			if (ndo_acc_choose(b.in, E, 0, b.T, &ch))
				die("choose");
			double tc = cpu() - t0;
			if (ch.pilot_top > most.pilot_top)
				most = ch;
			if (!ch.reachable) {
				printf("%s,%g,0,%d,,,,%.3g,,,,,%.4g,,%.4g,%s,,,%.3g\n", b.name, E, ch.level_needed,
				       ch.best_m / ch.umax, tc, cheapest, cname, best);
				fflush(stdout);
				continue;
			}
			double err, t = timed(&b, &ch.c, &err);
			ndo_acc_result r;
			ndo_acc_estimate es;
			if (ndo_acc_run(b.in, &ch.c, &r) || ndo_acc_estimate_run(b.in, &ch.c, r.u, r.umax, &es))
				die("chosen run");
			printf("%s,%g,1,%d,%s,%.4g,%lld,%.3g,%.3g,%.3g,%d,%.4g,%.4g,%.4g,%.4g,%s,%.3g,%.3g,"
			       "%.3g\n",
			       b.name, E, ch.c.level, ndo_method_names[ch.c.method], ch.c.h,
			       (long long)ch.c.steps, ch.error_m / ch.umax,
			       es.total_m / r.umax, err, err <= E, t, tc, es.cpu, cheapest,
			       cname, t / cheapest, (t + tc + es.cpu) / cheapest, best);
			fflush(stdout);
			ndo_acc_result_free(&r);
		}
		/* Each level's predicted space error (the choice whose pilots went
		 * furthest) against the sweep's: RK4 at its smallest step there
		 * (the time error halved away), and each method at 0.9 ×
		 * critical. */
		for (int l = 2; l <= n; l++) {
			double sp = INFINITY, se = NAN, rk = NAN;
			for (int q = 0; q < np; q++) {
				if (pts[q].c.level != l)
					continue;
				if (pts[q].c.method == NDO_RK4)
					sp = fmin(sp, pts[q].err);
				double *first = pts[q].c.method == NDO_RK4 ? &rk : &se;
				if (isnan(*first))
					*first = pts[q].err;
			}
			double pred = most.level_m[l] / b.umax;
			fprintf(stderr, "level,%s,%d,%s,%.3g,%.3g,%.3g,%.3g,%.3g\n", b.name, l,
			        l <= most.pilot_top ? "measured" : "extrapolated", pred, sp, pred / sp, se,
			        rk);
		}
		/* The sweep for the plot. */
		for (int q = 0; q < np; q++)
			fprintf(stderr, "point,%s,%d,%s,%.5g,%.5g,%.5g\n", b.name, pts[q].c.level,
			        ndo_method_names[pts[q].c.method], pts[q].c.h, pts[q].cpu, pts[q].err);
		teardown(&b);
	}
}

/* A level-l result of configuration (m, frac × critical) to time t, at
 * level N (finer results restricted, coarser subdivided); *umax: its
 * largest displacement. */
static double *run_to(bscene *b, ndo_acc *a, int l, ndo_method m, double frac, double t,
                      double *umax)
{
	ndo_acc_config c = at_fraction(a, l, m, frac, t);
	ndo_acc_result r;
	if (ndo_acc_run(a, &c, &r))
		die("pilot run");
	if (umax)
		*umax = r.umax;
	double *out;
	if (l <= b->n) {
		if (ndo_acc_prolong(l, b->n, r.u, &out))
			die("prolong");
	} else {
		size_t cnt = 3 * (size_t)((2 << l) + 1) * (size_t)((1 << l) + 1);
		double *t1 = malloc(cnt * sizeof *t1);
		out = malloc(cnt * sizeof *out);
		memcpy(out, r.u, cnt * sizeof *out);
		for (int k = l; k > b->n; k--) {
			ndo_restrict_nodes(k, 3 * sizeof(double), out, t1);
			double *sw = out;
			out = t1, t1 = sw;
		}
		free(t1);
	}
	ndo_acc_result_free(&r);
	return out;
}

static void pilot(int n, int argc, char **argv)
{
	printf("scene,t_s,largest_m,true_below,true_input,predicted_below,pilot_difference\n");
	for (int k = 0; k < argc; k++) {
		bscene b;
		setup(&b, argv[k], n);
		for (int i = 3; i >= 0; i--) {
			double t = b.T / (double)(1 << i), U;
			double *ref = run_to(&b, b.fine, n + 2, NDO_RK4, 0.2, t, &U);
			double *s1 = run_to(&b, b.in, n - 1, NDO_SYMPLECTIC_EULER, 0.9, t, NULL),
			       *s0 = run_to(&b, b.in, n, NDO_SYMPLECTIC_EULER, 0.9, t, NULL),
			       *p2 = run_to(&b, b.in, n - 2, NDO_RK4, 0.5, t, NULL),
			       *p1 = run_to(&b, b.in, n - 1, NDO_RK4, 0.5, t, NULL),
			       *p0 = run_to(&b, b.in, n, NDO_RK4, 0.5, t, NULL);
			printf("%s,%.4g,%.4g,%.3g,%.3g,%.3g,%.3g\n", b.name, t, U,
			       ndo_acc_distance(n, s1, ref) / U, ndo_acc_distance(n, s0, ref) / U,
			       ndo_acc_distance(n, p1, p2) / 3 / U, ndo_acc_distance(n, p0, p1) / U);
			fflush(stdout);
			free(ref), free(s1), free(s0), free(p2), free(p1), free(p0);
		}
		teardown(&b);
	}
}

static void cost(int n, int argc, char **argv)
{
	const ndo_method ms[2] = {NDO_SYMPLECTIC_EULER, NDO_RK4};
	printf("scene,level,method,vertices,integrated,steps,cpu_per_step_us,model_us,"
	       "measured_over_model\n");
	for (int k = 0; k < argc; k++) {
		bscene b;
		setup(&b, argv[k], n);
		for (int l = 2; l <= n; l++)
			for (int q = 0; q < 2; q++) {
				ndo_acc_config c = at_fraction(b.in, l, ms[q], 0.9, b.T);
				double err, t = timed(&b, &c, &err) / (double)c.steps;
				double model = ndo_acc_work(b.in, l, ms[q], 1);
				printf("%s,%d,%s,%zu,%.0f,%lld,%.4g,%.4g,%.3g\n", b.name, l,
				       ndo_method_names[ms[q]], ndo_vertex_count(l), ndo_acc_active(b.in, l),
				       (long long)c.steps, 1e6 * t, 1e6 * model, t / model);
				fflush(stdout);
			}
		teardown(&b);
	}
}

/* Level q's result at level `to` (q ≤ to): subdivided. */
static double *up_to(int q, int to, const double *u)
{
	double *out;
	if (ndo_acc_prolong(q, to, u, &out))
		die("prolong");
	return out;
}

/* Level l's result restricted to level l − 1 (its even rows and columns). */
static double *down_one(int l, const double *u)
{
	double *out = malloc(3 * sizeof(double) * (size_t)((2 << (l - 1)) + 1) *
	                     (size_t)((1 << (l - 1)) + 1));
	ndo_restrict_nodes(l, 3 * sizeof(double), u, out);
	return out;
}

/* The chooser's space-error predictors against the truth: the pilots (RK4
 * at half the critical step) at levels 2..N; for every top pilot level and
 * every level q up to it, the space error measured against the top pair's
 * extrapolation u* over all of top's nodes (ndo_acc_choose's) and over
 * level top − 1's nodes only (as a run's estimate measures it), and the
 * true error of q's pilot (at level N, against the reference). */
static void predictors(int n, int argc, char **argv)
{
	printf("scene,top,q,true,all_nodes,shared_nodes,D_all_top,D_shared_top\n");
	for (int k = 0; k < argc; k++) {
		bscene b;
		setup(&b, argv[k], n);
		double *pu[NDO_MAX_LEVEL + 1] = {0}, tr[NDO_MAX_LEVEL + 1];
		for (int l = 2; l <= n; l++) {
			ndo_acc_config c = at_fraction(b.in, l, NDO_RK4, 0.5, b.T);
			ndo_acc_result r;
			if (ndo_acc_run(b.in, &c, &r))
				die("pilot");
			pu[l] = r.u, r.u = NULL;
			ndo_acc_result_free(&r);
			tr[l] = true_error(&b, l, pu[l]);
		}
		for (int top = 3; top <= n; top++) {
			size_t nt = 3 * (size_t)((2 << top) + 1) * (size_t)((1 << top) + 1),
			       ns = 3 * (size_t)((2 << (top - 1)) + 1) * (size_t)((1 << (top - 1)) + 1);
			double *sa = up_to(top - 1, top, pu[top - 1]), *ss = down_one(top, pu[top]);
			double da = ndo_acc_distance(top, pu[top], sa), ds = ndo_acc_distance(top - 1, ss, pu[top - 1]);
			for (size_t i = 0; i < nt; i++)
				sa[i] = pu[top][i] + (pu[top][i] - sa[i]) / 3;
			for (size_t i = 0; i < ns; i++)
				ss[i] = ss[i] + (ss[i] - pu[top - 1][i]) / 3;
			for (int q = 2; q <= top; q++) {
				double *a = up_to(q, top, pu[q]), ea = ndo_acc_distance(top, a, sa), es;
				free(a);
				if (q == top) {
					double *r = down_one(top, pu[top]);
					es = ndo_acc_distance(top - 1, r, ss);
					free(r);
				} else {
					double *r = up_to(q, top - 1, pu[q]);
					es = ndo_acc_distance(top - 1, r, ss);
					free(r);
				}
				printf("%s,%d,%d,%.4g,%.4g,%.4g,%.4g,%.4g\n", b.name, top, q, tr[q] / b.umax,
				       ea / b.umax, es / b.umax, da / b.umax, ds / b.umax);
			}
			fflush(stdout);
			free(sa), free(ss);
		}
		for (int l = 2; l <= n; l++)
			free(pu[l]);
		teardown(&b);
	}
}

/* The time error's convergence: at levels N − 1 and N, RK4 (and
 * symplectic Euler) at 0.9 × the critical step and its halvings, against
 * RK4 at 0.05 × critical, at T/8 and T: the error and the order observed
 * between each step and its half, relative to the reference's largest
 * displacement (that run's, at T: no reference runs); and the run's estimate
 * (ndo_acc_estimate_run) at 0.9. */
static void timeorder(int n, int argc, char **argv)
{
	printf("scene,level,method,fraction,t_s,error,observed_order,estimate\n");
	const ndo_method ms[2] = {NDO_RK4, NDO_SYMPLECTIC_EULER};
	for (int k = 0; k < argc; k++) {
		bscene b;
		setup(&b, argv[k], n);
		for (int l = n - 1; l <= n; l++)
			for (int i = 0; i < 2; i++) {
				double U;
				double *t8 = run_to(&b, b.in, l, NDO_RK4, 0.05, b.T / 8, NULL),
				       *t1 = run_to(&b, b.in, l, NDO_RK4, 0.05, b.T, &U);
				double prev8 = NAN, prev1 = NAN, est = NAN;
				{
					ndo_acc_config c = at_fraction(b.in, l, ms[i], 0.9, b.T);
					ndo_acc_result r;
					ndo_acc_estimate e;
					if (ndo_acc_run(b.in, &c, &r) || ndo_acc_estimate_run(b.in, &c, r.u, r.umax, &e))
						die("run");
					est = e.time_m / U;
					fprintf(stderr, "%s level %d %s: time %s\n", b.name, l, ndo_method_names[ms[i]],
					        e.time_how);
					ndo_acc_result_free(&r);
				}
				for (double f = 0.9; f > 0.1; f /= 2) {
					double *a8 = run_to(&b, b.in, l, ms[i], f, b.T / 8, NULL),
					       *a1 = run_to(&b, b.in, l, ms[i], f, b.T, NULL);
					double e8 = ndo_acc_distance(n, a8, t8) / U,
					       e1 = ndo_acc_distance(n, a1, t1) / U;
					printf("%s,%d,%s,%.3g,%.4g,%.3g,%.3g,%.3g\n", b.name, l, ndo_method_names[ms[i]],
					       f, b.T / 8, e8, log2(prev8 / e8), f == 0.9 ? est : NAN);
					printf("%s,%d,%s,%.3g,%.4g,%.3g,%.3g,%.3g\n", b.name, l, ndo_method_names[ms[i]],
					       f, b.T, e1, log2(prev1 / e1), f == 0.9 ? est : NAN);
					fflush(stdout);
					prev8 = e8, prev1 = e1;
					free(a8), free(a1);
				}
				free(t8), free(t1);
			}
		teardown(&b);
	}
}

/* What each level makes of a scene's face forces selected at a point
 * (force face at=X radius=R): the faces whose centroids lie within R at
 * levels 2..N + 2 (the scene's rest shape restricted), their area and how
 * far from the point their nodes reach.  The total force is the same at
 * every level (shared by area): what differs is where it acts. */
static void loads(int n, int argc, char **argv)
{
	printf("scene,force,level,faces,area_m2,reach_m\n");
	for (int k = 0; k < argc; k++) {
		bscene b;
		setup(&b, argv[k], n);
		for (int l = 2; l <= n + 2; l++) {
			const double *X = ndo_acc_rest(b.fine, l);
			uint8_t *pin = calloc(ndo_vertex_count(l) * 4 + 64, 1);
			ndo_force *f;
			if (!X || !pin || ndo_scene_resolve(&b.sc, l, X, &f, pin))
				die("resolve");
			size_t ntri = (size_t)1 << (2 * l + 2);
			int32_t *tri = malloc(3 * ntri * sizeof *tri);
			ndo_triangles(l, tri);
			for (int q = 0; q < b.sc.nforces; q++) {
				const ndo_selection *sel = &b.sc.forces[q].sel;
				if (f[q].kind != NDO_FORCE_FACE || sel->kind != NDO_SEL_AT)
					continue;
				double area = 0, reach = 0;
				for (size_t i = 0; i < f[q].count; i++) {
					const int32_t *v = tri + 3 * (size_t)f[q].items[i];
					double e1[3], e2[3];
					for (int d = 0; d < 3; d++) {
						e1[d] = X[3 * v[1] + d] - X[3 * v[0] + d];
						e2[d] = X[3 * v[2] + d] - X[3 * v[0] + d];
					}
					double c0 = e1[1] * e2[2] - e1[2] * e2[1], c1 = e1[2] * e2[0] - e1[0] * e2[2],
					       c2 = e1[0] * e2[1] - e1[1] * e2[0];
					area += 0.5 * sqrt(c0 * c0 + c1 * c1 + c2 * c2);
					for (int j = 0; j < 3; j++) {
						double d0 = X[3 * v[j]] - sel->at[0], d1 = X[3 * v[j] + 1] - sel->at[1],
						       d2 = X[3 * v[j] + 2] - sel->at[2];
						reach = fmax(reach, sqrt(d0 * d0 + d1 * d1 + d2 * d2));
					}
				}
				printf("%s,%d,%d,%zu,%.4g,%.4g\n", b.name, q + 1, l, f[q].count, area, reach);
			}
			fflush(stdout);
			free(tri);
			free(pin);
			ndo_scene_forces_free(f, b.sc.nforces);
		}
		teardown(&b);
	}
}

int main(int argc, char **argv)
{
	if (argc >= 5)
		T_override = atof(argv[3]);
	if (argc >= 5 && strcmp(argv[1], "estimates") == 0)
		estimates(atoi(argv[2]), argc - 4, argv + 4);
	else if (argc >= 5 && strcmp(argv[1], "choose") == 0)
		choose(atoi(argv[2]), argc - 4, argv + 4);
	else if (argc >= 5 && strcmp(argv[1], "cost") == 0)
		no_reference = 1, cost(atoi(argv[2]), argc - 4, argv + 4);
	else if (argc >= 5 && strcmp(argv[1], "pilot") == 0)
		pilot(atoi(argv[2]), argc - 4, argv + 4);
	else if (argc >= 5 && strcmp(argv[1], "predictors") == 0)
		predictors(atoi(argv[2]), argc - 4, argv + 4);
	else if (argc >= 5 && strcmp(argv[1], "timeorder") == 0)
		no_reference = 1, timeorder(atoi(argv[2]), argc - 4, argv + 4);
	else if (argc >= 5 && strcmp(argv[1], "loads") == 0)
		no_reference = 1, loads(atoi(argv[2]), argc - 4, argv + 4);
	else {
		fprintf(stderr, "usage: bench_accuracy estimates|choose|cost|pilot|predictors|timeorder|loads N T NAME=INPUT:SCENE[:REST]...\n");
		return 2;
	}
	return 0;
}
