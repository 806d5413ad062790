/* codec_params.c — the state encodings' parameters (ndo/codec.h): parsing
 * and naming them, the object's box, error bounds, and their text form in a
 * session's description. */
#include "codec_private.h"
#include "ndo/io.h"
#include "ndo/status.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- parameters ----------------------------------------------------------- */
static const char *const enc_names[] = {"raw", "float32", "fixed", "predict", "hier"};

int ndo_codec_parse(const char *spec, ndo_codec_params *p)
{
	char name[32];
	int bits = NDO_CODEC_BITS_DEFAULT, key = NDO_CODEC_KEYFRAME_DEFAULT;
	double err = 0;
	const char *colon = strchr(spec, ':');
	size_t n = colon ? (size_t)(colon - spec) : strlen(spec);
	if (n == 0 || n >= sizeof name)
		return ndo__fail(NDO_EINVAL, "'%s': not raw, float32, fixed[:BITS], "
		                 "predict[:BITS[:KEYFRAME]] or hier[:BITS[:KEYFRAME]]", spec);
	memcpy(name, spec, n);
	name[n] = 0;
	int e = -1;
	for (int k = 0; k < 5; k++)
		if (strcmp(name, enc_names[k]) == 0)
			e = k;
	if (e < 0)
		return ndo__fail(NDO_EINVAL, "'%s': unknown encoding (raw, float32, fixed, predict, "
		                 "hier)",
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
			if (e < NDO_ENC_PREDICT || end == ks || *end || kk < 1 || kk > 4096)
				return ndo__fail(NDO_EINVAL, "'%s': the keyframe period must be 1..4096 "
				                 "(predict and hier only)", spec);
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
	int e = p->encoding >= 0 && p->encoding < 5 ? p->encoding : 0;
	char depth[32];
	if (p->error > 0)
		snprintf(depth, sizeof depth, "%.3g", p->error);
	else
		snprintf(depth, sizeof depth, "%d", p->bits);
	if (!strpbrk(depth, ".e") && p->error > 0) /* "1" would read as bits */
		snprintf(depth, sizeof depth, "%.1f", p->error);
	if (e == NDO_ENC_FIXED)
		snprintf(buf, size, "fixed:%s", depth);
	else if (e >= NDO_ENC_PREDICT)
		snprintf(buf, size, "%s:%s:%d", enc_names[e], depth, p->keyframe);
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
	case NDO_ENC_HIER:
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
	if (p->encoding < NDO_ENC_RAW || p->encoding > NDO_ENC_HIER)
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

typedef struct tile_lines {
	ndo_codec_params *p;
	int seen;
} tile_lines;

static int tile_line(void *arg, const char *l)
{
	tile_lines *t = arg;
	ndo_codec_params *p = t->p;
	int k;
	if (sscanf(l, "tile-encoding %d", &k) == 1)
		p->encoding = k, t->seen |= 1;
	else if (sscanf(l, "tile-bits %d", &k) == 1)
		p->bits = k, t->seen |= 2;
	else if (sscanf(l, "tile-keyframe %d", &k) == 1)
		p->keyframe = k, t->seen |= 4;
	else if (sscanf(l, "tile-box %lf %lf %lf %lf %lf %lf", &p->lo[0], &p->lo[1], &p->lo[2],
	                &p->ext[0], &p->ext[1], &p->ext[2]) == 6)
		t->seen |= 8;
	else if (sscanf(l, "tile-error %lf", &p->error) == 1 && p->error > 0)
		t->seen |= 16; /* optional: the step from an error budget */
	else
		return ndo__fail(NDO_EINVAL, "the owner's description: bad line '%s'", l);
	return 0;
}

int ndo_codec_params_take(char *text, ndo_codec_params *p)
{
	memset(p, 0, sizeof *p);
	p->encoding = NDO_ENC_RAW;
	tile_lines t = {p, 0};
	int rc = ndo_lines_take(text, "tile-", tile_line, &t);
	const int seen = t.seen;
	if (rc)
		return rc;
	if (seen && (seen & 15) != 15)
		return ndo__fail(NDO_EINVAL, "the owner's description: incomplete tile-* lines");
	return seen ? ndo_codec_params_check(p) : 0;
}

/* A description's scene as it arrives (len bytes, not NUL-terminated, NULL
 * when len is 0) as a string to take lines from (malloc'd; NULL: out of
 * memory, said). */
static char *scene_text(const void *scene, size_t len)
{
	char *text = malloc(len + 1);
	if (!text) {
		ndo__fail(NDO_ENOMEM, "out of memory");
		return NULL;
	}
	if (len)
		memcpy(text, scene, len);
	text[len] = 0;
	return text;
}

int ndo_codec_params_read(const void *scene, size_t len, ndo_codec_params *p)
{
	char *text = scene_text(scene, len);
	if (!text)
		return NDO_ENOMEM;
	int rc = ndo_codec_params_take(text, p);
	free(text);
	return rc;
}

/* ---- the send level ("send-level L") ----------------------------------- */
int ndo_send_level_text(int send_level, int level, char *buf, size_t size)
{
	int n = send_level < level ? snprintf(buf, size, "send-level %d\n", send_level) : 0;
	if (n == 0 && size)
		*buf = 0;
	if (n < 0 || (size_t)n >= size)
		return ndo__fail(NDO_ERANGE, "send level: the description line does not fit");
	return n;
}

typedef struct send_line {
	int level, *out, seen;
} send_line;

static int send_level_line(void *arg, const char *l)
{
	send_line *t = arg;
	int k, end = 0;
	if (t->seen || sscanf(l, "send-level %d%n", &k, &end) != 1 || l[end] || k < 0 ||
	    k > t->level)
		return ndo__fail(NDO_EINVAL, "the owner's description: bad line '%s' (a send level "
		                 "0..%d, once)", l, t->level);
	*t->out = k;
	t->seen = 1;
	return 0;
}

int ndo_send_level_take(char *text, int level, int *send_level)
{
	*send_level = level;
	send_line t = {level, send_level, 0};
	return ndo_lines_take(text, "send-level", send_level_line, &t);
}

int ndo_send_level_read(const void *scene, size_t len, int level, int *send_level)
{
	char *text = scene_text(scene, len);
	*send_level = level;
	if (!text)
		return NDO_ENOMEM;
	int rc = ndo_send_level_take(text, level, send_level);
	free(text);
	return rc;
}
