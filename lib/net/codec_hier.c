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
static const int weight[8] = {8, 8, 2, 2, -1, -1, -1, -1}; /* / 16 */

typedef struct hier {
	int rows, cols, top;
	const uint8_t *cls;
	int32_t *k;          /* this frame's codes, 3 a node */
	const int64_t *t;    /* time predictions, 3 a node (NULL: none) */
	uint8_t *mag;        /* |residual| (saturated), 3 a node */
	int64_t *dv;         /* k − T of the nodes coded so far, 3 a node */
	int allheld;         /* no SKIP node in the tile */
	const double *x;     /* encoder: the positions, 3 a node */
	const quant *z;
	double m2;           /* encoder: the largest error, squared */
	hmodel m;
} hier;

/* The encoder's choice of node n's codes given their predictions p,
 * within the error bound (the nearest codes' distance at least): per
 * axis the nearest code or its neighbour on the coordinate's other side,
 * whichever is nearer the prediction; when the three together are too
 * far, the fewest axes back to the nearest code (those that gain the
 * least residual first). */
static inline void choose(hier *h, size_t n, const int64_t p[3])
{
	int32_t *k = h->k + 3 * n;
	if (k[0] == p[0] && k[1] == p[1] && k[2] == p[2])
		return; /* the nearest codes, predicted */
	double e0[3], e1[3], w[3], lim = 0;
	int32_t alt[3];
	int gain[3], want = 0;
	for (int d = 0; d < 3; d++) {
		const double t = (h->x[3 * n + d] - h->z->lo[d]) / h->z->q[d];
		w[d] = h->z->q[d] * h->z->q[d];
		e0[d] = t - (double)k[d];
		alt[d] = k[d] + (e0[d] >= 0 ? 1 : -1);
		e1[d] = t - (double)alt[d];
		lim += e0[d] * e0[d] * w[d];
		/* the other code is nearer the prediction */
		const int64_t r0 = p[d] - k[d], r1 = p[d] - alt[d];
		gain[d] = (r0 < 0 ? -r0 : r0) > (r1 < 0 ? -r1 : r1);
		want |= gain[d] << d;
	}
	if (!want)
		return;
	const double m = h->m2 * (1 - 1e-9);
	lim = lim > m ? lim : m;
	int best = 0, bestn = 0;
	for (int c = want; c; c = (c - 1) & want) { /* subsets of want, from the largest */
		const int cnt = (c & 1) + (c >> 1 & 1) + (c >> 2 & 1);
		if (cnt <= bestn)
			continue;
		double d2 = 0;
		for (int d = 0; d < 3; d++)
			d2 += ((c >> d) & 1 ? e1[d] * e1[d] : e0[d] * e0[d]) * w[d];
		if (d2 <= lim)
			best = c, bestn = cnt;
	}
	for (int d = 0; d < 3; d++)
		if ((best >> d) & 1 && alt[d] > -CODE_MAX && alt[d] < CODE_MAX)
			k[d] = alt[d];
}

/* Set by tests: every node through the general stencil (bounds and
 * classes checked), the interior's reference. */
int ndo__codec_hier_general;

static inline int64_t tpred(const hier *h, size_t n, int d)
{
	return h->t ? h->t[3 * n + (size_t)d] : 0;
}

/* Node (i, j)'s spatial prediction of the time-prediction errors, 3
 * components (pred[], the count of stencil nodes used: 8, 2, 1 or 0), and
 * its edge's ends (−1: none). */
static inline int spatial(const hier *h, int i, int j, int s, int64_t pred[3], long ends[2])
{
	const int a = (i / s) & 1, b = (j / s) & 1;
	const int type = a && !b ? 0 : !a && b ? 1 : 2;
	const int bi = a ? i - s : i, bj = b ? j - s : j, st = 2 * s;
	const int64_t *D = h->dv;
	if (h->allheld && !ndo__codec_hier_general && bi >= st && bi + 2 * st < h->cols && bj >= st && bj + 2 * st < h->rows) {
		const long base = (long)bj * h->cols + bi, cs = (long)st * h->cols;
		long o[8];
		for (int q = 0; q < 8; q++)
			o[q] = 3 * (base + stencil[type][q][0] * st + stencil[type][q][1] * cs);
		for (int d = 0; d < 3; d++) {
			const int64_t sum = 8 * (D[o[0] + d] + D[o[1] + d]) + 2 * (D[o[2] + d] + D[o[3] + d]) -
			                    (D[o[4] + d] + D[o[5] + d] + D[o[6] + d] + D[o[7] + d]);
			pred[d] = rdiv(sum, 16);
		}
		ends[0] = o[0] / 3, ends[1] = o[1] / 3;
		return 8;
	}
	long idx[8];
	int held = 0;
	for (int q = 0; q < 8; q++) {
		const int ii = bi + stencil[type][q][0] * st, jj = bj + stencil[type][q][1] * st;
		idx[q] = ii >= 0 && ii < h->cols && jj >= 0 && jj < h->rows &&
		                 h->cls[(size_t)jj * (size_t)h->cols + (size_t)ii] != NDO_NODE_SKIP
		             ? (long)jj * h->cols + ii
		             : -1;
		held += idx[q] >= 0;
	}
	ends[0] = idx[0], ends[1] = idx[1];
	for (int d = 0; d < 3; d++)
		pred[d] = 0;
	if (held == 8) {
		for (int d = 0; d < 3; d++) {
			int64_t sum = 0;
			for (int q = 0; q < 8; q++)
				sum += weight[q] * D[3 * idx[q] + d];
			pred[d] = rdiv(sum, 16);
		}
		return 8;
	}
	if (idx[0] >= 0 && idx[1] >= 0) {
		for (int d = 0; d < 3; d++)
			pred[d] = rdiv(D[3 * idx[0] + d] + D[3 * idx[1] + d], 2);
		return 2;
	}
	const long e = idx[0] >= 0 ? idx[0] : idx[1];
	if (e < 0)
		return 0;
	for (int d = 0; d < 3; d++)
		pred[d] = D[3 * e + d];
	return 1;
}

static inline int group_of(int s) { return s == 1 ? 0 : s == 2 ? 1 : s == 4 ? 2 : 3; }

/* One node: mode 0 encode its codes' residuals, 1 decode them (−1: a code
 * out of range or a bad symbol), 2 its codes the predictions (a skipped
 * step's frame). */
static inline int node(hier *h, int mode, rcenc *e, rcdec *dc, int i, int j, int s,
                       int64_t last[3], uint64_t *any)
{
	const size_t n = (size_t)j * (size_t)h->cols + (size_t)i;
	if (h->cls[n] != NDO_NODE_LOSSY)
		return 0;
	int64_t sp[3];
	long ends[2] = {-1, -1};
	const int used = s ? spatial(h, i, j, s, sp, ends) : 0;
	const int g = used ? group_of(s) : H_TOP;
	int64_t pp[3];
	for (int d = 0; d < 3; d++)
		pp[d] = used ? tpred(h, n, d) + sp[d] : h->t ? tpred(h, n, d) : last[d];
	if (mode == 0 && h->x)
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
		if (!used)
			last[d] = h->k[3 * n + (size_t)d];
		h->dv[3 * n + (size_t)d] = (int64_t)h->k[3 * n + (size_t)d] - tpred(h, n, d);
	}
	return 0;
}

/* Every LOSSY node of the frame, the top level first. */
static int levels(hier *h, int mode, rcenc *e, rcdec *dc, uint64_t *any)
{
	int64_t last[3] = {0, 0, 0};
	const int S = h->top;
	for (int j = 0; j < h->rows; j += S)
		for (int i = 0; i < h->cols; i += S)
			if (node(h, mode, e, dc, i, j, 0, last, any))
				return -1;
	for (int s = S / 2; s >= 1; s /= 2)
		for (int j = 0; j < h->rows; j += s)
			for (int i = (j / s) & 1 ? 0 : s; i < h->cols; i += (j / s) & 1 ? s : 2 * s)
				if (node(h, mode, e, dc, i, j, s, last, any))
					return -1;
	return 0;
}

/* The time predictions of every node the frame holds, or none (a
 * reference lacks one of them, or there is none). */
static const int64_t *time_pred(const hcodes *c, int64_t *t)
{
	const ndo_codec_frame *r0 = c->r[0], *r1 = c->r[1];
	if (!r0)
		return NULL;
	const int nodes = c->rows * c->cols;
	for (int n = 0; n < nodes; n++)
		if (c->cls[n] != NDO_NODE_SKIP) {
			if (!r0->have[n])
				return NULL;
			if (r1 && !r1->have[n])
				r1 = NULL;
		}
	const int64_t g0 = r1 ? c->step - r0->step : 0, g1 = r1 ? r0->step - r1->step : 1;
	for (int n = 0; n < nodes; n++) {
		if (c->cls[n] == NDO_NODE_SKIP)
			continue;
		for (size_t v = 3 * (size_t)n; v < 3 * (size_t)n + 3; v++) {
			const int64_t k1 = r0->k[v];
			t[v] = !r1 ? k1 : g0 == g1 ? 2 * k1 - r1->k[v] : k1 + rdiv((k1 - r1->k[v]) * g0, g1);
		}
	}
	return t;
}

static void hier_init(hier *h, const hcodes *c, int32_t *k, int64_t *t, uint8_t *mag)
{
	h->rows = c->rows, h->cols = c->cols, h->cls = c->cls, h->k = k, h->mag = mag;
	int top = 1;
	while (2 * top < (c->rows > c->cols ? c->rows : c->cols))
		top *= 2;
	h->top = top;
	const int nodes = c->rows * c->cols;
	h->t = time_pred(c, t);
	h->dv = t + 3 * (size_t)nodes;
	h->x = NULL;
	h->allheld = 1;
	for (int n = 0; n < nodes; n++) {
		h->allheld &= c->cls[n] != NDO_NODE_SKIP;
		for (int d = 0; d < 3; d++) {
			mag[3 * n + d] = 0; /* an EXACT node's: no residual */
			if (c->cls[n] == NDO_NODE_EXACT)
				h->dv[3 * n + d] = (int64_t)k[3 * n + d] - tpred(h, (size_t)n, d);
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
