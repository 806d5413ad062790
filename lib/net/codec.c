/* codec.c — the encodings of a tile's frame: parameters, prediction,
 * payload (ndo/codec.h).  Pure functions: all state is the caller's. */
#include "ndo/codec.h"
#include "ndo/status.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zstd.h>

/* The hot loops are compiled for x86-64 and x86-64-v3 (AVX2), at -O3 so
 * that they vectorize; the loader picks what the CPU runs (lib/integrate.c's
 * NDO_HOT).  Integer results, and double operations without fused ones
 * (C11 mode): the same on both. */
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define NDO_HOT __attribute__((target_clones("arch=x86-64-v3", "default"), optimize("O3")))
#else
#define NDO_HOT
#endif

enum { KIND_INTRA = 0, KIND_PRED = 1, F_ZSTD = 4, F_WIDE = 8, F_NOREF = 16 };
/* zstd's level: 1 (docs/bench/net.md: levels -5..3 against bits and time;
 * set by bench_codec -z only) */
int ndo__codec_zstd_level = 1;
#define CODE_MAX (1 << 30)

/* ---- parameters ----------------------------------------------------------- */
static const char *const enc_names[] = {"raw", "float32", "fixed", "predict"};

int ndo_codec_parse(const char *spec, ndo_codec_params *p)
{
	char name[32];
	int bits = NDO_CODEC_BITS_DEFAULT, key = NDO_CODEC_KEYFRAME_DEFAULT;
	double err = 0;
	const char *colon = strchr(spec, ':');
	size_t n = colon ? (size_t)(colon - spec) : strlen(spec);
	if (n == 0 || n >= sizeof name)
		return ndo__fail(NDO_EINVAL, "'%s': not raw, float32, fixed[:BITS] or "
		                 "predict[:BITS[:KEYFRAME]]", spec);
	memcpy(name, spec, n);
	name[n] = 0;
	int e = -1;
	for (int k = 0; k < 4; k++)
		if (strcmp(name, enc_names[k]) == 0)
			e = k;
	if (e < 0)
		return ndo__fail(NDO_EINVAL, "'%s': unknown encoding (raw, float32, fixed, predict)",
		                 name);
	if (colon) {
		if (e < NDO_ENC_FIXED)
			return ndo__fail(NDO_EINVAL, "'%s': %s takes no parameters", spec, name);
		char *end;
		const char *f = colon + 1;
		size_t digits = strspn(f, "0123456789");
		if (digits && (f[digits] == '.' || f[digits] == 'e' || f[digits] == 'E')) {
			/* an error budget: the largest error over the diagonal */
			err = strtod(f, &end);
			if (end == f || !(err >= NDO_CODEC_ERROR_MIN && err <= NDO_CODEC_ERROR_MAX) ||
			    (*end && *end != ':'))
				return ndo__fail(NDO_EINVAL, "'%s': the error budget must be %g..%g of the "
				                 "diagonal", spec, NDO_CODEC_ERROR_MIN, NDO_CODEC_ERROR_MAX);
		} else {
			long b = strtol(f, &end, 10);
			if (end == f || b < 1 || b > 24 || (*end && *end != ':'))
				return ndo__fail(NDO_EINVAL, "'%s': bits must be 1..24, or an error "
				                 "budget (1e-4)", spec);
			bits = (int)b;
		}
		if (*end == ':') {
			const char *ks = end + 1;
			long kk = strtol(ks, &end, 10);
			if (e != NDO_ENC_PREDICT || end == ks || *end || kk < 1 || kk > 4096)
				return ndo__fail(NDO_EINVAL, "'%s': the keyframe period must be 1..4096 "
				                 "(predict only)", spec);
			key = (int)kk;
		}
	}
	memset(p, 0, sizeof *p); /* the box: the session's to find (ext 0) */
	p->encoding = e;
	p->bits = bits;
	p->keyframe = key;
	p->error = err;
	return 0;
}

void ndo_codec_name(const ndo_codec_params *p, char *buf, size_t size)
{
	int e = p->encoding >= 0 && p->encoding < 4 ? p->encoding : 0;
	char depth[32];
	if (p->error > 0)
		snprintf(depth, sizeof depth, "%.3g", p->error);
	else
		snprintf(depth, sizeof depth, "%d", p->bits);
	if (!strpbrk(depth, ".e") && p->error > 0) /* "1" would read as bits */
		snprintf(depth, sizeof depth, "%.1f", p->error);
	if (e == NDO_ENC_FIXED)
		snprintf(buf, size, "fixed:%s", depth);
	else if (e == NDO_ENC_PREDICT)
		snprintf(buf, size, "predict:%s:%d", depth, p->keyframe);
	else
		snprintf(buf, size, "%s", enc_names[e]);
}

void ndo_codec_box(const double *x, size_t n, double lo[3], double ext[3])
{
	double hi[3];
	for (int c = 0; c < 3; c++)
		lo[c] = n ? INFINITY : 0, hi[c] = n ? -INFINITY : 0;
	for (size_t k = 0; k < n; k++)
		for (int c = 0; c < 3; c++) {
			double v = x[3 * k + c];
			if (!isfinite(v))
				continue;
			lo[c] = fmin(lo[c], v);
			hi[c] = fmax(hi[c], v);
		}
	double big = 0;
	for (int c = 0; c < 3; c++) {
		if (!isfinite(lo[c]))
			lo[c] = hi[c] = 0;
		ext[c] = hi[c] - lo[c];
		big = fmax(big, ext[c]);
	}
	for (int c = 0; c < 3; c++)
		if (!(ext[c] > 1e-6 * big))
			ext[c] = big > 0 ? 1e-6 * big : 1;
}

double ndo_codec_diagonal(const ndo_codec_params *p)
{
	return sqrt(p->ext[0] * p->ext[0] + p->ext[1] * p->ext[1] + p->ext[2] * p->ext[2]);
}

double ndo_codec_max_error(const ndo_codec_params *p)
{
	switch (p->encoding) {
	case NDO_ENC_FIXED:
	case NDO_ENC_PREDICT:
		if (p->error > 0)
			return p->error * ndo_codec_diagonal(p);
		return ldexp(ndo_codec_diagonal(p), -(p->bits + 1));
	case NDO_ENC_FLOAT32: {
		/* round to nearest float: half an ulp of the largest magnitude in
		 * the box, per axis */
		double s = 0;
		for (int c = 0; c < 3; c++) {
			double m = fmax(fabs(p->lo[c]), fabs(p->lo[c] + p->ext[c]));
			int e;
			frexp(m, &e);
			double h = ldexp(1, e - 25);
			s += h * h;
		}
		return sqrt(s);
	}
	default:
		return 0;
	}
}

int ndo_codec_params_check(const ndo_codec_params *p)
{
	if (p->encoding < NDO_ENC_RAW || p->encoding > NDO_ENC_PREDICT)
		return ndo__fail(NDO_EINVAL, "tile encoding %d unknown", p->encoding);
	if (p->encoding == NDO_ENC_RAW)
		return 0;
	if (p->bits < 1 || p->bits > 24 || p->keyframe < 1 || p->keyframe > 4096)
		return ndo__fail(NDO_EINVAL, "tile encoding: bits %d (1..24), keyframe %d (1..4096)",
		                 p->bits, p->keyframe);
	if (p->error != 0 && !(p->error >= NDO_CODEC_ERROR_MIN && p->error <= NDO_CODEC_ERROR_MAX))
		return ndo__fail(NDO_EINVAL, "tile encoding: error budget %g (%g..%g)", p->error,
		                 NDO_CODEC_ERROR_MIN, NDO_CODEC_ERROR_MAX);
	for (int c = 0; c < 3; c++)
		if (!isfinite(p->lo[c]) || !isfinite(p->ext[c]) || !(p->ext[c] > 0) ||
		    fabs(p->lo[c]) > 1e300 || p->ext[c] > 1e300)
			return ndo__fail(NDO_EINVAL, "tile encoding: a bad box");
	return 0;
}

int ndo_codec_params_text(const ndo_codec_params *p, char *buf, size_t size)
{
	int n = 0;
	if (p->encoding != NDO_ENC_RAW)
		n = snprintf(buf, size,
		             "tile-encoding %d\ntile-bits %d\ntile-keyframe %d\n"
		             "tile-box %.17g %.17g %.17g %.17g %.17g %.17g\n",
		             p->encoding, p->bits, p->keyframe, p->lo[0], p->lo[1], p->lo[2], p->ext[0],
		             p->ext[1], p->ext[2]);
	else if (size)
		*buf = 0;
	if (n >= 0 && (size_t)n < size && p->encoding != NDO_ENC_RAW && p->error > 0) {
		int m = snprintf(buf + n, size - (size_t)n, "tile-error %.17g\n", p->error);
		n = m < 0 ? m : n + m;
	}
	if (n < 0 || (size_t)n >= size)
		return ndo__fail(NDO_ERANGE, "tile encoding: the description lines do not fit");
	return n;
}

int ndo_codec_params_take(char *text, ndo_codec_params *p)
{
	memset(p, 0, sizeof *p);
	p->encoding = NDO_ENC_RAW;
	int seen = 0, rc = 0;
	char *w = text;
	for (char *line = text; *line;) {
		char *end = strchr(line, '\n');
		size_t len = end ? (size_t)(end - line) + 1 : strlen(line);
		if (strncmp(line, "tile-", 5) != 0) {
			memmove(w, line, len);
			w += len;
			line += len;
			continue;
		}
		char l[256];
		snprintf(l, sizeof l, "%.*s", (int)(end ? len - 1 : len), line);
		line += len;
		int k;
		if (sscanf(l, "tile-encoding %d", &k) == 1)
			p->encoding = k, seen |= 1;
		else if (sscanf(l, "tile-bits %d", &k) == 1)
			p->bits = k, seen |= 2;
		else if (sscanf(l, "tile-keyframe %d", &k) == 1)
			p->keyframe = k, seen |= 4;
		else if (sscanf(l, "tile-box %lf %lf %lf %lf %lf %lf", &p->lo[0], &p->lo[1], &p->lo[2],
		                &p->ext[0], &p->ext[1], &p->ext[2]) == 6)
			seen |= 8;
		else if (sscanf(l, "tile-error %lf", &p->error) == 1 && p->error > 0)
			seen |= 16; /* optional: the step from an error budget */
		else if (!rc)
			rc = ndo__fail(NDO_EINVAL, "the owner's description: bad line '%s'", l);
	}
	*w = 0;
	if (rc)
		return rc;
	if (seen && (seen & 15) != 15)
		return ndo__fail(NDO_EINVAL, "the owner's description: incomplete tile-* lines");
	return seen ? ndo_codec_params_check(p) : 0;
}

int ndo_codec_params_read(const void *scene, size_t len, ndo_codec_params *p)
{
	char *text = malloc(len + 1);
	if (!text)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	if (len)
		memcpy(text, scene, len);
	text[len] = 0;
	int rc = ndo_codec_params_take(text, p);
	free(text);
	return rc;
}

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
static const ndo_codec_frame *before(const ndo_codec_hist *h, int64_t step, int32_t epoch)
{
	const ndo_codec_frame *b = NULL;
	if (h)
		for (int k = 0; k < NDO_CODEC_HISTORY; k++)
			if (h->f[k].step >= 0 && h->f[k].step < step && h->f[k].epoch == epoch &&
			    (!b || h->f[k].step > b->step))
				b = &h->f[k];
	return b;
}

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
	double *xg;      /* 6 x nodes: strided input gathered (ndo_codec_input.stride) */
	size_t xgcap;
	size_t rowcap;   /* its bytes */
	double err_max2, err_sum2; /* the last frame encoded: its LOSSY errors */
	size_t err_n;
	size_t ecap;
};

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
	free(w);
}

void ndo_codec_work_error(const ndo_codec_work *w, double *max2, double *sum2, size_t *count)
{
	*max2 = w->err_max2, *sum2 = w->err_sum2, *count = w->err_n;
}

static int grow(uint8_t **b, size_t *cap, size_t need)
{
	if (need <= *cap)
		return 0;
	uint8_t *n = realloc(*b, need);
	if (!n)
		return -1;
	*b = n;
	*cap = need;
	return 0;
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
	w->ecap = nodes;
	return 0;
}

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

/* ---- bytes ---------------------------------------------------------------------- */
typedef struct wbuf { uint8_t *p; size_t n, cap; int fail; } wbuf;

static void put(wbuf *b, const void *src, size_t n)
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
static int reserve(wbuf *b, size_t n)
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

static void put_byte(wbuf *b, uint8_t v)
{
	if (b->n < b->cap && !b->fail)
		b->p[b->n++] = v;
	else
		put(b, &v, 1);
}

static void put_varint(wbuf *b, uint64_t v)
{
	uint8_t t[10];
	int n = 0;
	do {
		t[n++] = (uint8_t)((v & 127) | (v > 127 ? 128 : 0));
		v >>= 7;
	} while (v);
	put(b, t, (size_t)n);
}

static void put_f64(wbuf *b, double d)
{
	uint64_t u;
	memcpy(&u, &d, 8);
	uint8_t t[8];
	for (int k = 0; k < 8; k++)
		t[k] = (uint8_t)(u >> (8 * k));
	put(b, t, 8);
}

typedef struct rbuf { const uint8_t *p; size_t n, pos; int bad; } rbuf;

static uint64_t get_varint(rbuf *r)
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

static double get_f64(rbuf *r)
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

static uint64_t zigzag(int64_t v) { return ((uint64_t)v << 1) ^ (uint64_t)(v >> 63); }
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

static int64_t unzigzag(uint64_t u) { return (int64_t)(u >> 1) ^ -(int64_t)(u & 1); }

/* ---- codes and prediction ------------------------------------------------------- */
/* The quantization step per axis, ext / 2^bits (exact: a power of two's
 * scaling), computed once for a set of parameters. */
typedef struct quant { double lo[3], q[3]; } quant;

static quant quant_of(const ndo_codec_params *p)
{
	quant z;
	/* an error budget: one step on every axis, half its cube's diagonal
	 * the budget — √3 q / 2 = error × diagonal */
	double q = p->error > 0 ? 2 * p->error * ndo_codec_diagonal(p) / sqrt(3) : 0;
	for (int c = 0; c < 3; c++)
		z.lo[c] = p->lo[c], z.q[c] = p->error > 0 ? q : ldexp(p->ext[c], -p->bits);
	return z;
}

/* The bits of a code across the box: `bits`, or those of the steps in
 * the box's longest axis (an error budget). */
static int code_bits(const ndo_codec_params *p, const quant *z)
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

void ndo_codec_frame_position(const ndo_codec_params *p, const ndo_codec_frame *f, int n,
                              double x[3])
{
	const quant z = quant_of(p);
	for (int d = 0; d < 3; d++)
		x[d] = f->have[n] ? frame_pos(&z, f, n, d) : NAN;
}

/* a/b rounded half away from zero (b > 0) */
static int64_t rdiv(int64_t a, int64_t b)
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

static void pctx_init(pctx *c, const ndo_codec_frame *r0, const ndo_codec_frame *r1,
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

static int carried(const pctx *c, int m) { return c->cls[m] != NDO_NODE_SKIP; }

/* rdiv(a, 2): halves rounded away from zero (C division truncates) */
static inline int64_t half(int64_t a)
{
	/* (a + 1 − 2 (a < 0)) / 2 as (a + (a ≥ 0)) >> 1, the arithmetic shift
	 * as a logical one with the sign kept (AVX2 has no 64-bit one) */
	const uint64_t t = (uint64_t)a + (a >= 0);
	return (int64_t)((t >> 1) | (t & 0x8000000000000000u));
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

static int64_t predict(const pctx *c, int n, int d)
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

/* ---- the predictor's common case, fast ------------------------------------------ */
/* Set (tests only): every frame through the general predictor above, so
 * that the fast one below can be checked against it byte for byte. */
int ndo__codec_general_only;

/* Whether a frame is in a common case, where predict() reduces to the
 * loops of fast_component() — the same integers without its branches:
 * every node carried, and the references predict() uses (r0; r1; r2 when
 * the last three steps are consecutive) holding every node.  Then every
 * node is predicted the same way (from its neighbours in a keyframe; r0's
 * code with r0 alone; else extrapolated) and its neighbours' values or
 * errors exist wherever the neighbours do. */
NDO_HOT static int uniform(const pctx *c)
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

/* The prediction of node n's component d in a uniform frame (see
 * uniform(); predict() without its checks): k holds this frame's codes
 * of the nodes before n in raster order (a keyframe's references). */
enum { M_INTRA, M_COPY, M_CURVED, M_LINEAR, M_GAP }; /* which references (uniform frames) */

static int fast_mode(const pctx *c)
{
	return !c->r[0] ? M_INTRA : !c->r[1] ? M_COPY : c->cons3 ? M_CURVED : c->cons ? M_LINEAR : M_GAP;
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
static void put_residuals(wbuf *b, const uint64_t *u, size_t m);

/* The codes, their error statistics, and the residuals into b. */
static int fast_encode(const pctx *c, const quant *z, rowsc *rs, const double *x, size_t xs,
                       ndo_codec_frame *recon, uint64_t *u, size_t lossy, uint64_t *any,
                       double err[2], wbuf *b)
{
	const int mode = fast_mode(c);
	if (mode == M_INTRA) {
		int rc = fast_encode_mode(c, M_INTRA, z, x, recon, u, lossy, any, err); /* xs: cols */
		put_residuals(b, u, 3 * lossy);
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

/* Decoder, a uniform frame: the LOSSY nodes' codes and values from the
 * residuals (as fast_encode() lays them out); recon->k holds the EXACT
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
static int fast_decode(const pctx *c, const quant *z, rowsc *rs, const uint64_t *u, size_t lossy,
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

/* The residuals u[0..m) (zigzag codes): 2-bit symbols, four to a byte,
 * first in the low bits — u itself below 3, 3 for an escape —, then each
 * escape's u − 3 as a varint. */
static void put_residuals(wbuf *b, const uint64_t *u, size_t m)
{
	size_t esc = 0;
	for (size_t k = 0; k < m; k++)
		esc += u[k] >= 3;
	const size_t nb = (m + 3) / 4;
	if (reserve(b, nb + 10 * esc + 1)) /* + 1: the escape slot written ahead */
		return;
	uint8_t *o = b->p + b->n, *e = o + nb; /* symbols; escapes after them */
	const size_t full = m / 4;
	for (size_t g = 0; g < full; g++) { /* four symbols a byte, without branches */
		const uint64_t *q = u + 4 * g;
		unsigned s0 = q[0] < 3 ? (unsigned)q[0] : 3, s1 = q[1] < 3 ? (unsigned)q[1] : 3,
		         s2 = q[2] < 3 ? (unsigned)q[2] : 3, s3 = q[3] < 3 ? (unsigned)q[3] : 3;
		o[g] = (uint8_t)(s0 | s1 << 2 | s2 << 4 | s3 << 6);
	}
	if (full < nb) {
		unsigned byte = 0;
		for (size_t k = 4 * full; k < m; k++)
			byte |= (u[k] < 3 ? (unsigned)u[k] : 3) << (2 * (k & 3));
		o[full] = (uint8_t)byte;
	}
	for (size_t k = 0; esc && k < m; k++) { /* the escapes, in order */
		uint64_t v = u[k];
		if (v < 3 + 128) { /* the escape of one byte, or none: no branch */
			*e = (uint8_t)(v - 3);
			e += v >= 3;
		} else {
			for (v -= 3; v > 127; v >>= 7)
				*e++ = (uint8_t)(v | 128);
			*e++ = (uint8_t)v;
		}
		esc -= v >= 3;
	}
	b->n = (size_t)(e - b->p);
}

/* The m residuals back (−1: the bytes end early, or a value beyond
 * 2^40, more than any code difference). */
static int get_residuals(rbuf *r, uint64_t *u, size_t m)
{
	size_t nb = (m + 3) / 4;
	if (r->pos > r->n || r->n - r->pos < nb)
		return -1;
	const uint8_t *in = r->p + r->pos;
	if (m & 3 && in[nb - 1] >> (2 * (m & 3)))
		return -1; /* the last byte's unused bits are zero */
	const size_t full = m / 4;
	size_t esc = 0;
	for (size_t g = 0; g < full; g++) { /* the symbols, without branches */
		const unsigned c = in[g];
		uint64_t *q = u + 4 * g;
		q[0] = c & 3, q[1] = c >> 2 & 3, q[2] = c >> 4 & 3, q[3] = c >> 6;
		esc += (c & 3) == 3, esc += (c >> 2 & 3) == 3, esc += (c >> 4 & 3) == 3,
		    esc += c >> 6 == 3;
	}
	for (size_t k = 4 * full; k < m; k++) {
		u[k] = (in[full] >> (2 * (k & 3))) & 3;
		esc += u[k] == 3;
	}
	size_t pos = r->pos + nb;
	for (size_t k = 0; esc && k < m; k++) { /* the escapes (rare: a branch) */
		if (u[k] != 3)
			continue;
		if (pos < r->n && r->p[pos] < 128) { /* of one byte */
			u[k] = (uint64_t)r->p[pos++] + 3;
		} else {
			rbuf t = {r->p, r->n, pos, 0};
			uint64_t v = get_varint(&t);
			if (t.bad || v > ((uint64_t)1 << 40))
				return -1;
			u[k] = v + 3;
			pos = t.pos;
		}
		esc--;
	}
	r->pos = pos;
	return 0;
}

/* The same read in place for the row loops: the 3 × lossy symbols at r's
 * position and their escapes (into esc, in order; sy->first: where each
 * component's begin); the same checks as get_residuals(). */
static int get_symbols(rbuf *r, size_t lossy, uint64_t *esc, syms *sy)
{
	const size_t m = 3 * lossy, nb = (m + 3) / 4;
	if (r->pos > r->n || r->n - r->pos < nb)
		return -1;
	const uint8_t *in = r->p + r->pos;
	if (m & 3 && in[nb - 1] >> (2 * (m & 3)))
		return -1; /* the last byte's unused bits are zero */
	/* the escapes before each component's first symbol (symbols 3: bit
	 * pairs 11) */
	size_t cnt[4] = {0, 0, 0, 0};
	for (int d = 0; d < 3; d++) {
		size_t k0 = (size_t)d * lossy, k1 = k0 + lossy, k = k0, c = 0;
		for (; k < k1 && (k & 31); k++)
			c += ((in[k >> 2] >> (2 * (k & 3))) & 3) == 3;
		for (; k + 32 <= k1; k += 32) { /* 32 symbols a word */
			uint64_t b;
			memcpy(&b, in + (k >> 2), 8);
			b = b & b >> 1 & 0x5555555555555555u; /* a pair's low bit: both set */
			b = (b & 0x3333333333333333u) + (b >> 2 & 0x3333333333333333u);
			b = (b + (b >> 4)) & 0x0f0f0f0f0f0f0f0fu;
			c += (size_t)((b * 0x0101010101010101u) >> 56);
		}
		for (; k < k1; k++)
			c += ((in[k >> 2] >> (2 * (k & 3))) & 3) == 3;
		cnt[d + 1] = cnt[d] + c;
	}
	size_t pos = r->pos + nb;
	for (size_t e = 0; e < cnt[3]; e++) {
		if (pos < r->n && r->p[pos] < 128) { /* of one byte */
			esc[e] = (uint64_t)r->p[pos++] + 3;
			continue;
		}
		rbuf t = {r->p, r->n, pos, 0};
		uint64_t v = get_varint(&t);
		if (t.bad || v > ((uint64_t)1 << 40))
			return -1;
		esc[e] = v + 3;
		pos = t.pos;
	}
	sy->sym = (uint8_t *)in;
	sy->esc = esc;
	sy->lossy = lossy;
	for (int d = 0; d < 3; d++)
		sy->first[d] = cnt[d];
	r->pos = pos;
	return 0;
}

/* ---- EXACT nodes under predict -------------------------------------------------- */
/* Their doubles travel losslessly, the positions not as they are: each
 * XOR its extrapolation from the references' positions, the 3E words as
 * byte planes, most significant first, so that zstd finds the planes of
 * agreeing high bytes as runs; then the velocities as they are (predicted
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

static void put_planes(wbuf *b, const uint64_t *w, size_t m)
{
	if (reserve(b, 8 * m))
		return;
	uint8_t *o = b->p + b->n;
	for (int plane = 7; plane >= 0; plane--)
		for (size_t k = 0; k < m; k++)
			*o++ = (uint8_t)(w[k] >> (8 * plane));
	b->n += 8 * m;
}

static int get_planes(rbuf *r, uint64_t *w, size_t m)
{
	if (r->pos > r->n || (r->n - r->pos) / 8 < m)
		return -1;
	const uint8_t *in = r->p + r->pos;
	for (size_t k = 0; k < m; k++)
		w[k] = 0;
	for (int plane = 7; plane >= 0; plane--)
		for (size_t k = 0; k < m; k++)
			w[k] |= (uint64_t)*in++ << (8 * plane);
	r->pos += 8 * m;
	return 0;
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

static void put_classes(wbuf *b, const uint8_t *cls, int nodes)
{
	for (int n = 0; n < nodes;) {
		int m = n;
		while (m < nodes && cls[m] == cls[n])
			m++;
		put_byte(b, cls[n]);
		put_varint(b, (uint64_t)(m - n));
		n = m;
	}
}

static int get_classes(rbuf *r, uint8_t *cls, int nodes)
{
	for (int n = 0; n < nodes;) {
		if (r->pos >= r->n)
			return -1;
		uint8_t c = r->p[r->pos++];
		uint64_t run = get_varint(r);
		if (r->bad || c > NDO_NODE_EXACT || run == 0 || run > (uint64_t)(nodes - n))
			return -1;
		memset(cls + n, c, (size_t)run);
		n += (int)run;
	}
	return 0;
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
	const quant z = quant_of(p);
	int rc = 0, ok = 1, allzero = 1, nexact = 0, errors_known = 0;
	*data = NULL;
	*len = 0;
	*unchanged = 0;
	*base_step = -1;
	wbuf body = {0}, out = {0};
	/* references */
	const ndo_codec_frame *r[3] = {0};
	if (enc == NDO_ENC_PREDICT && !intra && h)
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
	pctx_init(&pc, r[0], r[1], r[2], in->step);
	const int fast = enc == NDO_ENC_PREDICT && uniform(&pc);
	/* positions and velocities: rows in place (stride), or gathered
	 * contiguous for every loop but the row loops' */
	const double *X = in->x, *V = in->v;
	size_t XS = in->stride > 0 ? (size_t)in->stride : (size_t)in->cols;
	if (XS != (size_t)in->cols && !(fast && fast_mode(&pc) != M_INTRA)) {
		const size_t need = 6 * (size_t)nodes * sizeof *w->xg;
		if (need > w->xgcap) {
			double *g = realloc(w->xg, need);
			if (!g) {
				rc = ndo__fail(NDO_ENOMEM, "out of memory");
				goto done;
			}
			w->xg = g, w->xgcap = need;
		}
		for (int j = 0; j < in->rows; j++) {
			memcpy(w->xg + 3 * (size_t)j * in->cols, in->x + 3 * (size_t)j * XS,
			       3 * (size_t)in->cols * sizeof *X);
			memcpy(w->xg + 3 * ((size_t)nodes + (size_t)j * in->cols), in->v + 3 * (size_t)j * XS,
			       3 * (size_t)in->cols * sizeof *V);
		}
		X = w->xg, V = w->xg + 3 * (size_t)nodes, XS = (size_t)in->cols;
	}
	size_t cnt[3];
	class_pass(in->cls, nodes, enc, recon->have, cnt);
	const size_t lossy = cnt[1];
	if (in->cls[0] <= NDO_NODE_EXACT && cnt[in->cls[0]] == (size_t)nodes) { /* one run */
		put_byte(&body, in->cls[0]);
		put_varint(&body, (uint64_t)nodes);
	} else {
		put_classes(&body, in->cls, nodes);
	}
	size_t nw = 0; /* EXACT words under predict */
	for (int n = 0; n < nodes && cnt[2]; n++) {
		if (in->cls[n] != NDO_NODE_EXACT)
			continue;
		nexact++;
		const double *xn = X + 3 * ((size_t)(n / in->cols) * XS + (size_t)(n % in->cols)),
		             *vn = V + 3 * ((size_t)(n / in->cols) * XS + (size_t)(n % in->cols));
		for (int d = 0; d < 3; d++) {
			if (!isfinite(xn[d]) || !isfinite(vn[d]))
				ok = 0;
			recon->x[3 * n + d] = xn[d];
		}
		if (enc == NDO_ENC_PREDICT) {
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
		put_planes(&body, w->u, nw);
		for (int n = 0; n < nodes; n++) /* velocities as they are */
			if (in->cls[n] == NDO_NODE_EXACT)
				for (int d = 0; d < 3; d++)
					put_f64(&body, V[3 * ((size_t)(n / in->cols) * XS +
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
		if (fast_encode(&pc, &z, &rs, X, XS, recon, w->u, lossy, &any, err, &body))
			ok = 0;
		w->err_max2 = err[0], w->err_sum2 = err[1], w->err_n = lossy;
		errors_known = 1;
		allzero = any == 0;
	} else {
		/* codes of every carried node (the others' are not used) and the
		 * LOSSY nodes' values: code_of() and value_of() without branches */
		int out = 0;
		for (int n = 0; n < nodes; n++) {
			const double *xn = X + 3 * n;
			int lossy = in->cls[n] == NDO_NODE_LOSSY;
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
	if (!errors_known) { /* the error this frame introduces */
		double max2 = 0, sum2 = 0;
		for (int n = 0; n < nodes; n++) {
			if (in->cls[n] != NDO_NODE_LOSSY)
				continue;
			double e2 = 0;
			for (int d = 0; d < 3; d++) {
				double e = recon->x[3 * n + d] - X[3 * n + d];
				e2 += e * e;
			}
			sum2 += e2;
			max2 = e2 > max2 ? e2 : max2;
		}
		w->err_max2 = max2, w->err_sum2 = sum2, w->err_n = lossy;
	}
	if (enc == NDO_ENC_FIXED) {
		/* bits+2 wide, offset by 2^bits: the box and its extent on each side */
		int cb = code_bits(p, &z), width = cb + 2;
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
					w->u[m++] = zigzag(cur[n] - predict(&c, n, d));
		}
		uint64_t any = 0;
		for (size_t k = 0; k < m; k++)
			any |= w->u[k];
		allzero = any == 0;
		put_residuals(&body, w->u, m);
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
	if (enc == NDO_ENC_PREDICT) {
		size_t bound = ZSTD_compressBound(body.n);
		if (grow(&w->buf, &w->cap, bound)) {
			rc = ndo__fail(NDO_ENOMEM, "out of memory");
			goto done;
		}
		size_t z = ZSTD_compressCCtx(w->cc, w->buf, bound, body.p, body.n,
		                             ndo__codec_zstd_level);
		if (!ZSTD_isError(z) && z < body.n) {
			out.p[0] |= F_ZSTD;
			put(&out, w->buf, z);
		} else {
			put(&out, body.p, body.n);
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
	const quant z = quant_of(p);
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
		int cb = code_bits(p, &z), width = cb + 2;
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
	pctx_init(&c, ref[0], ref[1], ref[2], step);
	int32_t *cur = w->cur;
	c.cur = cur;
	size_t m = 0;
	if (uniform(&c)) {
		rowsc rs;
		syms sy;
		if (row_scratch(w, cols, &rs))
			return -2;
		if (fast_mode(&c) == M_INTRA ? get_residuals(r, w->u, 3 * lossy)
		                             : get_symbols(r, lossy, w->u, &sy))
			return -1;
		return fast_decode(&c, &z, &rs, w->u, lossy, &sy, recon, o);
	}
	if (get_residuals(r, w->u, 3 * lossy))
		return -1;
	for (int d = 0; d < 3; d++) {
		for (int n = 0; n < nodes; n++)
			cur[n] = recon->k[3 * n + d]; /* exact nodes' codes */
		for (int n = 0; n < nodes; n++)
			if (cls[n] == NDO_NODE_LOSSY) {
				int64_t k = predict(&c, n, d) + unzigzag(w->u[m++]);
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
	const quant z = quant_of(p);
	if (enc <= NDO_ENC_RAW || enc > NDO_ENC_PREDICT || nodes <= 0)
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
	if ((flags & 0xe0) || kind > KIND_PRED || ((flags & F_ZSTD) && enc != NDO_ENC_PREDICT) ||
	    ((flags & F_WIDE) && enc != NDO_ENC_FIXED) || (kind == KIND_PRED) != (base_step >= 0) ||
	    (kind == KIND_PRED && enc != NDO_ENC_PREDICT) || base_step >= step ||
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
	if (flags & F_ZSTD) {
		unsigned long long n = ZSTD_getFrameContentSize(b.p, b.n);
		size_t bound = body_bound(nodes);
		if (n == ZSTD_CONTENTSIZE_ERROR || n == ZSTD_CONTENTSIZE_UNKNOWN || n > bound) {
			res = NDO_DROP_CORRUPT; /* not zstd, or a bomb */
			goto done;
		}
		if (grow(&w->buf2, &w->cap2, (size_t)n + 1)) {
			res = NDO_DROP_RANGE;
			goto done;
		}
		size_t got = ZSTD_decompressDCtx(w->dc, w->buf2, (size_t)n, b.p, b.n);
		if (ZSTD_isError(got) || got != n) {
			res = NDO_DROP_CORRUPT;
			goto done;
		}
		b = (rbuf){w->buf2, (size_t)n, 0, 0};
	}
	recon->step = step;
	recon->time = time;
	recon->epoch = epoch;
	if (get_classes(&b, cls, nodes)) {
		res = NDO_DROP_CORRUPT;
		goto done;
	}
	int ok = 1;
	size_t nw = 0, cnt[3];
	class_pass(cls, nodes, enc, recon->have, cnt);
	const size_t nexact = cnt[2];
	if (enc == NDO_ENC_PREDICT && nexact && get_planes(&b, w->u, 3 * nexact)) {
		res = NDO_DROP_CORRUPT;
		goto done;
	}
	for (int n = 0; n < nodes && nexact; n++) {
		if (cls[n] != NDO_NODE_EXACT)
			continue;
		if (enc == NDO_ENC_PREDICT) {
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
	const ndo_codec_frame *prev = before(h, step, epoch);
	double dtp = prev ? time - prev->time : 0, inv = dtp > 0 ? 1 / dtp : 0;
	outs o = {x, v, S, prev, inv, 0};
	int dl = decode_lossy(p, w, &b, flags, cls, cnt[1], rows, cols, ref, step, recon, &o);
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
	for (int n = 0; n < nodes && !o.done; n++) {
		if (cls[n] == NDO_NODE_EXACT)
			continue;
		int lossy = cls[n] == NDO_NODE_LOSSY;
		int est = lossy && prev && prev->have[n] && dtp > 0;
		for (int d = 0; d < 3; d++) {
			x[S * n + d] = lossy ? recon->x[3 * n + d] : NAN;
			v[S * n + d] = est ? (recon->x[3 * n + d] - frame_pos(&z, prev, n, d)) * inv : NAN;
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
	const quant z = quant_of(p);
	const ndo_codec_frame *r[3] = {0};
	for (int k = 0, m = 0; h && k < NDO_CODEC_HISTORY && m < 3; k++)
		if (h->f[k].step >= 0 && h->f[k].step < step && step - h->f[k].step <= NDO_CODEC_MAX_GAP)
			r[m++] = &h->f[k];
	if (!r[0] || p->encoding != NDO_ENC_PREDICT)
		return ndo__fail(NDO_EINVAL, "no frame to predict step %lld from", (long long)step);
	uint8_t *cls = malloc((size_t)nodes);
	int32_t *cur = malloc((size_t)nodes * sizeof *cur);
	if (!cls || !cur) {
		free(cls), free(cur);
		return ndo__fail(NDO_ENOMEM, "out of memory");
	}
	for (int n = 0; n < nodes; n++)
		cls[n] = r[0]->have[n] ? NDO_NODE_LOSSY : NDO_NODE_SKIP;
	pctx c = {.cols = cols, .nodes = nodes, .cls = cls, .cur = cur};
	pctx_init(&c, r[0], r[1], r[2], step);
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
			int64_t k = predict(&c, n, d);
			if (k <= -CODE_MAX || k >= CODE_MAX)
				k = r[0]->k[3 * n + d];
			cur[n] = (int32_t)k;
			recon->k[3 * n + d] = (int32_t)k;
			x[3 * n + d] = recon->x[3 * n + d] = value_of(&z, d, k);
		}
	free(cls), free(cur);
	return 0;
}
