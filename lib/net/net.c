/* net.c — typed messages over a link (ndo/net.h). */
#include "ndo/net.h"
#include "ndo/auth.h"
#include "ndo/quadtree.h"
#include "ndo/status.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/random.h>
#include <sys/time.h>
#include <time.h>
#include <unistd.h>

#define MAX_SENDERS 64
/* Tiles held for their reference (struct ndo_net's held): at most this
 * many at once (which goes first, as `nobase`: evictee()), each at most
 * this long — a reference lost, not late, is replaced by the next
 * keyframe. */
#define HOLD_MAX 64
#define HOLD_SECONDS 1.0
/* Tiles whose keyframe was asked for lately, by this receiver or another
 * (ndo_net_ask_keys): the oldest forgotten beyond this many. */
#define ASKED_MAX 256

typedef struct sender {
	int32_t id;
	int64_t last[NDO_MSG_NTYPES]; /* last accepted seq, −1 none */
	int64_t seen[NDO_MSG_NTYPES]; /* newest seq arrived (held or not), −1 none */
	double heard;
} sender;

/* Sequence numbers found missing (a later one arrived first), to time the
 * ones that come late: how late reordered messages are here, remembered
 * over LATE_MEMORY seconds (many messages a little late — jitter — must
 * not make a receiver forget the few that come much later). */
#define GAPS_MAX 32
#define LATE_MEMORY 10.0

typedef struct tile_slot {
	int32_t sender;  /* 0: empty */
	int32_t code;
	int16_t channels;
	int64_t seq;     /* newest accepted */
	ndo_msg *pending;
} tile_slot;

struct ndo_net {
	ndo_link *link;
	char prefix[72];
	char channel[NDO_MSG_NTYPES][96];
	ndo_msg_ctx ctx;
	int64_t seq_out[NDO_MSG_NTYPES];
	sender senders[MAX_SENDERS];
	int nsenders;
	tile_slot *slots;
	size_t nslots, used;
	ndo_msg *queue;
	size_t qhead, qcount, qcap;
	int keep_all; /* tiles queue in arrival order too (ndo_net_keep_all_tiles) */
	int skipped;  /* and skipped steps' tiles are made (ndo_net_skipped_tiles) */
	ndo_codec *codec;
	ndo_codec *ccodec; /* tiles of the send level (NDO_TILE_COARSE), or NULL */
	ndo_codec_params cp;
	ndo_auth *auth; /* keyed session (ndo_net_set_key), else NULL */
	ndo_net_tile_want_fn want; /* ndo_net_set_tile_want, else NULL */
	void *want_user;
	int32_t other_owner; /* the sender of another object's description */
	ndo_net_stats st;
	double now;
	/* messages that arrived before the object was known (a description
	 * and the tiles right behind it come in one burst): kept as bytes and
	 * looked at again by ndo_net_attach() */
	struct parked {
		int type;
		uint8_t *data; /* authenticated and fresh in a keyed session: no trailer */
		size_t len;
	} *park;
	size_t npark, parkcap, parkbytes;
	/* encoded tiles that came before their reference frame (reordered):
	 * held, undecoded, until it is decoded (then they are), it can no
	 * longer come, or HOLD_SECONDS pass (then they are `nobase`) */
	struct held {
		ndo_msg m;
		double since;
		int unknown; /* of a tile no frame of which was decoded here (evictee) */
	} held[HOLD_MAX];
	int nheld;
	int ask;         /* ndo_net_ask_keys */
	double ask_wait; /* s from a request to its keyframe, smoothed */
	double late;     /* s a reordered message came after its gap was seen: the
	                    largest, decaying by e every LATE_MEMORY s since late_at */
	double late_at;
	struct gap {
		int32_t sender;
		int type;
		int64_t lo, hi; /* missing seqs lo..hi */
		double at;      /* when found missing */
	} gaps[GAPS_MAX];
	int ngaps, gapnext;
	struct asked {
		int32_t sender, code;
		int coarse;
		double at;
	} asked[ASKED_MAX];
	int nasked;
};

#define PARK_MAX_BYTES (32u << 20)

int ndo_net_create(ndo_link *link, const char *prefix, int32_t self_id, ndo_net **out)
{
	ndo__clear_error();
	if (!prefix || strlen(prefix) > 64 || self_id == 0) {
		ndo_link_destroy(link);
		return ndo__fail(NDO_EINVAL, "net: bad prefix or sender id");
	}
	ndo_net *n = calloc(1, sizeof *n);
	if (!n) {
		ndo_link_destroy(link);
		return ndo__fail(NDO_ENOMEM, "out of memory");
	}
	n->link = link;
	snprintf(n->prefix, sizeof n->prefix, "%s", prefix);
	for (int t = 0; t < NDO_MSG_NTYPES; t++)
		snprintf(n->channel[t], sizeof n->channel[t], "%s_%s", prefix,
		         ndo_msg_suffix((ndo_msg_type)t));
	n->ctx = (ndo_msg_ctx){.object_id = 0, .level = -1, .self_id = self_id};
	*out = n;
	return 0;
}

static void clear_tiles(ndo_net *n)
{
	for (size_t k = 0; k < n->nslots; k++)
		if (n->slots[k].pending) {
			ndo_msg_free(n->slots[k].pending);
			free(n->slots[k].pending);
			n->slots[k].pending = NULL;
		}
}

/* Drop held tile k, counted `nobase` when `count`; the last one takes its
 * place (its header pointing at its own copy, as every held one's does). */
static void unhold(ndo_net *n, int k, int count)
{
	ndo_msg_free(&n->held[k].m);
	n->held[k] = n->held[--n->nheld];
	n->held[k].m.hdr = (const ndo_msg_header_t *)&n->held[k].m.u;
	n->st.holding = (uint64_t)n->nheld;
	if (count)
		n->st.dropped[NDO_DROP_NOBASE]++;
}

static void unhold_all(ndo_net *n, int count)
{
	while (n->nheld)
		unhold(n, n->nheld - 1, count);
}

static void unpark_all(ndo_net *n)
{
	for (size_t k = 0; k < n->npark; k++)
		free(n->park[k].data);
	n->npark = n->parkbytes = 0;
}

void ndo_net_destroy(ndo_net *n)
{
	if (!n)
		return;
	unpark_all(n);
	free(n->park);
	unhold_all(n, 0);
	ndo_auth_destroy(n->auth);
	ndo_codec_destroy(n->codec);
	ndo_codec_destroy(n->ccodec);
	clear_tiles(n);
	free(n->slots);
	for (size_t k = 0; k < n->qcount; k++)
		ndo_msg_free(&n->queue[(n->qhead + k) % n->qcap]);
	free(n->queue);
	ndo_link_destroy(n->link);
	free(n);
}

ndo_msg_ctx *ndo_net_ctx(ndo_net *n) { return &n->ctx; }
void ndo_net_keep_all_tiles(ndo_net *n, int on) { n->keep_all = on != 0; }
void ndo_net_skipped_tiles(ndo_net *n, int on) { n->skipped = on != 0; }
const ndo_codec *ndo_net_codec(const ndo_net *n) { return n->codec; }

int ndo_net_set_codec(ndo_net *n, const ndo_codec_params *p, int level)
{
	unhold_all(n, 1);
	ndo_codec_destroy(n->codec);
	ndo_codec_destroy(n->ccodec);
	n->codec = n->ccodec = NULL;
	n->ctx.coarse = 0;
	n->cp = *p;
	if (p->encoding == NDO_ENC_RAW)
		return 0;
	return ndo_codec_create(p, level, &n->codec);
}

int ndo_net_set_send_level(ndo_net *n, int send_level, int level)
{
	unhold_all(n, 1);
	ndo_codec_destroy(n->ccodec);
	n->ccodec = NULL;
	n->ctx.coarse = 0;
	if (send_level < 0 || send_level > level)
		return ndo__fail(NDO_EINVAL, "send level %d for a level-%d object", send_level, level);
	n->ctx.coarse = level - send_level;
	if (n->cp.encoding == NDO_ENC_RAW || send_level == level)
		return 0;
	return ndo_codec_create(&n->cp, send_level, &n->ccodec);
}

const ndo_codec *ndo_net_coarse_codec(const ndo_net *n) { return n->ccodec; }
ndo_link *ndo_net_link(const ndo_net *n) { return n->link; }
int ndo_net_keyed(const ndo_net *n) { return n->auth != NULL; }

int ndo_net_set_key(ndo_net *n, const ndo_key *key)
{
	ndo_auth_destroy(n->auth);
	n->auth = NULL;
	return key ? ndo_auth_create(key, &n->auth) : 0;
}
const ndo_net_stats *ndo_net_stats_get(const ndo_net *n) { return &n->st; }
const char *ndo_net_channel(const ndo_net *n, ndo_msg_type t) { return n->channel[t]; }

int ndo_net_publish(ndo_net *n, ndo_msg_type t, void *msg)
{
	if ((unsigned)t >= NDO_MSG_NTYPES)
		return ndo__fail(NDO_EINVAL, "publish: bad type");
	ndo_msg_header_t *h = msg; /* every type starts with its header */
	struct timeval tv;
	gettimeofday(&tv, NULL);
	h->version = NDO_PROTOCOL_VERSION;
	h->object_id = n->ctx.object_id;
	h->sender_id = n->ctx.self_id;
	h->seq = n->seq_out[t]++;
	h->utime = (int64_t)tv.tv_sec * 1000000 + tv.tv_usec;
	uint8_t *buf;
	size_t len;
	int rc = ndo_msg_encode(t, msg, &buf, &len);
	if (rc)
		return rc;
	size_t wire = len + (n->auth ? NDO_AUTH_TRAILER : 0);
	if (wire > ndo_msg_max_payload(n->channel[t])) {
		free(buf);
		n->st.publish_failed++;
		return ndo__fail(NDO_ERANGE, "%s: %zu bytes do not fit one datagram (%zu)",
		                 n->channel[t], wire, ndo_msg_max_payload(n->channel[t]));
	}
	if (n->auth) {
		uint8_t *b = realloc(buf, wire);
		if (!b) {
			free(buf);
			return ndo__fail(NDO_ENOMEM, "out of memory");
		}
		buf = b;
		if ((rc = ndo_auth_seal(n->auth, n->channel[t], buf, len)) != 0) {
			free(buf);
			return rc;
		}
		len = wire;
	}
	rc = ndo_link_publish(n->link, n->channel[t], buf, len);
	free(buf);
	if (rc) {
		n->st.publish_failed++;
		return rc;
	}
	n->st.published++;
	n->st.bytes_out += len;
	return 0;
}

static sender *find_sender(ndo_net *n, int32_t id, int create)
{
	for (int k = 0; k < n->nsenders; k++)
		if (n->senders[k].id == id)
			return &n->senders[k];
	if (!create)
		return NULL;
	int k = n->nsenders;
	if (k == MAX_SENDERS) { /* forget the one heard from longest ago */
		k = 0;
		for (int q = 1; q < MAX_SENDERS; q++)
			if (n->senders[q].heard < n->senders[k].heard)
				k = q;
	} else {
		n->nsenders++;
	}
	n->senders[k].id = id;
	for (int t = 0; t < NDO_MSG_NTYPES; t++)
		n->senders[k].last[t] = n->senders[k].seen[t] = -1;
	return &n->senders[k];
}

static size_t slot_hash(int32_t sender, int32_t code, int16_t ch, size_t mask)
{
	uint64_t h = (uint64_t)(uint32_t)sender * 0x9e3779b97f4a7c15ull ^
	             (uint64_t)(uint32_t)code * 0xc2b2ae3d27d4eb4full ^ (uint64_t)(uint16_t)ch;
	return (size_t)(h ^ (h >> 29)) & mask;
}

/* Is slot o still of use: a tile waits in it, or its sender is still in
 * the senders' table (which forgets the least recently heard beyond
 * MAX_SENDERS; then that sender's sequence numbers are gone anyway)? */
static int slot_live(ndo_net *n, const tile_slot *o)
{
	return o->sender && (o->pending || find_sender(n, o->sender, 0));
}

static tile_slot *find_slot(ndo_net *n, int32_t sender, int32_t code, int16_t ch)
{
	if (n->used * 2 >= n->nslots) {
		/* rehash without the slots of forgotten senders, larger when the
		 * others fill more than a quarter (so that a quarter of it comes
		 * in before the next rehash): until 2026-11-30 a slot stayed for
		 * good, and a flood of tiles under new ids grew the table (and
		 * every ndo_net_take_tiles' scan) a slot a message */
		size_t live = 0;
		for (size_t k = 0; k < n->nslots; k++)
			live += (size_t)slot_live(n, &n->slots[k]);
		size_t cap = n->nslots ? n->nslots : 256;
		while (4 * (live + 1) > cap)
			cap *= 2;
		tile_slot *s = calloc(cap, sizeof *s);
		if (!s)
			return NULL;
		for (size_t k = 0; k < n->nslots; k++) {
			tile_slot *o = &n->slots[k];
			if (!slot_live(n, o))
				continue;
			size_t i = slot_hash(o->sender, o->code, o->channels, cap - 1);
			while (s[i].sender)
				i = (i + 1) & (cap - 1);
			s[i] = *o;
		}
		free(n->slots);
		n->slots = s;
		n->nslots = cap;
		n->used = live;
		n->st.tile_slots = cap;
	}
	size_t i = slot_hash(sender, code, ch, n->nslots - 1);
	while (n->slots[i].sender &&
	       !(n->slots[i].sender == sender && n->slots[i].code == code &&
	         n->slots[i].channels == ch))
		i = (i + 1) & (n->nslots - 1);
	if (!n->slots[i].sender) {
		n->slots[i] = (tile_slot){sender, code, ch, -1, NULL};
		n->used++;
	}
	return &n->slots[i];
}

static int enqueue(ndo_net *n, ndo_msg *m)
{
	if (n->qcount == n->qcap) {
		size_t cap = n->qcap ? 2 * n->qcap : 64;
		ndo_msg *q = malloc(cap * sizeof *q);
		if (!q)
			return -1;
		for (size_t k = 0; k < n->qcount; k++)
			q[k] = n->queue[(n->qhead + k) % n->qcap];
		free(n->queue);
		n->queue = q;
		n->qhead = 0;
		n->qcap = cap;
	}
	n->queue[(n->qhead + n->qcount++) % n->qcap] = *m;
	/* the union moved: point the header at the copy */
	ndo_msg *c = &n->queue[(n->qhead + n->qcount - 1) % n->qcap];
	c->hdr = (const ndo_msg_header_t *)&c->u;
	return 0;
}

/* A raw tile of another sender that the receiver does not use
 * (ndo_net_set_tile_want): 1 when passed over — its sequence number taken
 * as seen, its counter in a keyed session as used (a replay of it is
 * dropped as one) — 0 to decode it. */
static int unwanted(ndo_net *n, const uint8_t *data, size_t len, int sealed,
                    const ndo_auth_from *from)
{
	int64_t seq, step;
	int channels, encoding;
	int32_t id = ndo_msg_peek_tile(data, len, &seq, &step, &channels, &encoding);
	if (!id || id == n->ctx.self_id || encoding != NDO_ENC_RAW ||
	    n->want(n->want_user, id, step, channels))
		return 0;
	if (sealed && !ndo_auth_fresh(n->auth, id, from, n->now)) {
		n->st.dropped[NDO_DROP_REPLAY]++;
		return 1;
	}
	sender *s = find_sender(n, id, 1);
	s->heard = n->now;
	if (seq > s->last[NDO_MSG_TILE])
		s->last[NDO_MSG_TILE] = seq;
	n->st.unwanted++;
	return 1;
}

void ndo_net_set_tile_want(ndo_net *n, ndo_net_tile_want_fn want, void *user)
{
	n->want = want;
	n->want_user = user;
}

/* Message seq of type t from sender s, about to be accepted: the gap it
 * opens after its sender's newest, or one it fills (reordered, not lost).
 * Only for messages kept — a stale copy fills no gap (until 2026-11-30 a
 * duplicate counted `late` and took a gap back before it was dropped) —
 * and with no sum that overflows (seq is any value ≥ 0: a hostile
 * INT64_MAX was `last + 1` past the range). */
static void count_gaps(ndo_net *n, const sender *s, int t, int64_t seq)
{
	if (s->last[t] >= 0 && seq - 1 > s->last[t])
		n->st.gaps += (uint64_t)(seq - s->last[t] - 1);
	else if (seq < s->last[t] && n->st.gaps > 0) {
		n->st.gaps--;
		n->st.late++;
	}
}

/* An accepted message (a tile decoded), by its sender's sequence numbers:
 * queued, or a tile kept as its range's newest; freed when stale. */
static void accept(ndo_net *n, int t, ndo_msg *m)
{
	sender *s = find_sender(n, m->hdr->sender_id, 1);
	s->heard = n->now;
	int64_t seq = m->hdr->seq;
	if ((t == NDO_MSG_TILE && n->keep_all) || t == NDO_MSG_HALO || t == NDO_MSG_SOLVE) {
		/* the caller orders tiles by their step: a tile sent again (an
		 * older step after a newer one) is not stale here; nor are halos
		 * and split steps' phases (ndo/peer.h orders them by step and
		 * phase): a re-sent strip overtaken by a later message — the next
		 * strip of the same re-send, a checkpoint — was dropped, and a
		 * lock-step peer waited for it until its step timeout */
		count_gaps(n, s, t, seq);
		if (seq > s->last[t])
			s->last[t] = seq;
		if (enqueue(n, m) != 0) {
			ndo_msg_free(m);
			return;
		}
		n->st.accepted++;
		return;
	}
	if (t == NDO_MSG_TILE) {
		ndo_quad q;
		/* a tile of the send level: a node of the coarser grid's tree */
		int level = n->ctx.level - ((m->u.tile.channels & NDO_TILE_COARSE) ? n->ctx.coarse : 0);
		ndo_quad_from_range(level, m->u.tile.depth, m->u.tile.i0, m->u.tile.j0, m->u.tile.i1,
		                    m->u.tile.j1, &q);
		tile_slot *slot = find_slot(n, m->hdr->sender_id, ndo_quad_code(q), m->u.tile.channels);
		ndo_msg *keep = malloc(sizeof *keep);
		if (!slot || !keep) {
			free(keep);
			ndo_msg_free(m);
			return;
		}
		if (seq <= slot->seq) {
			free(keep);
			n->st.dropped[NDO_DROP_STALE]++;
			ndo_msg_free(m);
			return;
		}
		count_gaps(n, s, t, seq);
		if (seq > s->last[t])
			s->last[t] = seq;
		slot->seq = seq;
		if (slot->pending) {
			n->st.superseded++;
			ndo_msg_free(slot->pending);
			free(slot->pending);
		}
		*keep = *m;
		keep->hdr = (const ndo_msg_header_t *)&keep->u;
		slot->pending = keep;
		n->st.accepted++;
		return;
	}
	if (seq <= s->last[t]) {
		n->st.dropped[NDO_DROP_STALE]++;
		ndo_msg_free(m);
		return;
	}
	count_gaps(n, s, t, seq);
	s->last[t] = seq;
	if (enqueue(n, m) != 0) {
		ndo_msg_free(m);
		return;
	}
	n->st.accepted++;
}

/* How late reordered messages come here now: the largest lateness seen,
 * decayed over the time since. */
static double late_now(const ndo_net *n)
{
	return n->late > 0 ? n->late * exp(-(n->now - n->late_at) / LATE_MEMORY) : 0;
}

/* A validated message's place in its sender's sequence, as it arrives
 * (held or not): a gap it opens is remembered, and a message that fills one
 * times how late reordered messages come here (late_now). */
static void note_order(ndo_net *n, int t, const ndo_msg_header_t *h)
{
	sender *s = find_sender(n, h->sender_id, 1);
	s->heard = n->now;
	int64_t seq = h->seq, seen = s->seen[t];
	if (seq > seen) {
		s->seen[t] = seq;
		if (seen >= 0 && seq > seen + 1) {
			n->gaps[n->gapnext] = (struct gap){h->sender_id, t, seen + 1, seq - 1, n->now};
			n->gapnext = (n->gapnext + 1) % GAPS_MAX;
			n->ngaps += n->ngaps < GAPS_MAX;
		}
		return;
	}
	for (int k = 0; k < n->ngaps; k++) {
		const struct gap *g = &n->gaps[k];
		if (g->sender == h->sender_id && g->type == t && seq >= g->lo && seq <= g->hi) {
			double late = n->now - g->at, was = late_now(n);
			if (late >= was) {
				n->late = late;
				n->late_at = n->now;
			}
			return;
		}
	}
}

/* The quad-tree code of a tile (of the send level's grid when coarse), or
 * −1 (a range that validated always has one). */
static int32_t tile_code(const ndo_net *n, const ndo_msg_tile_t *t)
{
	int level = n->ctx.level - ((t->channels & NDO_TILE_COARSE) ? n->ctx.coarse : 0);
	ndo_quad q;
	if (ndo_quad_from_range(level, t->depth, t->i0, t->j0, t->i1, t->j1, &q) != 0)
		return -1;
	return ndo_quad_code(q);
}

/* The entry of a tile asked for lately (NULL: none, or the oldest's slot
 * when `make`). */
static struct asked *asked_of(ndo_net *n, int32_t sender, int32_t code, int coarse, int make)
{
	int old = 0;
	for (int k = 0; k < n->nasked; k++) {
		struct asked *a = &n->asked[k];
		if (a->sender == sender && a->code == code && a->coarse == coarse)
			return a;
		if (a->at < n->asked[old].at)
			old = k;
	}
	if (!make)
		return NULL;
	struct asked *a = n->nasked < ASKED_MAX ? &n->asked[n->nasked++] : &n->asked[old];
	*a = (struct asked){sender, code, coarse, -1e300};
	return a;
}

/* Another receiver's request, accepted (not stale): those tiles count as
 * asked for, here too — unless they are this peer's own, which it never
 * holds (a sender flooded with requests does not scan its table for each),
 * or the request comes under their sender's own id: the sender drops
 * that as its own message looped back, so only a forgery says it, and
 * believed it would keep every receiver from asking (a rogue repeating it
 * every 10 ms cut a lossy watch's requests from 26 to 2). */
static void heard_ask(ndo_net *n, const ndo_msg_header_t *h, const ndo_msg_key_request_t *k)
{
	if (k->sender == n->ctx.self_id || h->sender_id == k->sender)
		return;
	for (int j = 0; j < k->ntiles; j++)
		asked_of(n, k->sender, k->codes[j], k->coarse, 1)->at = n->now;
}

/* The decoder of a tile: the send level's (NDO_TILE_COARSE) or the object's. */
static ndo_codec *codec_of(const ndo_net *n, const ndo_msg_tile_t *t)
{
	return (t->channels & NDO_TILE_COARSE) ? n->ccodec : n->codec;
}

/* An encoded tile decoded in place (and checked against the box), the
 * steps skipped before it queued (ndo_net_skipped_tiles): 0; or it was
 * dropped (counted, freed): −1 undecoded, 1 decoded but outside the box
 * (the codec keeps it as its tile's reference all the same, as for a frame
 * that comes after it in order). */
static int decode_encoded(ndo_net *n, ndo_msg *m)
{
	/* decoded here, in arrival order: each frame is a reference for
	 * the next ones, whoever uses it */
	ndo_codec *codec = codec_of(n, &m->u.tile);
	const int key = m->u.tile.base_step < 0;
	ndo_drop r = codec ? ndo_codec_decode_tile(codec, &m->u.tile) : NDO_DROP_ENCODING;
	const int decoded = r == NDO_DROP_NONE;
	if (decoded) /* the decoded state, against the box */
		r = ndo_msg_check_box(&m->u.tile, &n->ctx);
	if (r != NDO_DROP_NONE) {
		n->st.dropped[r]++;
		ndo_msg_free(m);
		return decoded ? 1 : -1;
	}
	m->decoded = 1;
	if (n->nasked) { /* its frames decode again: a loss asks again at once */
		int32_t code = tile_code(n, &m->u.tile);
		struct asked *a = asked_of(n, m->u.tile.hdr.sender_id, code,
		                           (m->u.tile.channels & NDO_TILE_COARSE) != 0, 0);
		if (a && a->at > -1e299) {
			if (key) /* the time from a request to its keyframe, smoothed */
				n->ask_wait += 0.125 * (n->now - a->at - n->ask_wait);
			a->at = -1e300;
		}
	}
	int skipped = n->skipped && n->keep_all ? ndo_codec_skipped(codec, &m->u.tile) : 0;
	for (int k = 0; k < skipped; k++) {
		ndo_msg sk;
		memset(&sk, 0, sizeof sk);
		sk.type = NDO_MSG_TILE;
		sk.decoded = 1;
		if (ndo_codec_skipped_tile(codec, &m->u.tile, k, &sk.u.tile) != 0)
			break;
		sk.hdr = (const ndo_msg_header_t *)&sk.u;
		if (enqueue(n, &sk) != 0) {
			ndo_msg_free(&sk);
			break;
		}
	}
	return 0;
}

/* A held tile of a tile this receiver never decoded a frame of: only a
 * reordered keyframe could bring its reference (a new sender's, or a
 * rogue's). */
static int unknown_tile(const ndo_net *n, const ndo_msg_tile_t *t)
{
	const ndo_codec *c = codec_of(n, t);
	return !c || !ndo_codec_tile_known(c, t);
}

/* The held tile given up when the array is full (*unknown_out: an unknown
 * tile's): the oldest unknown one; else the oldest of the sender holding
 * the most (and hold() gives up a new unknown tile rather than a known
 * one).  So a sender that floods the array with tiles whose reference
 * never comes, under one id or many, pushes out its own and not the
 * others' (when the oldest of all went, a rogue's 128 such tiles a step
 * cut a reordered stream from 299 frames of 300 to 171, and under a new
 * id each to 147; test_session a_flood_pushes_out_its_own_held_tiles).
 * At most HOLD_MAX² steps, only when full, and no codec lookup: each held
 * tile's `unknown` is taken when it is held and cleared when a frame of
 * its tile decodes (release_held). */
static int evictee(const ndo_net *n, int *unknown_out)
{
	int pick = -1, pick_unknown = 0, pick_count = 0;
	for (int k = 0; k < n->nheld; k++) {
		const ndo_msg_tile_t *t = &n->held[k].m.u.tile;
		const int unknown = n->held[k].unknown;
		int count = 0;
		for (int q = 0; !unknown && q < n->nheld; q++)
			count += n->held[q].m.u.tile.hdr.sender_id == t->hdr.sender_id;
		const int better = pick < 0                       ? 1
		                   : unknown != pick_unknown      ? unknown
		                   : !unknown && count != pick_count ? count > pick_count
		                   : n->held[k].since < n->held[pick].since;
		if (better)
			pick = k, pick_unknown = unknown, pick_count = count;
	}
	*unknown_out = pick_unknown;
	return pick;
}

/* An encoded tile whose reference has not come yet, but may (a frame
 * overtaken by the next): 1 when held, undecoded, until release_held()
 * decodes it.  Decoding it now would drop it, and with it every frame
 * predicted from it up to the next keyframe. */
static int hold(ndo_net *n, ndo_msg *m)
{
	const ndo_codec *codec = codec_of(n, &m->u.tile);
	if (!codec || ndo_codec_base_state(codec, &m->u.tile) != NDO_BASE_PENDING)
		return 0;
	const int unknown = unknown_tile(n, &m->u.tile);
	if (n->nheld == HOLD_MAX) {
		int full_unknown, k = evictee(n, &full_unknown);
		if (!full_unknown && unknown)
			return 0; /* this one goes (decoded: `nobase`), not a known tile */
		unhold(n, k, 1);
	}
	n->held[n->nheld] = (struct held){*m, n->now, unknown};
	n->held[n->nheld].m.hdr = (const ndo_msg_header_t *)&n->held[n->nheld].m.u;
	n->nheld++;
	n->st.held++;
	n->st.holding = (uint64_t)n->nheld;
	return 1;
}

/* The same sender's tile of the same range and level: only a frame of its
 * own tile is a held tile's reference. */
static int same_tile(const ndo_msg_tile_t *a, const ndo_msg_tile_t *b)
{
	return a->hdr.sender_id == b->hdr.sender_id && a->depth == b->depth && a->i0 == b->i0 &&
	       a->j0 == b->j0 && a->i1 == b->i1 && a->j1 == b->j1 &&
	       (a->channels & NDO_TILE_COARSE) == (b->channels & NDO_TILE_COARSE);
}

/* After tile `t` was decoded: every held tile of the same tile whose
 * reference is now here decoded and accepted, in step order (each may be
 * the next one's); one whose reference can no longer come dropped as
 * `nobase`. */
static void release_held(ndo_net *n, const ndo_msg_tile_t *t)
{
	for (int again = 1; again && n->nheld;) {
		again = 0;
		int pick = -1;
		for (int k = 0; k < n->nheld; k++) {
			const ndo_msg_tile_t *tl = &n->held[k].m.u.tile;
			if (!same_tile(tl, t))
				continue;
			n->held[k].unknown = 0; /* a frame of its tile decoded */
			const ndo_codec *c = codec_of(n, tl);
			int st = c ? ndo_codec_base_state(c, tl) : NDO_BASE_GONE;
			if (st == NDO_BASE_GONE) {
				unhold(n, k--, 1);
				continue;
			}
			if (st == NDO_BASE_READY && (pick < 0 || tl->step < n->held[pick].m.u.tile.step))
				pick = k;
		}
		if (pick >= 0) {
			ndo_msg m = n->held[pick].m;
			m.hdr = (const ndo_msg_header_t *)&m.u;
			n->held[pick] = n->held[--n->nheld];
			n->held[pick].m.hdr = (const ndo_msg_header_t *)&n->held[pick].m.u;
			n->st.holding = (uint64_t)n->nheld;
			if (decode_encoded(n, &m) == 0)
				accept(n, NDO_MSG_TILE, &m);
			again = 1;
		}
	}
}

void ndo_net_ask_keys(ndo_net *n, int on)
{
	n->ask = on != 0;
	if (n->ask_wait <= 0)
		n->ask_wait = NDO_NET_ASK_MIN;
}

int32_t ndo_net_new_id(void)
{
	uint32_t r = 0;
	if (getrandom(&r, sizeof r, GRND_NONBLOCK) != (ssize_t)sizeof r) {
		struct timespec ts; /* no entropy yet (early boot): the clock and the pid */
		clock_gettime(CLOCK_REALTIME, &ts);
		uint64_t h = ((uint64_t)ts.tv_nsec ^ (uint64_t)ts.tv_sec << 30 ^ (uint64_t)getpid() << 20) *
		             0x9e3779b97f4a7c15ull;
		r = (uint32_t)(h >> 32);
	}
	return (int32_t)((r & 0x7ffffffe) | 1);
}

/* At the end of a poll, the link drained: ask the senders of the tiles
 * held longer than reordered messages come late for keyframes — one request
 * per (sender, grid), tiles asked for lately left out.  A request that
 * cannot be sent is counted (publish_failed), not an error: the tile's next
 * periodic keyframe still comes. */
static void ask_keys(ndo_net *n)
{
	ndo_msg_key_request_t r[HOLD_MAX];
	int32_t codes[HOLD_MAX][HOLD_MAX];
	int nr = 0;
	/* asked again when twice the usual wait for a keyframe passed without
	 * one (the request or the keyframe lost) */
	const double again = fmin(NDO_NET_ASK_AGAIN, fmax(NDO_NET_ASK_MIN, 2 * n->ask_wait));
	/* and not before a reordered reference would have come */
	const double wait = fmin(NDO_NET_ASK_AGAIN, 1.5 * late_now(n));
	for (int k = 0; k < n->nheld; k++) {
		const ndo_msg_tile_t *t = &n->held[k].m.u.tile;
		if (n->now - n->held[k].since < wait)
			continue;
		int32_t code = tile_code(n, t);
		if (code < 0)
			continue;
		int coarse = (t->channels & NDO_TILE_COARSE) != 0;
		struct asked *a = asked_of(n, t->hdr.sender_id, code, coarse, 1);
		if (n->now - a->at < again)
			continue;
		a->at = n->now;
		int g = 0;
		while (g < nr && !(r[g].sender == t->hdr.sender_id && r[g].coarse == coarse))
			g++;
		if (g == nr)
			r[nr++] = (ndo_msg_key_request_t){.sender = t->hdr.sender_id,
			                                  .coarse = (int8_t)coarse, .codes = codes[g]};
		r[g].codes[r[g].ntiles++] = code;
	}
	for (int g = 0; g < nr; g++)
		if (ndo_net_publish(n, NDO_MSG_KEY_REQUEST, &r[g]) == 0)
			n->st.keys_asked += (uint64_t)r[g].ntiles;
}

/* Held tiles past HOLD_SECONDS: their reference was lost, not late. */
static void expire_held(ndo_net *n)
{
	for (int k = 0; k < n->nheld; k++)
		if (n->now - n->held[k].since > HOLD_SECONDS)
			unhold(n, k--, 1);
}

/* A message of type t whose bytes (`sealed`: authenticated, trailer
 * removed; `from`: who sealed it) are in data[0..len). */
static void on_message(ndo_net *n, int t, const uint8_t *data, size_t len, int sealed,
                       const ndo_auth_from *from)
{
	ndo_msg m;
	/* our own, looped back by multicast: dropped before the decode copies
	 * it (a sealed one is checked as a replay first, below) */
	if (!sealed && n->ctx.self_id && ndo_msg_peek_sender((ndo_msg_type)t, data, len) == n->ctx.self_id) {
		n->st.own++;
		return;
	}
	if (t == NDO_MSG_TILE && n->want && unwanted(n, data, len, sealed, from))
		return;
	ndo_drop r = ndo_msg_decode((ndo_msg_type)t, data, len, &m);
	if (r != NDO_DROP_NONE) {
		/* without a key: a keyed session's message says so */
		if (!n->auth && ndo_auth_looks_sealed(data, len) &&
		    ndo_msg_decode((ndo_msg_type)t, data, len - NDO_AUTH_TRAILER, &m) == NDO_DROP_NONE) {
			ndo_msg_free(&m);
			r = NDO_DROP_KEYED;
		}
		n->st.dropped[r]++;
		return;
	}
	/* a replay is one whatever else is wrong with it (a replayed copy of
	 * our own message too); a parked message was checked here already
	 * and comes back unsealed */
	if (sealed && !ndo_auth_fresh(n->auth, m.hdr->sender_id, from, n->now)) {
		n->st.dropped[NDO_DROP_REPLAY]++;
		ndo_msg_free(&m);
		return;
	}
	if (m.hdr->sender_id == n->ctx.self_id) {
		n->st.own++;
		ndo_msg_free(&m);
		return;
	}
	r = ndo_msg_validate(&m, &n->ctx);
	if (r == NDO_DROP_UNKNOWN && n->ctx.object_id == 0 && n->parkbytes + len <= PARK_MAX_BYTES) {
		ndo_msg_free(&m);
		if (n->npark == n->parkcap) {
			size_t cap = n->parkcap ? 2 * n->parkcap : 64;
			struct parked *p = realloc(n->park, cap * sizeof *p);
			if (!p) {
				n->st.dropped[r]++;
				return;
			}
			n->park = p;
			n->parkcap = cap;
		}
		uint8_t *copy = malloc(len);
		if (!copy) {
			n->st.dropped[r]++;
			return;
		}
		memcpy(copy, data, len);
		n->park[n->npark++] = (struct parked){t, copy, len};
		n->parkbytes += len;
		return;
	}
	if (r == NDO_DROP_FOREIGN && t == NDO_MSG_DESCRIPTION &&
	    ndo_msg_validate(&m, &(ndo_msg_ctx){.level = -1, .self_id = n->ctx.self_id}) ==
	        NDO_DROP_NONE) /* a well-formed description: another owner */
		n->other_owner = m.hdr->sender_id;
	if (r == NDO_DROP_FOREIGN && t == NDO_MSG_HEARTBEAT && m.hdr->sender_id == n->other_owner &&
	    n->other_owner) {
		/* its heartbeats (one each 0.2 s from its start) against ours:
		 * elder when it has sent more, the smaller object id on a tie */
		int64_t mine = n->seq_out[NDO_MSG_HEARTBEAT];
		if (m.hdr->seq >= mine || /* seq + 1 > mine, without the sum */
		    (m.hdr->seq == mine - 1 && m.hdr->object_id < n->ctx.object_id)) {
			n->st.foreign_owner = m.hdr->sender_id;
			n->st.foreign_object = m.hdr->object_id;
		}
	}
	if (r != NDO_DROP_NONE) {
		n->st.dropped[r]++;
		ndo_msg_free(&m);
		return;
	}
	note_order(n, t, m.hdr);
	if (t == NDO_MSG_KEY_REQUEST) {
		/* its arrays stay with the queue when accept() keeps it */
		const ndo_msg_header_t h = *m.hdr;
		const ndo_msg_key_request_t k = m.u.key_request;
		const uint64_t was = n->st.accepted;
		accept(n, t, &m);
		if (n->st.accepted > was)
			heard_ask(n, &h, &k);
		return;
	}
	if (t == NDO_MSG_TILE && m.u.tile.encoding != NDO_ENC_RAW) {
		if (hold(n, &m))
			return;
		const ndo_msg_tile_t done = m.u.tile; /* its header and range (accept() may free
		                                          its arrays), for release_held() */
		const int r = decode_encoded(n, &m);
		if (r < 0)
			return;
		if (r == 0)
			accept(n, t, &m);
		/* decoded, kept or not: the frames held for it decode now (each
		 * checked against the box itself), not when their 1 s is up */
		release_held(n, &done);
		return;
	}
	accept(n, t, &m);
}

static void on_bytes(void *user, const char *channel, const void *data, size_t len)
{
	ndo_net *n = user;
	n->st.received++;
	n->st.bytes_in += len;
	int t = ndo_msg_type_of(n->prefix, channel);
	if (t < 0) {
		n->st.dropped[NDO_DROP_CHANNEL]++;
		return;
	}
	if (!n->auth) {
		on_message(n, t, data, len, 0, NULL);
		return;
	}
	size_t mlen;
	ndo_auth_from from;
	ndo_drop r = ndo_auth_open(n->auth, channel, data, len, &mlen, &from);
	if (r != NDO_DROP_NONE) {
		n->st.dropped[r]++;
		return;
	}
	on_message(n, t, data, mlen, 1, &from);
}

int ndo_net_poll(ndo_net *n, double now)
{
	n->now = now;
	uint64_t before = n->st.accepted;
	int rc = ndo_link_poll(n->link, now, on_bytes, n);
	expire_held(n);
	if (n->ask && n->nheld)
		ask_keys(n);
	n->st.dropped[NDO_DROP_INJECTED] = ndo_link_injected_drops(n->link);
	n->st.overflowed = ndo_link_overflows(n->link);
	if (rc < 0)
		return rc;
	return (int)(n->st.accepted - before);
}

void ndo_net_attach(ndo_net *n, int64_t object_id, int level)
{
	n->ctx.object_id = object_id;
	n->ctx.level = level;
	size_t np = n->npark;
	struct parked *p = n->park;
	n->park = NULL;
	n->npark = n->parkcap = n->parkbytes = 0;
	for (size_t k = 0; k < np; k++) {
		on_message(n, p[k].type, p[k].data, p[k].len, 0, NULL);
		free(p[k].data);
	}
	free(p);
}

int ndo_net_next(ndo_net *n, ndo_msg *m)
{
	if (!n->qcount)
		return 0;
	*m = n->queue[n->qhead];
	m->hdr = (const ndo_msg_header_t *)&m->u;
	n->qhead = (n->qhead + 1) % n->qcap;
	n->qcount--;
	return 1;
}

int ndo_net_take_tiles(ndo_net *n, ndo_msg **tiles, size_t *count)
{
	size_t c = 0;
	for (size_t k = 0; k < n->nslots; k++)
		c += n->slots[k].pending != NULL;
	*count = 0;
	*tiles = NULL;
	if (!c)
		return 0;
	ndo_msg *out = malloc(c * sizeof *out);
	if (!out)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	size_t i = 0;
	for (size_t k = 0; k < n->nslots; k++)
		if (n->slots[k].pending) {
			out[i] = *n->slots[k].pending;
			out[i].hdr = (const ndo_msg_header_t *)&out[i].u;
			free(n->slots[k].pending);
			n->slots[k].pending = NULL;
			i++;
		}
	*tiles = out;
	*count = c;
	return 0;
}

void ndo_net_forget(ndo_net *n, int32_t id)
{
	for (int k = 0; k < n->nsenders; k++)
		if (n->senders[k].id == id) {
			n->senders[k] = n->senders[--n->nsenders];
			break;
		}
	for (size_t k = 0; k < n->nslots; k++)
		if (n->slots[k].sender == id) {
			if (n->slots[k].pending) {
				ndo_msg_free(n->slots[k].pending);
				free(n->slots[k].pending);
				n->slots[k].pending = NULL;
			}
			n->slots[k].seq = -1; /* keep the slot: open addressing */
		}
}

void ndo_net_stats_format(const ndo_net *n, char *buf, size_t size)
{
	const ndo_net_stats *s = &n->st;
	uint64_t dropped = 0;
	for (int r = 1; r < NDO_DROP_N; r++)
		dropped += s->dropped[r];
	int len = snprintf(buf, size, "received %llu, accepted %llu, dropped %llu",
	                   (unsigned long long)s->received, (unsigned long long)s->accepted,
	                   (unsigned long long)dropped);
	const char *sep = " (";
	for (int r = 1; r < NDO_DROP_N && len > 0 && (size_t)len < size; r++)
		if (s->dropped[r]) {
			len += snprintf(buf + len, size - (size_t)len, "%s%s %llu", sep,
			                ndo_drop_name((ndo_drop)r), (unsigned long long)s->dropped[r]);
			sep = ", ";
		}
	if (len > 0 && (size_t)len < size)
		len += snprintf(buf + len, size - (size_t)len, "%s, gaps %llu, published %llu",
		                *sep == ',' ? ")" : "", (unsigned long long)s->gaps,
		                (unsigned long long)s->published);
	if (s->overflowed && len > 0 && (size_t)len < size)
		len += snprintf(buf + len, size - (size_t)len, ", overflowed %llu",
		                (unsigned long long)s->overflowed);
	if (s->held && len > 0 && (size_t)len < size)
		len += snprintf(buf + len, size - (size_t)len, ", held %llu", (unsigned long long)s->held);
	if (s->keys_asked && len > 0 && (size_t)len < size)
		len += snprintf(buf + len, size - (size_t)len, ", keyframes asked %llu",
		                (unsigned long long)s->keys_asked);
	if (s->unwanted && len > 0 && (size_t)len < size)
		snprintf(buf + len, size - (size_t)len, "; %llu tiles not used here, passed over",
		         (unsigned long long)s->unwanted);
}
