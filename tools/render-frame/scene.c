/* scene.c — grids to frames (scene.h). */
#include "scene.h"
#include "camera.h"

#include "ndo/status.h"
#include "ndo/subdivide.h"
#include "ndo/topology.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int rf_coloring_parse(const char *spec, rf_coloring *out)
{
	memset(out, 0, sizeof *out);
	out->component = -1;
	if (strcmp(spec, "auto") == 0)
		return out->mode = -1, 0;
	if (strcmp(spec, "solid") == 0)
		return out->mode = RF_COLOR_SOLID, 0;
	if (strcmp(spec, "owner") == 0)
		return out->mode = RF_COLOR_OWNER, 0;
	out->mode = RF_COLOR_SCALAR;
	if (strcmp(spec, "displacement") == 0)
		return out->displacement = 1, 0;
	const char *colon = strchr(spec, ':');
	size_t len = colon ? (size_t)(colon - spec) : strlen(spec);
	if (len == 0 || len >= sizeof out->channel)
		return -1;
	for (size_t k = 0; k < len; k++)
		if (!strchr("abcdefghijklmnopqrstuvwxyz0123456789_.-", spec[k]))
			return -1;
	memcpy(out->channel, spec, len);
	if (colon) {
		const char *c = colon + 1;
		if (c[0] && !c[1] && strchr("xyzw", c[0]))
			out->component = c[0] == 'w' ? 3 : c[0] - 'x';
		else if (c[0] >= '0' && c[0] <= '3' && !c[1])
			out->component = c[0] - '0';
		else
			return -1;
	}
	return 0;
}

void rf_coloring_name(const rf_coloring *c, char *buf, size_t size)
{
	if (c->displacement)
		snprintf(buf, size, "displacement");
	else if (c->component >= 0)
		snprintf(buf, size, "%s:%c", c->channel, "xyzw"[c->component]);
	else
		snprintf(buf, size, "%s", c->channel);
}

static int reserve(void **p, size_t *cap, size_t n, size_t elem)
{
	if (n <= *cap)
		return NDO_OK;
	void *q = realloc(*p, n * elem);
	if (!q)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	*p = q;
	*cap = n;
	return NDO_OK;
}

/* Value k of component c of a channel, as a double. */
static double value(const ndo_channel *ch, size_t k, int c)
{
	size_t i = k * (size_t)ch->comps + (size_t)c;
	switch (ch->type) {
	case NDO_F64: return ((const double *)ch->data)[i];
	case NDO_F32: return ((const float *)ch->data)[i];
	case NDO_U8: return ((const uint8_t *)ch->data)[i];
	case NDO_I32: return ((const int32_t *)ch->data)[i];
	}
	return 0;
}

static int prepare_scalar(rf_scene *s, const ndo_grid *g, const rf_coloring *c)
{
	const ndo_channel *pos = ndo_grid_find(g, NDO_CH_POSITION);
	const ndo_channel *ch;
	if (c->displacement) {
		ch = ndo_grid_find(g, NDO_CH_REST);
		if (!ch || ch->comps != 3 || (ch->type != NDO_F64 && ch->type != NDO_F32))
			return ndo__fail(NDO_ENOTFOUND, "no rest channel (3 floats): cannot colour by "
			                 "displacement");
	} else {
		ch = ndo_grid_find(g, c->channel);
		if (!ch)
			return ndo__fail(NDO_ENOTFOUND, "no channel '%s' to colour by", c->channel);
		if (c->component >= ch->comps)
			return ndo__fail(NDO_ERANGE, "channel '%s' has %d component%s, no '%c'",
			                 c->channel, ch->comps, ch->comps == 1 ? "" : "s",
			                 "xyzw"[c->component]);
	}
	int rc = reserve((void **)&s->scalar, &s->scalar_cap, g->count, sizeof *s->scalar);
	if (rc != NDO_OK)
		return rc;
	float lo = INFINITY, hi = -INFINITY;
	for (size_t k = 0; k < g->count; k++) {
		double v;
		if (c->displacement || c->component < 0) {
			double sum = 0;
			for (int d = 0; d < ch->comps; d++) {
				double x = value(ch, k, d) - (c->displacement ? value(pos, k, d) : 0);
				sum += x * x;
			}
			v = ch->comps == 1 && !c->displacement ? value(ch, k, 0) : sqrt(sum);
		} else {
			v = value(ch, k, c->component);
		}
		float f = (float)v;
		if (!isfinite(f))
			return ndo__fail(NDO_ERANGE, "channel '%s' has a non-finite value at node (%zu, %zu)",
			                 ch->name, k % (size_t)g->w, k / (size_t)g->w);
		s->scalar[k] = f;
		lo = f < lo ? f : lo;
		hi = f > hi ? f : hi;
	}
	s->frame.scalar = s->scalar;
	s->frame.range[0] = lo;
	s->frame.range[1] = hi;
	return NDO_OK;
}


/* Owner ids → palette places (issue 16): the peers in the order the grid
 * meets them, row by row from node (0, 0) — their places in the
 * partition — so that up to RF_PALETTE peers always get distinct colours
 * whatever their (random) ids.  Negative ids (unowned) stay −1. */
static void owner_ranks(const int32_t *id, size_t count, int32_t *rank)
{
	int32_t seen[64];
	int nseen = 0;
	for (size_t k = 0; k < count; k++) {
		if (id[k] < 0) {
			rank[k] = -1;
			continue;
		}
		int r = 0;
		while (r < nseen && seen[r] != id[k])
			r++;
		if (r == nseen && nseen < 64)
			seen[nseen++] = id[k];
		rank[k] = r < 64 ? r : 63; /* more than 64 peers: the colours repeat anyway */
	}
}

int rf_scene_prepare(rf_scene *s, const ndo_grid *in, int subdivide, const rf_coloring *c,
                     int refit)
{
	const ndo_grid *g = in;
	ndo_grid *fine = NULL;
	int rc;
	/* Checked before refining, so that the node named is the file's
	 * (refined, a NaN spreads over the butterfly's reach). */
	const ndo_channel *ipos = ndo_grid_find(in, NDO_CH_POSITION);
	for (size_t k = 0; k < in->count * 3; k++)
		if (!isfinite(value(ipos, k / 3, (int)(k % 3))))
			return ndo__fail(NDO_ERANGE, "position of node (%zu, %zu) is not finite",
			                 k / 3 % (size_t)in->w, k / 3 / (size_t)in->w);
	if (subdivide > 0) {
		if (in->level + subdivide > NDO_MAX_LEVEL)
			return ndo__fail(NDO_ERANGE, "level %d refined by %d exceeds the largest level, %d",
			                 in->level, subdivide, NDO_MAX_LEVEL);
		if ((rc = ndo_subdivide_levels(in, subdivide, NDO_CORNERS_ZORIN, &fine)) != NDO_OK)
			return rc;
		g = fine;
	}
	const ndo_channel *pos = ndo_grid_find(g, NDO_CH_POSITION);
	size_t padded = (size_t)(g->w + 2) * (size_t)(g->h + 2);
	float *tmp = malloc(g->count * 3 * sizeof *tmp);
	if (!tmp || (rc = reserve((void **)&s->position, &s->position_cap, padded * 3,
	                          sizeof *s->position)) != NDO_OK) {
		free(tmp);
		ndo_grid_destroy(fine);
		return tmp ? rc : ndo__fail(NDO_ENOMEM, "out of memory");
	}
	double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
	for (size_t k = 0; k < g->count * 3; k++) {
		double v = value(pos, k / 3, (int)(k % 3));
		if (!isfinite(v)) {
			/* finite values the refinement took beyond DBL_MAX; the
			 * message is made before `fine` (g) is freed */
			rc = ndo__fail(NDO_ERANGE, "position of node (%zu, %zu) of the grid refined "
			               "by %d levels is not finite", k / 3 % (size_t)g->w,
			               k / 3 / (size_t)g->w, subdivide);
			free(tmp);
			ndo_grid_destroy(fine);
			return rc;
		}
		lo[k % 3] = fmin(lo[k % 3], v);
		hi[k % 3] = fmax(hi[k % 3], v);
	}
	if (refit || !(s->unit > 0)) {
		/* half the box's diagonal, taken so that it cannot overflow */
		double m = 0, r2 = 0;
		for (int d = 0; d < 3; d++) {
			s->origin[d] = 0.5 * lo[d] + 0.5 * hi[d];
			m = fmax(m, 0.5 * hi[d] - 0.5 * lo[d]);
		}
		for (int d = 0; d < 3; d++)
			if (m > 0)
				r2 += pow((0.5 * hi[d] - 0.5 * lo[d]) / m, 2);
		s->unit = m > 0 ? m * sqrt(r2) : fmax(1, fabs(s->origin[0]) + fabs(s->origin[1]) +
		                                         fabs(s->origin[2]));
		if (!(s->unit > 0) || !isfinite(s->unit))
			s->unit = 1;
	}
	for (size_t k = 0; k < g->count * 3; k++) {
		double v = (value(pos, k / 3, (int)(k % 3)) - s->origin[k % 3]) / s->unit;
		tmp[k] = (float)v;
		if (!isfinite(tmp[k])) {
			/* only a later frame of a sequence can get here: it moved
			 * beyond 1e38 times the first frame's size */
			rc = ndo__fail(NDO_ERANGE, "node (%zu, %zu) is %.3g sizes of the first frame away "
			               "from it: cannot be drawn in one picture (use --refit)",
			               k / 3 % (size_t)g->w, k / 3 / (size_t)g->w, v);
			free(tmp);
			ndo_grid_destroy(fine);
			return rc;
		}
	}
	ndo_pad(g->level, 1, tmp, 3 * sizeof *tmp, s->position);
	rf_bounds(tmp, g->count, 3, s->center, &s->radius);
	free(tmp);

	memset(&s->frame, 0, sizeof s->frame);
	s->frame.level = g->level;
	s->frame.position = s->position;
	s->frame.wire_step = (float)(1 << subdivide);
	rc = NDO_OK;
	if (c->mode == RF_COLOR_OWNER) {
		const ndo_channel *ch = ndo_grid_find(g, NDO_CH_OWNER);
		if (!ch || ch->type != NDO_I32 || ch->comps != 1)
			rc = ndo__fail(NDO_ENOTFOUND, "no owner channel (1 × i32): cannot colour by owner");
		else if ((rc = reserve((void **)&s->owner, &s->owner_cap, g->count,
		                       sizeof *s->owner)) == NDO_OK) {
			owner_ranks(ch->data, g->count, s->owner);
			s->frame.owner = s->owner;
		}
	} else if (c->mode == RF_COLOR_SCALAR) {
		rc = prepare_scalar(s, g, c);
	}
	ndo_grid_destroy(fine);
	return rc;
}

void rf_scene_free(rf_scene *s)
{
	free(s->position);
	free(s->owner);
	free(s->scalar);
	memset(s, 0, sizeof *s);
}
