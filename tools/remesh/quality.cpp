/* quality.cpp — how far the remesh is from the input, measured the way
 * /work/shared/reference/README.md says Praun & Hoppe's figures were
 * (CGAL bounded-error symmetric Hausdorff distance with error bound 1e-5
 * of the diagonal; RMS of area-sampled point-to-surface distances both
 * ways; fold-overs against the nearest input face; self-intersections). */
#include "remesh.h"

#include <CGAL/AABB_face_graph_triangle_primitive.h>
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/compute_normal.h>
#include <CGAL/Polygon_mesh_processing/distance.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>

#include <cmath>
#include <random>
#include <sys/time.h>

namespace remesh {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_3;
using SM = CGAL::Surface_mesh<Point>;
using Prim = CGAL::AABB_face_graph_triangle_primitive<SM>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<K, Prim>>;
namespace PMP = CGAL::Polygon_mesh_processing;

double now_seconds()
{
	struct timeval tv;
	gettimeofday(&tv, nullptr);
	return tv.tv_sec + 1e-6 * tv.tv_usec;
}

void grid_mesh(const ndo_grid *g, Mesh &out)
{
	int L = g->level;
	std::vector<int32_t> vid(g->count), rep(ndo_vertex_count(L)),
	    tri(3 * ndo_triangle_count(L));
	ndo_vertex_ids(L, vid.data(), rep.data());
	ndo_triangles(L, tri.data());
	const double *pos = (const double *)ndo_grid_find(g, NDO_CH_POSITION)->data;
	out.p.resize(rep.size());
	for (size_t v = 0; v < rep.size(); v++)
		out.p[v] = {pos[3 * rep[v]], pos[3 * rep[v] + 1], pos[3 * rep[v] + 2]};
	out.f.resize(tri.size() / 3);
	for (size_t t = 0; t < out.f.size(); t++)
		out.f[t] = {vid[tri[3 * t]], vid[tri[3 * t + 1]], vid[tri[3 * t + 2]]};
}

double bbox_diagonal(const Mesh &m)
{
	Vec3 lo = m.p[0], hi = m.p[0];
	for (const Vec3 &p : m.p)
		for (int k = 0; k < 3; k++)
			lo[k] = std::min(lo[k], p[k]), hi[k] = std::max(hi[k], p[k]);
	return std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
	                 (hi[2] - lo[2]) * (hi[2] - lo[2]));
}

static bool to_sm(const Mesh &m, SM &sm)
{
	std::vector<Point> pts;
	for (const Vec3 &p : m.p)
		pts.emplace_back(p[0], p[1], p[2]);
	std::vector<std::array<std::size_t, 3>> polys;
	for (const Tri &t : m.f)
		polys.push_back({(std::size_t)t[0], (std::size_t)t[1], (std::size_t)t[2]});
	if (!PMP::is_polygon_soup_a_polygon_mesh(polys))
		return false;
	PMP::polygon_soup_to_polygon_mesh(pts, polys, sm);
	return true;
}

static double tri_area(const Vec3 &a, const Vec3 &b, const Vec3 &c, Vec3 *n = nullptr)
{
	double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
	Vec3 x = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
	if (n)
		*n = x;
	return 0.5 * std::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
}

/* Sum of squared distances from `count` points sampled uniformly by area
 * on `from` (fixed seed) to the surface in `to`. */
static double sampled_sq(const Mesh &from, const Tree &to, long count)
{
	std::vector<double> cum(from.f.size());
	double total = 0;
	for (size_t t = 0; t < from.f.size(); t++) {
		const Tri &f = from.f[t];
		total += tri_area(from.p[f[0]], from.p[f[1]], from.p[f[2]]);
		cum[t] = total;
	}
	std::mt19937_64 rng(2003);
	std::uniform_real_distribution<double> U(0, 1);
	double sum = 0;
	for (long k = 0; k < count; k++) {
		size_t t = std::lower_bound(cum.begin(), cum.end(), U(rng) * total) - cum.begin();
		if (t >= from.f.size())
			t = from.f.size() - 1;
		double r1 = std::sqrt(U(rng)), r2 = U(rng);
		double a = 1 - r1, b = r1 * (1 - r2), c = r1 * r2;
		const Vec3 &x = from.p[from.f[t][0]], &y = from.p[from.f[t][1]], &z = from.p[from.f[t][2]];
		Point q(a * x[0] + b * y[0] + c * z[0], a * x[1] + b * y[1] + c * z[1],
		        a * x[2] + b * y[2] + c * z[2]);
		sum += CGAL::to_double(to.squared_distance(q));
	}
	return sum;
}

void measure_quality(const Mesh &input, const ndo_grid *g, bool distances, bool selfint,
                     Quality &q)
{
	Mesh out;
	grid_mesh(g, out);
	q.diag = bbox_diagonal(input);
	/* areas, degenerate triangles, stretch efficiency of tetra → surface */
	double amin = INFINITY, amax = 0, A3 = 0, E = 0;
	q.degenerate = 0;
	for (const Tri &t : out.f) {
		const Vec3 &a = out.p[t[0]], &b = out.p[t[1]], &c = out.p[t[2]];
		double ar = tri_area(a, b, c);
		amin = std::min(amin, ar), amax = std::max(amax, ar);
		q.degenerate += !(ar > 1e-14 * q.diag * q.diag);
		double L = 0;
		for (int k = 0; k < 3; k++)
			L += (a[k] - b[k]) * (a[k] - b[k]) + (b[k] - c[k]) * (b[k] - c[k]) +
			     (c[k] - a[k]) * (c[k] - a[k]);
		A3 += ar;
		E += ar * L / 3.0; /* A3 ‖J‖²/2 with ‖J‖² = (2/3) ΣL on unit equilateral domain triangles */
	}
	q.area_ratio = amax > 0 ? amin / amax : 0;
	q.efficiency = E > 0 ? A3 * A3 / (E * out.f.size() * std::sqrt(3.0) / 4) : 0;
	SM so, si;
	q.closed_manifold = to_sm(out, so) && CGAL::is_closed(so);
	q.euler = (int)((long)out.p.size() - (long)out.f.size() * 3 / 2 + (long)out.f.size());
	if (!distances || !q.closed_manifold)
		return;
	to_sm(input, si);
	q.hausdorff = PMP::bounded_error_symmetric_Hausdorff_distance<CGAL::Sequential_tag>(
	                  si, so, 1e-5 * q.diag) / q.diag;
	Tree ti(faces(si).first, faces(si).second, si), to(faces(so).first, faces(so).second, so);
	ti.accelerate_distance_queries();
	to.accelerate_distance_queries();
	/* 10 samples per face of both meshes, 20 000 to 200 000 each way:
	 * the RMS estimate's relative standard error is then under 1%. */
	const long ns = std::min(200000L, std::max(20000L, 10L * (long)(input.f.size() + out.f.size())));
	double s1 = sampled_sq(input, to, ns), s2 = sampled_sq(out, ti, ns);
	q.rms = std::sqrt((s1 + s2) / (2.0 * ns)) / q.diag;
	/* fold-overs: remesh faces whose normal points against the normal of
	 * the input face nearest to their centroid */
	q.flipped = 0;
	for (const Tri &t : out.f) {
		const Vec3 &a = out.p[t[0]], &b = out.p[t[1]], &c = out.p[t[2]];
		Vec3 n;
		if (!(tri_area(a, b, c, &n) > 0))
			continue;
		Point cen((a[0] + b[0] + c[0]) / 3, (a[1] + b[1] + c[1]) / 3, (a[2] + b[2] + c[2]) / 3);
		auto cp = ti.closest_point_and_primitive(cen);
		K::Vector_3 ni = PMP::compute_face_normal(cp.second, si);
		q.flipped += n[0] * ni.x() + n[1] * ni.y() + n[2] * ni.z() < 0;
	}
	if (selfint) {
		std::vector<std::pair<SM::Face_index, SM::Face_index>> pairs;
		PMP::self_intersections<CGAL::Sequential_tag>(so, std::back_inserter(pairs));
		q.selfintersect = (long)pairs.size();
	}
}

} // namespace remesh
