/* codec_predict.c — codes and prediction (ndo/codec.h, "predict"): the
 * quantization of a set of parameters, the history of reference frames,
 * and the general predictor — in time from the references, corrected by
 * the row above's errors this step, or in space within a keyframe. */
#include "codec_private.h"
#include "ndo/status.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- history ---------------------------------------------------------------- */
static void frame_clear(ndo_codec_frame *f) { f->step = -1; }

int ndo_codec_hist_init(ndo_codec_hist *h, int nodes)
{
	memset(h, 0, sizeof *h);
	h->nodes = nodes;
	for (int k = 0; k < NDO_CODEC_HISTORY; k++) {
		ndo_codec_frame *f = &h->f[k];
		f->x = malloc(3 * (size_t)nodes * sizeof *f->x);
		f->k = malloc(3 * (size_t)nodes * sizeof *f->k);
		f->have = malloc((size_t)nodes);
		f->step = -1;
		if (!f->x || !f->k || !f->have) {
			ndo_codec_hist_free(h);
			return ndo__fail(NDO_ENOMEM, "out of memory");
		}
	}
	return 0;
}

void ndo_codec_hist_free(ndo_codec_hist *h)
{
	for (int k = 0; k < NDO_CODEC_HISTORY; k++) {
		free(h->f[k].x), free(h->f[k].k), free(h->f[k].have);
		h->f[k].x = NULL, h->f[k].k = NULL, h->f[k].have = NULL;
	}
}

void ndo_codec_hist_clear(ndo_codec_hist *h)
{
	for (int k = 0; k < NDO_CODEC_HISTORY; k++)
		frame_clear(&h->f[k]);
}

static void frame_copy(ndo_codec_frame *d, const ndo_codec_frame *s, int nodes)
{
	d->step = s->step;
	d->time = s->time;
	d->epoch = s->epoch;
	memcpy(d->x, s->x, 3 * (size_t)nodes * sizeof *d->x);
	memcpy(d->k, s->k, 3 * (size_t)nodes * sizeof *d->k);
	memcpy(d->have, s->have, (size_t)nodes);
}

static int hist_insert(ndo_codec_hist *h, ndo_codec_frame *f, int take);

void ndo_codec_hist_put(ndo_codec_hist *h, const ndo_codec_frame *f)
{
	hist_insert(h, (ndo_codec_frame *)f, 0); /* not written to */
}

int ndo_codec_hist_take(ndo_codec_hist *h, ndo_codec_frame *f)
{
	return hist_insert(h, f, 1);
}

static int hist_insert(ndo_codec_hist *h, ndo_codec_frame *f, int take)
{
	for (int k = 0; k < NDO_CODEC_HISTORY; k++)
		if (h->f[k].step >= 0 && (h->f[k].epoch != f->epoch || h->f[k].step == f->step))
			frame_clear(&h->f[k]); /* another partition's, or this step's again */
	/* compact: held frames first, newest first */
	ndo_codec_frame tmp[NDO_CODEC_HISTORY];
	int n = 0;
	for (int k = 0; k < NDO_CODEC_HISTORY; k++)
		if (h->f[k].step >= 0 && h->f[k].step != f->step)
			tmp[n++] = h->f[k];
	for (int k = 0; k < NDO_CODEC_HISTORY; k++)
		if (h->f[k].step < 0 || h->f[k].step == f->step)
			tmp[n++] = h->f[k];
	for (int a = 1; a < NDO_CODEC_HISTORY; a++) /* insertion sort, newest first */
		for (int b = a; b > 0 && tmp[b].step > tmp[b - 1].step; b--) {
			ndo_codec_frame t = tmp[b];
			tmp[b] = tmp[b - 1];
			tmp[b - 1] = t;
		}
	/* the slot to fill: the oldest (last), unless f is older than all held */
	int slot = NDO_CODEC_HISTORY - 1;
	if (tmp[slot].step >= 0 && tmp[slot].step > f->step)
		return 0; /* older than every frame held: of no use */
	if (take) { /* the frame's arrays into the slot, the slot's to the caller */
		ndo_codec_frame old = tmp[slot];
		tmp[slot] = *f;
		f->x = old.x, f->k = old.k, f->have = old.have;
	} else {
		frame_copy(&tmp[slot], f, h->nodes);
	}
	for (int b = slot; b > 0 && tmp[b].step > tmp[b - 1].step; b--) {
		ndo_codec_frame t = tmp[b];
		tmp[b] = tmp[b - 1];
		tmp[b - 1] = t;
	}
	memcpy(h->f, tmp, sizeof tmp);
	return take;
}

const ndo_codec_frame *ndo_codec_hist_find(const ndo_codec_hist *h, int64_t step)
{
	if (!h || step < 0)
		return NULL;
	for (int k = 0; k < NDO_CODEC_HISTORY; k++)
		if (h->f[k].step == step)
			return &h->f[k];
	return NULL;
}

/* The newest frame before `step` (velocity estimates). */
const ndo_codec_frame *ndo__codec_before(const ndo_codec_hist *h, int64_t step, int32_t epoch)
{
	const ndo_codec_frame *b = NULL;
	if (h)
		for (int k = 0; k < NDO_CODEC_HISTORY; k++)
			if (h->f[k].step >= 0 && h->f[k].step < step && h->f[k].epoch == epoch &&
			    (!b || h->f[k].step > b->step))
				b = &h->f[k];
	return b;
}

/* ---- codes and prediction ------------------------------------------------------- */
quant ndo__codec_quant_of(const ndo_codec_params *p)
{
	quant z;
	/* an error budget: one step on every axis, half its cube's diagonal
	 * the budget — √3 q / 2 = error × diagonal */
	double q = p->error > 0 ? 2 * p->error * ndo_codec_diagonal(p) / sqrt(3) : 0;
	for (int c = 0; c < 3; c++)
		z.lo[c] = p->lo[c], z.q[c] = p->error > 0 ? q : ldexp(p->ext[c], -p->bits);
	if (p->encoding == NDO_ENC_HIER) /* its codes: steps of q / HIER_FINE */
		for (int c = 0; c < 3; c++)
			z.q[c] /= HIER_FINE;
	return z;
}

/* The bits of a code across the box: `bits`, or those of the steps in
 * the box's longest axis (an error budget). */
int ndo__codec_code_bits(const ndo_codec_params *p, const quant *z)
{
	if (!(p->error > 0))
		return p->bits;
	double most = 0;
	for (int c = 0; c < 3; c++)
		most = fmax(most, p->ext[c] / z->q[c]);
	int b = 1;
	while (b < 28 && ldexp(1, b) < most)
		b++;
	return b;
}

void ndo_codec_frame_position(const ndo_codec_params *p, const ndo_codec_frame *f, int n,
                              double x[3])
{
	const quant z = ndo__codec_quant_of(p);
	for (int d = 0; d < 3; d++)
		x[d] = f->have[n] ? frame_pos(&z, f, n, d) : NAN;
}

void ndo__codec_pctx_init(pctx *c, const ndo_codec_frame *r0, const ndo_codec_frame *r1,
                      const ndo_codec_frame *r2, int64_t step)
{
	c->r[0] = r0, c->r[1] = r0 ? r1 : NULL, c->r[2] = r0 && r1 ? r2 : NULL;
	c->step = step;
	c->cons = c->r[1] && r0->step == step - 1 && r1->step == step - 2;
	c->cons3 = c->cons && c->r[2] && r2->step == step - 3;
}

/* The extrapolation of node n's component d from the references, and
 * whether there is one (both r0 and r1 hold the node). */
static int extrapolate(const pctx *c, int n, int d, int64_t *lin)
{
	const ndo_codec_frame *r0 = c->r[0], *r1 = c->r[1];
	if (!r1 || !r0->have[n] || !r1->have[n])
		return 0;
	int64_t k0 = r0->k[3 * n + d], k1 = r1->k[3 * n + d];
	if (c->cons)
		*lin = 2 * k0 - k1;
	else
		*lin = k0 + rdiv((k0 - k1) * (c->step - r0->step), r0->step - r1->step);
	return 1;
}

/* The prediction of node n's code on component d (node n is carried; in a
 * keyframe, the nodes before it in raster order are decoded in c->cur). */
/* Node m's extrapolation error this step (consecutive steps), in *e;
 * 0 when it has none (not carried, or not held by r0 and r1). */
static int error_at(const pctx *c, int m, int d, int64_t *e)
{
	if (!carried(c, m) || !c->r[0]->have[m] || !c->r[1]->have[m])
		return 0;
	*e = c->cur[m] - (2 * (int64_t)c->r[0]->k[3 * m + d] - c->r[1]->k[3 * m + d]);
	return 1;
}

int64_t ndo__codec_predict(const pctx *c, int n, int d)
{
	int64_t lin;
	if (c->r[0] && extrapolate(c, n, d, &lin)) {
		if (!c->cons)
			return lin;
		int64_t corr = 0, eu, el, er;
		if (c->cons3 && c->r[2]->have[n]) /* last step's second difference */
			corr = c->r[0]->k[3 * n + d] - 2 * (int64_t)c->r[1]->k[3 * n + d] +
			       c->r[2]->k[3 * n + d];
		int i = n % c->cols, u = n - c->cols;
		if (u >= 0 && error_at(c, u, d, &eu)) { /* the upper row's errors this step */
			if (i == 0 || !error_at(c, u - 1, d, &el))
				el = eu;
			if (i + 1 == c->cols || !error_at(c, u + 1, d, &er))
				er = eu;
			corr += clamp3(eu, el, er);
		}
		return lin + half(corr);
	}
	if (c->r[0] && c->r[0]->have[n])
		return c->r[0]->k[3 * n + d];
	/* intra: from this frame's neighbours */
	int i = n % c->cols;
	int left = i > 0 ? n - 1 : -1, up = n >= c->cols ? n - c->cols : -1;
	int ul = left >= 0 && up >= 0 ? up - 1 : -1;
	int a = left >= 0 && carried(c, left), b = up >= 0 && carried(c, up),
	    u = ul >= 0 && carried(c, ul);
	if (a && b && u)
		return med3(c->cur[left], c->cur[up], c->cur[ul]);
	if (a && b)
		return rdiv((int64_t)c->cur[left] + c->cur[up], 2);
	if (a)
		return c->cur[left];
	if (b)
		return c->cur[up];
	return 0;
}
