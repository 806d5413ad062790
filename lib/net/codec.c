/* codec.c — the state codec's payload (ndo/codec.h): the workspace, and a
 * tile's frame encoded and decoded — the header, the classes, the EXACT
 * nodes, the LOSSY nodes through the predictor.  Its parts are in
 * codec_params.c, codec_predict.c, codec_rows.c and codec_entropy.c
 * (codec_private.h).  Pure functions: all state is the caller's. */
#include "codec_private.h"
#include "ndo/status.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zstd.h>

/* ---- workspace ---------------------------------------------------------------- */
ndo_codec_work *ndo_codec_work_create(void)
{
	ndo_codec_work *w = calloc(1, sizeof *w);
	if (!w)
		return NULL;
	w->cc = ZSTD_createCCtx();
	w->dc = ZSTD_createDCtx();
	if (!w->cc || !w->dc) {
		ndo_codec_work_destroy(w);
		return NULL;
	}
	return w;
}

void ndo_codec_work_destroy(ndo_codec_work *w)
{
	if (!w)
		return;
	ZSTD_freeCCtx(w->cc);
	ZSTD_freeDCtx(w->dc);
	free(w->buf), free(w->buf2), free(w->cur), free(w->u), free(w->erow), free(w->row), free(w->xg);
	free(w->ht), free(w->hmag);
	free(w);
}

void ndo_codec_work_error(const ndo_codec_work *w, double *max2, double *sum2, size_t *count)
{
	*max2 = w->err_max2, *sum2 = w->err_sum2, *count = w->err_n;
}

static int work_nodes(ndo_codec_work *w, size_t nodes)
{
	if (nodes <= w->ecap)
		return 0;
	int32_t *cur = realloc(w->cur, nodes * sizeof *cur);
	if (!cur)
		return -1;
	w->cur = cur;
	uint64_t *u = realloc(w->u, (3 * nodes + 4) * sizeof *u); /* + 4: row_decode_mode() */
	if (!u)
		return -1;
	w->u = u;
	int64_t *er = realloc(w->erow, 6 * nodes * sizeof *er);
	if (!er)
		return -1;
	w->erow = er;
	int64_t *ht = realloc(w->ht, HIER_SCRATCH * nodes * sizeof *ht);
	if (!ht)
		return -1;
	w->ht = ht;
	uint8_t *hm = realloc(w->hmag, 3 * nodes);
	if (!hm)
		return -1;
	w->hmag = hm;
	w->ecap = nodes;
	return 0;
}

static int row_scratch(ndo_codec_work *w, int cols, rowsc *rs)
{
	const size_t L = 3 * (size_t)cols, E = L + 6, need = (3 * E + 8 * L) * 8;
	if (need > w->rowcap) {
		void *b = realloc(w->row, need);
		if (!b)
			return -1;
		w->row = b;
		w->rowcap = need;
	}
	int64_t *p = w->row;
	rs->e[0] = p + 3, rs->e[1] = p + E + 3, rs->ez = p + 2 * E + 3;
	memset(p + 2 * E, 0, E * sizeof *p);
	p += 3 * E;
	rs->lin = p, rs->kt = p + L, rs->uu = (uint64_t *)(p + 2 * L);
	rs->lo = (double *)(p + 3 * L), rs->q = (double *)(p + 4 * L), rs->sq = (double *)(p + 5 * L);
	rs->vv = (double *)(p + 6 * L), rs->kq = (int32_t *)(p + 7 * L);
	return 0;
}

/* ---- EXACT nodes under predict -------------------------------------------------- */
/* Their doubles travel losslessly, the positions not as they are: each
 * XOR its extrapolation from the references' positions, the 3E words as
 * byte planes (codec_entropy.c); then the velocities as they are (predicted
 * from the positions, or as planes, they saved under 2 % of the bits,
 * measured).  Double arithmetic without fused operations (C11 mode): the
 * same on every machine. */

static double pred_position(const quant *z, const ndo_codec_frame *r0,
                            const ndo_codec_frame *r1, int n, int d, double now)
{
	if (!r0 || !r0->have[n])
		return 0;
	double x0 = frame_pos(z, r0, n, d), p = x0;
	if (r1 && r1->have[n] && r0->time > r1->time)
		p = x0 + (x0 - frame_pos(z, r1, n, d)) * ((now - r0->time) / (r0->time - r1->time));
	return isfinite(p) ? p : 0;
}

/* ---- the body ------------------------------------------------------------------- */
/* A frame's have[] from its classes (cls[n] ≤ NDO_NODE_EXACT) and the count
 * of each class, in one pass. */
NDO_HOT static void class_pass(const uint8_t *restrict cls, int nodes, int enc,
                               uint8_t *restrict have, size_t cnt[3])
{
	const uint8_t lossy = enc == NDO_ENC_FLOAT32 ? NDO_HAVE_X : NDO_HAVE_CODE;
	unsigned c1 = 0, c2 = 0;
	for (int n = 0; n < nodes; n++) {
		const uint8_t c = cls[n];
		have[n] = c == NDO_NODE_LOSSY ? lossy : c == NDO_NODE_EXACT ? NDO_HAVE_X : 0;
		c1 += c == NDO_NODE_LOSSY;
		c2 += c == NDO_NODE_EXACT;
	}
	cnt[0] = (size_t)nodes - c1 - c2, cnt[1] = c1, cnt[2] = c2;
}

/* Every node of a frame NDO_HAVE_CODE (its position its code). */
NDO_HOT static int codes_all(const uint8_t *restrict have, int nodes)
{
	unsigned other = 0;
	for (int n = 0; n < nodes; n++)
		other |= have[n] ^ NDO_HAVE_CODE;
	return !other;
}

/* The decoder's output of a hier tile whose every node is LOSSY: the
 * positions from the codes k, the velocities from the previous frame's
 * codes kp (every node NDO_HAVE_CODE; NULL: none, NAN) times inv —
 * ndo_codec_decode_strided()'s loop over the nodes without its branches,
 * the same operations (no fused ones: the same doubles). */
NDO_HOT static void hier_out(const quant *z, const int32_t *restrict k,
                             const int32_t *restrict kp, double inv, int nodes,
                             double *restrict x, double *restrict v, size_t S)
{
	const double l0 = z->lo[0], l1 = z->lo[1], l2 = z->lo[2];
	const double q0 = z->q[0], q1 = z->q[1], q2 = z->q[2];
	for (int n = 0; n < nodes; n++) {
		const int32_t *kn = k + 3 * (size_t)n;
		double *xn = x + S * (size_t)n, *vn = v + S * (size_t)n;
		const double a = l0 + (double)kn[0] * q0, b = l1 + (double)kn[1] * q1,
		             c = l2 + (double)kn[2] * q2;
		xn[0] = a, xn[1] = b, xn[2] = c;
		if (!kp) {
			vn[0] = vn[1] = vn[2] = NAN;
			continue;
		}
		const int32_t *pn = kp + 3 * (size_t)n;
		vn[0] = (a - (l0 + (double)pn[0] * q0)) * inv;
		vn[1] = (b - (l1 + (double)pn[1] * q1)) * inv;
		vn[2] = (c - (l2 + (double)pn[2] * q2)) * inv;
	}
}

/* hier's encoder, a tile whose every node is LOSSY: whether a position
 * is NaN, infinite or far from the codes' range (ndo_codec_encode()'s
 * test, node by node, without branches). */
NDO_HOT static int hier_far(const quant *z, const double *restrict X, int nodes)
{
	const double l0 = z->lo[0], l1 = z->lo[1], l2 = z->lo[2];
	const double i0 = 1 / z->q[0], i1 = 1 / z->q[1], i2 = 1 / z->q[2], M = CODE_MAX / 2;
	unsigned far = 0;
	for (int n = 0; n < nodes; n++) {
		const double *xn = X + 3 * (size_t)n;
		const double a = (xn[0] - l0) * i0, b = (xn[1] - l1) * i1, c = (xn[2] - l2) * i2;
		far |= !(a > -M && a < M) | !(b > -M && b < M) | !(c > -M && c < M);
	}
	return far != 0;
}

/* hier's encoder, a tile whose every node is LOSSY: the largest and the
 * sum of the squared errors of the codes k against the positions X
 * (ndo_codec_encode()'s loop over the nodes without its branches: each
 * node's error in runs the compiler vectorizes, then summed in node order,
 * the same doubles). */
NDO_HOT static void hier_err(const quant *z, const int32_t *restrict k, const double *restrict X,
                             int nodes, double *max2, double *sum2)
{
	const double l0 = z->lo[0], l1 = z->lo[1], l2 = z->lo[2];
	const double q0 = z->q[0], q1 = z->q[1], q2 = z->q[2];
	double m = 0, s = 0, e2[256];
	for (int n0 = 0; n0 < nodes; n0 += 256) {
		const int cnt = nodes - n0 < 256 ? nodes - n0 : 256;
		const int32_t *kn = k + 3 * (size_t)n0;
		const double *xn = X + 3 * (size_t)n0;
		for (int i = 0; i < cnt; i++) {
			const double a = l0 + (double)kn[3 * i] * q0 - xn[3 * i],
			             b = l1 + (double)kn[3 * i + 1] * q1 - xn[3 * i + 1],
			             c = l2 + (double)kn[3 * i + 2] * q2 - xn[3 * i + 2];
			e2[i] = a * a + b * b + c * c;
		}
		for (int i = 0; i < cnt; i++)
			s += e2[i], m = e2[i] > m ? e2[i] : m;
	}
	*max2 = m, *sum2 = s;
}

/* The largest body a tile of `nodes` can have (bomb check). */
static size_t body_bound(int nodes)
{
	return (size_t)nodes * (2 * 11 + 48 + 3 * 11) + 64;
}

int ndo_codec_encode(const ndo_codec_params *p, ndo_codec_work *w, const ndo_codec_hist *h,
                     int intra, const ndo_codec_input *in, uint8_t **data, size_t *len,
                     int64_t *base_step, ndo_codec_frame *recon, int *unchanged)
{
	int own_w = !w;
	if (own_w && !(w = ndo_codec_work_create()))
		return ndo__fail(NDO_ENOMEM, "out of memory");
	const int nodes = in->rows * in->cols, enc = p->encoding;
	const quant z = ndo__codec_quant_of(p);
	int rc = 0, ok = 1, allzero = 1, nexact = 0, errors_known = 0;
	*data = NULL;
	*len = 0;
	*unchanged = 0;
	*base_step = -1;
	wbuf body = {0}, out = {0}, rcs = {0}, part = {0};
	/* references */
	const ndo_codec_frame *r[3] = {0};
	if (enc >= NDO_ENC_PREDICT && !intra && h)
		for (int k = 0, m = 0; k < NDO_CODEC_HISTORY && m < 3; k++)
			if (h->f[k].step >= 0 && h->f[k].step < in->step && h->f[k].epoch == in->epoch &&
			    in->step - h->f[k].step <= NDO_CODEC_MAX_GAP)
				r[m++] = &h->f[k];
	uint8_t flags = r[0] ? KIND_PRED : KIND_INTRA;
	if (intra == 2)
		flags |= F_NOREF;
	recon->step = in->step;
	recon->time = in->time;
	recon->epoch = in->epoch;
	if (work_nodes(w, (size_t)nodes)) {
		rc = ndo__fail(NDO_ENOMEM, "out of memory");
		goto done;
	}
	pctx pc = {.cols = in->cols, .nodes = nodes, .cls = in->cls, .erow = w->erow};
	ndo__codec_pctx_init(&pc, r[0], r[1], r[2], in->step);
	const int fast = enc == NDO_ENC_PREDICT && ndo__codec_uniform(&pc);
	/* positions: rows in place (stride), or gathered contiguous for every
	 * loop but the row loops'; velocities in place (only the EXACT nodes'
	 * are read: gathered with the positions, they were a third of hier's
	 * time outside codec_hier.c at level 7) */
	const double *X = in->x, *V = in->v;
	size_t XS = in->stride > 0 ? (size_t)in->stride : (size_t)in->cols;
	const size_t VS = XS;
	if (XS != (size_t)in->cols && !(fast && fast_mode(&pc) != M_INTRA)) {
		const size_t need = 3 * (size_t)nodes * sizeof *w->xg;
		if (need > w->xgcap) {
			double *g = realloc(w->xg, need);
			if (!g) {
				rc = ndo__fail(NDO_ENOMEM, "out of memory");
				goto done;
			}
			w->xg = g, w->xgcap = need;
		}
		for (int j = 0; j < in->rows; j++)
			memcpy(w->xg + 3 * (size_t)j * in->cols, in->x + 3 * (size_t)j * XS,
			       3 * (size_t)in->cols * sizeof *X);
		X = w->xg, XS = (size_t)in->cols;
	}
	size_t cnt[3];
	class_pass(in->cls, nodes, enc, recon->have, cnt);
	const size_t lossy = cnt[1];
	if (in->cls[0] <= NDO_NODE_EXACT && cnt[in->cls[0]] == (size_t)nodes) { /* one run */
		put_byte(&body, in->cls[0]);
		put_varint(&body, (uint64_t)nodes);
	} else {
		ndo__codec_put_classes(&body, in->cls, nodes);
	}
	size_t nw = 0; /* EXACT words under predict */
	for (int n = 0; n < nodes && cnt[2]; n++) {
		if (in->cls[n] != NDO_NODE_EXACT)
			continue;
		nexact++;
		const double *xn = X + 3 * ((size_t)(n / in->cols) * XS + (size_t)(n % in->cols)),
		             *vn = V + 3 * ((size_t)(n / in->cols) * VS + (size_t)(n % in->cols));
		for (int d = 0; d < 3; d++) {
			if (!isfinite(xn[d]) || !isfinite(vn[d]))
				ok = 0;
			recon->x[3 * n + d] = xn[d];
		}
		if (enc >= NDO_ENC_PREDICT) {
			for (int d = 0; d < 3; d++)
				w->u[nw++] = bits_of(xn[d]) ^
				             bits_of(pred_position(&z, r[0], r[1], n, d, in->time));
			continue;
		}
		for (int d = 0; d < 3; d++)
			put_f64(&body, xn[d]);
		for (int d = 0; d < 3; d++)
			put_f64(&body, vn[d]);
	}
	if (nw) {
		ndo__codec_put_planes(&body, w->u, nw);
		for (int n = 0; n < nodes; n++) /* velocities as they are */
			if (in->cls[n] == NDO_NODE_EXACT)
				for (int d = 0; d < 3; d++)
					put_f64(&body, V[3 * ((size_t)(n / in->cols) * VS +
					                      (size_t)(n % in->cols)) + (size_t)d]);
	}
	if (enc == NDO_ENC_FLOAT32) {
		for (int n = 0; n < nodes; n++)
			if (in->cls[n] == NDO_NODE_LOSSY)
				for (int d = 0; d < 3; d++) {
					float f = (float)X[3 * n + d];
					if (!isfinite(f))
						ok = 0;
					uint32_t u;
					memcpy(&u, &f, 4);
					uint8_t t[4] = {(uint8_t)u, (uint8_t)(u >> 8), (uint8_t)(u >> 16),
					                (uint8_t)(u >> 24)};
					put(&body, t, 4);
					recon->x[3 * n + d] = f;
				}
	} else if (fast) {
		uint64_t any;
		double err[2];
		rowsc rs;
		if (row_scratch(w, in->cols, &rs)) {
			rc = ndo__fail(NDO_ENOMEM, "out of memory");
			goto done;
		}
		if (ndo__codec_fast_encode(&pc, &z, &rs, X, XS, recon, w->u, lossy, &any, err, &body))
			ok = 0;
		w->err_max2 = err[0], w->err_sum2 = err[1], w->err_n = lossy;
		errors_known = 1;
		allzero = any == 0;
	} else {
		/* codes of every carried node (the others' are not used) and the
		 * LOSSY nodes' values: code_of() and value_of() without branches;
		 * under hier, which chooses the LOSSY nodes' codes itself, only
		 * their range: by a product, well inside the range or past it
		 * (NaN) checked again as code_of() does (its division) */
		int out = 0;
		const int hier = enc == NDO_ENC_HIER;
		const double iq[3] = {1 / z.q[0], 1 / z.q[1], 1 / z.q[2]};
		/* every node LOSSY and none far: nothing to check or make */
		const int none = hier && lossy == (size_t)nodes && !hier_far(&z, X, nodes);
		for (int n = 0; n < nodes && !none; n++) {
			const double *xn = X + 3 * n;
			int lossy = in->cls[n] == NDO_NODE_LOSSY;
			if (hier && lossy) {
				int far = 0;
				for (int d = 0; d < 3; d++) {
					const double u = (xn[d] - z.lo[d]) * iq[d];
					far |= !(u > -CODE_MAX / 2 && u < CODE_MAX / 2);
				}
				for (int d = 0; d < 3 && far; d++) {
					const double t = (xn[d] - z.lo[d]) / z.q[d] + 0.5;
					out |= !(t >= -CODE_MAX + 1 && t < CODE_MAX) & (recon->have[n] != 0);
				}
				continue;
			}
			for (int d = 0; d < 3; d++) {
				double t = (xn[d] - z.lo[d]) / z.q[d] + 0.5;
				int inr = t >= -CODE_MAX + 1 && t < CODE_MAX;
				out |= (!inr) & (recon->have[n] != 0);
				t = inr ? t : 0;
				int32_t k = (int32_t)t;
				k -= (double)k > t;
				recon->k[3 * n + d] = k;
				double val = z.lo[d] + (double)k * z.q[d];
				recon->x[3 * n + d] = lossy ? val : xn[d];
			}
		}
		if (out)
			ok = 0;
	}
	if (!ok) {
		rc = ndo__fail(NDO_ERANGE, "a position out of the codes' range");
		goto done;
	}
	if (enc == NDO_ENC_HIER) {
		/* the LOSSY codes are the coder's choice within the bound */
		hcodes hc = {in->rows, in->cols, in->cls, {r[0], r[1], r[2]}, in->step};
		uint64_t any;
		const double t0 = ndo__codec_hier_times ? ndo__now_ms() : 0;
		int he = ndo__codec_hier_encode(&hc, &z, ndo_codec_max_error(p), X, recon->k, w->ht,
		                                w->hmag, &any, &rcs);
		if (ndo__codec_hier_times)
			ndo__codec_hier_times->whole[0] += ndo__now_ms() - t0;
		if (he) {
			rc = he == -2 ? ndo__fail(NDO_ERANGE, "a position out of the codes' range")
			              : ndo__fail(NDO_ENOMEM, "out of memory");
			goto done;
		}
		allzero = any == 0;
	}
	if (!errors_known) { /* the error this frame introduces (hier: the LOSSY
	                      * nodes' values from its codes, not kept: a node
	                      * NDO_HAVE_CODE has no x, ndo/codec.h) */
		double max2 = 0, sum2 = 0;
		const int all_hier = enc == NDO_ENC_HIER && lossy == (size_t)nodes;
		if (all_hier)
			hier_err(&z, recon->k, X, nodes, &max2, &sum2);
		for (int n = 0; n < nodes && !all_hier; n++) {
			if (in->cls[n] != NDO_NODE_LOSSY)
				continue;
			double e2 = 0;
			for (int d = 0; d < 3; d++) {
				double e = (enc == NDO_ENC_HIER ? value_of(&z, d, recon->k[3 * n + d])
				                                : recon->x[3 * n + d]) -
				           X[3 * n + d];
				e2 += e * e;
			}
			sum2 += e2;
			max2 = e2 > max2 ? e2 : max2;
		}
		w->err_max2 = max2, w->err_sum2 = sum2, w->err_n = lossy;
	}
	if (enc == NDO_ENC_FIXED) {
		/* bits+2 wide, offset by 2^bits: the box and its extent on each side */
		int cb = ndo__codec_code_bits(p, &z), width = cb + 2;
		int64_t off = (int64_t)1 << cb, top = (int64_t)1 << width;
		int wide = 0;
		for (int n = 0; n < nodes && !wide; n++)
			if (in->cls[n] == NDO_NODE_LOSSY)
				for (int d = 0; d < 3; d++) {
					int64_t v = (int64_t)recon->k[3 * n + d] + off;
					wide |= v < 0 || v >= top;
				}
		if (wide) {
			flags |= F_WIDE;
			for (int n = 0; n < nodes; n++)
				if (in->cls[n] == NDO_NODE_LOSSY)
					for (int d = 0; d < 3; d++) {
						uint32_t u = (uint32_t)recon->k[3 * n + d];
						uint8_t t[4] = {(uint8_t)u, (uint8_t)(u >> 8), (uint8_t)(u >> 16),
						                (uint8_t)(u >> 24)};
						put(&body, t, 4);
					}
		} else {
			uint64_t acc = 0;
			int nb = 0;
			for (int n = 0; n < nodes; n++)
				if (in->cls[n] == NDO_NODE_LOSSY)
					for (int d = 0; d < 3; d++) {
						acc |= (uint64_t)(recon->k[3 * n + d] + off) << nb;
						nb += width;
						while (nb >= 8) {
							put_byte(&body, (uint8_t)acc);
							acc >>= 8;
							nb -= 8;
						}
					}
			if (nb > 0)
				put_byte(&body, (uint8_t)acc);
		}
	} else if (enc == NDO_ENC_PREDICT && !fast) {
		pctx c = pc;
		int32_t *cur = w->cur;
		c.cur = cur;
		size_t m = 0;
		for (int d = 0; d < 3; d++) {
			for (int n = 0; n < nodes; n++)
				cur[n] = recon->k[3 * n + d];
			for (int n = 0; n < nodes; n++)
				if (in->cls[n] == NDO_NODE_LOSSY)
					w->u[m++] = zigzag(cur[n] - ndo__codec_predict(&c, n, d));
		}
		uint64_t any = 0;
		for (size_t k = 0; k < m; k++)
			any |= w->u[k];
		allzero = any == 0;
		ndo__codec_put_residuals(&body, w->u, m);
	}
	if (body.fail) {
		rc = ndo__fail(NDO_ENOMEM, "out of memory");
		goto done;
	}
	/* the header and the body, compressed when it pays */
	put_byte(&out, flags);
	if (r[0]) {
		put_varint(&out, r[1] ? (uint64_t)(r[0]->step - r[1]->step) : 0);
		put_varint(&out, r[1] && r[2] ? (uint64_t)(r[1]->step - r[2]->step) : 0);
		*base_step = r[0]->step;
	}
	if (enc == NDO_ENC_HIER) {
		/* the classes and EXACT nodes (zstd when shorter) after their
		 * length, then the range coder's bytes */
		put_byte(&part, 0);
		if (ndo__codec_zstd_put(w, &part, &body)) {
			rc = ndo__fail(NDO_ENOMEM, "out of memory");
			goto done;
		}
		out.p[0] |= part.p[0] & F_ZSTD;
		put_varint(&out, (uint64_t)(part.n - 1));
		put(&out, part.p + 1, part.n - 1);
		put(&out, rcs.p, rcs.n);
	} else if (enc == NDO_ENC_PREDICT) {
		if (ndo__codec_zstd_put(w, &out, &body)) {
			rc = ndo__fail(NDO_ENOMEM, "out of memory");
			goto done;
		}
	} else {
		put(&out, body.p, body.n);
	}
	if (out.fail) {
		rc = ndo__fail(NDO_ENOMEM, "out of memory");
		goto done;
	}
	*unchanged = r[0] && allzero && nexact == 0;
	*data = out.p;
	*len = out.n;
	out.p = NULL;
done:
	free(body.p);
	free(out.p);
	free(rcs.p), free(part.p);
	if (own_w)
		ndo_codec_work_destroy(w);
	return rc;
}

/* Decode the LOSSY positions of the body (after the exact nodes). */
static int decode_lossy(const ndo_codec_params *p, ndo_codec_work *w, rbuf *r, uint8_t flags,
                        const uint8_t *cls, size_t lossy, int rows, int cols,
                        const ndo_codec_frame *ref[3], int64_t step, ndo_codec_frame *recon,
                        outs *o)
{
	const int nodes = rows * cols, enc = p->encoding;
	const quant z = ndo__codec_quant_of(p);
	if (enc == NDO_ENC_FLOAT32) {
		for (int n = 0; n < nodes; n++)
			if (cls[n] == NDO_NODE_LOSSY)
				for (int d = 0; d < 3; d++) {
					if (r->n - r->pos < 4)
						return -1;
					const uint8_t *t = r->p + r->pos;
					uint32_t u = t[0] | (uint32_t)t[1] << 8 | (uint32_t)t[2] << 16 |
					             (uint32_t)t[3] << 24;
					r->pos += 4;
					float f;
					memcpy(&f, &u, 4);
					if (!isfinite(f))
						return -1;
					recon->x[3 * n + d] = f;
				}
		return 0;
	}
	if (enc == NDO_ENC_FIXED) {
		int cb = ndo__codec_code_bits(p, &z), width = cb + 2;
		int64_t off = (int64_t)1 << cb;
		uint64_t acc = 0;
		int nb = 0;
		for (int n = 0; n < nodes; n++)
			if (cls[n] == NDO_NODE_LOSSY)
				for (int d = 0; d < 3; d++) {
					int64_t k;
					if (flags & F_WIDE) {
						if (r->n - r->pos < 4)
							return -1;
						const uint8_t *t = r->p + r->pos;
						k = (int32_t)(t[0] | (uint32_t)t[1] << 8 | (uint32_t)t[2] << 16 |
						              (uint32_t)t[3] << 24);
						r->pos += 4;
						if (k <= -CODE_MAX || k >= CODE_MAX)
							return -1;
					} else {
						while (nb < width) {
							if (r->pos >= r->n)
								return -1;
							acc |= (uint64_t)r->p[r->pos++] << nb;
							nb += 8;
						}
						k = (int64_t)(acc & (((uint64_t)1 << width) - 1)) - off;
						acc >>= width;
						nb -= width;
					}
					recon->k[3 * n + d] = (int32_t)k;
					recon->x[3 * n + d] = value_of(&z, d, k);
				}
		return 0;
	}
	/* predict */
	pctx c = {.cols = cols, .nodes = nodes, .cls = cls, .erow = w->erow};
	ndo__codec_pctx_init(&c, ref[0], ref[1], ref[2], step);
	int32_t *cur = w->cur;
	c.cur = cur;
	size_t m = 0;
	if (ndo__codec_uniform(&c)) {
		rowsc rs;
		syms sy;
		if (row_scratch(w, cols, &rs))
			return -2;
		if (fast_mode(&c) == M_INTRA ? ndo__codec_get_residuals(r, w->u, 3 * lossy)
		                             : ndo__codec_get_symbols(r, lossy, w->u, &sy))
			return -1;
		return ndo__codec_fast_decode(&c, &z, &rs, w->u, lossy, &sy, recon, o);
	}
	if (ndo__codec_get_residuals(r, w->u, 3 * lossy))
		return -1;
	for (int d = 0; d < 3; d++) {
		for (int n = 0; n < nodes; n++)
			cur[n] = recon->k[3 * n + d]; /* exact nodes' codes */
		for (int n = 0; n < nodes; n++)
			if (cls[n] == NDO_NODE_LOSSY) {
				int64_t k = ndo__codec_predict(&c, n, d) + unzigzag(w->u[m++]);
				if (k <= -CODE_MAX || k >= CODE_MAX)
					return -1;
				cur[n] = (int32_t)k;
			}
		const double lo = z.lo[d], q = z.q[d];
		for (int n = 0; n < nodes; n++)
			if (cls[n] == NDO_NODE_LOSSY) {
				recon->k[3 * n + d] = cur[n];
				recon->x[3 * n + d] = lo + (double)cur[n] * q;
			}
	}
	return 0;
}

ndo_drop ndo_codec_decode_strided(const ndo_codec_params *p, ndo_codec_work *w,
                                  const ndo_codec_hist *h, int rows, int cols,
                                  const uint8_t *data, size_t len, int64_t step, double time,
                                  int32_t epoch, int64_t base_step, double *x, double *v,
                                  int stride, ndo_codec_frame *recon)
{
	const size_t S = (size_t)stride;
	const int nodes = rows * cols, enc = p->encoding;
	const quant z = ndo__codec_quant_of(p);
	if (enc <= NDO_ENC_RAW || enc > NDO_ENC_HIER || nodes <= 0)
		return NDO_DROP_ENCODING;
	if (!data || len < 1)
		return NDO_DROP_CORRUPT;
	int own_w = !w;
	if (own_w && !(w = ndo_codec_work_create()))
		return NDO_DROP_RANGE;
	ndo_drop res = NDO_DROP_NONE;
	uint8_t *cls = NULL, flags = 0;
	rbuf r = {data, len, 0, 0};
	flags = data[r.pos++];
	int kind = flags & 3;
	const ndo_codec_frame *ref[3] = {0};
	if ((flags & 0xe0) || kind > KIND_PRED || ((flags & F_ZSTD) && enc < NDO_ENC_PREDICT) ||
	    ((flags & F_WIDE) && enc != NDO_ENC_FIXED) || (kind == KIND_PRED) != (base_step >= 0) ||
	    (kind == KIND_PRED && enc < NDO_ENC_PREDICT) || base_step >= step ||
	    (base_step >= 0 && step - base_step > NDO_CODEC_MAX_GAP)) {
		res = NDO_DROP_CORRUPT;
		goto done;
	}
	if (kind == KIND_PRED) {
		uint64_t g2 = get_varint(&r), g3 = get_varint(&r);
		if (r.bad || g2 > (uint64_t)base_step || (g2 == 0 && g3) ||
		    g3 > (uint64_t)base_step - g2) {
			res = NDO_DROP_CORRUPT;
			goto done;
		}
		ref[0] = ndo_codec_hist_find(h, base_step);
		ref[1] = g2 ? ndo_codec_hist_find(h, base_step - (int64_t)g2) : NULL;
		ref[2] = g3 ? ndo_codec_hist_find(h, base_step - (int64_t)g2 - (int64_t)g3) : NULL;
		if (!ref[0] || (g2 && !ref[1]) || (g3 && !ref[2])) {
			res = NDO_DROP_NOBASE;
			goto done;
		}
		for (int k = 0; k < 3; k++)
			if (ref[k] && ref[k]->epoch != epoch) {
				res = NDO_DROP_NOBASE;
				goto done;
			}
	}
	if (work_nodes(w, (size_t)nodes) || !(cls = malloc((size_t)nodes))) {
		res = NDO_DROP_RANGE;
		goto done;
	}
	rbuf b = {data + r.pos, len - r.pos, 0, 0};
	const uint8_t *rcp = NULL; /* hier: the range coder's bytes */
	size_t rcn = 0;
	if (enc == NDO_ENC_HIER) {
		uint64_t n1 = get_varint(&r);
		if (r.bad || n1 > len - r.pos) {
			res = NDO_DROP_CORRUPT;
			goto done;
		}
		b = (rbuf){data + r.pos, (size_t)n1, 0, 0};
		rcp = data + r.pos + n1, rcn = len - r.pos - (size_t)n1;
	}
	if ((flags & F_ZSTD) && (res = ndo__codec_zstd_get(w, &b, body_bound(nodes))) != NDO_DROP_NONE)
		goto done;
	recon->step = step;
	recon->time = time;
	recon->epoch = epoch;
	if (ndo__codec_get_classes(&b, cls, nodes)) {
		res = NDO_DROP_CORRUPT;
		goto done;
	}
	int ok = 1;
	size_t nw = 0, cnt[3];
	class_pass(cls, nodes, enc, recon->have, cnt);
	const size_t nexact = cnt[2];
	if (enc >= NDO_ENC_PREDICT && nexact && ndo__codec_get_planes(&b, w->u, 3 * nexact)) {
		res = NDO_DROP_CORRUPT;
		goto done;
	}
	for (int n = 0; n < nodes && nexact; n++) {
		if (cls[n] != NDO_NODE_EXACT)
			continue;
		if (enc >= NDO_ENC_PREDICT) {
			for (int d = 0; d < 3; d++)
				x[S * n + d] = recon->x[3 * n + d] =
				    double_of(w->u[nw++] ^ bits_of(pred_position(&z, ref[0], ref[1], n, d, time)));
			for (int d = 0; d < 3; d++)
				v[S * n + d] = get_f64(&b);
		} else {
			for (int d = 0; d < 3; d++)
				x[S * n + d] = recon->x[3 * n + d] = get_f64(&b);
			for (int d = 0; d < 3; d++)
				v[S * n + d] = get_f64(&b);
		}
		for (int d = 0; d < 3; d++) {
			ok &= isfinite(x[S * n + d]) && isfinite(v[S * n + d]);
			if (enc != NDO_ENC_FLOAT32)
				recon->k[3 * n + d] = code_of(&z, d, x[S * n + d], &ok);
		}
		if (b.bad || !ok)
			break;
	}
	if (b.bad || !ok) {
		res = NDO_DROP_CORRUPT;
		goto done;
	}
	/* velocities of LOSSY nodes from the previous frame */
	const ndo_codec_frame *prev = ndo__codec_before(h, step, epoch);
	double dtp = prev ? time - prev->time : 0, inv = dtp > 0 ? 1 / dtp : 0;
	outs o = {x, v, S, prev, inv, 0};
	int dl;
	if (enc == NDO_ENC_HIER) {
		hcodes hc = {rows, cols, cls, {ref[0], ref[1], ref[2]}, step};
		const double t0 = ndo__codec_hier_times ? ndo__now_ms() : 0;
		dl = ndo__codec_hier_decode(&hc, recon->k, w->ht, w->hmag, rcp, rcn);
		if (ndo__codec_hier_times)
			ndo__codec_hier_times->whole[1] += ndo__now_ms() - t0;
		/* the LOSSY nodes' values from their codes: below, with the
		 * output, and not kept (a node NDO_HAVE_CODE has no x, ndo/codec.h) */
	} else {
		dl = decode_lossy(p, w, &b, flags, cls, cnt[1], rows, cols, ref, step, recon, &o);
	}
	if (dl == -2) {
		res = NDO_DROP_RANGE;
		goto done;
	}
	if (dl || b.pos != b.n) {
		res = NDO_DROP_CORRUPT;
		goto done;
	}
	/* positions and velocities out (the fast decoder's are: no node of its
	 * frames is SKIP) */
	const int hier = enc == NDO_ENC_HIER;
	if (hier && cnt[1] == (size_t)nodes) {
		const int est = prev && dtp > 0 && codes_all(prev->have, nodes);
		hier_out(&z, recon->k, est ? prev->k : NULL, inv, nodes, x, v, S);
		o.done = 1;
	}
	for (int n = 0; n < nodes && !o.done; n++) {
		if (cls[n] == NDO_NODE_EXACT)
			continue;
		int lossy = cls[n] == NDO_NODE_LOSSY;
		int est = lossy && prev && prev->have[n] && dtp > 0;
		for (int d = 0; d < 3; d++) {
			const double xv = hier && lossy ? value_of(&z, d, recon->k[3 * n + d])
			                                : recon->x[3 * n + d];
			x[S * n + d] = lossy ? xv : NAN;
			v[S * n + d] = est ? (xv - frame_pos(&z, prev, n, d)) * inv : NAN;
		}
	}
done:
	free(cls);
	if (own_w)
		ndo_codec_work_destroy(w);
	if (res != NDO_DROP_NONE || (flags & F_NOREF))
		recon->step = -1; /* not to be kept as a reference */
	return res;
}

ndo_drop ndo_codec_decode(const ndo_codec_params *p, ndo_codec_work *w,
                          const ndo_codec_hist *h, int rows, int cols, const uint8_t *data,
                          size_t len, int64_t step, double time, int32_t epoch,
                          int64_t base_step, double *x, double *v, ndo_codec_frame *recon)
{
	return ndo_codec_decode_strided(p, w, h, rows, cols, data, len, step, time, epoch, base_step,
	                                x, v, 3, recon);
}

int ndo_codec_implied(const ndo_codec_params *p, const ndo_codec_hist *h, int rows, int cols,
                      int64_t step, double time, double *x, ndo_codec_frame *recon)
{
	const int nodes = rows * cols;
	const quant z = ndo__codec_quant_of(p);
	const ndo_codec_frame *r[3] = {0};
	for (int k = 0, m = 0; h && k < NDO_CODEC_HISTORY && m < 3; k++)
		if (h->f[k].step >= 0 && h->f[k].step < step && step - h->f[k].step <= NDO_CODEC_MAX_GAP)
			r[m++] = &h->f[k];
	if (!r[0] || p->encoding < NDO_ENC_PREDICT)
		return ndo__fail(NDO_EINVAL, "no frame to predict step %lld from", (long long)step);
	uint8_t *cls = malloc((size_t)nodes);
	int32_t *cur = malloc((size_t)nodes * sizeof *cur);
	if (!cls || !cur) {
		free(cls), free(cur);
		return ndo__fail(NDO_ENOMEM, "out of memory");
	}
	for (int n = 0; n < nodes; n++)
		cls[n] = r[0]->have[n] ? NDO_NODE_LOSSY : NDO_NODE_SKIP;
	if (p->encoding == NDO_ENC_HIER) {
		int64_t *t = malloc(HIER_SCRATCH * (size_t)nodes * sizeof *t);
		uint8_t *mag = malloc(3 * (size_t)nodes);
		hcodes hc = {rows, cols, cls, {r[0], r[1], r[2]}, step};
		int rc = !t || !mag ? ndo__fail(NDO_ENOMEM, "out of memory")
		         : ndo__codec_hier_implied(&hc, recon->k, t, mag)
		             ? ndo__fail(NDO_ERANGE, "step %lld: a code out of range", (long long)step)
		             : 0;
		recon->step = step;
		recon->time = time;
		recon->epoch = r[0]->epoch;
		for (int n = 0; n < nodes; n++) {
			recon->have[n] = cls[n] != NDO_NODE_SKIP;
			for (int d = 0; d < 3; d++)
				x[3 * n + d] = recon->x[3 * n + d] =
				    !rc && recon->have[n] ? value_of(&z, d, recon->k[3 * n + d]) : NAN;
		}
		free(t), free(mag), free(cls), free(cur);
		return rc;
	}
	pctx c = {.cols = cols, .nodes = nodes, .cls = cls, .cur = cur};
	ndo__codec_pctx_init(&c, r[0], r[1], r[2], step);
	recon->step = step;
	recon->time = time;
	recon->epoch = r[0]->epoch;
	for (int d = 0; d < 3; d++)
		for (int n = 0; n < nodes; n++) {
			recon->have[n] = cls[n] != NDO_NODE_SKIP;
			if (cls[n] == NDO_NODE_SKIP) {
				x[3 * n + d] = NAN;
				continue;
			}
			int64_t k = ndo__codec_predict(&c, n, d);
			if (k <= -CODE_MAX || k >= CODE_MAX)
				k = r[0]->k[3 * n + d];
			cur[n] = (int32_t)k;
			recon->k[3 * n + d] = (int32_t)k;
			x[3 * n + d] = recon->x[3 * n + d] = value_of(&z, d, k);
		}
	free(cls), free(cur);
	return 0;
}
