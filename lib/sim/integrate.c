/* integrate.c — the simulation object and the explicit integrators
 * (ndo/sim.h), and ndo_sim_step(), which dispatches to them or to the
 * implicit ones (implicit.c).  Both families evaluate the membrane's
 * acceleration and test divergence through accel.c; the critical step is
 * in stability.c, the forces in forces.c. */
#include "sim_private.h"
#include "ndo/status.h"
#include "ndo/topology.h"

#include <math.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

const char *const ndo_method_names[] = {"euler", "symplectic-euler", "midpoint", "rk4",
                                        "rkf45", "backward-euler", "trapezoid", NULL};

int ndo_method_parse(const char *name, ndo_method *m)
{
	for (int k = 0; ndo_method_names[k]; k++)
		if (strcmp(name, ndo_method_names[k]) == 0) {
			*m = (ndo_method)k;
			return NDO_OK;
		}
	return ndo__fail(NDO_ENOTFOUND, "unknown integrator '%s' (euler, symplectic-euler, "
	                 "midpoint, rk4, rkf45, backward-euler, trapezoid)", name);
}

int ndo_method_is_implicit(ndo_method m)
{
	return m == NDO_BACKWARD_EULER || m == NDO_TRAPEZOID;
}

/* ---- Butcher tableaux ---------------------------------------------------- */

typedef struct tableau {
	int s;            /* stages */
	double c[6];      /* stage times */
	double a[6][6];   /* stage weights, strictly lower triangular */
	double b[6];      /* the propagated solution */
	double bhat[6];   /* the embedded solution (rkf45) */
} tableau;

static const tableau tb_euler = {1, {0}, {{0}}, {1}, {0}};
static const tableau tb_midpoint = {2, {0, 0.5}, {{0}, {0.5}}, {0, 1}, {0}};
static const tableau tb_rk4 = {4,
                               {0, 0.5, 0.5, 1},
                               {{0}, {0.5}, {0, 0.5}, {0, 0, 1}},
                               {1. / 6, 1. / 3, 1. / 3, 1. / 6},
                               {0}};
/* Fehlberg's 4(5) pair, thesis eq. 3.7, propagating the 5th-order
 * solution (eq. 3.7.g) as the thesis does.  The thesis prints +845/4104
 * in eq. 3.7.e; Fehlberg's coefficient is −845/4104 (the row must sum to
 * c₅ = 1, and only then is the method 4th/5th order). */
static const tableau tb_rkf45 = {
	6,
	{0, 1. / 4, 3. / 8, 12. / 13, 1, 1. / 2},
	{{0},
	 {1. / 4},
	 {3. / 32, 9. / 32},
	 {1932. / 2197, -7200. / 2197, 7296. / 2197},
	 {439. / 216, -8, 3680. / 513, -845. / 4104},
	 {-8. / 27, 2, -3544. / 2565, 1859. / 4104, -11. / 40}},
	{16. / 135, 0, 6656. / 12825, 28561. / 56430, -9. / 50, 2. / 55},
	{25. / 216, 0, 1408. / 2565, 2197. / 4104, -1. / 5, 0}};

static const tableau *method_tableau(ndo_method m)
{
	switch (m) {
	case NDO_EULER: return &tb_euler;
	case NDO_MIDPOINT: return &tb_midpoint;
	case NDO_RK4: return &tb_rk4;
	case NDO_RKF45: return &tb_rkf45;
	default: return NULL;
	}
}

int ndo__stability_poly(ndo_method m, double r[7])
{
	const tableau *tb = method_tableau(m);
	if (!tb)
		return -1;
	/* R(z) = 1 + Σ_k (bᵀ A^(k−1) 1) z^k: the method applied to y' = λy. */
	double x[6];
	for (int i = 0; i < tb->s; i++)
		x[i] = 1;
	r[0] = 1;
	for (int k = 1; k <= tb->s; k++) {
		double dot = 0;
		for (int i = 0; i < tb->s; i++)
			dot += tb->b[i] * x[i];
		r[k] = dot;
		double y[6];
		for (int i = 0; i < tb->s; i++) {
			y[i] = 0;
			for (int j = 0; j < i; j++)
				y[i] += tb->a[i][j] * x[j];
		}
		memcpy(x, y, sizeof x);
	}
	return tb->s;
}

int ndo__tableau_check(ndo_method m, double *worst)
{
	const tableau *tb = method_tableau(m);
	if (!tb)
		return -1;
	double w = 0, sb = 0, sbh = 0;
	for (int i = 0; i < tb->s; i++) {
		double row = 0;
		for (int j = 0; j < i; j++)
			row += tb->a[i][j];
		w = fmax(w, fabs(row - tb->c[i]));
		sb += tb->b[i];
		sbh += tb->bhat[i];
	}
	w = fmax(w, fabs(sb - 1));
	if (m == NDO_RKF45)
		w = fmax(w, fabs(sbh - 1));
	*worst = w;
	return 0;
}

/* ---- creation ------------------------------------------------------------ */

/* Steps in a look at whether the threads pay (threads_pick). */
enum { PROBE = 8 };

void ndo_sim_defaults(ndo_sim_params *p)
{
	memset(p, 0, sizeof *p);
	p->material.stiffness = 1;
	p->material.density = 1;
	p->method = NDO_RK4;
	p->tol = 1e-6;
	p->pin_mode = NDO_PINS_PROJECT;
	p->energy_bound = 10;
}

static int check_params(const ndo_sim_params *p)
{
	const ndo_material *m = &p->material;
	if (!(m->stiffness > 0) || !isfinite(m->stiffness))
		return ndo__fail(NDO_ERANGE, "stiffness %g: must be positive and finite", m->stiffness);
	if (!(m->density > 0) || !isfinite(m->density))
		return ndo__fail(NDO_ERANGE, "density %g: must be positive and finite", m->density);
	if (!(m->damping >= 0) || !isfinite(m->damping))
		return ndo__fail(NDO_ERANGE, "damping %g: must be ≥ 0 and finite", m->damping);
	if (!(m->mass_damping >= 0) || !isfinite(m->mass_damping))
		return ndo__fail(NDO_ERANGE, "mass damping %g: must be ≥ 0 and finite",
		                 m->mass_damping);
	if ((int)p->method < 0 || p->method >= NDO_METHOD_COUNT)
		return ndo__fail(NDO_ERANGE, "unknown integrator %d", (int)p->method);
	if (!(p->tol > 0) || !(p->tol < 1))
		return ndo__fail(NDO_ERANGE, "tolerance %g: must lie in (0, 1)", p->tol);
	if (p->restiffen < 0)
		return ndo__fail(NDO_ERANGE, "restiffen %d: must be ≥ 0", p->restiffen);
	if (!(p->penalty >= 0) || !isfinite(p->penalty))
		return ndo__fail(NDO_ERANGE, "penalty %g: must be ≥ 0 and finite", p->penalty);
	if (!(p->energy_bound >= 0) || !isfinite(p->energy_bound))
		return ndo__fail(NDO_ERANGE, "energy bound %g: must be ≥ 0 and finite", p->energy_bound);
	if (p->nforces < 0 || (p->nforces > 0 && !p->forces))
		return ndo__fail(NDO_EINVAL, "bad force list");
	if ((int)p->solver < 0 || p->solver >= NDO_SOLVER_COUNT)
		return ndo__fail(NDO_ERANGE, "unknown solver %d", (int)p->solver);
	if (p->threads < 0 || p->threads > NDO_POOL_MAX)
		return ndo__fail(NDO_ERANGE, "%d threads: must be 0..%d", p->threads, NDO_POOL_MAX);
	return NDO_OK;
}

/* n planes of `count` doubles, zeroed, freed with planes_free().  Large
 * buffers come from mmap, each at the same offset within a 4 KiB page, so
 * the dozen streams a kernel walks in step (u, v, the stage buffers, the
 * sums, mass, damping) would all fall in the same L1 cache sets and alias
 * each other's loads and stores: measured, RK4 at level 8 ran at half the
 * speed it reaches when the buffers happen to come from the heap at
 * scattered offsets.  Each buffer is therefore shifted by its own multiple
 * of 64 bytes (the raw pointer kept just before it). */
static double *planes(size_t count, int n)
{
	static _Atomic unsigned seq;
	const size_t shift = 64 * (1 + (size_t)(seq++ % 31));
	char *raw = calloc(1, (size_t)n * count * sizeof(double) + shift);
	if (!raw)
		return NULL;
	double *p = (double *)(raw + shift);
	((void **)p)[-1] = raw;
	return p;
}

static void planes_free(double *p)
{
	if (p)
		free(((void **)p)[-1]);
}

/* Positions X + u as H × W × 3 (AoS), for the stencil and mass builders. */
static void positions_aos(const ndo_sim *s, const double *u, double *x)
{
	for (size_t p = 0; p < s->count; p++)
		for (int c = 0; c < 3; c++)
			x[3 * p + c] = s->X[(size_t)c * s->count + p] +
			               (u ? u[(size_t)c * s->count + p] : 0);
}

/* The edges from active to held nodes, with their stiffness coefficients
 * (rebuilt when K is). */
static int build_held_edges(ndo_sim *s)
{
	ndo__wave_plan_free(s); /* its chunks and held edges change */
	free(s->hedge);
	s->hedge = NULL;
	s->nhedge = 0;
	size_t cap = 0;
	const size_t w = (size_t)s->w;
	for (size_t pass = 0; pass < 2; pass++) {
		size_t n = 0;
		for (size_t k = 0; k < s->nispan; k++)
			for (size_t p = (size_t)s->ispan[k].a; p < (size_t)s->ispan[k].b; p++) {
				const size_t nb[6] = {p + 1, p + w, p + w - 1, p - 1, p - w, p - w + 1};
				const double cf[6] = {s->st.e[0][p], s->st.e[1][p], s->st.e[2][p],
				                      s->st.e[0][p - 1], s->st.e[1][p - w],
				                      s->st.e[2][p - w + 1]};
				for (int q = 0; q < 6; q++)
					if (!s->active[nb[q]]) {
						if (pass)
							s->hedge[n] = (ndo__edge){(int32_t)p, s->canon[nb[q]], cf[q]};
						n++;
					}
			}
		for (size_t k = 0; k < s->nbact; k++) {
			size_t b = (size_t)s->bact[k];
			for (int q = 0; q < 6; q++) {
				int32_t r = s->st.bnb[6 * b + q];
				if (!s->active[r]) {
					if (pass)
						s->hedge[n] = (ndo__edge){s->st.border[b], s->canon[r],
						                          s->st.bc[6 * b + q]};
					n++;
				}
			}
		}
		if (pass == 0) {
			cap = n;
			s->hedge = malloc((cap + 1) * sizeof *s->hedge);
			if (!s->hedge)
				return ndo__fail(NDO_ENOMEM, "out of memory for the active set");
		}
		s->nhedge = n;
	}
	/* the held nodes the active ones read, and of them those that move
	 * with their velocities (not pins) */
	free(s->hmove), free(s->hread);
	const size_t ndup = ndo_duplicate_count(s->level);
	s->hmove = malloc((s->nhedge + ndup + 1) * sizeof *s->hmove);
	s->hread = malloc((s->nhedge + ndup + 1) * sizeof *s->hread);
	uint8_t *seen = calloc(s->count, 1);
	size_t *pairs = malloc((2 * ndup + 1) * sizeof *pairs);
	if (!s->hmove || !s->hread || !seen || !pairs) {
		free(seen), free(pairs);
		return ndo__fail(NDO_ENOMEM, "out of memory for the active set");
	}
	s->nhmove = s->nhread = 0;
	for (size_t k = 0; k < s->nhedge; k++) {
		int32_t q = s->hedge[k].q;
		if (seen[q])
			continue;
		seen[q] = 1;
		s->hread[s->nhread++] = q;
		if (!s->pin[q])
			s->hmove[s->nhmove++] = q;
	}
	/* their stored duplicates, set alike (no sync of the whole buffer) */
	ndo_duplicates(s->level, pairs);
	for (size_t k = 0; k < ndup; k++) {
		size_t d = pairs[2 * k], q = pairs[2 * k + 1];
		if (!seen[q])
			continue;
		s->hread[s->nhread++] = (int32_t)d;
		if (!s->pin[q])
			s->hmove[s->nhmove++] = (int32_t)d;
	}
	free(seen), free(pairs);
	return NDO_OK;
}

/* Runs sp[0..n) cut into chunks of about NDO__CHUNK nodes, at most
 * NDO__CHUNKS of them, at run boundaries (a run is at most a row): *chunk
 * gets the first run of each chunk and n at the end.  The cut depends on
 * the runs alone, never on the thread count. */
enum { NDO__CHUNK = 512, NDO__CHUNKS = 1024 };
static int cut_chunks(const ndo__span *sp, size_t n, int32_t **chunk, int *nchunk)
{
	size_t total = 0;
	for (size_t k = 0; k < n; k++)
		total += (size_t)(sp[k].b - sp[k].a);
	size_t want = total / NDO__CHUNK;
	want = want < 1 ? 1 : want > NDO__CHUNKS ? NDO__CHUNKS : want;
	free(*chunk);
	if (!(*chunk = malloc((want + 1) * sizeof **chunk)))
		return -1;
	int c = 0;
	size_t done = 0;
	(*chunk)[c++] = 0;
	for (size_t k = 0; k < n; k++) {
		done += (size_t)(sp[k].b - sp[k].a);
		/* close chunk c − 1 once its share of the total is reached */
		if ((size_t)c < want && done * want >= total * (size_t)c && k + 1 < n)
			(*chunk)[c++] = (int32_t)(k + 1);
	}
	(*chunk)[c] = (int32_t)n;
	*nchunk = c;
	return 0;
}

/* The runs of active nodes, the active border nodes, the edges from
 * active to held nodes, and the chunks the threads share. */
static int build_spans(ndo_sim *s)
{
	ndo__rk4_plan_free(s);
	s->spare_held = 0;
	s->ahead = 0;
	free(s->espan), free(s->ispan), free(s->bact);
	s->espan = s->ispan = NULL;
	s->bact = NULL;
	s->nespan = s->nispan = s->nbact = 0;
	size_t cnt = s->count;
	/* At most one run per node; shrunk below. */
	s->espan = malloc((cnt / 2 + 2) * sizeof *s->espan);
	s->ispan = malloc((cnt / 2 + 2) * sizeof *s->ispan);
	s->bact = malloc((s->st.nborder + 1) * sizeof *s->bact);
	if (!s->espan || !s->ispan || !s->bact)
		return ndo__fail(NDO_ENOMEM, "out of memory for the active set");
	int w = s->w, n = s->n;
	for (size_t p = 0; p < cnt; p++) {
		if (!s->active[p] || s->canon[p] != (int32_t)p)
			continue;
		if (s->nespan && s->espan[s->nespan - 1].b == (int32_t)p)
			s->espan[s->nespan - 1].b++;
		else
			s->espan[s->nespan++] = (ndo__span){(int32_t)p, (int32_t)p + 1};
		int i = (int)(p % (size_t)w), j = (int)(p / (size_t)w);
		if (i >= 1 && i <= 2 * n - 1 && j >= 1 && j <= n - 1) {
			if (s->nispan && s->ispan[s->nispan - 1].b == (int32_t)p)
				s->ispan[s->nispan - 1].b++;
			else
				s->ispan[s->nispan++] = (ndo__span){(int32_t)p, (int32_t)p + 1};
		}
	}
	for (size_t b = 0; b < s->st.nborder; b++)
		if (s->active[s->st.border[b]])
			s->bact[s->nbact++] = (int32_t)b;
	if (cut_chunks(s->ispan, s->nispan, &s->ichunk, &s->nichunk) ||
	    cut_chunks(s->espan, s->nespan, &s->echunk, &s->nechunk))
		return ndo__fail(NDO_ENOMEM, "out of memory for the active set");
	free(s->cdiag);
	if (!(s->cdiag = calloc((size_t)s->nichunk + 1, sizeof *s->cdiag)))
		return ndo__fail(NDO_ENOMEM, "out of memory for the active set");
	s->any_held = 0;
	for (size_t p = 0; p < cnt; p++)
		s->any_held |= !s->active[p];
	return build_held_edges(s);
}

/* The largest |u| of the pins the size test measures (s->ppin). */
static void pins_size(ndo_sim *s)
{
	const size_t cnt = s->count;
	double m2 = 0;
	for (size_t k = 0; k < s->nppin; k++) {
		const size_t p = (size_t)s->ppin[k];
		double r2 = 0;
		for (int c = 0; c < 3; c++)
			r2 += s->u[(size_t)c * cnt + p] * s->u[(size_t)c * cnt + p];
		m2 = fmax(m2, r2);
	}
	s->upin = sqrt(m2);
}

/* The projected pins among the nodes mask marks (canonical; NULL: every
 * node), which the size test measures: a peer's region's, whose values its
 * messages carry, as the single process measures all of them.  Penalty
 * pins are integrated, measured as any node. */
static int region_pins(ndo_sim *s, const uint8_t *mask)
{
	free(s->ppin);
	s->ppin = NULL;
	s->nppin = 0;
	s->upin = 0;
	if (s->p.pin_mode != NDO_PINS_PROJECT)
		return NDO_OK;
	size_t n = 0;
	for (size_t p = 0; p < s->count; p++)
		n += s->pin[p] && s->canon[p] == (int32_t)p && (!mask || mask[p]);
	if (!n)
		return NDO_OK;
	if (!(s->ppin = malloc(n * sizeof *s->ppin)))
		return ndo__fail(NDO_ENOMEM, "out of memory for the pins");
	for (size_t p = 0; p < s->count; p++)
		if (s->pin[p] && s->canon[p] == (int32_t)p && (!mask || mask[p]))
			s->ppin[s->nppin++] = (int32_t)p;
	pins_size(s);
	return NDO_OK;
}

static int set_active(ndo_sim *s, const uint8_t *mask)
{
	for (size_t p = 0; p < s->count; p++) {
		int32_t c = s->canon[p];
		s->active[p] = (mask ? mask[c] != 0 : 1) &&
		               !(s->p.pin_mode == NDO_PINS_PROJECT && s->pin[c]);
	}
	return build_spans(s);
}

static int workspace(ndo_sim *s)
{
	int stages = 1;
	const tableau *tb = method_tableau(s->p.method);
	if (tb)
		stages = tb->s;
	size_t cnt = s->count;
	s->us = planes(cnt, 3);
	s->vs = planes(cnt, 3);
	s->tmp = planes(cnt, 3);
	if (!s->us || !s->vs || !s->tmp)
		return ndo__fail(NDO_ENOMEM, "out of memory for the integrator");
	for (int k = 0; k < stages; k++) {
		if (k > 0 && !(s->kv[k] = planes(cnt, 3)))
			return ndo__fail(NDO_ENOMEM, "out of memory for the integrator");
		if (!(s->ka[k] = planes(cnt, 3)))
			return ndo__fail(NDO_ENOMEM, "out of memory for the integrator");
	}
	if ((s->has_forces || s->npen) && !(s->f = planes(cnt, 3)))
		return ndo__fail(NDO_ENOMEM, "out of memory for the forces");
	return NDO_OK;
}

size_t ndo_sim_memory(int level, const ndo_sim_params *p)
{
	const size_t n = (size_t)1 << level, cnt = (2 * n + 1) * (n + 1);
	const tableau *tb = method_tableau(p->method);
	const size_t stages = tb ? (size_t)tb->s : 1;
	/* Planes of doubles (workspace()): X, u, v, us, vs, tmp, the forces,
	 * 3 each; the stages' k (all but the first) and a, 3 each; mass, its
	 * inverse, the damping rate and K's three edge weights, 1 each. */
	const size_t planes = 7 * 3 + (2 * stages - 1) * 3 + 6;
	/* Per node besides: the canonical index, pin and active flags, the
	 * runs (at most one per two nodes, two lists of 8 bytes) and the
	 * positions the setup reads the rest shape into. */
	size_t bytes = cnt * (planes * sizeof(double) + sizeof(int32_t) + 2 + 8 + 3 * sizeof(double));
	/* The multigrid solver's hierarchy and vectors are known in advance
	 * (CHOLMOD's factor only after its analysis: implicit.c checks it). */
	if (ndo_method_is_implicit(p->method) &&
	    ndo_solver_at(p->solver, level) == NDO_SOLVER_MULTIGRID)
		bytes += (size_t)ndo__implicit_mg_bytes(level);
	return bytes;
}

int ndo_sim_create(int level, const double *x, const double *v, const double *rest,
                   const uint8_t *pin, const ndo_sim_params *p, ndo_sim **out)
{
	ndo__clear_error();
	*out = NULL;
	if (level < 0 || level > NDO_MAX_LEVEL)
		return ndo__fail(NDO_ERANGE, "level %d is outside 0..%d", level, NDO_MAX_LEVEL);
	int rc = check_params(p);
	if (rc)
		return rc;
	if (p->max_memory) {
		size_t need = ndo_sim_memory(level, p);
		char a[16], b[16];
		if (need > p->max_memory)
			return ndo__fail(NDO_ENOMEM, "level %d with %s needs about %s; the limit is %s",
			                 level, ndo_method_names[p->method],
			                 ndo_bytes_text((double)need, a, sizeof a),
			                 ndo_bytes_text((double)p->max_memory, b, sizeof b));
	}
	ndo_sim *s = calloc(1, sizeof *s);
	if (!s)
		return ndo__fail(NDO_ENOMEM, "out of memory for a simulation");
	s->level = level;
	s->n = 1 << level;
	s->w = 2 * s->n + 1;
	s->h = s->n + 1;
	s->count = (size_t)s->w * (size_t)s->h;
	s->p = *p;
	s->p.forces = NULL;
	s->p.nforces = 0;
	s->bytes = ndo_sim_memory(level, p);
	size_t cnt = s->count;
	double *aos = malloc(3 * cnt * sizeof *aos);
	s->canon = malloc(cnt * sizeof *s->canon);
	s->X = planes(cnt, 3);
	s->u = planes(cnt, 3);
	s->v = planes(cnt, 3);
	s->mass = planes(cnt, 1);
	s->minv = planes(cnt, 1);
	s->gam = planes(cnt, 1);
	s->pin = calloc(cnt, 1);
	s->active = calloc(cnt, 1);
	if (!aos || !s->canon || !s->X || !s->u || !s->v || !s->mass || !s->minv || !s->gam ||
	    !s->pin || !s->active) {
		rc = ndo__fail(NDO_ENOMEM, "out of memory for a simulation");
		goto fail;
	}
	for (size_t q = 0; q < cnt; q++)
		s->canon[q] = (int32_t)ndo_canonical(level, (int)(q % (size_t)s->w),
		                                     (int)(q / (size_t)s->w));
	const double *R = rest ? rest : x;
	for (size_t q = 0; q < cnt; q++) {
		size_t c = (size_t)s->canon[q];
		for (int d = 0; d < 3; d++) {
			double xi = x[3 * c + d], Xi = R[3 * c + d], vi = v ? v[3 * c + d] : 0;
			if (!isfinite(xi) || !isfinite(Xi) || !isfinite(vi)) {
				rc = ndo__fail(NDO_ERANGE, "node (%d, %d): %s is not finite",
				               (int)(c % (size_t)s->w), (int)(c / (size_t)s->w),
				               !isfinite(xi) ? "position" : !isfinite(Xi) ? "rest position"
				                                                          : "velocity");
				goto fail;
			}
			/* Areas, energies and K u square the coordinates and multiply
			 * them by σ, ρ (≤ 1e12): beyond 1e100 they overflow, and a
			 * run would end as "zero area" or "diverged at step 0". */
			double big = fmax(fabs(xi), fmax(fabs(Xi), fabs(vi)));
			if (big > NDO_SIM_MAX_COORD) {
				rc = ndo__fail(NDO_ERANGE, "node (%d, %d): %s %.3g %s is beyond ±%g, where the "
				               "membrane's areas and energies overflow",
				               (int)(c % (size_t)s->w), (int)(c / (size_t)s->w),
				               fabs(xi) == big ? "position" : fabs(Xi) == big ? "rest position"
				                                                             : "velocity",
				               fabs(xi) == big ? xi : fabs(Xi) == big ? Xi : vi,
				               fabs(vi) == big && fabs(xi) != big && fabs(Xi) != big ? "m/s" : "m",
				               NDO_SIM_MAX_COORD);
				goto fail;
			}
			s->X[(size_t)d * cnt + q] = Xi;
			s->u[(size_t)d * cnt + q] = xi - Xi;
			s->v[(size_t)d * cnt + q] = vi;
		}
		s->pin[q] = pin ? pin[c] != 0 : 0;
	}
	positions_aos(s, NULL, aos);
	if ((rc = ndo_stencil_build(level, aos, p->material.stiffness, &s->st)))
		goto fail;
	if ((rc = ndo_lumped_mass(level, aos, p->material.density, s->mass, NULL)))
		goto fail;
	double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
	for (size_t q = 0; q < cnt; q++) {
		s->minv[q] = 1 / s->mass[q];
		/* B_ii = b·A_i + a·m_i with A_i = m_i/ρ the node's lumped area
		 * (thesis appendix B: the viscous force −b ∂u/∂t per unit area,
		 * lumped like the mass); the acceleration needs B_ii / m_i. */
		s->gam[q] = p->material.damping / p->material.density + p->material.mass_damping;
		/* A density so small that a node's mass is not a normal double
		 * (ρ = 1e-310) gave 1/m = inf: λ_max(M⁻¹K) inf, "stable at any
		 * step", and a NaN state at the first step. */
		if (!isfinite(s->minv[q]) || !isfinite(s->gam[q])) {
			rc = ndo__fail(NDO_ERANGE, "density %g: node (%d, %d)'s mass %g kg is too small "
			               "for a double's range (%s overflows)",
			               p->material.density, (int)(q % (size_t)s->w),
			               (int)(q / (size_t)s->w), s->mass[q],
			               isfinite(s->minv[q]) ? "the damping rate b/density" : "its inverse");
			goto fail;
		}
		for (int d = 0; d < 3; d++) {
			lo[d] = fmin(lo[d], aos[3 * q + d]);
			hi[d] = fmax(hi[d], aos[3 * q + d]);
		}
	}
	s->rest_size = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
	                    (hi[2] - lo[2]) * (hi[2] - lo[2]));
	/* Penalty pins: springs to the initial positions. */
	if (p->pin_mode == NDO_PINS_PENALTY) {
		size_t np = 0;
		for (size_t q = 0; q < cnt; q++)
			np += s->pin[q] && s->canon[q] == (int32_t)q;
		s->pen = malloc((np + 1) * sizeof *s->pen);
		s->pen_target = malloc((3 * np + 1) * sizeof *s->pen_target);
		if (!s->pen || !s->pen_target) {
			rc = ndo__fail(NDO_ENOMEM, "out of memory for pins");
			goto fail;
		}
		double dmax = 0;
		ndo_stencil_diagonal(&s->st, aos); /* aos is free by now: 3·count ≥ count */
		for (size_t q = 0; q < cnt; q++)
			dmax = fmax(dmax, aos[q]);
		/* Payne–Irons (thesis §4.3.3): "a very large number α". 1000 × the
		 * stiffest diagonal keeps a pinned node within 1/1000 of the motion
		 * of its neighbours. */
		s->alpha = p->penalty > 0 ? p->penalty : 1000 * dmax;
		for (size_t q = 0; q < cnt; q++)
			if (s->pin[q] && s->canon[q] == (int32_t)q) {
				for (int d = 0; d < 3; d++)
					s->pen_target[3 * s->npen + d] = s->u[(size_t)d * cnt + q];
				s->pen[s->npen++] = (int32_t)q;
			}
	}
	if ((rc = ndo__forces_resolve(s, p->forces, p->nforces)))
		goto fail;
	if (s->npen) {
		/* which pins are force nodes (their f holds a force besides the
		 * spring's: ndo__stage_power), the implicit step's springs */
		s->pen_forced = calloc(s->npen, 1);
		s->pen_f1 = malloc(3 * s->npen * sizeof *s->pen_f1);
		uint8_t *mark = calloc(cnt, 1);
		if (!s->pen_forced || !s->pen_f1 || !mark) {
			free(mark);
			rc = ndo__fail(NDO_ENOMEM, "out of memory for pins");
			goto fail;
		}
		for (size_t k = 0; k < s->nfnodes; k++)
			mark[s->fnodes[k]] = 1;
		for (size_t k = 0; k < s->npen; k++)
			s->pen_forced[k] = s->has_pressure || mark[s->pen[k]];
		free(mark);
	}
	if ((rc = workspace(s)) || (rc = set_active(s, NULL)) || (rc = region_pins(s, NULL)))
		goto fail;
	if (p->threads > 1) {
		size_t nodes = 0;
		for (size_t k = 0; k < s->nespan; k++)
			nodes += (size_t)(s->espan[k].b - s->espan[k].a);
		if (nodes >= NDO_SIM_THREAD_MIN && (rc = ndo_pool_create(p->threads, &s->pool)))
			goto fail;
		s->probe_steps = 8 * PROBE; /* the first steps look whether threads pay */
	}
	free(aos);
	*out = s;
	return NDO_OK;
fail:
	free(aos);
	ndo_sim_destroy(s);
	return rc;
}

int ndo_sim_from_grid(ndo_grid *g, const ndo_sim_params *p, ndo_sim **out)
{
	ndo__clear_error();
	*out = NULL;
	double *x = ndo_grid_f64(g, NDO_CH_POSITION, 3);
	if (!x)
		return ndo__fail(NDO_EFORMAT, "no usable position channel (3 floating-point values)");
	const double *v = NULL, *rest = NULL;
	const uint8_t *pin = NULL;
	if (ndo_grid_find(g, NDO_CH_VELOCITY) && !(v = ndo_grid_f64(g, NDO_CH_VELOCITY, 3)))
		return ndo__fail(NDO_EFORMAT, "channel 'velocity' is not 3 floating-point values");
	if (ndo_grid_find(g, NDO_CH_REST) && !(rest = ndo_grid_f64(g, NDO_CH_REST, 3)))
		return ndo__fail(NDO_EFORMAT, "channel 'rest' is not 3 floating-point values");
	ndo_channel *pc = ndo_grid_find(g, NDO_CH_PIN);
	if (pc) {
		if (pc->type != NDO_U8 || pc->comps != 1)
			return ndo__fail(NDO_EFORMAT, "channel 'pin' is not 1 × u8");
		pin = pc->data;
	}
	int rc = ndo_sim_create(g->level, x, v, rest, pin, p, out);
	if (rc == NDO_OK)
		ndo_sim_set_time(*out, g->time, g->step);
	return rc;
}

void ndo_sim_destroy(ndo_sim *s)
{
	if (!s)
		return;
	ndo__implicit_free(s);
	ndo__rk4_plan_free(s);
	ndo__wave_plan_free(s);
	ndo__sleep_free(s->sleep);
	ndo_stencil_free(&s->st);
	planes_free(s->X), planes_free(s->u), planes_free(s->v);
	planes_free(s->mass), planes_free(s->minv), planes_free(s->gam);
	free(s->pin), free(s->active), free(s->canon), free(s->pend), free(s->ppin);
	ndo_pool_destroy(s->pool);
	free(s->espan), free(s->ispan), free(s->bact), free(s->hedge), free(s->hmove),
	    free(s->hread);
	free(s->ichunk), free(s->echunk), free(s->cdiag);
	free(s->pen), free(s->pen_target), free(s->pen_forced), free(s->pen_f1);
	if (s->forces)
		ndo__forces_free(s);
	planes_free(s->f);
	planes_free(s->us), planes_free(s->vs), planes_free(s->tmp);
	free(s->err);
	for (int k = 0; k < 6; k++)
		planes_free(s->kv[k]), planes_free(s->ka[k]);
	free(s);
}

/* ---- state ---------------------------------------------------------------- */

double ndo_sim_time(const ndo_sim *s) { return s->t; }
int64_t ndo_sim_step_count(const ndo_sim *s) { return s->step; }
int ndo_sim_level(const ndo_sim *s) { return s->level; }
int ndo_sim_threads(const ndo_sim *s) { return ndo_pool_threads(s->pool); }
ndo_method ndo_sim_method(const ndo_sim *s) { return s->p.method; }
int ndo_sim_restiffen_every(const ndo_sim *s) { return s->p.restiffen; }

void ndo_sim_set_time(ndo_sim *s, double t, int64_t step)
{
	/* a sim that has not stepped begins its run here (a single process
	 * continuing a grid of step 100 counts --restiffen's steps from it);
	 * otherwise the state is another (a peer's restart, maybe at the step
	 * it was at, on a new region): the next step re-assembles K as that
	 * step's K is (ndo__restiffen_due) */
	if (!s->k_fixed && s->stats.steps == 0 && s->k_at == s->k_first)
		s->k_first = s->k_at = step;
	else
		s->k_at = NDO__K_STALE;
	s->t = t;
	s->step = step;
}

void ndo_sim_set_first_step(ndo_sim *s, int64_t first)
{
	if (s->k_at != s->k_first || first != s->k_first)
		s->k_at = NDO__K_STALE;
	s->k_first = first;
	s->k_fixed = 1;
}

void ndo_sim_stats_get(const ndo_sim *s, ndo_sim_stats *st) { *st = s->stats; }

void ndo_sim_get(const ndo_sim *s, double *x, double *v)
{
	size_t cnt = s->count;
	for (size_t p = 0; p < cnt; p++)
		for (int c = 0; c < 3; c++) {
			if (x)
				x[3 * p + c] = s->X[(size_t)c * cnt + p] + s->u[(size_t)c * cnt + p];
			if (v)
				v[3 * p + c] = s->v[(size_t)c * cnt + p];
		}
}

/* After ndo_sim_set*: the duplicates, and the pipeline's spare state at
 * the nodes written (sim_private.h, spare_held; all of them: NULL). */
static void state_written(ndo_sim *s, size_t n, const int32_t *nodes)
{
	/* a step begun ahead read every node but the pending ones */
	if (s->ahead && !nodes)
		s->ahead = 0;
	for (size_t k = 0; s->ahead && k < n; k++)
		if ((size_t)nodes[k] < s->count && !s->pend[s->canon[nodes[k]]])
			s->ahead = 0;
	if (!nodes) {
		ndo__sync_planes(s, s->u, 3);
		ndo__sync_planes(s, s->v, 3);
		s->spare_held = 0;
		return;
	}
	/* the written nodes' duplicates alone (a pass over every seam of the
	 * planes cost a peer more than its halo's writes), and their spare
	 * state */
	const size_t cnt = s->count;
	for (size_t k = 0; k < n; k++) {
		if ((size_t)nodes[k] >= cnt)
			continue;
		size_t p = (size_t)s->canon[nodes[k]];
		long d = ndo_duplicate_of(s->level, p);
		for (int c = 0; c < 3; c++) {
			size_t q = (size_t)c * cnt + p;
			if (s->spare_held)
				s->ka[0][q] = s->u[q], s->ka[1][q] = s->v[q];
			if (d < 0)
				continue;
			size_t r = (size_t)c * cnt + (size_t)d;
			s->u[r] = s->u[q], s->v[r] = s->v[q];
			if (s->spare_held)
				s->ka[0][r] = s->u[q], s->ka[1][r] = s->v[q];
		}
	}
}

void ndo_sim_set(ndo_sim *s, size_t n, const int32_t *nodes, const double *x,
                 const double *v)
{
	size_t cnt = s->count;
	int pinned = 0;
	s->udrift = 0; /* a drift is the state's: the size test measures again */
	if (!nodes)
		n = cnt;
	for (size_t k = 0; k < n; k++) {
		size_t q = nodes ? (size_t)nodes[k] : k;
		if (q >= cnt)
			continue;
		size_t p = (size_t)s->canon[q];
		pinned |= s->nppin && s->pin[p];
		for (int c = 0; c < 3; c++) {
			if (x)
				s->u[(size_t)c * cnt + p] = x[3 * k + c] - s->X[(size_t)c * cnt + p];
			if (v)
				s->v[(size_t)c * cnt + p] = v[3 * k + c];
		}
	}
	if (x && pinned) /* a pin among them: the size test's largest |u| again */
		pins_size(s);
	state_written(s, n, nodes);
}

void ndo_sim_get_nodes(const ndo_sim *s, size_t n, const int32_t *nodes, double *x, double *u,
                       double *v)
{
	/* one loop an array asked for: a whole region's frame goes through
	 * here, and a test a value cost as much as the copy */
	const size_t cnt = s->count;
	const double *restrict X = s->X, *restrict U = s->u, *restrict V = s->v;
	const int32_t *restrict canon = s->canon;
	if (x)
		for (size_t k = 0; k < n; k++) {
			const size_t p = (size_t)canon[nodes[k]];
			for (int c = 0; c < 3; c++)
				x[3 * k + c] = X[(size_t)c * cnt + p] + U[(size_t)c * cnt + p];
		}
	if (u)
		for (size_t k = 0; k < n; k++) {
			const size_t p = (size_t)canon[nodes[k]];
			for (int c = 0; c < 3; c++)
				u[3 * k + c] = U[(size_t)c * cnt + p];
		}
	if (v)
		for (size_t k = 0; k < n; k++) {
			const size_t p = (size_t)canon[nodes[k]];
			for (int c = 0; c < 3; c++)
				v[3 * k + c] = V[(size_t)c * cnt + p];
		}
}

void ndo_sim_get_nodes_at(const ndo_sim *s, size_t n, const int32_t *nodes, double *x,
                          double *v)
{
	const size_t cnt = s->count;
	const double *restrict X = s->X, *restrict U = s->u, *restrict V = s->v;
	const int32_t *restrict canon = s->canon;
	for (size_t k = 0; k < n; k++) {
		const size_t p = (size_t)canon[nodes[k]], o = 3 * (size_t)nodes[k];
		for (int c = 0; c < 3; c++) {
			if (x)
				x[o + c] = X[(size_t)c * cnt + p] + U[(size_t)c * cnt + p];
			if (v)
				v[o + c] = V[(size_t)c * cnt + p];
		}
	}
}

void ndo_sim_set_displacements(ndo_sim *s, size_t n, const int32_t *nodes, const double *u,
                               const double *v)
{
	const size_t cnt = s->count;
	int pinned = 0;
	if (u)
		s->udrift = 0; /* as ndo_sim_set */
	for (size_t k = 0; k < n; k++) {
		if ((size_t)nodes[k] >= cnt)
			continue;
		size_t p = (size_t)s->canon[nodes[k]];
		pinned |= s->nppin && s->pin[p];
		for (int c = 0; c < 3; c++) {
			if (u)
				s->u[(size_t)c * cnt + p] = u[3 * k + c];
			if (v)
				s->v[(size_t)c * cnt + p] = v[3 * k + c];
		}
	}
	if (u && pinned) /* as ndo_sim_set */
		pins_size(s);
	state_written(s, n, nodes);
}

void ndo_sim_restart_energy_bound(ndo_sim *s)
{
	s->e0_set = 0;
	s->work_abs_base = s->work_abs;
}

int ndo_sim_set_active(ndo_sim *s, const uint8_t *mask)
{
	ndo__clear_error();
	if (s->sleep)
		return ndo__fail(NDO_EINVAL, "a region and sleeping tiles do not go together");
	s->ext_active = mask != NULL;
	s->udrift = 0; /* another set of nodes: the size test measures again */
	int rc = set_active(s, mask);
	if (!rc)
		rc = region_pins(s, mask);
	ndo__implicit_invalidate(s, 1);
	/* The energy bound is over the integrated nodes: a new region starts
	 * it again from its own energy (a peer that takes over a moving region
	 * has not seen the work that moved it). */
	s->e0_set = 0;
	s->work_abs_base = s->work_abs;
	return rc;
}

int ndo_sim_set_sleep(ndo_sim *s, double umax, double vmax)
{
	ndo__clear_error();
	if (!(umax >= 0) || !(vmax >= 0) || !isfinite(umax) || !isfinite(vmax))
		return ndo__fail(NDO_EINVAL, "sleep bounds %g m, %g m/s: must be finite and ≥ 0",
		                 umax, vmax);
	int reach;
	switch (s->p.method) {
	case NDO_EULER:
	case NDO_SYMPLECTIC_EULER:
	case NDO_MIDPOINT: reach = 1; break;
	case NDO_RK4: reach = 2; break;
	default:
		return ndo__fail(NDO_EINVAL, "sleeping tiles: %s steps are not fixed stencil "
		                 "passes (euler, symplectic-euler, midpoint and rk4 only)",
		                 ndo_method_names[s->p.method]);
	}
	if (s->ext_active)
		return ndo__fail(NDO_EINVAL, "a region and sleeping tiles do not go together");
	ndo__sleep_free(s->sleep);
	s->sleep = NULL;
	s->node_steps = s->node_steps_all = 0;
	int rc = 0;
	if ((umax > 0 || vmax > 0) && (rc = ndo__sleep_create(s, umax, vmax, reach, &s->sleep)))
		return rc;
	return set_active(s, NULL);
}

void ndo_sim_sleep_stats_get(const ndo_sim *s, ndo_sim_sleep_stats *st)
{
	memset(st, 0, sizeof *st);
	st->node_steps = s->node_steps;
	st->node_steps_all = s->node_steps_all;
	if (!s->sleep)
		return;
	st->on = 1;
	ndo__sleep_counts(s->sleep, &st->checks, &st->wakes, &st->sleeps, &st->tiles, &st->awake);
}

void ndo_sim_set_held_motion(ndo_sim *s, int on)
{
	s->held_motion = on != 0;
	s->spare_held = 0;
	s->ahead = 0;
}

int ndo_sim_store(const ndo_sim *s, ndo_grid *g)
{
	ndo__clear_error();
	if (g->level != s->level)
		return ndo__fail(NDO_EINVAL, "grid level %d, simulation level %d", g->level, s->level);
	ndo_channel *cx, *cv, *cr;
	int rc;
	if (ndo_grid_find(g, NDO_CH_POSITION) &&
	    ndo_grid_find(g, NDO_CH_POSITION)->type != NDO_F64 &&
	    (rc = ndo_grid_convert(g, NDO_CH_POSITION, NDO_F64)))
		return rc;
	const char *names[2] = {NDO_CH_VELOCITY, NDO_CH_REST};
	for (int k = 0; k < 2; k++) {
		ndo_channel *c = ndo_grid_find(g, names[k]);
		if (c && (c->type != NDO_F64 || c->comps != 3))
			ndo_grid_remove(g, names[k]);
	}
	if ((rc = ndo_grid_add(g, NDO_CH_POSITION, NDO_F64, 3, &cx)) ||
	    (rc = ndo_grid_add(g, NDO_CH_VELOCITY, NDO_F64, 3, &cv)) ||
	    (rc = ndo_grid_add(g, NDO_CH_REST, NDO_F64, 3, &cr)))
		return rc;
	/* Adding channels may move the table: look them up again. */
	cx = ndo_grid_find(g, NDO_CH_POSITION);
	cv = ndo_grid_find(g, NDO_CH_VELOCITY);
	cr = ndo_grid_find(g, NDO_CH_REST);
	ndo_sim_get(s, cx->data, cv->data);
	double *r = cr->data;
	for (size_t p = 0; p < s->count; p++)
		for (int c = 0; c < 3; c++)
			r[3 * p + c] = s->X[(size_t)c * s->count + p];
	g->time = s->t;
	g->step = s->step;
	return NDO_OK;
}

/* ---- explicit integrators ---------------------------------------------------- */

/* out = base + h Σ_j coef_j src_j on the active nodes (3 planes), a chunk
 * of runs at a time on the simulation's threads; axpy uses the same
 * record with out = y and base = x. */
typedef struct lincomb {
	const ndo_sim *s;
	double *out;
	const double *base;
	double h;
	int n;
	const double *coef;
	const double *const *src;
} lincomb;

NDO_HOT static void combine_chunk(void *arg, int ch)
{
	const lincomb *l = arg;
	const ndo_sim *s = l->s;
	const size_t cnt = s->count;
	double *restrict out = l->out;
	const double *restrict base = l->base;
	const double h = l->h;
	for (int c = 0; c < 3; c++) {
		const size_t o = (size_t)c * cnt;
		for (size_t k = (size_t)s->echunk[ch]; k < (size_t)s->echunk[ch + 1]; k++)
			for (size_t p = o + (size_t)s->espan[k].a; p < o + (size_t)s->espan[k].b; p++) {
				double acc = 0;
				for (int j = 0; j < l->n; j++)
					acc += l->coef[j] * l->src[j][p];
				out[p] = base[p] + h * acc;
			}
	}
}

/* y += h x on the active nodes (3 planes), the same record with out = y
 * and base = x. */
NDO_HOT static void axpy_chunk(void *arg, int ch)
{
	const lincomb *l = arg;
	const ndo_sim *s = l->s;
	const size_t cnt = s->count;
	double *restrict y = l->out;
	const double *restrict x = l->base;
	const double h = l->h;
	for (int c = 0; c < 3; c++) {
		const size_t o = (size_t)c * cnt;
		for (size_t k = (size_t)s->echunk[ch]; k < (size_t)s->echunk[ch + 1]; k++)
			for (size_t p = o + (size_t)s->espan[k].a; p < o + (size_t)s->espan[k].b; p++)
				y[p] += h * x[p];
	}
}

/* Several of those updates in one run on the threads, a chunk through all
 * of them before the next: each node sees them in the order given (so the
 * same bits as one run each), with one wake-up of the threads and the
 * chunk's planes still in cache for the next update. */
enum { UPDATES_MAX = 16 };
typedef struct updates {
	int n;
	void (*fn[UPDATES_MAX])(void *, int);
	lincomb l[UPDATES_MAX];
} updates;

static void updates_chunk(void *arg, int ch)
{
	updates *u = arg;
	for (int i = 0; i < u->n; i++)
		u->fn[i](&u->l[i], ch);
}

static void updates_combine(updates *u, const ndo_sim *s, double *out, const double *base,
                            double h, int n, const double *coef, const double *const *src)
{
	u->fn[u->n] = combine_chunk;
	u->l[u->n++] = (lincomb){s, out, base, h, n, coef, src};
}

static void updates_axpy(updates *u, const ndo_sim *s, double *y, double h, const double *x)
{
	u->fn[u->n] = axpy_chunk;
	u->l[u->n++] = (lincomb){s, y, x, h, 0, NULL, NULL};
}

static void updates_run(const ndo_sim *s, updates *u)
{
	ndo__sim_run(s, s->nechunk, updates_chunk, u);
}

/* A step of size h is done whose mean input power was P: its work h P is
 * the step's own, added to the input work at the next step's divergence
 * test (ndo__pending_work).  Symplectic Euler: P = ½ f(t)·(v + v'), the
 * work on the energy it conserves, exactly (accel.c).  rk4 and rkf45:
 * P = Σ b_i f(t_i)·V_i over their stages (tableau_power), the quadrature
 * the step itself integrates with.  Forward Euler and midpoint: the
 * step's force at its mean velocity ½(v + v') (first_stage, step_rk).
 * The implicit methods: implicit.c. */
static void account(ndo_sim *s, double h, double P)
{
	s->pend_h = h;
	s->pend_power = P;
}

/* The step's mean input power by the method's own quadrature, Σ b_i P_i
 * (P_i the input power at stage i: s->stage_power).  Applied to the input
 * work W' = f(t)·v as one more equation, the step gives W exactly this
 * increment; for a linear membrane it is the forces' term of the step's
 * energy change, which is, exactly (Cooper 1987, for E = ½ yᵀSy),
 *   E' − E = h Σ b_i (f_i·V_i − V_iᵀB V_i) + ½ h² Σ_ij m_ij k_iᵀS k_j,
 *   m_ij = b_i b_j − b_i a_ij − b_j a_ji,
 * k_i = (V_i, A_i) the stage's derivative: the damping at the stages and
 * the method's own term, which a diverging step makes grow (forward
 * Euler: m = 1, ½ h² (aᵀMa + vᵀKv) a step).  So a push between the step's
 * ends is counted where the stages see it, and only there does the step
 * put it in. */
static double tableau_power(const tableau *tb, const double *P)
{
	double w = 0;
	for (int i = 0; i < tb->s; i++)
		if (tb->b[i] != 0)
			w += tb->b[i] * P[i];
	return w;
}

/* Stage 0 at the current state, with the divergence test.  Forward Euler
 * (a step h_mean > 0) takes its input power at the mean velocity
 * ½(v + v'), v' = v + h a, as symplectic Euler's pass does
 * (NDO__UPD_STORE_SE: the same a): its step's work is h f(t)·½(v + v'),
 * not its tableau's h f(t)·v.  That one is 0 from rest, where the step
 * still puts ½ h² f·M⁻¹f into the kinetic energy — the quadrature is
 * only first order, and from rest its error is the whole work — so the
 * test would stop a run from rest under a force at its first step
 * (test_sim pins_stay_put, a constant force, did).  The velocity changes
 * by h M⁻¹(f − K u − B v), so the kinetic energy by
 * h (f − K u − B v)·½(v + v'): the force's share is this work exactly,
 * and the potential energy's change, h vᵀK ½(u + u'), does not see the
 * force (u' = u + h v). */
static int first_stage(ndo_sim *s, double *a, double h_mean)
{
	ndo__diag d;
	if (h_mean > 0) {
		ndo__upd sp = {.mode = NDO__UPD_STORE_SE, .h = h_mean, .a = a};
		ndo__accel_update(s, s->t, s->u, s->v, &sp, &d);
	} else {
		ndo__accel(s, s->t, s->u, s->v, a, &d);
	}
	s->last_power = s->stage_power[0] = d.power;
	return ndo__diverged(s, &d, 1);
}

/* The stages of an explicit Runge–Kutta method from the current state
 * (stage 0 already in ka[0] when k0_ready). */
static int rk_stages(ndo_sim *s, const tableau *tb, double h, int k0_ready)
{
	int rc;
	if (!k0_ready && (rc = first_stage(s, s->ka[0], tb == &tb_euler ? h : 0)))
		return rc;
	if (tb->s > 1 && s->any_held)
		ndo__held_keep(s, s->us); /* held nodes keep u */
	for (int i = 1; i < tb->s; i++) {
		const double *su[6], *sv[6];
		double coef[6];
		int n = 0;
		for (int j = 0; j < i; j++)
			if (tb->a[i][j] != 0) {
				coef[n] = tb->a[i][j];
				su[n] = j == 0 ? s->v : s->kv[j];
				sv[n] = s->ka[j];
				n++;
			}
		ndo__held_at(s, s->us, tb->c[i] * h);
		updates up = {0};
		updates_combine(&up, s, s->us, s->u, h, n, coef, su);
		updates_combine(&up, s, s->kv[i], s->v, h, n, coef, sv);
		updates_run(s, &up);
		ndo__sync_planes(s, s->us, 3);
		ndo__sync_planes(s, s->kv[i], 3);
		ndo__accel(s, s->t + tb->c[i] * h, s->us, s->kv[i], s->ka[i], NULL);
		/* f holds the stage's forces (midpoint's work: step_rk) */
		if (tb->b[i] != 0 && tb != &tb_midpoint) {
			const ndo__vel w = {s->kv[i], s->count, 0, NULL, NULL, 0};
			s->stage_power[i] = ndo__stage_power(s, s->f, s->us, &w);
		}
	}
	return NDO_OK;
}

/* u += h Σ b_j kv_j (kv_0 = v), then v += h Σ b_j ka_j. */
static void rk_finish(ndo_sim *s, const tableau *tb, double h)
{
	updates up = {0};
	for (int j = 1; j < tb->s; j++)
		if (tb->b[j] != 0)
			updates_axpy(&up, s, s->u, h * tb->b[j], s->kv[j]);
	if (tb->b[0] != 0)
		updates_axpy(&up, s, s->u, h * tb->b[0], s->v);
	for (int j = 0; j < tb->s; j++)
		if (tb->b[j] != 0)
			updates_axpy(&up, s, s->v, h * tb->b[j], s->ka[j]);
	updates_run(s, &up);
	ndo__held_at(s, s->u, h); /* the boundary moves on with the sub-step */
	ndo__sync_planes(s, s->u, 3);
	ndo__sync_planes(s, s->v, 3);
}

static int step_rk(ndo_sim *s, const tableau *tb, double h)
{
	if (!tb)
		return ndo__fail(NDO_EINVAL, "not an explicit Runge–Kutta method");
	int rc = rk_stages(s, tb, h, 0);
	if (rc)
		return rc;
	/* forward Euler: its mean power (first_stage); midpoint: its stage's
	 * force at the mean velocity, v' = v + h a₁ as rk_finish makes it —
	 * its stage's quadrature h f(t + h/2)·(v + ½ h a₀) does not see the
	 * velocity the step's push gives, and counts 0 from rest under a
	 * force that is 0 at the start (the thesis' sines) while the step puts
	 * ½ h² f·M⁻¹f into the kinetic energy; the step changes the velocity
	 * by h a₁, so the kinetic energy by h M a₁·½(v + v'), of which this is
	 * the forces' share, exactly */
	double P = tableau_power(tb, s->stage_power);
	if (tb == &tb_euler) {
		P = s->last_power;
	} else if (tb == &tb_midpoint) {
		const ndo__vel w = {s->v, s->count, 0, NULL, s->ka[1], h};
		P = ndo__stage_power(s, s->f, s->us, &w);
	}
	rk_finish(s, tb, h);
	account(s, h, P);
	s->stats.substeps++;
	return NDO_OK;
}

/* Classic RK4 (rk4.c, which leaves the stages' input powers in
 * s->stage_power). */
static int step_rk4(ndo_sim *s, double h)
{
	int rc = ndo__rk4_step(s, h);
	if (rc)
		return rc;
	account(s, h, tableau_power(&tb_rk4, s->stage_power));
	s->stats.substeps++;
	return NDO_OK;
}

/* Whether symplectic Euler and midpoint take their fused passes
 * (ndo__accel_update: the acceleration used in the pass that computes
 * it, the new state written to spare planes): when every node is
 * integrated, so that the spare planes need nothing but what the pass
 * writes and the seams' copies. */
static int fused_fits(const ndo_sim *s)
{
	return !s->rk4_reference && !s->any_held;
}

/* The new state (u, v) in the spare planes (us, vs) swapped in. */
static void fused_swap(ndo_sim *s, double *u, double *v)
{
	ndo__sync_planes(s, u, 3);
	ndo__sync_planes(s, v, 3);
	double *ou = s->u, *ov = s->v;
	s->u = u, s->v = v;
	s->us = ou, s->vs = ov;
}

/* A fused method's first pass, at the step's state, with the divergence
 * test on its diagnostics: a step that diverges returns with the state as
 * it was (the pass wrote only the spare planes uo, vo). */
static int fused_first(ndo_sim *s, int mode, double h, double *uo, double *vo)
{
	ndo__upd up = {mode, h, uo, vo, NULL, NULL, NULL};
	ndo__diag d;
	ndo__accel_update(s, s->t, s->u, s->v, &up, &d);
	s->last_power = s->stage_power[0] = d.power;
	return ndo__diverged(s, &d, 1);
}

/* Symplectic Euler in one pass: the same bits as step_symplectic. */
static int step_symplectic_fused(ndo_sim *s, double h)
{
	s->h_mod = h;
	double *un = s->us, *vn = s->vs;
	int rc = fused_first(s, NDO__UPD_SYMPLECTIC, h, un, vn);
	if (rc)
		return rc;
	fused_swap(s, un, vn);
	account(s, h, s->last_power);
	s->stats.substeps++;
	return NDO_OK;
}

/* The midpoint method in two passes (the tableau's four: stage 0, the
 * stage state, stage 1, the finish): the same bits as step_rk. */
static int step_midpoint_fused(ndo_sim *s, double h)
{
	double *um = s->us, *vm = s->kv[1], *un = s->ka[0], *vn = s->ka[1];
	int rc = fused_first(s, NDO__UPD_HALF, h, um, vm);
	if (rc)
		return rc;
	ndo__sync_planes(s, um, 3);
	ndo__sync_planes(s, vm, 3);
	ndo__upd up = {NDO__UPD_FULL, h, un, vn, s->u, s->v, NULL};
	ndo__accel_update(s, s->t + 0.5 * h, um, vm, &up, NULL);
	/* the stage's force (in f) at the mean velocity (step_rk) */
	const ndo__vel w = {s->v, s->count, 0, vn, NULL, 0};
	const double P = ndo__stage_power(s, s->f, um, &w);
	ndo__sync_planes(s, un, 3);
	ndo__sync_planes(s, vn, 3);
	s->ka[0] = s->u, s->ka[1] = s->v;
	s->u = un, s->v = vn;
	account(s, h, P);
	s->stats.substeps++;
	return NDO_OK;
}

/* Symplectic Euler: v' = v + h a(u, v), u' = u + h v'. */
static int step_symplectic(ndo_sim *s, double h)
{
	if (fused_fits(s))
		return step_symplectic_fused(s, h);
	s->h_mod = h; /* the divergence test bounds the modified energy (accel.c) */
	/* the first stage, its input power taken as the fused pass takes it */
	ndo__upd sp = {.mode = NDO__UPD_STORE_SE, .h = h, .a = s->ka[0]};
	ndo__diag d;
	ndo__accel_update(s, s->t, s->u, s->v, &sp, &d);
	s->last_power = d.power;
	int rc = ndo__diverged(s, &d, 1);
	if (rc)
		return rc;
	/* v then u, node by node: u's update reads only its own node's v */
	updates up = {0};
	updates_axpy(&up, s, s->v, h, s->ka[0]);
	updates_axpy(&up, s, s->u, h, s->v);
	updates_run(s, &up);
	ndo__sync_planes(s, s->v, 3);
	ndo__sync_planes(s, s->u, 3);
	account(s, h, s->last_power);
	s->stats.substeps++;
	return NDO_OK;
}

/* The error of an rkf45 sub-step relative to the tolerance: max over the
 * active components (of the nodes in `rows` when not NULL: a peer's own)
 * of |e| / (tol (1 + max(|y|, |y'|))).  A NaN stays (it is "too large"),
 * so the maximum does not depend on the order the nodes are visited in:
 * peers that each take the maximum over their own nodes and then over
 * the peers get the single process's value, bit for bit. */
static double rkf45_error(ndo_sim *s, const tableau *tb, double h, const uint8_t *rows)
{
	const size_t cnt = s->count;
	double worst = 0, d[6];
	for (int j = 0; j < tb->s; j++)
		d[j] = tb->b[j] - tb->bhat[j];
	for (int part = 0; part < 2; part++) {
		const double *y = part ? s->v : s->u;
		for (size_t o = 0; o < 3 * cnt; o += cnt)
			for (size_t k = 0; k < s->nespan; k++)
				for (size_t p = o + (size_t)s->espan[k].a; p < o + (size_t)s->espan[k].b; p++) {
					if (rows && !rows[p - o])
						continue;
					double e = 0, y1 = 0;
					for (int j = 0; j < tb->s; j++) {
						const double *kj = part ? s->ka[j] : (j == 0 ? s->v : s->kv[j]);
						e += d[j] * kj[p];
						y1 += tb->b[j] * kj[p];
					}
					y1 = y[p] + h * y1;
					double r = fabs(h * e) / (s->p.tol * (1 + fmax(fabs(y[p]), fabs(y1))));
					if (isnan(r) || r > worst)
						worst = isnan(worst) ? worst : r;
				}
	}
	return worst;
}

/* rkf45's step in parts (ndo_sim_rkf45_begin/attempt/decide): the state
 * of the step under way lives in the simulation. */
static void rkf45_begin(ndo_sim *s, double H)
{
	s->rk_t_end = s->t + H;
	s->rk_hs = s->h_sub > 0 ? fmin(s->h_sub, H) : H;
	s->rk_k0 = 0;
	s->rk_rejected = 0;
	s->rk_t0 = s->t;
	s->rk_hsub0 = s->h_sub;
	s->rk_undo.work = s->work;
	s->rk_undo.work_abs = s->work_abs;
	s->rk_undo.pend_h = s->pend_h;
	s->rk_undo.pend_power = s->pend_power;
	s->rk_undo.e0 = s->e0;
	s->rk_undo.e0_set = s->e0_set;
	s->rk_undo.udrift = s->udrift;
	s->rk_undo.substeps = s->stats.substeps;
	s->rk_undo.rejected = s->stats.rejected;
	s->rk_undo.last_substep = s->stats.last_substep;
}

static int rkf45_attempt(ndo_sim *s, const uint8_t *rows, double *err)
{
	const tableau *tb = &tb_rkf45;
	double rem = s->rk_t_end - s->t;
	s->rk_last = s->rk_hs >= rem * (1 - 1e-12);
	s->rk_h = s->rk_last ? rem : s->rk_hs;
	int rc = rk_stages(s, tb, s->rk_h, s->rk_k0);
	if (rc)
		return rc;
	*err = rkf45_error(s, tb, s->rk_h, rows);
	return NDO_OK;
}

/* 1: the step is complete; 0: another sub-step; or a negative status. */
static int rkf45_decide(ndo_sim *s, double err)
{
	const tableau *tb = &tb_rkf45;
	const double h = s->rk_h, H = s->rk_t_end - s->rk_t0;
	if (err <= 1) {
		rk_finish(s, tb, h);
		account(s, h, tableau_power(tb, s->stage_power));
		s->stats.substeps++;
		s->stats.last_substep = h;
		/* The usual controller for a 4th-order error estimate: the
		 * 0.9 safety factor, at most ×5 per step and never growing
		 * right after a rejection. */
		double fac = err > 0 ? 0.9 * pow(err, -0.2) : 5;
		fac = fmin(s->rk_rejected ? 1 : 5, fmax(0.2, fac));
		if (!s->rk_last || h >= s->rk_hs)
			s->rk_hs = h * fac;
		s->rk_rejected = 0;
		s->rk_k0 = 0;
		if (s->rk_last) {
			s->t = s->rk_t_end;
			s->h_sub = s->rk_hs;
			return 1;
		}
		s->t += h;
		return 0;
	}
	s->stats.rejected++;
	double fac = isfinite(err) ? fmax(0.1, 0.9 * pow(err, -0.25)) : 0.1;
	s->rk_hs = h * fac;
	s->rk_rejected = 1;
	s->rk_k0 = 1; /* the state did not change: stage 0 stands */
	if (s->rk_hs < 1e-14 * fmax(fabs(s->t), H))
		return ndo__fail(NDO_EDIVERGED, "rkf45's step size underflowed (%.3g s) "
		                 "at t = %.9g s: the tolerance cannot be met", s->rk_hs, s->t);
	return 0;
}

static int step_rkf45(ndo_sim *s, double H)
{
	rkf45_begin(s, H);
	for (;;) {
		double err;
		int rc = rkf45_attempt(s, NULL, &err);
		if (rc)
			return rc;
		if ((rc = rkf45_decide(s, err)) < 0)
			return rc;
		if (rc == 1)
			return NDO_OK;
	}
}

/* ---- stepping ------------------------------------------------------------------ */

static double cpu_seconds(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
	return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int ndo__restiffen(ndo_sim *s, int from_rest)
{
	double t0 = cpu_seconds();
	double *x = malloc(3 * s->count * sizeof *x);
	if (!x)
		return ndo__fail(NDO_ENOMEM, "out of memory re-assembling K");
	positions_aos(s, from_rest ? NULL : s->u, x);
	int rc = ndo_stencil_build(s->level, x, s->p.material.stiffness, &s->st);
	free(x);
	if (rc) {
		char d[256];
		snprintf(d, sizeof d, "%s", ndo_errdetail());
		return ndo__fail(rc, "re-assembling K at step %lld: %s", (long long)s->step, d);
	}
	if ((rc = build_held_edges(s)))
		return rc;
	ndo__implicit_invalidate(s, 0);
	s->stats.restiffened++;
	s->stats.restiffen_seconds += cpu_seconds() - t0;
	return NDO_OK;
}

/* The step whose shape the K of the step from s->step is assembled from:
 * the last multiple of S steps after the run's first step, or that step
 * (the rest shape). */
static int64_t restiffen_step(const ndo_sim *s)
{
	int64_t rel = s->step - s->k_first, S = s->p.restiffen;
	return rel > 0 ? s->k_first + rel / S * S : s->k_first;
}

int ndo__restiffen_pending(const ndo_sim *s)
{
	return s->p.restiffen > 0 && restiffen_step(s) != s->k_at;
}

/* K as the step from s->step reads it.  A single process re-assembles it
 * every S steps from the shape of that step.  A peer that restarted from a
 * checkpoint (ndo_sim_set_time) holds the K of another step, or rows of
 * another region: it re-assembles the step's K from the rest shape or
 * from the state it restarted from, which is that K when the restart step
 * is a multiple of S (the owner puts its checkpoints there); at any other
 * step, from the current shape: not the single process's K (a run that
 * restarted there without a checkpoint is not exact anyway). */
int ndo__restiffen_due(ndo_sim *s)
{
	if (!ndo__restiffen_pending(s))
		return NDO_OK;
	int64_t want = restiffen_step(s);
	int rc = ndo__restiffen(s, want == s->k_first);
	if (rc == NDO_OK)
		s->k_at = want;
	return rc;
}

int ndo__step_tableau(ndo_sim *s, double h)
{
	int rc = step_rk(s, method_tableau(s->p.method), h);
	if (rc == NDO_OK) {
		s->t += h;
		s->step++;
		s->stats.steps++;
	}
	return rc;
}

/* Threads that do not pay: on a machine busy with other work a worker
 * may not run for a while, and a step waits for what it took; or the
 * grid's steps are too short.  So, while the simulation has threads, it
 * looks now and then — PROBE steps alternately alone and on the threads
 * (the first one, a warm-up, not timed) — and takes the faster way until
 * the next look: after probe_period seconds and at least 8 × PROBE steps;
 * the period doubles (up to PROBE_MAX s) while the answer stays and starts
 * again when it changes: at PROBE_MIN s after an answer "alone", so that
 * threads that pay again are soon seen, and at PROBE_THREADS s after an
 * answer "threads".  Between looks the steps on the threads are timed too:
 * once 4 of them take longer on average than the steps alone did in the
 * look, it looks again at once (the load changed), so a look while the
 * threads pay only renews that reference, and half its steps run alone.
 * Either way the bits are the same (the chunks do not depend on the
 * thread count). */
#define PROBE_MIN 0.25
#define PROBE_THREADS 2.0
#define PROBE_MAX 16.0

static double wall_seconds(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Before `steps` steps (with a pool): alone or on the threads (solo);
 * returns whether they are timed. */
static int threads_choose(ndo_sim *s, int64_t steps)
{
	if (s->probe_left == 0 && s->probe_steps >= 8 * PROBE && wall_seconds() >= s->probe_next) {
		s->probe_left = PROBE + 1;
		s->probe_sum[0] = s->probe_sum[1] = 0;
	}
	if (s->probe_left == 0) {
		s->probe_steps += steps;
		return !s->solo;
	}
	s->solo = s->probe_left % 2 == 0;
	return 1;
}

/* Before a step: alone or on the threads (chosen already when the step
 * was begun ahead, for the threads that ran its first units and the
 * layout of rk4's ring); returns the time it starts (to time the look's
 * steps) or 0. */
static double threads_pick(ndo_sim *s, int64_t steps)
{
	if (!s->pool)
		return 0;
	int timed = s->picked ? s->picked - 1 : threads_choose(s, steps);
	s->picked = 0;
	if (s->solo)
		s->stats.steps_alone += steps;
	return timed ? wall_seconds() : 0;
}

/* Whether the next threads_pick() will have the steps run alone. */
static int threads_next_solo(const ndo_sim *s)
{
	if (!s->pool)
		return 1;
	if (s->picked) /* chosen when the step was begun ahead */
		return s->solo;
	int left = s->probe_left;
	if (left == 0 && s->probe_steps >= 8 * PROBE && wall_seconds() >= s->probe_next)
		left = PROBE + 1;
	return left == 0 ? s->solo : left % 2 == 0;
}

/* After `steps` steps (ndo_sim_steps: a run of them, timed as one step
 * of their mean time) that threads_pick() timed from t0. */
static void threads_timed(ndo_sim *s, double t0, int64_t steps)
{
	if (t0 == 0)
		return;
	double now = wall_seconds();
	if (steps > 1)
		t0 = now - (now - t0) / (double)steps;
	if (s->probe_left == 0) { /* a step on the threads between looks */
		s->run_sum += now - t0;
		if (++s->run_n >= 4 && s->run_sum > s->run_n * s->probe_mean[0]) {
			s->probe_next = now; /* look again at the next step */
			s->probe_steps = 8 * PROBE;
			s->probe_period = 0;
		}
		return;
	}
	if (s->probe_left <= PROBE)
		s->probe_sum[s->solo ? 0 : 1] += now - t0;
	if (--s->probe_left > 0)
		return;
	int solo = s->probe_sum[0] < s->probe_sum[1];
	if (s->probe_period > 0 && solo == s->solo_last)
		s->probe_period = fmin(2 * s->probe_period, PROBE_MAX);
	else
		s->probe_period = solo ? PROBE_MIN : PROBE_THREADS;
	s->solo = s->solo_last = solo;
	s->probe_next = now + s->probe_period;
	s->probe_steps = 0;
	s->probe_mean[0] = s->probe_sum[0] / (PROBE / 2);
	s->probe_mean[1] = s->probe_sum[1] / (PROBE / 2);
	s->run_sum = 0, s->run_n = 0;
}

static int sim_step(ndo_sim *s, double h)
{
	ndo__clear_error();
	if (!(h > 0) || !isfinite(h))
		return ndo__fail(NDO_EINVAL, "step size %g: must be positive and finite", h);
	int rc = ndo__restiffen_due(s);
	if (rc)
		return rc;
	double t0 = s->t, w0 = threads_pick(s, 1);
	switch (s->p.method) {
	case NDO_EULER: rc = step_rk(s, method_tableau(s->p.method), h); break;
	case NDO_MIDPOINT:
		rc = fused_fits(s) ? step_midpoint_fused(s, h)
		                   : step_rk(s, method_tableau(s->p.method), h);
		break;
	case NDO_RK4: rc = step_rk4(s, h); break;
	case NDO_SYMPLECTIC_EULER: rc = step_symplectic(s, h); break;
	case NDO_RKF45: rc = step_rkf45(s, h); break;
	default: rc = ndo__implicit_step(s, h); break;
	}
	threads_timed(s, w0, 1);
	if (rc)
		return rc;
	if (s->p.method != NDO_RKF45)
		s->t = t0 + h;
	s->step++;
	s->stats.steps++;
	if (s->sleep) {
		size_t awake, all;
		ndo__sleep_nodes(s->sleep, &awake, &all);
		s->node_steps += (double)awake;
		s->node_steps_all += (double)all;
		if (ndo__sleep_check(s->sleep, s) && (rc = set_active(s, ndo__sleep_mask(s->sleep))))
			return rc;
	}
	return NDO_OK;
}

int ndo_sim_step(ndo_sim *s, double h)
{
	const unsigned fp = ndo_fp_flush();
	int rc = sim_step(s, h);
	ndo_fp_set(fp);
	return rc;
}

/* The runs of steps: RK4's chain (rk4.c) or the wave (wave.c). */
static int run_steps(ndo_sim *s, double h, int m, const double *t)
{
	return s->p.method == NDO_RK4 ? ndo__rk4_chain_run(s, h, m, t) : ndo__wave_run(s, h, m, t);
}

static void run_commit(ndo_sim *s, int m)
{
	if (s->p.method == NDO_RK4)
		ndo__rk4_chain_commit(s, m);
	else
		ndo__wave_commit(s, m);
}

/* m steps of the wave (wave.c) or of RK4's chain (rk4.c) from steps run
 * at times t[0..m): each step's divergence test and accounting in order,
 * as ndo_sim_step makes them; at a step that fails, the run again up to it (the state it
 * started from is still there).  *done: the steps taken — fewer than m
 * when the size test must see a step's state (ndo__size_needs_state):
 * the run again up to that step, whose state is then seen as a single
 * step sees it, and the caller goes on from there. */
static int steps_wave(ndo_sim *s, double h, int m, double *t, int *done)
{
	*done = 0;
	double w0 = threads_pick(s, m);
	t[0] = s->t;
	for (int j = 1; j <= m; j++)
		t[j] = t[j - 1] + h;
	int rc = run_steps(s, h, m, t);
	threads_timed(s, w0, m);
	if (rc)
		return rc;
	const int rk4 = s->p.method == NDO_RK4, two = s->p.method == NDO_MIDPOINT;
	for (int j = 0; j < m; j++) {
		ndo__diag d;
		if (rk4)
			ndo__rk4_chain_diag(s, j, &d);
		else
			ndo__wave_diag(s, j, &d);
		if (s->p.method == NDO_SYMPLECTIC_EULER)
			s->h_mod = h;
		if (ndo__size_needs_state(s, &d)) {
			int again = j > 0 ? run_steps(s, h, j, t) : NDO_OK;
			if (again)
				return again;
			run_commit(s, j);
			*done = j;
			if (ndo__size_is_drift(s, &d))
				return NDO_OK; /* step j again from its state, tested as a drift */
			s->stats.evaluations++;
			s->last_power = d.power;
			return ndo__diverged(s, &d, 1);
		}
		s->stats.evaluations++;
		s->last_power = d.power;
		if ((rc = ndo__diverged(s, &d, 1))) {
			int again = j > 0 ? run_steps(s, h, j, t) : NDO_OK;
			if (again)
				return again;
			run_commit(s, j);
			return rc;
		}
		if (rk4) { /* as step_rk4 */
			ndo__rk4_chain_powers(s, j, d.power); /* into s->stage_power */
			s->stats.evaluations += 3;
			account(s, h, tableau_power(&tb_rk4, s->stage_power));
		} else {
			s->stats.evaluations += two;
			/* midpoint: its stage's force at its mean velocity (step_rk) */
			account(s, h, two ? ndo__wave_power(s, j) : s->last_power);
		}
		s->stats.substeps++;
		s->t = t[j + 1];
		s->step++;
		s->stats.steps++;
	}
	run_commit(s, m);
	*done = m;
	return NDO_OK;
}

static int sim_steps(ndo_sim *s, double h, int64_t k)
{
	ndo__clear_error();
	if (!(h > 0) || !isfinite(h))
		return ndo__fail(NDO_EINVAL, "step size %g: must be positive and finite", h);
	if (k < 0)
		return ndo__fail(NDO_EINVAL, "%lld steps: must be ≥ 0", (long long)k);
	/* The wave where it pays: on the threads (no barrier between the
	 * passes and the steps), and on one thread from 65,536 nodes, where
	 * the state is larger than the caches and a unit finds the rows it
	 * reads still there (measured under load, bench_simulate wave:
	 * 1.15-1.9x one step at a time at levels 8 and 9; 0.87-0.97x at level
	 * 7, where the state stays in the cache anyway and the units'
	 * bookkeeping costs).  So below that size, steps that run alone
	 * (threads_pick) go one at a time, and a look at whether the threads
	 * pay compares those with the wave on the threads.  RK4 takes its own
	 * chain of two steps (rk4.c) the same way. */
	const int rk4 = ndo__rk4_chain_fits(s), fits = rk4 || ndo__wave_fits(s);
	double t[18]; /* a run's times: up to 6 steps (ndo__wave_batch), and one left over */
	while (k > 0) {
		int wave = fits && (s->count >= 65536 || s->wave_test || !threads_next_solo(s));
		int m = k >= 2 && wave ? rk4 ? ndo__rk4_chain_batch(s) : ndo__wave_batch(s) : 0;
		int rc;
		if (m >= 2) {
			/* No single step left over after the runs: a step alone
			 * costs more than a step of a run (bench_simulate wave,
			 * midpoint at level 8 on 2 threads, 2026-11-29: 183 steps/s
			 * one at a time, 217 in runs), and the threads' look times
			 * each call as steps of its mean time, so a single step
			 * among runs reads as the threads slowing down. */
			if (k <= m + 1 && !(rk4 && s->any_held)) /* (rk4.c: two at most) */
				m = (int)k;
			rc = steps_wave(s, h, m, t, &m);
		} else {
			m = 1;
			rc = ndo_sim_step(s, h);
		}
		if (rc)
			return rc;
		k -= m;
	}
	return NDO_OK;
}

int ndo_sim_steps(ndo_sim *s, double h, int64_t k)
{
	const unsigned fp = ndo_fp_flush();
	int rc = sim_steps(s, h, k);
	ndo_fp_set(fp);
	return rc;
}

static int sim_step_begin(ndo_sim *s, double h, size_t n, const int32_t *pending)
{
	ndo__clear_error();
	s->ahead = 0;
	if (!(h > 0) || !isfinite(h))
		return ndo__fail(NDO_EINVAL, "step size %g: must be positive and finite", h);
	/* a re-assembly due at this step reads the pending nodes' state */
	if (s->p.method != NDO_RK4 || !n || s->sleep || ndo__restiffen_pending(s))
		return 0;
	/* the step's threads: the units run now on them, in the ring they lay out */
	if (s->pool && !s->picked)
		s->picked = 1 + threads_choose(s, 1);
	return ndo__rk4_begin(s, h, n, pending);
}

int ndo_sim_step_begin(ndo_sim *s, double h, size_t n, const int32_t *pending)
{
	const unsigned fp = ndo_fp_flush();
	int rc = sim_step_begin(s, h, n, pending);
	ndo_fp_set(fp);
	return rc;
}

/* ---- rkf45 in parts (ndo/sim.h) ---------------------------------------------- */
static int sim_rkf45_begin(ndo_sim *s, double h)
{
	ndo__clear_error();
	if (s->p.method != NDO_RKF45)
		return ndo__fail(NDO_EINVAL, "ndo_sim_rkf45_begin: the method is %s",
		                 ndo_method_names[s->p.method]);
	if (!(h > 0) || !isfinite(h))
		return ndo__fail(NDO_EINVAL, "step size %g: must be positive and finite", h);
	int rc = ndo__restiffen_due(s);
	if (rc)
		return rc;
	rkf45_begin(s, h);
	return NDO_OK;
}

int ndo_sim_rkf45_begin(ndo_sim *s, double h)
{
	const unsigned fp = ndo_fp_flush();
	int rc = sim_rkf45_begin(s, h);
	ndo_fp_set(fp);
	return rc;
}

static int sim_rkf45_attempt(ndo_sim *s, const uint8_t *rows, double *err, double *h)
{
	ndo__clear_error();
	int rc = rkf45_attempt(s, rows, err);
	if (h)
		*h = s->rk_h;
	return rc;
}

int ndo_sim_rkf45_attempt(ndo_sim *s, const uint8_t *rows, double *err, double *h)
{
	const unsigned fp = ndo_fp_flush();
	int rc = sim_rkf45_attempt(s, rows, err, h);
	ndo_fp_set(fp);
	return rc;
}

static int sim_rkf45_decide(ndo_sim *s, double err)
{
	ndo__clear_error();
	int rc = rkf45_decide(s, err);
	if (rc == 1) {
		s->step++;
		s->stats.steps++;
	}
	return rc;
}

int ndo_sim_rkf45_decide(ndo_sim *s, double err)
{
	const unsigned fp = ndo_fp_flush();
	int rc = sim_rkf45_decide(s, err);
	ndo_fp_set(fp);
	return rc;
}

static void sim_rkf45_peek(const ndo_sim *s, size_t n, const int32_t *nodes, double *u, double *v)
{
	/* rk_finish's arithmetic, node by node, in its order (no contraction
	 * into fused multiply-adds under -std=c11: the same bits) */
	const tableau *tb = &tb_rkf45;
	const double h = s->rk_h;
	const size_t cnt = s->count;
	for (size_t k = 0; k < n; k++) {
		size_t p = (size_t)s->canon[nodes[k]];
		for (int c = 0; c < 3; c++) {
			size_t q = (size_t)c * cnt + p;
			double uu = s->u[q], vv = s->v[q];
			if (s->active[p]) {
				for (int j = 1; j < tb->s; j++)
					if (tb->b[j] != 0)
						uu += h * tb->b[j] * s->kv[j][q];
				if (tb->b[0] != 0)
					uu += h * tb->b[0] * s->v[q];
				for (int j = 0; j < tb->s; j++)
					if (tb->b[j] != 0)
						vv += h * tb->b[j] * s->ka[j][q];
			}
			u[3 * k + c] = uu;
			v[3 * k + c] = vv;
		}
	}
}

void ndo_sim_rkf45_peek(const ndo_sim *s, size_t n, const int32_t *nodes, double *u, double *v)
{
	const unsigned fp = ndo_fp_flush();
	sim_rkf45_peek(s, n, nodes, u, v);
	ndo_fp_set(fp);
}

double ndo_sim_rkf45_substep(const ndo_sim *s) { return s->h_sub; }

void ndo_sim_rkf45_set_substep(ndo_sim *s, double h)
{
	s->h_sub = h > 0 && isfinite(h) ? h : 0;
}

void ndo_sim_rkf45_abort(ndo_sim *s)
{
	s->t = s->rk_t0;
	s->h_sub = s->rk_hsub0;
	s->work = s->rk_undo.work;
	s->work_abs = s->rk_undo.work_abs;
	s->pend_h = s->rk_undo.pend_h;
	s->pend_power = s->rk_undo.pend_power;
	s->e0 = s->rk_undo.e0;
	s->e0_set = s->rk_undo.e0_set;
	s->udrift = s->rk_undo.udrift;
	s->stats.substeps = s->rk_undo.substeps;
	s->stats.rejected = s->rk_undo.rejected;
	s->stats.last_substep = s->rk_undo.last_substep;
}
