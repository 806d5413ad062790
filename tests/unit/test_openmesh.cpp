/* test_openmesh.cpp — subdivide (zorin corners) against an independent
 * implementation: OpenMesh's ModifiedButterflyT refines its own copy of
 * the mesh, level after level; the vertices are matched by topology (an
 * edge's new vertex is the one OpenMesh connects to both of its ends), and
 * every position must agree to 1e-12 of the shape's size. */
#include "check.h"
#include "ndo/ndo.h"

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Tools/Subdivider/Uniform/ModifiedButterFlyT.hh>

#include <cstdint>
#include <map>
#include <utility>
#include <vector>

struct Traits : OpenMesh::DefaultTraits {
	typedef OpenMesh::Vec3d Point;
};
typedef OpenMesh::TriMesh_ArrayKernelT<Traits> Mesh;

/* Distinct vertices and triangles of a grid. */
struct GridMesh {
	std::vector<int32_t> vid, rep, tri; /* tri: distinct ids */
};

static GridMesh grid_mesh(int level)
{
	GridMesh m;
	size_t count = (size_t)((2 << level) + 1) * ((1 << level) + 1);
	m.vid.resize(count);
	m.rep.resize(ndo_vertex_count(level));
	m.tri.resize(3 * ndo_triangle_count(level));
	ndo_vertex_ids(level, m.vid.data(), m.rep.data());
	ndo_triangles(level, m.tri.data());
	for (auto &t : m.tri)
		t = m.vid[t];
	return m;
}

/* Compare one shape refined `steps` times from `level`; returns the worst
 * relative difference, or a negative number if the topology did not match. */
static double compare(ndo_grid *g, int steps)
{
	const double *x = (const double *)g->ch[0].data;
	GridMesh gm = grid_mesh(g->level);
	Mesh om;
	std::vector<Mesh::VertexHandle> vh;
	double scale = 0;
	for (size_t v = 0; v < gm.rep.size(); v++) {
		const double *p = x + 3 * (size_t)gm.rep[v];
		vh.push_back(om.add_vertex(Mesh::Point(p[0], p[1], p[2])));
		for (int c = 0; c < 3; c++)
			scale = std::max(scale, std::fabs(p[c]));
	}
	for (size_t t = 0; t < gm.tri.size(); t += 3)
		if (!om.add_face(vh[gm.tri[t]], vh[gm.tri[t + 1]], vh[gm.tri[t + 2]]).is_valid())
			return -1;
	/* map[v] = the OpenMesh vertex index of our vertex v at this level */
	std::vector<int> map(gm.rep.size());
	for (size_t v = 0; v < map.size(); v++)
		map[v] = (int)v;
	ndo_grid *cur = g;
	double worst = 0;
	for (int s = 0; s < steps; s++) {
		int old_n = (int)om.n_vertices();
		OpenMesh::Subdivider::Uniform::ModifiedButterflyT<Mesh> sub;
		sub.attach(om);
		sub(1);
		sub.detach();
		/* each new OpenMesh vertex sits between exactly two old ones */
		std::map<std::pair<int, int>, int> mid;
		for (int w = old_n; w < (int)om.n_vertices(); w++) {
			std::vector<int> ends;
			for (auto n : om.vv_range(om.vertex_handle(w)))
				if (n.idx() < old_n)
					ends.push_back(n.idx());
			if (ends.size() != 2)
				return -1;
			mid[{std::min(ends[0], ends[1]), std::max(ends[0], ends[1])}] = w;
		}
		ndo_grid *fine;
		ndo_subdivide(cur, NDO_CORNERS_ZORIN, &fine);
		GridMesh fm = grid_mesh(fine->level);
		std::vector<int> fmap(fm.rep.size(), -1);
		int w = cur->w;
		/* even nodes keep their OpenMesh vertex; odd nodes find theirs
		 * through the coarse edge they split */
		for (int j = 0; j < cur->h; j++)
			for (int i = 0; i < w; i++)
				fmap[fm.vid[ndo_node(fine->w, 2 * i, 2 * j)]] = map[gm.vid[ndo_node(w, i, j)]];
		std::vector<int32_t> stri(3 * ndo_triangle_count(cur->level));
		ndo_triangles(cur->level, stri.data());
		for (size_t t = 0; t < stri.size(); t++) {
			int32_t s0 = stri[t], s1 = stri[t % 3 == 2 ? t - 2 : t + 1];
			int a = map[gm.vid[s0]], b = map[gm.vid[s1]];
			auto it = mid.find({std::min(a, b), std::max(a, b)});
			if (it == mid.end())
				return -1;
			fmap[fm.vid[ndo_canonical(fine->level, s0 % w + s1 % w, s0 / w + s1 / w)]] = it->second;
		}
		const double *y = (const double *)fine->ch[0].data;
		for (size_t v = 0; v < fm.rep.size(); v++) {
			if (fmap[v] < 0)
				return -1;
			auto p = om.point(om.vertex_handle(fmap[v]));
			for (int c = 0; c < 3; c++)
				worst = std::max(worst, std::fabs(y[3 * (size_t)fm.rep[v] + c] - p[c]) / scale);
		}
		if (cur != g)
			ndo_grid_destroy(cur);
		cur = fine;
		gm = fm;
		map = fmap;
	}
	if (cur != g)
		ndo_grid_destroy(cur);
	return worst;
}

static void matches_openmesh_modified_butterfly()
{
	const char *shapes[] = {"sphere", "ellipsoid", "wavy", "tetra"};
	for (const char *shape : shapes)
		for (int level = 0; level <= 3; level++) {
			ndo_grid *g;
			ndo_shape_make(shape, level, nullptr, &g);
			int steps = level <= 1 ? 3 : 2;
			double err = compare(g, steps);
			CHECK(err >= 0, "%s level %d: vertices could not be matched", shape, level);
			CHECK(err <= 1e-12, "%s level %d → %d: relative difference %.3g > 1e-12", shape, level,
			      level + steps, err);
			ndo_grid_destroy(g);
		}
}

/* The thesis rule must not match OpenMesh at the corners (else the
 * comparison above could not tell the rules apart). */
static void thesis_rule_differs_from_openmesh()
{
	ndo_grid *g, *t;
	ndo_shape_make("sphere", 2, nullptr, &g);
	ndo_subdivide(g, NDO_CORNERS_THESIS, &t);
	ndo_grid *z;
	ndo_subdivide(g, NDO_CORNERS_ZORIN, &z);
	double d = 0;
	for (size_t k = 0; k < 3 * z->count; k++)
		d = std::max(d, std::fabs(((double *)z->ch[0].data)[k] - ((double *)t->ch[0].data)[k]));
	CHECK(d > 1e-3, "thesis and zorin corners differ by only %.3g on a level-2 sphere", d);
	ndo_grid_destroy(g);
	ndo_grid_destroy(t);
	ndo_grid_destroy(z);
}

int main()
{
	ck_program = "openmesh";
	RUN(matches_openmesh_modified_butterfly);
	RUN(thesis_rule_differs_from_openmesh);
	return ck_failed_cases != 0;
}
