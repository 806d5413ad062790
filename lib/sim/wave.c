/* wave.c — several steps of symplectic Euler or midpoint as one pipeline
 * (ndo_sim_steps, ndo/sim.h), so that the threads need no barrier between
 * the passes, nor between the steps.
 *
 * A step of symplectic Euler is one pass over the nodes, midpoint's two
 * (ndo__accel_update: the stage state, then the new state).  A pass reads
 * its input one row beyond the rows it writes (the stencil's ring), and
 * every seam joins nodes of one row (ndo/topology.h), so pass p of a chunk
 * of rows needs only pass p − 1 of the chunks whose rows meet its rows ± 1
 * (chunks.c, lo[c]..hi[c]: the same chunks whose reads meet its writes,
 * so a unit also never overwrites what a unit of the pass before still
 * reads).
 * m steps are m · (1 or 2) passes, one run on the threads: each thread
 * walks the units (pass, chunk) in wavefront order — pass p of chunk c at
 * c + p·L — the first from the bottom row up, the second from the top
 * down (as rk4.c's pipeline, whose idea this is), claims a unit before
 * running it, skips units others claimed, runs first any unit it reads
 * that nobody claimed, and waits (on a condition variable, never
 * spinning) only for a unit another thread is running, of an earlier
 * pass: no wait closes a cycle, and alone a thread runs every unit.
 *
 * The state of step j is X_j: X_0 the simulation's (u, v), never written
 * during the run, then B, C, B, C, ... (spare planes); midpoint's stage
 * state goes to M.  Each first pass keeps its diagnostics per chunk (the
 * border nodes' and the held edges' terms per node, to be added in the
 * passes' order), so that after the run the steps' divergence tests are
 * made in order on the same sums as single steps make (integrate.c,
 * ndo_sim_steps); when step j fails, the run is made again for j steps
 * from X_0, still there.  A unit evaluates its chunk's force items at its
 * pass's time, and copies the seam duplicates of the nodes it wrote.
 * Held nodes (pins) never move: B, C and M get u at those read, and the
 * final state u and v at every held node. */
#include "sim_private.h"
#include "units.h"
#include "ndo/status.h"

#include <stdlib.h>
#include <string.h>

struct ndo__wave_plan {
	ndo__chunks ch;        /* what each chunk writes, reads and waits for, its
	                        * seam duplicates and held edges (sim_private.h) */
	/* a run: unit states, the first passes' diagnostics */
	int cap;               /* steps the arrays below hold */
	ndo__units u;          /* unit states, 2·cap·C */
	ndo__diag *dg;         /* cap·C */
	double *bt, *et;       /* cap·nbact·NDO__BTERMS, cap·nhedge·3 */
	/* midpoint: each step's input power (its stage's force at its mean
	 * velocity) as terms (ndo__stage_power_sum), cap·nfnodes and
	 * cap·nhedge·3 */
	double *ft, *st;
};

void ndo__wave_plan_free(ndo_sim *s)
{
	struct ndo__wave_plan *P = s->wave_plan;
	if (!P)
		return;
	ndo__chunks_free(&P->ch);
	free(P->dg), free(P->bt), free(P->et), free(P->ft), free(P->st);
	ndo__units_destroy(&P->u);
	free(P);
	s->wave_plan = NULL;
}

/* What a run of steps can take: symplectic Euler and midpoint with fixed
 * stencil passes — no penalty pins, pressure, sleeping tiles, re-assembly
 * of K or moving held nodes (a peer's boundary). */
int ndo__wave_fits(const ndo_sim *s)
{
	return (s->p.method == NDO_SYMPLECTIC_EULER || s->p.method == NDO_MIDPOINT) &&
	       !s->rk4_reference && s->npen == 0 && !s->has_pressure && !s->sleep &&
	       s->p.restiffen == 0 && !(s->held_motion && s->nhmove) && s->n >= 2 &&
	       s->nispan >= 1 && s->nichunk >= 1;
}

/* The plan: the chunks (chunks.c, as rk4.c's pipeline has them), each
 * with the seam duplicates of the nodes it writes and the held edges of
 * its active nodes, whether or not the region holds nodes. */
static int plan_build(ndo_sim *s)
{
	struct ndo__wave_plan *P = calloc(1, sizeof *P);
	if (!P)
		return ndo__fail(NDO_ENOMEM, "out of memory for the steps' pipeline");
	ndo__units_init(&P->u);
	s->wave_plan = P;
	if (ndo__chunks_build(s, &P->ch, NDO__CHUNKS_DUPS | NDO__CHUNKS_EDGES)) {
		ndo__wave_plan_free(s);
		return ndo__fail(NDO_ENOMEM, "out of memory for the steps' pipeline");
	}
	return NDO_OK;
}

/* Steps a run takes at most: the wavefront spans (passes − 1)·L chunks,
 * which the two threads meet across; a quarter of the chunks keeps that
 * part small.  And at most WAVE_PASSES passes: a thread's window of the
 * wavefront, about passes · L chunks of 512 nodes, is what stays in the
 * cache from one pass of a chunk to the next.  With up to 16 steps (32
 * passes for midpoint) it did not: 6 passes against 16 steps, on 2
 * threads at levels 8 and 9, symplectic Euler 1.22x and 1.25x the steps/s,
 * midpoint 1.54x and 1.41x (one thread: midpoint 1.05x and 1.21x,
 * symplectic Euler 1.0x; level 7 1.0x); rk4, not in the wave, 1.0x in the
 * same runs (bench_simulate threads, the two builds alternated, medians of
 * 3-4 rounds, 2026-11-29, load 0.7-1.2: docs/simulate-peer.md).  4 and 8
 * passes were within noise of 6, but for symplectic Euler at level 9 on 2
 * threads, where 8 passes lost 20%.  2..6 steps (0: the plan could not be
 * made). */
enum { WAVE_PASSES = 6 };

int ndo__wave_batch(ndo_sim *s)
{
	if (!s->wave_plan && plan_build(s))
		return 0;
	const int pps = s->p.method == NDO_MIDPOINT ? 2 : 1;
	int m = s->wave_plan->ch.C / (4 * s->wave_plan->ch.L * pps);
	if (m > WAVE_PASSES / pps)
		m = WAVE_PASSES / pps;
	return m < 2 ? 2 : m;
}

typedef struct wave_run {
	ndo_sim *s;
	double h;
	const double *t;
	int pps, np;           /* passes a step, in all */
	double *xu[3], *xv[3]; /* X_0 (A), B, C */
	double *mu, *mv;       /* midpoint's stage state */
	int threads;
} wave_run;

/* X_j's planes: A, then B and C in turn. */
static int xbuf(int j)
{
	return j == 0 ? 0 : j % 2 ? 1 : 2;
}

static void unit_run(wave_run *J, int p, int c)
{
	ndo_sim *s = J->s;
	struct ndo__wave_plan *P = s->wave_plan;
	const ndo__chunks *K = &P->ch;
	const int j = p / J->pps, second = p % J->pps != 0;
	const int a = xbuf(j), b = xbuf(j + 1);
	const double *u, *v;
	double t = J->t[j];
	ndo__upd up = {0};
	up.h = J->h;
	if (J->pps == 1) {
		u = J->xu[a], v = J->xv[a];
		up.mode = NDO__UPD_SYMPLECTIC, up.uo = J->xu[b], up.vo = J->xv[b];
	} else if (!second) {
		u = J->xu[a], v = J->xv[a];
		up.mode = NDO__UPD_HALF, up.uo = J->mu, up.vo = J->mv;
	} else {
		u = J->mu, v = J->mv;
		t = J->t[j] + 0.5 * J->h;
		up.mode = NDO__UPD_FULL, up.uo = J->xu[b], up.vo = J->xv[b];
		up.u0 = J->xu[a], up.v0 = J->xv[a];
	}
	if (s->has_forces)
		ndo__forces_eval_chunk(s, t, u, K, c);
	ndo__diag *d = NULL;
	double *bt = NULL;
	if (!second) {
		d = &P->dg[(size_t)j * (size_t)K->C + (size_t)c];
		memset(d, 0, sizeof *d);
		bt = P->bt + (size_t)j * s->nbact * NDO__BTERMS;
	}
	/* f is zero but at the force nodes (no pressure, no penalty pins): a
	 * chunk without any runs without it, the same bits (rk4.c) */
	ndo__accel_runs(s, u, v, K->zoff[c + 1] > K->zoff[c] ? s->f : NULL, &up, d,
	                (size_t)s->ichunk[c], (size_t)s->ichunk[c + 1]);
	ndo__accel_border_nodes(s, u, v, s->f, &up, K->blist + K->boff[c],
	                        (size_t)(K->boff[c + 1] - K->boff[c]), bt);
	if (d) {
		/* ndo__held_power's terms, v at the active node (symplectic
		 * Euler: ½(v + v')), u at the held */
		const size_t cnt = s->count;
		double *et = P->et + (size_t)j * s->nhedge * 3;
		for (int32_t i = K->eoff[c]; i < K->eoff[c + 1]; i++) {
			const ndo__edge *e = &s->hedge[K->elist[i]];
			for (int comp = 0; comp < 3; comp++)
				et[3 * (size_t)K->elist[i] + (size_t)comp] =
					ndo__power_velocity(&up, v, (size_t)comp * cnt + (size_t)e->p) * e->c *
					u[(size_t)comp * cnt + (size_t)e->q];
		}
	}
	if (second) {
		/* midpoint's input power (integrate.c, step_rk): the stage's
		 * force at the chunk's force nodes, and its held edges', at the
		 * step's mean velocity, the new one just written */
		const ndo__vel w = {J->xv[a], s->count, 0, J->xv[b], NULL, 0};
		double *ft = P->ft + (size_t)j * s->nfnodes, *st = P->st + (size_t)j * s->nhedge * 3;
		for (int32_t i = K->zoff[c]; i < K->zoff[c + 1]; i++)
			ft[K->zfi[i]] = ndo__fv(s->f, &w, (size_t)K->zlist[i], s->count);
		for (int32_t i = K->eoff[c]; i < K->eoff[c + 1]; i++)
			for (int comp = 0; comp < 3; comp++)
				st[3 * (size_t)K->elist[i] + (size_t)comp] =
					ndo__held_term(s, &s->hedge[K->elist[i]], u, &w, comp);
	}
	ndo__chunks_copy_dups(s, K, c, up.uo);
	ndo__chunks_copy_dups(s, K, c, up.vo);
}

/* Unit (p, c), claimed: the units it reads done (run here when nobody has
 * claimed them, waited for when somebody has), then itself. */
static void unit_take(wave_run *J, int p, int c)
{
	struct ndo__wave_plan *P = J->s->wave_plan;
	if (p > 0) {
		int lo = P->ch.lo[c], hi = P->ch.hi[c];
		if (J->s->wave_test == 3)
			lo = hi = c; /* wrong on purpose (tests): the neighbours not waited for */
		for (int q = lo; q <= hi; q++) {
			int idx = (p - 1) * P->ch.C + q;
			if (ndo__unit_claim(&P->u, idx))
				unit_take(J, p - 1, q);
			else
				ndo__unit_wait(&P->u, idx);
		}
	}
	unit_run(J, p, c);
	ndo__unit_done(&P->u, p * P->ch.C + c);
}

static void take(void *run, int p, int c)
{
	unit_take(run, p, c);
}

/* Thread `who` of J->threads: every unit (units.h), in wavefront order or
 * (tests) shuffled. */
static void wave_thread(void *arg, int who)
{
	wave_run *J = arg;
	struct ndo__wave_plan *P = J->s->wave_plan;
	ndo__units_walk(&P->u, P->ch.C, P->ch.L, J->np, J->threads, who, NULL, J->s->wave_test & 1,
	                (uint64_t)J->s->step, take, J);
}

/* The run's planes: X_0 = (u, v), B, C and midpoint's M. */
static void run_planes(ndo_sim *s, wave_run *J)
{
	J->xu[0] = s->u, J->xv[0] = s->v;
	if (s->p.method == NDO_MIDPOINT) {
		J->xu[1] = s->us, J->xv[1] = s->kv[1];
		J->xu[2] = s->ka[0], J->xv[2] = s->ka[1];
		J->mu = s->tmp, J->mv = s->vs;
	} else {
		J->xu[1] = s->us, J->xv[1] = s->vs;
		J->xu[2] = s->tmp, J->xv[2] = s->ka[0];
		J->mu = J->mv = NULL;
	}
}

int ndo__wave_run(ndo_sim *s, double h, int m, const double *t)
{
	if (!s->wave_plan) {
		int rc = plan_build(s);
		if (rc)
			return rc;
	}
	struct ndo__wave_plan *P = s->wave_plan;
	const int C = P->ch.C, pps = s->p.method == NDO_MIDPOINT ? 2 : 1;
	if (m > P->cap) {
		free((void *)P->u.state), free(P->dg), free(P->bt), free(P->et);
		free(P->ft), free(P->st);
		P->u.state = malloc((size_t)(pps * m * C) * sizeof *P->u.state);
		P->dg = malloc((size_t)(m * C) * sizeof *P->dg);
		P->bt = malloc(((size_t)m * s->nbact * NDO__BTERMS + 1) * sizeof *P->bt);
		P->et = malloc(((size_t)m * s->nhedge * 3 + 1) * sizeof *P->et);
		P->ft = malloc(((size_t)m * s->nfnodes + 1) * sizeof *P->ft);
		P->st = malloc(((size_t)m * s->nhedge * 3 + 1) * sizeof *P->st);
		P->cap = m;
		if (!P->u.state || !P->dg || !P->bt || !P->et || !P->ft || !P->st) {
			ndo__wave_plan_free(s);
			return ndo__fail(NDO_ENOMEM, "out of memory for the steps' pipeline");
		}
	}
	wave_run J = {.s = s, .h = h, .t = t, .pps = pps, .np = pps * m};
	run_planes(s, &J);
	s->spare_held = 0;
	if (s->any_held) { /* held nodes read: u in every state written */
		ndo__held_keep(s, J.xu[1]);
		ndo__held_keep(s, J.xu[2]);
		if (J.mu)
			ndo__held_keep(s, J.mu);
	}
	for (int i = 0; i < J.np * C; i++)
		atomic_init(&P->u.state[i], NDO__UNIT_FREE);
	J.threads = ndo__sim_threads_now(s);
	ndo__sim_run(s, J.threads, wave_thread, &J);
	if (s->wave_test & 1) /* a shuffling thread that found no memory left units */
		ndo__units_rest(&P->u, J.np * C, C, take, &J);
	return NDO_OK;
}

void ndo__wave_diag(ndo_sim *s, int j, ndo__diag *d)
{
	struct ndo__wave_plan *P = s->wave_plan;
	const int C = P->ch.C;
	memcpy(s->cdiag, P->dg + (size_t)j * (size_t)C, (size_t)C * sizeof *s->cdiag);
	ndo__border_terms_sum(s, P->bt + (size_t)j * s->nbact * NDO__BTERMS, &s->cdiag[C]);
	ndo__diag_sum(s, d);
	if (s->nhedge) {
		const double *et = P->et + (size_t)j * s->nhedge * 3;
		double pw = 0;
		for (size_t k = 0; k < 3 * s->nhedge; k++)
			pw += et[k];
		d->power += pw;
	}
}

double ndo__wave_power(const ndo_sim *s, int j)
{
	const struct ndo__wave_plan *P = s->wave_plan;
	return ndo__stage_power_sum(s, P->ft + (size_t)j * s->nfnodes,
	                            P->st + (size_t)j * s->nhedge * 3);
}

static void swap(double **a, double **b)
{
	double *t = *a;
	*a = *b, *b = t;
}

void ndo__wave_commit(ndo_sim *s, int m)
{
	if (m == 0)
		return;
	wave_run J;
	run_planes(s, &J);
	const int x = xbuf(m);
	double *nu = J.xu[x], *nv = J.xv[x];
	if (s->any_held) { /* held nodes as they were, u and v */
		const size_t cnt = s->count;
		for (size_t p = 0; p < cnt; p++)
			if (!s->active[p])
				for (int c = 0; c < 3; c++) {
					nu[(size_t)c * cnt + p] = s->u[(size_t)c * cnt + p];
					nv[(size_t)c * cnt + p] = s->v[(size_t)c * cnt + p];
				}
	}
	if (s->p.method == NDO_MIDPOINT) {
		swap(&s->u, x == 1 ? &s->us : &s->ka[0]);
		swap(&s->v, x == 1 ? &s->kv[1] : &s->ka[1]);
	} else {
		swap(&s->u, x == 1 ? &s->us : &s->tmp);
		swap(&s->v, x == 1 ? &s->vs : &s->ka[0]);
	}
}
