/* remesh.h — the pieces of the remesh tool (C++17; CGAL, Eigen): input
 * loading and validation, spherical parameterization, resampling onto the
 * tetrahedral grid, quality measures.  The library (lib/) stays C; this
 * header is private to tools/remesh/. */
#ifndef NDO_REMESH_H
#define NDO_REMESH_H

#include <array>
#include <cstdint>
#include <string>
#include <vector>

extern "C" {
#include "ndo/ndo.h"
}

namespace remesh {

using Vec3 = std::array<double, 3>;
using Tri = std::array<int, 3>;

/* An indexed triangle mesh: closed, manifold, genus 0 and outward once
 * validate() accepted it. */
struct Mesh {
	std::vector<Vec3> p;
	std::vector<Tri> f;
};

/* Read `path` ("-" or empty: stdin).  OFF, OBJ, PLY and STL go through
 * CGAL's readers, which keep the file's own vertex indexing (STL has none:
 * its reader merges exactly equal points, the only sharing STL can say);
 * every other format goes through assimp, whose loaders split vertices
 * at attribute seams, so there exactly equal positions are merged.  Never
 * merges by proximity.  Polygons are triangulated (CGAL).  Returns false
 * with a one-line reason in *why. */
bool load(const std::string &path, Mesh &m, std::vector<std::string> &notes,
          std::string &why);

/* CGAL validation: triangle mesh, no degenerate faces, manifold, closed,
 * one component, Euler characteristic 2, outward orientation.  Inward
 * orientation is fixed in place (and noted).  Unreferenced vertices are
 * dropped (and noted).  False with the defect in *why ("genus 2 (Euler
 * characteristic -2); remesh needs genus 0"). */
bool validate(Mesh &m, std::vector<std::string> &notes, std::string &why);

/* Progress on stderr (a bar when stderr is a terminal, nothing otherwise). */
void progress(const char *phase, double fraction);
void progress_done();

/* Spherical parameterization: s[v] on the unit sphere for every vertex. */
enum class ParamMethod { Hierarchical, Spring };
struct ParamOptions {
	ParamMethod method = ParamMethod::Hierarchical;
	int sweeps = 6;          /* final full-resolution optimization sweeps */
	int spring_steps = 400;  /* spring embedder: time steps */
	double spring_c = 0.95;  /* spring embedder: the thesis' C (eq. 4.4) */
	int relax = 1;           /* spring embedder: relaxation (eq. 4.7) on */
};
struct ParamStats {
	double efficiency = 0; /* L2 stretch efficiency (Sander 2001, 1 = isometric) */
	long flips = 0;        /* spherical triangles with det(s_a, s_b, s_c) <= 0 */
	int base_vertices = 0; /* hierarchical: vertices of the base mesh */
	long placement_failures = 0; /* hierarchical: splits with no kernel point found (0 expected) */
};
void parameterize(const Mesh &m, const ParamOptions &o, std::vector<Vec3> &s,
                  ParamStats &st);
/* L2 stretch efficiency (ΣA)² / (E·ΣA') of the map from the chord
 * triangles of s to the mesh, and the flipped count. */
void param_measure(const Mesh &m, const std::vector<Vec3> &s, ParamStats &st);

/* Domain → sphere maps for every stored node of a level-L grid. */
enum class DomainMap { Gnomonic, EqualArea, Spring };
void domain_points(DomainMap map, int level, std::vector<Vec3> &d);

/* Resampling. */
struct SphereLocator; /* AABB tree over the parameterized chord triangles */
SphereLocator *locator_create(const Mesh &m, const std::vector<Vec3> &s);
void locator_destroy(SphereLocator *l);
/* The surface point whose parameter is the direction q (any length). */
Vec3 locate(const SphereLocator *l, const Vec3 &q);

/* The rotation R (row-major 3×3) of the domain that minimizes the
 * Dirichlet energy of the resampled grid (the L2 stretch of the map from
 * the flat tetrahedron to the surface, sampled at a coarse level). */
void optimize_rotation(const SphereLocator *l, DomainMap map, double R[9],
                       double *energy_before, double *energy_after);
/* Fill the grid's positions: every canonical node once, then ndo_sync. */
void resample(const SphereLocator *l, DomainMap map, const double R[9],
              ndo_grid *g);

/* Quality of the remesh against the input, distances over the input's
 * bounding-box diagonal. */
struct Quality {
	double diag = 0;
	double hausdorff = -1, rms = -1; /* relative to diag; -1: not measured */
	long flipped = -1;               /* remesh faces against nearest input face */
	long selfintersect = -1;         /* self-intersecting face pairs */
	double area_ratio = 0;           /* min / max remesh triangle area */
	double efficiency = 0;           /* L2 stretch efficiency of tetra → surface */
	long degenerate = 0;             /* zero-area remesh triangles */
	int euler = 0;                   /* V − E + F of the remesh */
	bool closed_manifold = false;
};
void grid_mesh(const ndo_grid *g, Mesh &out);
void measure_quality(const Mesh &input, const ndo_grid *g, bool distances,
                     bool selfint, Quality &q);

double now_seconds();

} // namespace remesh
#endif
