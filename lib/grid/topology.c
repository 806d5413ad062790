/* topology.c — the tetrahedral grid's seams, ghost map, neighbours,
 * triangles and distinct vertices (ndo/topology.h, DESIGN.md). */
#include "ndo/topology.h"

#include <stdlib.h>
#include <string.h>

const int ndo_dirs[6][2] = {{1, 0}, {0, 1}, {-1, 1}, {-1, 0}, {0, -1}, {1, -1}};

void ndo_ghost(int level, int *pi, int *pj)
{
	int n = 1 << level, i = *pi, j = *pj;
	for (;;) {
		if (j < 0) {          /* fold across the bottom row, about B */
			i = 2 * n - i;
			j = -j;
		} else if (j > n) {   /* fold across the top row, about D */
			i = 2 * n - i;
			j = 2 * n - j;
		} else {
			break;
		}
	}
	i %= 2 * n;              /* the column seam */
	if (i < 0)
		i += 2 * n;
	*pi = i;
	*pj = j;
}

size_t ndo_canonical(int level, int i, int j)
{
	int n = 1 << level;
	ndo_ghost(level, &i, &j);
	if ((j == 0 || j == n) && i > n)
		i = 2 * n - i;
	return ndo_node(2 * n + 1, i, j);
}

int ndo_is_corner(int level, int i, int j)
{
	int n = 1 << level;
	return (j == 0 || j == n) && (i == 0 || i == n || i == 2 * n);
}

void ndo_neighbors(int level, int i, int j, size_t nb[6])
{
	int w = (2 << level) + 1;
	for (int k = 0; k < 6; k++) {
		int a = i + ndo_dirs[k][0], b = j + ndo_dirs[k][1];
		ndo_ghost(level, &a, &b);
		nb[k] = ndo_node(w, a, b);
	}
}

size_t ndo_vertex_count(int level)
{
	return 2 * ((size_t)1 << (2 * level)) + 2;
}

size_t ndo_triangle_count(int level)
{
	return (size_t)1 << (2 * level + 2);
}

size_t ndo_duplicate_count(int level)
{
	return 3 * ((size_t)1 << level) - 1;
}

void ndo_vertex_ids(int level, int32_t *vid, int32_t *rep)
{
	int n = 1 << level, w = 2 * n + 1;
	size_t count = (size_t)w * (size_t)(n + 1);
	int32_t next = 0;
	/* Canonical nodes come before their duplicates in index order, so
	 * one pass numbers every vertex when its canonical node is met. */
	for (size_t k = 0; k < count; k++) {
		int i = (int)(k % (size_t)w), j = (int)(k / (size_t)w);
		size_t c = ndo_canonical(level, i, j);
		if (c == k) {
			if (rep)
				rep[next] = (int32_t)k;
			vid[k] = next++;
		} else {
			vid[k] = vid[c];
		}
	}
}

void ndo_triangles(int level, int32_t *tri)
{
	int n = 1 << level, w = 2 * n + 1;
	for (int j = 0; j < n; j++)
		for (int i = 0; i < 2 * n; i++) {
			int32_t a = (int32_t)ndo_node(w, i, j), b = a + 1,
			        c = a + w, d = c + 1;
			*tri++ = a, *tri++ = b, *tri++ = c;
			*tri++ = b, *tri++ = d, *tri++ = c;
		}
}

void ndo_duplicates(int level, size_t *pairs)
{
	int n = 1 << level, w = 2 * n + 1;
	for (int i = n + 1; i <= 2 * n; i++) {       /* bottom row, folds at B */
		*pairs++ = ndo_node(w, i, 0);
		*pairs++ = ndo_node(w, 2 * n - i, 0);
	}
	for (int i = n + 1; i <= 2 * n; i++) {       /* top row, folds at D */
		*pairs++ = ndo_node(w, i, n);
		*pairs++ = ndo_node(w, 2 * n - i, n);
	}
	for (int j = 1; j < n; j++) {                /* the column seam */
		*pairs++ = ndo_node(w, 2 * n, j);
		*pairs++ = ndo_node(w, 0, j);
	}
}

long ndo_duplicate_of(int level, size_t k)
{
	size_t n = (size_t)1 << level, w = 2 * n + 1, i = k % w, j = k / w;
	if ((j == 0 || j == n) && i < n)
		return (long)(j * w + 2 * n - i); /* the bottom and top folds */
	if (i == 0 && j > 0 && j < n)
		return (long)(j * w + 2 * n); /* the column seam */
	return -1;
}

/* ndo_sync's copies for nodes of `nb` bytes; with nb a constant (the
 * callers below) each copy is a move or two, not a call to memcpy: a peer
 * syncs a dozen planes of doubles every step, 3·2^level copies of 8 bytes
 * each, and the calls cost more than the copies. */
static inline void sync_nodes(int level, unsigned char *d, size_t nb)
{
	int n = 1 << level, w = 2 * n + 1;
#define COPY(dst, src) memcpy(d + (dst) * nb, d + (src) * nb, nb)
	for (int i = n + 1; i <= 2 * n; i++) {
		COPY(ndo_node(w, i, 0), ndo_node(w, 2 * n - i, 0));
		COPY(ndo_node(w, i, n), ndo_node(w, 2 * n - i, n));
	}
	for (int j = 1; j < n; j++)
		COPY(ndo_node(w, 2 * n, j), ndo_node(w, 0, j));
#undef COPY
}

void ndo_sync(int level, void *data, size_t node_bytes)
{
	switch (node_bytes) { /* the grid's and the simulation's usual nodes */
	case 1: sync_nodes(level, data, 1); break;
	case 4: sync_nodes(level, data, 4); break;
	case 8: sync_nodes(level, data, 8); break;
	case 12: sync_nodes(level, data, 12); break;
	case 24: sync_nodes(level, data, 24); break;
	default: sync_nodes(level, data, node_bytes);
	}
}

size_t ndo_grid_unsynced(const ndo_grid *g, const char **channel, int *i, int *j)
{
	int n = 1 << g->level, w = 2 * n + 1;
	size_t bad = 0;
	size_t npairs = ndo_duplicate_count(g->level);
	size_t *pairs = malloc(2 * npairs * sizeof *pairs);
	if (!pairs)
		return 0;
	ndo_duplicates(g->level, pairs);
	for (int c = 0; c < g->nchannels; c++) {
		size_t nb = (size_t)g->ch[c].comps * ndo_type_size(g->ch[c].type);
		const unsigned char *d = g->ch[c].data;
		for (size_t k = 0; k < npairs; k++)
			if (memcmp(d + pairs[2 * k] * nb, d + pairs[2 * k + 1] * nb, nb) != 0) {
				if (!bad++) {
					if (channel)
						*channel = g->ch[c].name;
					if (i)
						*i = (int)(pairs[2 * k] % (size_t)w);
					if (j)
						*j = (int)(pairs[2 * k] / (size_t)w);
				}
			}
	}
	free(pairs);
	return bad;
}

void ndo_grid_sync(ndo_grid *g)
{
	for (int c = 0; c < g->nchannels; c++)
		ndo_sync(g->level, g->ch[c].data,
		         (size_t)g->ch[c].comps * ndo_type_size(g->ch[c].type));
}

void ndo_pad(int level, int pad, const void *src, size_t node_bytes, void *dst)
{
	int n = 1 << level, w = 2 * n + 1, h = n + 1;
	int pw = w + 2 * pad;
	const unsigned char *s = src;
	unsigned char *d = dst;
	for (int j = -pad; j < h + pad; j++) {
		unsigned char *row = d + (size_t)(j + pad) * (size_t)pw * node_bytes;
		if (j >= 0 && j < h)
			memcpy(row + (size_t)pad * node_bytes,
			       s + (size_t)j * (size_t)w * node_bytes,
			       (size_t)w * node_bytes);
		int inside = j >= 0 && j < h;
		for (int i = -pad; i < w + pad; i++) {
			if (inside && i == 0)
				i = w; /* the stored part of the row is copied above */
			int a = i, b = j;
			ndo_ghost(level, &a, &b);
			memcpy(row + (size_t)(i + pad) * node_bytes,
			       s + ndo_node(w, a, b) * node_bytes, node_bytes);
		}
	}
}
