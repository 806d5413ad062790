/* ndo/membrane.h — the uniform-tension membrane's stiffness K and lumped
 * mass M on the regular grid (thesis §4.3, eq. 4.8–4.12, appendix B;
 * DESIGN.md, "Physics").
 *
 * K = σ·L, where L is the cotangent stiffness of the piecewise-linear
 * membrane energy ½ σ ∫ |∇u|² dA: each triangle contributes the element
 * matrix of thesis eq. 4.12 whose three edge coefficients are
 * k_e = ½ cot(angle opposite edge e), so that for an edge ij shared by two
 * triangles L_ij = −½ (cot α_ij + cot β_ij) and L_ii = −Σ_j L_ij.  K acts
 * on each coordinate of the displacement u = x − X separately; the force on
 * the membrane is −K u.  The weights are dimensionless (scale invariant), so
 * K has the units of σ: N/m.  M is lumped: node i carries ρ × one third of
 * the area of its incident triangles (kg, with ρ in kg/m²).
 *
 * Two forms of K, kept independent on purpose:
 *   - ndo_csr: a sparse matrix over the distinct vertices (ndo_vertex_ids
 *     numbering), assembled triangle by triangle — slow, obviously
 *     correct: the reference.
 *   - ndo_stencil: the form the integrators use.  The grid is regular, so
 *     K applies as a 7-point stencil with per-node coefficients over the
 *     stored nodes, neighbours taken through the ghost map.
 * tests/unit/test_membrane.c holds the one to the other.
 *
 * Arrays of positions are H × W × 3 doubles (the grid's "position" channel
 * layout, AoS); scalar fields on the stencil are H × W doubles ("planes",
 * node (i, j) at j·W + i).
 */
#ifndef NDO_MEMBRANE_H
#define NDO_MEMBRANE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The three edge coefficients of one triangle a, b, c (thesis eq. 4.12):
 * w[0] = ½ cot(angle at a) belongs to edge bc, w[1] = ½ cot(angle at b) to
 * edge ca, w[2] = ½ cot(angle at c) to edge ab.  Returns the triangle's
 * area (0 for a degenerate triangle, whose weights are then set to 0). */
double ndo_cotan_weights(const double a[3], const double b[3], const double c[3],
                         double w[3]);

/* A square sparse matrix in compressed rows, full (both triangles stored),
 * columns ascending within a row.  Owned arrays; free with ndo_csr_free. */
typedef struct ndo_csr {
	int32_t n;    /* rows = columns */
	int64_t *ptr; /* n + 1 row starts */
	int32_t *col; /* ptr[n] column indices */
	double *val;  /* ptr[n] values */
} ndo_csr;

/* K = σ·L over the distinct vertices of a level-`level` grid with stored
 * positions x (H × W × 3), assembled from the 4^(n+1) triangles.
 * NDO_ERANGE (naming the triangle) if a triangle is degenerate or a
 * position is not finite. */
int ndo_membrane_csr(int level, const double *x, double sigma, ndo_csr *K);

void ndo_csr_free(ndo_csr *K);

/* out = K·in for `comps` interleaved components per vertex (in, out: n ×
 * comps doubles, not aliased). */
void ndo_csr_apply(const ndo_csr *K, const double *in, double *out, int comps);

/* The stencil form of K.  For a stored node p and lattice direction k
 * (ndo_dirs order), nb_k(p) is the stored node the ghost map gives for
 * p + dir_k, and
 *     (K u)_p = Σ_k c_k(p) (u_p − u_nb_k(p)).
 * Interior nodes (1 ≤ i ≤ 2N−1, 1 ≤ j ≤ N−1) read their six coefficients
 * from three planes of edge weights, e[k][p] = σ·w(p, p + dir_k) for
 * k = 0, 1, 2, and e[0][p−1], e[1][p−W], e[2][p−W+1] for the opposite
 * directions, so the interior operator is exactly symmetric and needs no
 * ghost lookups.  The canonical nodes on the rectangle's border (rows 0 and
 * N, column 0) carry a table of six neighbours and coefficients; at the four
 * valence-3 corners each neighbour appears twice in the table and each copy
 * has half the edge's weight (the thesis' "duplicated edges").  Stored
 * duplicates have no stencil of their own: their K u is their canonical
 * node's (see ndo_stencil_apply). */
typedef struct ndo_stencil {
	int level, n, w, h;
	size_t count;      /* W·H stored nodes */
	double *e[3];      /* count each: σ × full edge weight towards dir k */
	size_t nborder;    /* canonical border nodes */
	int32_t *border;   /* nborder stored indices, ascending */
	int32_t *bnb;      /* 6·nborder neighbour stored indices */
	double *bc;        /* 6·nborder coefficients c_k */
} ndo_stencil;

/* Build (or rebuild in place, reusing the arrays: pass a stencil that is
 * zeroed or was built before at the same level) the stencil of K = σ·L from
 * positions x (H × W × 3).  Edge weights come from the two lattice
 * triangles on either side of each edge, through the ghost map.
 * NDO_ERANGE if a triangle is degenerate or a position not finite. */
int ndo_stencil_build(int level, const double *x, double sigma, ndo_stencil *s);

void ndo_stencil_free(ndo_stencil *s);

/* ku = K u for one scalar plane u (H × W), on every stored node
 * (duplicates get their canonical node's value).  ku must not alias u. */
void ndo_stencil_apply(const ndo_stencil *s, const double *u, double *ku);

/* The diagonal of K (H × W): Σ_k c_k(p). */
void ndo_stencil_diagonal(const ndo_stencil *s, double *d);

/* The stencil written out as a sparse matrix over the distinct vertices
 * (for the reference comparison and the implicit solvers): row vid(p) gets
 * −c_k(p) at column vid(nb_k(p)) and Σ c_k on the diagonal. */
int ndo_stencil_csr(const ndo_stencil *s, ndo_csr *K);

/* Lumped mass per stored node (m: H × W doubles, kg): ρ × one third of
 * the area of the incident triangles, at positions x (H × W × 3).
 * Duplicates carry their vertex's mass.  *area (may be NULL) receives the
 * total area in m².  NDO_ERANGE (naming the triangle) for a degenerate
 * triangle or a position that is not finite. */
int ndo_lumped_mass(int level, const double *x, double rho, double *m, double *area);

#ifdef __cplusplus
}
#endif
#endif
