/* checkpoint.c — exact lock-step's checkpoints (checkpoint.h). */
#include "checkpoint.h"
#include "ndo/status.h"
#include "ndo/topology.h"

#include <stdlib.h>
#include <string.h>

typedef struct slot {
	int64_t step;  /* −1: free */
	double time;
	double substep; /* rkf45's next sub-step size (checkpoint.h) */
	size_t held;   /* canonical nodes held */
	uint8_t *have; /* per stored node */
	double *val;   /* per stored node: v (3), u (3) */
} slot;

struct ndo__ck {
	size_t count, ncanon;
	uint8_t *canon;  /* per stored node: canonical (not a seam's duplicate) */
	slot s[NDO__CK_SLOTS];
	double *buf;     /* send scratch: 6 per node */
	int32_t *rs, *rl;
};

int ndo__ck_create(int level, ndo__ck **out)
{
	ndo__ck *ck = calloc(1, sizeof *ck);
	if (!ck)
		return NDO_ENOMEM;
	size_t w = ((size_t)2 << level) + 1, count = w * (((size_t)1 << level) + 1);
	ck->count = count;
	int bad = !(ck->canon = malloc(count)) || !(ck->buf = malloc(6 * count * sizeof *ck->buf)) ||
	          !(ck->rs = malloc(count * sizeof *ck->rs)) ||
	          !(ck->rl = malloc(count * sizeof *ck->rl));
	for (int k = 0; k < NDO__CK_SLOTS && !bad; k++) {
		ck->s[k].step = -1;
		bad = !(ck->s[k].have = calloc(count, 1)) ||
		      !(ck->s[k].val = malloc(6 * count * sizeof *ck->s[k].val));
	}
	if (bad) {
		ndo__ck_destroy(ck);
		return NDO_ENOMEM;
	}
	for (size_t k = 0; k < count; k++) {
		ck->canon[k] = ndo_canonical(level, (int)(k % w), (int)(k / w)) == k;
		ck->ncanon += ck->canon[k];
	}
	*out = ck;
	return 0;
}

void ndo__ck_destroy(ndo__ck *ck)
{
	if (!ck)
		return;
	for (int k = 0; k < NDO__CK_SLOTS; k++)
		free(ck->s[k].have), free(ck->s[k].val);
	free(ck->canon), free(ck->buf), free(ck->rs), free(ck->rl);
	free(ck);
}

static slot *find(const ndo__ck *ck, int64_t step)
{
	for (int k = 0; k < NDO__CK_SLOTS; k++)
		if (ck->s[k].step == step && step >= 0)
			return (slot *)&ck->s[k];
	return NULL;
}

int64_t ndo__ck_whole(const ndo__ck *ck)
{
	int64_t best = -1;
	for (int k = 0; k < NDO__CK_SLOTS; k++)
		if (ck->s[k].step > best && ck->s[k].held == ck->ncanon)
			best = ck->s[k].step;
	return best;
}

static void clear(slot *sl)
{
	sl->step = -1;
	sl->held = 0;
}

/* The slot for `step`: its own, a free one, or the oldest that is not the
 * newest whole step, when older than `step`; NULL: not kept. */
static slot *slot_for(ndo__ck *ck, int64_t step)
{
	slot *sl = find(ck, step);
	if (sl)
		return sl;
	int64_t whole = ndo__ck_whole(ck);
	slot *old = NULL;
	for (int k = 0; k < NDO__CK_SLOTS; k++) {
		slot *c = &ck->s[k];
		if (c->step < 0) {
			old = c;
			break;
		}
		if (c->step != whole && (!old || c->step < old->step))
			old = c;
	}
	if (!old || (old->step >= 0 && old->step > step))
		return NULL;
	if (old->step >= 0)
		memset(old->have, 0, ck->count);
	clear(old);
	old->step = step;
	return old;
}

/* Node c's state into the slot: canonical nodes only, as `held` counts
 * them against ncanon (a message's duplicates, counted, made a step whole
 * with canonical nodes missing: 47 duplicates and 467 of 514 canonical
 * nodes at level 4, and the restart from it waited for ever). */
static void put_one(ndo__ck *ck, slot *sl, size_t c, const double *val)
{
	if (c >= ck->count || !ck->canon[c])
		return;
	memcpy(sl->val + 6 * c, val, 6 * sizeof *val);
	if (!sl->have[c]) {
		sl->have[c] = 1;
		sl->held++;
	}
}

void ndo__ck_put(ndo__ck *ck, int64_t step, double time, double substep, size_t n,
                 const int32_t *nodes, const double *u, const double *v)
{
	slot *sl = slot_for(ck, step);
	if (!sl)
		return;
	sl->time = time;
	sl->substep = substep;
	for (size_t k = 0; k < n; k++) {
		double val[6];
		memcpy(val, v + 3 * k, 3 * sizeof *val);
		memcpy(val + 3, u + 3 * k, 3 * sizeof *val);
		put_one(ck, sl, (size_t)nodes[k], val);
	}
}

void ndo__ck_put_msg(ndo__ck *ck, const ndo_msg_halo_t *h, const int32_t *owner)
{
	slot *sl = slot_for(ck, h->step);
	if (!sl)
		return;
	sl->time = h->time;
	sl->substep = h->substep;
	size_t k = 0;
	for (int r = 0; r < h->nruns; r++)
		for (int32_t q = 0; q < h->len[r]; q++, k += 6) {
			size_t c = (size_t)h->start[r] + (size_t)q;
			if (!owner || owner[c] == h->hdr.sender_id)
				put_one(ck, sl, c, &h->values[k]);
		}
}

size_t ndo__ck_missing(const ndo__ck *ck, int64_t step, size_t n, const int32_t *nodes)
{
	const slot *sl = find(ck, step);
	if (!sl)
		return n;
	size_t miss = 0;
	for (size_t k = 0; k < n; k++)
		miss += !sl->have[nodes[k]];
	return miss;
}

int ndo__ck_get(const ndo__ck *ck, int64_t step, size_t n, const int32_t *nodes, double *u,
                double *v, double *time, double *substep)
{
	const slot *sl = find(ck, step);
	if (!sl || ndo__ck_missing(ck, step, n, nodes))
		return -1;
	for (size_t k = 0; k < n; k++) {
		const double *val = sl->val + 6 * (size_t)nodes[k];
		memcpy(v + 3 * k, val, 3 * sizeof *v);
		memcpy(u + 3 * k, val + 3, 3 * sizeof *u);
	}
	*time = sl->time;
	*substep = sl->substep;
	return 0;
}

void ndo__ck_drop_after(ndo__ck *ck, int64_t step)
{
	for (int k = 0; k < NDO__CK_SLOTS; k++)
		if (ck->s[k].step > step) {
			memset(ck->s[k].have, 0, ck->count);
			clear(&ck->s[k]);
		}
}

int ndo__ck_send(ndo__ck *ck, ndo_session *s, int64_t step, size_t n, const int32_t *nodes,
                 uint64_t *bytes)
{
	const slot *sl = find(ck, step);
	if (!sl)
		return 0;
	const ndo_net_stats *ns = ndo_net_stats_get(ndo_session_net(s));
	uint64_t b0 = ns->bytes_out;
	ndo_msg_halo_t h;
	memset(&h, 0, sizeof h);
	h.step = step;
	h.time = sl->time;
	h.confirmed = 1;
	h.checkpoint = 1;
	h.substep = sl->substep;
	int rc = ndo_session_send_nodes(s, &h, n, nodes, sl->val, NULL, sl->have, ck->rs, ck->rl,
	                                ck->buf);
	if (rc < 0)
		return rc;
	*bytes += ns->bytes_out - b0;
	return 0;
}
