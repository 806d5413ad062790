/* peer.c — a simulating peer: session + simulation + time keeping
 * (ndo/peer.h; docs/peers.md). */
#include "ndo/peer.h"
#include "checkpoint.h"
#include "peer_solve.h"
#include "peer_test.h"
#include "rollback.h"
#include "ndo/scene.h"
#include "ndo/status.h"
#include "ndo/tile.h"
#include "ndo/topology.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define RESEND_MAX 0.2      /* s: the longest gap between re-sends */
#define IDLE_WAIT 0.05      /* s: the longest a caller sleeps (protocol timers) */
#define LAST_COPIES 3       /* the owner leaves once its last frame went out this often */
#define LAST_GAPS 16        /* ... and this many first re-send gaps after it gathered */

/* The stashes (tiles, halos) keep messages for later, in two classes:
 * of the partition in force (its members', of a step this peer has not
 * reached, or before it made its region) and of the next partition
 * (anyone's: its members are not known yet, unstash checks them).  Each
 * class holds at most STASH_COUNT messages and stash_budget() bytes —
 * STASH_GRIDS grids' worth of state (6 doubles a node), more than all
 * peers' strips of the steps they can be ahead (reach()) — and keeps what
 * it has: a message that does not fit is dropped (counted stale), and one
 * that was needed comes again, since a peer waiting for this one re-sends.
 * Until 2026-11-30 each stash kept 8192 messages of any partition and step
 * and then dropped the oldest: a stranger's halos of a far partition made
 * each peer of a level-4 run hold 311 MB (a level-7 one could hold 13 GB),
 * and past the count each message cost a 0.9 MB memmove. */
#define STASH_COUNT 2048
#define STASH_GRIDS 4
#define STASH_FLOOR ((size_t)1 << 20) /* bytes: room for a few datagrams at the
                                         smallest levels */
typedef struct stash_use {
	size_t count[2], bytes[2]; /* [0] the partition in force, [1] the next */
	int32_t epoch;             /* ... as of this partition */
} stash_use;

/* A repeated message's timer: the next one not before `at`, the gaps
 * doubling from the first up to RESEND_MAX (gap 0: none sent yet). */
typedef struct backoff {
	double at, gap;
} backoff;

static void backoff_next(backoff *b, double now, double first)
{
	b->gap = b->gap > 0 ? fmin(2 * b->gap, RESEND_MAX) : first;
	b->at = now + b->gap;
}

/* ... from its first gap again */
static void backoff_start(backoff *b, double now, double first)
{
	b->gap = 0;
	backoff_next(b, now, first);
}

struct ndo_peer {
	ndo_peer_opts o;
	ndo_session *s;
	ndo_sim *sim;
	int owner;
	/* the run */
	char *scene;           /* owner: the description text */
	double dt, speed, step_timeout;
	ndo_clock clock;
	int hold;              /* the boundary stands still during a step */
	int peers_needed;
	int owner_went; /* a joiner: a message of the owner's run came, so it has
	                   announced its partition (owner_spoke) */
	int32_t exact_epoch; /* the newest partition of which a member's confirmed
	                        strip came (realtime: its window there began at the
	                        first step, exact; join_point) */
	int64_t first, final;
	/* the object */
	int level;
	size_t count, ncanon;
	int32_t *canon;        /* stored index → canonical index */
	int32_t *canons;       /* the canonical indices */
	int64_t *nstep;        /* per canonical node: the step of the value held,
	                          −1 unknown */
	uint8_t *mask;         /* stored nodes this peer integrates */
	int32_t *halo;         /* canonical nodes next to the region, not in it */
	size_t nhalo, nowned;
	double *hx, *hv, *xs, *vs;
	ndo_grid *prev;        /* position/velocity at prev_step (re-sends) */
	int prev_valid;
	int64_t prev_step;
	double prev_time;
	/* where this peer is */
	int announced, started, simulating, ended, done;
	int end_reason;   /* the session's end (NDO_EV_ENDED): NDO_LEAVE_* */
	int32_t epoch_done;    /* the partition the region was last made for */
	int32_t poi_held;      /* a joiner's POI, asked for once its simulation is
	                          built (joiner_ready), −1: none or asked */
	int wants_share;       /* a joiner with a POI (not an observer) */
	double epoch_t0;       /* ... when (split steps: the others' time to
	                          show up under it, members_alive) */
	int64_t cur;
	double tcur;
	int64_t fill_step, max_seen;
	double fill_time;
	struct { int64_t step; double time; } times[64]; /* a step's time, from tiles */
	double created, wall0;
	int64_t sched0;        /* realtime: the step at wall0 */
	/* waiting and re-sending */
	int blocked;
	double block_t0;
	backoff resend;         /* the halos', a split step's or the last frame's re-sends */
	double gather_t0;
	int last_resends;       /* the last step's frame sent again (finishing) */
	double gathered_at;     /* owner: when the last step was whole here (< 0: not yet) */
	int notes_missed;
	/* exact lock-step: per peer heard from, the partition of its newest
	 * halo, its newest step there, and when (a neighbour still sending is
	 * alive: waiting for it is not waiting for a dead peer) */
	struct { int32_t id, epoch; int64_t step; double at; } heard[NDO_MAX_PEERS];
	/* tiles for later */
	ndo_msg_tile_t *stash;
	size_t nstash, capstash;
	stash_use tuse;
	/* exact lock-step (ndo/peer.h): halos of `W` rings exchanged every `K`
	 * steps as displacement tiles, whole regions every `N` */
	int exact, W, K, N;
	int32_t *own;          /* stored nodes of the region (duplicates too) */
	size_t nown;
	int32_t *ownc;         /* canonical nodes of the region */
	size_t nownc;
	int32_t *orun;         /* ownc as runs of consecutive nodes: start, end pairs */
	size_t norun;
	uint8_t *hmark;        /* per canonical node: in the halo (rings 1..W) */
	uint8_t *act;          /* per stored node: integrated (region and halo) */
	int32_t *dist;         /* BFS scratch */
	int32_t *strip;        /* canonical nodes of the region a neighbour's halo holds */
	size_t nstrip;
	double *hu;            /* per stored node: the halo's received displacement */
	double *sbuf[2];       /* per stored node: (v, u) of the strip at sstep[] */
	int64_t sstep[2];
	double stime[2];
	int32_t sepoch[2];
	int8_t sconf[2];       /* ... and whether it was exact (halo_t.confirmed) */
	int synced;            /* the grid holds the region's state at cur */
	int64_t ahead;         /* the step begun ahead of its halo (ndo_sim_step_begin), −1 */
	ndo_msg_halo_t *hstash; /* halos for later steps or partitions */
	size_t nhstash, caphstash;
	stash_use huse;
	ndo__ps *ps;           /* rkf45 and the implicit methods: steps of several
	                          exchanges (peer_solve.h), when exact */
	double split_t0;       /* ... the last progress of the step waited for */
	int64_t split_phases;  /* ... and the phases sent then */
	ndo__rb *rb;           /* realtime with exact halos: rollback (rollback.h) */
	/* restarts (checkpoint.h): exact lock-step of the fixed-step explicit
	 * methods keeps checkpoints every C steps and goes back to the
	 * partition's restart step when the partition changes during the run */
	int C;
	ndo__ck *ck;
	int inexact;           /* went on with older values since the last
	                          (re)start, here or at another peer (a halo
	                          not confirmed): its checkpoints are not
	                          sent, its halos say so (taint) */
	int64_t inexact_at;    /* ... the first step whose state it holds */
	int32_t inexact_from;  /* ... the peer it began at (0: this one) */
	/* owner: each simulating peer's last word (an empty halo at the last
	 * step: exact or not), of the partition in force */
	int32_t word[NDO_MAX_PEERS];
	int nword;
	int64_t rs_step;       /* a restart waiting for checkpoint nodes, −1: none */
	int64_t rs_from;       /* ... the step this peer was at */
	int64_t ck_skip;       /* the step just restarted from: its checkpoint is held */
	int64_t ck_until;      /* owner: re-sends checkpoint ck_at while waiting at
	                          a step up to this */
	int64_t ck_at;
	int ck_wanted;         /* owner: a peer waiting for checkpoint ck_at's
	                          nodes spoke since it last sent them */
	backoff ck_send;       /* owner: ... and sends them again unasked */
	int64_t ck_last;       /* its newest checkpoint step of this
	                          partition (−1: none) */
	backoff ck_ask;        /* owner, successor: asks for the others' parts of ck_last */
	backoff ck_answer;     /* answers to asks (ck_ask), for ck_answer_step (a
	                          small message must not draw a region's state
	                          at any rate) */
	int64_t ck_answer_step;
	double ck_deaf_until;  /* tests: checkpoints not heard before then */
	int last_sent;         /* ... the last step's frame went out (confirmed,
	                          or after gather_timeout unconfirmed) */
	int failed;
	double now;
	char message[320];
	ndo_peer_stats st;
};

const char *ndo_clock_name(ndo_clock s)
{
	return s == NDO_CLOCK_REALTIME ? "realtime" : "lockstep";
}

int ndo_clock_parse(const char *s)
{
	if (strcmp(s, "lockstep") == 0 || strcmp(s, "lock-step") == 0)
		return NDO_CLOCK_LOCKSTEP;
	if (strcmp(s, "realtime") == 0 || strcmp(s, "real-time") == 0)
		return NDO_CLOCK_REALTIME;
	return -1;
}

static void note(ndo_peer *p, const char *fmt, ...)
{
	if (!p->o.note)
		return;
	char buf[512];
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(buf, sizeof buf, fmt, ap);
	va_end(ap);
	p->o.note(p->o.note_user, buf);
}

static int32_t *owner_channel(ndo_peer *p)
{
	return ndo_grid_find(ndo_session_grid(p->s), NDO_CH_OWNER)->data;
}

/* ---- the object's arrays (once its level is known) --------------------- */
static int arrays(ndo_peer *p)
{
	if (p->canon)
		return 0;
	ndo_grid *g = ndo_session_grid(p->s);
	p->level = g->level;
	p->count = g->count;
	p->canon = malloc(p->count * sizeof *p->canon);
	p->canons = malloc(p->count * sizeof *p->canons);
	p->nstep = malloc(p->count * sizeof *p->nstep);
	p->mask = calloc(p->count, 1);
	p->halo = malloc(p->count * sizeof *p->halo);
	p->hx = malloc(3 * p->count * sizeof *p->hx);
	p->hv = malloc(3 * p->count * sizeof *p->hv);
	p->xs = malloc(3 * p->count * sizeof *p->xs);
	p->vs = malloc(3 * p->count * sizeof *p->vs);
	if (!p->canon || !p->canons || !p->nstep || !p->mask || !p->halo || !p->hx || !p->hv ||
	    !p->xs || !p->vs || ndo_grid_create(p->level, &p->prev) ||
	    ndo_grid_add(p->prev, NDO_CH_VELOCITY, NDO_F64, 3, NULL))
		return ndo__fail(NDO_ENOMEM, "out of memory");
	p->ncanon = 0;
	for (size_t k = 0; k < p->count; k++) {
		int i = (int)(k % (size_t)g->w), j = (int)(k / (size_t)g->w);
		p->canon[k] = (int32_t)ndo_canonical(p->level, i, j);
		if ((size_t)p->canon[k] == k)
			p->canons[p->ncanon++] = (int32_t)k;
		p->nstep[k] = -1;
	}
	return 0;
}

static void taint(ndo_peer *p, int64_t step, int32_t from);

/* A step after the run's last (known once the simulation is made: the
 * owner's, a joiner's from the owner's description): no peer sends one,
 * and taken it would stand for where the others are (max_seen: a
 * realtime peer would run to catch up, an observer would count the last
 * step held) and keep every later value of its nodes out (nstep). */
static int beyond_final(const ndo_peer *p, int64_t step)
{
	return p->sim && step > p->final;
}

/* ---- tiles in ------------------------------------------------------------ */
/* A halo's values into the grid: the halo nodes its sender owns, when
 * newer.  Returns the nodes taken. */
static size_t halo_into_grid(ndo_peer *p, const ndo_msg_halo_t *h)
{
	ndo_grid *g = ndo_session_grid(p->s);
	double *x = ndo_grid_f64(g, NDO_CH_POSITION, 3), *v = ndo_grid_f64(g, NDO_CH_VELOCITY, 3);
	const double *rest = ndo_grid_f64(g, NDO_CH_REST, 3);
	const int32_t *own = owner_channel(p);
	const int32_t from = h->hdr.sender_id;
	size_t k = 0, taken = 0;
	for (int r = 0; r < h->nruns; r++)
		for (int32_t q = 0; q < h->len[r]; q++, k += 6) {
			size_t c = (size_t)h->start[r] + (size_t)q;
			if ((size_t)p->canon[c] != c || own[c] != from || !p->hmark[c] ||
			    h->step < p->nstep[c])
				continue;
			taken++;
			const double *val = &h->values[k];
			long dup = ndo_duplicate_of(p->level, c); /* the grid's copy of it */
			for (int d = 0; d < 3; d++) {
				v[3 * c + d] = val[d];
				p->hu[3 * c + d] = val[3 + d];
				x[3 * c + d] = rest[3 * c + d] + val[3 + d];
				if (dup >= 0)
					v[3 * dup + d] = v[3 * c + d], x[3 * dup + d] = x[3 * c + d];
			}
			p->nstep[c] = h->step;
		}
	return taken;
}

/* A halo (ndo_msg_halo_t) of exact lock-step: into the halo nodes the
 * sender owns, when newer. */
static void write_halo(ndo_peer *p, const ndo_msg_halo_t *h)
{
	if (beyond_final(p, h->step))
		return;
	if (!h->confirmed)
		taint(p, h->step, h->hdr.sender_id);
	if (h->nruns == 0) { /* a taint or a last word: no values */
		if (p->owner && p->exact && !p->rb && h->step >= p->final) {
			int k = 0;
			while (k < p->nword && p->word[k] != h->hdr.sender_id)
				k++;
			if (k == p->nword && k < NDO_MAX_PEERS)
				p->word[p->nword++] = h->hdr.sender_id;
		}
		return;
	}
	if (!p->exact || !p->hmark)
		return;
	/* rollback keeps its halos itself; the grid's halo nodes come from
	 * whole regions, which the owner gathers (a halo may be tentative, and
	 * rest + u is not the position bit for bit).  One it does not keep
	 * (outside its window) says nothing of where the others are: until
	 * 2026-11-30 it moved max_seen all the same, and a member's halo of
	 * step 10^12 had realtime() "catch up" at every update, 1,450 steps
	 * in 1.5 s against a pace of 750 */
	size_t taken = p->rb ? (size_t)ndo__rb_receive(p->rb, h, p->now) : halo_into_grid(p, h);
	if (!taken)
		return;
	if (h->step > p->max_seen)
		p->max_seen = h->step;
	p->times[h->step & 63].step = h->step;
	p->times[h->step & 63].time = h->time;
}

/* A tile's values into the nodes `take` accepts (fill: of the owner's
 * snapshot). */
static void write_tile(ndo_peer *p, const ndo_msg_tile_t *t, int fill)
{
	if (!fill && beyond_final(p, t->step))
		return;
	ndo_grid *g = ndo_session_grid(p->s);
	double *x = ndo_grid_f64(g, NDO_CH_POSITION, 3), *v = ndo_grid_f64(g, NDO_CH_VELOCITY, 3);
	const int32_t *own = owner_channel(p);
	const int32_t from = t->hdr.sender_id;
	const int hasx = t->channels & NDO_TILE_POSITION, hasv = t->channels & NDO_TILE_VELOCITY;
	const int partitioned = ndo_session_cells(p->s, NULL, NULL) != NULL;
	size_t k = 0, taken = 0;
	for (int j = t->j0; j <= t->j1; j++)
		for (int i = t->i0; i <= t->i1; i++) {
			size_t node = ndo_node(g->w, i, j), c = (size_t)p->canon[node];
			int mine = own[c] == from && (partitioned || !fill);
			/* the sender's own nodes when newer; a snapshot fills what is
			 * not known otherwise (its other values are the owner's view:
			 * of no known step) */
			int take = mine ? t->step >= p->nstep[c] : fill && p->nstep[c] < 0;
			/* exact lock-step: the halo takes displacements (write_halo),
			 * positions only for the last step (the owner's gather) */
			if (take && mine && p->exact && p->hmark && p->hmark[c] && t->step < p->final)
				take = 0;
			/* a decoded tile's NaN: a node it does not carry (ndo/codec.h) */
			if (hasx && isnan(t->values[k]))
				take = 0;
			if (take) {
				if (hasx)
					memcpy(x + 3 * node, &t->values[k], 3 * sizeof *x);
				if (hasv && !isnan(t->values[k + (hasx ? 3 : 0)]))
					memcpy(v + 3 * node, &t->values[k + (hasx ? 3 : 0)], 3 * sizeof *v);
				if (mine && node == c) {
					p->nstep[c] = t->step;
					taken++;
				}
			}
			k += (size_t)(hasx ? 3 : 0) + (hasv ? 3 : 0);
		}
	if (!taken) /* nothing of its sender's: says nothing about the run */
		return;
	if (t->step > p->max_seen)
		p->max_seen = t->step;
	p->times[t->step & 63].step = t->step;
	p->times[t->step & 63].time = t->time;
}

/* How far ahead of this peer another peer of its partition can be: a
 * neighbour one exchange (K steps: it waits for this peer's halo), any
 * peer of a chain of NDO_MAX_PEERS one exchange each, and one more (the
 * owner's re-sends of a restart's checkpoint use the same reach). */
static int64_t reach(const ndo_peer *p)
{
	return (int64_t)p->K * (NDO_MAX_PEERS + 1);
}

/* The step this peer is at, or goes back to (a restart waiting for its
 * checkpoint). */
static int64_t base_step(const ndo_peer *p)
{
	return p->rs_step > p->cur ? p->rs_step : p->cur;
}

/* Is `step` of partition `epoch` one no peer sends: after the run's last,
 * or further ahead of this peer, running in that partition, than a peer of
 * it can be? */
static int too_far(const ndo_peer *p, int32_t epoch, int64_t step)
{
	return beyond_final(p, step) || (epoch == ndo_session_epoch(p->s) && p->announced &&
	                                 p->simulating && step > base_step(p) + reach(p));
}

/* Bytes a stashed message holds: its arrays and its copy's bookkeeping. */
static size_t stash_size(size_t structure, int64_t ints, int64_t doubles)
{
	return structure + 64 + 4 * (size_t)ints + 8 * (size_t)doubles;
}

static size_t stash_budget(const ndo_peer *p)
{
	return STASH_GRIDS * 6 * sizeof(double) * p->count + STASH_FLOOR;
}

/* May a message of partition `epoch` at `step`, of `size` bytes, wait in
 * the stash whose use is *u?  Not one of a partition after the next (this
 * peer missed one: it installs the newest, re-sent every heartbeat, and
 * the neighbours re-send meanwhile), nor one of a step further ahead than
 * a peer of this partition can be, nor one its class has no room for. */
static void stash_prune(ndo_peer *p);

static int stash_admit(ndo_peer *p, stash_use *u, int32_t epoch, int64_t step, size_t size)
{
	int32_t now = ndo_session_epoch(p->s);
	int next = epoch > now;
	if (u->epoch != now)
		stash_prune(p); /* a new partition: what the old ones left goes */
	if (epoch > now + 1 || too_far(p, epoch, step) || u->count[next] >= STASH_COUNT ||
	    u->bytes[next] + size > stash_budget(p)) {
		p->st.stale++;
		return 0;
	}
	u->count[next]++;
	u->bytes[next] += size;
	return 1;
}

static size_t tile_size(const ndo_msg_tile_t *t)
{
	return stash_size(sizeof *t, 0, t->nvalues);
}

static int stash_tile(ndo_peer *p, const ndo_msg_tile_t *t)
{
	if (!stash_admit(p, &p->tuse, t->epoch, t->step, tile_size(t)))
		return 0;
	if (p->nstash == p->capstash) {
		size_t cap = p->capstash ? 2 * p->capstash : 64;
		ndo_msg_tile_t *q = realloc(p->stash, cap * sizeof *q);
		if (!q)
			return NDO_ENOMEM;
		p->stash = q;
		p->capstash = cap;
	}
	if (ndo_tile_copy(t, &p->stash[p->nstash]))
		return NDO_ENOMEM;
	p->nstash++;
	p->st.stashed++;
	return 0;
}

/* Is tile t for later: of a partition this peer has not installed yet, or
 * (lock-step, running) of a step it has not reached? */
static int later(const ndo_peer *p, const ndo_msg_tile_t *t)
{
	if (t->epoch > ndo_session_epoch(p->s))
		return 1;
	return p->clock == NDO_CLOCK_LOCKSTEP && p->announced && p->simulating && t->step > p->cur;
}

/* Is `id` one of the peers of the partition in force? */
static int member(const ndo_peer *p, int32_t id)
{
	int n = 0;
	const int32_t *ids;
	if (!ndo_session_cells(p->s, &n, &ids))
		return 0;
	for (int k = 0; k < n; k++)
		if (ids[k] == id)
			return 1;
	return 0;
}

/* Is a message of partition `epoch` from `id` no use here: of an older
 * partition than the one in force, or of that one from a peer outside it?
 * (A message of a later partition is kept for it whoever sent it, and
 * checked again when that partition is in force, unstash: until 2026-11-30 a stranger's
 * empty halo of the next partition, taken then, tainted the run and
 * stopped its checkpoints, and strangers' last words took the places of
 * the peers'.) */
static int outside(const ndo_peer *p, int32_t epoch, int32_t id)
{
	int32_t now = ndo_session_epoch(p->s);
	return epoch < now || (epoch == now && !member(p, id));
}

/* The session's tile_fn: every position/velocity tile of another peer. */
static void on_tile(void *user, const ndo_msg_tile_t *t, int flags)
{
	ndo_peer *p = user;
	int fill = (flags & NDO_TILE_FN_FILL) != 0;
	int rc = arrays(p);
	if (rc) {
		p->failed = rc;
		return;
	}
	if (fill) {
		write_tile(p, t, 1);
		if (t->step >= p->fill_step) {
			p->fill_step = t->step;
			p->fill_time = t->time;
		}
		return;
	}
	if (outside(p, t->epoch, t->hdr.sender_id)) {
		p->st.stale++; /* an old partition's, or from a peer outside this one */
		return;
	}
	if (later(p, t)) {
		if ((rc = stash_tile(p, t)))
			p->failed = rc;
		return;
	}
	write_tile(p, t, 0);
}

static int halo_later(const ndo_peer *p, const ndo_msg_halo_t *h)
{
	if (h->epoch > ndo_session_epoch(p->s))
		return 1;
	/* the region of the partition in force is not made yet (the session
	 * installed it in this very update, or this peer has not announced):
	 * which nodes are its halo is not known — the last region's marks
	 * took a neighbour's step 1 into a node of the new halo at step 0 */
	if (p->epoch_done != ndo_session_epoch(p->s))
		return 1;
	/* rollback keeps the halos of later steps itself */
	return !p->rb && p->announced && p->simulating && h->step > p->cur;
}

static void halo_free(ndo_msg_halo_t *h)
{
	free(h->start), free(h->len), free(h->values);
}

static size_t halo_size(const ndo_msg_halo_t *h)
{
	return stash_size(sizeof *h, 2 * (int64_t)h->nruns, h->nvalues);
}

static void on_checkpoint(ndo_peer *p, const ndo_msg_halo_t *h);

/* How long a neighbour may be silent and still count as alive: the
 * session's peer timeout (after it the owner drops a silent peer, and a new
 * partition restarts the run), at least the step timeout.  Not the step
 * timeout alone: a neighbour waiting itself re-sends at most every
 * RESEND_MAX (0.2 s), so under loss a few re-sends lost in a row would
 * time out a live peer (10 % loss, level 4, 16000 steps: 1 run in 4). */
static double silence(const ndo_peer *p)
{
	double t = p->o.session.timeout > 0 ? p->o.session.timeout : 2.0;
	return fmax(t, p->step_timeout);
}

/* Note a halo or a split step's phase (of any partition) from another
 * peer `id`: its partition, its newest step in that partition and when it
 * came.  Only a peer of the partition in force counts (those are the ones
 * asked about: strangers took the NDO_MAX_PEERS places), and only a step
 * one can be at (too_far: until 2026-11-30 a member's id on one halo of a
 * far step made that member look dead to alive_at_cur for good). */
static void heard(ndo_peer *p, int32_t id, int32_t epoch, int64_t step)
{
	if (!member(p, id) || too_far(p, epoch, step))
		return;
	int k, free_k = -1;
	for (k = 0; k < NDO_MAX_PEERS; k++) {
		if (p->heard[k].id == id)
			break;
		if (free_k < 0 && (p->heard[k].id == 0 || p->now - p->heard[k].at > silence(p)))
			free_k = k;
	}
	if (k == NDO_MAX_PEERS) {
		if (free_k < 0)
			return;
		k = free_k;
		p->heard[k].id = id;
		p->heard[k].epoch = -1;
	}
	if (epoch < p->heard[k].epoch)
		return;
	if (epoch > p->heard[k].epoch || step > p->heard[k].step)
		p->heard[k].step = step;
	p->heard[k].epoch = epoch;
	p->heard[k].at = p->now;
}

/* Is neighbour `id` alive and able to send step cur still: a halo came
 * from it within silence(p), either of an older partition (it has
 * not installed this one yet, and will go back to its restart step) or of
 * this one at most one exchange ahead (its two re-sent strips hold cur)? */
static int alive_at_cur(const ndo_peer *p, int32_t id)
{
	int32_t epoch = ndo_session_epoch(p->s);
	for (int k = 0; k < NDO_MAX_PEERS; k++)
		if (p->heard[k].id == id)
			return p->now - p->heard[k].at < silence(p) &&
			       (p->heard[k].epoch < epoch || (p->heard[k].step <= p->cur + p->K &&
			                                       p->heard[k].step >= p->cur - p->K));
	return 0;
}

/* The net's tile filter: the others' whole-region tiles that a simulating
 * peer in exact lock-step does not use, passed over undecoded.  Its region
 * and halo come from its own steps, the halos and the checkpoints; of the
 * others' nodes it keeps only their last step (the owner's gather, a
 * joiner's -o).  So every tile before the run starts (the snapshot), the
 * rest and pin channels, and the last step's, are taken; the frames between
 * are not (unless the caller reads them: keep_tiles). */
static int tile_wanted(void *user, int32_t sender, int64_t step, int channels)
{
	const ndo_peer *p = user;
	const int motion = NDO_TILE_POSITION | NDO_TILE_VELOCITY | NDO_TILE_COARSE;
	(void)sender;
	return !p->started || !p->exact || p->rb || !p->sim || (channels & ~motion) ||
	       step >= p->final;
}

/* A joiner: a halo, checkpoint or part of a split step from the owner, of
 * a partition this peer holds or an older one, says the owner has
 * announced (one of a newer partition says nothing of the partition the
 * owner announced with). */
static void owner_spoke(ndo_peer *p, int32_t sender, int32_t epoch)
{
	if (sender == ndo_session_owner_id(p->s) && epoch <= ndo_session_epoch(p->s))
		p->owner_went = 1;
}

/* The session's halo_fn: another peer's halo (or checkpoint). */
static void on_halo(void *user, const ndo_msg_halo_t *h)
{
	ndo_peer *p = user;
	if (arrays(p)) {
		p->failed = NDO_ENOMEM;
		return;
	}
	owner_spoke(p, h->hdr.sender_id, h->epoch);
	if (h->checkpoint) {
		if (p->now >= p->ck_deaf_until)
			on_checkpoint(p, h);
		return;
	}
	heard(p, h->hdr.sender_id, h->epoch, h->step);
	if (h->nruns == 0 && h->confirmed && h->step < p->final) {
		/* a keepalive (restart_wait): heard; at the restart step, it
		 * may still lack some of its checkpoint nodes (of this partition,
		 * or of an older one whose successor it has not yet heard of) */
		if (p->owner && h->step == p->ck_at && h->epoch <= ndo_session_epoch(p->s))
			p->ck_wanted = 1;
		return;
	}
	if (outside(p, h->epoch, h->hdr.sender_id)) {
		p->st.stale++;
		return;
	}
	if (h->confirmed && h->nruns > 0 && h->epoch == ndo_session_epoch(p->s))
		p->exact_epoch = h->epoch;
	if (!halo_later(p, h)) {
		write_halo(p, h);
		return;
	}
	if (!stash_admit(p, &p->huse, h->epoch, h->step, halo_size(h)))
		return;
	if (p->nhstash == p->caphstash) {
		size_t cap = p->caphstash ? 2 * p->caphstash : 16;
		ndo_msg_halo_t *q = realloc(p->hstash, cap * sizeof *q);
		if (!q) {
			p->failed = NDO_ENOMEM;
			return;
		}
		p->hstash = q;
		p->caphstash = cap;
	}
	ndo_msg_halo_t *c = &p->hstash[p->nhstash];
	*c = *h;
	size_t nr = (size_t)(h->nruns > 0 ? h->nruns : 1), nv = (size_t)(h->nvalues > 0 ? h->nvalues : 1);
	c->start = malloc(nr * sizeof *c->start);
	c->len = malloc(nr * sizeof *c->len);
	c->values = malloc(nv * sizeof *c->values);
	if (!c->start || !c->len || !c->values) {
		halo_free(c);
		p->failed = NDO_ENOMEM;
		return;
	}
	if (h->nruns > 0) { /* an empty halo (a taint, a last word) holds none */
		memcpy(c->start, h->start, (size_t)h->nruns * sizeof *c->start);
		memcpy(c->len, h->len, (size_t)h->nruns * sizeof *c->len);
		memcpy(c->values, h->values, (size_t)h->nvalues * sizeof *c->values);
	}
	p->nhstash++;
	p->st.stashed++;
}

/* A message kept in a stash: its class's use, as of the partition now in
 * force. */
static void stash_count(const ndo_peer *p, stash_use *u, int32_t epoch, size_t size)
{
	int next = epoch > ndo_session_epoch(p->s);
	u->count[next]++;
	u->bytes[next] += size;
}

/* The stashes as of the partition in force: what is of an older
 * partition, or of the one in force from a peer outside it, dropped; with
 * `use`, what is for now taken (written); the rest counted by class (a
 * joiner installs partitions before it has made its region, and the old
 * one's halos would fill the class of the new one's). */
static void stash_sweep(ndo_peer *p, int use)
{
	size_t keep = 0;
	int wrote = 0;
	p->tuse = p->huse = (stash_use){.epoch = ndo_session_epoch(p->s)};
	for (size_t k = 0; k < p->nstash; k++) {
		ndo_msg_tile_t *t = &p->stash[k];
		if (outside(p, t->epoch, t->hdr.sender_id)) {
			p->st.stale++;
			free(t->values);
		} else if (use && !later(p, t)) {
			write_tile(p, t, 0);
			free(t->values);
			wrote = 1;
		} else {
			stash_count(p, &p->tuse, t->epoch, tile_size(t));
			p->stash[keep++] = *t;
		}
	}
	p->nstash = keep;
	keep = 0;
	for (size_t k = 0; k < p->nhstash; k++) {
		ndo_msg_halo_t *h = &p->hstash[k];
		if (outside(p, h->epoch, h->hdr.sender_id)) {
			p->st.stale++;
			halo_free(h);
		} else if (use && !halo_later(p, h)) {
			write_halo(p, h); /* its nodes' duplicates too */
			halo_free(h);
		} else {
			stash_count(p, &p->huse, h->epoch, halo_size(h));
			p->hstash[keep++] = *h;
		}
	}
	p->nhstash = keep;
	if (wrote)
		ndo_grid_sync(ndo_session_grid(p->s));
}

static void stash_prune(ndo_peer *p) { stash_sweep(p, 0); }

/* Use what the stash holds for now; drop what is too old. */
static void unstash(ndo_peer *p) { stash_sweep(p, 1); }

/* The session's solve_fn: another peer's part of a split step. */
static void on_solve(void *user, const ndo_msg_solve_t *m)
{
	ndo_peer *p = user;
	heard(p, m->hdr.sender_id, m->epoch, m->step);
	owner_spoke(p, m->hdr.sender_id, m->epoch);
	if (p->ps && (m->epoch > ndo_session_epoch(p->s) || member(p, m->hdr.sender_id)))
		ndo__ps_receive(p->ps, m);
}

/* ---- exact lock-step: halos ---------------------------------------------- */
int ndo_peer_halo_rings(ndo_method m)
{
	switch (m) {
	case NDO_EULER:
	case NDO_SYMPLECTIC_EULER:
	case NDO_MIDPOINT: return 1;
	case NDO_RK4: return 2;
	case NDO_RKF45: return 3; /* a sub-step's: its steps are split (peer_solve.h) */
	default: return 0; /* the implicit methods reach everywhere */
	}
}

/* Rings (through the ghost map) from the canonical nodes with from[c]
 * set, up to `max`: dist[c] = 0 on them, 1..max around, −1 further. */
static void rings(ndo_peer *p, const uint8_t *from, int max)
{
	ndo_grid *g = ndo_session_grid(p->s);
	int32_t *q = (int32_t *)p->xs; /* scratch: count ints fit 3·count doubles */
	size_t head = 0, tail = 0;
	for (size_t k = 0; k < p->count; k++)
		p->dist[k] = -1;
	for (size_t k = 0; k < p->ncanon; k++)
		if (from[p->canons[k]]) {
			p->dist[p->canons[k]] = 0;
			q[tail++] = p->canons[k];
		}
	while (head < tail) {
		size_t c = (size_t)q[head++];
		if (p->dist[c] >= max)
			continue;
		size_t nb[6];
		ndo_neighbors(p->level, (int)(c % (size_t)g->w), (int)(c / (size_t)g->w), nb);
		for (int d = 0; d < 6; d++) {
			size_t h = (size_t)p->canon[nb[d]];
			if (p->dist[h] < 0) {
				p->dist[h] = p->dist[c] + 1;
				q[tail++] = (int32_t)h;
			}
		}
	}
}

/* The exact region's sets: the halo (rings 1..W of the region: received
 * every K steps and integrated along, the overlap both sides compute), the
 * integrated set, and the strip (the region's nodes within W rings of
 * another peer's region: what the neighbours' halos hold). */
static int exact_region(ndo_peer *p)
{
	const int32_t *own = owner_channel(p);
	int32_t self = ndo_session_self(p->s);
	if (!p->hmark) {
		p->own = malloc(p->count * sizeof *p->own);
		p->ownc = malloc(p->count * sizeof *p->ownc);
		p->orun = malloc(2 * p->count * sizeof *p->orun);
		p->hmark = calloc(p->count, 1);
		p->act = calloc(p->count, 1);
		p->dist = malloc(p->count * sizeof *p->dist);
		p->strip = malloc(p->count * sizeof *p->strip);
		p->hu = calloc(3 * p->count, sizeof *p->hu);
		p->sbuf[0] = calloc(6 * p->count, sizeof(double));
		p->sbuf[1] = calloc(6 * p->count, sizeof(double));
		if (!p->own || !p->ownc || !p->orun || !p->hmark || !p->act || !p->dist || !p->strip ||
		    !p->hu || !p->sbuf[0] || !p->sbuf[1])
			return ndo__fail(NDO_ENOMEM, "out of memory");
		p->sstep[0] = p->sstep[1] = -1;
	}
	uint8_t *from = calloc(p->count, 1);
	if (!from)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	/* the halo and the integrated set */
	for (size_t k = 0; k < p->ncanon; k++)
		from[p->canons[k]] = p->mask[p->canons[k]];
	rings(p, from, p->W);
	p->nhalo = p->nown = 0;
	size_t nownc = 0; /* p->nownc below */
	for (size_t k = 0; k < p->count; k++) {
		int32_t dk = p->dist[p->canon[k]];
		p->act[k] = dk >= 0 && dk < p->W;
		if (p->mask[k])
			p->own[p->nown++] = (int32_t)k;
		if ((size_t)p->canon[k] != k)
			continue;
		p->hmark[k] = dk > 0;
		if (dk > 0)
			p->halo[p->nhalo++] = (int32_t)k;
		if (dk == 0)
			p->ownc[nownc++] = (int32_t)k;
	}
	p->nownc = nownc;
	/* its runs: a band's rows are runs of hundreds (its seams' duplicates
	 * are not canonical and break them), so marking the region's step
	 * each step is a few fills, not a scattered store a node */
	p->norun = 0;
	for (size_t k = 0; k < nownc; k++) {
		if (p->norun && p->orun[2 * p->norun - 1] == p->ownc[k])
			p->orun[2 * p->norun - 1]++;
		else {
			p->orun[2 * p->norun] = p->ownc[k];
			p->orun[2 * p->norun + 1] = p->ownc[k] + 1;
			p->norun++;
		}
	}
	/* the strip: rings around the others' regions */
	for (size_t k = 0; k < p->ncanon; k++)
		from[p->canons[k]] = own[p->canons[k]] != self;
	rings(p, from, p->W);
	p->nstrip = 0;
	for (size_t k = 0; k < nownc; k++)
		if (p->dist[p->ownc[k]] >= 0)
			p->strip[p->nstrip++] = p->ownc[k];
	free(from);
	p->sstep[0] = p->sstep[1] = -1; /* a new strip: the old snapshots are not its */
	return 0;
}

/* The grid's region at cur, from the simulation (the steps between
 * whole-region publications leave it behind). */
static void sync_own(ndo_peer *p)
{
	if (!p->exact || p->synced || !p->sim || !p->nown)
		return;
	ndo_grid *g = ndo_session_grid(p->s);
	ndo_sim_get_nodes_at(p->sim, p->nown, p->own, ndo_grid_f64(g, NDO_CH_POSITION, 3),
	                     ndo_grid_f64(g, NDO_CH_VELOCITY, 3));
	p->synced = 1;
}

/* Snapshot the strip at cur into slot b. */
static void strip_snapshot(ndo_peer *p, int b)
{
	ndo_sim_get_nodes(p->sim, p->nstrip, p->strip, NULL, p->xs, p->vs);
	double *sb = p->sbuf[b];
	for (size_t k = 0; k < p->nstrip; k++) {
		size_t c = (size_t)p->strip[k];
		memcpy(sb + 6 * c, p->vs + 3 * k, 3 * sizeof *sb);
		memcpy(sb + 6 * c + 3, p->xs + 3 * k, 3 * sizeof *sb);
	}
	p->sstep[b] = p->cur;
	p->sconf[b] = (int8_t)!p->inexact;
	p->stime[b] = p->tcur;
	p->sepoch[b] = ndo_session_epoch(p->s);
}

/* Send the strip of slot b as halo messages: runs of consecutive node
 * indices, as many per datagram as fit. */
static int strip_send(ndo_peer *p, int b)
{
	if (p->sstep[b] < 0 || p->sepoch[b] != ndo_session_epoch(p->s) || !p->nstrip)
		return 0;
	const ndo_net_stats *ns = ndo_net_stats_get(ndo_session_net(p->s));
	uint64_t b0 = ns->bytes_out;
	ndo_msg_halo_t h;
	memset(&h, 0, sizeof h);
	h.step = p->sstep[b];
	h.confirmed = p->sconf[b]; /* every input the true one: not after a taint */
	h.time = p->stime[b];
	int rc = ndo_session_send_nodes(p->s, &h, p->nstrip, p->strip, p->sbuf[b], NULL, NULL,
	                                (int32_t *)p->hx, (int32_t *)p->hv, p->xs);
	if (rc < 0)
		return rc;
	p->st.halo_tiles += rc;
	p->st.halo_bytes += ns->bytes_out - b0;
	return 0;
}

/* Exact lock-step: the state from `step` on is no longer the single
 * process's — a step taken with the halo's older values (a step timeout),
 * a region taken over from frames (a new partition without a restart),
 * or either at peer `from`, whose halo said so.  Until a restart this
 * peer's halos say so too (so the taint reaches every peer: multicast),
 * it sends no checkpoints, and the owner reports the result as not exact
 * (ndo_peer_stats.inexact_at). */
static void taint(ndo_peer *p, int64_t step, int32_t from)
{
	if (p->inexact || !p->exact || p->rb)
		return;
	p->inexact = 1;
	p->inexact_at = step;
	p->inexact_from = from;
}

/* An empty halo: the taint on its own (not confirmed) where no strip
 * carries it — the split steps, whose phases have no such flag — and at
 * the last step every simulating peer's last word, exact or not, which the
 * owner waits for with the last step's tiles (so its verdict covers a
 * taint of the last step itself). */
/* An empty halo of the partition in force at `step`, confirmed or not (a
 * taint, a last word, restart_wait's sign of life). */
static int empty_halo_send(ndo_peer *p, int64_t step, double time, int confirmed)
{
	ndo_msg_halo_t h;
	memset(&h, 0, sizeof h);
	h.step = step;
	h.time = time;
	h.confirmed = (int8_t)confirmed;
	int rc = ndo_session_send_halo(p->s, &h);
	return rc < 0 ? rc : 0;
}

static int verdict_send(ndo_peer *p)
{
	const int last = p->cur >= p->final;
	if (!p->exact || p->rb || !p->simulating || (last ? p->owner : !p->inexact))
		return 0;
	return empty_halo_send(p, p->cur, p->tcur, !p->inexact);
}

/* Whole-region tiles at cur (frames, the first and last steps). */
static int frame_send(ndo_peer *p)
{
	sync_own(p);
	const ndo_net_stats *ns = ndo_net_stats_get(ndo_session_net(p->s));
	uint64_t b0 = ns->bytes_out;
	int rc = ndo_session_publish(p->s, p->cur, p->tcur);
	p->st.frame_bytes += ns->bytes_out - b0;
	p->st.frames++;
	return rc < 0 ? rc : 0;
}

/* ---- checkpoints and restarts (checkpoint.h) ------------------------------ */
/* Exact lock-step: a new partition during the run restarts every peer
 * from a checkpoint, and the run stays exact — every method: the state
 * (u, v), the time and rkf45's next sub-step size are all a step reads.
 * (Realtime rolls back instead.) */
static int restartable(const ndo_peer *p)
{
	return p->exact && !p->rb && p->clock == NDO_CLOCK_LOCKSTEP && p->sim && p->C > 0;
}

int ndo_peer_checkpoint_default(int level)
{
	int shift = level < 4 ? 0 : level > 7 ? 3 : level - 4;
	return 20 << shift;
}

static int ck_ready(ndo_peer *p)
{
	if (!p->ck && ndo__ck_create(p->level, &p->ck))
		return ndo__fail(NDO_ENOMEM, "out of memory");
	return 0;
}

/* The owner: its next partitions restart from the newest step it holds
 * whole (from its announcement of the first: the run's first step).  A
 * joiner keeps every simulating peer's checkpoints too, and names the
 * step the same way: the partitions it makes if it succeeds the owner
 * (ndo_session_set_succession).  Called after every change of the store:
 * the step named must be the one the store keeps from eviction (the
 * newest whole).  Until 2026-11-30 a joiner named it only when a message
 * came, not when its own part made a step whole: the owner's part of
 * step s came first (it was whole only later), the owner's next parts
 * were lost, the store evicted the step still named to keep s, and a
 * successor that had to restart after the owner's last step went back to
 * a step nobody held (restart_begin drops the newer ones) and waited for
 * it for ever (test_peer, split_restarts_keep_the_single_process: seed 10,
 * the owner's leaves lost). */
static void ck_whole(ndo_peer *p)
{
	if (p->ck && p->announced && restartable(p))
		ndo_session_set_restart(p->s, ndo__ck_whole(p->ck));
}

/* Keep n canonical nodes' state at cur, from the simulation. */
static void ck_take(ndo_peer *p, size_t n, const int32_t *nodes)
{
	ndo_sim_get_nodes(p->sim, n, nodes, NULL, p->xs, p->vs);
	ndo__ck_put(p->ck, p->cur, p->tcur, ndo_sim_rkf45_substep(p->sim), n, nodes, p->xs, p->vs);
}

static int npeers(const ndo_peer *p);

/* A checkpoint step: the region's state kept, and sent to the others
 * (the owner's too when another peer simulates: a successor's). */
static int checkpoint(ndo_peer *p)
{
	int rc = ck_ready(p);
	if (rc)
		return rc;
	ck_take(p, p->nownc, p->ownc);
	p->st.checkpoints++;
	ck_whole(p);
	p->ck_last = p->cur;
	p->ck_ask = (backoff){0, 0};
	/* the owner's own part goes out too: a successor restarts from it */
	if (p->owner && npeers(p) < 2)
		return 0;
	return ndo__ck_send(p->ck, p->s, p->cur, p->nownc, p->ownc, &p->st.checkpoint_bytes);
}

/* The owner sends checkpoint ck_at whole (a restart's, for the peers that
 * lack some of it). */
static int ck_resend(ndo_peer *p)
{
	return ndo__ck_send(p->ck, p->s, p->ck_at, p->ncanon, p->canons, &p->st.checkpoint_bytes);
}

/* A checkpoint message: every simulating peer keeps every member's (the
 * owner to restart from; a joiner to restart from if it succeeds the
 * owner, and its region's part of a restart step), and a joiner the
 * owner's re-sends; messages of an older partition are not used (their
 * steps after its restart step may have been computed with older values).
 * A member's part is of the partition in force (one of the next is not
 * known to be its member's: its owner asks again, ck_ask) and only the
 * nodes of its region are kept (the owner's re-sends: any); and no part
 * of a step further ahead than a peer of the partition can be (reach()).
 * Until 2026-11-30 a member's id on a checkpoint of any nodes 20 steps
 * ahead, its duplicates counted, made the owner's restart step one that
 * nobody held (checkpoint.c put_one), and the peers waited for ever. */
static void on_checkpoint(ndo_peer *p, const ndo_msg_halo_t *h)
{
	int32_t from = h->hdr.sender_id, epoch = ndo_session_epoch(p->s);
	int from_owner = !p->owner && from == ndo_session_owner_id(p->s);
	if (h->epoch < epoch || !p->sim || !(from_owner || (member(p, from) && h->epoch == epoch)) ||
	    (p->simulating && h->step > base_step(p) + reach(p))) {
		p->st.stale++;
		return;
	}
	if (ck_ready(p)) {
		p->failed = NDO_ENOMEM;
		return;
	}
	if (h->nruns == 0 && !h->confirmed) {
		/* the owner or its successor lacks part of checkpoint h->step (a
		 * message lost): this peer's part again, if it holds it (ck_ask) */
		if (!(from_owner || from == ndo_session_successor(p->s)) ||
		    from == ndo_session_self(p->s) || h->epoch != ndo_session_epoch(p->s) ||
		    p->now < p->ck_answer.at)
			return;
		if (h->step != p->ck_answer_step)
			p->ck_answer.gap = 0; /* (the gaps double while the asks are for one step) */
		p->ck_answer_step = h->step;
		backoff_next(&p->ck_answer, p->now, p->o.resend);
		if (ndo__ck_send(p->ck, p->s, h->step, p->nownc, p->ownc, &p->st.checkpoint_bytes) < 0)
			p->failed = NDO_ENOMEM;
		return;
	}
	ndo__ck_put_msg(p->ck, h, from_owner ? NULL : owner_channel(p));
	ck_whole(p);
}

/* An ask for checkpoint `step` (ck_ask). */
static int ck_ask_send(ndo_peer *p, int64_t step)
{
	p->st.checkpoint_asks++;
	ndo_msg_halo_t h;
	memset(&h, 0, sizeof h);
	h.step = step;
	h.checkpoint = 1;
	int rc = ndo_session_send_halo(p->s, &h);
	return rc < 0 ? rc : 0;
}

/* The owner, and the joiner that would succeed it (ndo_session_successor):
 * while its newest checkpoint of this partition lacks some peer's part (one
 * of its messages lost) two exchanges after it, it asks for the parts again
 * (an empty, unconfirmed checkpoint halo; every other simulating peer, the
 * owner too, sends its own part), after the re-send gap, doubling up to
 * 0.2 s.  Otherwise a restart would go back to the checkpoint before it, or
 * to the first step — the successor's too: until 2026-11-30 only the owner
 * asked, and under 10 % loss at level 6 (bands, a checkpoint every 80 steps)
 * 11 of 40 successors went back 85-257 steps (10 of them 126 or more)
 * instead of at most 80. */
static int ck_ask(ndo_peer *p)
{
	int heir = !p->owner && p->simulating &&
	           ndo_session_successor(p->s) == ndo_session_self(p->s);
	if (!(p->owner || heir) || !p->ck || !p->started || p->ck_last < 0 || !restartable(p) ||
	    p->cur < p->ck_last + 2 * (int64_t)p->K || p->now < p->ck_ask.at ||
	    ndo__ck_whole(p->ck) >= p->ck_last)
		return 0;
	backoff_next(&p->ck_ask, p->now, p->o.resend);
	return ck_ask_send(p, p->ck_last);
}

static int publish(ndo_peer *p);
static void go(ndo_peer *p);

/* A restart waiting for checkpoint nodes: go back to rs_step when this
 * peer holds its region and halo there.  0 (done or waiting) or a
 * negative status. */
static int restart_try(ndo_peer *p)
{
	int64_t R = p->rs_step;
	if (R < 0)
		return 0;
	int32_t *nodes = p->dist; /* scratch: count ints */
	memcpy(nodes, p->ownc, p->nownc * sizeof *nodes);
	memcpy(nodes + p->nownc, p->halo, p->nhalo * sizeof *nodes);
	size_t n = p->nownc + p->nhalo;
	double t, sub;
	if (ndo__ck_get(p->ck, R, n, nodes, p->xs, p->vs, &t, &sub))
		return 0;
	ndo_sim_set_displacements(p->sim, n, nodes, p->xs, p->vs);
	ndo_sim_set_time(p->sim, t, R);
	ndo_sim_rkf45_set_substep(p->sim, sub); /* rkf45's controller at R (0 for the others) */
	ndo_sim_restart_energy_bound(p->sim);
	ndo_grid *g = ndo_session_grid(p->s);
	double *x = ndo_grid_f64(g, NDO_CH_POSITION, 3), *v = ndo_grid_f64(g, NDO_CH_VELOCITY, 3);
	const double *rest = ndo_grid_f64(g, NDO_CH_REST, 3);
	for (size_t q = 0; q < p->ncanon; q++)
		if (p->nstep[p->canons[q]] > R)
			p->nstep[p->canons[q]] = R;
	for (size_t k = 0; k < n; k++) {
		size_t c = (size_t)nodes[k];
		for (int d = 0; d < 3; d++) {
			p->hu[3 * c + d] = p->xs[3 * k + d];
			v[3 * c + d] = p->vs[3 * k + d];
			x[3 * c + d] = rest[3 * c + d] + p->xs[3 * k + d];
		}
		p->nstep[c] = R;
	}
	ndo_grid_sync(g);
	int64_t back = p->rs_from - R;
	p->rs_step = -1;
	p->cur = R;
	p->tcur = t;
	g->step = R;
	g->time = t;
	p->synced = 0;
	p->sstep[0] = p->sstep[1] = -1;
	p->inexact = 0;
	p->inexact_at = -1;
	p->inexact_from = 0;
	p->ck_skip = R;
	p->blocked = 0;
	p->gather_t0 = -1;
	p->last_resends = 0;
	p->gathered_at = -1;
	if (p->started) {
		p->st.restarts++;
		p->st.restart_steps += back > 0 ? back : 0;
		note(p, "partition %d: restarting from step %lld (a checkpoint), %lld step%s to take "
		     "again", ndo_session_epoch(p->s), (long long)R, (long long)(back > 0 ? back : 0),
		     back == 1 ? "" : "s");
	} else {
		go(p);
	}
	unstash(p);
	return publish(p);
}

/* The partition's restart step R: every simulating peer goes back to it.
 * `from` is the step this peer's region was at (R: none to take again). */
static int restart_begin(ndo_peer *p, int64_t R, int64_t from)
{
	int rc = ck_ready(p);
	if (rc)
		return rc;
	ndo__ck_drop_after(p->ck, R);
	ck_whole(p); /* (a joiner may have held a newer step whole) */
	p->ck_last = -1; /* (this partition's checkpoints come after R) */
	p->rs_step = R;
	p->rs_from = from;
	p->blocked = 0;
	backoff_start(&p->resend, p->now, p->o.resend);
	if (p->owner) {
		/* what a peer lacks of R: sent now, and again while the owner waits
		 * near R when a peer says it still lacks some (its keepalive at R,
		 * ck_wanted; such a peer holds its neighbours, and so the owner,
		 * within a few exchanges of R) */
		p->ck_at = R;
		p->ck_until = R + (int64_t)p->K * (NDO_MAX_PEERS + 1);
		p->ck_wanted = 0;
		backoff_start(&p->ck_send, p->now, p->o.resend);
		if ((rc = ck_resend(p)))
			return rc;
	}
	return restart_try(p);
}

/* What exact lock-step sends at cur: the strip at an exchange step, the
 * whole region at a frame step, the first and the last. */
static int exact_publish(ndo_peer *p)
{
	int rc;
	int64_t rel = p->cur - p->first;
	int last = p->cur >= p->final;
	if (p->rb) {
		/* rollback sends its strips itself; the last step's frame goes
		 * once it is confirmed (finishing) */
		if (last || !(rel == 0 || (p->N > 0 && rel % p->N == 0)))
			return 0;
		if ((rc = frame_send(p)))
			return rc;
		return ndo__rb_published(p->rb);
	}
	if (!last && rel % p->K == 0 && !p->ps) {
		int b = (int)((rel / p->K) & 1);
		strip_snapshot(p, b);
		if ((rc = strip_send(p, b)))
			return rc;
		p->st.exchanges++;
	}
	/* checkpoints every C steps (a multiple of K: a restart step is an
	 * exchange step), none after a step taken with older values */
	int64_t C = restartable(p) ? (p->C + p->K - 1) / p->K * p->K : 0;
	if (C && !last && rel > 0 && rel % C == 0 && !p->inexact && p->cur != p->ck_skip &&
	    (rc = checkpoint(p)))
		return rc;
	/* the taint where no strip carries it; at the last step the last word */
	if ((last || p->ps) && (rc = verdict_send(p)))
		return rc;
	if (last || rel == 0 || (p->N > 0 && rel % p->N == 0))
		return frame_send(p);
	return 0;
}

/* ---- the region ---------------------------------------------------------- */
/* Rollback's window starts again at cur: confirmed when it is the run's
 * first step, not yet under way (the run's own state); otherwise (a new
 * partition during the run, a joiner that came late) the region was taken
 * over from frames, and the run is no longer exact. */
static int rb_restart(ndo_peer *p)
{
	int exact = !p->started && p->cur == p->first;
	if (!exact)
		note(p, "step %lld: a new partition: from now on realtime rolls back without "
		     "waiting for confirmation (the run is no longer exact)", (long long)p->cur);
	p->synced = 0;
	return ndo__rb_restart(p->rb, p->cur, exact);
}

/* Mask, halo and owned count from the owner channel. */
static int region(ndo_peer *p)
{
	ndo_grid *g = ndo_session_grid(p->s);
	const int32_t *own = owner_channel(p);
	int32_t self = ndo_session_self(p->s);
	uint8_t *was = malloc(p->count);
	if (!was)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	if (p->ps)
		ndo__ps_abort(p->ps); /* a split step under way starts again */
	memcpy(was, p->mask, p->count);
	p->nowned = 0;
	for (size_t k = 0; k < p->count; k++) {
		p->mask[k] = own[p->canon[k]] == self;
		p->nowned += p->mask[k] && (size_t)p->canon[k] == k;
	}
	/* halo: the 1-ring (through the ghost map) of the region, outside it —
	 * what the 7-point stencil and the face forces read */
	uint8_t *inh = calloc(p->count, 1);
	if (!inh) {
		free(was);
		return ndo__fail(NDO_ENOMEM, "out of memory");
	}
	p->nhalo = 0;
	for (size_t q = 0; q < p->ncanon; q++) {
		size_t c = (size_t)p->canons[q];
		if (!p->mask[c])
			continue;
		size_t nb[6];
		ndo_neighbors(p->level, (int)(c % (size_t)g->w), (int)(c / (size_t)g->w), nb);
		for (int d = 0; d < 6; d++) {
			size_t h = (size_t)p->canon[nb[d]];
			if (!p->mask[h] && !inh[h]) {
				inh[h] = 1;
				p->halo[p->nhalo++] = (int32_t)h;
			}
		}
	}
	free(inh);
	/* nodes that came to this peer: the simulation takes their newest
	 * values (it held them, perhaps at older ones; with a send level, the
	 * others' whole regions as they travelled, refined, when newer) */
	if (p->sim) {
		ndo_session_refine_others(p->s, p->nstep);
		double *x = ndo_grid_f64(g, NDO_CH_POSITION, 3), *v = ndo_grid_f64(g, NDO_CH_VELOCITY, 3);
		int32_t *nodes = malloc(p->ncanon * sizeof *nodes);
		if (!nodes) {
			free(was);
			return ndo__fail(NDO_ENOMEM, "out of memory");
		}
		size_t n = 0;
		for (size_t q = 0; q < p->ncanon; q++) {
			size_t c = (size_t)p->canons[q];
			/* a split step's halo is in the simulation, exchanged at this
			 * step's start, not in the grid (whole regions every N steps) */
			if (p->mask[c] && !was[c] && !(p->ps && p->hmark && p->hmark[c])) {
				memcpy(p->xs + 3 * n, x + 3 * c, 3 * sizeof *x);
				memcpy(p->vs + 3 * n, v + 3 * c, 3 * sizeof *v);
				nodes[n++] = (int32_t)c;
			}
		}
		if (n)
			ndo_sim_set(p->sim, n, nodes, p->xs, p->vs);
		free(nodes);
		ndo_method m = ndo_sim_method(p->sim);
		int split = ndo__ps_method(m);
		/* realtime with exact halos rolls back (rollback.h): the explicit
		 * methods of a fixed reach; rkf45 and the implicit methods (steps
		 * of several exchanges) keep the extrapolated boundary */
		int roll = p->clock == NDO_CLOCK_REALTIME && !p->hold && ndo_peer_halo_rings(m) > 0 &&
		           !split;
		p->exact = (p->clock == NDO_CLOCK_LOCKSTEP && !p->hold &&
		            (ndo_peer_halo_rings(m) > 0 || split)) || roll;
		ndo_session_set_exact_halos(p->s, p->exact); /* tiles are frames only */
		int rc = 0;
		if (p->exact) {
			/* K steps reach D·K rings.  The outermost ring received is held
			 * (not integrated).  A one-stage method reads it only at its
			 * values of the exchange step.  A multi-stage one reads, of the
			 * first step, its displacement u and the first stage's u + c·h·v
			 * (ring D's later stages reach no node that counts): in lock-step
			 * the held ring moves along its velocity (ndo_sim_set_held_motion:
			 * the very arithmetic of an integrated node's first stage), so D·K
			 * rings are exact.  Rollback keeps one ring more, held still (its
			 * predictions carry that ring itself).  A split step (rkf45, the
			 * implicit methods) exchanges several times within each step
			 * (peer_solve.h): K is 1 */
			if (split)
				p->K = 1;
			int multi = m != NDO_EULER && m != NDO_SYMPLECTIC_EULER;
			p->W = split ? ndo__ps_rings(m) : ndo_peer_halo_rings(m) * p->K + (multi && roll);
			rc = exact_region(p);
			ndo_sim_set_held_motion(p->sim, multi && !roll && !split);
			if (!rc)
				rc = ndo_sim_set_active(p->sim, p->act);
			if (!rc && split && !p->ps)
				rc = ndo__ps_create(p->s, p->sim, !p->o.block, &p->ps);
			if (!rc && split) {
				ndo__ps_region r = {p->ownc, p->nownc, p->halo, p->nhalo, p->strip,
				                    p->nstrip, p->mask};
				ndo__ps_set_region(p->ps, &r);
			}
			/* the first re-send waits two steps of the pace: a neighbour's
			 * frontier moves once a step */
			if (!rc && roll && !p->rb)
				rc = ndo__rb_create(p->s, p->sim, p->count,
				                    fmax(p->o.resend, 2 * p->dt / p->speed), &p->rb);
			if (!rc && roll) {
				ndo__rb_region r = {p->own, p->nown, p->halo, p->nhalo, p->strip, p->nstrip,
				                    p->act, owner_channel(p), p->canon, p->K, p->first};
				rc = ndo__rb_set_region(p->rb, &r);
				if (!rc && p->announced)
					rc = rb_restart(p);
			}
		} else {
			ndo_sim_set_held_motion(p->sim, !p->hold);
			rc = ndo_sim_set_active(p->sim, p->mask);
		}
		if (rc) {
			free(was);
			return rc;
		}
	}
	free(was);
	p->simulating = p->nowned > 0;
	p->synced = 0;
	return 0;
}

/* ---- tiles out ----------------------------------------------------------- */
static int publish(ndo_peer *p)
{
	if (p->exact)
		return exact_publish(p);
	int rc = ndo_session_publish(p->s, p->cur, p->tcur);
	return rc < 0 ? rc : 0;
}

/* A restart waiting for checkpoint nodes sends nothing of the partition,
 * and its neighbours, which wait for its halo at R, must not take it
 * for dead meanwhile (a step they took alone after the step timeout would
 * leave the run inexact: no partition follows to restart it).  An empty
 * confirmed halo of the partition at R says it lives (alive_at_cur). */
static int restart_wait(ndo_peer *p)
{
	if (!p->exact || p->rb || !p->simulating)
		return 0;
	return empty_halo_send(p, p->rs_step, 0, 1);
}

/* The last two steps again: a neighbour that lost one of them may be
 * waiting for it (it can be one step behind or one ahead). */
static int resend(ndo_peer *p)
{
	int rc;
	/* every way below sends the last step's frame again once it went out
	 * (finishing counts the copies) */
	if (p->started && p->cur >= p->final && (!p->rb || p->last_sent) && p->rs_step < 0)
		p->last_resends++;
	if (p->rb) {
		/* the strips a neighbour may lack, the whole region at the first
		 * step and the last (once it went out) */
		p->st.resends++;
		if ((rc = ndo__rb_resend(p->rb, p->now, 1)))
			return rc;
		return !p->started || (p->cur >= p->final && p->last_sent) ? frame_send(p) : 0;
	}
	if (p->owner && p->ck_at >= 0 && (p->rs_step >= 0 || p->cur <= p->ck_until) &&
	    (p->ck_wanted || p->now >= p->ck_send.at)) {
		/* again for a peer that says it still waits for them (its
		 * keepalive at R: restart_wait), else after a gap that doubles
		 * (its keepalives may not reach this peer: a partition it has
		 * not yet heard of), not at every wait near R */
		p->ck_wanted = 0;
		backoff_next(&p->ck_send, p->now, p->o.resend);
		if ((rc = ck_resend(p)))
			return rc;
	}
	if (p->rs_step >= 0)
		return restart_wait(p); /* nothing of this partition yet but that it lives */
	if (p->exact) {
		/* the strips of the last two exchanges (a neighbour waits for one
		 * of them), the whole region at the first and last steps */
		p->st.resends++;
		for (int b = 0; b < 2; b++)
			if ((rc = strip_send(p, b)))
				return rc;
		if (p->ps && (rc = ndo__ps_resend(p->ps)))
			return rc;
		if ((p->ps || p->cur >= p->final) && (rc = verdict_send(p)))
			return rc;
		return p->cur >= p->final || !p->started ? frame_send(p) : 0;
	}
	if (p->prev_valid && (rc = ndo_session_publish_from(p->s, p->prev, p->prev_step,
	                                                    p->prev_time)) < 0)
		return rc;
	p->st.resends++;
	return publish(p);
}

/* Send again when the next re-send is due (the gap doubling up to
 * RESEND_MAX): NDO_PEER_WAITING or a negative status. */
static int resend_due(ndo_peer *p)
{
	if (p->now < p->resend.at)
		return NDO_PEER_WAITING;
	int rc = resend(p);
	if (rc)
		return rc;
	backoff_next(&p->resend, p->now, p->o.resend);
	return NDO_PEER_WAITING;
}

/* ---- starting -------------------------------------------------------------- */
static int npeers(const ndo_peer *p)
{
	int n = 0;
	if (!ndo_session_cells(p->s, &n, NULL))
		return 0;
	return n;
}

/* A joiner reads the owner's description: physics for ndo_scene, "peer-*"
 * lines for itself. */
static int read_description(ndo_peer *p, ndo_scene *sc)
{
	const char *text = ndo_session_scene(p->s);
	size_t len = strlen(text);
	char *phys = malloc(len + 1), *copy = strdup(text);
	if (!phys || !copy) {
		free(phys), free(copy);
		return ndo__fail(NDO_ENOMEM, "out of memory");
	}
	size_t n = 0;
	int have_final = 0, rc = 0;
	char *save = NULL;
	for (char *line = strtok_r(copy, "\n", &save); line && !rc; line = strtok_r(NULL, "\n", &save)) {
		if (strncmp(line, "peer-", 5) != 0) {
			n += (size_t)sprintf(phys + n, "%s\n", line);
			continue;
		}
		char key[32];
		double val;
		if (sscanf(line, "%31s %lf", key, &val) != 2 || !isfinite(val)) {
			rc = ndo__fail(NDO_EINVAL, "the owner's description: bad line '%s'", line);
		} else if (strcmp(key, "peer-clock") == 0) {
			p->clock = val == NDO_CLOCK_REALTIME ? NDO_CLOCK_REALTIME : NDO_CLOCK_LOCKSTEP;
		} else if (strcmp(key, "peer-hold-boundary") == 0) {
			p->hold = val != 0;
		} else if (strcmp(key, "peer-halo-steps") == 0 && val >= 1 && val <= 1000) {
			p->K = (int)val;
		} else if (strcmp(key, "peer-publish-every") == 0 && val >= -1 && val <= 1e9) {
			p->N = (int)val;
		} else if (strcmp(key, "peer-step-timeout") == 0 && val > 0) {
			p->step_timeout = val;
		} else if (strcmp(key, "peer-speed") == 0 && val > 0) {
			p->speed = val;
		} else if (strcmp(key, "peer-peers") == 0 && val >= 1 && val <= NDO_MAX_PEERS) {
			p->peers_needed = (int)val;
		} else if (strcmp(key, "peer-first-step") == 0 && val >= 0 && val < 1e15) {
			p->first = (int64_t)val;
		} else if (strcmp(key, "peer-final-step") == 0 && val >= 0 && val < 1e15) {
			p->final = (int64_t)val;
			have_final = 1;
		} else if (strcmp(key, "peer-checkpoint-every") == 0 && val >= 0 && val <= 1e9) {
			p->C = (int)val;
		} else if (strcmp(key, "peer-frames-every") == 0 && val >= 0 && val <= 1e9) {
			/* for watches (ndo/watch.h) */
		} else {
			rc = ndo__fail(NDO_EINVAL, "the owner's description: unknown or bad '%s'", line);
		}
	}
	phys[n] = 0;
	free(copy);
	if (!rc && !have_final)
		rc = ndo__fail(NDO_EINVAL, "the owner's description names no final step "
		               "(not a simulate-peer owner?)");
	if (!rc)
		rc = ndo_scene_apply_text(sc, phys, "the owner's description");
	free(phys);
	if (!rc && sc->dt_auto)
		rc = ndo__fail(NDO_EINVAL, "the owner's description gives no step size");
	return rc;
}

/* Joiner, READY: build the simulation from the description and the grid. */
static int joiner_ready(ndo_peer *p)
{
	int rc = arrays(p);
	if (rc)
		return rc;
	ndo_scene sc;
	ndo_scene_init(&sc);
	if ((rc = read_description(p, &sc))) {
		ndo_scene_free(&sc);
		return rc;
	}
	/* the last step's tiles are exact: what the owner gathers (ndo/codec.h) */
	ndo_session_set_exact_step(p->s, p->final);
	p->dt = sc.dt;
	ndo_grid *g = ndo_session_grid(p->s);
	double *rest = ndo_grid_f64(g, NDO_CH_REST, 3);
	uint8_t *pins = calloc(g->count, 1);
	ndo_force *forces = NULL;
	if (!pins) {
		ndo_scene_free(&sc);
		return ndo__fail(NDO_ENOMEM, "out of memory");
	}
	if ((rc = ndo_scene_resolve(&sc, g->level, rest, &forces, pins)) == 0) {
		ndo_sim_params prm = sc.sim;
		prm.forces = forces;
		prm.nforces = sc.nforces;
		rc = ndo_sim_from_grid(g, &prm, &p->sim);
		ndo_scene_forces_free(forces, sc.nforces);
		if (rc == 0) /* --restiffen counts from the run's first step */
			ndo_sim_set_first_step(p->sim, p->first);
	}
	free(pins);
	ndo_scene_free(&sc);
	if (rc) {
		char d[400];
		snprintf(d, sizeof d, "%s", ndo_errdetail());
		return ndo__fail(rc, "the owner's object: %s", d);
	}
	if ((rc = region(p)))
		return rc;
	if (p->poi_held >= 0) {
		rc = ndo_session_set_poi(p->s, p->poi_held);
		p->poi_held = -1;
	}
	return rc;
}

/* Realtime with rollback, before this peer started: did the partition in
 * force begin the run — a member's confirmed strip of it came (exact_epoch)
 * or waits in the stash for the region?  A window that restarts during the
 * run confirms nothing (rb_restart), so its strips never say confirmed. */
static int run_began_here(const ndo_peer *p)
{
	int32_t e = ndo_session_epoch(p->s);
	if (p->exact_epoch == e)
		return 1;
	for (size_t k = 0; k < p->nhstash; k++) {
		const ndo_msg_halo_t *h = &p->hstash[k];
		if (h->confirmed && h->nruns > 0 && h->epoch == e && member(p, h->hdr.sender_id))
			return 1;
	}
	return 0;
}

/* A joiner that starts to simulate: the step its neighbours are at.
 * Lock-step: the oldest step its halo holds (a neighbour further on waits
 * for this peer; one behind would not have let the others on).  Realtime:
 * the newest.  At least the snapshot's.
 *
 * Except a realtime joiner of the partition the run began with that holds
 * the first step whole (its snapshot): it starts there, exact, and
 * realtime() catches it up.  Its neighbours can still go back there: they
 * confirm no step past the first without its strips, and a window that
 * filled stopped them (NDO_EPACE).  Frames of theirs may show newer steps
 * in its halo (a joiner that stalled took a neighbour's frame of the
 * partition installed in the same update, before its region — and so the
 * halo's marks — was made), but nobody computed its region for them:
 * until 2026-12-01 it started at the newest, not exact, and its
 * neighbours, never confirmed past step 0, filled their windows
 * (test_peer realtime_a_stalled_joiner_starts_at_the_first_step). */
static void join_point(ndo_peer *p)
{
	int64_t at = -1;
	int newest = p->clock == NDO_CLOCK_REALTIME; /* realtime: catch up */
	for (size_t k = 0; k < p->nhalo; k++) {
		int64_t s = p->nstep[p->halo[k]];
		if (s >= 0 && (at < 0 || (newest ? s > at : s < at)))
			at = s;
	}
	if (at < p->fill_step)
		at = p->fill_step;
	if (p->rb && !p->started && p->fill_step >= 0 && p->fill_step <= p->first &&
	    run_began_here(p))
		at = p->first;
	p->cur = at;
	p->tcur = p->times[at & 63].step == at ? p->times[at & 63].time
	                                        : p->fill_time + (double)(at - p->fill_step) * p->dt;
	if (p->sim)
		ndo_sim_set_time(p->sim, p->tcur, p->cur);
	for (size_t q = 0; q < p->ncanon; q++)
		if (p->mask[p->canons[q]])
			p->nstep[p->canons[q]] = p->cur;
	p->wall0 = p->now;
	p->sched0 = p->cur;
	p->prev_valid = 0;
	/* exact lock-step without a restart: a region from frames — a
	 * simulating peer's; an observer computes nothing, and what it holds
	 * at the end is what the peers computed (their halos carry their
	 * taints) */
	if (p->cur > p->first && p->simulating)
		taint(p, p->cur, 0);
}

/* The first state: this peer's region at the step it starts from, sent
 * to the others. */
static int announce(ndo_peer *p)
{
	ndo_grid *g = ndo_session_grid(p->s);
	int rc = region(p);
	if (rc)
		return rc;
	p->epoch_done = ndo_session_epoch(p->s);
	p->epoch_t0 = p->now;
	int64_t R = ndo_session_restart(p->s);
	/* a joiner whose object is the run's first step holds it whole: a
	 * restart from there (a partition made before the start) needs no
	 * checkpoint nodes */
	int holds_R = R == p->first && p->fill_step <= p->first && p->max_seen <= p->first;
	if (!p->owner && p->simulating && restartable(p) && R >= 0 && !holds_R) {
		/* a run under way whose partition restarts: from its step */
		p->announced = 1;
		return restart_begin(p, R, R);
	}
	if (p->owner) {
		ndo_session_set_grace(p->s, 0); /* the joiners' silence counts from here */
		if (p->sim)
			ndo_sim_set_time(p->sim, p->tcur, p->cur);
		for (size_t q = 0; q < p->ncanon; q++)
			if (p->mask[p->canons[q]])
				p->nstep[p->canons[q]] = p->cur;
	} else {
		join_point(p);
	}
	g->step = p->cur;
	g->time = p->tcur;
	p->announced = 1;
	if ((p->owner || (p->cur == p->first && p->fill_step <= p->first &&
	                  p->max_seen <= p->first)) && restartable(p) && !ck_ready(p)) {
		/* the run's first step, held whole by the owner's simulation (and
		 * a joiner's that starts there, from the snapshot): a partition
		 * made from here on (a peer dropped before the start, while
		 * others may have begun; a joiner's if it succeeds the owner)
		 * restarts every peer from it */
		ck_take(p, p->ncanon, p->canons);
		ck_whole(p);
	}
	if (p->rb && (rc = rb_restart(p)))
		return rc;
	unstash(p); /* halos kept until the region was made */
	backoff_start(&p->resend, p->now, p->o.resend);
	return p->simulating ? publish(p) : 0;
}

/* Every node holds the run's first step: the peers' clocks start.  Exact
 * lock-step needs only its halo (what its steps read): a peer that lost
 * some other region's announcement starts all the same, and the strips
 * its neighbours re-send while they wait are all it needs. */
static int all_at(const ndo_peer *p, int64_t step)
{
	if (p->exact && p->ps)
		return 1; /* a split step waits for what it needs itself */
	if (p->rb)
		return ndo__rb_ready(p->rb);
	if (p->exact && p->hmark) {
		for (size_t k = 0; k < p->nhalo; k++)
			if (p->nstep[p->halo[k]] < step)
				return 0;
		return 1;
	}
	for (size_t q = 0; q < p->ncanon; q++)
		if (p->nstep[p->canons[q]] < step)
			return 0;
	return 1;
}

static void go(ndo_peer *p)
{
	p->started = 1;
	ndo_session_set_grace(p->s, 0);
	p->st.start_time = p->now;
	p->wall0 = p->now;
	p->sched0 = p->cur;
	int np = npeers(p);
	if (p->simulating)
		note(p, "%s: step %lld, %d peer%s simulate%s, this one %zu of %zu nodes; %s to step "
		     "%lld", p->cur == p->first ? "starting" : "joining the run", (long long)p->cur, np,
		     np == 1 ? "" : "s", np == 1 ? "s" : "", p->nowned, p->ncanon,
		     ndo_clock_name(p->clock), (long long)p->final);
	else /* a joiner that asked for a share of a run under way: until it comes */
		note(p, "%s from step %lld: %d peer%s simulate%s, %s to step %lld",
		     p->wants_share ? "waiting for its share" : "observing",
		     (long long)(p->max_seen > p->cur ? p->max_seen : p->cur), np, np == 1 ? "" : "s",
		     np == 1 ? "s" : "", ndo_clock_name(p->clock), (long long)p->final);
}

/* Before the run: announce when this peer can, start when everyone has
 * (a joiner that comes when the run is under way starts at once). */
static int starting(ndo_peer *p)
{
	double now = p->now;
	int np = npeers(p);
	if (!p->announced) {
		int ready = p->owner || (p->sim && ndo_session_ready(p->s));
		/* The owner keeps a silent joiner's place until it has its
		 * --peers (a joiner stalled while it takes in the object); then
		 * one silent for longer than the timeout is dropped (the next
		 * update, without the grace) instead of counted: a partition
		 * made after the announcement, before the start, is taken over
		 * from frames, and one that counts a dead peer never starts. */
		if (p->owner)
			ndo_session_set_grace(p->s, p->o.start_timeout);
		if (ready && np >= p->peers_needed && p->owner && ndo_session_silent(p->s)) {
			ndo_session_set_grace(p->s, 0);
			return NDO_PEER_WAITING;
		}
		/* a joiner: once the owner has announced, a partition made since
		 * (a peer left or was dropped before the start) may count fewer
		 * than --peers; waiting for them would hold the start for good */
		if (ready && (np >= p->peers_needed || (!p->owner && p->owner_went))) {
			int rc = announce(p);
			if (rc)
				return rc;
		}
	}
	if (p->announced) {
		int late = !p->owner && (p->max_seen > p->first || p->fill_step > p->first);
		/* A joiner announces a partition of --peers as soon as it has one,
		 * but the owner may not (a silent peer in it, dropped first): in
		 * exact runs it starts once the owner has spoken in its partition
		 * or an older one (owner_spoke), not with one the owner replaced
		 * before the start — its first step would hold the old region's
		 * values (the others' halos of the step before come from the
		 * snapshot, so nothing else holds it back). */
		int owner_in = p->owner || !p->exact || p->owner_went;
		if (late || !p->simulating || (owner_in && all_at(p, p->first))) {
			go(p);
			return NDO_PEER_WAITING;
		}
		int rc = resend_due(p); /* an announcement may be lost */
		if (rc < 0)
			return rc;
	}
	if (now - p->created > p->o.start_timeout) {
		if (p->owner)
			snprintf(p->message, sizeof p->message, "only %d of %d peers came within %.3g s",
			         np, p->peers_needed, p->o.start_timeout);
		else if (!p->sim)
			snprintf(p->message, sizeof p->message, "no object %s within %.3g s",
			         ndo_session_grid(p->s) ? "arrived whole" : "was described",
			         p->o.start_timeout);
		if (p->owner || !p->sim) {
			p->ended = 1;
			return NDO_PEER_ENDED;
		}
	}
	return NDO_PEER_WAITING;
}

/* ---- a step ---------------------------------------------------------------- */
static double wall(void) { return ndo_now(); }

/* Halo nodes that do not hold the value of step `cur`. */
static size_t missing(const ndo_peer *p)
{
	size_t n = 0;
	if (p->exact && (p->cur - p->first) % p->K != 0)
		return 0; /* between exchanges the halo is integrated here */
	for (size_t k = 0; k < p->nhalo; k++)
		n += p->nstep[p->halo[k]] < p->cur;
	return n;
}

/* An exact step taken (lock-step with halos, or split): the region is at
 * cur + 1; publish what is due and take the tiles kept for it. */
static int stepped(ndo_peer *p)
{
	p->cur++;
	p->tcur = ndo_sim_time(p->sim);
	p->synced = 0;
	/* (locals: a store through p->nstep could be p->cur's, and the
	 * compiler would reload both at every node) */
	int64_t *restrict nstep = p->nstep;
	const int64_t cur = p->cur;
	for (size_t r = 0; r < p->norun; r++)
		for (int32_t c = p->orun[2 * r]; c < p->orun[2 * r + 1]; c++)
			nstep[c] = cur;
	if (p->blocked)
		p->st.wait_seconds += p->now - p->block_t0;
	p->blocked = 0;
	p->st.steps++;
	p->st.end_time = p->now;
	int rc = publish(p);
	if (rc)
		return rc;
	unstash(p);
	return NDO_PEER_STEPPED;
}

/* Exact lock-step: at an exchange step the halo takes the received
 * displacements and velocities (of this very step: lockstep() waited for
 * them); in between, the halo is integrated along with the region. */
static int step_exact(ndo_peer *p)
{
	if (p->rb) {
		double t0 = wall();
		int rc = ndo__rb_step(p->rb, p->dt);
		p->st.compute_seconds += wall() - t0;
		return rc ? rc : stepped(p);
	}
	if ((p->cur - p->first) % p->K == 0) {
		ndo_grid *g = ndo_session_grid(p->s);
		const double *v = ndo_grid_f64(g, NDO_CH_VELOCITY, 3);
		int64_t late = 0;
		for (size_t k = 0; k < p->nhalo; k++) {
			size_t c = (size_t)p->halo[k];
			memcpy(p->xs + 3 * k, p->hu + 3 * c, 3 * sizeof *p->xs);
			memcpy(p->vs + 3 * k, v + 3 * c, 3 * sizeof *p->vs);
			if (p->nstep[c] != p->cur) {
				late++;
				double a = fabs((double)(p->cur - p->nstep[c]));
				p->st.lag_sum += a / (double)p->nhalo;
				if (a > p->st.lag_max)
					p->st.lag_max = a;
			}
		}
		p->st.missed += late;
		if (p->nhalo) {
			ndo_sim_set_displacements(p->sim, p->nhalo, p->halo, p->xs, p->vs);
			/* the halo brings the energy its owners' forces put in: the
			 * bound restarts from the state with it (a region at rest
			 * would otherwise "diverge" when the first wave arrives) */
			ndo_sim_restart_energy_bound(p->sim);
		}
	}
	double t0 = wall();
	int rc = ndo_sim_step(p->sim, p->dt);
	p->st.compute_seconds += wall() - t0;
	if (rc)
		return rc;
	return stepped(p);
}

static int step(ndo_peer *p)
{
	if (p->exact)
		return step_exact(p);
	ndo_grid *g = ndo_session_grid(p->s);
	double *x = ndo_grid_f64(g, NDO_CH_POSITION, 3), *v = ndo_grid_f64(g, NDO_CH_VELOCITY, 3);
	/* the held boundary: the others' values, as new as this peer has them;
	 * a value of another step (a miss, or a free-running neighbour) is
	 * carried along its velocity by at most one step unless the boundary is
	 * held.  Further, linear extrapolation overshoots the stiff modes (by
	 * |1 + i·a·hω| for a value a steps old) and a lossy realtime run blew
	 * up (docs/peers.md). */
	double age = 0;
	int64_t late = 0;
	for (size_t k = 0; k < p->nhalo; k++) {
		size_t c = (size_t)p->halo[k];
		int64_t a = p->nstep[c] < 0 ? p->cur - p->first + 1 : p->cur - p->nstep[c];
		double tau = p->hold || p->nstep[c] < 0 ? 0 : fmax(-1.0, fmin(1.0, (double)a)) * p->dt;
		for (int d = 0; d < 3; d++) {
			p->hx[3 * k + d] = x[3 * c + d] + tau * v[3 * c + d];
			p->hv[3 * k + d] = v[3 * c + d];
		}
		if (a != 0) {
			late += a > 0;
			age += fabs((double)a);
			if (fabs((double)a) > p->st.lag_max)
				p->st.lag_max = fabs((double)a);
		}
	}
	if (p->nhalo) {
		ndo_sim_set(p->sim, p->nhalo, p->halo, p->hx, p->hv);
		p->st.lag_sum += age / (double)p->nhalo;
	}
	p->st.missed += late;
	/* keep this step for re-sends */
	memcpy(ndo_grid_f64(p->prev, NDO_CH_POSITION, 3), x, 3 * p->count * sizeof *x);
	memcpy(ndo_grid_f64(p->prev, NDO_CH_VELOCITY, 3), v, 3 * p->count * sizeof *v);
	p->prev_step = p->cur;
	p->prev_time = p->tcur;
	p->prev_valid = 1;
	double t0 = wall();
	int rc = ndo_sim_step(p->sim, p->dt);
	p->st.compute_seconds += wall() - t0;
	if (rc)
		return rc;
	ndo_sim_get(p->sim, p->xs, p->vs);
	for (size_t k = 0; k < p->count; k++)
		if (p->mask[k]) {
			memcpy(x + 3 * k, p->xs + 3 * k, 3 * sizeof *x);
			memcpy(v + 3 * k, p->vs + 3 * k, 3 * sizeof *v);
		}
	p->cur++;
	p->tcur = ndo_sim_time(p->sim);
	for (size_t q = 0; q < p->ncanon; q++)
		if (p->mask[p->canons[q]])
			p->nstep[p->canons[q]] = p->cur;
	if (p->blocked)
		p->st.wait_seconds += p->now - p->block_t0;
	p->blocked = 0;
	p->st.steps++;
	p->st.end_time = p->now;
	if ((rc = publish(p)))
		return rc;
	unstash(p);
	return NDO_PEER_STEPPED;
}

/* Can peer `id` still send its part of split step cur, which this peer
 * has waited `waited` s for?  Yes when a phase of it came within
 * silence(p) of this partition at cur or before (one behind is waited for
 * anyway: ndo__ps_behind), or at cur + 1 while this peer has waited less
 * than silence(p) — it finished cur, and re-sends cur's last phase until
 * this peer's next one comes; one that went on alone after a timeout never
 * sends it, and waiting on for it while it waits for this one, behind,
 * would be a deadlock.  One not heard of under this partition yet has
 * silence(p) from when this peer installed it (or from its last message
 * of another partition, if later) to show up: it may still be installing
 * it, or waiting for the checkpoint it restarts from. */
static int split_alive(const ndo_peer *p, int32_t id, double waited)
{
	int32_t epoch = ndo_session_epoch(p->s);
	for (int k = 0; k < NDO_MAX_PEERS; k++) {
		if (p->heard[k].id != id)
			continue;
		if (p->heard[k].epoch != epoch)
			return p->now - fmax(p->heard[k].at, p->epoch_t0) < silence(p);
		if (p->now - p->heard[k].at >= silence(p))
			return 0;
		if (p->heard[k].step <= p->cur)
			return 1;
		return p->heard[k].step == p->cur + 1 && waited < silence(p);
	}
	return p->now - p->epoch_t0 < silence(p);
}

/* A split step with restarts: is every other peer of the partition alive
 * and able to send its part of step cur (split_alive)?  Then the step
 * timeout does not take the step alone: its phases come (every peer
 * re-sends its last two), and a step taken alone would leave the run
 * inexact with no partition to restart it.  Every peer waits for every
 * other one, not only its neighbours: the phases' sums are everyone's. */
static int members_alive(ndo_peer *p, double waited)
{
	if (!restartable(p))
		return 0;
	int n = 0;
	const int32_t *ids;
	if (!ndo_session_cells(p->s, &n, &ids))
		return 0;
	for (int k = 0; k < n; k++)
		if (ids[k] != ndo_session_self(p->s) && !split_alive(p, ids[k], waited))
			return 0;
	return 1;
}

/* Exact lock-step of rkf45 and the implicit methods: the step goes on
 * as far as the others' messages allow (peer_solve.h); a peer that waits
 * sends its last two phases again, and after step_timeout without
 * progress takes the step alone (ndo_sim_step, the others' nodes held at
 * their older values) and counts the miss — unless another peer is
 * behind (a new partition caught the peers at different steps): then the
 * one behind gives up and catches up, and the peers meet at its next step
 * instead of overtaking each other; and, with restarts, unless every
 * other peer is alive (members_alive). */
static int step_split(ndo_peer *p)
{
	double t0 = wall();
	/* alone, the peer's step is the single process's: no one to split with */
	int alone = ndo__ps_alone(p->ps);
	int rc = alone ? ndo_sim_step(p->sim, p->dt) : ndo__ps_advance(p->ps, p->cur, p->dt);
	p->st.compute_seconds += wall() - t0;
	if (rc < 0)
		return rc;
	if (rc == 0 && !alone) {
		double now = p->now;
		ndo__ps_stats ps;
		ndo__ps_stats_get(p->ps, &ps);
		if (!p->blocked) {
			p->blocked = 1;
			p->block_t0 = now;
			p->st.waited++;
		}
		if (p->split_t0 < p->block_t0 || ps.phases != p->split_phases) {
			/* a new wait, or the step went on: the re-sends and the timeout
			 * start again (a step of many phases may take longer than
			 * step_timeout, and each phase may need a re-send) */
			p->split_t0 = now;
			p->split_phases = ps.phases;
			backoff_start(&p->resend, now, p->o.resend);
		}
		if (now - p->split_t0 < p->step_timeout || ndo__ps_behind(p->ps, p->cur) ||
		    members_alive(p, now - p->split_t0))
			return resend_due(p); /* a peer behind this one comes: it gives up, not this one */
		/* a neighbour that died, or peers that a new partition caught at
		 * different steps: this step is taken alone, with the halo's
		 * older values (the run is no longer exact), and the peers meet
		 * again at the next one */
		p->st.timeouts++;
		taint(p, p->cur + 1, 0);
		if ((rc = verdict_send(p)))
			return rc;
		p->st.missed += (int64_t)p->nhalo;
		if (p->notes_missed++ < 5)
			note(p, "step %lld: the other peers' part of the step did not come within %.2g s: "
			     "this step is taken with older values%s", (long long)p->cur,
			     now - p->split_t0, p->notes_missed == 5 ? " (no more such messages)" : "");
		ndo__ps_abort(p->ps);
		t0 = wall();
		rc = ndo_sim_step(p->sim, p->dt);
		p->st.compute_seconds += wall() - t0;
		if (rc)
			return rc;
	}
	return stepped(p);
}

/* Exact lock-step with restarts: is every neighbour whose halo at cur is
 * missing alive and able to send it still (alive_at_cur)?  Then the step
 * timeout does not go on with older values: under loss a re-sent strip
 * comes, while a step taken without it would leave the run inexact for
 * good (no partition follows to restart it); a dead neighbour falls
 * silent and is timed out as before.  Only with restarts: every peer of a
 * partition starts it at the same step R, so a live neighbour is at most
 * one exchange away and holds what this peer waits for (without them, a
 * partition takes effect at whatever step each peer is, and peers more
 * than an exchange apart would wait for each other for ever). */
static int neighbours_alive(ndo_peer *p)
{
	if (!restartable(p))
		return 0;
	const int32_t *own = owner_channel(p);
	int32_t last = 0;
	for (size_t k = 0; k < p->nhalo; k++) {
		int32_t c = p->halo[k];
		if (p->nstep[c] >= p->cur || own[c] == last)
			continue;
		last = own[c];
		if (!alive_at_cur(p, last))
			return 0;
	}
	return 1;
}

/* Lock-step: step when the halo holds step `cur`; otherwise wait,
 * re-send, and after step_timeout go on. */
static int lockstep(ndo_peer *p)
{
	if (p->exact && p->ps)
		return step_split(p);
	size_t miss = missing(p);
	if (miss == 0)
		return step(p);
	double now = p->now, ahead = 0;
	if (p->exact && !p->rb && p->sim && p->ahead != p->cur) {
		/* while the halo is in flight: the units of the step that do not
		 * read it (rk4's pipeline; the same bits, ndo/sim.h); the step
		 * itself (step_exact) runs the rest once it came */
		p->ahead = p->cur;
		double t0 = wall();
		int rc = ndo_sim_step_begin(p->sim, p->dt, p->nhalo, p->halo);
		ahead = wall() - t0;
		p->st.compute_seconds += ahead;
		if (rc < 0)
			return rc;
		p->st.ahead += rc > 0;
	}
	if (!p->blocked) {
		p->blocked = 1;
		p->block_t0 = now + ahead; /* waiting: from the end of the work done ahead */
		backoff_start(&p->resend, now, p->o.resend);
		p->st.waited++;
	}
	if (now - p->block_t0 >= p->step_timeout && !neighbours_alive(p)) {
		p->st.timeouts++;
		taint(p, p->cur + 1, 0); /* no checkpoints until a restart */
		if (p->notes_missed++ < 5) {
			const int32_t *own = owner_channel(p);
			char who[64] = "";
			int n = 0;
			for (size_t k = 0; k < p->nhalo && n < 3; k++) {
				int32_t id = own[p->halo[k]];
				if (p->nstep[p->halo[k]] < p->cur && !strstr(who, "?")) {
					char one[16];
					snprintf(one, sizeof one, "%d", id);
					if (!strstr(who, one)) {
						snprintf(who + strlen(who), sizeof who - strlen(who), "%s%s",
						         n ? ", " : "", one);
						n++;
					}
				}
			}
			note(p, "step %lld: no step %lld from peer %s for %.2g s (%zu boundary node%s): "
			     "going on with older values%s", (long long)p->cur, (long long)p->cur, who,
			     now - p->block_t0, miss, miss == 1 ? "" : "s",
			     p->notes_missed == 5 ? " (no more such messages)" : "");
		}
		return step(p);
	}
	return resend_due(p);
}

/* Rollback: what arrived since the last call recomputed, the confirmed
 * strips a neighbour waits for sent again. */
static int rb_catch_up(ndo_peer *p)
{
	double t0 = wall();
	int n = ndo__rb_catch_up(p->rb);
	p->st.compute_seconds += wall() - t0;
	if (n < 0)
		return n;
	if (n > 0)
		p->synced = 0; /* the grid's region: from the recomputed state */
	return ndo__rb_resend(p->rb, p->now, 0);
}

/* Realtime: step k at wall0 + (k − sched0)·dt/speed with whatever values
 * are there.  A peer that started later (its first state announced later,
 * over a lossy link) or fell behind catches up: while another peer's
 * newest step is ahead of its own it steps at once, and its schedule
 * restarts from there — so the peers keep the earliest starter's pace
 * instead of a permanent offset. */
static int realtime(ndo_peer *p)
{
	int rc;
	if (p->rb && (rc = rb_catch_up(p)))
		return rc;
	double due = p->wall0 + (double)(p->cur + 1 - p->sched0) * p->dt / p->speed;
	/* the pace: a peer that fell further behind the wall clock than
	 * step_timeout cannot keep it (its steps, and rollback's
	 * recomputations, take longer than the pace allows) */
	if (p->now > due + p->step_timeout)
		return ndo__fail(NDO_EPACE, "step %lld was due %.3g s ago (more than --step-timeout "
		                 "%.3g s): this peer cannot keep the pace of %.3g s a step",
		                 (long long)(p->cur + 1), p->now - due, p->step_timeout,
		                 p->dt / p->speed);
	if (p->now >= due) {
		if (p->now > due + p->dt / p->speed)
			p->st.behind++;
		return step(p);
	}
	if (p->max_seen > p->cur) {
		rc = step(p);
		p->wall0 = p->now;
		p->sched0 = p->cur;
		p->st.behind++;
		return rc;
	}
	return NDO_PEER_WAITING;
}

/* Owner, exact lock-step: how many simulating peers of the partition in
 * force have not sent their last word yet (*silent), and one of them. */
static int32_t last_words(const ndo_peer *p, int *silent)
{
	int n = 0;
	const int32_t *ids;
	*silent = 0;
	if (!p->exact || p->rb || !ndo_session_cells(p->s, &n, &ids))
		return 0;
	int32_t who = 0;
	for (int k = 0; k < n; k++) {
		if (ids[k] == ndo_session_self(p->s))
			continue;
		int j = 0;
		while (j < p->nword && p->word[j] != ids[k])
			j++;
		if (j == p->nword)
			(*silent)++, who = ids[k];
	}
	return who;
}

/* The canonical nodes this peer holds at a step before the last. */
static size_t behind_last(const ndo_peer *p)
{
	size_t behind = 0;
	for (size_t q = 0; q < p->ncanon; q++)
		behind += p->nstep[p->canons[q]] < p->final;
	return behind;
}

/* This peer holds the last step: every node's value of it.  One tile of
 * it is not enough: a lost one leaves its nodes older (until 2026-11-30
 * an observer that had one said DONE and held 0.74 of the motion off:
 * test_peer an_observer_on_its_way_follows_the_successor, seed 187). */
static int holds_last(const ndo_peer *p)
{
	return p->max_seen >= p->final && behind_last(p) == 0;
}

/* After the last step: the owner gathers, a joiner keeps its last steps
 * available until the owner ends the session. */
static int finishing(ndo_peer *p)
{
	double now = p->now;
	if (p->gather_t0 < 0) {
		p->gather_t0 = now;
		backoff_start(&p->resend, now, p->o.resend);
	}
	if (p->rb && !p->last_sent) {
		/* the last step's frame (what the owner gathers) once every input
		 * of the run is confirmed: then it is the lock-step state */
		int rc = rb_catch_up(p);
		if (rc)
			return rc;
		ndo__rb_stats rs;
		ndo__rb_stats_get(p->rb, &rs);
		int ok = ndo__rb_confirmed(p->rb, p->final);
		if (!ok && rs.exact && now - p->gather_t0 < p->o.gather_timeout)
			return p->simulating ? resend_due(p) : NDO_PEER_WAITING;
		if (!ok && rs.exact)
			note(p, "step %lld: not confirmed within %.3g s (the frontier is step %lld): the "
			     "result holds unconfirmed values", (long long)p->final, p->o.gather_timeout,
			     (long long)ndo__rb_frontier(p->rb));
		p->last_sent = 1;
		p->gather_t0 = now; /* the owner gathers from now */
		if ((rc = frame_send(p)))
			return rc;
	}
	if (p->rb) {
		int rc = ndo__rb_resend(p->rb, now, 0);
		if (rc)
			return rc;
	}
	if (p->owner) {
		size_t behind = behind_last(p);
		int silent = 0;
		int32_t who = last_words(p, &silent);
		/* gathered, it leaves once its last frame went out LAST_COPIES
		 * times and LAST_GAPS first re-send gaps have passed since (the
		 * joiners re-send theirs meanwhile, at 1 and 3 gaps after their
		 * last step, which came before): observers and render-frame,
		 * which nobody answers, assemble the result from these frames,
		 * and a copy sent once was lost with the loss's odds (test_peer
		 * an_observer_on_its_way_follows_the_successor, 10 % loss: 2
		 * seeds of 40 ended without the last step; counting the owner's
		 * own copies alone, a joiner whose last frame came late had sent
		 * it once: seed 187 of 121 ended holding 0.74 of the motion off) */
		int gathered = behind == 0 && !silent;
		if (gathered && p->gathered_at < 0)
			p->gathered_at = now;
		if (gathered && p->simulating &&
		    (p->last_resends < LAST_COPIES - 1 ||
		     now - p->gathered_at < LAST_GAPS * p->o.resend) &&
		    now - p->gather_t0 < p->o.gather_timeout)
			return resend_due(p);
		if (gathered || now - p->gather_t0 >= p->o.gather_timeout) {
			p->st.ungathered = (int64_t)behind;
			p->st.unsaid = silent;
			if (behind)
				note(p, "step %lld: %zu nodes of the others did not arrive within %.3g s: "
				     "the output holds their newest values", (long long)p->final, behind,
				     p->o.gather_timeout);
			if (silent)
				note(p, "step %lld: %d peer%s (peer %d …) did not say within %.3g s whether "
				     "its last step was exact: the result is exact as far as the others "
				     "know", (long long)p->final, silent, silent == 1 ? "" : "s", who,
				     p->o.gather_timeout);
			p->done = 1;
			return NDO_PEER_DONE;
		}
	}
	return p->simulating ? resend_due(p) : NDO_PEER_WAITING;
}

/* ---- events ------------------------------------------------------------------ */
static int on_partition(ndo_peer *p)
{
	if (!p->canon || (!p->owner && !p->sim))
		return 0; /* the region is made at the start */
	if (ndo_session_epoch(p->s) == p->epoch_done)
		return 0; /* several events, one partition in force */
	p->epoch_done = ndo_session_epoch(p->s);
	p->epoch_t0 = p->now;
	p->nword = 0; /* the last words of this partition's peers */
	size_t before = p->nowned;
	int was = p->simulating;
	int rc = region(p);
	if (rc)
		return rc;
	int np = npeers(p);
	int64_t R = ndo_session_restart(p->s);
	int restart = R >= 0 && p->simulating && restartable(p);
	if (R >= 0 && !p->simulating && restartable(p)) {
		/* an observer: every simulating peer goes back to R, a step
		 * computed exactly, so a taint it heard of is undone (before
		 * 2026-11-29 an observer of a kill said "NOT exact" of an exact
		 * run) */
		p->inexact = 0;
		p->inexact_at = -1;
		p->inexact_from = 0;
	}
	if (p->announced && !was && p->simulating && !p->owner && restart) {
		note(p, "simulating from step %lld: %zu of %zu nodes (partition %d, %d peers)",
		     (long long)R, p->nowned, p->ncanon, ndo_session_epoch(p->s), np);
		return restart_begin(p, R, R);
	}
	if (p->announced && !was && p->simulating && !p->owner && p->cur < p->final) {
		join_point(p);
		if (p->rb && (rc = rb_restart(p)))
			return rc;
		note(p, "simulating from step %lld: %zu of %zu nodes (partition %d, %d peers)",
		     (long long)p->cur, p->nowned, p->ncanon, ndo_session_epoch(p->s), np);
		return publish(p);
	}
	if (p->announced) {
		if (p->started) {
			p->st.repartitions++;
			note(p, "partition %d at step %lld: %d peer%s, this one %zu nodes (was %zu)",
			     ndo_session_epoch(p->s), (long long)p->cur, np, np == 1 ? "" : "s",
			     p->nowned, before);
		}
		if (restart) /* announced: started, or about to */
			return restart_begin(p, R, was && p->started ? p->cur : R);
		if (p->owner && !p->started)
			/* no restart (none held, or none asked for): the owner holds
			 * the first step whole, so a dead peer's first state, never
			 * announced, is its own; else it would wait for it until its
			 * start timeout while the others, who began, go on */
			for (size_t q = 0; q < p->ncanon; q++)
				if (p->nstep[p->canons[q]] < p->first)
					p->nstep[p->canons[q]] = p->first;
		for (size_t q = 0; q < p->ncanon; q++)
			if (p->mask[p->canons[q]] && p->nstep[p->canons[q]] < p->cur) {
				p->nstep[p->canons[q]] = p->cur;
				if (p->started) /* taken over from older values */
					taint(p, p->cur, 0);
			}
		unstash(p);
		p->blocked = 0;
		if (p->simulating)
			return publish(p);
	}
	return 0;
}

static int events(ndo_peer *p)
{
	ndo_event e;
	int rc = 0;
	while (!rc && ndo_session_event(p->s, &e)) {
		switch (e.type) {
		case NDO_EV_READY:
			if (!p->owner) {
				rc = joiner_ready(p);
				note(p, "joined object %llx (owner %d): level %d, %s",
				     (unsigned long long)ndo_session_object(p->s), ndo_session_owner_id(p->s),
				     p->level, ndo_clock_name(p->clock));
			}
			break;
		case NDO_EV_PARTITION: rc = on_partition(p); break;
		case NDO_EV_JOINED: note(p, "peer %d joined", e.peer); break;
		case NDO_EV_LEFT:
			note(p, "peer %d left%s%s", e.peer, *e.message ? ": " : "", e.message);
			break;
		case NDO_EV_OWNER:
			/* the owner fell silent (the session's succession): this peer
			 * owns the session if it is the successor; the partition that
			 * restarts every peer without the lost owner comes next */
			note(p, "%s", e.message);
			if (e.peer == ndo_session_self(p->s)) {
				p->owner = 1;
				p->ck_last = -1;
				p->st.took_over = 1;
			}
			break;
		case NDO_EV_ENDED:
			p->ended = 1;
			p->end_reason = e.reason;
			snprintf(p->message, sizeof p->message, "%s", e.message);
			break;
		default: break;
		}
	}
	return rc;
}

/* --restiffen S: K is re-assembled every S steps from the shape of that
 * step, and a peer holds only its region's and halo's shapes.  In exact
 * lock-step an exchange comes at every re-assembly (K a divisor of S: the
 * halo's outer rings, re-assembled mid-exchange from values not yet
 * exact, kept those rows until the next re-assembly, 1e-5 of the largest
 * displacement off with K 2 and S 5), and checkpoints come at multiples
 * of S, where a restart re-assembles K from the checkpoint's state
 * (ndo_sim_set_first_step): until 2026-12-01 a peer counted S from its
 * own first step and kept its K through restarts, and a join ended 1.1
 * of the largest displacement off, reported exact. */
static void restiffen_align(ndo_peer *p, int S)
{
	if (S <= 0 || p->hold || p->clock != NDO_CLOCK_LOCKSTEP)
		return;
	int K = p->K, g = K;
	for (int b = S; b;) {
		int t = g % b;
		g = b, b = t;
	}
	int64_t C = p->C;
	if (C > 0) {
		C = (C + S - 1) / S * S;
		if (C > 1000000000)
			C = 1000000000 / S * S;
	}
	if (g != K || C != p->C)
		note(p, "restiffen %d: a halo exchange every %d step%s, checkpoints every %lld "
		     "steps (K is re-assembled where the peers exchange and restart)", S, g,
		     g == 1 ? "" : "s", (long long)C);
	p->K = g;
	p->C = (int)C;
}

/* ---- the public calls ----------------------------------------------------------- */
int ndo_peer_update(ndo_peer *p, double now)
{
	ndo__clear_error();
	p->now = now;
	if (p->created < 0)
		p->created = now;
	if (p->done)
		return NDO_PEER_DONE;
	if (p->ended)
		return NDO_PEER_ENDED;
	int rc = ndo_session_update(p->s, now);
	if (rc < 0)
		return rc;
	if (p->failed)
		return ndo__fail(p->failed, "out of memory");
	if ((rc = events(p)))
		return rc;
	/* while the run is under way the owner's death does not end the
	 * session: its successor restarts every peer from a checkpoint (every
	 * simulating peer keeps them all) or, without checkpoints, takes the
	 * regions over from frames (ndo_session_set_succession).  Before the
	 * start it ends it; after this peer's last step too, unless a restart
	 * can redo what the owner had not gathered (it may not even have taken
	 * its own last step): until its leave, its silence is a death */
	if (p->started)
		ndo_session_set_succession(p->s, p->sim &&
		                                     ((p->simulating ? p->cur : p->max_seen) < p->final ||
		                                      restartable(p)));
	else if (!p->owner && !p->simulating)
		/* not started and outside the partition (an observer, a joiner
		 * on its way in): it cannot be the successor, and follows one.
		 * Until 2026-11-30 an observer that had the description but not
		 * yet the whole object when the owner died took the successor
		 * for a stranger (its rest tiles too: they come from the owner
		 * only) and waited for the dead owner until its start timeout
		 * (peers-owner.sh under load; test_peer
		 * an_observer_on_its_way_follows_the_successor) */
		ndo_session_set_succession(p->s, 1);
	if (p->ended) {
		/* an owner ends only by gathering (done, above): ended, it gave
		 * way to a successor (after its last step too: it had not
		 * gathered).  A simulating joiner past its last step whose owner
		 * fell silent (a run that cannot restart: no successor) holds the
		 * owner's region of the last step only if its last frame came:
		 * until 2026-11-30 it ended done with those nodes at older steps,
		 * 0.9 of the largest displacement off, and wrote them to -o
		 * (test_peer the_owners_death_costs_a_restart, the owner killed at
		 * step 296 of 300 without checkpoints).  The owner's leave after
		 * it gathered keeps the old rule: the run completed, and -o is the
		 * object as this peer holds it (ungathered counts what is older) */
		int complete = !p->owner && p->started &&
		               (p->simulating ? p->cur >= p->final &&
		                                    (p->end_reason != NDO_LEAVE_TIMEOUT || holds_last(p))
		                              : holds_last(p));
		if (!complete && !p->owner && p->simulating && p->cur >= p->final &&
		    p->end_reason == NDO_LEAVE_TIMEOUT) {
			size_t n = strlen(p->message);
			snprintf(p->message + n, sizeof p->message - n,
			         "; %zu nodes of step %lld never arrived here: no result",
			         behind_last(p), (long long)p->final);
		}
		/* a run of no steps (-n 0): the owner held the whole first step,
		 * gathered and ended at once, before this joiner started; it
		 * holds the object at that step, the run's result (until
		 * 2026-12-01 it ended "the session ended at step 0", exit 4) */
		if (!p->owner && !p->started && p->sim && p->final <= p->first &&
		    p->end_reason != NDO_LEAVE_TIMEOUT) {
			p->cur = p->first;
			complete = 1;
		}
		if (complete) {
			/* what -o holds of older steps: the others' last tiles lost
			 * (every copy) before the owner's leave */
			if (p->simulating)
				p->st.ungathered = (int64_t)behind_last(p);
			p->done = 1;
			return NDO_PEER_DONE;
		}
		return NDO_PEER_ENDED;
	}
	if (p->rs_step >= 0) {
		if ((rc = restart_try(p)))
			return rc;
		if (p->rs_step >= 0)
			return resend_due(p);
	}
	if ((rc = ck_ask(p)))
		return rc;
	if (!p->started)
		return starting(p);
	/* an observer of an exact lock-step run that holds every node's last
	 * step has all it will get: those values are the run's (a restart
	 * after a lost owner computes them again bit for bit), so it does not
	 * wait for the owner's leave, whose three copies may all be lost
	 * (test_peer OBS_SEED 187: it waited a timeout for the successor and
	 * another for the next peer) */
	if (!p->owner && !p->simulating && p->exact && p->clock == NDO_CLOCK_LOCKSTEP &&
	    holds_last(p)) {
		snprintf(p->message, sizeof p->message, "run complete at step %lld",
		         (long long)p->final);
		p->done = 1;
		return NDO_PEER_DONE;
	}
	if (p->cur >= p->final)
		return finishing(p);
	if (!p->simulating)
		return NDO_PEER_WAITING;
	return p->clock == NDO_CLOCK_REALTIME ? realtime(p) : lockstep(p);
}

double ndo_peer_deadline(const ndo_peer *p)
{
	double now = p->now, d = now + IDLE_WAIT;
	if (p->done || p->ended)
		return d;
	if (p->rs_step >= 0)
		return fmin(d, p->resend.at);
	if (!p->started)
		return d;
	if (p->rb)
		d = fmin(d, ndo__rb_next_resend(p->rb));
	if (p->cur >= p->final) {
		if (p->owner || (p->rb && !p->last_sent))
			d = fmin(d, p->gather_t0 + p->o.gather_timeout);
		if (p->owner && p->gathered_at >= 0)
			d = fmin(d, p->gathered_at + LAST_GAPS * p->o.resend);
		return p->simulating ? fmin(d, p->resend.at) : d;
	}
	if (!p->simulating)
		return d;
	if (p->clock == NDO_CLOCK_REALTIME)
		return p->max_seen > p->cur ? now
		                            : fmin(d, p->wall0 + (double)(p->cur + 1 - p->sched0) *
		                                                     p->dt / p->speed);
	if (!p->blocked)
		return now; /* it may step: ask again at once */
	/* the step timeout, until it has passed: after it a peer that waits
	 * on for a neighbour still alive (neighbours_alive, members_alive)
	 * sleeps until a message, a re-send or IDLE_WAIT.  Until 2026-11-30
	 * the passed timeout stayed the deadline, and such a peer spun: 7
	 * joiners of a level-9 run on 2 cores, restarting after their owner
	 * was taken for lost, each burnt 30 % of a core for minutes in
	 * lockstep()'s checks (tests/bench/peers.sh, 8 peers) */
	double t0 = p->exact && p->ps ? p->split_t0 : p->block_t0, to = t0 + p->step_timeout;
	return fmin(d, to > now ? fmin(p->resend.at, to) : p->resend.at);
}

int ndo_peer_create(const ndo_peer_opts *o, ndo_net *net, ndo_grid *grid, ndo_sim *sim,
                    const ndo_peer_run *run, ndo_peer **out)
{
	ndo__clear_error();
	int owner = o->session.role == NDO_ROLE_OWNER;
	ndo_peer *p = calloc(1, sizeof *p);
	if (!p || (owner && (!grid || !sim || !run || !(run->dt > 0) || run->steps < 0)) ||
	    (!owner && (grid || sim || run))) {
		ndo_net_destroy(net);
		ndo_grid_destroy(grid);
		ndo_sim_destroy(sim);
		free(p);
		return p ? ndo__fail(NDO_EINVAL, "peer: an owner needs a grid, its simulation and "
		                     "a run; a joiner none") : ndo__fail(NDO_ENOMEM, "out of memory");
	}
	p->o = *o;
	if (!(p->o.step_timeout > 0)) p->o.step_timeout = 0.5;
	if (!(p->o.speed > 0)) p->o.speed = 1;
	if (!(p->o.start_timeout > 0)) p->o.start_timeout = 60;
	if (!(p->o.resend > 0)) p->o.resend = 0.01;
	if (!(p->o.gather_timeout > 0)) p->o.gather_timeout = 10;
	p->owner = owner;
	p->clock = o->clock ? o->clock : NDO_CLOCK_LOCKSTEP;
	p->step_timeout = p->o.step_timeout;
	p->hold = o->hold_boundary != 0;
	p->K = o->halo_steps > 0 ? o->halo_steps : 1;
	p->ahead = -1;
	p->N = o->publish_every > 0 ? o->publish_every : o->publish_every < 0 ? -1 : 10;
	p->speed = p->o.speed;
	p->peers_needed = o->peers > 1 ? o->peers : 1;
	p->sim = sim;
	p->gather_t0 = -1;
	p->gathered_at = -1;
	p->C = o->checkpoint_every > 0   ? o->checkpoint_every
	       : o->checkpoint_every < 0 ? 0
	                                 : ndo_peer_checkpoint_default(grid ? grid->level : 0);
	p->rs_step = p->ck_skip = p->ck_at = p->ck_last = p->ck_answer_step = -1;
	p->inexact_at = -1;
	p->fill_step = -1;
	p->max_seen = -1;
	p->exact_epoch = -1;
	p->created = -1;
	ndo_session_opts so = o->session;
	if (!(so.retry > 0))
		so.retry = 0.25; /* a joiner asks again soon: the snapshot is many tiles */
	so.tile_fn = on_tile;
	so.halo_fn = on_halo;
	so.solve_fn = on_solve;
	so.tile_user = p;
	/* a peer outside the partition — an observer, a joiner building its
	 * simulation — may be silent as long as a joiner may take to come */
	if (!(so.outside_timeout > 0))
		so.outside_timeout = p->o.start_timeout;
	/* A joiner asks for its share only once it can step it: building the
	 * simulation is one long call without heartbeats (7 s at level 10 on a
	 * loaded machine), and a partition that gives it a region meanwhile
	 * makes the owner count its silence, and drop it, before the start, and
	 * holds the others' lock-step in a run under way. */
	p->poi_held = -1;
	if (!owner && so.poi >= 0) {
		p->poi_held = so.poi;
		p->wants_share = 1;
		so.poi = -1;
	}
	if (owner) {
		p->dt = run->dt;
		p->cur = p->first = grid->step;
		p->tcur = grid->time;
		p->final = grid->step + run->steps;
		ndo_sim_set_first_step(sim, p->first);
		restiffen_align(p, ndo_sim_restiffen_every(sim));
		/* the steps whose whole regions go out, for watches that count
		 * what they lost (ndo/watch.h): exact lock-step every N (0: the
		 * first and last only), otherwise every step */
		ndo_method m = ndo_sim_method(sim);
		int split = ndo__ps_method(m), rings = ndo_peer_halo_rings(m) > 0;
		int exact = !p->hold && (p->clock == NDO_CLOCK_LOCKSTEP ? rings || split
		                                                        : rings && !split);
		char peer_lines[400];
		snprintf(peer_lines, sizeof peer_lines,
		         "dt %.17g\nsteps %lld\npeer-clock %d\npeer-hold-boundary %d\n"
		         "peer-halo-steps %d\npeer-publish-every %d\npeer-step-timeout %.17g\n"
		         "peer-speed %.17g\npeer-peers %d\npeer-first-step %lld\n"
		         "peer-final-step %lld\npeer-frames-every %d\npeer-checkpoint-every %d\n",
		         run->dt, (long long)run->steps, (int)p->clock, p->hold, p->K, p->N,
		         p->step_timeout, p->speed,
		         p->peers_needed, (long long)p->first, (long long)p->final,
		         exact ? (p->N > 0 ? p->N : 0) : 1, p->C);
		size_t len = strlen(run->physics) + strlen(peer_lines) + 1;
		if (len > NDO_MAX_SCENE + 1) {
			ndo_net_destroy(net);
			ndo_grid_destroy(grid);
			ndo_peer_destroy(p, NULL);
			return ndo__fail(NDO_ERANGE, "the physics settings take %zu bytes; a description "
			                 "holds %d", len - 1, NDO_MAX_SCENE);
		}
		p->scene = malloc(len);
		if (!p->scene) {
			ndo_net_destroy(net);
			ndo_grid_destroy(grid);
			ndo_peer_destroy(p, NULL);
			return ndo__fail(NDO_ENOMEM, "out of memory");
		}
		snprintf(p->scene, len, "%s%s", run->physics, peer_lines);
		so.scene = p->scene;
	}
	int rc = ndo_session_create(&so, net, grid, &p->s);
	if (rc) {
		p->s = NULL;
		ndo_peer_destroy(p, NULL);
		return rc;
	}
	if (owner)
		ndo_session_set_exact_step(p->s, p->final);
	/* until the run starts (go(); the owner: starting()), the start
	 * timeout bounds the wait */
	ndo_session_set_grace(p->s, p->o.start_timeout);
	if (!p->o.keep_tiles)
		ndo_net_set_tile_want(ndo_session_net(p->s), tile_wanted, p);
	if (owner && ((rc = arrays(p)) || (rc = region(p)))) {
		ndo_peer_destroy(p, NULL);
		return rc;
	}
	*out = p;
	return 0;
}

void ndo_peer_leave(ndo_peer *p, const char *message)
{
	if (!p || !p->s)
		return;
	char msg[128];
	if (!message && p->owner && p->done)
		snprintf(msg, sizeof msg, "run complete at step %lld", (long long)p->final);
	else
		snprintf(msg, sizeof msg, "%s", message ? message : "");
	ndo_session_leave(p->s, msg);
}

void ndo_peer_destroy(ndo_peer *p, const char *message)
{
	if (!p)
		return;
	ndo_peer_leave(p, message);
	ndo_session_destroy(p->s, NULL);
	ndo_sim_destroy(p->sim);
	ndo_grid_destroy(p->prev);
	for (size_t k = 0; k < p->nstash; k++)
		free(p->stash[k].values);
	free(p->stash);
	free(p->scene);
	free(p->canon), free(p->canons), free(p->nstep), free(p->mask), free(p->halo);
	free(p->hx), free(p->hv), free(p->xs), free(p->vs);
	free(p->own), free(p->ownc), free(p->orun), free(p->hmark), free(p->act), free(p->dist);
	free(p->strip);
	free(p->hu), free(p->sbuf[0]), free(p->sbuf[1]);
	for (size_t k = 0; k < p->nhstash; k++)
		halo_free(&p->hstash[k]);
	free(p->hstash);
	ndo__ps_destroy(p->ps);
	ndo__rb_destroy(p->rb);
	ndo__ck_destroy(p->ck);
	free(p);
}

ndo_grid *ndo_peer_grid(ndo_peer *p)
{
	if (p->exact)
		sync_own(p);
	return ndo_session_grid(p->s);
}
ndo_sim *ndo_peer_sim(ndo_peer *p) { return p->sim; }
ndo_session *ndo_peer_session(ndo_peer *p) { return p->s; }
int64_t ndo_peer_step(const ndo_peer *p) { return p->cur; }
int64_t ndo_peer_first_step(const ndo_peer *p) { return p->first; }
int64_t ndo_peer_final_step(const ndo_peer *p) { return p->final; }
double ndo_peer_dt(const ndo_peer *p) { return p->dt; }
ndo_clock ndo_peer_clock(const ndo_peer *p) { return p->clock; }
const char *ndo_peer_message(const ndo_peer *p) { return p->message; }
void ndo__peer_deaf_to_checkpoints(ndo_peer *p, double until) { p->ck_deaf_until = until; }
int ndo__peer_ask_checkpoint(ndo_peer *p, int64_t step) { return ck_ask_send(p, step); }

size_t ndo__peer_stash_bytes(const ndo_peer *p)
{
	size_t n = p->ps ? ndo__ps_stash_bytes(p->ps) : 0;
	for (size_t k = 0; k < p->nstash; k++)
		n += tile_size(&p->stash[k]);
	for (size_t k = 0; k < p->nhstash; k++)
		n += halo_size(&p->hstash[k]);
	return n;
}
int ndo_peer_simulating(const ndo_peer *p) { return p->simulating; }
int ndo_peer_started(const ndo_peer *p) { return p->started; }
void ndo_peer_stats_get(const ndo_peer *p, ndo_peer_stats *st)
{
	*st = p->st;
	st->exact = p->exact;
	st->inexact_at = p->inexact ? p->inexact_at : -1;
	st->inexact_peer = p->inexact ? p->inexact_from : 0;
	st->halo_rings = p->exact ? p->W : 1;
	if (p->ps) {
		ndo__ps_stats ps;
		ndo__ps_stats_get(p->ps, &ps);
		st->exchanges += ps.phases;
		st->halo_tiles += ps.messages;
		st->halo_bytes += ps.bytes;
		st->attempts = ps.attempts;
		st->rejected = ps.rejected;
		st->solves = ps.solves;
		st->iterations = ps.iterations;
	}
	if (p->rb) {
		ndo__rb_stats rs;
		ndo__rb_stats_get(p->rb, &rs);
		st->rollback = 1;
		st->exchanges += rs.strips;
		st->halo_tiles += rs.messages;
		st->halo_bytes += rs.bytes;
		st->rollbacks = rs.rollbacks;
		st->recomputed = rs.recomputed;
		st->rollback_depth = rs.depth_max;
		st->predicted = rs.predicted;
		st->window = rs.window;
		st->confirmed = rs.exact && ndo__rb_confirmed(p->rb, p->final);
		st->frontier = ndo__rb_frontier(p->rb);
		st->shown_error = rs.shown_error;
		st->shown_disp = rs.shown_disp;
		st->shown_frames = rs.shown_frames;
		st->shown_wrong = rs.shown_wrong;
	}
}
