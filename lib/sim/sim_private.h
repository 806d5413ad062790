/* sim_private.h — the simulation's internals, shared by integrate.c,
 * accel.c, forces.c, implicit.c and stability.c (not installed). */
#ifndef NDO_SIM_PRIVATE_H
#define NDO_SIM_PRIVATE_H

#include "ndo/machine.h"
#include "ndo/pool.h"
#include "ndo/simd.h"
#include "ndo/membrane.h"
#include "ndo/sim.h"

#include <math.h>
#include <stdint.h>

/* The hot loops are compiled twice, for x86-64 (SSE2) and for x86-64-v3
 * (AVX2 + FMA), and the loader picks what the CPU runs (GCC function
 * multi-versioning): about twice the speed where AVX2 exists, while the
 * library still runs on any x86-64.  Sanitizer builds compile one variant
 * (see lib/net/codec_private.h). */
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && \
    !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
#define NDO_HOT __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define NDO_HOT
#endif

/* The stencil loops are written four nodes at a time in GCC's vector
 * types (ndo/simd.h; rk4.c, accel.c): every plane's neighbours read from
 * its base at the node's index plus a row or a constant.  (GCC's own
 * vectorizer kept a pointer for each neighbour of each plane, about 40,
 * spilled and reloaded at every iteration.) */

/* A run of consecutive stored indices [a, b). */
typedef struct ndo__span {
	int32_t a, b;
} ndo__span;

/* A force resolved against the grid: the stored nodes it touches and, for
 * face forces, each face's share of the amplitude. */
typedef struct ndo__force {
	ndo_force f;       /* items owned */
	double *share;     /* face: count area fractions */
	int32_t *nodes;    /* face: 3 × count canonical nodes (triangle_nodes) */
} ndo__force;

/* An edge from an active node p to a held node q, stiffness c. */
typedef struct ndo__edge {
	int32_t p, q;
	double c;
} ndo__edge;

typedef struct ndo__implicit ndo__implicit;
typedef struct ndo__sleep ndo__sleep;

struct ndo_sim {
	int level, n, w, h;
	size_t count;          /* W·H stored nodes */
	ndo_sim_params p;      /* forces point to `forces` below */
	ndo_stencil st;
	double *X;             /* rest shape, 3 planes */
	double *mass, *minv;   /* lumped mass and its inverse, 1 plane each */
	double *gam;           /* damping rate B_ii / m_i, 1 plane */
	double *u, *v;         /* displacement x − X and velocity, 3 planes each */
	uint8_t *pin;          /* 1 plane of flags */
	uint8_t *active;       /* integrated nodes (canonical and duplicates) */
	int32_t *canon;        /* canonical stored index of every node */
	double rest_size;      /* rest bounding-box diagonal, m */
	double udrift;         /* the size test (ndo__diverged): the largest |u| up to
	                        * which the state was seen to be a drift of the whole
	                        * body, not a deformation (0: none yet) */
	/* The projected pins of the nodes stepped (the whole object's, or
	 * those within ndo_sim_set_active's region: the ones its messages
	 * carry), canonical indices, and the largest |u| among them: the size
	 * test measures them with the integrated nodes (ndo__deformation) */
	int32_t *ppin;
	size_t nppin;
	double upin;

	/* The active canonical nodes as runs: all of them (for elementwise
	 * updates), the interior ones (fast stencil), and the positions in
	 * st.border of the active border nodes. */
	ndo__span *espan, *ispan;
	size_t nespan, nispan;
	int32_t *bact;
	size_t nbact;
	ndo__edge *hedge;
	size_t nhedge;
	int any_held;          /* some node is not integrated */
	/* The held nodes next to the active ones that are not pins (canonical
	 * indices, then their stored duplicates), and whether they move with
	 * their velocities during a step (ndo_sim_set_held_motion). */
	int32_t *hmove;
	size_t nhmove;
	int held_motion;
	/* Every held node next to an active one, pins too (canonical, then
	 * their duplicates): what a stage of an active node reads from a held
	 * one. */
	int32_t *hread;
	size_t nhread;

	/* Penalty pins: stored index, spring α, target displacement. */
	size_t npen;
	int32_t *pen;
	double alpha, *pen_target; /* 3 per penalty pin */
	uint8_t *pen_forced;   /* the pin is a force node (ndo__stage_power) */

	/* External forces. */
	ndo__force *forces;
	int nforces;
	int has_forces;        /* any force at all: f is used */
	int has_pressure;
	double *f;             /* 3 planes, zero except where forces act */
	int32_t *fnodes;       /* nodes f may be nonzero at (canonical) */
	size_t nfnodes;

	/* Workspace: stage state, stage velocities and accelerations. */
	double *us, *vs;       /* 3 planes each */
	double *kv[6], *ka[6]; /* 3 planes each, as many as the method needs */
	double *err;           /* rkf45: 6 planes */
	double *tmp;           /* 3 planes */

	double t;
	int64_t step;
	/* --restiffen: K is assembled from the shape at k_first (the rest
	 * shape: the run's first step) or at the last multiple of S steps
	 * after it; k_at the step the K held was assembled for (NDO__K_STALE:
	 * unknown, after the state jumped to another step), k_fixed: k_first
	 * set by ndo_sim_set_first_step, not moved by ndo_sim_set_time */
	int64_t k_first, k_at;
	int k_fixed;
	ndo_sim_stats stats;
	double h_sub;          /* rkf45's next sub-step */
	/* rkf45's step under way (ndo_sim_rkf45_begin): its end, the next
	 * sub-step, the sub-step attempted and whether it is the last, stage 0
	 * ready, the last attempt rejected; the time and h_sub it began at */
	double rk_t_end, rk_hs, rk_h, rk_t0, rk_hsub0;
	int rk_last, rk_k0, rk_rejected;
	/* ... and what its sub-steps change besides the state, which
	 * ndo_sim_rkf45_abort puts back: the input work (committed and
	 * pending), the energy bound's reference, the size test's threshold
	 * and the sub-step counts (the force evaluations were made: they stay) */
	struct {
		double work, work_abs, pend_h, pend_power, e0, udrift, last_substep;
		int e0_set;
		int64_t substeps, rejected;
	} rk_undo;

	/* Divergence: the reference energy and the input work. */
	int e0_set;
	double h_mod;          /* symplectic Euler: the step of its modified energy
	                        * (0 before the first step: the plain energy) */
	double e0, work, work_abs; /* input work up to the last step's start */
	double work_abs_base;      /* work_abs when the energy bound last restarted
	                              (ndo_sim_set_active) */
	double last_power;     /* f·v at the start of the current step; symplectic
	                        * Euler: the step's mean power ½ f·(v + v'), whose
	                        * product with h is the work the step did on its
	                        * modified energy, exactly (accel.c); forward Euler
	                        * takes it so too (integrate.c, first_stage) */
	double stage_power[6]; /* the explicit Runge–Kutta step under way: the input
	                        * power at each stage, f(t_i)·V_i (ndo__stage_power;
	                        * stage 0's is last_power) */
	double imp_power0;     /* the trapezoid's step under way: its input power at
	                        * the velocity it starts from (implicit.c, step_power) */
	double *pen_f1;        /* the implicit step under way: α (u + h v − x̄) at each
	                        * penalty pin, 3 a pin (the spring's force at t + h
	                        * in f, taken back out of the input power) */
	double pend_h, pend_power; /* the last step: its size and mean input power,
	                            * whose product is the work the step itself
	                            * integrated (integrate.c, account) */

	ndo__implicit *imp;
	int imp_df;            /* ndo_sim_implicit_begin left f(t+h) − f(t) in vs */

	/* Sleeping tiles (sleep.c; NULL: every node stepped), and the
	 * node-steps taken and those a run with every tile awake takes. */
	ndo__sleep *sleep;
	int ext_active;        /* ndo_sim_set_active gave a region (a peer) */
	double node_steps, node_steps_all;

	/* Threads (ndo_sim_params.threads; NULL: one).  The runs are cut into
	 * chunks fixed by the grid and its active set, not by the thread
	 * count: chunk c of the interior is ispan[ichunk[c] .. ichunk[c+1]),
	 * chunk nichunk the active border nodes; of the elementwise updates,
	 * espan[echunk[c] .. echunk[c+1]).  Each interior chunk's diagnostics
	 * go to cdiag[c] and are added in chunk order, so every thread count
	 * gives the same bits. */
	ndo_pool *pool;
	/* Whether the threads pay (integrate.c, threads_pick): a few steps on
	 * one thread and on all, in turn, now and then; `solo` until the next
	 * look when one was faster.  solo: steps run on the caller alone. */
	int solo;
	int probe_left;        /* steps of the look under way */
	double probe_sum[2];   /* its wall seconds, alone and on the threads */
	double probe_next;     /* the monotonic time of the next look */
	double probe_period;   /* between looks, s */
	int64_t probe_steps;   /* steps since the last look */
	int solo_last;         /* what the last look found */
	double probe_mean[2];  /* its mean step, alone and on the threads */
	double run_sum;        /* seconds of the steps on the threads since */
	int run_n;
	int picked;            /* ndo_sim_step_begin chose solo for the next step:
	                        * 1 + whether threads_pick times it, else 0 */
	size_t bytes;          /* ndo_sim_memory() of this simulation */
	int32_t *ichunk, *echunk;
	int nichunk, nechunk;
	struct ndo__diag *cdiag;

	/* RK4's step as one pipeline of (stage, chunk) units (rk4.c): built
	 * at the first step that can take it, freed when the chunks change.
	 * rk4_reference: take the four passes instead, and symplectic Euler
	 * and midpoint their passes through ndo__accel (integrate.c) rather
	 * than ndo__accel_update's fused ones, and ndo__forces_eval the face
	 * forces one item at a time (item_force) rather than in batches
	 * (tests compare). */
	struct ndo__rk4_plan *rk4_plan;
	int rk4_reference;
	/* Tests: the stencil loops of rk4.c and accel.c run every node through
	 * their scalar tails, not four at a time (ndo__v4), to compare. */
	int scalar_loops;
	/* Tests: the ring's slots per share (rk4.c, ring_layout) when fewer
	 * than its own 3L + 1, at least the 3L − 2 below which the slots'
	 * waits would close a cycle: a slot is then needed again before the
	 * wavefront has read it for the last time (0: the ring's own). */
	int rk4_ring_slots;
	/* With held nodes (a peer's region): ka[0] and ka[1], the spare state
	 * the pipeline writes the next step into, hold u's and v's values at
	 * every held node (duplicates too) but the moving ones (hmove, which
	 * each step sets), so that a step need not copy them over: set by the
	 * pipeline's first such step, kept by its steps and by ndo_sim_set*,
	 * cleared by a new region, ndo_sim_set_held_motion and the passes. */
	int spare_held;

	/* Several steps of symplectic Euler or midpoint as one pipeline of
	 * (pass, chunk) units across the steps (wave.c, ndo_sim_steps): the
	 * plan, built at the first such run and freed when the chunks or the
	 * held edges change.  wave_test (tests only; nonzero: the wave, and
	 * rk4's chain of steps (rk4.c), also where it would not pay,
	 * ndo_sim_steps): 4 in its own order, 1 in shuffled ones; 3 besides
	 * lets a unit wait only for its own chunk's pass before (wrong: the
	 * test that must catch it). */
	struct ndo__wave_plan *wave_plan;
	int wave_test;

	/* A step begun ahead (ndo_sim_step_begin): the pipeline's units that
	 * read none of the pending nodes (pend, per stored node) are done for
	 * the step from time ahead_t of size ahead_h.  Dropped (ahead = 0) by
	 * a write to any other node, a new region, held motion, the time. */
	int ahead;
	double ahead_t, ahead_h;
	uint8_t *pend;
};

/* sleep.c: the tiles (reach: rings a step's stages reach), a look every
 * few steps (1: the awake set changed; ndo__sleep_mask() holds it), the
 * canonical nodes awake, the counts. */
int ndo__sleep_create(const ndo_sim *s, double umax, double vmax, int reach, ndo__sleep **out);
void ndo__sleep_free(ndo__sleep *z);
int ndo__sleep_check(ndo__sleep *z, const ndo_sim *s);
const uint8_t *ndo__sleep_mask(const ndo__sleep *z);
void ndo__sleep_nodes(const ndo__sleep *z, size_t *awake, size_t *all);
void ndo__sleep_counts(const ndo__sleep *z, int64_t *checks, int64_t *wakes, int64_t *sleeps,
                       int *tiles, int *awake);

/* Stage diagnostics accumulated by the force evaluation. */
typedef struct ndo__diag {
	double pe2;   /* Σ u·Ku (twice the potential energy) */
	double ke2;   /* Σ m |v|² */
	double power; /* Σ f·v */
	double umax2; /* max |u|² */
	double vku;   /* Σ v·Ku (symplectic Euler's modified energy; the explicit
	               * kernels of accel.c fill it, rk4's pass leaves it 0) */
} ndo__diag;

/* The chunks' diagnostics (cdiag[0 .. nichunk]), added in chunk order. */
void ndo__diag_sum(const ndo_sim *s, ndo__diag *d);

/* The threads this step runs on (1 when alone, see `solo`). */
static inline int ndo__sim_threads_now(const ndo_sim *s)
{
	return s->solo ? 1 : ndo_pool_threads(s->pool);
}

/* fn(ctx, c) for every chunk c in 0..n−1, on the simulation's threads. */
static inline void ndo__sim_run(const ndo_sim *s, int n, void (*fn)(void *, int), void *ctx)
{
	ndo_pool_run(s->solo ? NULL : s->pool, n, fn, ctx);
}

/* Add a kernel's partial sums to the diagnostics. */
static inline void ndo__diag_add(ndo__diag *d, double pe2, double ke2, double power,
                                 double umax2)
{
	d->pe2 += pe2;
	d->ke2 += ke2;
	d->power += power;
	d->umax2 = fmax(d->umax2, umax2);
}


/* One force item's share of the force plane at some of its nodes: force
 * k, item (face or node) q, and the bits d of the item's nodes (a face's
 * three, a node's one) whose entries this evaluation adds (forces.c). */
typedef struct ndo__fitem {
	int32_t k, q;
	int32_t mask;
} ndo__fitem;

/* ndo__forces_eval restricted: zero f at the `nzero` nodes `zero`, then
 * add the items' contributions, in the order given, to the nodes their
 * masks select.  Each node gets the same additions in the same order as
 * from ndo__forces_eval when the items keep the force-then-item order
 * and every node's items are listed (no pressure forces). */
void ndo__forces_eval_items(ndo_sim *s, double t, const double *u, const int32_t *zero,
                            size_t nzero, const ndo__fitem *items, size_t nitems);
/* The canonical nodes of item q of force k (3 for a face, 1 for a node);
 * returns their count. */
int ndo__force_item_nodes(const ndo_sim *s, int k, size_t q, int32_t v[3]);

/* The chunks of the interior runs (s->ichunk) as the pipelines of (pass,
 * chunk) units see them (chunks.c; rk4.c's RK4 pipeline and wave.c's
 * steps embed one each).  A unit of chunk c writes its interior runs,
 * its active border nodes and (NDO__CHUNKS_DUPS) the seam duplicates of
 * those — rows r0[c]..r1[c], border rows 0 and n included — and reads
 * them one row further and at the nodes of its force items — rows
 * a0[c]..a1[c]; it waits for the units of the pass before of chunks
 * lo[c]..hi[c], those whose writes meet its reads or whose reads meet its
 * writes; L, the lag between passes in the wavefront, is the most chunks
 * from c to lo[c] or hi[c] counting c, at least 2.  The lists by chunk are list[off[c]..off[c+1]):
 * its active border nodes bact[blist[i]]; its active force nodes zlist[i]
 * (zfi[i]: the node's place in s->fnodes);
 * its force items fitem[i] (every item with an active node in the chunk,
 * in the forces' order, its mask those nodes); (NDO__CHUNKS_DUPS) the
 * (duplicate, canonical) pairs it copies, dlist[2i], dlist[2i + 1];
 * (NDO__CHUNKS_EDGES) its held edges hedge[elist[i]], those of its active
 * nodes.  Lists not asked for are NULL. */
typedef struct ndo__chunks {
	int C, L;
	int32_t *r0, *r1, *a0, *a1, *lo, *hi;
	int32_t *boff, *blist, *zoff, *zlist, *zfi, *foff;
	ndo__fitem *fitem;
	int32_t *doff, *dlist, *eoff, *elist;
	/* The force items compact (ndo__forces_eval_chunk): for a chunk c
	 * with cfit[c] (every item a face along its normal, the items' nodes
	 * at most NDO__CF_MAX), those nodes cnode[coff[c]..coff[c+1]), each
	 * item's three as indices into them (fci[3i + d], i as fitem's) and
	 * each active force node's (zci[i], i as zlist's). */
	uint8_t *cfit;
	int32_t *coff, *cnode, *fci, *zci;
} ndo__chunks;
#define NDO__CF_MAX 1024
enum { NDO__CHUNKS_DUPS = 1, NDO__CHUNKS_EDGES = 2 };
/* Build K for s's chunks (what: NDO__CHUNKS_ flags); NDO_ENOMEM with K
 * empty when out of memory (the caller says what for).  Freed by
 * ndo__chunks_free, which leaves K empty. */
int ndo__chunks_build(const ndo_sim *s, ndo__chunks *K, int what);
void ndo__chunks_free(ndo__chunks *K);
/* Chunk c's seam duplicates (NDO__CHUNKS_DUPS) copied from their
 * canonical nodes in the 3 planes x (a pass's output, the rows it wrote). */
void ndo__chunks_copy_dups(const ndo_sim *s, const ndo__chunks *K, int c, double *x);
/* ndo__forces_eval_items for chunk c of K, the same bits: where the
 * chunk's items are faces along their normals (K->cfit[c]) the positions
 * of their nodes made once, not once a face, and the sums kept in a
 * compact array, not in f's planes, until the end. */
void ndo__forces_eval_chunk(ndo_sim *s, double t, const double *u, const ndo__chunks *K,
                            int c);
/* Units that took the compact path (for the tests: that they ran it). */
extern _Atomic long ndo__forces_compact_units;

/* f ← external forces at time t with displacements u (forces.c). */
void ndo__forces_eval(ndo_sim *s, double t, const double *u);
int ndo__forces_resolve(ndo_sim *s, const ndo_force *forces, int nforces);
void ndo__forces_free(ndo_sim *s);

/* The force plane f at time t for displacements u: external forces plus
 * the penalty springs; NULL when there are neither (accel.c). */
const double *ndo__forces_prepare(ndo_sim *s, double t, const double *u);

/* a ← M⁻¹(f − K u − penalty) − γ v on the active nodes, for the stage
 * state (u, v) at time t (external forces evaluated here); diag may be
 * NULL (accel.c). */
void ndo__accel(ndo_sim *s, double t, const double *u, const double *v, double *a,
                ndo__diag *diag);

/* What ndo__accel_update() does with the acceleration a at each active
 * node instead of storing it, in the same pass (one sweep over the nodes
 * and one wake-up of the threads, not two), with the same arithmetic as
 * storing a and updating after (integrate.c: step_symplectic, step_rk):
 *   NDO__UPD_SYMPLECTIC  vo = v + h a,  uo = u + h vo
 *   NDO__UPD_HALF        uo = u + h (0 + ½ v),  vo = v + h (0 + ½ a)
 *                        (the midpoint's stage, as the tableau's sums)
 *   NDO__UPD_FULL        uo = u0 + h v,  vo = v0 + h a  (its finish)
 *   NDO__UPD_STORE_SE    a stored, as without an update, and the input
 *                        power taken as NDO__UPD_SYMPLECTIC takes it
 *                        (symplectic Euler's passes: the fused pass's
 *                        diagnostics, bit for bit; forward Euler's
 *                        stage, whose work is taken so too: integrate.c,
 *                        first_stage)
 * where (u, v) is the stage state the acceleration is taken at and
 * (u0, v0) the step's.  The outputs are other planes than the inputs. */
enum { NDO__UPD_SYMPLECTIC = 1, NDO__UPD_HALF, NDO__UPD_FULL, NDO__UPD_STORE_SE };
typedef struct ndo__upd {
	int mode;
	double h;
	double *uo, *vo;
	const double *u0, *v0; /* NDO__UPD_FULL */
	double *a;             /* NDO__UPD_STORE_SE */
} ndo__upd;

/* The velocity at component q that the input power takes: v, or in a
 * symplectic Euler pass (up) ½(v + v'), v' = v + h a the new one (written
 * to vo, or made from the stored a) — with the force at the step's start,
 * the power whose product with h is the step's work on the modified
 * energy that the divergence test bounds (accel.c; the power at the
 * steps' ends, by the trapezoidal rule, missed a push between two ends
 * where the power is 0); forward Euler's is taken so too (integrate.c,
 * first_stage). */
static inline double ndo__power_velocity(const ndo__upd *up, const double *v, size_t q)
{
	if (!up)
		return v[q];
	if (up->mode == NDO__UPD_SYMPLECTIC)
		return 0.5 * (v[q] + up->vo[q]);
	if (up->mode == NDO__UPD_STORE_SE)
		return 0.5 * (v[q] + (v[q] + up->h * up->a[q]));
	return v[q];
}

/* The power the held nodes put into the active ones, and the penalty
 * springs' share of the diagnostics moved from input power to potential
 * energy, at the velocities ndo__power_velocity takes (up: the pass's
 * update, or NULL) (accel.c; the fused RK4 kernel calls them too). */
double ndo__held_power(const ndo_sim *s, const double *u, const double *v, const ndo__upd *up);
void ndo__penalty_diag(const ndo_sim *s, const double *u, const double *v, const ndo__upd *up,
                       ndo__diag *d);

/* ndo__accel's acceleration, used at once as `up` says (accel.c). */
void ndo__accel_update(ndo_sim *s, double t, const double *u, const double *v,
                       const ndo__upd *up, ndo__diag *diag);

/* The same over interior runs [k0, k1) only, diagnostics added to d (may
 * be NULL), and over the active border nodes bact[list[0..n)] (their
 * diagnostics, when terms is not NULL, as NDO__BTERMS numbers a node at
 * terms + NDO__BTERMS · k for bact[k]; ndo__border_terms_sum adds them in
 * the border's order, as a pass over every border node does): the
 * pieces of a pass the wave runs chunk by chunk (wave.c; accel.c). */
enum { NDO__BTERMS = 13 };
void ndo__accel_runs(const ndo_sim *s, const double *u, const double *v, const double *F,
                     const ndo__upd *up, ndo__diag *d, size_t k0, size_t k1);
void ndo__accel_border_nodes(const ndo_sim *s, const double *u, const double *v, const double *F,
                             const ndo__upd *up, const int32_t *list, size_t n, double *terms);
void ndo__border_terms_sum(const ndo_sim *s, const double *terms, ndo__diag *d);

/* The divergence test on a diagnosed state at the start of a step
 * (accel.c).  commit: close the last step's work with this power. */
int ndo__diverged(ndo_sim *s, const ndo__diag *d, int commit);
/* Whether ndo__diverged, given diagnostics d, would measure the
 * deformation of s's state (a node, an integrated one or a projected pin,
 * beyond 100 × the rest size from rest, past the drift seen so far): it reads the state, so its caller must hold
 * the state d describes (wave.c's runs test after the fact: integrate.c
 * runs them again up to that step first). */
int ndo__size_needs_state(const ndo_sim *s, const ndo__diag *d);
/* With s holding that state: 1, and the drift noted, when no integrated
 * node nor projected pin is 100 × the rest size from the integrated nodes'
 * mass-weighted mean displacement; 0 otherwise (ndo__diverged then
 * fails). */
int ndo__size_is_drift(ndo_sim *s, const ndo__diag *d);
/* The largest distance of an integrated node's displacement, or a
 * projected pin's (s->ppin), from the integrated nodes' mass-weighted mean
 * (mean: that mean; *pin, when not NULL: whether that node is a pin;
 * accel.c). */
double ndo__deformation(const ndo_sim *s, double mean[3], int *pin);

/* The input work so far, the last step's included. */
void ndo__pending_work(const ndo_sim *s, double *w, double *w_abs);

/* The velocities an input power is taken at: V's component c of node p
 * at V[c·vs + p + vd] (rk4.c's ring; elsewhere vs = count, vd = 0); or,
 * with V1 (or A) given, the mean ½(V + V1) of a step's velocities before
 * and after it, V1 = V + h A when only A is kept — the same bits either
 * way where V1 was made so (midpoint's work: integrate.c, step_rk). */
typedef struct ndo__vel {
	const double *V;
	size_t vs;
	ptrdiff_t vd;
	const double *V1, *A;
	double h;
} ndo__vel;

static inline double ndo__vel_at(const ndo__vel *w, int c, size_t p)
{
	const size_t q = (size_t)((ptrdiff_t)((size_t)c * w->vs + p) + w->vd);
	const double x = w->V[q];
	if (w->V1)
		return 0.5 * (x + w->V1[q]);
	if (w->A)
		return 0.5 * (x + (x + w->h * w->A[q]));
	return x;
}

/* The input power at a stage whose forces F holds (ndo__forces_prepare's
 * plane at the stage's time and displacements U, or NULL), at the
 * velocities w: f·V at the active force nodes in the order of s->fnodes
 * (every active node, in index order, with pressure), f the external
 * forces alone (the penalty springs' share taken out), then the held
 * nodes' power Σ V_p c U_q (ndo__held_power's order).  The pipelines
 * (rk4.c, wave.c) keep the same terms per node (ndo__fv, ndo__held_term)
 * and add them in this order (ndo__stage_power_sum): the same bits on
 * every path and thread count (accel.c). */
double ndo__stage_power(const ndo_sim *s, const double *F, const double *U, const ndo__vel *w);

/* One force node's term of it: Σ_c F_c V_c, in the order of c. */
static inline double ndo__fv(const double *F, const ndo__vel *w, size_t p, size_t cnt)
{
	return F[p] * ndo__vel_at(w, 0, p) + F[cnt + p] * ndo__vel_at(w, 1, p) +
	       F[2 * cnt + p] * ndo__vel_at(w, 2, p);
}

/* One held edge's term for component c: V_p c U_q (ndo__held_power's). */
static inline double ndo__held_term(const ndo_sim *s, const ndo__edge *e, const double *U,
                                    const ndo__vel *w, int c)
{
	return ndo__vel_at(w, c, (size_t)e->p) * e->c * U[(size_t)c * s->count + (size_t)e->q];
}

/* The stage power from per-node terms: ft[k] the term of force node
 * s->fnodes[k] (read only where that node is active), et[3e + c] held edge
 * e's; the sum ndo__stage_power makes (no penalty pins, no pressure: the
 * pipelines take neither). */
double ndo__stage_power_sum(const ndo_sim *s, const double *ft, const double *et);


/* Implicit methods (implicit.c). */
int ndo__implicit_step(ndo_sim *s, double h);
void ndo__implicit_free(ndo_sim *s);
void ndo__implicit_invalidate(ndo_sim *s, int pattern);
/* The start of an implicit step of size h: the acceleration a at the
 * state (in ka[0]) with the divergence test, and f(t+h) − f(t) (in vs;
 * NULL without forces), f then holding f(t+h) (implicit.c). */
int ndo__implicit_prepare(ndo_sim *s, double h, double **a, double **df);
/* The implicit step of size h done (s->u, s->v its new state, f and df
 * still ndo__implicit_prepare's): its input work closed (implicit.c). */
void ndo__implicit_account(ndo_sim *s, double h);
/* The stencil's 6 neighbours (stored indices) and coefficients of
 * canonical node p, as the implicit system's row p has them. */
void ndo__row_stencil(const ndo_sim *s, size_t p, int32_t nb[6], double cf[6]);
/* ndo_sim_implicit_rows: how many rows take the interior loop (tests) */
size_t ndo__rows_regular(const ndo_sim_rows *r);
/* The multigrid solver's bytes at a level: hierarchy, vectors, assembly. */
double ndo__implicit_mg_bytes(int level);

/* Held nodes of a stage buffer at the state's u (keep), or at u + τ v
 * when they move with their velocities (at) (integrate.c). */
void ndo__held_keep(ndo_sim *s, double *buf);
void ndo__held_at(ndo_sim *s, double *buf, double tau);

/* One classic RK4 step, without the work accounting (rk4.c), and the
 * pipeline's plan freed (the chunks changed). */
int ndo__rk4_step(ndo_sim *s, double h);
void ndo__rk4_plan_free(ndo_sim *s);
/* The chunks whose ring slot an earlier chunk of the same step used
 * (0 before the pipeline's first step; tests). */
int ndo__rk4_ring_reuses(const ndo_sim *s);
int ndo__rk4_begin(ndo_sim *s, double h, size_t n, const int32_t *pending);
/* RK4's steps as a chain (rk4.c, ndo_sim_steps), as the wave's below:
 * whether it can take them, and how many a run takes; m steps from times
 * t[0..m) into spare planes, the state left alone; step j's stage-0
 * diagnostics; step j's stage powers into s->stage_power (stage 0's
 * given); the state after m steps swapped in. */
int ndo__rk4_chain_fits(const ndo_sim *s);
int ndo__rk4_chain_batch(const ndo_sim *s);
int ndo__rk4_chain_run(ndo_sim *s, double h, int m, const double *t);
void ndo__rk4_chain_diag(ndo_sim *s, int j, ndo__diag *d);
void ndo__rk4_chain_powers(ndo_sim *s, int j, double last_power);
void ndo__rk4_chain_commit(ndo_sim *s, int m);
/* The most steps a run of the RK4 pipeline has taken (tests). */
int ndo__rk4_chain_cap(const ndo_sim *s);

/* The wave (wave.c): whether it can take this simulation's steps; m
 * steps of size h from the state (u, v) at times t[0..m) into spare planes,
 * the state left alone; step j's first-pass diagnostics as the passes sum
 * them; the state after the m steps swapped in.  The plan freed. */
int ndo__wave_fits(const ndo_sim *s);
int ndo__wave_run(ndo_sim *s, double h, int m, const double *t);
void ndo__wave_diag(ndo_sim *s, int j, ndo__diag *d);
/* Midpoint: step j's input power, its stage's force at the step's mean
 * velocity (ndo__stage_power's sum). */
double ndo__wave_power(const ndo_sim *s, int j);
void ndo__wave_commit(ndo_sim *s, int m);
int ndo__wave_batch(ndo_sim *s);
void ndo__wave_plan_free(ndo_sim *s);

/* Copy the canonical values of the stage planes to their duplicates
 * (accel.c). */
void ndo__sync_planes(const ndo_sim *s, double *planes, int nplanes);

/* K re-assembled from the deformed shape X + u (integrate.c); _due: when
 * a step starts and the restiffen period says so. */
#define NDO__K_STALE INT64_MIN
int ndo__restiffen(ndo_sim *s, int from_rest);
int ndo__restiffen_due(ndo_sim *s);
int ndo__restiffen_pending(const ndo_sim *s);

/* R(z) = Σ r_k z^k of an explicit Runge–Kutta method; returns the
 * degree, or −1 for a method that is not one (integrate.c). */
int ndo__stability_poly(ndo_method m, double r[7]);

/* ndo_stable_step (fast 1: what it runs) or the same with every mode's scan
 * in full (0): the slow reference test_sim checks it against (stability.c). */
double ndo__stable_step_scan(ndo_method m, double omega, double gamma, int *bound, int fast);

/* ndo_sim_critical (fast 1: what it runs) or the same with the power
 * iteration's passes one after the other (0): the reference (stability.c). */
int ndo__sim_critical(ndo_sim *s, ndo_critical *c, int fast);

/* One step of the simulation's explicit Runge–Kutta method through the
 * generic tableau path (the reference the fused RK4 kernel is tested
 * against). */
int ndo__step_tableau(ndo_sim *s, double h);

/* The largest |row sum − c_i|, |Σ b − 1| of the method's tableau. */
int ndo__tableau_check(ndo_method m, double *worst);

#endif
