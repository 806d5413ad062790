/* codec_private.h — what the parts of the state codec share (not
 * installed): the workspace, the payload's byte buffers, codes and the
 * predictor's context, and each part's entry points.
 *
 *   codec_params.c   the encodings' parameters and their text form
 *   codec_predict.c  quantization codes, the reference history, the
 *                    general predictor (ndo/codec.h "predict")
 *   codec_rows.c     the predictor's common case, fast: a row at a time
 *   codec_entropy.c  residuals as 2-bit symbols + escapes, EXACT nodes'
 *                    byte planes, class runs, zstd
 *   codec.c          the workspace and the payload: encode, decode
 *
 * The small helpers are inline here, so that the row loops and the body
 * compile them into their loops as they did in one file. */
#ifndef NDO_CODEC_PRIVATE_H
#define NDO_CODEC_PRIVATE_H

#include "ndo/codec.h"
#include "ndo/simd.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <zstd.h>

/* The hot loops are compiled for x86-64 and x86-64-v3 (AVX2), at -O3 so
 * that they vectorize (ndo/simd.h).  Integer results, and double
 * operations without fused ones (C11 mode): the same on both.  Under
 * AddressSanitizer one variant: the clones of codec_hier.c's levels() took
 * 138 s to compile there (20 s with one). */
#define NDO_HOT NDO_HOT_O3

enum { KIND_INTRA = 0, KIND_PRED = 1, F_ZSTD = 4, F_WIDE = 8, F_NOREF = 16 };
#define CODE_MAX (1 << 30)

/* ---- workspace ---------------------------------------------------------------- */
struct ndo_codec_work {
	ZSTD_CCtx *cc;
	ZSTD_DCtx *dc;
	uint8_t *buf, *buf2;
	size_t cap, cap2;
	int32_t *cur;    /* nodes: one component's codes */
	uint64_t *u;     /* 3 x nodes: the residuals, zigzag-coded */
	int64_t *erow;   /* 6 x nodes: two rows' extrapolation errors (pctx) */
	void *row;       /* the row loops' scratch (row_scratch()) */
	double *xg;      /* 3 x nodes: strided positions gathered (ndo_codec_input.stride) */
	size_t xgcap;
	size_t rowcap;   /* its bytes */
	double err_max2, err_sum2; /* the last frame encoded: its LOSSY errors */
	size_t err_n;
	size_t ecap;
	int64_t *ht;     /* hier: HIER_SCRATCH x nodes */
	uint8_t *hmag;   /* hier: 3 x nodes residual magnitudes */
};

/* The row loops' scratch for rows of `cols` nodes (L = 3 cols values):
 * three rows of extrapolation errors with 3 values of padding each side
 * (the previous row, the current one, a row of zeros), the steps and
 * offsets per value, and per-value temporaries. */
typedef struct rowsc {
	int64_t *e[2], *ez; /* [−3, L + 3) */
	int64_t *lin, *kt;  /* L */
	uint64_t *uu;       /* L */
	double *lo, *q, *sq, *vv; /* L */
	int32_t *kq;        /* L */
} rowsc;

/* The residuals as the payload has them (ndo/codec.h), read or written in
 * place by the row loops: value k (component d of the LOSSY node of rank
 * i: k = d × lossy + i) is the 2-bit symbol k of sym[]; the escapes (the
 * values ≥ 3 themselves) of component d at esc[first[d] ...] in order
 * (encoder: at esc[d × lossy ...], ne[d] of them). */
typedef struct syms {
	uint8_t *sym;
	uint64_t *esc;
	size_t lossy, first[3], ne[3];
} syms;

/* ---- bytes ------------------------------------------------------------------- */
typedef struct wbuf { uint8_t *p; size_t n, cap; int fail; } wbuf;

static inline void put(wbuf *b, const void *src, size_t n)
{
	if (b->fail)
		return;
	if (b->n + n > b->cap) {
		size_t cap = b->cap ? 2 * b->cap : 4096;
		while (cap < b->n + n)
			cap *= 2;
		uint8_t *q = realloc(b->p, cap);
		if (!q) {
			b->fail = 1;
			return;
		}
		b->p = q;
		b->cap = cap;
	}
	memcpy(b->p + b->n, src, n);
	b->n += n;
}

/* Room for n more bytes at b->p + b->n (0, or −1: out of memory). */
static inline int reserve(wbuf *b, size_t n)
{
	if (b->fail)
		return -1;
	if (b->n + n <= b->cap)
		return 0;
	size_t cap = b->cap ? b->cap : 4096;
	while (cap < b->n + n)
		cap *= 2;
	uint8_t *q = realloc(b->p, cap);
	if (!q) {
		b->fail = 1;
		return -1;
	}
	b->p = q;
	b->cap = cap;
	return 0;
}

static inline void put_byte(wbuf *b, uint8_t v)
{
	if (b->n < b->cap && !b->fail)
		b->p[b->n++] = v;
	else
		put(b, &v, 1);
}

static inline void put_varint(wbuf *b, uint64_t v)
{
	uint8_t t[10];
	int n = 0;
	do {
		t[n++] = (uint8_t)((v & 127) | (v > 127 ? 128 : 0));
		v >>= 7;
	} while (v);
	put(b, t, (size_t)n);
}

static inline void put_f64(wbuf *b, double d)
{
	uint64_t u;
	memcpy(&u, &d, 8);
	uint8_t t[8];
	for (int k = 0; k < 8; k++)
		t[k] = (uint8_t)(u >> (8 * k));
	put(b, t, 8);
}

typedef struct rbuf { const uint8_t *p; size_t n, pos; int bad; } rbuf;

static inline uint64_t get_varint(rbuf *r)
{
	uint64_t v = 0;
	for (int s = 0; s < 64; s += 7) {
		if (r->pos >= r->n) {
			r->bad = 1;
			return 0;
		}
		uint8_t c = r->p[r->pos++];
		v |= (uint64_t)(c & 127) << s;
		if (!(c & 128))
			return v;
	}
	r->bad = 1;
	return 0;
}

static inline double get_f64(rbuf *r)
{
	if (r->n - r->pos < 8 || r->pos > r->n) {
		r->bad = 1;
		return 0;
	}
	uint64_t u = 0;
	for (int k = 0; k < 8; k++)
		u |= (uint64_t)r->p[r->pos + k] << (8 * k);
	r->pos += 8;
	double d;
	memcpy(&d, &u, 8);
	return d;
}

static inline uint64_t zigzag(int64_t v) { return ((uint64_t)v << 1) ^ (uint64_t)(v >> 63); }
static inline uint64_t bits_of(double d)
{
	uint64_t u;
	memcpy(&u, &d, 8);
	return u;
}

static inline double double_of(uint64_t u)
{
	double d;
	memcpy(&d, &u, 8);
	return d;
}

/* a little-endian word as read by memcpy, in the machine's order */
static inline uint64_t le64(uint64_t w)
{
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
	return __builtin_bswap64(w);
#else
	return w;
#endif
}

static inline int64_t unzigzag(uint64_t u) { return (int64_t)(u >> 1) ^ -(int64_t)(u & 1); }

/* ---- codes and the predictor's context ----------------------------------------- */
/* The quantization step per axis, ext / 2^bits (exact: a power of two's
 * scaling), computed once for a set of parameters. */
typedef struct quant { double lo[3], q[3]; } quant;

/* The code of coordinate x on axis c, 0 when it is out of range (*ok = 0). */
static inline int32_t code_of(const quant *z, int c, double x, int *ok)
{
	double t = (x - z->lo[c]) / z->q[c] + 0.5;
	if (!(t >= -CODE_MAX + 1 && t < CODE_MAX)) { /* floor(t) in (−CODE_MAX, CODE_MAX) */
		*ok = 0;
		return 0;
	}
	int32_t k = (int32_t)t; /* floor(t), without a call to libm */
	return k - ((double)k > t);
}

static inline double value_of(const quant *z, int c, int64_t k)
{
	return z->lo[c] + (double)k * z->q[c];
}

/* Node n's position on axis d in frame f (which holds the node): from
 * its code (NDO_HAVE_CODE), or as kept (NDO_HAVE_X). */
static inline double frame_pos(const quant *z, const ndo_codec_frame *f, int n, int d)
{
	return f->have[n] == NDO_HAVE_X ? f->x[3 * n + d] : value_of(z, d, f->k[3 * n + d]);
}

/* a/b rounded half away from zero (b > 0) */
static inline int64_t rdiv(int64_t a, int64_t b)
{
	if (b <= 0)
		return a; /* cannot happen: references are of distinct steps */
	return a >= 0 ? (a + b / 2) / b : -((-a + b / 2) / b);
}

/* LOCO-I's median predictor of left a, up b, upper-left c: min(a, b)
 * when c ≥ max(a, b), max(a, b) when c ≤ min(a, b), else a + b − c.
 * Without branches: the data decide, and would mispredict them. */
static inline int64_t med3(int64_t a, int64_t b, int64_t c)
{
	int64_t mx = a > b ? a : b, mn = a < b ? a : b;
	int64_t r = c <= mn ? mx : a + b - c;
	return c >= mx ? mn : r;
}

/* a clamped between b and c (the median of the three) */
static inline int64_t clamp3(int64_t a, int64_t b, int64_t c)
{
	int64_t mx = b > c ? b : c, mn = b < c ? b : c;
	return a < mn ? mn : a > mx ? mx : a;
}

/* What the predictor works with for one frame (ndo/codec.h, "predict"). */
typedef struct pctx {
	const ndo_codec_frame *r[3]; /* references, newest first (NULL: absent) */
	int64_t step;
	int cols, nodes;
	const uint8_t *cls;          /* this frame's classes */
	const int32_t *cur;          /* this frame's codes so far (one component) */
	int cons, cons3;             /* r0, r1 at step−1, step−2; and r2 at step−3 */
	int64_t *erow;               /* fast loops: 2 rows × cols × 3 errors, scratch */
} pctx;

static inline int carried(const pctx *c, int m) { return c->cls[m] != NDO_NODE_SKIP; }

/* rdiv(a, 2): halves rounded away from zero (C division truncates) */
static inline int64_t half(int64_t a)
{
	/* (a + 1 − 2 (a < 0)) / 2 as (a + (a ≥ 0)) >> 1, the arithmetic shift
	 * as a logical one with the sign kept (AVX2 has no 64-bit one) */
	const uint64_t t = (uint64_t)a + (a >= 0);
	return (int64_t)((t >> 1) | (t & 0x8000000000000000u));
}

/* The prediction of node n's component d in a uniform frame (see
 * ndo__codec_uniform(); ndo__codec_predict() without its checks): k holds this frame's codes
 * of the nodes before n in raster order (a keyframe's references). */
enum { M_INTRA, M_COPY, M_CURVED, M_LINEAR, M_GAP }; /* which references (uniform frames) */

static inline int fast_mode(const pctx *c)
{
	return !c->r[0] ? M_INTRA : !c->r[1] ? M_COPY : c->cons3 ? M_CURVED : c->cons ? M_LINEAR : M_GAP;
}

/* Decoder, a uniform frame: the LOSSY nodes' codes and values from the
 * residuals (as ndo__codec_fast_encode() lays them out); recon->k holds the EXACT
 * nodes' codes.  −1 when a code comes out of range. */
/* Where a decoder's positions and velocities go (ndo_codec_decode_strided),
 * and what velocities are estimated from; done: the LOSSY nodes' are out. */
typedef struct outs {
	double *x, *v;
	size_t S;
	const ndo_codec_frame *prev; /* NULL: none */
	double inv;                  /* 1 / (time − prev's), 0: no estimate */
	int done;
} outs;

/* ---- the parts' entry points ------------------------------------------------ */
/* codec_predict.c: codes and prediction, the reference history. */
quant ndo__codec_quant_of(const ndo_codec_params *p);
int ndo__codec_code_bits(const ndo_codec_params *p, const quant *z);
void ndo__codec_pctx_init(pctx *c, const ndo_codec_frame *r0, const ndo_codec_frame *r1,
                          const ndo_codec_frame *r2, int64_t step);
int64_t ndo__codec_predict(const pctx *c, int n, int d);
const ndo_codec_frame *ndo__codec_before(const ndo_codec_hist *h, int64_t step, int32_t epoch);

/* codec_rows.c: the predictor's common case, a row at a time. */
int ndo__codec_uniform(const pctx *c);
int ndo__codec_fast_encode(const pctx *c, const quant *z, rowsc *rs, const double *x, size_t xs,
                           ndo_codec_frame *recon, uint64_t *u, size_t lossy, uint64_t *any,
                           double err[2], wbuf *b);
int ndo__codec_fast_decode(const pctx *c, const quant *z, rowsc *rs, const uint64_t *u,
                           size_t lossy, const syms *sy, ndo_codec_frame *recon, outs *o);

/* codec_entropy.c: the residuals as 2-bit symbols and escapes, the EXACT
 * nodes' byte planes, the class runs, and zstd over the body. */
void ndo__codec_put_residuals(wbuf *b, const uint64_t *u, size_t m);
int ndo__codec_get_residuals(rbuf *r, uint64_t *u, size_t m);
int ndo__codec_get_symbols(rbuf *r, size_t lossy, uint64_t *esc, syms *sy);
void ndo__codec_put_planes(wbuf *b, const uint64_t *w, size_t m);
int ndo__codec_get_planes(rbuf *r, uint64_t *w, size_t m);
void ndo__codec_put_classes(wbuf *b, const uint8_t *cls, int nodes);
int ndo__codec_get_classes(rbuf *r, uint8_t *cls, int nodes);
/* The body after out's header, zstd-compressed when that is shorter (then
 * F_ZSTD is set in out's first byte); −1: out of memory. */
int ndo__codec_zstd_put(ndo_codec_work *w, wbuf *out, const wbuf *body);
/* A compressed body (F_ZSTD) of at most `bound` bytes into w's buffer, and
 * *b reading it: NDO_DROP_NONE, or why not. */
ndo_drop ndo__codec_zstd_get(ndo_codec_work *w, rbuf *b, size_t bound);

/* codec_hier.c: the hierarchical coder ("hier") and its range coder.  An
 * encoder writes to a wbuf; a decoder reads p[0, n), counting in `over`
 * the bytes it wanted past the end (0 for a whole stream). */
typedef struct rcenc {
	uint64_t low;
	uint32_t range;
	uint8_t cache;
	uint64_t pending;
	wbuf *b;
} rcenc;
typedef struct rcdec {
	const uint8_t *p;
	size_t n, pos, over;
	uint32_t range, code;
} rcdec;
void ndo__rc_enc_init(rcenc *e, wbuf *b);
void ndo__rc_enc_bit(rcenc *e, uint16_t *p, int bit); /* p: P(0) in 1/2048, adapted */
void ndo__rc_enc_direct(rcenc *e, int bit);           /* probability 1/2 */
void ndo__rc_enc_flush(rcenc *e);
void ndo__rc_dec_init(rcdec *d, const uint8_t *p, size_t n);
int ndo__rc_dec_bit(rcdec *d, uint16_t *p);
int ndo__rc_dec_direct(rcdec *d);

/* A frame for the hierarchical coder: the tile, its classes, the
 * references (newest first, NULL: absent) and the step. */
#define HIER_SCRATCH 15 /* int64 a node: codec_hier.c's hier_init() lays them out */
#define HIER_FINE 16 /* hier's codes: steps of q / 16; its residuals: steps of q */
typedef struct hcodes {
	int rows, cols;
	const uint8_t *cls;
	const ndo_codec_frame *r[3];
	int64_t step;
} hcodes;
/* k: the frame's codes (3 a node; encoder: every carried node's but the
 * LOSSY ones', which it chooses, their positions x checked in range; decoder:
 * the EXACT nodes', the LOSSY ones' filled); t (HIER_SCRATCH a node) and
 * mag (3 a node) scratch.  Encode: 0, −1 (out of memory) or −2 (a code out
 * of range); *any: a nonzero
 * residual.  Decode: 0, or −1 (corrupt: bad symbols, a code out of range,
 * bytes missing or left over).  Implied: the LOSSY codes predicted, no
 * residual (0, or −1: a code out of range). */
int ndo__codec_hier_encode(const hcodes *c, const quant *z, double maxerr, const double *x,
                           int32_t *k, int64_t *t, uint8_t *mag, uint64_t *any, wbuf *b);
int ndo__codec_hier_decode(const hcodes *c, int32_t *k, int64_t *t, uint8_t *mag,
                           const uint8_t *p, size_t n);
int ndo__codec_hier_implied(const hcodes *c, int32_t *k, int64_t *t, uint8_t *mag);

/* Where hier's bits go (tests/bench/bench_codec.c -v): when set, every
 * frame encoded adds to it, per group (levels 1, 2, 4, 8 and coarser, the
 * top and stencil-less nodes), the nodes, those all 0, the values, those
 * 0, and the ideal bits (the model's probabilities) of the node flags,
 * the values' zero flags and the nonzero values' signs and magnitudes;
 * the levels' slope shares (3 bits each) and the range coder's bytes. */
typedef struct hier_stats {
	double nodes[5], zero_nodes[5], values[5], zeros[5];
	double node_bits[5], zero_bits[5], value_bits[5];
	double beta_bits, rc_bytes, frames;
} hier_stats;
extern hier_stats *ndo__codec_hier_stats;

/* Where hier's time goes (tests/bench/bench_codec.c -v 2; apart from the
 * bits, whose ideal costs take time themselves): when set, every frame
 * adds its ms (wall clock, one thread) per phase (encoder: 0 predict, 1 the slopes' costs, 2
 * choose and code, 5 setup; decoder: 3 predict, 4 decode, 6 setup) and
 * level (0: level 1, 1: level 2, 2: the coarser ones; setups: 2), and the
 * hier calls' whole times in codec.c (encode, decode). */
typedef struct hier_times {
	double ms[7][3], whole[2];
} hier_times;
extern hier_times *ndo__codec_hier_times;

/* the time in ms for hier_times' phases: the monotonic clock, which the
 * vDSO reads in ~20 ns (the thread's CPU clock is a system call, ~1 us,
 * and its ~300 calls a level-7 step added 0.5 ms) */
static inline double ndo__now_ms(void)
{
	struct timespec t;
	clock_gettime(CLOCK_MONOTONIC, &t);
	return 1e3 * (double)t.tv_sec + 1e-6 * (double)t.tv_nsec;
}

#endif
