/* sphere.h — point location on a triangulated sphere, shared by the
 * resampling (resample.cpp) and the rotation search (rotation.cpp).
 * Private to tools/remesh/. */
#ifndef NDO_REMESH_SPHERE_H
#define NDO_REMESH_SPHERE_H

#include "remesh.h"

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>

namespace remesh {

using KS = CGAL::Simple_cartesian<double>;
using Tri3 = KS::Triangle_3;
using TriIt = std::vector<Tri3>::const_iterator;
using Prim = CGAL::AABB_triangle_primitive<KS, TriIt>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<KS, Prim>>;

static inline double det3(const Vec3 &a, const Vec3 &b, const Vec3 &c)
{
	return a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
	       a[2] * (b[0] * c[1] - b[1] * c[0]);
}

static inline Vec3 rotate(const double R[9], const Vec3 &p)
{
	return {R[0] * p[0] + R[1] * p[1] + R[2] * p[2], R[3] * p[0] + R[4] * p[1] + R[5] * p[2],
	        R[6] * p[0] + R[7] * p[1] + R[8] * p[2]};
}

static inline Vec3 unrotate(const double R[9], const Vec3 &p)
{
	return {R[0] * p[0] + R[3] * p[1] + R[6] * p[2], R[1] * p[0] + R[4] * p[1] + R[7] * p[2],
	        R[2] * p[0] + R[5] * p[1] + R[8] * p[2]};
}

/* Positively oriented chord triangles that tile the sphere (a bijective
 * parameterization's, or the domain grid's), for locating directions.  The
 * chord triangles tile a polyhedron star-shaped about the centre, so the
 * ray from the centre through q meets the one triangle whose central
 * projection holds q.  Found by walking from a nearby triangle — each step
 * crosses the edge whose plane through the centre has q on its far side,
 * one to three steps from a neighbour's triangle — and, when there is no
 * hint or the walk takes too long (a walk can cycle where triangles are
 * very uneven), by an AABB tree's ray query. */
struct SphereIndex {
	const Vec3 *p = nullptr;             /* corner positions */
	const int32_t *t = nullptr;          /* 3 corner indices per triangle */
	size_t n = 0;                        /* triangles */
	std::vector<std::array<int, 3>> adj; /* neighbour across the edge opposite corner k */
	std::vector<Tri3> tris;
	Tree tree;

	/* id[c]: the vertex corner index c stands for (stored grid duplicates
	 * share one); edges match on ids. */
	void build(const Vec3 *pts, const int32_t *tri, size_t ntri, const int32_t *id);

	/* The triangle whose central projection holds q (any length), walking
	 * from `hint` (or −1), and q's central-projection barycentrics in b. */
	int find(const Vec3 &q, double b[3], int hint) const;
};

struct SphereLocator {
	const Mesh &m;
	const std::vector<Vec3> &s; /* the parameterization */
	SphereIndex idx;
	std::vector<Vec3> normal;         /* unit normals of the input faces */
	std::vector<std::vector<int>> vf; /* input faces around each vertex */
	std::vector<int> order, parent;   /* vertices breadth first, each one's predecessor */
	SphereLocator(const Mesh &mesh, const std::vector<Vec3> &sphere) : m(mesh), s(sphere) {}
};

/* The surface point with parameter q; *face: a face to walk from (or −1),
 * on return the face found. */
Vec3 locate_face(const SphereLocator *l, const Vec3 &q, int *face);

/* Positions of every stored node of a level-L grid whose domain points
 * are d, rotated by R: canonical nodes located once, then copied to their
 * duplicates (ndo_sync), so the grid closes exactly.  faces (W*H or
 * NULL): the input face each node lies on. */
void sample(const SphereLocator *l, int level, const std::vector<Vec3> &d, const double R[9],
            double *pos, int *faces, bool show);

} // namespace remesh
#endif
