/* resample.cpp — the tetrahedral domain on the sphere, its rotation, and
 * the resampling of every grid node from the parameterized surface
 * (thesis §4.2.2.2; Praun & Hoppe 2003, §5). */
#include "remesh.h"

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>

#include <cmath>
#include <random>
#include <stdexcept>

namespace remesh {

using KS = CGAL::Simple_cartesian<double>;
using Tri3 = KS::Triangle_3;
using TriIt = std::vector<Tri3>::const_iterator;
using Prim = CGAL::AABB_triangle_primitive<KS, TriIt>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<KS, Prim>>;

struct SphereLocator {
	const Mesh &m;
	const std::vector<Vec3> &s;
	std::vector<Tri3> tris;
	Tree tree;
	SphereLocator(const Mesh &mesh, const std::vector<Vec3> &sphere) : m(mesh), s(sphere) {}
};

void domain_points(DomainMap map, int level, std::vector<Vec3> &d)
{
	int n = 1 << level, w = 2 * n + 1;
	d.resize((size_t)w * (n + 1));
	if (map == DomainMap::Spring) {
		/* 30 damped sweeps per level: the area spread stops changing in
		 * the third decimal by then (docs/remesh.md) */
		if (ndo_domain_spring(level, 30, d[0].data()) != NDO_OK)
			throw std::runtime_error(ndo_errdetail());
		return;
	}
	for (int j = 0; j <= n; j++)
		for (int i = 0; i <= 2 * n; i++) {
			int face;
			double b[3];
			ndo_domain_locate(level, i, j, &face, b);
			ndo_domain_sphere(map == DomainMap::Gnomonic ? NDO_MAP_GNOMONIC : NDO_MAP_EQUAL_AREA,
			                  face, b, d[ndo_node(w, i, j)].data());
		}
}

SphereLocator *locator_create(const Mesh &m, const std::vector<Vec3> &s)
{
	SphereLocator *l = new SphereLocator(m, s);
	l->tris.reserve(m.f.size());
	for (const Tri &t : m.f) {
		const Vec3 &a = s[t[0]], &b = s[t[1]], &c = s[t[2]];
		l->tris.emplace_back(KS::Point_3(a[0], a[1], a[2]), KS::Point_3(b[0], b[1], b[2]),
		                     KS::Point_3(c[0], c[1], c[2]));
	}
	l->tree.insert(l->tris.cbegin(), l->tris.cend());
	l->tree.build();
	return l;
}

void locator_destroy(SphereLocator *l) { delete l; }

static double det3(const Vec3 &a, const Vec3 &b, const Vec3 &c)
{
	return a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
	       a[2] * (b[0] * c[1] - b[1] * c[0]);
}

Vec3 locate(const SphereLocator *l, const Vec3 &q)
{
	/* The chord triangles of a bijective parameterization tile a polyhedron
	 * star-shaped about the origin: the ray from the origin through q
	 * meets exactly one (or an edge or corner two or more share). */
	KS::Ray_3 ray(KS::Point_3(0, 0, 0), KS::Vector_3(q[0], q[1], q[2]));
	auto hit = l->tree.any_intersected_primitive(ray);
	int fi;
	if (hit) {
		fi = (int)(*hit - l->tris.cbegin());
	} else {
		/* a ray that slips through a crack between chord triangles in
		 * floating point: take the nearest chord triangle */
		double r = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
		auto cp = l->tree.closest_point_and_primitive(KS::Point_3(q[0] / r, q[1] / r, q[2] / r));
		fi = (int)(cp.second - l->tris.cbegin());
	}
	const Tri &t = l->m.f[fi];
	const Vec3 &a = l->s[t[0]], &b = l->s[t[1]], &c = l->s[t[2]];
	/* central projection: q ∝ α a + β b + γ c, α + β + γ = 1 */
	double la = det3(q, b, c), lb = det3(a, q, c), lc = det3(a, b, q);
	la = std::max(la, 0.0), lb = std::max(lb, 0.0), lc = std::max(lc, 0.0);
	double sum = la + lb + lc;
	if (!(sum > 0))
		la = lb = lc = sum = 1;
	la /= sum, lb /= sum, lc /= sum;
	const Vec3 &x = l->m.p[t[0]], &y = l->m.p[t[1]], &z = l->m.p[t[2]];
	return {la * x[0] + lb * y[0] + lc * z[0], la * x[1] + lb * y[1] + lc * z[1],
	        la * x[2] + lb * y[2] + lc * z[2]};
}

static Vec3 rotate(const double R[9], const Vec3 &p)
{
	return {R[0] * p[0] + R[1] * p[1] + R[2] * p[2], R[3] * p[0] + R[4] * p[1] + R[5] * p[2],
	        R[6] * p[0] + R[7] * p[1] + R[8] * p[2]};
}

/* Positions of every stored node: canonical nodes located once, then
 * copied to their duplicates, so the grid closes exactly. */
static void sample(const SphereLocator *l, int level, const std::vector<Vec3> &d,
                   const double R[9], double *pos, bool show)
{
	int n = 1 << level, w = 2 * n + 1;
	size_t done = 0, total = (size_t)w * (n + 1);
	for (int j = 0; j <= n; j++) {
		for (int i = 0; i <= 2 * n; i++) {
			size_t k = ndo_node(w, i, j);
			if (ndo_canonical(level, i, j) != k)
				continue;
			Vec3 x = locate(l, rotate(R, d[k]));
			pos[3 * k] = x[0], pos[3 * k + 1] = x[1], pos[3 * k + 2] = x[2];
		}
		done += w;
		if (show && (j & 15) == 0)
			progress("resample", (double)done / total);
	}
	ndo_sync(level, pos, 3 * sizeof(double));
}

/* Sander's stretch energy Σ A3 ‖J‖²/2 of the map from the flat
 * tetrahedron's grid triangles (equilateral, edge 1: ‖J‖² = (2/3) Σ L) to
 * the resampled triangles. */
static double grid_energy(int level, const double *pos, const std::vector<int32_t> &tri)
{
	double E = 0;
	for (size_t t = 0; t < tri.size(); t += 3) {
		const double *a = pos + 3 * tri[t], *b = pos + 3 * tri[t + 1], *c = pos + 3 * tri[t + 2];
		double u[3], v[3], e[3], L = 0;
		for (int k = 0; k < 3; k++) {
			u[k] = b[k] - a[k], v[k] = c[k] - a[k], e[k] = c[k] - b[k];
			L += u[k] * u[k] + v[k] * v[k] + e[k] * e[k];
		}
		double x = u[1] * v[2] - u[2] * v[1], y = u[2] * v[0] - u[0] * v[2],
		       z = u[0] * v[1] - u[1] * v[0];
		double a3 = 0.5 * std::sqrt(x * x + y * y + z * z);
		E += a3 * L / 3.0;
	}
	(void)level;
	return E;
}

static void mat_mul(const double A[9], const double B[9], double C[9])
{
	double T[9];
	for (int r = 0; r < 3; r++)
		for (int c = 0; c < 3; c++)
			T[3 * r + c] = A[3 * r] * B[c] + A[3 * r + 1] * B[3 + c] + A[3 * r + 2] * B[6 + c];
	std::copy(T, T + 9, C);
}

static void axis_angle(int axis, double ang, double R[9])
{
	double c = std::cos(ang), s = std::sin(ang);
	std::fill(R, R + 9, 0.0);
	int a = (axis + 1) % 3, b = (axis + 2) % 3;
	R[3 * axis + axis] = 1;
	R[3 * a + a] = c, R[3 * a + b] = -s;
	R[3 * b + a] = s, R[3 * b + b] = c;
}

static void quat_matrix(double w, double x, double y, double z, double R[9])
{
	R[0] = 1 - 2 * (y * y + z * z), R[1] = 2 * (x * y - w * z), R[2] = 2 * (x * z + w * y);
	R[3] = 2 * (x * y + w * z), R[4] = 1 - 2 * (x * x + z * z), R[5] = 2 * (y * z - w * x);
	R[6] = 2 * (x * z - w * y), R[7] = 2 * (y * z + w * x), R[8] = 1 - 2 * (x * x + y * y);
}

void optimize_rotation(const SphereLocator *l, DomainMap map, double R[9], double *e0, double *e1)
{
	/* Praun & Hoppe choose the domain's rotation that minimizes stretch;
	 * here: the stretch energy of the resampled grid at a coarse level —
	 * 96 random rotations (fixed seed) at level 4, then coordinate descent
	 * over small rotations at level 5. */
	const int L0 = 4, L1 = 5;
	std::vector<Vec3> d0, d1;
	domain_points(map, L0, d0);
	domain_points(map, L1, d1);
	std::vector<int32_t> t0(3 * ndo_triangle_count(L0)), t1(3 * ndo_triangle_count(L1));
	ndo_triangles(L0, t0.data());
	ndo_triangles(L1, t1.data());
	std::vector<double> p0(3 * d0.size()), p1(3 * d1.size());
	auto energy = [&](int lev, const double M[9]) {
		if (lev == L0) {
			sample(l, L0, d0, M, p0.data(), false);
			return grid_energy(L0, p0.data(), t0);
		}
		sample(l, L1, d1, M, p1.data(), false);
		return grid_energy(L1, p1.data(), t1);
	};
	double I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
	std::copy(I, I + 9, R);
	*e0 = energy(L1, I);
	double best = energy(L0, I);
	std::mt19937 rng(12345);
	std::normal_distribution<double> g(0, 1);
	const int tries = 96;
	for (int k = 0; k < tries; k++) {
		double q[4] = {g(rng), g(rng), g(rng), g(rng)};
		double r = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
		double M[9];
		quat_matrix(q[0] / r, q[1] / r, q[2] / r, q[3] / r, M);
		double E = energy(L0, M);
		if (E < best)
			best = E, std::copy(M, M + 9, R);
		progress("rotation", 0.7 * (k + 1) / tries);
	}
	best = energy(L1, R);
	for (double step = 0.15; step > 0.005; step *= 0.5) {
		bool improved = true;
		while (improved) {
			improved = false;
			for (int axis = 0; axis < 3; axis++)
				for (int sign = -1; sign <= 1; sign += 2) {
					double A[9], M[9];
					axis_angle(axis, sign * step, A);
					mat_mul(A, R, M);
					double E = energy(L1, M);
					if (E < best) {
						best = E, std::copy(M, M + 9, R);
						improved = true;
					}
				}
		}
		progress("rotation", 0.7 + 0.3 * (1 - step / 0.15));
	}
	*e1 = best;
}

void resample(const SphereLocator *l, DomainMap map, const double R[9], ndo_grid *g)
{
	std::vector<Vec3> d;
	domain_points(map, g->level, d);
	double *pos = ndo_grid_f64(g, NDO_CH_POSITION, 3);
	if (!pos)
		throw std::runtime_error("grid has no position channel");
	sample(l, g->level, d, R, pos, true);
}

} // namespace remesh
