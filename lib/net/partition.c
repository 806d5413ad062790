/* partition.c — the quad-tree partitions (ndo/partition.h; thesis §4.5,
 * Table 4.1). */
#include "ndo/partition.h"
#include "ndo/quadtree.h"
#include "ndo/status.h"
#include "ndo/topology.h"

#include <stdlib.h>
#include <string.h>

const char *ndo_part_method_name(ndo_part_method m)
{
	switch (m) {
	case NDO_PART_QUADTREE: return "quadtree";
	case NDO_PART_TABLE41: return "table41";
	case NDO_PART_METIS: return "metis";
	case NDO_PART_BANDS: return "bands";
	}
	return "?";
}

int ndo_part_method_parse(const char *s)
{
	for (int m = NDO_PART_QUADTREE; m <= NDO_PART_BANDS; m++)
		if (strcmp(s, ndo_part_method_name((ndo_part_method)m)) == 0)
			return m;
	return -1;
}

double ndo_partition_imbalance(int level, const int32_t *cell, int k)
{
	size_t nc = ndo_cell_count(level);
	long count[NDO_MAX_PEERS] = {0}, max = 0;
	for (size_t c = 0; c < nc; c++)
		if (cell[c] >= 0 && cell[c] < k)
			count[cell[c]]++;
	for (int p = 0; p < k; p++)
		if (count[p] > max)
			max = count[p];
	return (double)max * k / (double)nc;
}

void ndo_partition_node_owner(int level, const int32_t *cell, const int32_t *ids,
                              int32_t *owner)
{
	int n = 1 << level, w = 2 * n + 1;
	for (int j = 0; j <= n; j++)
		for (int i = 0; i < w; i++) {
			size_t c = ndo_canonical(level, i, j);
			int ci = (int)(c % (size_t)w), cj = (int)(c / (size_t)w);
			ci = ci < 2 * n ? ci : 2 * n - 1;
			cj = cj < n ? cj : n - 1;
			owner[(size_t)j * w + i] = ids[cell[cj * 2 * n + ci]];
		}
}

/* Breadth-first distances over the cell graph from `src` cells. */
static void bfs(int level, const int32_t *src, int nsrc, int32_t *dist, int32_t *queue)
{
	size_t nc = ndo_cell_count(level);
	int w = 2 << level;
	for (size_t c = 0; c < nc; c++)
		dist[c] = -1;
	size_t head = 0, tail = 0;
	for (int s = 0; s < nsrc; s++)
		if (dist[src[s]] < 0) {
			dist[src[s]] = 0;
			queue[tail++] = src[s];
		}
	while (head < tail) {
		int32_t c = queue[head++], nb[4];
		ndo_cell_neighbors(level, c % w, c / w, nb);
		for (int q = 0; q < 4; q++)
			if (dist[nb[q]] < 0) {
				dist[nb[q]] = dist[c] + 1;
				queue[tail++] = nb[q];
			}
	}
}

/* Seeds: each peer's POI cell; a missing POI becomes the cell farthest
 * from the others, and a POI already taken moves to the nearest free cell. */
static int seeds(int level, int k, const int32_t *poi, int32_t *seed, int32_t *used)
{
	size_t nc = ndo_cell_count(level);
	int32_t *dist = malloc(nc * sizeof *dist), *queue = malloc(nc * sizeof *queue);
	if (!dist || !queue) {
		free(dist), free(queue);
		return NDO_ENOMEM;
	}
	int ns = 0;
	int32_t given[NDO_MAX_PEERS];
	for (int p = 0; p < k; p++)
		if (poi[p] >= 0)
			given[ns++] = ndo_face_cell(poi[p]);
	for (int p = 0; p < k; p++) {
		if (poi[p] >= 0) {
			seed[p] = ndo_face_cell(poi[p]);
			used[p] = poi[p];
			continue;
		}
		int32_t best = 0;
		if (ns > 0) {
			bfs(level, given, ns, dist, queue);
			for (size_t c = 0; c < nc; c++)
				if (dist[c] > dist[best])
					best = (int32_t)c;
		}
		seed[p] = best;
		used[p] = 2 * best;
		given[ns++] = best;
	}
	/* distinct seeds: a later peer on a taken cell moves to the nearest free one */
	for (int p = 1; p < k; p++) {
		int clash = 0;
		for (int q = 0; q < p; q++)
			clash |= seed[q] == seed[p];
		if (!clash)
			continue;
		bfs(level, &seed[p], 1, dist, queue);
		for (size_t t = 0; t < nc; t++) {
			int32_t c = queue[t], taken = 0;
			for (int q = 0; q < p; q++)
				taken |= seed[q] == c;
			if (!taken) {
				seed[p] = c;
				break;
			}
		}
	}
	free(dist), free(queue);
	return 0;
}

/* ---- the improved quad-tree partition: balanced greedy growth --------- */
typedef struct heap {
	int64_t *key; /* priority (larger first) << 20 | ... packed with the cell */
	size_t n, cap;
} heap;

static int heap_push(heap *h, int64_t v)
{
	if (h->n == h->cap) {
		size_t cap = h->cap ? 2 * h->cap : 256;
		int64_t *k = realloc(h->key, cap * sizeof *k);
		if (!k)
			return -1;
		h->key = k;
		h->cap = cap;
	}
	size_t i = h->n++;
	while (i > 0 && h->key[(i - 1) / 2] < v) {
		h->key[i] = h->key[(i - 1) / 2];
		i = (i - 1) / 2;
	}
	h->key[i] = v;
	return 0;
}

static int64_t heap_pop(heap *h)
{
	int64_t top = h->key[0], last = h->key[--h->n];
	size_t i = 0;
	for (;;) {
		size_t c = 2 * i + 1;
		if (c >= h->n)
			break;
		if (c + 1 < h->n && h->key[c + 1] > h->key[c])
			c++;
		if (h->key[c] <= last)
			break;
		h->key[i] = h->key[c];
		i = c;
	}
	if (h->n)
		h->key[i] = last;
	return top;
}

/* Key: neighbours in the region (more first), then distance to the seed
 * (nearer first), then the cell. */
static int64_t key_of(int nbrs, int32_t dist, int32_t cell)
{
	return ((int64_t)nbrs << 52) | ((int64_t)(0xFFFFF - (dist & 0xFFFFF)) << 32) | cell;
}

static int grow(int level, int k, const int32_t *seed, int32_t *cell)
{
	size_t nc = ndo_cell_count(level);
	int w = 2 << level, rc = NDO_ENOMEM;
	int32_t *dist = malloc((size_t)k * nc * sizeof *dist), *queue = malloc(nc * sizeof *queue);
	uint8_t *cnt = calloc((size_t)k * nc, 1);
	heap h[NDO_MAX_PEERS];
	memset(h, 0, sizeof h);
	long size[NDO_MAX_PEERS] = {0}, target[NDO_MAX_PEERS];
	if (!dist || !queue || !cnt)
		goto out;
	for (int p = 0; p < k; p++) {
		bfs(level, &seed[p], 1, dist + (size_t)p * nc, queue);
		target[p] = (long)(nc / (size_t)k) + ((size_t)p < nc % (size_t)k);
	}
	for (size_t c = 0; c < nc; c++)
		cell[c] = -1;
	size_t left = nc;
	for (int p = 0; p < k; p++)
		if (heap_push(&h[p], key_of(4, 0, seed[p])) < 0)
			goto out;
	while (left > 0) {
		/* the region furthest below its share that can still grow; once all
		 * have their shares (or are walled in), any that can grow */
		int best = -1;
		for (int pass = 0; pass < 2 && best < 0; pass++)
			for (int p = 0; p < k; p++) {
				while (h[p].n && cell[h[p].key[0] & 0xFFFFFFFF] >= 0)
					heap_pop(&h[p]); /* taken meanwhile */
				if (!h[p].n || (pass == 0 && size[p] >= target[p]))
					continue;
				if (best < 0 || size[p] * target[best] < size[best] * target[p])
					best = p;
			}
		if (best < 0)
			break; /* cannot happen on a connected graph */
		int32_t c = (int32_t)(heap_pop(&h[best]) & 0xFFFFFFFF), nb[4];
		cell[c] = best;
		size[best]++;
		left--;
		ndo_cell_neighbors(level, c % w, c / w, nb);
		for (int q = 0; q < 4; q++) {
			int32_t d = nb[q];
			if (cell[d] >= 0)
				continue;
			uint8_t *m = &cnt[(size_t)best * nc + d];
			(*m)++;
			if (heap_push(&h[best], key_of(*m, dist[(size_t)best * nc + d], d)) < 0)
				goto out;
		}
	}
	rc = 0;
out:
	for (int p = 0; p < k; p++)
		free(h[p].key);
	free(dist), free(queue), free(cnt);
	return rc ? ndo__fail(rc, "partition: out of memory") : 0;
}

/* Move boundary cells to the neighbouring region that holds more of their
 * neighbours, while both regions stay within lo..hi cells and no seed
 * moves: each move shortens the cut by its gain. */
static void refine(int level, int k, const int32_t *seed, int32_t *cell, long lo, long hi)
{
	size_t nc = ndo_cell_count(level);
	int w = 2 << level;
	long size[NDO_MAX_PEERS] = {0};
	for (size_t c = 0; c < nc; c++)
		size[cell[c]]++;
	for (int pass = 0; pass < 30; pass++) {
		long moved = 0;
		for (size_t c = 0; c < nc; c++) {
			int32_t a = cell[c], nb[4];
			int is_seed = 0;
			for (int p = 0; p < k; p++)
				is_seed |= seed[p] == (int32_t)c;
			if (is_seed || size[a] - 1 < lo)
				continue;
			ndo_cell_neighbors(level, (int)(c % (size_t)w), (int)(c / (size_t)w), nb);
			int in[NDO_MAX_PEERS] = {0};
			for (int q = 0; q < 4; q++)
				in[cell[nb[q]]]++;
			int b = -1;
			for (int p = 0; p < k; p++)
				if (p != a && in[p] > in[a] && size[p] + 1 <= hi &&
				    (b < 0 || in[p] > in[b] || (in[p] == in[b] && size[p] < size[b])))
					b = p;
			/* equal gain moves only from larger to smaller: balance */
			if (b < 0)
				for (int p = 0; p < k; p++)
					if (p != a && in[p] > 0 && in[p] == in[a] && size[p] + 1 < size[a] &&
					    size[a] > (lo + hi) / 2 && size[p] + 1 <= hi)
						b = p;
			if (b < 0)
				continue;
			cell[c] = b;
			size[a]--, size[b]++;
			moved++;
		}
		if (!moved)
			break;
	}
}

/* ---- the thesis' Table 4.1, literally --------------------------------- */
/* Leaves at depth D; a subtree is "empty" when none of its leaves has an
 * owner.  Works on the leaf array (cols × rows at depth D). */
typedef struct t41 {
	int level, D, cols, rows;
	int32_t *leaf; /* owner slot of each leaf, −1 empty */
	long area[NDO_MAX_PEERS];
} t41;

static void span(const t41 *t, ndo_quad q, int *a0, int *b0, int *a1, int *b1)
{
	/* leaves of q: at depth D, q covers a block of leaves */
	if (q.depth == 0) {
		*a0 = 0, *b0 = 0, *a1 = t->cols, *b1 = t->rows;
		return;
	}
	int f = 1 << (t->D - q.depth);
	*a0 = q.qi * f, *b0 = q.qj * f, *a1 = *a0 + f, *b1 = *b0 + f;
}

static int subtree_empty(const t41 *t, ndo_quad q)
{
	int a0, b0, a1, b1;
	span(t, q, &a0, &b0, &a1, &b1);
	for (int b = b0; b < b1; b++)
		for (int a = a0; a < a1; a++)
			if (t->leaf[b * t->cols + a] >= 0)
				return 0;
	return 1;
}

static void claim(t41 *t, ndo_quad q, int p)
{
	int a0, b0, a1, b1;
	span(t, q, &a0, &b0, &a1, &b1);
	for (int b = b0; b < b1; b++)
		for (int a = a0; a < a1; a++) {
			t->leaf[b * t->cols + a] = p;
			t->area[p]++;
		}
}

static ndo_quad parent(ndo_quad q)
{
	if (q.depth == 1)
		return (ndo_quad){0, 0, 0};
	return (ndo_quad){q.depth - 1, q.qi / 2, q.qj / 2};
}

static int children(ndo_quad q, ndo_quad *ch)
{
	if (q.depth == 0) {
		ch[0] = (ndo_quad){1, 0, 0};
		ch[1] = (ndo_quad){1, 1, 0};
		return 2;
	}
	for (int k = 0; k < 4; k++)
		ch[k] = (ndo_quad){q.depth + 1, 2 * q.qi + (k & 1), 2 * q.qj + (k >> 1)};
	return 4;
}

static int table41(int level, int k, const int32_t *seed, int32_t *cell)
{
	t41 t = {.level = level};
	/* leaf depth: the thesis leaves it to the packet size; 5 gives 16 × 32
	 * leaves, enough for eight peers, and single cells below level 4 */
	t.D = level + 1 < 5 ? level + 1 : 5;
	ndo_quad_dims(t.D, &t.cols, &t.rows);
	t.leaf = malloc((size_t)t.cols * t.rows * sizeof *t.leaf);
	if (!t.leaf)
		return ndo__fail(NDO_ENOMEM, "partition: out of memory");
	for (int c = 0; c < t.cols * t.rows; c++)
		t.leaf[c] = -1;
	int n = 1 << level, w = 2 * n;
	ndo_quad cur[NDO_MAX_PEERS];
	/* phase 1: descend to the leaf that covers the selected face */
	for (int p = 0; p < k; p++) {
		ndo_quad q = ndo_quad_at(level, t.D, seed[p] % w, seed[p] / w);
		if (t.leaf[q.qj * t.cols + q.qi] >= 0) { /* shared leaf: nearest empty */
			long bestd = -1;
			for (int b = 0; b < t.rows; b++)
				for (int a = 0; a < t.cols; a++) {
					long d = labs(a - q.qi) + labs(b - q.qj);
					if (t.leaf[b * t.cols + a] < 0 && (bestd < 0 || d < bestd))
						bestd = d, cur[p] = (ndo_quad){t.D, a, b};
				}
			q = cur[p];
		}
		cur[p] = q;
		claim(&t, q, p);
	}
	/* phase 2: the smallest region climbs, taking its empty siblings (all
	 * of them if all are empty, else the closest empty one) */
	for (;;) {
		int p = -1;
		for (int r = 0; r < k; r++)
			if (cur[r].depth > 0 && (p < 0 || t.area[r] < t.area[p]))
				p = r;
		if (p < 0)
			break;
		ndo_quad up = parent(cur[p]), ch[4];
		int nch = children(up, ch), all = 1;
		for (int c = 0; c < nch; c++)
			if (ch[c].qi != cur[p].qi || ch[c].qj != cur[p].qj || ch[c].depth != cur[p].depth)
				all &= subtree_empty(&t, ch[c]);
		int best = -1;
		long bestd = 0;
		for (int c = 0; c < nch; c++) {
			if (ch[c].qi == cur[p].qi && ch[c].qj == cur[p].qj)
				continue;
			if (!subtree_empty(&t, ch[c]))
				continue;
			if (all) {
				claim(&t, ch[c], p);
				continue;
			}
			long d = labs(ch[c].qi - cur[p].qi) + labs(ch[c].qj - cur[p].qj);
			if (best < 0 || d < bestd)
				best = c, bestd = d;
		}
		if (!all && best >= 0)
			claim(&t, ch[best], p);
		cur[p] = up;
	}
	/* the rest ("while the grid is not full"): each empty leaf goes to the
	 * smallest region next to it, until none is left */
	for (int changed = 1; changed;) {
		changed = 0;
		for (int b = 0; b < t.rows; b++)
			for (int a = 0; a < t.cols; a++) {
				if (t.leaf[b * t.cols + a] >= 0)
					continue;
				int nbp[4] = {-1, -1, -1, -1};
				if (a > 0) nbp[0] = t.leaf[b * t.cols + a - 1];
				if (a + 1 < t.cols) nbp[1] = t.leaf[b * t.cols + a + 1];
				if (b > 0) nbp[2] = t.leaf[(b - 1) * t.cols + a];
				if (b + 1 < t.rows) nbp[3] = t.leaf[(b + 1) * t.cols + a];
				int p = -1;
				for (int q = 0; q < 4; q++)
					if (nbp[q] >= 0 && (p < 0 || t.area[nbp[q]] < t.area[p]))
						p = nbp[q];
				if (p >= 0) {
					t.leaf[b * t.cols + a] = p;
					t.area[p]++;
					changed = 1;
				}
			}
	}
	for (int j = 0; j < n; j++)
		for (int i = 0; i < w; i++) {
			ndo_quad q = ndo_quad_at(level, t.D, i, j);
			cell[j * w + i] = t.leaf[q.qj * t.cols + q.qi];
		}
	free(t.leaf);
	return 0;
}

/* ---- parts made without the POIs (METIS, bands) ------------------------ */

/* Relabel parts 0..k-1 so that each peer gets the part that holds its
 * POI's cell where it can; the other parts go to the peers left, in order. */
static void to_pois(int level, int k, const int32_t *seed, int32_t *cell)
{
	size_t nc = ndo_cell_count(level);
	int map[NDO_MAX_PEERS], given[NDO_MAX_PEERS] = {0};
	for (int part = 0; part < k; part++)
		map[part] = -1;
	for (int p = 0; p < k; p++) {
		int part = cell[seed[p]];
		if (map[part] < 0) {
			map[part] = p;
			given[p] = 1;
		}
	}
	for (int part = 0, p = 0; part < k; part++) {
		if (map[part] >= 0)
			continue;
		while (given[p])
			p++;
		map[part] = p;
		given[p] = 1;
	}
	for (size_t c = 0; c < nc; c++)
		cell[c] = map[cell[c]];
}

/* Bands: k runs of whole cell rows, 0 at the bottom, each cut a row's
 * boundary (2N cell edges: the shortest that splits the grid's 2N x N
 * rows into runs of whole rows), balanced by the stored nodes each row
 * owns (ndo_partition_node_owner(): node row j < N goes with cell row j,
 * node row N with cell row N-1; the folded rows 0 and N hold N+1 each). */
static int bands(int level, int k, int32_t *cell)
{
	const int n = 1 << level, w = 2 * n;
	if (k > n)
		return ndo__fail(NDO_EINVAL, "partition: %d bands for %d cell rows", k, n);
	long *cum = calloc((size_t)n + 1, sizeof *cum); /* cum[b]: nodes of cell rows < b */
	if (!cum)
		return ndo__fail(NDO_ENOMEM, "partition: out of memory");
	for (int j = 0; j <= n; j++)
		for (int i = 0; i <= w; i++)
			if (ndo_canonical(level, i, j) == (size_t)j * (size_t)(w + 1) + (size_t)i)
				cum[(j < n ? j : n - 1) + 1]++;
	for (int b = 1; b <= n; b++)
		cum[b] += cum[b - 1];
	int lo = 0; /* the first row of the band being made */
	for (int p = 0; p < k; p++) {
		int hi = n; /* the last band takes the rest */
		if (p < k - 1) {
			long want = cum[n] * (p + 1) / k;
			hi = lo + 1;
			for (int b = lo + 2; b <= n - (k - 1 - p); b++)
				if (labs(cum[b] - want) < labs(cum[hi] - want))
					hi = b;
		}
		for (int j = lo; j < hi; j++)
			for (int i = 0; i < w; i++)
				cell[j * w + i] = p;
		lo = hi;
	}
	free(cum);
	return 0;
}

int ndo_partition(int level, ndo_part_method method, int k, const int32_t *poi,
                  int32_t *cell, int32_t *pois_used)
{
	ndo__clear_error();
	if (level < 0 || level > 10 || k < 1 || k > NDO_MAX_PEERS)
		return ndo__fail(NDO_EINVAL, "partition: level %d, %d peers (1..%d)", level, k,
		                 NDO_MAX_PEERS);
	size_t nc = ndo_cell_count(level);
	if ((size_t)k > nc)
		return ndo__fail(NDO_EINVAL, "partition: %d peers for %zu cells", k, nc);
	for (int p = 0; p < k; p++)
		if (poi[p] < -1 || poi[p] >= (int64_t)(2 * nc))
			return ndo__fail(NDO_EINVAL, "partition: face %d out of range", poi[p]);
	int32_t seed[NDO_MAX_PEERS], used[NDO_MAX_PEERS];
	if (seeds(level, k, poi, seed, used) != 0)
		return ndo__fail(NDO_ENOMEM, "partition: out of memory");
	if (pois_used)
		memcpy(pois_used, used, (size_t)k * sizeof *used);
	int rc;
	switch (method) {
	case NDO_PART_TABLE41:
		return table41(level, k, seed, cell);
	case NDO_PART_QUADTREE: {
		rc = grow(level, k, seed, cell);
		if (rc)
			return rc;
		long mean = (long)(nc / (size_t)k), slack = mean / 50 > 0 ? mean / 50 : 1;
		refine(level, k, seed, cell, mean - slack, mean + slack);
		return 0;
	}
	case NDO_PART_METIS:
	case NDO_PART_BANDS:
		/* parts made without the POIs, then given to the peers of their POIs */
		rc = method == NDO_PART_METIS ? ndo_partition_metis(level, k, cell) : bands(level, k, cell);
		if (rc)
			return rc;
		to_pois(level, k, seed, cell);
		return 0;
	}
	return ndo__fail(NDO_EINVAL, "partition: unknown method %d", (int)method);
}

void ndo_partition_cells(int level, const ndo_msg_partition_t *p, int32_t *cell)
{
	int w = 2 << level;
	for (int k = 0; k < p->nleaves; k++) {
		ndo_quad q;
		ndo_quad_decode(level, p->leaves[k], &q);
		int i0, j0, i1, j1;
		ndo_quad_range(level, q, &i0, &j0, &i1, &j1);
		for (int j = j0; j < j1; j++)
			for (int i = i0; i < i1; i++)
				cell[j * w + i] = p->slots[k];
	}
}
