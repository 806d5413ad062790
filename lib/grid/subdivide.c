/* subdivide.c — modified butterfly as three convolutions over the
 * ghost-padded grid, plus the valence-3 corner rule (ndo/subdivide.h). */
#include "ndo/subdivide.h"
#include "grid_private.h"
#include "ndo/status.h"
#include "ndo/topology.h"

#include <stdlib.h>
#include <string.h>

size_t ndo_butterfly_scratch(int level, int comps)
{
	size_t n = (size_t)1 << level;
	return (2 * n + 3) * (n + 3) * (size_t)comps;
}

/* The three kernels, written out per row.  r(d)[i] is padded node
 * (i, j+d) of coarse row j; offsets (di, dj) from the edge's first end.
 *   horizontal (i,j)-(i+1,j):   ends (0,0) (1,0); wings (0,1) (1,-1);
 *                               far (-1,1) (1,1) (0,-1) (2,-1)
 *   vertical   (i,j)-(i,j+1):   ends (0,0) (0,1); wings (1,0) (-1,1);
 *                               far (1,-1) (1,1) (-1,0) (-1,2)
 *   diagonal   (i+1,j)-(i,j+1): ends (1,0) (0,1); wings (0,0) (1,1);
 *                               far (1,-1) (-1,1) (2,0) (0,2)
 * Every far/wing vertex is found by crossing one edge of a triangle next
 * to the edge; through the ghost cells this is exact except at edges that
 * end at a corner (valence 3), which the corner rule rewrites. */
#define DEFINE_KERNEL(T, NAME)                                                   \
static inline __attribute__((always_inline)) void                                \
NAME(int level, int C, const T *pad, T *out)                                     \
{                                                                                \
	const int n = 1 << level, w = 2 * n + 1, pw = w + 2, w2 = 2 * w - 1;         \
	const T e = (T)NDO_BF_EDGE, wg = (T)NDO_BF_WING, f = (T)NDO_BF_FAR;          \
	for (int j = 0; j <= n; j++) {                                               \
		const T *rm = pad + ((size_t)(j) * pw + 1) * C;     /* row j-1 */        \
		const T *r0 = rm + (size_t)pw * C, *r1 = r0 + (size_t)pw * C;            \
		const T *r2 = r1 + (size_t)pw * C;                                       \
		T *even = out + (size_t)(2 * j) * w2 * C;                                \
		for (int i = 0; i < w; i++)                                              \
			for (int k = 0; k < C; k++)                                          \
				even[2 * i * C + k] = r0[i * C + k];                             \
		for (int i = 0; i < w - 1; i++)                                          \
			for (int k = 0; k < C; k++) {                                        \
				const int a = i * C + k;                                         \
				even[(2 * i + 1) * C + k] =                                      \
				    e * (r0[a] + r0[a + C]) + wg * (r1[a] + rm[a + C]) +         \
				    f * (r1[a - C] + r1[a + C] + rm[a] + rm[a + 2 * C]);         \
			}                                                                    \
		if (j == n)                                                              \
			break;                                                               \
		T *odd = even + (size_t)w2 * C;                                          \
		for (int i = 0; i < w; i++)                                              \
			for (int k = 0; k < C; k++) {                                        \
				const int a = i * C + k;                                         \
				odd[2 * i * C + k] =                                             \
				    e * (r0[a] + r1[a]) + wg * (r0[a + C] + r1[a - C]) +         \
				    f * (rm[a + C] + r1[a + C] + r0[a - C] + r2[a - C]);         \
			}                                                                    \
		for (int i = 0; i < w - 1; i++)                                          \
			for (int k = 0; k < C; k++) {                                        \
				const int a = i * C + k;                                         \
				odd[(2 * i + 1) * C + k] =                                       \
				    e * (r0[a + C] + r1[a]) + wg * (r0[a] + r1[a + C]) +         \
				    f * (rm[a + C] + r1[a - C] + r0[a + 2 * C] + r2[a]);         \
			}                                                                    \
	}                                                                            \
}

DEFINE_KERNEL(double, kernel_f64)
DEFINE_KERNEL(float, kernel_f32)

/* The comps = 3 case (positions, velocities) again with a constant width,
 * so the compiler unrolls the inner loops. */
static void kernel_f64_3(int level, const double *pad, double *out)
{
	kernel_f64(level, 3, pad, out);
}

/* Zorin's valence-3 rule on the 12 edges at the corners A, B, C, D: the
 * fine node of edge (e, o) is rewritten at its canonical index. */
#define DEFINE_CORNERS(T, NAME)                                                  \
static void NAME(int level, int C, const T *in, T *out)                          \
{                                                                                \
	const int n = 1 << level, w = 2 * n + 1;                                     \
	static const int corner[4][2] = {{0, 0}, {1, 0}, {0, 1}, {1, 1}};            \
	size_t nb[4][3];                                                             \
	for (int c = 0; c < 4; c++) {                                                \
		size_t six[6];                                                           \
		ndo_neighbors(level, corner[c][0] * n, corner[c][1] * n, six);           \
		for (int k = 0; k < 3; k++)                                              \
			nb[c][k] = ndo_canonical(level, (int)(six[k] % w), (int)(six[k] / w)); \
	}                                                                            \
	for (int c = 0; c < 4; c++) {                                                \
		size_t e = ndo_node(w, corner[c][0] * n, corner[c][1] * n);              \
		for (int k = 0; k < 3; k++) {                                            \
			size_t o = nb[c][k];                                                 \
			int fi = 2 * corner[c][0] * n + ndo_dirs[k][0],                      \
			    fj = 2 * corner[c][1] * n + ndo_dirs[k][1];                      \
			size_t dst = ndo_canonical(level + 1, fi, fj);                       \
			/* the other end is a corner too only at level 0 */              \
			int oc = -1;                                                         \
			for (int d = 0; d < 4; d++)                                          \
				if (ndo_canonical(level, corner[d][0] * n, corner[d][1] * n) == o) \
					oc = d;                                                      \
			for (int q = 0; q < C; q++) {                                        \
				double v = rule3(in, C, q, e, o, nb[c]);                         \
				if (oc >= 0)                                                     \
					v = 0.5 * (v + rule3(in, C, q, o, e, nb[oc]));               \
				out[dst * C + q] = (T)v;                                         \
			}                                                                    \
		}                                                                        \
	}                                                                            \
}

/* 3/4 e + 5/12 o − 1/12 (the two other neighbours of e). */
#define DEFINE_RULE3(T, NAME)                                                    \
static double NAME(const T *in, int C, int q, size_t e, size_t o,                \
                   const size_t nb[3])                                           \
{                                                                                \
	double s = NDO_BF3_SELF * in[e * C + q] + NDO_BF3_S0 * in[o * C + q];        \
	for (int k = 0; k < 3; k++)                                                  \
		if (nb[k] != o)                                                          \
			s += NDO_BF3_S12 * in[nb[k] * C + q];                                \
	return s;                                                                    \
}

#define rule3 rule3_f64
DEFINE_RULE3(double, rule3_f64)
DEFINE_CORNERS(double, corners_f64)
#undef rule3
#define rule3 rule3_f32
DEFINE_RULE3(float, rule3_f32)
DEFINE_CORNERS(float, corners_f32)
#undef rule3

void ndo_butterfly_f64(int level, int comps, const double *in, double *out,
                       double *scratch, ndo_corner_rule rule)
{
	ndo_pad(level, 1, in, (size_t)comps * sizeof(double), scratch);
	if (comps == 3)
		kernel_f64_3(level, scratch, out);
	else
		kernel_f64(level, comps, scratch, out);
	if (rule == NDO_CORNERS_ZORIN)
		corners_f64(level, comps, in, out);
	ndo_sync(level + 1, out, (size_t)comps * sizeof(double));
}

static void butterfly_f32(int level, int comps, const float *in, float *out,
                          float *scratch, ndo_corner_rule rule)
{
	ndo_pad(level, 1, in, (size_t)comps * sizeof(float), scratch);
	kernel_f32(level, comps, scratch, out);
	if (rule == NDO_CORNERS_ZORIN)
		corners_f32(level, comps, in, out);
	ndo_sync(level + 1, out, (size_t)comps * sizeof(float));
}

/* Integer channels: the new node takes the smaller of its edge's ends. */
#define DEFINE_LABELS(T, NAME)                                                   \
static void NAME(int level, int C, const T *pad, T *out)                         \
{                                                                                \
	const int n = 1 << level, w = 2 * n + 1, pw = w + 2, w2 = 2 * w - 1;         \
	for (int j = 0; j <= n; j++) {                                               \
		const T *r0 = pad + ((size_t)(j + 1) * pw + 1) * C, *r1 = r0 + (size_t)pw * C; \
		T *even = out + (size_t)(2 * j) * w2 * C, *odd = even + (size_t)w2 * C;  \
		for (int i = 0; i < w; i++)                                              \
			for (int k = 0; k < C; k++) {                                        \
				const int a = i * C + k;                                         \
				T x = r0[a];                                                     \
				even[2 * i * C + k] = x;                                         \
				if (i + 1 < w)                                                   \
					even[(2 * i + 1) * C + k] = x < r0[a + C] ? x : r0[a + C];   \
				if (j == n)                                                      \
					continue;                                                    \
				odd[2 * i * C + k] = x < r1[a] ? x : r1[a];                      \
				if (i + 1 < w)                                                   \
					odd[(2 * i + 1) * C + k] =                                   \
					    r0[a + C] < r1[a] ? r0[a + C] : r1[a];                   \
			}                                                                    \
	}                                                                            \
}

DEFINE_LABELS(uint8_t, labels_u8)
DEFINE_LABELS(int32_t, labels_i32)

int ndo_subdivide(const ndo_grid *in, ndo_corner_rule rule, ndo_grid **out)
{
	*out = NULL;
	if (in->level >= NDO_MAX_LEVEL)
		return ndo__fail(NDO_ERANGE,
		                 "cannot refine level %d: the largest level is %d",
		                 in->level, NDO_MAX_LEVEL);
	ndo_grid *g;
	int rc = ndo__grid_alloc(in->level + 1, &g);
	if (rc)
		return rc;
	g->time = in->time;
	g->step = in->step;
	free(g->history);
	g->history = strdup(in->history);
	int maxc = 1;
	for (int c = 0; c < in->nchannels; c++)
		if (in->ch[c].comps > maxc)
			maxc = in->ch[c].comps;
	double *scratch = malloc(ndo_butterfly_scratch(in->level, maxc) * sizeof(double));
	if (!scratch || !g->history) {
		free(scratch);
		ndo_grid_destroy(g);
		return ndo__fail(NDO_ENOMEM, "out of memory refining to level %d",
		                 in->level + 1);
	}
	for (int c = 0; c < in->nchannels && rc == NDO_OK; c++) {
		const ndo_channel *src = &in->ch[c];
		ndo_channel *dst;
		if ((rc = ndo_grid_add(g, src->name, src->type, src->comps, &dst)))
			break;
		size_t nb = (size_t)src->comps * ndo_type_size(src->type);
		switch (src->type) {
		case NDO_F64:
			ndo_butterfly_f64(in->level, src->comps, src->data, dst->data,
			                  scratch, rule);
			break;
		case NDO_F32:
			butterfly_f32(in->level, src->comps, src->data, dst->data,
			              (float *)scratch, rule);
			break;
		case NDO_U8:
			ndo_pad(in->level, 1, src->data, nb, scratch);
			labels_u8(in->level, src->comps, (const uint8_t *)scratch, dst->data);
			ndo_sync(g->level, dst->data, nb);
			break;
		case NDO_I32:
			ndo_pad(in->level, 1, src->data, nb, scratch);
			labels_i32(in->level, src->comps, (const int32_t *)scratch, dst->data);
			ndo_sync(g->level, dst->data, nb);
			break;
		}
	}
	free(scratch);
	if (rc) {
		ndo_grid_destroy(g);
		return rc;
	}
	*out = g;
	return NDO_OK;
}

int ndo_subdivide_levels(const ndo_grid *in, int k, ndo_corner_rule rule,
                         ndo_grid **out)
{
	*out = NULL;
	if (k < 0 || in->level + k > NDO_MAX_LEVEL)
		return ndo__fail(NDO_ERANGE,
		                 "level %d + %d is outside 0..%d", in->level, k,
		                 NDO_MAX_LEVEL);
	ndo_grid *g;
	int rc = ndo_grid_copy(in, &g);
	for (int s = 0; s < k && rc == NDO_OK; s++) {
		ndo_grid *next;
		rc = ndo_subdivide(g, rule, &next);
		ndo_grid_destroy(g);
		g = rc ? NULL : next;
	}
	if (rc)
		return rc;
	*out = g;
	return NDO_OK;
}
