/* load.cpp — read a mesh without merging what the file keeps apart, and
 * validate it with CGAL before any work (issue 8: "Validate with CGAL
 * before any work"). */
#include "remesh.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/IO/polygon_soup_io.h>
#include <CGAL/Polygon_mesh_processing/connected_components.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Polygon_mesh_processing/shape_predicates.h>
#include <CGAL/Polygon_mesh_processing/stitch_borders.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <CGAL/Surface_mesh.h>

#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <sys/stat.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <set>
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
	if (data.size() >= 12 && data.compare(0, 4, "glTF") == 0)
		return "glb";
	/* Binary STL: an 80-byte header, a triangle count, 50 bytes a
	 * triangle.  Its header may well begin with "solid", so the size
	 * decides first. */
	if (data.size() >= 84) {
		uint32_t n;
		std::memcpy(&n, data.data() + 80, 4);
		if (84 + 50 * (uint64_t)n == data.size())
			return "stl";
	}
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
	if (head.rfind("v ", 0) == 0 || head.rfind("#", 0) == 0 || head.rfind("o ", 0) == 0 ||
	    head.rfind("mtllib", 0) == 0 || head.rfind("g ", 0) == 0)
		return "obj";
	if (head.rfind("{", 0) == 0 && data.find("\"asset\"") != std::string::npos)
		return "gltf";
	return "";
}

/* CGAL's readers report a bad file on std::cerr ("Error: incorrect file
 * format") besides returning false; remesh says it in its own words, so
 * the library's text is held back while it reads. */
struct QuietCerr {
	std::ostringstream sink;
	std::streambuf *old;
	QuietCerr() : old(std::cerr.rdbuf(sink.rdbuf())) {}
	~QuietCerr() { std::cerr.rdbuf(old); }
};

/* Why an ASCII OFF or OBJ file CGAL refused cannot be read: the first
 * vertex whose coordinates are not finite numbers, or the vertices it
 * lacks; an OFF face's vertex index that is not one of its vertices (OBJ's
 * faces: obj_faces).  Only a diagnosis (the reading is CGAL's): "" when
 * none found. */
static std::string ascii_defect(const std::string &ext, const std::string &data)
{
	std::istringstream in(data);
	std::string line;
	long lineno = 0, vertex = ext == "obj" ? 1 : 0, declared = -1, seen = 0, face = 0;
	bool header = false;
	while (std::getline(in, line)) {
		lineno++;
		size_t hash = line.find('#');
		if (hash != std::string::npos)
			line.erase(hash);
		std::istringstream ls(line);
		std::string tok;
		if (!(ls >> tok))
			continue;
		std::vector<std::string> coords;
		if (ext == "obj") {
			if (tok != "v")
				continue;
		} else if (!header) {
			header = true;
			if (tok.size() >= 3 && tok.compare(tok.size() - 3, 3, "OFF") == 0 && !(ls >> tok))
				continue; /* counts on the next line */
			if (tok.size() >= 3 && tok.compare(tok.size() - 3, 3, "OFF") == 0)
				continue;
			declared = std::strtol(tok.c_str(), nullptr, 10);
			continue;
		} else if (declared < 0) {
			declared = std::strtol(tok.c_str(), nullptr, 10);
			continue;
		} else if (seen >= declared) {
			/* a face: its corner count, then as many vertex indices */
			long n = std::strtol(tok.c_str(), nullptr, 10);
			for (long k = 0; k < n && ls >> tok; k++) {
				char *end;
				errno = 0;
				long v = std::strtol(tok.c_str(), &end, 10);
				if (*end != '\0' || errno == ERANGE)
					return "face " + std::to_string(face) + " (line " + std::to_string(lineno) +
					       "): '" + tok + "' is not a vertex index";
				if (v < 0 || v >= declared)
					return "face " + std::to_string(face) + " (line " + std::to_string(lineno) +
					       ") refers to vertex " + std::to_string(v) + " of " +
					       std::to_string(declared);
			}
			face++;
			continue;
		} else {
			coords.push_back(tok);
		}
		while (coords.size() < 3 && ls >> tok)
			coords.push_back(tok);
		seen++;
		for (const std::string &c : coords) {
			char *end;
			double x = std::strtod(c.c_str(), &end);
			if (*end != '\0' || !std::isfinite(x))
				return "vertex " + std::to_string(vertex) + " (line " + std::to_string(lineno) +
				       "): coordinate '" + c + "' is not a finite number";
		}
		if (coords.size() < 3)
			return "vertex " + std::to_string(vertex) + " (line " + std::to_string(lineno) +
			       "): " + std::to_string(coords.size()) + " coordinates, not 3";
		vertex++;
	}
	if (ext == "off" && declared >= 0 && seen < declared)
		return "truncated: " + std::to_string(seen) + " of the " + std::to_string(declared) +
		       " vertices it declares";
	return "";
}

/* Coordinates beyond this are refused: areas and distances square them,
 * and simulate-peer accepts positions up to ±1e100 m (NDO_SIM_MAX_COORD). */
static const double kMaxCoord = 1e100;

/* The first coordinate that is not finite or too large: "" when all are
 * fine.  `name` says how the file numbers the point. */
static std::string bad_coordinate(double x, double y, double z)
{
	for (double c : {x, y, z}) {
		char buf[64];
		std::snprintf(buf, sizeof buf, "%.17g", c);
		if (!std::isfinite(c))
			return std::string("coordinate ") + (std::isnan(c) ? "NaN" : buf) + " is not finite";
		if (std::fabs(c) > kMaxCoord) {
			std::snprintf(buf, sizeof buf, "%.3g", c);
			return std::string("coordinate ") + buf + " is beyond ±1e100";
		}
	}
	return "";
}

static std::string plural(long n, const char *one, const char *many)
{
	return std::to_string(n) + " " + (n == 1 ? one : many);
}

/* How the file numbers its faces and vertices, for messages: OBJ counts
 * both from 1 (a face by its place among the `f` lines, with its line; a
 * vertex referred to relatively, as −1 for the last before the line, is
 * named with what was written), OFF and PLY from 0, STL has facets and
 * their corners. */
struct Names {
	std::string ext;
	std::vector<long> line;             /* OBJ: each face's line */
	std::vector<std::vector<long>> ref; /* OBJ: each face's references as written */

	std::string face(std::size_t f) const
	{
		if (ext == "obj")
			return "face " + std::to_string(f + 1) + " (line " + std::to_string(line[f]) + ")";
		return (ext == "stl" ? "facet " : "face ") + std::to_string(f);
	}
	/* vertex v (0-based, as read), corner k of face f */
	std::string vertex(std::size_t f, std::size_t k, std::size_t v) const
	{
		if (ext != "obj") /* PLY's indices are signed: −1 read as 2^64 − 1 */
			return "vertex " + std::to_string((long long)v);
		std::string s = "vertex " + std::to_string(v + 1);
		if (ref[f][k] < 0)
			s += " (written " + std::to_string(ref[f][k]) + ")";
		return s;
	}
};

/* The faces of an OBJ file as the file numbers them (a vertex reference is
 * the number before any '/': 1 for the file's first vertex, or −1 for the
 * last vertex before the line, −2 the one before it).  CGAL 5.5's reader,
 * whose points are kept, takes 0 as a relative reference to the vertex
 * after the line (a 0 in a file of 6 vertices was reported as "vertex 6
 * of 6"; before a later `v` line, silently that vertex), lets a reference
 * one past the last vertex through its own test, turns a relative one
 * before the first vertex into an index near 2^64 and reads "f 1\t2\t3"
 * as a face of one vertex: the references are read here.  False with the
 * face and the reference named in *why. */
static bool obj_faces(const std::string &data, Names &names,
                      std::vector<std::vector<std::size_t>> &polys, std::string &why)
{
	/* each line's first word, comments cut */
	auto first_word = [](std::string &line, std::istringstream &ls, std::string &tok) {
		size_t hash = line.find('#');
		if (hash != std::string::npos)
			line.erase(hash);
		ls.clear();
		ls.str(line);
		return bool(ls >> tok);
	};
	std::string line, tok;
	std::istringstream ls;
	std::size_t nv = 0;
	{
		std::istringstream in(data);
		while (std::getline(in, line))
			nv += first_word(line, ls, tok) && tok == "v";
	}
	std::istringstream in(data);
	long lineno = 0;
	std::size_t before = 0; /* vertices before the line */
	polys.clear();
	names.line.clear();
	names.ref.clear();
	while (std::getline(in, line)) {
		lineno++;
		if (!first_word(line, ls, tok))
			continue;
		if (tok == "v")
			before++;
		if (tok != "f")
			continue;
		const std::size_t f = polys.size();
		names.line.push_back(lineno);
		names.ref.emplace_back();
		polys.emplace_back();
		while (ls >> tok) {
			std::string num = tok.substr(0, tok.find('/'));
			char *end;
			errno = 0;
			long r = std::strtol(num.c_str(), &end, 10);
			if (num.empty() || *end != '\0' || errno == ERANGE) {
				why = names.face(f) + ": '" + tok + "' is not a vertex reference";
				return false;
			}
			if (r == 0) {
				why = names.face(f) + " refers to vertex 0: OBJ numbers vertices from 1";
				return false;
			}
			if (r > 0 && (unsigned long)r > nv) {
				why = names.face(f) + " refers to vertex " + std::to_string(r) + " of " +
				      std::to_string(nv);
				return false;
			}
			if (r < -(long)before) {
				why = names.face(f) + " refers to vertex " + std::to_string(r) + ", before the " +
				      "first: " + plural((long)before, "vertex comes", "vertices come") +
				      " before its line";
				return false;
			}
			names.ref[f].push_back(r);
			polys[f].push_back(r > 0 ? (std::size_t)r - 1 : before - (std::size_t)-r);
		}
	}
	return true;
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
static bool read_assimp(const std::string &path, const std::string &data,
                        const std::string &ext, bool weld, std::vector<Point> &pts,
                        std::vector<std::vector<std::size_t>> &polys,
                        std::vector<std::string> &notes, std::string &why)
{
	Assimp::Importer imp;
	/* From a file, assimp opens what the file refers to (a .gltf's
	 * external .bin beside it); from memory it cannot. */
	const aiScene *sc =
		path.empty() ? imp.ReadFileFromMemory(data.data(), data.size(),
		                                      aiProcess_PreTransformVertices, ext.c_str())
		             : imp.ReadFile(path, aiProcess_PreTransformVertices);
	if (!sc) {
		why = std::string("not a mesh assimp can read: ") + imp.GetErrorString();
		return false;
	}
	std::map<std::array<double, 3>, std::size_t> index;
	std::size_t given = 0;
	for (unsigned mi = 0; mi < sc->mNumMeshes; mi++) {
		const aiMesh *am = sc->mMeshes[mi];
		if (!(am->mPrimitiveTypes & (aiPrimitiveType_TRIANGLE | aiPrimitiveType_POLYGON)))
			continue;
		std::vector<std::size_t> id(am->mNumVertices);
		for (unsigned v = 0; v < am->mNumVertices; v++) {
			std::array<double, 3> key = {am->mVertices[v].x, am->mVertices[v].y,
			                             am->mVertices[v].z};
			std::string bad = bad_coordinate(key[0], key[1], key[2]);
			if (!bad.empty()) {
				why = (sc->mNumMeshes > 1 ? "mesh " + std::to_string(mi) + ", " : std::string()) +
				      "vertex " + std::to_string(v) + ": " + bad;
				return false;
			}
			given++;
			if (!weld) {
				id[v] = pts.size();
				pts.emplace_back(key[0], key[1], key[2]);
				continue;
			}
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
			for (unsigned k = 0; k < af.mNumIndices; k++) {
				/* a truncated file can leave assimp with indices
				 * beyond its vertices */
				if (af.mIndices[k] >= am->mNumVertices) {
					why = "face " + std::to_string(fi) + " refers to vertex " +
					      std::to_string(af.mIndices[k]) + " of " +
					      std::to_string(am->mNumVertices) + " (truncated or corrupt)";
					return false;
				}
				poly.push_back(id[af.mIndices[k]]);
			}
			polys.push_back(poly);
		}
	}
	if (weld && given > pts.size())
		notes.push_back("welded " + std::to_string(given - pts.size()) +
		                " coincident vertices the format keeps apart (normal or texture "
		                "seams); --no-weld keeps them apart");
	return true;
}

/* Triangulate the polygons with more than three corners.  CGAL's polygon
 * triangulation (one face at a time, which keeps the indexing) picks the
 * diagonals that are best for the polygon alone; a diagonal that is
 * already an edge of the mesh (two quads of a non-planar band, suzanne's
 * ears) would make that edge non-manifold, so such a polygon takes a fan
 * whose diagonals are all new, from the first corner that has one. */
static bool triangulate(const std::vector<Point> &pts,
                        std::vector<std::vector<std::size_t>> &polys, const Names &names,
                        std::string &why)
{
	auto key = [](std::size_t a, std::size_t b) {
		return a < b ? std::make_pair(a, b) : std::make_pair(b, a);
	};
	std::set<std::pair<std::size_t, std::size_t>> edges;
	for (auto &pg : polys)
		for (size_t k = 0; k < pg.size(); k++)
			edges.insert(key(pg[k], pg[(k + 1) % pg.size()]));
	std::vector<std::vector<std::size_t>> tris;
	for (std::size_t f = 0; f < polys.size(); f++) {
		const std::vector<std::size_t> &pg = polys[f];
		if (pg.size() == 3) {
			tris.push_back(pg);
			continue;
		}
		std::vector<Point> ring;
		for (std::size_t v : pg)
			ring.push_back(pts[v]);
		std::vector<CGAL::Triple<int, int, int>> out;
		PMP::triangulate_hole_polyline(ring, std::back_inserter(out));
		if (out.size() != pg.size() - 2) {
			why = names.face(f) + ": a polygon of " + std::to_string(pg.size()) +
			      " vertices that cannot be triangulated";
			return false;
		}
		std::vector<std::array<std::size_t, 3>> cand;
		for (auto &t : out)
			cand.push_back({pg[t.first], pg[t.second], pg[t.third]});
		auto fresh = [&](const std::vector<std::array<std::size_t, 3>> &ts) {
			std::set<std::pair<std::size_t, std::size_t>> sides, seen;
			for (size_t k = 0; k < pg.size(); k++)
				sides.insert(key(pg[k], pg[(k + 1) % pg.size()]));
			for (auto &t : ts)
				for (int k = 0; k < 3; k++) {
					auto e = key(t[k], t[(k + 1) % 3]);
					if (!sides.count(e) && edges.count(e) && !seen.count(e))
						return false;
					seen.insert(e);
				}
			return true;
		};
		if (!fresh(cand)) {
			for (size_t s = 0; s < pg.size(); s++) {
				std::vector<std::array<std::size_t, 3>> fan;
				for (size_t k = 1; k + 1 < pg.size(); k++)
					fan.push_back({pg[s], pg[(s + k) % pg.size()], pg[(s + k + 1) % pg.size()]});
				if (fresh(fan)) {
					cand.swap(fan);
					break;
				}
			}
		}
		for (auto &t : cand) {
			for (int k = 0; k < 3; k++)
				edges.insert(key(t[k], t[(k + 1) % 3]));
			tris.push_back({t[0], t[1], t[2]});
		}
	}
	polys.swap(tris);
	return true;
}

bool load(const std::string &path, Mesh &m, bool weld, std::vector<std::string> &notes,
          std::string &why)
{
	std::string data;
	bool from_stdin = path.empty() || path == "-";
	if (from_stdin) {
		std::ostringstream ss;
		ss << std::cin.rdbuf();
		data = ss.str();
	} else {
		struct stat st;
		if (stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode)) {
			why = "is a directory, not a mesh file";
			return false;
		}
		std::ifstream f(path, std::ios::binary);
		if (!f) {
			why = std::strerror(errno);
			return false;
		}
		try {
			data.assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
		} catch (const std::exception &) {
			why = std::string("read error: ") + std::strerror(errno ? errno : EIO);
			return false;
		}
		if (f.bad()) {
			why = std::string("read error: ") + std::strerror(errno ? errno : EIO);
			return false;
		}
	}
	if (data.empty()) {
		why = "empty file";
		return false;
	}
	std::string ext = from_stdin ? sniff(data) : lower_ext(path);
	Names names;
	names.ext = ext;
	m.base = ext == "obj" ? 1 : 0;
	std::vector<Point> pts;
	std::vector<std::vector<std::size_t>> polys;
	/* PLY triangle strips (a common scan format) are beyond CGAL's PLY
	 * reader; assimp's reads them. */
	bool strips = ext == "ply" && data.find("element tristrips") < data.find("end_header");
	bool via_cgal = (ext == "off" || ext == "obj" || ext == "ply" || ext == "stl") && !strips;
	if (via_cgal) {
		std::istringstream is(data, std::ios::binary);
		if (ext == "ply" || ext == "stl")
			CGAL::IO::set_mode(is, CGAL::IO::BINARY);
		bool ok;
		{
			QuietCerr quiet;
			ok = read_cgal(ext, is, pts, polys);
		}
		/* OBJ: the faces read again, as the file numbers them (obj_faces),
		 * and a reference CGAL refused named */
		if (ext == "obj" && (ok || ascii_defect(ext, data).empty())) {
			std::vector<std::vector<std::size_t>> faces;
			if (!obj_faces(data, names, faces, why))
				return false;
			if (ok)
				polys.swap(faces);
		}
		if (!ok) {
			std::string d = ext == "off" || ext == "obj" ? ascii_defect(ext, data) : "";
			std::string up = ext;
			for (char &c : up)
				c = (char)std::toupper((unsigned char)c);
			why = d.empty() ? "not a readable " + up + " file (malformed or truncated)" : d;
			return false;
		}
		/* Coordinates: finite and in range, named as the file numbers
		 * them (OBJ from 1, OFF and PLY from 0; STL has facets only). */
		for (std::size_t v = 0; v < pts.size(); v++) {
			std::string bad = bad_coordinate(pts[v].x(), pts[v].y(), pts[v].z());
			if (bad.empty())
				continue;
			if (ext == "stl") {
				for (std::size_t f = 0; f < polys.size(); f++)
					for (std::size_t k = 0; k < polys[f].size(); k++)
						if (polys[f][k] == v) {
							why = "facet " + std::to_string(f) + ", corner " +
							      std::to_string(k) + ": " + bad;
							return false;
						}
			}
			why = "vertex " + std::to_string(ext == "obj" ? v + 1 : v) + ": " + bad;
			return false;
		}
	} else {
		if (ext.empty() && from_stdin) {
			why = "not a mesh format remesh recognizes on standard input (give a file "
			      "with its extension)";
			return false;
		}
		if (!read_assimp(from_stdin ? "" : path, data, ext, weld, pts, polys, notes, why))
			return false;
	}
	if (polys.empty()) {
		why = pts.empty() ? "no vertices and no faces" : "no faces (" + std::to_string(pts.size()) +
		                                                 " vertices, a point cloud?)";
		return false;
	}
	/* Faces named as the file numbers them (assimp's formats: as assimp
	 * numbers them, from 0); a face that repeats a vertex is refused here,
	 * before triangulation renumbers the faces. */
	bool poly = false;
	for (size_t i = 0; i < polys.size(); i++) {
		const std::vector<std::size_t> &pg = polys[i];
		if (pg.size() < 3) {
			why = names.face(i) + " has " + plural((long)pg.size(), "vertex", "vertices");
			return false;
		}
		for (std::size_t k = 0; k < pg.size(); k++)
			if (pg[k] >= pts.size()) {
				why = names.face(i) + " refers to " + names.vertex(i, k, pg[k]) + " of " +
				      std::to_string(pts.size());
				return false;
			}
		for (std::size_t k = 1; k < pg.size(); k++)
			for (std::size_t l = 0; l < k; l++) {
				if (pg[k] != pg[l])
					continue;
				if (ext == "stl")
					why = names.face(i) + ": corners " + std::to_string(l) + " and " +
					      std::to_string(k) + " are the same point (degenerate facet)";
				else
					why = names.face(i) + " repeats " + names.vertex(i, k, pg[k]) +
					      " (degenerate face)";
				return false;
			}
		poly |= pg.size() > 3;
	}
	if (poly) {
		size_t np = polys.size();
		if (!triangulate(pts, polys, names, why))
			return false;
		notes.push_back("triangulated " + std::to_string(np) + " polygons into " +
		                std::to_string(polys.size()) + " triangles");
	}
	m.p.resize(pts.size());
	for (size_t i = 0; i < pts.size(); i++)
		m.p[i] = {pts[i].x(), pts[i].y(), pts[i].z()};
	m.f.resize(polys.size());
	for (size_t i = 0; i < polys.size(); i++)
		m.f[i] = {(int)polys[i][0], (int)polys[i][1], (int)polys[i][2]};
	return true;
}

bool validate(Mesh &m, bool weld, std::vector<std::string> &notes, std::string &why,
              long *selfintersect)
{
	/* Repeated corners: a face that is not a triangle (load refuses them in
	 * the formats CGAL reads, naming the file's face; here assimp's). */
	for (size_t i = 0; i < m.f.size(); i++) {
		const Tri &t = m.f[i];
		if (t[0] == t[1] || t[1] == t[2] || t[2] == t[0]) {
			why = "face " + std::to_string(i) + " repeats vertex " +
			      std::to_string((t[0] == t[1] || t[0] == t[2] ? t[0] : t[1]) + m.base) +
			      " (degenerate face)";
			return false;
		}
	}
	/* Drop unreferenced vertices (they would change the Euler number);
	 * file[v]: the number the file gives vertex v, for messages. */
	std::vector<long> file(m.p.size());
	for (size_t v = 0; v < m.p.size(); v++)
		file[v] = (long)v + m.base;
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
		std::vector<long> fq(nv);
		for (size_t v = 0; v < m.p.size(); v++)
			if (used[v] >= 0)
				q[used[v]] = m.p[v], fq[used[v]] = file[v];
		m.p.swap(q);
		file.swap(fq);
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
		      " shared by more than two faces (first: vertices " + std::to_string(file[ea]) +
		      "–" + std::to_string(file[eb]) + ")";
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
	auto border_edges = [&sm]() {
		long b = 0;
		for (auto h : sm.halfedges())
			b += sm.is_border(h);
		return b;
	};
	long welded = 0, open_before = 0;
	if (!CGAL::is_closed(sm) && weld) {
		/* A mesh split along its UV or normal seams (how OBJ and glTF
		 * exporters write textured models) is open only where the split
		 * copies meet: CGAL stitches border edges whose ends coincide. */
		open_before = border_edges();
		welded = (long)PMP::stitch_borders(sm);
		sm.collect_garbage();
		if (welded)
			notes.push_back("welded the surface's open seams: " +
			                plural(welded, "pair of coincident border edges",
			                       "pairs of coincident border edges") +
			                " stitched (UV or normal seams); --no-weld keeps them apart");
	}
	if (!CGAL::is_closed(sm)) {
		long b = border_edges();
		why = "open surface: " + plural(b, "boundary edge", "boundary edges");
		if (welded)
			why += " left after welding " + std::to_string(open_before - b) +
			       " coincident ones";
		else if (!weld)
			why += " (--no-weld: coincident vertices were kept apart)";
		why += "; remesh needs a closed surface";
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
	/* A surface that passes through itself is still remeshed (the grid
	 * follows it), but the user hears of it (CGAL's box-intersection
	 * test on the triangles). */
	if (selfintersect) {
		std::vector<std::pair<SM::Face_index, SM::Face_index>> pairs;
		PMP::self_intersections<CGAL::Parallel_if_available_tag>(faces(sm), sm,
		                                                         std::back_inserter(pairs));
		*selfintersect = (long)pairs.size();
		if (!pairs.empty())
			notes.push_back("warning: the input intersects itself: " +
			                plural((long)pairs.size(), "pair of faces", "pairs of faces") +
			                " cross (the grid follows the surface as it is)");
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
