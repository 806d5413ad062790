/* bench_peers — what splitting the surface among peers costs in accuracy,
 * in one process (the peers on an in-memory bus with a fake clock, so the
 * numbers do not depend on the machine): the thesis' figure-5.3 scene
 * against the single process.
 *
 *   bench_peers lag [-l LEVEL]       the one-step boundary lag in lock-step
 *                                    (h = 0.01, 0.005, 0.0025 s):
 *                                    error by method, step, boundary (held as
 *                                    in the thesis, or extrapolated) and peers
 *   bench_peers realtime [-l LEVEL]  realtime peers that roll back, 3 peers\n *                                    by loss and delay: difference, rollbacks,\n *                                    recomputed steps, the frames' error
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

/* Realtime peers that roll back (docs/peers.md, "Realtime"): 3 peers, rk4
 * at 0.019 s (0.9 of its critical step at level 6), 2 s, by loss and
 * delay: the final difference, the rollbacks and recomputed steps, and
 * what the frames shown during the run (every 10 steps) differed from the
 * confirmed states, against the thesis' held boundary with the same
 * faults (no rollback). */
static void realtime(int level)
{
	/* the last: 20 ms with a halo exchange every 2 steps (38 ms) */
	static const double drops[] = {0, 0.05, 0.2}, delays[] = {0, 10, 20, 20};
	printf("| loss | delay (ms) | steps per exchange | difference | every step confirmed | rollbacks (3 peers) | "
	       "recomputed steps per step | deepest rollback (steps) | frames shown wrong | "
	       "shown error (of the largest displacement) | held boundary: difference |\n");
	printf("|---|---|---|---|---|---|---|---|---|---|---|\n");
	for (int a = 0; a < 3; a++)
		for (int b = 0; b < 4; b++) {
			setup su = {.integrator = "rk4", .dt = 0.019, .steps = 105,
			            .clock = NDO_CLOCK_REALTIME, .peers = 3, .level = level,
			            .halo_steps = b == 3 ? 2 : 1};
			su.faults = (ndo_faults){.drop = drops[a], .delay_ms = delays[b], .seed = 1};
			world *w = world_new();
			int rc = add_owner(w, &su);
			for (int i = 1; i < 3 && !rc; i++)
				rc = add_joiner(w, &su, POIS[i - 1] * (4 << (2 * level)) / 16384);
			int ok = !rc && run(w, 60) == 0;
			double *x = solo(&su);
			double d = ok ? difference(ndo_peer_grid(w->p[0]), x) : NAN;
			int64_t rolls = 0, recomputed = 0, steps = 0, depth = 0, wrong = 0, frames = 0;
			double err = 0, disp = 0;
			int confirmed = ok;
			for (int i = 0; i < w->n; i++) {
				ndo_peer_stats st;
				ndo_peer_stats_get(w->p[i], &st);
				confirmed &= st.confirmed && w->state[i] == NDO_PEER_DONE;
				rolls += st.rollbacks;
				recomputed += st.recomputed;
				steps += st.steps;
				depth = st.rollback_depth > depth ? st.rollback_depth : depth;
				wrong += st.shown_wrong;
				frames += st.shown_frames;
				err = fmax(err, st.shown_error);
				disp = fmax(disp, st.shown_disp);
			}
			free(x);
			world_free(w);
			su.hold = 1;
			ndo_peer_stats hs;
			double held = run_split(&su, 3, &hs);
			printf("| %g | %g | %d | %.2g | %s | %lld | %.2f | %lld | %lld of %lld | %.2e | %.2e |\n",
			       drops[a], delays[b], b == 3 ? 2 : 1, d, confirmed ? "yes" : "no", (long long)rolls,
			       steps ? (double)recomputed / (double)steps : 0.0, (long long)depth,
			       (long long)wrong, (long long)frames, disp > 0 ? err / disp : 0.0, held);
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
