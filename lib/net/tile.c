/* tile.c — grid ⇄ state tiles (ndo/tile.h). */
#include "ndo/tile.h"
#include "ndo/status.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static const char *const vec_names[3] = {NDO_CH_POSITION, NDO_CH_VELOCITY, NDO_CH_REST};

int ndo_tile_pack(const ndo_grid *g, ndo_quad q, int channels, ndo_msg_tile_t *t)
{
	int i0, j0, i1, j1;
	ndo_quad_range(g->level, q, &i0, &j0, &i1, &j1);
	int vpn = ndo_tile_values_per_node(channels);
	size_t nodes = (size_t)(i1 - i0 + 1) * (size_t)(j1 - j0 + 1);
	double *v = malloc(nodes * (size_t)vpn * sizeof *v);
	if (!v)
		return ndo__fail(NDO_ENOMEM, "tile: out of memory");
	const double *vec[3] = {0};
	for (int c = 0; c < 3; c++) {
		ndo_channel *ch = ndo_grid_find(g, vec_names[c]);
		vec[c] = ch && ch->type == NDO_F64 && ch->comps == 3 ? ch->data : NULL;
	}
	ndo_channel *pin = ndo_grid_find(g, NDO_CH_PIN);
	const uint8_t *pv = pin && pin->type == NDO_U8 ? pin->data : NULL;
	size_t k = 0;
	const int body = NDO_TILE_POSITION | NDO_TILE_VELOCITY | NDO_TILE_REST | NDO_TILE_PIN;
	if ((channels & body) == (NDO_TILE_POSITION | NDO_TILE_VELOCITY) && vec[0] && vec[1]) {
		/* a frame's tile, position and velocity: a node's six values
		 * copied as they lie, no test a value (test_msg
		 * tiles_pack_as_the_reference checks both loops against a
		 * node-by-node packer) */
		const size_t row = (size_t)(i1 - i0 + 1);
		for (int j = j0; j <= j1; j++) {
			const double *restrict x = vec[0] + 3 * ndo_node(g->w, i0, j);
			const double *restrict u = vec[1] + 3 * ndo_node(g->w, i0, j);
			double *restrict o = v + k;
			for (size_t n = 0; n < row; n++) {
				memcpy(o + 6 * n, x + 3 * n, 3 * sizeof *o);
				memcpy(o + 6 * n + 3, u + 3 * n, 3 * sizeof *o);
			}
			k += 6 * row;
		}
	} else
		for (int j = j0; j <= j1; j++)
			for (int i = i0; i <= i1; i++) {
				size_t node = ndo_node(g->w, i, j);
				for (int c = 0; c < 3; c++)
					if (channels & (1 << c))
						for (int d = 0; d < 3; d++)
							v[k++] = vec[c] ? vec[c][3 * node + d] : 0.0;
				if (channels & NDO_TILE_PIN)
					v[k++] = pv && pv[node] ? 1.0 : 0.0;
			}
	t->depth = (int8_t)q.depth;
	t->i0 = i0, t->j0 = j0, t->i1 = i1, t->j1 = j1;
	t->channels = (int16_t)channels;
	t->encoding = NDO_ENC_RAW;
	t->base_step = -1;
	t->nvalues = (int32_t)k;
	t->values = v;
	t->nbytes = 0;
	t->data = NULL;
	return 0;
}

size_t ndo_tile_apply(ndo_grid *g, const ndo_msg_tile_t *t, const int32_t *owner,
                      int32_t only)
{
	double *vec[3] = {0};
	for (int c = 0; c < 3; c++) {
		ndo_channel *ch = ndo_grid_find(g, vec_names[c]);
		vec[c] = ch && ch->type == NDO_F64 && ch->comps == 3 ? ch->data : NULL;
	}
	ndo_channel *pin = ndo_grid_find(g, NDO_CH_PIN);
	uint8_t *pv = pin && pin->type == NDO_U8 ? pin->data : NULL;
	size_t k = 0, written = 0;
	for (int j = t->j0; j <= t->j1; j++)
		for (int i = t->i0; i <= t->i1; i++) {
			size_t node = ndo_node(g->w, i, j);
			int take = !owner || owner[node] == only;
			written += take;
			for (int c = 0; c < 3; c++)
				if (t->channels & (1 << c)) {
					/* NaN: a decoded tile does not carry this node (ndo/codec.h) */
					if (take && vec[c] && !isnan(t->values[k]))
						memcpy(&vec[c][3 * node], &t->values[k], 3 * sizeof(double));
					k += 3;
				}
			if (t->channels & NDO_TILE_PIN) {
				if (take && pv)
					pv[node] = t->values[k] != 0;
				k++;
			}
		}
	return written;
}

int ndo_tile_copy(const ndo_msg_tile_t *t, ndo_msg_tile_t *out)
{
	*out = *t;
	out->values = malloc((size_t)(t->nvalues > 0 ? t->nvalues : 1) * sizeof *out->values);
	out->data = NULL;
	out->nbytes = 0;
	if (!out->values)
		return ndo__fail(NDO_ENOMEM, "tile: out of memory");
	if (t->nvalues > 0)
		memcpy(out->values, t->values, (size_t)t->nvalues * sizeof *out->values);
	return 0;
}
