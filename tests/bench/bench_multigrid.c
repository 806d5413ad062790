/* bench_multigrid — the implicit methods' two solvers side by side:
 * conjugate gradients with the multigrid V-cycle against CHOLMOD.
 *
 *   bench_multigrid speed L...     steps/s of backward Euler and trapezoid
 *                                  with each solver at levels L (the thesis
 *                                  scene, half RK4's critical step), their
 *                                  ratio, iterations per solve, and how far
 *                                  the multigrid step is from CHOLMOD's
 *   bench_multigrid iters H... L...  iterations per solve of backward Euler
 *                                  at levels L for fixed steps H (written with
 *                                  a '.') and at half RK4's critical step
 *   bench_multigrid memory L M S H  peak resident memory of three steps of
 *                                  method M with solver S at level L, step H,
 *                                  against the estimate --max-memory checks
 *   bench_multigrid steps L M N    CPU and wall seconds of N steps of method M with the
 *                                  multigrid solver at level L (half RK4's
 *                                  step, after 5 steps that build it) and
 *                                  iterations per solve: one side of a paired
 *                                  comparison of two builds, run alternately;
 *                                  and a hash of the final velocities' bits,
 *                                  the same where two builds compute the same
 *
 * Timings are medians of 7 runs of at least 0.1 s each, on one thread or,
 * after -t T (first), on T; the two solvers' runs alternate, and the ratio
 * is the median of the 7 pairs' ratios.
 * Output: markdown table rows (tests/bench/multigrid.sh assembles them). */
#include "ndo/ndo.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>

static double now(void)
{
	struct timespec t;
	clock_gettime(CLOCK_MONOTONIC, &t);
	return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static int cmp(const void *a, const void *b)
{
	double x = *(const double *)a, y = *(const double *)b;
	return (x > y) - (x < y);
}

static double median(double *v, int n)
{
	qsort(v, (size_t)n, sizeof *v, cmp);
	return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

#define REPS 7

static void die(void)
{
	fprintf(stderr, "bench_multigrid: %s\n", ndo_errdetail());
	exit(1);
}

/* The thesis scene (figure 5.3): the wavy surface, k = 1 N/m, b = 0.1, a
 * sinusoidal 2.4 N force on the faces around (0, 0, 1). */
static int threads = 1;

static ndo_sim *scene(ndo_grid *g, ndo_method m, ndo_solver sv, ndo_force **forces)
{
	ndo_scene sc;
	ndo_scene_init(&sc);
	ndo_scene_set(&sc, "force", "face at=0,0,1 radius=0.2 amplitude=2.4 frequency=1");
	uint8_t *pin = calloc(g->count, 1);
	if (ndo_scene_resolve(&sc, g->level, g->ch[0].data, forces, pin))
		die();
	ndo_sim_params p = sc.sim;
	p.method = m;
	p.solver = sv;
	p.threads = threads;
	p.forces = *forces;
	p.nforces = sc.nforces;
	ndo_sim *s;
	if (ndo_sim_create(g->level, g->ch[0].data, NULL, NULL, NULL, &p, &s))
		die();
	free(pin);
	ndo_scene_free(&sc);
	return s;
}

static double h_rk4(ndo_grid *g)
{
	ndo_force *f;
	ndo_sim *s = scene(g, NDO_RK4, NDO_SOLVER_AUTO, &f);
	ndo_critical c;
	ndo_sim_critical(s, &c);
	ndo_sim_destroy(s);
	ndo_scene_forces_free(f, 1);
	return c.h_crit;
}

/* Steps taking at least 0.1 s (after 5 steps that build the factor or the
 * hierarchy). */
static long calibrate(ndo_sim *s, double h)
{
	for (int k = 0; k < 5; k++)
		if (ndo_sim_step(s, h))
			die();
	long n = 1;
	for (;;) {
		double t0 = now();
		for (long k = 0; k < n; k++)
			if (ndo_sim_step(s, h))
				die();
		double el = now() - t0;
		if (el > 0.1)
			return n;
		n = el > 0.01 ? (long)(n * 0.12 / el) + 1 : n * 10;
	}
}

/* Steps per second of n steps. */
static double timed(ndo_sim *s, double h, long n)
{
	double t0 = now();
	for (long q = 0; q < n; q++)
		if (ndo_sim_step(s, h))
			die();
	return (double)n / (now() - t0);
}

/* The largest difference between the two solvers' velocities after
 * `steps` steps from the same state, relative to the largest velocity. */
static double difference(ndo_grid *g, ndo_method m, double h, int steps)
{
	ndo_force *f1, *f2;
	ndo_sim *a = scene(g, m, NDO_SOLVER_MULTIGRID, &f1), *b = scene(g, m, NDO_SOLVER_CHOLMOD, &f2);
	for (int k = 0; k < steps; k++)
		if (ndo_sim_step(a, h) || ndo_sim_step(b, h))
			die();
	size_t n = 3 * g->count;
	double *va = malloc(n * sizeof *va), *vb = malloc(n * sizeof *vb), d = 0, big = 0;
	ndo_sim_get(a, NULL, va);
	ndo_sim_get(b, NULL, vb);
	for (size_t q = 0; q < n; q++) {
		d = fmax(d, fabs(va[q] - vb[q]));
		big = fmax(big, fabs(vb[q]));
	}
	free(va), free(vb);
	ndo_sim_destroy(a), ndo_sim_destroy(b);
	ndo_scene_forces_free(f1, 1), ndo_scene_forces_free(f2, 1);
	return big > 0 ? d / big : d;
}

static void speed(int argc, char **argv)
{
	printf("| integrator | level | nodes | step (s) | CHOLMOD (steps/s) | multigrid (steps/s) "
	       "| ratio | levels | iterations/solve | relative residual | step difference |\n");
	printf("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
	for (int a = 0; a < argc; a++) {
		int level = atoi(argv[a]);
		ndo_grid *g;
		if (ndo_shape_make("wavy", level, NULL, &g))
			die();
		double h = 0.5 * h_rk4(g);
		const ndo_method ms[] = {NDO_BACKWARD_EULER, NDO_TRAPEZOID};
		for (int k = 0; k < 2; k++) {
			ndo_force *f1, *f2;
			ndo_sim *c = scene(g, ms[k], NDO_SOLVER_CHOLMOD, &f1);
			ndo_sim *m = scene(g, ms[k], NDO_SOLVER_MULTIGRID, &f2);
			/* 7 pairs of runs, CHOLMOD then multigrid: a busy machine slows
			 * both runs of a pair alike; the ratio is the median of the
			 * pairs' ratios. */
			long nc = calibrate(c, h), nm = calibrate(m, h);
			double rc[REPS], rm[REPS], q[REPS];
			for (int r = 0; r < REPS; r++) {
				rc[r] = timed(c, h, nc);
				rm[r] = timed(m, h, nm);
				q[r] = rm[r] / rc[r];
			}
			double sc = median(rc, REPS), sm = median(rm, REPS), ratio = median(q, REPS);
			ndo_sim_stats st;
			ndo_sim_stats_get(m, &st);
			int levels = 0, direct = 0;
			ndo_sim_solver_info(m, &levels, &direct);
			printf("| %s | %d | %zu | %.3g | %.4g | %.4g | %.2f | %d%s | %.1f | %.2g | %.2g |\n",
			       ndo_method_names[ms[k]], level, ndo_vertex_count(level), h, sc, sm, ratio,
			       levels, direct ? "" : " (Jacobi)",
			       (double)st.iterations / (double)st.solves, st.last_residual,
			       difference(g, ms[k], h, 20));
			fflush(stdout);
			ndo_sim_destroy(c), ndo_sim_destroy(m);
			ndo_scene_forces_free(f1, 1), ndo_scene_forces_free(f2, 1);
		}
		ndo_grid_destroy(g);
	}
}

/* Iterations per solve of backward Euler over 5 steps of each size. */
static void iters(int argc, char **argv)
{
	int nh = 0;
	double hs[8];
	while (nh < 8 && nh < argc && strchr(argv[nh], '.'))
		hs[nh] = atof(argv[nh]), nh++;
	printf("| level | nodes |");
	for (int k = 0; k < nh; k++)
		printf(" h = %g s |", hs[k]);
	printf(" h = ½ rk4's |\n|---:|---:|");
	for (int k = 0; k <= nh; k++)
		printf("---:|");
	printf("\n");
	for (int a = nh; a < argc; a++) {
		int level = atoi(argv[a]);
		ndo_grid *g;
		if (ndo_shape_make("wavy", level, NULL, &g))
			die();
		printf("| %d | %zu |", level, ndo_vertex_count(level));
		for (int k = 0; k <= nh; k++) {
			double h = k < nh ? hs[k] : 0.5 * h_rk4(g);
			ndo_force *f;
			ndo_sim *s = scene(g, NDO_BACKWARD_EULER, NDO_SOLVER_MULTIGRID, &f);
			for (int q = 0; q < 5; q++)
				if (ndo_sim_step(s, h))
					die();
			ndo_sim_stats st;
			ndo_sim_stats_get(s, &st);
			int levels = 0, direct = 0;
			ndo_sim_solver_info(s, &levels, &direct);
			printf(" %.1f (%d%s) |", (double)st.iterations / (double)st.solves, levels,
			       direct ? "" : "j");
			fflush(stdout);
			ndo_sim_destroy(s);
			ndo_scene_forces_free(f, 1);
		}
		printf("\n");
		ndo_grid_destroy(g);
	}
}

/* One configuration per process (peak RSS only grows): level L, method,
 * solver; three steps at h; the peak resident memory against
 * ndo_sim_memory()'s estimate (for CHOLMOD plus the factor it states). */
static void memory(int argc, char **argv)
{
	if (argc != 4) {
		fprintf(stderr, "usage: bench_multigrid memory L METHOD SOLVER H\n");
		exit(2);
	}
	int level = atoi(argv[0]);
	ndo_method m;
	ndo_solver sv;
	if (ndo_method_parse(argv[1], &m) || ndo_solver_parse(argv[2], &sv))
		die();
	double h = atof(argv[3]);
	struct rusage ru;
	getrusage(RUSAGE_SELF, &ru);
	long before = ru.ru_maxrss;
	ndo_grid *g;
	if (ndo_shape_make("wavy", level, NULL, &g))
		die();
	getrusage(RUSAGE_SELF, &ru);
	long grid = ru.ru_maxrss - before;
	ndo_force *f;
	ndo_sim *s = scene(g, m, sv, &f);
	ndo_sim_params p;
	ndo_sim_defaults(&p);
	p.method = m;
	p.solver = sv;
	double t0 = now();
	for (int k = 0; k < 3; k++)
		if (ndo_sim_step(s, h))
			die();
	double el = now() - t0;
	getrusage(RUSAGE_SELF, &ru);
	ndo_sim_stats st;
	ndo_sim_stats_get(s, &st);
	printf("| %d | %zu | %s | %s | %g | %.0f | %.0f | %.2f | %.1f |\n", level, ndo_vertex_count(level),
	       argv[1], argv[2], h, (double)(ru.ru_maxrss - grid) / 1024,
	       (double)ndo_sim_memory(level, &p) / 1048576, el / 3,
	       st.solves ? (double)st.iterations / (double)st.solves : 0.0);
	ndo_sim_destroy(s);
	ndo_scene_forces_free(f, 1);
	ndo_grid_destroy(g);
}

static void steps(int argc, char **argv)
{
	ndo_method m;
	if (argc != 3 || ndo_method_parse(argv[1], &m) || atol(argv[2]) < 1) {
		fprintf(stderr, "usage: bench_multigrid steps L METHOD N\n");
		exit(2);
	}
	int level = atoi(argv[0]);
	long n = atol(argv[2]);
	ndo_grid *g;
	if (ndo_shape_make("wavy", level, NULL, &g))
		die();
	double h = 0.5 * h_rk4(g);
	ndo_force *f;
	ndo_sim *s = scene(g, m, NDO_SOLVER_MULTIGRID, &f);
	for (int k = 0; k < 5; k++)
		if (ndo_sim_step(s, h))
			die();
	ndo_sim_stats st0, st;
	ndo_sim_stats_get(s, &st0);
	struct timespec t0, t1, w0, w1;
	clock_gettime(CLOCK_MONOTONIC, &w0);
	clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t0);
	for (long k = 0; k < n; k++)
		if (ndo_sim_step(s, h))
			die();
	clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t1);
	clock_gettime(CLOCK_MONOTONIC, &w1);
	ndo_sim_stats_get(s, &st);
	size_t nv = 3 * g->count;
	double *v = malloc(nv * sizeof *v);
	if (!v)
		die();
	ndo_sim_get(s, NULL, v);
	uint64_t hash = 14695981039346656037u; /* FNV-1a over the bytes */
	const unsigned char *vb = (const unsigned char *)v;
	for (size_t q = 0; q < nv * sizeof *v; q++)
		hash = (hash ^ vb[q]) * 1099511628211u;
	free(v);
	double cpu = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
	double wall = (double)(w1.tv_sec - w0.tv_sec) + 1e-9 * (double)(w1.tv_nsec - w0.tv_nsec);
	printf("%s level %d: %ld steps %.4f CPU s, %.1f steps per CPU s, %.1f steps per s (wall), "
	       "%.2f iterations/solve, %lld steps alone, velocities %016llx\n",
	       argv[1], level, n, cpu, (double)n / cpu, (double)n / wall,
	       (double)(st.iterations - st0.iterations) / (double)(st.solves - st0.solves),
	       (long long)(st.steps_alone - st0.steps_alone), (unsigned long long)hash);
	ndo_sim_destroy(s);
	ndo_scene_forces_free(f, 1);
	ndo_grid_destroy(g);
}

int main(int argc, char **argv)
{
	if (argc >= 3 && strcmp(argv[1], "-t") == 0) {
		threads = atoi(argv[2]);
		argv += 2;
		argc -= 2;
	}
	if (argc >= 2 && strcmp(argv[1], "speed") == 0)
		speed(argc - 2, argv + 2);
	else if (argc >= 2 && strcmp(argv[1], "iters") == 0)
		iters(argc - 2, argv + 2);
	else if (argc >= 2 && strcmp(argv[1], "memory") == 0)
		memory(argc - 2, argv + 2);
	else if (argc >= 2 && strcmp(argv[1], "steps") == 0)
		steps(argc - 2, argv + 2);
	else {
		fprintf(stderr, "usage: bench_multigrid [-t T] speed L... | iters H... L... | memory L METHOD "
		        "SOLVER H | steps L METHOD N\n");
		return 2;
	}
	return 0;
}
