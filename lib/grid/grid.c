/* grid.c — the grid container: channels, copies, conversions, history
 * (ndo/grid.h). */
#include "ndo/grid.h"
#include "grid_private.h"
#include "ndo/gridfile.h"
#include "ndo/status.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

size_t ndo_type_size(ndo_type t)
{
	switch (t) {
	case NDO_F64: return 8;
	case NDO_F32: return 4;
	case NDO_U8: return 1;
	case NDO_I32: return 4;
	}
	return 0;
}

const char *ndo_type_name(ndo_type t)
{
	switch (t) {
	case NDO_F64: return "f64";
	case NDO_F32: return "f32";
	case NDO_U8: return "u8";
	case NDO_I32: return "i32";
	}
	return "?";
}

static int valid_name(const char *name)
{
	size_t len = strlen(name);
	if (len == 0 || len >= NDO_NAME_LEN)
		return 0;
	for (size_t k = 0; k < len; k++) {
		char c = name[k];
		if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
		      c == '_' || c == '-' || c == '.'))
			return 0;
	}
	return 1;
}

int ndo__grid_alloc(int level, ndo_grid **out)
{
	*out = NULL;
	if (level < 0 || level > NDO_MAX_LEVEL)
		return ndo__fail(NDO_ERANGE, "level %d is outside 0..%d", level,
		                 NDO_MAX_LEVEL);
	ndo_grid *g = calloc(1, sizeof *g);
	if (!g)
		return ndo__fail(NDO_ENOMEM, "out of memory for a grid");
	g->level = level;
	g->n = 1 << level;
	g->w = 2 * g->n + 1;
	g->h = g->n + 1;
	g->count = (size_t)g->w * (size_t)g->h;
	g->history = calloc(1, 1);
	if (!g->history) {
		free(g);
		return ndo__fail(NDO_ENOMEM, "out of memory for a grid");
	}
	*out = g;
	return NDO_OK;
}

int ndo_grid_create(int level, ndo_grid **out)
{
	int rc = ndo__grid_alloc(level, out);
	if (rc == NDO_OK && (rc = ndo_grid_add(*out, NDO_CH_POSITION, NDO_F64, 3, NULL))) {
		ndo_grid_destroy(*out);
		*out = NULL;
	}
	return rc;
}

void ndo_grid_destroy(ndo_grid *g)
{
	if (!g)
		return;
	for (int c = 0; c < g->nchannels; c++)
		free(g->ch[c].data);
	free(g->history);
	free(g);
}

int ndo_grid_copy(const ndo_grid *g, ndo_grid **out)
{
	ndo_grid *c = malloc(sizeof *c);
	*out = NULL;
	if (!c)
		return ndo__fail(NDO_ENOMEM, "out of memory copying a grid");
	*c = *g;
	c->history = strdup(g->history);
	int ok = c->history != NULL;
	for (int k = 0; k < g->nchannels; k++) {
		size_t bytes = g->count * (size_t)g->ch[k].comps *
		               ndo_type_size(g->ch[k].type);
		c->ch[k].data = ok ? malloc(bytes) : NULL;
		if (!c->ch[k].data)
			ok = 0;
		else
			memcpy(c->ch[k].data, g->ch[k].data, bytes);
	}
	if (!ok) {
		ndo_grid_destroy(c);
		return ndo__fail(NDO_ENOMEM, "out of memory copying a grid");
	}
	*out = c;
	return NDO_OK;
}

ndo_channel *ndo_grid_find(const ndo_grid *g, const char *name)
{
	for (int c = 0; c < g->nchannels; c++)
		if (strcmp(g->ch[c].name, name) == 0)
			return (ndo_channel *)&g->ch[c];
	return NULL;
}

int ndo_grid_add(ndo_grid *g, const char *name, ndo_type type, int comps,
                 ndo_channel **out)
{
	if (out)
		*out = NULL;
	if (!valid_name(name))
		return ndo__fail(NDO_EINVAL,
		                 "bad channel name '%.40s' (1..15 of a-z 0-9 _ . -)",
		                 name);
	if (ndo_type_size(type) == 0 || comps < 1 || comps > 4)
		return ndo__fail(NDO_EINVAL, "channel '%s': bad type or width", name);
	ndo_channel *c = ndo_grid_find(g, name);
	if (c) {
		if (c->type != type || c->comps != comps)
			return ndo__fail(NDO_EINVAL,
			                 "channel '%s' exists as %d × %s, not %d × %s",
			                 name, c->comps, ndo_type_name(c->type), comps,
			                 ndo_type_name(type));
		if (out)
			*out = c;
		return NDO_OK;
	}
	if (g->nchannels == NDO_MAX_CHANNELS)
		return ndo__fail(NDO_ERANGE, "more than %d channels", NDO_MAX_CHANNELS);
	void *data = calloc(g->count * (size_t)comps, ndo_type_size(type));
	if (!data)
		return ndo__fail(NDO_ENOMEM, "out of memory for channel '%s'", name);
	c = &g->ch[g->nchannels++];
	memset(c->name, 0, sizeof c->name);
	strcpy(c->name, name);
	c->type = type;
	c->comps = comps;
	c->data = data;
	if (out)
		*out = c;
	return NDO_OK;
}

void ndo_grid_remove(ndo_grid *g, const char *name)
{
	ndo_channel *c = ndo_grid_find(g, name);
	if (!c || strcmp(name, NDO_CH_POSITION) == 0)
		return;
	free(c->data);
	int k = (int)(c - g->ch);
	memmove(&g->ch[k], &g->ch[k + 1],
	        (size_t)(g->nchannels - k - 1) * sizeof g->ch[0]);
	g->nchannels--;
}

static double get_value(const void *data, ndo_type t, size_t k)
{
	switch (t) {
	case NDO_F64: return ((const double *)data)[k];
	case NDO_F32: return ((const float *)data)[k];
	case NDO_U8: return ((const uint8_t *)data)[k];
	case NDO_I32: return ((const int32_t *)data)[k];
	}
	return 0;
}

static void put_value(void *data, ndo_type t, size_t k, double v)
{
	switch (t) {
	case NDO_F64: ((double *)data)[k] = v; break;
	case NDO_F32: ((float *)data)[k] = (float)v; break;
	case NDO_U8:
		((uint8_t *)data)[k] = isnan(v) ? 0 : v < 0 ? 0 : v > 255 ? 255 : (uint8_t)v;
		break;
	case NDO_I32:
		((int32_t *)data)[k] = isnan(v) ? 0 : v < INT32_MIN ? INT32_MIN
		                       : v > INT32_MAX ? INT32_MAX : (int32_t)v;
		break;
	}
}

int ndo_grid_convert(ndo_grid *g, const char *name, ndo_type type)
{
	ndo_channel *c = ndo_grid_find(g, name);
	if (!c)
		return ndo__fail(NDO_ENOTFOUND, "no channel '%s'", name);
	if (ndo_type_size(type) == 0)
		return ndo__fail(NDO_EINVAL, "bad type %d", (int)type);
	if (c->type == type)
		return NDO_OK;
	size_t n = g->count * (size_t)c->comps;
	void *data = malloc(n * ndo_type_size(type));
	if (!data)
		return ndo__fail(NDO_ENOMEM, "out of memory converting '%s'", name);
	for (size_t k = 0; k < n; k++)
		put_value(data, type, k, get_value(c->data, c->type, k));
	free(c->data);
	c->data = data;
	c->type = type;
	return NDO_OK;
}

double *ndo_grid_f64(ndo_grid *g, const char *name, int comps)
{
	ndo_channel *c = ndo_grid_find(g, name);
	if (!c || c->comps != comps || (c->type != NDO_F64 && c->type != NDO_F32))
		return NULL;
	if (ndo_grid_convert(g, name, NDO_F64))
		return NULL;
	return ndo_grid_find(g, name)->data;
}

int ndo_grid_nonfinite(const ndo_grid *g, const char *name, int *i, int *j)
{
	const ndo_channel *c = ndo_grid_find(g, name);
	if (!c || (c->type != NDO_F64 && c->type != NDO_F32))
		return 0;
	size_t n = g->count * (size_t)c->comps;
	for (size_t k = 0; k < n; k++) {
		double v = c->type == NDO_F64 ? ((const double *)c->data)[k]
		                              : (double)((const float *)c->data)[k];
		if (!isfinite(v)) {
			size_t node = k / (size_t)c->comps;
			if (i)
				*i = (int)(node % (size_t)g->w);
			if (j)
				*j = (int)(node / (size_t)g->w);
			return 1;
		}
	}
	return 0;
}

/* Quote one argument the way a POSIX shell would need it. */
static size_t quote_arg(const char *a, char *out)
{
	int plain = *a != '\0';
	for (const char *p = a; *p; p++)
		if (!strchr("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
		            "0123456789_-./=:,+%@", *p))
			plain = 0;
	size_t n = 0;
	if (plain) {
		for (const char *p = a; *p; p++)
			out ? (void)(out[n++] = *p) : (void)n++;
		return n;
	}
	out ? (void)(out[n++] = '\'') : (void)n++;
	for (const char *p = a; *p; p++) {
		if (*p == '\'') {
			if (out)
				memcpy(out + n, "'\\''", 4);
			n += 4;
		} else if (*p == '\n') {
			out ? (void)(out[n++] = ' ') : (void)n++;
		} else {
			out ? (void)(out[n++] = *p) : (void)n++;
		}
	}
	out ? (void)(out[n++] = '\'') : (void)n++;
	return n;
}

/* A history over NDO_HISTORY_MAX bytes is one no reader takes: a grid
 * that came through thousands of tools (a simulation continued in
 * chunks) could go through none more, and simulate-peer said so after
 * its whole run.  The first line stays (where the grid came from: what
 * render-frame reads), then a line saying how many were dropped, then the
 * newest lines that fit; a newest line that alone does not fit is cut. */
static void trim_history(char *h)
{
	size_t len = strlen(h);
	if (len <= NDO_HISTORY_MAX)
		return;
	char *second = strchr(h, '\n');
	size_t first = second ? (size_t)(second - h) + 1 : 0;
	if (first > NDO_HISTORY_MAX / 2) /* a first line that alone fills it */
		first = 0;
	char mark[96];
	size_t lines = 0, room = NDO_HISTORY_MAX - first - (sizeof mark - 1);
	const char *keep = h + len; /* the newest whole lines within room */
	while (keep > h + first) {
		const char *start = keep - 1;
		while (start > h + first && start[-1] != '\n')
			start--;
		if ((size_t)(h + len - start) > room)
			break;
		keep = start;
	}
	if (keep == h + len) /* the newest line alone is too long: its tail */
		keep = h + len - room;
	for (const char *q = h + first; q < keep; q++)
		lines += *q == '\n';
	int n = snprintf(mark, sizeof mark, "# %zu earlier line%s dropped: the history is kept "
	                 "under %u bytes\n", lines, lines == 1 ? "" : "s", NDO_HISTORY_MAX);
	size_t tail = (size_t)(h + len - keep);
	memmove(h + first + (size_t)n, keep, tail + 1);
	memcpy(h + first, mark, (size_t)n);
}

int ndo_grid_add_history(ndo_grid *g, int argc, char *const argv[])
{
	size_t len = 0;
	for (int k = 0; k < argc; k++)
		len += quote_arg(argv[k], NULL) + 1;
	size_t old = strlen(g->history);
	char *h = realloc(g->history, old + len + 2);
	if (!h)
		return ndo__fail(NDO_ENOMEM, "out of memory for history");
	g->history = h;
	char *p = h + old;
	for (int k = 0; k < argc; k++) {
		p += quote_arg(argv[k], p);
		*p++ = k + 1 < argc ? ' ' : '\n';
	}
	if (argc == 0)
		*p++ = '\n';
	*p = '\0';
	trim_history(h);
	return NDO_OK;
}
