/* sleep.c — tiles of a still surface that are not stepped (issue 18,
 * docs/simulate-peer.md "Sleeping tiles").
 *
 * The stored grid is cut into square tiles of TILE × TILE nodes (a node
 * belongs to the tile of its canonical copy).  Every `every` steps the
 * awake tiles are looked at: a tile is quiet when no force acts on it and
 * every node has |u| ≤ umax and |v| ≤ vmax.  A quiet tile whose
 * neighbours (tiles sharing a stencil edge, across the seams too) are all
 * quiet or asleep falls asleep: its nodes become held (ndo_sim_set_active's
 * machinery: they keep their state and are not stepped).  A tile that is
 * not quiet wakes its sleeping neighbours.  `every` is small enough that a
 * disturbance (at most `reach` rings a step) cannot cross an awake tile
 * between two looks, so motion meets an awake tile before a sleeping one.
 *
 * Deterministic: the decision reads the state only, never a clock or the
 * thread count.  This file only decides; integrate.c applies the mask. */
#include "sim_private.h"

#include "ndo/grid.h"
#include "ndo/status.h"
#include "ndo/topology.h"

#include <stdlib.h>
#include <string.h>

enum { TILE = 32, STAY = 4 };

struct ndo__sleep {
	double umax2, vmax2;
	int every, since;
	int ntiles;
	int32_t *tile_of;     /* per stored node */
	int32_t *tstart;      /* canonical nodes of tile t: tnodes[tstart[t] .. tstart[t+1]) */
	int32_t *tnodes;
	int32_t *astart;      /* neighbour tiles: adj[astart[t] .. astart[t+1]) */
	int32_t *adj;
	uint8_t *forced, *awake, *quiet, *next;
	uint8_t *age;         /* per tile: looks since it last woke (to STAY) */
	uint8_t *mask;        /* per stored node: awake */
	int32_t *stepped;     /* per tile: canonical nodes a step integrates (not
	                         projected pins) */
	size_t nawake_nodes, nall_nodes; /* of them, in awake tiles and in all */
	int64_t checks, wakes, sleeps;
};

static int cmp_pair(const void *a, const void *b)
{
	const int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
	return x < y ? -1 : x > y;
}

void ndo__sleep_free(ndo__sleep *z)
{
	if (!z)
		return;
	free(z->tile_of), free(z->tstart), free(z->tnodes), free(z->astart), free(z->adj);
	free(z->forced), free(z->awake), free(z->quiet), free(z->next), free(z->mask);
	free(z->stepped), free(z->age);
	free(z);
}

static void fill_mask(ndo__sleep *z, const ndo_sim *s)
{
	for (size_t p = 0; p < s->count; p++)
		z->mask[p] = z->awake[z->tile_of[p]];
	z->nawake_nodes = 0;
	for (int t = 0; t < z->ntiles; t++)
		if (z->awake[t])
			z->nawake_nodes += (size_t)z->stepped[t];
}

int ndo__sleep_create(const ndo_sim *s, double umax, double vmax, int reach, ndo__sleep **out)
{
	*out = NULL;
	ndo__sleep *z = calloc(1, sizeof *z);
	if (!z)
		return ndo__fail(NDO_ENOMEM, "out of memory for sleeping tiles");
	z->umax2 = umax * umax;
	z->vmax2 = vmax * vmax;
	/* a look every TILE / (2·reach) steps: a disturbance crosses at most
	 * half an awake tile between looks */
	z->every = TILE / (2 * (reach > 0 ? reach : 1));
	if (z->every < 1)
		z->every = 1;
	const int w = s->w, h = s->h, tx = (w + TILE - 1) / TILE, ty = (h + TILE - 1) / TILE;
	z->ntiles = tx * ty;
	const size_t cnt = s->count, nt = (size_t)z->ntiles;
	z->tile_of = malloc(cnt * sizeof *z->tile_of);
	z->tstart = calloc(nt + 1, sizeof *z->tstart);
	z->tnodes = malloc(cnt * sizeof *z->tnodes);
	z->astart = calloc(nt + 1, sizeof *z->astart);
	z->forced = calloc(nt, 1), z->awake = malloc(nt), z->quiet = malloc(nt), z->next = malloc(nt);
	z->mask = malloc(cnt);
	z->stepped = calloc(nt, sizeof *z->stepped);
	z->age = calloc(nt, 1);
	int64_t *pairs = malloc(6 * cnt * sizeof *pairs);
	if (!z->tile_of || !z->tstart || !z->tnodes || !z->astart || !z->forced || !z->awake ||
	    !z->quiet || !z->next || !z->mask || !z->stepped || !z->age || !pairs) {
		free(pairs);
		ndo__sleep_free(z);
		return ndo__fail(NDO_ENOMEM, "out of memory for sleeping tiles");
	}
	for (size_t p = 0; p < cnt; p++) {
		size_t c = (size_t)s->canon[p];
		z->tile_of[p] = (int32_t)((c / (size_t)w) / TILE * (size_t)tx + (c % (size_t)w) / TILE);
	}
	/* the canonical nodes of each tile, and the pairs of neighbouring tiles */
	size_t np = 0;
	for (size_t p = 0; p < cnt; p++)
		if ((size_t)s->canon[p] == p)
			z->tstart[z->tile_of[p] + 1]++;
	for (size_t t = 0; t < nt; t++)
		z->tstart[t + 1] += z->tstart[t];
	int32_t *fill = z->astart; /* scratch, rebuilt below */
	memcpy(fill, z->tstart, (nt + 1) * sizeof *fill);
	for (size_t p = 0; p < cnt; p++) {
		if ((size_t)s->canon[p] != p)
			continue;
		int32_t t = z->tile_of[p];
		z->tnodes[fill[t]++] = (int32_t)p;
		if (!(s->p.pin_mode == NDO_PINS_PROJECT && s->pin[p])) {
			z->stepped[t]++;
			z->nall_nodes++;
		}
		size_t nb[6];
		ndo_neighbors(s->level, (int)(p % (size_t)w), (int)(p / (size_t)w), nb);
		for (int d = 0; d < 6; d++) {
			int32_t u = z->tile_of[nb[d]];
			if (u != t)
				pairs[np++] = (int64_t)t * z->ntiles + u;
		}
	}
	qsort(pairs, np, sizeof *pairs, cmp_pair);
	size_t nu = 0;
	for (size_t k = 0; k < np; k++)
		if (!nu || pairs[k] != pairs[nu - 1])
			pairs[nu++] = pairs[k];
	memset(z->astart, 0, (nt + 1) * sizeof *z->astart);
	z->adj = malloc((nu + 1) * sizeof *z->adj);
	if (!z->adj) {
		free(pairs);
		ndo__sleep_free(z);
		return ndo__fail(NDO_ENOMEM, "out of memory for sleeping tiles");
	}
	for (size_t k = 0; k < nu; k++) {
		z->astart[pairs[k] / z->ntiles + 1]++;
		z->adj[k] = (int32_t)(pairs[k] % z->ntiles);
	}
	for (size_t t = 0; t < nt; t++)
		z->astart[t + 1] += z->astart[t];
	free(pairs);
	/* tiles a force acts on never sleep; pressure acts everywhere */
	for (size_t k = 0; k < s->nfnodes; k++)
		z->forced[z->tile_of[s->fnodes[k]]] = 1;
	if (s->has_pressure)
		memset(z->forced, 1, nt);
	memset(z->age, STAY, nt); /* at the start any quiet tile may sleep */
	/* a tile of pins alone is never stepped anyway: asleep for good */
	for (size_t t = 0; t < nt; t++)
		z->awake[t] = z->stepped[t] > 0;
	fill_mask(z, s);
	*out = z;
	return NDO_OK;
}

/* Is tile t quiet?  Stops at its first moving node, so a scene where
 * everything moves costs a few nodes a tile. */
static int tile_quiet(const ndo__sleep *z, const ndo_sim *s, int t)
{
	if (z->forced[t])
		return 0;
	const size_t cnt = s->count;
	const double *ux = s->u, *uy = s->u + cnt, *uz = s->u + 2 * cnt;
	const double *vx = s->v, *vy = s->v + cnt, *vz = s->v + 2 * cnt;
	for (int32_t k = z->tstart[t]; k < z->tstart[t + 1]; k++) {
		size_t p = (size_t)z->tnodes[k];
		if (ux[p] * ux[p] + uy[p] * uy[p] + uz[p] * uz[p] > z->umax2 ||
		    vx[p] * vx[p] + vy[p] * vy[p] + vz[p] * vz[p] > z->vmax2)
			return 0;
	}
	return 1;
}

int ndo__sleep_check(ndo__sleep *z, const ndo_sim *s)
{
	if (++z->since < z->every)
		return 0;
	z->since = 0;
	z->checks++;
	const int nt = z->ntiles;
	for (int t = 0; t < nt; t++)
		z->quiet[t] = z->awake[t] ? (uint8_t)tile_quiet(z, s, t) : 1;
	int changed = 0;
	for (int t = 0; t < nt; t++) {
		uint8_t a = z->awake[t];
		if (!z->stepped[t]) {
			a = 0;
		} else if (a) {
			/* awake: sleeps when it and every neighbour are quiet, and
			 * it has been awake STAY looks (no flapping at the bound) */
			int all = z->quiet[t] && z->age[t] >= STAY;
			for (int32_t k = z->astart[t]; all && k < z->astart[t + 1]; k++)
				all = z->quiet[z->adj[k]];
			if (all) {
				a = 0;
				z->sleeps++;
			} else if (z->age[t] < STAY) {
				z->age[t]++;
			}
		} else {
			/* asleep: wakes when a neighbour moves */
			for (int32_t k = z->astart[t]; k < z->astart[t + 1]; k++)
				if (!z->quiet[z->adj[k]]) {
					a = 1;
					z->age[t] = 0;
					z->wakes++;
					break;
				}
		}
		z->next[t] = a;
		changed |= a != z->awake[t];
	}
	if (!changed)
		return 0;
	memcpy(z->awake, z->next, (size_t)nt);
	fill_mask(z, s);
	return 1;
}

const uint8_t *ndo__sleep_mask(const ndo__sleep *z) { return z->mask; }

void ndo__sleep_nodes(const ndo__sleep *z, size_t *awake, size_t *all)
{
	*awake = z->nawake_nodes;
	*all = z->nall_nodes;
}

void ndo__sleep_counts(const ndo__sleep *z, int64_t *checks, int64_t *wakes, int64_t *sleeps,
                       int *tiles, int *awake)
{
	*checks = z->checks, *wakes = z->wakes, *sleeps = z->sleeps, *tiles = 0, *awake = 0;
	for (int t = 0; t < z->ntiles; t++)
		if (z->tstart[t + 1] > z->tstart[t]) {
			++*tiles;
			*awake += z->awake[t];
		}
}
