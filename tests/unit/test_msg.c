/* test_msg — hostile input to the message layer: malformed, truncated,
 * oversized, out-of-range, non-finite, stale and foreign messages are each
 * dropped under their reason, never trusted (ndo/msg.h, ndo/net.h); tiles
 * fit one datagram at every level and pack as the node-by-node reference;
 * the quad tree's codes round-trip. */
#include "check.h"
#include "ndo/codec.h"
#include "ndo/msg.h"
#include "ndo/net.h"
#include "ndo/quadtree.h"
#include "ndo/sim.h"
#include "ndo/status.h"
#include "ndo/tile.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static ndo_msg_tile_t make_tile(int level, int depth)
{
	ndo_msg_tile_t t;
	memset(&t, 0, sizeof t);
	t.hdr = (ndo_msg_header_t){NDO_PROTOCOL_VERSION, 42, 7, 0, 0};
	ndo_quad q = {depth, 0, 0};
	ndo_quad_range(level, q, &t.i0, &t.j0, &t.i1, &t.j1);
	t.depth = (int8_t)depth;
	t.channels = NDO_TILE_POSITION | NDO_TILE_VELOCITY;
	t.base_step = -1;
	t.nvalues = (int32_t)(ndo_quad_node_count(level, depth) * 6);
	t.values = calloc((size_t)t.nvalues, sizeof(double));
	return t;
}

static ndo_drop roundtrip(ndo_msg_type type, const void *msg, const ndo_msg_ctx *c)
{
	uint8_t *buf;
	size_t len;
	if (ndo_msg_encode(type, msg, &buf, &len) != 0)
		return NDO_DROP_N;
	ndo_msg m;
	ndo_drop r = ndo_msg_decode(type, buf, len, &m);
	if (r == NDO_DROP_NONE) {
		r = ndo_msg_validate(&m, c);
		ndo_msg_free(&m);
	}
	free(buf);
	return r;
}

static void tile_fields_checked(void)
{
	ndo_msg_ctx c = {.object_id = 42, .level = 4, .self_id = 1};
	ndo_msg_tile_t t = make_tile(4, 2);
	CHECK(roundtrip(NDO_MSG_TILE, &t, &c) == NDO_DROP_NONE, "a good tile passes");
	ndo_msg_ctx foreign = {.object_id = 43, .level = 4, .self_id = 1};
	CHECK(roundtrip(NDO_MSG_TILE, &t, &foreign) == NDO_DROP_FOREIGN, "foreign object");
	ndo_msg_ctx unknown = {.object_id = 0, .level = -1, .self_id = 1};
	CHECK(roundtrip(NDO_MSG_TILE, &t, &unknown) == NDO_DROP_UNKNOWN, "before the description");
	t.hdr.version = 2;
	CHECK(roundtrip(NDO_MSG_TILE, &t, &c) == NDO_DROP_VERSION, "version");
	t.hdr.version = NDO_PROTOCOL_VERSION;
	t.i1++;
	CHECK(roundtrip(NDO_MSG_TILE, &t, &c) == NDO_DROP_RANGE, "range not a tree node");
	t.i1--;
	ndo_msg_ctx higher = {.object_id = 42, .level = 3, .self_id = 1};
	CHECK(roundtrip(NDO_MSG_TILE, &t, &higher) != NDO_DROP_NONE, "range vs another level");
	t.values[5] = NAN;
	CHECK(roundtrip(NDO_MSG_TILE, &t, &c) == NDO_DROP_NONFINITE, "NaN");
	t.values[5] = INFINITY;
	CHECK(roundtrip(NDO_MSG_TILE, &t, &c) == NDO_DROP_NONFINITE, "infinity");
	t.values[5] = 0;
	t.nvalues -= 6;
	CHECK(roundtrip(NDO_MSG_TILE, &t, &c) == NDO_DROP_LENGTH, "short values array");
	t.nvalues += 6;
	t.encoding = 9;
	CHECK(roundtrip(NDO_MSG_TILE, &t, &c) == NDO_DROP_ENCODING, "unknown encoding");
	t.encoding = NDO_ENC_PREDICT;
	CHECK(roundtrip(NDO_MSG_TILE, &t, &c) == NDO_DROP_LENGTH, "an encoded tile with values[]");
	t.encoding = 0;
	t.channels = 64;
	CHECK(roundtrip(NDO_MSG_TILE, &t, &c) == NDO_DROP_RANGE, "unknown channel bits");
	free(t.values);
}

/* A tile of the send level (NDO_TILE_COARSE): a tile of the coarser grid,
 * only when the description gave a send level, position and velocity only. */
static void coarse_tiles_checked(void)
{
	ndo_msg_ctx none = {.object_id = 42, .level = 6, .self_id = 1};
	ndo_msg_ctx two = {.object_id = 42, .level = 6, .self_id = 1, .coarse = 2};
	ndo_msg_tile_t t = make_tile(4, 2); /* a level-4 tile: 2 levels below 6 */
	t.channels |= NDO_TILE_COARSE;
	CHECK(roundtrip(NDO_MSG_TILE, &t, &two) == NDO_DROP_NONE, "a level-4 tile of a level-6 "
	      "object sent at level 4 passes");
	CHECK(roundtrip(NDO_MSG_TILE, &t, &none) == NDO_DROP_RANGE, "a coarse tile without a send level");
	ndo_msg_ctx one = two;
	one.coarse = 1;
	CHECK(roundtrip(NDO_MSG_TILE, &t, &one) == NDO_DROP_LENGTH ||
	      roundtrip(NDO_MSG_TILE, &t, &one) == NDO_DROP_RANGE, "a level-4 tile for send level 5");
	ndo_msg_ctx below0 = two;
	below0.coarse = 7;
	CHECK(roundtrip(NDO_MSG_TILE, &t, &below0) == NDO_DROP_RANGE, "a send level below 0");
	t.channels = NDO_TILE_REST | NDO_TILE_COARSE;
	t.nvalues = (int32_t)(ndo_quad_node_count(4, 2) * 3);
	CHECK(roundtrip(NDO_MSG_TILE, &t, &two) == NDO_DROP_RANGE, "the rest shape is not sent coarse");
	t.channels = NDO_TILE_VELOCITY | NDO_TILE_COARSE;
	CHECK(roundtrip(NDO_MSG_TILE, &t, &two) == NDO_DROP_RANGE, "a coarse tile carries positions");
	free(t.values);
	/* the description's line */
	int L;
	char good[] = "stiffness 1\nsend-level 4\n", bad[] = "send-level 7\n", junk[] = "send-level 4x\n",
	     twice[] = "send-level 3\nsend-level 4\n", noline[] = "stiffness 1\n";
	CHECK(ndo_send_level_take(good, 6, &L) == 0 && L == 4 && strcmp(good, "stiffness 1\n") == 0,
	      "send-level 4 read and taken out: %d, '%s'", L, good);
	CHECK(ndo_send_level_take(noline, 6, &L) == 0 && L == 6, "no line: the object's level");
	CHECK(ndo_send_level_take(bad, 6, &L) == NDO_EINVAL, "a send level above the object's");
	CHECK(ndo_send_level_take(junk, 6, &L) == NDO_EINVAL, "a bad line");
	CHECK(ndo_send_level_take(twice, 6, &L) == NDO_EINVAL, "two lines");
	char line[32];
	CHECK(ndo_send_level_text(6, 6, line, sizeof line) == 0 && !*line,
	      "no line at the object's level");
	CHECK(ndo_send_level_text(4, 6, line, sizeof line) > 0 && strcmp(line, "send-level 4\n") == 0,
	      "the line: '%s'", line);
}

/* A peer's halo (exact lock-step): runs inside the grid, increasing and
 * disjoint, six finite values a node. */
static void halos_checked(void)
{
	ndo_msg_ctx c = {.object_id = 42, .level = 4, .self_id = 1};
	int32_t start[2] = {10, 40}, len[2] = {3, 2};
	double v[30] = {0};
	ndo_msg_halo_t h = {.hdr = {NDO_PROTOCOL_VERSION, 42, 7, 0, 0}, .step = 5, .time = 0.1,
	                    .nruns = 2, .start = start, .len = len, .nvalues = 30, .values = v};
	CHECK(roundtrip(NDO_MSG_HALO, &h, &c) == NDO_DROP_NONE, "a good halo passes");
	start[1] = 12;
	CHECK(roundtrip(NDO_MSG_HALO, &h, &c) == NDO_DROP_RANGE, "overlapping runs");
	start[1] = 40, len[0] = 0;
	CHECK(roundtrip(NDO_MSG_HALO, &h, &c) == NDO_DROP_RANGE, "an empty run");
	len[0] = 3, start[1] = 17 * 33 + 100; /* level 4: 33 × 17 nodes */
	CHECK(roundtrip(NDO_MSG_HALO, &h, &c) == NDO_DROP_RANGE, "a run beyond the grid");
	start[1] = 40, h.nvalues = 24;
	CHECK(roundtrip(NDO_MSG_HALO, &h, &c) == NDO_DROP_LENGTH, "values for 4 nodes of 5");
	h.nvalues = 30, v[7] = NAN;
	CHECK(roundtrip(NDO_MSG_HALO, &h, &c) == NDO_DROP_NONFINITE, "NaN");
	v[7] = 0, h.confirmed = 1;
	CHECK(roundtrip(NDO_MSG_HALO, &h, &c) == NDO_DROP_NONE, "a confirmed halo passes");
	h.confirmed = 2;
	CHECK(roundtrip(NDO_MSG_HALO, &h, &c) == NDO_DROP_RANGE, "confirmed neither 0 nor 1");
	h.confirmed = 0, h.checkpoint = 1;
	CHECK(roundtrip(NDO_MSG_HALO, &h, &c) == NDO_DROP_NONE, "a checkpoint passes");
	h.checkpoint = 2;
	CHECK(roundtrip(NDO_MSG_HALO, &h, &c) == NDO_DROP_RANGE, "checkpoint neither 0 nor 1");
	/* rkf45's sub-step size, in a checkpoint only: positive and finite */
	h.checkpoint = 1, h.substep = 0.004;
	CHECK(roundtrip(NDO_MSG_HALO, &h, &c) == NDO_DROP_NONE, "a checkpoint with a sub-step passes");
	h.substep = -0.004;
	CHECK(roundtrip(NDO_MSG_HALO, &h, &c) == NDO_DROP_RANGE, "a negative sub-step");
	h.substep = NAN;
	CHECK(roundtrip(NDO_MSG_HALO, &h, &c) == NDO_DROP_NONFINITE, "a NaN sub-step");
	h.substep = INFINITY;
	CHECK(roundtrip(NDO_MSG_HALO, &h, &c) == NDO_DROP_RANGE, "an infinite sub-step");
	h.checkpoint = 0, h.substep = 0.004;
	CHECK(roundtrip(NDO_MSG_HALO, &h, &c) == NDO_DROP_RANGE, "a sub-step in a halo");
	h.substep = 0;
	ndo_msg_ctx unknown = {.object_id = 0, .level = -1, .self_id = 1};
	CHECK(roundtrip(NDO_MSG_HALO, &h, &unknown) == NDO_DROP_UNKNOWN, "before the description");
}

/* A split step's exchange (solve_t): runs as in a halo, 0, 3 or 6 finite
 * values a node, at most NDO_MAX_SUMS finite partial sums, a phase up to
 * NDO_MAX_PHASE and a step up to NDO_MAX_SOLVE_STEP (until 2026-11-30 any:
 * phase 2^24 of step s was phase 0 of s + 1 to the receiver, and a step
 * past 2^39 overflowed its key). */
static void solves_checked(void)
{
	ndo_msg_ctx c = {.object_id = 42, .level = 4, .self_id = 1};
	int32_t start[2] = {10, 40}, len[2] = {3, 2};
	double v[30] = {0}, sums[NDO_MAX_SUMS + 1] = {0.5, 1};
	ndo_msg_solve_t h = {.hdr = {NDO_PROTOCOL_VERSION, 42, 7, 0, 0}, .step = 5, .phase = 3,
	                     .per_node = 6, .nruns = 2, .start = start, .len = len, .nvalues = 30,
	                     .values = v, .nsums = 2, .sums = sums};
	CHECK(roundtrip(NDO_MSG_SOLVE, &h, &c) == NDO_DROP_NONE, "a good state strip passes");
	h.per_node = 3, h.nvalues = 15;
	CHECK(roundtrip(NDO_MSG_SOLVE, &h, &c) == NDO_DROP_NONE, "a good vector passes");
	h.nvalues = 30;
	CHECK(roundtrip(NDO_MSG_SOLVE, &h, &c) == NDO_DROP_LENGTH, "30 values for 5 nodes of 3");
	h.per_node = 4, h.nvalues = 20;
	CHECK(roundtrip(NDO_MSG_SOLVE, &h, &c) == NDO_DROP_RANGE, "4 values a node");
	h.per_node = 0, h.nvalues = 0, h.nruns = 0;
	CHECK(roundtrip(NDO_MSG_SOLVE, &h, &c) == NDO_DROP_NONE, "sums only");
	h.phase = -1;
	CHECK(roundtrip(NDO_MSG_SOLVE, &h, &c) == NDO_DROP_RANGE, "a negative phase");
	/* the key step · 2^24 + phase: neither aliased nor overflowed */
	h.phase = NDO_MAX_PHASE, h.step = NDO_MAX_SOLVE_STEP;
	CHECK(roundtrip(NDO_MSG_SOLVE, &h, &c) == NDO_DROP_NONE, "the last phase of the last step");
	h.phase = NDO_MAX_PHASE + 1;
	CHECK(roundtrip(NDO_MSG_SOLVE, &h, &c) == NDO_DROP_RANGE, "phase 2^24 (the next step's 0)");
	h.phase = 3, h.step = NDO_MAX_SOLVE_STEP + 1;
	CHECK(roundtrip(NDO_MSG_SOLVE, &h, &c) == NDO_DROP_RANGE, "step 2^39 (its key overflows)");
	h.step = INT64_MAX;
	CHECK(roundtrip(NDO_MSG_SOLVE, &h, &c) == NDO_DROP_RANGE, "step INT64_MAX");
	h.step = 5;
	h.phase = 3, h.nsums = NDO_MAX_SUMS + 1;
	CHECK(roundtrip(NDO_MSG_SOLVE, &h, &c) == NDO_DROP_RANGE, "too many sums");
	h.nsums = 2, sums[1] = INFINITY;
	CHECK(roundtrip(NDO_MSG_SOLVE, &h, &c) == NDO_DROP_NONFINITE, "an infinite sum");
	sums[1] = 1, h.per_node = 6, h.nruns = 2, h.nvalues = 30, start[1] = 12;
	CHECK(roundtrip(NDO_MSG_SOLVE, &h, &c) == NDO_DROP_RANGE, "overlapping runs");
	start[1] = 40, v[29] = NAN;
	CHECK(roundtrip(NDO_MSG_SOLVE, &h, &c) == NDO_DROP_NONFINITE, "NaN");
	v[29] = 0;
	ndo_msg_ctx unknown = {.object_id = 0, .level = -1, .self_id = 1};
	CHECK(roundtrip(NDO_MSG_SOLVE, &h, &unknown) == NDO_DROP_UNKNOWN, "before the description");
}

/* The node values of halos, checkpoints and split steps against the
 * object's box, as a tile's state is: a velocity component above vmax, a
 * displacement u = x − X past the drift bound or more than
 * 1 + 2 · NDO_SIM_DEFORM_MAX + 1 diagonals from another of the message
 * (x's spread, X's), a vector of the solve (velocities) above vmax are
 * `box`; partial sums only finite.  A member's halo of 1e300s used to
 * pass (finite) and end a 2-peer rk4 run with "the state is not finite";
 * a body deformed 100 diagonals either way (one the simulation runs) was
 * refused at 10 diagonals. */
static void node_values_checked_against_the_box(void)
{
	ndo_msg_ctx c = {.object_id = 42, .level = 4, .self_id = 1};
	const double lo[3] = {0, 0, 0}, hi[3] = {3, 4, 0}; /* diagonal 5 */
	CHECK(ndo_msg_set_box(&c, lo, hi) == 0, "set the box");
	CHECK(c.umax == (1 + NDO_SIM_DEFORM_MAX + NDO_DRIFT_MAX) * 5 && c.spread == 201 * 5,
	      "the displacement bound: 101 diagonals and the drift (got %g), the spread 201 "
	      "(got %g)", c.umax, c.spread);
	int32_t start[1] = {10}, len[1] = {2};
	double v[12] = {0};
	ndo_msg_halo_t h = {.hdr = {NDO_PROTOCOL_VERSION, 42, 7, 0, 0}, .step = 5, .time = 0.1,
	                    .confirmed = 1, .nruns = 1, .start = start, .len = len, .nvalues = 12,
	                    .values = v};
	v[9] = 49.9, v[10] = -49.9, v[6] = -0.99 * c.vmax;
	CHECK(roundtrip(NDO_MSG_HALO, &h, &c) == NDO_DROP_NONE, "a halo within the bounds passes");
	v[3] = v[9] = 1000 * 5, v[4] = v[10] = -1000 * 5;
	CHECK(roundtrip(NDO_MSG_HALO, &h, &c) == NDO_DROP_NONE, "a halo drifted 1000 diagonals passes");
	v[3] = -100 * 5, v[9] = 100 * 5, v[4] = v[10] = 0;
	CHECK(roundtrip(NDO_MSG_HALO, &h, &c) == NDO_DROP_NONE,
	      "a halo of a body deformed 100 diagonals either way passes");
	v[3] = v[4] = v[9] = 0, v[10] = -49.9;
	struct { int at; double val; const char *what; } bad[] = {
		{9, 1011, "a displacement 202.2 diagonals from the other's"},
		{11, -1e300, "a displacement of -1e300"},
		{6, 1.01 * c.vmax, "a velocity above vmax"}, {0, 1e300, "a velocity of 1e300"}};
	for (size_t k = 0; k < sizeof bad / sizeof *bad; k++) {
		double keep = v[bad[k].at];
		v[bad[k].at] = bad[k].val;
		h.checkpoint = 0;
		CHECK(roundtrip(NDO_MSG_HALO, &h, &c) == NDO_DROP_BOX, "a halo with %s: box", bad[k].what);
		h.checkpoint = 1;
		CHECK(roundtrip(NDO_MSG_HALO, &h, &c) == NDO_DROP_BOX, "a checkpoint with %s: box",
		      bad[k].what);
		v[bad[k].at] = keep;
	}
	h.checkpoint = 0;
	ndo_msg_ctx nobox = {.object_id = 42, .level = 4, .self_id = 1};
	v[0] = 1e300;
	CHECK(roundtrip(NDO_MSG_HALO, &h, &nobox) == NDO_DROP_NONE, "no box (a point): finite passes");
	v[0] = 0;
	/* solve_t: a state strip as a halo, a vector as velocities, sums finite */
	double sums[2] = {1e300, -1e300};
	ndo_msg_solve_t m = {.hdr = {NDO_PROTOCOL_VERSION, 42, 7, 0, 0}, .step = 5, .phase = 1,
	                     .per_node = 6, .nruns = 1, .start = start, .len = len, .nvalues = 12,
	                     .values = v, .nsums = 2, .sums = sums};
	CHECK(roundtrip(NDO_MSG_SOLVE, &m, &c) == NDO_DROP_NONE, "a state strip within the bounds, "
	      "sums of ±1e300: passes");
	v[10] = 1011;
	CHECK(roundtrip(NDO_MSG_SOLVE, &m, &c) == NDO_DROP_BOX, "a state strip's displacement 202.2 "
	      "diagonals from the other's: box");
	m.per_node = 3, m.nvalues = 6;
	CHECK(roundtrip(NDO_MSG_SOLVE, &m, &c) == NDO_DROP_NONE,
	      "a vector of 1011 (a velocity) passes");
	v[4] = -2 * c.vmax;
	CHECK(roundtrip(NDO_MSG_SOLVE, &m, &c) == NDO_DROP_BOX, "a vector above vmax: box");
}

/* A keyframe request (key_request_t): a nonzero sender, 1..64 tiles, each
 * a quad-tree code of the object's level (or of the send level's, coarse). */
static void key_requests_checked(void)
{
	ndo_msg_ctx c = {.object_id = 42, .level = 4, .self_id = 1};
	ndo_quad q = {.depth = 4, .qi = 3, .qj = 1}; /* depth 4: levels 3 and up */
	int32_t codes[NDO_MAX_KEY_TILES + 1] = {0, ndo_quad_code(q)};
	ndo_msg_key_request_t k = {.hdr = {NDO_PROTOCOL_VERSION, 42, 7, 0, 0}, .sender = 9,
	                           .ntiles = 2, .codes = codes};
	CHECK(roundtrip(NDO_MSG_KEY_REQUEST, &k, &c) == NDO_DROP_NONE, "a good request passes");
	k.sender = 0;
	CHECK(roundtrip(NDO_MSG_KEY_REQUEST, &k, &c) == NDO_DROP_RANGE, "sender 0");
	k.sender = 9, k.ntiles = 0;
	CHECK(roundtrip(NDO_MSG_KEY_REQUEST, &k, &c) == NDO_DROP_RANGE, "no tile");
	k.ntiles = NDO_MAX_KEY_TILES + 1;
	CHECK(roundtrip(NDO_MSG_KEY_REQUEST, &k, &c) == NDO_DROP_RANGE, "65 tiles");
	k.ntiles = NDO_MAX_KEY_TILES;
	CHECK(roundtrip(NDO_MSG_KEY_REQUEST, &k, &c) == NDO_DROP_NONE, "64 tiles");
	k.ntiles = 2, codes[1] = -1;
	CHECK(roundtrip(NDO_MSG_KEY_REQUEST, &k, &c) == NDO_DROP_RANGE, "a negative code");
	codes[1] = 1 << 30;
	CHECK(roundtrip(NDO_MSG_KEY_REQUEST, &k, &c) == NDO_DROP_RANGE, "a code beyond the level's");
	codes[1] = ndo_quad_code(q), k.coarse = 1;
	CHECK(roundtrip(NDO_MSG_KEY_REQUEST, &k, &c) == NDO_DROP_RANGE, "coarse with no send level");
	c.coarse = 1;
	CHECK(roundtrip(NDO_MSG_KEY_REQUEST, &k, &c) == NDO_DROP_NONE, "coarse, of level 3");
	c.coarse = 2; /* level 2's tree is 3 deep */
	CHECK(roundtrip(NDO_MSG_KEY_REQUEST, &k, &c) == NDO_DROP_RANGE, "a code beyond the send level's");
	k.coarse = 2;
	CHECK(roundtrip(NDO_MSG_KEY_REQUEST, &k, &c) == NDO_DROP_RANGE, "coarse neither 0 nor 1");
	k.coarse = 0;
	ndo_msg_ctx unknown = {.object_id = 0, .level = -1, .self_id = 1};
	CHECK(roundtrip(NDO_MSG_KEY_REQUEST, &k, &unknown) == NDO_DROP_UNKNOWN, "before the description");
}

static void bytes_checked_before_decoding(void)
{
	ndo_msg_tile_t t = make_tile(4, 2);
	uint8_t *buf;
	size_t len;
	ndo_msg_encode(NDO_MSG_TILE, &t, &buf, &len);
	ndo_msg m;
	for (size_t cut = 0; cut < len; cut += 37)
		CHECK(ndo_msg_decode(NDO_MSG_TILE, buf, cut, &m) == NDO_DROP_MALFORMED,
		      "truncated to %zu bytes", cut);
	uint8_t *longer = malloc(len + 1);
	memcpy(longer, buf, len);
	longer[len] = 0;
	CHECK(ndo_msg_decode(NDO_MSG_TILE, longer, len + 1, &m) == NDO_DROP_MALFORMED,
	      "trailing byte");
	free(longer);
	/* nvalues claims 2^29+1 doubles: LCM's own decoder would overflow
	 * (8 × count wraps to 8) — the walk refuses it */
	size_t off = 8 + (2 + 8 + 4 + 8 + 8) + 8 + 8 + 4 + 1 + 16 + 2 + 1 + 8;
	uint8_t save[4];
	memcpy(save, buf + off, 4);
	buf[off] = 0x20, buf[off + 1] = 0, buf[off + 2] = 0, buf[off + 3] = 1;
	CHECK(ndo_msg_decode(NDO_MSG_TILE, buf, len, &m) == NDO_DROP_MALFORMED, "huge count");
	buf[off] = 0xff, buf[off + 1] = 0xff, buf[off + 2] = 0xff, buf[off + 3] = 0xfe;
	CHECK(ndo_msg_decode(NDO_MSG_TILE, buf, len, &m) == NDO_DROP_MALFORMED, "negative count");
	memcpy(buf + off, save, 4);
	CHECK(ndo_msg_decode(NDO_MSG_TILE, buf, len, &m) == NDO_DROP_NONE, "restored decodes");
	ndo_msg_free(&m);
	buf[0] ^= 1;
	CHECK(ndo_msg_decode(NDO_MSG_TILE, buf, len, &m) == NDO_DROP_MALFORMED, "wrong type hash");
	CHECK(ndo_msg_decode(NDO_MSG_HELLO, buf, len, &m) == NDO_DROP_MALFORMED, "other type");
	free(buf);
	free(t.values);
	/* a string without its NUL */
	ndo_msg_hello_t h = {{NDO_PROTOCOL_VERSION, 42, 7, 0, 0}, 2, "abc"};
	ndo_msg_encode(NDO_MSG_HELLO, &h, &buf, &len);
	buf[len - 1] = 'x';
	CHECK(ndo_msg_decode(NDO_MSG_HELLO, buf, len, &m) == NDO_DROP_MALFORMED, "unterminated string");
	free(buf);
}

static void control_messages_checked(void)
{
	ndo_msg_ctx c = {.object_id = 42, .level = 3, .self_id = 1};
	ndo_msg_header_t hd = {NDO_PROTOCOL_VERSION, 42, 7, 0, 0};
	ndo_msg_poi_t p = {hd, 4 << 6};
	CHECK(roundtrip(NDO_MSG_POI, &p, &c) == NDO_DROP_RANGE, "POI beyond the faces");
	p.face = (4 << 6) - 1;
	CHECK(roundtrip(NDO_MSG_POI, &p, &c) == NDO_DROP_NONE, "last face");
	int32_t peers[2] = {7, 7}, pois[2] = {0, 1}, leaves[2] = {1, 2};
	int8_t slots[2] = {0, 1};
	ndo_msg_partition_t part = {hd, 1, NDO_PART_QUADTREE, 2, peers, pois, 2, leaves, slots, -1};
	CHECK(roundtrip(NDO_MSG_PARTITION, &part, &c) == NDO_DROP_RANGE, "duplicate peer ids");
	peers[1] = 8;
	CHECK(roundtrip(NDO_MSG_PARTITION, &part, &c) == NDO_DROP_NONE, "two squares");
	part.restart = 40;
	CHECK(roundtrip(NDO_MSG_PARTITION, &part, &c) == NDO_DROP_NONE, "a restart step");
	part.restart = -2;
	CHECK(roundtrip(NDO_MSG_PARTITION, &part, &c) == NDO_DROP_RANGE, "restart below -1");
	part.restart = -1;
	leaves[1] = 1;
	CHECK(roundtrip(NDO_MSG_PARTITION, &part, &c) == NDO_DROP_RANGE, "overlapping leaves");
	part.nleaves = 1;
	CHECK(roundtrip(NDO_MSG_PARTITION, &part, &c) == NDO_DROP_RANGE, "uncovered cells");
	double f0[3] = {0, 0, 1e300 * 1e300};
	double *rows[1] = {f0};
	int32_t faces[1] = {3};
	ndo_msg_force_t f = {hd, 0, 1, faces, rows};
	CHECK(roundtrip(NDO_MSG_FORCE, &f, &c) == NDO_DROP_NONFINITE, "infinite force");
	ndo_msg_leave_t l = {hd, 7, 9, ""};
	CHECK(roundtrip(NDO_MSG_LEAVE, &l, &c) == NDO_DROP_RANGE, "leave reason");
	ndo_msg_hello_t h = {hd, 2, "a\033[2Jb"};
	CHECK(roundtrip(NDO_MSG_HELLO, &h, &c) == NDO_DROP_RANGE, "control characters in a name");
	ndo_msg_heartbeat_t hb = {hd, -1, 0, 0};
	CHECK(roundtrip(NDO_MSG_HEARTBEAT, &hb, &c) == NDO_DROP_RANGE, "negative step");
}

/* A receiver (channels S_*, peer 1, object 42 at level 4) on a new bus,
 * and the sender's link *a on it. */
static ndo_net *receiver(ndo_bus **bus, ndo_link **a)
{
	ndo_bus_create(bus);
	ndo_link *b;
	ndo_link_open_mem(*bus, a);
	ndo_link_open_mem(*bus, &b);
	ndo_net *rx;
	ndo_net_create(b, "S", 1, &rx);
	ndo_net_attach(rx, 42, 4);
	return rx;
}

/* Stale and duplicate messages through a real ndo_net on a bus. */
static void stale_dropped_latest_kept(void)
{
	ndo_bus *bus;
	ndo_link *a;
	ndo_net *rx = receiver(&bus, &a);
	ndo_msg_tile_t t = make_tile(4, 2);
	t.hdr = (ndo_msg_header_t){NDO_PROTOCOL_VERSION, 42, 7, 0, 0};
	uint8_t *buf[3];
	size_t len[3];
	for (int k = 0; k < 3; k++) {
		t.hdr.seq = k;
		t.step = k;
		ndo_msg_encode(NDO_MSG_TILE, &t, &buf[k], &len[k]);
	}
	/* 2 arrives, then 0 (stale: older than what we hold for that range) */
	ndo_link_publish(a, "S_TILE", buf[2], len[2]);
	ndo_link_publish(a, "S_TILE", buf[0], len[0]);
	ndo_net_poll(rx, 0);
	ndo_msg *tiles;
	size_t n;
	ndo_net_take_tiles(rx, &tiles, &n);
	CHECK(n == 1 && tiles[0].u.tile.step == 2, "the newest tile kept (%zu, step %lld)", n,
	      n ? (long long)tiles[0].u.tile.step : -1LL);
	for (size_t k = 0; k < n; k++)
		ndo_msg_free(&tiles[k]);
	free(tiles);
	const ndo_net_stats *st = ndo_net_stats_get(rx);
	CHECK(st->dropped[NDO_DROP_STALE] == 1, "one stale (%llu)",
	      (unsigned long long)st->dropped[NDO_DROP_STALE]);
	CHECK(st->gaps == 0, "gap 0..2 counted then filled: %llu", (unsigned long long)st->gaps);
	for (int k = 0; k < 3; k++)
		free(buf[k]);
	free(t.values);
	ndo_net_destroy(rx);
	ndo_link_destroy(a);
	ndo_bus_destroy(bus);
}

/* The tile filter (ndo_net_set_tile_want): the fields it is asked with
 * are the tile's (ndo_msg_peek_tile against the encoded ones), and a tile
 * it refuses is neither decoded nor queued and leaves no gap. */
static int want_from_step;
static int want(void *user, int32_t sender, int64_t step, int channels)
{
	(void)user;
	return sender != 7 || step >= want_from_step || channels != (NDO_TILE_POSITION | NDO_TILE_VELOCITY);
}

static void unwanted_tiles_passed_over(void)
{
	ndo_msg_tile_t t = make_tile(4, 2);
	t.hdr.seq = 1234567890123;
	t.step = 9876543210;
	t.channels = NDO_TILE_POSITION | NDO_TILE_REST;
	uint8_t *b;
	size_t n;
	ndo_msg_encode(NDO_MSG_TILE, &t, &b, &n);
	int64_t seq, step;
	int ch, enc;
	int32_t id = ndo_msg_peek_tile(b, n, &seq, &step, &ch, &enc);
	CHECK(id == 7 && seq == t.hdr.seq && step == t.step && ch == t.channels && enc == 0,
	      "peeked sender %d seq %lld step %lld channels %d encoding %d", id, (long long)seq,
	      (long long)step, ch, enc);
	CHECK(ndo_msg_peek_tile(b, 77, &seq, &step, &ch, &enc) == 0, "too short: not a tile");
	free(b);
	ndo_msg_halo_t h = {.hdr = t.hdr, .step = 5};
	ndo_msg_encode(NDO_MSG_HALO, &h, &b, &n);
	CHECK(ndo_msg_peek_tile(b, n, &seq, &step, &ch, &enc) == 0, "a halo's bytes: not a tile");
	free(b);

	ndo_bus *bus;
	ndo_link *a;
	ndo_net *rx = receiver(&bus, &a);
	ndo_net_keep_all_tiles(rx, 1);
	ndo_net_set_tile_want(rx, want, NULL);
	want_from_step = 3;
	t.channels = NDO_TILE_POSITION | NDO_TILE_VELOCITY;
	for (int k = 0; k < 4; k++) { /* steps 0..3: 0..2 passed over, 3 taken */
		t.hdr.seq = k;
		t.step = k;
		ndo_msg_encode(NDO_MSG_TILE, &t, &b, &n);
		ndo_link_publish(a, "S_TILE", b, n);
		free(b);
	}
	ndo_net_poll(rx, 0);
	ndo_msg m;
	int got = 0;
	int64_t last = -1;
	while (ndo_net_next(rx, &m)) {
		got++;
		last = m.u.tile.step;
		ndo_msg_free(&m);
	}
	const ndo_net_stats *st = ndo_net_stats_get(rx);
	CHECK(got == 1 && last == 3 && st->unwanted == 3 && st->gaps == 0 && st->accepted == 1,
	      "1 tile taken (%d, step %lld), 3 passed over (%llu), gaps %llu", got, (long long)last,
	      (unsigned long long)st->unwanted, (unsigned long long)st->gaps);
	char line[256];
	ndo_net_stats_format(rx, line, sizeof line);
	CHECK(strstr(line, "3 tiles not used here") != NULL, "the stats say so: %s", line);
	free(t.values);
	ndo_net_destroy(rx);
	ndo_link_destroy(a);
	ndo_bus_destroy(bus);
}

static void tiles_fit_one_datagram(void)
{
	for (int level = 0; level <= 10; level++) {
		const int chs[2] = {NDO_TILE_POSITION | NDO_TILE_VELOCITY, NDO_TILE_REST | NDO_TILE_PIN};
		for (int k = 0; k < 2; k++) {
			int d = ndo_tile_depth(level, chs[k], "NDO_TILE");
			ndo_msg_tile_t t = make_tile(level, d);
			t.channels = (int16_t)chs[k];
			t.nvalues = (int32_t)(ndo_quad_node_count(level, d) *
			                      (size_t)ndo_tile_values_per_node(chs[k]));
			size_t size = ndo_msg_encoded_size(NDO_MSG_TILE, &t);
			CHECK(size <= ndo_msg_max_payload("NDO_TILE"),
			      "level %d: %zu bytes > %zu", level, size, ndo_msg_max_payload("NDO_TILE"));
			if (d > 0) { /* and one depth shallower would not */
				t.nvalues = (int32_t)(ndo_quad_node_count(level, d - 1) *
				                      (size_t)ndo_tile_values_per_node(chs[k]));
				CHECK(ndo_msg_encoded_size(NDO_MSG_TILE, &t) > ndo_msg_max_payload("NDO_TILE"),
				      "level %d depth %d is the shallowest that fits", level, d);
			}
			if (level == 7 && k == 0)
				printf("    level 7 state tile: depth %d, %zu nodes, %zu bytes\n", d,
				       ndo_quad_node_count(level, d), size);
			free(t.values);
		}
	}
}

/* The reference for ndo_tile_pack: node by node over the range, each
 * asked channel's values in bit order (position, velocity, rest: three
 * each; pin: 1 or 0), a missing channel as zeros. */
static double *pack_reference(const ndo_grid *g, ndo_quad q, int channels, size_t *n)
{
	int i0, j0, i1, j1;
	ndo_quad_range(g->level, q, &i0, &j0, &i1, &j1);
	const char *names[3] = {NDO_CH_POSITION, NDO_CH_VELOCITY, NDO_CH_REST};
	double *v = malloc((size_t)(i1 - i0 + 1) * (size_t)(j1 - j0 + 1) * 10 * sizeof *v);
	size_t k = 0;
	for (int j = j0; j <= j1; j++)
		for (int i = i0; i <= i1; i++) {
			size_t node = (size_t)j * (size_t)g->w + (size_t)i;
			for (int c = 0; c < 3; c++) {
				if (!(channels & (1 << c)))
					continue;
				const ndo_channel *ch = ndo_grid_find(g, names[c]);
				for (int d = 0; d < 3; d++)
					v[k++] = ch ? ((const double *)ch->data)[3 * node + d] : 0;
			}
			if (channels & NDO_TILE_PIN) {
				const ndo_channel *ch = ndo_grid_find(g, NDO_CH_PIN);
				v[k++] = ch && ((const uint8_t *)ch->data)[node] ? 1 : 0;
			}
		}
	*n = k;
	return v;
}

/* Every tile of a level-4 grid at every depth, for the channel sets a
 * session sends (a frame's position and velocity take a loop of their
 * own, tile.c), equal to the reference value for value; and without a
 * velocity channel, zeros in its place. */
static void tiles_pack_as_the_reference(void)
{
	ndo_grid *g;
	CHECK(ndo_grid_create(4, &g) == 0, "a level-4 grid");
	ndo_channel *ch;
	double *x = g->ch[0].data;
	for (size_t k = 0; k < 3 * g->count; k++)
		x[k] = 0.5 + (double)k;
	for (int pass = 0; pass < 2; pass++) {
		if (pass == 1) {
			ndo_grid_add(g, NDO_CH_VELOCITY, NDO_F64, 3, &ch);
			for (size_t k = 0; k < 3 * g->count; k++)
				((double *)ch->data)[k] = -0.25 - (double)k;
			ndo_grid_add(g, NDO_CH_PIN, NDO_U8, 1, &ch);
			for (size_t k = 0; k < g->count; k++)
				((uint8_t *)ch->data)[k] = k % 3 == 0;
		}
		const int sets[] = {NDO_TILE_POSITION | NDO_TILE_VELOCITY,
		                    NDO_TILE_POSITION | NDO_TILE_VELOCITY | NDO_TILE_COARSE,
		                    NDO_TILE_POSITION, NDO_TILE_REST | NDO_TILE_PIN, NDO_TILE_ALL};
		int tiles = 0, bad = 0;
		for (size_t s = 0; s < sizeof sets / sizeof *sets; s++)
			for (int d = 0; d <= g->level + 1; d++) {
				int cols, rows;
				ndo_quad_dims(d, &cols, &rows);
				for (int qj = 0; qj < rows; qj++)
					for (int qi = 0; qi < cols; qi++) {
						ndo_quad q = {d, qi, qj};
						ndo_msg_tile_t t;
						size_t n;
						double *ref = pack_reference(g, q, sets[s], &n);
						CHECK(ndo_tile_pack(g, q, sets[s], &t) == 0, "pack");
						bad += (size_t)t.nvalues != n || t.channels != sets[s] ||
						       memcmp(t.values, ref, n * sizeof *ref) != 0;
						tiles++;
						free(t.values);
						free(ref);
					}
			}
		CHECK(bad == 0, "%s velocity: %d of %d tiles differ from the reference",
		      pass ? "with" : "without", bad, tiles);
	}
	ndo_grid_destroy(g);
}

static void quad_codes_roundtrip(void)
{
	int level = 5, bad = 0;
	for (int d = 0; d <= level + 1; d++) {
		int cols, rows;
		ndo_quad_dims(d, &cols, &rows);
		for (int qj = 0; qj < rows; qj++)
			for (int qi = 0; qi < cols; qi++) {
				ndo_quad q = {d, qi, qj}, r;
				int i0, j0, i1, j1;
				ndo_quad_range(level, q, &i0, &j0, &i1, &j1);
				bad += ndo_quad_decode(level, ndo_quad_code(q), &r) != 0 || r.depth != d ||
				       r.qi != qi || r.qj != qj;
				bad += ndo_quad_from_range(level, d, i0, j0, i1, j1, &r) != 0 || r.qi != qi;
			}
	}
	CHECK(bad == 0, "%d quad-tree nodes fail to round-trip", bad);
	ndo_quad r;
	CHECK(ndo_quad_decode(level, 1 << 30, &r) != 0, "code beyond the tree");
}

int main(void)
{
	ck_program = "test_msg";
	RUN(tile_fields_checked);
	RUN(coarse_tiles_checked);
	RUN(halos_checked);
	RUN(solves_checked);
	RUN(node_values_checked_against_the_box);
	RUN(key_requests_checked);
	RUN(bytes_checked_before_decoding);
	RUN(control_messages_checked);
	RUN(stale_dropped_latest_kept);
	RUN(unwanted_tiles_passed_over);
	RUN(tiles_fit_one_datagram);
	RUN(tiles_pack_as_the_reference);
	RUN(quad_codes_roundtrip);
	return ck_failed_cases != 0;
}
