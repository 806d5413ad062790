/* implicit.c — backward Euler and the trapezoidal rule, solved with CHOLMOD
 * or with multigrid-preconditioned conjugate gradients (ndo/sim.h,
 * multigrid.h).
 *
 * With x' = v eliminated, each step is one symmetric positive definite
 * solve for the new velocities of the integrated nodes A:
 *   backward Euler  (M + hB + h²K_AA) v' = M v + h (f(t+h) − K u)
 *   trapezoid       (M + h/2 B + h²/4 K_AA) v'
 *                     = (M − h/2 B) v − h²/4 K_AA v + h/2 (f(t) + f(t+h)) − h K u
 * then u' = u + h v' (backward Euler) or u' = u + h/2 (v + v') (trapezoid).
 * K u is the full product, so the held nodes enter as boundary values; they
 * do not move during the step.  Penalty springs add α to K's diagonal.
 * The matrix depends on h, the active set and K: it is factored once
 * (symbolic analysis once per active set) and again only when one of them
 * changes — re-assembling K (restiffening) refactors.  The multigrid
 * solver likewise rebuilds its hierarchy only then, and starts each solve
 * from the explicit prediction v + h a.  Forces that follow
 * the surface (normal directions, pressure) are evaluated at t + h at the
 * predicted positions u + h v (their dependence on the positions is not
 * in the matrix), which keeps the trapezoid second order.
 */
#include "sim_private.h"
#include "multigrid.h"
#include "ndo/status.h"
#include "ndo/topology.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <suitesparse/cholmod.h>

const char *const ndo_solver_names[] = {"auto", "multigrid", "cholmod", NULL};

int ndo_solver_parse(const char *name, ndo_solver *sv)
{
	for (int k = 0; ndo_solver_names[k]; k++)
		if (strcmp(name, ndo_solver_names[k]) == 0) {
			*sv = (ndo_solver)k;
			return NDO_OK;
		}
	return ndo__fail(NDO_ENOTFOUND, "unknown solver '%s' (auto, multigrid, cholmod)", name);
}

ndo_solver ndo_solver_at(ndo_solver sv, int level)
{
	if (sv != NDO_SOLVER_AUTO)
		return sv;
	return level >= NDO_MULTIGRID_MIN_LEVEL ? NDO_SOLVER_MULTIGRID : NDO_SOLVER_CHOLMOD;
}

double ndo__implicit_mg_bytes(int level)
{
	size_t n = ndo_vertex_count(level);
	/* The hierarchy and its vectors, the solve's b and x (n × 3 each), the
	 * rows' mass, and the assembly: a triplet of 7 entries a row (two
	 * indices, a value) turned into the matrix. */
	return ndo__mg_bytes(n) + (double)n * (2 * 24 + 8 + 7 * 16);
}

/* The multigrid step's elementwise passes run over chunks of MG_ROWS rows
 * (mg_pass_chunk). */
#define MG_ROWS 4096

/* Steps the trapezoid takes the full product A v after finding v changed
 * since the last solve (peers' seams change it every step: the failed try
 * costs a right-hand side's pass). */
#define AV_SKIP 7

struct ndo__implicit {
	cholmod_common cm;
	cholmod_factor *L;
	/* Multigrid: the full matrix, its hierarchy, the rows' mass part of
	 * the diagonal, and the solve's right-hand sides and solutions (rows ×
	 * 3, row-major). */
	int mg_on;
	cholmod_sparse *A;
	ndo__mg *mg;
	double *mass, *b3, *x3;
	double *part;    /* the rigid correction's partial sums, 8 a chunk */
	/* The acceleration at the start of the last step (rows × 3), for the
	 * extrapolated first guess; valid for the step im->h when aprev_ok. */
	double *aprev;
	int aprev_ok;
	/* Trapezoid: A v at the next step's start from the last solve, A x =
	 * b − r plus the rigid shift times A's row sums (rsum), while v is
	 * still x + shift on every row (checked in the right-hand side's
	 * pass): valid when av_ok; av_skip steps left without trying after
	 * v was found changed. */
	double *rsum;
	const double *res;
	double shift[3];
	int av_ok, av_skip;
	int32_t *idx;    /* stored node → row of A, or −1 */
	int32_t *nodes;  /* row → canonical stored node */
	size_t na;
	double h;        /* the step the factor is for */
	int valid;       /* the factor matches h, K and the active set */
	int pattern_ok;  /* the symbolic analysis matches the active set */
};

/* The multigrid's hierarchy, matrix and row arrays (sized for the active
 * rows when they were built), released. */
static void mg_release(ndo__implicit *im)
{
	ndo__mg_free(im->mg);
	im->mg = NULL;
	cholmod_free_sparse(&im->A, &im->cm);
	free(im->mass), free(im->b3), free(im->x3), free(im->part), free(im->aprev);
	free(im->rsum);
	im->mass = im->b3 = im->x3 = im->part = im->aprev = im->rsum = NULL;
	im->aprev_ok = im->av_ok = 0;
}

void ndo__implicit_free(ndo_sim *s)
{
	ndo__implicit *im = s->imp;
	if (!im)
		return;
	if (im->L)
		cholmod_free_factor(&im->L, &im->cm);
	mg_release(im);
	cholmod_finish(&im->cm);
	free(im->idx);
	free(im->nodes);
	free(im);
	s->imp = NULL;
}

/* Keep rounding out of the rigid modes.  With every node integrated and
 * no penalty springs, the rows of the system sum to the momentum equation
 * without K (1ᵀK = 0, K symmetric): (1 + c h γ) P' = Σ rhs without its K
 * terms, c = 1 (backward Euler) or ½ (trapezoid), γ the same at every
 * node.  In floating point the K terms do not sum to zero: at σ = 1e12
 * their rounding, ~ε σ |u| per node, moved the centre of mass of a
 * trapezoid run 2.8 m in 500 steps of 1 s.  So the computed velocities
 * take the uniform shift that gives P' its exact value (per axis). */
static void rigid_exact(const ndo_sim *s, const ndo__implicit *im, double h, int trap,
                        const double *df, double *xv, size_t rs, size_t cs)
{
	const size_t cnt = s->count;
	double g = s->gam[im->nodes[0]], c = trap ? 0.5 : 1;
	for (int k = 0; k < 3; k++) {
		double want = 0, got = 0, msum = 0;
		for (size_t r = 0; r < im->na; r++) {
			size_t p = (size_t)im->nodes[r], q = (size_t)k * cnt + p;
			double m = s->mass[p], v = s->v[q];
			/* s->f holds f(t + h) when there are forces, df = f(t+h) − f(t) */
			double f1 = s->f ? s->f[q] : 0, f0 = df ? f1 - df[q] : f1;
			want += trap ? m * v - 0.5 * h * m * g * v + 0.5 * h * (f0 + f1) : m * v + h * f1;
			got += m * xv[(size_t)k * cs + r * rs];
			msum += m;
		}
		double shift = (want / (1 + c * h * g) - got) / msum;
		for (size_t r = 0; r < im->na; r++)
			xv[(size_t)k * cs + r * rs] += shift;
	}
}

ndo_solver ndo_sim_solver_info(const ndo_sim *s, int *levels, int *direct)
{
	int l = 0, d = 0;
	if (s->imp && s->imp->mg)
		l = ndo__mg_levels(s->imp->mg, &d);
	if (levels)
		*levels = l;
	if (direct)
		*direct = d;
	if (s->p.method != NDO_BACKWARD_EULER && s->p.method != NDO_TRAPEZOID)
		return NDO_SOLVER_AUTO;
	return ndo_solver_at(s->p.solver, s->level);
}

void ndo__implicit_invalidate(ndo_sim *s, int pattern)
{
	if (!s->imp)
		return;
	s->imp->valid = 0;
	if (pattern)
		s->imp->pattern_ok = 0;
}

static int index_rows(ndo_sim *s, ndo__implicit *im)
{
	free(im->idx);
	free(im->nodes);
	im->idx = malloc(s->count * sizeof *im->idx);
	im->nodes = malloc((s->count + 1) * sizeof *im->nodes);
	if (!im->idx || !im->nodes)
		return ndo__fail(NDO_ENOMEM, "out of memory for the implicit solver");
	im->na = 0;
	for (size_t p = 0; p < s->count; p++)
		im->idx[p] = -1;
	for (size_t k = 0; k < s->nespan; k++)
		for (int32_t p = s->espan[k].a; p < s->espan[k].b; p++) {
			im->idx[p] = (int32_t)im->na;
			im->nodes[im->na++] = p;
		}
	/* Duplicates share their vertex's row. */
	for (size_t p = 0; p < s->count; p++)
		im->idx[p] = im->idx[s->canon[p]];
	return NDO_OK;
}

/* The stencil's 6 neighbours and coefficients of canonical node p. */
void ndo__row_stencil(const ndo_sim *s, size_t p, int32_t nb[6], double cf[6])
{
	const size_t w = (size_t)s->w;
	int i = (int)(p % w), j = (int)(p / w);
	if (i >= 1 && i <= 2 * s->n - 1 && j >= 1 && j <= s->n - 1) {
		const size_t q[6] = {p + 1, p + w, p + w - 1, p - 1, p - w, p - w + 1};
		const double c[6] = {s->st.e[0][p], s->st.e[1][p], s->st.e[2][p],
		                     s->st.e[0][p - 1], s->st.e[1][p - w], s->st.e[2][p - w + 1]};
		for (int k = 0; k < 6; k++)
			nb[k] = (int32_t)q[k], cf[k] = c[k];
		return;
	}
	size_t lo = 0, hi = s->st.nborder;
	while (lo < hi) { /* border is ascending */
		size_t mid = (lo + hi) / 2;
		if ((size_t)s->st.border[mid] < p)
			lo = mid + 1;
		else
			hi = mid;
	}
	for (int k = 0; k < 6; k++)
		nb[k] = s->st.bnb[6 * lo + k], cf[k] = s->st.bc[6 * lo + k];
}

/* A = M + cb·B + ck·(K_AA + P) as a CHOLMOD matrix: the upper triangle
 * (stype 1), or with full set both triangles (stype 0). */
static cholmod_sparse *assemble(ndo_sim *s, ndo__implicit *im, double cb, double ck, int full)
{
	size_t nz = 7 * im->na + 1;
	cholmod_triplet *T = cholmod_allocate_triplet(im->na, im->na, nz, full ? 0 : 1,
	                                              CHOLMOD_REAL, &im->cm);
	if (!T)
		return NULL;
	int *Ti = T->i, *Tj = T->j;
	double *Tx = T->x;
	size_t n = 0;
	double *pen = calloc(s->count, sizeof *pen);
	if (!pen) {
		cholmod_free_triplet(&T, &im->cm);
		return NULL;
	}
	for (size_t k = 0; k < s->npen; k++)
		pen[s->pen[k]] = s->alpha;
	for (size_t r = 0; r < im->na; r++) {
		size_t p = (size_t)im->nodes[r];
		int32_t nb[6];
		double cf[6];
		ndo__row_stencil(s, p, nb, cf);
		double diag = s->mass[p] * (1 + cb * s->gam[p]) + ck * pen[p];
		for (int k = 0; k < 6; k++) {
			diag += ck * cf[k];
			int32_t c = im->idx[nb[k]];
			/* Each edge once, from its lower row (stype > 0 transposes
			 * nothing we leave out); at a corner both half-weight copies. */
			if (c > (int32_t)r || (full && c >= 0 && c != (int32_t)r)) {
				Ti[n] = (int)r, Tj[n] = c, Tx[n] = -ck * cf[k];
				n++;
			}
		}
		Ti[n] = (int)r, Tj[n] = (int)r, Tx[n] = diag;
		n++;
		if (im->mass)
			im->mass[r] = s->mass[p] * (1 + cb * s->gam[p]);
	}
	free(pen);
	T->nnz = n;
	cholmod_sparse *A = cholmod_triplet_to_sparse(T, n, &im->cm);
	cholmod_free_triplet(&T, &im->cm);
	return A;
}

/* The multigrid solver for step h: the full matrix and its hierarchy. */
static int mg_build(ndo_sim *s, ndo__implicit *im, double h)
{
	int rc;
	if (!im->pattern_ok) {
		if ((rc = index_rows(s, im)))
			return rc;
		free(im->mass), free(im->b3), free(im->x3), free(im->aprev), free(im->part);
		free(im->rsum);
		im->mass = malloc((im->na + 1) * sizeof *im->mass);
		im->rsum = malloc((im->na + 1) * sizeof *im->rsum);
		im->b3 = malloc((3 * im->na + 1) * sizeof *im->b3);
		im->x3 = malloc((3 * im->na + 1) * sizeof *im->x3);
		im->aprev = malloc((3 * im->na + 1) * sizeof *im->aprev);
		im->part = malloc(8 * (im->na / MG_ROWS + 1) * sizeof *im->part);
		if (!im->mass || !im->rsum || !im->b3 || !im->x3 || !im->aprev || !im->part)
			return ndo__fail(NDO_ENOMEM, "out of memory for the implicit solver");
		/* the multigrid's products read one double past the last row */
		im->b3[3 * im->na] = im->x3[3 * im->na] = 0;
		im->pattern_ok = 1;
	}
	ndo__mg_free(im->mg);
	im->mg = NULL;
	im->aprev_ok = 0;
	im->av_ok = 0;
	cholmod_free_sparse(&im->A, &im->cm);
	int trap = s->p.method == NDO_TRAPEZOID;
	im->A = assemble(s, im, trap ? h / 2 : h, trap ? h * h / 4 : h * h, 1);
	if (!im->A)
		return ndo__fail(NDO_ENOMEM, "out of memory assembling the implicit system");
	{
		const int *Ap = im->A->p;
		const double *Ax = im->A->x;
		for (size_t r = 0; r < im->na; r++) {
			double sum = 0;
			for (int k = Ap[r]; k < Ap[r + 1]; k++)
				sum += Ax[k];
			im->rsum[r] = sum;
		}
	}
	if ((rc = ndo__mg_create(s->level, im->nodes, im->na, im->A, im->mass, &im->cm, s->pool,
	                         &im->mg)))
		return rc;
	im->h = h;
	im->valid = 1;
	s->stats.factorizations++;
	return NDO_OK;
}

static int factor(ndo_sim *s, ndo__implicit *im, double h)
{
	int rc;
	if (im->mg_on)
		return mg_build(s, im, h);
	if (!im->pattern_ok) {
		if ((rc = index_rows(s, im)))
			return rc;
		if (im->L)
			cholmod_free_factor(&im->L, &im->cm);
	}
	int trap = s->p.method == NDO_TRAPEZOID;
	cholmod_sparse *A = assemble(s, im, trap ? h / 2 : h, trap ? h * h / 4 : h * h, 0);
	if (!A)
		return ndo__fail(NDO_ENOMEM, "out of memory assembling the implicit system");
	if (!im->pattern_ok) {
		im->L = cholmod_analyze(A, &im->cm);
		if (!im->L) {
			cholmod_free_sparse(&A, &im->cm);
			return ndo__fail(NDO_ENOMEM, "CHOLMOD could not analyze the system");
		}
		im->pattern_ok = 1;
	}
	/* The factor's size is known from the analysis: its nonzeros (a value
	 * and, at most, an index each) on top of the simulation's arrays. */
	if (s->p.max_memory) {
		double need = (double)s->bytes + 12.0 * im->cm.lnz;
		if (need > (double)s->p.max_memory) {
			char a[16], b[16];
			cholmod_free_sparse(&A, &im->cm);
			return ndo__fail(NDO_ENOMEM, "level %d with %s needs about %s (%.3g million "
			                 "nonzeros in CHOLMOD's factor); the limit is %s", s->level,
			                 trap ? "trapezoid" : "backward-euler", ndo_bytes_text(need, a, sizeof a),
			                 im->cm.lnz / 1e6,
			                 ndo_bytes_text((double)s->p.max_memory, b, sizeof b));
		}
	}
	int ok = cholmod_factorize(A, im->L, &im->cm);
	cholmod_free_sparse(&A, &im->cm);
	if (!ok || im->cm.status == CHOLMOD_NOT_POSDEF)
		return ndo__fail(NDO_EDIVERGED, "the implicit system is not positive definite "
		                 "(CHOLMOD status %d)", im->cm.status);
	if (im->cm.status < CHOLMOD_OK)
		return ndo__fail(NDO_ENOMEM, "CHOLMOD failed (status %d)", im->cm.status);
	im->h = h;
	im->valid = 1;
	s->stats.factorizations++;
	return NDO_OK;
}

/* The step with CHOLMOD's factor: the right-hand side column by column. */
static int cholmod_step(ndo_sim *s, ndo__implicit *im, double h, const double *a,
                        const double *df)
{
	const size_t cnt = s->count;
	const int trap = s->p.method == NDO_TRAPEZOID;
	/* Trapezoid: K_AA v_A (held velocities do not enter: held positions
	 * stay put during the step). */
	double *kv = s->tmp;
	if (trap) {
		double *vm = s->us;
		for (size_t q = 0; q < 3 * cnt; q++)
			vm[q] = s->active[q % cnt] ? s->v[q] : 0;
		for (int c = 0; c < 3; c++)
			ndo_stencil_apply(&s->st, vm + (size_t)c * cnt, kv + (size_t)c * cnt);
		for (size_t k = 0; k < s->npen; k++)
			for (int c = 0; c < 3; c++) {
				size_t q = (size_t)c * cnt + (size_t)s->pen[k];
				kv[q] += s->alpha * vm[q];
			}
	}
	cholmod_dense *B = cholmod_allocate_dense(im->na, 3, im->na, CHOLMOD_REAL, &im->cm);
	if (!B)
		return ndo__fail(NDO_ENOMEM, "out of memory for the implicit solver");
	double *bx = B->x;
	for (size_t r = 0; r < im->na; r++) {
		size_t p = (size_t)im->nodes[r];
		double m = s->mass[p], g = s->gam[p];
		for (int c = 0; c < 3; c++) {
			size_t q = (size_t)c * cnt + p;
			/* M(a + γv) = f(t) − K u − P(u − ū). */
			double rhs = m * s->v[q] + h * m * (a[q] + g * s->v[q]);
			if (trap)
				rhs += -0.5 * h * m * g * s->v[q] - 0.25 * h * h * kv[q] +
				       (df ? 0.5 * h * df[q] : 0);
			else if (df)
				rhs += h * df[q];
			bx[(size_t)c * im->na + r] = rhs;
		}
	}
	cholmod_dense *X = cholmod_solve(CHOLMOD_A, im->L, B, &im->cm);
	cholmod_free_dense(&B, &im->cm);
	if (!X)
		return ndo__fail(NDO_ENOMEM, "CHOLMOD could not solve (status %d)", im->cm.status);
	double *xv = X->x;
	if (!s->any_held && s->npen == 0)
		rigid_exact(s, im, h, trap, df, xv, 1, im->na);
	for (size_t r = 0; r < im->na; r++) {
		size_t p = (size_t)im->nodes[r];
		for (int c = 0; c < 3; c++) {
			size_t q = (size_t)c * cnt + p;
			double vn = xv[(size_t)c * im->na + r];
			s->u[q] += trap ? 0.5 * h * (s->v[q] + vn) : h * vn;
			s->v[q] = vn;
		}
	}
	cholmod_free_dense(&X, &im->cm);
	return NDO_OK;
}

/* The multigrid step's elementwise passes over the rows, in chunks of
 * MG_ROWS on the simulation's threads (each row on its own: any thread
 * count gives the same bits). */
typedef struct mg_pass {
	ndo_sim *s;
	ndo__implicit *im;
	double h, c0, c1;
	const double *a, *df, *av;
	double shift[3]; /* the rigid correction, added in the update */
	int phase; /* 0: v to rows; 1: the right-hand side and first guess; 2: the update;
	              3: the rigid correction's sums */
	int trap, ext;
	int cached; /* phase 1, trapezoid: A v from the last solve (im->res, b3, x3),
	               and part[8k + 7] = 1 where v is not x3 + shift */
} mg_pass;

static void mg_pass_chunk(void *ctx, int k)
{
	const mg_pass *P = ctx;
	ndo_sim *s = P->s;
	ndo__implicit *im = P->im;
	const size_t cnt = s->count, a0 = (size_t)k * MG_ROWS;
	const size_t e = a0 + MG_ROWS < im->na ? a0 + MG_ROWS : im->na;
	const double h = P->h;
	if (P->phase == 3) {
		/* rigid_exact's sums over this chunk's rows (with f(t+h) in s->f
		 * and df = f(t+h) − f(t)) */
		const double g = s->gam[im->nodes[0]];
		double w[3] = {0, 0, 0}, got[3] = {0, 0, 0}, msum = 0;
		for (size_t r = a0; r < e; r++) {
			size_t p = (size_t)im->nodes[r];
			double m = s->mass[p];
			for (int c = 0; c < 3; c++) {
				size_t q = (size_t)c * cnt + p;
				double v = s->v[q], f1 = s->f ? s->f[q] : 0, f0 = P->df ? f1 - P->df[q] : f1;
				w[c] += P->trap ? m * v - 0.5 * h * m * g * v + 0.5 * h * (f0 + f1) : m * v + h * f1;
				got[c] += m * im->x3[3 * r + (size_t)c];
			}
			msum += m;
		}
		double *o = im->part + 8 * (size_t)k;
		for (int c = 0; c < 3; c++)
			o[c] = w[c], o[3 + c] = got[c];
		o[6] = msum;
		return;
	}
	/* One loop a phase, the step's constants in locals (the stores below
	 * may not change them, which the compiler could not know). */
	const int32_t *nodes = im->nodes;
	const double *v = s->v;
	double *x3 = im->x3;
	if (P->phase == 0) {
		for (size_t r = a0; r < e; r++) {
			const size_t p = (size_t)nodes[r];
			for (int c = 0; c < 3; c++)
				x3[3 * r + (size_t)c] = v[(size_t)c * cnt + p];
		}
	} else if (P->phase == 1) {
		/* M(a + γv) = f(t) − K u − P(u − ū).  Trapezoid: with
		 * A v = M(1 + h/2 γ) v + h²/4 (K_AA + P) v the right-hand
		 * side M v + h M(a + γv) − h/2 M γ v − h²/4 (K_AA + P) v
		 * + h/2 Δf is 2 M v + h M (a + γ v) − A v + h/2 Δf (its
		 * rounding, ε |M v|, is far below the tolerance). */
		const double *an = P->a, *df = P->df, *av = P->av, c0 = P->c0, c1 = P->c1;
		const int trap = P->trap, ext = P->ext;
		double *b3 = im->b3, *aprev = im->aprev;
		/* cached: A v = A x + shift A 1 = b − r + shift rsum, the last
		 * solve's b and x read before this step's are written; where some
		 * row's v is not x + shift (changed from outside), the chunk says
		 * so and the step starts over. */
		const int cached = P->cached;
		const double *res = im->res, *rsum = im->rsum;
		const double sh[3] = {im->shift[0], im->shift[1], im->shift[2]};
		int miss = 0;
		for (size_t r = a0; r < e; r++) {
			const size_t p = (size_t)nodes[r];
			const double m = s->mass[p], g = s->gam[p];
			for (int c = 0; c < 3; c++) {
				const size_t q = (size_t)c * cnt + p, j = 3 * r + (size_t)c;
				const double vq = v[q], aq = an[q];
				double avj = 0;
				if (cached) {
					miss |= vq != x3[j] + sh[c];
					avj = b3[j] - res[j] + sh[c] * rsum[r];
				} else if (trap) {
					avj = av[j];
				}
				b3[j] = trap ? 2 * m * vq + h * m * (aq + g * vq) - avj +
				                   (df ? 0.5 * h * df[q] : 0)
				             : m * vq + h * m * (aq + g * vq) + (df ? h * df[q] : 0);
				x3[j] = vq + c0 * aq + (ext ? c1 * aprev[j] : 0);
				aprev[j] = aq;
			}
		}
		if (cached)
			im->part[8 * (size_t)k + 7] = miss;
	} else {
		const int trap = P->trap;
		const double sh[3] = {P->shift[0], P->shift[1], P->shift[2]};
		double *u = s->u, *vw = s->v;
		for (size_t r = a0; r < e; r++) {
			const size_t p = (size_t)nodes[r];
			for (int c = 0; c < 3; c++) {
				const size_t q = (size_t)c * cnt + p;
				const double vn = x3[3 * r + (size_t)c] + sh[c];
				u[q] += trap ? 0.5 * h * (vw[q] + vn) : h * vn;
				vw[q] = vn;
			}
		}
	}
}

static void mg_pass_run(mg_pass *P, int phase)
{
	P->phase = phase;
	ndo__sim_run(P->s, (int)((P->im->na + MG_ROWS - 1) / MG_ROWS), mg_pass_chunk, P);
}

/* The step with the multigrid solver: the right-hand side row by row. */
static int mg_step(ndo_sim *s, ndo__implicit *im, double h, const double *a, const double *df)
{
	const int trap = s->p.method == NDO_TRAPEZOID;
	/* The first guess, where the step is near the explicit limit (the
	 * hierarchy is Jacobi alone): the new velocity with the acceleration
	 * over the step extrapolated linearly from the last step's start and
	 * this one's, a(t+h) ≈ 2a(t) − a(t−h) — backward Euler
	 * v' = v + h a(t+h), trapezoid v' = v + h/2 (a(t) + a(t+h)) — or
	 * v + h a(t) after a change.  Measured at level 8 on the thesis scene,
	 * backward Euler: 7.2 iterations per solve from v + h a(t), 6.4 from
	 * the extrapolation.  Far beyond the limit the guess is v: there the
	 * prediction is huge, and CG's rounding floor, ε ‖A‖ times the largest
	 * iterate, rose above the tolerance (stalled at 4e-10 with
	 * h = 4000 × RK4's limit). */
	int direct;
	const int near = ndo__mg_levels(im->mg, &direct) == 1 && !direct, ext = near && im->aprev_ok;
	/* The solver's loops run where the step's passes run: alone when the
	 * look at whether the threads pay found they do not (integrate.c,
	 * threads_pick), or the look would time the solver, two thirds of the
	 * step, on the threads both ways. */
	ndo__mg_set_pool(im->mg, s->solo ? NULL : s->pool);
	mg_pass P = {.s = s, .im = im, .h = h, .a = a, .df = df, .trap = trap, .ext = ext,
	             .c0 = !near ? 0 : !ext ? h : trap ? 1.5 * h : 2 * h,
	             .c1 = !ext ? 0 : trap ? -0.5 * h : -h};
	const int nch = (int)((im->na + MG_ROWS - 1) / MG_ROWS);
	/* Trapezoid: A v, the held velocities left out (held positions stay
	 * put): from the last solve where v has not changed since (the
	 * fallback's guess, with aprev already a(t), is v + h a(t) as after a
	 * change), or the full product. */
	P.cached = trap && im->av_ok && im->av_skip == 0;
	if (trap && im->av_skip > 0)
		im->av_skip--;
	im->av_ok = 0;
	if (P.cached) {
		mg_pass_run(&P, 1);
		int miss = 0;
		for (int k = 0; k < nch; k++)
			miss |= im->part[8 * (size_t)k + 7] != 0;
		if (miss) {
			P.cached = 0;
			im->av_skip = AV_SKIP;
			s->stats.av_misses++;
		}
	}
	if (!P.cached) {
		if (trap) {
			mg_pass_run(&P, 0);
			ndo__mg_apply(im->mg, im->x3, im->b3);
			P.av = im->b3;
		}
		/* av (in b3) is read before b3 is written, element by element. */
		mg_pass_run(&P, 1);
	} else {
		s->stats.av_reused++;
	}
	im->aprev_ok = 1;
	int iters, rc;
	double res;
	if ((rc = ndo__mg_solve(im->mg, im->b3, im->x3, NDO_SOLVER_TOL, NDO_SOLVER_TOL_STALL, 500,
	                        &iters, &res)))
		return rc;
	s->stats.iterations += iters;
	s->stats.last_iterations = iters;
	s->stats.last_residual = res;
	if (!s->any_held && s->npen == 0) {
		/* rigid_exact's shift, its sums over chunks of rows on the
		 * threads (added in chunk order: the same bits on any count) */
		mg_pass_run(&P, 3);
		double sum[7] = {0, 0, 0, 0, 0, 0, 0};
		for (int k = 0; k < nch; k++)
			for (int c = 0; c < 7; c++)
				sum[c] += im->part[8 * (size_t)k + (size_t)c];
		double g = s->gam[im->nodes[0]], cg = trap ? 0.5 : 1;
		for (int c = 0; c < 3; c++)
			P.shift[c] = (sum[c] / (1 + cg * h * g) - sum[3 + c]) / sum[6];
	}
	mg_pass_run(&P, 2);
	if (trap && (im->res = ndo__mg_residual(im->mg))) {
		memcpy(im->shift, P.shift, sizeof im->shift);
		im->av_ok = 1;
	}
	return NDO_OK;
}

/* The solver, created on first use (multigrid or CHOLMOD as the solver
 * setting says at this level; CHOLMOD with `direct`), with its factor or
 * hierarchy for step h. */
static int ready(ndo_sim *s, double h, int direct)
{
	ndo__implicit *im = s->imp;
	if (!im) {
		im = s->imp = calloc(1, sizeof *im);
		if (!im)
			return ndo__fail(NDO_ENOMEM, "out of memory for the implicit solver");
		cholmod_start(&im->cm);
		im->cm.print = 0; /* errors come back as status codes */
		im->mg_on = ndo_solver_at(s->p.solver, s->level) == NDO_SOLVER_MULTIGRID;
	}
	if (direct && im->mg_on) { /* a region's block solve needs the factor */
		/* CHOLMOD's rows and analysis, not the multigrid's: a peer whose
		 * timed-out step, taken alone (ndo_sim_step), built the hierarchy
		 * wrote a larger next region's rows past its arrays */
		mg_release(im);
		im->mg_on = 0;
		im->valid = 0;
		im->pattern_ok = 0;
	}
	int rc;
	if ((!im->valid || im->h != h) && (rc = factor(s, im, h)))
		return rc;
	return NDO_OK;
}

static int sim_implicit_precondition(ndo_sim *s, double h, const double *r, double *z)
{
	ndo__clear_error();
	if (s->p.method != NDO_BACKWARD_EULER && s->p.method != NDO_TRAPEZOID)
		return ndo__fail(NDO_EINVAL, "ndo_sim_implicit_precondition: the method is not "
		                 "implicit"); /* (integrate.c has the names: it calls this file) */
	int rc = ready(s, h, 1);
	if (rc)
		return rc;
	ndo__implicit *im = s->imp;
	const size_t cnt = s->count;
	cholmod_dense *B = cholmod_allocate_dense(im->na, 3, im->na, CHOLMOD_REAL, &im->cm);
	if (!B)
		return ndo__fail(NDO_ENOMEM, "out of memory for the implicit solver");
	double *bx = B->x;
	for (size_t r0 = 0; r0 < im->na; r0++)
		for (int c = 0; c < 3; c++)
			bx[(size_t)c * im->na + r0] = r[(size_t)c * cnt + (size_t)im->nodes[r0]];
	cholmod_dense *X = cholmod_solve(CHOLMOD_A, im->L, B, &im->cm);
	cholmod_free_dense(&B, &im->cm);
	if (!X)
		return ndo__fail(NDO_ENOMEM, "CHOLMOD could not solve (status %d)", im->cm.status);
	const double *xv = X->x;
	for (size_t r0 = 0; r0 < im->na; r0++)
		for (int c = 0; c < 3; c++)
			z[(size_t)c * cnt + (size_t)im->nodes[r0]] = xv[(size_t)c * im->na + r0];
	cholmod_free_dense(&X, &im->cm);
	return NDO_OK;
}

int ndo_sim_implicit_precondition(ndo_sim *s, double h, const double *r, double *z)
{
	const unsigned fp = ndo_fp_flush();
	int rc = sim_implicit_precondition(s, h, r, z);
	ndo_fp_set(fp);
	return rc;
}

/* The force difference's elementwise passes, in chunks of PREP_ELEMS
 * values on the simulation's threads: phase 0 keeps f(t) in s->vs and puts
 * the predicted positions u + h v in s->us, phase 1 leaves f(t+h) − f(t)
 * in s->vs. */
#define PREP_ELEMS 16384
typedef struct prep_pass {
	ndo_sim *s;
	double h;
	int phase;
} prep_pass;

static void prep_chunk(void *ctx, int k)
{
	const prep_pass *P = ctx;
	ndo_sim *s = P->s;
	const size_t n = 3 * s->count, a = (size_t)k * PREP_ELEMS;
	const size_t e = a + PREP_ELEMS < n ? a + PREP_ELEMS : n;
	const double h = P->h, *f = s->f, *u = s->u, *v = s->v;
	double *df = s->vs, *up = s->us;
	if (P->phase == 0)
		for (size_t q = a; q < e; q++) {
			df[q] = f[q];
			up[q] = u[q] + h * v[q];
		}
	else
		for (size_t q = a; q < e; q++)
			df[q] = f[q] - df[q];
}

/* The input power of the implicit step under way at velocities V:
 * f_s·V + the held nodes' power (their u stays put through the step), f_s
 * the external force the step integrates with — backward Euler f(t+h),
 * the trapezoid f̄ = ½ (f(t) + f(t+h)) = f(t+h) − ½ df — at the force
 * nodes in the order ndo__stage_power takes them.  With f and df as
 * ndo__implicit_prepare leaves them (s->f holds the springs' force at
 * t + h too, −pen_f1: taken back out; df at a pin is the external
 * forces' change alone, the springs' taken out there). */
static void step_term(double *pw, const double *f, const double *df, const double *V,
                      size_t p, size_t cnt)
{
	for (int c = 0; c < 3; c++) {
		const size_t q = (size_t)c * cnt + p;
		*pw += (df ? f[q] - 0.5 * df[q] : f[q]) * V[q];
	}
}

static double step_power(const ndo_sim *s, const double *V)
{
	const size_t cnt = s->count;
	const double *f = s->f;
	const double *df = f && s->p.method == NDO_TRAPEZOID ? s->vs : NULL;
	double pw = 0;
	if (f && s->has_pressure)
		for (size_t k = 0; k < s->nespan; k++)
			for (size_t p = (size_t)s->espan[k].a; p < (size_t)s->espan[k].b; p++)
				step_term(&pw, f, df, V, p, cnt);
	else if (f)
		for (size_t k = 0; k < s->nfnodes; k++)
			if (s->active[s->fnodes[k]])
				step_term(&pw, f, df, V, (size_t)s->fnodes[k], cnt);
	for (size_t k = 0; f && k < s->npen; k++) {
		const size_t p = (size_t)s->pen[k];
		if (s->active[p] && s->pen_forced[k])
			for (int c = 0; c < 3; c++)
				pw += s->pen_f1[3 * k + (size_t)c] * V[(size_t)c * cnt + p];
	}
	return pw + ndo__held_power(s, s->u, V, NULL);
}

/* The implicit step of size h is done (s->v its new velocities): its
 * input work, exactly the forces' term of its energy change for the
 * linear membrane (E = ½ vᵀMv + ½ uᵀKu, K with the springs' α, B = γM):
 *   backward Euler  E' − E = h f(t+h)·v' − h v'ᵀBv' − ½ (|Δv|²_M + |Δu|²_K)
 *   trapezoid       E' − E = h f̄·v̄ − h v̄ᵀBv̄,  v̄ = ½ (v + v')
 * (the trapezoid keeps E but for these; backward Euler loses the last
 * term besides).  The power at the steps' ends by the trapezoidal rule,
 * counted until 2026-11-30, is the trapezoid's ½ h (f·v + f'·v'), off by
 * ¼ h Δf·Δv. */
void ndo__implicit_account(ndo_sim *s, double h)
{
	const double P1 = step_power(s, s->v);
	s->pend_h = h;
	s->pend_power = s->p.method == NDO_TRAPEZOID ? 0.5 * (s->imp_power0 + P1) : P1;
}

int ndo__implicit_prepare(ndo_sim *s, double h, double **accel, double **dforce)
{
	const size_t cnt = s->count;
	/* a = M⁻¹(f(t) − K u) − γ v (f holds the penalty springs), with the
	 * divergence test. */
	ndo__diag d;
	double *a = s->ka[0];
	ndo__accel(s, s->t, s->u, s->v, a, &d);
	s->last_power = d.power;
	int rc = ndo__diverged(s, &d, 1);
	if (rc)
		return rc;
	/* f(t+h) − f(t), at the positions the step starts from. */
	double *df = NULL;
	if (s->f) {
		/* f(t+h) at the predicted positions u + h v, so that forces that
		 * follow the surface keep the trapezoid second order. */
		df = s->vs;
		prep_pass P = {s, h, 0};
		const int nch = (int)((3 * cnt + PREP_ELEMS - 1) / PREP_ELEMS);
		ndo__sim_run(s, nch, prep_chunk, &P);
		ndo__forces_prepare(s, s->t + h, s->us);
		P.phase = 1;
		ndo__sim_run(s, nch, prep_chunk, &P);
		/* The penalty springs are in the matrix already: take their
		 * change, −α h v, back out. */
		for (size_t k = 0; k < s->npen; k++)
			for (int c = 0; c < 3; c++) {
				size_t q = (size_t)c * cnt + (size_t)s->pen[k];
				df[q] += s->alpha * h * s->v[q];
				/* the spring's force at t + h in f, for step_power */
				s->pen_f1[3 * k + (size_t)c] = s->alpha * (s->us[q] - s->pen_target[3 * k + c]);
			}
	}
	if (s->p.method == NDO_TRAPEZOID)
		s->imp_power0 = step_power(s, s->v);
	*accel = a;
	*dforce = df;
	return NDO_OK;
}

int ndo__implicit_step(ndo_sim *s, double h)
{
	int rc = ready(s, h, 0);
	if (rc)
		return rc;
	ndo__implicit *im = s->imp;
	double *a, *df;
	if ((rc = ndo__implicit_prepare(s, h, &a, &df)))
		return rc;
	if (im->mg_on)
		rc = mg_step(s, im, h, a, df);
	else
		rc = cholmod_step(s, im, h, a, df);
	if (rc)
		return rc;
	s->stats.solves++;
	ndo__sync_planes(s, s->u, 3);
	ndo__sync_planes(s, s->v, 3);
	ndo__implicit_account(s, h);
	s->stats.substeps++;
	return NDO_OK;
}
