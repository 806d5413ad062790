/* bench_simulate — how fast the membrane integrators run, and how close
 * the stencil kernel comes to this machine's limits.
 *
 *   bench_simulate speed L...   steps/s and node-steps/s of every
 *                               integrator at levels L (the thesis scene)
 *   bench_simulate limits       copy bandwidth at L2, L3 and DRAM sizes;
 *                               FMA throughput with SSE2, AVX2, AVX-512
 *   bench_simulate kernel L...  the RK4 kernel's GFLOP/s and GB/s
 *   bench_simulate threads T L...  steps/s of rk4, symplectic Euler and
 *                               midpoint on 1 and on T threads, in
 *                               alternating runs, and their ratio (the
 *                               steps as simulate-peer takes them
 *                               between frames: ndo_sim_steps)
 *   bench_simulate pipeline T L...  rk4's four passes against its
 *                               pipeline (lib/sim/rk4.c), on 1 and T
 *                               threads, in alternating runs
 *   bench_simulate region [M] L...  a 2-peer partition's region (method
 *                               M: quadtree, the default, or table41, metis,
 *                               bands; held nodes, lock-step rk4's 2-ring
 *                               halo) by the passes and by the pipeline,
 *                               against the whole object, one thread, in
 *                               process CPU time, and the cut's length
 *   bench_simulate fused T L...  the same for symplectic Euler and
 *                               midpoint: their passes through the stored
 *                               acceleration against the fused ones
 *                               (integrate.c, ndo__accel_update)
 *   bench_simulate wave T L...  the same for symplectic Euler and
 *                               midpoint: steps one at a time
 *                               (ndo_sim_step) against runs of them
 *                               (ndo_sim_steps: lib/sim/wave.c)
 *   bench_simulate bandwidth T  the STREAM-like triad on 1 and on T
 *                               threads over the same arrays, in
 *                               alternating runs: what more threads can
 *                               give a pass bound by memory
 *
 * Timings are medians of 7 runs of at least 0.1 s each, single thread
 * (threads: the ratio is the median of the 7 pairs' ratios); limits and
 * kernel in process CPU time, the others in wall time.
 * Output: markdown table rows (tests/bench/simulate.sh assembles them). */
#include "ndo/ndo.h"
#include "ndo/partition.h"
#include "ndo/peer.h"
#include "sim_private.h" /* rk4_reference: the passes beside the pipeline */

#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static double now(void)
{
	struct timespec t;
	clock_gettime(CLOCK_MONOTONIC, &t);
	return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* Process CPU seconds: the limits and the kernel (one thread) are timed
 * by the CPU time they get, so that a machine busy with other work, which
 * takes the core away for a while, slows neither (its caches and memory
 * bandwidth are still shared). */
static double cpu_now(void)
{
	struct timespec t;
	clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
	return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* The clock steps_per_second(), bandwidth() and gflops() read. */
static double (*clock_of)(void) = now;

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

/* The thesis scene (figure 5.3): the wavy surface, k = 1 N/m, b = 0.1,
 * a sinusoidal 2.4 N force on the faces around (0, 0, 1). */
static ndo_sim *thesis_scene_on(ndo_grid *g, ndo_method m, int threads, ndo_force **forces)
{
	ndo_scene sc;
	ndo_scene_init(&sc);
	ndo_scene_set(&sc, "force", "face at=0,0,1 radius=0.2 amplitude=2.4 frequency=1");
	uint8_t *pin = calloc(g->count, 1);
	if (ndo_scene_resolve(&sc, g->level, g->ch[0].data, forces, pin)) {
		fprintf(stderr, "bench_simulate: %s\n", ndo_errdetail());
		exit(1);
	}
	ndo_sim_params p = sc.sim;
	p.method = m;
	p.threads = threads;
	p.forces = *forces;
	p.nforces = sc.nforces;
	ndo_sim *s;
	if (ndo_sim_create(g->level, g->ch[0].data, NULL, NULL, NULL, &p, &s)) {
		fprintf(stderr, "bench_simulate: %s\n", ndo_errdetail());
		exit(1);
	}
	free(pin);
	ndo_scene_free(&sc);
	return s;
}

static ndo_sim *thesis_scene(ndo_grid *g, ndo_method m, ndo_force **forces)
{
	return thesis_scene_on(g, m, 1, forces);
}

/* Calls before any timing: a simulation with threads spends its first 9
 * calls (a step, or a run of steps that ndo_sim_steps takes as one
 * pipeline) looking whether they pay, alternately alone and on the
 * threads (lib/sim/integrate.c, threads_pick), and then runs the faster
 * way.  A timed run inside that look measures the look: at level 10,
 * where rk4's 0.1 s is two steps, 2 threads gave 0.95-1.04x one this way
 * and 1.56x after the look (2026-11-29, the same minute).  `many`: the
 * calls are ndo_sim_steps' runs (of 2 steps), as timed_how(many) takes
 * them, so that the look compares what is timed. */
enum { WARM_CALLS = 12 };

static void warm(ndo_sim *s, double h, int many)
{
	for (int k = 0; k < WARM_CALLS; k++)
		if (many ? ndo_sim_steps(s, h, 2) : ndo_sim_step(s, h)) {
			fprintf(stderr, "bench_simulate: %s\n", ndo_errdetail());
			exit(1);
		}
}

/* Steps taking at least 0.1 s (at least one), after the warm-up, taken
 * as timed_how(many) takes them: a simulation with threads compares the
 * steps on them with the look's steps alone, and steps one at a time
 * against the look's runs would send it to look again. */
static long calibrate_how(ndo_sim *s, double h, int many)
{
	warm(s, h, many);
	long n = many ? 2 : 1;
	for (;;) {
		double t0 = now();
		if (many)
			ndo_sim_steps(s, h, n);
		for (long k = 0; k < n && !many; k++)
			ndo_sim_step(s, h);
		double el = now() - t0;
		if (el > 0.1)
			return n;
		n = el > 0.01 ? (long)(n * 0.12 / el) + 1 : n * 10;
	}
}

static long calibrate(ndo_sim *s, double h)
{
	return calibrate_how(s, h, 0);
}

/* The step h (half the first simulation's critical step) and the steps
 * n that take it at least 0.1 s; the others stepped as long, warm (wave:
 * the odd ones through ndo_sim_steps, as they are timed). */
static long calibrate_all(ndo_sim **s, int ns, double *h, int wave)
{
	ndo_critical c;
	ndo_sim_critical(s[0], &c);
	*h = 0.5 * c.h_crit;
	long n = calibrate(s[0], *h);
	for (int k = 1; k < ns; k++)
		calibrate_how(s[k], *h, wave && k % 2);
	return n;
}

/* Steps per second of n steps, one call each or (many) one call of
 * ndo_sim_steps, as simulate-peer takes steps with nothing between them. */
static double timed_how(ndo_sim *s, double h, long n, int many)
{
	double t0 = now();
	int rc = 0;
	if (many)
		rc = ndo_sim_steps(s, h, n);
	for (long q = 0; q < n && !many && rc == 0; q++)
		rc = ndo_sim_step(s, h);
	if (rc) {
		fprintf(stderr, "bench_simulate: %s\n", ndo_errdetail());
		exit(1);
	}
	return (double)n / (now() - t0);
}

/* Median steps per second of `s` at step h. */
static double steps_per_second(ndo_sim *s, double h)
{
	for (int k = 0; k < 5; k++)
		ndo_sim_step(s, h);
	double r[REPS];
	long n = 1;
	for (;;) { /* calibrate: n steps take at least 0.1 s */
		double t0 = clock_of();
		for (long k = 0; k < n; k++)
			ndo_sim_step(s, h);
		double el = clock_of() - t0;
		if (el > 0.1)
			break;
		n = el > 0.01 ? (long)(n * 0.12 / el) + 1 : n * 10;
	}
	for (int k = 0; k < REPS; k++) {
		double t0 = clock_of();
		for (long q = 0; q < n; q++)
			if (ndo_sim_step(s, h)) {
				fprintf(stderr, "bench_simulate: %s\n", ndo_errdetail());
				exit(1);
			}
		r[k] = (double)n / (clock_of() - t0);
	}
	return median(r, REPS);
}

/* rk4, symplectic Euler and midpoint on one thread and on T, the same
 * scene, timed in turn: each ratio within a pair of runs made together. */
static void threads(int argc, char **argv)
{
	int T = atoi(argv[0]);
	const ndo_method ms[] = {NDO_RK4, NDO_SYMPLECTIC_EULER, NDO_MIDPOINT};
	printf("| integrator | level | nodes | 1 thread (steps/s) | %d threads (steps/s) | ratio | "
	       "%d threads: timed steps alone |\n", T, T);
	printf("|---|---:|---:|---:|---:|---:|---:|\n");
	for (int a = 1; a < argc; a++) {
		int level = atoi(argv[a]);
		ndo_grid *g;
		ndo_shape_make("wavy", level, NULL, &g);
		for (int k = 0; k < 3; k++) {
			ndo_force *f1, *fT;
			ndo_sim *s1 = thesis_scene_on(g, ms[k], 1, &f1);
			ndo_sim *sT = thesis_scene_on(g, ms[k], T, &fT);
			ndo_critical c;
			ndo_sim_critical(s1, &c);
			double h = 0.5 * c.h_crit;
			long n = calibrate_how(s1, h, 1);
			calibrate_how(sT, h, 1);
			double r1[REPS], rT[REPS], q[REPS];
			ndo_sim_stats a0, a1;
			ndo_sim_stats_get(sT, &a0);
			for (int r = 0; r < REPS; r++) {
				r1[r] = timed_how(s1, h, n, 1);
				rT[r] = timed_how(sT, h, n, 1);
				q[r] = rT[r] / r1[r];
			}
			ndo_sim_stats_get(sT, &a1);
			/* the share of the timed steps the T-thread simulation ran on one
			 * (its looks, and where the threads did not pay): a ratio near 1
			 * with a large share measured the guard, not the scaling */
			const double alone = a1.steps > a0.steps ? (double)(a1.steps_alone - a0.steps_alone) /
			                                               (double)(a1.steps - a0.steps)
			                                         : 0;
			printf("| %s | %d | %zu | %.4g | %.4g | %.2f | %.0f%% |\n", ndo_method_names[ms[k]],
			       level, ndo_vertex_count(level), median(r1, REPS), median(rT, REPS),
			       median(q, REPS), 100 * alone);
			fflush(stdout);
			ndo_sim_destroy(s1);
			ndo_sim_destroy(sT);
			ndo_scene_forces_free(f1, 1);
			ndo_scene_forces_free(fT, 1);
		}
		ndo_grid_destroy(g);
	}
}

/* RK4's two ways (lib/sim/rk4.c): the four passes and the pipeline, on
 * one thread and on T, the four timed in turn; the ratios are medians of
 * the runs' ratios within a round. */
static void pipeline(int argc, char **argv, const ndo_method *ms, int nm, const char *fast,
                     int wave)
{
	int T = atoi(argv[0]);
	const char *slow = wave ? "one at a time" : "passes";
	printf("| %slevel | nodes | %s, 1 thread | %s, 1 thread | ratio | %s, %d threads "
	       "| %s, %d threads | ratio | %s %d threads / %s 1 thread |\n",
	       nm > 1 ? "integrator | " : "", slow, fast, slow, T, fast, T, fast, T, slow);
	printf("|%s---:|---:|---:|---:|---:|---:|---:|---:|---:|\n", nm > 1 ? "---|" : "");
	for (int a = 1; a < argc; a++)
	for (int im = 0; im < nm; im++) {
		int level = atoi(argv[a]);
		ndo_grid *g;
		ndo_shape_make("wavy", level, NULL, &g);
		ndo_force *f[4];
		ndo_sim *s[4];
		for (int k = 0; k < 4; k++) {
			s[k] = thesis_scene_on(g, ms[im], k < 2 ? 1 : T, &f[k]);
			s[k]->rk4_reference = !wave && k % 2 == 0;
		}
		double h;
		long n = calibrate_all(s, 4, &h, wave);
		double r[4][REPS], q[3][REPS];
		for (int rep = 0; rep < REPS; rep++) {
			for (int k = 0; k < 4; k++)
				r[k][rep] = timed_how(s[k], h, n, wave && k % 2);
			q[0][rep] = r[1][rep] / r[0][rep];
			q[1][rep] = r[3][rep] / r[2][rep];
			q[2][rep] = r[3][rep] / r[0][rep];
		}
		if (nm > 1)
			printf("| %s ", ndo_method_names[ms[im]]);
		printf("| %d | %zu | %.4g | %.4g | %.2f | %.4g | %.4g | %.2f | %.2f |\n", level,
		       ndo_vertex_count(level), median(r[0], REPS), median(r[1], REPS), median(q[0], REPS),
		       median(r[2], REPS), median(r[3], REPS), median(q[1], REPS), median(q[2], REPS));
		fflush(stdout);
		for (int k = 0; k < 4; k++) {
			ndo_sim_destroy(s[k]);
			ndo_scene_forces_free(f[k], 1);
		}
		ndo_grid_destroy(g);
	}
}

/* Steps per process CPU second of n steps. */
static double timed_cpu(ndo_sim *s, double h, long n)
{
	double t0 = cpu_now();
	for (long q = 0; q < n; q++)
		if (ndo_sim_step(s, h)) {
			fprintf(stderr, "bench_simulate: %s\n", ndo_errdetail());
			exit(1);
		}
	return (double)n / (cpu_now() - t0);
}

/* What one of 2 lock-step peers integrates a step: the 2-peer partition
 * by `method` (the POIs of tests/bench/peers.sh: slot 0 the joiner's face,
 * slot 1 the owner's, anywhere), the slot's region and the rings of its
 * halo but the outermost (ndo_peer_halo_rings: held, moving with its
 * velocity). */
static void peer_region(const ndo_grid *g, ndo_part_method method, int slot, uint8_t *mask,
                        long *cut)
{
	const int level = g->level, n = 1 << level, w = g->w;
	int32_t poi[2] = {(int32_t)(9000LL * (4LL << (2 * level)) / 16384), -1};
	int32_t *cell = malloc((size_t)2 * n * n * sizeof *cell), ids[2] = {0, 1};
	int32_t *own = malloc(g->count * sizeof *own), *dist = malloc(g->count * sizeof *dist);
	int32_t *q = malloc(g->count * sizeof *q);
	int32_t *canon = malloc(g->count * sizeof *canon);
	if (!cell || !own || !dist || !q || !canon ||
	    ndo_partition(level, method, 2, poi, cell, NULL)) {
		fprintf(stderr, "bench_simulate: partition: %s\n", ndo_errdetail());
		exit(1);
	}
	*cut = ndo_cells_cut(level, cell);
	ndo_partition_node_owner(level, cell, ids, own);
	for (int j = 0; j <= n; j++)
		for (int i = 0; i < w; i++)
			canon[(size_t)j * w + i] = (int32_t)ndo_canonical(level, i, j);
	size_t head = 0, tail = 0;
	for (size_t k = 0; k < g->count; k++) {
		dist[k] = -1;
		if (canon[k] == (int32_t)k && own[k] == slot)
			dist[k] = 0, q[tail++] = (int32_t)k;
	}
	const int W = ndo_peer_halo_rings(NDO_RK4);
	while (head < tail) {
		size_t c = (size_t)q[head++];
		if (dist[c] >= W)
			continue;
		size_t nb[6];
		ndo_neighbors(level, (int)(c % (size_t)w), (int)(c / (size_t)w), nb);
		for (int d = 0; d < 6; d++) {
			size_t h = (size_t)canon[nb[d]];
			if (dist[h] < 0)
				dist[h] = dist[c] + 1, q[tail++] = (int32_t)h;
		}
	}
	for (size_t k = 0; k < g->count; k++)
		mask[k] = dist[canon[k]] >= 0 && dist[canon[k]] < W;
	free(cell), free(own), free(dist), free(q), free(canon);
}

/* A 2-peer region's step, by the passes and by the pipeline, against the
 * whole object's (the pipeline), one thread, timed in turn in process CPU
 * time: the computing a peer's step costs beside the single process's,
 * for each of the two regions (lock-step goes at the slower one's pace). */
static void region(int argc, char **argv)
{
	ndo_part_method method = NDO_PART_QUADTREE;
	if (argc > 0 && ndo_part_method_parse(argv[0]) > 0)
		method = (ndo_part_method)ndo_part_method_parse(argv[0]), argc--, argv++;
	printf("partition: %s\n", ndo_part_method_name(method));
	printf("| level | nodes | cut (cell edges) | region | integrated by the peer | whole, steps/s | region, passes | "
	       "region, pipeline | pipeline / passes | whole step / region step (pipeline) |\n");
	printf("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
	for (int a = 0; a < argc; a++) {
		int level = atoi(argv[a]);
		ndo_grid *g;
		ndo_shape_make("wavy", level, NULL, &g);
		long cut = 0;
		uint8_t *mask[2] = {malloc(g->count), malloc(g->count)};
		size_t inside[2] = {0, 0};
		for (int r = 0; r < 2; r++) {
			peer_region(g, method, r, mask[r], &cut);
			for (size_t k = 0; k < g->count; k++)
				inside[r] += mask[r][k] && ndo_canonical(level, (int)(k % (size_t)g->w),
				                                         (int)(k / (size_t)g->w)) == k;
		}
		/* the whole; each region by the passes and by the pipeline */
		ndo_force *f[5];
		ndo_sim *s[5];
		for (int k = 0; k < 5; k++) {
			s[k] = thesis_scene_on(g, NDO_RK4, 1, &f[k]);
			s[k]->rk4_reference = k == 1 || k == 3;
			if (k > 0) {
				ndo_sim_set_held_motion(s[k], 1);
				ndo_sim_set_active(s[k], mask[(k - 1) / 2]);
			}
		}
		double h;
		long n = calibrate_all(s, 5, &h, 0);
		double r[5][REPS], q[4][REPS];
		for (int rep = 0; rep < REPS; rep++) {
			for (int k = 0; k < 5; k++)
				r[k][rep] = timed_cpu(s[k], h, n);
			for (int m = 0; m < 2; m++) {
				q[2 * m][rep] = r[2 + 2 * m][rep] / r[1 + 2 * m][rep];
				q[2 * m + 1][rep] = r[0][rep] / r[2 + 2 * m][rep];
			}
		}
		for (int m = 0; m < 2; m++)
			printf("| %d | %zu | %ld | %d | %zu | %.4g | %.4g | %.4g | %.2f | %.2f |\n", level,
			       ndo_vertex_count(level), cut, m, inside[m], median(r[0], REPS),
			       median(r[1 + 2 * m], REPS), median(r[2 + 2 * m], REPS),
			       median(q[2 * m], REPS), median(q[2 * m + 1], REPS));
		fflush(stdout);
		for (int k = 0; k < 5; k++) {
			ndo_sim_destroy(s[k]);
			ndo_scene_forces_free(f[k], 1);
		}
		free(mask[0]), free(mask[1]);
		ndo_grid_destroy(g);
	}
}

static void speed(int argc, char **argv)
{
	printf("| integrator | level | nodes | step (s) | steps/s | node-steps/s |\n");
	printf("|---|---:|---:|---:|---:|---:|\n");
	for (int a = 0; a < argc; a++) {
		int level = atoi(argv[a]);
		ndo_grid *g;
		ndo_shape_make("wavy", level, NULL, &g);
		double h_rk4 = 0;
		for (int m = 0; m < NDO_METHOD_COUNT; m++) {
			ndo_force *forces;
			ndo_sim *s = thesis_scene(g, (ndo_method)m, &forces);
			ndo_critical c;
			ndo_sim_critical(s, &c);
			if (m == NDO_RK4)
				h_rk4 = c.h_crit;
			/* Each method at half its own critical step; the implicit ones
			 * at half RK4's (their cost per step does not depend on it). */
			double h = isinf(c.h_crit) ? 0.5 * h_rk4 : 0.5 * c.h_crit;
			double sps = steps_per_second(s, h);
			size_t nodes = ndo_vertex_count(level);
			printf("| %s | %d | %zu | %.3g | %.4g | %.3g |\n", ndo_method_names[m], level, nodes, h,
			       sps, sps * (double)nodes);
			fflush(stdout);
			ndo_sim_destroy(s);
			ndo_scene_forces_free(forces, 1);
		}
		ndo_grid_destroy(g);
	}
}

/* ---- machine limits ------------------------------------------------------- */

/* STREAM-like loops over n doubles, compiled for AVX2 like the kernel's
 * clone: copy b = a (16 bytes per element) and triad a = b + s c (24). */
__attribute__((target("avx2,fma"), optimize("O3"), noinline)) static void copy_avx2(double *restrict b,
                                                                    const double *restrict a,
                                                                    size_t n)
{
	for (size_t i = 0; i < n; i++)
		b[i] = a[i];
}

__attribute__((target("avx2,fma"), optimize("O3"), noinline)) static void triad_avx2(double *restrict a,
                                                                     const double *restrict b,
                                                                     const double *restrict c,
                                                                     size_t n)
{
	for (size_t i = 0; i < n; i++)
		a[i] = b[i] + 0.5 * c[i];
}

/* GB/s of the copy (triad = 0) or the triad on arrays of n doubles. */
static double bandwidth(size_t n, int triad)
{
	double *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b), *c = malloc(n * sizeof *c);
	for (size_t k = 0; k < n; k++)
		a[k] = (double)k, b[k] = 0, c[k] = 1;
	double r[REPS];
	long reps = (long)(2e8 / (double)n) + 1;
	for (int q = 0; q < REPS; q++) {
		double t0 = clock_of();
		for (long k = 0; k < reps; k++) {
			if (triad)
				triad_avx2(a, b, c, n);
			else
				copy_avx2(b, a, n);
			__asm__ volatile("" ::"r"(a), "r"(b) : "memory");
		}
		r[q] = (triad ? 24.0 : 16.0) * (double)n * (double)reps / (clock_of() - t0) / 1e9;
	}
	free(a), free(b), free(c);
	return median(r, REPS);
}

/* FMA throughput: 10 independent chains x = x * m + c (enough to cover
 * the latency of two pipes, few enough to stay in 16 registers), in the
 * vector width of each instruction set; GFLOP/s with 2 flops per
 * multiply-add. */
typedef double v2 __attribute__((vector_size(16)));
typedef double v4 __attribute__((vector_size(32)));
typedef double v8 __attribute__((vector_size(64)));
#define CHAINS 10

#define FMA_LOOP(T, LANES)                                                      \
	T x[CHAINS], m, c;                                                        \
	for (int k = 0; k < LANES; k++)                                           \
		m[k] = 0.999999, c[k] = 1e-6;                                         \
	for (int j = 0; j < CHAINS; j++)                                          \
		for (int k = 0; k < LANES; k++)                                       \
			x[j][k] = j + k;                                                  \
	for (long i = 0; i < iters; i++)                                          \
		for (int j = 0; j < CHAINS; j++)                                      \
			x[j] = x[j] * m + c;                                              \
	double sum = 0;                                                           \
	for (int j = 0; j < CHAINS; j++)                                          \
		for (int k = 0; k < LANES; k++)                                       \
			sum += x[j][k];                                                   \
	return sum;

__attribute__((optimize("O3"))) static double fma_sse2(long iters) { FMA_LOOP(v2, 2) }
__attribute__((target("avx2,fma"), optimize("O3"))) static double fma_avx2(long iters)
{
	FMA_LOOP(v4, 4)
}
__attribute__((target("avx512f"), optimize("O3"))) static double fma_avx512(long iters)
{
	FMA_LOOP(v8, 8)
}

static double gflops(double (*fn)(long), int lanes)
{
	long iters = 20000000;
	double r[REPS];
	volatile double sink = 0;
	for (int q = 0; q < REPS; q++) {
		double t0 = clock_of();
		sink += fn(iters);
		r[q] = 2.0 * CHAINS * lanes * (double)iters / (clock_of() - t0) / 1e9;
	}
	(void)sink;
	return median(r, REPS);
}

static void limits(void)
{
	clock_of = cpu_now;
	printf("| measurement | value |\n|---|---:|\n");
	const struct {
		const char *what;
		size_t bytes;
	} sizes[] = {{"copy, 256 KiB arrays (L2)", 256 << 10},
	             {"copy, 2 MiB arrays (L3, like level 6's state)", 2 << 20},
	             {"copy, 64 MiB arrays (DRAM)", 64 << 20}};
	for (int k = 0; k < 3; k++) {
		printf("| %s | %.1f GB/s |\n", sizes[k].what, bandwidth(sizes[k].bytes / 8, 0));
		printf("| triad%s | %.1f GB/s |\n", strchr(sizes[k].what, ','),
		       bandwidth(sizes[k].bytes / 8, 1));
	}
	__builtin_cpu_init();
	printf("| mul + add, SSE2 (2 doubles) | %.1f GFLOP/s |\n", gflops(fma_sse2, 2));
	if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"))
		printf("| FMA, AVX2 (4 doubles) | %.1f GFLOP/s |\n", gflops(fma_avx2, 4));
	if (__builtin_cpu_supports("avx512f"))
		printf("| FMA, AVX-512 (8 doubles) | %.1f GFLOP/s |\n", gflops(fma_avx512, 8));
}

/* The triad on 1 and on T threads: the same three arrays of n doubles,
 * thread i on its slice, reps sweeps each, wall time from the threads'
 * start to the last one's end (a thread per run: its start is small
 * beside a run of 0.1 s or more). */
typedef struct triad_slice {
	double *a, *b, *c;
	size_t n;
	long reps;
} triad_slice;

static void *triad_thread(void *arg)
{
	triad_slice *t = arg;
	for (long k = 0; k < t->reps; k++) {
		triad_avx2(t->a, t->b, t->c, t->n);
		__asm__ volatile("" ::"r"(t->a) : "memory");
	}
	return NULL;
}

static double triad_threads(double *a, double *b, double *c, size_t n, long reps, int T)
{
	pthread_t th[64];
	triad_slice sl[64];
	double t0 = now();
	for (int i = 0; i < T; i++) {
		size_t o = n * (size_t)i / (size_t)T, e = n * (size_t)(i + 1) / (size_t)T;
		sl[i] = (triad_slice){a + o, b + o, c + o, e - o, reps};
		if (i > 0 && pthread_create(&th[i], NULL, triad_thread, &sl[i])) {
			fprintf(stderr, "bench_simulate: cannot start a thread\n");
			exit(1);
		}
	}
	triad_thread(&sl[0]);
	for (int i = 1; i < T; i++)
		pthread_join(th[i], NULL);
	return 24.0 * (double)n * (double)reps / (now() - t0) / 1e9;
}

static void bandwidth_threads(int T)
{
	if (T < 2 || T > 64) {
		fprintf(stderr, "bench_simulate: bandwidth: %d threads: must be 2 to 64\n", T);
		exit(2);
	}
	printf("| three arrays of | like | 1 thread (GB/s) | %d threads (GB/s) | ratio |\n", T);
	printf("|---:|---|---:|---:|---:|\n");
	const struct {
		size_t bytes;
		const char *like;
	} sizes[] = {{768 << 10, "L2 of one core"},
	             {6 << 20, "level 7's state (7.3 MiB)"},
	             {24 << 20, "level 8's state (29 MiB)"},
	             {96 << 20, "level 9's (117 MiB)"},
	             {384 << 20, "level 10's (467 MiB)"}};
	for (int k = 0; k < 5; k++) {
		size_t n = sizes[k].bytes / 24;
		double *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b), *c = malloc(n * sizeof *c);
		if (!a || !b || !c) {
			fprintf(stderr, "bench_simulate: out of memory\n");
			exit(1);
		}
		for (size_t i = 0; i < n; i++)
			a[i] = (double)i, b[i] = 0, c[i] = 1;
		long reps = (long)(3e8 / (double)n) + 1;
		triad_threads(a, b, c, n, reps, 1), triad_threads(a, b, c, n, reps, T);
		double r1[REPS], rT[REPS], q[REPS];
		for (int r = 0; r < REPS; r++) {
			r1[r] = triad_threads(a, b, c, n, reps, 1);
			rT[r] = triad_threads(a, b, c, n, reps, T);
			q[r] = rT[r] / r1[r];
		}
		printf("| %.2f MiB | %s | %.1f | %.1f | %.2f |\n", (double)sizes[k].bytes / 1048576.0,
		       sizes[k].like, median(r1, REPS), median(rT, REPS), median(q, REPS));
		fflush(stdout);
		free(a), free(b), free(c);
	}
}

/* The fused RK4 pass per node and stage (integrate.c, rk4_interior), with
 * forces: stencil 3 × (6 sub + 6 mul + 5 add) = 51, acceleration 3 × 4 =
 * 12, stage update 3 × 8 = 24 (the middle stages; the first 3 × 4 + the
 * diagnostics ≈ 24, the last 3 × 6): 87 + 87 + 87 + 81 ≈ 342 flops per
 * node-step.  Memory: each pass reads the stage displacement, velocity,
 * the state, the two running sums (6 × 3 planes), three edge planes,
 * 1/m, γ and the force (3 planes) and writes 4 × 3 planes: 29 + 12 = 41
 * doubles, 328 bytes per node and stage, 1312 per node-step.  (γ is now
 * one number, and the pipeline skips the force plane in chunks without
 * force nodes: most of the thesis scene's rows stream 37; the count stays
 * 41 so that the figures compare with the earlier runs.) */
#define RK4_FLOPS 342.0
#define RK4_BYTES 1312.0

static void kernel(int argc, char **argv)
{
	clock_of = cpu_now;
	printf("| level | nodes | state (MiB) | steps/s | GFLOP/s | GB/s |\n");
	printf("|---:|---:|---:|---:|---:|---:|\n");
	for (int a = 0; a < argc; a++) {
		int level = atoi(argv[a]);
		ndo_grid *g;
		ndo_shape_make("wavy", level, NULL, &g);
		ndo_force *forces;
		ndo_sim *s = thesis_scene(g, NDO_RK4, &forces);
		ndo_critical c;
		ndo_sim_critical(s, &c);
		double sps = steps_per_second(s, 0.5 * c.h_crit);
		double n = (double)g->count;
		printf("| %d | %zu | %.2f | %.4g | %.2f | %.1f |\n", level, ndo_vertex_count(level),
		       n * 29 * 8 / 1048576.0, sps, sps * n * RK4_FLOPS / 1e9, sps * n * RK4_BYTES / 1e9);
		ndo_sim_destroy(s);
		ndo_scene_forces_free(forces, 1);
		ndo_grid_destroy(g);
	}
}

int main(int argc, char **argv)
{
	if (argc >= 2 && strcmp(argv[1], "speed") == 0)
		speed(argc - 2, argv + 2);
	else if (argc >= 2 && strcmp(argv[1], "limits") == 0)
		limits();
	else if (argc >= 2 && strcmp(argv[1], "kernel") == 0)
		kernel(argc - 2, argv + 2);
	else if (argc >= 4 && strcmp(argv[1], "threads") == 0)
		threads(argc - 2, argv + 2);
	else if (argc >= 4 && strcmp(argv[1], "pipeline") == 0)
		pipeline(argc - 2, argv + 2, (const ndo_method[]){NDO_RK4}, 1, "pipeline", 0);
	else if (argc >= 4 && strcmp(argv[1], "fused") == 0)
		pipeline(argc - 2, argv + 2, (const ndo_method[]){NDO_SYMPLECTIC_EULER, NDO_MIDPOINT}, 2,
		         "fused", 0);
	else if (argc >= 4 && strcmp(argv[1], "wave") == 0)
		pipeline(argc - 2, argv + 2,
		         (const ndo_method[]){NDO_SYMPLECTIC_EULER, NDO_MIDPOINT, NDO_RK4}, 3,
		         "ndo_sim_steps", 1);
	else if (argc == 3 && strcmp(argv[1], "bandwidth") == 0)
		bandwidth_threads(atoi(argv[2]));
	else if (argc >= 3 && strcmp(argv[1], "region") == 0)
		region(argc - 2, argv + 2);
	else {
		fprintf(stderr, "usage: bench_simulate speed|kernel|region [METHOD] LEVEL... | "
		                "threads|pipeline|fused|wave T LEVEL... | bandwidth T | limits\n");
		return 2;
	}
	return 0;
}
