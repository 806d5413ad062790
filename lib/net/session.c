/* session.c — one peer of a shared object (ndo/session.h; thesis §4.4,
 * figure 4.14). */
#include "ndo/session.h"
#include "peer_test.h"
#include "ndo/levels.h"
#include "ndo/partition.h"
#include "ndo/restrict.h"
#include "ndo/quadtree.h"
#include "ndo/status.h"
#include "ndo/tile.h"
#include "ndo/topology.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#define NEV 64
#define FULL_SEND_GAP 0.25 /* s: at most one full description burst per this */
#define TILE_FILL 0.5      /* a transmit tile is at least this much the sender's */

typedef struct member {
	int32_t id, poi;
	double heard;
} member;

struct ndo_session {
	ndo_session_opts o;
	char name[NDO_MAX_NAME + 1];
	char *scene;
	ndo_net *net;
	ndo_grid *grid;
	int32_t self, owner_id;
	int32_t gone_said; /* the last peer whose leave was told (drop_member): a LEAVE comes twice */
	int64_t object;
	int level, ended, ready, described;
	member m[NDO_MAX_MEMBERS]; /* owner: everyone but itself; joiner: from PEERS */
	int nm;
	/* the partition in force */
	int32_t epoch;
	int64_t restart;      /* its restart step (partition_t.restart), −1: none */
	int64_t restart_next; /* owner: what the next partition carries */
	int npeers;
	int32_t peers[NDO_MAX_PEERS], pois[NDO_MAX_PEERS];
	ndo_part_method method;
	int32_t *cells;
	int32_t *leaf_codes, *leaf_slots; /* owner: to publish */
	size_t nleaves;
	int32_t *tiles;                   /* my transmit tiles (quad codes) */
	size_t ntiles;
	int tdepth_state, tdepth_rest;
	/* joiner: which nodes have arrived */
	uint8_t *have;
	size_t have_rest, have_state;
	/* clocks */
	double now, next_hb, owner_heard, last_ask, last_full, next_poi;
	double grace; /* the owner's or a member's silence tolerated, at least (0: none) */
	int hb_count, full_pending;
	uint64_t overflowed; /* the link's overflows when last looked at */
	int32_t poi_acked; /* the POI the owner's last partition shows for us */
	/* succession (ndo_session_set_succession): on, and the owners that
	 * fell silent and the peers that left (never followed) */
	int succession;
	int32_t lost[NDO_MAX_PEERS];
	int nlost;
	ndo_event ev[NEV];
	int evhead, evcount;
	ndo_msg force;
	int holding_force;
	int applied; /* a tile was written since the last ndo_grid_sync */
	uint64_t rng;
	/* compact state (ndo/codec.h) */
	ndo_codec_params codec;   /* raw until known */
	ndo_codec *enc;           /* this peer's encoder (NULL: raw) */
	uint8_t *cls, *cls_exact; /* per stored node: NDO_NODE_* (and all own EXACT) */
	size_t nexact;
	int tdepth_enc;
	int64_t exact_step;
	/* the send level (ndo/codec.h "send-level"): whole-region state as
	 * tiles of the level-send_level grid, every 2^(level − send_level)-th node */
	int send_level;          /* = level: none below the object's */
	int exact_halos;         /* the simulating peers exchange exact halos */
	ndo_grid *cgrid;         /* the send level: this peer's state sampled, owner */
	double *crecv;           /* the others' coarse positions, velocities (6 a node) */
	int64_t *cstep;          /* ... their step (−1: none) */
	ndo_codec *cenc;         /* its encoder (NULL: raw) */
	uint8_t *ccls;           /* per coarse node: LOSSY (this peer's) or SKIP */
	uint8_t *cuse;           /* ndo_session_refine_others: taken as it travelled */
	int32_t *ctiles;         /* coarse tiles with a node of this peer's */
	size_t nctiles;
	int cdepth, cdepth_raw;
	double *cview, *tilex;   /* coarse positions as receivers hold them; a tile's */
	double *dview;           /* refined displacement + rest, at the object's level */
	int measure_disp;        /* ndo_session_measure_displacement */
	uint8_t *fmask;          /* this peer's nodes at the object's level */
	ndo_refiner *refiner;
	double diag;             /* the rest shape's box diagonal */
	ndo_session_level_stats lst;
};

static void push_event(ndo_session *s, ndo_event e)
{
	if (s->evcount == NEV) { /* drop the oldest rather than the newest */
		s->evhead = (s->evhead + 1) % NEV;
		s->evcount--;
	}
	s->ev[(s->evhead + s->evcount++) % NEV] = e;
}

static void event(ndo_session *s, ndo_event_type t, int32_t peer, int reason, const char *msg)
{
	ndo_event e;
	memset(&e, 0, sizeof e);
	e.type = t;
	e.peer = peer;
	e.reason = reason;
	e.epoch = s->epoch;
	if (msg)
		snprintf(e.message, sizeof e.message, "%s", msg);
	push_event(s, e);
}

static void count_authority(ndo_session *s)
{
	((ndo_net_stats *)ndo_net_stats_get(s->net))->dropped[NDO_DROP_AUTHORITY]++;
}

/* ---- grid and partition state ------------------------------------------ */
static int prepare_grid(ndo_session *s)
{
	ndo_grid *g = s->grid;
	if (ndo_grid_convert(g, NDO_CH_POSITION, NDO_F64) != 0)
		return NDO_EINVAL;
	const char *vecs[2] = {NDO_CH_VELOCITY, NDO_CH_REST};
	for (int k = 0; k < 2; k++) {
		ndo_channel *c = ndo_grid_find(g, vecs[k]);
		if (c && c->comps == 3 && c->type != NDO_F64 && ndo_grid_convert(g, vecs[k], NDO_F64))
			return NDO_EINVAL;
		if (!c && ndo_grid_add(g, vecs[k], NDO_F64, 3, NULL) != 0)
			return NDO_ENOMEM;
	}
	if (ndo_grid_add(g, NDO_CH_PIN, NDO_U8, 1, NULL) != 0 ||
	    ndo_grid_add(g, NDO_CH_OWNER, NDO_I32, 1, NULL) != 0)
		return ndo__fail(NDO_EINVAL, "the grid's pin/owner channels have another type");
	s->level = g->level;
	s->tdepth_state = ndo_tile_depth(g->level, NDO_TILE_POSITION | NDO_TILE_VELOCITY,
	                                 ndo_net_channel(s->net, NDO_MSG_TILE));
	s->tdepth_rest = ndo_tile_depth(g->level, NDO_TILE_REST | NDO_TILE_PIN,
	                                ndo_net_channel(s->net, NDO_MSG_TILE));
	/* encoded tiles are 4 times larger (a quarter of the messages and of
	 * their headers): a tile that does not fit goes raw, as its 4 children */
	s->tdepth_enc = s->tdepth_state > 0 ? s->tdepth_state - 1 : 0;
	free(s->cls);
	free(s->cls_exact);
	s->cls = calloc(g->count, 1);
	s->cls_exact = calloc(g->count, 1);
	if (!s->cls || !s->cls_exact)
		return NDO_ENOMEM;
	return 0;
}

/* The classes of the stored nodes for the encoder (ndo_codec_classify). */
static void classify(ndo_session *s)
{
	s->nexact = ndo_codec_classify(s->level, ndo_grid_find(s->grid, NDO_CH_OWNER)->data, s->self,
	                               s->cls);
	for (size_t k = 0; k < s->grid->count; k++)
		s->cls_exact[k] = s->cls[k] == NDO_NODE_SKIP ? NDO_NODE_SKIP : NDO_NODE_EXACT;
}

static int32_t *owner_channel(ndo_session *s)
{
	return ndo_grid_find(s->grid, NDO_CH_OWNER)->data;
}

/* ---- the send level ------------------------------------------------------ */
static size_t level_nodes(int level)
{
	return (size_t)((2 << level) + 1) * (size_t)((1 << level) + 1);
}

/* The send level's grids, encoder and buffers, once the level and the
 * encoding are known (owner: at creation; joiner: with the description). */
static int coarse_prepare(ndo_session *s)
{
	if (s->send_level >= s->level)
		return 0;
	int L = s->send_level, rc;
	size_t nc = level_nodes(L);
	if ((rc = ndo_grid_create(L, &s->cgrid)) ||
	    (rc = ndo_grid_add(s->cgrid, NDO_CH_VELOCITY, NDO_F64, 3, NULL)) ||
	    (rc = ndo_grid_add(s->cgrid, NDO_CH_OWNER, NDO_I32, 1, NULL)) ||
	    (rc = ndo_grid_add(s->cgrid, NDO_CH_REST, NDO_F64, 3, NULL)))
		return rc;
	s->dview = malloc(3 * s->grid->count * sizeof *s->dview);
	s->crecv = malloc(6 * nc * sizeof *s->crecv);
	s->cstep = malloc(nc * sizeof *s->cstep);
	s->ccls = calloc(nc, 1);
	s->cuse = calloc(nc, 1);
	s->cview = malloc(3 * nc * sizeof *s->cview);
	s->fmask = calloc(s->grid->count, 1);
	if (!s->crecv || !s->cstep || !s->ccls || !s->cuse || !s->cview || !s->fmask || !s->dview)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	for (size_t k = 0; k < nc; k++)
		s->cstep[k] = -1;
	if ((rc = ndo_refiner_create(L, s->level - L, 3, &s->refiner)))
		return rc;
	const char *ch = ndo_net_channel(s->net, NDO_MSG_TILE);
	s->cdepth_raw = ndo_tile_depth(L, NDO_TILE_POSITION | NDO_TILE_VELOCITY, ch);
	s->cdepth = s->cdepth_raw;
	if (s->codec.encoding != NDO_ENC_RAW) {
		if ((rc = ndo_codec_create(&s->codec, L, &s->cenc)))
			return rc;
		s->cdepth = s->cdepth_raw > 0 ? s->cdepth_raw - 1 : 0; /* as tdepth_enc */
	}
	int cols, rows;
	ndo_quad_dims(s->cdepth, &cols, &rows);
	int i0, j0, i1, j1;
	ndo_quad_range(L, (ndo_quad){s->cdepth, 0, 0}, &i0, &j0, &i1, &j1);
	s->tilex = malloc(3 * (size_t)(i1 - i0 + 1) * (size_t)(j1 - j0 + 1) * sizeof *s->tilex);
	s->ctiles = malloc((size_t)cols * (size_t)rows * sizeof *s->ctiles);
	if (!s->tilex || !s->ctiles)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	s->lst.level = s->level;
	s->lst.send_level = L;
	return 0;
}

/* The rest shape's positions, or the positions when it is all zero (none
 * given). */
static const double *rest_or_positions(ndo_session *s)
{
	const double *x = ndo_grid_f64(s->grid, NDO_CH_REST, 3);
	int have_rest = 0;
	for (size_t k = 0; x && k < 3 * s->grid->count && !have_rest; k++)
		have_rest = x[k] != 0;
	return have_rest ? x : ndo_grid_f64(s->grid, NDO_CH_POSITION, 3);
}

/* The diagonal the errors are reported against: the rest shape's box (a
 * joiner has it once the snapshot came). */
static double rest_diagonal(ndo_session *s)
{
	const double *x = rest_or_positions(s);
	double lo[3], ext[3];
	ndo_codec_box(x, s->grid->count, lo, ext);
	return sqrt(ext[0] * ext[0] + ext[1] * ext[1] + ext[2] * ext[2]);
}

/* The coarse nodes' owners (sampled), classes and this peer's coarse tiles:
 * every tile at the depth that fits a datagram with a node of its own. */
static int coarse_classify(ndo_session *s)
{
	int L = s->send_level, k = s->level - L;
	int32_t *cown = ndo_grid_find(s->cgrid, NDO_CH_OWNER)->data;
	const int32_t *own = owner_channel(s);
	ndo_sample_nodes(s->level, k, sizeof *cown, own, cown);
	size_t nc = s->cgrid->count;
	for (size_t n = 0; n < nc; n++)
		s->ccls[n] = cown[n] == s->self ? NDO_NODE_LOSSY : NDO_NODE_SKIP;
	for (size_t n = 0; n < s->grid->count; n++)
		s->fmask[n] = own[n] == s->self;
	int cols, rows;
	ndo_quad_dims(s->cdepth, &cols, &rows);
	s->nctiles = 0;
	for (int qj = 0; qj < rows; qj++)
		for (int qi = 0; qi < cols; qi++) {
			ndo_quad q = {s->cdepth, qi, qj};
			int i0, j0, i1, j1, any = 0;
			ndo_quad_range(L, q, &i0, &j0, &i1, &j1);
			for (int j = j0; j <= j1 && !any; j++)
				for (int i = i0; i <= i1 && !any; i++)
					any = s->ccls[ndo_node(s->cgrid->w, i, j)] == NDO_NODE_LOSSY;
			if (any)
				s->ctiles[s->nctiles++] = ndo_quad_code(q);
		}
	return 0;
}

/* Whole-region state at the send level now?  Not at the exact step (the
 * owner's gather), and not when the tiles are the boundary another
 * simulating peer integrates with (no exact halos). */
static int coarse_now(const ndo_session *s, int64_t step)
{
	return s->cgrid && step != s->exact_step && (s->npeers <= 1 || s->exact_halos);
}

/* Install a partition: cells (taken over), peers, pois, epoch. */
static int install(ndo_session *s, int32_t *cells, int npeers, const int32_t *peers,
                   const int32_t *pois, int32_t epoch, ndo_part_method method, int64_t restart)
{
	s->restart = restart;
	free(s->cells);
	s->cells = cells;
	s->npeers = npeers;
	memcpy(s->peers, peers, (size_t)npeers * sizeof *peers);
	memcpy(s->pois, pois, (size_t)npeers * sizeof *pois);
	s->epoch = epoch;
	s->method = method;
	ndo_partition_node_owner(s->level, cells, peers, owner_channel(s));
	int slot = -1;
	for (int p = 0; p < npeers; p++)
		if (peers[p] == s->self)
			slot = p;
	s->poi_acked = slot >= 0 ? pois[slot] : -2;
	/* my transmit tiles: quad-tree nodes no shallower than the depth at
	 * which a position+velocity tile fits a datagram, each at least half
	 * mine (receivers take only the sender's nodes from a tile).  The
	 * region's exact leaves would be 60-460 tiles a step for a quad-tree
	 * region at levels 5-7; half-filled nodes are 10-30 times fewer for
	 * about the same bytes (docs/peers.md, "Tiles"). */
	free(s->tiles);
	s->tiles = NULL;
	s->ntiles = 0;
	if (slot >= 0 && ndo_quad_cover(s->level, cells, slot, s->enc ? s->tdepth_enc : s->tdepth_state,
	                                TILE_FILL, &s->tiles, &s->ntiles) != 0)
		return NDO_ENOMEM;
	if (s->enc)
		classify(s);
	if (s->cgrid && coarse_classify(s))
		return NDO_ENOMEM;
	/* the leaves as the owner sends them: as coarse as they come */
	free(s->leaf_codes);
	free(s->leaf_slots);
	s->leaf_codes = s->leaf_slots = NULL;
	return ndo_quad_leaves(s->level, cells, 0, &s->leaf_codes, &s->leaf_slots, &s->nleaves);
}

/* Owner: partition among itself and the members that gave a POI. */
static int repartition(ndo_session *s)
{
	int32_t peers[NDO_MAX_PEERS], pois[NDO_MAX_PEERS], used[NDO_MAX_PEERS];
	int k = 0;
	peers[k] = s->self;
	pois[k++] = s->o.poi;
	for (int i = 0; i < s->nm && k < NDO_MAX_PEERS; i++)
		if (s->m[i].poi >= 0) {
			peers[k] = s->m[i].id;
			pois[k++] = s->m[i].poi;
		}
	int32_t *cells = malloc(ndo_cell_count(s->level) * sizeof *cells);
	if (!cells)
		return NDO_ENOMEM;
	int rc = ndo_partition(s->level, s->method, k, pois, cells, used);
	if (rc) {
		free(cells);
		return rc;
	}
	/* the owner's own POI stays −1 on the wire when it gave none */
	used[0] = s->o.poi;
	for (int p = 1; p < k; p++)
		used[p] = pois[p];
	rc = install(s, cells, k, peers, used, s->epoch + 1, s->method, s->restart_next);
	event(s, NDO_EV_PARTITION, 0, 0, NULL);
	return rc;
}

/* ---- publishing -------------------------------------------------------- */
static int publish_partition(ndo_session *s)
{
	ndo_msg_partition_t p;
	memset(&p, 0, sizeof p);
	p.epoch = s->epoch;
	p.method = (int8_t)s->method;
	p.npeers = (int16_t)s->npeers;
	p.peers = s->peers;
	p.pois = s->pois;
	p.nleaves = (int32_t)s->nleaves;
	p.leaves = s->leaf_codes;
	int8_t *slots = malloc(s->nleaves ? s->nleaves : 1);
	if (!slots)
		return NDO_ENOMEM;
	for (size_t k = 0; k < s->nleaves; k++)
		slots[k] = (int8_t)s->leaf_slots[k];
	p.slots = slots;
	p.restart = s->restart;
	int rc = ndo_net_publish(s->net, NDO_MSG_PARTITION, &p);
	free(slots);
	return rc;
}

static int publish_peers(ndo_session *s)
{
	int32_t ids[NDO_MAX_MEMBERS + 1], pois[NDO_MAX_MEMBERS + 1];
	int n = 0;
	ids[n] = s->self;
	pois[n++] = s->o.poi;
	for (int i = 0; i < s->nm; i++) {
		ids[n] = s->m[i].id;
		pois[n++] = s->m[i].poi;
	}
	ndo_msg_peers_t p = {.npeers = (int16_t)(n > NDO_MAX_MEMBERS ? NDO_MAX_MEMBERS : n),
	                     .peers = ids, .pois = pois};
	return ndo_net_publish(s->net, NDO_MSG_PEERS, &p);
}

static int publish_description(ndo_session *s)
{
	ndo_msg_description_t d = {.level = (int8_t)s->level, .owner_id = s->self,
	                           .epoch = s->epoch, .partition = (int8_t)s->method,
	                           .scene_len = (int16_t)strlen(s->scene),
	                           .scene = (uint8_t *)s->scene};
	return ndo_net_publish(s->net, NDO_MSG_DESCRIPTION, &d);
}

static int publish_raw(ndo_session *s, const ndo_grid *src, ndo_quad q, int channels,
                       int64_t step, double time)
{
	ndo_msg_tile_t t;
	memset(&t, 0, sizeof t);
	int rc = ndo_tile_pack(src, q, channels, &t);
	if (rc)
		return rc;
	t.step = step;
	t.time = time;
	t.epoch = s->epoch;
	rc = ndo_net_publish(s->net, NDO_MSG_TILE, &t);
	free(t.values);
	return rc;
}

/* A position+velocity tile's header: quad-tree node q of a level-`level`
 * grid at step, time and the epoch in force. */
static void state_tile_head(const ndo_session *s, int level, ndo_quad q, int64_t step,
                            double time, ndo_msg_tile_t *t)
{
	memset(t, 0, sizeof *t);
	int i0, j0, i1, j1;
	ndo_quad_range(level, q, &i0, &j0, &i1, &j1);
	t->depth = (int8_t)q.depth;
	t->i0 = i0, t->j0 = j0, t->i1 = i1, t->j1 = j1;
	t->channels = NDO_TILE_POSITION | NDO_TILE_VELOCITY;
	t->step = step;
	t->time = time;
	t->epoch = s->epoch;
}

/* Quad-tree node q's children: the root has two (the N x N squares), the
 * others four. */
static int quad_children(ndo_quad q) { return q.depth == 0 ? 2 : 4; }
static ndo_quad quad_child(ndo_quad q, int c)
{
	return q.depth == 0 ? (ndo_quad){1, c, 0}
	                    : (ndo_quad){q.depth + 1, 2 * q.qi + (c & 1), 2 * q.qj + (c >> 1)};
}

/* One position+velocity tile in the session's encoding: 1 sent, 0 not
 * sent (unchanged), or a negative status.  A tile that cannot be encoded
 * or does not fit one datagram goes raw (its children when it is
 * shallower than a raw tile). */
static int publish_encoded(ndo_session *s, const ndo_grid *src, ndo_quad q, int64_t step,
                           double time)
{
	ndo_msg_tile_t t;
	state_tile_head(s, s->level, q, step, time, &t);
	const uint8_t *cls = step == s->exact_step ? s->cls_exact : s->cls;
	int rc = ndo_codec_encode_tile(s->enc, s->self, src, cls, q, src != s->grid, &t);
	if (rc == 1)
		return 0;
	if (rc == 0) {
		rc = ndo_net_publish(s->net, NDO_MSG_TILE, &t);
		free(t.data);
		if (rc != NDO_ERANGE)
			return rc ? rc : 1;
		ndo_codec_forget_tile(s->enc, s->self, q); /* receivers never saw it */
	} else if (rc != NDO_ERANGE) {
		return rc;
	}
	const int ch = NDO_TILE_POSITION | NDO_TILE_VELOCITY;
	if (q.depth >= s->tdepth_state)
		return (rc = publish_raw(s, src, q, ch, step, time)) ? rc : 1;
	for (int c = 0; c < quad_children(q); c++)
		if ((rc = publish_raw(s, src, quad_child(q, c), ch, step, time)))
			return rc;
	return 1;
}

/* ---- whole-region state at the send level ---- */
#define COARSE_STATE (NDO_TILE_POSITION | NDO_TILE_VELOCITY | NDO_TILE_COARSE)

/* What receivers hold of a coarse tile's nodes of this peer's, into cview:
 * the exact values (raw), or the encoder's reconstruction. */
static void coarse_view(ndo_session *s, ndo_quad q, int encoded)
{
	int i0, j0, i1, j1;
	ndo_quad_range(s->send_level, q, &i0, &j0, &i1, &j1);
	const double *x = ndo_grid_f64(s->cgrid, NDO_CH_POSITION, 3);
	if (encoded && ndo_codec_last_positions(s->cenc, s->tilex) != 0)
		encoded = 0;
	size_t m = 0;
	for (int j = j0; j <= j1; j++)
		for (int i = i0; i <= i1; i++, m++) {
			size_t n = ndo_node(s->cgrid->w, i, j);
			if (s->ccls[n] == NDO_NODE_LOSSY)
				memcpy(s->cview + 3 * n, encoded ? s->tilex + 3 * m : x + 3 * n, 3 * sizeof *x);
		}
}

/* One coarse tile in the session's encoding: 1 sent, 0 not (unchanged),
 * or a negative status; one that cannot be encoded or does not fit goes
 * raw, as its children when it is shallower than a raw tile. */
static int publish_coarse_tile(ndo_session *s, ndo_quad q, int standalone, int64_t step,
                               double time)
{
	int rc = NDO_ERANGE;
	if (s->cenc) {
		ndo_msg_tile_t t;
		state_tile_head(s, s->send_level, q, step, time, &t);
		rc = ndo_codec_encode_tile(s->cenc, s->self, s->cgrid, s->ccls, q, standalone, &t);
		if (rc == 1 || rc == 0)
			coarse_view(s, q, 1);
		if (rc == 1)
			return 0;
		if (rc == 0) {
			t.channels |= NDO_TILE_COARSE;
			rc = ndo_net_publish(s->net, NDO_MSG_TILE, &t);
			free(t.data);
			if (rc != NDO_ERANGE)
				return rc ? rc : 1;
			ndo_codec_forget_tile(s->cenc, s->self, q);
		} else if (rc != NDO_ERANGE) {
			return rc;
		}
	}
	coarse_view(s, q, 0);
	if (q.depth >= s->cdepth_raw)
		return (rc = publish_raw(s, s->cgrid, q, COARSE_STATE, step, time)) ? rc : 1;
	for (int c = 0; c < quad_children(q); c++)
		if ((rc = publish_raw(s, s->cgrid, quad_child(q, c), COARSE_STATE, step, time)))
			return rc;
	return 1;
}

/* The error at the object's level of what receivers hold: the coarse
 * state as they reconstruct it (this peer's nodes; the others' as
 * received, or as this peer holds them), refined, against this peer's
 * nodes' exact positions. */
static void coarse_error(ndo_session *s, const ndo_grid *src)
{
	const double *x = ndo_grid_f64((ndo_grid *)src, NDO_CH_POSITION, 3);
	const int32_t *cown = ndo_grid_find(s->cgrid, NDO_CH_OWNER)->data;
	const double *cx = ndo_grid_f64(s->cgrid, NDO_CH_POSITION, 3);
	for (size_t n = 0; n < s->cgrid->count; n++)
		if (s->ccls[n] != NDO_NODE_LOSSY)
			memcpy(s->cview + 3 * n, s->cstep[n] >= 0 && cown[n] != s->self ? s->crecv + 6 * n
			                                                                  : cx + 3 * n,
			       3 * sizeof *cx);
	const double *f = ndo_refine(s->refiner, s->cview);
	double max, sum2;
	size_t count;
	ndo_level_error(s->level, f, x, s->fmask, &max, &sum2, &count);
	if (!(s->diag > 0))
		s->diag = rest_diagonal(s);
	double d = s->diag > 0 ? s->diag : 1;
	if (max / d > s->lst.max_error)
		s->lst.max_error = max / d;
	s->lst.sum_sq_error += sum2 / (d * d);
	s->lst.error_nodes += count;
	s->lst.frames++;
	/* the same with the displacement refined onto the rest shape at the
	 * object's level, for a receiver that holds it (not what the watch does) */
	const double *rest = ndo_grid_f64((ndo_grid *)src, NDO_CH_REST, 3);
	const double *crest = ndo_grid_f64(s->cgrid, NDO_CH_REST, 3);
	if (!s->measure_disp || !rest || !crest || !s->dview)
		return;
	for (size_t n = 0; n < 3 * s->cgrid->count; n++)
		s->cview[n] -= crest[n];
	f = ndo_refine(s->refiner, s->cview);
	for (size_t n = 0; n < 3 * src->count; n++)
		s->dview[n] = f[n] + rest[n];
	ndo_level_error(s->level, s->dview, x, s->fmask, &max, &sum2, &count);
	if (max / d > s->lst.max_error_disp)
		s->lst.max_error_disp = max / d;
	s->lst.sum_sq_error_disp += sum2 / (d * d);
}

/* This peer's region at the send level, from src (s->grid, or an earlier
 * step's grid sent again: standalone frames, no error counted). */
static int publish_coarse(ndo_session *s, const ndo_grid *src, int64_t step, double time)
{
	const int k = s->level - s->send_level;
	const char *chans[3] = {NDO_CH_POSITION, NDO_CH_VELOCITY, NDO_CH_REST};
	for (int c = 0; c < 3; c++) {
		const double *from = ndo_grid_f64((ndo_grid *)src, chans[c], 3);
		if (from)
			ndo_sample_nodes(s->level, k, 3 * sizeof(double), from,
			                 ndo_grid_f64(s->cgrid, chans[c], 3));
	}
	s->cgrid->step = step;
	s->cgrid->time = time;
	int standalone = src != s->grid, sent = 0;
	for (size_t n = 0; n < s->nctiles; n++) {
		ndo_quad q;
		ndo_quad_decode(s->send_level, s->ctiles[n], &q);
		int rc = publish_coarse_tile(s, q, standalone, step, time);
		if (rc < 0)
			return rc;
		sent += rc;
	}
	if (!standalone)
		coarse_error(s, src);
	return sent;
}

static int publish_tiles_from(ndo_session *s, const ndo_grid *src, const int32_t *codes,
                              size_t n, int channels, int64_t step, double time)
{
	int sent = 0;
	for (size_t k = 0; k < n; k++) {
		ndo_quad q;
		ndo_quad_decode(s->level, codes[k], &q);
		if (s->enc && channels == (NDO_TILE_POSITION | NDO_TILE_VELOCITY)) {
			int rc = publish_encoded(s, src, q, step, time);
			if (rc < 0)
				return rc;
			sent += rc;
			continue;
		}
		int rc = publish_raw(s, src, q, channels, step, time);
		if (rc)
			return rc;
		sent++;
	}
	return sent;
}

static int publish_tiles(ndo_session *s, const int32_t *codes, size_t n, int channels,
                         int64_t step, double time)
{
	return publish_tiles_from(s, s->grid, codes, n, channels, step, time);
}

/* Every tile of the whole grid at `depth`. */
static int publish_everything(ndo_session *s, int depth, int channels)
{
	int cols, rows;
	ndo_quad_dims(depth, &cols, &rows);
	int32_t *codes = malloc((size_t)cols * rows * sizeof *codes);
	if (!codes)
		return NDO_ENOMEM;
	for (int qj = 0; qj < rows; qj++)
		for (int qi = 0; qi < cols; qi++)
			codes[qj * cols + qi] = ndo_quad_code((ndo_quad){depth, qi, qj});
	/* raw: a joiner starts from the exact state */
	ndo_codec *enc = s->enc;
	s->enc = NULL;
	int rc = publish_tiles(s, codes, (size_t)cols * rows, channels, s->grid->step,
	                       s->grid->time);
	s->enc = enc;
	free(codes);
	return rc;
}

/* The owner's answer to a hello or a description request (figure 4.14 b, e):
 * description, partition, peers, the rest shape and the whole state. */
static int full_send(ndo_session *s)
{
	int rc;
	if ((rc = publish_description(s)) || (rc = publish_partition(s)) || (rc = publish_peers(s)))
		return rc;
	rc = publish_everything(s, s->tdepth_rest, NDO_TILE_REST | NDO_TILE_PIN);
	if (rc >= 0)
		rc = publish_everything(s, s->tdepth_state, NDO_TILE_POSITION | NDO_TILE_VELOCITY);
	s->last_full = s->now;
	s->full_pending = 0;
	return rc < 0 ? rc : 0;
}

/* ---- members ----------------------------------------------------------- */
static member *find_member(ndo_session *s, int32_t id)
{
	for (int i = 0; i < s->nm; i++)
		if (s->m[i].id == id)
			return &s->m[i];
	return NULL;
}

static member *add_member(ndo_session *s, int32_t id, int32_t poi)
{
	member *m = find_member(s, id);
	if (m || s->nm == NDO_MAX_MEMBERS - 1)
		return m;
	m = &s->m[s->nm++];
	*m = (member){id, poi, s->now};
	event(s, NDO_EV_JOINED, id, 0, NULL);
	return m;
}

static int simulates(const ndo_session *s, int32_t id)
{
	for (int p = 0; p < s->npeers; p++)
		if (s->peers[p] == id)
			return 1;
	return 0;
}

/* Owner: a member is gone (announced or timed out). */
static int drop_member(ndo_session *s, int32_t id, int reason, const char *why)
{
	member *m = find_member(s, id);
	if (!m) { /* never took part, but says why it goes (a joiner refusing its --poi) */
		if (why && *why && s->o.role == NDO_ROLE_OWNER && id != s->gone_said)
			event(s, NDO_EV_LEFT, id, reason, why); /* once: a LEAVE comes twice */
		s->gone_said = id;
		return 0;
	}
	*m = s->m[--s->nm];
	ndo_net_forget(s->net, id);
	event(s, NDO_EV_LEFT, id, reason, why);
	s->gone_said = id; /* its second LEAVE finds no member: said already */
	int rc = 0;
	if (simulates(s, id) && (rc = repartition(s)) == 0)
		rc = publish_partition(s);
	if (!rc)
		rc = publish_peers(s);
	return rc;
}

/* ---- succession ------------------------------------------------------- */
static int lost(const ndo_session *s, int32_t id)
{
	for (int k = 0; k < s->nlost; k++)
		if (s->lost[k] == id)
			return 1;
	return 0;
}

static void lose(ndo_session *s, int32_t id)
{
	if (!lost(s, id) && s->nlost < NDO_MAX_PEERS)
		s->lost[s->nlost++] = id;
}

/* Who owns the session when the owner falls silent: the first simulating
 * peer of the partition in force other than the owner, the owners lost
 * before it and the peers this one heard leave — the same peer everywhere
 * that partition is (not the peer list: a joiner may not have had one
 * yet when the owner died).  0: none (no succession, no partition, nobody
 * left). */
static int32_t successor(ndo_session *s)
{
	if (!s->succession || !s->cells)
		return 0;
	for (int p = 0; p < s->npeers; p++) {
		int32_t id = s->peers[p];
		if (id != s->owner_id && !lost(s, id))
			return id;
	}
	return 0;
}

/* This peer owns the session now: the owner's partitions (without the
 * lost owner, restarting from restart_next), description and peer list
 * at once, and the owner's duties from here on. */
static int take_over(ndo_session *s)
{
	s->o.role = NDO_ROLE_OWNER;
	s->owner_id = s->self;
	s->full_pending = 1;
	for (int i = 0; i < s->nm; i++) /* a lost successor is not a member any more */
		if (lost(s, s->m[i].id))
			s->m[i--] = s->m[--s->nm];
	/* every simulating peer of the partition is one (its point of
	 * interest as the partition gives it), whether or not a peer list
	 * said so: one that is gone too is dropped after the timeout */
	for (int p = 0; p < s->npeers; p++) {
		int32_t id = s->peers[p];
		member *m = id == s->self || lost(s, id) ? NULL : find_member(s, id);
		if (m)
			m->poi = s->pois[p];
		else if (id != s->self && !lost(s, id))
			add_member(s, id, s->pois[p]);
	}
	int rc = repartition(s);
	if (!rc)
		rc = publish_description(s);
	if (!rc)
		rc = publish_partition(s);
	if (!rc)
		rc = publish_peers(s);
	return rc;
}

/* The owner is lost (`how`): `next` (successor()) owns the session. */
static int succeed(ndo_session *s, int32_t next, const char *how)
{
	char why[200];
	int32_t gone = s->owner_id;
	lose(s, gone);
	snprintf(why, sizeof why, "the owner (peer %d) %s: peer %d owns the session now%s", gone,
	         how, next, next == s->self ? " (this one)" : "");
	ndo_net_forget(s->net, gone);
	s->owner_id = next;
	s->owner_heard = s->now;
	event(s, NDO_EV_OWNER, next, 0, why);
	return next == s->self ? take_over(s) : 0;
}

/* A message of the owner's kind from `from`, not the owner, for a newer
 * partition than the one in force (`epoch`): the successor, which took
 * the owner for dead before this peer did, is followed at once; anyone
 * else is counted (an authority drop).  `listed`: the message itself names
 * `from` among the simulating peers (a partition).  1: follow it now; 0:
 * dropped; negative: a status. */
static int successor_speaks(ndo_session *s, int32_t from, int32_t epoch, int listed)
{
	/* a peer outside its partition (an observer; a joiner not yet in it)
	 * may hold none, or an old one that does not name the successor: the
	 * owner's first, before the joiners came, the newer ones lost.  It
	 * follows a member the owner listed, or one the partition it sends
	 * lists, once the owner has been silent for the timeout, as long as
	 * the successor waits before it takes over.  Until 2026-11-30 such a
	 * peer holding a partition followed only the successor it named (none:
	 * an observer in peers-owner.sh timed the dead owner out only at its
	 * start timeout; test_peer
	 * an_observer_with_an_old_partition_follows_the_successor) */
	int outsider = !s->cells || !simulates(s, s->self);
	int unnamed = outsider && s->succession && !lost(s, from) &&
	              (listed || find_member(s, from)) && s->now - s->owner_heard >= s->o.timeout;
	if (s->o.role != NDO_ROLE_OWNER && epoch > s->epoch && (from == successor(s) || unnamed)) {
		int rc = succeed(s, from, "is silent to its successor");
		return rc ? rc : 1;
	}
	count_authority(s);
	return 0;
}

/* ---- receiving --------------------------------------------------------- */
static int on_description(ndo_session *s, const ndo_msg_description_t *d)
{
	if (s->o.role == NDO_ROLE_OWNER)
		return 0;
	if (s->described) {
		if (d->hdr.sender_id != s->owner_id) {
			int rc = successor_speaks(s, d->hdr.sender_id, d->epoch, 0);
			return rc < 0 ? rc : 0;
		}
		return 0;
	}
	if (s->o.object_id && d->hdr.object_id != s->o.object_id)
		return 0;
	{ /* a description whose tile encoding this build cannot use: ignored */
		ndo_codec_params cp;
		int bad = ndo_codec_params_read(d->scene, (size_t)d->scene_len, &cp);
		if (bad == NDO_ENOMEM)
			return bad;
		char *copy = malloc((size_t)d->scene_len + 1); /* scene: NULL when empty */
		if (copy && d->scene_len)
			memcpy(copy, d->scene, (size_t)d->scene_len);
		if (copy)
			copy[d->scene_len] = 0;
		ndo_msg_ctx probe = {0};
		if (!copy)
			return NDO_ENOMEM;
		if (!bad && ndo_msg_box_take(copy, &probe) < 0) /* a bad object box */
			bad = NDO_EINVAL;
		int L;
		if (!bad && d->level >= 0 && d->level <= NDO_MAX_LEVEL &&
		    ndo_send_level_take(copy, d->level, &L)) /* a bad send level */
			bad = NDO_EINVAL;
		free(copy);
		if (bad) {
			((ndo_net_stats *)ndo_net_stats_get(s->net))->dropped[NDO_DROP_RANGE]++;
			return 0;
		}
	}
	ndo_grid *g;
	int rc = ndo_grid_create(d->level, &g);
	if (rc)
		return rc;
	s->grid = g;
	s->object = d->hdr.object_id;
	s->owner_id = d->hdr.sender_id;
	s->owner_heard = s->now;
	if ((rc = prepare_grid(s)) != 0)
		return rc;
	free(s->scene);
	s->scene = malloc((size_t)d->scene_len + 1);
	if (!s->scene)
		return NDO_ENOMEM;
	if (d->scene_len)
		memcpy(s->scene, d->scene, (size_t)d->scene_len);
	s->scene[d->scene_len] = 0;
	/* the object's box: the bound on the state received (checked above) */
	ndo_msg_box_take(s->scene, ndo_net_ctx(s->net));
	/* the tile encoding: decoded by the net, encoded by this peer */
	if ((rc = ndo_codec_params_take(s->scene, &s->codec)) ||
	    (rc = ndo_net_set_codec(s->net, &s->codec, s->level)))
		return rc; /* checked above: only out of memory */
	if (s->codec.encoding != NDO_ENC_RAW && (rc = ndo_codec_create(&s->codec, s->level, &s->enc)))
		return rc;
	if ((rc = ndo_send_level_take(s->scene, s->level, &s->send_level)) ||
	    (rc = ndo_net_set_send_level(s->net, s->send_level, s->level)) || (rc = coarse_prepare(s)))
		return rc;
	s->method = (ndo_part_method)d->partition;
	s->have = calloc(g->count, 1);
	if (!s->have)
		return NDO_ENOMEM;
	/* until a partition says otherwise, the owner integrates everything */
	int32_t *own = owner_channel(s);
	for (size_t k = 0; k < g->count; k++)
		own[k] = s->owner_id;
	s->described = 1;
	ndo_net_attach(s->net, s->object, s->level);
	s->next_poi = s->now;
	return 0;
}

static int on_partition(ndo_session *s, const ndo_msg_partition_t *p)
{
	int32_t from = p->hdr.sender_id;
	if (from != s->owner_id && s->o.role == NDO_ROLE_OWNER && s->succession &&
	    p->epoch > s->epoch && simulates(s, from)) {
		/* a successor: the others took this owner for dead (it was
		 * silent for the timeout) and went on without it */
		char why[200];
		snprintf(why, sizeof why, "peer %d owns the session now: the others took this owner "
		         "for lost (silent for longer than the timeout)", from);
		s->ended = 1;
		event(s, NDO_EV_ENDED, from, NDO_LEAVE_TIMEOUT, why);
		return 0;
	}
	if (from != s->owner_id) {
		int listed = 0;
		for (int k = 0; k < p->npeers; k++)
			listed |= p->peers[k] == from;
		int rc = successor_speaks(s, from, p->epoch, listed);
		if (rc <= 0)
			return rc;
	}
	if (s->o.role == NDO_ROLE_OWNER || !s->described || p->epoch <= s->epoch)
		return 0; /* old news (it is re-sent every heartbeat) */
	int32_t *cells = malloc(ndo_cell_count(s->level) * sizeof *cells);
	if (!cells)
		return NDO_ENOMEM;
	ndo_partition_cells(s->level, p, cells);
	int rc = install(s, cells, p->npeers, p->peers, p->pois, p->epoch,
	                 (ndo_part_method)p->method, p->restart);
	event(s, NDO_EV_PARTITION, 0, 0, NULL);
	return rc;
}

static void on_peers(ndo_session *s, const ndo_msg_peers_t *p)
{
	if (p->hdr.sender_id != s->owner_id) {
		if (p->hdr.sender_id != successor(s)) /* (followed with its partition) */
			count_authority(s);
		return;
	}
	if (s->o.role == NDO_ROLE_OWNER)
		return;
	for (int i = 0; i < s->nm; i++) { /* gone from the list */
		int there = 0;
		for (int k = 0; k < p->npeers; k++)
			there |= p->peers[k] == s->m[i].id;
		if (!there) {
			lose(s, s->m[i].id);
			event(s, NDO_EV_LEFT, s->m[i].id, NDO_LEAVE_QUIT, NULL);
			ndo_net_forget(s->net, s->m[i].id);
			s->m[i--] = s->m[--s->nm];
		}
	}
	for (int k = 0; k < p->npeers; k++)
		if (p->peers[k] != s->self && p->peers[k] != s->owner_id) {
			member *m = find_member(s, p->peers[k]);
			if (m) /* its POI as the owner knows it now (the partitions of a successor) */
				m->poi = p->pois[k];
			else
				add_member(s, p->peers[k], p->pois[k]);
		}
}

static int on_leave(ndo_session *s, const ndo_msg_leave_t *l)
{
	int32_t from = l->hdr.sender_id;
	char why[300];
	if (s->o.role == NDO_ROLE_OWNER) {
		if (l->peer != from) { /* only the owner speaks for others */
			count_authority(s);
			return 0;
		}
		return drop_member(s, from, l->reason, l->message);
	}
	if (from == s->owner_id && (l->peer == from || l->reason == NDO_LEAVE_OWNER_QUIT)) {
		snprintf(why, sizeof why, "the owner quit%s%s", *l->message ? ": " : "", l->message);
		s->ended = 1;
		event(s, NDO_EV_ENDED, from, NDO_LEAVE_OWNER_QUIT, why);
		return 0;
	}
	if (l->peer == s->self && from == s->owner_id) {
		snprintf(why, sizeof why, "the owner dropped this peer%s%s", *l->message ? ": " : "",
		         l->message);
		s->ended = 1;
		event(s, NDO_EV_ENDED, from, l->reason, why);
		return 0;
	}
	if (l->peer != from && from != s->owner_id) {
		count_authority(s);
		return 0;
	}
	lose(s, l->peer); /* never the owner's successor */
	member *m = find_member(s, l->peer);
	if (m) {
		*m = s->m[--s->nm];
		ndo_net_forget(s->net, l->peer);
		event(s, NDO_EV_LEFT, l->peer, l->reason, l->message);
	}
	return 0;
}

static void apply_tile(ndo_session *s, const ndo_msg_tile_t *t, int decoded);

static int handle(ndo_session *s, ndo_msg *m)
{
	int32_t from = m->hdr->sender_id;
	int owner = s->o.role == NDO_ROLE_OWNER;
	member *mem = find_member(s, from);
	if (mem)
		mem->heard = s->now;
	if (!owner && from == s->owner_id)
		s->owner_heard = s->now;
	switch (m->type) {
	case NDO_MSG_HELLO:
		if (owner && m->u.hello.role == NDO_ROLE_JOINER) {
			add_member(s, from, -1);
			s->full_pending = 1;
			return publish_peers(s);
		}
		return 0;
	case NDO_MSG_DESC_REQUEST:
		if (owner && (m->u.desc_request.owner_id == 0 || m->u.desc_request.owner_id == s->self)) {
			add_member(s, from, -1);
			s->full_pending = 1;
		}
		return 0;
	case NDO_MSG_KEY_REQUEST: {
		/* a receiver lost a frame of tiles this peer sends */
		const ndo_msg_key_request_t *k = &m->u.key_request;
		ndo_codec *c = k->coarse ? s->cenc : s->enc;
		for (int j = 0; c && k->sender == s->self && j < k->ntiles; j++)
			ndo_codec_want_key(c, s->self, k->codes[j]);
		return 0;
	}
	case NDO_MSG_HEARTBEAT:
		if (owner && !mem)
			add_member(s, from, -1); /* its hello was lost */
		return 0;
	case NDO_MSG_POI:
		if (owner) {
			member *p = add_member(s, from, -1);
			if (p && p->poi != m->u.poi.face) {
				p->poi = m->u.poi.face;
				int rc = repartition(s);
				return rc ? rc : publish_partition(s);
			}
		}
		return 0;
	case NDO_MSG_DESCRIPTION: return on_description(s, &m->u.description);
	case NDO_MSG_PARTITION: return on_partition(s, &m->u.partition);
	case NDO_MSG_PEERS: on_peers(s, &m->u.peers); return 0;
	case NDO_MSG_HALO:
		if (s->grid && s->described && s->o.halo_fn)
			s->o.halo_fn(s->o.tile_user, &m->u.halo);
		return 0;
	case NDO_MSG_SOLVE:
		if (s->grid && s->described && s->o.solve_fn)
			s->o.solve_fn(s->o.tile_user, &m->u.solve);
		return 0;
	case NDO_MSG_TILE: /* with tile_fn: every tile, in arrival order */
		if (s->grid && s->described)
			apply_tile(s, &m->u.tile, m->decoded);
		return 0;
	case NDO_MSG_LEAVE: return on_leave(s, &m->u.leave);
	case NDO_MSG_FORCE: {
		ndo_event e;
		memset(&e, 0, sizeof e);
		e.type = NDO_EV_FORCE;
		e.peer = from;
		e.step = m->u.force.step;
		e.nforces = m->u.force.nforces;
		push_event(s, e); /* faces/forces filled when popped */
		if (s->holding_force)
			ndo_msg_free(&s->force);
		s->force = *m;
		s->force.hdr = (const ndo_msg_header_t *)&s->force.u;
		s->holding_force = 1;
		m->hdr = NULL; /* kept */
		return 0;
	}
	default:
		return 0;
	}
}

/* One tile from another peer.  Rest and pin come only from the owner and
 * are written here; position and velocity go into the nodes the sender
 * owns (before READY the owner's snapshot fills every node), or to the
 * caller's tile_fn.  Marks what a joiner has received: only tiles that
 * travelled raw count.  A decoded tile (ndo/codec.h) is no snapshot: it
 * carries the sender's nodes only (NaN elsewhere), its LOSSY values are
 * not the sender's, and marking its whole range made a joiner that had
 * lost part of the snapshot READY with zeros in its region (issue 7). */
static void apply_tile(ndo_session *s, const ndo_msg_tile_t *t, int decoded)
{
	int32_t *own = owner_channel(s);
	int32_t from = t->hdr.sender_id;
	if (t->channels & NDO_TILE_COARSE) { /* the send level: kept apart (frames) */
		if (!s->cgrid)
			return;
		const int32_t *cown = ndo_grid_find(s->cgrid, NDO_CH_OWNER)->data;
		const int hasv = (t->channels & NDO_TILE_VELOCITY) != 0;
		size_t k = 0;
		for (int j = t->j0; j <= t->j1; j++)
			for (int i = t->i0; i <= t->i1; i++, k += hasv ? 6 : 3) {
				size_t n = ndo_node(s->cgrid->w, i, j);
				if (cown[n] != from || t->step < s->cstep[n] || isnan(t->values[k]))
					continue;
				memcpy(s->crecv + 6 * n, &t->values[k], 3 * sizeof *s->crecv);
				for (int d = 0; d < 3; d++)
					s->crecv[6 * n + 3 + d] = hasv ? t->values[k + 3 + d] : NAN;
				s->cstep[n] = t->step;
			}
		return;
	}
	if (t->channels & (NDO_TILE_REST | NDO_TILE_PIN)) {
		if (from != s->owner_id || s->o.role == NDO_ROLE_OWNER) {
			count_authority(s);
			return;
		}
		ndo_tile_apply(s->grid, t, NULL, 0);
	} else {
		int fill = !s->ready && from == s->owner_id && !decoded;
		if (s->o.tile_fn)
			s->o.tile_fn(s->o.tile_user, t,
			             (fill ? NDO_TILE_FN_FILL : 0) | (decoded ? NDO_TILE_FN_DECODED : 0));
		else
			ndo_tile_apply(s->grid, t, fill ? NULL : own, from);
	}
	s->applied = 1;
	if (s->have && !decoded) {
		uint8_t bit = (t->channels & NDO_TILE_REST) ? 1 : 2;
		for (int j = t->j0; j <= t->j1; j++)
			for (int i = t->i0; i <= t->i1; i++) {
				size_t node = ndo_node(s->grid->w, i, j);
				if (bit == 2 && !(own[node] == from || from == s->owner_id))
					continue;
				if (!(s->have[node] & bit)) {
					s->have[node] |= bit;
					*(bit == 1 ? &s->have_rest : &s->have_state) += 1;
				}
			}
	}
	if (!s->o.tile_fn && t->step > s->grid->step) { /* with tile_fn: the caller's */
		s->grid->step = t->step;
		s->grid->time = t->time;
	}
}

/* The newest tile of each range since the last update (without tile_fn). */
static void apply_tiles(ndo_session *s)
{
	ndo_msg *tiles;
	size_t n;
	if (ndo_net_take_tiles(s->net, &tiles, &n) != 0)
		return;
	if (s->grid && s->described)
		for (size_t k = 0; k < n; k++)
			apply_tile(s, &tiles[k].u.tile, tiles[k].decoded);
	for (size_t k = 0; k < n; k++)
		ndo_msg_free(&tiles[k]);
	free(tiles);
}

/* ---- the step ---------------------------------------------------------- */
static int send_hello(ndo_session *s)
{
	ndo_msg_hello_t h = {.role = (int8_t)s->o.role, .name = s->name};
	return ndo_net_publish(s->net, NDO_MSG_HELLO, &h);
}

/* Owner: how long member `id` may be silent: the timeout in the partition
 * in force, where its neighbours wait for it; outside it (an observer, a
 * joiner building its simulation — 7 s at level 10 on a loaded machine —
 * before it asks for a share) nobody waits, so outside_timeout. */
static double silence_limit(const ndo_session *s, int32_t id)
{
	for (int p = 0; p < s->npeers; p++)
		if (s->peers[p] == id)
			return s->o.timeout;
	return fmax(s->o.timeout, s->o.outside_timeout);
}

int ndo_session_update(ndo_session *s, double now)
{
	/* Silence is counted while this peer listens: of a gap between two
	 * updates (a process stopped or starved of the CPU, a long step) no
	 * more than half the timeout counts against the others, so that a
	 * peer that stalls does not drop everyone it did not hear meanwhile
	 * (an owner stopped for 0.8 s at a timeout of 0.5 s dropped both its
	 * joiners), while a dead peer's silence still grows by half the
	 * timeout or more at every update. */
	const double prev = s->now, gap = now - prev - 0.5 * s->o.timeout;
	if (gap > 0) {
		for (int i = 0; i < s->nm; i++)
			s->m[i].heard += gap;
		s->owner_heard += gap;
	}
	s->now = now;
	if (s->ended)
		return 0;
	int rc = ndo_net_poll(s->net, now);
	if (rc < 0)
		return rc;
	/* Nor is it counted while this peer could not hear: when its socket's
	 * buffer filled since the last update and the kernel dropped datagrams
	 * (ndo_link_overflows), a peer silent meanwhile may have spoken.  At
	 * level 10 a whole object is 150 MB: its sender's own copy, looped back,
	 * overflowed its 64 MiB buffer for seconds, and the owner dropped its
	 * live joiners for "no heartbeat" (docs/peers.md, "Joins, leaves").  A
	 * dead peer's silence counts again once the flood is over. */
	const uint64_t over = ndo_net_stats_get(s->net)->overflowed;
	if (over != s->overflowed) {
		s->overflowed = over;
		const double deaf = now - prev - fmax(gap, 0);
		for (int i = 0; deaf > 0 && i < s->nm; i++)
			s->m[i].heard = fmin(now, s->m[i].heard + deaf);
		if (deaf > 0)
			s->owner_heard = fmin(now, s->owner_heard + deaf);
	}
	ndo_msg m;
	while (ndo_net_next(s->net, &m)) {
		rc = handle(s, &m);
		ndo_msg_free(&m);
		if (rc < 0)
			return rc;
		if (s->ended)
			return 0;
	}
	apply_tiles(s);
	if (s->applied && s->grid)
		ndo_grid_sync(s->grid);
	s->applied = 0;
	int owner = s->o.role == NDO_ROLE_OWNER;
	if (owner) {
		for (int i = 0; i < s->nm; i++)
			if (now - s->m[i].heard > fmax(silence_limit(s, s->m[i].id), s->grace)) {
				int32_t id = s->m[i].id;
				char why[96];
				snprintf(why, sizeof why, "no heartbeat for %.1f s", now - s->m[i].heard);
				ndo_msg_leave_t l = {.peer = id, .reason = NDO_LEAVE_TIMEOUT, .message = why};
				if ((rc = ndo_net_publish(s->net, NDO_MSG_LEAVE, &l)) ||
				    (rc = drop_member(s, id, NDO_LEAVE_TIMEOUT, why)))
					return rc;
				i = -1; /* the list changed */
			}
		if (s->full_pending && now - s->last_full >= FULL_SEND_GAP && (rc = full_send(s)))
			return rc;
	} else {
		if (!s->ready && s->described && s->cells && s->have_rest == s->grid->count &&
		    s->have_state == s->grid->count) {
			s->ready = 1;
			event(s, NDO_EV_READY, s->owner_id, 0, NULL);
		}
		if (!s->ready && now - s->last_ask >= s->o.retry) {
			/* a late joiner, or one that lost part of the description */
			ndo_msg_desc_request_t d = {.owner_id = s->owner_id};
			rc = s->described ? ndo_net_publish(s->net, NDO_MSG_DESC_REQUEST, &d) : send_hello(s);
			if (rc)
				return rc;
			s->last_ask = now;
		}
		if (s->described && now - s->owner_heard > fmax(s->o.timeout, s->grace)) {
			char why[96];
			int32_t next = successor(s);
			if (next) {
				snprintf(why, sizeof why, "timed out (silent for %.1f s)", now - s->owner_heard);
				return succeed(s, next, why);
			}
			snprintf(why, sizeof why, "the owner timed out (silent for %.1f s)",
			         now - s->owner_heard);
			s->ended = 1;
			event(s, NDO_EV_ENDED, s->owner_id, NDO_LEAVE_TIMEOUT, why);
			return 0;
		}
		/* the point of interest once the object is whole here: a
		 * partition that gives this peer a region while it still waits
		 * for the snapshot would hold the others' lock-step meanwhile */
		if (s->ready && s->cells && s->poi_acked != s->o.poi && now >= s->next_poi &&
		    !(s->o.poi < 0 && s->poi_acked == -2)) {
			ndo_msg_poi_t p = {.face = s->o.poi};
			if ((rc = ndo_net_publish(s->net, NDO_MSG_POI, &p)))
				return rc;
			s->next_poi = now + s->o.heartbeat;
		}
	}
	if (now >= s->next_hb) {
		ndo_msg_heartbeat_t h = {.step = s->grid ? s->grid->step : 0,
		                         .time = s->grid ? s->grid->time : 0, .epoch = s->epoch};
		if (s->described && (rc = ndo_net_publish(s->net, NDO_MSG_HEARTBEAT, &h)))
			return rc;
		if (owner) {
			if ((rc = publish_partition(s)) || (rc = publish_peers(s)))
				return rc;
			if (s->hb_count % 5 == 0 && (rc = publish_description(s)))
				return rc;
		}
		s->hb_count++;
		s->next_hb = now + s->o.heartbeat;
	}
	return 0;
}

int ndo_session_event(ndo_session *s, ndo_event *ev)
{
	if (!s->evcount)
		return 0;
	*ev = s->ev[s->evhead];
	s->evhead = (s->evhead + 1) % NEV;
	s->evcount--;
	if (ev->type == NDO_EV_FORCE && s->holding_force) {
		ev->faces = s->force.u.force.faces;
		ev->forces = (const double (*)[3])NULL;
		ev->nforces = s->force.u.force.nforces;
		/* the generated struct holds rows as double*: flatten for the caller */
		static _Thread_local double flat[NDO_MAX_FORCES][3];
		for (int k = 0; k < ev->nforces; k++)
			memcpy(flat[k], s->force.u.force.forces[k], sizeof flat[k]);
		ev->forces = (const double (*)[3])flat;
	}
	return 1;
}

int ndo_session_publish(ndo_session *s, int64_t step, double time)
{
	if (!s->grid || s->ended || (!s->ready && s->o.role != NDO_ROLE_OWNER))
		return 0;
	s->grid->step = step;
	s->grid->time = time;
	if (coarse_now(s, step))
		return publish_coarse(s, s->grid, step, time);
	return publish_tiles(s, s->tiles, s->ntiles, NDO_TILE_POSITION | NDO_TILE_VELOCITY, step,
	                     time);
}

int ndo_session_send_halo(ndo_session *s, ndo_msg_halo_t *h)
{
	if (!s->grid || s->ended || (!s->ready && s->o.role != NDO_ROLE_OWNER))
		return 0;
	h->epoch = s->epoch;
	return ndo_net_publish(s->net, NDO_MSG_HALO, h);
}

int ndo_session_send_nodes(ndo_session *s, ndo_msg_halo_t *h, size_t n, const int32_t *nodes,
                           const double *vals, const int32_t *idx, const uint8_t *have,
                           int32_t *rs, int32_t *rl, double *buf)
{
	/* ~60 kB a message: one datagram with the header and channel name */
	const size_t budget = 60000;
	int sent = 0;
	size_t k = 0;
	while (k < n) {
		size_t nr = 0, nn = 0, bytes = 64;
		for (; k < n && bytes + 56 <= budget; k++) {
			int32_t c = nodes[k];
			if (have && !have[c])
				continue;
			if (nr && rs[nr - 1] + rl[nr - 1] == c) {
				rl[nr - 1]++;
				bytes += 48;
			} else {
				rs[nr] = c;
				rl[nr++] = 1;
				bytes += 56;
			}
			memcpy(buf + 6 * nn++, vals + 6 * (size_t)(idx ? idx[k] : c), 6 * sizeof *buf);
		}
		if (!nn)
			break;
		h->nruns = (int32_t)nr;
		h->start = rs;
		h->len = rl;
		h->nvalues = (int32_t)(6 * nn);
		h->values = buf;
		int rc = ndo_session_send_halo(s, h);
		if (rc < 0)
			return rc;
		sent++;
	}
	return sent;
}

int ndo_session_send_solve(ndo_session *s, ndo_msg_solve_t *m)
{
	if (!s->grid || s->ended || (!s->ready && s->o.role != NDO_ROLE_OWNER))
		return 0;
	m->epoch = s->epoch;
	return ndo_net_publish(s->net, NDO_MSG_SOLVE, m);
}

int ndo_session_publish_from(ndo_session *s, const ndo_grid *src, int64_t step, double time)
{
	if (!s->grid || s->ended || (!s->ready && s->o.role != NDO_ROLE_OWNER))
		return 0;
	if (src->level != s->level)
		return ndo__fail(NDO_EINVAL, "publish: a level-%d grid for a level-%d object",
		                 src->level, s->level);
	if (coarse_now(s, step))
		return publish_coarse(s, src, step, time);
	return publish_tiles_from(s, src, s->tiles, s->ntiles,
	                          NDO_TILE_POSITION | NDO_TILE_VELOCITY, step, time);
}

int ndo_session_set_poi(ndo_session *s, int32_t face)
{
	if (s->level >= 0 && s->grid && (face < -1 || face >= (int64_t)4 << (2 * s->level)))
		return ndo__fail(NDO_ERANGE, "point of interest %d: faces are 0..%lld", face,
		                 ((long long)4 << (2 * s->level)) - 1);
	s->o.poi = face;
	if (s->o.role == NDO_ROLE_OWNER && s->grid) {
		int rc = repartition(s);
		return rc ? rc : publish_partition(s);
	}
	s->next_poi = s->now;
	return 0;
}

int ndo_session_send_forces(ndo_session *s, int64_t step, int n, const int32_t *faces,
                            const double (*forces)[3])
{
	if (n < 0 || n > NDO_MAX_FORCES)
		return ndo__fail(NDO_ERANGE, "forces: %d (0..%d)", n, NDO_MAX_FORCES);
	double *rows[NDO_MAX_FORCES];
	for (int k = 0; k < n; k++)
		rows[k] = (double *)forces[k];
	ndo_msg_force_t f = {.step = step, .nforces = (int16_t)n, .faces = (int32_t *)faces,
	                     .forces = rows};
	return ndo_net_publish(s->net, NDO_MSG_FORCE, &f);
}

/* ---- life -------------------------------------------------------------- */
/* The owner's description: n more bytes of lines. */
static int scene_append(ndo_session *s, const char *lines, size_t n)
{
	size_t have = strlen(s->scene);
	if (have + n > NDO_MAX_SCENE)
		return ndo__fail(NDO_ERANGE, "the description takes more than %d bytes", NDO_MAX_SCENE);
	char *sc = realloc(s->scene, have + n + 1);
	if (!sc)
		return NDO_ENOMEM;
	memcpy(sc + have, lines, n);
	sc[have + n] = 0;
	s->scene = sc;
	return 0;
}

/* The owner's box (its rest shape, or its positions when it has none):
 * the bound on the state every peer receives (ndo_msg_set_box), in the
 * description as an object-box line.  An object that is a point (a grid
 * of zeros) has none: its state is only checked to be finite. */
static int owner_box(ndo_session *s, ndo_msg_ctx *c)
{
	const double *x = rest_or_positions(s);
	char line[256];
	int n = ndo_msg_box_text(x, s->grid->count, line, sizeof line);
	if (n < 0)
		return n;
	if (ndo_msg_box_take(line, c) < 0) { /* a point, or not finite */
		ndo__clear_error();
		return 0; /* no bound but finiteness (a grid of zeros, in tests) */
	}
	n = ndo_msg_box_text(x, s->grid->count, line, sizeof line); /* take emptied it */
	return scene_append(s, line, (size_t)n);
}

/* The owner's encoding: the box, the encoder, the net's decoder and the
 * description's lines. */
static int owner_codec(ndo_session *s, const ndo_codec_params *p)
{
	s->codec = *p;
	if (!(s->codec.ext[0] > 0)) {
		const double *x = ndo_grid_f64(s->grid, NDO_CH_REST, 3);
		ndo_channel *rest = ndo_grid_find(s->grid, NDO_CH_REST);
		int have_rest = x && rest && rest->data; /* a rest channel that is not all zero */
		if (have_rest) {
			have_rest = 0;
			for (size_t k = 0; k < 3 * s->grid->count && !have_rest; k++)
				have_rest = x[k] != 0;
		}
		if (!have_rest)
			x = ndo_grid_f64(s->grid, NDO_CH_POSITION, 3);
		ndo_codec_box(x, s->grid->count, s->codec.lo, s->codec.ext);
	}
	char lines[512];
	int n = ndo_codec_params_text(&s->codec, lines, sizeof lines), rc;
	if (n < 0)
		return n;
	if ((rc = ndo_codec_create(&s->codec, s->level, &s->enc)) ||
	    (rc = ndo_net_set_codec(s->net, &s->codec, s->level)))
		return rc;
	return scene_append(s, lines, (size_t)n);
}

/* The owner's send level: the description's line, the net's decoder of
 * the others' coarse tiles, the coarse grids. */
static int owner_send_level(ndo_session *s, int coarse_levels)
{
	if (coarse_levels < 0 || coarse_levels > s->level)
		return ndo__fail(NDO_ERANGE, "a send level %d levels below a level-%d object",
		                 coarse_levels, s->level);
	s->send_level = s->level - coarse_levels;
	char line[64];
	int n = ndo_send_level_text(s->send_level, s->level, line, sizeof line), rc;
	if (n < 0)
		return n;
	if ((rc = scene_append(s, line, (size_t)n)) ||
	    (rc = ndo_net_set_send_level(s->net, s->send_level, s->level)))
		return rc;
	return coarse_prepare(s);
}

int ndo_session_create(const ndo_session_opts *o, ndo_net *net, ndo_grid *grid,
                       ndo_session **out)
{
	ndo__clear_error();
	int owner = o->role == NDO_ROLE_OWNER;
	if ((o->role != NDO_ROLE_OWNER && o->role != NDO_ROLE_JOINER) || (owner != !!grid) ||
	    (o->scene && strlen(o->scene) > NDO_MAX_SCENE)) {
		ndo_net_destroy(net);
		ndo_grid_destroy(grid);
		return ndo__fail(NDO_EINVAL, "session: an owner needs a grid, a joiner none; "
		                 "scene ≤ %d bytes", NDO_MAX_SCENE);
	}
	ndo_session *s = calloc(1, sizeof *s);
	if (!s) {
		ndo_net_destroy(net);
		ndo_grid_destroy(grid);
		return ndo__fail(NDO_ENOMEM, "out of memory");
	}
	s->o = *o;
	if (!s->o.heartbeat) s->o.heartbeat = 0.2;
	if (!s->o.timeout) s->o.timeout = 2.0;
	if (!s->o.retry) s->o.retry = 1.0;
	if (!s->o.partition) s->o.partition = NDO_PART_QUADTREE;
	snprintf(s->name, sizeof s->name, "%s", o->name ? o->name : "peer");
	for (char *c = s->name; *c; c++)
		if (*c < 32 || *c == 127)
			*c = '?';
	s->scene = strdup(o->scene ? o->scene : "");
	s->net = net;
	s->grid = grid;
	if (o->tile_fn)
		ndo_net_keep_all_tiles(net, 1);
	ndo_net_ask_keys(net, 1); /* for the encoded tiles other peers send */
	s->level = -1;
	s->send_level = NDO_MAX_LEVEL + 1; /* none below the object's until known */
	s->epoch = 0;
	s->restart = s->restart_next = -1;
	s->exact_step = -1;
	s->codec.encoding = NDO_ENC_RAW;
	s->method = s->o.partition;
	s->rng = o->seed ? o->seed : (uint64_t)time(NULL) * 1000003u ^ (uint64_t)getpid() << 20 ^
	                             (uint64_t)(ndo_now() * 1e9);
	s->self = o->self_id ? o->self_id : (int32_t)((ndo_rng_next(&s->rng) & 0x7ffffffe) | 1);
	ndo_msg_ctx *c = ndo_net_ctx(net);
	c->self_id = s->self;
	int rc = s->scene ? 0 : NDO_ENOMEM;
	if (!rc && owner) {
		s->object = o->object_id ? o->object_id
		                         : (int64_t)((ndo_rng_next(&s->rng) >> 2) | 1);
		s->owner_id = s->self;
		c->object_id = s->object;
		rc = prepare_grid(s);
		c->level = s->level;
		if (!rc)
			rc = owner_box(s, c);
		s->described = s->ready = 1;
		if (!rc && o->codec && o->codec->encoding != NDO_ENC_RAW)
			rc = owner_codec(s, o->codec);
		if (!rc)
			rc = owner_send_level(s, o->coarse_levels);
		if (!rc)
			rc = repartition(s);
		s->evcount = 0; /* the owner's first partition is no news */
	} else if (!rc) {
		s->object = o->object_id;
		c->object_id = 0; /* attach to the first description that matches */
		s->last_ask = -1e9;
	}
	if (rc) {
		ndo_session_destroy(s, NULL);
		return rc;
	}
	*out = s;
	return 0;
}

void ndo_session_leave(ndo_session *s, const char *message)
{
	if (!s || !s->described || s->ended)
		return;
	int owner = s->o.role == NDO_ROLE_OWNER;
	ndo_msg_leave_t l = {.peer = s->self,
	                     .reason = (int8_t)(owner ? NDO_LEAVE_OWNER_QUIT : NDO_LEAVE_QUIT),
	                     .message = (char *)(message ? message : "")};
	char buf[NDO_MAX_TEXT + 1];
	snprintf(buf, sizeof buf, "%s", l.message);
	l.message = buf;
	/* three times: a lost leave costs the others a timeout (after the
	 * last step, a successor's restart and gather: docs/peers.md; with two
	 * copies 1 joiner in 100 under 10 % loss, in test_peer's
	 * TEST_PEER_OWNER sweep 3 runs in 150 ended with two heirs) */
	for (int k = 0; k < 3; k++)
		ndo_net_publish(s->net, NDO_MSG_LEAVE, &l);
	s->ended = 1;
}

void ndo_session_destroy(ndo_session *s, const char *message)
{
	if (!s)
		return;
	ndo_session_leave(s, message);
	if (s->holding_force)
		ndo_msg_free(&s->force);
	ndo_net_destroy(s->net);
	ndo_grid_destroy(s->grid);
	free(s->scene);
	free(s->cells);
	free(s->leaf_codes);
	free(s->leaf_slots);
	free(s->tiles);
	free(s->have);
	free(s->cls);
	free(s->cls_exact);
	ndo_codec_destroy(s->enc);
	ndo_grid_destroy(s->cgrid);
	free(s->crecv), free(s->cstep), free(s->ccls), free(s->cuse), free(s->cview), free(s->tilex);
	free(s->fmask), free(s->ctiles), free(s->dview);
	ndo_codec_destroy(s->cenc);
	ndo_refiner_destroy(s->refiner);
	free(s);
}

void ndo_session_set_exact_step(ndo_session *s, int64_t step) { s->exact_step = step; }
void ndo__session_forget_members(ndo_session *s) { s->nm = 0; }
void ndo_session_set_succession(ndo_session *s, int on) { s->succession = on != 0; }
void ndo_session_set_grace(ndo_session *s, double seconds) { s->grace = seconds; }

int ndo_session_silent(const ndo_session *s)
{
	int n = 0;
	for (int i = 0; i < s->nm; i++)
		n += s->now - s->m[i].heard > silence_limit(s, s->m[i].id);
	return n;
}
void ndo_session_set_exact_halos(ndo_session *s, int on) { s->exact_halos = on != 0; }
void ndo_session_measure_displacement(ndo_session *s, int on) { s->measure_disp = on != 0; }
int ndo_session_send_level(const ndo_session *s) { return s->level < 0 ? -1 : s->send_level; }

void ndo_session_level_stats_get(const ndo_session *s, ndo_session_level_stats *st)
{
	*st = s->lst;
	st->level = s->level;
	st->send_level = s->level < 0 ? -1 : s->send_level;
	if (s->cenc)
		ndo_codec_stats_get(s->cenc, &st->enc);
	else
		memset(&st->enc, 0, sizeof st->enc);
}

int64_t ndo_session_refine_others(ndo_session *s, int64_t *nstep)
{
	if (!s->cgrid || !s->grid || !s->described)
		return 0;
	const int k = s->level - s->send_level, wc = s->cgrid->w;
	const size_t nc = s->cgrid->count;
	double *x = ndo_grid_f64(s->grid, NDO_CH_POSITION, 3);
	double *v = ndo_grid_f64(s->grid, NDO_CH_VELOCITY, 3);
	/* a coarse node is taken as it travelled when that is newer than what
	 * the grid holds; the oldest of those is the refinement's step */
	int64_t oldest = -1;
	for (size_t n = 0; n < nc; n++) {
		size_t f = ndo_canonical(s->level, (int)(n % (size_t)wc) << k, (int)(n / (size_t)wc) << k);
		s->cuse[n] = s->cstep[n] >= 0 && nstep[f] < s->cstep[n];
		if (s->cuse[n] && (oldest < 0 || s->cstep[n] < oldest))
			oldest = s->cstep[n];
	}
	int64_t taken = 0;
	for (int comp = 0; comp < 2 && oldest >= 0; comp++) { /* positions, then velocities */
		double *f = comp ? v : x;
		ndo_sample_nodes(s->level, k, 3 * sizeof(double), f, s->cview);
		for (size_t n = 0; n < nc; n++)
			if (s->cuse[n] && !isnan(s->crecv[6 * n + 3 * comp]))
				memcpy(s->cview + 3 * n, s->crecv + 6 * n + 3 * comp, 3 * sizeof *f);
		memcpy(s->dview, ndo_refine(s->refiner, s->cview), 3 * s->grid->count * sizeof *f);
		for (int j = 0; j <= (1 << s->level); j++)
			for (int i = 0; i <= (2 << s->level); i++) {
				size_t n = ndo_node(s->grid->w, i, j);
				if (nstep[n] >= oldest || ndo_canonical(s->level, i, j) != n)
					continue;
				memcpy(f + 3 * n, s->dview + 3 * n, 3 * sizeof *f);
				if (comp) {
					nstep[n] = oldest;
					taken++;
				}
			}
	}
	if (taken)
		ndo_grid_sync(s->grid);
	return taken;
}

int ndo_session_frame(ndo_session *s, ndo_grid **out)
{
	*out = NULL;
	if (!s->grid || !s->described)
		return ndo__fail(NDO_EINVAL, "no object yet");
	int rc = ndo_restrict(s->grid, s->level - s->send_level, out);
	if (rc || !s->cgrid)
		return rc;
	double *x = ndo_grid_f64(*out, NDO_CH_POSITION, 3), *v = ndo_grid_f64(*out, NDO_CH_VELOCITY, 3);
	const int32_t *cown = ndo_grid_find(*out, NDO_CH_OWNER)->data;
	for (size_t n = 0; n < (*out)->count; n++)
		if (cown[n] != s->self && s->cstep[n] >= 0) {
			memcpy(x + 3 * n, s->crecv + 6 * n, 3 * sizeof *x);
			if (v && !isnan(s->crecv[6 * n + 3]))
				memcpy(v + 3 * n, s->crecv + 6 * n + 3, 3 * sizeof *v);
		}
	return 0;
}
const ndo_codec_params *ndo_session_codec(const ndo_session *s) { return &s->codec; }
size_t ndo_session_exact_nodes(const ndo_session *s) { return s->enc ? s->nexact : 0; }

void ndo_session_codec_stats(const ndo_session *s, ndo_codec_stats *enc, ndo_codec_stats *dec)
{
	if (enc) {
		memset(enc, 0, sizeof *enc);
		if (s->enc)
			ndo_codec_stats_get(s->enc, enc);
		if (s->cenc) {
			ndo_codec_stats c;
			ndo_codec_stats_get(s->cenc, &c);
			enc->keys_asked += c.keys_asked;
			enc->keys_forced += c.keys_forced;
			enc->keyframes += c.keyframes;
			enc->encoded += c.encoded;
		}
	}
	if (dec) {
		memset(dec, 0, sizeof *dec);
		const ndo_codec *c = ndo_net_codec(s->net);
		if (c)
			ndo_codec_stats_get(c, dec);
	}
}

ndo_grid *ndo_session_grid(ndo_session *s) { return s->described ? s->grid : NULL; }
int ndo_session_ready(const ndo_session *s) { return s->ready && !s->ended; }
int ndo_session_ended(const ndo_session *s) { return s->ended; }
int32_t ndo_session_self(const ndo_session *s) { return s->self; }
int64_t ndo_session_object(const ndo_session *s) { return s->object; }
int32_t ndo_session_owner_id(const ndo_session *s) { return s->owner_id; }
int32_t ndo_session_successor(ndo_session *s) { return successor(s); }
const char *ndo_session_scene(const ndo_session *s) { return s->scene; }
int32_t ndo_session_epoch(const ndo_session *s) { return s->epoch; }
int64_t ndo_session_restart(const ndo_session *s) { return s->restart; }
void ndo_session_set_restart(ndo_session *s, int64_t step) { s->restart_next = step < 0 ? -1 : step; }
ndo_net *ndo_session_net(ndo_session *s) { return s->net; }

const int32_t *ndo_session_cells(const ndo_session *s, int *npeers, const int32_t **peers)
{
	if (npeers)
		*npeers = s->npeers;
	if (peers)
		*peers = s->peers;
	return s->cells;
}

size_t ndo_session_owned_nodes(const ndo_session *s)
{
	if (!s->grid || !s->described)
		return 0;
	const int32_t *own = ndo_grid_find(s->grid, NDO_CH_OWNER)->data;
	size_t n = 0;
	for (size_t k = 0; k < s->grid->count; k++)
		n += own[k] == s->self;
	return n;
}
