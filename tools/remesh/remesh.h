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
	int base = 0; /* the number the file gives its first vertex, for messages:
	                 1 for OBJ, 0 for the other formats */
};

/* Read `path` ("-" or empty: stdin).  OFF, OBJ, PLY and STL go through
 * CGAL's readers, which keep the file's own vertex indexing (STL has none:
 * its reader merges exactly equal points, the only sharing STL can say);
 * every other format goes through assimp (PLY triangle strips too; from a
 * file, so a .gltf finds its .bin), whose loaders split vertices at
 * attribute seams, so there exactly equal positions are merged when
 * `weld`.  Never merges by proximity.  Every coordinate must be finite
 * and within ±1e100 (else the vertex as the file numbers it is named).
 * Polygons are triangulated (CGAL) without creating an edge the mesh
 * already has.  On standard input the format is recognized from the
 * bytes (OFF, OBJ, PLY, ASCII and binary STL, glTF, GLB).  A face that
 * refers to a vertex the file lacks (OBJ's 0, a relative reference before
 * the first vertex), repeats one or has fewer than three is refused.
 * Returns false with a one-line reason in *why, naming faces and vertices
 * as the file numbers them: OBJ from 1 (a face by its place among the `f`
 * lines and its line; a relative reference as written too), OFF and PLY
 * from 0 (an OFF face with its line), STL by facet and corner; m.base
 * says which for validate's messages. */
bool load(const std::string &path, Mesh &m, bool weld, std::vector<std::string> &notes,
          std::string &why);

/* CGAL validation: triangle mesh, no degenerate faces, manifold, closed,
 * one component, Euler characteristic 2, outward orientation (a vertex
 * named as the file numbers it, m.base, whatever was dropped).  Inward
 * orientation is fixed in place (and noted).  Unreferenced vertices are
 * dropped (and noted).  An open surface whose border edges coincide in
 * pairs (split along UV seams) is stitched when `weld` (CGAL
 * stitch_borders; noted).  With `selfintersect`, the pairs of faces that
 * intersect are counted there (and noted as a warning).  False with the
 * defect in *why ("genus 2 (Euler characteristic -2); remesh needs
 * genus 0"). */
bool validate(Mesh &m, bool weld, std::vector<std::string> &notes, std::string &why,
              long *selfintersect);

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
	double conformal = 0.35; /* hierarchical: weight of the inverse map's Dirichlet energy */
	double importance = 0.5; /* hierarchical: curvature importance (0: plain L2 stretch) */
	double guard = 12;       /* hierarchical: anisotropy Γ/γ the guard allows (0: off) */
	bool fade = true;        /* hierarchical: fade the inverse term and importance (not
	                          * for a split copy, see hierarchical()) */
	int level = 0;           /* hierarchical: the grid level it is for (importance's scale) */
};
struct ParamStats {
	double efficiency = 0; /* L2 stretch efficiency (Sander 2001, 1 = isometric) */
	double efficiency_sphere = 0; /* the same as Praun–Hoppe measure it: spherical triangles */
	long flips = 0;        /* spherical triangles with det(s_a, s_b, s_c) <= 0 */
	double sliver_share = 0; /* share of the surface mapped with anisotropy Γ/γ > 10 */
	int base_vertices = 0; /* hierarchical: vertices of the base mesh */
	long placement_failures = 0; /* hierarchical: splits with no kernel point found (0 expected) */
	int subdivided = 0;    /* times the input was split 1-to-4 first (param_mesh) */
	size_t faces = 0;      /* faces parameterized */
};
/* The mesh the parameterization works on: m, split 1-to-4 at its edge
 * midpoints (the same surface) as long as that leaves at most twice the
 * level's grid triangles, and at most 100 000 faces.  Within one face the
 * parameterization is linear, so a grid finer than the input samples each
 * large face uniformly however curved its surroundings; smaller faces let
 * the samples gather at creases and tips (cactus, 1236 faces, at level 7:
 * Hausdorff 0.59% → 0.37%).  Returns the number of splits (0: out = m). */
int param_mesh(const Mesh &m, int level, Mesh &out);
void parameterize(const Mesh &m, const ParamOptions &o, std::vector<Vec3> &s,
                  ParamStats &st);
/* L2 stretch efficiency (ΣA)² / (E·ΣA') of the map from the chord
 * triangles of s to the mesh, the same over spherical triangles as
 * Praun–Hoppe's SphereParam measures it ((ΣA)² / (E_sph·4π)), and the
 * flipped count. */
void param_measure(const Mesh &m, const std::vector<Vec3> &s, ParamStats &st);

/* Domain → sphere maps for every stored node of a level-L grid.  Blend:
 * the equal-area map's images moved a share `blend` of the way towards
 * the gnomonic map's (normalized), which samples the neighbourhoods of
 * the tetrahedron's corners more densely (0: equal-area, 1: gnomonic). */
enum class DomainMap { Gnomonic, EqualArea, Blend, Spring };
struct Domain {
	DomainMap map = DomainMap::Blend;
	double blend = 0.3;
};
void domain_points(const Domain &dom, int level, std::vector<Vec3> &d);

/* Resampling. */
struct SphereLocator; /* point location on the parameterized sphere (sphere.h) */
SphereLocator *locator_create(const Mesh &m, const std::vector<Vec3> &s);
void locator_destroy(SphereLocator *l);

/* The rotation R (row-major 3×3, applied to the domain's points) for a
 * grid of `level`: the identity and `rotations` random rotations (fixed
 * seed) screened one level coarser, the best four and 24 small turns from
 * the best at the level itself (at most 7), by the estimated Hausdorff
 * distance to the input times 1 + 30 × the share of folded triangles
 * (rotation.cpp). */
struct RotationResult {
	int level = 0;     /* the level of the estimates */
	int evaluated = 0; /* rotations evaluated */
	double hausdorff_before = 0, hausdorff_after = 0; /* estimated, absolute, identity → R */
	long flipped_before = 0, flipped_after = 0;       /* estimated fold-overs */
};
void optimize_rotation(const SphereLocator *l, const Domain &dom, int level, int rotations,
                       double R[9], RotationResult &res);
/* Fill the grid's positions: every canonical node once, then ndo_sync. */
void resample(const SphereLocator *l, const Domain &dom, const double R[9], ndo_grid *g);

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
double bbox_diagonal(const Mesh &m);
void measure_quality(const Mesh &input, const ndo_grid *g, bool distances,
                     bool selfint, Quality &q);

double now_seconds();

} // namespace remesh
#endif
