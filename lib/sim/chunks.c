/* chunks.c — the chunks of the interior runs (s->ichunk) as the two
 * pipelines of (pass, chunk) units see them: rk4.c's RK4 pipeline (a
 * step's four stages) and wave.c's steps (several steps' passes).  Both
 * rest on the same two facts — the stencil reaches one row, and every
 * seam joins nodes of one row (ndo/topology.h) — so pass p of a chunk
 * needs only pass p − 1 of the chunks whose rows meet its rows ± 1; what
 * a chunk writes, reads and waits for is worked out here once, for both
 * (sim_private.h, ndo__chunks), and each plan adds its own extras. */
#include "sim_private.h"
#include "ndo/status.h"
#include "ndo/topology.h"

#include <stdlib.h>

/* Items of a list of `n` owned by chunk c, counted then filled: the
 * offsets off[0..C] and the items. */
static int32_t *bucket(int C, size_t n, const int32_t *owner, int32_t **off)
{
	*off = calloc((size_t)C + 2, sizeof **off);
	int32_t *list = malloc((n + 1) * sizeof *list);
	if (!*off || !list) {
		free(list);
		return NULL;
	}
	for (size_t i = 0; i < n; i++)
		(*off)[owner[i] + 2]++;
	for (int c = 0; c < C; c++)
		(*off)[c + 2] += (*off)[c + 1];
	for (size_t i = 0; i < n; i++)
		list[(*off)[owner[i] + 1]++] = (int32_t)i;
	return list;
}

/* Rows a0..a1 widened to take row j. */
static void widen(int32_t *a0, int32_t *a1, int32_t j)
{
	if (j < *a0)
		*a0 = j;
	if (j > *a1)
		*a1 = j;
}

void ndo__chunks_copy_dups(const ndo_sim *s, const ndo__chunks *K, int c, double *x)
{
	const size_t cnt = s->count, n = (size_t)(K->doff[c + 1] - K->doff[c]);
	const int32_t *pairs = K->dlist + 2 * K->doff[c];
	for (int comp = 0; comp < 3; comp++) {
		double *X = x + (size_t)comp * cnt;
		for (size_t i = 0; i < n; i++)
			X[pairs[2 * i]] = X[pairs[2 * i + 1]];
	}
}

void ndo__chunks_free(ndo__chunks *K)
{
	free(K->r0), free(K->r1), free(K->a0), free(K->a1), free(K->lo), free(K->hi);
	free(K->boff), free(K->blist), free(K->zoff), free(K->zlist), free(K->zfi), free(K->foff),
	    free(K->fitem);
	free(K->doff), free(K->dlist), free(K->eoff), free(K->elist);
	free(K->cfit), free(K->coff), free(K->cnode), free(K->fci), free(K->zci);
	*K = (ndo__chunks){0};
}

/* The compact force items (ndo__chunks: cfit, coff, cnode, fci, zci):
 * each chunk's distinct item nodes in the order its items meet them. */
static int compact(const ndo_sim *s, ndo__chunks *K)
{
	const int C = K->C;
	const size_t m = (size_t)K->foff[C];
	K->cfit = calloc((size_t)C + 1, 1);
	K->coff = calloc((size_t)C + 1, sizeof *K->coff);
	K->cnode = malloc((3 * m + 1) * sizeof *K->cnode);
	K->fci = malloc((3 * m + 1) * sizeof *K->fci);
	K->zci = malloc(((size_t)K->zoff[C] + 1) * sizeof *K->zci);
	int32_t *idx = malloc((s->count + 1) * sizeof *idx); /* node → compact index, −1 */
	if (!K->cfit || !K->coff || !K->cnode || !K->fci || !K->zci || !idx) {
		free(idx);
		return NDO_ENOMEM;
	}
	for (size_t p = 0; p < s->count; p++)
		idx[p] = -1;
	int32_t n = 0;
	for (int c = 0; c < C; c++) {
		const int32_t n0 = n;
		int fit = 1;
		for (int32_t i = K->foff[c]; i < K->foff[c + 1] && fit; i++) {
			const ndo__force *F = &s->forces[K->fitem[i].k];
			fit = F->f.kind == NDO_FORCE_FACE && F->f.normal;
			for (int d = 0; fit && d < 3; d++) {
				int32_t p = F->nodes[3 * (size_t)K->fitem[i].q + (size_t)d];
				if (idx[p] < 0) {
					idx[p] = n - n0;
					K->cnode[n++] = p;
				}
				K->fci[3 * (size_t)i + (size_t)d] = idx[p];
			}
		}
		for (int32_t i = K->zoff[c]; i < K->zoff[c + 1] && fit; i++) {
			fit = idx[K->zlist[i]] >= 0; /* (each is some item's node) */
			K->zci[i] = idx[K->zlist[i]];
		}
		fit = fit && n - n0 <= NDO__CF_MAX && K->foff[c + 1] > K->foff[c];
		for (int32_t i = n0; i < n; i++)
			idx[K->cnode[i]] = -1;
		if (!fit)
			n = n0; /* the chunk keeps the general path */
		K->cfit[c] = (uint8_t)fit;
		K->coff[c + 1] = n;
	}
	free(idx);
	return NDO_OK;
}

/* Without held nodes every interior row is one run, so a chunk is whole
 * rows and row 0 goes with row 1, row n with row n − 1.  With held nodes
 * (a peer's region and halo) a row may have any number of runs, in one
 * chunk or two, or none: a border node goes with the chunk of the last
 * run of its row, or of the nearest row that has runs; force items are
 * evaluated only at active nodes. */
int ndo__chunks_build(const ndo_sim *s, ndo__chunks *K, int what)
{
	const int C = s->nichunk, n = s->n, w = s->w;
	const size_t cnt = s->count;
	*K = (ndo__chunks){.C = C};
	int32_t *rowc = malloc(((size_t)n + 1) * sizeof *rowc);
	int32_t *own = malloc((cnt + 1) * sizeof *own); /* each node's writer, or −1 */
	const size_t ndup = ndo_duplicate_count(s->level);
	size_t nb = s->nbact > s->nfnodes ? s->nbact : s->nfnodes; /* owner's items */
	if (ndup > nb)
		nb = ndup;
	if ((what & NDO__CHUNKS_EDGES) && s->nhedge > nb)
		nb = s->nhedge;
	int32_t *owner = malloc((nb + 1) * sizeof *owner);
	size_t *pairs = NULL;
	int32_t *zn = NULL, *zk = NULL; /* the active force nodes, their places in fnodes */
	K->r0 = malloc((size_t)C * sizeof *K->r0), K->r1 = malloc((size_t)C * sizeof *K->r1);
	K->a0 = malloc(((size_t)C + 1) * sizeof *K->a0);
	K->a1 = malloc(((size_t)C + 1) * sizeof *K->a1);
	K->lo = malloc((size_t)C * sizeof *K->lo), K->hi = malloc((size_t)C * sizeof *K->hi);
	if (!rowc || !own || !owner || !K->r0 || !K->r1 || !K->a0 || !K->a1 || !K->lo || !K->hi)
		goto oom;
	for (int j = 0; j <= n; j++)
		rowc[j] = -1;
	for (size_t p = 0; p < cnt; p++)
		own[p] = -1;
	for (int c = 0; c < C; c++) {
		K->r0[c] = K->a0[c] = n + 1, K->r1[c] = K->a1[c] = -1;
		for (int32_t k = s->ichunk[c]; k < s->ichunk[c + 1]; k++) {
			rowc[s->ispan[k].a / w] = c;
			widen(&K->r0[c], &K->r1[c], s->ispan[k].a / w);
			for (int32_t p = s->ispan[k].a; p < s->ispan[k].b; p++)
				own[p] = c;
		}
	}
	/* rows without runs: the nearest row's chunk, the lower one first */
	for (int j = 0; j <= n; j++)
		if (rowc[j] < 0 || rowc[j] >= C)
			for (int d = 1; d <= n; d++) {
				if (j - d >= 0 && rowc[j - d] >= 0 && rowc[j - d] < C) {
					rowc[j] = rowc[j - d] + C; /* marked: found here, not a row's own */
					break;
				}
				if (j + d <= n && rowc[j + d] >= 0 && rowc[j + d] < C) {
					rowc[j] = rowc[j + d] + C;
					break;
				}
			}
	for (int j = 0; j <= n; j++)
		rowc[j] %= C;
	/* Border nodes by the chunk of their row. */
	for (size_t k = 0; k < s->nbact; k++) {
		int32_t p = s->st.border[s->bact[k]];
		owner[k] = own[p] = rowc[p / w];
		widen(&K->r0[owner[k]], &K->r1[owner[k]], p / w);
	}
	if (!(K->blist = bucket(C, s->nbact, owner, &K->boff)))
		goto oom;
	/* The seam duplicates of the active canonical nodes, by the chunk
	 * that writes the canonical one (its row's). */
	if (what & NDO__CHUNKS_DUPS) {
		if (!(pairs = malloc((2 * ndup + 1) * sizeof *pairs)))
			goto oom;
		ndo_duplicates(s->level, pairs);
		size_t m = 0;
		for (size_t i = 0; i < ndup; i++)
			if (own[pairs[2 * i + 1]] >= 0)
				pairs[2 * m] = pairs[2 * i], pairs[2 * m + 1] = pairs[2 * i + 1],
				owner[m++] = own[pairs[2 * i + 1]];
		int32_t *idx = bucket(C, m, owner, &K->doff);
		if (!idx || !(K->dlist = malloc((2 * m + 1) * sizeof *K->dlist))) {
			free(idx);
			goto oom;
		}
		for (size_t i = 0; i < m; i++) {
			size_t q = (size_t)idx[i];
			K->dlist[2 * i] = (int32_t)pairs[2 * q];
			K->dlist[2 * i + 1] = (int32_t)pairs[2 * q + 1];
			widen(&K->r0[owner[q]], &K->r1[owner[q]], (int32_t)(pairs[2 * q] / (size_t)w));
		}
		free(idx);
	}
	/* Held edges by the chunk of their active node. */
	if (what & NDO__CHUNKS_EDGES) {
		for (size_t k = 0; k < s->nhedge; k++)
			owner[k] = own[s->hedge[k].p];
		for (size_t k = 0; k < s->nhedge; k++)
			if (owner[k] < 0)
				goto oom; /* not reached: every active canonical node is owned */
		if (!(K->elist = bucket(C, s->nhedge, owner, &K->eoff)))
			goto oom;
	}
	/* Force nodes by their chunk: the active ones (f at a held node is
	 * never read; a peer's region is spared the others' force items). */
	size_t nz = 0;
	if (!(zn = malloc((s->nfnodes + 1) * sizeof *zn)) ||
	    !(zk = malloc((s->nfnodes + 1) * sizeof *zk)))
		goto oom;
	for (size_t k = 0; k < s->nfnodes; k++) {
		int32_t p = s->fnodes[k];
		if (s->active[p])
			zk[nz] = (int32_t)k, zn[nz] = p, owner[nz++] = own[p];
	}
	if (!(K->zlist = bucket(C, nz, owner, &K->zoff)) ||
	    !(K->zfi = malloc(((size_t)K->zoff[C] + 1) * sizeof *K->zfi)))
		goto oom;
	for (int32_t i = 0; i < K->zoff[C]; i++) {
		K->zfi[i] = zk[K->zlist[i]];
		K->zlist[i] = zn[K->zlist[i]];
	}
	/* A unit reads one row beyond what it writes, and the nodes of its
	 * force items. */
	for (int c = 0; c < C; c++)
		if (K->r1[c] >= 0)
			K->a0[c] = K->r0[c] - 1, K->a1[c] = K->r1[c] + 1;
	/* Force items: for each chunk, every item with an active node in it, in
	 * the forces' order, marked with those nodes. */
	size_t nitem = 0;
	for (int k = 0; k < s->nforces; k++)
		nitem += s->forces[k].f.count;
	K->foff = calloc((size_t)C + 1, sizeof *K->foff);
	K->fitem = malloc((3 * nitem + 1) * sizeof *K->fitem);
	if (!K->foff || !K->fitem)
		goto oom;
	size_t m = 0;
	for (int c = 0; c < C; c++) {
		K->foff[c] = (int32_t)m;
		for (int k = 0; k < s->nforces; k++)
			for (size_t q = 0; q < s->forces[k].f.count; q++) {
				int32_t v[3], mask = 0;
				int nv = ndo__force_item_nodes(s, k, q, v);
				for (int d = 0; d < nv; d++)
					if (s->active[v[d]] && own[v[d]] == c)
						mask |= 1 << d;
				if (mask) {
					K->fitem[m++] = (ndo__fitem){k, (int32_t)q, mask};
					/* a face's nodes; a node's vertex normal, its neighbours */
					for (int d = 0; d < nv; d++) {
						widen(&K->a0[c], &K->a1[c], v[d] / w - (nv == 1));
						widen(&K->a0[c], &K->a1[c], v[d] / w + (nv == 1));
					}
				}
			}
	}
	K->foff[C] = (int32_t)m;
	if (compact(s, K))
		goto oom;
	/* What each chunk waits for: the chunks whose writes meet its reads
	 * or whose reads meet its writes. */
	K->L = 2;
	for (int c = 0; c < C; c++) {
		K->lo[c] = c, K->hi[c] = c;
		for (int q = 0; q < C; q++)
			if ((K->r0[q] <= K->a1[c] && K->a0[c] <= K->r1[q]) ||
			    (K->a0[q] <= K->r1[c] && K->r0[c] <= K->a1[q])) {
				if (q < K->lo[c])
					K->lo[c] = q;
				if (q > K->hi[c])
					K->hi[c] = q;
			}
		if (K->hi[c] - c + 1 > K->L)
			K->L = K->hi[c] - c + 1;
		if (c - K->lo[c] + 1 > K->L)
			K->L = c - K->lo[c] + 1;
	}
	free(rowc), free(own), free(owner), free(pairs), free(zn), free(zk);
	return NDO_OK;
oom:
	free(rowc), free(own), free(owner), free(pairs), free(zn), free(zk);
	ndo__chunks_free(K);
	return NDO_ENOMEM;
}
