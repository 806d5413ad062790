/* rollback.c — a realtime peer that rolls back (rollback.h; docs/peers.md
 * "Realtime"). */
#include "rollback.h"
#include "ndo/net.h"
#include "ndo/status.h"
#include "ndo/topology.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define RESEND_MAX 0.2 /* s: the longest gap between re-sends */
#define NB_MAX 64      /* neighbours tracked (NDO_MAX_PEERS simulate) */

enum { H_NONE = 0, H_PREDICTED, H_TENTATIVE, H_CONFIRMED }; /* a halo value */
#define H_CHANGED 0x80 /* with H_TENTATIVE: not the value the step used */

/* One step of the window. */
typedef struct slot {
	int64_t step;   /* −1: empty */
	double t;       /* the simulation's time at `step` */
	int have;       /* the region's state at `step` is kept */
	int cf;         /* ... and confirmed */
	int pub;        /* a frame of it went out: pu holds its displacements */
	size_t ncf;     /* halo nodes holding a confirmed value */
	double *st;     /* 6 · nown: the region's velocity and displacement */
	double *hin;    /* 6 · nhalo: the halo's (received or predicted) */
	uint8_t *hs;    /* nhalo: H_* */
	double *pu;     /* 3 · nown, when pub */
} slot;

/* A neighbour: the newest step it sent confirmed (its own steps are
 * confirmed up to there: it needs this peer's strips from that step on),
 * and when this peer sends them again. */
typedef struct nb {
	int32_t id;
	int64_t kf;
	double next, gap;
} nb;

struct ndo__rb {
	ndo_session *s;
	ndo_sim *sim;
	size_t count;
	double resend0;
	ndo__rb_region r;
	int32_t *hidx;   /* per canonical node: its index in the halo, −1 */
	int32_t *hown;   /* per halo node: its peer */
	uint8_t *hheld;  /* per halo node: the outermost ring (held in a step) */
	int32_t *hnoff, *hnl; /* per halo node k of that ring, its integrated lattice
	                       * neighbours hnl[hnoff[k]..hnoff[k+1]) (canonical) */
	double *nv;      /* scratch: their velocities, 3 · their count */
	int32_t *sidx;   /* per strip node: its index in r.own */
	slot *w;
	int win;
	int64_t base, cur, fr, roll;
	int64_t mark[2][2]; /* (cur, fr) at two earlier steps, a quarter window
	                     * apart at least: the recent rate of confirmation */
	int exact;
	double h;        /* the step size (predictions of the held ring) */
	nb nbs[NB_MAX];
	int nnb;
	/* scratch */
	double *bu, *bv; /* 3 · max(nown, nhalo) */
	double *vals;    /* 6 · nstrip */
	int32_t *rs, *rl;
	ndo__rb_stats st;
};

static void slots_free(ndo__rb *rb)
{
	for (int k = 0; k < rb->win && rb->w; k++) {
		slot *S = &rb->w[k];
		free(S->st), free(S->hin), free(S->hs), free(S->pu);
	}
	free(rb->w);
	rb->w = NULL;
	rb->win = 0;
}

int ndo__rb_create(ndo_session *s, ndo_sim *sim, size_t count, double resend, ndo__rb **out)
{
	ndo__rb *rb = calloc(1, sizeof *rb);
	if (!rb)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	rb->mark[0][0] = rb->mark[1][0] = -1;
	rb->s = s;
	rb->sim = sim;
	rb->count = count;
	rb->resend0 = resend;
	rb->hidx = malloc(count * sizeof *rb->hidx);
	if (!rb->hidx) {
		free(rb);
		return ndo__fail(NDO_ENOMEM, "out of memory");
	}
	for (size_t k = 0; k < count; k++)
		rb->hidx[k] = -1;
	*out = rb;
	return 0;
}

void ndo__rb_destroy(ndo__rb *rb)
{
	if (!rb)
		return;
	slots_free(rb);
	free(rb->hidx), free(rb->hown), free(rb->hheld), free(rb->sidx);
	free(rb->hnoff), free(rb->hnl), free(rb->nv);
	free(rb->bu), free(rb->bv), free(rb->vals), free(rb->rs), free(rb->rl);
	free(rb);
}

int ndo__rb_set_region(ndo__rb *rb, const ndo__rb_region *r)
{
	/* (the caller's halo array already holds the new halo: clear all) */
	for (size_t k = 0; k < rb->count; k++)
		rb->hidx[k] = -1;
	slots_free(rb);
	free(rb->hown), free(rb->hheld), free(rb->sidx);
	free(rb->hnoff), free(rb->hnl), free(rb->nv);
	rb->hnoff = rb->hnl = NULL, rb->nv = NULL;
	free(rb->bu), free(rb->bv), free(rb->vals), free(rb->rs), free(rb->rl);
	rb->r = *r;
	size_t nh = r->nhalo ? r->nhalo : 1, ns = r->nstrip ? r->nstrip : 1;
	size_t nbuf = r->nown > nh ? r->nown : nh;
	rb->hown = malloc(nh * sizeof *rb->hown);
	rb->hheld = malloc(nh);
	rb->sidx = malloc(ns * sizeof *rb->sidx);
	rb->bu = malloc(3 * nbuf * sizeof *rb->bu);
	rb->bv = malloc(3 * nbuf * sizeof *rb->bv);
	rb->vals = malloc(6 * ns * sizeof *rb->vals);
	rb->rs = malloc(ns * sizeof *rb->rs);
	rb->rl = malloc(ns * sizeof *rb->rl);
	if (!rb->hown || !rb->hheld || !rb->sidx || !rb->bu || !rb->bv || !rb->vals || !rb->rs ||
	    !rb->rl)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	rb->nnb = 0;
	for (size_t k = 0; k < r->nhalo; k++) {
		int32_t c = r->halo[k];
		rb->hidx[c] = (int32_t)k;
		rb->hown[k] = r->owner[c];
		rb->hheld[k] = !r->act[c];
		int known = 0;
		for (int q = 0; q < rb->nnb && !known; q++)
			known = rb->nbs[q].id == r->owner[c];
		if (!known && rb->nnb < NB_MAX)
			rb->nbs[rb->nnb++] = (nb){.id = r->owner[c]};
	}
	/* the held ring's integrated neighbours, which its predictions follow */
	const int level = ndo_sim_level(rb->sim), W = (2 << level) + 1;
	rb->hnoff = malloc((nh + 1) * sizeof *rb->hnoff);
	rb->hnl = malloc((6 * nh + 1) * sizeof *rb->hnl);
	rb->nv = malloc((18 * nh + 1) * sizeof *rb->nv);
	if (!rb->hnoff || !rb->hnl || !rb->nv)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	int32_t nn = 0;
	for (size_t k = 0; k < r->nhalo; k++) {
		rb->hnoff[k] = nn;
		if (!rb->hheld[k])
			continue;
		size_t nb[6];
		ndo_neighbors(level, (int)((size_t)r->halo[k] % (size_t)W),
		              (int)((size_t)r->halo[k] / (size_t)W), nb);
		for (int d = 0; d < 6; d++) {
			int32_t c = r->canon[nb[d]];
			if (r->act[c])
				rb->hnl[nn++] = c;
		}
	}
	rb->hnoff[r->nhalo] = nn;
	/* the strip's nodes in the region's list (canonical ones: the strip) */
	int32_t *at = malloc(rb->count * sizeof *at);
	if (!at)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	for (size_t k = 0; k < r->nown; k++)
		at[r->own[k]] = (int32_t)k;
	for (size_t k = 0; k < r->nstrip; k++)
		rb->sidx[k] = at[r->strip[k]];
	free(at);
	/* the window: as many steps as fit the memory budget */
	size_t bytes = sizeof(slot) + 8 * (6 * r->nown + 6 * r->nhalo) + r->nhalo;
	size_t win = NDO__RB_MEMORY / bytes;
	if (win > NDO__RB_WINDOW)
		win = NDO__RB_WINDOW;
	if (win < 8)
		win = 8;
	rb->w = calloc(win, sizeof *rb->w);
	if (!rb->w)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	rb->win = (int)win;
	rb->st.window = rb->win;
	for (int k = 0; k < rb->win; k++) {
		slot *S = &rb->w[k];
		S->step = -1;
		S->st = malloc(6 * (r->nown ? r->nown : 1) * sizeof *S->st);
		S->hin = malloc(6 * nh * sizeof *S->hin);
		S->hs = malloc(nh);
		if (!S->st || !S->hin || !S->hs)
			return ndo__fail(NDO_ENOMEM, "out of memory");
	}
	return 0;
}

/* Is s an exchange step (halos sent, received and taken)? */
static int xstep(const ndo__rb *rb, int64_t s) { return (s - rb->r.first) % rb->r.K == 0; }
/* The first exchange step at or after s. */
static int64_t xup(const ndo__rb *rb, int64_t s)
{
	int64_t m = (s - rb->r.first) % rb->r.K;
	return m ? s + rb->r.K - m : s;
}

/* The slot of `step`, emptied for it if it held another step. */
static slot *at(ndo__rb *rb, int64_t step)
{
	slot *S = &rb->w[step % rb->win];
	if (S->step != step) {
		S->step = step;
		S->have = S->cf = S->pub = 0;
		S->ncf = 0;
		memset(S->hs, H_NONE, rb->r.nhalo);
	}
	return S;
}

/* Send the strip of `step` (its state kept) as halo messages: runs of
 * consecutive node indices, as many per datagram as fit. */
static int send_strip(ndo__rb *rb, int64_t step)
{
	slot *S = &rb->w[step % rb->win];
	if (S->step != step || !S->have || !rb->r.nstrip || !xstep(rb, step))
		return 0;
	const ndo_net_stats *ns = ndo_net_stats_get(ndo_session_net(rb->s));
	uint64_t b0 = ns->bytes_out;
	ndo_msg_halo_t h;
	memset(&h, 0, sizeof h);
	h.step = step;
	h.time = S->t;
	h.confirmed = (int8_t)(S->cf != 0);
	int rc = ndo_session_send_nodes(rb->s, &h, rb->r.nstrip, rb->r.strip, S->st, rb->sidx, NULL,
	                                rb->rs, rb->rl, rb->vals);
	if (rc < 0)
		return rc;
	rb->st.messages += rc;
	rb->st.strips++;
	rb->st.bytes += ns->bytes_out - b0;
	return 0;
}

/* Keep the simulation's state as the region's at `step`. */
static void keep(ndo__rb *rb, slot *S)
{
	ndo_sim_get_nodes(rb->sim, rb->r.nown, rb->r.own, NULL, rb->bu, rb->bv);
	for (size_t k = 0; k < rb->r.nown; k++) {
		memcpy(S->st + 6 * k, rb->bv + 3 * k, 3 * sizeof *S->st);
		memcpy(S->st + 6 * k + 3, rb->bu + 3 * k, 3 * sizeof *S->st);
	}
	S->t = ndo_sim_time(rb->sim);
	S->have = 1;
}

/* A step of the window is confirmed: a frame shown of it is measured. */
static void confirm(ndo__rb *rb, slot *S)
{
	S->cf = 1;
	if (!S->pub || !S->pu)
		return;
	double e = 0, d = 0;
	for (size_t k = 0; k < rb->r.nown; k++)
		for (int q = 0; q < 3; q++) {
			double u = S->st[6 * k + 3 + (size_t)q];
			e = fmax(e, fabs(S->pu[3 * k + (size_t)q] - u));
			d = fmax(d, fabs(u));
		}
	rb->st.shown_error = fmax(rb->st.shown_error, e);
	rb->st.shown_disp = fmax(rb->st.shown_disp, d);
	rb->st.shown_frames++;
	rb->st.shown_wrong += e > 0;
	S->pub = 0;
}

int ndo__rb_restart(ndo__rb *rb, int64_t step, int exact)
{
	if (!rb->w)
		return 0;
	for (int k = 0; k < rb->win; k++)
		rb->w[k].step = -1;
	rb->base = rb->cur = rb->fr = step;
	rb->mark[0][0] = rb->mark[1][0] = -1;
	rb->roll = INT64_MAX;
	rb->exact = exact;
	rb->st.exact = exact;
	for (int q = 0; q < rb->nnb; q++) {
		rb->nbs[q].kf = step;
		rb->nbs[q].gap = rb->resend0;
		rb->nbs[q].next = 0; /* the first call sends the start again */
	}
	slot *S = at(rb, step);
	keep(rb, S);
	S->cf = exact;
	return send_strip(rb, step);
}

static nb *neighbour(ndo__rb *rb, int32_t id)
{
	for (int q = 0; q < rb->nnb; q++)
		if (rb->nbs[q].id == id)
			return &rb->nbs[q];
	return NULL;
}

int ndo__rb_receive(ndo__rb *rb, const ndo_msg_halo_t *h, double now)
{
	if (!rb->w)
		return 0;
	int64_t s = h->step;
	if (s < rb->base || s >= rb->base + rb->win || !xstep(rb, s)) {
		rb->st.dropped++;
		return 0;
	}
	slot *S = at(rb, s);
	const int32_t from = h->hdr.sender_id;
	size_t i = 0;
	int got = 0;
	for (int r = 0; r < h->nruns; r++)
		for (int32_t q = 0; q < h->len[r]; q++, i++) {
			int32_t c = h->start[r] + q, k = rb->hidx[c];
			if (k < 0 || rb->hown[k] != from || rb->r.canon[c] != c)
				continue;
			got++;
			if (S->hs[k] == H_CONFIRMED)
				continue; /* a confirmed value is final */
			double *in = S->hin + 6 * (size_t)k;
			const double *val = h->values + 6 * i;
			int used = S->hs[k] != H_NONE && s < rb->cur;
			int changed = (S->hs[k] & H_CHANGED) || memcmp(in, val, 6 * sizeof *in) != 0;
			memcpy(in, val, 6 * sizeof *in);
			if (h->confirmed) {
				/* a step taken with another value: redo it */
				if (used && changed && s < rb->roll)
					rb->roll = s;
				S->hs[k] = H_CONFIRMED;
				S->ncf++;
			} else {
				/* another tentative value: the next recomputation takes it,
				 * but it starts none itself — tentative values would bounce
				 * between the peers, each one's rollback another's */
				S->hs[k] = H_TENTATIVE | (used && changed ? H_CHANGED : 0);
			}
		}
	nb *n = got && h->confirmed ? neighbour(rb, from) : NULL;
	if (n && s > n->kf) {
		n->kf = s;
		n->gap = rb->resend0;
		n->next = now + n->gap;
	}
	return got;
}

/* The halo of step s into the simulation (which is at s): received
 * values, and predictions where none came — the simulation's own values
 * of those nodes (rings 1..W−1 were integrated along the last step), the
 * held outermost ring carried along its velocity by one step. */
static void halo_in(ndo__rb *rb, slot *S, int first)
{
	size_t nh = rb->r.nhalo;
	int need = 0;
	for (size_t k = 0; k < nh; k++) {
		S->hs[k] &= (uint8_t)~H_CHANGED; /* the values used from now on */
		need |= S->hs[k] <= H_PREDICTED;
	}
	if (need) {
		ndo_sim_get_nodes(rb->sim, nh, rb->r.halo, NULL, rb->bu, rb->bv);
		const int32_t nn = rb->hnoff[nh];
		if (nn)
			ndo_sim_get_nodes(rb->sim, (size_t)nn, rb->hnl, NULL, NULL, rb->nv);
		for (size_t k = 0; k < nh; k++) {
			if (S->hs[k] > H_PREDICTED)
				continue;
			double *in = S->hin + 6 * k;
			/* rings 1..W−1: as the simulation integrated them; the held
			 * ring moves on by a step at its integrated neighbours' mean
			 * velocity (until 2026-11-30 at its own last velocity, which
			 * nothing updates while it is predicted: without confirmation,
			 * hundreds of predicted steps carried it off in a straight
			 * line and tore the region, docs/peers.md) */
			const int32_t a = rb->hnoff[k], b = rb->hnoff[k + 1];
			for (int d = 0; d < 3; d++) {
				double v = rb->bv[3 * k + (size_t)d];
				if (rb->hheld[k] && b > a) {
					double sv = 0;
					for (int32_t i = a; i < b; i++)
						sv += rb->nv[3 * (size_t)i + (size_t)d];
					v = sv / (double)(b - a);
				}
				in[d] = v;
				in[3 + d] = rb->bu[3 * k + (size_t)d] + (rb->hheld[k] ? rb->h * v : 0);
			}
			rb->st.predicted += first && S->hs[k] == H_NONE;
			S->hs[k] = H_PREDICTED;
		}
	}
	for (size_t k = 0; k < nh; k++) {
		memcpy(rb->bv + 3 * k, S->hin + 6 * k, 3 * sizeof *rb->bv);
		memcpy(rb->bu + 3 * k, S->hin + 6 * k + 3, 3 * sizeof *rb->bu);
	}
	if (nh) {
		ndo_sim_set_displacements(rb->sim, nh, rb->r.halo, rb->bu, rb->bv);
		/* the halo brings the energy its owners' forces put in (as in
		 * exact lock-step) */
		ndo_sim_restart_energy_bound(rb->sim);
	}
}

/* The oldest step the window must keep: this peer's frontier (a rollback
 * goes no further back) and its neighbours' (they may need the strips
 * from there again), the latter no older than what leaves room for the
 * next step: a neighbour that far behind is beyond help.  Without
 * confirmation (exact 0): as much as fits. */
static void slide(ndo__rb *rb)
{
	int64_t lo = rb->cur + 2 - rb->win, b = rb->fr;
	for (int q = 0; q < rb->nnb; q++) {
		int64_t k = rb->nbs[q].kf < lo ? lo : rb->nbs[q].kf;
		if (k < b)
			b = k;
	}
	if (!rb->exact)
		b = lo;
	if (b > rb->base)
		rb->base = b;
	if (rb->roll < rb->base)
		rb->roll = rb->base; /* (exact 0: older changes are given up) */
}

/* Take step s → s + 1 (the simulation at s). */
static int one_step(ndo__rb *rb, int64_t s, int first)
{
	slot *S = &rb->w[s % rb->win];
	int x = xstep(rb, s); /* between exchanges the halo is integrated along */
	if (x)
		halo_in(rb, S, first);
	int rc = ndo_sim_step(rb->sim, rb->h);
	if (rc)
		return rc;
	slot *N = at(rb, s + 1);
	keep(rb, N);
	int was = N->cf;
	if (rb->exact && S->cf && (!x || S->ncf == rb->r.nhalo))
		confirm(rb, N);
	else
		N->cf = 0;
	/* a newly confirmed strip goes twice: a lost confirmation holds up
	 * every later step of every peer until it is sent again (at 20 % loss,
	 * the deepest rollback went from 31 steps to 4, the steps recomputed
	 * from 10 a step to 1.2: bench_peers realtime, level 4) */
	rc = send_strip(rb, s + 1);
	if (!rc && N->cf && !was)
		rc = send_strip(rb, s + 1);
	return rc;
}

int ndo__rb_catch_up(ndo__rb *rb)
{
	if (!rb->w)
		return 0;
	int n = 0, rc;
	if (rb->roll < rb->cur) {
		int64_t r = rb->roll;
		slot *R = &rb->w[r % rb->win];
		if (R->step != r || !R->have)
			return ndo__fail(NDO_EINVAL, "rollback: step %lld is not kept", (long long)r);
		for (size_t k = 0; k < rb->r.nown; k++) {
			memcpy(rb->bv + 3 * k, R->st + 6 * k, 3 * sizeof *rb->bv);
			memcpy(rb->bu + 3 * k, R->st + 6 * k + 3, 3 * sizeof *rb->bu);
		}
		ndo_sim_set_displacements(rb->sim, rb->r.nown, rb->r.own, rb->bu, rb->bv);
		ndo_sim_set_time(rb->sim, R->t, r);
		rb->roll = INT64_MAX;
		for (int64_t s = r; s < rb->cur; s++)
			if ((rc = one_step(rb, s, 0)))
				return rc;
		n = (int)(rb->cur - r);
		rb->st.rollbacks++;
		rb->st.recomputed += n;
		if (n > rb->st.depth_max)
			rb->st.depth_max = n;
	}
	/* steps confirmed without a change of value: their strips again, now
	 * confirmed */
	while (rb->fr < rb->cur) {
		slot *S = &rb->w[rb->fr % rb->win], *N = &rb->w[(rb->fr + 1) % rb->win];
		if (!rb->exact || !S->cf)
			break;
		if (!N->cf) {
			if (xstep(rb, rb->fr) && S->ncf != rb->r.nhalo)
				break;
			confirm(rb, N);
			if ((rc = send_strip(rb, rb->fr + 1)))
				return rc;
			if ((rc = send_strip(rb, rb->fr + 1))) /* twice, as in one_step */
				return rc;
		}
		rb->fr++;
	}
	slide(rb);
	return n;
}

/* Why the window filled, from the confirmations of the last quarter
 * window or more: none (a neighbour starved or gone), or fewer than the
 * steps taken — a network delay of more than --halo-steps steps, which K
 * steps an exchange would cover (K steps are confirmed a delay at best). */
static void window_why(const ndo__rb *rb, char *why, size_t n)
{
	const int64_t dc = rb->cur - rb->mark[0][0], dfr = rb->fr - rb->mark[0][1];
	*why = 0;
	if (rb->mark[0][0] < 0 || dc <= 0)
		return;
	const double rho = (double)dfr / (double)dc;
	if (rho < 0.05)
		snprintf(why, n, "; %lld steps confirmed in the last %lld taken (a neighbour starved "
		         "or gone)", (long long)dfr, (long long)dc);
	else if (rho < 0.95) /* a tenth more: K/rho kept up only just (test_peer) */
		snprintf(why, n, "; %.2f steps confirmed a step taken lately: the network's delay is "
		         "longer than %d step%s of the pace (--halo-steps %d), and --halo-steps %d or "
		         "more would keep up", rho, rb->r.K, rb->r.K == 1 ? "" : "s", rb->r.K,
		         (int)ceil(1.1 * rb->r.K / rho));
}

int ndo__rb_step(ndo__rb *rb, double h)
{
	rb->h = h;
	slide(rb);
	if (rb->cur + 1 >= rb->base + rb->win) {
		char why[200];
		window_why(rb, why, sizeof why);
		return ndo__fail(NDO_EPACE, "%d steps taken since step %lld, the newest that all "
		                 "its inputs confirmed: the rollback window is full%s",
		                 rb->win - 1, (long long)rb->base, why);
	}
	if (rb->mark[1][0] < 0 || rb->cur - rb->mark[1][0] >= rb->win / 4) {
		rb->mark[0][0] = rb->mark[1][0], rb->mark[0][1] = rb->mark[1][1];
		rb->mark[1][0] = rb->cur, rb->mark[1][1] = rb->fr;
		if (rb->mark[0][0] < 0)
			rb->mark[0][0] = rb->cur, rb->mark[0][1] = rb->fr;
	}
	int rc = one_step(rb, rb->cur, 1);
	if (rc)
		return rc;
	rb->cur++;
	/* the oldest confirmed strip a neighbour may still need, once more with
	 * every step: at 20 % loss a lost confirmation would otherwise wait
	 * for a re-send, and every step after it for the confirmation */
	if (rb->exact) {
		int64_t m = rb->fr;
		for (int q = 0; q < rb->nnb; q++)
			if (rb->nbs[q].kf < m)
				m = rb->nbs[q].kf;
		m = xup(rb, m);
		if (m < rb->cur && m >= rb->base && ndo__rb_confirmed(rb, m))
			return send_strip(rb, m);
	}
	return 0;
}

int64_t ndo__rb_newest(const ndo__rb *rb) { return rb->cur; }
int64_t ndo__rb_frontier(const ndo__rb *rb) { return rb->fr; }

int ndo__rb_confirmed(const ndo__rb *rb, int64_t step)
{
	if (!rb->w || !rb->exact || step < rb->base || step >= rb->base + rb->win)
		return 0;
	const slot *S = &rb->w[step % rb->win];
	return S->step == step && S->cf;
}

int ndo__rb_ready(const ndo__rb *rb)
{
	if (!rb->w)
		return 0;
	const slot *S = &rb->w[rb->base % rb->win];
	return S->step == rb->base && (S->ncf == rb->r.nhalo || !xstep(rb, rb->base));
}

int ndo__rb_published(ndo__rb *rb)
{
	if (!rb->w || !rb->exact)
		return 0;
	slot *S = &rb->w[rb->cur % rb->win];
	if (S->cf) {
		rb->st.shown_frames++; /* shown confirmed: no error */
		return 0;
	}
	if (!S->pu && !(S->pu = malloc(3 * (rb->r.nown ? rb->r.nown : 1) * sizeof *S->pu)))
		return ndo__fail(NDO_ENOMEM, "out of memory");
	for (size_t k = 0; k < rb->r.nown; k++)
		memcpy(S->pu + 3 * k, S->st + 6 * k + 3, 3 * sizeof *S->pu);
	S->pub = 1;
	return 0;
}

int ndo__rb_resend(ndo__rb *rb, double now, int force)
{
	if (!rb->w)
		return 0;
	/* the steps some neighbour waits for: from its frontier, two of them,
	 * as far as this peer has them confirmed (inexact: the newest two) */
	int64_t from = INT64_MAX;
	for (int q = 0; q < rb->nnb; q++) {
		nb *n = &rb->nbs[q];
		if (!force && !(now >= n->next))
			continue;
		int64_t k = rb->exact ? n->kf : rb->cur - 1;
		if (rb->exact && k > rb->fr)
			continue;
		if (k < from)
			from = k;
		n->next = now + n->gap;
		n->gap = fmin(2 * n->gap, fmin(RESEND_MAX, 4 * rb->resend0));
	}
	if (from == INT64_MAX && force)
		from = rb->exact ? rb->fr : rb->cur;
	if (from == INT64_MAX)
		return 0;
	if (from < rb->base)
		from = rb->base;
	from = xup(rb, from - (rb->exact ? 0 : rb->r.K - 1)); /* (exact 0: the newest) */
	for (int64_t s = from; s <= from + rb->r.K && s <= rb->cur; s += rb->r.K) {
		if (rb->exact && !ndo__rb_confirmed(rb, s))
			break;
		int rc = send_strip(rb, s);
		if (rc)
			return rc;
		rb->st.resends++;
	}
	return 0;
}

double ndo__rb_next_resend(const ndo__rb *rb)
{
	double t = INFINITY;
	for (int q = 0; q < rb->nnb; q++)
		if (!rb->exact || rb->nbs[q].kf <= rb->fr)
			t = fmin(t, rb->nbs[q].next);
	return t;
}

void ndo__rb_stats_get(const ndo__rb *rb, ndo__rb_stats *st) { *st = rb->st; }
