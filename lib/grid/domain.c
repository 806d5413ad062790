/* domain.c — the tetrahedral domain and its gnomonic and equal-area maps
 * onto the sphere (ndo/domain.h). */
#include "ndo/domain.h"

#include <math.h>

#define R3 0.57735026918962576451 /* 1/√3 */

const double ndo_tetra_vertex[4][3] = {
	{R3, R3, R3}, {R3, -R3, -R3}, {-R3, R3, -R3}, {-R3, -R3, R3}};

const int ndo_tetra_face[4][3] = {
	{NDO_A, NDO_B, NDO_C}, {NDO_B, NDO_D, NDO_C},
	{NDO_B, NDO_A, NDO_D}, {NDO_A, NDO_C, NDO_D}};

void ndo_domain_locate(int level, int i, int j, int *face, double bary[3])
{
	int n = 1 << level;
	double inv = 1.0 / n; /* exact: n is a power of two */
	int u = i <= n ? i : i - n, first = i <= n;
	if (u + j <= n) {       /* ABC or BAD: (1−u−v, u, v) */
		*face = first ? 0 : 2;
		bary[0] = (n - u - j) * inv;
		bary[1] = u * inv;
		bary[2] = j * inv;
	} else {                /* BDC or ACD: (1−v, u+v−1, 1−u) */
		*face = first ? 1 : 3;
		bary[0] = (n - j) * inv;
		bary[1] = (u + j - n) * inv;
		bary[2] = (n - u) * inv;
	}
}

void ndo_domain_tetra(int face, const double b[3], double p[3])
{
	const double *v0 = ndo_tetra_vertex[ndo_tetra_face[face][0]],
	             *v1 = ndo_tetra_vertex[ndo_tetra_face[face][1]],
	             *v2 = ndo_tetra_vertex[ndo_tetra_face[face][2]];
	for (int k = 0; k < 3; k++)
		p[k] = b[0] * v0[k] + b[1] * v1[k] + b[2] * v2[k];
}

static double dot(const double a[3], const double b[3])
{
	return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void normalize(double a[3])
{
	double r = sqrt(dot(a, a));
	a[0] /= r, a[1] /= r, a[2] /= r;
}

/* The inverse of Snyder's equal-area projection on one of the six right
 * triangles (centre p, edge midpoint m, vertex v) of a face.  On the
 * sphere the triangle P M V has a right angle at M, the angle G = 60° at
 * P, and area 4π/24 = π/6.
 *  1. The azimuth Az of q about p (from pm) becomes Az' such that the
 *     spherical triangle P M Q' covers the same fraction of π/6 as the
 *     flat triangle p m q' covers of p m v (q' on the edge): that fraction
 *     is tan Az / tan G, and a right spherical triangle with leg g = PM
 *     and angle Az' at P has area S with tan Az' = sin S / (cos S − cos g).
 *  2. Along the ray, the fraction t = |pq| / |pq'| becomes the arc z with
 *     1 − cos z = t² (1 − cos z'), z' = |PQ'| = atan(tan g / cos Az'),
 *     so that areas within the wedge scale like the flat t². */
static void equal_area(int face, const double b[3], double s[3])
{
	const int *fv = ndo_tetra_face[face];
	int k = 0;
	for (int m = 1; m < 3; m++)
		if (b[m] > b[k])
			k = m;
	int l = (k + 1) % 3, o = (k + 2) % 3;
	if (b[o] > b[l])
		l = o;
	const double *tk = ndo_tetra_vertex[fv[k]], *tl = ndo_tetra_vertex[fv[l]];
	double p[3], m[3], q[3], e1[3], e2[3];
	ndo_domain_tetra(face, (const double[3]){1.0 / 3, 1.0 / 3, 1.0 / 3}, p);
	ndo_domain_tetra(face, b, q);
	for (int c = 0; c < 3; c++) {
		m[c] = 0.5 * (tk[c] + tl[c]);
		e1[c] = m[c] - p[c];
	}
	double pm = sqrt(dot(e1, e1));
	for (int c = 0; c < 3; c++)
		e1[c] /= pm;
	for (int c = 0; c < 3; c++)
		e2[c] = tk[c] - p[c];
	double a = dot(e2, e1);
	for (int c = 0; c < 3; c++)
		e2[c] -= a * e1[c];
	normalize(e2);
	double x = 0, y = 0;
	for (int c = 0; c < 3; c++) {
		x += (q[c] - p[c]) * e1[c];
		y += (q[c] - p[c]) * e2[c];
	}
	double P[3] = {p[0], p[1], p[2]}, M[3] = {m[0], m[1], m[2]};
	normalize(P);
	normalize(M);
	if (x <= 0) { /* the face centre itself */
		s[0] = P[0], s[1] = P[1], s[2] = P[2];
		return;
	}
	double cosg = dot(P, M), g = acos(cosg);
	double S = (M_PI / 6) * (y / x) / sqrt(3.0);   /* tan Az / tan 60° of π/6 */
	double az = atan2(sin(S), cos(S) - cosg);
	double zedge = atan(tan(g) / cos(az));
	double t = x / pm;                              /* |pq| / |pq'| */
	double z = 2 * asin(fmin(1.0, t * sin(zedge / 2)));
	/* unit tangents at P: E1 towards M, E2 towards the vertex side */
	double E1[3], E2[3], V[3] = {tk[0], tk[1], tk[2]};
	normalize(V);
	double pmc = dot(M, P), pvc = dot(V, P);
	for (int c = 0; c < 3; c++) {
		E1[c] = M[c] - pmc * P[c];
		E2[c] = V[c] - pvc * P[c];
	}
	normalize(E1);
	double a2 = dot(E2, E1);
	for (int c = 0; c < 3; c++)
		E2[c] -= a2 * E1[c];
	normalize(E2);
	double ca = cos(az), sa = sin(az), cz = cos(z), sz = sin(z);
	for (int c = 0; c < 3; c++)
		s[c] = cz * P[c] + sz * (ca * E1[c] + sa * E2[c]);
	normalize(s);
}

void ndo_domain_sphere(ndo_sphere_map map, int face, const double b[3], double s[3])
{
	if (map == NDO_MAP_EQUAL_AREA) {
		equal_area(face, b, s);
		return;
	}
	ndo_domain_tetra(face, b, s);
	normalize(s);
}
