/* ndo/sim.h — simulating the membrane: M v' = −B v − K (x − X) + f,
 * x' = v (thesis eq. 4.8–4.10, appendix B; DESIGN.md, "Physics"), with
 * every integrator behind one interface.
 *
 * Units: SI.  Positions in metres, time in seconds, stiffness σ in N/m
 * (the thesis' k), areal density ρ in kg/m², forces in N, pressure in Pa.
 *
 * The model:
 *   K   cotangent stiffness σ·L of the rest shape X (ndo/membrane.h),
 *       optionally re-assembled from the deformed shape every S steps;
 *   M   lumped mass, ρ × one third of the incident rest areas;
 *   B   damping, diagonal ("applied directly on the nodal velocities",
 *       thesis §4.3.1): the viscous force −b ∂u/∂t per unit area of
 *       appendix B (eq. B.12–B.14), lumped like the mass, B_ii = b·A_i
 *       (b in N·s/m³, A_i the node's third of its triangles' area), plus
 *       optional mass-proportional damping B += a·M (a in 1/s).  With a
 *       uniform density the two are the same thing: every mode decays at
 *       the rate γ = b/ρ + a.  (A per-node constant B_ii = b, the other
 *       reading of the thesis, would damp 4× harder at each finer level:
 *       the same scene would be a different system at every level.)
 *   f   external forces (struct ndo_force) and, for pins held by penalty,
 *       the penalty springs.
 * The state is integrated as the displacement u = x − X and the velocity
 * v, both as three H × W planes ("structure of arrays").  Stored duplicate
 * nodes are one degree of freedom: only canonical nodes are integrated and
 * every duplicate is a bitwise copy of its canonical node after every
 * stage (ndo_sync).
 *
 * Regions, for peers that split the surface (thesis §4.5): a simulation
 * integrates only its *active* nodes (ndo_sim_set_active; all nodes by
 * default).  Every other node is *held*: during a step its position stays
 * exactly as given and acts on the active nodes as a boundary condition;
 * its velocity is kept as given and not used.  A peer sets the held
 * nodes from the other peers' last states (ndo_sim_set) between steps —
 * the thesis' one-step boundary lag.  Pinned nodes (pin mode "project")
 * are held nodes that are never released.
 *
 * Subnormal numbers: every call that steps or solves (ndo_sim_step,
 * ndo_sim_steps, ndo_sim_step_begin, the rkf45 and implicit parts below)
 * computes with them flushed to zero (ndo_fp_flush, ndo/pool.h: results
 * below 2.2e-308 are 0, and so are such inputs), on the caller's thread
 * and its workers alike, and gives the caller's floating-point control
 * back on return.  A run from rest carries a front of ever smaller
 * displacements outwards from the force, and on x86 an operation on a
 * subnormal costs a hundred cycles or more: RK4 at level 8 took 2-2.5
 * times as long a step while the front crossed the grid.  Every peer
 * does the same, so the bits agree between peers and the single process
 * as before.
 */
#ifndef NDO_SIM_H
#define NDO_SIM_H

#include <stddef.h>
#include <stdint.h>

#include "ndo/grid.h"
#include "ndo/pool.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The integrators.  Explicit: forward Euler, symplectic (semi-implicit)
 * Euler, explicit midpoint (RK2), classic RK4, Runge–Kutta–Fehlberg 4(5)
 * with error control (thesis eq. 3.7; the 5th-order solution is
 * propagated, as there).  Implicit, solved with CHOLMOD: backward Euler and
 * the trapezoidal rule. */
typedef enum ndo_method {
	NDO_EULER = 0,
	NDO_SYMPLECTIC_EULER,
	NDO_MIDPOINT,
	NDO_RK4,
	NDO_RKF45,
	NDO_BACKWARD_EULER,
	NDO_TRAPEZOID,
	NDO_METHOD_COUNT
} ndo_method;

/* "euler", "symplectic-euler", "midpoint", "rk4", "rkf45",
 * "backward-euler", "trapezoid" (index = ndo_method), NULL-terminated. */
extern const char *const ndo_method_names[];

/* NDO_ENOTFOUND for an unknown name. */
int ndo_method_parse(const char *name, ndo_method *m);
int ndo_method_is_implicit(ndo_method m);

/* How the implicit methods solve their symmetric positive definite
 * systems.  CHOLMOD: a sparse Cholesky factor per step size (the
 * reference; its fill grows faster than the nodes).  MULTIGRID: conjugate
 * gradients preconditioned by a geometric multigrid V-cycle on the grid's
 * own levels (lib/sim/multigrid.h), to a relative residual of
 * NDO_SOLVER_TOL: O(n) work and memory per step.  AUTO (the default):
 * multigrid from level NDO_MULTIGRID_MIN_LEVEL up, CHOLMOD below, where the
 * factor is small and faster (docs/bench/multigrid.md). */
typedef enum ndo_solver {
	NDO_SOLVER_AUTO = 0,
	NDO_SOLVER_MULTIGRID,
	NDO_SOLVER_CHOLMOD,
	NDO_SOLVER_COUNT
} ndo_solver;
#define NDO_SOLVER_TOL 1e-12
/* A solve that rounding stalls above NDO_SOLVER_TOL (the true residual no
 * better over two restarts, or the iteration limit) ends there if its
 * relative residual is at most this; above it, the step fails. */
#define NDO_SOLVER_TOL_STALL 1e-10
#define NDO_MULTIGRID_MIN_LEVEL 6

/* "auto", "multigrid", "cholmod" (index = ndo_solver), NULL-terminated. */
extern const char *const ndo_solver_names[];

/* NDO_ENOTFOUND for an unknown name. */
int ndo_solver_parse(const char *name, ndo_solver *s);

/* The solver `s` means at `level` (AUTO resolved). */
ndo_solver ndo_solver_at(ndo_solver s, int level);

typedef struct ndo_material {
	double stiffness;    /* σ, N/m (> 0) */
	double density;      /* ρ, kg/m² (> 0) */
	double damping;      /* b: viscous damping per unit area, N·s/m³ (≥ 0) */
	double mass_damping; /* a: mass-proportional damping B += a·M, 1/s (≥ 0) */
} ndo_material;

/* External forces.  The time factor is
 *     s(t) = sin(2π·frequency·t + phase)  when frequency > 0,
 *     s(t) = 1                            when frequency = 0 (constant),
 * and each kind distributes amplitude·s(t) as follows:
 *   NDO_FORCE_FACE      the thesis' forces on selected faces: a total of
 *                       amplitude N over the listed triangles, shared in
 *                       proportion to their rest areas, each triangle's
 *                       share split equally between its three vertices —
 *                       so the load does not change with the level;
 *   NDO_FORCE_POINT     amplitude N on each listed node;
 *   NDO_FORCE_PRESSURE  a uniform pressure of amplitude Pa on the whole
 *                       surface, along the current outward normals.
 * The direction is the current (deformed) outward normal of each face
 * (follower load; for point forces the area-weighted vertex normal) when
 * `normal` is set, else the fixed unit vector dir. */
typedef enum ndo_force_kind {
	NDO_FORCE_FACE = 0,
	NDO_FORCE_POINT,
	NDO_FORCE_PRESSURE
} ndo_force_kind;

typedef struct ndo_force {
	ndo_force_kind kind;
	double amplitude; /* N (face, point) or Pa (pressure) */
	double frequency; /* Hz, ≥ 0 */
	double phase;     /* radians */
	int normal;       /* 1: along the outward normal; 0: along dir */
	double dir[3];    /* unit vector (normalized by ndo_sim_create) */
	size_t count;     /* items */
	int32_t *items;   /* face: triangle ids (ndo_triangles order);
	                     point: stored node indices.  Copied by
	                     ndo_sim_create. */
} ndo_force;

/* amplitude · s(t). */
double ndo_force_value(const ndo_force *f, double t);

/* How pinned nodes are held.  PROJECT (the default) removes them from the
 * integration: they never move.  PENALTY is the thesis' Payne–Irons method
 * (§4.3.3): each pinned node is tied to its initial position by a spring
 * of stiffness α — a large number on the diagonal of K — and integrated
 * like the others; the stable step of every explicit method then shrinks
 * as 1/√α. */
typedef enum ndo_pin_mode { NDO_PINS_PROJECT = 0, NDO_PINS_PENALTY } ndo_pin_mode;

typedef struct ndo_sim_params {
	ndo_material material;
	ndo_method method;
	double tol;          /* rkf45: local error tolerance per step (see
	                        ndo_sim_step); default 1e-6 */
	int restiffen;       /* re-assemble K from the deformed shape every
	                        `restiffen` steps; 0 (default): never */
	ndo_pin_mode pin_mode;
	double penalty;      /* α in N/m for NDO_PINS_PENALTY; 0 (default):
	                        1000 × the largest diagonal entry of K */
	double energy_bound; /* divergence when the energy exceeds this many
	                        times (initial energy + input work); default 10,
	                        0 switches the energy test off (NaN, Inf and the
	                        blown-up bounding box are always tested) */
	const ndo_force *forces;
	int nforces;
	size_t max_memory;   /* the most bytes the simulation may take (its
	                        arrays, and the implicit methods' factor); 0
	                        (default): no limit.  A larger run is refused
	                        with NDO_ENOMEM and the estimate, before it
	                        allocates (ndo_sim_memory) */
	ndo_solver solver;   /* the implicit methods' linear solver (default
	                        NDO_SOLVER_AUTO) */
	int threads;         /* threads that share a step's loops, 0..NDO_POOL_MAX
	                        (ndo/pool.h); 0 and 1 (default): the caller's
	                        alone.  The result is the same, bit for bit, for
	                        every count; grids of fewer than
	                        NDO_SIM_THREAD_MIN integrated nodes use one */
} ndo_sim_params;

/* The smallest grid, in integrated nodes, whose steps are shared among
 * threads: below it a step is too short to pay for waking a thread
 * (docs/bench/simulate.md, "Threads"). */
#define NDO_SIM_THREAD_MIN 20000

/* σ = 1 N/m, ρ = 1 kg/m², b = 0, a = 0, rk4, tol 1e-6, no restiffening,
 * projected pins, energy bound 10, no forces, one thread. */
void ndo_sim_defaults(ndo_sim_params *p);

typedef struct ndo_sim ndo_sim;

/* Create a simulation of a level-`level` grid.  x: positions, H × W × 3
 * doubles; v: velocities (NULL: at rest); rest: the rest shape X (NULL:
 * x); pin: H × W bytes, nonzero = pinned (NULL: none).  A duplicate node
 * takes its canonical node's values.  K and M are assembled from the rest
 * shape.  Time and step count start at 0 (ndo_sim_set_time to change).
 * NDO_ERANGE for non-finite input, a coordinate or velocity beyond
 * ±NDO_SIM_MAX_COORD (naming the node), a degenerate rest triangle, a
 * density under which a node's mass (or b/density) leaves a double's range,
 * or a bad parameter, NDO_EINVAL for a force item out of range. */
#define NDO_SIM_MAX_COORD 1e100
/* The divergence test's bound on the shape (ndo_sim_step): a node — a
 * projected pin too — more than this many rest bounding-box diagonals
 * from where the body's mean displacement puts it has diverged; a state
 * within it is a legitimate one, which the network's bound on state lets
 * through (ndo/msg.h: one message's nodes within twice it of each other). */
#define NDO_SIM_DEFORM_MAX 100.0
int ndo_sim_create(int level, const double *x, const double *v, const double *rest,
                   const uint8_t *pin, const ndo_sim_params *p, ndo_sim **out);

/* The same from a grid: positions from "position", and "velocity", "rest"
 * and "pin" when present (f32 channels are converted in place); time and
 * step from the grid. */
int ndo_sim_from_grid(ndo_grid *g, const ndo_sim_params *p, ndo_sim **out);

/* Accepts NULL. */
void ndo_sim_destroy(ndo_sim *s);

/* The bytes a simulation of a level-`level` grid with these parameters
 * allocates for its state, workspace and stencil (the implicit methods'
 * factor comes on top: its size is known after the symbolic analysis, and
 * checked against max_memory then). */
size_t ndo_sim_memory(int level, const ndo_sim_params *p);

/* The threads a step runs on: ndo_sim_params.threads, or 1 where the grid
 * is below NDO_SIM_THREAD_MIN integrated nodes. */
int ndo_sim_threads(const ndo_sim *s);

/* Advance by one step of size h seconds with the chosen method.  rkf45
 * takes as many adaptive sub-steps as its tolerance needs to land exactly
 * on t + h (the error of a sub-step, the difference between the embedded
 * 4th- and 5th-order solutions, must satisfy |e_i| ≤ tol·(1 + |y_i|) for
 * every displacement and velocity component, in metres and m/s); the
 * other methods take exactly one step.
 *
 * Every step first checks the state it starts from: NaN or Inf, an energy
 * beyond energy_bound × (initial energy + input work), or a node further
 * than NDO_SIM_DEFORM_MAX (100) × the rest shape's bounding-box diagonal
 * from where the integrated nodes' mass-weighted mean displacement puts it
 * (from its rest position moved with the body: a free body that drifts
 * whole does not diverge; a projected pin is such a node, so the free part
 * of a pinned body may not go further than that from its pins; with
 * ndo_sim_set_active, the region's nodes and pins) mean divergence.  The
 * input work is each step's own (docs/simulate-peer.md, "Divergence"):
 * symplectic and forward Euler h f(t)·½(v + v'), midpoint
 * h f(t + h/2)·½(v + v'), rk4 and rkf45 their stages' h Σ b_i f(t_i)·V_i,
 * backward Euler h f(t+h)·v', the trapezoid h ½(f(t) + f(t+h))·½(v + v');
 * the force the held nodes' displacements put on the integrated ones
 * counts as an external one.  Then the step returns NDO_EDIVERGED, leaves
 * the state as it is (the first bad state, at ndo_sim_time) and records
 * what was wrong in ndo_errdetail().  Call ndo_sim_check() to test the
 * state after the last step.  Other errors: NDO_EINVAL (h not positive
 * and finite), NDO_ERANGE (re-assembling K met a degenerate triangle),
 * NDO_ENOMEM, NDO_EDIVERGED also when CHOLMOD finds the matrix not
 * positive definite or rkf45's sub-step underflows. */
int ndo_sim_step(ndo_sim *s, double h);

/* k steps of size h, for callers with nothing to do between them: the
 * same bits as k calls of ndo_sim_step() (state, time, step count,
 * energies, work, statistics) on any thread count, and the same return:
 * at the first step that fails it returns that step's status with the
 * state as that step left it (NDO_EDIVERGED: the first bad state, at
 * ndo_sim_time; ndo_sim_step_count says how many steps were taken).
 * Symplectic Euler and midpoint without penalty pins, pressure, sleeping
 * tiles, re-assembly of K or a moving boundary run up to six passes (6
 * steps of symplectic Euler, 3 of midpoint) at a time as one pipeline on
 * the threads, with no wait between the passes or the steps
 * (lib/sim/wave.c), and rk4 (pins too, none moving) two steps
 * (lib/sim/rk4.c) — when the steps run on the
 * threads, or from 65,536 nodes on one (where a pipeline's rows are
 * still in the cache when the next step reads them); the others step
 * one at a time.
 * k = 0
 * does nothing; NDO_EINVAL for k < 0 or h not positive and finite. */
int ndo_sim_steps(ndo_sim *s, double h, int64_t k);

/* Begin the next step (of size h) ahead of part of its input: run now
 * what of it does not read the state of the n nodes `pending` (stored
 * indices; a peer's halo, ndo/peer.h, whose values are in flight), so
 * that a caller waiting for their values computes the rest meanwhile.
 * Then the caller writes those nodes (ndo_sim_set_displacements,
 * ndo_sim_set) and ndo_sim_step(s, h) takes the step: the same bits as
 * the step without the begin.  Writing any other node, a new region,
 * held motion, another time or another h drops what was done ahead
 * (ndo_sim_step then takes the whole step).  Only rk4's pipeline (see
 * lib/sim/rk4.c) begins ahead, and not at a step that re-assembles K:
 * otherwise nothing is done.  Returns the (stage, chunk) units run ahead
 * (0: none), NDO_EINVAL for a bad h, NDO_ENOMEM. */
int ndo_sim_step_begin(ndo_sim *s, double h, size_t n, const int32_t *pending);

/* rkf45's step in parts, for peers that split the object (ndo/peer.h):
 * ndo_sim_step(s, h) for rkf45 is
 *     ndo_sim_rkf45_begin(s, h);
 *     do { ndo_sim_rkf45_attempt(s, NULL, &err, NULL); }
 *     while ((rc = ndo_sim_rkf45_decide(s, err)) == 0);
 * Between the calls a caller may overwrite held nodes (a peer's halo, at
 * the state an accepted sub-step ended in) and replace err by the largest
 * err over every peer: the error is a maximum over nodes, so the peers'
 * maximum is the single process's, bit for bit, and so are the sub-steps
 * taken.  begin: NDO_EINVAL for another method or a bad h; it re-assembles
 * K when due as ndo_sim_step does.  attempt: the stages of the next
 * sub-step (size in *h, may be NULL) and its error relative to the
 * tolerance over the active nodes whose byte in `rows` (H × W) is
 * nonzero (NULL: every active node); a state that diverged returns
 * NDO_EDIVERGED.  decide: accept (the state advances) or reject (a smaller
 * sub-step next) by err; 1 when the step is complete (time and step count
 * advanced), 0 when another attempt follows, NDO_EDIVERGED when the
 * sub-step underflows.  abort: back to the time and sub-step size the
 * step began with, and to its input work, energy bound and sub-step
 * counts, as if it had not begun (the caller restores the state). */
int ndo_sim_rkf45_begin(ndo_sim *s, double h);
int ndo_sim_rkf45_attempt(ndo_sim *s, const uint8_t *rows, double *err, double *h);
int ndo_sim_rkf45_decide(ndo_sim *s, double err);
void ndo_sim_rkf45_abort(ndo_sim *s);
/* The displacement and velocity (n × 3 doubles each) that n nodes (stored
 * indices) will have if the sub-step just attempted is accepted, bit for
 * bit: a peer sends its strip's with the error, so that one exchange per
 * attempt serves both (ndo/peer.h). */
void ndo_sim_rkf45_peek(const ndo_sim *s, size_t n, const int32_t *nodes, double *u, double *v);
/* The controller's state between steps: the sub-step size the next step
 * tries first (s; 0 before rkf45's first step: the step's whole size).
 * With the state (u, v) and the time it is all a step reads, so a peer
 * that goes back to a checkpoint (ndo/peer.h) sets it too and takes the
 * single process's sub-steps from there bit for bit.  Other methods keep
 * it at 0 and ignore it; set: a negative or non-finite size is taken as
 * 0. */
double ndo_sim_rkf45_substep(const ndo_sim *s);
void ndo_sim_rkf45_set_substep(ndo_sim *s, double h);

/* The implicit system by rows, for a solver that is not this
 * simulation's own — peers that solve it together (ndo/peer.h) — instead
 * of ndo_sim_step's CHOLMOD factor.  Backward Euler and the trapezoid
 * solve, each step, A v' = b for the new velocities of the unknowns (every
 * node but the pins held in project mode; implicit.c has A and b).  A
 * caller that holds the exact state of its rows and of their 1-ring (the
 * others held: ndo_sim_set_active) calls
 *   begin(s, h, rows, n, b, dinv)  the divergence test, then b and the
 *                                  inverse diagonal of A (Jacobi) on the
 *                                  rows (0 on rows that are no unknowns
 *                                  or not active);
 *   apply(s, h, rows, n, x, y)     y = A x on the rows, x given on the
 *                                  rows and their 1-ring;
 *   rigid(s, h, rows, n, x, sums, &gamma)
 *                                  for an object without pins, where
 *                                  ndo_sim_step corrects the momentum of
 *                                  the solution: the rows' parts of the
 *                                  sums it needs (sums[0..2] the wanted
 *                                  momentum, [3..5] M x, [6] the mass);
 *                                  the shift of axis k is then
 *                                  (Σ[k] / (1 + c h γ) − Σ[3+k]) / Σ[6],
 *                                  c = 1 (backward Euler) or ½ (trapezoid);
 *                                  returns 0 when there is no correction;
 *   end(s, h, x)                   the new velocities x on the active
 *                                  nodes: the step ends (state, time,
 *                                  step count).
 * Vectors are 3 planes of W·H doubles (component c of stored node p at
 * c·W·H + p), read and written at canonical nodes.  rows: canonical
 * stored indices.  begin: NDO_EINVAL for an explicit method or a bad h,
 * NDO_EDIVERGED as ndo_sim_step. */
int ndo_sim_implicit_begin(ndo_sim *s, double h, const int32_t *rows, size_t n, double *b,
                           double *dinv);
void ndo_sim_implicit_apply(const ndo_sim *s, double h, const int32_t *rows, size_t n,
                            const double *x, double *y);
/* ndo_sim_implicit_apply for many vectors on the same rows and h, the
 * same bits several times faster: the rows sorted once into runs that
 * read the grid's interior stencil and the rest.  *r: NULL, or made
 * before and filled again (NDO_ENOMEM leaves it to free).  Valid while
 * the rows, h, the pins and the active set stay (a solve makes it again
 * each step).  x and y must not overlap. */
typedef struct ndo_sim_rows ndo_sim_rows;
int ndo_sim_implicit_rows(const ndo_sim *s, double h, const int32_t *rows, size_t n,
                          ndo_sim_rows **r);
void ndo_sim_implicit_apply_rows(const ndo_sim *s, const ndo_sim_rows *r, const double *x,
                                 double *y);
/* The rows lo ≤ p < hi alone, written at y[c·stride + p − lo] (a block of
 * a caller's, stride ≥ hi − lo): a solver that uses each block at once,
 * while it is in the cache.  The same bits as ndo_sim_implicit_apply_rows;
 * the rows must have been given in ascending order (ndo_sim_rows_sorted;
 * else nothing is written). */
int ndo_sim_rows_sorted(const ndo_sim_rows *r);
void ndo_sim_implicit_apply_range(const ndo_sim *s, const ndo_sim_rows *r, const double *x,
                                  double *y, size_t stride, size_t lo, size_t hi);
void ndo_sim_rows_free(ndo_sim_rows *r);
int ndo_sim_implicit_rigid(const ndo_sim *s, double h, const int32_t *rows, size_t n,
                           const double *x, double sums[7], double *gamma);
int ndo_sim_implicit_end(ndo_sim *s, double h, const double *x);
/* z = A_AA⁻¹ r on the active unknowns, with the simulation's own CHOLMOD
 * factor of the system restricted to them (factored when h, K or the
 * active set changed): for a peer whose active nodes are its region, the
 * block-Jacobi (additive Schwarz without overlap) preconditioner of the
 * whole system.  z's other entries are left as they are.  NDO_ENOMEM,
 * NDO_EDIVERGED (not positive definite). */
int ndo_sim_implicit_precondition(ndo_sim *s, double h, const double *r, double *z);

/* The divergence test of ndo_sim_step on the current state, without
 * stepping: NDO_OK or NDO_EDIVERGED. */
int ndo_sim_check(ndo_sim *s);

double ndo_sim_time(const ndo_sim *s);
int64_t ndo_sim_step_count(const ndo_sim *s);
void ndo_sim_set_time(ndo_sim *s, double t, int64_t step);
/* The step the run began at (default: the step of the first
 * ndo_sim_set_time before any step, else 0): --restiffen's S steps count
 * from it, and K for a step is assembled from the rest shape up to S
 * steps after it, then from the shape at the last multiple of S.  A peer
 * sets it to the run's first step; after ndo_sim_set_time on a sim that
 * has stepped (a restart), the next step re-assembles K as it is at that
 * step: from the rest shape, or from the state when the step
 * is a multiple of S (the single process's K; at any other step K is
 * taken from the current shape, not the single process's). */
void ndo_sim_set_first_step(ndo_sim *s, int64_t first);
int ndo_sim_level(const ndo_sim *s);
ndo_method ndo_sim_method(const ndo_sim *s);
/* --restiffen: K re-assembled every this many steps (0: never). */
int ndo_sim_restiffen_every(const ndo_sim *s);

/* Counters since creation. */
typedef struct ndo_sim_stats {
	int64_t steps;         /* ndo_sim_step calls that succeeded */
	int64_t substeps;      /* rkf45: accepted sub-steps (others: = steps) */
	int64_t rejected;      /* rkf45: rejected sub-steps */
	int64_t evaluations;   /* force evaluations (stiffness products) */
	int64_t restiffened;   /* re-assemblies of K */
	int64_t factorizations;/* CHOLMOD numeric factorizations, or multigrid
	                          hierarchies built */
	double restiffen_seconds; /* CPU time spent re-assembling (and
	                             refactoring) */
	double last_substep;   /* rkf45: the last accepted sub-step, s */
	int64_t solves;        /* implicit methods: linear solves */
	int64_t iterations;    /* multigrid: conjugate-gradient iterations, all
	                          solves */
	int last_iterations;   /* multigrid: the last solve's iterations */
	double last_residual;  /* multigrid: the last solve's relative residual
	                          ‖b − A x‖ / ‖b‖ (worst coordinate) */
	int64_t av_reused;     /* multigrid trapezoid: steps that took A v from
	                          the last solve (v unchanged since) */
	int64_t av_misses;     /* ... that tried and found v changed (the full
	                          product instead) */
	int64_t steps_alone;   /* with threads: steps run on one thread — the
	                          half of each look at whether the threads pay,
	                          and every step while they do not (a machine
	                          busy with other work) */
} ndo_sim_stats;
void ndo_sim_stats_get(const ndo_sim *s, ndo_sim_stats *st);

/* Sleeping tiles (docs/simulate-peer.md, "Sleeping tiles"): the grid is
 * cut into tiles of 32 × 32 stored nodes; every few steps a tile on which
 * no force acts and whose every node has |u| ≤ umax (m) and |v| ≤ vmax
 * (m/s), with all its neighbour tiles as still, stops being stepped (its
 * nodes hold their state), and a sleeping tile wakes as soon as a
 * neighbour tile moves beyond those bounds.  The result then differs from
 * the every-node run by about umax near the sleeping tiles.  umax = vmax = 0
 * turns it off (every tile awake again).  For euler, symplectic-euler,
 * midpoint and rk4 on a simulation without a region (ndo_sim_set_active):
 * NDO_EINVAL otherwise, and for negative or non-finite bounds. */
int ndo_sim_set_sleep(ndo_sim *s, double umax, double vmax);

typedef struct ndo_sim_sleep_stats {
	int on;                  /* sleeping tiles are on */
	int tiles, awake;        /* tiles (with nodes), of them awake now */
	int64_t checks, wakes, sleeps; /* looks, tiles woken, tiles fallen asleep */
	double node_steps;       /* canonical node-steps taken since set_sleep */
	double node_steps_all;   /* ... with every tile awake */
} ndo_sim_sleep_stats;
void ndo_sim_sleep_stats_get(const ndo_sim *s, ndo_sim_sleep_stats *st);

/* The implicit methods' solver as it runs: NDO_SOLVER_MULTIGRID or
 * NDO_SOLVER_CHOLMOD (explicit methods: NDO_SOLVER_AUTO).  With multigrid
 * and a hierarchy built (after the first step), *levels receives its
 * levels (1: the smoother alone) and *direct whether CHOLMOD factors its
 * coarsest level; otherwise both 0.  Either may be NULL. */
ndo_solver ndo_sim_solver_info(const ndo_sim *s, int *levels, int *direct);

/* The state.  x, v: H × W × 3 doubles (either may be NULL). */
void ndo_sim_get(const ndo_sim *s, double *x, double *v);

/* Overwrite the state of n nodes (stored indices in `nodes`; nodes NULL:
 * all W·H nodes in order, n ignored).  x, v: n × 3 doubles (either may be
 * NULL to keep that part).  A duplicate index writes its vertex. */
void ndo_sim_set(ndo_sim *s, size_t n, const int32_t *nodes, const double *x,
                 const double *v);

/* The state of n nodes (stored indices in `nodes`), each of x
 * (positions X + u), u (displacements) and v: n × 3 doubles, NULL to skip.
 * The displacement is the integrated state: x − X does not give it back
 * bit for bit, so peers that must reproduce the single process exactly
 * exchange u (docs/peers.md). */
void ndo_sim_get_nodes(const ndo_sim *s, size_t n, const int32_t *nodes, double *x, double *u,
                       double *v);

/* The same into arrays indexed by node (a grid's channels): node
 * nodes[k]'s position at x[3 nodes[k] ..], its velocity at v[3 nodes[k] ..]
 * (NULL to skip); the other entries are left as they are. */
void ndo_sim_get_nodes_at(const ndo_sim *s, size_t n, const int32_t *nodes, double *x,
                          double *v);

/* Overwrite the displacement u and velocity v (n × 3 doubles each, either
 * NULL to keep it) of n nodes: ndo_sim_set for the integrated state
 * itself, bit for bit. */
void ndo_sim_set_displacements(ndo_sim *s, size_t n, const int32_t *nodes, const double *u,
                               const double *v);

/* Restart the energy bound of the divergence test, as
 * ndo_sim_set_active() does: for a caller that overwrote part of the
 * state (ndo_sim_set*) with energy the bound did not see come in as work
 * — a peer's halo (ndo/peer.h).  The NaN and distance tests stay. */
void ndo_sim_restart_energy_bound(ndo_sim *s);

/* Integrate only the nodes whose mask byte is nonzero (H × W; a
 * duplicate follows its canonical node); hold all others (see the top of
 * this header).  NULL: all nodes.  Pinned nodes stay held in project mode.
 * The energy bound of the divergence test (over the integrated nodes)
 * restarts: its initial energy is taken at the next step, and only the
 * input work from then on counts. */
int ndo_sim_set_active(ndo_sim *s, const uint8_t *mask);

/* How held nodes next to the active ones behave during a step of an
 * explicit method.  0 (the default): they stand still at the values given
 * (the region's boundary condition of the thesis' one-step lag).  1: they
 * move with their given velocities, u + τ v at the stage time t + τ, and
 * end the step there — the boundary extrapolated over the step.  A
 * one-stage method (forward and symplectic Euler) reads its neighbours
 * only at τ = 0 and is not changed; for the multi-stage ones (midpoint,
 * rk4, rkf45) it turns the lag's O(h) error into a smaller one
 * (docs/peers.md measures it).  Pins never move; the implicit methods
 * hold the boundary still either way. */
void ndo_sim_set_held_motion(ndo_sim *s, int on);

/* Write the state into g (same level): "position" (x), "velocity" and
 * "rest" as f64 channels (added if absent), and the time and step count. */
int ndo_sim_store(const ndo_sim *s, ndo_grid *g);

/* Energies and motion of the whole object now (one stiffness product). */
typedef struct ndo_sim_energy {
	double kinetic;          /* ½ Σ m |v|², J */
	double potential;        /* ½ Σ u·K u (+ ½ α |x − x̄|² at penalty pins), J */
	double work;             /* the external forces' work so far, J, as
	                            the divergence test counts it: each
	                            step's own (ndo_sim_step) */
	double max_displacement; /* max |x − X|, m */
} ndo_sim_energy;
void ndo_sim_energy_get(ndo_sim *s, ndo_sim_energy *e);

/* ---- the stable step -------------------------------------------------- */

/* What limits a method's step (ndo_critical.bound). */
enum {
	NDO_BOUND_NONE = 0,    /* unconditionally stable (implicit methods) */
	NDO_BOUND_OSCILLATION, /* the top mode's oscillation, h ω_max > 1: the
	                          imaginary-axis interval, h ≈ c_imag/ω_max,
	                          shifted by damping */
	NDO_BOUND_DAMPING,     /* stable only because damping outweighs a
	                          growth on the imaginary axis (forward Euler
	                          h ≈ γ/ω², midpoint h ≈ (4γ/ω⁴)^⅓, rkf45 with
	                          light damping); 0 without damping */
	NDO_BOUND_REAL         /* an overdamped mode: the negative real axis,
	                          h ≈ c_real/γ */
};

typedef struct ndo_critical {
	double lambda_max;  /* λ_max(M⁻¹K) over the integrated nodes, 1/s² */
	double omega_max;   /* √λ_max, rad/s */
	double gamma;       /* damping rate of that mode, φᵀBφ / φᵀMφ, 1/s */
	double h_crit;      /* the method's largest stable step, s (0: none,
	                       INFINITY: any) */
	double c_imag;      /* stability interval on the imaginary axis (hω) */
	double c_real;      /* ... on the negative real axis (h|λ|) */
	int bound;          /* NDO_BOUND_* */
	int iterations;     /* power iterations used */
	double converged;   /* relative change of the estimate over the last
	                       10 iterations */
} ndo_critical;

/* Estimate the critical step of the simulation's method for its current
 * stiffness, mass, damping, pins and active set: λ_max(M⁻¹K) by power
 * iteration (seeded, deterministic; a few hundred stiffness products),
 * then ndo_stable_step.  Exact for mass-proportional damping; with nodal
 * damping the top mode's damping rate is its Rayleigh quotient. */
int ndo_sim_critical(ndo_sim *s, ndo_critical *c);

/* The largest h for which `m` is stable on every mode u'' + γu' + ω²u = 0
 * with 0 < ω ≤ omega (damping rate γ fixed): the spectral radius of the
 * method's one-step matrix stays ≤ 1.  0 if unstable for every h > 0,
 * INFINITY if stable for every h.  *bound (may be NULL) receives the
 * NDO_BOUND_* that limits it. */
double ndo_stable_step(ndo_method m, double omega, double gamma, int *bound);

/* The spectral radius of one step of `m` with size h on that mode: the
 * factor by which the mode grows (> 1) or decays per step. */
double ndo_amplification(ndo_method m, double omega, double gamma, double h);

/* The method's stability interval on the imaginary axis (largest y with
 * the method stable for hλ = i·t, 0 < t ≤ y) or on the negative real axis
 * (imaginary = 0).  INFINITY for the implicit methods. */
double ndo_stability_interval(ndo_method m, int imaginary);

#ifdef __cplusplus
}
#endif
#endif
