/* peer_solve.c — lock-step steps of several exchanges: rkf45's sub-steps
 * with the error reduced over the peers, the implicit methods' system by
 * conjugate gradients over the peers (peer_solve.h; docs/peers.md).
 *
 * A step is a sequence of phases 0, 1, 2, ..., the same on every peer
 * because every decision is taken from the same reduced values.  In each
 * phase every simulating peer sends one solve_t (split into datagrams):
 * its strip's state (rkf45's sub-step start, the implicit step's start),
 * or a vector (the preconditioned residual), and its partial sums.  A
 * peer goes on when its halo holds every node of the phase and every
 * peer's sums have come; it adds the sums in the order of the peers' ids
 * (or takes their maximum), so all get the same bits.
 *
 * rkf45:    state (4 rings) → [error, the strip's state should the
 *           attempt be accepted] → [error, state] ...: one exchange per
 *           attempt (a rejected attempt's state is not used; the last
 *           attempt of a step brings the next step's halo, so only the
 *           run's first step, or one after a new partition, exchanges the
 *           state alone).  The owned nodes' stage values are the single
 *           process's, and the error is a maximum: the sub-steps are the
 *           single process's, and so is the result, bit for bit.
 * implicit: state (1 ring) → b, x₀ = v, r₀ = b − A x₀, u₀ = M⁻¹r₀ →
 *           [u₀, (b·b, r·r)] → w = A u, m = M⁻¹w → [m, (r·u, w·u, r·r)]
 *           → n = A m, the recurrences → [m, (r·u, w·u, r·r)] → ... until
 *           |r| ≤ 1e-13 |b| (pipelined conjugate gradients: one exchange
 *           per iteration); then, for an object without pins, the
 *           momentum correction's sums → [(7 sums)] → the step ends.
 *           Preconditioned with A's diagonal (Jacobi, the default), or
 *           with each region's block of A factored by CHOLMOD (block
 *           Jacobi, --precondition block: the solve is exact within a
 *           region, and only the coupling across the cut is iterated);
 *           the result is the single process's CHOLMOD solution to the
 *           solve's tolerance, not bit for bit. */
#include "peer_solve.h"
#include "peer_test.h"
#include "ndo/simd.h"
#include "ndo/status.h"

#include <math.h>
#include <float.h>
#include <stdlib.h>
#include <string.h>

#define CG_TOL 1e-13       /* |r| ≤ CG_TOL |b| (2-norms over every unknown) */
#define CG_MAX 20000       /* iterations before the solve gives up */
/* The stash keeps messages of later phases in two classes, of the
 * partition in force (its members': peer.c checks) and of the next one
 * (anyone's: take() checks them once it is in force), each at most
 * STASH_COUNT messages and STASH_GRIDS grids' worth of state (6 doubles a
 * node; a peer's phase is one strip of 3 or 6 a node, and the others can
 * be at most a step ahead) plus STASH_FLOOR bytes.  It keeps what it has:
 * a message that does not fit is dropped, and a re-send brings it again.
 * Not kept either: a phase of a partition after the next (this peer
 * missed one, and installs the newest when its partition message comes
 * again), or more than REACH steps after the step under way.  Until
 * 2026-11-30 it kept 4096 messages of any partition and step: a stranger
 * could make a level-7 peer hold 6 GB. */
#define STASH_COUNT 2048
#define STASH_GRIDS 4
#define STASH_FLOOR ((size_t)1 << 20)
#define REACH (NDO_MAX_PEERS + 1)

enum {
	IDLE,       /* no step under way */
	SEND_STATE, /* send the strip's state, then wait for the halo's */
	WAIT_STATE,
	ATTEMPT,    /* rkf45: stages and error of the next sub-step */
	WAIT_ERR,
	WAIT_U,     /* implicit: u₀ = M⁻¹r₀ on the halo and (b·b, r·r) */
	WAIT_M,     /* implicit: m = M⁻¹w on the halo and (r·u, w·u, r·r) */
	WAIT_RIGID  /* implicit: the momentum correction's sums */
};

typedef struct stashed {
	ndo_msg_solve_t m; /* copies of the arrays */
} stashed;

/* The phases a peer keeps, and sends again while it waits: a peer may be
 * two phases ahead of another.  Every phase but a step's first (the state,
 * from the neighbours alone) waits for every peer's sums; so a peer that
 * has the last phase of step S from all goes on through S + 1's first
 * without hearing from a peer that is not its neighbour, sends S + 1's
 * second, and waits there.  A peer still waiting for S's last (its copy
 * from that peer lost) needs it from that peer's third newest phase.
 * With two kept, such a loss stalled the step until the step timeout and
 * took it inexact (3 peers in bands, the trapezoid, 10 % loss). */
#define SLOTS 3

typedef struct sent {
	int64_t key;
	int per_node, nsums;
	double sums[NDO_MAX_SUMS];
	double *values; /* per strip node, per_node each */
} sent;

struct ndo__ps {
	ndo_session *s;
	ndo_sim *sim;
	ndo_method method;
	int implicit;
	size_t count;
	ndo__ps_region r;
	/* the step under way */
	int64_t step;
	int32_t phase;   /* the phase last sent (−1: none yet) */
	int state;
	double h;
	int64_t iter;
	/* what came for the phase awaited */
	int64_t *rkey;   /* per canonical node: the key of the value in rval */
	double *rval;    /* 6 per node */
	size_t got;      /* halo nodes that hold the awaited key */
	int32_t ids[NDO_MAX_PEERS];
	int nids;
	int64_t skey[NDO_MAX_PEERS];
	int64_t seen[NDO_MAX_PEERS]; /* each peer's newest step heard of (this partition) */
	double sums[NDO_MAX_PEERS][NDO_MAX_SUMS];
	int nsums[NDO_MAX_PEERS];
	stashed *stash;
	size_t nstash, capstash;
	size_t scount[2], sbytes[2]; /* the stash's classes: [0] the partition in
	                                force, [1] the next */
	sent last[SLOTS];
	/* rkf45: the state the step began with (abort) */
	double *snap_u, *snap_v;
	int32_t *all;
	int snapped;
	/* implicit: conjugate gradients, 3 planes each */
	double *x, *b, *rr, *z, *p, *q, *u, *w, *m, *nv, *sv, *dinv, *tmp;
	double *m2;      /* the diagonal's fused iteration: the next m, while m is read */
	double gam, alpha, bb;
	ndo_sim_rows *rows; /* the region's rows for the step's products */
	int32_t *orun;   /* the region's rows as runs of consecutive nodes, in their */
	size_t norun;    /* order: [orun[2k], orun[2k+1]) */
	int jacobi;      /* precondition with the diagonal (1; 2: through the general
	                  * recurrences, cg_update's: the fast path's reference), not the
	                  * region's block (0) */
	int peek;        /* rkf45: the state strip is the attempt's outcome */
	int64_t ready;   /* rkf45: the step whose start the halo holds (−1: none) */
	ndo__ps_stats st;
};

int ndo__ps_method(ndo_method m)
{
	return m == NDO_RKF45 || ndo_method_is_implicit(m);
}

int ndo__ps_rings(ndo_method m)
{
	return m == NDO_RKF45 ? 4 : 1;
}

static int64_t key_of(int64_t step, int32_t phase)
{
	return step * (NDO_MAX_PHASE + 1) + phase;
}

static void free_msg(ndo_msg_solve_t *m)
{
	free(m->start), free(m->len), free(m->values), free(m->sums);
}

void ndo__ps_destroy(ndo__ps *ps)
{
	if (!ps)
		return;
	for (size_t k = 0; k < ps->nstash; k++)
		free_msg(&ps->stash[k].m);
	free(ps->stash);
	free(ps->rkey), free(ps->rval);
	for (int b = 0; b < SLOTS; b++)
		free(ps->last[b].values);
	free(ps->snap_u), free(ps->snap_v), free(ps->all);
	free(ps->x), free(ps->b), free(ps->rr), free(ps->z), free(ps->p), free(ps->q);
	free(ps->u), free(ps->w), free(ps->m), free(ps->m2), free(ps->nv), free(ps->sv);
	free(ps->dinv), free(ps->tmp);
	ndo_sim_rows_free(ps->rows);
	free(ps->orun);
	free(ps);
}

int ndo__ps_reference;

int ndo__ps_create(ndo_session *s, ndo_sim *sim, int jacobi, ndo__ps **out)
{
	ndo__clear_error();
	ndo__ps *ps = calloc(1, sizeof *ps);
	ndo_grid *g = ndo_session_grid(s);
	if (!ps)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	ps->s = s;
	ps->sim = sim;
	ps->method = ndo_sim_method(sim);
	ps->implicit = ndo_method_is_implicit(ps->method);
	ps->jacobi = jacobi && ndo__ps_reference ? 2 : jacobi;
	ps->count = g->count;
	ps->step = -1;
	ps->phase = -1;
	ps->state = IDLE;
	ps->ready = -1;
	size_t n = ps->count;
	int ok = (ps->rkey = malloc(n * sizeof *ps->rkey)) && (ps->rval = malloc(6 * n * sizeof(double))) &&
	         (ps->tmp = malloc((8 * n + 8192) * sizeof(double)));
	for (int b = 0; b < SLOTS && ok; b++)
		ok = (ps->last[b].values = malloc(6 * n * sizeof(double))) != NULL;
	if (ok && ps->method == NDO_RKF45)
		ok = (ps->snap_u = malloc(3 * n * sizeof(double))) &&
		     (ps->snap_v = malloc(3 * n * sizeof(double))) && (ps->all = malloc(n * sizeof(int32_t)));
	if (ok && ps->implicit)
		ok = (ps->x = calloc(3 * n, sizeof(double))) && (ps->b = calloc(3 * n, sizeof(double))) &&
		     (ps->rr = calloc(3 * n, sizeof(double))) && (ps->z = calloc(3 * n, sizeof(double))) &&
		     (ps->p = calloc(3 * n, sizeof(double))) && (ps->q = calloc(3 * n, sizeof(double))) &&
		     (ps->u = calloc(3 * n, sizeof(double))) && (ps->w = calloc(3 * n, sizeof(double))) &&
		     (ps->m = calloc(3 * n, sizeof(double))) && (ps->m2 = calloc(3 * n, sizeof(double))) &&
		     (ps->nv = calloc(3 * n, sizeof(double))) &&
		     (ps->sv = calloc(3 * n, sizeof(double))) &&
		     (ps->dinv = calloc(n, sizeof(double))) &&
		     (ps->orun = malloc(2 * n * sizeof(int32_t)));
	if (!ok) {
		ndo__ps_destroy(ps);
		return ndo__fail(NDO_ENOMEM, "out of memory");
	}
	for (size_t k = 0; k < n; k++)
		ps->rkey[k] = -1;
	if (ps->all)
		for (size_t k = 0; k < n; k++)
			ps->all[k] = (int32_t)k;
	for (int b = 0; b < SLOTS; b++)
		ps->last[b].key = -1;
	*out = ps;
	return 0;
}

void ndo__ps_stats_get(const ndo__ps *ps, ndo__ps_stats *st)
{
	*st = ps->st;
}

/* ---- the peers, in the order of their ids ------------------------------ */
static void members(ndo__ps *ps)
{
	int n = 0;
	const int32_t *ids = NULL;
	ndo_session_cells(ps->s, &n, &ids);
	if (n > NDO_MAX_PEERS)
		n = NDO_MAX_PEERS;
	ps->nids = n;
	for (int k = 0; k < n; k++)
		ps->ids[k] = ids[k];
	for (int a = 1; a < n; a++) /* insertion sort: at most 8 */
		for (int b = a; b > 0 && ps->ids[b - 1] > ps->ids[b]; b--) {
			int32_t t = ps->ids[b];
			ps->ids[b] = ps->ids[b - 1];
			ps->ids[b - 1] = t;
		}
	for (int k = 0; k < n; k++)
		ps->skey[k] = -1;
}

static int member_index(const ndo__ps *ps, int32_t id)
{
	for (int k = 0; k < ps->nids; k++)
		if (ps->ids[k] == id)
			return k;
	return -1;
}

/* ---- receiving ------------------------------------------------------------ */
static int64_t awaited(const ndo__ps *ps)
{
	return ps->step < 0 || ps->phase < 0 ? -1 : key_of(ps->step, ps->phase);
}

/* Take a message of the phase awaited: its halo nodes and its sums. */
static void take(ndo__ps *ps, const ndo_msg_solve_t *m)
{
	const int64_t key = key_of(m->step, m->phase);
	const int32_t *own = ndo_grid_find(ndo_session_grid(ps->s), NDO_CH_OWNER)->data;
	int i = member_index(ps, m->hdr.sender_id);
	if (i < 0)
		return;
	if (ps->skey[i] != key) {
		ps->skey[i] = key;
		ps->nsums[i] = m->nsums;
		if (m->nsums)
			memcpy(ps->sums[i], m->sums, (size_t)m->nsums * sizeof(double));
	}
	const int vpn = m->per_node;
	if (!vpn)
		return;
	size_t k = 0;
	for (int r = 0; r < m->nruns; r++)
		for (int32_t j = 0; j < m->len[r]; j++, k += (size_t)vpn) {
			size_t c = (size_t)m->start[r] + (size_t)j;
			if (own[c] != m->hdr.sender_id || ps->rkey[c] == key)
				continue; /* not the sender's, or already here */
			/* a halo node? (the strip may hold nodes of others' halos) */
			ps->rkey[c] = key;
			memcpy(ps->rval + 6 * c, m->values + k, (size_t)vpn * sizeof(double));
		}
}

static size_t msg_size(const ndo_msg_solve_t *m)
{
	return sizeof *m + 64 + 8 * (size_t)m->nruns + 8 * (size_t)m->nvalues +
	       8 * (size_t)m->nsums;
}

static int stash(ndo__ps *ps, const ndo_msg_solve_t *m)
{
	int32_t epoch = ndo_session_epoch(ps->s);
	int next = m->epoch > epoch;
	size_t size = msg_size(m);
	if (m->epoch > epoch + 1 || (!next && ps->step >= 0 && m->step > ps->step + REACH) ||
	    ps->scount[next] >= STASH_COUNT ||
	    ps->sbytes[next] + size > STASH_GRIDS * 6 * sizeof(double) * ps->count + STASH_FLOOR)
		return 0; /* a re-send brings what is needed */
	if (ps->nstash == ps->capstash) {
		size_t cap = ps->capstash ? 2 * ps->capstash : 32;
		stashed *q = realloc(ps->stash, cap * sizeof *q);
		if (!q)
			return NDO_ENOMEM;
		ps->stash = q;
		ps->capstash = cap;
	}
	ndo_msg_solve_t *c = &ps->stash[ps->nstash].m;
	*c = *m;
	c->start = malloc((size_t)(m->nruns ? m->nruns : 1) * sizeof *c->start);
	c->len = malloc((size_t)(m->nruns ? m->nruns : 1) * sizeof *c->len);
	c->values = malloc((size_t)(m->nvalues ? m->nvalues : 1) * sizeof *c->values);
	c->sums = malloc((size_t)(m->nsums ? m->nsums : 1) * sizeof *c->sums);
	if (!c->start || !c->len || !c->values || !c->sums) {
		free_msg(c);
		return NDO_ENOMEM;
	}
	/* (a decoded empty array is NULL) */
	if (m->nruns) {
		memcpy(c->start, m->start, (size_t)m->nruns * sizeof *c->start);
		memcpy(c->len, m->len, (size_t)m->nruns * sizeof *c->len);
	}
	if (m->nvalues)
		memcpy(c->values, m->values, (size_t)m->nvalues * sizeof *c->values);
	if (m->nsums)
		memcpy(c->sums, m->sums, (size_t)m->nsums * sizeof *c->sums);
	ps->nstash++;
	ps->scount[next]++;
	ps->sbytes[next] += size;
	return 0;
}

void ndo__ps_receive(ndo__ps *ps, const ndo_msg_solve_t *m)
{
	int32_t epoch = ndo_session_epoch(ps->s);
	if (m->epoch < epoch)
		return;
	int i = m->epoch == epoch ? member_index(ps, m->hdr.sender_id) : -1;
	/* (not a step further ahead than a peer can be: one far ahead would
	 * hide that the peer is behind, ndo__ps_behind) */
	if (i >= 0 && m->step > ps->seen[i] && (ps->step < 0 || m->step <= ps->step + REACH))
		ps->seen[i] = m->step;
	int64_t key = key_of(m->step, m->phase), want = awaited(ps);
	if (m->epoch == epoch && key == want) {
		take(ps, m);
		return;
	}
	if (m->epoch > epoch || want < 0 || key > want)
		stash(ps, m); /* for later (out of memory: a re-send brings it again) */
}

/* The stash's messages of the phase now awaited; drop the older ones. */
static void unstash(ndo__ps *ps)
{
	int32_t epoch = ndo_session_epoch(ps->s);
	int64_t want = awaited(ps);
	size_t keep = 0;
	ps->scount[0] = ps->scount[1] = ps->sbytes[0] = ps->sbytes[1] = 0;
	for (size_t k = 0; k < ps->nstash; k++) {
		ndo_msg_solve_t *m = &ps->stash[k].m;
		int64_t key = key_of(m->step, m->phase);
		if (m->epoch < epoch || (m->epoch == epoch && want >= 0 && key < want)) {
			free_msg(m);
		} else if (m->epoch == epoch && key == want) {
			take(ps, m);
			free_msg(m);
		} else {
			int next = m->epoch > epoch;
			ps->scount[next]++;
			ps->sbytes[next] += msg_size(m);
			ps->stash[keep++] = ps->stash[k];
		}
	}
	ps->nstash = keep;
}

size_t ndo__ps_stash_bytes(const ndo__ps *ps)
{
	size_t n = 0;
	for (size_t k = 0; k < ps->nstash; k++)
		n += msg_size(&ps->stash[k].m);
	return n;
}

/* Does the halo hold the awaited phase's values, and have every peer's
 * sums come? */
static int halo_complete(const ndo__ps *ps)
{
	int64_t key = awaited(ps);
	for (size_t k = 0; k < ps->r.nhalo; k++)
		if (ps->rkey[ps->r.halo[k]] != key)
			return 0;
	return 1;
}

static int sums_complete(const ndo__ps *ps)
{
	int64_t key = awaited(ps);
	for (int k = 0; k < ps->nids; k++)
		if (ps->skey[k] != key)
			return 0;
	return 1;
}

/* Σ over the peers, in id order, of sums[j]. */
static double total(const ndo__ps *ps, int j)
{
	double t = 0;
	for (int k = 0; k < ps->nids; k++)
		t += j < ps->nsums[k] ? ps->sums[k][j] : 0;
	return t;
}

/* ---- sending ---------------------------------------------------------------- */
/* Send slot b (the strip's values and the sums) as solve_t messages:
 * runs of consecutive node indices, as many per datagram as fit. */
static int send_slot(ndo__ps *ps, int b)
{
	sent *sl = &ps->last[b];
	if (sl->key < 0)
		return 0;
	const ndo_net_stats *ns = ndo_net_stats_get(ndo_session_net(ps->s));
	uint64_t b0 = ns->bytes_out;
	const size_t budget = 60000;
	const size_t vpn = (size_t)sl->per_node, n = vpn ? ps->r.nstrip : 0;
	int32_t *start = (int32_t *)ps->tmp, *len = start + ps->count;
	double *vals = ps->tmp + ps->count; /* scratch: after the runs */
	size_t k = 0;
	do {
		size_t nr = 0, nn = 0, bytes = 128 + 8 * NDO_MAX_SUMS;
		while (k < n && bytes + 8 + 8 * vpn <= budget) {
			int32_t c = ps->r.strip[k];
			if (nr && start[nr - 1] + len[nr - 1] == c) {
				len[nr - 1]++;
				bytes += 8 * vpn;
			} else {
				start[nr] = c;
				len[nr++] = 1;
				bytes += 8 + 8 * vpn;
			}
			memcpy(vals + vpn * nn, sl->values + vpn * k, vpn * sizeof *vals);
			nn++;
			k++;
		}
		ndo_msg_solve_t m;
		memset(&m, 0, sizeof m);
		m.step = sl->key / (NDO_MAX_PHASE + 1);
		m.phase = (int32_t)(sl->key % (NDO_MAX_PHASE + 1));
		m.per_node = (int8_t)vpn;
		m.nruns = (int32_t)nr;
		m.start = start;
		m.len = len;
		m.nvalues = (int32_t)(vpn * nn);
		m.values = vals;
		m.nsums = sl->nsums;
		m.sums = sl->sums;
		int rc = ndo_session_send_solve(ps->s, &m);
		if (rc < 0)
			return rc;
		ps->st.messages++;
	} while (k < n);
	ps->st.bytes += ns->bytes_out - b0;
	return 0;
}

/* The strip's state if the sub-step just attempted is accepted (velocity,
 * displacement per node), into slot values via next_phase's planes. */
static void peek_strip(ndo__ps *ps, double *vals)
{
	size_t n = ps->r.nstrip;
	double *u = ps->tmp, *v = ps->tmp + 3 * n;
	ndo_sim_rkf45_peek(ps->sim, n, ps->r.strip, u, v);
	for (size_t k = 0; k < n; k++) {
		memcpy(vals + 6 * k, v + 3 * k, 3 * sizeof(double));
		memcpy(vals + 6 * k + 3, u + 3 * k, 3 * sizeof(double));
	}
}

/* The next phase: this peer's part (per node of the strip: `vpn` values
 * of `planes`/the state; `sums`) goes out and is taken as received. */
static int next_phase(ndo__ps *ps, int vpn, const double *planes, const double *sums, int nsums)
{
	if (ps->phase >= NDO_MAX_PHASE)
		return ndo__fail(NDO_EDIVERGED, "step %lld takes more than %d exchanges",
		                 (long long)ps->step, NDO_MAX_PHASE);
	ps->phase++;
	int b = (int)(ps->st.phases % SLOTS); /* the oldest (not by phase: a step's last
	                                        and the next step's first may share it) */
	sent *sl = &ps->last[b];
	sl->key = key_of(ps->step, ps->phase);
	sl->per_node = vpn;
	sl->nsums = nsums;
	if (nsums)
		memcpy(sl->sums, sums, (size_t)nsums * sizeof *sums);
	if (vpn == 6 && ps->peek) {
		peek_strip(ps, sl->values);
	} else if (vpn == 6) {
		/* velocity, displacement */
		ndo_sim_get_nodes(ps->sim, ps->r.nstrip, ps->r.strip, NULL, ps->tmp,
		                  ps->tmp + 3 * ps->r.nstrip);
		for (size_t k = 0; k < ps->r.nstrip; k++) {
			memcpy(sl->values + 6 * k, ps->tmp + 3 * ps->r.nstrip + 3 * k, 3 * sizeof(double));
			memcpy(sl->values + 6 * k + 3, ps->tmp + 3 * k, 3 * sizeof(double));
		}
	} else if (vpn == 3) {
		for (size_t k = 0; k < ps->r.nstrip; k++)
			for (int c = 0; c < 3; c++)
				sl->values[3 * k + c] = planes[(size_t)c * ps->count + (size_t)ps->r.strip[k]];
	}
	/* our own sums, as every peer's */
	int i = member_index(ps, ndo_session_self(ps->s));
	if (i >= 0) {
		ps->skey[i] = sl->key;
		ps->nsums[i] = nsums;
		if (nsums)
			memcpy(ps->sums[i], sums, (size_t)nsums * sizeof *sums);
	}
	ps->st.phases++;
	int rc = send_slot(ps, b);
	unstash(ps);
	return rc;
}

int ndo__ps_alone(const ndo__ps *ps)
{
	return ps->nids <= 1;
}

int ndo__ps_behind(const ndo__ps *ps, int64_t step)
{
	int self = member_index(ps, ndo_session_self(ps->s));
	for (int k = 0; k < ps->nids; k++)
		if (k != self && ps->seen[k] >= 0 && ps->seen[k] < step)
			return 1;
	return 0;
}

int ndo__ps_resend(ndo__ps *ps)
{
	int rc;
	for (int b = 0; b < SLOTS; b++)
		if ((rc = send_slot(ps, b)))
			return rc;
	return 0;
}

/* ---- the region ------------------------------------------------------------- */
void ndo__ps_abort(ndo__ps *ps)
{
	if (ps->state != IDLE && ps->method == NDO_RKF45 && ps->snapped) {
		ndo_sim_set_displacements(ps->sim, ps->count, ps->all, ps->snap_u, ps->snap_v);
		ndo_sim_rkf45_abort(ps->sim);
	}
	ps->state = IDLE;
	ps->step = -1;
	ps->phase = -1;
	ps->snapped = 0;
	ps->ready = -1;
}

void ndo__ps_set_region(ndo__ps *ps, const ndo__ps_region *r)
{
	ps->r = *r;
	members(ps);
	ps->norun = 0;
	for (size_t k = 0; ps->orun && k < r->nown; k++) {
		if (ps->norun && ps->orun[2 * ps->norun - 1] == r->own[k])
			ps->orun[2 * ps->norun - 1]++;
		else
			ps->orun[2 * ps->norun] = r->own[k], ps->orun[2 * ps->norun + 1] = r->own[k] + 1,
			ps->norun++;
	}
	for (int k = 0; k < NDO_MAX_PEERS; k++)
		ps->seen[k] = -1;
	/* values of the old partition's phases are not this one's, whatever
	 * their key (a step started again has the same keys) */
	for (size_t k = 0; k < ps->count; k++)
		ps->rkey[k] = -1;
	for (int b = 0; b < SLOTS; b++)
		ps->last[b].key = -1; /* the old strip's */
}

/* ---- the halo's values into the simulation or a vector ---------------------- */
static void halo_state(ndo__ps *ps)
{
	size_t n = ps->r.nhalo;
	double *u = ps->tmp, *v = ps->tmp + 3 * n;
	for (size_t k = 0; k < n; k++) {
		const double *val = ps->rval + 6 * (size_t)ps->r.halo[k];
		memcpy(v + 3 * k, val, 3 * sizeof(double));
		memcpy(u + 3 * k, val + 3, 3 * sizeof(double));
	}
	if (n) {
		ndo_sim_set_displacements(ps->sim, n, ps->r.halo, u, v);
		/* the halo brings energy its owners' forces put in */
		ndo_sim_restart_energy_bound(ps->sim);
	}
}

/* planes ← the halo's received vector (3 a node). */
static void halo_vector(ndo__ps *ps, double *planes)
{
	for (size_t k = 0; k < ps->r.nhalo; k++) {
		size_t c = (size_t)ps->r.halo[k];
		for (int d = 0; d < 3; d++)
			planes[(size_t)d * ps->count + c] = ps->rval[6 * c + (size_t)d];
	}
}

/* The step's state on the strip, alone: the first phase of a step whose
 * halo did not come with the last one. */
static int send_state(ndo__ps *ps)
{
	ps->state = WAIT_STATE;
	return next_phase(ps, 6, NULL, NULL, 0);
}

/* ---- rkf45 ------------------------------------------------------------------ */
static int rkf45_advance(ndo__ps *ps)
{
	for (;;) {
		switch (ps->state) {
		case SEND_STATE: {
			int rc = send_state(ps);
			if (rc)
				return rc;
			break;
		}
		case WAIT_STATE:
			if (!halo_complete(ps))
				return 0;
			halo_state(ps);
			ps->state = ATTEMPT;
			break;
		case ATTEMPT: {
			double err;
			int rc = ndo_sim_rkf45_attempt(ps->sim, ps->r.mask, &err, NULL);
			if (rc)
				return rc;
			ps->st.attempts++;
			/* NaN and infinity travel as the largest double: the
			 * controller treats all three alike (reject, a tenth) */
			if (!isfinite(err))
				err = DBL_MAX;
			/* with the error, the strip's state after the sub-step should
			 * it be accepted: the next sub-step's halo, without another
			 * exchange */
			ps->peek = 1;
			rc = next_phase(ps, 6, NULL, &err, 1);
			ps->peek = 0;
			if (rc)
				return rc;
			ps->state = WAIT_ERR;
			break;
		}
		case WAIT_ERR: {
			if (!sums_complete(ps) || !halo_complete(ps))
				return 0;
			double err = 0;
			for (int k = 0; k < ps->nids; k++)
				if (ps->nsums[k] > 0 && ps->sums[k][0] > err)
					err = ps->sums[k][0];
			ndo_sim_stats a, b;
			ndo_sim_stats_get(ps->sim, &a);
			int rc = ndo_sim_rkf45_decide(ps->sim, err);
			if (rc < 0)
				return rc;
			ndo_sim_stats_get(ps->sim, &b);
			if (b.rejected > a.rejected) {
				ps->st.rejected++;
				ps->state = ATTEMPT; /* the same state, a smaller sub-step */
				break;
			}
			halo_state(ps); /* the halo at the accepted sub-step's end */
			if (rc == 1) {
				ps->state = IDLE;
				ps->ready = ps->step + 1; /* the next step's halo is here */
				return 1;
			}
			ps->state = ATTEMPT;
			break;
		}
		default: return ndo__fail(NDO_EINVAL, "peer solve: state %d", ps->state);
		}
	}
}

/* ---- the implicit methods: conjugate gradients --------------------------------- */
/* Σ a·b over the rows' 3 planes, in the rows' order (the runs follow it:
 * the same sum, bit for bit, as node by node). */
static double dot(const ndo__ps *ps, const double *a, const double *b)
{
	double s = 0;
	for (int c = 0; c < 3; c++)
		for (size_t r = 0; r < ps->norun; r++) {
			const size_t q1 = (size_t)c * ps->count + (size_t)ps->orun[2 * r + 1];
			for (size_t q = (size_t)c * ps->count + (size_t)ps->orun[2 * r]; q < q1; q++)
				s += a[q] * b[q];
		}
	return s;
}

/* out = M⁻¹ in on the rows: the region's block (CHOLMOD) or the diagonal. */
static int precondition(ndo__ps *ps, const double *in, double *out)
{
	const size_t n = ps->count;
	const double *const dinv = ps->dinv;
	for (int c = 0; c < 3; c++)
		for (size_t r = 0; r < ps->norun; r++) {
			const size_t p1 = (size_t)ps->orun[2 * r + 1], o = (size_t)c * n;
			for (size_t p = (size_t)ps->orun[2 * r]; p < p1; p++)
				out[o + p] = ps->jacobi ? dinv[p] * in[o + p] : 0;
		}
	return ps->jacobi ? 0 : ndo_sim_implicit_precondition(ps->sim, ps->h, in, out);
}

/* y = A x on the rows (x on the rows and the halo), the step's rows
 * gathered once (ndo_sim_implicit_apply's bits). */
static void apply(ndo__ps *ps, const double *x, double *y)
{
	ndo_sim_implicit_apply_rows(ps->sim, ps->rows, x, y);
}

/* The solve is done: the momentum correction's sums when the single
 * process makes one (a phase more), else the step's end. */
static int solved(ndo__ps *ps)
{
	double sums[7], gamma;
	if (ndo_sim_implicit_rigid(ps->sim, ps->h, ps->r.own, ps->r.nown, ps->x, sums, &gamma)) {
		int rc = next_phase(ps, 0, NULL, sums, 7);
		if (rc)
			return rc;
		ps->state = WAIT_RIGID;
		return 0;
	}
	ndo_sim_implicit_end(ps->sim, ps->h, ps->x);
	ps->state = IDLE;
	return 1;
}

/* The next iteration's exchange: m = M⁻¹w on the strip, with the partial
 * sums (r·u, w·u, r·r): `made` by the update, or NULL; m_made: the update
 * made m too (jacobi_iteration). */
static int send_m(ndo__ps *ps, const double *made, int m_made)
{
	int rc = 0;
	if (!m_made)
		rc = precondition(ps, ps->w, ps->m);
	if (rc)
		return rc;
	double sums[3];
	if (made)
		memcpy(sums, made, sizeof sums);
	else
		sums[0] = dot(ps, ps->rr, ps->u), sums[1] = dot(ps, ps->w, ps->u),
		sums[2] = dot(ps, ps->rr, ps->rr);
	if ((rc = next_phase(ps, 3, ps->m, sums, 3)))
		return rc;
	ps->state = WAIT_M;
	return 0;
}

/* An iteration's vector updates on the rows [p0, p1) of the plane from
 * entry o (β unused on the first: it copies), preconditioned with the
 * region's block (m = M⁻¹w is made after), and the next exchange's sums
 * (r·u, w·u, r·r) added in the entries' order: one pass where the updates
 * and each dot product took one each, the same bits (three sums in one
 * loop: three chains of additions side by side). */
static void cg_update(ndo__ps *ps, size_t o, size_t p0, size_t p1, double beta,
                      double alpha, double sums[3])
{
	const size_t q0 = o + p0, q1 = o + p1;
	double *restrict z = ps->z, *restrict q = ps->q, *restrict sv = ps->sv,
	                 *restrict p = ps->p, *restrict x = ps->x, *restrict rr = ps->rr,
	                 *restrict u = ps->u, *restrict w = ps->w, *restrict m = ps->m;
	const double *restrict nv = ps->nv;
	const int first = ps->iter == 1;
	double s0 = sums[0], s1 = sums[1], s2 = sums[2];
	for (size_t k = q0; k < q1; k++) {
		if (first)
			z[k] = nv[k], q[k] = m[k], sv[k] = w[k], p[k] = u[k];
		else {
			z[k] = nv[k] + beta * z[k];
			q[k] = m[k] + beta * q[k];
			sv[k] = w[k] + beta * sv[k];
			p[k] = u[k] + beta * p[k];
		}
		x[k] += alpha * p[k];
		rr[k] -= alpha * sv[k];
		u[k] -= alpha * q[k];
		w[k] -= alpha * z[k];
		s0 += rr[k] * u[k];
		s1 += w[k] * u[k];
		s2 += rr[k] * rr[k];
	}
	sums[0] = s0, sums[1] = s1, sums[2] = s2;
}

/* cg_update with the diagonal as preconditioner: there u = D⁻¹r, q = D⁻¹s
 * and m = D⁻¹w (in exact arithmetic; the recurrences u −= αq, q = m + βq
 * keep them so), so u and q are made from r where they are needed instead
 * of kept as vectors of their own, and m is written, not read: 8 streams
 * read and 7 written an entry, where the general update reads 11 and
 * writes 9.  The sums go in four lanes, entry k of a run in lane k mod 4
 * (a run's rest in lane 0), added at the end as (l0 + l1) + (l2 + l3):
 * not the entries' order, but the same on every peer for a given
 * partition, so every peer still reduces the same bits. */
#define LANES 4
/* Entry e of cg_update_jacobi (first: β = 0 and the directions not read,
 * as they hold nothing yet); T: double, or ndo__v4 for four entries, one
 * a lane (ndo/simd.h: the same bits), with LD and ST its loads and
 * stores. */
#define JACOBI_ENTRY(T, LD, ST, e, A0, A1, A2, first)                              \
	do {                                                                           \
		const T u_ = LD(d + (e)) * LD(rr + (e));                                   \
		const T z_ = (first) ? LD(nv + (e)) : LD(nv + (e)) + beta * LD(z + (e));   \
		const T s_ = (first) ? LD(w + (e)) : LD(w + (e)) + beta * LD(sv + (e));    \
		const T p_ = (first) ? u_ : u_ + beta * LD(p + (e));                       \
		ST(z + (e), z_), ST(sv + (e), s_), ST(p + (e), p_);                        \
		ST(x + (e), LD(x + (e)) + alpha * p_);                                     \
		const T r_ = LD(rr + (e)) - alpha * s_, w_ = LD(w + (e)) - alpha * z_;     \
		const T v_ = LD(d + (e)) * r_;                                             \
		ST(rr + (e), r_), ST(w + (e), w_), ST(m + (e), LD(d + (e)) * w_);          \
		A0 += r_ * v_, A1 += w_ * v_, A2 += r_ * r_;                               \
	} while (0)
static NDO_HOT_O3 void cg_update_jacobi(ndo__ps *ps, size_t o, size_t p0, size_t p1,
                                        const double *nvp, double *mout, double beta,
                                        double alpha, double lanes[3][LANES])
{
	const size_t q0 = o + p0, len = p1 - p0, body = len - len % LANES;
	double *restrict z = ps->z + q0, *restrict sv = ps->sv + q0, *restrict p = ps->p + q0,
	                 *restrict x = ps->x + q0, *restrict rr = ps->rr + q0,
	                 *restrict w = ps->w + q0, *restrict m = mout + q0;
	const double *restrict nv = nvp, *restrict d = ps->dinv + p0;
	ndo__v4 a0 = V4_LD(lanes[0]), a1 = V4_LD(lanes[1]), a2 = V4_LD(lanes[2]);
	double t0 = 0, t1 = 0, t2 = 0; /* the rest, lane 0's */
	if (ps->iter == 1) {
		for (size_t k = 0; k < body; k += LANES)
			JACOBI_ENTRY(ndo__v4, V4_LD, V4_ST, k, a0, a1, a2, 1);
		for (size_t k = body; k < len; k++)
			JACOBI_ENTRY(double, V1_LD, V1_ST, k, t0, t1, t2, 1);
	} else {
		for (size_t k = 0; k < body; k += LANES)
			JACOBI_ENTRY(ndo__v4, V4_LD, V4_ST, k, a0, a1, a2, 0);
		for (size_t k = body; k < len; k++)
			JACOBI_ENTRY(double, V1_LD, V1_ST, k, t0, t1, t2, 0);
	}
	a0[0] += t0, a1[0] += t1, a2[0] += t2;
	V4_ST(lanes[0], a0), V4_ST(lanes[1], a1), V4_ST(lanes[2], a2);
}
#undef JACOBI_ENTRY

/* An iteration with the diagonal: block by block of the region's nodes,
 * n = A m on the block (ndo_sim_implicit_apply_range, into a buffer that
 * stays in the cache) and at once the updates that read it; the new m goes
 * to the other buffer (m2), as the next blocks' products still read this
 * one's neighbours, and the two are swapped at the end.  The sums as
 * cg_update_jacobi's lanes, block by block: the same on every peer for a
 * given partition. */
#define BLOCK 512
static void jacobi_iteration(ndo__ps *ps, double beta, double alpha, double sums[3])
{
	const size_t n = ps->count;
	double lanes[3][LANES] = {{0}}, nvb[3 * BLOCK];
	size_t r0 = 0; /* the first run that ends after the block's start */
	const size_t end = ps->norun ? (size_t)ps->orun[2 * ps->norun - 1] : 0;
	for (size_t lo = ps->norun ? (size_t)ps->orun[0] : 0; lo < end; lo += BLOCK) {
		const size_t hi = lo + BLOCK < end ? lo + BLOCK : end;
		while (r0 < ps->norun && (size_t)ps->orun[2 * r0 + 1] <= lo)
			r0++;
		if (r0 == ps->norun || (size_t)ps->orun[2 * r0] >= hi)
			continue; /* no row of the region in this block */
		ndo_sim_implicit_apply_range(ps->sim, ps->rows, ps->m, nvb, BLOCK, lo, hi);
		for (int c = 0; c < 3; c++)
			for (size_t r = r0; r < ps->norun && (size_t)ps->orun[2 * r] < hi; r++) {
				size_t a = (size_t)ps->orun[2 * r], b = (size_t)ps->orun[2 * r + 1];
				a = a > lo ? a : lo, b = b < hi ? b : hi;
				cg_update_jacobi(ps, (size_t)c * n, a, b, nvb + (size_t)c * BLOCK + (a - lo),
				                 ps->m2, beta, alpha, lanes);
			}
	}
	double *t = ps->m;
	ps->m = ps->m2, ps->m2 = t;
	for (int i = 0; i < 3; i++)
		sums[i] = (lanes[i][0] + lanes[i][1]) + (lanes[i][2] + lanes[i][3]);
}

/* Pipelined preconditioned conjugate gradients (Ghysels and Vanroose,
 * 2014, algorithm 4): one exchange per iteration carries both the vector
 * the next product needs (m = M⁻¹w, on the strip) and the partial sums of
 * the iteration's dot products, where the textbook method needs a halo
 * exchange and two reductions in turn. */
static int implicit_advance(ndo__ps *ps)
{
	const size_t n = ps->count;
	const int32_t *own = ps->r.own;
	const size_t nown = ps->r.nown;
	for (;;) {
		switch (ps->state) {
		case SEND_STATE: {
			int rc = send_state(ps);
			if (rc)
				return rc;
			break;
		}
		case WAIT_STATE: {
			if (!halo_complete(ps))
				return 0;
			halo_state(ps);
			int rc = ndo_sim_implicit_begin(ps->sim, ps->h, own, nown, ps->b, ps->dinv);
			if (!rc)
				rc = ndo_sim_implicit_rows(ps->sim, ps->h, own, nown, &ps->rows);
			if (rc)
				return rc;
			/* x₀ = v on the rows and the halo (the last step's solution) */
			double *v = ps->tmp;
			ndo_sim_get_nodes(ps->sim, nown, own, NULL, NULL, v);
			for (size_t k = 0; k < nown; k++)
				for (int c = 0; c < 3; c++)
					ps->x[(size_t)c * n + (size_t)own[k]] = v[3 * k + c];
			for (size_t k = 0; k < ps->r.nhalo; k++) {
				size_t h = (size_t)ps->r.halo[k];
				for (int c = 0; c < 3; c++)
					ps->x[(size_t)c * n + h] = ps->rval[6 * h + (size_t)c];
			}
			apply(ps, ps->x, ps->w);
			for (size_t k = 0; k < nown; k++)
				for (int c = 0; c < 3; c++) {
					size_t q = (size_t)c * n + (size_t)own[k];
					ps->rr[q] = ps->b[q] - ps->w[q];
				}
			if ((rc = precondition(ps, ps->rr, ps->u)))
				return rc;
			ps->iter = 0;
			ps->st.solves++;
			double sums[2] = {dot(ps, ps->b, ps->b), dot(ps, ps->rr, ps->rr)};
			if ((rc = next_phase(ps, 3, ps->u, sums, 2)))
				return rc;
			ps->state = WAIT_U;
			break;
		}
		case WAIT_U: {
			if (!halo_complete(ps) || !sums_complete(ps))
				return 0;
			ps->bb = total(ps, 0);
			if (!(total(ps, 1) > CG_TOL * CG_TOL * ps->bb))
				return solved(ps); /* x₀ solves it (a body at rest) */
			halo_vector(ps, ps->u);
			apply(ps, ps->u, ps->w);
			int rc = send_m(ps, NULL, 0);
			if (rc)
				return rc;
			break;
		}
		case WAIT_M: {
			if (!halo_complete(ps) || !sums_complete(ps))
				return 0;
			double gam = total(ps, 0), del = total(ps, 1), rr = total(ps, 2);
			if (!(rr > CG_TOL * CG_TOL * ps->bb))
				return solved(ps);
			if (++ps->iter > CG_MAX)
				return ndo__fail(NDO_EDIVERGED, "the distributed solve of step %lld did not "
				                 "converge in %d iterations (residual %.3g of the right-hand "
				                 "side)", (long long)ps->step, CG_MAX, sqrt(rr / ps->bb));
			ps->st.iterations++;
			halo_vector(ps, ps->m);
			double alpha, beta;
			int first = ps->iter == 1;
			if (first) {
				beta = 0;
				alpha = gam / del;
			} else {
				beta = gam / ps->gam;
				alpha = gam / (del - beta * gam / ps->alpha);
			}
			if (!(alpha > 0) || !isfinite(alpha))
				return ndo__fail(NDO_EDIVERGED, "the implicit system is not positive definite "
				                 "(step %lld of the distributed solve: α = %g)",
				                 (long long)ps->step, alpha);
			ps->gam = gam;
			ps->alpha = alpha;
			double sums[3] = {0, 0, 0};
			const int fast = ps->jacobi == 1 && ndo_sim_rows_sorted(ps->rows);
			if (fast)
				jacobi_iteration(ps, beta, alpha, sums);
			else {
				apply(ps, ps->m, ps->nv);
				for (int c = 0; c < 3; c++)
					for (size_t r = 0; r < ps->norun; r++)
						cg_update(ps, (size_t)c * n, (size_t)ps->orun[2 * r],
						          (size_t)ps->orun[2 * r + 1], beta, alpha, sums);
			}
			int rc = send_m(ps, sums, fast);
			if (rc)
				return rc;
			break;
		}
		case WAIT_RIGID: {
			if (!sums_complete(ps))
				return 0;
			double sums[7], gamma;
			ndo_sim_implicit_rigid(ps->sim, ps->h, own, nown, ps->x, sums, &gamma);
			double c = ps->method == NDO_TRAPEZOID ? 0.5 : 1, msum = total(ps, 6);
			for (int a = 0; a < 3; a++) {
				double shift = (total(ps, a) / (1 + c * ps->h * gamma) - total(ps, 3 + a)) / msum;
				for (size_t k = 0; k < nown; k++)
					ps->x[(size_t)a * n + (size_t)own[k]] += shift;
			}
			ndo_sim_implicit_end(ps->sim, ps->h, ps->x);
			ps->state = IDLE;
			return 1;
		}
		default: return ndo__fail(NDO_EINVAL, "peer solve: state %d", ps->state);
		}
	}
}

int ndo__ps_advance(ndo__ps *ps, int64_t step, double h)
{
	ndo__clear_error();
	if (step > NDO_MAX_SOLVE_STEP) /* its phases' keys would overflow */
		return ndo__fail(NDO_ERANGE, "step %lld: a split step's exchanges go to step %lld",
		                 (long long)step, (long long)NDO_MAX_SOLVE_STEP);
	if (ps->step != step || ps->state == IDLE) {
		ps->step = step;
		ps->phase = -1;
		ps->h = h;
		ps->state = SEND_STATE;
		members(ps);
		if (ps->method == NDO_RKF45) {
			ndo_sim_get_nodes(ps->sim, ps->count, ps->all, NULL, ps->snap_u, ps->snap_v);
			ps->snapped = 1;
			int rc = ndo_sim_rkf45_begin(ps->sim, h);
			if (rc)
				return rc;
			/* the last step's last attempt brought this step's halo */
			if (ps->ready == step)
				ps->state = ATTEMPT;
			ps->ready = -1;
		}
	}
	return ps->implicit ? implicit_advance(ps) : rkf45_advance(ps);
}
