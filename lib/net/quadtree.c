/* quadtree.c — the quad tree over the grid's cells (ndo/quadtree.h). */
#include "ndo/quadtree.h"
#include "ndo/status.h"

#include <stdlib.h>

void ndo_quad_dims(int depth, int *cols, int *rows)
{
	*cols = depth == 0 ? 1 : 1 << depth;
	*rows = depth == 0 ? 1 : 1 << (depth - 1);
}

void ndo_quad_cells(int level, int depth, int *w, int *h)
{
	int n = 1 << level;
	if (depth == 0) {
		*w = 2 * n;
		*h = n;
	} else {
		*w = *h = n >> (depth - 1);
	}
}

void ndo_quad_range(int level, ndo_quad q, int *i0, int *j0, int *i1, int *j1)
{
	int w, h;
	ndo_quad_cells(level, q.depth, &w, &h);
	*i0 = q.qi * w;
	*j0 = q.qj * h;
	*i1 = *i0 + w;
	*j1 = *j0 + h;
}

size_t ndo_quad_node_count(int level, int depth)
{
	int w, h;
	ndo_quad_cells(level, depth, &w, &h);
	return (size_t)(w + 1) * (size_t)(h + 1);
}

int ndo_quad_from_range(int level, int depth, int i0, int j0, int i1, int j1,
                        ndo_quad *q)
{
	if (level < 0 || level > 30 || depth < 0 || depth > level + 1)
		return NDO_ERANGE;
	int w, h, cols, rows;
	ndo_quad_cells(level, depth, &w, &h);
	ndo_quad_dims(depth, &cols, &rows);
	if (i0 < 0 || j0 < 0 || i0 % w != 0 || j0 % h != 0 || i1 != i0 + w || j1 != j0 + h)
		return NDO_ERANGE;
	if (i0 / w >= cols || j0 / h >= rows)
		return NDO_ERANGE;
	q->depth = depth;
	q->qi = i0 / w;
	q->qj = j0 / h;
	return 0;
}

/* Codes: depth 0 is 0; depth d ≥ 1 starts after the 1 + 2 + 8 + ... nodes
 * of the shallower depths: 1 + Σ_{e<d} 2^(2e−1) = 1 + (2^(2d−1) − 2)/3·... ,
 * counted by a loop to stay obviously right. */
static int32_t depth_offset(int depth)
{
	int32_t off = 0;
	for (int d = 0; d < depth; d++) {
		int c, r;
		ndo_quad_dims(d, &c, &r);
		off += (int32_t)c * r;
	}
	return off;
}

int32_t ndo_quad_code(ndo_quad q)
{
	int c, r;
	ndo_quad_dims(q.depth, &c, &r);
	return depth_offset(q.depth) + q.qj * c + q.qi;
}

int ndo_quad_decode(int level, int32_t code, ndo_quad *q)
{
	if (code < 0 || level < 0 || level > 12)
		return NDO_ERANGE;
	for (int d = 0; d <= level + 1; d++) {
		int c, r;
		ndo_quad_dims(d, &c, &r);
		if (code < (int32_t)c * r) {
			q->depth = d;
			q->qi = code % c;
			q->qj = code / c;
			return 0;
		}
		code -= (int32_t)c * r;
	}
	return NDO_ERANGE;
}

ndo_quad ndo_quad_at(int level, int depth, int ci, int cj)
{
	int w, h;
	ndo_quad_cells(level, depth, &w, &h);
	return (ndo_quad){depth, ci / w, cj / h};
}

void ndo_cell_neighbors(int level, int i, int j, int32_t nb[4])
{
	int n = 1 << level, w = 2 * n;
	nb[0] = j * w + (i + w - 1) % w;
	nb[1] = j * w + (i + 1) % w;
	/* Below row 0 the edge (i,0)–(i+1,0) is the edge (2N−i,0)–(2N−i−1,0)
	 * of cell 2N−1−i (the fold at B); above row N−1 likewise (fold at D). */
	nb[2] = j > 0 ? (j - 1) * w + i : (w - 1 - i);
	nb[3] = j < n - 1 ? (j + 1) * w + i : (n - 1) * w + (w - 1 - i);
}

long ndo_cells_cut(int level, const int32_t *lab)
{
	int n = 1 << level, w = 2 * n;
	long cut = 0;
	for (int j = 0; j < n; j++)
		for (int i = 0; i < w; i++) {
			int32_t nb[4];
			ndo_cell_neighbors(level, i, j, nb);
			int32_t c = j * w + i;
			for (int k = 0; k < 4; k++)
				if (nb[k] > c && lab[nb[k]] != lab[c])
					cut++;
		}
	return cut;
}

typedef struct leafbuf {
	int32_t *codes, *labels;
	size_t count, cap;
	int failed;
} leafbuf;

static void push(leafbuf *b, int32_t code, int32_t label)
{
	if (b->failed)
		return;
	if (b->count == b->cap) {
		size_t cap = b->cap ? 2 * b->cap : 64;
		int32_t *c = realloc(b->codes, cap * sizeof *c);
		if (c)
			b->codes = c;
		int32_t *l = realloc(b->labels, cap * sizeof *l);
		if (l)
			b->labels = l;
		if (!c || !l) {
			b->failed = 1;
			return;
		}
		b->cap = cap;
	}
	b->codes[b->count] = code;
	b->labels[b->count++] = label;
}

/* The label of every cell of q if they all agree, else INT32_MIN. */
static int32_t uniform(int level, ndo_quad q, const int32_t *lab)
{
	int i0, j0, i1, j1, w = 2 << level;
	ndo_quad_range(level, q, &i0, &j0, &i1, &j1);
	int32_t first = lab[j0 * w + i0];
	for (int j = j0; j < j1; j++)
		for (int i = i0; i < i1; i++)
			if (lab[j * w + i] != first)
				return INT32_MIN;
	return first;
}

static void walk(int level, ndo_quad q, const int32_t *lab, int min_depth, leafbuf *b)
{
	if (q.depth >= min_depth) {
		int32_t u = uniform(level, q, lab);
		if (u != INT32_MIN) {
			if (u >= 0)
				push(b, ndo_quad_code(q), u);
			return;
		}
	}
	if (q.depth == level + 1) /* a single cell is always uniform */
		return;
	if (q.depth == 0) {
		walk(level, (ndo_quad){1, 0, 0}, lab, min_depth, b);
		walk(level, (ndo_quad){1, 1, 0}, lab, min_depth, b);
		return;
	}
	for (int dj = 0; dj < 2; dj++)
		for (int di = 0; di < 2; di++)
			walk(level, (ndo_quad){q.depth + 1, 2 * q.qi + di, 2 * q.qj + dj}, lab,
			     min_depth, b);
}

int ndo_quad_leaves(int level, const int32_t *lab, int min_depth, int32_t **codes,
                    int32_t **labels, size_t *count)
{
	leafbuf b = {0};
	walk(level, (ndo_quad){0, 0, 0}, lab, min_depth, &b);
	if (b.failed) {
		free(b.codes);
		free(b.labels);
		return ndo__fail(NDO_ENOMEM, "quad-tree leaves: out of memory");
	}
	*codes = b.codes;
	*labels = b.labels;
	*count = b.count;
	return 0;
}

/* Cells of q labelled `label`, and all of q's cells. */
static size_t share(int level, ndo_quad q, const int32_t *lab, int32_t label, size_t *all)
{
	int i0, j0, i1, j1, w = 2 << level;
	ndo_quad_range(level, q, &i0, &j0, &i1, &j1);
	size_t n = 0;
	for (int j = j0; j < j1; j++)
		for (int i = i0; i < i1; i++)
			n += lab[j * w + i] == label;
	*all = (size_t)(i1 - i0) * (size_t)(j1 - j0);
	return n;
}

static void cover(int level, ndo_quad q, const int32_t *lab, int32_t label, int min_depth,
                  double fill, leafbuf *b)
{
	if (q.depth >= min_depth) {
		size_t all, n = share(level, q, lab, label, &all);
		if (n == 0)
			return;
		if ((double)n >= fill * (double)all || q.depth == level + 1) {
			push(b, ndo_quad_code(q), label);
			return;
		}
	}
	if (q.depth == 0) {
		cover(level, (ndo_quad){1, 0, 0}, lab, label, min_depth, fill, b);
		cover(level, (ndo_quad){1, 1, 0}, lab, label, min_depth, fill, b);
		return;
	}
	for (int dj = 0; dj < 2; dj++)
		for (int di = 0; di < 2; di++)
			cover(level, (ndo_quad){q.depth + 1, 2 * q.qi + di, 2 * q.qj + dj}, lab, label,
			      min_depth, fill, b);
}

int ndo_quad_cover(int level, const int32_t *lab, int32_t label, int min_depth, double fill,
                   int32_t **codes, size_t *count)
{
	leafbuf b = {0};
	cover(level, (ndo_quad){0, 0, 0}, lab, label, min_depth, fill, &b);
	free(b.labels);
	if (b.failed) {
		free(b.codes);
		return ndo__fail(NDO_ENOMEM, "quad-tree cover: out of memory");
	}
	*codes = b.codes;
	*count = b.count;
	return 0;
}
