/* membrane.c — cotangent stiffness (thesis eq. 4.12) as a reference CSR
 * matrix and as the grid stencil, and the lumped mass (ndo/membrane.h). */
#include "ndo/membrane.h"
#include "ndo/status.h"
#include "ndo/topology.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

double ndo_cotan_weights(const double a[3], const double b[3], const double c[3],
                         double w[3])
{
	const double *v[3] = {a, b, c};
	double cr[3], area2 = 0;
	{
		double e1[3], e2[3];
		for (int d = 0; d < 3; d++) {
			e1[d] = b[d] - a[d];
			e2[d] = c[d] - a[d];
		}
		cr[0] = e1[1] * e2[2] - e1[2] * e2[1];
		cr[1] = e1[2] * e2[0] - e1[0] * e2[2];
		cr[2] = e1[0] * e2[1] - e1[1] * e2[0];
		area2 = sqrt(cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]);
	}
	if (!(area2 > 0) || !isfinite(area2)) {
		w[0] = w[1] = w[2] = 0;
		return 0;
	}
	/* cot(angle at v) = (e1 · e2) / |e1 × e2|, and |e1 × e2| is twice the
	 * area whichever corner it is taken from. */
	for (int k = 0; k < 3; k++) {
		const double *o = v[k], *p = v[(k + 1) % 3], *q = v[(k + 2) % 3];
		double dot = 0;
		for (int d = 0; d < 3; d++)
			dot += (p[d] - o[d]) * (q[d] - o[d]);
		w[k] = 0.5 * dot / area2;
	}
	return 0.5 * area2;
}

/* The canonical stored index of every stored node. */
static int32_t *canonical_map(int level)
{
	int n = 1 << level, w = 2 * n + 1;
	size_t count = (size_t)w * (size_t)(n + 1);
	int32_t *c = malloc(count * sizeof *c);
	if (!c)
		return NULL;
	for (size_t p = 0; p < count; p++)
		c[p] = (int32_t)ndo_canonical(level, (int)(p % (size_t)w), (int)(p / (size_t)w));
	return c;
}

static int check_finite(int level, const double *x)
{
	int w = (2 << level) + 1;
	size_t count = (size_t)w * (size_t)((1 << level) + 1);
	for (size_t p = 0; p < 3 * count; p++)
		if (!isfinite(x[p]))
			return ndo__fail(NDO_ERANGE, "position of node (%d, %d) is not finite",
			                 (int)(p / 3 % (size_t)w), (int)(p / 3 / (size_t)w));
	return NDO_OK;
}

static int degenerate(int level, size_t t)
{
	int n = 1 << level;
	size_t cell = t / 2;
	return ndo__fail(NDO_ERANGE,
	                 "triangle %zu (cell %d, %d) is degenerate: zero area, no stiffness",
	                 t, (int)(cell % (size_t)(2 * n)), (int)(cell / (size_t)(2 * n)));
}

/* ---- the reference: triangle-by-triangle assembly ---------------------- */

void ndo_csr_free(ndo_csr *K)
{
	if (!K)
		return;
	free(K->ptr);
	free(K->col);
	free(K->val);
	memset(K, 0, sizeof *K);
}

/* Rows of at most `cap` entries while assembling; compressed at the end. */
typedef struct rows {
	int32_t n, cap;
	int32_t *len, *col;
	double *val;
} rows;

static void rows_add(rows *r, int32_t i, int32_t j, double v)
{
	int32_t *c = r->col + (size_t)i * r->cap;
	double *x = r->val + (size_t)i * r->cap;
	for (int32_t k = 0; k < r->len[i]; k++)
		if (c[k] == j) {
			x[k] += v;
			return;
		}
	/* cap bounds the valence + 1; a full row cannot happen on a grid. */
	c[r->len[i]] = j;
	x[r->len[i]++] = v;
}

static int cmp_entry(const void *a, const void *b)
{
	int32_t x = *(const int32_t *)a, y = *(const int32_t *)b;
	return (x > y) - (x < y);
}

static int rows_compress(rows *r, ndo_csr *K)
{
	memset(K, 0, sizeof *K);
	K->n = r->n;
	K->ptr = malloc(((size_t)r->n + 1) * sizeof *K->ptr);
	int64_t nnz = 0;
	for (int32_t i = 0; i < r->n; i++)
		nnz += r->len[i];
	K->col = malloc((size_t)(nnz ? nnz : 1) * sizeof *K->col);
	K->val = malloc((size_t)(nnz ? nnz : 1) * sizeof *K->val);
	if (!K->ptr || !K->col || !K->val) {
		ndo_csr_free(K);
		return ndo__fail(NDO_ENOMEM, "out of memory for a sparse matrix");
	}
	int64_t at = 0;
	struct { int32_t c; double v; } tmp[32];
	for (int32_t i = 0; i < r->n; i++) {
		K->ptr[i] = at;
		int32_t len = r->len[i];
		for (int32_t k = 0; k < len; k++) {
			tmp[k].c = r->col[(size_t)i * r->cap + k];
			tmp[k].v = r->val[(size_t)i * r->cap + k];
		}
		qsort(tmp, (size_t)len, sizeof tmp[0], cmp_entry);
		for (int32_t k = 0; k < len; k++) {
			K->col[at] = tmp[k].c;
			K->val[at++] = tmp[k].v;
		}
	}
	K->ptr[r->n] = at;
	return NDO_OK;
}

static int rows_init(rows *r, int32_t n, int32_t cap)
{
	r->n = n;
	r->cap = cap;
	r->len = calloc((size_t)n, sizeof *r->len);
	r->col = malloc((size_t)n * (size_t)cap * sizeof *r->col);
	r->val = malloc((size_t)n * (size_t)cap * sizeof *r->val);
	if (!r->len || !r->col || !r->val) {
		free(r->len), free(r->col), free(r->val);
		return ndo__fail(NDO_ENOMEM, "out of memory for a sparse matrix");
	}
	return NDO_OK;
}

static void rows_free(rows *r)
{
	free(r->len);
	free(r->col);
	free(r->val);
}

int ndo_membrane_csr(int level, const double *x, double sigma, ndo_csr *K)
{
	ndo__clear_error();
	memset(K, 0, sizeof *K);
	int rc = check_finite(level, x);
	if (rc)
		return rc;
	int n = 1 << level, w = 2 * n + 1;
	size_t count = (size_t)w * (size_t)(n + 1), ntri = ndo_triangle_count(level);
	int32_t nv = (int32_t)ndo_vertex_count(level);
	int32_t *vid = malloc(count * sizeof *vid), *tri = malloc(3 * ntri * sizeof *tri);
	rows r;
	if (!vid || !tri) {
		free(vid), free(tri);
		return ndo__fail(NDO_ENOMEM, "out of memory for a sparse matrix");
	}
	if ((rc = rows_init(&r, nv, 8))) {
		free(vid), free(tri);
		return rc;
	}
	ndo_vertex_ids(level, vid, NULL);
	ndo_triangles(level, tri);
	for (size_t t = 0; t < ntri; t++) {
		const int32_t *s = tri + 3 * t;
		double wt[3];
		if (ndo_cotan_weights(x + 3 * (size_t)s[0], x + 3 * (size_t)s[1],
		                      x + 3 * (size_t)s[2], wt) == 0) {
			rc = degenerate(level, t);
			break;
		}
		/* Thesis eq. 4.12: the element matrix couples the two ends of each
		 * edge with −k_e and adds k_e to both diagonals. */
		for (int e = 0; e < 3; e++) {
			int32_t a = vid[s[(e + 1) % 3]], b = vid[s[(e + 2) % 3]];
			double k = sigma * wt[e];
			rows_add(&r, a, b, -k);
			rows_add(&r, b, a, -k);
			rows_add(&r, a, a, k);
			rows_add(&r, b, b, k);
		}
	}
	if (rc == NDO_OK)
		rc = rows_compress(&r, K);
	rows_free(&r);
	free(vid);
	free(tri);
	return rc;
}

void ndo_csr_apply(const ndo_csr *K, const double *in, double *out, int comps)
{
	for (int32_t i = 0; i < K->n; i++)
		for (int c = 0; c < comps; c++) {
			double s = 0;
			for (int64_t k = K->ptr[i]; k < K->ptr[i + 1]; k++)
				s += K->val[k] * in[(size_t)K->col[k] * comps + c];
			out[(size_t)i * comps + c] = s;
		}
}

/* ---- the stencil -------------------------------------------------------- */

void ndo_stencil_free(ndo_stencil *s)
{
	if (!s)
		return;
	for (int k = 0; k < 3; k++)
		free(s->e[k]);
	free(s->border);
	free(s->bnb);
	free(s->bc);
	memset(s, 0, sizeof *s);
}

/* The canonical border nodes: row 0 and row N for i ≤ N, column 0 between. */
static size_t border_nodes(int level, int32_t *out)
{
	int n = 1 << level, w = 2 * n + 1;
	size_t k = 0;
	for (int i = 0; i <= n; i++)
		out[k++] = (int32_t)ndo_node(w, i, 0);
	for (int j = 1; j < n; j++)
		out[k++] = (int32_t)ndo_node(w, 0, j);
	for (int i = 0; i <= n; i++)
		out[k++] = (int32_t)ndo_node(w, i, n);
	return k;
}

static int stencil_alloc(int level, ndo_stencil *s)
{
	int n = 1 << level;
	memset(s, 0, sizeof *s);
	s->level = level;
	s->n = n;
	s->w = 2 * n + 1;
	s->h = n + 1;
	s->count = (size_t)s->w * (size_t)s->h;
	size_t nb = 2 * ((size_t)n + 1) + (size_t)(n > 0 ? n - 1 : 0);
	for (int k = 0; k < 3; k++)
		s->e[k] = calloc(s->count, sizeof(double));
	s->border = malloc(nb * sizeof *s->border);
	s->bnb = malloc(6 * nb * sizeof *s->bnb);
	s->bc = malloc(6 * nb * sizeof *s->bc);
	if (!s->e[0] || !s->e[1] || !s->e[2] || !s->border || !s->bnb || !s->bc) {
		ndo_stencil_free(s);
		return ndo__fail(NDO_ENOMEM, "out of memory for the stiffness stencil");
	}
	s->nborder = border_nodes(level, s->border);
	return NDO_OK;
}

/* σ × the full weight of the lattice edge from stored node (i, j) in
 * direction k: ½ (cot α + cot β) with α, β the angles opposite the edge in
 * the lattice triangles (p, nb_{k−1}, nb_k) and (p, nb_k, nb_{k+1}).
 * Returns 0 and sets *bad to the offending cell when a triangle is
 * degenerate. */
static double edge_weight(int level, const double *x, const int32_t *canon, int i,
                          int j, int k, double sigma, int *bad)
{
	size_t nb[6];
	ndo_neighbors(level, i, j, nb);
	int w = (2 << level) + 1;
	const double *p = x + 3 * (size_t)canon[ndo_node(w, i, j)];
	const double *a = x + 3 * (size_t)canon[nb[(k + 5) % 6]];
	const double *b = x + 3 * (size_t)canon[nb[k]];
	const double *c = x + 3 * (size_t)canon[nb[(k + 1) % 6]];
	double w1[3], w2[3];
	/* In (p, a, b) the angle at a faces edge pb; in (p, b, c) the angle at
	 * c faces edge pb.  ndo_cotan_weights' w[1] is ½ cot at its 2nd vertex,
	 * w[2] at its 3rd. */
	if (ndo_cotan_weights(p, a, b, w1) == 0 || ndo_cotan_weights(p, b, c, w2) == 0) {
		*bad = 1;
		return 0;
	}
	return sigma * (w1[1] + w2[2]);
}

int ndo_stencil_build(int level, const double *x, double sigma, ndo_stencil *s)
{
	ndo__clear_error();
	int rc = check_finite(level, x);
	if (rc)
		return rc;
	if (!s->e[0] || s->level != level) {
		ndo_stencil_free(s);
		if ((rc = stencil_alloc(level, s)))
			return rc;
	}
	int32_t *canon = canonical_map(level);
	if (!canon)
		return ndo__fail(NDO_ENOMEM, "out of memory for the stiffness stencil");
	int n = s->n, w = s->w, bad = 0;
	for (int j = 0; j <= n && !bad; j++)
		for (int i = 0; i <= 2 * n && !bad; i++)
			for (int k = 0; k < 3; k++) {
				s->e[k][ndo_node(w, i, j)] = edge_weight(level, x, canon, i, j, k, sigma, &bad);
				if (bad) {
					rc = ndo__fail(NDO_ERANGE, "a triangle at node (%d, %d) is degenerate: "
					               "zero area, no stiffness", i, j);
					break;
				}
			}
	for (size_t b = 0; b < s->nborder && !bad; b++) {
		int32_t p = s->border[b];
		int i = (int)(p % w), j = (int)(p / w);
		size_t nb[6];
		ndo_neighbors(level, i, j, nb);
		for (int k = 0; k < 6; k++) {
			/* Valence-3 corners see each neighbour twice (the 180° cone of
			 * the lattice around them): each copy carries half the weight. */
			int mult = 0;
			for (int q = 0; q < 6; q++)
				mult += canon[nb[q]] == canon[nb[k]];
			s->bnb[6 * b + k] = canon[nb[k]];
			s->bc[6 * b + k] = edge_weight(level, x, canon, i, j, k, sigma, &bad) / mult;
		}
	}
	free(canon);
	return rc;
}

/* Interior rows: six coefficients from the three edge planes, neighbours
 * at fixed offsets. */
static void apply_interior(const ndo_stencil *s, const double *u, double *ku)
{
	const size_t w = (size_t)s->w;
	const double *e0 = s->e[0], *e1 = s->e[1], *e2 = s->e[2];
	for (int j = 1; j < s->n; j++) {
		size_t r = (size_t)j * w;
		for (size_t p = r + 1; p < r + w - 1; p++) {
			double up = u[p];
			ku[p] = e0[p] * (up - u[p + 1]) + e1[p] * (up - u[p + w]) +
			        e2[p] * (up - u[p + w - 1]) + e0[p - 1] * (up - u[p - 1]) +
			        e1[p - w] * (up - u[p - w]) + e2[p - w + 1] * (up - u[p - w + 1]);
		}
	}
}

void ndo_stencil_apply(const ndo_stencil *s, const double *u, double *ku)
{
	apply_interior(s, u, ku);
	for (size_t b = 0; b < s->nborder; b++) {
		int32_t p = s->border[b];
		double up = u[p], sum = 0;
		for (int k = 0; k < 6; k++)
			sum += s->bc[6 * b + k] * (up - u[s->bnb[6 * b + k]]);
		ku[p] = sum;
	}
	ndo_sync(s->level, ku, sizeof(double));
}

void ndo_stencil_diagonal(const ndo_stencil *s, double *d)
{
	const size_t w = (size_t)s->w;
	for (int j = 1; j < s->n; j++)
		for (size_t p = (size_t)j * w + 1; p < (size_t)j * w + w - 1; p++)
			d[p] = s->e[0][p] + s->e[1][p] + s->e[2][p] + s->e[0][p - 1] +
			       s->e[1][p - w] + s->e[2][p - w + 1];
	for (size_t b = 0; b < s->nborder; b++) {
		double sum = 0;
		for (int k = 0; k < 6; k++)
			sum += s->bc[6 * b + k];
		d[s->border[b]] = sum;
	}
	ndo_sync(s->level, d, sizeof(double));
}

int ndo_stencil_csr(const ndo_stencil *s, ndo_csr *K)
{
	ndo__clear_error();
	int32_t nv = (int32_t)ndo_vertex_count(s->level);
	int32_t *vid = malloc(s->count * sizeof *vid);
	rows r;
	if (!vid)
		return ndo__fail(NDO_ENOMEM, "out of memory for a sparse matrix");
	int rc = rows_init(&r, nv, 8);
	if (rc) {
		free(vid);
		return rc;
	}
	ndo_vertex_ids(s->level, vid, NULL);
	const size_t w = (size_t)s->w;
	for (int j = 1; j < s->n; j++)
		for (size_t p = (size_t)j * w + 1; p < (size_t)j * w + w - 1; p++) {
			const size_t nb[6] = {p + 1, p + w, p + w - 1, p - 1, p - w, p - w + 1};
			const double c[6] = {s->e[0][p], s->e[1][p], s->e[2][p], s->e[0][p - 1],
			                     s->e[1][p - w], s->e[2][p - w + 1]};
			for (int k = 0; k < 6; k++) {
				rows_add(&r, vid[p], vid[nb[k]], -c[k]);
				rows_add(&r, vid[p], vid[p], c[k]);
			}
		}
	for (size_t b = 0; b < s->nborder; b++) {
		int32_t p = s->border[b];
		for (int k = 0; k < 6; k++) {
			rows_add(&r, vid[p], vid[s->bnb[6 * b + k]], -s->bc[6 * b + k]);
			rows_add(&r, vid[p], vid[p], s->bc[6 * b + k]);
		}
	}
	rc = rows_compress(&r, K);
	rows_free(&r);
	free(vid);
	return rc;
}

int ndo_lumped_mass(int level, const double *x, double rho, double *m, double *area)
{
	ndo__clear_error();
	int rc = check_finite(level, x);
	if (rc)
		return rc;
	int n = 1 << level, w = 2 * n + 1;
	size_t count = (size_t)w * (size_t)(n + 1), ntri = ndo_triangle_count(level);
	int32_t *canon = canonical_map(level), *tri = malloc(3 * ntri * sizeof *tri);
	if (!canon || !tri) {
		free(canon), free(tri);
		return ndo__fail(NDO_ENOMEM, "out of memory for the mass matrix");
	}
	ndo_triangles(level, tri);
	memset(m, 0, count * sizeof *m);
	double total = 0;
	for (size_t t = 0; t < ntri && rc == NDO_OK; t++) {
		int32_t a = canon[tri[3 * t]], b = canon[tri[3 * t + 1]], c = canon[tri[3 * t + 2]];
		double wt[3];
		double ar = ndo_cotan_weights(x + 3 * (size_t)a, x + 3 * (size_t)b,
		                              x + 3 * (size_t)c, wt);
		if (ar == 0) {
			rc = degenerate(level, t);
			break;
		}
		total += ar;
		m[a] += rho * ar / 3;
		m[b] += rho * ar / 3;
		m[c] += rho * ar / 3;
	}
	ndo_sync(level, m, sizeof *m);
	if (area)
		*area = total;
	free(canon);
	free(tri);
	return rc;
}
