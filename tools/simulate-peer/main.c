/* simulate-peer — simulate the uniform-tension membrane on a grid (thesis
 * §4.3, appendix B).  The physics is the library's: ndo/sim.h (integrators,
 * critical step), ndo/membrane.h (K, M), ndo/scene.h (settings).  This file
 * reads the settings, reports the critical step, runs the steps and writes
 * frames, the CSV log and the result. */
#include "simulate.h"

#include <getopt.h>
#include <signal.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

/* SIGINT or SIGTERM: stop after the current step, keep the log, write no
 * output and leave no temporary file behind. */
static volatile sig_atomic_t interrupted;
static void on_signal(int sig)
{
	interrupted = sig;
}

static __attribute__((noreturn)) void usage(void)
{
	printf(
	    "Usage: %s [options] [IN.tgrid]\n"
	    "       %s --owner [options] [peer options] [IN.tgrid]\n"
	    "       %s --join [--poi FACE] [peer options] [-o OUT] [--frames P] [--log F]\n"
	    "Simulate a uniform-tension membrane on a grid: M v' = -B v - K (x - X) + f.\n"
	    "Reads IN (default: standard input), writes the final grid with velocities\n"
	    "to OUT (default: standard output).  Prints the critical step before running.\n"
	    "\n"
	    "  -s, --scene FILE        settings from a scene file (lines 'option value');\n"
	    "                          options on the command line override it\n"
	    "  -i, --integrator NAME   euler, symplectic-euler, midpoint, rk4 (default),\n"
	    "                          rkf45, backward-euler, trapezoid\n"
	    "      --dt H|auto         step in seconds, (0, 1e6]; auto (default): the\n"
	    "                          dt-safety fraction of the critical step\n"
	    "      --dt-safety F       fraction of the critical step for --dt auto, (0, 1]\n"
	    "                          (default 0.9)\n"
	    "  -n, --steps N           steps to take, 0..1e12 (default 100)\n"
	    "  -t, --time T            or simulated seconds, (0, 1e9]: N = ceil(T/H) steps\n"
	    "                          of T/N\n"
	    "      --tol TOL           rkf45 error tolerance per sub-step, [1e-14, 0.1]\n"
	    "                          (default 1e-6; metres and m/s)\n"
	    "      --solver S          the implicit methods' linear solver: multigrid\n"
	    "                          (conjugate gradients with a V-cycle on the grid's\n"
	    "                          levels, to a relative residual of 1e-12), cholmod\n"
	    "                          (a sparse Cholesky factor) or auto (default:\n"
	    "                          multigrid from level 6 up, cholmod below)\n"
	    "  -k, --stiffness K       membrane tension sigma in N/m, (0, 1e12] (default 1)\n"
	    "      --density RHO       areal density in kg/m^2, (0, 1e12] (default 1)\n"
	    "  -b, --damping B         viscous damping per unit area in N s/m^3 (B_ii = B x\n"
	    "                          node area), [0, 1e12]\n"
	    "                          (default 0.1, the thesis' b)\n"
	    "      --mass-damping A    mass-proportional damping B += A M, 1/s, [0, 1e12]\n"
	    "                          (default 0)\n"
	    "      --rest FILE         rest shape from another grid of the same level\n"
	    "                          (default: the input's rest channel, else its positions)\n"
	    "      --restiffen S       re-assemble K from the deformed shape every S steps,\n"
	    "                          0..1e9 (default 0: never)\n"
	    "      --pin SEL           pin nodes: nodes=I:J,..  faces=T,..  at=X,Y,Z\n"
	    "                          [radius=R] (repeatable; adds to the pin channel)\n"
	    "      --pins MODE         project (default: pinned nodes never move) or\n"
	    "                          penalty (Payne-Irons springs, thesis 4.3.3)\n"
	    "      --penalty ALPHA     penalty spring in N/m, (0, 1e15] (default 1000 x the\n"
	    "                          largest diagonal entry of K)\n"
	    "      --force SPEC        KIND key=value..: KIND face, point or pressure;\n"
	    "                          faces=T,.. nodes=I:J,.. at=X,Y,Z radius=R\n"
	    "                          amplitude=A (N; Pa) frequency=F (Hz) phase=DEG\n"
	    "                          direction=normal|X,Y,Z (repeatable)\n"
	    "  -o, --output OUT        the final grid (.tgrid, '-') or a mesh (.obj .ply\n"
	    "                          .stl .glb .gltf)\n"
	    "      --frames PATTERN    write frames, e.g. 'out/f%%05d.tgrid' (frame 0 is\n"
	    "                          the initial state; out/ is made when missing)\n"
	    "      --frame-every N     a frame every N steps, 1..1e12 (default 1)\n"
	    "      --log FILE          CSV log: step, time, step size, energies, input\n"
	    "                          work, max displacement, rkf45 sub-steps ('-':\n"
	    "                          standard output, with -o FILE)\n"
	    "      --log-every N       a log row every N steps, 1..1e12 (default 1)\n"
	    "      --perturb A         add a seeded random displacement of up to A metres\n"
	    "                          per coordinate, [0, 1e6] (default 0)\n"
	    "      --seed S            seed for --perturb (default 0)\n"
	    "      --energy-bound F    diverged when the energy exceeds F x (initial energy\n"
	    "                          + input work), [0, 1e12] (default 10; 0: off;\n"
	    "                          with --accuracy: off unless given)\n"
	    "      --max-memory SIZE   refuse a run that needs more, before it allocates\n"
	    "                          (bytes, or with k, M, G, T; default: the memory\n"
	    "                          available now); the error estimate's time window\n"
	    "                          is left out when it and the run exceed SIZE\n"
	    "      --threads N         threads a step runs on, 1..the processors this\n"
	    "                          process may use (default: all of them alone, 1 as a\n"
	    "                          peer); the same result for every N; grids under\n"
	    "                          20,000 nodes (level 6 and below) run on one\n"
	    "                          thread, and steps run alone while the threads do\n"
	    "                          not pay (timed every few seconds); 2 or more:\n"
	    "                          the error estimate's runs beside a run on one\n"
	    "                          thread, else after it with its two parts side\n"
	    "                          by side, and --accuracy's measured runs beside\n"
	    "                          its pilots\n"
	    "      --accuracy E[m]     choose the level (up to the input's), integrator\n"
	    "                          and step that meet the error E at the least\n"
	    "                          predicted cost: E a share of the largest\n"
	    "                          displacement, (0, 1), or with 'm' metres; prints\n"
	    "                          the choice, refuses (exit 2) an E the input's level\n"
	    "                          cannot reach; for -t T (or the scene's time), not\n"
	    "                          with -i, --dt, --dt-safety or -n (a scene's are\n"
	    "                          ignored).  Every single-process run not\n"
	    "                          --quiet ends with its estimated time and space\n"
	    "                          errors (also in --log; a peer's run does not)\n"
	    "      --no-estimate       a single process: no error estimate (its runs\n"
	    "                          cost up to 3/4 of the run's node-steps, more\n"
	    "                          under 128 steps, beside it on another core when\n"
	    "                          the run has one thread)\n"
	    "      --sleep D[m]        tiles of 32x32 nodes with no force, whose nodes\n"
	    "                          move less than D metres from rest (and |v| <\n"
	    "                          D/(8 dt)) and whose neighbours are as still, are\n"
	    "                          not stepped until a neighbour moves (euler,\n"
	    "                          symplectic-euler, midpoint, rk4; a single process);\n"
	    "                          0: off (default; with --accuracy E, E/10)\n"
	    "      --info              print the setup and the critical step (with\n"
	    "                          --accuracy: the choice), then exit\n"
	    "  -q, --quiet             print nothing but errors\n"
	    "Peers (several processes simulate one surface over LCM; docs/peers.md):\n"
	    "      --owner             create the object from IN and own it; -o writes the\n"
	    "                          whole object with an owner channel\n"
	    "      --join              join the object on the channel (physics, step and\n"
	    "                          clock come from the owner; no input, -o optional)\n"
	    "      --poi FACE          ask for a share of the work around this triangle\n"
	    "                          (joiner without: observe)\n"
	    "      --peers N           owner: start when N peers simulate, 1..8 (default 1)\n"
	    "      --clock MODE        owner: lockstep (default) or realtime (on the wall\n"
	    "                          clock; euler, symplectic-euler, midpoint and rk4\n"
	    "                          roll back and recompute when a halo differs from\n"
	    "                          what a step used, and end on the lock-step result)\n"
	    "      --speed X           owner, realtime: simulated s per wall s (default 1)\n"
	    "      --boundary MODE     owner: exact (the default: halos exchanged, the\n"
	    "                          single process's result: bit for bit, and\n"
	    "                          backward-euler and trapezoid solved over the\n"
	    "                          peers to the solve's tolerance; realtime rkf45,\n"
	    "                          backward-euler and trapezoid need extrapolate\n"
	    "                          or hold: they do not roll back),\n"
	    "                          extrapolate or hold (the thesis' lag)\n"
	    "      --halo-steps K      owner: steps per halo exchange, 1..1000\n"
	    "                          (default 1; wider halos, fewer round trips; rkf45\n"
	    "                          and the implicit methods exchange within each step)\n"
	    "      --publish-every N   owner: whole regions every N steps for\n"
	    "                          observers and render-frame (0: only the first\n"
	    "                          and last step), or every T seconds of\n"
	    "                          simulated time with Ts (e.g. 0.04s: 25 Hz; the\n"
	    "                          nearest whole number of steps, at least 1)\n"
	    "                          (default: --publish-rate 30, at least 10 steps,\n"
	    "                          at most about 100 MB a second)\n"
	    "      --publish-rate R    owner: whole regions at most about R times a\n"
	    "                          second of wall time, 1e-6..1e6: every N steps, N\n"
	    "                          fixed at the start from the run's predicted\n"
	    "                          speed (a count per node and method, the same on\n"
	    "                          any machine: docs/peers.md; realtime: --speed/dt)\n"
	    "      --checkpoint-every C\n"
	    "                          owner, lockstep (every method): every simulating\n"
	    "                          peer sends its region's exact state to the others\n"
	    "                          every C steps (default 20 up to level 4, doubling\n"
	    "                          a level to 160 from level 7; rounded up to a\n"
	    "                          multiple of --halo-steps; 0: none); a join, a\n"
	    "                          leave or a dropped peer restarts every peer from\n"
	    "                          the newest step the owner holds whole: the result\n"
	    "                          stays the single process's (0: not exact after\n"
	    "                          them, and the owner says NOT exact); a silent\n"
	    "                          owner is succeeded by the first joiner of its\n"
	    "                          partition, which restarts the others the same way\n"
	    "                          and writes its own -o\n"
	    "      --precondition P    lockstep backward-euler and trapezoid: this peer's\n"
	    "                          rows of the solve over the peers preconditioned\n"
	    "                          by the diagonal (default) or block (its region's\n"
	    "                          block, factored by CHOLMOD: fewer iterations,\n"
	    "                          each a block solve, slower from level 5)\n"
	    "      --send-level L      owner: whole-region state (observers, render-frame,\n"
	    "                          frames) travels at level L, 0..the simulated\n"
	    "                          level (default: the simulated level), every\n"
	    "                          2^k-th node, k levels below: frames are level L\n"
	    "                          (refine: subdivide, render-frame -k); halos and\n"
	    "                          the owner's -o stay exact\n"
	    "      --partition M       owner: bands (whole grid rows; the default from\n"
	    "                          level 3), quadtree (the default below), table41\n"
	    "                          or metis\n"
	    "      --encoding E        owner: state tiles raw (default), float32,\n"
	    "                          fixed[:BITS], predict[:BITS[:KEYFRAME]] or\n"
	    "                          hier[:BITS[:KEYFRAME]] (bits 1..24, default\n"
	    "                          13: error <= 6.1e-5 of the box's diagonal; or\n"
	    "                          instead of bits an error budget over the\n"
	    "                          diagonal, 1e-7..0.01, e.g. predict:1e-4;\n"
	    "                          keyframe 1..4096 steps, default 32)\n"
	    "      --step-timeout S    owner, lockstep: wait for a neighbour; realtime: the\n"
	    "                          most a peer may fall behind the wall clock\n"
	    "                          (default 0.5)\n"
	    "      --peer-timeout S    silence after which a peer is gone (default 2;\n"
	    "                          before the start --start-timeout: a joiner's\n"
	    "                          for the owner, the owner's for the joiners\n"
	    "                          until it has its --peers); a silent owner ends\n"
	    "                          the session before the run, and is succeeded\n"
	    "                          once it is under way (lockstep with checkpoints:\n"
	    "                          after the last step too, until it ended the\n"
	    "                          session); not counted while this peer's socket\n"
	    "                          overflowed; a peer outside the partition (an\n"
	    "                          observer, a joiner building its simulation)\n"
	    "                          may be silent for --start-timeout\n"
	    "      --start-timeout S   owner: for the --peers; joiner: for an object\n"
	    "                          (default 60)\n"
	    "      --gather-timeout S  owner: for the others' last step (default 10)\n"
	    "      --lcm URL           LCM provider (default: LCM_DEFAULT_URL, LCM's own)\n"
	    "      --channel PREFIX    channels PREFIX_* (default NDO)\n"
	    "      --name NAME         shown to the other peers\n"
	    "      --key FILE          the session key (64 hex digits, mode 600): every\n"
	    "                          message is authenticated and only peers with the\n"
	    "                          key take part (default: $NDO_KEY; none: anyone on\n"
	    "                          the network can join and write the state)\n"
	    "      --new-key FILE      write a new random key to FILE (never overwrites);\n"
	    "                          with --owner, use it; alone, write it and exit\n"
	    "      --drop P  --delay MS  --jitter MS  --reorder P  --fault-seed S\n"
	    "                          inject loss, delay and reordering into what this\n"
	    "                          peer receives\n"
	    "  -h, --help              show this help and exit\n"
	    "      --version           show the version and exit\n"
	    "\n"
	    "Exit status: 0 success, 1 bad input or failed write, 2 usage error,\n"
	    "3 the simulation diverged (the output grid is not written; frames and log\n"
	    "rows written before the divergence stay, all of finite states), 130\n"
	    "interrupted (SIGINT or SIGTERM: the same, after the current step); peers:\n"
	    "4 the session ended before the run completed (the owner quit or fell\n"
	    "silent, or the peers or the object did not come), 5 realtime: this peer\n"
	    "cannot keep the pace (it fell --step-timeout behind the wall clock, or its\n"
	    "window of unconfirmed steps is full).\n",
	    ndo_progname, ndo_progname, ndo_progname);
	ndo_close_stdout();
	exit(NDO_EXIT_OK);
}

static double now(void)
{
	struct timespec t;
	clock_gettime(CLOCK_MONOTONIC, &t);
	return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* ---- the run ------------------------------------------------------------- */

static void diverged(run *r)
{
	ndo_sim_stats st;
	ndo_sim_stats_get(r->sim, &st);
	char ratio[64] = "";
	if (isfinite(r->crit.h_crit) && r->crit.h_crit > 0)
		snprintf(ratio, sizeof ratio, " = %.3g x the critical step", r->dt / r->crit.h_crit);
	fprintf(stderr, "%s: diverged at step %lld (t = %.6g s, step %.4g s%s): %s; %s\n",
	        ndo_progname, (long long)ndo_sim_step_count(r->sim), ndo_sim_time(r->sim), r->dt,
	        ratio, ndo_errdetail(),
	        r->sc.output ? "the output was not written" : "nothing written to standard output");
	if (r->logging && ndo_out_commit(&r->log))
		ndo_warn("%s: %s", r->sc.log, ndo_errdetail());
	ndo_close_stdout();
	exit(EXIT_DIVERGED);
}

static void write_frame(run *r, int64_t k)
{
	if (ndo_sim_check(r->sim))
		diverged(r);
	char path[4096];
	int len = snprintf(path, sizeof path, r->sc.frames, (int)k);
	if (len < 0 || (size_t)len >= sizeof path)
		ndo_die("--frames: the path for frame %lld is too long", (long long)k);
	/* the pattern's directory is made, as a user of 'out/f%04d.tgrid' expects */
	if (ndo_mkdir_parents(path) || accuracy_store(r, r->frame) ||
	    ndo_grid_export(path, r->frame))
		ndo_die("%s: %s", path, ndo_errdetail());
}

static void progress(run *r, int64_t k, double t0)
{
	double el = now() - t0;
	fprintf(stderr, "\r%s: step %lld/%lld  t = %.4g s  %.0f steps/s\033[K", ndo_progname,
	        (long long)k, (long long)r->steps, ndo_sim_time(r->sim), el > 0 ? k / el : 0);
}

static void simulate(run *r)
{
	log_open(r);
	if (r->sc.frames) {
		if (ndo_grid_copy(r->g, &r->frame) ||
		    ndo_grid_add_history(r->frame, ndo_cli_argc(), ndo_cli_argv()))
			ndo_die("%s", ndo_errdetail());
	}
	int show = !r->quiet && isatty(STDERR_FILENO);
	int64_t frame = 0;
	double t0 = now(), shown = t0;
	struct sigaction sa = {0};
	sa.sa_handler = on_signal;
	sigaction(SIGINT, &sa, NULL);
	sigaction(SIGTERM, &sa, NULL);
	accuracy_begin(r);
	/* Between the steps that log, write a frame or sample the accuracy,
	 * the steps run with nothing between them: ndo_sim_steps (symplectic
	 * Euler, midpoint and rk4 then pipeline several steps; the same bits), at
	 * most 16 at a time so that interrupts and progress are seen, and as
	 * even calls (17 steps as 9 and 8, not 16 and 1): a single step costs
	 * more than a step of a run, and the threads' looks at whether they
	 * pay time the calls as they come (lib/sim/integrate.c). */
	for (int64_t k = 0;;) {
		accuracy_sample(r, k);
		if (r->logging && (k % r->sc.log_every == 0 || k == r->steps))
			log_row(r, r->sim, ndo_sim_step_count(r->sim));
		if (r->frame && k % r->sc.frame_every == 0)
			write_frame(r, frame++);
		if (show && now() - shown > 0.25) {
			shown = now();
			progress(r, k, t0);
		}
		if (k == r->steps)
			break;
		if (interrupted) {
			if (show)
				fputc('\n', stderr);
			if (r->logging && ndo_out_commit(&r->log))
				ndo_warn("%s: %s", r->sc.log, ndo_errdetail());
			fprintf(stderr, "%s: interrupted at step %lld (t = %.6g s); %s\n", ndo_progname,
			        (long long)ndo_sim_step_count(r->sim), ndo_sim_time(r->sim),
			        r->sc.output ? "the output was not written" : "nothing written to "
			                                                       "standard output");
			ndo_close_stdout();
			exit(EXIT_INTERRUPTED);
		}
		int64_t to = r->steps; /* the next event */
		if (r->logging && (k / r->sc.log_every + 1) * r->sc.log_every < to)
			to = (k / r->sc.log_every + 1) * r->sc.log_every;
		if (r->frame && (k / r->sc.frame_every + 1) * r->sc.frame_every < to)
			to = (k / r->sc.frame_every + 1) * r->sc.frame_every;
		if (accuracy_next(r, k) < to)
			to = accuracy_next(r, k);
		const int64_t calls = (to - k + 15) / 16;
		to = k + (to - k + calls - 1) / calls;
		int rc = ndo_sim_steps(r->sim, r->dt, to - k);
		if (rc) {
			if (show)
				fputc('\n', stderr);
			if (rc != NDO_EDIVERGED) /* out of memory: not the physics */
				ndo_die("step %lld: %s", (long long)ndo_sim_step_count(r->sim) + 1,
				        ndo_errdetail());
			diverged(r);
		}
		k = to;
	}
	double el = now() - t0;
	if (show)
		fprintf(stderr, "\r\033[K");
	if (ndo_sim_check(r->sim))
		diverged(r);
	accuracy_report(r);
	if (r->logging && ndo_out_commit(&r->log))
		ndo_die("%s: %s", r->sc.log, ndo_errdetail());
	r->logging = 0;
	if (!r->quiet) {
		ndo_sim_stats st;
		ndo_sim_stats_get(r->sim, &st);
		double sps = el > 0 ? (double)r->steps / el : 0;
		fprintf(stderr, "%s: %lld steps to t = %.6g s in %.3g s: %.4g steps/s, %.4g "
		        "node-steps/s", ndo_progname, (long long)r->steps, ndo_sim_time(r->sim), el,
		        sps, sps * (double)ndo_vertex_count(ndo_sim_level(r->sim)));
		if (ndo_sim_threads(r->sim) > 1)
			fprintf(stderr, " on %d threads (%.0f%% of the steps on one: where the threads did "
			        "not pay, and half of each look at whether they do)",
			        ndo_sim_threads(r->sim),
			        st.steps > 0 ? 100.0 * (double)st.steps_alone / (double)st.steps : 0.0);
		if (ndo_sim_method(r->sim) == NDO_RKF45)
			fprintf(stderr, "; %lld sub-steps, %lld rejected", (long long)st.substeps,
			        (long long)st.rejected);
		if (st.restiffened)
			fprintf(stderr, "; K re-assembled %lld times (%.3g s)", (long long)st.restiffened,
			        st.restiffen_seconds);
		fputc('\n', stderr);
		sleep_report(r);
	}
	accuracy_print();
}

static void finish(run *r)
{
	if (accuracy_store(r, r->g))
		ndo_die("%s", ndo_errdetail());
	if (r->pins) {
		ndo_channel *c;
		ndo_grid_remove(r->g, NDO_CH_PIN);
		if (ndo_grid_add(r->g, NDO_CH_PIN, NDO_U8, 1, &c))
			ndo_die("%s", ndo_errdetail());
		memcpy(c->data, r->pins, r->g->count);
	}
	ndo_cli_save(r->sc.output, r->g);
}

/* ---- options ------------------------------------------------------------------ */

/* Two names of one file: the same string, or the same existing file. */
static int same_file(const char *a, const char *b)
{
	if (!a || !b || ndo_is_stdio(a) || ndo_is_stdio(b))
		return 0;
	struct stat sa, sb;
	return strcmp(a, b) == 0 || (stat(a, &sa) == 0 && stat(b, &sb) == 0 &&
	                             sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino);
}

/* --log FILE, before the work (as -o is): a place it cannot be written
 * fails now, not after the setup, the critical step and --accuracy's
 * pilots; '-' beside a grid on standard output would put the CSV and the
 * binary grid in one stream; the file of -o, the input or the rest shape
 * would be replaced by the CSV (or replace it). */
static void check_log(run *r, int grid_out)
{
	const char *log = r->sc.log;
	if (ndo_is_stdio(log) && grid_out && ndo_is_stdio(r->sc.output))
		ndo_usage_error("--log -: the grid goes to standard output too; give -o FILE, or the "
		                "log a file");
	const char *other[] = {r->sc.output, r->in, r->sc.rest};
	const char *what[] = {"the output (-o)", "the input grid", "the rest grid (--rest)"};
	for (int k = 0; k < 3; k++)
		if (same_file(log, other[k]))
			ndo_usage_error("--log %s: that is %s", log, what[k]);
	ndo_cli_check_writable("--log", log);
}

static void options(run *r, int argc, char **argv)
{
	enum { OPT_INFO = 256, OPT_VERSION, OPT_SETTING, OPT_PEER, OPT_PEER_FLAG, OPT_THREADS,
	       OPT_MEMORY, OPT_ACCURACY, OPT_SLEEP, OPT_NO_ESTIMATE };
	static const struct option opts[] = {
		{"scene", required_argument, 0, 's'},
		{"integrator", required_argument, 0, 'i'},
		{"steps", required_argument, 0, 'n'},
		{"time", required_argument, 0, 't'},
		{"stiffness", required_argument, 0, 'k'},
		{"damping", required_argument, 0, 'b'},
		{"output", required_argument, 0, 'o'},
		{"dt", required_argument, 0, OPT_SETTING},
		{"dt-safety", required_argument, 0, OPT_SETTING},
		{"tol", required_argument, 0, OPT_SETTING},
		{"solver", required_argument, 0, OPT_SETTING},
		{"density", required_argument, 0, OPT_SETTING},
		{"mass-damping", required_argument, 0, OPT_SETTING},
		{"rest", required_argument, 0, OPT_SETTING},
		{"restiffen", required_argument, 0, OPT_SETTING},
		{"pin", required_argument, 0, OPT_SETTING},
		{"pins", required_argument, 0, OPT_SETTING},
		{"penalty", required_argument, 0, OPT_SETTING},
		{"force", required_argument, 0, OPT_SETTING},
		{"frames", required_argument, 0, OPT_SETTING},
		{"frame-every", required_argument, 0, OPT_SETTING},
		{"log", required_argument, 0, OPT_SETTING},
		{"log-every", required_argument, 0, OPT_SETTING},
		{"perturb", required_argument, 0, OPT_SETTING},
		{"seed", required_argument, 0, OPT_SETTING},
		{"energy-bound", required_argument, 0, OPT_SETTING},
		{"owner", no_argument, 0, OPT_PEER_FLAG},
		{"join", no_argument, 0, OPT_PEER_FLAG},
		{"poi", required_argument, 0, OPT_PEER},
		{"lcm", required_argument, 0, OPT_PEER},
		{"channel", required_argument, 0, OPT_PEER},
		{"name", required_argument, 0, OPT_PEER},
		{"partition", required_argument, 0, OPT_PEER},
		{"clock", required_argument, 0, OPT_PEER},
		{"speed", required_argument, 0, OPT_PEER},
		{"peers", required_argument, 0, OPT_PEER},
		{"boundary", required_argument, 0, OPT_PEER},
		{"halo-steps", required_argument, 0, OPT_PEER},
		{"publish-every", required_argument, 0, OPT_PEER},
		{"publish-rate", required_argument, 0, OPT_PEER},
		{"send-level", required_argument, 0, OPT_PEER},
		{"checkpoint-every", required_argument, 0, OPT_PEER},
		{"precondition", required_argument, 0, OPT_PEER},
		{"encoding", required_argument, 0, OPT_PEER},
		{"step-timeout", required_argument, 0, OPT_PEER},
		{"peer-timeout", required_argument, 0, OPT_PEER},
		{"start-timeout", required_argument, 0, OPT_PEER},
		{"gather-timeout", required_argument, 0, OPT_PEER},
		{"drop", required_argument, 0, OPT_PEER},
		{"delay", required_argument, 0, OPT_PEER},
		{"jitter", required_argument, 0, OPT_PEER},
		{"reorder", required_argument, 0, OPT_PEER},
		{"fault-seed", required_argument, 0, OPT_PEER},
		{"key", required_argument, 0, OPT_PEER},
		{"new-key", required_argument, 0, OPT_PEER},
		{"threads", required_argument, 0, OPT_THREADS},
		{"max-memory", required_argument, 0, OPT_MEMORY},
		{"accuracy", required_argument, 0, OPT_ACCURACY},
		{"sleep", required_argument, 0, OPT_SLEEP},
		{"no-estimate", no_argument, 0, OPT_NO_ESTIMATE},
		{"info", no_argument, 0, OPT_INFO},
		{"quiet", no_argument, 0, 'q'},
		{"help", no_argument, 0, 'h'},
		{"version", no_argument, 0, OPT_VERSION},
		{0, 0, 0, 0}};
	/* Settings are applied after the scene file, in order, so the
	 * command line wins wherever the two disagree. */
	const char **keys = r->keys = calloc((size_t)argc + 1, sizeof *keys),
	           **vals = r->vals = calloc((size_t)argc + 1, sizeof *vals);
	const char *scene = NULL;
	if (!keys || !vals)
		ndo_die("out of memory");
	int n = 0, c, idx;
	while ((c = getopt_long(argc, argv, ":s:i:n:t:k:b:o:qh", opts, &idx)) != -1) {
		switch (c) {
		case 's': scene = optarg; break;
		case 'i': keys[n] = "integrator", vals[n++] = optarg; break;
		case 'n': keys[n] = "steps", vals[n++] = optarg; break;
		case 't': keys[n] = "time", vals[n++] = optarg; break;
		case 'k': keys[n] = "stiffness", vals[n++] = optarg; break;
		case 'b': keys[n] = "damping", vals[n++] = optarg; break;
		case 'o': keys[n] = "output", vals[n++] = optarg; break;
		case OPT_SETTING:
			keys[n] = opts[idx].name, vals[n++] = optarg;
			r->energy_bound_set |= !strcmp(opts[idx].name, "energy-bound");
			break;
		case OPT_PEER:
		case OPT_PEER_FLAG: peer_option(&r->net, opts[idx].name, optarg); break;
		case OPT_THREADS: {
			char *end;
			long t = strtol(optarg, &end, 10);
			int most = ndo_cpu_count();
			if (end == optarg || *end || t < 1 || t > most)
				ndo_usage_error("--threads %s: give 1..%d (the processors this process may "
				                "run on)", optarg, most);
			r->threads = (int)t;
			break;
		}
		case OPT_MEMORY: {
			char *end;
			double b = strtod(optarg, &end);
			double unit = !*end ? 1 : !strcmp(end, "k") ? 1e3 : !strcmp(end, "M") ? 1e6
			            : !strcmp(end, "G") ? 1e9 : !strcmp(end, "T") ? 1e12 : 0;
			if (end == optarg || !(b * unit >= 1e3) || !(b * unit <= 1e15))
				ndo_usage_error("--max-memory %s: give bytes from 1k to 1000T (suffix k, M, G "
				                "or T)", optarg);
			r->max_memory = (size_t)(b * unit);
			break;
		}
		case OPT_ACCURACY: accuracy_option(r, optarg); break;
		case OPT_SLEEP: sleep_option(r, optarg); break;
		case OPT_NO_ESTIMATE: r->no_estimate = 1; break;
		case OPT_INFO: r->info = 1; break;
		case 'q': r->quiet = 1; break;
		case 'h': usage();
		case OPT_VERSION: ndo_print_version();
		default: ndo_bad_option(c);
		}
	}
	if (r->accuracy && r->net.role)
		ndo_usage_error("--accuracy: a single process only (not with --owner or --join)");
	/* --accuracy chooses the integrator and the step, so the steps too: a
	 * scene's are ignored (accuracy_plan), the command line's refused. */
	for (int k = 0; r->accuracy && k < n; k++)
		if (!strcmp(keys[k], "integrator") || !strcmp(keys[k], "dt") ||
		    !strcmp(keys[k], "dt-safety") || !strcmp(keys[k], "steps"))
			ndo_usage_error("--accuracy chooses the integrator and the step: not with --%s "
			                "(give the duration with -t)", keys[k]);
	if (r->sleep > 0 && r->net.role)
		ndo_usage_error("--sleep: a single process only (not with --owner or --join)");
	if (r->no_estimate && r->net.role)
		ndo_usage_error("--no-estimate: a single process only (a peer makes none)");
	if (r->no_estimate && r->accuracy)
		ndo_usage_error("--no-estimate: not with --accuracy (it reports the error achieved)");
	if (optind + 1 < argc)
		ndo_usage_error("more than one input: '%s'", argv[optind + 1]);
	r->in = optind < argc ? argv[optind] : NULL;
	peer_check(&r->net, scene, r->in, n, keys);
	if (scene && ndo_scene_load(&r->sc, scene))
		ndo_die("%s", ndo_errdetail());
	for (int k = 0; k < n; k++)
		if (ndo_scene_set(&r->sc, keys[k], vals[k]))
			ndo_usage_error("--%s", ndo_errdetail());
	free(keys);
	free(vals);
	r->keys = r->vals = NULL;
	if (r->accuracy && !(r->sc.duration > 0))
		ndo_usage_error("--accuracy: no duration: give -t T (or 'time T' in the scene)");
	if (r->net.role != NDO_ROLE_JOINER && ndo_is_stdio(r->in) && isatty(STDIN_FILENO))
		ndo_usage_error("no input: give a grid file or pipe one in");
	/* One grid on standard input: the input's, unless a file is given
	 * (the rest grid read after it found nothing: "empty input"). */
	if (r->sc.rest && ndo_is_stdio(r->sc.rest) && ndo_is_stdio(r->in) &&
	    r->net.role != NDO_ROLE_JOINER)
		ndo_usage_error("--rest -: standard input holds the input grid; give the input or "
		                "the rest grid as a file");
	int grid_out = r->net.role != NDO_ROLE_JOINER || r->sc.output;
	if (!r->info && grid_out)
		ndo_cli_check_output(r->sc.output);
	if (!r->info && r->sc.log)
		check_log(r, grid_out);
	if (r->sc.frames) {
		char probe[4096];
		int len = snprintf(probe, sizeof probe, r->sc.frames, 0);
		if (len < 0 || (size_t)len >= sizeof probe)
			ndo_usage_error("--frames: the path for frame 0 is too long");
		if (ndo_unknown_extension(probe))
			ndo_usage_error("--frames: %s: unknown extension (use .tgrid, .obj, .ply, .stl, "
			                ".glb or .gltf)", probe);
	}
}

int main(int argc, char **argv)
{
	ndo_cli_init(argc, argv);
	static run r;
	ndo_scene_init(&r.sc);
	peer_defaults(&r.net);
	options(&r, argc, argv);
	if (r.net.role)
		return peers_main(&r);
	setup(&r);
	plan(&r);
	accuracy_plan(&r);
	sleep_apply(&r);
	if (r.info) {
		ndo_close_stdout();
		return NDO_EXIT_OK;
	}
	simulate(&r);
	finish(&r);
	accuracy_free(&r);
	ndo_sim_destroy(r.sim);
	ndo_grid_destroy(r.frame);
	ndo_grid_destroy(r.g);
	free(r.pins);
	ndo_scene_free(&r.sc);
	ndo_close_stdout();
	return NDO_EXIT_OK;
}
