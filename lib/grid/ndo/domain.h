/* ndo/domain.h — the tetrahedral domain and its maps to the sphere
 * (thesis §4.2.2.1, figures 4.4–4.5).
 *
 * The grid rectangle unfolds a regular tetrahedron with vertices A, B, C,
 * D (unit circumradius, centred at the origin) into four faces:
 *   ABC = nodes i + j ≤ N, i ≤ N          BDC = i ≤ N, i + j ≥ N
 *   BAD = i ≥ N, (i − N) + j ≤ N          ACD = i ≥ N, (i − N) + j ≥ N
 * each listed counter-clockwise seen from outside.
 */
#ifndef NDO_DOMAIN_H
#define NDO_DOMAIN_H

#ifdef __cplusplus
extern "C" {
#endif

enum { NDO_A = 0, NDO_B = 1, NDO_C = 2, NDO_D = 3 };

/* Vertex positions, unit length: A = (1,1,1)/√3, B = (1,−1,−1)/√3,
 * C = (−1,1,−1)/√3, D = (−1,−1,1)/√3. */
extern const double ndo_tetra_vertex[4][3];

/* The faces as vertex triples, counter-clockwise from outside:
 * ABC, BDC, BAD, ACD. */
extern const int ndo_tetra_face[4][3];

/* How the tetrahedron is mapped onto the unit sphere. */
typedef enum ndo_sphere_map {
	/* Central projection of the flat faces (thesis figure 4.4): triangles
	 * near the tetrahedron's vertices come out up to 27 times smaller
	 * than those at face centres. */
	NDO_MAP_GNOMONIC = 0,
	/* Snyder's equal-area polyhedral projection (Snyder 1992, "An
	 * equal-area map projection for polyhedral globes") applied to the
	 * tetrahedron: each face splits into six right triangles about its
	 * centre and is mapped so that equal areas on the face cover equal
	 * areas of the sphere.  Continuous across faces, exact on every seam. */
	NDO_MAP_EQUAL_AREA = 1
} ndo_sphere_map;

/* The face (0..3) and barycentric coordinates (with respect to that face's
 * vertices in ndo_tetra_face order) of stored node (i, j) at `level`.
 * Nodes on a face boundary get one of their faces. */
void ndo_domain_locate(int level, int i, int j, int *face, double bary[3]);

/* The point of face `face` at barycentric `bary` on the flat tetrahedron. */
void ndo_domain_tetra(int face, const double bary[3], double p[3]);

/* The same point mapped onto the unit sphere. */
void ndo_domain_sphere(ndo_sphere_map map, int face, const double bary[3],
                       double s[3]);

/* The thesis' stretch-optimized gnomonic projection (§4.2.2.1, eqs.
 * 4.3–4.6, figure 4.5b): the level-`level` grid's nodes start at their
 * gnomonic images and relax as a spring embedder on the sphere — each
 * node to the stiffness-weighted mean of its six neighbours, stiffness of
 * an edge = 1 + the standardized area of its two triangles (floored at
 * 0.05), so large triangles pull tight and small ones open up — for
 * `iterations` damped sweeps at levels 1 and 2; finer levels are the
 * normalized edge midpoints of the coarser one (geodesic subdivision).
 * Relaxing finer levels too makes areas less uniform, not more (measured
 * min/max chord-triangle area at level 7: 0.29 relaxing levels ≤ 2, 0.11
 * relaxing ≤ 4, 0.001 relaxing all — zero-length springs converge to a
 * nearly conformal map, which piles area up at the four 180° cone points;
 * the gnomonic projection gives 0.04 at level 5).  Unlike the two maps
 * above it exists only at grid nodes.
 * s: W*H*3 doubles (row-major stored nodes, ndo_node()), unit vectors,
 * stored duplicates equal.  NDO_ERANGE for a bad level or count,
 * NDO_ENOMEM. */
int ndo_domain_spring(int level, int iterations, double *s);

#ifdef __cplusplus
}
#endif
#endif
