/* accel.c — the membrane's acceleration a = M⁻¹(f − K u) − γ v (thesis
 * §4.3, appendix B) with the energy diagnostics, the external force plane,
 * and the divergence test: what the explicit integrators (integrate.c) and
 * the implicit ones (implicit.c) both evaluate, below both. */
#include "sim_private.h"
#include "ndo/status.h"
#include "ndo/topology.h"

#include <math.h>
#include <string.h>

void ndo__sync_planes(const ndo_sim *s, double *planes, int nplanes)
{
	for (int c = 0; c < nplanes; c++)
		ndo_sync(s->level, planes + (size_t)c * s->count, sizeof(double));
}

/* ---- the acceleration ------------------------------------------------------ */

/* a = M⁻¹(f − K u) − γ v over the interior runs, stored in a or (upd, a
 * constant NDO__UPD_*) used at once as up says.  hasF, hasD and upd are
 * constants at each call site, so the compiler emits a loop for each,
 * the plain ones free to vectorize. */
static inline __attribute__((always_inline)) void
accel_interior(const ndo_sim *s, const double *restrict u, const double *restrict v,
               const double *restrict F, double *restrict a, const ndo__upd *up,
               ndo__diag *d, const int hasF, const int hasD, const int upd, const size_t k0,
               const size_t k1)
{
	const size_t cnt = s->count, w = (size_t)s->w;
	const double *restrict e0 = s->st.e[0], *restrict e1 = s->st.e[1],
	                       *restrict e2 = s->st.e[2];
	const double *restrict minv = s->minv, *restrict mass = s->mass;
	/* The damping rate is the same at every node (integrate.c: b/ρ + a,
	 * as rk4.c and implicit.c take it): one number, not a plane. */
	const double ga = s->gam[0];
	const double *restrict ux = u, *restrict uy = u + cnt, *restrict uz = u + 2 * cnt;
	const double *restrict vx = v, *restrict vy = v + cnt, *restrict vz = v + 2 * cnt;
	double *restrict ax = a, *restrict ay = a + cnt, *restrict az = a + 2 * cnt;
	const double h = upd ? up->h : 0;
	double *restrict uox = upd ? up->uo : NULL, *restrict uoy = upd ? up->uo + cnt : NULL,
	                 *restrict uoz = upd ? up->uo + 2 * cnt : NULL;
	double *restrict vox = upd ? up->vo : NULL, *restrict voy = upd ? up->vo + cnt : NULL,
	                 *restrict voz = upd ? up->vo + 2 * cnt : NULL;
	const int full = upd == NDO__UPD_FULL;
	const double *restrict u0x = full ? up->u0 : NULL, *restrict u0y = full ? up->u0 + cnt : NULL,
	                       *restrict u0z = full ? up->u0 + 2 * cnt : NULL;
	const double *restrict v0x = full ? up->v0 : NULL, *restrict v0y = full ? up->v0 + cnt : NULL,
	                       *restrict v0z = full ? up->v0 + 2 * cnt : NULL;
	double pe2 = 0, ke2 = 0, pw = 0, um = 0, vku = 0;
	/* the input power at ½(v + v'), v' = v + h a (ndo__power_velocity) */
#define SE_POWER (upd == NDO__UPD_SYMPLECTIC || upd == NDO__UPD_STORE_SE)
	for (size_t k = k0; k < k1; k++) {
		const size_t lo = (size_t)s->ispan[k].a, hi = (size_t)s->ispan[k].b;
		/* Four nodes at a time (sim_private.h, ndo__v4), then the rest one
		 * at a time, one text for both (T the type, L a load, S a store, Z
		 * T's zero); the diagnostics summed as GCC's AVX2 reduction of the
		 * omp simd loop this replaced summed them (a sum a lane Pe.. over
		 * the four-node steps, the last 0-3 nodes into lane 0, then the
		 * lanes into the running sum in order; the largest |u|² Um
		 * likewise): the same bits as before. */
#define ACCEL_NODE(T, L, S, Z, Pe, Ke, Pw, Vk, UMAX)                                        \
	do {                                                                                \
		const T c0 = L(e0 + p), c1 = L(e1 + p), c2 = L(e2 + p), c3 = L(e0 + p - 1),     \
		        c4 = L(e1 + p - w), c5 = L(e2 + p - w + 1);                              \
		const T kx = ACCEL_KU(ux, L), ky = ACCEL_KU(uy, L), kz = ACCEL_KU(uz, L);        \
		const T fx = hasF ? L(F + p) : Z, fy = hasF ? L(F + cnt + p) : Z,               \
		        fz = hasF ? L(F + 2 * cnt + p) : Z;                                      \
		const T Vx = L(vx + p), Vy = L(vy + p), Vz = L(vz + p);                         \
		const T Ux = L(ux + p), Uy = L(uy + p), Uz = L(uz + p), mi = L(minv + p);       \
		const T gx = mi * (fx - kx) - ga * Vx;                                          \
		const T gy = mi * (fy - ky) - ga * Vy;                                          \
		const T gz = mi * (fz - kz) - ga * Vz;                                          \
		/* symplectic Euler's new velocity */                                           \
		const T nx = Vx + h * gx, ny = Vy + h * gy, nz = Vz + h * gz;                   \
		if (upd == NDO__UPD_SYMPLECTIC) {                                               \
			S(vox + p, nx), S(voy + p, ny), S(voz + p, nz);                             \
			S(uox + p, Ux + h * nx), S(uoy + p, Uy + h * ny), S(uoz + p, Uz + h * nz);  \
		} else if (upd == NDO__UPD_HALF) {                                              \
			/* the tableau's combination: acc = 0, acc += ½ x, base + h acc */          \
			const T sx = Z + 0.5 * Vx, sy = Z + 0.5 * Vy, sz = Z + 0.5 * Vz;            \
			const T tx = Z + 0.5 * gx, ty = Z + 0.5 * gy, tz = Z + 0.5 * gz;            \
			S(uox + p, Ux + h * sx), S(uoy + p, Uy + h * sy), S(uoz + p, Uz + h * sz);  \
			S(vox + p, Vx + h * tx), S(voy + p, Vy + h * ty), S(voz + p, Vz + h * tz);  \
		} else if (upd == NDO__UPD_FULL) {                                              \
			S(uox + p, L(u0x + p) + h * Vx), S(uoy + p, L(u0y + p) + h * Vy);           \
			S(uoz + p, L(u0z + p) + h * Vz);                                            \
			S(vox + p, L(v0x + p) + h * gx), S(voy + p, L(v0y + p) + h * gy);           \
			S(voz + p, L(v0z + p) + h * gz);                                            \
		} else {                                                                        \
			S(ax + p, gx), S(ay + p, gy), S(az + p, gz);                                \
		}                                                                               \
		if (hasD) {                                                                     \
			Pe += Ux * kx + Uy * ky + Uz * kz;                                          \
			Ke += L(mass + p) * (Vx * Vx + Vy * Vy + Vz * Vz);                          \
			if (SE_POWER) /* 2 × the step's mean power (below) */                       \
				Pw += fx * (Vx + nx) + fy * (Vy + ny) + fz * (Vz + nz);                 \
			else                                                                        \
				Pw += fx * Vx + fy * Vy + fz * Vz;                                      \
			Vk += Vx * kx + Vy * ky + Vz * kz;                                          \
			UMAX(Ux * Ux + Uy * Uy + Uz * Uz);                                          \
		}                                                                               \
	} while (0)
#define ACCEL_KU(U, L)                                                                    \
	(c0 * (L(U + p) - L(U + p + 1)) + c1 * (L(U + p) - L(U + p + w)) +                 \
	 c2 * (L(U + p) - L(U + p + w - 1)) + c3 * (L(U + p) - L(U + p - 1)) +             \
	 c4 * (L(U + p) - L(U + p - w)) + c5 * (L(U + p) - L(U + p - w + 1)))
/* the largest |u|²: a select (a libm fmax stops vectorization) */
#define UMAX4(u2)                                                                         \
	do {                                                                              \
		const ndo__v4 u2_ = (u2);                                                     \
		const ndo__v4i gt = u2_ > Um;                                                 \
		Um = (ndo__v4)(((ndo__v4i)u2_ & gt) | ((ndo__v4i)Um & ~gt));                  \
	} while (0)
#define UMAX1(u2)                                                                         \
	do {                                                                              \
		const double u2_ = (u2);                                                      \
		M0 = u2_ > M0 ? u2_ : M0;                                                     \
	} while (0)
		size_t p = lo;
		ndo__v4 Pe = {0, 0, 0, 0}, Ke = Pe, Pw = Pe, Vk = Pe, Um = Pe;
		const size_t vend = s->scalar_loops ? lo : hi;
		for (; p + 4 <= vend; p += 4)
			ACCEL_NODE(ndo__v4, V4_LD, V4_ST, ((ndo__v4){0, 0, 0, 0}), Pe, Ke, Pw, Vk, UMAX4);
		double P0 = Pe[0], K0 = Ke[0], W0 = Pw[0], V0 = Vk[0], M0 = Um[0];
		for (; p < hi; p++)
			ACCEL_NODE(double, V1_LD, V1_ST, 0.0, P0, K0, W0, V0, UMAX1);
#undef UMAX1
#undef UMAX4
#undef ACCEL_KU
#undef ACCEL_NODE
		if (hasD) {
			pe2 += P0, pe2 += Pe[1], pe2 += Pe[2], pe2 += Pe[3];
			ke2 += K0, ke2 += Ke[1], ke2 += Ke[2], ke2 += Ke[3];
			pw += W0, pw += Pw[1], pw += Pw[2], pw += Pw[3];
			vku += V0, vku += Vk[1], vku += Vk[2], vku += Vk[3];
			const double ml[4] = {M0, Um[1], Um[2], Um[3]};
			for (int l = 0; l < 4; l++)
				um = ml[l] > um ? ml[l] : um;
		}
	}
	if (hasD) {
		ndo__diag_add(d, pe2, ke2, SE_POWER ? 0.5 * pw : pw, um);
		d->vku += vku;
	}
#undef SE_POWER
}

/* The acceleration at one component of a node, used as up says (or
 * stored in a when up is NULL). */
static void border_update(const ndo_sim *s, const ndo__upd *up, double *a, const double *u,
                          const double *v, size_t q, double g)
{
	if (!up || up->mode == NDO__UPD_STORE_SE) {
		a[q] = g;
		return;
	}
	const double h = up->h;
	if (up->mode == NDO__UPD_SYMPLECTIC) {
		up->vo[q] = v[q] + h * g;
		up->uo[q] = u[q] + h * up->vo[q];
	} else if (up->mode == NDO__UPD_HALF) {
		double su = 0, sv = 0;
		su += 0.5 * v[q];
		sv += 0.5 * g;
		up->uo[q] = u[q] + h * su;
		up->vo[q] = v[q] + h * sv;
	} else {
		up->uo[q] = up->u0[q] + h * v[q];
		up->vo[q] = up->v0[q] + h * g;
	}
}

/* The active border nodes, through their neighbour tables: bact[list[i]]
 * for i in 0..n−1, or every one (list NULL).  Diagnostics go to d, or
 * (the wave, wave.c) to terms, NDO__BTERMS per node at its place in bact,
 * to be added in the border's order afterwards. */
static void accel_border(const ndo_sim *s, const double *u, const double *v, const double *F,
                         double *a, const ndo__upd *up, const int32_t *list, size_t n,
                         ndo__diag *d, double *terms)
{
	const size_t cnt = s->count;
	for (size_t i = 0; i < n; i++) {
		const size_t k = list ? (size_t)list[i] : i;
		size_t b = (size_t)s->bact[k];
		size_t p = (size_t)s->st.border[b];
		const int32_t *nb = s->st.bnb + 6 * b;
		const double *cf = s->st.bc + 6 * b;
		double *t = terms ? terms + NDO__BTERMS * k : NULL;
		for (int c = 0; c < 3; c++) {
			const double *U = u + (size_t)c * cnt;
			double ku = 0;
			for (int q = 0; q < 6; q++)
				ku += cf[q] * (U[p] - U[nb[q]]);
			double f = F ? F[(size_t)c * cnt + p] : 0, vc = v[(size_t)c * cnt + p];
			border_update(s, up, a, u, v, (size_t)c * cnt + p,
			              s->minv[p] * (f - ku) - s->gam[p] * vc);
			const double vp = ndo__power_velocity(up, v, (size_t)c * cnt + p);
			if (d) {
				d->pe2 += U[p] * ku;
				d->vku += vc * ku;
				d->ke2 += s->mass[p] * vc * vc;
				d->power += f * vp;
			}
			if (t) {
				t[4 * c] = U[p] * ku;
				t[4 * c + 1] = vc * ku;
				t[4 * c + 2] = s->mass[p] * vc * vc;
				t[4 * c + 3] = f * vp;
			}
		}
		const double u2 = u[p] * u[p] + u[cnt + p] * u[cnt + p] + u[2 * cnt + p] * u[2 * cnt + p];
		if (d)
			d->umax2 = fmax(d->umax2, u2);
		if (t)
			t[12] = u2;
	}
}

void ndo__accel_border_nodes(const ndo_sim *s, const double *u, const double *v, const double *F,
                             const ndo__upd *up, const int32_t *list, size_t n, double *terms)
{
	accel_border(s, u, v, F, NULL, up, list, n, NULL, terms);
}

void ndo__border_terms_sum(const ndo_sim *s, const double *terms, ndo__diag *d)
{
	memset(d, 0, sizeof *d);
	for (size_t k = 0; k < s->nbact; k++) {
		const double *t = terms + NDO__BTERMS * k;
		for (int c = 0; c < 3; c++) {
			d->pe2 += t[4 * c];
			d->vku += t[4 * c + 1];
			d->ke2 += t[4 * c + 2];
			d->power += t[4 * c + 3];
		}
		d->umax2 = fmax(d->umax2, t[12]);
	}
}

/* A stage buffer's held nodes at the state's displacement u: only those an
 * active node reads (the others are never read), so a peer's step costs
 * its region, not the whole grid (a full copy was 2·3·count doubles a step).
 * Their duplicates are in the list (u's agree with their canonical nodes'):
 * no sync of the whole buffer's seams (a memcpy call a node, three planes,
 * seven times a step of the pipeline). */
void ndo__held_keep(ndo_sim *s, double *buf)
{
	const size_t cnt = s->count;
	for (size_t k = 0; k < s->nhread; k++)
		for (int c = 0; c < 3; c++) {
			size_t q = (size_t)c * cnt + (size_t)s->hread[k];
			buf[q] = s->u[q];
		}
}

/* Held nodes at the time τ after the state's: buf = u + τ v on them (the
 * boundary moving with its velocity, ndo_sim_set_held_motion). */
void ndo__held_at(ndo_sim *s, double *buf, double tau)
{
	if (!s->held_motion || !s->nhmove)
		return;
	const size_t cnt = s->count;
	for (size_t k = 0; k < s->nhmove; k++)
		for (int c = 0; c < 3; c++) {
			size_t q = (size_t)c * cnt + (size_t)s->hmove[k];
			buf[q] = s->u[q] + tau * s->v[q];
		}
}

/* The power the held nodes put into the active ones: Σ v_p · c u_q over
 * the edges from an active p to a held q (the part of −K u that the held
 * displacements contribute).  Only for the divergence bound. */
double ndo__held_power(const ndo_sim *s, const double *u, const double *v, const ndo__upd *up)
{
	const size_t cnt = s->count;
	double pw = 0;
	for (size_t k = 0; k < s->nhedge; k++) {
		size_t p = (size_t)s->hedge[k].p, q = (size_t)s->hedge[k].q;
		for (int c = 0; c < 3; c++)
			pw += ndo__power_velocity(up, v, (size_t)c * cnt + p) * s->hedge[k].c *
			      u[(size_t)c * cnt + q];
	}
	return pw;
}

const double *ndo__forces_prepare(ndo_sim *s, double t, const double *u)
{
	if (!s->f)
		return NULL;
	const size_t cnt = s->count;
	for (size_t k = 0; k < s->npen; k++)
		for (int c = 0; c < 3; c++)
			s->f[(size_t)c * cnt + (size_t)s->pen[k]] = 0;
	if (s->has_forces)
		ndo__forces_eval(s, t, u);
	/* Payne–Irons penalty springs (thesis §4.3.3) to the pins' initial
	 * positions: a force like any other, so every kernel handles them. */
	for (size_t k = 0; k < s->npen; k++) {
		size_t p = (size_t)s->pen[k];
		for (int c = 0; c < 3; c++)
			s->f[(size_t)c * cnt + p] -=
				s->alpha * (u[(size_t)c * cnt + p] - s->pen_target[3 * k + c]);
	}
	return s->f;
}

/* The kernels counted the penalty springs as forces: move their share
 * from the input power to the potential energy. */
void ndo__penalty_diag(const ndo_sim *s, const double *u, const double *v, const ndo__upd *up,
                       ndo__diag *d)
{
	const size_t cnt = s->count;
	for (size_t k = 0; k < s->npen; k++) {
		size_t p = (size_t)s->pen[k];
		if (!s->active[p])
			continue;
		for (int c = 0; c < 3; c++) {
			double du = u[(size_t)c * cnt + p] - s->pen_target[3 * k + c];
			d->pe2 += s->alpha * du * du;
			d->power += s->alpha * du * ndo__power_velocity(up, v, (size_t)c * cnt + p);
			d->vku += s->alpha * du * v[(size_t)c * cnt + p];
		}
	}
}

/* One chunk of the acceleration: interior runs, or (the last chunk) the
 * border nodes. */
typedef struct accel_job {
	const ndo_sim *s;
	const double *u, *v, *F;
	double *a;
	const ndo__upd *up;
	int diag;
} accel_job;

/* The interior loops of one update mode (a constant): with or without
 * forces and diagnostics. */
#define ACCEL_RUNS(UPD)                                                                          \
	do {                                                                                     \
		if (d && j->F)                                                                   \
			accel_interior(s, j->u, j->v, j->F, j->a, j->up, d, 1, 1, UPD, k0, k1);     \
		else if (d)                                                                      \
			accel_interior(s, j->u, j->v, NULL, j->a, j->up, d, 0, 1, UPD, k0, k1);     \
		else if (j->F)                                                                   \
			accel_interior(s, j->u, j->v, j->F, j->a, j->up, NULL, 1, 0, UPD, k0, k1);  \
		else                                                                             \
			accel_interior(s, j->u, j->v, NULL, j->a, j->up, NULL, 0, 0, UPD, k0, k1);  \
	} while (0)

/* The acceleration stored (j->up NULL) or used at once as j->up says. */
NDO_HOT static void accel_chunk(void *arg, int c)
{
	const accel_job *j = arg;
	const ndo_sim *s = j->s;
	ndo__diag *d = j->diag ? &s->cdiag[c] : NULL;
	if (d)
		memset(d, 0, sizeof *d);
	if (c == s->nichunk) {
		accel_border(s, j->u, j->v, j->F, j->a, j->up, NULL, s->nbact, d, NULL);
		return;
	}
	const size_t k0 = (size_t)s->ichunk[c], k1 = (size_t)s->ichunk[c + 1];
	switch (j->up ? j->up->mode : 0) {
	case 0: ACCEL_RUNS(0); break;
	case NDO__UPD_SYMPLECTIC: ACCEL_RUNS(NDO__UPD_SYMPLECTIC); break;
	case NDO__UPD_HALF: ACCEL_RUNS(NDO__UPD_HALF); break;
	case NDO__UPD_STORE_SE: ACCEL_RUNS(NDO__UPD_STORE_SE); break;
	default: ACCEL_RUNS(NDO__UPD_FULL);
	}
}

/* Interior runs [k0, k1) used at once as up says (the wave, wave.c). */
NDO_HOT void ndo__accel_runs(const ndo_sim *s, const double *u, const double *v, const double *F,
                             const ndo__upd *up, ndo__diag *d, size_t k0, size_t k1)
{
	const accel_job jj = {s, u, v, F, NULL, up, d != NULL}, *j = &jj;
	switch (up->mode) {
	case NDO__UPD_SYMPLECTIC: ACCEL_RUNS(NDO__UPD_SYMPLECTIC); break;
	case NDO__UPD_HALF: ACCEL_RUNS(NDO__UPD_HALF); break;
	default: ACCEL_RUNS(NDO__UPD_FULL);
	}
}
#undef ACCEL_RUNS

void ndo__diag_sum(const ndo_sim *s, ndo__diag *d)
{
	memset(d, 0, sizeof *d);
	for (int c = 0; c <= s->nichunk; c++) {
		ndo__diag_add(d, s->cdiag[c].pe2, s->cdiag[c].ke2, s->cdiag[c].power, s->cdiag[c].umax2);
		d->vku += s->cdiag[c].vku;
	}
}

static void accel_run(ndo_sim *s, double t, const double *u, const double *v, double *a,
                      const ndo__upd *up, ndo__diag *d)
{
	accel_job j = {s, u, v, ndo__forces_prepare(s, t, u), a, up, d != NULL};
	ndo__sim_run(s, s->nichunk + 1, accel_chunk, &j);
	if (d) {
		ndo__diag_sum(s, d);
		d->power += ndo__held_power(s, u, v, up);
		ndo__penalty_diag(s, u, v, up, d);
	}
	s->stats.evaluations++;
}

void ndo__accel(ndo_sim *s, double t, const double *u, const double *v, double *a, ndo__diag *d)
{
	accel_run(s, t, u, v, a, NULL, d);
}

void ndo__accel_update(ndo_sim *s, double t, const double *u, const double *v,
                       const ndo__upd *up, ndo__diag *d)
{
	accel_run(s, t, u, v, up->mode == NDO__UPD_STORE_SE ? up->a : NULL, up, d);
}

/* ---- the input work -------------------------------------------------------- */

double ndo__stage_power(const ndo_sim *s, const double *F, const double *U, const ndo__vel *w)
{
	const size_t cnt = s->count;
	double pw = 0;
	if (F && s->has_pressure)
		for (size_t k = 0; k < s->nespan; k++)
			for (size_t p = (size_t)s->espan[k].a; p < (size_t)s->espan[k].b; p++)
				pw += ndo__fv(F, w, p, cnt);
	else if (F)
		for (size_t k = 0; k < s->nfnodes; k++)
			if (s->active[s->fnodes[k]])
				pw += ndo__fv(F, w, (size_t)s->fnodes[k], cnt);
	/* f holds the springs' −α (u − x̄) at the pins: theirs is potential
	 * energy (ndo__penalty_diag), not input */
	for (size_t k = 0; F && k < s->npen; k++) {
		const size_t p = (size_t)s->pen[k];
		if (!s->active[p] || !s->pen_forced[k])
			continue;
		for (int c = 0; c < 3; c++)
			pw += s->alpha * (U[(size_t)c * cnt + p] - s->pen_target[3 * k + c]) *
			      ndo__vel_at(w, c, p);
	}
	double hp = 0;
	for (size_t k = 0; k < s->nhedge; k++)
		for (int c = 0; c < 3; c++)
			hp += ndo__held_term(s, &s->hedge[k], U, w, c);
	return pw + hp;
}

double ndo__stage_power_sum(const ndo_sim *s, const double *ft, const double *et)
{
	double pw = 0, hp = 0;
	for (size_t k = 0; k < s->nfnodes; k++)
		if (s->active[s->fnodes[k]])
			pw += ft[k];
	for (size_t k = 0; k < 3 * s->nhedge; k++)
		hp += et[k];
	return pw + hp;
}

/* ---- divergence ------------------------------------------------------------ */

/* Each step closes its own work (integrate.c, account): the work so far
 * is the committed work and the last step's. */
void ndo__pending_work(const ndo_sim *s, double *w, double *w_abs)
{
	*w = s->work + s->pend_h * s->pend_power;
	*w_abs = s->work_abs + s->pend_h * fabs(s->pend_power);
}

/* The largest distance of an integrated node's displacement, or a
 * projected pin's, from the integrated nodes' mass-weighted mean (mean:
 * that mean).  The pins count: they are the body's nodes as much as the
 * others, and a free part driven 1,000 box diagonals from the pins it
 * hangs on, barely deformed itself, is a body stretched 1,000 diagonals —
 * until 2026-12-01 the test measured the integrated nodes alone and let
 * it run, while the peers' messages, which bound one message's nodes to
 * 1 + 2 · NDO_SIM_DEFORM_MAX diagonals of each other, dropped the halos
 * that held a pin and such a node, and a 2-peer run stalled. */
double ndo__deformation(const ndo_sim *s, double mean[3], int *pin)
{
	const size_t cnt = s->count;
	double m = 0, su[3] = {0, 0, 0}, dev2 = 0;
	for (size_t k = 0; k < s->nespan; k++)
		for (int32_t p = s->espan[k].a; p < s->espan[k].b; p++) {
			m += s->mass[p];
			for (int e = 0; e < 3; e++)
				su[e] += s->mass[p] * s->u[(size_t)e * cnt + (size_t)p];
		}
	for (int e = 0; e < 3; e++)
		mean[e] = m > 0 ? su[e] / m : 0;
	for (size_t k = 0; k < s->nespan; k++)
		for (int32_t p = s->espan[k].a; p < s->espan[k].b; p++) {
			double r2 = 0;
			for (int e = 0; e < 3; e++) {
				double r = s->u[(size_t)e * cnt + (size_t)p] - mean[e];
				r2 += r * r;
			}
			dev2 = fmax(dev2, r2);
		}
	double pin2 = 0;
	for (size_t k = 0; k < s->nppin; k++) {
		const size_t p = (size_t)s->ppin[k];
		double r2 = 0;
		for (int e = 0; e < 3; e++) {
			double r = s->u[(size_t)e * cnt + p] - mean[e];
			r2 += r * r;
		}
		pin2 = fmax(pin2, r2);
	}
	if (pin)
		*pin = pin2 > dev2;
	return sqrt(fmax(dev2, pin2));
}

/* The largest |u| of a node the size test measures: an integrated one's
 * (d, NaN kept) or a projected pin's. */
static double size_umax(const ndo_sim *s, const ndo__diag *d)
{
	const double umax = sqrt(d->umax2);
	return s->upin > umax ? s->upin : umax;
}

int ndo__size_needs_state(const ndo_sim *s, const ndo__diag *d)
{
	const double umax = size_umax(s, d);
	return umax > NDO_SIM_DEFORM_MAX * s->rest_size && umax > s->udrift;
}

int ndo__size_is_drift(ndo_sim *s, const ndo__diag *d)
{
	double mean[3];
	if (!(ndo__deformation(s, mean, NULL) <= NDO_SIM_DEFORM_MAX * s->rest_size))
		return 0;
	s->udrift = size_umax(s, d) + s->rest_size;
	return 1;
}

int ndo__diverged(ndo_sim *s, const ndo__diag *d, int commit)
{
	double work, work_abs;
	ndo__pending_work(s, &work, &work_abs);
	if (commit) {
		s->work = work;
		s->work_abs = work_abs;
		s->pend_h = 0;
	}
	/* Symplectic Euler conserves not E = ½(vᵀMv + uᵀKu) but its modified
	 * energy Ẽ = ½(vᵀMv + uᵀKu − h vᵀKu) (for v ← v + h a(u), then
	 * u ← u + h v: Ẽ(uₙ₊₁, vₙ₊₁) = ½(vₙ₊₁ᵀM vₙ + uₙᵀK uₙ) = Ẽ(uₙ, vₙ)).  E
	 * itself swings by (1 + hω/2)/(1 − hω/2) over a period — 19× at
	 * 0.9 × the critical step — which a bound on E would call divergence.
	 * Ẽ is positive definite exactly while hω < 2, the method's stability
	 * limit, so a bound on Ẽ still catches a step too large. */
	double E = 0.5 * (d->pe2 + d->ke2);
	if (s->p.method == NDO_SYMPLECTIC_EULER && s->h_mod > 0)
		E = 0.5 * (d->pe2 + d->ke2 - s->h_mod * d->vku);
	if (!isfinite(E) || !isfinite(d->umax2) || !isfinite(d->power))
		return ndo__fail(NDO_EDIVERGED, "the state is not finite (NaN or Inf)");
	double umax = size_umax(s, d);
	if (ndo__size_needs_state(s, d)) {
		/* Beyond 100 × the object's size from rest: a free body may have
		 * got there whole (the thesis' figure 5.3, level 4, a stable step:
		 * its mean momentum carried it 348 m by t = 4,698 s, and the test
		 * of |u| alone stopped the run).  What diverges is the shape: the
		 * test is on each node's distance from where the body's mean
		 * displacement puts it, measured here (a pass over the nodes, made
		 * again only once some node has gone a size further). */
		int pin;
		double mean[3], dev = ndo__deformation(s, mean, &pin);
		if (!(dev <= NDO_SIM_DEFORM_MAX * s->rest_size))
			return ndo__fail(NDO_EDIVERGED,
			                 "a %snode is %.3g m from where the body's mean displacement "
			                 "(%.3g m) puts it, more than 100 × the object's size (%.3g m)",
			                 pin ? "pinned " : "", dev,
			                 sqrt(mean[0] * mean[0] + mean[1] * mean[1] + mean[2] * mean[2]),
			                 s->rest_size);
		if (commit)
			s->udrift = umax + s->rest_size;
	}
	if (!s->e0_set) {
		/* A region's energy (its rows of uᵀKu) can be negative: the
		 * cross terms with held neighbours.  The bound takes its size. */
		s->e0 = fabs(E);
		s->e0_set = 1;
	}
	/* The floor: the energy of a displacement of 1e-9 × the object's
	 * size everywhere, so that rounding noise around a state at rest is
	 * not mistaken for growth. */
	double floor = 1e-18 * s->p.material.stiffness * s->rest_size * s->rest_size;
	work_abs -= s->work_abs_base;
	if (s->p.energy_bound > 0 && E > s->p.energy_bound * (s->e0 + work_abs) + floor)
		return ndo__fail(NDO_EDIVERGED,
		                 "energy %.3g J exceeds %g × (initial %.3g J + input work %.3g J)", E,
		                 s->p.energy_bound, s->e0, work_abs);
	return NDO_OK;
}

int ndo_sim_check(ndo_sim *s)
{
	ndo__clear_error();
	ndo__diag d;
	ndo__accel(s, s->t, s->u, s->v, s->tmp, &d);
	return ndo__diverged(s, &d, 0);
}

void ndo_sim_energy_get(ndo_sim *s, ndo_sim_energy *e)
{
	const size_t cnt = s->count;
	double ke2 = 0, pe2 = 0, um = 0;
	for (int c = 0; c < 3; c++)
		ndo_stencil_apply(&s->st, s->u + (size_t)c * cnt, s->tmp + (size_t)c * cnt);
	for (size_t p = 0; p < cnt; p++) {
		if (s->canon[p] != (int32_t)p)
			continue;
		double u2 = 0;
		for (int c = 0; c < 3; c++) {
			size_t q = (size_t)c * cnt + p;
			ke2 += s->mass[p] * s->v[q] * s->v[q];
			pe2 += s->u[q] * s->tmp[q];
			u2 += s->u[q] * s->u[q];
		}
		um = fmax(um, u2);
	}
	for (size_t k = 0; k < s->npen; k++)
		for (int c = 0; c < 3; c++) {
			double du = s->u[(size_t)c * cnt + (size_t)s->pen[k]] - s->pen_target[3 * k + c];
			pe2 += s->alpha * du * du;
		}
	double wabs;
	e->kinetic = 0.5 * ke2;
	e->potential = 0.5 * pe2;
	ndo__pending_work(s, &e->work, &wabs);
	e->max_displacement = sqrt(um);
}
