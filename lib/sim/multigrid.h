/* multigrid.h — conjugate gradients preconditioned by a geometric multigrid
 * V-cycle on the grid's own level hierarchy, for the implicit methods'
 * symmetric positive definite systems (multigrid.c; used by implicit.c,
 * not installed).
 *
 * The hierarchy: level n−1 is every other node of level n (ndo/restrict.h),
 * so a coarse node (i, j) is fine node (2i, 2j) and every other fine node
 * is the midpoint of a coarse lattice edge (horizontal, vertical or the
 * cells' diagonal (+1, −1)).  Prolongation P is linear interpolation along
 * those edges (the coarse hat functions written in the fine ones);
 * restriction is Pᵀ; the coarse operators are Galerkin's Pᵀ A P (7-point
 * stencils again: two coarse hats that are not lattice neighbours share no
 * fine edge).  A coarse node is a degree of freedom when its fine node is;
 * held fine nodes take no correction.  Smoothing: Chebyshev polynomials in
 * D⁻¹A (D the diagonal), the same before and after, so the V-cycle is a
 * symmetric preconditioner.  CHOLMOD factors the coarsest level (level 4,
 * at most 600 rows).  Where the mass dominates the stiffness on every row
 * of the finest level (the usual case for steps near the explicit limit)
 * there is no hierarchy: Jacobi alone preconditions (multigrid.c, THETA).
 *
 * Every loop runs over fixed chunks of rows and adds its partial sums in
 * chunk order: the same bits on any number of threads. */
#ifndef NDO_SIM_MULTIGRID_H
#define NDO_SIM_MULTIGRID_H

#include "ndo/pool.h"

#include <stddef.h>
#include <stdint.h>

#include <suitesparse/cholmod.h>

typedef struct ndo__mg ndo__mg;

/* Build the hierarchy of A: n × n, symmetric with both triangles stored
 * (stype 0), sorted, packed, CHOLMOD_INT; the caller keeps A and must keep
 * it (and nodes) alive while the hierarchy is used.  Row r is the canonical
 * stored node nodes[r] of a level-`level` grid (ascending).  mass: n
 * doubles, the mass part of A's diagonal (the rest is stiffness); where the
 * stiffness part is at most THETA × the mass part on every row, there is
 * no hierarchy (multigrid.c).  cm: the caller's CHOLMOD
 * workspace; pool: the threads (NULL: one).  NDO_ENOMEM, or NDO_EDIVERGED
 * when the operator is not positive definite. */
int ndo__mg_create(int level, const int32_t *nodes, size_t n, cholmod_sparse *A,
                   const double *mass, cholmod_common *cm, ndo_pool *pool, ndo__mg **out);
void ndo__mg_free(ndo__mg *mg);

/* Solve A X = B for three right-hand sides at once.  b, x: n × 3 doubles,
 * row-major (row r's three components together; x has one double more,
 * x[3n], read and not used); x holds the initial guess
 * and receives the solution.  Each column stops when its residual
 * ‖b − A x‖₂ is at most tol·‖b‖₂, or within 16·ε·‖|A||x|‖₂ (the rounding
 * floor of the product itself, which a very stiff system reaches first).
 * Where the true residual is above that, the iteration starts again from
 * it; one that stalls (the true residual no better than half its best over
 * two such restarts, or max_iter iterations) ends if its relative residual
 * is at most `stall` (≥ tol).  *iters: the iterations of the slowest
 * column; *relres: its final relative residual.  NDO_EDIVERGED when it
 * stalls above `stall`. */
int ndo__mg_solve(ndo__mg *mg, const double *b, double *x, double tol, double stall, int max_iter,
                  int *iters, double *relres);

/* The threads the next loops run on (NULL: the caller alone), until the
 * next call; the pool given to ndo__mg_create until the first.  The same
 * bits either way. */
void ndo__mg_set_pool(ndo__mg *mg, ndo_pool *pool);

/* y = A x on the finest level (n × 3 each, row-major; not aliased; x has
 * one double more, x[3n], read and not used). */
void ndo__mg_apply(ndo__mg *mg, const double *x, double *y);

/* The last solve's residual b − A x (n × 3, row-major), computed from the
 * x it returned, or NULL when it ended on the iteration's updated residual
 * (a stall at max_iter).  Valid until the next solve or ndo__mg_free. */
const double *ndo__mg_residual(const ndo__mg *mg);

/* The levels of the hierarchy (1: smoothing alone) and whether the
 * coarsest is factored. */
int ndo__mg_levels(const ndo__mg *mg, int *direct);

/* About the bytes the hierarchy of a system of n rows takes, with its
 * solve's vectors and the largest transient of its setup. */
double ndo__mg_bytes(size_t n);

#endif
