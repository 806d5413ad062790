/* load.cpp — read a mesh without merging what the file keeps apart, and
 * validate it with CGAL before any work (issue 8: "Validate with CGAL
 * before any work"). */
#include "remesh.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/IO/polygon_soup_io.h>
#include <CGAL/Polygon_mesh_processing/connected_components.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/shape_predicates.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <CGAL/Surface_mesh.h>

#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <cctype>
#include <cstring>
#include <fstream>
#include <iostream>
#include <iterator>
#include <map>
#include <sstream>
#include <unordered_map>

namespace remesh {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_3;
using SM = CGAL::Surface_mesh<Point>;
namespace PMP = CGAL::Polygon_mesh_processing;

static std::string lower_ext(const std::string &path)
{
	size_t dot = path.find_last_of('.'), slash = path.find_last_of('/');
	if (dot == std::string::npos || (slash != std::string::npos && dot < slash))
		return "";
	std::string e = path.substr(dot + 1);
	for (char &c : e)
		c = (char)std::tolower((unsigned char)c);
	return e;
}

/* Guess a format from the first bytes (stdin has no name). */
static std::string sniff(const std::string &data)
{
	size_t i = 0;
	while (i < data.size() && (data[i] == ' ' || data[i] == '\n' || data[i] == '\r' || data[i] == '\t'))
		i++;
	std::string head = data.substr(i, 16);
	if (head.rfind("ply", 0) == 0)
		return "ply";
	if (head.find("OFF") != std::string::npos && head.find("OFF") < 6)
		return "off";
	if (head.rfind("solid", 0) == 0)
		return "stl";
	if (head.rfind("v ", 0) == 0 || head.rfind("#", 0) == 0 || head.rfind("o ", 0) == 0)
		return "obj";
	return "";
}

static bool read_cgal(const std::string &ext, std::istream &is,
                      std::vector<Point> &pts,
                      std::vector<std::vector<std::size_t>> &polys)
{
	if (ext == "off")
		return CGAL::IO::read_OFF(is, pts, polys);
	if (ext == "obj")
		return CGAL::IO::read_OBJ(is, pts, polys);
	if (ext == "ply")
		return CGAL::IO::read_PLY(is, pts, polys);
	if (ext == "stl")
		return CGAL::IO::read_STL(is, pts, polys);
	return false;
}

/* assimp: every mesh of the scene, transforms applied, exactly equal
 * positions merged (its loaders split a vertex wherever a normal or a
 * texture coordinate changes, which a closed surface must undo). */
static bool read_assimp(const std::string &data, const std::string &ext,
                        std::vector<Point> &pts,
                        std::vector<std::vector<std::size_t>> &polys,
                        std::string &why)
{
	Assimp::Importer imp;
	const aiScene *sc = imp.ReadFileFromMemory(
		data.data(), data.size(), aiProcess_PreTransformVertices, ext.c_str());
	if (!sc) {
		why = std::string("not a mesh assimp can read: ") + imp.GetErrorString();
		return false;
	}
	std::map<std::array<double, 3>, std::size_t> index;
	for (unsigned mi = 0; mi < sc->mNumMeshes; mi++) {
		const aiMesh *am = sc->mMeshes[mi];
		if (!(am->mPrimitiveTypes & (aiPrimitiveType_TRIANGLE | aiPrimitiveType_POLYGON)))
			continue;
		std::vector<std::size_t> id(am->mNumVertices);
		for (unsigned v = 0; v < am->mNumVertices; v++) {
			std::array<double, 3> key = {am->mVertices[v].x, am->mVertices[v].y,
			                             am->mVertices[v].z};
			auto it = index.emplace(key, pts.size());
			if (it.second)
				pts.emplace_back(key[0], key[1], key[2]);
			id[v] = it.first->second;
		}
		for (unsigned fi = 0; fi < am->mNumFaces; fi++) {
			const aiFace &af = am->mFaces[fi];
			if (af.mNumIndices < 3)
				continue; /* points and lines are not surface */
			std::vector<std::size_t> poly;
			for (unsigned k = 0; k < af.mNumIndices; k++)
				poly.push_back(id[af.mIndices[k]]);
			polys.push_back(poly);
		}
	}
	return true;
}

bool load(const std::string &path, Mesh &m, std::vector<std::string> &notes,
          std::string &why)
{
	std::string data;
	bool from_stdin = path.empty() || path == "-";
	if (from_stdin) {
		std::ostringstream ss;
		ss << std::cin.rdbuf();
		data = ss.str();
	} else {
		std::ifstream f(path, std::ios::binary);
		if (!f) {
			why = std::strerror(errno);
			return false;
		}
		data.assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
		if (f.bad()) {
			why = std::strerror(errno);
			return false;
		}
	}
	if (data.empty()) {
		why = "empty file";
		return false;
	}
	std::string ext = from_stdin ? sniff(data) : lower_ext(path);
	std::vector<Point> pts;
	std::vector<std::vector<std::size_t>> polys;
	if (ext == "off" || ext == "obj" || ext == "ply" || ext == "stl") {
		std::istringstream is(data, std::ios::binary);
		if (ext == "ply" || ext == "stl")
			CGAL::IO::set_mode(is, CGAL::IO::BINARY);
		if (!read_cgal(ext, is, pts, polys)) {
			why = "not a readable " + ext + " file";
			return false;
		}
	} else if (!read_assimp(data, ext, pts, polys, why)) {
		return false;
	}
	if (polys.empty()) {
		why = "no faces";
		return false;
	}
	/* Triangulate polygons with more than three corners (CGAL). */
	bool poly = false;
	for (size_t i = 0; i < polys.size(); i++) {
		if (polys[i].size() < 3) {
			why = "face " + std::to_string(i) + " has " +
			      std::to_string(polys[i].size()) + " vertices";
			return false;
		}
		for (std::size_t v : polys[i])
			if (v >= pts.size()) {
				why = "face " + std::to_string(i) + " refers to vertex " +
				      std::to_string(v) + " of " + std::to_string(pts.size());
				return false;
			}
		poly |= polys[i].size() > 3;
	}
	if (poly) {
		std::vector<std::vector<std::size_t>> tris;
		for (auto &pg : polys) {
			if (pg.size() == 3) {
				tris.push_back(pg);
				continue;
			}
			/* CGAL's polygon triangulation of one face at a time keeps
			 * the indexing (a face graph would need a manifold input) */
			std::vector<Point> ring;
			for (std::size_t v : pg)
				ring.push_back(pts[v]);
			std::vector<CGAL::Triple<int, int, int>> out;
			PMP::triangulate_hole_polyline(ring, std::back_inserter(out));
			if (out.size() != pg.size() - 2) {
				why = "a polygon of " + std::to_string(pg.size()) +
				      " vertices cannot be triangulated";
				return false;
			}
			for (auto &t : out)
				tris.push_back({pg[t.first], pg[t.second], pg[t.third]});
		}
		notes.push_back("triangulated " + std::to_string(polys.size()) +
		                " polygons into " + std::to_string(tris.size()) + " triangles");
		polys.swap(tris);
	}
	m.p.resize(pts.size());
	for (size_t i = 0; i < pts.size(); i++)
		m.p[i] = {pts[i].x(), pts[i].y(), pts[i].z()};
	m.f.resize(polys.size());
	for (size_t i = 0; i < polys.size(); i++)
		m.f[i] = {(int)polys[i][0], (int)polys[i][1], (int)polys[i][2]};
	return true;
}

static std::string plural(long n, const char *one, const char *many)
{
	return std::to_string(n) + " " + (n == 1 ? one : many);
}

bool validate(Mesh &m, std::vector<std::string> &notes, std::string &why)
{
	/* Repeated corners: a face that is not a triangle. */
	for (size_t i = 0; i < m.f.size(); i++) {
		const Tri &t = m.f[i];
		if (t[0] == t[1] || t[1] == t[2] || t[2] == t[0]) {
			why = "face " + std::to_string(i) + " repeats vertex " +
			      std::to_string(t[0] == t[1] || t[0] == t[2] ? t[0] : t[1]) +
			      " (degenerate face)";
			return false;
		}
	}
	/* Drop unreferenced vertices (they would change the Euler number). */
	std::vector<int> used(m.p.size(), -1);
	int nv = 0;
	for (const Tri &t : m.f)
		for (int v : t)
			if (used[v] < 0)
				used[v] = nv++;
	if ((size_t)nv < m.p.size()) {
		notes.push_back("dropped " + plural((long)(m.p.size() - nv), "unreferenced vertex",
		                                   "unreferenced vertices"));
		std::vector<Vec3> q(nv);
		for (size_t v = 0; v < m.p.size(); v++)
			if (used[v] >= 0)
				q[used[v]] = m.p[v];
		m.p.swap(q);
		for (Tri &t : m.f)
			for (int &v : t)
				v = used[v];
	}
	/* Edges: more than two faces is non-manifold; two faces using an edge
	 * in the same direction is inconsistent orientation. */
	std::unordered_map<uint64_t, int> dir; /* directed edge → count */
	for (const Tri &t : m.f)
		for (int k = 0; k < 3; k++)
			dir[(uint64_t)(uint32_t)t[k] << 32 | (uint32_t)t[(k + 1) % 3]]++;
	long nonmanifold = 0, inconsistent = 0, border = 0;
	int ea = -1, eb = -1;
	for (auto &e : dir) {
		int a = (int)(e.first >> 32), b = (int)(e.first & 0xffffffffu);
		auto r = dir.find((uint64_t)(uint32_t)b << 32 | (uint32_t)a);
		int back = r == dir.end() ? 0 : r->second;
		if (a < b || back == 0) {
			int total = e.second + back;
			if (total > 2) {
				nonmanifold++;
				if (ea < 0)
					ea = a, eb = b;
			} else if (e.second == 2 || back == 2) {
				inconsistent++;
			} else if (total == 1) {
				border++;
			}
		}
	}
	if (nonmanifold) {
		why = "not manifold: " + plural(nonmanifold, "edge", "edges") +
		      " shared by more than two faces (first: vertices " + std::to_string(ea) +
		      "–" + std::to_string(eb) + ")";
		return false;
	}
	std::vector<Point> pts;
	pts.reserve(m.p.size());
	for (const Vec3 &p : m.p)
		pts.emplace_back(p[0], p[1], p[2]);
	std::vector<std::array<std::size_t, 3>> polys(m.f.size());
	for (size_t i = 0; i < m.f.size(); i++)
		polys[i] = {(std::size_t)m.f[i][0], (std::size_t)m.f[i][1], (std::size_t)m.f[i][2]};
	if (inconsistent) {
		/* CGAL re-orients a consistently orientable soup without
		 * duplicating points; if it must duplicate, the surface is
		 * non-orientable or pinched at a vertex. */
		if (!PMP::orient_polygon_soup(pts, polys)) {
			why = "not an orientable manifold (" +
			      plural(inconsistent, "edge", "edges") + " used twice in one direction)";
			return false;
		}
		notes.push_back("re-oriented faces to a consistent orientation (" +
		                plural(inconsistent, "edge was", "edges were") + " inconsistent)");
	}
	if (!PMP::is_polygon_soup_a_polygon_mesh(polys)) {
		why = "not manifold: a vertex joins separate fans of faces (non-manifold vertex)";
		return false;
	}
	SM sm;
	PMP::polygon_soup_to_polygon_mesh(pts, polys, sm);
	if (!CGAL::is_closed(sm)) {
		long b = 0;
		for (auto h : sm.halfedges())
			b += sm.is_border(h);
		why = "open surface: " + plural(b, "boundary edge", "boundary edges") +
		      "; remesh needs a closed surface";
		return false;
	}
	auto fcc = sm.add_property_map<SM::Face_index, std::size_t>("f:cc").first;
	std::size_t ncc = PMP::connected_components(sm, fcc);
	if (ncc != 1) {
		why = std::to_string(ncc) + " connected components; remesh needs one";
		return false;
	}
	long chi = (long)sm.number_of_vertices() - (long)sm.number_of_edges() +
	           (long)sm.number_of_faces();
	if (chi != 2) {
		long genus = (2 - chi) / 2;
		why = "genus " + std::to_string(genus) + " (Euler characteristic " +
		      std::to_string(chi) + "); remesh needs genus 0";
		return false;
	}
	long degenerate = 0;
	for (auto f : sm.faces())
		degenerate += PMP::is_degenerate_triangle_face(f, sm);
	if (degenerate) {
		why = plural(degenerate, "degenerate (zero-area) face", "degenerate (zero-area) faces");
		return false;
	}
	/* Back to the indexed mesh in CGAL's vertex order (the soup's). */
	m.f.clear();
	for (auto f : sm.faces()) {
		Tri t;
		int k = 0;
		for (auto v : CGAL::vertices_around_face(sm.halfedge(f), sm))
			t[k++] = (int)v.idx();
		m.f.push_back(t);
	}
	m.p.resize(sm.number_of_vertices());
	for (auto v : sm.vertices()) {
		const Point &p = sm.point(v);
		m.p[v.idx()] = {p.x(), p.y(), p.z()};
	}
	if (!PMP::is_outward_oriented(sm)) {
		for (Tri &t : m.f)
			std::swap(t[1], t[2]);
		notes.push_back("faces were oriented inward; reversed them");
	}
	return true;
}

} // namespace remesh
