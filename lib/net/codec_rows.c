/* codec_rows.c — the predictor's common case, fast (ndo/codec.h,
 * "predict"): frames whose every node is predicted the same way go
 * through flat, vectorized loops — a keyframe node by node, predicted
 * frames a row at a time — with the same integers as the general predictor
 * (codec_predict.c), hence the same bytes (tests/unit/test_codec.c checks
 * them against it). */
#include "codec_private.h"
#include "ndo/status.h"

#include <math.h>
#include <string.h>

/* ---- the predictor's common case, fast ------------------------------------------ */
/* Set (tests only): every frame through the general predictor above, so
 * that the fast one below can be checked against it byte for byte. */
int ndo__codec_general_only;

/* Whether a frame is in a common case, where ndo__codec_predict() reduces to the
 * loops of fast_component() — the same integers without its branches:
 * every node carried, and the references ndo__codec_predict() uses (r0; r1; r2 when
 * the last three steps are consecutive) holding every node.  Then every
 * node is predicted the same way (from its neighbours in a keyframe; r0's
 * code with r0 alone; else extrapolated) and its neighbours' values or
 * errors exist wherever the neighbours do. */
NDO_HOT int ndo__codec_uniform(const pctx *c)
{
	if (ndo__codec_general_only)
		return 0;
	const uint8_t *h0 = c->r[0] ? c->r[0]->have : NULL, *h1 = c->r[1] ? c->r[1]->have : h0,
	              *h2 = c->cons3 ? c->r[2]->have : h1;
	int all = 1;
	if (!h0) {
		for (int n = 0; n < c->nodes; n++)
			all &= c->cls[n] != NDO_NODE_SKIP;
	} else {
		for (int n = 0; n < c->nodes; n++)
			all &= (c->cls[n] != NDO_NODE_SKIP) & (h0[n] != 0) & (h1[n] != 0) & (h2[n] != 0);
	}
	return all;
}

/* mode: fast_mode(c), a constant where this is inlined (a loop each) */
static inline __attribute__((always_inline)) int64_t
fast_predict(const pctx *c, const int mode, const int32_t *k, const int64_t *eprev, int64_t *lin,
             int n, int i, int j, int d)
{
	const int cols = c->cols, m = 3 * n + d;
	if (mode == M_INTRA) {
		if (i > 0 && j > 0)
			return med3(k[m - 3], k[m - 3 * cols], k[m - 3 * cols - 3]);
		return i > 0 ? k[m - 3] : j > 0 ? k[m - 3 * cols] : 0;
	}
	int64_t a = c->r[0]->k[m];
	if (mode == M_COPY)
		return a;
	int64_t b = c->r[1]->k[m];
	if (mode == M_CURVED || mode == M_LINEAR) {
		int64_t corr = mode == M_CURVED ? a - 2 * b + c->r[2]->k[m] : 0;
		if (j > 0) { /* the upper row's extrapolation errors this step */
			const int q = 3 * i + d;
			int64_t eu = eprev[q];
			corr += clamp3(eu, i > 0 ? eprev[q - 3] : eu, i + 1 < cols ? eprev[q + 3] : eu);
		}
		*lin = 2 * a - b;
		return *lin + half(corr);
	}
	const int64_t g = c->step - c->r[0]->step, gap = c->r[0]->step - c->r[1]->step;
	if (gap == 1) /* the usual gap, after skipped steps: rdiv() without a division */
		return a + (a - b) * g;
	return a + rdiv((a - b) * g, gap);
}

/* Encoder, a uniform frame, in one pass over the nodes: codes (as
 * code_of(), without branches) into recon->k, the LOSSY nodes' values into
 * recon->x (the others' positions as they are), the LOSSY residuals,
 * zigzag-coded, into u[d × lossy + the node's rank].  Returns −1 when a
 * code is out of range, else 0; *any: the residuals or'ed together. */
static inline __attribute__((always_inline)) int
fast_encode_mode(const pctx *c, const int mode, const quant *z, const double *x,
                 ndo_codec_frame *recon, uint64_t *u, size_t lossy, uint64_t *any, double err[2])
{
	double max2 = 0, sum2 = 0;
	int64_t *erow = c->erow;
	const int cols = c->cols, rows = c->nodes / cols;
	const uint8_t *cls = c->cls;
	int32_t *k = recon->k;
	int out = 0;
	uint64_t acc = 0;
	size_t li = 0;
	for (int j = 0, n = 0; j < rows; j++) {
		int64_t *ecur = erow + (size_t)(j & 1) * 3 * (size_t)cols,
		        *eprev = erow + (size_t)(~j & 1) * 3 * (size_t)cols;
		for (int i = 0; i < cols; i++, n++) {
			const int ls = cls[n] == NDO_NODE_LOSSY;
			double e2 = 0;
			for (int d = 0; d < 3; d++) {
				const double xv = x[3 * n + d];
				double t = (xv - z->lo[d]) / z->q[d] + 0.5;
				int inr = t >= -CODE_MAX + 1 && t < CODE_MAX;
				out |= !inr;
				t = inr ? t : 0;
				int32_t kk = (int32_t)t;
				kk -= (double)kk > t;
				k[3 * n + d] = kk;
				const double val = ls ? z->lo[d] + (double)kk * z->q[d] : xv;
				recon->x[3 * n + d] = val;
				e2 += (val - xv) * (val - xv);
				int64_t lin = 0;
				uint64_t uu = zigzag(kk - fast_predict(c, mode, k, eprev, &lin, n, i, j, d));
				ecur[3 * i + d] = kk - lin; /* used in the two modes that set lin */
				if (ls)
					u[d * lossy + li] = uu;
				acc |= ls ? uu : 0;
			}
			li += (size_t)ls;
			sum2 += e2; /* 0 but for LOSSY nodes */
			max2 = e2 > max2 ? e2 : max2;
		}
	}
	*any = acc;
	err[0] = max2, err[1] = sum2;
	return out ? -1 : 0;
}

static void row_steps(rowsc *rs, const quant *z, size_t L);
static int row_encode_mode_any(const pctx *c, int mode, rowsc *rs, const double *x, size_t xs,
                               ndo_codec_frame *recon, syms *sy, uint64_t *any, double err[2]);


/* The codes, their error statistics, and the residuals into b. */
int ndo__codec_fast_encode(const pctx *c, const quant *z, rowsc *rs, const double *x, size_t xs,
                       ndo_codec_frame *recon, uint64_t *u, size_t lossy, uint64_t *any,
                       double err[2], wbuf *b)
{
	const int mode = fast_mode(c);
	if (mode == M_INTRA) {
		int rc = fast_encode_mode(c, M_INTRA, z, x, recon, u, lossy, any, err); /* xs: cols */
		ndo__codec_put_residuals(b, u, 3 * lossy);
		return rc;
	}
	/* the symbols written in place, the escapes after them */
	const size_t nb = (3 * lossy + 3) / 4;
	if (reserve(b, nb))
		return 0; /* b->fail */
	memset(b->p + b->n, 0, nb);
	syms sy = {.sym = b->p + b->n, .esc = u, .lossy = lossy};
	b->n += nb;
	row_steps(rs, z, 3 * (size_t)c->cols);
	int rc = row_encode_mode_any(c, mode, rs, x, xs, recon, &sy, any, err);
	if (reserve(b, 10 * (sy.ne[0] + sy.ne[1] + sy.ne[2])))
		return 0;
	uint8_t *e = b->p + b->n;
	for (int d = 0; d < 3; d++)
		for (size_t k = 0; k < sy.ne[d]; k++) {
			uint64_t v = u[(size_t)d * lossy + k] - 3;
			for (; v > 127; v >>= 7)
				*e++ = (uint8_t)(v | 128);
			*e++ = (uint8_t)v;
		}
	b->n = (size_t)(e - b->p);
	return rc;
}

static inline __attribute__((always_inline)) int
fast_decode_mode(const pctx *c, const int mode, const quant *z, const uint64_t *u, size_t lossy,
                 ndo_codec_frame *recon, outs *o)
{
	const ndo_codec_frame *prev = o->prev && o->inv > 0 ? o->prev : NULL;
	const double inv = o->inv;
	const size_t S = o->S;
	const int cols = c->cols, rows = c->nodes / cols;
	const uint8_t *cls = c->cls;
	int32_t *k = recon->k;
	size_t li = 0;
	int bad = 0;
	int64_t *erow = c->erow;
	for (int j = 0, n = 0; j < rows; j++) {
		int64_t *ecur = erow + (size_t)(j & 1) * 3 * (size_t)cols,
		        *eprev = erow + (size_t)(~j & 1) * 3 * (size_t)cols;
		for (int i = 0; i < cols; i++, n++) {
			if (cls[n] != NDO_NODE_LOSSY) { /* EXACT: its code is known; its error */
				if (mode == M_CURVED || mode == M_LINEAR)
					for (int d = 0; d < 3; d++)
						ecur[3 * i + d] = k[3 * n + d] - (2 * (int64_t)c->r[0]->k[3 * n + d] -
						                                  c->r[1]->k[3 * n + d]);
				continue;
			}
			const int est = prev && prev->have[n];
			for (int d = 0; d < 3; d++) {
				int64_t lin = 0;
				int64_t kk = fast_predict(c, mode, k, eprev, &lin, n, i, j, d) +
				             unzigzag(u[d * lossy + li]);
				int inr = kk > -CODE_MAX && kk < CODE_MAX;
				bad |= !inr;
				kk = inr ? kk : 0;
				k[3 * n + d] = (int32_t)kk;
				ecur[3 * i + d] = kk - lin;
				const double val = z->lo[d] + (double)kk * z->q[d];
				recon->x[3 * n + d] = val;
				o->x[S * n + d] = val;
				o->v[S * n + d] = est ? (val - frame_pos(z, prev, n, d)) * inv : NAN;
			}
			li++;
		}
	}
	o->done = 1;
	return bad ? -1 : 0;
}

static int row_decode_mode_any(const pctx *c, int mode, rowsc *rs, const syms *sy,
                               ndo_codec_frame *recon, outs *o);

/* A keyframe (u: its residuals), or a predicted frame (sy: its symbols). */
int ndo__codec_fast_decode(const pctx *c, const quant *z, rowsc *rs, const uint64_t *u, size_t lossy,
                       const syms *sy, ndo_codec_frame *recon, outs *o)
{
	const int mode = fast_mode(c);
	if (mode == M_INTRA)
		return fast_decode_mode(c, M_INTRA, z, u, lossy, recon, o);
	row_steps(rs, z, 3 * (size_t)c->cols);
	return row_decode_mode_any(c, mode, rs, sy, recon, o);
}

/* ---- the same, a row at a time -------------------------------------------------- */
/* With references (every mode but M_INTRA) a node's prediction needs the
 * references and the row above only, so a row's 3 × cols values go
 * through one flat loop (no branches: the row above's errors padded with
 * copies of its end values, as fast_predict() substitutes them, or zeros
 * on the first row), and the classes enter after it, node by node.  The
 * same integers as fast_predict(), hence the same bytes. */
/* rdiv(a, b) for 0 < b ≤ NDO_CODEC_MAX_GAP and |a| < 2^62, without a
 * division: rinv = (2^64 − 1) / b, the quotient estimated by a multiply
 * (at most one short) and corrected. */
static inline int64_t rdiv_by(int64_t a, int64_t b, uint64_t rinv)
{
	const uint64_t n = (uint64_t)(a < 0 ? -a : a) + (uint64_t)(b / 2);
	uint64_t q = (uint64_t)(((unsigned __int128)n * rinv) >> 64);
	q += n - q * (uint64_t)b >= (uint64_t)b;
	return a < 0 ? -(int64_t)q : (int64_t)q;
}

/* A mode's references for the row loops: every pointer valid (r0 standing
 * in for an unused one: loops without branches), the steps since r0 (g)
 * and from r1 to r0 (gap: more than 1 after skipped steps), and the gap's
 * reciprocal for rdiv_by(). */
typedef struct refs {
	const int32_t *r0, *r1, *r2;
	int64_t g, gap;
	uint64_t rinv;
} refs;

static inline __attribute__((always_inline)) refs refs_of(const pctx *c, const int mode)
{
	refs R;
	R.r0 = c->r[0]->k;
	R.r1 = mode != M_COPY ? c->r[1]->k : R.r0;
	R.r2 = mode == M_CURVED ? c->r[2]->k : R.r0;
	R.g = c->step - c->r[0]->step;
	R.gap = mode == M_GAP ? c->r[0]->step - c->r[1]->step : 1;
	R.rinv = UINT64_MAX / (uint64_t)R.gap;
	return R;
}

static inline __attribute__((always_inline)) int64_t
row_predict(const int mode, int64_t a, int64_t b, int64_t cc, const int64_t *ep, int64_t *lin,
            const refs *R)
{
	if (mode == M_COPY)
		return a;
	if (mode == M_CURVED || mode == M_LINEAR) {
		int64_t corr = mode == M_CURVED ? a - 2 * b + cc : 0;
		corr += clamp3(ep[0], ep[-3], ep[3]);
		*lin = 2 * a - b;
		return *lin + half(corr);
	}
	if (R->gap == 1)
		return a + (a - b) * R->g;
	return a + rdiv_by((a - b) * R->g, R->gap, R->rinv);
}

/* The decoder's codes of a row: each prediction plus its residual uu
 * (zigzagged), and the linear part of the prediction (lins). */
static inline __attribute__((always_inline)) void
row_codes(const int mode, size_t L, const int32_t *restrict ar, const int32_t *restrict br,
          const int32_t *restrict cr, const int64_t *restrict ep, const uint64_t *restrict uu,
          int64_t *restrict kt, int64_t *restrict lins, const refs *R)
{
	for (size_t m = 0; m < L; m++) {
		int64_t lin = 0;
		const int64_t pr = row_predict(mode, ar[m], br[m], cr[m], ep + m, &lin, R);
		kt[m] = pr + unzigzag(uu[m]);
		lins[m] = lin;
	}
}

static void row_pad(int64_t *e, size_t L)
{
	for (int d = 0; d < 3; d++)
		e[d - 3] = e[d], e[L + (size_t)d] = e[L - 3 + (size_t)d];
}

static void row_steps(rowsc *rs, const quant *z, size_t L)
{
	for (size_t m = 0; m < L; m++)
		rs->lo[m] = z->lo[m % 3], rs->q[m] = z->q[m % 3];
}

static inline __attribute__((always_inline)) int
row_encode_mode(const pctx *c, const int mode, rowsc *rs, const double *x, size_t xs,
                ndo_codec_frame *recon, syms *sy, uint64_t *any, double err[2])
{
	const size_t lossy = sy->lossy;
	uint8_t *restrict sb = sy->sym;
	uint64_t *restrict esc = sy->esc;
	size_t ne0 = 0, ne1 = 0, ne2 = 0;
	const int cols = c->cols, rows = c->nodes / cols;
	const size_t L = 3 * (size_t)cols;
	const uint8_t *cls = c->cls;
	const refs R = refs_of(c, mode);
	const double *restrict LO = rs->lo, *restrict Q = rs->q;
	double *restrict sq = rs->sq;
	uint64_t *restrict uu = rs->uu;
	double max2 = 0, sum2 = 0;
	int out = 0;
	uint64_t acc = 0;
	size_t li = 0;
	const int flat = lossy == (size_t)c->nodes; /* every node LOSSY */
	for (int j = 0; j < rows; j++) {
		const size_t M0 = (size_t)j * L;
		const int64_t *restrict ep = j ? rs->e[~j & 1] : rs->ez;
		int64_t *restrict ec = rs->e[j & 1];
		const double *restrict xr = x + 3 * (size_t)j * xs;
		int32_t *restrict kr = recon->k + M0;
		double *restrict xo = recon->x + M0;
		const int32_t *ar = R.r0 + M0, *br = R.r1 + M0, *cr = R.r2 + M0;
		for (size_t m = 0; m < L; m++) { /* the codes (code_of()) */
			const double xv = xr[m];
			double t = (xv - LO[m]) / Q[m] + 0.5;
			int inr = (t >= -CODE_MAX + 1) & (t < CODE_MAX);
			out |= !inr;
			uint64_t tb = bits_of(t) & -(uint64_t)inr; /* t, or 0 out of range: a */
			t = double_of(tb);                        /* select that vectorizes */
			int32_t kk = (int32_t)t;
			kk -= (double)kk > t;
			kr[m] = kk;
			const double val = LO[m] + (double)kk * Q[m];
			sq[m] = (val - xv) * (val - xv);
		}
		for (size_t m = 0; m < L; m++) { /* their prediction */
			const int64_t kk = kr[m];
			int64_t lin = 0;
			const int64_t pr = row_predict(mode, ar[m], br[m], cr[m], ep + m,
			                               &lin, &R);
			ec[m] = kk - lin;
			uu[m] = zigzag(kk - pr);
		}
		row_pad(ec, L);
		if (flat) { /* every node LOSSY: the same, component by component */
			for (int i = 0; i < cols; i++) {
				const size_t m = 3 * (size_t)i;
				const double e2 = sq[m] + sq[m + 1] + sq[m + 2];
				sum2 += e2;
				max2 = e2 > max2 ? e2 : max2;
			}
			uint64_t a = 0;
			for (size_t m = 0; m < L; m++)
				a |= uu[m];
			acc |= a;
			size_t nn[3] = {ne0, ne1, ne2};
			for (int d = 0; d < 3; d++) {
				const size_t k0 = (size_t)d * lossy + li;
				uint64_t *restrict ed = esc + (size_t)d * lossy;
				size_t ne = nn[d];
				const uint64_t *ud = uu + d;
				int i = 0;
				/* the symbols up to a byte boundary OR'ed in, then whole
				 * bytes stored (no read-modify-write chain), the rest OR'ed */
				for (; i < cols && ((k0 + (size_t)i) & 3); i++) {
					const size_t k = k0 + (size_t)i;
					const uint64_t v = ud[3 * (size_t)i];
					sb[k >> 2] |= (uint8_t)((v < 3 ? v : 3) << (2 * (k & 3)));
					ed[ne] = v, ne += v >= 3;
				}
				for (; i + 4 <= cols; i += 4) {
					unsigned byte = 0;
					for (int t = 0; t < 4; t++) {
						const uint64_t v = ud[3 * (size_t)(i + t)];
						byte |= (unsigned)(v < 3 ? v : 3) << (2 * t);
						ed[ne] = v, ne += v >= 3;
					}
					sb[(k0 + (size_t)i) >> 2] = (uint8_t)byte;
				}
				for (; i < cols; i++) {
					const size_t k = k0 + (size_t)i;
					const uint64_t v = ud[3 * (size_t)i];
					sb[k >> 2] |= (uint8_t)((v < 3 ? v : 3) << (2 * (k & 3)));
					ed[ne] = v, ne += v >= 3;
				}
				nn[d] = ne;
			}
			ne0 = nn[0], ne1 = nn[1], ne2 = nn[2];
			li += (size_t)cols;
			continue;
		}
		const uint8_t *cl = cls + (size_t)j * (size_t)cols;
		for (int i = 0; i < cols; i++) {
			const size_t m = 3 * (size_t)i;
			if (cl[i] != NDO_NODE_LOSSY) { /* EXACT: its position as it is */
				xo[m] = xr[m], xo[m + 1] = xr[m + 1], xo[m + 2] = xr[m + 2];
				continue;
			}
			const double e2 = sq[m] + sq[m + 1] + sq[m + 2];
			sum2 += e2;
			max2 = e2 > max2 ? e2 : max2;
			const uint64_t v0 = uu[m], v1 = uu[m + 1], v2 = uu[m + 2];
			acc |= v0 | v1 | v2;
			size_t k = li; /* symbols OR'ed into zeroed bytes; escapes stored, counted */
			sb[k >> 2] |= (uint8_t)((v0 < 3 ? v0 : 3) << (2 * (k & 3)));
			esc[ne0] = v0, ne0 += v0 >= 3;
			k += lossy;
			sb[k >> 2] |= (uint8_t)((v1 < 3 ? v1 : 3) << (2 * (k & 3)));
			esc[lossy + ne1] = v1, ne1 += v1 >= 3;
			k += lossy;
			sb[k >> 2] |= (uint8_t)((v2 < 3 ? v2 : 3) << (2 * (k & 3)));
			esc[2 * lossy + ne2] = v2, ne2 += v2 >= 3;
			li++;
		}
	}
	*any = acc;
	err[0] = max2, err[1] = sum2;
	sy->ne[0] = ne0, sy->ne[1] = ne1, sy->ne[2] = ne2;
	return out ? -1 : 0;
}

/* The decoder's codes (out of range: 0, the frame rejected by the caller),
 * their errors, values and velocity estimates, for a row's L values. */
static inline __attribute__((always_inline)) void
row_values(size_t L, const int64_t *restrict kt, const int64_t *restrict lins,
           const double *restrict LO, const double *restrict Q, const int32_t *restrict pk,
           double inv, int32_t *restrict kq, int64_t *restrict ec, double *restrict val,
           double *restrict vv)
{
	for (size_t m = 0; m < L; m++) {
		const int64_t k = kt[m];
		const int64_t kc = k & -(int64_t)((k > -CODE_MAX) & (k < CODE_MAX));
		const int32_t k32 = (int32_t)kc; /* int32 to double: a vector conversion */
		kq[m] = k32;
		ec[m] = kc - lins[m];
		const double vl = LO[m] + (double)k32 * Q[m];
		val[m] = vl;
		vv[m] = (vl - (LO[m] + (double)pk[m] * Q[m])) * inv; /* frame_pos() of a code */
	}
}

static inline __attribute__((always_inline)) int
row_decode_mode(const pctx *c, const int mode, rowsc *rs, const syms *sy,
                ndo_codec_frame *recon, outs *o)
{
	const size_t lossy = sy->lossy;
	const uint8_t *restrict sb = sy->sym;
	const uint64_t *restrict esc = sy->esc;
	size_t e0 = sy->first[0], e1 = sy->first[1], e2 = sy->first[2];
	const ndo_codec_frame *prev = o->prev && o->inv > 0 ? o->prev : NULL;
	const double inv = o->inv;
	const size_t S = o->S;
	const int cols = c->cols, rows = c->nodes / cols;
	const size_t L = 3 * (size_t)cols;
	const uint8_t *cls = c->cls;
	const refs R = refs_of(c, mode);
	const double *restrict LO = rs->lo, *restrict Q = rs->q;
	uint64_t *restrict uu = rs->uu;
	int64_t *restrict lins = rs->lin, *restrict kt = rs->kt;
	size_t li = 0;
	int bad = 0;
	/* flat: every node LOSSY and every previous position a code (the
	 * common case): each row's symbols are three runs, one a component,
	 * and its codes, positions and velocities go out in flat loops */
	int flat = lossy == (size_t)c->nodes && prev;
	if (flat) {
		unsigned f = 1;
		for (int n = 0; n < c->nodes; n++) /* no early exit: vectorized */
			f &= prev->have[n] == NDO_HAVE_CODE;
		flat = (int)f;
	}
	const size_t nsb = (3 * lossy + 3) / 4; /* the symbols' bytes */
	for (int j = 0; j < rows; j++) {
		const size_t M0 = (size_t)j * L, n0 = (size_t)j * (size_t)cols;
		const int64_t *restrict ep = j ? rs->e[~j & 1] : rs->ez;
		int64_t *restrict ec = rs->e[j & 1];
		int32_t *restrict kr = recon->k + M0;
		const int32_t *ar = R.r0 + M0, *br = R.r1 + M0, *cr = R.r2 + M0;
		const uint8_t *cl = cls + n0;
		if (flat) {
			size_t ee[3] = {e0, e1, e2};
			for (int d = 0; d < 3; d++) {
				const size_t k0 = (size_t)d * lossy + n0;
				size_t e = ee[d];
				uint64_t *restrict ud = uu + d;
				int i = 0;
				/* up to 29 symbols from a word read at once, while the
				 * word lies within the symbols' bytes */
				while (i < cols && ((k0 + (size_t)i) >> 2) + 8 <= nsb) {
					const size_t k = k0 + (size_t)i;
					uint64_t wd;
					memcpy(&wd, sb + (k >> 2), 8);
					wd = le64(wd) >> (2 * (k & 3));
					const int n = cols - i < 29 ? cols - i : 29;
					wd &= ((uint64_t)1 << (2 * n)) - 1;
					for (int t = 0; t < n; t++) /* the symbols, then the escapes */
						ud[3 * (size_t)(i + t)] = (wd >> (2 * t)) & 3;
					for (uint64_t em = wd & wd >> 1 & 0x5555555555555555u; em; em &= em - 1)
						ud[3 * (size_t)(i + __builtin_ctzll(em) / 2)] = esc[e++];
					i += n;
				}
				for (; i < cols; i++) {
					const size_t k = k0 + (size_t)i;
					const unsigned s = (sb[k >> 2] >> (2 * (k & 3))) & 3;
					ud[3 * (size_t)i] = s == 3 ? esc[e] : s;
					e += s == 3;
				}
				ee[d] = e;
			}
			e0 = ee[0], e1 = ee[1], e2 = ee[2];
			row_codes(mode, L, ar, br, cr, ep, uu, kt, lins, &R);
			double *val = rs->sq, *vv = rs->vv;
			int32_t *kq = rs->kq;
			row_values(L, kt, lins, LO, Q, prev->k + M0, inv, kq, ec, val, vv);
			int b = 0;
			for (size_t m = 0; m < L; m++) {
				const int64_t k = kt[m];
				b |= (k <= -CODE_MAX) | (k >= CODE_MAX);
				kr[m] = kq[m];
			}
			bad |= b;
			double *ox = o->x + S * n0, *ov = o->v + S * n0;
			if (S == 6 && o->v == o->x + 3) { /* a node's 6 values together */
				for (int i = 0; i < cols; i++) {
					memcpy(ox + 6 * (size_t)i, val + 3 * (size_t)i, 3 * sizeof *val);
					memcpy(ox + 6 * (size_t)i + 3, vv + 3 * (size_t)i, 3 * sizeof *vv);
				}
			} else {
				for (int i = 0; i < cols; i++)
					for (int d = 0; d < 3; d++) {
						ox[S * (size_t)i + (size_t)d] = val[3 * (size_t)i + (size_t)d];
						ov[S * (size_t)i + (size_t)d] = vv[3 * (size_t)i + (size_t)d];
					}
			}
			row_pad(ec, L);
			continue;
		}
		for (int i = 0; i < cols; i++) { /* the row's residuals, node by node */
			const size_t m = 3 * (size_t)i;
			if (cl[i] == NDO_NODE_LOSSY) { /* an escape: the component's next */
				size_t k = li;
				unsigned s = (sb[k >> 2] >> (2 * (k & 3))) & 3;
				uu[m] = s == 3 ? esc[e0] : s, e0 += s == 3;
				k += lossy;
				s = (sb[k >> 2] >> (2 * (k & 3))) & 3;
				uu[m + 1] = s == 3 ? esc[e1] : s, e1 += s == 3;
				k += lossy;
				s = (sb[k >> 2] >> (2 * (k & 3))) & 3;
				uu[m + 2] = s == 3 ? esc[e2] : s, e2 += s == 3;
				li++;
			} else {
				uu[m] = uu[m + 1] = uu[m + 2] = 0;
			}
		}
		row_codes(mode, L, ar, br, cr, ep, uu, kt, lins, &R);
		/* codes (out of range: 0, the frame rejected below), values,
		 * velocity estimates */
		double *val = rs->sq, *vv = rs->vv;
		int32_t *kq = rs->kq;
		row_values(L, kt, lins, LO, Q, prev ? prev->k + M0 : ar, inv, kq, ec, val, vv);
		for (int i = 0; i < cols; i++) {
			const size_t m = 3 * (size_t)i, n = n0 + (size_t)i;
			if (cl[i] != NDO_NODE_LOSSY) { /* EXACT: its code is known; its error */
				for (int d = 0; d < 3; d++)
					ec[m + d] = kr[m + d] - lins[m + d];
				continue;
			}
			const int ph = prev ? prev->have[n] : 0;
			for (int d = 0; d < 3; d++) {
				const int64_t k = kt[m + d];
				bad |= (k <= -CODE_MAX) | (k >= CODE_MAX);
				kr[m + d] = kq[m + d];
				o->x[S * n + d] = val[m + d];
				o->v[S * n + d] = !ph                ? NAN
				                  : ph == NDO_HAVE_X ? (val[m + d] - prev->x[3 * n + d]) * inv
				                                     : vv[m + d];
			}
		}
		row_pad(ec, L);
	}
	o->done = 1;
	return bad ? -1 : 0;
}

/* A loop per mode (the mode constant in each). */
NDO_HOT static int row_encode_mode_any(const pctx *c, int mode, rowsc *rs, const double *x,
                                       size_t xs, ndo_codec_frame *recon, syms *sy,
                                       uint64_t *any, double err[2])
{
	switch (mode) {
	case M_COPY: return row_encode_mode(c, M_COPY, rs, x, xs, recon, sy, any, err);
	case M_CURVED: return row_encode_mode(c, M_CURVED, rs, x, xs, recon, sy, any, err);
	case M_LINEAR: return row_encode_mode(c, M_LINEAR, rs, x, xs, recon, sy, any, err);
	default: return row_encode_mode(c, M_GAP, rs, x, xs, recon, sy, any, err);
	}
}

NDO_HOT static int row_decode_mode_any(const pctx *c, int mode, rowsc *rs, const syms *sy,
                                       ndo_codec_frame *recon, outs *o)
{
	switch (mode) {
	case M_COPY: return row_decode_mode(c, M_COPY, rs, sy, recon, o);
	case M_CURVED: return row_decode_mode(c, M_CURVED, rs, sy, recon, o);
	case M_LINEAR: return row_decode_mode(c, M_LINEAR, rs, sy, recon, o);
	default: return row_decode_mode(c, M_GAP, rs, sy, recon, o);
	}
}
