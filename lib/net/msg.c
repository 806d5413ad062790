/* msg.c — decoding with checks, validation and encoding of the peers'
 * messages (ndo/msg.h). */
#include "ndo/msg.h"
#include "ndo/quadtree.h"
#include "ndo/io.h"
#include "ndo/sim.h"
#include "ndo/status.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* What the generated code offers for each type, in one table. */
typedef struct typeops {
	const char *suffix;
	const char *lcm_name; /* as nested field typestr names it */
	int (*encode)(void *, int, int, const void *);
	int (*decode)(const void *, int, int, void *);
	int (*cleanup)(void *);
	int (*encoded_size)(const void *);
	int (*num_fields)(void);
	int (*get_field)(const void *, int, lcm_field_t *);
	int64_t (*hash)(void);
	size_t struct_size;
} typeops;

#define OPS(T, SUFFIX)                                                            \
	{ SUFFIX, #T, (int (*)(void *, int, int, const void *))ndo_msg_##T##_encode,   \
	  (int (*)(const void *, int, int, void *))ndo_msg_##T##_decode,               \
	  (int (*)(void *))ndo_msg_##T##_decode_cleanup,                               \
	  (int (*)(const void *))ndo_msg_##T##_encoded_size, ndo_msg_##T##_num_fields, \
	  (int (*)(const void *, int, lcm_field_t *))ndo_msg_##T##_get_field,          \
	  __ndo_msg_##T##_get_hash, sizeof(ndo_msg_##T) }

static const typeops types[NDO_MSG_NTYPES] = {
	[NDO_MSG_DESCRIPTION] = OPS(description_t, "DESC"),
	[NDO_MSG_TILE] = OPS(tile_t, "TILE"),
	[NDO_MSG_POI] = OPS(poi_t, "POI"),
	[NDO_MSG_PARTITION] = OPS(partition_t, "PARTITION"),
	[NDO_MSG_HELLO] = OPS(hello_t, "HELLO"),
	[NDO_MSG_PEERS] = OPS(peers_t, "PEERS"),
	[NDO_MSG_LEAVE] = OPS(leave_t, "LEAVE"),
	[NDO_MSG_HEARTBEAT] = OPS(heartbeat_t, "HEARTBEAT"),
	[NDO_MSG_DESC_REQUEST] = OPS(desc_request_t, "DESC_REQUEST"),
	[NDO_MSG_FORCE] = OPS(force_t, "FORCE"),
	[NDO_MSG_HALO] = OPS(halo_t, "HALO"),
	[NDO_MSG_SOLVE] = OPS(solve_t, "SOLVE"),
	[NDO_MSG_KEY_REQUEST] = OPS(key_request_t, "KEY_REQUEST"),
};
/* The one nested type. */
static const typeops header_ops = OPS(header_t, "");

const char *ndo_msg_suffix(ndo_msg_type t)
{
	return (unsigned)t < NDO_MSG_NTYPES ? types[t].suffix : "?";
}

int ndo_msg_type_of(const char *prefix, const char *channel)
{
	size_t n = strlen(prefix);
	if (strncmp(channel, prefix, n) != 0 || channel[n] != '_')
		return -1;
	for (int t = 0; t < NDO_MSG_NTYPES; t++)
		if (strcmp(channel + n + 1, types[t].suffix) == 0)
			return t;
	return -1;
}

const char *ndo_drop_name(ndo_drop r)
{
	static const char *names[NDO_DROP_N] = {
		"none", "injected", "channel", "malformed", "version", "foreign", "unknown",
		"range", "length", "nonfinite", "encoding", "stale", "authority", "corrupt",
		"nobase", "unsigned", "wrongkey", "forged", "replay", "keyed", "box"};
	return (unsigned)r < NDO_DROP_N ? names[r] : "?";
}

size_t ndo_msg_max_payload(const char *channel)
{
	/* measured (tests/unit/test_lcm_facts.c): one datagram while
	 * channel + 1 + payload ≤ 65,499 bytes; with LCM's 8-byte header that
	 * is the largest IPv4 UDP payload, 65,507 bytes */
	return NDO_LCM_SHORT_MAX - 1 - strlen(channel);
}

/* ---- the shape walk ----------------------------------------------------
 * Walks an encoded struct field by field using the generated field table,
 * reading scalar fields into a shadow struct (so that the table's variable
 * dimensions, which it reads from the struct, are the received values) and
 * skipping arrays after checking that their sizes are sane and present.
 * Returns the bytes the struct occupies, or −1. */
static const typeops *nested(const char *typestr)
{
	return strcmp(typestr, "header_t") == 0 ? &header_ops : NULL;
}

static int scalar_size(lcm_field_type_t t)
{
	switch (t) {
	case LCM_FIELD_INT8_T: case LCM_FIELD_BYTE: case LCM_FIELD_BOOLEAN: return 1;
	case LCM_FIELD_INT16_T: return 2;
	case LCM_FIELD_INT32_T: case LCM_FIELD_FLOAT: return 4;
	case LCM_FIELD_INT64_T: case LCM_FIELD_DOUBLE: return 8;
	default: return 0;
	}
}

static int64_t read_be(const uint8_t *p, int n)
{
	uint64_t v = 0;
	for (int k = 0; k < n; k++)
		v = v << 8 | p[k];
	/* sign-extend an n-byte integer */
	if (n < 8 && (v >> (8 * n - 1)) & 1)
		v |= ~(uint64_t)0 << (8 * n);
	return (int64_t)v;
}

static long walk(const typeops *ops, const uint8_t *buf, long len, void *shadow, int depth)
{
	if (depth > 4)
		return -1;
	long pos = 0;
	int nf = ops->num_fields();
	for (int i = 0; i < nf; i++) {
		lcm_field_t f;
		memset(&f, 0, sizeof f);
		if (ops->get_field(shadow, i, &f) != 0)
			return -1;
		/* elements of the field: product of its dimensions */
		int64_t count = 1;
		for (int d = 0; d < f.num_dim; d++) {
			if (f.dim_size[d] < 0)
				return -1;
			count *= f.dim_size[d];
			if (count > len)
				return -1; /* even one byte each would overrun */
		}
		if (f.type == LCM_FIELD_USER_TYPE) {
			const typeops *sub = nested(f.typestr);
			if (!sub || f.num_dim != 0)
				return -1;
			long used = walk(sub, buf + pos, len - pos, f.data, depth + 1);
			if (used < 0)
				return -1;
			pos += used;
		} else if (f.type == LCM_FIELD_STRING) {
			for (int64_t k = 0; k < count; k++) {
				if (len - pos < 4)
					return -1;
				int64_t n = read_be(buf + pos, 4);
				pos += 4;
				/* length counts the terminating NUL, which must be there */
				if (n < 1 || n > len - pos || buf[pos + n - 1] != 0)
					return -1;
				pos += n;
			}
		} else {
			int sz = scalar_size(f.type);
			if (sz == 0)
				return -1;
			if (count * sz > len - pos)
				return -1;
			if (f.num_dim == 0) {
				int64_t v = read_be(buf + pos, sz);
				switch (f.type) {
				case LCM_FIELD_INT8_T: case LCM_FIELD_BYTE: case LCM_FIELD_BOOLEAN:
					*(int8_t *)f.data = (int8_t)v; break;
				case LCM_FIELD_INT16_T: *(int16_t *)f.data = (int16_t)v; break;
				case LCM_FIELD_INT32_T: *(int32_t *)f.data = (int32_t)v; break;
				case LCM_FIELD_INT64_T: *(int64_t *)f.data = v; break;
				default: break; /* floats size nothing */
				}
			}
			pos += count * sz;
		}
	}
	return pos;
}

ndo_drop ndo_msg_decode(ndo_msg_type t, const void *buf, size_t len, ndo_msg *m)
{
	memset(m, 0, sizeof *m);
	if ((unsigned)t >= NDO_MSG_NTYPES || !buf || len < 8 || len > (1u << 30))
		return NDO_DROP_MALFORMED;
	const typeops *ops = &types[t];
	const uint8_t *b = buf;
	if (read_be(b, 8) != ops->hash())
		return NDO_DROP_MALFORMED;
	ndo_msg shadow; /* its union holds any of the generated structs */
	memset(&shadow, 0, sizeof shadow);
	long used = walk(ops, b + 8, (long)len - 8, &shadow.u, 0);
	if (used < 0 || (size_t)used + 8 != len)
		return NDO_DROP_MALFORMED; /* short, inconsistent, or trailing bytes */
	m->type = t;
	if (ops->decode(buf, 0, (int)len, &m->u) != (int)len) {
		/* cannot happen after the walk; clean up whatever was allocated */
		ops->cleanup(&m->u);
		memset(m, 0, sizeof *m);
		return NDO_DROP_MALFORMED;
	}
	m->hdr = (const ndo_msg_header_t *)&m->u; /* every type starts with hdr */
	return NDO_DROP_NONE;
}

int32_t ndo_msg_peek_sender(ndo_msg_type t, const void *buf, size_t len)
{
	const uint8_t *b = buf;
	if ((unsigned)t >= NDO_MSG_NTYPES || !buf || len < 22 || read_be(b, 8) != types[t].hash())
		return 0;
	return (int32_t)read_be(b + 18, 4);
}

int32_t ndo_msg_peek_tile(const void *buf, size_t len, int64_t *seq, int64_t *step,
                          int *channels, int *encoding)
{
	/* hash 8, header: version 2, object 8, sender 4, seq 8, utime 8; then
	 * step 8, time 8, epoch 4, depth 1, i0 j0 i1 j1 16, channels 2,
	 * encoding 1 */
	const uint8_t *b = buf;
	if (!buf || len < 78 || read_be(b, 8) != types[NDO_MSG_TILE].hash())
		return 0;
	*seq = read_be(b + 22, 8);
	*step = read_be(b + 38, 8);
	*channels = (int)read_be(b + 75, 2);
	*encoding = (int)read_be(b + 77, 1);
	return (int32_t)read_be(b + 18, 4);
}

void ndo_msg_free(ndo_msg *m)
{
	if (m && m->hdr) {
		types[m->type].cleanup(&m->u);
		m->hdr = NULL;
	}
}

int ndo_msg_encode(ndo_msg_type t, const void *msg, uint8_t **buf, size_t *len)
{
	if ((unsigned)t >= NDO_MSG_NTYPES || !msg)
		return ndo__fail(NDO_EINVAL, "encode: bad message type %d", (int)t);
	int n = types[t].encoded_size(msg);
	if (n <= 0)
		return ndo__fail(NDO_EINVAL, "encode: %s: bad size", types[t].suffix);
	uint8_t *b = malloc((size_t)n);
	if (!b)
		return ndo__fail(NDO_ENOMEM, "encode: out of memory");
	if (types[t].encode(b, 0, n, msg) != n) {
		free(b);
		return ndo__fail(NDO_EINVAL, "encode: %s: encoder failed", types[t].suffix);
	}
	*buf = b;
	*len = (size_t)n;
	return 0;
}

size_t ndo_msg_encoded_size(ndo_msg_type t, const void *msg)
{
	return (unsigned)t < NDO_MSG_NTYPES ? (size_t)types[t].encoded_size(msg) : 0;
}

int ndo_tile_values_per_node(int ch)
{
	return 3 * (!!(ch & NDO_TILE_POSITION) + !!(ch & NDO_TILE_VELOCITY) +
	            !!(ch & NDO_TILE_REST)) + !!(ch & NDO_TILE_PIN);
}

int ndo_tile_depth(int level, int channels, const char *channel)
{
	ndo_msg_tile_t t;
	memset(&t, 0, sizeof t);
	size_t max = ndo_msg_max_payload(channel) - NDO_AUTH_TRAILER;
	for (int d = 0; d <= level + 1; d++) {
		t.nvalues = (int32_t)(ndo_quad_node_count(level, d) *
		                      (size_t)ndo_tile_values_per_node(channels));
		if ((size_t)ndo_msg_tile_t_encoded_size(&t) <= max)
			return d;
	}
	return level + 1; /* a single cell always fits */
}

/* ---- validation -------------------------------------------------------- */
/* Without a branch a value (a halo's 3,000 a step): |x| <= DBL_MAX is
 * isfinite(x), false for a NaN and for ±inf. */
static int finite_all(const double *v, long n)
{
	int ok = 1;
	for (long k = 0; k < n; k++)
		ok &= fabs(v[k]) <= DBL_MAX;
	return ok;
}

static int text_ok(const uint8_t *s, long n, long max)
{
	if (n < 0 || n > max)
		return 0;
	for (long k = 0; k < n; k++)
		if ((s[k] < 32 && s[k] != '\n' && s[k] != '\t') || s[k] == 127)
			return 0;
	return 1;
}

static int string_ok(const char *s, long max)
{
	return s && text_ok((const uint8_t *)s, (long)strnlen(s, (size_t)max + 1), max);
}

static int64_t face_count(int level) { return (int64_t)4 << (2 * level); }

static int peers_ok(const int32_t *ids, int n)
{
	for (int a = 0; a < n; a++) {
		if (ids[a] == 0)
			return 0;
		for (int b = 0; b < a; b++)
			if (ids[a] == ids[b])
				return 0;
	}
	return 1;
}

static int pois_ok(const int32_t *pois, int n, int level)
{
	for (int a = 0; a < n; a++)
		if (pois[a] < -1 || pois[a] >= face_count(level))
			return 0;
	return 1;
}

static int method_ok(int m)
{
	return m >= NDO_PART_QUADTREE && m <= NDO_PART_BANDS;
}

/* The leaves of a partition cover every cell exactly once. */
static ndo_drop leaves_ok(const ndo_msg_partition_t *p, int level)
{
	size_t ncell = ndo_cell_count(level);
	uint8_t *seen = calloc(ncell, 1);
	if (!seen)
		return NDO_DROP_RANGE; /* cannot check: do not trust */
	ndo_drop r = NDO_DROP_NONE;
	size_t covered = 0;
	int w = 2 << level;
	for (int k = 0; k < p->nleaves && r == NDO_DROP_NONE; k++) {
		ndo_quad q;
		if (ndo_quad_decode(level, p->leaves[k], &q) != 0 || p->slots[k] < 0 ||
		    p->slots[k] >= p->npeers) {
			r = NDO_DROP_RANGE;
			break;
		}
		int i0, j0, i1, j1;
		ndo_quad_range(level, q, &i0, &j0, &i1, &j1);
		for (int j = j0; j < j1 && r == NDO_DROP_NONE; j++)
			for (int i = i0; i < i1; i++) {
				if (seen[j * w + i]++) {
					r = NDO_DROP_RANGE; /* overlapping leaves */
					break;
				}
				covered++;
			}
	}
	if (r == NDO_DROP_NONE && covered != ncell)
		r = NDO_DROP_RANGE; /* cells nobody owns */
	free(seen);
	return r;
}

static ndo_drop check_header(const ndo_msg *m, const ndo_msg_ctx *c)
{
	const ndo_msg_header_t *h = m->hdr;
	if (h->version != NDO_PROTOCOL_VERSION)
		return NDO_DROP_VERSION;
	if (h->sender_id == 0 || h->seq < 0)
		return NDO_DROP_RANGE;
	if (m->type == NDO_MSG_HELLO && h->object_id == 0)
		return NDO_DROP_NONE; /* a joiner that does not know the object yet */
	if (h->object_id == 0)
		return NDO_DROP_RANGE;
	if (c->object_id != 0 && h->object_id != c->object_id)
		return NDO_DROP_FOREIGN;
	if (c->object_id == 0 && m->type != NDO_MSG_DESCRIPTION && m->type != NDO_MSG_HELLO &&
	    m->type != NDO_MSG_LEAVE && m->type != NDO_MSG_HEARTBEAT)
		return NDO_DROP_UNKNOWN; /* the thesis: "simply ignores this package" */
	return NDO_DROP_NONE;
}

/* The spread of one message's positions (or displacements) so far, a
 * component: lo..hi. */
typedef struct spread {
	double lo[3], hi[3];
} spread;

static void spread_init(spread *s)
{
	for (int c = 0; c < 3; c++)
		s->lo[c] = INFINITY, s->hi[c] = -INFINITY;
}

/* Not fmin/fmax, which GCC calls in libm (their NaN rules): a call a
 * value of every halo.  The same results: a NaN x leaves lo and hi as
 * they were, as fmin and fmax do, and the sign of a zero does not change
 * hi − lo. */
static void spread_add(spread *s, int c, double x)
{
	s->lo[c] = x < s->lo[c] ? x : s->lo[c];
	s->hi[c] = x > s->hi[c] ? x : s->hi[c];
}

static int spread_over(const spread *s, double most)
{
	for (int c = 0; c < 3; c++)
		if (s->hi[c] - s->lo[c] > most)
			return 1;
	return 0;
}

/* Node values of halo_t and solve_t against the box: per node a state
 * (per_node 6: velocity, then displacement u = x − X) or a vector of
 * velocities (3: the conjugate-gradient solve's, M⁻¹r and M⁻¹A·u are
 * velocities); velocity components within ±vmax, displacement components
 * within ±umax (ndo_msg_set_box). */
static ndo_drop nodes_in_box(const double *v, int64_t nvalues, int per_node,
                             const ndo_msg_ctx *ctx)
{
	if (!ctx->has_box || per_node <= 0)
		return NDO_DROP_NONE;
	/* the largest |velocity| and |displacement| and the spread, then the
	 * bounds: the verdict of a test of each value in turn (every value is
	 * finite here: finite_all came first), without a branch a value */
	spread u;
	spread_init(&u);
	double vm = 0, um = 0;
	for (int64_t k = 0; k < nvalues; k += per_node)
		for (int c = 0; c < per_node; c++) {
			const double a = fabs(v[k + c]);
			if (c < 3) {
				vm = a > vm ? a : vm;
			} else {
				um = a > um ? a : um;
				spread_add(&u, c - 3, v[k + c]);
			}
		}
	if (vm > ctx->vmax || um > ctx->umax)
		return NDO_DROP_BOX;
	/* x's spread and X's, the box's extent (a diagonal at most) */
	return spread_over(&u, ctx->spread + ctx->diag) ? NDO_DROP_BOX : NDO_DROP_NONE;
}

/* Types whose fields are checked against the level. */
static int needs_level(ndo_msg_type t)
{
	return t == NDO_MSG_TILE || t == NDO_MSG_POI || t == NDO_MSG_PARTITION ||
	       t == NDO_MSG_PEERS || t == NDO_MSG_FORCE || t == NDO_MSG_HALO ||
	       t == NDO_MSG_SOLVE || t == NDO_MSG_KEY_REQUEST;
}

/* The nodes in runs of node indices (halo_t, solve_t): −1 unless the runs
 * are increasing, disjoint and inside a level-L grid. */
static int64_t run_nodes(int L, int32_t nruns, const int32_t *start, const int32_t *len)
{
	const int64_t n = 1 << L, nodes = (2 * n + 1) * (n + 1);
	if (nruns < 0 || nruns > nodes)
		return -1;
	int64_t next = 0, count = 0;
	for (int k = 0; k < nruns; k++) {
		if (start[k] < next || len[k] < 1 || len[k] > nodes - start[k])
			return -1;
		next = (int64_t)start[k] + len[k];
		count += len[k];
	}
	return count;
}

ndo_drop ndo_msg_validate(const ndo_msg *m, const ndo_msg_ctx *c)
{
	if (!m || !m->hdr)
		return NDO_DROP_MALFORMED;
	ndo_drop r = check_header(m, c);
	if (r != NDO_DROP_NONE)
		return r;
	int L = c->level;
	if (needs_level(m->type) && L < 0)
		return NDO_DROP_UNKNOWN;
	switch (m->type) {
	case NDO_MSG_DESCRIPTION: {
		const ndo_msg_description_t *d = &m->u.description;
		if (d->level < 0 || d->level > 10 || d->owner_id != d->hdr.sender_id ||
		    d->epoch < 0 || !method_ok(d->partition))
			return NDO_DROP_RANGE;
		if (!text_ok(d->scene, d->scene_len, NDO_MAX_SCENE))
			return NDO_DROP_RANGE;
		if (L >= 0 && d->level != L)
			return NDO_DROP_RANGE; /* an object does not change level */
		return NDO_DROP_NONE;
	}
	case NDO_MSG_TILE: {
		const ndo_msg_tile_t *t = &m->u.tile;
		ndo_quad q;
		if (t->step < 0 || !isfinite(t->time) || t->time < 0 || t->epoch < 0)
			return t->time != t->time ? NDO_DROP_NONFINITE : NDO_DROP_RANGE;
		if (t->channels & NDO_TILE_COARSE) { /* of the send level's grid */
			if (c->coarse < 1 || c->coarse > L ||
			    (t->channels & ~(NDO_TILE_POSITION | NDO_TILE_VELOCITY | NDO_TILE_COARSE)) ||
			    !(t->channels & NDO_TILE_POSITION))
				return NDO_DROP_RANGE;
			L -= c->coarse;
		}
		if (ndo_quad_from_range(L, t->depth, t->i0, t->j0, t->i1, t->j1, &q) != 0)
			return NDO_DROP_RANGE;
		if (t->channels <= 0 || (t->channels & ~(NDO_TILE_ALL | NDO_TILE_COARSE)))
			return NDO_DROP_RANGE;
		if (t->encoding < NDO_ENC_RAW || t->encoding > NDO_ENC_HIER)
			return NDO_DROP_ENCODING;
		if (t->encoding != NDO_ENC_RAW) { /* the payload is the codec's to check */
			if ((t->channels & ~NDO_TILE_COARSE) != (NDO_TILE_POSITION | NDO_TILE_VELOCITY) ||
			    t->base_step < -1 ||
			    t->base_step >= t->step)
				return NDO_DROP_RANGE;
			if (t->nvalues != 0 || t->nbytes < 1)
				return NDO_DROP_LENGTH;
			return NDO_DROP_NONE;
		}
		if (t->base_step != -1 || t->nbytes != 0)
			return NDO_DROP_LENGTH;
		int64_t want = (int64_t)ndo_quad_node_count(L, t->depth) *
		               ndo_tile_values_per_node(t->channels);
		if (t->nvalues != want)
			return NDO_DROP_LENGTH;
		if (!finite_all(t->values, t->nvalues))
			return NDO_DROP_NONFINITE;
		if (t->channels & NDO_TILE_PIN) { /* pins are 0 or 1 */
			int vpn = ndo_tile_values_per_node(t->channels);
			for (int64_t k = vpn - 1; k < want; k += vpn)
				if (t->values[k] != 0 && t->values[k] != 1)
					return NDO_DROP_RANGE;
		}
		return ndo_msg_check_box(t, c);
	}
	case NDO_MSG_POI:
		return m->u.poi.face >= -1 && m->u.poi.face < face_count(L) ? NDO_DROP_NONE
		                                                            : NDO_DROP_RANGE;
	case NDO_MSG_PARTITION: {
		const ndo_msg_partition_t *p = &m->u.partition;
		if (p->epoch < 0 || p->restart < -1 || !method_ok(p->method) || p->npeers < 1 ||
		    p->npeers > NDO_MAX_PEERS || p->nleaves < 1 ||
		    (size_t)p->nleaves > ndo_cell_count(L))
			return NDO_DROP_RANGE;
		if (!peers_ok(p->peers, p->npeers) || !pois_ok(p->pois, p->npeers, L))
			return NDO_DROP_RANGE;
		return leaves_ok(p, L);
	}
	case NDO_MSG_HELLO:
		if (m->u.hello.role != 1 && m->u.hello.role != 2)
			return NDO_DROP_RANGE;
		return string_ok(m->u.hello.name, NDO_MAX_NAME) ? NDO_DROP_NONE : NDO_DROP_RANGE;
	case NDO_MSG_PEERS: {
		const ndo_msg_peers_t *p = &m->u.peers;
		if (p->npeers < 1 || p->npeers > NDO_MAX_MEMBERS || !peers_ok(p->peers, p->npeers) ||
		    !pois_ok(p->pois, p->npeers, L))
			return NDO_DROP_RANGE;
		return NDO_DROP_NONE;
	}
	case NDO_MSG_LEAVE: {
		const ndo_msg_leave_t *l = &m->u.leave;
		if (l->peer == 0 || l->reason < 1 || l->reason > 4)
			return NDO_DROP_RANGE;
		return string_ok(l->message, NDO_MAX_TEXT) ? NDO_DROP_NONE : NDO_DROP_RANGE;
	}
	case NDO_MSG_HEARTBEAT: {
		const ndo_msg_heartbeat_t *h = &m->u.heartbeat;
		if (!isfinite(h->time))
			return NDO_DROP_NONFINITE;
		return h->step >= 0 && h->time >= 0 && h->epoch >= 0 ? NDO_DROP_NONE
		                                                      : NDO_DROP_RANGE;
	}
	case NDO_MSG_DESC_REQUEST:
		return NDO_DROP_NONE;
	case NDO_MSG_HALO: {
		const ndo_msg_halo_t *h = &m->u.halo;
		if (h->step < 0 || !isfinite(h->time) || h->time < 0 || h->epoch < 0 ||
		    (h->confirmed != 0 && h->confirmed != 1) ||
		    (h->checkpoint != 0 && h->checkpoint != 1) || !isfinite(h->substep) ||
		    h->substep < 0 || (h->substep != 0 && !h->checkpoint))
			return h->time != h->time || h->substep != h->substep ? NDO_DROP_NONFINITE
			                                                      : NDO_DROP_RANGE;
		int64_t count = run_nodes(L, h->nruns, h->start, h->len);
		if (count < 0)
			return NDO_DROP_RANGE;
		if (h->nvalues != 6 * count)
			return NDO_DROP_LENGTH;
		if (!finite_all(h->values, h->nvalues))
			return NDO_DROP_NONFINITE;
		return nodes_in_box(h->values, h->nvalues, 6, c);
	}
	case NDO_MSG_SOLVE: {
		const ndo_msg_solve_t *h = &m->u.solve;
		if (h->step < 0 || h->step > NDO_MAX_SOLVE_STEP || h->phase < 0 ||
		    h->phase > NDO_MAX_PHASE || h->epoch < 0 ||
		    (h->per_node != 0 && h->per_node != 3 && h->per_node != 6))
			return NDO_DROP_RANGE;
		if (h->nsums < 0 || h->nsums > NDO_MAX_SUMS)
			return NDO_DROP_RANGE;
		int64_t count = run_nodes(L, h->nruns, h->start, h->len);
		if (count < 0)
			return NDO_DROP_RANGE;
		if (h->nvalues != h->per_node * count)
			return NDO_DROP_LENGTH;
		if (!finite_all(h->values, h->nvalues) || !finite_all(h->sums, h->nsums))
			return NDO_DROP_NONFINITE;
		return nodes_in_box(h->values, h->nvalues, h->per_node, c);
	}
	case NDO_MSG_KEY_REQUEST: {
		const ndo_msg_key_request_t *k = &m->u.key_request;
		if (k->sender == 0 || (k->coarse != 0 && k->coarse != 1) || k->ntiles < 1 ||
		    k->ntiles > NDO_MAX_KEY_TILES)
			return NDO_DROP_RANGE;
		if (k->coarse) { /* of the send level's grid */
			if (c->coarse < 1 || c->coarse > L)
				return NDO_DROP_RANGE;
			L -= c->coarse;
		}
		ndo_quad q;
		for (int j = 0; j < k->ntiles; j++)
			if (ndo_quad_decode(L, k->codes[j], &q) != 0)
				return NDO_DROP_RANGE;
		return NDO_DROP_NONE;
	}
	case NDO_MSG_FORCE: {
		const ndo_msg_force_t *f = &m->u.force;
		if (f->step < 0 || f->nforces < 0 || f->nforces > NDO_MAX_FORCES)
			return NDO_DROP_RANGE;
		for (int k = 0; k < f->nforces; k++) {
			if (f->faces[k] < 0 || f->faces[k] >= face_count(L))
				return NDO_DROP_RANGE;
			if (!finite_all(f->forces[k], 3))
				return NDO_DROP_NONFINITE;
		}
		return NDO_DROP_NONE;
	}
	default:
		return NDO_DROP_MALFORMED;
	}
}

/* ---- the object's box ---------------------------------------------------- */
int ndo_msg_set_box(ndo_msg_ctx *ctx, const double lo[3], const double hi[3])
{
	double d2 = 0;
	for (int c = 0; c < 3; c++) {
		if (!isfinite(lo[c]) || !isfinite(hi[c]) || lo[c] > hi[c])
			return ndo__fail(NDO_EINVAL, "object box: not a finite box");
		d2 += (hi[c] - lo[c]) * (hi[c] - lo[c]);
	}
	double diag = sqrt(d2);
	if (!(diag > 0) || !isfinite(diag))
		return ndo__fail(NDO_EINVAL, "object box: empty");
	for (int c = 0; c < 3; c++) {
		ctx->lo[c] = lo[c] - NDO_BOX_SLACK * diag;
		ctx->hi[c] = hi[c] + NDO_BOX_SLACK * diag;
	}
	ctx->diag = diag;
	ctx->vmax = NDO_SPEED_MAX * diag;
	/* x within the deformation the simulation lets a body have of the box
	 * moved by the drift (beyond lo..hi, which hold the slack already):
	 * until 2026-12-01 the spread was the slack's, 9 diagonals, and a
	 * point force of 200 N on the thesis' scene (34 diagonals, a run the
	 * single process makes) stalled a 2-peer run, its halos dropped */
	ctx->drift = (NDO_DRIFT_MAX + NDO_SIM_DEFORM_MAX - NDO_BOX_SLACK) * diag;
	ctx->spread = (1 + 2 * NDO_SIM_DEFORM_MAX) * diag;
	/* x as above, the rest X within the box itself */
	ctx->umax = (1 + NDO_SIM_DEFORM_MAX + NDO_DRIFT_MAX) * diag;
	ctx->has_box = 1;
	return 0;
}

int ndo_msg_box_text(const double *x, size_t count, char *buf, size_t size)
{
	double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
	for (size_t k = 0; k < count; k++)
		for (int c = 0; c < 3; c++) {
			lo[c] = fmin(lo[c], x[3 * k + c]);
			hi[c] = fmax(hi[c], x[3 * k + c]);
		}
	int n = snprintf(buf, size, "object-box %.17g %.17g %.17g %.17g %.17g %.17g\n", lo[0], lo[1],
	                 lo[2], hi[0], hi[1], hi[2]);
	if (n < 0 || (size_t)n >= size)
		return ndo__fail(NDO_ERANGE, "object box: no room");
	return n;
}

typedef struct box_lines {
	ndo_msg_ctx *ctx;
	int found;
} box_lines;

static int box_line(void *arg, const char *l)
{
	box_lines *b = arg;
	double lo[3], hi[3];
	int bad = b->found || sscanf(l, "object-box %lf %lf %lf %lf %lf %lf", &lo[0], &lo[1],
	                             &lo[2], &hi[0], &hi[1], &hi[2]) != 6 ||
	          ndo_msg_set_box(b->ctx, lo, hi) != 0;
	b->found = 1;
	return bad ? ndo__fail(NDO_EINVAL, "the owner's description: bad line '%s'", l) : 0;
}

int ndo_msg_box_take(char *text, ndo_msg_ctx *ctx)
{
	box_lines b = {ctx, 0};
	int rc = ndo_lines_take(text, "object-box", box_line, &b);
	return rc ? rc : b.found;
}

ndo_drop ndo_msg_check_box(const ndo_msg_tile_t *t, const ndo_msg_ctx *ctx)
{
	int vpn = ndo_tile_values_per_node(t->channels);
	if (vpn <= 0 || t->nvalues % vpn)
		return NDO_DROP_LENGTH;
	spread at;
	spread_init(&at);
	for (int32_t k = 0; k < t->nvalues; k += vpn) {
		const double *v = t->values + k;
		for (int bit = 0; bit < 3; bit++) { /* position, velocity, rest */
			if (!(t->channels & (1 << bit)))
				continue;
			if (!isnan(v[0])) {
				for (int c = 0; c < 3; c++) {
					if (!isfinite(v[c]))
						return NDO_DROP_NONFINITE;
					if (!ctx->has_box)
						continue;
					if (bit == 0) { /* a body may have drifted whole */
						if (v[c] < ctx->lo[c] - ctx->drift || v[c] > ctx->hi[c] + ctx->drift)
							return NDO_DROP_BOX;
						spread_add(&at, c, v[c]);
					} else if (bit == 1 ? fabs(v[c]) > ctx->vmax
					                    : v[c] < ctx->lo[c] || v[c] > ctx->hi[c]) {
						return NDO_DROP_BOX;
					}
				}
			}
			v += 3;
		}
	}
	return ctx->has_box && spread_over(&at, ctx->spread) ? NDO_DROP_BOX : NDO_DROP_NONE;
}
