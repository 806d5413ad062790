/* rk4.c — classic RK4 (ndo/sim.h's NDO_RK4) in low-storage form, each
 * stage one pass over the nodes that fuses the stencil, the acceleration,
 * the running sums of the final combination and the next stage's state:
 *   stage 0  (U, V) = (u, v):    Σu = V, Σv = a;     next = (u, v) + h/2 (V, a)
 *   stage 1, 2:                  Σu += 2V, Σv += 2a; next = (u, v) + c (V, a)
 *   stage 3:                     (u, v) += h/6 (Σu + V, Σv + a)
 * Stage displacements alternate between two buffers (the stencil reads
 * the neighbours' old values); stage velocities are only read at their own
 * node, so one buffer is updated in place.  Same arithmetic as the tableau
 * path (integrate.c, rk_stages) up to the order of the additions.
 *
 * Two ways to run the four passes, the same bits:
 *
 * - passes: each stage over every chunk on the simulation's threads, the
 *   forces and the seams' copies between them (four wake-ups of the
 *   threads and four sweeps over all the state a step);
 * - the pipeline (no penalty pins, no pressure): the stencil reaches one row, and every
 *   seam joins nodes of one row (ndo/topology.h), so stage k of a chunk of
 *   rows needs only stage k − 1 of the chunks that hold its rows ± 1.  A
 *   step is one run on the threads.  Each thread walks the units (stage,
 *   chunk) in wavefront order — stage k of chunk c at position c + k·L, L
 *   chunks behind the stage before — so that the rows a unit reads were
 *   written a few units before and are still in cache (a window of about
 *   3L + 1 chunks of 512 nodes); the first thread from the bottom row up,
 *   the second from the top down, further pairs from the middle of their
 *   own share, so that they meet only at the ends of their shares.  A
 *   thread claims a unit before running it, skips the units others have
 *   claimed, and first runs itself any unit it reads that nobody has
 *   claimed; it waits (on a condition variable, never spinning) only for a
 *   unit another thread is running — a unit of the stage before, so no
 *   wait closes a cycle — and alone, a thread runs every unit.  A unit's
 *   forces, border nodes and seam copies are done in it, for its rows.  Stage 3 writes the new state to spare buffers, swapped in once
 *   the divergence test (on stage 0's diagnostics) has passed, so that a
 *   step that diverges leaves the state as it was, as the passes do.
 *   Held nodes (a peer's region and halo, ndo_sim_set_active): a chunk
 *   is any runs of active nodes, so a row may be shared by two chunks or
 *   have no run; each unit waits for the units whose rows meet its rows
 *   ± 1 (chunks.c), copies only the seam duplicates of the nodes it
 *   wrote, and stage 2 writes a third buffer, its held nodes at t + h
 *   while stage 1 reads stage 0's at t + h/2; the spare state keeps the
 *   held nodes' values from step to step (sim_private.h, spare_held).
 *   The stage velocity and the two running sums, read only at their own
 *   node, are needed from stage 0 of a chunk to its stage 3: in the
 *   pipeline they live in a ring of chunk-sized slots (ring_layout), R =
 *   3L + 1 a thread's share of the chunks, reused in the wavefront's
 *   order (stage 0 of a chunk waits for stage 3 of the slot's chunk
 *   before), so that they stay in cache and are never written back to
 *   memory; the two stage displacements, read at the neighbours, stay
 *   whole planes.
 *
 * A chain of steps (ndo_sim_steps; held nodes, pins, that do not move):
 * two steps as one run of the pipeline, stage k of step j being pass
 * 4j + k, so that the threads wait neither between the stages nor between
 * the steps (as wave.c does for symplectic Euler and midpoint).  Step j
 * goes from state X_j to X_{j+1}: X_0 the simulation's (u, v), never
 * written, then (ka[0], ka[1]) and (ka[3], tmp) in turn, each with the held
 * nodes' u and v (spare_held; copied into X_2 at the start of a run);
 * stage 0 of step j + 1 of a chunk waits
 * for stage 3 of step j of the chunks beside it, which also keeps it from
 * overwriting stage displacements those still read; the ring holds its
 * slots twice, one set for the even steps and one for the odd.  Each
 * step's diagnostics and stage powers are kept per chunk, so that the
 * divergence tests are made after the run in order, as single steps
 * make them (integrate.c, steps_wave: a step that fails, the run again
 * up to it from X_0).
 *
 * Stages 1-3 run the three coordinates in one loop (the edge planes and
 * 1/m loaded once a node); stage 0 one loop a coordinate, the order its
 * diagnostics are summed in. */
#include "sim_private.h"
#include "units.h"
#include "ndo/status.h"

#include <stdlib.h>
#include <string.h>

enum { RK4_FIRST, RK4_MID, RK4_LAST, RK4_LAST_TO };

typedef struct rk4_pass {
	const double *U;  /* stage displacement (3 planes) */
	double *Un;       /* the next stage's (RK4_FIRST, RK4_MID) */
	double *vs;       /* the stage velocity buffer */
	double *su, *sv;  /* the running sums */
	double *u, *v;    /* the state */
	double *uo, *vo;  /* RK4_LAST_TO: the new state (RK4_LAST: in place) */
	const double *F;  /* forces or NULL */
	double c, h6;
	/* vs, su and sv: node p's coordinate comp at [comp·ss + p + sd] (the
	 * passes: whole planes, ss = count, sd = 0; the pipeline: a chunk's
	 * slot of the ring, sd = slot start − first row's start) */
	size_t ss;
	ptrdiff_t sd;
} rk4_pass;

static inline __attribute__((always_inline)) void
rk4_interior(const ndo_sim *s, const rk4_pass *g, const int mode, const int hasF, ndo__diag *d,
             const size_t k0, const size_t k1)
{
	const size_t cnt = s->count, w = (size_t)s->w;
	const double *restrict e0 = s->st.e[0], *restrict e1 = s->st.e[1],
	                       *restrict e2 = s->st.e[2];
	const double *restrict minv = s->minv, *restrict mass = s->mass;
	/* The damping rate is the same at every node (integrate.c: b/ρ + a):
	 * one number, not a plane streamed through every pass. */
	const double ga = s->gam[0];
	const double c = g->c, h6 = g->h6;
	double pe2 = 0, ke2 = 0, pw = 0, um = 0;
	for (size_t k = k0; k < k1; k++) {
		const size_t lo = (size_t)s->ispan[k].a, hi = (size_t)s->ispan[k].b;
		if (mode != RK4_FIRST) {
			/* The three coordinates in one loop: the edge planes and 1/m
			 * loaded once a node, not three times.  (Stage 0 keeps one loop a
			 * coordinate: its diagnostics are summed in that order.) */
			const ptrdiff_t so = (ptrdiff_t)lo + g->sd;
#define RK4_PLANES(comp)                                                                    \
	const size_t o##comp = (comp) * cnt;                                                    \
	const ptrdiff_t r##comp = (ptrdiff_t)((comp) * g->ss) + so;                             \
	const double *restrict U##comp = g->U + o##comp;                                        \
	const double *restrict F##comp = hasF ? g->F + o##comp : NULL;                          \
	double *restrict Un##comp = mode == RK4_MID ? g->Un + o##comp : NULL;                   \
	double *restrict u##comp = g->u + o##comp, *restrict v##comp = g->v + o##comp;          \
	double *restrict uo##comp = mode == RK4_LAST_TO ? g->uo + o##comp : NULL;               \
	double *restrict vo##comp = mode == RK4_LAST_TO ? g->vo + o##comp : NULL;               \
	double *restrict su##comp = g->su + r##comp, *restrict sv##comp = g->sv + r##comp;      \
	double *restrict vs##comp = g->vs + r##comp;
			RK4_PLANES(0)
			RK4_PLANES(1)
			RK4_PLANES(2)
#undef RK4_PLANES
			/* Four nodes at a time (sim_private.h, ndo__v4), then the rest
			 * one at a time: one text for both (RK4_NODE, T the type, L a
			 * load, S a store, Z T's zero), so the same operations in the
			 * same order. */
#define RK4_COORD(comp, T, L, S, Z)                                                         \
	do {                                                                                \
		const double *restrict U = U##comp;                                             \
		const T up = L(U + p);                                                          \
		const T ku = E0 * (up - L(U + p + 1)) + E1 * (up - L(U + p + w)) +              \
		             E2 * (up - L(U + p + w - 1)) + E0m * (up - L(U + p - 1)) +          \
		             E1m * (up - L(U + p - w)) + E2m * (up - L(U + p - w + 1));          \
		const T f = hasF ? L(F##comp + p) : Z, vp = L(vs##comp + i);                    \
		const T a = mi * (f - ku) - ga * vp;                                            \
		if (mode == RK4_MID) {                                                          \
			S(su##comp + i, L(su##comp + i) + 2 * vp);                                  \
			S(sv##comp + i, L(sv##comp + i) + 2 * a);                                   \
			S(Un##comp + p, L(u##comp + p) + c * vp);                                   \
			S(vs##comp + i, L(v##comp + p) + c * a);                                    \
		} else if (mode == RK4_LAST) {                                                  \
			S(u##comp + p, L(u##comp + p) + h6 * (L(su##comp + i) + vp));               \
			S(v##comp + p, L(v##comp + p) + h6 * (L(sv##comp + i) + a));               \
		} else {                                                                        \
			S(uo##comp + p, L(u##comp + p) + h6 * (L(su##comp + i) + vp));              \
			S(vo##comp + p, L(v##comp + p) + h6 * (L(sv##comp + i) + a));              \
		}                                                                               \
	} while (0)
#define RK4_NODE(T, L, S, Z)                                                                \
	do {                                                                                \
		const size_t i = p - lo;                                                        \
		const T E0 = L(e0 + p), E1 = L(e1 + p), E2 = L(e2 + p), E0m = L(e0 + p - 1),    \
		        E1m = L(e1 + p - w), E2m = L(e2 + p - w + 1), mi = L(minv + p);         \
		RK4_COORD(0, T, L, S, Z);                                                       \
		RK4_COORD(1, T, L, S, Z);                                                       \
		RK4_COORD(2, T, L, S, Z);                                                       \
	} while (0)
			size_t p = lo;
			const size_t vend = s->scalar_loops ? lo : hi;
			for (; p + 4 <= vend; p += 4)
				RK4_NODE(ndo__v4, V4_LD, V4_ST, ((ndo__v4){0, 0, 0, 0}));
			for (; p < hi; p++)
				RK4_NODE(double, V1_LD, V1_ST, 0);
#undef RK4_NODE
#undef RK4_COORD
			continue;
		}
		for (int comp = 0; comp < 3; comp++) {
			const size_t o = (size_t)comp * cnt;
			const double *restrict U = g->U + o;
			const double *restrict F = hasF ? g->F + o : NULL;
			double *restrict Un = g->Un + o;
			double *restrict u = g->u + o, *restrict v = g->v + o;
			/* vs, su, sv from node lo on, indexed p − lo (rk4_pass: ss, sd);
			 * RK4_FIRST reads v and writes vs */
			const ptrdiff_t so = (ptrdiff_t)((size_t)comp * g->ss + lo) + g->sd;
			double *restrict su = g->su + so, *restrict sv = g->sv + so;
			double *restrict vs = g->vs + so;
			/* Stage 0 (only it comes here): four nodes at a time as the stages
			 * after it, its diagnostics summed as GCC's vectorized reduction of
			 * the omp simd loop this replaces summed them on AVX2 — one sum a
			 * lane over the four-node steps, the last 0-3 nodes added to lane
			 * 0, then the lanes added to the running sum in order — so the
			 * same bits as before there. */
			ndo__v4 P = {0, 0, 0, 0}, K = {0, 0, 0, 0}, W = {0, 0, 0, 0};
#define RK4_FIRST_NODE(T, L, S, Z, P, K, W)                                                 \
	do {                                                                                \
		const size_t i = p - lo;                                                        \
		const T up = L(U + p);                                                          \
		const T ku = L(e0 + p) * (up - L(U + p + 1)) + L(e1 + p) * (up - L(U + p + w)) + \
		             L(e2 + p) * (up - L(U + p + w - 1)) +                               \
		             L(e0 + p - 1) * (up - L(U + p - 1)) +                               \
		             L(e1 + p - w) * (up - L(U + p - w)) +                               \
		             L(e2 + p - w + 1) * (up - L(U + p - w + 1));                        \
		const T f = hasF ? L(F + p) : Z, vp = L(v + p);                                 \
		const T a = L(minv + p) * (f - ku) - ga * vp;                                   \
		S(su + i, vp);                                                                  \
		S(sv + i, a);                                                                   \
		S(Un + p, L(u + p) + c * vp);                                                   \
		S(vs + i, L(v + p) + c * a);                                                    \
		P += up * ku;                                                                   \
		K += L(mass + p) * vp * vp;                                                     \
		W += f * vp;                                                                    \
	} while (0)
			size_t p = lo;
			const size_t vend = s->scalar_loops ? lo : hi;
			for (; p + 4 <= vend; p += 4)
				RK4_FIRST_NODE(ndo__v4, V4_LD, V4_ST, ((ndo__v4){0, 0, 0, 0}), P, K, W);
			double P0 = P[0], K0 = K[0], W0 = W[0];
			for (; p < hi; p++)
				RK4_FIRST_NODE(double, V1_LD, V1_ST, 0, P0, K0, W0);
#undef RK4_FIRST_NODE
			pe2 += P0, pe2 += P[1], pe2 += P[2], pe2 += P[3];
			ke2 += K0, ke2 += K[1], ke2 += K[2], ke2 += K[3];
			pw += W0, pw += W[1], pw += W[2], pw += W[3];
		}
		if (d) {
			const double *restrict ux = g->U, *restrict uy = g->U + cnt, *restrict uz = g->U + 2 * cnt;
#pragma omp simd reduction(max : um)
			for (size_t p = lo; p < hi; p++) {
				const double u2 = ux[p] * ux[p] + uy[p] * uy[p] + uz[p] * uz[p];
				um = u2 > um ? u2 : um; /* not fmax: a libm call stops vectorization */
			}
		}
	}
	if (d)
		ndo__diag_add(d, pe2, ke2, pw, um);
}

/* Border nodes' diagnostics as the pipeline keeps them, to be added in
 * the border's order afterwards: per node, u·Ku, m v², f·v for each
 * coordinate, then |u|². */
enum { RK4_BTERMS = 10 };

/* The same for active border nodes (neighbour tables): bact[list[i]] for i
 * in 0..n−1, or every one (list NULL).  Stage 0's diagnostics go to d, or
 * (the pipeline) to terms, RK4_BTERMS per node. */
static inline __attribute__((always_inline)) void
rk4_border_nodes(const ndo_sim *s, const rk4_pass *g, const int mode, const int32_t *list,
                 size_t n, ndo__diag *d, double *terms)
{
	const size_t cnt = s->count;
	for (size_t i = 0; i < n; i++) {
		size_t k = list ? (size_t)list[i] : i;
		size_t b = (size_t)s->bact[k], p = (size_t)s->st.border[b];
		const int32_t *nb = s->st.bnb + 6 * b;
		const double *cf = s->st.bc + 6 * b;
		double *t = terms ? terms + RK4_BTERMS * k : NULL;
		/* the three coordinates' stencil sums first, each in its own
		 * order as before; then the coordinates one after the other, so
		 * the diagnostics are summed in the same order */
		double up[3], ku[3] = {0, 0, 0};
		for (int comp = 0; comp < 3; comp++)
			up[comp] = g->U[(size_t)comp * cnt + p];
		for (int j = 0; j < 6; j++) {
			size_t q = (size_t)nb[j];
			for (int comp = 0; comp < 3; comp++)
				ku[comp] += cf[j] * (up[comp] - g->U[(size_t)comp * cnt + q]);
		}
		double u2 = 0;
		for (int comp = 0; comp < 3; comp++) {
			size_t q = (size_t)comp * cnt + p;
			size_t qs = (size_t)((ptrdiff_t)((size_t)comp * g->ss + p) + g->sd); /* vs, su, sv */
			double f = g->F ? g->F[q] : 0;
			double vp = mode == RK4_FIRST ? g->v[q] : g->vs[qs];
			double a = s->minv[p] * (f - ku[comp]) - s->gam[p] * vp;
			if (mode == RK4_FIRST) {
				g->su[qs] = vp;
				g->sv[qs] = a;
				g->Un[q] = g->u[q] + g->c * vp;
				g->vs[qs] = g->v[q] + g->c * a;
				if (d) {
					d->pe2 += up[comp] * ku[comp];
					d->ke2 += s->mass[p] * vp * vp;
					d->power += f * vp;
				}
				if (t) {
					t[comp] = up[comp] * ku[comp];
					t[3 + comp] = s->mass[p] * vp * vp;
					t[6 + comp] = f * vp;
				}
				u2 += up[comp] * up[comp];
			} else if (mode == RK4_MID) {
				g->su[qs] += 2 * vp;
				g->sv[qs] += 2 * a;
				g->Un[q] = g->u[q] + g->c * vp;
				g->vs[qs] = g->v[q] + g->c * a;
			} else if (mode == RK4_LAST) {
				g->u[q] += g->h6 * (g->su[qs] + vp);
				g->v[q] += g->h6 * (g->sv[qs] + a);
			} else {
				g->uo[q] = g->u[q] + g->h6 * (g->su[qs] + vp);
				g->vo[q] = g->v[q] + g->h6 * (g->sv[qs] + a);
			}
		}
		if (d)
			d->umax2 = fmax(d->umax2, u2);
		if (t)
			t[9] = u2;
	}
}

/* One loop per mode (a constant in each): the mode's tests out of the
 * node loop. */
static void rk4_border(const ndo_sim *s, const rk4_pass *g, int mode, const int32_t *list,
                       size_t n, ndo__diag *d, double *terms)
{
	switch (mode) {
	case RK4_FIRST: rk4_border_nodes(s, g, RK4_FIRST, list, n, d, terms); break;
	case RK4_MID: rk4_border_nodes(s, g, RK4_MID, list, n, d, terms); break;
	case RK4_LAST: rk4_border_nodes(s, g, RK4_LAST, list, n, d, terms); break;
	default: rk4_border_nodes(s, g, RK4_LAST_TO, list, n, d, terms);
	}
}

/* Interior runs [k0, k1) of a pass (constant arguments: the compiler
 * makes one loop per combination). */
NDO_HOT static void rk4_runs(const ndo_sim *s, const rk4_pass *g, int mode, ndo__diag *d,
                             size_t k0, size_t k1)
{
#define RUNS(M, D)                                                                          \
	(g->F ? rk4_interior(s, g, M, 1, D, k0, k1) : rk4_interior(s, g, M, 0, D, k0, k1))
	switch (mode) {
	case RK4_FIRST: RUNS(RK4_FIRST, d); break;
	case RK4_MID: RUNS(RK4_MID, NULL); break;
	case RK4_LAST: RUNS(RK4_LAST, NULL); break;
	default: RUNS(RK4_LAST_TO, NULL);
	}
#undef RUNS
}

/* ---- the passes ------------------------------------------------------------ */

/* One chunk of a pass: interior runs, or (the last chunk) the border. */
typedef struct rk4_job {
	const ndo_sim *s;
	const rk4_pass *g;
	int mode, diag;
} rk4_job;

static void rk4_chunk(void *arg, int c)
{
	const rk4_job *j = arg;
	const ndo_sim *s = j->s;
	ndo__diag *d = j->diag ? &s->cdiag[c] : NULL;
	if (d)
		memset(d, 0, sizeof *d);
	if (c == s->nichunk)
		rk4_border(s, j->g, j->mode, NULL, s->nbact, d, NULL);
	else
		rk4_runs(s, j->g, j->mode, d, (size_t)s->ichunk[c], (size_t)s->ichunk[c + 1]);
}

/* A pass of stage k at time t; stages 1-3 keep their input power (the
 * stage velocity read before the pass overwrites it with the next's). */
static void rk4_pass_run(ndo_sim *s, rk4_pass *g, int mode, int k, double t, ndo__diag *d)
{
	g->F = ndo__forces_prepare(s, t, g->U);
	if (k > 0) {
		const ndo__vel w = {g->vs, s->count, 0, NULL, NULL, 0};
		s->stage_power[k] = ndo__stage_power(s, g->F, g->U, &w);
	}
	rk4_job j = {s, g, mode, d != NULL};
	ndo__sim_run(s, s->nichunk + 1, rk4_chunk, &j);
	if (d) {
		ndo__diag_sum(s, d);
		d->power += ndo__held_power(s, g->U, g->v, NULL);
		ndo__penalty_diag(s, g->U, g->v, NULL, d);
	}
	s->stats.evaluations++;
}

static int step_passes(ndo_sim *s, double h)
{
	/* Buffers: A = us and B = kv[1] for the stage displacements, vs for the
	 * stage velocity, kv[2] and kv[3] for the running sums. */
	double *A = s->us, *B = s->kv[1];
	if (s->any_held) {
		/* Held nodes keep u in both stage buffers. */
		ndo__held_keep(s, A);
		ndo__held_keep(s, B);
		ndo__held_at(s, A, h / 2);
		ndo__held_at(s, B, h / 2);
	}
	rk4_pass g = {s->u, A, s->vs, s->kv[2], s->kv[3], s->u, s->v, NULL, NULL, NULL,
	              h / 2, h / 6, s->count, 0};
	ndo__diag d;
	rk4_pass_run(s, &g, RK4_FIRST, 0, s->t, &d);
	s->last_power = s->stage_power[0] = d.power;
	int rc = ndo__diverged(s, &d, 1);
	if (rc)
		return rc;
	ndo__sync_planes(s, A, 3);
	g.U = A, g.Un = B;
	rk4_pass_run(s, &g, RK4_MID, 1, s->t + h / 2, NULL);
	ndo__sync_planes(s, B, 3);
	g.U = B, g.Un = A, g.c = h;
	rk4_pass_run(s, &g, RK4_MID, 2, s->t + h / 2, NULL);
	ndo__sync_planes(s, A, 3);
	ndo__held_at(s, A, h);
	g.U = A, g.Un = NULL;
	rk4_pass_run(s, &g, RK4_LAST, 3, s->t + h, NULL);
	ndo__held_at(s, s->u, h);
	ndo__sync_planes(s, s->u, 3);
	ndo__sync_planes(s, s->v, 3);
	return NDO_OK;
}

/* ---- the pipeline ------------------------------------------------------------ */

struct ndo__rk4_plan {
	ndo__chunks ch;        /* what each chunk writes, reads and waits for
	                        * (sim_private.h); with held nodes, the seam
	                        * duplicates it copies (ch.dlist) */
	uint8_t *late;         /* 4·C: the unit reads a pending node (ndo_sim_step_begin) */
	int32_t *plist;        /* ... of these pending nodes (pn; s->pend marks them) */
	size_t pn;
	int marked, early;     /* late[] and s->pend are plist's; its units not late */
	int held;              /* the region has held nodes (a peer's) */
	/* Per step of a run (cap steps: one, or a chain's m): stage 0's
	 * diagnostics, per chunk (C) and as RK4_BTERMS terms per active border
	 * node; stages 1-3's input power as terms (ndo__stage_power_sum): each
	 * force node's (s->nfnodes a stage) and each held edge's (3·nhedge) */
	int cap;
	ndo__diag *dg;
	double *bterms;
	double *ft, *et;
	/* The ring (ring_layout): the stage velocity and the running sums, read
	 * at their own node only, live from stage 0 of a chunk to its stage 3,
	 * in one of R = 3L + 1 slots of S nodes of the share of the thread
	 * that walks its chunks; stage 0 of chunk c waits for stage 3 of
	 * prev[c], the slot's chunk before. */
	int R, ring_T;         /* slots a share; the thread count of slot[], prev[] */
	size_t S;              /* a slot: rows r0..r1 of the widest chunk */
	int32_t *slot, *prev;
	int32_t *prevn;        /* the slot's last chunk in a step, which a chain's
	                        * share's first R chunks wait for two steps later */
	size_t nslot;          /* the slots; the ring holds them twice: a chain's
	                        * even steps take the first, odd steps the second */
	uint8_t *alone;        /* chunks on a slot of their own, out of the shares'
	                        * turns (late ones, ndo_sim_step_begin) */
	double *rvs, *rsu, *rsv; /* the ring: vs, su, sv, 3 planes of rps each */
	size_t rps;
	size_t ring_cap;       /* slots in ring, when the passes' planes are too small */
	double *ring;
	ndo__units u;          /* the run's units' states, 4·cap·C */
};

void ndo__rk4_plan_free(ndo_sim *s)
{
	struct ndo__rk4_plan *P = s->rk4_plan;
	if (!P)
		return;
	ndo__chunks_free(&P->ch);
	free(P->late), free(P->plist), free(P->dg), free(P->bterms), free(P->ft), free(P->et);
	free(P->slot), free(P->prev), free(P->prevn), free(P->alone), free(P->ring);
	ndo__units_destroy(&P->u);
	free(P);
	s->rk4_plan = NULL;
}

/* Whether the pipeline can take this simulation's steps: a region with held
 * nodes (a peer's) too, at any size.  On a quiet machine (bench_simulate
 * region, docs/bench/peers-regions.md) each 2-peer region at levels 6-8
 * stepped 1.05-1.38x faster through it than through the passes in 10 of 12
 * cases (bands of whole rows 1.05-1.15x in all 6), 0.96-0.97x in two
 * quad-tree regions; an earlier bound of 32,768 nodes came from runs under
 * load. */
static int pipeline_fits(const ndo_sim *s)
{
	return !s->rk4_reference && s->npen == 0 && !s->has_pressure && s->n >= 2 &&
	       s->nispan >= 1 && s->nichunk >= 1;
}

/* The per-step arrays for runs of up to m steps. */
static int plan_cap(const ndo_sim *s, struct ndo__rk4_plan *P, int m)
{
	if (m <= P->cap)
		return NDO_OK;
	const size_t C = (size_t)P->ch.C, M = (size_t)m;
	free((void *)P->u.state), free(P->dg), free(P->bterms), free(P->ft), free(P->et);
	P->u.state = malloc(4 * M * C * sizeof *P->u.state);
	P->dg = malloc(M * C * sizeof *P->dg);
	P->bterms = malloc((M * RK4_BTERMS * s->nbact + 1) * sizeof *P->bterms);
	P->ft = malloc((M * 3 * s->nfnodes + 1) * sizeof *P->ft);
	P->et = malloc((M * 9 * s->nhedge + 1) * sizeof *P->et);
	P->cap = m;
	if (P->u.state && P->dg && P->bterms && P->ft && P->et)
		return NDO_OK;
	P->cap = 0;
	return NDO_ENOMEM;
}

/* The plan: the chunks (chunks.c), with held nodes their seam
 * duplicates too (without, every interior row is one run, so a chunk is
 * whole rows and copies its rows' seams: sync_rows), then the ring's
 * slots and a step's diagnostics. */
static int plan_build(ndo_sim *s)
{
	struct ndo__rk4_plan *P = calloc(1, sizeof *P);
	if (!P)
		return ndo__fail(NDO_ENOMEM, "out of memory for the RK4 pipeline");
	ndo__units_init(&P->u);
	s->rk4_plan = P;
	P->held = s->any_held;
	if (ndo__chunks_build(s, &P->ch, P->held ? NDO__CHUNKS_DUPS | NDO__CHUNKS_EDGES : 0))
		goto oom;
	const int C = P->ch.C, L = P->ch.L, w = s->w;
	P->R = 3 * L + 1;
	for (int c = 0; c < C; c++)
		if ((size_t)(P->ch.r1[c] - P->ch.r0[c] + 1) * (size_t)w > P->S)
			P->S = (size_t)(P->ch.r1[c] - P->ch.r0[c] + 1) * (size_t)w;
	P->slot = malloc((size_t)C * sizeof *P->slot), P->prev = malloc((size_t)C * sizeof *P->prev);
	P->prevn = malloc((size_t)C * sizeof *P->prevn);
	P->alone = calloc((size_t)C + 1, 1);
	P->late = malloc(4 * (size_t)C);
	if (!P->slot || !P->prev || !P->prevn || !P->alone || !P->late || plan_cap(s, P, 1))
		goto oom;
	return NDO_OK;
oom:
	ndo__rk4_plan_free(s);
	return ndo__fail(NDO_ENOMEM, "out of memory for the RK4 pipeline");
}

/* Copy the canonical values of rows r0..r1 of 3 planes to their
 * duplicates in those rows (ndo_sync, a row at a time: every seam joins
 * nodes of one row). */
static void sync_rows(const ndo_sim *s, double *x, int r0, int r1)
{
	const size_t cnt = s->count, w = (size_t)s->w;
	const int n = s->n;
	for (int c = 0; c < 3; c++) {
		double *X = x + (size_t)c * cnt;
		for (int j = r0; j <= r1; j++) {
			double *row = X + (size_t)j * w;
			if (j == 0 || j == n)
				for (int i = n + 1; i <= 2 * n; i++)
					row[i] = row[2 * n - i];
			else
				row[2 * n] = row[0];
		}
	}
}

/* The ring's slots for T threads, as pipe_thread walks the chunks: each
 * pair of threads shares a range of chunks, the even one walking up from
 * its bottom, the odd one (if any) down from its top, each half (the whole
 * range for a thread alone) a share.  Chunk c at distance d from its
 * share's start takes slot d mod R of the share's, after the chunk R
 * closer to the start (prev); chunks marked alone are left out of that
 * count (the others' d counts only the others) and take one slot each
 * after the share's R.  The waits prev adds close no cycle: a wait
 * goes R chunks or more back towards the start and 3 stages up, and the
 * stages' own waits bring it at most 3(L − 1) < R chunks forward again.
 * The ring holds the slots twice: a chain of steps (ndo__rk4_chain_run)
 * takes the first for its even steps, the second for its odd ones (a
 * single step the first), so that a share's first chunks can begin a
 * step while the step before still runs at the share's end; there a
 * share's first R chunks (no prev) wait for the slot's last chunk two
 * steps before (prevn): an earlier step, so no cycle either. */
static int ring_layout(ndo_sim *s, struct ndo__rk4_plan *P, int T)
{
	if (s->rk4_ring_slots > 0 && s->rk4_ring_slots < P->R)
		P->R = s->rk4_ring_slots > 3 * P->ch.L - 2 ? s->rk4_ring_slots : 3 * P->ch.L - 2;
	const int C = P->ch.C, R = P->R, pairs = (T + 1) / 2;
	size_t nslot = 0;
	P->ring_T = 0; /* (until it is laid out: not on running out of memory) */
	int32_t *last = malloc(((size_t)R + 1) * sizeof *last); /* each slot's chunk */
	if (!last)
		return ndo__fail(NDO_ENOMEM, "out of memory for the RK4 pipeline's ring");
	for (int pair = 0; pair < pairs; pair++) {
		const int lo = (int)((long)C * pair / pairs), hi = (int)((long)C * (pair + 1) / pairs);
		const int two = 2 * pair + 1 < T, mid = two ? lo + (hi - lo) / 2 : hi;
		for (int half = 0; half < 1 + two; half++) {
			const int a = half ? mid : lo, b = half ? hi : mid;
			int j = 0; /* the share's chunks on the ring's slots so far */
			for (int d = 0; d < b - a; d++) {
				const int c = half ? hi - 1 - d : a + d;
				if (P->alone[c])
					continue;
				P->slot[c] = (int32_t)(nslot + (size_t)(j % R));
				P->prev[c] = j >= R ? last[j % R] : -1;
				last[j % R] = c;
				j++;
			}
			/* a chain: the share's first R chunks after the slot's last
			 * chunk two steps before (its own half of the ring) */
			for (int d = 0, jj = 0; d < b - a && jj < R; d++) {
				const int c = half ? hi - 1 - d : a + d;
				if (!P->alone[c])
					P->prevn[c] = last[jj++];
			}
			nslot += (size_t)(j < R ? j : R);
			for (int c = a; c < b; c++)
				if (P->alone[c])
					P->slot[c] = (int32_t)nslot++, P->prev[c] = -1, P->prevn[c] = c;
		}
	}
	free(last);
	/* The ring: at the start of the planes the passes keep vs, su and sv
	 * in (nothing there is kept from step to step) when it fits, as it
	 * does from level 7 up where every node is integrated; else in a
	 * buffer of its own (step_pipeline binds it). */
	P->nslot = nslot;
	P->rps = 2 * nslot * P->S;
	if (P->rps > s->count && 2 * nslot > P->ring_cap) {
		free(P->ring);
		P->ring_cap = 0;
		if (!(P->ring = malloc(9 * P->rps * sizeof *P->ring)))
			return ndo__fail(NDO_ENOMEM, "out of memory for the RK4 pipeline's ring");
		P->ring_cap = 2 * nslot;
	}
	P->ring_T = T;
	P->marked = 0; /* a step begun ahead: its late units follow prev too */
	return NDO_OK;
}

/* The ring's planes as ring_bind binds them this step. */
static void ring_planes(const ndo_sim *s, const struct ndo__rk4_plan *P, double **vs, double **su,
                        double **sv)
{
	if (P->rps <= s->count) /* (the planes as they are this step) */
		*vs = s->vs, *su = s->kv[2], *sv = s->kv[3];
	else
		*vs = P->ring, *su = P->ring + 3 * P->rps, *sv = P->ring + 6 * P->rps;
}

/* The ring laid out for T threads and bound, before a step's first unit
 * runs (ndo_sim_step_begin's too). */
static int ring_bind(ndo_sim *s, struct ndo__rk4_plan *P, int T)
{
	if (P->ring_T != T) {
		int rc = ring_layout(s, P, T);
		if (rc)
			return rc;
	}
	ring_planes(s, P, &P->rvs, &P->rsu, &P->rsv);
	return NDO_OK;
}

/* Whether the ring is laid out for T threads and bound as ring_bind would
 * bind it now: the units a step begun ahead ran kept their values there. */
static int ring_bound(const ndo_sim *s, const struct ndo__rk4_plan *P, int T)
{
	double *vs, *su, *sv;
	ring_planes(s, P, &vs, &su, &sv);
	return P->ring_T == T && P->rvs == vs && P->rsu == su && P->rsv == sv;
}

int ndo__rk4_ring_reuses(const ndo_sim *s)
{
	const struct ndo__rk4_plan *P = s->rk4_plan;
	int n = 0;
	for (int c = 0; P && P->ring_T && c < P->ch.C; c++)
		n += P->prev[c] >= 0;
	return n;
}

/* A run on the threads: one step, or a chain of m steps (the units of
 * step j are passes 4j..4j + 3).  Step j goes from state X_j to X_{j+1}
 * (xbuf: X_0 the simulation's (u, v), never written, then (ka[0], ka[1])
 * and (ka[3], tmp) in turn); its stage displacements share A, B and A2. */
typedef struct rk4_pipe {
	ndo_sim *s;
	rk4_pass g[4];     /* the stages' passes, but for the state */
	double dt[4];      /* the stages' times after a step's start */
	const double *t;   /* the steps' start times */
	int mode[4];
	double *out[3];    /* what stages 0-2 write that the seams copy */
	double *xu[3], *xv[3];
	int m, threads;
	const uint8_t *skip; /* units not to run (the late ones, begun ahead) or NULL */
} rk4_pipe;

static int xbuf(int j)
{
	return j == 0 ? 0 : j % 2 ? 1 : 2;
}

static void unit_run(rk4_pipe *J, int p, int c);

static void unit_need(rk4_pipe *J, int idx);

/* Unit (p, c), claimed: the units it reads done (run here when nobody
 * has claimed them, waited for when somebody has), then itself. */
static void unit_take(rk4_pipe *J, int p, int c)
{
	struct ndo__rk4_plan *P = J->s->rk4_plan;
	const int C = P->ch.C;
	if (p % 4 == 0) {
		/* the slot free: its chunk before through stage 3, in this step
		 * or (a share's first chunks) two steps before (ring_layout) */
		if (P->prev[c] >= 0)
			unit_need(J, (p + 3) * C + P->prev[c]);
		else if (p >= 8)
			unit_need(J, (p - 5) * C + P->prevn[c]);
	}
	if (p > 0) {
		int lo = P->ch.lo[c], hi = P->ch.hi[c];
		if (J->m > 1 && J->s->wave_test == 3)
			lo = hi = c; /* wrong on purpose (tests): the neighbours not waited for */
		for (int q = lo; q <= hi; q++)
			unit_need(J, (p - 1) * C + q);
	}
	unit_run(J, p, c);
	ndo__unit_done(&P->u, p * C + c);
}

/* Unit idx done: run here if nobody has claimed it, else waited for. */
static void unit_need(rk4_pipe *J, int idx)
{
	struct ndo__rk4_plan *P = J->s->rk4_plan;
	if (ndo__unit_claim(&P->u, idx))
		unit_take(J, idx / P->ch.C, idx % P->ch.C);
	else
		ndo__unit_wait(&P->u, idx);
}

static void unit_run(rk4_pipe *J, int p, int c)
{
	const int j = p / 4, k = p % 4;
	/* stages 0..3 (said here for GCC, whose -Warray-bounds at -O1 did not
	 * follow p % 4) */
	if (k < 0 || k > 3)
		__builtin_unreachable();
	ndo_sim *s = J->s;
	struct ndo__rk4_plan *P = s->rk4_plan;
	const ndo__chunks *K = &P->ch;
	rk4_pass gl = J->g[k];
	const int x = xbuf(j), xn = xbuf(j + 1);
	gl.u = J->xu[x], gl.v = J->xv[x];
	gl.uo = J->xu[xn], gl.vo = J->xv[xn];
	if (k == 0)
		gl.U = gl.u; /* stage 0's displacement: the step's state */
	if (s->has_forces)
		ndo__forces_eval_chunk(s, J->t[j] + J->dt[k], gl.U, K, c);
	ndo__diag *d = NULL;
	if (k == 0) {
		d = &P->dg[(size_t)j * (size_t)K->C + (size_t)c];
		memset(d, 0, sizeof *d);
	}
	/* Without pressure and penalty pins (pipeline_fits) the force plane
	 * is zero but at the force nodes: a chunk with none of them in its
	 * rows runs the loops without forces, 3 streams of zeros fewer (the
	 * same bits: f − Ku with f = 0 either way). */
	const double *F = gl.F;
	gl.vs = P->rvs, gl.su = P->rsu, gl.sv = P->rsv;
	gl.ss = P->rps;
	const size_t slot = (size_t)P->slot[c] + (size_t)(j % 2) * P->nslot;
	gl.sd = (ptrdiff_t)(slot * P->S) - (ptrdiff_t)K->r0[c] * s->w;
	if (K->zoff[c + 1] == K->zoff[c])
		gl.F = NULL;
	if (k > 0) {
		/* the stage's input power at the chunk's force nodes and held
		 * edges, before the pass overwrites the stage velocity */
		const ndo__vel w = {gl.vs, gl.ss, gl.sd, NULL, NULL, 0};
		const size_t sk = 3 * (size_t)j + (size_t)(k - 1);
		double *ft = P->ft + sk * s->nfnodes;
		double *et = P->et + sk * 3 * s->nhedge;
		for (int32_t i = K->zoff[c]; i < K->zoff[c + 1]; i++)
			ft[K->zfi[i]] = ndo__fv(F, &w, (size_t)K->zlist[i], s->count);
		for (int32_t i = P->held ? K->eoff[c] : 0; P->held && i < K->eoff[c + 1]; i++)
			for (int comp = 0; comp < 3; comp++)
				et[3 * (size_t)K->elist[i] + (size_t)comp] =
					ndo__held_term(s, &s->hedge[K->elist[i]], gl.U, &w, comp);
	}
	rk4_runs(s, &gl, J->mode[k], d, (size_t)s->ichunk[c], (size_t)s->ichunk[c + 1]);
	gl.F = F;
	rk4_border(s, &gl, J->mode[k], K->blist + K->boff[c], (size_t)(K->boff[c + 1] - K->boff[c]),
	           NULL, k == 0 ? P->bterms + (size_t)j * RK4_BTERMS * s->nbact : NULL);
	double *out[2] = {k < 3 ? J->out[k] : gl.uo, k < 3 ? NULL : gl.vo};
	for (int b = 0; b < 2; b++)
		if (out[b]) {
			if (P->held) /* rows other chunks may share: the chunk's pairs */
				ndo__chunks_copy_dups(s, K, c, out[b]);
			else
				sync_rows(s, out[b], K->r0[c], K->r1[c]);
		}
}

static void take(void *run, int p, int c)
{
	unit_take(run, p, c);
}

/* Thread `who` of J->threads: every unit (units.h) not to skip, in
 * wavefront order or (tests, a chain) shuffled. */
static void pipe_thread(void *arg, int who)
{
	rk4_pipe *J = arg;
	struct ndo__rk4_plan *P = J->s->rk4_plan;
	ndo__units_walk(&P->u, P->ch.C, P->ch.L, 4 * J->m, J->threads, who, J->skip,
	                J->m > 1 && (J->s->wave_test & 1), (uint64_t)J->s->step, take, J);
}

/* The pipeline's buffers and the held nodes' stage values for m steps
 * of size h from times t[0..m) (with held nodes, one); `fresh`: the
 * units' states too (not when a step was begun ahead: its held nodes
 * are set again, from the pending nodes' values that came since). */
static int pipe_setup(ndo_sim *s, double h, int m, const double *t, rk4_pipe *J, int fresh)
{
	if (!s->rk4_plan) {
		int rc = plan_build(s);
		if (rc)
			return rc;
	}
	struct ndo__rk4_plan *P = s->rk4_plan;
	if (plan_cap(s, P, m))
		return ndo__fail(NDO_ENOMEM, "out of memory for the RK4 pipeline");
	double *A = s->us, *B = s->kv[1];
	/* Stage 2's displacement: over stage 0's (A) when every node is
	 * integrated; with held nodes in a buffer of its own, whose held nodes
	 * stand at t + h while A's are at t + h/2 for stage 1 (the passes move
	 * A's between the stages: here stages 1 and 3 run at once). */
	double *A2 = A;
	*J = (rk4_pipe){.s = s, .t = t, .m = m};
	J->xu[0] = s->u, J->xv[0] = s->v;
	J->xu[1] = s->ka[0], J->xv[1] = s->ka[1];
	J->xu[2] = s->ka[3], J->xv[2] = s->tmp; /* (ka[2]: A2 with held nodes) */
	if (P->held) {
		A2 = s->ka[2];
		if (!s->spare_held) {
			/* the new state's held nodes are the old ones': copied once,
			 * then kept (sim_private.h) */
			memcpy(J->xu[1], s->u, 3 * s->count * sizeof *s->u);
			memcpy(J->xv[1], s->v, 3 * s->count * sizeof *s->v);
			s->spare_held = 1;
		}
		ndo__held_keep(s, A);
		ndo__held_keep(s, B);
		ndo__held_keep(s, A2);
		ndo__held_at(s, A, h / 2);
		ndo__held_at(s, B, h / 2);
		ndo__held_at(s, A2, h);
	}
	const double *F = s->has_forces ? s->f : NULL;
	/* vs, su, sv: the ring's; u, v, uo, vo and stage 0's U: the step's
	 * (unit_run) */
	const rk4_pass g = {NULL, A, NULL, NULL, NULL, NULL, NULL, NULL, NULL, F, h / 2, h / 6, 0, 0};
	for (int k = 0; k < 4; k++)
		J->g[k] = g;
	J->g[1].U = A, J->g[1].Un = B;
	J->g[2].U = B, J->g[2].Un = A2, J->g[2].c = h;
	J->g[3].U = A2, J->g[3].Un = NULL;
	const double dt[4] = {0, h / 2, h / 2, h};
	const int mode[4] = {RK4_FIRST, RK4_MID, RK4_MID, RK4_LAST_TO};
	memcpy(J->dt, dt, sizeof dt);
	memcpy(J->mode, mode, sizeof mode);
	J->out[0] = A, J->out[1] = B, J->out[2] = A2;
	J->threads = ndo__sim_threads_now(s);
	if (fresh) {
		for (int i = 0; i < 4 * m * P->ch.C; i++)
			atomic_init(&P->u.state[i], NDO__UNIT_FREE);
		return ring_bind(s, P, J->threads);
	}
	return NDO_OK;
}

/* Step j's stage-0 diagnostics: the border's in its order, then the
 * chunks'. */
static void pipe_diag(ndo_sim *s, int j, ndo__diag *d)
{
	const struct ndo__rk4_plan *P = s->rk4_plan;
	const size_t C = (size_t)P->ch.C;
	memcpy(s->cdiag, P->dg + (size_t)j * C, C * sizeof *s->cdiag);
	ndo__diag *bd = &s->cdiag[s->nichunk];
	memset(bd, 0, sizeof *bd);
	const double *bt = P->bterms + (size_t)j * RK4_BTERMS * s->nbact;
	for (size_t k = 0; k < s->nbact; k++) {
		const double *tk = bt + RK4_BTERMS * k;
		for (int comp = 0; comp < 3; comp++) {
			bd->pe2 += tk[comp];
			bd->ke2 += tk[3 + comp];
			bd->power += tk[6 + comp];
		}
		bd->umax2 = fmax(bd->umax2, tk[9]);
	}
	ndo__diag_sum(s, d);
}

/* Step j's stages 1-3 input powers into s->stage_power. */
static void pipe_powers(ndo_sim *s, int j)
{
	const struct ndo__rk4_plan *P = s->rk4_plan;
	for (int k = 1; k < 4; k++) {
		const size_t sk = 3 * (size_t)j + (size_t)(k - 1);
		s->stage_power[k] =
			ndo__stage_power_sum(s, P->ft + sk * s->nfnodes, P->et + sk * 3 * s->nhedge);
	}
}

static int step_pipeline(ndo_sim *s, double h)
{
	/* begun ahead (ndo_sim_step_begin) for this very step and still
	 * valid: the units done stay done, in the ring as it was laid out
	 * and bound for them (else what was done ahead is dropped: the whole
	 * step runs) */
	int ahead = s->ahead && s->spare_held && s->rk4_plan && s->ahead_t == s->t &&
	            s->ahead_h == h && ring_bound(s, s->rk4_plan, ndo__sim_threads_now(s));
	s->ahead = 0;
	rk4_pipe J;
	const double t0 = s->t;
	int rc = pipe_setup(s, h, 1, &t0, &J, !ahead);
	if (rc)
		return rc;
	struct ndo__rk4_plan *P = s->rk4_plan;
	double *un = J.xu[1], *vn = J.xv[1];
	ndo__sim_run(s, J.threads, pipe_thread, &J);
	ndo__diag d;
	pipe_diag(s, 0, &d);
	d.power += ndo__held_power(s, s->u, s->v, NULL);
	s->stats.evaluations++;
	s->last_power = s->stage_power[0] = d.power;
	rc = ndo__diverged(s, &d, 1);
	if (rc)
		return rc;
	pipe_powers(s, 0);
	s->stats.evaluations += 3;
	if (P->held)
		ndo__held_at(s, un, h); /* the boundary moves on with the step (the spare's
		                          * moving held nodes are the state's but for this) */
	s->ka[0] = s->u, s->ka[1] = s->v;
	s->u = un, s->v = vn;
	return NDO_OK;
}

/* ---- a chain of steps (ndo_sim_steps) ------------------------------------------ */

/* Whether steps can run as a chain: the pipeline's steps with held nodes
 * (pins, a region) that do not move, no sleeping tiles and no
 * re-assembly of K between the steps.  With held nodes a chain is at most
 * two steps (ndo__rk4_chain_diag reads X_1 after the run). */
int ndo__rk4_chain_fits(const ndo_sim *s)
{
	return s->p.method == NDO_RK4 && pipeline_fits(s) && !(s->held_motion && s->nhmove) &&
	       !s->sleep && s->p.restiffen == 0;
}

/* Steps a chain takes: 2 (8 passes; wave.c's WAVE_PASSES measured 6-8
 * passes as about the window a thread keeps in its cache). */
int ndo__rk4_chain_batch(const ndo_sim *s)
{
	(void)s;
	return 2;
}

int ndo__rk4_chain_run(ndo_sim *s, double h, int m, const double *t)
{
	if (m > 2 && s->any_held)
		return ndo__fail(NDO_EINVAL, "a chain of %d steps with held nodes", m);
	s->ahead = 0;
	rk4_pipe J;
	int rc = pipe_setup(s, h, m, t, &J, 1);
	if (rc)
		return rc;
	if (s->any_held && m == 2) {
		/* X_2, the new state, holds the held nodes' u and v (X_1 does:
		 * spare_held, pipe_setup) */
		const size_t cnt = s->count;
		for (size_t p = 0; p < cnt; p++)
			if (!s->active[p])
				for (int c = 0; c < 3; c++) {
					J.xu[2][(size_t)c * cnt + p] = s->u[(size_t)c * cnt + p];
					J.xv[2][(size_t)c * cnt + p] = s->v[(size_t)c * cnt + p];
				}
	}
	ndo__sim_run(s, J.threads, pipe_thread, &J);
	if (s->wave_test & 1) /* a shuffling thread that found no memory left units */
		ndo__units_rest(&s->rk4_plan->u, 4 * m * s->rk4_plan->ch.C, s->rk4_plan->ch.C, take, &J);
	return NDO_OK;
}

int ndo__rk4_chain_cap(const ndo_sim *s)
{
	return s->rk4_plan ? s->rk4_plan->cap : 0;
}

void ndo__rk4_chain_diag(ndo_sim *s, int j, ndo__diag *d)
{
	pipe_diag(s, j, d);
	if (s->nhedge) { /* the held nodes' power, from step j's state (j ≤ 1) */
		const int x = xbuf(j);
		d->power += ndo__held_power(s, x ? s->ka[0] : s->u, x ? s->ka[1] : s->v, NULL);
	}
}

void ndo__rk4_chain_powers(ndo_sim *s, int j, double power0)
{
	s->stage_power[0] = power0;
	pipe_powers(s, j);
}

static void swap(double **a, double **b)
{
	double *t = *a;
	*a = *b, *b = t;
}

void ndo__rk4_chain_commit(ndo_sim *s, int m)
{
	if (m == 0)
		return;
	const int x = xbuf(m);
	swap(&s->u, x == 1 ? &s->ka[0] : &s->ka[3]);
	swap(&s->v, x == 1 ? &s->ka[1] : &s->tmp);
}

/* Begin the step ahead (ndo_sim_step_begin): a unit is late when the rows
 * it reads hold a pending node (its state, or as a held node its stage
 * values) or it reads a late unit of the stage before, or (stage 0) its
 * ring slot's chunk before is late; the others run now, on the threads
 * and in the ring's layout the step will use (step_pipeline drops them
 * if it would not).  Every unit writes only its active nodes' stage and
 * spare values and its chunk's slot of the ring, which nothing before the
 * rest of the step reads or writes. */
int ndo__rk4_begin(ndo_sim *s, double h, size_t n, const int32_t *pending)
{
	if (!pipeline_fits(s))
		return 0;
	if (!s->pend && !(s->pend = calloc(s->count, 1)))
		return ndo__fail(NDO_ENOMEM, "out of memory");
	if (!s->rk4_plan) {
		int rc = plan_build(s);
		if (rc)
			return rc;
	}
	struct ndo__rk4_plan *P = s->rk4_plan;
	const ndo__chunks *K = &P->ch;
	/* The ring laid out for the threads the step runs on (ndo_sim_step_begin
	 * chose them for it): the late units follow from its slots' waits. */
	const int T = ndo__sim_threads_now(s);
	/* the marks: kept while the plan, the ring's layout and the pending
	 * nodes stay (a peer's halo from one exchange to the next) */
	if (!P->marked || P->ring_T != T || P->pn != n ||
	    memcmp(P->plist, pending, n * sizeof *pending)) {
		const int C = K->C, N = s->n, w = s->w;
		int32_t *pl = realloc(P->plist, (n + 1) * sizeof *pl);
		uint8_t *prow = calloc((size_t)N + 1, 1);
		if (!pl || !prow) {
			free(prow);
			P->plist = pl;
			P->marked = 0;
			return ndo__fail(NDO_ENOMEM, "out of memory");
		}
		P->plist = pl;
		memcpy(pl, pending, n * sizeof *pl);
		P->pn = n;
		memset(s->pend, 0, s->count);
		for (size_t k = 0; k < n; k++)
			if ((size_t)pending[k] < s->count) {
				s->pend[s->canon[pending[k]]] = 1;
				prow[pending[k] / w] = 1; /* a seam's nodes share a row */
				prow[s->canon[pending[k]] / w] = 1;
			}
		/* Late: reads a pending row, or a late unit of the stage before */
		int early = 0;
		for (int k = 0; k < 4; k++)
			for (int c = 0; c < C; c++) {
				uint8_t late = 0;
				for (int j = K->a0[c] < 0 ? 0 : K->a0[c]; j <= K->a1[c] && j <= N && !late; j++)
					late = prow[j];
				for (int q = K->lo[c]; k > 0 && q <= K->hi[c] && !late; q++)
					late = P->late[(k - 1) * C + q];
				P->late[k * C + c] = late;
				early += !late;
			}
		free(prow);
		/* The ring: where some unit is early, the chunks late at stage 3
		 * take slots of their own (ring_layout), out of the early chunks'
		 * way: an early chunk on a slot after a late one would wait for it
		 * (on 2 threads, the odd one walks down from the top of its share,
		 * the lower band's halo: half the band would be late). */
		int relay = P->ring_T != T;
		for (int c = 0; c < C; c++) {
			uint8_t alone = early > 0 && P->late[3 * C + c];
			relay |= alone != P->alone[c];
			P->alone[c] = alone;
		}
		if (relay) {
			int rc = ring_layout(s, P, T);
			if (rc)
				return rc;
		}
		/* And (stage 0) late when stage 3 of the chunk that used its slot
		 * before (prev) is: none with those slots, but so whatever the
		 * layout (prev may come later in the chunks' order: sweeps until
		 * nothing changes; the waits close no cycle, ring_layout). */
		for (int changed = 1; changed;) {
			changed = 0;
			for (int k = 0; k < 4; k++)
				for (int c = 0; c < C; c++) {
					if (P->late[k * C + c])
						continue;
					uint8_t late = k == 0 && P->prev[c] >= 0 && P->late[3 * C + P->prev[c]];
					for (int q = K->lo[c]; k > 0 && q <= K->hi[c] && !late; q++)
						late = P->late[(k - 1) * C + q];
					if (late)
						P->late[k * C + c] = 1, changed = 1;
				}
		}
		P->early = 0;
		for (int i = 0; i < 4 * C; i++)
			P->early += !P->late[i];
		P->marked = 1;
	}
	if (!P->early)
		return 0; /* every unit reads them (a quad-tree region): the step runs whole */
	rk4_pipe J;
	const double t0 = s->t;
	int rc = pipe_setup(s, h, 1, &t0, &J, 1);
	if (rc)
		return rc;
	J.skip = P->late;
	ndo__sim_run(s, J.threads, pipe_thread, &J);
	s->ahead = 1;
	s->ahead_t = s->t;
	s->ahead_h = h;
	return P->early;
}

int ndo__rk4_step(ndo_sim *s, double h)
{
	if (pipeline_fits(s))
		return step_pipeline(s, h);
	s->spare_held = 0; /* the passes move u's held nodes in place */
	s->ahead = 0;
	return step_passes(s, h);
}
