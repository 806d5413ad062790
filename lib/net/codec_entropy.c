/* codec_entropy.c — the entropy stage of the state codec (ndo/codec.h):
 * residuals as 2-bit symbols with varint escapes, read in one piece or in
 * place for the row loops; the EXACT nodes' doubles as byte planes; the
 * nodes' classes as runs; and zstd over the whole body. */
#include "codec_private.h"
#include "ndo/status.h"

#include <string.h>
#include <zstd.h>

/* zstd's level: 1 (docs/bench/net.md: levels -5..3 against bits and time;
 * set by bench_codec -z only) */
int ndo__codec_zstd_level = 1;

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

/* The residuals u[0..m) (zigzag codes): 2-bit symbols, four to a byte,
 * first in the low bits — u itself below 3, 3 for an escape —, then each
 * escape's u − 3 as a varint. */
void ndo__codec_put_residuals(wbuf *b, const uint64_t *u, size_t m)
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
int ndo__codec_get_residuals(rbuf *r, uint64_t *u, size_t m)
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
 * component's begin); the same checks as ndo__codec_get_residuals(). */
int ndo__codec_get_symbols(rbuf *r, size_t lossy, uint64_t *esc, syms *sy)
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

/* The EXACT nodes' words (codec.c) as byte planes, most significant
 * first, so that zstd finds the planes of agreeing high bytes as runs. */
void ndo__codec_put_planes(wbuf *b, const uint64_t *w, size_t m)
{
	if (reserve(b, 8 * m))
		return;
	uint8_t *o = b->p + b->n;
	for (int plane = 7; plane >= 0; plane--)
		for (size_t k = 0; k < m; k++)
			*o++ = (uint8_t)(w[k] >> (8 * plane));
	b->n += 8 * m;
}

int ndo__codec_get_planes(rbuf *r, uint64_t *w, size_t m)
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

void ndo__codec_put_classes(wbuf *b, const uint8_t *cls, int nodes)
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

int ndo__codec_get_classes(rbuf *r, uint8_t *cls, int nodes)
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

int ndo__codec_zstd_put(ndo_codec_work *w, wbuf *out, const wbuf *body)
{
	size_t bound = ZSTD_compressBound(body->n);
	if (grow(&w->buf, &w->cap, bound))
		return -1;
	size_t z = ZSTD_compressCCtx(w->cc, w->buf, bound, body->p, body->n,
	                             ndo__codec_zstd_level);
	if (!ZSTD_isError(z) && z < body->n) {
		out->p[0] |= F_ZSTD;
		put(out, w->buf, z);
	} else {
		put(out, body->p, body->n);
	}
	return out->fail ? -1 : 0;
}

ndo_drop ndo__codec_zstd_get(ndo_codec_work *w, rbuf *b, size_t bound)
{
	unsigned long long n = ZSTD_getFrameContentSize(b->p, b->n);
	if (n == ZSTD_CONTENTSIZE_ERROR || n == ZSTD_CONTENTSIZE_UNKNOWN || n > bound)
		return NDO_DROP_CORRUPT; /* not zstd, or a bomb */
	if (grow(&w->buf2, &w->cap2, (size_t)n + 1))
		return NDO_DROP_RANGE;
	size_t got = ZSTD_decompressDCtx(w->dc, w->buf2, (size_t)n, b->p, b->n);
	if (ZSTD_isError(got) || got != n)
		return NDO_DROP_CORRUPT;
	*b = (rbuf){w->buf2, (size_t)n, 0, 0};
	return NDO_DROP_NONE;
}
