/* codec_hier.c — the hierarchical coder (ndo/codec.h, "hier", which has
 * the definition and the payload): a tile's codes level by level, each new
 * node's residual against the butterfly of the coarser nodes (a
 * subdivision wavelet) combined with the time prediction, through an
 * adaptive binary range coder with contexts.
 *
 * Choices, by measurement (tests/bench/bench_codec, the thesis' scene, 5 s,
 * bits per node per update of the payload, level 6 / level 7; -v 1 shows
 * where the bits go):
 *   - codes and predictions 16 times finer than the bound's step q, the
 *     residuals in steps of q from the prediction itself, the sender free
 *     to pick any within the bound (the residual nearest 0): 4.21 → 4.00 /
 *     2.65 → 1.48 against codes on the q lattice (whose rounding of the
 *     prediction alone spends the whole bound); the nearest code with no
 *     such choice: 4.74 / 3.38;
 *   - the slope's share β per level (the sender's, from 0..4 quarters):
 *     against a fixed linear extrapolation 4.77 / 4.01, copying k1 5.06 /
 *     2.82 — the fine levels of level 7 want no slope, the coarse ones all
 *     of it; β up to 7 quarters, per component, or an acceleration term
 *     gained nothing;
 *   - contexts beyond the edge ends' magnitudes (the previous node's, the
 *     other components') gained under 0.3 %: the residuals are close to
 *     white; the zero flags' context with the earlier components' nonzero
 *     count 4.014 → 4.000 / 1.485 → 1.477, not worth a change of payload;
 *     keyframes cost level 6 0.23 bits (4.014 at every 32nd step, 3.783
 *     at every 1000th);
 *   - the encoder's pass over a level (predictions, then the cost of each
 *     β over every fourth value) keeps its predictions for the coding pass;
 *     the decoder predicts a level before reading it too, β known; both
 *     predict the finest two levels' row interiors in runs the compiler
 *     vectorizes (then predict_run_all(), now predict_compact(), with
 *     ndo__codec_hier_general the node by node reference): level 7 encode
 *     4.0 → 3.4 ms, decode 2.1 → 1.9 ms (CPU, load 3-9; docs/bench/net.md).
 *   - the encoder takes residual 0 without rounding when the prediction
 *     is within the bound, the decoder makes the slope only for a level
 *     with β > 0, the finest level stores no magnitudes or motion: level
 *     7 enc + dec 0.92 of before, the same payloads (docs/bench/net.md);
 *     a context of the node's last motion detail (|w|) gained 0.5 % at
 *     level 6 and lost 0.2 % at level 7, not kept.
 *   - codec.c makes no code of the LOSSY nodes (the β costs make their
 *     sampled ones from x), the decoder's runs predict only the nodes
 *     kept, at every level: level 7 enc + dec 0.92 of before, the same
 *     payloads (docs/bench/net.md, the fourth pass).
 *   - each pass its own function; predictions over the coarser lattice
 *     copied compact (predict_compact(): no values computed in vain, the
 *     tile's edges without the general stencil's checks); the decoder's
 *     predictions the codes themselves, so that a node whose residuals are
 *     all 0 costs its flag alone (P_DECODE_D): level 7 enc + dec 0.87 of
 *     c90eaed's, the same payloads (tests/bench/hier-speed c90eaed 3);
 *     with the β costs over the sampled values alone and without branches
 *     (collect_sampled()), int32 butterflies, the zero-residual nodes
 *     found before the coder (encode_zeros()), the decoder's flags in
 *     contexts kept (fc) and less around hier in codec.c: 0.67
 *     (hier-speed c90eaed 5; docs/bench/net.md, the fifth pass).
 *   - the decoder's codes of a run made in two loops (cpx_dec32(): the
 *     part without the node's own references vectorized, one addition a
 *     value in the strided loop), no slope copied at β = 0, and the
 *     encoder's zero nodes' flag contexts made in encode_zeros(): level 7
 *     enc + dec 0.935 of 9e552f7's, decode 0.886, the same payloads
 *     (hier-speed 9e552f7 7; docs/bench/net.md, the seventh pass).
 * No entropy coding library in Debian 12 fits (libaec is Rice coding for
 * sampled data): the range coder is LZMA's binary one, written here;
 * tests/unit/test_hier.c checks it against the ideal adaptive length, a
 * decoder given any bytes reads none past the end (it counts what it
 * lacks, and the frame is corrupt) and its loops are bounded. */
#include "codec_private.h"

#include <math.h>
#include <string.h>

hier_stats *ndo__codec_hier_stats;
hier_times *ndo__codec_hier_times;

/* stmt, its CPU time added to ndo__codec_hier_times' phase k, level
 * column c (0: level 1, 1: level 2, 2: the coarser levels and the setup) */
#define LCOL(s) ((s) == 1 ? 0 : (s) == 2 ? 1 : 2)
#define PHASE(k, c, stmt)                                                      \
	do {                                                                   \
		hier_times *ht_ = ndo__codec_hier_times;                       \
		const double t0_ = ht_ ? ndo__now_ms() : 0;                    \
		stmt;                                                          \
		if (ht_)                                                       \
			ht_->ms[k][c] += ndo__now_ms() - t0_;                  \
	} while (0)

/* the ideal cost of a bit under probability p (P(0) in 1/2048) */
static double pcost(uint16_t p, int bit) { return -log2((bit ? 2048.0 - p : (double)p) / 2048.0); }

/* ---- the range coder ------------------------------------------------------------ */
enum { RC_BITS = 11, RC_ONE = 1 << RC_BITS, RC_MOVE = 5 };
#define RC_TOP (1u << 24)

void ndo__rc_enc_init(rcenc *e, wbuf *b)
{
	*e = (rcenc){0, 0xffffffffu, 0, 1, b};
}

static inline void shift_low(rcenc *e)
{
	if ((uint32_t)e->low < 0xff000000u || (e->low >> 32) != 0) {
		const uint8_t carry = (uint8_t)(e->low >> 32);
		uint8_t t = e->cache;
		do {
			put_byte(e->b, (uint8_t)(t + carry));
			t = 0xff;
		} while (--e->pending);
		e->cache = (uint8_t)(e->low >> 24);
	}
	e->pending++;
	e->low = (e->low & 0x00ffffffu) << 8;
}

static inline void rc_bit(rcenc *e, uint16_t *p, int bit)
{
	const uint32_t bound = (e->range >> RC_BITS) * *p;
	if (!bit) {
		e->range = bound;
		*p = (uint16_t)(*p + ((RC_ONE - *p) >> RC_MOVE));
	} else {
		e->low += bound;
		e->range -= bound;
		*p = (uint16_t)(*p - (*p >> RC_MOVE));
	}
	while (e->range < RC_TOP) {
		e->range <<= 8;
		shift_low(e);
	}
}

static inline void rc_direct(rcenc *e, int bit)
{
	e->range >>= 1;
	if (bit)
		e->low += e->range;
	while (e->range < RC_TOP) {
		e->range <<= 8;
		shift_low(e);
	}
}

void ndo__rc_enc_bit(rcenc *e, uint16_t *p, int bit) { rc_bit(e, p, bit); }
void ndo__rc_enc_direct(rcenc *e, int bit) { rc_direct(e, bit); }

void ndo__rc_enc_flush(rcenc *e)
{
	for (int k = 0; k < 5; k++)
		shift_low(e);
}

static inline uint8_t rc_byte(rcdec *d)
{
	if (d->pos < d->n)
		return d->p[d->pos++];
	d->over++;
	return 0;
}

void ndo__rc_dec_init(rcdec *d, const uint8_t *p, size_t n)
{
	*d = (rcdec){p, n, 0, 0, 0xffffffffu, 0};
	if (rc_byte(d) != 0) /* the encoder's first byte is always 0 */
		d->over++;
	for (int k = 0; k < 4; k++)
		d->code = d->code << 8 | rc_byte(d);
}

static inline int rd_bit(rcdec *d, uint16_t *p)
{
	const uint32_t bound = (d->range >> RC_BITS) * *p;
	int bit;
	if (d->code < bound) {
		d->range = bound;
		*p = (uint16_t)(*p + ((RC_ONE - *p) >> RC_MOVE));
		bit = 0;
	} else {
		d->code -= bound;
		d->range -= bound;
		*p = (uint16_t)(*p - (*p >> RC_MOVE));
		bit = 1;
	}
	if (d->range < RC_TOP) { /* once is enough: range ≥ 2^24 >> 11 × 31 ≥ 2^16 */
		d->range <<= 8;
		d->code = d->code << 8 | rc_byte(d);
		if (d->range < RC_TOP) {
			d->range <<= 8;
			d->code = d->code << 8 | rc_byte(d);
		}
	}
	return bit;
}

static inline int rd_direct(rcdec *d)
{
	d->range >>= 1;
	int bit = d->code >= d->range;
	if (bit)
		d->code -= d->range;
	if (d->range < RC_TOP) {
		d->range <<= 8;
		d->code = d->code << 8 | rc_byte(d);
	}
	return bit;
}

int ndo__rc_dec_bit(rcdec *d, uint16_t *p) { return rd_bit(d, p); }
int ndo__rc_dec_direct(rcdec *d) { return rd_direct(d); }

/* ---- the model ------------------------------------------------------------------ */
enum { H_GROUPS = 5, H_TOP = 4, H_NB = 3, H_EXP = 40 };

typedef struct hmodel {
	uint16_t node[H_GROUPS][H_NB];  /* every residual of the node 0 */
	uint16_t zero[H_GROUPS][3][H_NB];
	uint16_t sign[H_GROUPS][3];
	uint16_t ex[H_GROUPS][H_NB][H_EXP];
} hmodel;

static void model_init(hmodel *m)
{
	uint16_t *p = (uint16_t *)m;
	for (size_t k = 0; k < sizeof *m / sizeof *p; k++)
		p[k] = RC_ONE / 2;
}

/* the neighbours' context: the sum of the edge ends' magnitudes */
static inline int nb_of(unsigned t) { return t == 0 ? 0 : t <= 2 ? 1 : 2; }

/* a nonzero residual's sign and magnitude */
static inline void put_nz(rcenc *e, hmodel *m, int g, int d, int nb, int64_t r)
{
	rc_bit(e, &m->sign[g][d], r < 0);
	const uint64_t a = r < 0 ? -(uint64_t)r : (uint64_t)r;
	const int k = 63 - __builtin_clzll(a);
	for (int i = 0; i < k; i++)
		rc_bit(e, &m->ex[g][nb][i], 1);
	rc_bit(e, &m->ex[g][nb][k], 0); /* k < H_EXP: |r| < 2^36 (P's bound) */
	for (int i = k - 1; i >= 0; i--)
		rc_direct(e, (int)(a >> i) & 1);
}

/* put_nz()'s ideal cost, in the model's state before it */
static double nz_cost(const hmodel *m, int g, int d, int nb, int64_t r)
{
	const uint64_t a = r < 0 ? -(uint64_t)r : (uint64_t)r;
	const int k = 63 - __builtin_clzll(a);
	double c = pcost(m->sign[g][d], r < 0) + k + pcost(m->ex[g][nb][k], 0);
	for (int i = 0; i < k; i++)
		c += pcost(m->ex[g][nb][i], 1);
	return c;
}

/* −1 and *bad: an exponent past H_EXP − 1 */
static inline int64_t get_nz(rcdec *dc, hmodel *m, int g, int d, int nb, int *bad)
{
	const int neg = rd_bit(dc, &m->sign[g][d]);
	int k = 0;
	while (k < H_EXP - 1 && rd_bit(dc, &m->ex[g][nb][k]))
		k++;
	if (k == H_EXP - 1) {
		*bad = 1;
		return 0;
	}
	uint64_t a = 1;
	for (int i = 0; i < k; i++)
		a = a << 1 | (uint64_t)rd_direct(dc);
	return neg ? -(int64_t)a : (int64_t)a;
}

/* ---- prediction ----------------------------------------------------------------- */
/* The stencils in units of the coarser level's spacing 2s, from a base
 * node: ends, wings, far (lib/grid/subdivide.c). */
static const signed char stencil[3][8][2] = {
	{{0, 0}, {1, 0}, {0, 1}, {1, -1}, {-1, 1}, {1, 1}, {0, -1}, {2, -1}},  /* horizontal */
	{{0, 0}, {0, 1}, {1, 0}, {-1, 1}, {1, -1}, {1, 1}, {-1, 0}, {-1, 2}},  /* vertical */
	{{1, 0}, {0, 1}, {0, 0}, {1, 1}, {1, -1}, {-1, 1}, {2, 0}, {0, 2}},    /* diagonal */
};

enum { BETA_MAX = 4, BETA_IMPLIED = 4 }; /* the slope's share, in quarters */

typedef struct hier {
	int rows, cols, top, allheld, alllossy, intra;
	const uint8_t *cls;
	int32_t *k;           /* this frame's codes, 3 a node */
	const int32_t *k1;    /* the reference's codes (a keyframe: zeros) */
	int32_t *v, *dk;      /* the slope (0 without), k − k1 of the nodes coded so far */
	int64_t *pb, *pw;     /* a level's 16 P(β = 0) and 16 × its slope part (the
	                         decoder's pb, β known: the prediction itself) */
	uint8_t *ctx;         /* a level's contexts, 3 a node (4 g + nb) */
	uint8_t *mag;         /* |residual| (saturated), 3 a node */
	const double *x;      /* encoder: the positions, 3 a node */
	const quant *z;
	double iq[3];         /* encoder: 1 / q (the bound has a margin of 1e-9) */
	double m2, w2[3], R[3], r[3]; /* encoder: the bound squared; per axis q², its
	                                 ball's and inscribed box's half-widths in codes */
	int rel[3][8];        /* a level's stencils: node offsets from the node */
	const int32_t *s1, *s2; /* the slope's references, until v is made (slope_fill()) */
	int32_t *dc, *vc;     /* predict_compact(): dk and v on the coarser lattice, */
	uint8_t *mc;          /* and mag; */
	uint8_t *fc;          /* and the decoder's node flag contexts (g H_NB + nn), a node */
	int64_t g0, g1;       /* their steps' gaps: this frame's from s1, s1's from s2 */
	hmodel m;
} hier;

/* The encoder's choice of node n's residuals r (steps of q, HIER_FINE
 * codes) given its predictions p: its codes p + HIER_FINE r, within the
 * error bound (the nearest residuals' distance at least).  Each residual
 * the one nearest 0 within the bound's box on its axis; when those three
 * are too far, each within the box inscribed in the bound's ball (always
 * near enough), then axis by axis back to the first choice while they
 * stay near enough.  −1: a code out of range. */
static inline __attribute__((always_inline)) int choose(hier *h, size_t n, const int64_t p[3],
                                                      int64_t r[3])
{
	const double F = HIER_FINE;
	double t[3], u[3], lim = 0;
	int64_t rn[3], a[3], b[3];
	for (int d = 0; d < 3; d++) {
		t[d] = (h->x[3 * n + d] - h->z->lo[d]) * h->iq[d];
		u[d] = t[d] - (double)p[d]; /* in codes, from the prediction */
		lim += u[d] * u[d] * h->w2[d];
	}
	if (lim <= h->m2) { /* the prediction within the bound: 0, as below (its ea) */
		for (int d = 0; d < 3; d++) {
			if (p[d] <= -CODE_MAX || p[d] >= CODE_MAX)
				return -1;
			h->k[3 * n + d] = (int32_t)p[d];
			r[d] = 0;
		}
		return 0;
	}
	lim = 0;
	for (int d = 0; d < 3; d++) {
		rn[d] = (int64_t)floor(u[d] / F + 0.5);
		const double e = u[d] - F * (double)rn[d];
		lim += e * e * h->w2[d];
	}
	if (rn[0] | rn[1] | rn[2]) {
		double R[3], rr[3];
		for (int d = 0; d < 3; d++) { /* h->r: the bound's R / √3, made once */
			R[d] = lim > h->m2 ? sqrt(lim / h->w2[d]) : h->R[d];
			rr[d] = lim > h->m2 ? R[d] / sqrt(3.0) : h->r[d];
		}
		lim = lim > h->m2 ? lim : h->m2;
		double ea = 0, eb = 0;
		for (int d = 0; d < 3; d++) {
			int64_t lo = (int64_t)ceil((u[d] - R[d]) / F), hi = (int64_t)floor((u[d] + R[d]) / F);
			lo = lo > rn[d] ? rn[d] : lo, hi = hi < rn[d] ? rn[d] : hi;
			a[d] = 0 < lo ? lo : 0 > hi ? hi : 0;
			ea += (u[d] - F * (double)a[d]) * (u[d] - F * (double)a[d]) * h->w2[d];
			lo = (int64_t)ceil((u[d] - rr[d]) / F), hi = (int64_t)floor((u[d] + rr[d]) / F);
			lo = lo > rn[d] ? rn[d] : lo, hi = hi < rn[d] ? rn[d] : hi;
			b[d] = 0 < lo ? lo : 0 > hi ? hi : 0;
			eb += (u[d] - F * (double)b[d]) * (u[d] - F * (double)b[d]) * h->w2[d];
		}
		if (ea > lim) {
			if (!(eb <= lim)) /* cannot be: the inscribed box's corner is on the ball */
				b[0] = rn[0], b[1] = rn[1], b[2] = rn[2];
			else
				for (int d = 0; d < 3; d++) {
					const double e2 = eb -
					                  (u[d] - F * (double)b[d]) * (u[d] - F * (double)b[d]) * h->w2[d] +
					                  (u[d] - F * (double)a[d]) * (u[d] - F * (double)a[d]) * h->w2[d];
					if (e2 <= lim)
						b[d] = a[d], eb = e2;
				}
			a[0] = b[0], a[1] = b[1], a[2] = b[2];
		}
		rn[0] = a[0], rn[1] = a[1], rn[2] = a[2];
	}
	for (int d = 0; d < 3; d++) {
		const int64_t k = p[d] + HIER_FINE * rn[d];
		if (k <= -CODE_MAX || k >= CODE_MAX)
			return -1;
		h->k[3 * n + d] = (int32_t)k;
		r[d] = rn[d];
	}
	return 0;
}

/* Set by tests: every node through the general stencil (bounds and
 * classes checked), one by one, the interior's and the runs' reference. */
int ndo__codec_hier_general;

/* Node n = (i, j), of type `type` (0 horizontal, 1 vertical, 2 diagonal)
 * in level s (0: the top): 16 × its prediction with no slope (base: 16 k1
 * + the butterfly of the coarser nodes' k − k1) and 16 × the slope's
 * detail (w: 16 v − the butterfly of their v), per component, and its
 * context per component (4 × the group g + nb).  Returns the stencil
 * nodes used: 8, 2 (the ends' mean), 1 (the one end held) or 0. */
static inline __attribute__((always_inline)) int
pred16(const hier *h, int i, int j, int s, int type, const int slope, int64_t base[3], int64_t w[3],
       int ctx[3])
{
	const long n = (long)j * h->cols + i;
	const int32_t *K1 = h->k1 + 3 * n, *V = h->v + 3 * n, *D = h->dk, *VV = h->v;
	if (!s) {
		for (int d = 0; d < 3; d++)
			base[d] = 16 * (int64_t)K1[d], w[d] = slope ? 16 * (int64_t)V[d] : 0, ctx[d] = 4 * H_TOP;
		return 0;
	}
	const int g = (s == 1 ? 0 : s == 2 ? 1 : s == 4 ? 2 : 3) * 4;
	const int bi = type != 1 ? i - s : i, bj = type != 0 ? j - s : j, st = 2 * s;
	long o[8];
	int held = 0;
	if (h->allheld && bi >= st && bi + 2 * st < h->cols && bj >= st && bj + 2 * st < h->rows &&
	    !ndo__codec_hier_general) {
		for (int q = 0; q < 8; q++)
			o[q] = 3 * (n + h->rel[type][q]);
		const uint8_t *ma = h->mag + o[0], *mb = h->mag + o[1];
		for (int d = 0; d < 3; d++) {
			base[d] = 16 * (int64_t)K1[d] +
			          8 * ((int64_t)D[o[0] + d] + D[o[1] + d]) +
			          2 * ((int64_t)D[o[2] + d] + D[o[3] + d]) -
			          ((int64_t)D[o[4] + d] + D[o[5] + d] + D[o[6] + d] + D[o[7] + d]);
			w[d] = !slope ? 0
			       : 16 * (int64_t)V[d] - 8 * ((int64_t)VV[o[0] + d] + VV[o[1] + d]) -
			             2 * ((int64_t)VV[o[2] + d] + VV[o[3] + d]) +
			             ((int64_t)VV[o[4] + d] + VV[o[5] + d] + VV[o[6] + d] + VV[o[7] + d]);
			ctx[d] = g + nb_of((unsigned)ma[d] + mb[d]);
		}
		return 8;
	}
	for (int q = 0; q < 8; q++) {
		const int ii = bi + stencil[type][q][0] * st, jj = bj + stencil[type][q][1] * st;
		o[q] = ii >= 0 && ii < h->cols && jj >= 0 && jj < h->rows &&
		               h->cls[(size_t)jj * (size_t)h->cols + (size_t)ii] != NDO_NODE_SKIP
		           ? 3 * ((long)jj * h->cols + ii)
		           : -1;
		held += o[q] >= 0;
	}
	if (held == 8) {
		for (int d = 0; d < 3; d++) {
			base[d] = 16 * (int64_t)K1[d];
			w[d] = slope ? 16 * (int64_t)V[d] : 0;
			for (int q = 0; q < 8; q++) {
				const int wq = q < 2 ? 8 : q < 4 ? 2 : -1;
				base[d] += wq * (int64_t)D[o[q] + d];
				w[d] -= slope ? wq * (int64_t)VV[o[q] + d] : 0;
			}
			ctx[d] = g + nb_of((unsigned)h->mag[o[0] + d] + h->mag[o[1] + d]);
		}
		return 8;
	}
	if (o[0] >= 0 && o[1] >= 0) {
		for (int d = 0; d < 3; d++) {
			base[d] = 16 * (int64_t)K1[d] + 8 * ((int64_t)D[o[0] + d] + D[o[1] + d]);
			w[d] = slope ? 16 * (int64_t)V[d] - 8 * ((int64_t)VV[o[0] + d] + VV[o[1] + d]) : 0;
			ctx[d] = g + nb_of((unsigned)h->mag[o[0] + d] + h->mag[o[1] + d]);
		}
		return 2;
	}
	const long e = o[0] >= 0 ? o[0] : o[1];
	for (int d = 0; d < 3; d++) {
		base[d] = 16 * (int64_t)K1[d] + (e >= 0 ? 16 * (int64_t)D[e + d] : 0);
		w[d] = slope ? 16 * (int64_t)V[d] - (e >= 0 ? 16 * (int64_t)VV[e + d] : 0) : 0;
		ctx[d] = e >= 0 ? g + nb_of(h->mag[e + d]) : 4 * H_TOP;
	}
	return e >= 0;
}

/* the prediction: (4 base + β w) / 64, rounded half up */
static inline int64_t pred_of(int64_t base, int64_t w, int beta)
{
	return (4 * base + beta * w + 32) >> 6; /* an arithmetic shift (GCC, Clang) */
}

enum { P_PREDICT, P_COLLECT, P_ENCODE, P_ENCODE1, P_DECODE, P_DECODE_D, P_DECODE_NZ, P_IMPLIED };

typedef struct pass {
	int beta[3];          /* this level's slope shares (one for now: all equal) */
	int slope;            /* P_PREDICT: the slope's detail wanted */
	int fused;            /* P_PREDICT: pb the prediction itself (β known: the decoder) */
	int direct;           /* P_PREDICT, fused: the prediction made the code itself (k,
	                         and the level's mag 0 and dk), for P_DECODE_D */
	int oor;              /* P_PREDICT, direct: a prediction out of the codes' range */
	int64_t last[3];      /* a keyframe's top level: the last node's codes */
	uint64_t cost[BETA_MAX + 1];
	uint64_t any, sample;
	int bad;
	rcenc *e;
	rcdec *dc;
} pass;

/* One node of a level, in pass `mode`: P_PREDICT its predictions and
 * contexts kept (pb, pw, ctx), P_COLLECT the cost of each β from them,
 * P_ENCODE the codes chosen and their residuals from them, P_ENCODE1
 * both at once (a keyframe), P_DECODE the residuals read and the codes
 * made (a keyframe: predicting as it goes, else from the kept
 * predictions), P_DECODE_D the same from the codes P_PREDICT made the
 * predictions (ps->direct: a node whose residuals are all 0, most of the
 * fine ones, needs only its flag read), P_IMPLIED the codes the
 * predictions. */
static inline __attribute__((always_inline)) void node(hier *h, const int mode, pass *ps, int i,
                                                       int j, int s, int type)
{
	const size_t n = (size_t)j * (size_t)h->cols + (size_t)i;
	if (h->cls[n] != NDO_NODE_LOSSY)
		return;
	int64_t base[3], w[3], pp[3];
	int ctx[3], used = 1;
	if (mode == P_PREDICT) {
		pred16(h, i, j, s, type, ps->slope, base, w, ctx);
		if (ps->direct) {
			for (int d = 0; d < 3; d++) {
				const size_t v = 3 * n + (size_t)d;
				const int64_t k = pred_of(base[d], w[d], ps->beta[d]);
				ps->oor |= k <= -CODE_MAX || k >= CODE_MAX;
				h->k[v] = (int32_t)k, h->ctx[v] = (uint8_t)ctx[d];
				if (s != 1)
					h->mag[v] = 0, h->dk[v] = (int32_t)(k - h->k1[v]);
			}
			return;
		}
		for (int d = 0; d < 3; d++)
			h->pb[3 * n + d] = ps->fused ? pred_of(base[d], w[d], ps->beta[d]) : base[d],
			h->pw[3 * n + d] = w[d], h->ctx[3 * n + d] = (uint8_t)ctx[d];
		return;
	}
	if (mode == P_DECODE_D || mode == P_DECODE_NZ) { /* the codes made; the residuals from 0
	                                                    (P_DECODE_NZ: the node's flag read, 1) */
		const int g = h->ctx[3 * n] >> 2;
		const int nbs = (h->ctx[3 * n] & 3) + (h->ctx[3 * n + 1] & 3) + (h->ctx[3 * n + 2] & 3);
		if (mode == P_DECODE_D && !rd_bit(ps->dc, &h->m.node[g][nbs == 0 ? 0 : nbs <= 2 ? 1 : 2]))
			return;
		int64_t res[3] = {0, 0, 0};
		for (int d = 0; d < 3; d++) {
			const int nb = h->ctx[3 * n + d] & 3;
			if ((d == 2 && !(res[0] | res[1])) || rd_bit(ps->dc, &h->m.zero[g][d][nb]))
				res[d] = get_nz(ps->dc, &h->m, g, d, nb, &ps->bad);
		}
		for (int d = 0; d < 3; d++) {
			const size_t v = 3 * n + (size_t)d;
			const int64_t r = res[d], k = h->k[v] + HIER_FINE * r;
			if (k <= -CODE_MAX || k >= CODE_MAX) {
				ps->bad = 1;
				return;
			}
			h->k[v] = (int32_t)k;
			if (s == 1)
				continue;
			const uint64_t a = r < 0 ? -(uint64_t)r : (uint64_t)r;
			h->mag[v] = (uint8_t)(a > 255 ? 255 : a);
			h->dk[v] = h->k[v] - h->k1[v];
		}
		return;
	}
	if (mode == P_DECODE && !h->intra) {
		for (int d = 0; d < 3; d++)
			pp[d] = h->pb[3 * n + d], ctx[d] = h->ctx[3 * n + d];
	} else if (mode == P_ENCODE || mode == P_COLLECT) {
		for (int d = 0; d < 3; d++)
			base[d] = h->pb[3 * n + d], w[d] = h->pw[3 * n + d], ctx[d] = h->ctx[3 * n + d];
	} else {
		used = pred16(h, i, j, s, type, ps->beta[0] != 0, base, w, ctx);
	}
	if (mode == P_COLLECT) {
		for (int d = 0; d < 3; d++) {
			if (ps->sample++ & 3) /* the costs of every fourth value */
				continue;
			/* the nearest code (codec.c's code_of(), which skips the
			 * nodes hier codes; the range checked there) */
			const double t = (h->x[3 * n + d] - h->z->lo[d]) / h->z->q[d] + 0.5;
			int64_t kq = (int64_t)t;
			kq -= (double)kq > t;
			for (int b = 0; b <= BETA_MAX; b++) {
				const int64_t e = kq - pred_of(base[d], w[d], b);
				const uint64_t a = ((e < 0 ? -(uint64_t)e : (uint64_t)e) + HIER_FINE / 2) / HIER_FINE;
				ps->cost[b] += a ? 2 + 2 * (uint64_t)(64 - __builtin_clzll(a)) : 0;
			}
		}
		return;
	}
	const int dpcm = h->intra && !used; /* a keyframe's node without a stencil */
	for (int d = 0; d < 3 && !(mode == P_DECODE && !h->intra); d++)
		pp[d] = dpcm ? ps->last[d] : pred_of(base[d], w[d], ps->beta[d]);
	int64_t res[3] = {0, 0, 0};
	if ((mode == P_ENCODE || mode == P_ENCODE1) && choose(h, n, pp, res)) {
		ps->bad = 1;
		return;
	}
	/* the node's flag (context: the group, the ends' magnitudes over the
	 * components), then each component's (the last implied when the others
	 * are 0), then each nonzero one's sign and magnitude */
	const int g = ctx[0] >> 2;
	const int nbs = (ctx[0] & 3) + (ctx[1] & 3) + (ctx[2] & 3), nn = nbs == 0 ? 0 : nbs <= 2 ? 1 : 2;
	if (mode == P_ENCODE || mode == P_ENCODE1) {
		const int nz = (res[0] | res[1] | res[2]) != 0;
		hier_stats *st = ndo__codec_hier_stats;
		if (st) {
			st->nodes[g]++, st->zero_nodes[g] += !nz, st->values[g] += 3;
			st->node_bits[g] += pcost(h->m.node[g][nn], nz);
			st->zeros[g] += (res[0] == 0) + (res[1] == 0) + (res[2] == 0);
		}
		rc_bit(ps->e, &h->m.node[g][nn], nz);
		if (nz) {
			for (int d = 0; d < 3; d++) {
				const int nb = ctx[d] & 3;
				if (d < 2 || res[0] | res[1]) {
					if (st)
						st->zero_bits[g] += pcost(h->m.zero[g][d][nb], res[d] != 0);
					rc_bit(ps->e, &h->m.zero[g][d][nb], res[d] != 0);
				}
				if (res[d]) {
					if (st)
						st->value_bits[g] += nz_cost(&h->m, g, d, nb, res[d]);
					put_nz(ps->e, &h->m, g, d, nb, res[d]);
				}
			}
			ps->any = 1;
		}
	} else if (mode == P_DECODE && rd_bit(ps->dc, &h->m.node[g][nn])) {
		for (int d = 0; d < 3; d++)
			if ((d == 2 && !(res[0] | res[1])) || rd_bit(ps->dc, &h->m.zero[g][d][ctx[d] & 3]))
				res[d] = get_nz(ps->dc, &h->m, g, d, ctx[d] & 3, &ps->bad);
	}
	for (int d = 0; d < 3; d++) {
		const size_t v = 3 * n + (size_t)d;
		const int64_t r = res[d];
		if (mode != P_ENCODE && mode != P_ENCODE1) {
			const int64_t k = pp[d] + HIER_FINE * r;
			if (k <= -CODE_MAX || k >= CODE_MAX) {
				ps->bad = 1;
				return;
			}
			h->k[v] = (int32_t)k;
		}
		ps->last[d] = dpcm ? h->k[v] : ps->last[d];
		if (s == 1) /* the finest level: no level reads its magnitudes or motion */
			continue;
		const uint64_t a = r < 0 ? -(uint64_t)r : (uint64_t)r;
		h->mag[v] = (uint8_t)(a > 255 ? 255 : a);
		h->dk[v] = h->k[v] - h->k1[v];
	}
}

/* Every node of level s (0: the top) in raster order, in pass `mode`. */
static inline __attribute__((always_inline)) void level(hier *h, const int mode, pass *ps, int s)
{
	if (!s) {
		for (int j = 0; j < h->rows && !ps->bad; j += h->top)
			for (int i = 0; i < h->cols; i += h->top)
				node(h, mode, ps, i, j, 0, 0);
		return;
	}
	for (int j = 0; j < h->rows && !ps->bad; j += s) {
		if (!(j & s)) /* an even row of the level: horizontal edges */
			for (int i = s; i < h->cols; i += 2 * s)
				node(h, mode, ps, i, j, s, 0);
		else
			for (int i = 0; i < h->cols; i += s)
				node(h, mode, ps, i, j, s, i & s ? 2 : 1);
	}
}

/* The passes, each its own function: levels() with every pass inlined
 * was one function of ~160 kB of code, its passes' loops sharing its
 * registers and its stack; apart (with LOCAL_CODER below), level 7 enc +
 * dec 0.99 of before (tests/bench/hier-speed c90eaed 3, load 3.5), and
 * a change to one pass no longer moves the others' code (one that added a
 * pass to the decoder slowed the encoder 13 %). */
NDO_HOT __attribute__((noinline)) static void level_predict(hier *h, pass *ps, int s)
{
	level(h, P_PREDICT, ps, s);
}
/* predict_compact()'s runs and collect_sampled()'s: their values on the stack */
enum { RUN_NODES = 128 };

/* The coding passes run on local copies of the pass and of the range
 * coder's state: through ps->e or ps->dc, the coder's range and code
 * (uint32_t) might be the target of any store of a code (int32_t), and
 * the compiler read them from memory again after each; local, whose
 * address no store can hold, they stay in registers. */
#define LOCAL_CODER(ps, f, stmt)                                                       \
	do {                                                                           \
		pass p_ = *(ps);                                                       \
		__typeof__(*p_.f) c_ = *p_.f;                                          \
		p_.f = &c_;                                                            \
		stmt;                                                                  \
		p_.f = (ps)->f;                                                        \
		*p_.f = c_;                                                            \
		*(ps) = p_;                                                            \
	} while (0)
NDO_HOT __attribute__((noinline)) static void level_collect(hier *h, pass *ps, int s)
{
	pass p = *ps;
	level(h, P_COLLECT, &p, s);
	*ps = p;
}

/* P_COLLECT over level s ≥ 1 of a tile whose every node is LOSSY
 * (h->alllossy): every value of the level counts in ps->sample, so the
 * sampled ones (every fourth) are known without visiting the others;
 * node() P_COLLECT's costs of those alone, without branches. */
NDO_HOT __attribute__((noinline)) static void collect_sampled(hier *h, pass *ps, int s)
{
	const int C = h->cols, R = h->rows;
	const int64_t *const pb = h->pb, *const pw = h->pw;
	const double *const x = h->x, *const lo = h->z->lo, *const q = h->z->q;
	uint64_t smp = ps->sample, cost[BETA_MAX + 1];
	memcpy(cost, ps->cost, sizeof cost);
	for (int j = 0; j < R; j += s) {
		/* the row's nodes: an even row of the level horizontal edges, from
		 * i = s every 2s; an odd one every s (level()) */
		const int i0 = j & s ? 0 : s, di = j & s ? s : 2 * s;
		const int cnt = i0 < C ? (C - 1 - i0) / di + 1 : 0;
		/* the row's sampled values (smp counts the values before it): their
		 * index and nearest code, then their costs (apart, the divisions'
		 * latency overlaps; in one loop each waited for its own) */
		for (int v = (int)((4 - (smp & 3)) & 3), nq = v / 3, d = v % 3; v < 3 * cnt;) {
			size_t su[RUN_NODES];
			int64_t sk[RUN_NODES];
			int nv = 0;
			for (; v < 3 * cnt && nv < RUN_NODES; v += 4) {
				const size_t u = 3 * ((size_t)j * (size_t)C + (size_t)i0 + (size_t)nq * (size_t)di) +
				                 (size_t)d;
				const double t = (x[u] - lo[d]) / q[d] + 0.5;
				int64_t kq = (int64_t)t;
				kq -= (double)kq > t;
				su[nv] = u, sk[nv++] = kq;
				/* 4 values on: the next node, and the next component */
				nq++, d++;
				if (d == 3)
					nq++, d = 0;
			}
			for (int k = 0; k < nv; k++) {
				/* node()'s cost without branches, which GCC makes of a ?: or
				 * a product by a != 0 (|e| and a = 0 are data: mispredicted,
				 * they cost more than the rest): for a ≥ 1 clz(a | 1) = clz(a),
				 * for a = 0 the −4 (a − 1 wraps) cancels 2 + 2 × 1 */
				const int64_t y = 4 * pb[su[k]] + 32, w = pw[su[k]], kq = sk[k];
				for (int b = 0; b <= BETA_MAX; b++) {
					const int64_t e = kq - ((y + b * w) >> 6); /* pred_of() */
					const uint64_t sg = (uint64_t)(e >> 63), ae = ((uint64_t)e ^ sg) - sg;
					const uint64_t a = (ae + HIER_FINE / 2) / HIER_FINE;
					cost[b] += 2 + 2 * (uint64_t)(64 - __builtin_clzll(a | 1)) - 4 * ((a - 1) >> 63);
				}
			}
		}
		smp += 3 * (uint64_t)cnt;
	}
	ps->sample = smp;
	memcpy(ps->cost, cost, sizeof cost);
}
NDO_HOT __attribute__((noinline)) static void level_encode(hier *h, pass *ps, int s)
{
	LOCAL_CODER(ps, e, level(h, P_ENCODE, &p_, s));
}

/* P_ENCODE over level s ≥ 1 of a tile whose every node is LOSSY, in two
 * loops: first each node's predictions and choose()'s first test (the
 * prediction within the bound: residuals 0), its codes (and above level 1
 * mag 0 and dk) made, a flag kept (zf, a byte a node: 0, or 1 + the
 * context of node()'s flag, made here off the coder's chain); then in raster
 * order a flagged node's flag bit alone, the others through node().  The
 * first loop has no branch on the data and no coder: the floating point
 * of one node overlaps the next's. */
NDO_HOT __attribute__((noinline)) static void encode_zeros(hier *h, const pass *ps, int s,
                                                          uint8_t *zf)
{
	const int C = h->cols, R = h->rows, beta = ps->beta[0], fine = s == 1;
	const int64_t *const pb = h->pb, *const pw = h->pw;
	const double *const x = h->x, *const lo = h->z->lo, *const iq = h->iq, *const w2 = h->w2;
	const double m2 = h->m2;
	const int32_t *const K1 = h->k1;
	int32_t *const kk = h->k, *const dk = h->dk;
	uint8_t *const mag = h->mag;
	const uint8_t *const ctx = h->ctx;
	for (int j = 0; j < R; j += s) {
		const int i0 = j & s ? 0 : s, di = j & s ? s : 2 * s;
		for (int i = i0; i < C; i += di) {
			const size_t n = (size_t)j * (size_t)C + (size_t)i;
			int64_t p[3];
			double lim = 0;
			unsigned in = 1;
			for (int d = 0; d < 3; d++) { /* as choose() */
				const size_t u = 3 * n + (size_t)d;
				p[d] = pred_of(pb[u], pw[u], beta);
				const double t = (x[u] - lo[d]) * iq[d], e = t - (double)p[d];
				lim += e * e * w2[d];
				in &= p[d] > -CODE_MAX && p[d] < CODE_MAX;
			}
			const int z = (lim <= m2) & in;
			/* encode_flagged()'s context of the flag (node()'s) */
			const uint8_t *const cx = ctx + 3 * n;
			const int nbs = (cx[0] & 3) + (cx[1] & 3) + (cx[2] & 3);
			zf[n] = (uint8_t)(z * (1 + (cx[0] >> 2) * H_NB + (nbs > 0) + (nbs > 2)));
			if (!z)
				continue;
			for (int d = 0; d < 3; d++) {
				const size_t u = 3 * n + (size_t)d;
				kk[u] = (int32_t)p[d];
				if (!fine)
					mag[u] = 0, dk[u] = (int32_t)(p[d] - K1[u]);
			}
		}
	}
}

static inline __attribute__((always_inline)) void encode_flagged(hier *h, pass *ps, int s,
                                                                 const uint8_t *zf)
{
	const int C = h->cols, R = h->rows;
	uint16_t *const pn = &h->m.node[0][0]; /* zf: 1 + the flag's context */
	for (int j = 0; j < R && !ps->bad; j += s) {
		const int i0 = j & s ? 0 : s, di = j & s ? s : 2 * s;
		for (int i = i0; i < C; i += di) {
			const size_t n = (size_t)j * (size_t)C + (size_t)i;
			if (!zf[n]) {
				node(h, P_ENCODE, ps, i, j, s, !(j & s) ? 0 : i & s ? 2 : 1);
				continue;
			}
			rc_bit(ps->e, pn + (zf[n] - 1), 0); /* node()'s flag, 0 */
		}
	}
}

NDO_HOT __attribute__((noinline)) static void level_encode_zf(hier *h, pass *ps, int s)
{
	uint8_t *const zf = h->mc; /* predict_compact()'s, free until the next level */
	encode_zeros(h, ps, s, zf);
	LOCAL_CODER(ps, e, encode_flagged(h, &p_, s, zf));
}
NDO_HOT __attribute__((noinline)) static void level_decode(hier *h, pass *ps, int s)
{
	LOCAL_CODER(ps, dc, level(h, P_DECODE, &p_, s));
}
NDO_HOT __attribute__((noinline)) static void level_decode_direct(hier *h, pass *ps, int s)
{
	LOCAL_CODER(ps, dc, level(h, P_DECODE_D, &p_, s));
}

/* P_DECODE_D over level s ≥ 1 of a tile whose every node is LOSSY and
 * whose predictions predict_compact() made: a node's flag read in the
 * context it kept (fc), node() only for a node with a nonzero residual. */
static inline __attribute__((always_inline)) void decode_flagged(hier *h, pass *ps, int s)
{
	const int C = h->cols, R = h->rows;
	const uint8_t *const fc = h->fc;
	uint16_t *const pn = &h->m.node[0][0];
	for (int j = 0; j < R && !ps->bad; j += s) {
		const int i0 = j & s ? 0 : s, di = j & s ? s : 2 * s;
		for (int i = i0; i < C && !ps->bad; i += di) {
			const size_t n = (size_t)j * (size_t)C + (size_t)i;
			if (rd_bit(ps->dc, pn + fc[n]))
				node(h, P_DECODE_NZ, ps, i, j, s, 0);
		}
	}
}
NDO_HOT __attribute__((noinline)) static void level_decode_fc(hier *h, pass *ps, int s)
{
	LOCAL_CODER(ps, dc, decode_flagged(h, &p_, s));
}

/* predict_compact()'s arrays and settings, in locals: through h, any
 * int32_t store might change them */
typedef struct cpx {
	int32_t *kk, *dk;
	uint8_t *cx, *mag, *fc;
	int64_t *pb, *pw;
	const int32_t *K1, *V;
	const uint8_t *cls;
	int slope, beta, direct, fine;
} cpx;

/* m nodes' values, `step` nodes apart from node n0, from their butterflies
 * (tb, tw: the stencils' parts of 16 × the prediction without slope and
 * of 16 × the slope's detail) and contexts (tc), where P_PREDICT keeps
 * them (node(), P_PREDICT); the butterflies int32_t when the stencils'
 * values are small enough (cpx_put32), else int64_t */
#define CPX_PUT(NAME, T)                                                               \
static inline __attribute__((always_inline)) void                                      \
NAME(const cpx *x, size_t n0, size_t step, int m, const T *tb, const T *tw,            \
     const uint8_t *tc, unsigned *oor)                                                 \
{                                                                                      \
	const int32_t *const K1 = x->K1, *const V = x->V;                                     \
	if (x->beta < 0) { /* the encoder's */                                                \
		int64_t *const pb = x->pb, *const pw = x->pw;                                        \
		uint8_t *const cx = x->cx;                                                           \
		for (int q = 0; q < m; q++)                                                          \
			for (int d = 0; d < 3; d++) {                                                       \
				const size_t u = 3 * (n0 + step * (size_t)q) + (size_t)d;                          \
				const int v = 3 * q + d;                                                           \
				pb[u] = 16 * (int64_t)K1[u] + tb[v];                                               \
				pw[u] = 16 * (int64_t)V[u] + tw[v];                                                \
				cx[u] = tc[v];                                                                     \
			}                                                                                   \
	} else if (!x->direct) {                                                              \
		int64_t *const pb = x->pb;                                                           \
		uint8_t *const cx = x->cx;                                                           \
		for (int q = 0; q < m; q++)                                                          \
			for (int d = 0; d < 3; d++) {                                                       \
				const size_t u = 3 * (n0 + step * (size_t)q) + (size_t)d;                          \
				const int v = 3 * q + d;                                                           \
				pb[u] = pred_of(16 * (int64_t)K1[u] + tb[v],                                       \
				                x->slope ? 16 * (int64_t)V[u] + tw[v] : 0, x->beta);               \
				cx[u] = tc[v];                                                                     \
			}                                                                                   \
	} else {                                                                              \
		int32_t *const kk = x->kk, *const dk = x->dk;                                        \
		uint8_t *const cx = x->cx, *const mag = x->mag, *const fc = x->fc;                   \
		const uint8_t *const cls = x->cls;                                                   \
		const int slope = x->slope, beta = x->beta, fine = x->fine;                          \
		unsigned out = 0;                                                                    \
		for (int q = 0; q < m; q++) {                                                        \
			const size_t n = n0 + step * (size_t)q;                                             \
			const int lossy = cls[n] == NDO_NODE_LOSSY;                                         \
			const int nbs = (tc[3 * q] & 3) + (tc[3 * q + 1] & 3) + (tc[3 * q + 2] & 3);         \
			fc[n] = (uint8_t)((tc[3 * q] >> 2) * H_NB + (nbs > 0) + (nbs > 2)); /* nb_of() */  \
			for (int d = 0; d < 3; d++) {                                                       \
				const size_t u = 3 * n + (size_t)d;                                                \
				const int v = 3 * q + d;                                                           \
				const int64_t k = pred_of(16 * (int64_t)K1[u] + tb[v],                             \
				                          slope ? 16 * (int64_t)V[u] + tw[v] : 0, beta);           \
				cx[u] = tc[v];                                                                     \
				if (!lossy) /* an EXACT node's code stays */                                       \
					continue;                                                                         \
				out |= k <= -CODE_MAX || k >= CODE_MAX;                                            \
				kk[u] = (int32_t)k;                                                                \
				if (!fine)                                                                         \
					mag[u] = 0, dk[u] = (int32_t)(k - K1[u]);                                         \
			}                                                                                   \
		}                                                                                    \
		*oor |= out;                                                                         \
	}                                                                                     \
}
CPX_PUT(cpx_put, int64_t)
CPX_PUT(cpx_put32, int32_t)

/* cpx_put32()'s decoder (x->direct) in a tile whose every node is LOSSY:
 * the same codes, with the part of each that does not depend on the node's
 * own references in a loop of its own over the run (vectorized), so that
 * the loop over the nodes, whose stores are 3 values every `step` nodes
 * (not vectorized), does one addition a value.  pred_of(16 K1 + tb,
 * 16 V + tw, β) = (64 K1 + 4 tb + β tw + 32 + 16 β V) >> 6 = K1 + ((4 tb +
 * β tw + 32 + 16 β V) >> 6) (64 K1 a multiple of 64, the shift a floor);
 * without the slope (β = 0 in the decoder) K1 + ((tb + 8) >> 4).  With
 * |tb|, |tw| ≤ 24 × 2^22 (predict_compact()'s `narrow`) 4 tb + β tw + 32
 * is within ±2^30: int32_t; the codes, K1 plus that (K1 any int32_t
 * in a hostile stream's reference, 16 β V up to 2^36), in int64_t. */
static inline __attribute__((always_inline)) void
cpx_dec32(const cpx *x, size_t n0, size_t step, int m, const int32_t *tb, const int32_t *tw,
          const uint8_t *tc, unsigned *oor, const int slope, const int fine)
{
	const int32_t *const K1 = x->K1, *const V = x->V;
	int32_t *const kk = x->kk, *const dk = x->dk;
	uint8_t *const cx = x->cx, *const mag = x->mag, *const fc = x->fc;
	const int beta = x->beta, nv = 3 * m;
	int32_t a[3 * RUN_NODES];
	if (!slope)
		for (int v = 0; v < nv; v++)
			a[v] = (tb[v] + 8) >> 4; /* an arithmetic shift (GCC, Clang) */
	else
		for (int v = 0; v < nv; v++)
			a[v] = 4 * tb[v] + beta * tw[v] + 32;
	unsigned out = 0;
	for (int q = 0; q < m; q++) {
		const size_t n = n0 + step * (size_t)q;
		const int nbs = (tc[3 * q] & 3) + (tc[3 * q + 1] & 3) + (tc[3 * q + 2] & 3);
		fc[n] = (uint8_t)((tc[3 * q] >> 2) * H_NB + (nbs > 0) + (nbs > 2)); /* nb_of() */
		for (int d = 0; d < 3; d++) {
			const size_t u = 3 * n + (size_t)d;
			const int v = 3 * q + d;
			/* in int64_t: a reference's code might be any int32_t */
			const int64_t k = !slope ? (int64_t)K1[u] + a[v]
			                         : K1[u] + (((int64_t)a[v] + 16 * (int64_t)beta * V[u]) >> 6);
			out |= (k <= -CODE_MAX) | (k >= CODE_MAX);
			cx[u] = tc[v];
			kk[u] = (int32_t)k;
			if (!fine)
				mag[u] = 0, dk[u] = (int32_t)(k - K1[u]);
		}
	}
	*oor |= out;
}

NDO_HOT __attribute__((noinline)) static void predict_compact(hier *h, pass *ps, int s)
{
	const int st = 2 * s, C = h->cols, R = h->rows;
	const int Cc = (C - 1) / st + 1, Rc = (R - 1) / st + 1;
	const int g = (s == 1 ? 0 : s == 2 ? 1 : s == 4 ? 2 : 3) * 4, slope = ps->slope;
	const cpx x = {h->k, h->dk, h->ctx, h->mag, h->fc, h->pb, h->pw, h->k1, h->v, h->cls,
	               slope, ps->fused ? ps->beta[0] : -1, ps->direct, s == 1};
	int32_t *const Dc = h->dc, *const Vc = h->vc;
	uint8_t *const Mc = h->mc;
	const size_t sst = 3 * (size_t)st;
	const uint32_t SMALL = 1u << 22;
	uint32_t big = 0; /* the OR of value + 2^22: ≥ 2^23 for one past ±2^22 */
	for (int J = 0; J < Rc; J++) {
		const int32_t *ds = x.dk + sst * (size_t)J * (size_t)C,
		              *vs = x.V + sst * (size_t)J * (size_t)C;
		const uint8_t *ms = x.mag + sst * (size_t)J * (size_t)C;
		int32_t *dd = Dc + 3 * (size_t)J * (size_t)Cc, *vd = Vc + 3 * (size_t)J * (size_t)Cc;
		uint8_t *md = Mc + 3 * (size_t)J * (size_t)Cc;
		if (slope)
			for (int I = 0; I < Cc; I++, ds += sst, vs += sst, ms += sst, dd += 3, vd += 3, md += 3)
				for (int d = 0; d < 3; d++) {
					dd[d] = ds[d], vd[d] = vs[d], md[d] = ms[d];
					big |= ((uint32_t)dd[d] + SMALL) | ((uint32_t)vd[d] + SMALL);
				}
		else /* no slope (the decoder's β = 0): Vc unread */
			for (int I = 0; I < Cc; I++, ds += sst, ms += sst, dd += 3, md += 3)
				for (int d = 0; d < 3; d++) {
					dd[d] = ds[d], md[d] = ms[d];
					big |= (uint32_t)dd[d] + SMALL;
				}
	}
	/* every value within ±2^22: the butterflies (|sum of weights| 24) in
	 * int32_t, twice the lanes of int64_t */
	const int narrow = big < 2 * SMALL;
	/* the decoder's codes in a tile whose every node is LOSSY: cpx_dec32() */
	const int dec = narrow && ps->direct && h->alllossy;
	unsigned oor = 0;
	for (int t = 0; t < 3; t++) {
		/* the stencil's offsets (values, compact) and its extent */
		long c[8];
		int imin = 0, imax = 0, jmin = 0, jmax = 0;
		for (int q = 0; q < 8; q++) {
			const int di = stencil[t][q][0], dj = stencil[t][q][1];
			imin = di < imin ? di : imin, imax = di > imax ? di : imax;
			jmin = dj < jmin ? dj : jmin, jmax = dj > jmax ? dj : jmax;
			c[q] = 3L * ((long)dj * Cc + di);
		}
		const int oi = t != 1 ? s : 0, oj = t != 0 ? s : 0; /* the node, from its base */
		for (int J = 0; J < Rc && st * J + oj < R; J++) {
			/* the row's nodes (none when the tile is narrower than oi + 1) */
			const int j = st * J + oj, nI = C - 1 - oi >= 0 ? (C - 1 - oi) / st + 1 : 0;
			int a = -imin, b = Cc - 1 - imax; /* the interior: bases [a, b] */
			b = b < nI - 1 ? b : nI - 1;
			if (J < -jmin || J > Rc - 1 - jmax || a > b)
				a = nI, b = nI - 1;
			const size_t row = (size_t)j * (size_t)C + (size_t)oi;
			/* the nodes whose stencil leaves the tile: pred16()'s general
			 * case, every node held: the ends' mean, the one end, or none */
			for (int I = 0; I < nI; I++) {
				if (I == a) {
					I = b;
					continue;
				}
				int64_t tb[3], tw[3];
				uint8_t tc[3];
				long e[2];
				int ne = 0;
				for (int q = 0; q < 2; q++) {
					const int ii = I + stencil[t][q][0], jj = J + stencil[t][q][1];
					if (ii >= 0 && ii < Cc && jj >= 0 && jj < Rc)
						e[ne++] = 3L * ((long)jj * Cc + ii);
				}
				for (int d = 0; d < 3; d++) {
					if (ne == 2) {
						const unsigned u = (unsigned)Mc[e[0] + d] + Mc[e[1] + d];
						tb[d] = 8 * ((int64_t)Dc[e[0] + d] + Dc[e[1] + d]);
						tw[d] = slope ? -8 * ((int64_t)Vc[e[0] + d] + Vc[e[1] + d]) : 0;
						tc[d] = (uint8_t)(g + nb_of(u));
					} else if (ne == 1) {
						tb[d] = 16 * (int64_t)Dc[e[0] + d];
						tw[d] = slope ? -16 * (int64_t)Vc[e[0] + d] : 0;
						tc[d] = (uint8_t)(g + nb_of(Mc[e[0] + d]));
					} else {
						tb[d] = tw[d] = 0;
						tc[d] = 4 * H_TOP;
					}
				}
				cpx_put(&x, row + (size_t)st * (size_t)I, 0, 1, tb, tw, tc, &oor);
			}
			/* the interior's, in runs */
			for (int I0 = a; I0 <= b; I0 += RUN_NODES) {
				int64_t tb[3 * RUN_NODES], tw[3 * RUN_NODES];
				uint8_t tc[3 * RUN_NODES];
				const int m = b - I0 + 1 < RUN_NODES ? b - I0 + 1 : RUN_NODES, nv = 3 * m;
				const long v0 = 3L * ((long)J * Cc + I0);
				const int32_t *D = Dc + v0, *VV = Vc + v0;
				const uint8_t *M = Mc + v0;
				for (int v = 0; v < nv; v++) {
					const unsigned u = (unsigned)M[v + c[0]] + M[v + c[1]];
					tc[v] = (uint8_t)(g + (u > 0) + (u > 2)); /* nb_of(u) */
				}
				if (narrow) {
					int32_t tb32[3 * RUN_NODES], tw32[3 * RUN_NODES];
					for (int v = 0; v < nv; v++)
						tb32[v] = 8 * (D[v + c[0]] + D[v + c[1]]) + 2 * (D[v + c[2]] + D[v + c[3]]) -
						          (D[v + c[4]] + D[v + c[5]] + D[v + c[6]] + D[v + c[7]]);
					for (int v = 0; v < nv && slope; v++) /* else unread */
						tw32[v] = -8 * (VV[v + c[0]] + VV[v + c[1]]) -
						          2 * (VV[v + c[2]] + VV[v + c[3]]) +
						          (VV[v + c[4]] + VV[v + c[5]] + VV[v + c[6]] + VV[v + c[7]]);
					const size_t n0 = row + (size_t)st * (size_t)I0;
					if (!dec)
						cpx_put32(&x, n0, (size_t)st, m, tb32, tw32, tc, &oor);
					else if (!slope && x.fine)
						cpx_dec32(&x, n0, (size_t)st, m, tb32, tw32, tc, &oor, 0, 1);
					else if (!slope)
						cpx_dec32(&x, n0, (size_t)st, m, tb32, tw32, tc, &oor, 0, 0);
					else if (x.fine)
						cpx_dec32(&x, n0, (size_t)st, m, tb32, tw32, tc, &oor, 1, 1);
					else
						cpx_dec32(&x, n0, (size_t)st, m, tb32, tw32, tc, &oor, 1, 0);
					continue;
				}
				for (int v = 0; v < nv; v++)
					tb[v] = 8 * ((int64_t)D[v + c[0]] + D[v + c[1]]) +
					        2 * ((int64_t)D[v + c[2]] + D[v + c[3]]) -
					        ((int64_t)D[v + c[4]] + D[v + c[5]] + D[v + c[6]] + D[v + c[7]]);
				if (slope)
					for (int v = 0; v < nv; v++)
						tw[v] = -8 * ((int64_t)VV[v + c[0]] + VV[v + c[1]]) -
						        2 * ((int64_t)VV[v + c[2]] + VV[v + c[3]]) +
						        ((int64_t)VV[v + c[4]] + VV[v + c[5]] + VV[v + c[6]] +
						         VV[v + c[7]]);
				else
					memset(tw, 0, (size_t)nv * sizeof *tw);
				cpx_put(&x, row + (size_t)st * (size_t)I0, (size_t)st, m, tb, tw, tc, &oor);
			}
		}
	}
	ps->oor |= oor;
}

/* P_PREDICT over level s (0: the top): predict_compact() when every
 * node is held, else node by node */
static inline __attribute__((always_inline)) void predict_level(hier *h, pass *ps, int s)
{
	if (!s || !h->allheld || ndo__codec_hier_general)
		level_predict(h, ps, s);
	else
		predict_compact(h, ps, s);
}

NDO_HOT static void slope_fill(hier *h);

/* Every LOSSY node of the frame, the top level first; each level's slope
 * share first (3 direct bits) unless the frame is a keyframe. */
NDO_HOT static int levels(hier *h, int mode, rcenc *e, rcdec *dc, uint64_t *any)
{
	pass ps = {.beta = {BETA_IMPLIED, BETA_IMPLIED, BETA_IMPLIED}, .e = e, .dc = dc};
	for (int s = h->top; s >= 1; s /= 2) {
		const int ls = s == h->top ? 0 : s; /* the top level: no stencil */
		const int st = 2 * s, C = h->cols;
		const int shift[3] = {-s, -s * C, -s - s * C}; /* the base node, from the node */
		for (int t = 0; t < 3; t++)
			for (int q = 0; q < 8; q++)
				h->rel[t][q] = shift[t] + stencil[t][q][0] * st + stencil[t][q][1] * st * C;
		int beta = BETA_IMPLIED;
		if (mode == P_ENCODE && !h->intra) {
			memset(ps.cost, 0, sizeof ps.cost);
			ps.slope = 1;
			PHASE(0, LCOL(ls), predict_level(h, &ps, ls));
			if (ls && h->alllossy && !ndo__codec_hier_general)
				PHASE(1, LCOL(ls), collect_sampled(h, &ps, ls));
			else
				PHASE(1, LCOL(ls), level_collect(h, &ps, ls));
			for (int b = BETA_MAX; b >= 0; b--) /* ties: the implied frames' */
				if (ps.cost[b] < ps.cost[beta])
					beta = b;
			for (int b = 2; b >= 0; b--)
				rc_direct(e, beta >> b & 1);
			if (ndo__codec_hier_stats)
				ndo__codec_hier_stats->beta_bits += 3;
			ps.any |= (uint64_t)(beta != BETA_IMPLIED);
		} else if (mode == P_DECODE && !h->intra) {
			beta = 0;
			for (int b = 2; b >= 0; b--)
				beta = beta << 1 | rd_direct(dc);
			if (beta > BETA_MAX)
				return -1;
			if (beta)
				slope_fill(h);
			ps.slope = beta != 0, ps.fused = 1, ps.direct = 1, ps.oor = 0;
			ps.beta[0] = ps.beta[1] = ps.beta[2] = beta;
			PHASE(3, LCOL(ls), predict_level(h, &ps, ls));
			if (ps.oor) { /* a prediction out of range: P_DECODE's checks, node by node */
				ps.direct = 0;
				PHASE(3, LCOL(ls), predict_level(h, &ps, ls));
			}
		}
		ps.beta[0] = ps.beta[1] = ps.beta[2] = beta;
		if (mode == P_ENCODE && !h->intra)
			PHASE(2, LCOL(ls),
			      ls && h->alllossy && !ndo__codec_hier_stats && !ndo__codec_hier_general
			          ? level_encode_zf(h, &ps, ls)
			          : level_encode(h, &ps, ls));
		else if (mode == P_ENCODE)
			PHASE(2, LCOL(ls), level(h, P_ENCODE1, &ps, ls));
		else if (mode == P_DECODE && ps.direct && ls && h->allheld && h->alllossy &&
		         !ndo__codec_hier_general)
			PHASE(4, LCOL(ls), level_decode_fc(h, &ps, ls));
		else if (mode == P_DECODE && ps.direct)
			PHASE(4, LCOL(ls), level_decode_direct(h, &ps, ls));
		else if (mode == P_DECODE)
			PHASE(4, LCOL(ls), level_decode(h, &ps, ls));
		else
			level(h, P_IMPLIED, &ps, ls);
		if (ps.bad)
			return -1;
		if (h->top == 1)
			break;
	}
	if (any)
		*any = ps.any;
	return 0;
}

/* The references' codes and slope for every node the frame holds; none
 * (a keyframe's zeros) when the newest lacks one of them or there is
 * none, no slope when the second lacks one. */
NDO_HOT static void time_refs(hier *h, const hcodes *c, int32_t *zeros)
{
	const ndo_codec_frame *r0 = c->r[0], *r1 = c->r[1];
	const int nodes = c->rows * c->cols;
	const size_t N = 3 * (size_t)nodes;
	if (r0) { /* without branches: a missing node in either */
		const uint8_t *h0 = r0->have, *h1 = r1 ? r1->have : r0->have;
		unsigned miss0 = 0, miss1 = 0;
		for (int n = 0; n < nodes; n++) {
			const unsigned held = c->cls[n] != NDO_NODE_SKIP;
			miss0 |= held & (h0[n] == 0), miss1 |= held & (h1[n] == 0);
		}
		r0 = miss0 ? NULL : r0, r1 = miss1 ? NULL : r1;
	}
	h->intra = !r0;
	h->s1 = h->s2 = NULL;
	if (!r0) {
		memset(zeros, 0, N * sizeof *zeros);
		memset(h->v, 0, N * sizeof *h->v);
		h->k1 = zeros;
		return;
	}
	h->k1 = r0->k;
	if (!r1) {
		memset(h->v, 0, N * sizeof *h->v);
		return;
	}
	h->s1 = r0->k, h->s2 = r1->k, h->g0 = c->step - r0->step, h->g1 = r0->step - r1->step;
}

/* The slope v from the references time_refs() kept (h->s1, h->s2), once:
 * a decoder whose levels all have β = 0 never needs it.  NDO_HOT (as
 * time_refs()): its loops vectorized, the setups 0.7 and 0.5 of their time
 * before (bench_codec -v 2, level 7). */
NDO_HOT static void slope_fill(hier *h)
{
	if (!h->s1)
		return;
	const size_t N = 3 * (size_t)h->rows * (size_t)h->cols;
	const int64_t g0 = h->g0, g1 = h->g1;
	const int32_t *k1 = h->s1, *k2 = h->s2;
	h->s1 = h->s2 = NULL;
	if (g0 == g1) { /* consecutive: within ±2^31 */
		for (size_t v = 0; v < N; v++)
			h->v[v] = (int32_t)((int64_t)k1[v] - k2[v]);
		return;
	}
	if (g1 > 0 && g0 % g1 == 0) { /* a whole multiple: rdiv() exact, without its division */
		const int64_t m = g0 / g1;
		for (size_t v = 0; v < N; v++) {
			int64_t s = ((int64_t)k1[v] - k2[v]) * m;
			h->v[v] = (int32_t)(s > CODE_MAX ? CODE_MAX : s < -CODE_MAX ? -CODE_MAX : s);
		}
		return;
	}
	for (size_t v = 0; v < N; v++) {
		int64_t s = rdiv(((int64_t)k1[v] - k2[v]) * g0, g1);
		h->v[v] = (int32_t)(s > CODE_MAX ? CODE_MAX : s < -CODE_MAX ? -CODE_MAX : s);
	}
}

static void hier_init(hier *h, const hcodes *c, int32_t *k, int64_t *t, uint8_t *mag)
{
	const int nodes = c->rows * c->cols;
	const size_t N = 3 * (size_t)nodes;
	h->rows = c->rows, h->cols = c->cols, h->cls = c->cls, h->k = k, h->mag = mag;
	int top = 1;
	while (2 * top < (c->rows > c->cols ? c->rows : c->cols))
		top *= 2;
	h->top = top;
	/* the scratch (HIER_SCRATCH int64 a node): pb, pw; v, dk, zeros; ctx
	 * (11 a node); predict_compact()'s dc, vc and mc (≤ 3 values a node
	 * each: its lattice has at most as many nodes as the tile) and fc, 3.5
	 * a node */
	h->pb = t, h->pw = t + N;
	int32_t *t32 = (int32_t *)(t + 2 * N);
	h->v = t32, h->dk = t32 + N;
	h->ctx = (uint8_t *)(t32 + 3 * N);
	h->dc = (int32_t *)(t + 11 * (size_t)nodes), h->vc = h->dc + N;
	h->mc = (uint8_t *)(h->vc + N), h->fc = h->mc + N;
	time_refs(h, c, t32 + 2 * N);
	h->x = NULL;
	h->allheld = !memchr(c->cls, NDO_NODE_SKIP, (size_t)nodes);
	h->alllossy = h->allheld;
	memset(mag, 0, N); /* an EXACT node's: no residual */
	for (const uint8_t *e = c->cls; (e = memchr(e, NDO_NODE_EXACT, (size_t)(c->cls + nodes - e)));
	     e++) {
		h->alllossy = 0;
		const size_t n = (size_t)(e - c->cls);
		for (int d = 0; d < 3; d++)
			h->dk[3 * n + d] = (int32_t)((int64_t)k[3 * n + d] - h->k1[3 * n + d]);
	}
	model_init(&h->m);
}

int ndo__codec_hier_encode(const hcodes *c, const quant *z, double maxerr, const double *x,
                           int32_t *k, int64_t *t, uint8_t *mag, uint64_t *any, wbuf *b)
{
	hier h;
	PHASE(5, 2, hier_init(&h, c, k, t, mag); slope_fill(&h));
	h.x = x, h.z = z, h.m2 = maxerr * maxerr * (1 - 1e-9);
	for (int d = 0; d < 3; d++) {
		h.w2[d] = z->q[d] * z->q[d], h.iq[d] = 1 / z->q[d];
		h.R[d] = sqrt(h.m2 / h.w2[d]), h.r[d] = h.R[d] / sqrt(3.0);
	}
	rcenc e;
	ndo__rc_enc_init(&e, b);
	const size_t n0 = b->n;
	if (levels(&h, P_ENCODE, &e, NULL, any))
		return -2;
	ndo__rc_enc_flush(&e);
	if (ndo__codec_hier_stats)
		ndo__codec_hier_stats->rc_bytes += (double)(b->n - n0), ndo__codec_hier_stats->frames++;
	return b->fail ? -1 : 0;
}

int ndo__codec_hier_decode(const hcodes *c, int32_t *k, int64_t *t, uint8_t *mag,
                           const uint8_t *p, size_t n)
{
	hier h;
	PHASE(6, 2, hier_init(&h, c, k, t, mag));
	rcdec d;
	ndo__rc_dec_init(&d, p, n);
	if (levels(&h, P_DECODE, NULL, &d, NULL))
		return -1;
	return d.over || d.pos != d.n ? -1 : 0;
}

int ndo__codec_hier_implied(const hcodes *c, int32_t *k, int64_t *t, uint8_t *mag)
{
	hier h;
	hier_init(&h, c, k, t, mag);
	slope_fill(&h);
	return levels(&h, P_IMPLIED, NULL, NULL, NULL);
}
