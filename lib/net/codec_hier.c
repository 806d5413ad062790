/* codec_hier.c — the hierarchical coder (ndo/codec.h, "hier"): a tile's
 * codes level by level, each new node's residual against the butterfly of
 * the coarser nodes (a subdivision wavelet) combined with the time
 * prediction, the residuals through an adaptive binary range coder with
 * contexts.
 *
 * The levels of a tile of rows × cols nodes: S the largest power of two
 * below max(rows, cols) (1 at least); the top level holds the nodes whose
 * tile coordinates (i, j) are multiples of S, level s (S/2, ..., 1) the
 * nodes with multiples of s that no coarser level holds.  A node of level s
 * is the midpoint of an edge of level 2s — horizontal (i odd, j even in
 * units of s), vertical, or diagonal from (i+s, j−s) to (i−s, j+s), the
 * grid's triangulation — and its spatial prediction is the modified
 * butterfly of that edge (ends 1/2, wings 1/8, far −1/16: lib/grid/subdivide.c's
 * kernels) over the coarser nodes, or the ends' mean when one of the eight
 * is outside the tile or not held by the frame, or the one end held, or
 * none.
 *
 * Everything is integer codes (the quantizer predict uses): T(n), the time
 * prediction of node n (k1 copied with one reference; 2k1 − k2 with two,
 * the slope scaled to the steps when they are not consecutive; 0 in a
 * keyframe, or when a reference lacks a node the frame holds), and the
 * prediction of node n of a level below the top is
 *     P(n) = T(n) + B[k − T](n),
 * the butterfly of the coarser nodes' time-prediction errors (rounded half
 * away from zero): the time prediction of the detail coefficient plus the
 * coarse level's correction.  A top-level node's P is T (a keyframe: the
 * previous top node's code, 0 for the first).  Closed loop: the codes are
 * the quantizer's, every prediction is made from codes the decoder holds.
 *
 * The residual r = k − P of each component: a zero flag, in context of
 * the level (1, 2, 4, 8 and coarser, the top), the component and the
 * magnitude of the edge's two ends' residuals (0, 1-2, more); then the
 * sign; then |r| as Elias gamma: the exponent in unary with adaptive bits
 * (level, neighbours), the mantissa as direct bits.  The range coder is
 * LZMA's (11-bit probabilities adapting by 1/32, carry through a cache
 * byte): a decoder given any bytes reads none past the end (it counts the
 * bytes missing, and the frame is corrupt) and its loops are bounded. */
#include "codec_private.h"

#include <math.h>
#include <string.h>

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

static inline void put_res(rcenc *e, hmodel *m, int g, int d, int nb, int64_t r)
{
	rc_bit(e, &m->zero[g][d][nb], r != 0);
	if (!r)
		return;
	rc_bit(e, &m->sign[g][d], r < 0);
	const uint64_t a = r < 0 ? -(uint64_t)r : (uint64_t)r;
	const int k = 63 - __builtin_clzll(a);
	for (int i = 0; i < k; i++)
		rc_bit(e, &m->ex[g][nb][i], 1);
	rc_bit(e, &m->ex[g][nb][k], 0); /* k < H_EXP: |r| < 2^36 (P's bound) */
	for (int i = k - 1; i >= 0; i--)
		rc_direct(e, (int)(a >> i) & 1);
}

/* −1 and *bad: an exponent past H_EXP − 1 */
static inline int64_t get_res(rcdec *dc, hmodel *m, int g, int d, int nb, int *bad)
{
	if (!rd_bit(dc, &m->zero[g][d][nb]))
		return 0;
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
	int rows, cols, top, allheld, intra;
	const uint8_t *cls;
	int32_t *k;          /* this frame's codes, 3 a node */
	int64_t *k1, *v;     /* the reference's codes and the slope (0 in a keyframe) */
	int64_t *dk;         /* k − k1 of the nodes coded so far */
	int64_t *base, *w;   /* encoder: a level's 16 P(β = 0) and 16 × its slope part */
	uint8_t *mag;        /* |residual| (saturated), 3 a node */
	const double *x;     /* encoder: the positions, 3 a node */
	const quant *z;
	double m2;           /* encoder: the largest error, squared */
	hmodel m;
} hier;

/* The encoder's choice of node n's codes given their predictions p,
 * within the error bound (the nearest codes' distance at least): each
 * code the one nearest its prediction within the bound's box on its
 * axis; when those three are too far, each within the box inscribed in
 * the bound's ball (always near enough), then axis by axis back to the
 * first choice while they stay near enough. */
static inline void choose(hier *h, size_t n, const int64_t p[3])
{
	int32_t *k = h->k + 3 * n;
	if (k[0] == p[0] && k[1] == p[1] && k[2] == p[2])
		return; /* the nearest codes, predicted */
	double t[3], w[3], lim = 0;
	int64_t a[3], b[3];
	for (int d = 0; d < 3; d++) {
		t[d] = (h->x[3 * n + d] - h->z->lo[d]) / h->z->q[d];
		w[d] = h->z->q[d] * h->z->q[d];
		const double e = t[d] - (double)k[d];
		lim += e * e * w[d];
	}
	const double m = h->m2 * (1 - 1e-9);
	lim = lim > m ? lim : m;
	double ea = 0;
	for (int d = 0; d < 3; d++) {
		const double R = sqrt(lim / w[d]), r = R / sqrt(3.0);
		int64_t lo = (int64_t)ceil(t[d] - R), hi = (int64_t)floor(t[d] + R);
		lo = lo > k[d] ? k[d] : lo, hi = hi < k[d] ? k[d] : hi;
		a[d] = p[d] < lo ? lo : p[d] > hi ? hi : p[d];
		ea += (t[d] - (double)a[d]) * (t[d] - (double)a[d]) * w[d];
		lo = (int64_t)ceil(t[d] - r), hi = (int64_t)floor(t[d] + r);
		lo = lo > k[d] ? k[d] : lo, hi = hi < k[d] ? k[d] : hi;
		b[d] = p[d] < lo ? lo : p[d] > hi ? hi : p[d];
	}
	if (ea > lim) {
		double eb = 0;
		for (int d = 0; d < 3; d++)
			eb += (t[d] - (double)b[d]) * (t[d] - (double)b[d]) * w[d];
		if (!(eb <= lim)) /* cannot be: the inscribed box's corner is on the ball */
			return;
		for (int d = 0; d < 3; d++) {
			const double e2 = eb - (t[d] - (double)b[d]) * (t[d] - (double)b[d]) * w[d] +
			                  (t[d] - (double)a[d]) * (t[d] - (double)a[d]) * w[d];
			if (e2 <= lim)
				b[d] = a[d], eb = e2;
		}
		a[0] = b[0], a[1] = b[1], a[2] = b[2];
	}
	for (int d = 0; d < 3; d++)
		if (a[d] > -CODE_MAX && a[d] < CODE_MAX)
			k[d] = (int32_t)a[d];
}

/* Set by tests: every node through the general stencil (bounds and
 * classes checked), the interior's reference. */
int ndo__codec_hier_general;

/* Node n = (i, j) of level s (0: the top): 16 × its prediction with no
 * slope (base: 16 k1 + the butterfly of the coarser nodes' k − k1) and
 * 16 × the slope's detail (w: 16 v − the butterfly of their v), per
 * component; its edge's ends (−1: none).  Returns the stencil nodes used:
 * 8, 2 (the ends' mean), 1 (the one end held) or 0. */
static inline int pred16(const hier *h, int i, int j, int s, int64_t base[3], int64_t w[3],
                         long ends[2])
{
	const long n = (long)j * h->cols + i;
	const int64_t *K1 = h->k1 + 3 * n, *V = h->v + 3 * n, *D = h->dk, *VV = h->v;
	ends[0] = ends[1] = -1;
	if (!s) {
		for (int d = 0; d < 3; d++)
			base[d] = 16 * K1[d], w[d] = 16 * V[d];
		return 0;
	}
	const int a = (i / s) & 1, b = (j / s) & 1;
	const int type = a && !b ? 0 : !a && b ? 1 : 2;
	const int bi = a ? i - s : i, bj = b ? j - s : j, st = 2 * s;
	long o[8];
	int held = 0;
	if (h->allheld && !ndo__codec_hier_general && bi >= st && bi + 2 * st < h->cols &&
	    bj >= st && bj + 2 * st < h->rows) {
		const long bn = (long)bj * h->cols + bi, cs = (long)st * h->cols;
		for (int q = 0; q < 8; q++)
			o[q] = 3 * (bn + stencil[type][q][0] * st + stencil[type][q][1] * cs);
		held = 8;
	} else {
		for (int q = 0; q < 8; q++) {
			const int ii = bi + stencil[type][q][0] * st, jj = bj + stencil[type][q][1] * st;
			o[q] = ii >= 0 && ii < h->cols && jj >= 0 && jj < h->rows &&
			               h->cls[(size_t)jj * (size_t)h->cols + (size_t)ii] != NDO_NODE_SKIP
			           ? 3 * ((long)jj * h->cols + ii)
			           : -1;
			held += o[q] >= 0;
		}
	}
	if (held == 8) {
		ends[0] = o[0] / 3, ends[1] = o[1] / 3;
		for (int d = 0; d < 3; d++) {
			base[d] = 16 * K1[d] + 8 * (D[o[0] + d] + D[o[1] + d]) + 2 * (D[o[2] + d] + D[o[3] + d]) -
			          (D[o[4] + d] + D[o[5] + d] + D[o[6] + d] + D[o[7] + d]);
			w[d] = 16 * V[d] - 8 * (VV[o[0] + d] + VV[o[1] + d]) - 2 * (VV[o[2] + d] + VV[o[3] + d]) +
			       (VV[o[4] + d] + VV[o[5] + d] + VV[o[6] + d] + VV[o[7] + d]);
		}
		return 8;
	}
	if (o[0] >= 0 && o[1] >= 0) {
		ends[0] = o[0] / 3, ends[1] = o[1] / 3;
		for (int d = 0; d < 3; d++) {
			base[d] = 16 * K1[d] + 8 * (D[o[0] + d] + D[o[1] + d]);
			w[d] = 16 * V[d] - 8 * (VV[o[0] + d] + VV[o[1] + d]);
		}
		return 2;
	}
	const long e = o[0] >= 0 ? o[0] : o[1];
	for (int d = 0; d < 3; d++) {
		base[d] = 16 * K1[d] + (e >= 0 ? 16 * D[e + d] : 0);
		w[d] = 16 * V[d] - (e >= 0 ? 16 * VV[e + d] : 0);
	}
	if (e < 0)
		return 0;
	ends[0] = e / 3;
	return 1;
}

static inline int group_of(int s) { return s == 1 ? 0 : s == 2 ? 1 : s == 4 ? 2 : 3; }

/* the prediction: (4 base + β w) / 64, rounded half away from zero */
static inline int64_t pred_of(int64_t base, int64_t w, int beta)
{
	return rdiv(4 * base + beta * w, 64);
}

/* One node of level s: mode 0 encode its residuals (base and w given:
 * pass 1), 1 decode them (−1: a code out of range or a bad symbol), 2
 * its codes the predictions (a skipped step's frame). */
static inline int node(hier *h, int mode, rcenc *e, rcdec *dc, int i, int j, int s, int beta,
                       int64_t last[3], uint64_t *any)
{
	const size_t n = (size_t)j * (size_t)h->cols + (size_t)i;
	if (h->cls[n] != NDO_NODE_LOSSY)
		return 0;
	int64_t base[3], w[3];
	long ends[2];
	const int used = pred16(h, i, j, s, base, w, ends);
	const int g = used ? group_of(s) : H_TOP;
	int64_t pp[3];
	for (int d = 0; d < 3; d++)
		pp[d] = used || !h->intra ? pred_of(base[d], w[d], beta) : last[d];
	if (mode == 0)
		choose(h, n, pp);
	for (int d = 0; d < 3; d++) {
		const int64_t p = pp[d];
		unsigned t = (ends[0] >= 0 ? h->mag[3 * ends[0] + d] : 0) +
		             (ends[1] >= 0 ? h->mag[3 * ends[1] + d] : 0);
		const int nb = nb_of(t);
		int64_t r = 0;
		if (mode == 0) {
			r = (int64_t)h->k[3 * n + (size_t)d] - p;
			put_res(e, &h->m, g, d, nb, r);
			*any |= (uint64_t)r;
		} else {
			int bad = 0;
			if (mode == 1)
				r = get_res(dc, &h->m, g, d, nb, &bad);
			const int64_t k = p + r;
			if (bad || k <= -CODE_MAX || k >= CODE_MAX)
				return -1;
			h->k[3 * n + (size_t)d] = (int32_t)k;
		}
		const uint64_t a = r < 0 ? -(uint64_t)r : (uint64_t)r;
		h->mag[3 * n + (size_t)d] = (uint8_t)(a > 255 ? 255 : a);
		last[d] = used ? last[d] : h->k[3 * n + (size_t)d];
		h->dk[3 * n + (size_t)d] = (int64_t)h->k[3 * n + (size_t)d] - h->k1[3 * n + (size_t)d];
	}
	return 0;
}

/* The nodes of level s (0: the top), in raster order. */
#define FOR_LEVEL(h, s, i, j)                                                           \
	for (int j = 0; j < (h)->rows; j += (s) ? (s) : (h)->top)                           \
		for (int i = (s) && !((j / ((s) ? (s) : 1)) & 1) ? (s) : 0; i < (h)->cols;       \
		     i += (s) ? ((j / ((s) ? (s) : 1)) & 1 ? (s) : 2 * (s)) : (h)->top)

/* The encoder's slope share for level s: of β = 0..4 quarters, the one
 * whose residuals from the nearest codes cost least (a nonzero residual:
 * 2 + twice its bits), ties to BETA_IMPLIED. */
static int beta_of(hier *h, int s)
{
	uint64_t cost[BETA_MAX + 1] = {0};
	FOR_LEVEL(h, s, i, j) {
		const size_t n = (size_t)j * (size_t)h->cols + (size_t)i;
		if (h->cls[n] != NDO_NODE_LOSSY)
			continue;
		long ends[2];
		int64_t base[3], w[3];
		pred16(h, i, j, s, base, w, ends);
		for (int d = 0; d < 3; d++)
			for (int b = 0; b <= BETA_MAX; b++) {
				const int64_t r = h->k[3 * n + (size_t)d] - pred_of(base[d], w[d], b);
				const uint64_t a = r < 0 ? -(uint64_t)r : (uint64_t)r;
				cost[b] += a ? 2 + 2 * (uint64_t)(64 - __builtin_clzll(a)) : 0;
			}
	}
	int best = BETA_IMPLIED;
	for (int b = BETA_MAX; b >= 0; b--)
		if (cost[b] < cost[best])
			best = b;
	return best;
}

/* Every LOSSY node of the frame, the top level first; each level's slope
 * share first (3 direct bits) unless the frame is a keyframe. */
static int levels(hier *h, int mode, rcenc *e, rcdec *dc, uint64_t *any)
{
	int64_t last[3] = {0, 0, 0};
	for (int s = h->top; s >= 1; s /= 2) {
		const int ls = s == h->top ? 0 : s; /* the top level: no stencil */
		int beta = BETA_IMPLIED;
		if (!h->intra && mode == 0) {
			beta = beta_of(h, ls);
			for (int b = 2; b >= 0; b--)
				rc_direct(e, beta >> b & 1);
			*any |= (uint64_t)(beta != BETA_IMPLIED);
		} else if (!h->intra && mode == 1) {
			beta = 0;
			for (int b = 2; b >= 0; b--)
				beta = beta << 1 | rd_direct(dc);
			if (beta > BETA_MAX)
				return -1;
		}
		FOR_LEVEL(h, ls, i, j)
		if (node(h, mode, e, dc, i, j, ls, beta, last, any))
			return -1;
		if (h->top == 1)
			break;
	}
	return 0;
}

/* The references' codes and slope for every node the frame holds; none
 * (a keyframe's zeros) when the newest lacks one of them or there is
 * none, no slope when the second lacks one. */
static void time_refs(hier *h, const hcodes *c)
{
	const ndo_codec_frame *r0 = c->r[0], *r1 = c->r[1];
	const int nodes = c->rows * c->cols;
	for (int n = 0; n < nodes && r0; n++)
		if (c->cls[n] != NDO_NODE_SKIP) {
			if (!r0->have[n])
				r0 = NULL;
			else if (r1 && !r1->have[n])
				r1 = NULL;
		}
	h->intra = !r0;
	const int64_t g0 = r0 && r1 ? c->step - r0->step : 0, g1 = r0 && r1 ? r0->step - r1->step : 1;
	for (int n = 0; n < nodes; n++)
		for (size_t v = 3 * (size_t)n; v < 3 * (size_t)n + 3; v++) {
			if (!r0 || c->cls[n] == NDO_NODE_SKIP) {
				h->k1[v] = h->v[v] = 0;
				continue;
			}
			const int64_t k1 = r0->k[v];
			h->k1[v] = k1;
			h->v[v] = !r1 ? 0 : g0 == g1 ? k1 - r1->k[v] : rdiv((k1 - r1->k[v]) * g0, g1);
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
	h->k1 = t, h->v = t + N, h->dk = t + 2 * N, h->base = t + 3 * N, h->w = t + 4 * N;
	time_refs(h, c);
	h->x = NULL;
	h->allheld = 1;
	for (int n = 0; n < nodes; n++) {
		h->allheld &= c->cls[n] != NDO_NODE_SKIP;
		for (int d = 0; d < 3; d++) {
			mag[3 * n + d] = 0; /* an EXACT node's: no residual */
			if (c->cls[n] == NDO_NODE_EXACT)
				h->dk[3 * n + d] = (int64_t)k[3 * n + d] - h->k1[3 * n + d];
		}
	}
	model_init(&h->m);
}

int ndo__codec_hier_encode(const hcodes *c, const quant *z, double maxerr, const double *x,
                           int32_t *k, int64_t *t, uint8_t *mag, uint64_t *any, wbuf *b)
{
	hier h;
	hier_init(&h, c, k, t, mag);
	h.x = x, h.z = z, h.m2 = maxerr * maxerr;
	rcenc e;
	ndo__rc_enc_init(&e, b);
	*any = 0;
	levels(&h, 0, &e, NULL, any);
	ndo__rc_enc_flush(&e);
	return b->fail ? -1 : 0;
}

int ndo__codec_hier_decode(const hcodes *c, int32_t *k, int64_t *t, uint8_t *mag,
                           const uint8_t *p, size_t n)
{
	hier h;
	hier_init(&h, c, k, t, mag);
	rcdec d;
	ndo__rc_dec_init(&d, p, n);
	if (levels(&h, 1, NULL, &d, NULL))
		return -1;
	return d.over || d.pos != d.n ? -1 : 0;
}

int ndo__codec_hier_implied(const hcodes *c, int32_t *k, int64_t *t, uint8_t *mag)
{
	hier h;
	hier_init(&h, c, k, t, mag);
	return levels(&h, 2, NULL, NULL, NULL);
}
