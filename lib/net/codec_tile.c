/* codec_tile.c — encoded tiles on the wire: each (sender, tile)'s history,
 * the last frames sent (to send them again), decoding in place
 * (ndo/codec.h). */
#include "ndo/codec.h"
#include "ndo/status.h"
#include "ndo/topology.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* The history kept for all tiles, least used forgotten beyond it: the
 * object's twice over (the senders of a new partition's tiles beside the
 * old ones), and at least MEMORY_MIN.  Until 2026-11-30 it was a fixed
 * 256 MB, below a level-10 object's history alone (2.1 M nodes × 160
 * bytes, 336 MB): each tile was forgotten just before its next frame, so
 * every frame of every tile was a keyframe (4.8 bits a node against 0.5
 * at level 9, encode + decode 219 ms against 11). */
#define MEMORY_MIN ((size_t)256 << 20)
#define CACHED 2                       /* frames kept per tile to send again */

typedef struct cached {
	int64_t step, base;
	uint8_t *data;
	size_t len;
} cached;

typedef struct entry {
	int32_t sender, code;
	int32_t epoch;
	int nodes;
	ndo_codec_hist h;
	int64_t last_key;   /* encoder: step of the last keyframe */
	int64_t last_sent;  /* encoder: step of the last frame sent (or skipped) */
	int skips;          /* encoder: steps skipped in a row */
	int since_key;      /* encoder: frames sent since the last keyframe */
	int want_key;       /* encoder: a receiver asked for a keyframe */
	cached c[CACHED];   /* encoder: the last frames sent */
	size_t at;          /* its place in the codec's e[] */
	struct entry *older, *newer; /* the order of use (get()) */
	/* decoder: the last frame decoded (for ndo_codec_skipped) */
	int64_t dec_step, dec_base;
	double dec_time, base_time;
} entry;

struct ndo_codec {
	ndo_codec_params p;
	int level;
	ndo_codec_work *w;
	/* The entries: in e[], found by (sender, code) in slot[] (open
	 * addressing, nslot a power of two at least twice n), and in the order
	 * of their last use from oldest (the first forgotten) to newest: each
	 * step O(1), whatever the count.  Until 2026-11-30 every lookup and
	 * every forgetting scanned them all, and a flood of valid keyframes
	 * of one-node tiles under new ids, up to memory_max, made that
	 * millions a message. */
	entry **e, **slot;
	size_t n, cap, nslot, memory, memory_max;
	entry *oldest, *newest;
	ndo_codec_stats st;
	double *x, *v;      /* a tile's values, scratch */
	uint8_t *cls;
	size_t scap;
	ndo_codec_frame fr; /* a frame, scratch */
	int frnodes;
	const ndo_codec_frame *last; /* the frame ndo_codec_encode_tile() last made */
	int last_nodes;
};

size_t ndo_codec_classify(int level, const int32_t *own, int32_t self, uint8_t *cls)
{
	const int w = (2 << level) + 1;
	const size_t count = (size_t)w * (size_t)((1 << level) + 1);
	for (size_t k = 0; k < count; k++) {
		size_t c = ndo_canonical(level, (int)(k % (size_t)w), (int)(k / (size_t)w));
		cls[k] = own[c] == self ? NDO_NODE_LOSSY : NDO_NODE_SKIP;
	}
	for (size_t k = 0; k < count; k++) {
		int i = (int)(k % (size_t)w), j = (int)(k / (size_t)w);
		if (ndo_canonical(level, i, j) != k || own[k] == self)
			continue;
		size_t nb[6];
		ndo_neighbors(level, i, j, nb);
		for (int d = 0; d < 6; d++) {
			size_t c = ndo_canonical(level, (int)(nb[d] % (size_t)w), (int)(nb[d] / (size_t)w));
			if (own[c] == self)
				cls[c] = NDO_NODE_EXACT;
		}
	}
	size_t n = 0;
	for (size_t k = 0; k < count; k++) { /* duplicates as their canonical node */
		cls[k] = cls[ndo_canonical(level, (int)(k % (size_t)w), (int)(k / (size_t)w))];
		n += cls[k] == NDO_NODE_EXACT;
	}
	return n;
}

static double mono(void)
{
	struct timespec t;
	clock_gettime(CLOCK_MONOTONIC, &t);
	return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* A tile's history in bytes (ndo_codec_hist: NDO_CODEC_HISTORY frames of
 * x, k and have, 37 bytes a node). */
static size_t entry_size(int nodes) { return (size_t)nodes * 40 * NDO_CODEC_HISTORY; }

int ndo_codec_create(const ndo_codec_params *p, int level, ndo_codec **out)
{
	ndo__clear_error();
	int rc = ndo_codec_params_check(p);
	if (rc)
		return rc;
	if (level < 0 || level > 10)
		return ndo__fail(NDO_EINVAL, "codec: level %d", level);
	ndo_codec *c = calloc(1, sizeof *c);
	if (!c || !(c->w = ndo_codec_work_create())) {
		free(c);
		return ndo__fail(NDO_ENOMEM, "out of memory");
	}
	c->p = *p;
	c->level = level;
	const size_t count = (size_t)((2 << level) + 1) * (size_t)((1 << level) + 1);
	c->memory_max = 2 * entry_size((int)count);
	if (c->memory_max < MEMORY_MIN)
		c->memory_max = MEMORY_MIN;
	*out = c;
	return 0;
}

static void entry_free(entry *e)
{
	if (!e)
		return;
	ndo_codec_hist_free(&e->h);
	for (int k = 0; k < CACHED; k++)
		free(e->c[k].data);
	free(e);
}

void ndo_codec_destroy(ndo_codec *c)
{
	if (!c)
		return;
	for (size_t k = 0; k < c->n; k++)
		entry_free(c->e[k]);
	free(c->e);
	free(c->slot);
	free(c->x), free(c->v), free(c->cls);
	free(c->fr.x), free(c->fr.k), free(c->fr.have);
	ndo_codec_work_destroy(c->w);
	free(c);
}

const ndo_codec_params *ndo_codec_params_of(const ndo_codec *c) { return &c->p; }
void ndo_codec_set_memory(ndo_codec *c, size_t bytes) { c->memory_max = bytes; }
void ndo_codec_stats_get(const ndo_codec *c, ndo_codec_stats *st) { *st = c->st; }

/* Scratch for a tile of `nodes`. */
static int scratch(ndo_codec *c, int nodes)
{
	if ((size_t)nodes > c->scap) {
		free(c->x), free(c->v), free(c->cls);
		c->x = malloc(3 * (size_t)nodes * sizeof *c->x);
		c->v = malloc(3 * (size_t)nodes * sizeof *c->v);
		c->cls = malloc((size_t)nodes);
		c->scap = c->x && c->v && c->cls ? (size_t)nodes : 0;
		if (!c->scap)
			return ndo__fail(NDO_ENOMEM, "out of memory");
	}
	if (nodes > c->frnodes) {
		free(c->fr.x), free(c->fr.k), free(c->fr.have);
		c->fr.x = malloc(3 * (size_t)nodes * sizeof *c->fr.x);
		c->fr.k = malloc(3 * (size_t)nodes * sizeof *c->fr.k);
		c->fr.have = malloc((size_t)nodes);
		c->frnodes = c->fr.x && c->fr.k && c->fr.have ? nodes : 0;
		if (!c->frnodes)
			return ndo__fail(NDO_ENOMEM, "out of memory");
	}
	return 0;
}

static size_t home(const ndo_codec *c, int32_t sender, int32_t code)
{
	uint64_t k = ((uint64_t)(uint32_t)sender << 32 | (uint32_t)code) * 0x9e3779b97f4a7c15ull;
	return (size_t)(k ^ k >> 29) & (c->nslot - 1);
}

/* The entry of (sender, code), or NULL. */
static entry *find(const ndo_codec *c, int32_t sender, int32_t code)
{
	if (!c->nslot)
		return NULL;
	for (size_t i = home(c, sender, code);; i = (i + 1) & (c->nslot - 1)) {
		entry *e = c->slot[i];
		if (!e || (e->sender == sender && e->code == code))
			return e;
	}
}

static void slot_put(ndo_codec *c, entry *e)
{
	size_t i = home(c, e->sender, e->code);
	while (c->slot[i])
		i = (i + 1) & (c->nslot - 1);
	c->slot[i] = e;
}

/* Room in slot[] for one more entry: 0, or NDO_ENOMEM. */
static int slot_room(ndo_codec *c)
{
	if (2 * (c->n + 1) <= c->nslot)
		return 0;
	size_t ns = c->nslot ? 2 * c->nslot : 128;
	entry **sl = calloc(ns, sizeof *sl);
	if (!sl)
		return NDO_ENOMEM;
	free(c->slot);
	c->slot = sl;
	c->nslot = ns;
	for (size_t k = 0; k < c->n; k++)
		slot_put(c, c->e[k]);
	return 0;
}

/* Entry e out of slot[]: the entries after it in its run moved back
 * where their probes pass (linear probing's deletion). */
static void slot_erase(ndo_codec *c, const entry *e)
{
	const size_t mask = c->nslot - 1;
	size_t i = home(c, e->sender, e->code);
	while (c->slot[i] != e)
		i = (i + 1) & mask;
	for (size_t j = (i + 1) & mask; c->slot[j]; j = (j + 1) & mask) {
		size_t h = home(c, c->slot[j]->sender, c->slot[j]->code);
		/* slot[j] may fill the hole at i when its home is not in (i, j] */
		if (((j - h) & mask) >= ((j - i) & mask)) {
			c->slot[i] = c->slot[j];
			i = j;
		}
	}
	c->slot[i] = NULL;
}

static void unlink_use(ndo_codec *c, entry *e)
{
	*(e->older ? &e->older->newer : &c->oldest) = e->newer;
	*(e->newer ? &e->newer->older : &c->newest) = e->older;
	e->older = e->newer = NULL;
}

static void link_newest(ndo_codec *c, entry *e)
{
	e->older = c->newest;
	e->newer = NULL;
	*(c->newest ? &c->newest->newer : &c->oldest) = e;
	c->newest = e;
}

/* Entry e forgotten: out of slot[], the order of use and e[]. */
static void drop_entry(ndo_codec *c, entry *e)
{
	slot_erase(c, e);
	unlink_use(c, e);
	c->e[e->at] = c->e[--c->n];
	c->e[e->at]->at = e->at;
	c->memory -= entry_size(e->nodes);
	entry_free(e);
}

/* The entry of (sender, code), the newest in use, made when missing
 * (*made set; NULL: out of memory). */
static entry *get(ndo_codec *c, int32_t sender, int32_t code, int nodes, int *made)
{
	*made = 0;
	entry *e = find(c, sender, code);
	if (e) {
		unlink_use(c, e);
		link_newest(c, e);
		return e;
	}
	while (c->memory + entry_size(nodes) > c->memory_max && c->n) /* forget the least used */
		drop_entry(c, c->oldest);
	if (c->n == c->cap) {
		size_t cap = c->cap ? 2 * c->cap : 64;
		entry **ne = realloc(c->e, cap * sizeof *ne);
		if (!ne)
			return NULL;
		c->e = ne;
		c->cap = cap;
	}
	if (slot_room(c))
		return NULL;
	e = calloc(1, sizeof *e);
	if (!e || ndo_codec_hist_init(&e->h, nodes)) {
		free(e);
		return NULL;
	}
	e->sender = sender;
	e->code = code;
	e->nodes = nodes;
	e->epoch = -1;
	e->last_key = e->last_sent = e->dec_step = e->dec_base = -1;
	for (int k = 0; k < CACHED; k++)
		e->c[k].step = -1;
	e->at = c->n;
	c->e[c->n++] = e;
	slot_put(c, e);
	link_newest(c, e);
	c->memory += entry_size(nodes);
	*made = 1;
	return e;
}

static void forget(entry *e, int32_t epoch)
{
	ndo_codec_hist_clear(&e->h);
	e->epoch = epoch;
	e->last_key = e->last_sent = -1;
	e->skips = e->since_key = e->want_key = 0;
	for (int k = 0; k < CACHED; k++) {
		free(e->c[k].data);
		e->c[k].data = NULL;
		e->c[k].step = -1;
	}
}

static int fill_tile(ndo_msg_tile_t *t, int enc, int64_t base, const uint8_t *data, size_t len)
{
	uint8_t *d = malloc(len ? len : 1);
	if (!d)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	memcpy(d, data, len);
	t->encoding = (int8_t)enc;
	t->base_step = base;
	t->nvalues = 0;
	t->values = NULL;
	t->nbytes = (int32_t)len;
	t->data = d;
	return 0;
}

int ndo_codec_encode_tile(ndo_codec *c, int32_t self, const ndo_grid *g, const uint8_t *cls,
                          ndo_quad q, int standalone, ndo_msg_tile_t *t)
{
	double t0 = mono();
	c->last = NULL;
	int i0, j0, i1, j1;
	ndo_quad_range(g->level, q, &i0, &j0, &i1, &j1);
	int cols = i1 - i0 + 1, rows = j1 - j0 + 1, nodes = rows * cols;
	const double *x = ndo_grid_f64((ndo_grid *)g, NDO_CH_POSITION, 3);
	const double *v = ndo_grid_f64((ndo_grid *)g, NDO_CH_VELOCITY, 3);
	if (!x || !v)
		return ndo__fail(NDO_EINVAL, "codec: the grid has no f64 position and velocity");
	int rc = scratch(c, nodes);
	if (rc)
		return rc;
	int made;
	entry *e = get(c, self, ndo_quad_code(q), nodes, &made);
	if (!e)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	if (e->epoch != t->epoch && !standalone)
		forget(e, t->epoch);
	if (standalone) { /* a step sent again: the same bytes, if still held */
		for (int k = 0; k < CACHED; k++)
			if (e->c[k].step == t->step && e->c[k].data && e->epoch == t->epoch)
				return fill_tile(t, c->p.encoding, e->c[k].base, e->c[k].data, e->c[k].len);
		if (e->epoch == t->epoch && t->step <= e->last_sent && t->step > e->c[0].step &&
		    e->c[0].step >= 0)
			return 1; /* it was skipped */
	}
	for (int j = 0; j < rows; j++) { /* a row of the tile is a run of the grid's */
		size_t node = ndo_node(g->w, i0, j0 + j), n = (size_t)j * (size_t)cols;
		memcpy(c->cls + n, cls + node, (size_t)cols);
	}
	/* positions and velocities read in place, a grid row apart */
	const size_t first = ndo_node(g->w, i0, j0);
	ndo_codec_input in = {rows,    cols,    x + 3 * first, v + 3 * first, c->cls,
	                      t->step, t->time, t->epoch,      g->w};
	/* a keyframe when one is due — but not right after skipped steps: the
	 * frame after them tells receivers what they were (the next is the key) */
	int periodic = e->last_key < 0 || t->step <= e->last_sent || e->h.f[0].step < 0 ||
	               (t->step - e->last_key >= c->p.keyframe && e->skips == 0);
	/* or one a receiver asked for, at most one in NDO_CODEC_KEY_GAP frames */
	int asked = !periodic && e->want_key && e->since_key + 1 >= NDO_CODEC_KEY_GAP && e->skips == 0;
	int due = periodic || asked;
	int intra = standalone ? 2 : due ? 1 : 0;
	uint8_t *data;
	size_t len;
	int64_t base;
	int unchanged;
	rc = ndo_codec_encode(&c->p, c->w, &e->h, intra, &in, &data, &len, &base, &c->fr, &unchanged);
	if (rc == NDO_ERANGE && !standalone) {
		forget(e, t->epoch);
		c->st.raw_fallbacks++;
	}
	if (rc)
		return rc;
	if (!standalone) { /* the error of the LOSSY nodes (the others' is 0) */
		double max2, sum;
		size_t count;
		ndo_codec_work_error(c->w, &max2, &sum, &count);
		c->st.sum_sq_error += sum;
		c->st.error_nodes += count;
		if (max2 > c->st.max_error * c->st.max_error)
			c->st.max_error = sqrt(max2);
	}
	if (!standalone && unchanged && e->skips < NDO_CODEC_MAX_SKIP) {
		free(data);
		e->skips++;
		e->last_sent = t->step;
		c->st.skipped++;
		c->st.encode_seconds += mono() - t0;
		c->last = &c->fr, c->last_nodes = nodes; /* what receivers imply */
		return 1;
	}
	if (!standalone) {
		if (base < 0) /* a keyframe: later frames refer to it and after only */
			ndo_codec_hist_clear(&e->h);
		if (ndo_codec_hist_take(&e->h, &c->fr))
			c->frnodes = nodes; /* c->fr now has the dropped frame's arrays */
		e->skips = 0;
		e->last_sent = t->step;
		e->since_key++;
		if (base < 0) {
			e->last_key = t->step;
			e->since_key = 0;
			c->st.keys_forced += (uint64_t)asked;
			e->want_key = 0;
		}
		free(e->c[CACHED - 1].data);
		memmove(&e->c[1], &e->c[0], (CACHED - 1) * sizeof e->c[0]);
		e->c[0] = (cached){t->step, base, data, len};
		rc = fill_tile(t, c->p.encoding, base, data, len);
		c->last = ndo_codec_hist_find(&e->h, t->step);
		if (!c->last) /* older than every frame held: not kept, still in fr */
			c->last = &c->fr;
		c->last_nodes = nodes;
	} else {
		rc = fill_tile(t, c->p.encoding, base, data, len);
		free(data);
	}
	c->st.encoded++;
	c->st.keyframes += base < 0;
	c->st.payload_bytes += len;
	c->st.encode_seconds += mono() - t0;
	return rc;
}

int ndo_codec_last_positions(const ndo_codec *c, double *x)
{
	if (!c->last)
		return ndo__fail(NDO_EINVAL, "codec: no frame encoded");
	for (int n = 0; n < c->last_nodes; n++)
		ndo_codec_frame_position(&c->p, c->last, n, x + 3 * n);
	return 0;
}

int ndo_codec_want_key(ndo_codec *c, int32_t self, int32_t code)
{
	entry *e = find(c, self, code);
	if (!e)
		return 0;
	c->st.keys_asked++;
	e->want_key = e->last_key >= 0; /* none sent yet: the first is one */
	return 1;
}

void ndo_codec_forget_tile(ndo_codec *c, int32_t self, ndo_quad q)
{
	entry *e = find(c, self, ndo_quad_code(q));
	if (e)
		forget(e, e->epoch);
}

ndo_drop ndo_codec_decode_tile(ndo_codec *c, ndo_msg_tile_t *t)
{
	if (t->encoding == NDO_ENC_RAW)
		return NDO_DROP_NONE;
	if (t->encoding != c->p.encoding)
		return NDO_DROP_ENCODING;
	double t0 = mono();
	int cols = t->i1 - t->i0 + 1, rows = t->j1 - t->j0 + 1, nodes = rows * cols;
	ndo_quad q;
	if (ndo_quad_from_range(c->level, t->depth, t->i0, t->j0, t->i1, t->j1, &q) != 0)
		return NDO_DROP_RANGE;
	if (scratch(c, nodes))
		return NDO_DROP_RANGE;
	/* An entry is made only for a frame that decodes: before 2026-11-30
	 * a corrupt one under a new id each left one, and a flood of them
	 * (300,000 16-byte keyframes) made the table 400 MB and every later
	 * tile's lookups 1 ms. */
	int made;
	entry *e = get(c, t->hdr.sender_id, ndo_quad_code(q), nodes, &made);
	double *vals = malloc(6 * (size_t)nodes * sizeof *vals);
	if (!e || !vals) {
		free(vals);
		if (e && made)
			drop_entry(c, e);
		return NDO_DROP_RANGE;
	}
	int keep = t->epoch >= e->epoch; /* an old partition's frame is no reference */
	if (e->epoch != t->epoch) {
		if (!keep && t->base_step >= 0) {
			free(vals);
			if (made)
				drop_entry(c, e);
			c->st.nobase++;
			return NDO_DROP_NOBASE;
		}
		if (keep)
			forget(e, t->epoch);
	}
	ndo_drop r = ndo_codec_decode_strided(&c->p, c->w, &e->h, rows, cols, t->data,
	                                      (size_t)t->nbytes, t->step, t->time, t->epoch,
	                                      t->base_step, vals, vals + 3, 6, &c->fr);
	if (r != NDO_DROP_NONE) {
		free(vals);
		if (made)
			drop_entry(c, e);
		if (r == NDO_DROP_CORRUPT)
			c->st.corrupt++;
		if (r == NDO_DROP_NOBASE)
			c->st.nobase++;
		return r;
	}
	const ndo_codec_frame *base = ndo_codec_hist_find(&e->h, t->base_step);
	e->base_time = base ? base->time : t->time;
	if (c->fr.step >= 0 && keep) {
		if (t->base_step < 0) /* a keyframe, as the sender keeps it */
			ndo_codec_hist_clear(&e->h);
		if (ndo_codec_hist_take(&e->h, &c->fr))
			c->frnodes = nodes;
	}
	e->dec_step = keep ? t->step : -1;
	e->dec_base = t->base_step;
	e->dec_time = t->time;
	free(t->data);
	t->data = NULL;
	t->nbytes = 0;
	free(t->values);
	t->values = vals;
	t->nvalues = 6 * nodes;
	t->encoding = NDO_ENC_RAW;
	t->base_step = -1;
	c->st.decoded++;
	c->st.decode_seconds += mono() - t0;
	return NDO_DROP_NONE;
}

/* The entry of a tile's sender and range, or NULL (none yet, or a range
 * that is no node of the tree). */
static entry *entry_of(const ndo_codec *c, const ndo_msg_tile_t *t)
{
	ndo_quad q;
	if (ndo_quad_from_range(c->level, t->depth, t->i0, t->j0, t->i1, t->j1, &q) != 0)
		return NULL;
	return find(c, t->hdr.sender_id, ndo_quad_code(q));
}

int ndo_codec_tile_known(const ndo_codec *c, const ndo_msg_tile_t *t)
{
	return entry_of(c, t) != NULL;
}

int ndo_codec_base_state(const ndo_codec *c, const ndo_msg_tile_t *t)
{
	if (t->encoding == NDO_ENC_RAW || t->encoding != c->p.encoding || t->base_step < 0)
		return NDO_BASE_READY;
	ndo_quad q;
	if (ndo_quad_from_range(c->level, t->depth, t->i0, t->j0, t->i1, t->j1, &q) != 0)
		return NDO_BASE_READY; /* the decode drops it as range */
	const entry *e = entry_of(c, t);
	if (!e || t->epoch > e->epoch)
		return NDO_BASE_PENDING;
	if (t->epoch < e->epoch)
		return NDO_BASE_GONE;
	if (ndo_codec_hist_find(&e->h, t->base_step))
		return NDO_BASE_READY;
	return t->base_step > e->dec_step ? NDO_BASE_PENDING : NDO_BASE_GONE;
}

int ndo_codec_skipped(const ndo_codec *c, const ndo_msg_tile_t *t)
{
	entry *e = entry_of(c, t);
	if (!e || e->dec_step != t->step || e->dec_base < 0 || (c->p.encoding != NDO_ENC_PREDICT && c->p.encoding != NDO_ENC_HIER))
		return 0;
	int64_t gap = t->step - e->dec_base - 1;
	return gap > 0 && gap <= NDO_CODEC_MAX_SKIP ? (int)gap : 0;
}

int ndo_codec_skipped_tile(ndo_codec *c, const ndo_msg_tile_t *t, int k, ndo_msg_tile_t *out)
{
	entry *e = entry_of(c, t);
	int n = ndo_codec_skipped(c, t);
	if (!e || k < 0 || k >= n)
		return ndo__fail(NDO_EINVAL, "no skipped step %d", k);
	int cols = t->i1 - t->i0 + 1, rows = t->j1 - t->j0 + 1, nodes = rows * cols;
	if (scratch(c, nodes))
		return NDO_ENOMEM;
	int64_t step = e->dec_base + 1 + k;
	double frac = (double)(step - e->dec_base) / (double)(t->step - e->dec_base);
	double time = e->base_time + frac * (t->time - e->base_time);
	/* the frames before `step`: the history without the newer ones */
	ndo_codec_hist view = e->h;
	for (int f = 0; f < NDO_CODEC_HISTORY; f++)
		if (view.f[f].step >= step)
			view.f[f].step = -1;
	int rc = ndo_codec_implied(&c->p, &view, rows, cols, step, time, c->x, &c->fr);
	if (rc)
		return rc;
	double *vals = malloc(6 * (size_t)nodes * sizeof *vals);
	if (!vals)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	for (int m = 0; m < nodes; m++) {
		memcpy(vals + 6 * m, c->x + 3 * m, 3 * sizeof *vals);
		for (int d = 0; d < 3; d++)
			vals[6 * m + 3 + d] = NAN;
	}
	*out = *t;
	out->step = step;
	out->time = time;
	out->values = vals;
	out->nvalues = 6 * nodes;
	out->data = NULL;
	out->nbytes = 0;
	c->st.implied++;
	return 0;
}
