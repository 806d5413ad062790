/* ndo/accuracy.h — how far a simulation is from the truth, and the
 * cheapest simulation that meets a stated error (issue 18;
 * docs/simulate-peer.md, "How accurate a run is" and "Asking for an
 * accuracy").
 *
 * Errors are the largest position error over the nodes at the end of the
 * run, in metres, and relative to the run's *largest displacement*: the
 * largest |x − X| over the nodes and over the run (sampled at least 64
 * times and at the end).  Two parts:
 *
 *   time   the integrator's error at the run's step: the larger of two
 *          Richardson estimates.  Early, at the run's own level, on a
 *          window — the run's first eighth (at least 16 steps; all of a
 *          shorter run) at h and at h/2, compared at the window's middle
 *          and end, d = |u_h − u_h/2| / (1 − 2^−p), p the method's order:
 *          it sees the top modes only level n has (RK4 at its largest step
 *          damps them, most of its error there).  Over the whole run, one
 *          level coarser: level n−1 at twice the step against the space
 *          companion below, e = |u_2h − u_h| / (2^p − 1) (at half the step
 *          when twice is beyond level n−1's critical step): the error that
 *          grows with time (a phase error) in the motion every level
 *          carries.  Either alone missed: the coarse one RK4's top modes
 *          (0.08–0.5× the truth), the window carried to the end by its
 *          growth a slowly forced scene (6×; docs/simulate-peer.md).
 *          Symplectic Euler damps no mode: the coarse estimate alone, at
 *          order 1.5 (a bounded first-order offset and a growing
 *          second-order phase error; conjugate to a second-order method).
 *          rkf45: the window at its tolerance and a hundredth of it,
 *          carried to the end by the growth between the two comparisons,
 *          d ∝ t^g with g in [0, 1].
 *   space  the discretisation's error at the run's level n: the same scene
 *          and the same integrator and step at level n−1 (inputs
 *          restricted from level n: every other node, ndo/restrict.h),
 *          compared after butterfly subdivision:  D_n = |u_n − S u_{n−1}|
 *          and e_n = D_n / (r − 1), r = 4 (the error falls by r per level,
 *          so u_{n−1} − u_n = e_{n−1} − e_n = (r − 1) e_n; linear elements
 *          converge at second order in the mesh size, which halves per
 *          level).  The ratio observed between coarse levels is
 *          pre-asymptotic (2 to 2.4 from levels 3-5 on the thesis scenes)
 *          and made worse estimates; the benchmark measures both.
 *
 * The estimates cost 3/8 (the window) + 1/4 (level n−1 at h) + 1/8 (at
 * 2h) of the run's node-steps for runs of 128 steps or more (the
 * window's 16 steps make it more for shorter runs; symplectic Euler has
 * no window), and once per level and method level n−1's critical step
 * (a power iteration and ndo_stable_step's scan of the modes: 0.3–0.4 ms
 * for RK4 and symplectic Euler since the scan is strided, 2–4 ms before).
 *
 * A scene is ndo_scene settings over an input at some level; coarser
 * levels restrict the input (positions, velocities, rest shape, pins) and
 * resolve the forces anew (a total force spread by area, so the load is
 * the same at every level).  Forces selected by face or node ids exist
 * only at the input level: then nothing coarser is available
 * (NDO_EINVAL). */
#ifndef NDO_ACCURACY_H
#define NDO_ACCURACY_H

#include <stdint.h>

#include "ndo/scene.h"
#include "ndo/sim.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ndo_acc ndo_acc;

/* The scene `sc` (forces, material, integrator settings; its pins are
 * taken from `pin`, already resolved) over a level-`level` input: x, v
 * (NULL: at rest), rest, pin (NULL: none), H × W × 3 doubles and H × W
 * bytes, copied; time starts at t0.  NDO_ENOMEM. */
int ndo_acc_create(const ndo_scene *sc, int level, const double *x, const double *v,
                   const double *rest, const uint8_t *pin, double t0, ndo_acc **out);
void ndo_acc_destroy(ndo_acc *a);
int ndo_acc_level(const ndo_acc *a);
/* The rest shape at `level` (≤ the input's; restricted on first use),
 * H × W × 3 doubles owned by a; NULL when out of memory or range. */
const double *ndo_acc_rest(ndo_acc *a, int level);

/* The top mode of `level` (ω_max, rad/s, and its damping rate γ, 1/s;
 * ndo_critical's omega_max and gamma), when the caller has it already:
 * ndo_acc_choose then runs no power iteration there (at the input's level
 * it would be a second simulation of the input's size beside the
 * caller's).  Ignored unless omega_max > 0. */
void ndo_acc_set_critical(ndo_acc *a, int level, double omega_max, double gamma);
/* The most bytes the estimate may have in use beside the run's own
 * simulation (0, the default: what the kernel reports free when it
 * runs): the time window's companion, a second simulation of the run's
 * size, is not run when the two together would exceed it (simulate-peer
 * --max-memory). */
void ndo_acc_set_max_memory(ndo_acc *a, size_t bytes);
/* The threads the estimate may use (1, the default, or more): with two or
 * more, ndo_acc_estimate_run runs its time window (at the run's level)
 * on a thread of its own beside the companions one level coarser, or,
 * without a window (symplectic Euler), those two companions side by side,
 * when both parts fit in the memory at once; the same estimate either
 * way. */
void ndo_acc_set_threads(ndo_acc *a, int threads);

/* One configuration: level (≤ the input's), method, step h and steps
 * (rkf45: the output interval; tol its tolerance). */
typedef struct ndo_acc_config {
	int level;
	ndo_method method;
	double h;
	int64_t steps;
	double tol;
} ndo_acc_config;

/* A simulation of the scene at `level` with `method` (and tol), at the
 * input's time.  NDO_EINVAL when level is coarser than the input and the
 * forces are given by ids; errors of ndo_sim_create. */
int ndo_acc_sim(ndo_acc *a, int level, ndo_method method, double tol, ndo_sim **out);

/* The largest displacement of a run, sampled: call ndo_acc_sample after
 * steps (as often as wanted), read it with ndo_acc_sampled; reset with
 * ndo_acc_sample_reset.  Uses the sim's level's rest shape. */
void ndo_acc_sample_reset(ndo_acc *a);
void ndo_acc_sample(ndo_acc *a, const ndo_sim *s);
double ndo_acc_sampled(const ndo_acc *a);

/* Run a configuration to its end.  u: the final displacement at the
 * configuration's level (H × W × 3 doubles, owned by the result; free
 * with ndo_acc_result_free); umax: the largest displacement (64 samples
 * and the end); cpu: CPU seconds; node_evals: force evaluations × the
 * level's vertices.  NDO_EDIVERGED when it diverged. */
typedef struct ndo_acc_result {
	double *u;
	double umax;
	double cpu;
	double node_evals;
} ndo_acc_result;
int ndo_acc_run(ndo_acc *a, const ndo_acc_config *c, ndo_acc_result *r);
void ndo_acc_result_free(ndo_acc_result *r);

/* The final displacement of a simulation of this scene (sim's level;
 * H × W × 3 doubles into u). */
void ndo_acc_displacement(const ndo_acc *a, const ndo_sim *s, double *u);

/* Subdivide a level-`from` displacement (or velocity) field u to level
 * `to` ≥ from (butterfly, Zorin corners); *out: H × W × 3 doubles at
 * `to`, malloc'd (the caller frees).  NDO_ENOMEM. */
int ndo_acc_prolong(int from, int to, const double *u, double **out);

/* The largest node distance between two level-`level` fields, m. */
double ndo_acc_distance(int level, const double *a, const double *b);

/* The errors of a run of configuration c whose final displacement is u
 * (at c->level) and largest displacement umax.  NaN parts were not
 * estimated (level 0, a companion diverged, forces by ids, a run of no
 * steps): `why` says which.  cpu: what estimating cost (CPU s);
 * node_evals: the companion runs' force evaluations × vertices. */
typedef struct ndo_acc_estimate {
	double time_m, space_m; /* m */
	double total_m;         /* the two together, m: the largest node's
	                         * |time + space| as fields where the time error
	                         * is the coarse companion's, else their sum */
	double umax;            /* the largest displacement, m */
	double rate;            /* r used for the space error (4) */
	double cpu, node_evals;
	char time_how[192];     /* how the time error was estimated */
	char why[160];          /* what was not estimated, and why ("" if all was) */
} ndo_acc_estimate;
int ndo_acc_estimate_run(ndo_acc *a, const ndo_acc_config *c, const double *u, double umax,
                         ndo_acc_estimate *e);

/* The same estimate in two calls, its companion runs (they need nothing
 * of the run) beside the caller's run: _begin starts them on a thread of
 * their own when ndo_acc_set_threads gave 2 or more (the run keeps one;
 * with 3 or more they also go side by side as above), and returns;
 * _end(c, u, umax) waits for them and compares — the same figures as
 * ndo_acc_estimate_run, which _end does itself when nothing was begun for
 * c.  cpu counts the companions' threads only.  _cancel stops them
 * (within a step) and drops what they made; ndo_acc_destroy cancels. */
int ndo_acc_estimate_begin(ndo_acc *a, const ndo_acc_config *c);
int ndo_acc_estimate_end(ndo_acc *a, const ndo_acc_config *c, const double *u, double umax,
                         ndo_acc_estimate *e);
void ndo_acc_estimate_cancel(ndo_acc *a);

/* The predicted CPU seconds of `steps` steps of `method` at `level` of
 * this scene: a count of work, not a measurement (the same every time, on
 * any load), steps × (A + B × vertices + C × integrated vertices — the
 * unpinned ones, the only ones a step updates), with constants per method
 * measured once (lib/sim/accuracy.c; bench_accuracy cost).  Symplectic
 * Euler and RK4, ndo_acc_choose's candidates, only: NaN for the others
 * and on failure (out of memory). */
double ndo_acc_work(ndo_acc *a, int level, ndo_method method, int64_t steps);
/* The integrated (unpinned, distinct) vertices at `level`; -1 on failure. */
double ndo_acc_active(ndo_acc *a, int level);

/* The order of the method's error (rkf45: 5). */
int ndo_method_order(ndo_method m);

/* --accuracy: the configuration that meets `target` — relative to the
 * largest displacement (metres = 0) or in metres — at the least predicted
 * cost, for a run of `duration` seconds.  Candidates: every level from
 * the first pilot's (below) to the input's, and the two methods that
 * dominate the work-precision diagram of the membrane (symplectic Euler
 * for rough answers, RK4 otherwise), each at its largest stable step
 * (0.9 × critical) or the step whose predicted time error fits.
 *
 * The prediction: pilots run the scene with RK4 at half its critical step
 * at levels from 2 up (an input at level 2 or 3: at levels n − 2 and
 * n − 1), each one level finer, until a level one above the last pilot is
 * predicted to suffice or the next pilot would be the input level
 * itself; the last two pilots' difference gives the space error of
 * every level as above (by r = 4 per level), the last one the largest
 * displacement.  At the last pilot level, RK4 and symplectic Euler at
 * 0.9 × their critical steps against the pilot give each method's error
 * constant C in e = C h^p.  The cost is counted, not timed
 * (ndo_acc_work: steps × a per-method constant per step, per vertex and
 * per integrated vertex), so the same scene, duration and target give the
 * same choice on any load.  A
 * configuration meets the target when e_space + e_time ≤ margin × target
 * (margin 0.7 at the pilots' levels, measured, 0.5 above them: what the
 * estimates' spread on the benchmark's scenes needs for 90%); at the
 * input's level only, a space error over that share but under the target
 * leaves the time error half of what is left.  When no level up to the
 * input's meets it — the input level's predicted space error alone is
 * above the target — *choice gets reachable = 0, the input level's
 * predicted error (best_m) and the level that would meet it
 * (level_needed, by r per level), and nothing runs.
 * The pilots and measured runs go without the energy test (at most 0.9 ×
 * a critical step, where a linear scene cannot diverge), the NaN/Inf and
 * size tests kept; a measured run that still diverges takes its method
 * out at its level (and above the pilots, when it is the top's).
 * NDO_EINVAL: target ≤ 0, or relative target ≥ 1, or a relative target
 * when nothing moves in the pilots (umax 0); NDO_EDIVERGED: a pilot
 * diverged, or no candidate was left (the detail names the run); errors
 * of the pilots. */
typedef struct ndo_acc_choice {
	ndo_acc_config c;
	double target_m;        /* the target in metres */
	double umax;            /* predicted largest displacement, m */
	double time_m, space_m; /* predicted errors, m */
	double error_m;         /* predicted error, m: time_m + space_m, or at levels up
	                           to the pilots' measured against their extrapolation */
	double cpu;             /* predicted CPU seconds of the run (ndo_acc_work: counted
	                           work, the same on any load) */
	double node_evals;      /* predicted force evaluations × vertices */
	double pilot_cpu;       /* what choosing cost (pilots, critical steps), CPU s
	                           (every thread's) */
	double pilot_wall;      /* ... and its wall time, s: with ndo_acc_set_threads
	                           ≥ 2 each level's two measured runs go beside its
	                           pilot */
	int pilot_top;          /* the finest pilot level */
	int critical_top;       /* the finest level whose critical step was computed:
	                           finer ones cannot beat the choice even at twice the
	                           coarser level's step (the cost of a power iteration
	                           at the input level is saved) */
	double rate;            /* r per level (4) */
	int reachable;
	double best_m;          /* the input level's predicted space error, m */
	int level_needed;
	double level_m[NDO_MAX_LEVEL + 1]; /* each level's predicted space error, m:
	                           measured against u* up to pilot_top, r per level
	                           above; INFINITY below the first pilot and above
	                           the input's level */
} ndo_acc_choice;
int ndo_acc_choose(ndo_acc *a, double target, int metres, double duration, ndo_acc_choice *ch);

#ifdef __cplusplus
}
#endif
#endif
