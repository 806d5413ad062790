/* forces.c — external forces on the membrane: sinusoidal forces on faces
 * (the thesis' experiments, §5.2), point forces and uniform pressure
 * (ndo/sim.h, struct ndo_force). */
#include "sim_private.h"
#include "ndo/status.h"
#include "ndo/topology.h"

#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

double ndo_force_value(const ndo_force *f, double t)
{
	if (f->frequency > 0)
		return f->amplitude * sin(2 * M_PI * f->frequency * t + f->phase);
	return f->amplitude;
}

/* The three stored nodes of triangle t (ndo_triangles order). */
static void triangle_nodes(const ndo_sim *s, size_t t, int32_t v[3])
{
	size_t cell = t / 2;
	int i = (int)(cell % (size_t)(2 * s->n)), j = (int)(cell / (size_t)(2 * s->n));
	int32_t a = (int32_t)ndo_node(s->w, i, j), b = a + 1, c = a + s->w, d = c + 1;
	if (t % 2 == 0)
		v[0] = a, v[1] = b, v[2] = c;
	else
		v[0] = b, v[1] = d, v[2] = c;
	for (int k = 0; k < 3; k++)
		v[k] = s->canon[v[k]];
}

static void position(const ndo_sim *s, const double *u, int32_t p, double x[3])
{
	for (int c = 0; c < 3; c++)
		x[c] = s->X[(size_t)c * s->count + (size_t)p] + u[(size_t)c * s->count + (size_t)p];
}

/* ½ (b − a) × (c − a): the area vector, outward for the grids ndo makes. */
static void area_vector(const double a[3], const double b[3], const double c[3], double n[3])
{
	double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
	double e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
	n[0] = 0.5 * (e1[1] * e2[2] - e1[2] * e2[1]);
	n[1] = 0.5 * (e1[2] * e2[0] - e1[0] * e2[2]);
	n[2] = 0.5 * (e1[0] * e2[1] - e1[1] * e2[0]);
}

static void unit(double n[3])
{
	double l = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
	if (l > 0)
		n[0] /= l, n[1] /= l, n[2] /= l;
}

static int add_fnode(ndo_sim *s, int32_t p, size_t *cap)
{
	for (size_t k = 0; k < s->nfnodes; k++)
		if (s->fnodes[k] == p)
			return NDO_OK;
	if (s->nfnodes == *cap) {
		size_t nc = *cap ? 2 * *cap : 64;
		int32_t *q = realloc(s->fnodes, nc * sizeof *q);
		if (!q)
			return ndo__fail(NDO_ENOMEM, "out of memory for forces");
		s->fnodes = q;
		*cap = nc;
	}
	s->fnodes[s->nfnodes++] = p;
	return NDO_OK;
}

int ndo__forces_resolve(ndo_sim *s, const ndo_force *forces, int nforces)
{
	size_t ntri = ndo_triangle_count(s->level), cap = 0;
	s->forces = calloc((size_t)(nforces > 0 ? nforces : 1), sizeof *s->forces);
	if (!s->forces)
		return ndo__fail(NDO_ENOMEM, "out of memory for forces");
	s->nforces = nforces;
	for (int k = 0; k < nforces; k++) {
		const ndo_force *in = &forces[k];
		ndo__force *f = &s->forces[k];
		f->f = *in;
		f->f.items = NULL;
		if (!isfinite(in->amplitude) || !(in->frequency >= 0) || !isfinite(in->frequency) ||
		    !isfinite(in->phase))
			return ndo__fail(NDO_ERANGE, "force %d: amplitude, frequency and phase must "
			                 "be finite, the frequency ≥ 0", k + 1);
		if (in->kind != NDO_FORCE_PRESSURE && !in->normal) {
			double d[3] = {in->dir[0], in->dir[1], in->dir[2]};
			double l = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
			/* The squares of a direction's components under 1e-154 or over
			 * 1e154 leave the doubles (direction=1e-300,0,0 had length 0,
			 * 1e200,0,0 length inf, both refused as not "nonzero finite"):
			 * there the vector is first divided by its largest component.
			 * Elsewhere the length as before, so that results keep their
			 * bits. */
			if (!(l > 1e-150 && l < 1e150)) {
				double m = fmax(fabs(d[0]), fmax(fabs(d[1]), fabs(d[2])));
				if (!(m > 0) || !isfinite(m))
					return ndo__fail(NDO_ERANGE, "force %d: the direction must be a nonzero "
					                 "finite vector", k + 1);
				for (int c = 0; c < 3; c++)
					d[c] /= m;
				l = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
			}
			for (int c = 0; c < 3; c++)
				f->f.dir[c] = d[c] / l;
		}
		if (in->kind == NDO_FORCE_PRESSURE) {
			s->has_pressure = 1;
			continue;
		}
		if (in->count == 0)
			return ndo__fail(NDO_EINVAL, "force %d selects no %s", k + 1,
			                 in->kind == NDO_FORCE_FACE ? "faces" : "nodes");
		f->f.items = malloc(in->count * sizeof *f->f.items);
		if (!f->f.items)
			return ndo__fail(NDO_ENOMEM, "out of memory for forces");
		f->f.count = in->count;
		if (in->kind == NDO_FORCE_FACE) {
			f->share = malloc(in->count * sizeof *f->share);
			f->nodes = malloc(3 * in->count * sizeof *f->nodes);
			if (!f->share || !f->nodes)
				return ndo__fail(NDO_ENOMEM, "out of memory for forces");
			double total = 0;
			for (size_t q = 0; q < in->count; q++) {
				if (in->items[q] < 0 || (size_t)in->items[q] >= ntri)
					return ndo__fail(NDO_EINVAL, "force %d: face %d is outside 0..%zu",
					                 k + 1, (int)in->items[q], ntri - 1);
				int32_t v[3];
				double a[3], b[3], c[3], n[3];
				triangle_nodes(s, (size_t)in->items[q], v);
				memcpy(f->nodes + 3 * q, v, sizeof v);
				for (int d = 0; d < 3; d++) {
					a[d] = s->X[(size_t)d * s->count + (size_t)v[0]];
					b[d] = s->X[(size_t)d * s->count + (size_t)v[1]];
					c[d] = s->X[(size_t)d * s->count + (size_t)v[2]];
				}
				area_vector(a, b, c, n);
				f->share[q] = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
				total += f->share[q];
				f->f.items[q] = in->items[q];
				for (int d = 0; d < 3; d++)
					if (add_fnode(s, v[d], &cap))
						return NDO_ENOMEM;
			}
			for (size_t q = 0; q < in->count; q++)
				f->share[q] /= total;
		} else {
			for (size_t q = 0; q < in->count; q++) {
				if (in->items[q] < 0 || (size_t)in->items[q] >= s->count)
					return ndo__fail(NDO_EINVAL, "force %d: node %d is outside 0..%zu",
					                 k + 1, (int)in->items[q], s->count - 1);
				f->f.items[q] = s->canon[in->items[q]];
				if (add_fnode(s, f->f.items[q], &cap))
					return NDO_ENOMEM;
			}
		}
	}
	s->has_forces = nforces > 0;
	return NDO_OK;
}

void ndo__forces_free(ndo_sim *s)
{
	for (int k = 0; k < s->nforces; k++) {
		free(s->forces[k].f.items);
		free(s->forces[k].share);
		free(s->forces[k].nodes);
	}
	free(s->forces);
	free(s->fnodes);
}

/* The area-weighted normal at node p (the six lattice triangles around
 * it; at a corner each real triangle is counted twice, which leaves the
 * direction unchanged). */
static void vertex_normal(const ndo_sim *s, const double *u, int32_t p, double n[3])
{
	size_t nb[6];
	ndo_neighbors(s->level, (int)(p % s->w), (int)(p / s->w), nb);
	double x0[3], x1[3], x2[3], a[3];
	position(s, u, p, x0);
	n[0] = n[1] = n[2] = 0;
	for (int k = 0; k < 6; k++) {
		position(s, u, s->canon[nb[k]], x1);
		position(s, u, s->canon[nb[(k + 1) % 6]], x2);
		area_vector(x0, x1, x2, a);
		for (int c = 0; c < 3; c++)
			n[c] += a[c];
	}
	unit(n);
}

/* Item q of face or node force F at value val: its canonical nodes (the
 * count returned) and what each of them gets, add[e] for coordinate e.
 * Faces along their normals go through the batches below (face_adds);
 * here only under rk4_reference, the one-at-a-time arithmetic the tests
 * hold the batches to. */
static int item_force(const ndo_sim *s, const ndo__force *F, size_t q, const double *u,
                      double val, int32_t v[3], double add[3])
{
	double dir[3];
	if (F->f.kind == NDO_FORCE_FACE) {
		memcpy(v, F->nodes + 3 * q, 3 * sizeof *v);
		if (F->f.normal) {
			double a[3], b[3], c[3];
			position(s, u, v[0], a);
			position(s, u, v[1], b);
			position(s, u, v[2], c);
			area_vector(a, b, c, dir);
			unit(dir);
		} else {
			memcpy(dir, F->f.dir, sizeof dir);
		}
		double each = val * F->share[q] / 3;
		for (int e = 0; e < 3; e++)
			add[e] = each * dir[e];
		return 3;
	}
	v[0] = F->f.items[q];
	if (F->f.normal)
		vertex_normal(s, u, v[0], dir);
	else
		memcpy(dir, F->f.dir, sizeof dir);
	for (int e = 0; e < 3; e++)
		add[e] = val * dir[e];
	return 1;
}

int ndo__force_item_nodes(const ndo_sim *s, int k, size_t q, int32_t v[3])
{
	const ndo__force *F = &s->forces[k];
	if (F->f.kind == NDO_FORCE_FACE) {
		memcpy(v, F->nodes + 3 * q, 3 * sizeof *v);
		return 3;
	}
	v[0] = F->f.items[q];
	return 1;
}

/* Face items along their normals, FBATCH at a time: the positions
 * gathered, then the area vectors, their lengths and the shares in one
 * loop the compiler vectorizes (the sqrt and the divisions were most of
 * an item's time: perf, level 6, the thesis scene).  The same operations
 * in the same order as area_vector(), unit() and item_force(), each
 * correctly rounded, so the same bits as ndo__forces_eval (no
 * contraction into FMAs under -std=c11). */
#define FBATCH 32
typedef struct face_batch {
	double a[3][FBATCH], b[3][FBATCH], c[3][FBATCH];
	double each[FBATCH]; /* val · share: face_adds() divides by 3, vectorized */
	double add[3][FBATCH];
} face_batch;

/* O3: GCC 12's O2 vectorizes only the cheapest loops; no-trapping-math:
 * the divisions where l is 0 are computed and not used (the Makefile
 * compiles this file with -fno-math-errno, the sqrt's part). */
#if defined(__GNUC__) && !defined(__clang__)
#define FACE_OPT __attribute__((optimize("O3", "no-trapping-math")))
#else
#define FACE_OPT
#endif
FACE_OPT NDO_HOT static void face_adds(face_batch *restrict B, int m)
{
	for (int i = 0; i < m; i++) {
		double e1x = B->b[0][i] - B->a[0][i], e1y = B->b[1][i] - B->a[1][i],
		       e1z = B->b[2][i] - B->a[2][i];
		double e2x = B->c[0][i] - B->a[0][i], e2y = B->c[1][i] - B->a[1][i],
		       e2z = B->c[2][i] - B->a[2][i];
		double nx = 0.5 * (e1y * e2z - e1z * e2y);
		double ny = 0.5 * (e1z * e2x - e1x * e2z);
		double nz = 0.5 * (e1x * e2y - e1y * e2x);
		double l = sqrt(nx * nx + ny * ny + nz * nz);
		/* n / l is not used where l is 0: unit() leaves n as it is */
		double qx = nx / l, qy = ny / l, qz = nz / l;
		const double each = B->each[i] / 3; /* item_force()'s val · share / 3 */
		B->add[0][i] = each * (l > 0 ? qx : nx);
		B->add[1][i] = each * (l > 0 ? qy : ny);
		B->add[2][i] = each * (l > 0 ? qz : nz);
	}
}

/* Slot i of B: the positions of the face's nodes v[3], and val · share. */
static inline __attribute__((always_inline)) void
face_gather(const ndo_sim *s, const double *u, face_batch *B, int i, const int32_t *v, double each)
{
	const size_t cnt = s->count;
	for (int d = 0; d < 3; d++) {
		double *x = d == 0 ? &B->a[0][i] : d == 1 ? &B->b[0][i] : &B->c[0][i];
		size_t p = (size_t)v[d];
		for (int c = 0; c < 3; c++)
			x[c * FBATCH] = s->X[(size_t)c * cnt + p] + u[(size_t)c * cnt + p];
	}
	B->each[i] = each;
}

void ndo__forces_eval(ndo_sim *s, double t, const double *u)
{
	size_t cnt = s->count;
	double *f = s->f;
	if (s->has_pressure)
		memset(f, 0, 3 * cnt * sizeof *f);
	else
		for (size_t k = 0; k < s->nfnodes; k++)
			for (int c = 0; c < 3; c++)
				f[(size_t)c * cnt + (size_t)s->fnodes[k]] = 0;
	for (int k = 0; k < s->nforces; k++) {
		const ndo__force *F = &s->forces[k];
		double val = ndo_force_value(&F->f, t);
		if (val == 0)
			continue;
		if (F->f.kind == NDO_FORCE_PRESSURE) {
			size_t ntri = ndo_triangle_count(s->level);
			for (size_t q = 0; q < ntri; q++) {
				int32_t v[3];
				double a[3], b[3], c[3], n[3];
				triangle_nodes(s, q, v);
				position(s, u, v[0], a);
				position(s, u, v[1], b);
				position(s, u, v[2], c);
				area_vector(a, b, c, n);
				for (int d = 0; d < 3; d++)
					for (int e = 0; e < 3; e++)
						f[(size_t)e * cnt + (size_t)v[d]] += val * n[e] / 3;
			}
			continue;
		}
		/* (rk4_reference: one item at a time, the reference the tests
		 * hold the batches to) */
		if (F->f.kind == NDO_FORCE_FACE && F->f.normal && !s->rk4_reference) {
			face_batch B;
			for (size_t q0 = 0; q0 < F->f.count; q0 += FBATCH) {
				int m = F->f.count - q0 < FBATCH ? (int)(F->f.count - q0) : FBATCH;
				for (int i = 0; i < m; i++)
					face_gather(s, u, &B, i, F->nodes + 3 * (q0 + (size_t)i),
					            val * F->share[q0 + (size_t)i]);
				face_adds(&B, m);
				for (int i = 0; i < m; i++) {
					const int32_t *v = F->nodes + 3 * (q0 + (size_t)i);
					for (int d = 0; d < 3; d++)
						for (int e = 0; e < 3; e++)
							f[(size_t)e * cnt + (size_t)v[d]] += B.add[e][i];
				}
			}
			continue;
		}
		for (size_t q = 0; q < F->f.count; q++) {
			int32_t v[3];
			double add[3];
			int nv = item_force(s, F, q, u, val, v, add);
			for (int d = 0; d < nv; d++)
				for (int e = 0; e < 3; e++)
					f[(size_t)e * cnt + (size_t)v[d]] += add[e];
		}
	}
}

void ndo__forces_eval_items(ndo_sim *s, double t, const double *u, const int32_t *zero,
                            size_t nzero, const ndo__fitem *items, size_t nitems)
{
	const size_t cnt = s->count;
	double *f = s->f;
	for (size_t k = 0; k < nzero; k++)
		for (int c = 0; c < 3; c++)
			f[(size_t)c * cnt + (size_t)zero[k]] = 0;
	int kval = -1;
	double val = 0, vals[FBATCH];
	int slot[FBATCH];
	face_batch B;
	for (size_t i0 = 0; i0 < nitems; i0 += FBATCH) {
		int m = nitems - i0 < FBATCH ? (int)(nitems - i0) : FBATCH, nf = 0;
		/* the batch's values, and its face items along normals gathered */
		for (int i = 0; i < m; i++) {
			const ndo__fitem *it = &items[i0 + (size_t)i];
			const ndo__force *F = &s->forces[it->k];
			if (it->k != kval)
				kval = it->k, val = ndo_force_value(&F->f, t);
			vals[i] = val;
			slot[i] = -1;
			if (val == 0 || F->f.kind != NDO_FORCE_FACE || !F->f.normal)
				continue;
			face_gather(s, u, &B, nf, F->nodes + 3 * (size_t)it->q, val * F->share[it->q]);
			slot[i] = nf++;
		}
		face_adds(&B, nf);
		/* the additions in the items' order */
		for (int i = 0; i < m; i++) {
			const ndo__fitem *it = &items[i0 + (size_t)i];
			if (vals[i] == 0)
				continue;
			int32_t v[3];
			double add[3];
			int nv;
			if (slot[i] >= 0) {
				nv = 3;
				const int32_t *fv = s->forces[it->k].nodes + 3 * (size_t)it->q;
				for (int c = 0; c < 3; c++)
					v[c] = fv[c], add[c] = B.add[c][slot[i]];
			} else {
				nv = item_force(s, &s->forces[it->k], (size_t)it->q, u, vals[i], v, add);
			}
			for (int d = 0; d < nv; d++)
				if (it->mask >> d & 1)
					for (int e = 0; e < 3; e++)
						f[(size_t)e * cnt + (size_t)v[d]] += add[e];
		}
	}
}

_Atomic long ndo__forces_compact_units;

void ndo__forces_eval_chunk(ndo_sim *s, double t, const double *u, const ndo__chunks *K, int c)
{
	const int32_t *zero = K->zlist + K->zoff[c];
	const size_t nzero = (size_t)(K->zoff[c + 1] - K->zoff[c]);
	const ndo__fitem *items = K->fitem + K->foff[c];
	const size_t nitems = (size_t)(K->foff[c + 1] - K->foff[c]);
	if (!K->cfit[c]) {
		ndo__forces_eval_items(s, t, u, zero, nzero, items, nitems);
		return;
	}
	atomic_fetch_add_explicit(&ndo__forces_compact_units, 1, memory_order_relaxed);
	/* x = X + u at each node once (the same sums face_gather() makes),
	 * and each node's sum in acc, f written at the end: the same
	 * additions in the same order as ndo__forces_eval_items, so the same
	 * bits */
	const size_t cnt = s->count, nc = (size_t)(K->coff[c + 1] - K->coff[c]);
	const int32_t *cn = K->cnode + K->coff[c], *ci = K->fci + 3 * (size_t)K->foff[c];
	const int32_t *zc = K->zci + K->zoff[c];
	double x[3 * NDO__CF_MAX], acc[3 * NDO__CF_MAX];
	for (size_t i = 0; i < nc; i++)
		for (int e = 0; e < 3; e++)
			x[3 * i + (size_t)e] = s->X[(size_t)e * cnt + (size_t)cn[i]] +
			                       u[(size_t)e * cnt + (size_t)cn[i]];
	/* every node's sums from 0, the others' too: each item adds at its
	 * three nodes without a test of its mask (a mispredicted branch cost
	 * more than the additions); a node not this chunk's is never written
	 * to f, and a node of the chunk's gets its items' additions alone, as
	 * the mask would have it (every item of the node has its bit) */
	memset(acc, 0, 3 * nc * sizeof *acc);
	int kval = -1;
	double val = 0;
	int slot[FBATCH];
	face_batch B;
	for (size_t i0 = 0; i0 < nitems; i0 += FBATCH) {
		int m = nitems - i0 < FBATCH ? (int)(nitems - i0) : FBATCH, nf = 0;
		for (int i = 0; i < m; i++) {
			const ndo__fitem *it = &items[i0 + (size_t)i];
			const ndo__force *F = &s->forces[it->k];
			if (it->k != kval)
				kval = it->k, val = ndo_force_value(&F->f, t);
			slot[i] = -1;
			if (val == 0)
				continue;
			const int32_t *v = ci + 3 * (i0 + (size_t)i);
			for (int e = 0; e < 3; e++) {
				B.a[e][nf] = x[3 * (size_t)v[0] + (size_t)e];
				B.b[e][nf] = x[3 * (size_t)v[1] + (size_t)e];
				B.c[e][nf] = x[3 * (size_t)v[2] + (size_t)e];
			}
			B.each[nf] = val * F->share[it->q];
			slot[i] = nf++;
		}
		face_adds(&B, nf);
		for (int i = 0; i < m; i++) {
			if (slot[i] < 0)
				continue;
			const int32_t *v = ci + 3 * (i0 + (size_t)i);
			for (int d = 0; d < 3; d++)
				for (int e = 0; e < 3; e++)
					acc[3 * (size_t)v[d] + (size_t)e] += B.add[e][slot[i]];
		}
	}
	double *f = s->f;
	for (size_t k = 0; k < nzero; k++)
		for (int e = 0; e < 3; e++)
			f[(size_t)e * cnt + (size_t)zero[k]] = acc[3 * (size_t)zc[k] + (size_t)e];
}
