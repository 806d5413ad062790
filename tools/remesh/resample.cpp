/* resample.cpp — the tetrahedral domain on the sphere, point location on
 * the parameterized sphere, and the resampling of every grid node from
 * the surface (thesis §4.2.2.2; Praun & Hoppe 2003, §5). */
#include "sphere.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace remesh {

void domain_points(const Domain &dom, int level, std::vector<Vec3> &d)
{
	int n = 1 << level, w = 2 * n + 1;
	d.resize((size_t)w * (n + 1));
	if (dom.map == DomainMap::Spring) {
		/* 30 damped sweeps per level: the area spread stops changing in
		 * the third decimal by then (docs/remesh.md) */
		if (ndo_domain_spring(level, 30, d[0].data()) != NDO_OK)
			throw std::runtime_error(ndo_errdetail());
		return;
	}
	/* The blend: both maps take each of the six right triangles of a face
	 * (centre, edge midpoint, corner) onto the same spherical triangle
	 * (the gnomonic map keeps straight lines straight), so the normalized
	 * mean of the two images stays in it; seams stay exact because both
	 * maps are functions of the point of the tetrahedron alone.  Every
	 * chord triangle of the blend is positively oriented at levels 0..10
	 * for shares 0, 0.1, ..., 1 (checked when this was written). */
	double t = dom.map == DomainMap::Gnomonic ? 1 : dom.map == DomainMap::EqualArea ? 0 : dom.blend;
	for (int j = 0; j <= n; j++)
		for (int i = 0; i <= 2 * n; i++) {
			int face;
			double b[3], e[3], g[3];
			ndo_domain_locate(level, i, j, &face, b);
			Vec3 &x = d[ndo_node(w, i, j)];
			if (t < 1)
				ndo_domain_sphere(NDO_MAP_EQUAL_AREA, face, b, e);
			if (t > 0)
				ndo_domain_sphere(NDO_MAP_GNOMONIC, face, b, g);
			if (t <= 0 || t >= 1) {
				const double *y = t <= 0 ? e : g;
				x = {y[0], y[1], y[2]};
				continue;
			}
			for (int k = 0; k < 3; k++)
				x[k] = (1 - t) * e[k] + t * g[k];
			double r = std::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
			x = {x[0] / r, x[1] / r, x[2] / r};
		}
}

void SphereIndex::build(const Vec3 *pts, const int32_t *tri, size_t ntri, const int32_t *id)
{
	p = pts, t = tri, n = ntri;
	adj.assign(n, {-1, -1, -1});
	std::vector<std::pair<uint64_t, int>> e;
	e.reserve(3 * n);
	for (size_t f = 0; f < n; f++)
		for (int k = 0; k < 3; k++) {
			uint32_t a = (uint32_t)id[t[3 * f + (k + 1) % 3]], b = (uint32_t)id[t[3 * f + (k + 2) % 3]];
			e.push_back({(uint64_t)std::min(a, b) << 32 | std::max(a, b), (int)(3 * f + k)});
		}
	std::sort(e.begin(), e.end());
	for (size_t i = 0; i + 1 < e.size(); i++)
		if (e[i].first == e[i + 1].first) {
			int x = e[i].second, y = e[i + 1].second;
			adj[x / 3][x % 3] = y / 3, adj[y / 3][y % 3] = x / 3;
			i++;
		}
	tris.clear();
	tris.reserve(n);
	for (size_t f = 0; f < n; f++) {
		const Vec3 &a = p[t[3 * f]], &b = p[t[3 * f + 1]], &c = p[t[3 * f + 2]];
		tris.emplace_back(KS::Point_3(a[0], a[1], a[2]), KS::Point_3(b[0], b[1], b[2]),
		                  KS::Point_3(c[0], c[1], c[2]));
	}
	tree.clear();
	tree.insert(tris.cbegin(), tris.cend());
	tree.build();
	tree.accelerate_distance_queries(); /* now, not at the first query: queries run in parallel */
}

int SphereIndex::find(const Vec3 &q, double b[3], int f) const
{
	for (int step = 0; step < 256 && f >= 0; step++) {
		const Vec3 &A = p[t[3 * f]], &B = p[t[3 * f + 1]], &C = p[t[3 * f + 2]];
		double l0 = det3(q, B, C), l1 = det3(A, q, C), l2 = det3(A, B, q);
		if (l0 >= 0 && l1 >= 0 && l2 >= 0) {
			double sum = l0 + l1 + l2;
			if (!(sum > 0))
				l0 = l1 = l2 = sum = 1;
			b[0] = l0 / sum, b[1] = l1 / sum, b[2] = l2 / sum;
			return f;
		}
		f = adj[f][l0 <= l1 ? (l0 <= l2 ? 0 : 2) : (l1 <= l2 ? 1 : 2)];
	}
	KS::Ray_3 ray(KS::Point_3(0, 0, 0), KS::Vector_3(q[0], q[1], q[2]));
	auto hit = tree.any_intersected_primitive(ray);
	if (hit) {
		f = (int)(*hit - tris.cbegin());
	} else {
		/* a ray that slips through a crack between chord triangles in
		 * floating point: take the nearest chord triangle */
		double r = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
		auto cp = tree.closest_point_and_primitive(KS::Point_3(q[0] / r, q[1] / r, q[2] / r));
		f = (int)(cp.second - tris.cbegin());
	}
	/* central projection: q ∝ α a + β b + γ c, α + β + γ = 1 (clamped:
	 * q may lie a rounding error outside the triangle the ray hit) */
	const Vec3 &A = p[t[3 * f]], &B = p[t[3 * f + 1]], &C = p[t[3 * f + 2]];
	double l0 = std::max(det3(q, B, C), 0.0), l1 = std::max(det3(A, q, C), 0.0),
	       l2 = std::max(det3(A, B, q), 0.0), sum = l0 + l1 + l2;
	if (!(sum > 0))
		l0 = l1 = l2 = sum = 1;
	b[0] = l0 / sum, b[1] = l1 / sum, b[2] = l2 / sum;
	return f;
}

SphereLocator *locator_create(const Mesh &m, const std::vector<Vec3> &s)
{
	SphereLocator *l = new SphereLocator(m, s);
	std::vector<int32_t> ident(s.size());
	for (size_t v = 0; v < s.size(); v++)
		ident[v] = (int32_t)v;
	static_assert(sizeof(Tri) == 3 * sizeof(int32_t), "Tri is three ints");
	l->idx.build(s.data(), m.f[0].data(), m.f.size(), ident.data());
	for (const Tri &t : m.f) {
		const Vec3 &a = m.p[t[0]], &b = m.p[t[1]], &c = m.p[t[2]];
		Vec3 u = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
		Vec3 n = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
		double r = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
		l->normal.push_back(r > 0 ? Vec3{n[0] / r, n[1] / r, n[2] / r} : Vec3{0, 0, 0});
	}
	l->vf.resize(m.p.size());
	for (size_t fi = 0; fi < m.f.size(); fi++)
		for (int v : m.f[fi])
			l->vf[v].push_back((int)fi);
	std::vector<char> seen(m.p.size(), 0);
	l->parent.assign(m.p.size(), -1);
	l->order.reserve(m.p.size());
	l->order.push_back(0);
	seen[0] = 1;
	for (size_t h = 0; h < l->order.size(); h++)
		for (int fi : l->vf[l->order[h]])
			for (int u : m.f[fi])
				if (!seen[u]) {
					seen[u] = 1;
					l->parent[u] = l->order[h];
					l->order.push_back(u);
				}
	return l;
}

void locator_destroy(SphereLocator *l) { delete l; }

Vec3 locate_face(const SphereLocator *l, const Vec3 &q, int *face)
{
	double b[3];
	int f = l->idx.find(q, b, *face);
	*face = f;
	const Tri &t = l->m.f[f];
	const Vec3 &x = l->m.p[t[0]], &y = l->m.p[t[1]], &z = l->m.p[t[2]];
	return {b[0] * x[0] + b[1] * y[0] + b[2] * z[0], b[0] * x[1] + b[1] * y[1] + b[2] * z[1],
	        b[0] * x[2] + b[1] * y[2] + b[2] * z[2]};
}

void sample(const SphereLocator *l, int level, const std::vector<Vec3> &d, const double R[9],
            double *pos, int *faces, bool show)
{
	int n = 1 << level, w = 2 * n + 1;
	size_t done = 0, total = (size_t)w * (n + 1);
	int row = -1; /* the face of the previous row's first node: where a row starts walking */
	for (int j = 0; j <= n; j++) {
		int f = row;
		for (int i = 0; i <= 2 * n; i++) {
			size_t k = ndo_node(w, i, j);
			if (ndo_canonical(level, i, j) != k)
				continue;
			Vec3 x = locate_face(l, rotate(R, d[k]), &f);
			if (i == 0 || row < 0)
				row = f;
			pos[3 * k] = x[0], pos[3 * k + 1] = x[1], pos[3 * k + 2] = x[2];
			if (faces)
				faces[k] = f;
		}
		done += w;
		if (show && (j & 15) == 0)
			progress("resample", (double)done / total);
	}
	ndo_sync(level, pos, 3 * sizeof(double));
	if (faces)
		ndo_sync(level, faces, sizeof(int));
}

void resample(const SphereLocator *l, const Domain &dom, const double R[9], ndo_grid *g)
{
	std::vector<Vec3> d;
	domain_points(dom, g->level, d);
	double *pos = ndo_grid_f64(g, NDO_CH_POSITION, 3);
	if (!pos)
		throw std::runtime_error("grid has no position channel");
	sample(l, g->level, d, R, pos, nullptr, true);
}

} // namespace remesh
