/* bench_peers — what splitting the surface among peers costs in accuracy,
 * in one process (the peers on an in-memory bus with a fake clock, so the
 * numbers do not depend on the machine): the thesis' figure-5.3 scene
 * against the single process.
 *
 *   bench_peers lag [-l LEVEL]       the one-step boundary lag in lock-step
 *                                    (h = 0.01, 0.005, 0.0025 s):
 *                                    error by method, step, boundary (held as
 *                                    in the thesis, or extrapolated) and peers
 *   bench_peers realtime [-l LEVEL]  free-running peers: error by network delay
 *   bench_peers split [-l LEVEL]     rkf45 and the implicit methods split
 *                                    exactly (docs/peers.md): difference
 *                                    (from a CHOLMOD single process),
 *                                    exchanges (rounds of messages) and bytes
 *                                    a step, rkf45's attempts, the solve's
 *                                    iterations with the region's block or
 *                                    the diagonal as the preconditioner
 */
#include "../unit/peer_world.h"

static double run_split(setup *su, int n, ndo_peer_stats *st)
{
	int ok;
	double d = split_run(su, n, st, &ok);
	return ok ? d : NAN;
}

static void lag(int level)
{
	static const char *methods[] = {"symplectic-euler", "midpoint", "rk4", "rkf45",
	                                "trapezoid"};
	/* level 6: symplectic Euler's critical step is 0.015 s, rk4's 0.021 s */
	static const double hs[] = {0.01, 0.005, 0.0025};
	printf("| method | h (s) | peers | boundary held (thesis) | boundary extrapolated |\n");
	printf("|---|---|---|---|---|\n");
	for (int m = 0; m < 5; m++)
		for (int k = 0; k < 3; k++)
			for (int n = 2; n <= 4; n += 2) {
				setup su = {.integrator = methods[m], .dt = hs[k],
				            .steps = (int64_t)(1.0 / hs[k] + 0.5),
				            .clock = NDO_CLOCK_LOCKSTEP, .peers = n, .level = level,
				            .extra = m == 3 ? "tol 1e-6" : NULL};
				ndo_peer_stats st;
				su.hold = 1;
				double held = run_split(&su, n, &st);
				su.hold = 0;
				double ext = run_split(&su, n, &st);
				printf("| %s | %g | %d | %.2e | %.2e |\n", methods[m], hs[k], n, held, ext);
				fflush(stdout);
			}
}

static void realtime(int level)
{
	static const double delays[] = {0, 2, 5, 10, 20, 40};
	printf("| delay (ms) | peers | error, extrapolated | mean lag (steps) | error, held |\n");
	printf("|---|---|---|---|---|\n");
	for (int k = 0; k < 6; k++)
		for (int n = 2; n <= 4; n += 2) {
			setup su = {.integrator = "rk4", .dt = 0.01, .steps = 100,
			            .clock = NDO_CLOCK_REALTIME, .peers = n, .level = level};
			su.faults = (ndo_faults){.delay_ms = delays[k], .seed = 1};
			ndo_peer_stats st;
			double ext = run_split(&su, n, &st);
			double lagm = st.steps ? st.lag_sum / (double)st.steps : 0;
			su.hold = 1;
			double held = run_split(&su, n, &st);
			printf("| %g | %d | %.2e | %.2f | %.2e |\n", delays[k], n, ext, lagm, held);
			fflush(stdout);
		}
}

static void split(int level)
{
	printf("| method | h (s) | peers | preconditioner | difference | exchanges a step | "
	       "halo kB a step (owner) | rkf45: attempts a step / solve: iterations a solve |\n");
	printf("|---|---|---|---|---|---|---|---|\n");
	static const char *methods[] = {"rkf45", "backward-euler", "trapezoid"};
	static const double hs[] = {0.02, 0.1};
	for (int m = 0; m < 3; m++)
		for (int k = 0; k < 2; k++)
			for (int n = 2; n <= 4; n += 2)
				for (int jac = 0; jac <= (m > 0); jac++) {
					setup su = {.integrator = methods[m], .dt = hs[k],
					            .steps = (int64_t)(1.0 / hs[k] + 0.5),
					            .clock = NDO_CLOCK_LOCKSTEP, .peers = n, .level = level,
					            .jacobi = jac,
					            .extra = m == 0 ? "tol 1e-6" : "solver cholmod"};
					ndo_peer_stats st;
					double d = run_split(&su, n, &st);
					double per = m ? (st.solves ? (double)st.iterations / (double)st.solves : 0)
					               : (double)st.attempts / (double)st.steps;
					printf("| %s | %g | %d | %s | %.2g | %.1f | %.1f | %.1f |\n", methods[m],
					       hs[k], n, m == 0 ? "" : jac ? "diagonal" : "region's block", d,
					       (double)st.exchanges / (double)st.steps,
					       (double)st.halo_bytes / 1e3 / (double)st.steps, per);
					fflush(stdout);
				}
}

int main(int argc, char **argv)
{
	int level = argc > 3 && strcmp(argv[2], "-l") == 0 ? atoi(argv[3]) : 5;
	if (argc > 1 && strcmp(argv[1], "lag") == 0)
		lag(level);
	else if (argc > 1 && strcmp(argv[1], "realtime") == 0)
		realtime(level);
	else if (argc > 1 && strcmp(argv[1], "split") == 0)
		split(level);
	else {
		fprintf(stderr, "usage: bench_peers lag|realtime|split [-l LEVEL]\n");
		return 2;
	}
	return 0;
}
