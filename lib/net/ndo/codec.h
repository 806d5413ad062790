/* ndo/codec.h — compact state: the encodings of a state tile's positions
 * and velocities (tile_t.encoding; docs/protocol.md "Encodings",
 * docs/net-bench.md).
 *
 * Five encodings, chosen by the owner for a session (the description
 * carries the choice as "tile-*" lines, so every peer and observer agrees):
 *
 *   raw      every value a double in tile_t.values[] (384 bits a node)
 *   float32  positions as float32 (the thesis' state: 96 bits a node)
 *   fixed    positions as fixed-point integers, q = extent / 2^bits per
 *            axis of the object's bounding box, packed bits+2 wide
 *   predict  positions as those integers, predicted (below) and the
 *            residuals entropy-coded with zstd
 *   hier     positions as integers 16 times finer, coded level by level
 *            against the butterfly of the coarser nodes and the last two
 *            frames, the residuals in steps of q by a range coder (below)
 *
 * Nodes of a tile fall in three classes (the sender decides):
 *   EXACT  nodes another simulating peer integrates with (its halo: the
 *          sender's nodes next to that peer's region): position and
 *          velocity travel as doubles, so lock-step runs are what they are
 *          with raw tiles, bit for bit;
 *   LOSSY  the sender's other nodes: position only, with an error of at
 *          most ndo_codec_max_error() (half a step per axis); a receiver
 *          estimates their velocity from its previous frame of the tile;
 *   SKIP   nodes of other peers that the tile's range covers: not sent.
 *
 * A keyframe starts a tile's history again at both ends (the tile layer
 * clears it before keeping the keyframe), so frames after it refer to it
 * and later frames only.
 *
 * `predict` is closed-loop: every prediction is made from the frames as a
 * receiver reconstructs them (integer codes, so the arithmetic is exact
 * and the same on every machine), and errors do not drift.  A node's code
 * is predicted from the tile's last three frames sent, k1, k2, k3, at the
 * steps before: the linear extrapolation 2k1 − k2 plus half the sum of two
 * corrections (rounded half away from zero): last step's second
 * difference k1 − 2k2 + k3, and the upper row's extrapolation errors this
 * step — the upper neighbour's, clamped between the upper-left's and the
 * upper-right's (the upper's standing in for a missing one; none on the
 * first row or without an upper neighbour).  Neither correction when the
 * steps are not consecutive (the extrapolation scaled to the gap), each
 * only when it exists.  Only the row above enters, never the node to the
 * left, so a row decodes without a chain from node to node (the earlier
 * correction, LOCO-I's median of the left, upper and upper-left errors,
 * took 1 % fewer bits at level 6 over 2 s, 4.51 against 4.57 a node, and
 * made decoding sequential).  A
 * keyframe (no reference: the codes predicted from their left, upper and
 * upper-left neighbours, LOCO-I's median) comes every `keyframe` steps
 * and whenever the sender has no reference, so a receiver that lost a
 * frame of a tile recovers by the next keyframe.  A tile whose every node
 * is predicted exactly (every residual 0) and carries no EXACT node is not
 * sent (at most MAX_SKIP steps in a row); the next frame's base step tells
 * a receiver which steps were skipped, and their frames are the
 * predictions (ndo_codec_implied()).
 *
 * The payload (tile_t.data) is: one flags byte (bits 0-1 kind: 0 intra,
 * 1 predicted; bit 2 zstd; bit 3 wide fixed-point; bits 4-7 zero), for a
 * predicted frame two unsigned LEB128 varints g2, g3 (the steps from the
 * base to the second and third reference, 0 when absent), then the body —
 * zstd-compressed with bit 2 —: the classes as run lengths (varint pairs:
 * class, count; raster order over the tile), the EXACT nodes' six doubles
 * each (little-endian; predict: first every EXACT position XOR its
 * extrapolation from the references' positions, as 8 byte planes, most
 * significant first, then the velocities), then the LOSSY nodes'
 * positions: float32 ×3;
 * fixed codes bit-packed; predict residuals zigzag-coded, component by
 * component, as 2-bit symbols four to a byte (first in the low bits; the
 * residual itself below 3, 3 an escape; unused bits of the last byte zero)
 * followed by every escape's zigzag − 3 as a varint.
 *
 * `hier` (lib/net/codec_hier.c): codes in steps of q/16 (q the step of
 * fixed and predict, so the bound is theirs); a tile's nodes in levels —
 * the top level every S-th node of the tile (S the largest power of two
 * below its larger side), then level s = S/2, ..., 1 the nodes at
 * multiples of s not in a coarser level, each the midpoint of an edge of
 * level 2s (horizontal, vertical, or the grid's diagonal).  Node n's
 * prediction, from codes the receiver holds: with k1, k2 the tile's last
 * two frames (the slope v = k1 − k2, scaled to the steps when they are not
 * consecutive; none without k2; no k1 at all in a keyframe, or when a
 * reference lacks a node the frame holds), 16 P = 16 k1(n) + B[k − k1](n) +
 * β/4 (16 v(n) − B[v](n)), rounded half up, where B is the modified
 * butterfly over the edge's eight stencil nodes (weights 8, 8, 2, 2, −1 ×
 * 4, over 16) — the ends' mean, or the one end, when one of them is
 * outside the tile or not held — and β ∈ 0..4 the sender's choice per
 * level; a top-level node's stencil is empty (in a keyframe it is
 * predicted by the previous top-level node, 0 for the first).  Its
 * residual r (per component) puts it at P + 16 r: the sender picks, within
 * the bound, the r nearest 0 (so r = 0 whenever the prediction is within
 * the bound), and the receiver holds exactly P + 16 r.  Skipped tiles as
 * predict (their frames the predictions with β = 4 on every level).
 *
 * The payload: the flags byte and g2, g3 as above (bit 2: zstd on the
 * first part), a varint n1, n1 bytes (zstd-compressed with bit 2) of the
 * classes and EXACT nodes as predict has them, then to the end the range
 * coder's bytes (LZMA's binary coder: 11-bit adaptive probabilities, 5
 * bytes flushed, the first 0): per level, top first, β as 3 direct bits
 * (not in a keyframe), then per LOSSY node of the level in raster order a
 * flag "some residual nonzero" (context: the level group 1, 2, 4, 8+, top;
 * the magnitudes of the edge ends' residuals), then per component a zero
 * flag (the third implied when the first two are 0; context the group,
 * component and its ends' magnitudes), each nonzero one's sign and |r| as
 * Elias gamma (the exponent in unary, adaptive; the mantissa bits direct).
 * The decoder reads every byte and no more, or the frame is corrupt.
 *
 * Nothing received is trusted: a payload that does not parse, decompresses
 * to more than a tile of that size can hold (a decompression bomb), carries
 * a non-finite double or a code out of range is NDO_DROP_CORRUPT; a
 * predicted frame whose reference frames the receiver does not hold is
 * NDO_DROP_NOBASE.  Both are counted drops, never a crash.
 */
#ifndef NDO_CODEC_H
#define NDO_CODEC_H

#include <stddef.h>
#include <stdint.h>

#include "ndo/grid.h"
#include "ndo/msg.h"
#include "ndo/quadtree.h"

#ifdef __cplusplus
extern "C" {
#endif

enum { NDO_NODE_SKIP = 0, NDO_NODE_LOSSY = 1, NDO_NODE_EXACT = 2 };

#define NDO_CODEC_BITS_DEFAULT 13     /* max error 0.61e-4 of the box's diagonal */
#define NDO_CODEC_KEYFRAME_DEFAULT 32 /* steps between keyframes */
#define NDO_CODEC_MAX_SKIP 8          /* steps a tile may go unsent in a row */
#define NDO_CODEC_MAX_GAP 8192        /* steps between a frame and its reference */
#define NDO_CODEC_ERROR_MIN 1e-7      /* error budgets, over the box's diagonal */
#define NDO_CODEC_ERROR_MAX 0.01

typedef struct ndo_codec_params {
	int encoding;     /* NDO_ENC_RAW, _FLOAT32, _FIXED, _PREDICT, _HIER */
	int bits;         /* fixed, predict, hier: 1..24 */
	int keyframe;     /* predict, hier: 1..4096 */
	double error;     /* fixed, predict, hier: > 0, an error budget instead of bits:
	                     the largest LOSSY error over the box's diagonal
	                     (NDO_CODEC_ERROR_MIN..MAX), one step q on every
	                     axis with √3 q / 2 = error × diagonal; 0: bits */
	double lo[3];     /* the box the codes count from (the rest shape's) */
	double ext[3];    /* its extent per axis, > 0 */
} ndo_codec_params;

/* "raw", "float32", "fixed[:BITS]", "predict[:BITS[:KEYFRAME]]",
 * "hier[:BITS[:KEYFRAME]]" →
 * encoding, bits and keyframe; BITS may be an error budget instead, a
 * number with a point or an exponent ("predict:1e-4": the largest error
 * 1e-4 of the box's diagonal, the coarsest step that keeps it).  The box
 * is zero (the owner's session takes its rest shape's).  0, or
 * NDO_EINVAL with a detail naming what is wrong. */
int ndo_codec_parse(const char *spec, ndo_codec_params *p);
/* The spec back ("predict:13:32"). */
void ndo_codec_name(const ndo_codec_params *p, char *buf, size_t size);
/* The box of n points (3 doubles each): lo and ext; an axis of zero
 * extent gets 1e-6 of the largest (or 1 for a single point). */
void ndo_codec_box(const double *x, size_t n, double lo[3], double ext[3]);
/* The largest distance between a LOSSY position and its decoded value:
 * half the quantization step's diagonal, diag/2^(bits+1), or the error
 * budget × diag (float32: the
 * float rounding of the box's far corner; raw: 0). */
double ndo_codec_max_error(const ndo_codec_params *p);
/* The box's diagonal. */
double ndo_codec_diagonal(const ndo_codec_params *p);

/* The description lines ("tile-encoding 3\ntile-bits 13\n..."), nothing
 * for raw.  Returns the length written (< size) or NDO_ERANGE. */
int ndo_codec_params_text(const ndo_codec_params *p, char *buf, size_t size);
/* Read and remove the "tile-*" lines from a description's text (in
 * place): *p is raw when there are none.  0, or NDO_EINVAL (a bad line:
 * ndo_errdetail()). */
int ndo_codec_params_take(char *text, ndo_codec_params *p);
/* The same for a description's scene as it arrives (len bytes, not
 * NUL-terminated; NULL when len is 0), which is left as it is.  0,
 * NDO_EINVAL or NDO_ENOMEM. */
int ndo_codec_params_read(const void *scene, size_t len, ndo_codec_params *p);
/* 0 when *p is a consistent set of parameters, else NDO_EINVAL. */
int ndo_codec_params_check(const ndo_codec_params *p);

/* The send level (docs/protocol.md, "Send level"): whole-region state
 * travels at level L ≤ the object's (its every 2^k-th node, k = level −
 * L), as tiles with NDO_TILE_COARSE; the owner's description says so in a
 * line "send-level L" (none when L is the object's level).  _text writes
 * the line (nothing when L = level): the length, or NDO_ERANGE.  _take
 * reads and removes it from a description's text (*send_level = level
 * when there is none); _read leaves the scene as it is.  0, NDO_EINVAL (a
 * bad line, or L outside 0..level), NDO_ENOMEM. */
int ndo_send_level_text(int send_level, int level, char *buf, size_t size);
int ndo_send_level_take(char *text, int level, int *send_level);
int ndo_send_level_read(const void *scene, size_t len, int level, int *send_level);

/* ---- one tile's frames (pure functions) ------------------------------------ */

/* A frame of a tile as every receiver reconstructs it. */
typedef struct ndo_codec_frame {
	int64_t step;  /* −1: none */
	double time;
	int32_t epoch;
	double *x;     /* nodes × 3: positions where have is NDO_HAVE_X */
	int32_t *k;    /* nodes × 3: codes (fixed, predict) */
	uint8_t *have; /* nodes: 0 where the frame does not hold the node, else
	                  how: NDO_HAVE_CODE (a LOSSY node under fixed or
	                  predict: its position is lo + k q, x is not kept) or
	                  NDO_HAVE_X (the position in x) */
} ndo_codec_frame;
enum { NDO_HAVE_CODE = 1, NDO_HAVE_X = 2 };

/* Node n's position in frame f (NaN when f does not hold it). */
void ndo_codec_frame_position(const ndo_codec_params *p, const ndo_codec_frame *f, int n,
                              double x[3]);

/* A tile's history: its last frames, newest first. */
#define NDO_CODEC_HISTORY 4
typedef struct ndo_codec_hist {
	int nodes;
	ndo_codec_frame f[NDO_CODEC_HISTORY];
} ndo_codec_hist;

int ndo_codec_hist_init(ndo_codec_hist *h, int nodes); /* 0 or NDO_ENOMEM */
void ndo_codec_hist_free(ndo_codec_hist *h);
/* Forget every frame. */
void ndo_codec_hist_clear(ndo_codec_hist *h);
/* Insert frame `f` (copied) in step order, replacing one of the same step;
 * the oldest falls out.  Frames of another epoch than f's are forgotten. */
void ndo_codec_hist_put(ndo_codec_hist *h, const ndo_codec_frame *f);
/* The same without a copy: the history takes f's arrays (sized for at
 * least h->nodes) and gives f those of the frame that fell out (sized for
 * h->nodes).  Returns 1 when it did, 0 when f was of no use (older than
 * every frame held) and is left as it was. */
int ndo_codec_hist_take(ndo_codec_hist *h, ndo_codec_frame *f);
/* The frame of `step` held, or NULL. */
const ndo_codec_frame *ndo_codec_hist_find(const ndo_codec_hist *h, int64_t step);

/* Scratch space and zstd contexts for the calls below (one thread each);
 * NULL to a call: made and freed within it (slower). */
typedef struct ndo_codec_work ndo_codec_work;
ndo_codec_work *ndo_codec_work_create(void); /* NULL when out of memory */
void ndo_codec_work_destroy(ndo_codec_work *w);
/* The position error of the last frame ndo_codec_encode() made with w
 * (its LOSSY nodes: what receivers reconstruct against the value): the
 * largest squared distance, their sum, the count of LOSSY nodes. */
void ndo_codec_work_error(const ndo_codec_work *w, double *max2, double *sum2, size_t *count);

/* What the encoder is given: one tile's rows × cols nodes, row-major. */
typedef struct ndo_codec_input {
	int rows, cols;
	const double *x, *v;  /* nodes × 3 */
	const uint8_t *cls;   /* nodes: NDO_NODE_* */
	int64_t step;
	double time;
	int32_t epoch;
	int stride;           /* nodes from a row's first in x and v to the next
	                         row's (≥ cols; 0: cols) — a tile of a grid in
	                         place; cls is always rows × cols */
} ndo_codec_input;

/* Encode one frame.  `h`: the tile's history as receivers hold it;
 * intra: 0 predict from h (a keyframe when h holds nothing), 1 a keyframe,
 * 2 a keyframe receivers do not keep as a reference (flags bit 4: a step
 * sent again after its frame left the history).  Out: *data (malloc'd, *len bytes), the
 * base step (−1: none) and `recon`, the frame every receiver will
 * reconstruct (arrays sized for in->rows × cols, owned by the caller).
 * *unchanged is set when the frame is predicted, holds no EXACT node and
 * every residual is 0 (the caller may skip it).  0, NDO_ENOMEM, or
 * NDO_ERANGE (a position too far out of the box for the codes, or not
 * finite: send this tile raw). */
int ndo_codec_encode(const ndo_codec_params *p, ndo_codec_work *w, const ndo_codec_hist *h,
                     int intra,
                     const ndo_codec_input *in, uint8_t **data, size_t *len,
                     int64_t *base_step, ndo_codec_frame *recon, int *unchanged);

/* Decode one frame of rows × cols nodes: x, v (nodes × 3, the caller's)
 * get every carried node's position and velocity; the others, and the
 * velocities of LOSSY nodes without a previous frame in `h`, are NaN.
 * `recon` as for ndo_codec_encode (its step is −1 when the frame is not to
 * be kept as a reference).  NDO_DROP_NONE, NDO_DROP_CORRUPT,
 * NDO_DROP_NOBASE, or NDO_DROP_RANGE (a memory shortage: not the
 * sender's fault, but the frame is lost all the same). */
ndo_drop ndo_codec_decode(const ndo_codec_params *p, ndo_codec_work *w,
                          const ndo_codec_hist *h, int rows,
                          int cols, const uint8_t *data, size_t len, int64_t step, double time,
                          int32_t epoch, int64_t base_step, double *x, double *v,
                          ndo_codec_frame *recon);

/* The same, node n's position and velocity at x[stride × n ...] and
 * v[stride × n ...] (stride ≥ 3): a tile's values (6 a node) in place. */
ndo_drop ndo_codec_decode_strided(const ndo_codec_params *p, ndo_codec_work *w,
                                  const ndo_codec_hist *h, int rows, int cols,
                                  const uint8_t *data, size_t len, int64_t step, double time,
                                  int32_t epoch, int64_t base_step, double *x, double *v,
                                  int stride, ndo_codec_frame *recon);

/* The frame of a skipped step (base_step < step < the next frame's step):
 * every node the base frame holds, predicted with no residual. */
int ndo_codec_implied(const ndo_codec_params *p, const ndo_codec_hist *h, int rows, int cols,
                      int64_t step, double time, double *x, ndo_codec_frame *recon);

/* ---- tiles on the wire (state per sender and tile) ------------------------- */

typedef struct ndo_codec ndo_codec;

typedef struct ndo_codec_stats {
	uint64_t encoded, skipped, keyframes, raw_fallbacks;
	uint64_t decoded, implied, corrupt, nobase;
	/* encoder: tiles receivers asked a keyframe of (ndo_codec_want_key),
	 * and keyframes sent early because of it */
	uint64_t keys_asked, keys_forced;
	double encode_seconds, decode_seconds; /* CLOCK_MONOTONIC */
	uint64_t payload_bytes;                /* data[] bytes encoded */
	/* encoder: the position error it introduced (LOSSY nodes of every
	 * frame sent or skipped: the distance of what receivers reconstruct
	 * from the value) */
	double max_error, sum_sq_error;
	uint64_t error_nodes;
} ndo_codec_stats;

/* The classes of a level's stored nodes (W × H) for sender `self`, from
 * the owner channel (W × H ids, stored duplicates agreeing): its nodes in
 * the 1-ring (through the ghost map) of another peer's region EXACT — what
 * that peer's halo holds —, its other nodes LOSSY, the rest SKIP.
 * Returns the count of EXACT stored nodes. */
size_t ndo_codec_classify(int level, const int32_t *owner, int32_t self, uint8_t *cls);

/* Tiles of a level-`level` object under *p. */
int ndo_codec_create(const ndo_codec_params *p, int level, ndo_codec **out);
void ndo_codec_destroy(ndo_codec *c); /* accepts NULL */
const ndo_codec_params *ndo_codec_params_of(const ndo_codec *c);
/* The memory the tiles' histories may take (each (sender, tile) pair's
 * NDO_CODEC_HISTORY frames): beyond it the least recently used are
 * forgotten (their next frame a keyframe, or `nobase` here).  By default
 * twice the object's, at least 256 MB. */
void ndo_codec_set_memory(ndo_codec *c, size_t bytes);

/* Encode a position+velocity tile of g (f64 position and velocity) for
 * quad-tree node q, step `t->step`, time, epoch already set in *t: fills
 * t->encoding, base_step, nbytes, data (malloc'd; values NULL).  cls:
 * per stored node of g, NDO_NODE_*.  Keeps the tile's history under
 * (sender `self`, q); `standalone` ≠ 0: a keyframe that does not touch
 * the history (a step sent again whose frame is no longer held).
 * Returns 1 when the tile is unchanged and may be skipped (nothing
 * filled), 0 when filled, NDO_ERANGE when it cannot be encoded (send it
 * raw: its history is forgotten), NDO_ENOMEM. */
int ndo_codec_encode_tile(ndo_codec *c, int32_t self, const ndo_grid *g, const uint8_t *cls,
                          ndo_quad q, int standalone, ndo_msg_tile_t *t);

/* After ndo_codec_encode_tile() returned 0 or 1 (not a step sent again):
 * the positions every receiver reconstructs for that tile's nodes (x:
 * nodes × 3, row-major over the tile; NaN where the frame holds none).
 * 0, or NDO_EINVAL when there is no such frame. */
int ndo_codec_last_positions(const ndo_codec *c, double *x);

/* Receivers lost a frame of (self, tile `code`) and ask for a keyframe
 * (ndo_msg_key_request_t): its next frame is one, unless its last keyframe
 * is fewer than NDO_CODEC_KEY_GAP frames back — then the frame that many
 * after it is.  So however many receivers ask, and however often, at most
 * one frame in NDO_CODEC_KEY_GAP of a tile is a keyframe they asked for.  1 when the tile is one this encoder sends, 0
 * otherwise (nothing changes). */
#define NDO_CODEC_KEY_GAP 4
int ndo_codec_want_key(ndo_codec *c, int32_t self, int32_t code);

/* Forget the history of (self, q): a tile that was encoded but not sent. */
void ndo_codec_forget_tile(ndo_codec *c, int32_t self, ndo_quad q);

/* Decode a validated tile in place into raw form (encoding RAW, values
 * malloc'd: nodes × (position, velocity), NaN where not carried; data
 * freed).  A raw tile is left as it is.  NDO_DROP_NONE or the reason. */
ndo_drop ndo_codec_decode_tile(ndo_codec *c, ndo_msg_tile_t *t);

/* Before ndo_codec_decode_tile(): whether a validated tile's reference
 * frame is here.  NDO_BASE_READY: a raw tile, a keyframe, a predicted one
 * whose base step this receiver decoded (of its epoch), or one that cannot
 * decode for another reason (the decode says which); NDO_BASE_PENDING: a
 * predicted frame whose base is newer than every frame of its tile decoded
 * here, or of a newer epoch than theirs (a reordered frame: its reference
 * may still arrive); NDO_BASE_GONE: older than that (it never will).  No
 * side effect. */
enum { NDO_BASE_READY, NDO_BASE_PENDING, NDO_BASE_GONE };
int ndo_codec_base_state(const ndo_codec *c, const ndo_msg_tile_t *t);
/* 1 when a frame of the tile's sender and range has been decoded here. */
int ndo_codec_tile_known(const ndo_codec *c, const ndo_msg_tile_t *t);

/* After ndo_codec_decode_tile() of a predicted tile t: the steps skipped
 * before it (0 when none) and the tile of the k-th of them (0-based,
 * oldest first) into *out (raw, values malloc'd; header copied from t).
 * 0 or NDO_ENOMEM. */
int ndo_codec_skipped(const ndo_codec *c, const ndo_msg_tile_t *t);
int ndo_codec_skipped_tile(ndo_codec *c, const ndo_msg_tile_t *t, int k, ndo_msg_tile_t *out);

void ndo_codec_stats_get(const ndo_codec *c, ndo_codec_stats *st);

#ifdef __cplusplus
}
#endif
#endif
