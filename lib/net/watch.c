/* watch.c — a passive observer of a peers' session (ndo/watch.h). */
#include "ndo/watch.h"
#include "ndo/levels.h"
#include "ndo/partition.h"
#include "ndo/quadtree.h"
#include "ndo/session.h"
#include "ndo/status.h"
#include "ndo/tile.h"
#include "ndo/topology.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define EPOCHS 16    /* partitions kept, newest first out */
#define HELD_MAX 4096 /* tiles kept until their partition arrives */
#define CLOSE_GRACE 0.25 /* s to listen on after the owner quit */

typedef struct epoch_map {
	int32_t epoch; /* −1: empty */
	int32_t *owner;
} epoch_map;

typedef struct pending {
	int64_t step; /* −1: free */
	double time;
	double *x;        /* positions, 3 per stored node */
	int32_t *epoch;   /* per canonical node: the epoch of its value, −1 none */
	int32_t top;      /* the newest epoch used */
	size_t filled;
	int complete;     /* every node has its value: out when the older are */
} pending;

struct ndo_watch {
	ndo_watch_opts o;
	ndo_net *net;
	int attached, ended;
	int64_t object;
	int32_t owner_id;
	int level;
	int flevel, fk;   /* the frames' level: the send level, level − fk */
	int fw;           /* its grid's width */
	size_t count, ncanon; /* at the frames' level */
	int32_t *canon;
	ndo_grid *base;   /* rest and pin as received */
	int have_rest, have_pin;
	epoch_map maps[EPOCHS];
	pending *pend;
	int npend;
	int64_t done_step; /* the last step handed out or skipped */
	int started;       /* a frame was handed out or skipped */
	/* the steps whose whole regions the peers publish (the description's
	 * peer-frames-every, peer-first-step, peer-final-step, dt): every
	 * fevery-th from `first`, and first and final; fevery −1: not said */
	int64_t fevery, first, final, max_step;
	double dt, last_time;
	int32_t last_top;  /* the partition of the last frame out (−1: none) */
	ndo_msg_tile_t *held; /* tiles of a partition not received yet */
	size_t nheld, capheld;
	ndo_grid **ready;  /* complete frames, in step order */
	double *ready_stale; /* ... the share of their nodes held (hold_lost) */
	int nready, capready;
	double *last;      /* hold_lost: the positions of the last frame out */
	double stale;      /* the stale share of the frame ndo_watch_next gave */
	double heard, now;
	double close_at;   /* the owner quit: end at this time (−1: not yet) */
	char why[300];
	ndo_watch_stats st;
};

int ndo_watch_create(ndo_net *net, const ndo_watch_opts *o, ndo_watch **out)
{
	ndo__clear_error();
	ndo_watch *w = calloc(1, sizeof *w);
	if (!w) {
		ndo_net_destroy(net);
		return ndo__fail(NDO_ENOMEM, "out of memory");
	}
	w->o = *o;
	if (w->o.every < 1)
		w->o.every = 1;
	if (w->o.window <= 0)
		w->o.window = 16;
	w->net = net;
	w->level = -1;
	w->st.level = -1;
	w->st.send_level = -1;
	w->done_step = -1;
	w->fevery = -1;
	w->max_step = -1;
	w->last_top = -1;
	w->heard = -1;
	w->close_at = -1;
	for (int k = 0; k < EPOCHS; k++)
		w->maps[k].epoch = -1;
	ndo_net_keep_all_tiles(net, 1);
	if (!o->passive) {
		ndo_net_ctx(net)->self_id = ndo_net_new_id();
		ndo_net_ask_keys(net, 1);
	}
	*out = w;
	return 0;
}

static void free_pending(pending *p)
{
	free(p->x);
	free(p->epoch);
	p->x = NULL;
	p->epoch = NULL;
	p->step = -1;
}

void ndo_watch_destroy(ndo_watch *w)
{
	if (!w)
		return;
	ndo_net_destroy(w->net);
	ndo_grid_destroy(w->base);
	for (int k = 0; k < EPOCHS; k++)
		free(w->maps[k].owner);
	for (int k = 0; k < w->npend; k++)
		free_pending(&w->pend[k]);
	free(w->pend);
	for (int k = 0; k < w->nready; k++)
		ndo_grid_destroy(w->ready[k]);
	for (size_t k = 0; k < w->nheld; k++)
		free(w->held[k].values);
	free(w->held);
	free(w->ready);
	free(w->ready_stale);
	free(w->last);
	free(w->canon);
	free(w);
}

/* ---- the object ---------------------------------------------------------- */
static int attach(ndo_watch *w, const ndo_msg_description_t *d)
{
	if (w->attached || (w->o.object_id && d->hdr.object_id != w->o.object_id))
		return 0;
	/* the owner's tile encoding (ndo/codec.h): decoded by the net */
	ndo_codec_params cp;
	int rc = ndo_codec_params_read(d->scene, (size_t)d->scene_len, &cp);
	int L = d->level;
	if (rc == 0)
		rc = ndo_net_set_codec(w->net, &cp, d->level);
	if (rc == 0 && (rc = ndo_send_level_read(d->scene, (size_t)d->scene_len, d->level, &L)) == 0)
		rc = ndo_net_set_send_level(w->net, L, d->level);
	if (rc == NDO_EINVAL)
		return 0; /* a description this build cannot use: wait for another */
	if (rc)
		return rc;
	ndo_net_skipped_tiles(w->net, 1);
	{ /* the object's box: the bound on the state (none if the line is bad) */
		char *copy = malloc((size_t)d->scene_len + 1); /* scene: NULL when empty */
		if (copy && d->scene_len)
			memcpy(copy, d->scene, (size_t)d->scene_len);
		if (copy)
			copy[d->scene_len] = 0;
		if (!copy)
			return ndo__fail(NDO_ENOMEM, "out of memory");
		ndo_msg_box_take(copy, ndo_net_ctx(w->net));
		char *save = NULL;
		for (char *line = strtok_r(copy, "\n", &save); line; line = strtok_r(NULL, "\n", &save)) {
			char key[32];
			double val;
			if (sscanf(line, "%31s %lf", key, &val) != 2 || !isfinite(val) || val < 0 || val > 1e15)
				continue;
			if (strcmp(key, "peer-frames-every") == 0)
				w->fevery = (int64_t)val;
			else if (strcmp(key, "peer-first-step") == 0)
				w->first = (int64_t)val;
			else if (strcmp(key, "peer-final-step") == 0)
				w->final = (int64_t)val;
			else if (strcmp(key, "dt") == 0)
				w->dt = val;
		}
		free(copy);
	}
	rc = ndo_grid_create(d->level, &w->base);
	if (rc)
		return rc;
	if (ndo_grid_add(w->base, NDO_CH_REST, NDO_F64, 3, NULL) ||
	    ndo_grid_add(w->base, NDO_CH_PIN, NDO_U8, 1, NULL))
		return ndo__fail(NDO_ENOMEM, "out of memory");
	w->level = d->level;
	w->flevel = L;
	w->fk = d->level - L;
	w->fw = (2 << L) + 1;
	w->count = (size_t)w->fw * (size_t)((1 << L) + 1);
	w->canon = malloc(w->count * sizeof *w->canon);
	w->pend = calloc((size_t)w->o.window, sizeof *w->pend);
	if (!w->canon || !w->pend)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	w->npend = w->o.window;
	for (int k = 0; k < w->npend; k++)
		w->pend[k].step = -1;
	w->ncanon = 0;
	for (size_t k = 0; k < w->count; k++) {
		w->canon[k] = (int32_t)ndo_canonical(w->flevel, (int)(k % (size_t)w->fw),
		                                     (int)(k / (size_t)w->fw));
		w->ncanon += (size_t)w->canon[k] == k;
	}
	w->object = d->hdr.object_id;
	w->owner_id = d->hdr.sender_id;
	w->attached = 1;
	w->st.object_id = w->object;
	w->st.level = w->level;
	w->st.send_level = w->flevel;
	ndo_net_attach(w->net, w->object, w->level);
	return 0;
}

static int release(ndo_watch *w, int32_t epoch);

static epoch_map *find_epoch(ndo_watch *w, int32_t epoch)
{
	for (int k = 0; k < EPOCHS; k++)
		if (w->maps[k].epoch == epoch)
			return &w->maps[k];
	return NULL;
}

/* A partition newer than every one held from a peer that simulates in
 * the newest: the owner's successor (ndo/session.h, succession), which
 * owns the session once the owner fell silent. */
static int successor(const ndo_watch *w, const ndo_msg_partition_t *p)
{
	const epoch_map *newest = NULL;
	for (int k = 0; k < EPOCHS; k++)
		if (w->maps[k].epoch >= 0 && (!newest || w->maps[k].epoch > newest->epoch))
			newest = &w->maps[k];
	if (!newest || p->epoch <= newest->epoch)
		return 0;
	for (size_t k = 0; k < w->count; k++)
		if (newest->owner[k] == p->hdr.sender_id)
			return 1;
	return 0;
}

static int on_partition(ndo_watch *w, const ndo_msg_partition_t *p)
{
	if (p->hdr.sender_id != w->owner_id) {
		if (!successor(w, p))
			return 0;
		w->owner_id = p->hdr.sender_id;
	}
	if (find_epoch(w, p->epoch))
		return 0;
	epoch_map *m = &w->maps[0]; /* replace the oldest */
	for (int k = 1; k < EPOCHS; k++)
		if (w->maps[k].epoch < m->epoch)
			m = &w->maps[k];
	size_t ncells = ndo_cell_count(w->level);
	int32_t *cells = malloc(ncells * sizeof *cells);
	int32_t *fine = malloc(w->base->count * sizeof *fine);
	int32_t *owner = m->owner ? m->owner : malloc(w->count * sizeof *owner);
	if (!cells || !owner || !fine) {
		free(cells), free(fine);
		if (!m->owner)
			free(owner);
		return ndo__fail(NDO_ENOMEM, "out of memory");
	}
	ndo_partition_cells(w->level, p, cells);
	ndo_partition_node_owner(w->level, cells, p->peers, fine);
	/* a node of the send level is its level-n node's */
	ndo_sample_nodes(w->level, w->fk, sizeof *owner, fine, owner);
	free(cells), free(fine);
	m->owner = owner;
	m->epoch = p->epoch;
	return release(w, p->epoch);
}

/* ---- frames -------------------------------------------------------------- */
static int push_ready(ndo_watch *w, ndo_grid *g, double stale)
{
	if (w->nready == w->capready) {
		int cap = w->capready ? 2 * w->capready : 8;
		ndo_grid **r = realloc(w->ready, (size_t)cap * sizeof *r);
		if (!r)
			return ndo__fail(NDO_ENOMEM, "out of memory");
		w->ready = r;
		double *st = realloc(w->ready_stale, (size_t)cap * sizeof *st);
		if (!st)
			return ndo__fail(NDO_ENOMEM, "out of memory");
		w->ready_stale = st;
		w->capready = cap;
	}
	w->ready_stale[w->nready] = stale;
	w->ready[w->nready++] = g;
	return 0;
}

/* Hand out frame p: complete, or (hold_lost) with the nodes it lacks at
 * the last frame's values. */
static int emit_one(ndo_watch *w, pending *p)
{
	double stale = 0;
	if (!p->complete) {
		size_t lost = 0;
		for (size_t k = 0; k < w->count; k++)
			if (p->epoch[w->canon[k]] < 0) {
				memcpy(p->x + 3 * k, w->last + 3 * k, 3 * sizeof *p->x);
				lost += (size_t)w->canon[k] == k;
			}
		stale = (double)lost / (double)w->ncanon;
		w->st.held++;
		w->st.stale_sum += stale;
		if (stale > w->st.stale_max)
			w->st.stale_max = stale;
	}
	ndo_grid *g;
	int rc = ndo_grid_create(w->flevel, &g);
	if (rc)
		return rc;
	ndo_channel *own;
	if (ndo_grid_add(g, NDO_CH_OWNER, NDO_I32, 1, &own)) {
		ndo_grid_destroy(g);
		return ndo__fail(NDO_ENOMEM, "out of memory");
	}
	memcpy(ndo_grid_f64(g, NDO_CH_POSITION, 3), p->x, 3 * w->count * sizeof *p->x);
	/* a step lost whole is drawn under the partition of the frame before */
	int32_t top = p->top >= 0 ? p->top : w->last_top;
	epoch_map *m = top >= 0 ? find_epoch(w, top) : NULL;
	if (m && m->owner)
		memcpy(own->data, m->owner, w->count * sizeof *m->owner);
	if (w->have_rest) {
		ndo_channel *c;
		if (ndo_grid_add(g, NDO_CH_REST, NDO_F64, 3, &c) == 0)
			ndo_sample_nodes(w->level, w->fk, 3 * sizeof(double),
			                 ndo_grid_find(w->base, NDO_CH_REST)->data, c->data);
	}
	if (w->have_pin) {
		ndo_channel *c;
		if (ndo_grid_add(g, NDO_CH_PIN, NDO_U8, 1, &c) == 0)
			ndo_sample_nodes(w->level, w->fk, 1, ndo_grid_find(w->base, NDO_CH_PIN)->data,
			                 c->data);
	}
	g->step = p->step;
	g->time = p->time;
	ndo_grid_sync(g);
	if ((rc = push_ready(w, g, stale))) {
		ndo_grid_destroy(g);
		return rc;
	}
	if (w->o.hold_lost) {
		if (!w->last && !(w->last = malloc(3 * w->count * sizeof *w->last)))
			return ndo__fail(NDO_ENOMEM, "out of memory");
		memcpy(w->last, ndo_grid_f64(g, NDO_CH_POSITION, 3), 3 * w->count * sizeof *w->last);
	}
	w->st.frames++;
	w->done_step = p->step;
	w->started = 1;
	w->last_time = p->time;
	w->last_top = top;
	free_pending(p);
	return 0;
}

static pending *oldest_open(ndo_watch *w)
{
	pending *o = NULL;
	for (int k = 0; k < w->npend; k++)
		if (w->pend[k].step >= 0 && (!o || w->pend[k].step < o->step))
			o = &w->pend[k];
	return o;
}

/* Was step s published (and watched)? */
static int expected(const ndo_watch *w, int64_t s)
{
	if (w->fevery < 0 || s % w->o.every != 0 || s < w->first || s > w->final)
		return 0;
	return s == w->first || s == w->final || (w->fevery > 0 && (s - w->first) % w->fevery == 0);
}

/* The published steps after the last one handed out or skipped and
 * before `upto` of which no tile came at all: lost whole.  With hold_lost
 * (and a frame out before) each is handed out with every node held;
 * otherwise counted. */
static int lost_whole(ndo_watch *w, int64_t upto)
{
	if (!w->started || w->fevery < 0)
		return 0;
	for (int64_t s = w->done_step + 1; s < upto; s++) {
		if (!expected(w, s))
			continue;
		if (w->o.hold_lost && w->last) {
			pending p = {.step = s, .time = w->last_time + (double)(s - w->done_step) * w->dt,
			             .top = -1};
			p.x = malloc(3 * w->count * sizeof *p.x);
			p.epoch = malloc(w->count * sizeof *p.epoch);
			if (!p.x || !p.epoch) {
				free_pending(&p);
				return ndo__fail(NDO_ENOMEM, "out of memory");
			}
			for (size_t k = 0; k < w->count; k++)
				p.epoch[k] = -1;
			int rc = emit_one(w, &p);
			if (rc)
				return rc;
		} else {
			w->st.incomplete++;
			w->done_step = s;
		}
	}
	return 0;
}

static int emit(ndo_watch *w, pending *p)
{
	int rc = lost_whole(w, p->step);
	return rc ? rc : emit_one(w, p);
}

/* An open frame whose tiles are lost: handed out with the lost nodes held
 * (hold_lost, once a frame has gone out), or skipped and counted. */
static int give_up(ndo_watch *w, pending *p)
{
	if (w->o.hold_lost && w->last)
		return emit(w, p);
	int rc = lost_whole(w, p->step);
	if (rc)
		return rc;
	w->done_step = p->step;
	w->started = 1;
	free_pending(p);
	w->st.incomplete++;
	return 0;
}

/* Hand out the complete frames that no open older frame holds back; with
 * `all` (the end), skip the incomplete ones instead of waiting. */
static int flush(ndo_watch *w, int all)
{
	pending *o;
	while ((o = oldest_open(w))) {
		if (o->complete) {
			int rc = emit(w, o);
			if (rc)
				return rc;
		} else if (all) {
			int rc = give_up(w, o);
			if (rc)
				return rc;
		} else {
			break;
		}
	}
	/* the end: published steps after the last one out of which nothing came */
	return all ? lost_whole(w, w->max_step + 1) : 0;
}

/* The open frame of `step`, opened if need be (closing the oldest when
 * all are in use); NULL when out of memory. */
static pending *frame_of(ndo_watch *w, int64_t step, int *failed)
{
	pending *free_slot = NULL, *oldest = NULL;
	for (int k = 0; k < w->npend; k++) {
		pending *p = &w->pend[k];
		if (p->step == step)
			return p;
		if (p->step < 0 && !free_slot)
			free_slot = p;
		if (p->step >= 0 && (!oldest || p->step < oldest->step))
			oldest = p;
	}
	if (!free_slot) { /* give the oldest up: its tiles are lost */
		if (oldest->step > step)
			return NULL; /* older than every open frame: too late */
		int rc = give_up(w, oldest);
		if (!rc)
			rc = flush(w, 0);
		if (rc) {
			*failed = 1;
			return NULL;
		}
		free_slot = oldest;
	}
	pending *p = free_slot;
	p->x = malloc(3 * w->count * sizeof *p->x);
	p->epoch = malloc(w->count * sizeof *p->epoch);
	if (!p->x || !p->epoch) {
		free_pending(p);
		*failed = 1;
		return NULL;
	}
	for (size_t k = 0; k < w->count; k++)
		p->epoch[k] = -1;
	p->step = step;
	p->filled = 0;
	p->top = -1;
	p->complete = 0;
	return p;
}

static int hold(ndo_watch *w, const ndo_msg_tile_t *t)
{
	if (w->nheld == HELD_MAX) {
		free(w->held[0].values);
		memmove(w->held, w->held + 1, (w->nheld - 1) * sizeof *w->held);
		w->nheld--;
		w->st.unknown++;
	}
	if (w->nheld == w->capheld) {
		size_t cap = w->capheld ? 2 * w->capheld : 64;
		ndo_msg_tile_t *q = realloc(w->held, cap * sizeof *q);
		if (!q)
			return ndo__fail(NDO_ENOMEM, "out of memory");
		w->held = q;
		w->capheld = cap;
	}
	int rc = ndo_tile_copy(t, &w->held[w->nheld]);
	if (rc)
		return rc;
	w->nheld++;
	return 0;
}

static int on_tile(ndo_watch *w, const ndo_msg_tile_t *t);

/* A partition arrived: the tiles that waited for it. */
static int release(ndo_watch *w, int32_t epoch)
{
	size_t keep = 0;
	int rc = 0;
	for (size_t k = 0; k < w->nheld; k++) {
		if (w->held[k].epoch == epoch && !rc) {
			rc = on_tile(w, &w->held[k]);
			free(w->held[k].values);
		} else {
			w->held[keep++] = w->held[k];
		}
	}
	w->nheld = keep;
	return rc;
}

/* 1 when tile t carries a node its sender owns under partition m, of
 * the nodes a frame takes from it (a coarse tile's all, a fine one's every
 * 2^fk-th when the run sends a coarser level: as on_tile copies them). */
static int carries_own(const ndo_watch *w, const epoch_map *m, const ndo_msg_tile_t *t)
{
	const int fine = !(t->channels & NDO_TILE_COARSE), mask = fine ? (1 << w->fk) - 1 : 0,
	          sh = fine ? w->fk : 0;
	for (int j = t->j0; j <= t->j1; j++)
		for (int i = t->i0; i <= t->i1; i++)
			if (!(i & mask) && !(j & mask) &&
			    m->owner[w->canon[ndo_node(w->fw, i >> sh, j >> sh)]] == t->hdr.sender_id)
				return 1;
	return 0;
}

static int on_tile(ndo_watch *w, const ndo_msg_tile_t *t)
{
	int32_t from = t->hdr.sender_id;
	if (t->channels & (NDO_TILE_REST | NDO_TILE_PIN)) {
		if (from == w->owner_id) {
			ndo_tile_apply(w->base, t, NULL, 0);
			ndo_grid_sync(w->base);
			w->have_rest |= (t->channels & NDO_TILE_REST) != 0;
			w->have_pin |= (t->channels & NDO_TILE_PIN) != 0;
		}
		return 0;
	}
	if (!(t->channels & NDO_TILE_POSITION) || t->step % w->o.every != 0 ||
	    t->step <= w->done_step) {
		w->st.unused++;
		return 0;
	}
	epoch_map *m = find_epoch(w, t->epoch);
	if (!m) /* its partition may come later (reordered): keep it */
		return hold(w, t);
	/* Only a tile with a node of its sender's opens a frame or moves the
	 * newest step: until 2026-11-30 a sender of none (a rogue in an open
	 * session) opened a frame a tile, and 16 of them at steps ahead gave
	 * up every open frame of the owner's and moved the frames handed out
	 * past all its steps (test_session a_stranger_opens_no_frames). */
	if (!carries_own(w, m, t)) {
		w->st.unused++;
		return 0;
	}
	if (t->step > w->max_step)
		w->max_step = t->step;
	int failed = 0;
	pending *p = frame_of(w, t->step, &failed);
	if (!p) {
		if (failed)
			return ndo__fail(NDO_ENOMEM, "out of memory");
		w->st.unused++;
		return 0;
	}
	p->time = t->time;
	int per = ndo_tile_values_per_node(t->channels);
	/* a tile of the object's level in a run that sends a coarser one (the
	 * exact last step): its every 2^fk-th node */
	const int fine = !(t->channels & NDO_TILE_COARSE), mask = fine ? (1 << w->fk) - 1 : 0,
	          sh = fine ? w->fk : 0;
	size_t k = 0;
	for (int j = t->j0; j <= t->j1; j++)
		for (int i = t->i0; i <= t->i1; i++, k += (size_t)per) {
			if ((i & mask) || (j & mask))
				continue;
			size_t node = ndo_node(w->fw, i >> sh, j >> sh), c = (size_t)w->canon[node];
			if (m->owner[c] != from || p->epoch[c] > t->epoch || isnan(t->values[k]))
				continue; /* NaN: a node a decoded tile does not carry */
			memcpy(p->x + 3 * node, &t->values[k], 3 * sizeof *p->x);
			if (node == c) {
				if (p->epoch[c] < 0)
					p->filled++;
				p->epoch[c] = t->epoch;
			}
		}
	if (t->epoch > p->top)
		p->top = t->epoch;
	w->st.tiles++;
	if (p->filled == w->ncanon && !p->complete) {
		p->complete = 1;
		return flush(w, 0);
	}
	return 0;
}

static void on_leave(ndo_watch *w, const ndo_msg_leave_t *l)
{
	if (l->hdr.sender_id == w->owner_id && w->close_at < 0 &&
	    (l->peer == w->owner_id || l->reason == NDO_LEAVE_OWNER_QUIT)) {
		/* the others' last tiles may still be on their way */
		w->close_at = w->now + CLOSE_GRACE;
		snprintf(w->why, sizeof w->why, "the owner quit%s%s", *l->message ? ": " : "",
		         l->message);
	}
}

int ndo_watch_update(ndo_watch *w, double now)
{
	ndo__clear_error();
	w->now = now;
	if (w->heard < 0)
		w->heard = now;
	if (w->ended)
		return 0;
	int rc = ndo_net_poll(w->net, now);
	if (rc < 0)
		return rc;
	if (rc > 0)
		w->heard = now;
	ndo_msg m;
	while (!w->ended && ndo_net_next(w->net, &m)) {
		switch (m.type) {
		case NDO_MSG_DESCRIPTION: rc = attach(w, &m.u.description); break;
		case NDO_MSG_PARTITION: rc = w->attached ? on_partition(w, &m.u.partition) : 0; break;
		case NDO_MSG_TILE: rc = w->attached ? on_tile(w, &m.u.tile) : 0; break;
		case NDO_MSG_LEAVE: if (w->attached) on_leave(w, &m.u.leave); rc = 0; break;
		default: rc = 0; break;
		}
		ndo_msg_free(&m);
		if (rc < 0)
			return rc;
	}
	if (!w->ended && w->close_at >= 0 && now >= w->close_at)
		w->ended = 1;
	if (!w->ended && ndo_link_ended(ndo_net_link(w->net))) { /* a log read to its end */
		w->ended = 1;
		const char *note = ndo_link_note(ndo_net_link(w->net));
		if (!*w->why)
			snprintf(w->why, sizeof w->why, "the end of the log%s%s", *note ? ", " : "", note);
	}
	if (!w->ended && w->o.timeout > 0 && now - w->heard > w->o.timeout) {
		w->ended = 1;
		snprintf(w->why, sizeof w->why, "nothing heard for %.3g s", now - w->heard);
	}
	return w->ended && w->attached ? flush(w, 1) : 0;
}

int ndo_watch_next(ndo_watch *w, ndo_grid **frame)
{
	if (!w->nready)
		return 0;
	*frame = w->ready[0];
	w->stale = w->ready_stale[0];
	memmove(w->ready, w->ready + 1, (size_t)(w->nready - 1) * sizeof *w->ready);
	memmove(w->ready_stale, w->ready_stale + 1, (size_t)(w->nready - 1) * sizeof *w->ready_stale);
	w->nready--;
	return 1;
}

double ndo_watch_stale(const ndo_watch *w) { return w->stale; }

int ndo_watch_ended(const ndo_watch *w)
{
	return w->ended && w->nready == 0;
}

const char *ndo_watch_why(const ndo_watch *w) { return w->why; }

void ndo_watch_stats_get(const ndo_watch *w, ndo_watch_stats *st)
{
	*st = w->st;
	if (w->ended)
		st->unknown += (int64_t)w->nheld;
}
