/* param.cpp — spherical parameterization of a closed genus-0 mesh.
 *
 * Default (hierarchical): Praun & Hoppe 2003, §4 — simplify the mesh by
 * half-edge collapses (Garland–Heckbert quadrics) down to a tetrahedron,
 * embed that on the sphere, then undo the collapses one by one: each
 * vertex comes back at a point of the kernel of its one-ring (so no
 * spherical triangle flips), and vertices move only by steps that lower
 * the L2 stretch (Sander et al. 2001) and keep every incident triangle
 * positively oriented.  The result is a bijection by construction: every
 * chord triangle keeps det(s_a, s_b, s_c) > 0 at all times, and the map
 * never passes through a degenerate triangle (the set of valid positions
 * of one vertex is an intersection of hemispheres, hence convex, and each
 * move follows a great-circle arc inside it).
 *
 * Alternative (spring): the thesis' spring embedder (§4.2.2.1, eqs.
 * 4.3–4.7) started from the gnomonic projection of the mesh, with
 * relaxation.  Nothing stops it from folding; flips are counted and
 * reported. */
#include "remesh.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <queue>
#include <stdexcept>
#include <unordered_map>

namespace remesh {

static inline Vec3 sub(const Vec3 &a, const Vec3 &b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
static inline Vec3 add(const Vec3 &a, const Vec3 &b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
static inline Vec3 mul(const Vec3 &a, double s) { return {a[0] * s, a[1] * s, a[2] * s}; }
static inline double dot(const Vec3 &a, const Vec3 &b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
static inline Vec3 cross(const Vec3 &a, const Vec3 &b)
{
	return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
static inline double norm(const Vec3 &a) { return std::sqrt(dot(a, a)); }
static inline Vec3 unit(const Vec3 &a) { return mul(a, 1.0 / norm(a)); }
static inline double det3(const Vec3 &a, const Vec3 &b, const Vec3 &c) { return dot(a, cross(b, c)); }

static const double INF = std::numeric_limits<double>::infinity();

/* Orientation of the chord triangle a b c seen from outside: the normal
 * from edge differences (accurate for tiny triangles, where the triple
 * product a·(b×c) of nearly parallel unit vectors is all rounding) along
 * the centroid.  Positive: counter-clockwise, not flipped. */
static inline double orient(const Vec3 &a, const Vec3 &b, const Vec3 &c)
{
	return dot(cross(sub(b, a), sub(c, a)), add(add(a, b), c));
}

/* A parameter triangle counts as valid only with a margin: orient > 0 and
 * area / (longest edge)² above 1e-10 (about 1/10 of the shape rounding
 * can still resolve), so that later moves of the other corners, each
 * checked in its own rounding, cannot tip it over. */
static inline bool valid_triangle(const Vec3 &a, const Vec3 &b, const Vec3 &c)
{
	Vec3 e0 = sub(b, a), e1 = sub(c, b), e2 = sub(a, c);
	double l = std::max(dot(e0, e0), std::max(dot(e1, e1), dot(e2, e2)));
	Vec3 n = cross(e0, sub(c, a));
	double o = dot(n, add(add(a, b), c));
	return o > 6e-13 * l && o > 3e-3 * norm(n); /* plane 0.001 off the centre */
}

/* The energy of one triangle: its stretch A3 · ‖J‖² / 2 (Sander 2001: A3
 * the surface area, J the Jacobian of the map from the parameter triangle
 * p0 p1 p2 to the surface triangle), with ‖J‖² = Σ_i L_i cot θ_i / (2 A_p)
 * = Σ_i L_i (−e_j·e_k) / (4 A_p²) (L_i the squared surface edge opposite
 * corner i, θ_i the parameter angle at i); plus mu times the Dirichlet
 * energy of the inverse map, A3 · ‖J⁻¹‖² / 2 = Σ_i L_i (−e_j·e_k) / (8 A3)
 * (the same sum: the inverse's stretch, which grows where the parameter
 * triangle is large or thin for its surface triangle).  Stretch alone lets
 * parameter triangles go thin for free (only the larger singular value
 * costs), and the resampled grid then folds over where they are; the
 * inverse term keeps them round, pulling towards a conformal map.  +∞ if
 * the parameter triangle is flipped or degenerate. */
struct FaceGeom {
	double a3;     /* surface area */
	double L[3];   /* squared surface edge lengths opposite each corner */
	double mu = 0; /* weight of the inverse map's Dirichlet energy */
	double gk = 0, gm = 0; /* anisotropy guard: weight, bound (below) */
};

/* The anisotropy guard: gk (M / gm − 1)² where M = ‖J‖² / det J = Γ/γ +
 * γ/Γ (the MIPS energy: 2 for a similar triangle, about the ratio Γ/γ of
 * the singular values for a thin one) exceeds gm; nothing below.  The
 * grid's fold-overs sit on such slivers: on bunny00 half of them on the
 * 0.4% of the surface where Γ/γ > 20 (median Γ/γ of all faces 1.5), and
 * curvature or undersampling (Γ) pick them out far worse.  Unlike the
 * inverse term, which pulls every triangle towards a similar one at a
 * cost in stretch everywhere, the guard only caps the anisotropy. */
static inline double guard_energy(const FaceGeom &g, double N, double c2)
{
	if (!(g.gk > 0))
		return 0;
	double M = N / (2 * g.a3 * std::sqrt(c2));
	return M > g.gm ? g.gk * (M / g.gm - 1) * (M / g.gm - 1) : 0;
}

static FaceGeom face_geom(const std::vector<Vec3> &X, const Tri &t, bool floor = true)
{
	FaceGeom g;
	const Vec3 &x0 = X[t[0]], &x1 = X[t[1]], &x2 = X[t[2]];
	g.a3 = 0.5 * norm(cross(sub(x1, x0), sub(x2, x0)));
	Vec3 e0 = sub(x2, x1), e1 = sub(x0, x2), e2 = sub(x1, x0);
	g.L[0] = dot(e0, e0), g.L[1] = dot(e1, e1), g.L[2] = dot(e2, e2);
	/* A sliver's area is no barrier: E ≥ A3²/A_p lets a parameter
	 * triangle whose surface triangle has no area collapse for free, and
	 * its degenerate neighbours then leave no room to split a vertex.
	 * Weigh each triangle by at least 5% of the area of an equilateral
	 * triangle with its mean squared edge (a change to the objective for
	 * slivers only). */
	double eq = std::sqrt(3.0) / 12 * (g.L[0] + g.L[1] + g.L[2]);
	if (floor)
		g.a3 = std::max(g.a3, 0.05 * eq);
	return g;
}

/* Area of the spherical triangle a b c (van Oosterom & Strackee 1983). */
static inline double sphere_area(const Vec3 &a, const Vec3 &b, const Vec3 &c)
{
	return 2 * std::atan2(det3(a, b, c), 1 + dot(a, b) + dot(b, c) + dot(c, a));
}

static double face_energy(const FaceGeom &g, const Vec3 &p0, const Vec3 &p1, const Vec3 &p2,
                          bool barrier = true)
{
	if (!valid_triangle(p0, p1, p2))
		return INF;
	Vec3 a = sub(p1, p0), b = sub(p2, p0), e0 = sub(p2, p1);
	Vec3 c = cross(a, b);
	double c2 = dot(c, c);
	if (!(c2 > 1e-300))
		return INF;
	double N = g.L[0] * dot(a, b) - g.L[1] * dot(a, e0) + g.L[2] * dot(b, e0);
	/* A3/8 · N / A_p² (A_p² = |c|²/4), divided by h, the distance of the
	 * chord triangle's plane from the centre: h ≈ 1 for the small
	 * triangles of a fine mesh, → 0 for a triangle that spreads over a
	 * hemisphere, whose flat area then says nothing of its spherical one;
	 * without the barrier coarse levels would collapse onto great circles. */
	double h = barrier ? dot(c, add(add(p0, p1), p2)) / (3 * std::sqrt(c2)) : 1;
	if (barrier) {
		/* A long thin triangle (an "accordion" fold: corners far apart
		 * near one great circle) has a chord triangle standing off the
		 * sphere, with q = A_p / A_sph times its spherical area and
		 * about 1/q of its spherical height: its stretch on the sphere
		 * is about q² that of the chord.  Charged so when q² > 1/h
		 * (only such needles: q ≈ 1 for small triangles, < 1 for the
		 * large ones of coarse levels, which keep the barrier).  Without
		 * it the optimizer packs thin parts into fans of needles whose
		 * chord area exceeds the sphere's (man: chord areas 1.135 × 4π),
		 * good on chords and bad on the sphere (stretch efficiency of
		 * man 0.219 on chords, 0.189 on spherical triangles; with it
		 * 0.215 on both, and fold-overs 1581 → 850). */
		double as = sphere_area(p0, p1, p2);
		if (!(as > 0))
			return INF;
		double q = 0.5 * std::sqrt(c2) / as;
		if (q * q * h > 1)
			return 0.5 * g.a3 * N / c2 * q * q + g.mu * N / g.a3 + guard_energy(g, N, c2);
	}
	return 0.5 * g.a3 * N / c2 / h + g.mu * N / g.a3 + guard_energy(g, N, c2);
}

/* Its gradient with respect to p0 (p1, p2 fixed): with E = (A3/2) N/|c|²
 * + mu N / A3, ∇N = −L0 (a + b) + (L1 − L2) e0 and ∇|c|² = 2 c × e0;
 * the guard's M = N / (2 A3 |c|). */
static Vec3 face_grad0(const FaceGeom &g, const Vec3 &p0, const Vec3 &p1, const Vec3 &p2)
{
	Vec3 a = sub(p1, p0), b = sub(p2, p0), e0 = sub(p2, p1);
	Vec3 c = cross(a, b);
	double c2 = dot(c, c);
	double N = g.L[0] * dot(a, b) - g.L[1] * dot(a, e0) + g.L[2] * dot(b, e0);
	Vec3 gN = add(mul(add(a, b), -g.L[0]), mul(e0, g.L[1] - g.L[2]));
	Vec3 gc = mul(cross(c, e0), 2 * N / c2);
	Vec3 gE = mul(sub(gN, gc), 0.5 * g.a3 / c2);
	double E = 0.5 * g.a3 * N / c2;
	const double cl = std::sqrt(c2);
	Vec3 gI = mul(gN, g.mu / g.a3); /* the inverse term and the guard */
	if (g.gk > 0) {
		double M = N / (2 * g.a3 * cl);
		if (M > g.gm) {
			Vec3 gM = sub(mul(gN, 1 / (2 * g.a3 * cl)), mul(cross(c, e0), N / (2 * g.a3 * cl * c2)));
			gI = add(gI, mul(gM, 2 * g.gk * (M / g.gm - 1) / g.gm));
		}
	}
	/* h = orient / (3|c|): ∇orient = S × e0 + c, ∇|c| = (c × e0)/|c| */
	Vec3 S = add(add(p0, p1), p2);
	double orient = dot(c, S), h = orient / (3 * cl);
	Vec3 gh = mul(sub(mul(add(cross(S, e0), c), cl), mul(cross(c, e0), orient / cl)), 1 / (3 * c2));
	{
		/* the needle branch of face_energy: E q², q = A_p / A_sph, with
		 * A_sph = 2 atan2(num, den) (van Oosterom & Strackee) */
		double num = det3(p0, p1, p2);
		double den = 1 + dot(p0, p1) + dot(p1, p2) + dot(p2, p0);
		double as = 2 * std::atan2(num, den), ap = 0.5 * cl;
		double q = ap / as;
		if (as > 0 && q * q * h > 1) {
			Vec3 gap = mul(cross(c, e0), 0.5 / cl);
			Vec3 gas = mul(sub(mul(cross(p1, p2), den), mul(add(p1, p2), num)), 2 / (num * num + den * den));
			Vec3 gq = sub(mul(gap, 1 / as), mul(gas, ap / (as * as)));
			Vec3 r = add(mul(gE, q * q), mul(gq, 2 * q * E));
			return add(r, gI);
		}
	}
	return add(sub(mul(gE, 1 / h), mul(gh, E / (h * h))), gI);
}

/* Praun–Hoppe's measure of one face (their SphereParam's efficiency):
 * Σ A3 Γ² over the parameter triangle taken as the sphere sees it, not
 * as its chord — split at the point of the longest edge's great circle
 * nearest the opposite corner, so that a long thin spherical triangle,
 * whose chord triangle stands up off the sphere with far more area (the
 * "accordion"), counts with its small spherical area.  Γ² = ‖J‖²/2 of
 * each half (domain → surface, the surface point on the split edge
 * interpolated linearly), weighed by the half's surface area. */
static double half_stretch(const Vec3 &d0, const Vec3 &d1, const Vec3 &d2, const Vec3 &x0,
                           const Vec3 &x1, const Vec3 &x2)
{
	Vec3 a = sub(d1, d0), b = sub(d2, d0);
	double la = norm(a), u = dot(b, a) / la, v = std::sqrt(std::max(0.0, dot(b, b) - u * u));
	Vec3 ja = mul(sub(x1, x0), 1 / la);                     /* ∂x/∂u */
	Vec3 jb = mul(sub(sub(x2, x0), mul(ja, u)), 1 / v);      /* ∂x/∂v */
	double a3 = 0.5 * norm(cross(sub(x1, x0), sub(x2, x0)));
	return 0.5 * (dot(ja, ja) + dot(jb, jb)) * a3;
}

static double sphere_face_stretch(const Vec3 d[3], const Vec3 x[3])
{
	double l[3];
	for (int i = 0; i < 3; i++) {
		Vec3 e = sub(d[(i + 1) % 3], d[(i + 2) % 3]);
		l[i] = dot(e, e);
	}
	int i = l[0] > l[1] ? (l[0] > l[2] ? 0 : 2) : (l[1] > l[2] ? 1 : 2);
	int j = (i + 1) % 3, k = (i + 2) % 3;
	Vec3 n = unit(cross(d[j], d[k]));
	Vec3 q = unit(sub(d[i], mul(n, dot(n, d[i])))); /* on arc j k, nearest i */
	/* q = d_k + t (d_j − d_k) projected to the sphere: t from the chord */
	Vec3 e = sub(d[j], d[k]);
	double qe = dot(q, e), t = (qe * dot(q, d[k]) - dot(e, d[k])) / (l[i] - qe * qe);
	Vec3 xq = add(mul(x[j], t), mul(x[k], 1 - t));
	return half_stretch(q, d[i], d[j], xq, x[i], x[j]) + half_stretch(q, d[k], d[i], xq, x[k], x[i]);
}

void param_measure(const Mesh &m, const std::vector<Vec3> &s, ParamStats &st)
{
	double E = 0, A3 = 0, Ap = 0, Es = 0, Asliver = 0;
	long flips = 0;
	for (const Tri &t : m.f) {
		FaceGeom g = face_geom(m.p, t, false);
		const Vec3 &p0 = s[t[0]], &p1 = s[t[1]], &p2 = s[t[2]];
		if (orient(p0, p1, p2) <= 0) {
			flips++;
			continue;
		}
		/* Sander's measure as it is: no sliver floor, no barrier; a
		 * valid triangle too thin for face_energy's margin counts too */
		Vec3 a = sub(p1, p0), b = sub(p2, p0), e0 = sub(p2, p1);
		Vec3 c = cross(a, b);
		double N = g.L[0] * dot(a, b) - g.L[1] * dot(a, e0) + g.L[2] * dot(b, e0);
		E += 0.5 * g.a3 * N / dot(c, c);
		/* Γ/γ = r with r + 1/r = M = ‖J‖² / det J */
		double M = N / (2 * g.a3 * norm(c));
		if (0.5 * (M + std::sqrt(std::max(0.0, M * M - 4))) > 10)
			Asliver += g.a3;
		Vec3 d[3] = {p0, p1, p2}, x[3] = {m.p[t[0]], m.p[t[1]], m.p[t[2]]};
		Es += sphere_face_stretch(d, x);
		A3 += g.a3;
		Ap += 0.5 * norm(cross(sub(p1, p0), sub(p2, p0)));
	}
	st.flips = flips;
	st.sliver_share = A3 > 0 ? Asliver / A3 : 0;
	/* Scale the parameter to the surface's total area: L2² = E·ΣA_p/(ΣA3)². */
	st.efficiency = E > 0 && std::isfinite(E) ? A3 * A3 / (E * Ap) : 0;
	/* Praun–Hoppe's: the sphere's area 4π as the parameter's, and the
	 * spherical split above (equal to ours for small round triangles) */
	st.efficiency_sphere = Es > 0 && std::isfinite(Es) && flips == 0 ? A3 * A3 / (Es * 4 * M_PI) : 0;
}

/* How much each face matters for the grid of `level`: 1 + beta · min(8,
 * max(0, κ h − 1)) (only what is curved at the grid's scale: a weight on
 * every face costs stretch everywhere, which bunny00 cannot spare), with h the grid's mean edge length on this surface and κ a
 * curvature: the largest dihedral angle of the face over the distance
 * between the two centroids, averaged over about h (n Jacobi sweeps over
 * face neighbours spread over √n face widths).  A surface triangle that
 * matters w times as much is weighed as a similar triangle w times larger,
 * which for L2 stretch gives it w times the samples: the distance of a
 * linear interpolant from a curved surface grows like κ h², so curved
 * places (tips of thin parts, rims, creases) get the samples that bring
 * the Hausdorff distance down, flat places give them up. */
static std::vector<double> importance(const Mesh &m, int level, double beta, double k0)
{
	size_t nf = m.f.size();
	std::vector<double> imp(nf, 1.0);
	if (!(beta > 0) || level <= 0)
		return imp;
	std::vector<Vec3> n(nf), c(nf);
	std::vector<double> area(nf);
	double A = 0;
	for (size_t i = 0; i < nf; i++) {
		const Tri &t = m.f[i];
		Vec3 x = cross(sub(m.p[t[1]], m.p[t[0]]), sub(m.p[t[2]], m.p[t[0]]));
		double l = norm(x);
		area[i] = 0.5 * l;
		A += area[i];
		n[i] = l > 0 ? mul(x, 1 / l) : Vec3{0, 0, 0};
		c[i] = mul(add(add(m.p[t[0]], m.p[t[1]]), m.p[t[2]]), 1.0 / 3);
	}
	double T = std::pow(4.0, level + 1), h = std::sqrt(4 * A / (std::sqrt(3.0) * T));
	/* face adjacency */
	std::vector<std::pair<uint64_t, int>> e;
	for (size_t i = 0; i < nf; i++)
		for (int k = 0; k < 3; k++) {
			uint32_t a = m.f[i][k], b = m.f[i][(k + 1) % 3];
			e.push_back({(uint64_t)std::min(a, b) << 32 | std::max(a, b), (int)i});
		}
	std::sort(e.begin(), e.end());
	std::vector<std::vector<int>> adj(nf);
	std::vector<double> kap(nf, 0);
	double elen = 0;
	for (size_t i = 0; i + 1 < e.size(); i++)
		if (e[i].first == e[i + 1].first) {
			int a = e[i].second, b = e[i + 1].second;
			adj[a].push_back(b), adj[b].push_back(a);
			double ang = std::acos(std::max(-1.0, std::min(1.0, dot(n[a], n[b]))));
			double d = norm(sub(c[a], c[b]));
			elen += d;
			double k = d > 0 ? ang / d : 0;
			kap[a] = std::max(kap[a], k), kap[b] = std::max(kap[b], k);
			i++;
		}
	elen /= std::max<size_t>(1, e.size() / 2);
	int iters = (int)std::min(30.0, std::max(1.0, (h / elen) * (h / elen)));
	std::vector<double> nk(nf);
	for (int it = 0; it < iters; it++) {
		for (size_t i = 0; i < nf; i++) {
			double s = kap[i] * area[i], w = area[i];
			for (int j : adj[i])
				s += kap[j] * area[j], w += area[j];
			nk[i] = w > 0 ? s / w : kap[i];
		}
		kap.swap(nk);
	}
	for (size_t i = 0; i < nf; i++)
		imp[i] = 1 + beta * std::min(8.0, std::max(0.0, kap[i] * h - k0));
	return imp;
}

/* ---- the progressive mesh ------------------------------------------ */

namespace {

struct Quadric {
	double q[10] = {0}; /* a² ab ac ad b² bc bd c² cd d² */
	void add_plane(double a, double b, double c, double d, double w)
	{
		double v[4] = {a, b, c, d};
		int k = 0;
		for (int i = 0; i < 4; i++)
			for (int j = i; j < 4; j++)
				q[k++] += w * v[i] * v[j];
	}
	void operator+=(const Quadric &o)
	{
		for (int k = 0; k < 10; k++)
			q[k] += o.q[k];
	}
	double eval(const Vec3 &p) const
	{
		double x = p[0], y = p[1], z = p[2];
		return q[0] * x * x + 2 * q[1] * x * y + 2 * q[2] * x * z + 2 * q[3] * x +
		       q[4] * y * y + 2 * q[5] * y * z + 2 * q[6] * y + q[7] * z * z +
		       2 * q[8] * z + q[9];
	}
};

struct Collapse {
	int v, u;             /* v was collapsed into u */
	int fl, fr;           /* the two faces that vanished */
	std::vector<int> mod; /* faces in which v was replaced by u */
	double share, share0; /* surface area (weighted, plain) each face of mod took over from fl, fr */
};

struct Candidate {
	double cost;
	int v, u;
	unsigned sv, su;
	bool operator<(const Candidate &o) const { return cost > o.cost; }
};

struct Hier {
	const Mesh &m;
	std::vector<Tri> f;
	std::vector<char> falive, valive;
	std::vector<std::vector<int>> vf;
	std::vector<Collapse> rec;
	/* The surface each alive face stands for: its own, plus what the
	 * faces that vanished in collapses around it stood for (shared out
	 * equally among the faces whose corner changed, given back on the
	 * split), weighted by importance (w) and plain (w0). */
	std::vector<double> w, w0;
	int nalive;

	Hier(const Mesh &mesh, const std::vector<double> &imp)
	    : m(mesh), f(mesh.f), falive(mesh.f.size(), 1), valive(mesh.p.size(), 1),
	      vf(mesh.p.size()), nalive((int)mesh.p.size())
	{
		for (size_t i = 0; i < f.size(); i++)
			for (int v : f[i])
				vf[v].push_back((int)i);
		w.resize(f.size());
		w0.resize(f.size());
		for (size_t i = 0; i < f.size(); i++) {
			w0[i] = 0.5 * norm(cross(sub(m.p[f[i][1]], m.p[f[i][0]]), sub(m.p[f[i][2]], m.p[f[i][0]])));
			w[i] = imp[i] * w0[i];
		}
	}

	void ring(int v, std::vector<int> &out) const
	{
		out.clear();
		for (int fi : vf[v])
			for (int w : f[fi])
				if (w != v && std::find(out.begin(), out.end(), w) == out.end())
					out.push_back(w);
	}

	static void drop(std::vector<int> &l, int x)
	{
		auto it = std::find(l.begin(), l.end(), x);
		if (it != l.end()) {
			*it = l.back();
			l.pop_back();
		}
	}

	/* Half-edge collapse v → u legal?  Topology: the link condition (the
	 * common neighbours of u and v are exactly the two opposite corners),
	 * more than four vertices left.  Geometry (when `geom`): no face of v
	 * turns its normal by more than ~85° or becomes degenerate. */
	bool legal(int v, int u, bool geom, std::vector<int> &rv, std::vector<int> &ru) const
	{
		if (nalive <= 4 || !valive[v] || !valive[u])
			return false;
		int shared = 0;
		for (int fi : vf[v])
			shared += (f[fi][0] == u || f[fi][1] == u || f[fi][2] == u);
		if (shared != 2)
			return false;
		ring(v, rv);
		ring(u, ru);
		int common = 0;
		for (int w : rv)
			common += std::find(ru.begin(), ru.end(), w) != ru.end();
		if (common != 2)
			return false;
		if (!geom)
			return true;
		const std::vector<Vec3> &X = m.p;
		for (int fi : vf[v]) {
			const Tri &t = f[fi];
			if (t[0] == u || t[1] == u || t[2] == u)
				continue;
			Vec3 a = X[t[0]], b = X[t[1]], c = X[t[2]];
			Vec3 n0 = cross(sub(b, a), sub(c, a));
			Vec3 q[3] = {a, b, c};
			for (int k = 0; k < 3; k++)
				if (t[k] == v)
					q[k] = X[u];
			Vec3 n1 = cross(sub(q[1], q[0]), sub(q[2], q[0]));
			double l0 = norm(n0), l1 = norm(n1);
			if (!(l1 > 1e-12 * l0) || dot(n0, n1) < 0.1 * l0 * l1)
				return false;
			/* no slivers: 2√3 A / ΣL² = 1 for equilateral triangles */
			double L = dot(sub(q[1], q[0]), sub(q[1], q[0])) +
			           dot(sub(q[2], q[1]), sub(q[2], q[1])) +
			           dot(sub(q[0], q[2]), sub(q[0], q[2]));
			if (std::sqrt(3.0) * l1 < 0.02 * L && l1 < l0)
				return false;
		}
		return true;
	}

	void collapse(int v, int u)
	{
		Collapse c;
		c.v = v, c.u = u, c.fl = c.fr = -1;
		std::vector<int> faces = vf[v];
		for (int fi : faces) {
			Tri &t = f[fi];
			if (t[0] == u || t[1] == u || t[2] == u) {
				(c.fl < 0 ? c.fl : c.fr) = fi;
				falive[fi] = 0;
				for (int w : t)
					if (w != v)
						drop(vf[w], fi);
			} else {
				for (int &w : t)
					if (w == v)
						w = u;
				vf[u].push_back(fi);
				c.mod.push_back(fi);
			}
		}
		vf[v].clear();
		valive[v] = 0;
		nalive--;
		c.share = c.mod.empty() ? 0 : (w[c.fl] + w[c.fr]) / c.mod.size();
		c.share0 = c.mod.empty() ? 0 : (w0[c.fl] + w0[c.fr]) / c.mod.size();
		for (int fi : c.mod)
			w[fi] += c.share, w0[fi] += c.share0;
		rec.push_back(std::move(c));
	}

	void split(const Collapse &c)
	{
		valive[c.v] = 1;
		nalive++;
		for (int fi : c.mod) {
			for (int &x : f[fi])
				if (x == c.u)
					x = c.v;
			drop(vf[c.u], fi);
			vf[c.v].push_back(fi);
			w[fi] -= c.share, w0[fi] -= c.share0;
		}
		for (int fi : {c.fl, c.fr}) {
			falive[fi] = 1;
			for (int w : f[fi])
				vf[w].push_back(fi);
		}
	}

	/* Simplify to a tetrahedron: quadric-ordered half-edge collapses with
	 * the geometric check, then (if some vertices are left that only a
	 * fold could remove) by edge length with the topological check alone. */
	void simplify(int target)
	{
		const std::vector<Vec3> &X = m.p;
		std::vector<Quadric> Q(X.size());
		for (const Tri &t : f) {
			Vec3 n = cross(sub(X[t[1]], X[t[0]]), sub(X[t[2]], X[t[0]]));
			double l = norm(n);
			if (!(l > 0))
				continue;
			Vec3 u = mul(n, 1 / l);
			double d = -dot(u, X[t[0]]);
			for (int v : t)
				Q[v].add_plane(u[0], u[1], u[2], d, 0.5 * l);
		}
		std::vector<unsigned> stamp(X.size(), 0);
		std::vector<int> rv, ru;
		for (int pass = 0; pass < 2 && nalive > target; pass++) {
			bool geom = pass == 0;
			std::priority_queue<Candidate> pq;
			auto push = [&](int v, int u) {
				double cost = geom ? Q[v].eval(X[u]) + Q[u].eval(X[u])
				                   : dot(sub(X[v], X[u]), sub(X[v], X[u]));
				pq.push({cost, v, u, stamp[v], stamp[u]});
			};
			for (size_t fi = 0; fi < f.size(); fi++)
				if (falive[fi])
					for (int k = 0; k < 3; k++)
						push(f[fi][k], f[fi][(k + 1) % 3]);
			size_t total = X.size();
			while (!pq.empty() && nalive > target) {
				Candidate c = pq.top();
				pq.pop();
				if (stamp[c.v] != c.sv || stamp[c.u] != c.su)
					continue;
				if (!legal(c.v, c.u, geom, rv, ru))
					continue;
				collapse(c.v, c.u);
				Q[c.u] += Q[c.v];
				stamp[c.u]++;
				stamp[c.v]++;
				/* only the costs of u's edges changed (u's quadric); edges
				 * that became legal or illegal nearby are checked when they
				 * come up.  (Re-queueing the whole 2-ring instead built the
				 * same hierarchy five times slower: bunny00 1.4 s → 0.3 s.) */
				ring(c.u, ru);
				for (int w : ru) {
					push(w, c.u);
					push(c.u, w);
				}
				if ((rec.size() & 1023) == 0)
					progress("simplify", (double)rec.size() / (double)(total - 4));
			}
		}
	}
};

struct Optimizer {
	const Hier &h;
	std::vector<Vec3> &s;
	std::vector<FaceGeom> geom; /* per face, for the face's current corners */

	double mu;                  /* inverse-term weight of a face of importance 1 */
	double ia = 1;              /* share of the importance in force */
	double gk = 0, gm = 0;      /* guard: weight per s0² A3, MIPS bound */
	double s02;                 /* the sphere's mean scale², A / 4π */

	Optimizer(const Hier &hier, std::vector<Vec3> &sphere, double mu1, double scale2)
	    : h(hier), s(sphere), geom(hier.f.size()), mu(mu1), s02(scale2)
	{
	}

	/* A face's weights for its current corners.  A coarse face stands for
	 * the surface collapsed into it (Hier::w) and is weighed as a similar
	 * triangle of that area, so that coarse levels share the sphere out
	 * the way the finished surface will (thin parts keep their due);
	 * importance enters the same way.  The inverse term grows with the
	 * square of the importance, so that faces weighed larger keep their
	 * shape as they get more of the sphere (measured: without it the
	 * important places fold over).  The share ia of the importance in
	 * force, mu and the guard change over the hierarchy (hierarchical()). */
	void refresh(int fi)
	{
		FaceGeom &g = geom[fi];
		g = face_geom(h.m.p, h.f[fi]);
		double w = h.w0[fi] + ia * (h.w[fi] - h.w0[fi]);
		if (w > g.a3) {
			double r = w / g.a3;
			g.a3 *= r;
			for (double &L : g.L)
				L *= r;
		}
		double imp = h.w0[fi] > 0 ? w / h.w0[fi] : 1;
		g.mu = mu * imp * imp;
		g.gk = gk * g.a3 * s02;
		g.gm = gm;
	}

	void refresh_all()
	{
		for (size_t fi = 0; fi < h.f.size(); fi++)
			if (h.falive[fi])
				refresh((int)fi);
	}

	/* Energy of v's faces with v at p. */
	double energy(int v, const Vec3 &p) const
	{
		double E = 0;
		for (int fi : h.vf[v]) {
			const Tri &t = h.f[fi];
			int k = t[0] == v ? 0 : t[1] == v ? 1 : 2;
			const Vec3 &p1 = s[t[(k + 1) % 3]], &p2 = s[t[(k + 2) % 3]];
			FaceGeom g = geom[fi];
			/* rotate the corner data so v is corner 0 */
			FaceGeom r = g;
			for (int i = 0; i < 3; i++)
				r.L[i] = g.L[(i + k) % 3];
			E += face_energy(r, p, p1, p2);
			if (E == INF)
				return INF;
		}
		return E;
	}

	Vec3 gradient(int v) const
	{
		Vec3 g = {0, 0, 0};
		const Vec3 &p = s[v];
		for (int fi : h.vf[v]) {
			const Tri &t = h.f[fi];
			int k = t[0] == v ? 0 : t[1] == v ? 1 : 2;
			FaceGeom r = geom[fi];
			for (int i = 0; i < 3; i++)
				r.L[i] = geom[fi].L[(i + k) % 3];
			g = add(g, face_grad0(r, p, s[t[(k + 1) % 3]], s[t[(k + 2) % 3]]));
		}
		return sub(g, mul(p, dot(g, p))); /* tangent part */
	}

	/* Mean chord from v to its ring: the scale of a step. */
	double scale(int v) const
	{
		double r = 0;
		int n = 0;
		for (int fi : h.vf[v])
			for (int w : h.f[fi])
				if (w != v)
					r += norm(sub(s[w], s[v])), n++;
		return n ? r / n : 0;
	}

	/* Gradient of v's energy at p (tangent part), with v moved to p. */
	Vec3 gradient_at(int v, const Vec3 &p)
	{
		Vec3 keep = s[v];
		s[v] = p;
		Vec3 g = gradient(v);
		s[v] = keep;
		return g;
	}

	/* Newton's method on v's energy in the tangent plane (the Hessian from
	 * differences of the analytic gradient), with backtracking: a move is
	 * taken only if it lowers the energy, which is +∞ for any flipped or
	 * degenerate triangle.  A gradient step where the Hessian is not
	 * positive definite, or while v is below the margin (E = +∞: any valid
	 * move is taken).  Newton's steps converge in a few iterations where
	 * gradient descent zig-zags in the long narrow valleys of thin
	 * triangles: at equal time the L2 stretch efficiency of man went from
	 * 0.204 to 0.220 and its fold-overs halved. */
	void relax(int v, int iters)
	{
		double E0 = energy(v, s[v]);
		for (int it = 0; it < iters; it++) {
			const Vec3 p = s[v];
			Vec3 g = gradient(v);
			double gl = norm(g);
			if (!(gl > 0))
				return;
			Vec3 t1 = mul(g, 1 / gl), t2 = cross(p, t1);
			double sc = scale(v), hh = 1e-4 * sc;
			Vec3 ga = gradient_at(v, unit(add(p, mul(t1, hh)))),
			     gb = gradient_at(v, unit(add(p, mul(t2, hh))));
			/* in the basis t1 (along the gradient), t2: g = (gl, 0) */
			double H11 = (dot(ga, t1) - gl) / hh, H22 = dot(gb, t2) / hh,
			       H12 = 0.5 * (dot(ga, t2) + dot(gb, t1) - gl) / hh;
			double det = H11 * H22 - H12 * H12;
			Vec3 d;
			double t;
			if (H11 > 0 && H22 > 0 && det > 0 && E0 < INF) {
				d = add(mul(t1, -H22 * gl / det), mul(t2, H12 * gl / det));
				t = 1;
				double dl = norm(d);
				if (dl > 0.5 * sc)
					t = 0.5 * sc / dl;
			} else {
				d = mul(t1, -1);
				t = E0 < INF ? std::min(0.5 * sc, E0 / gl) : 0.5 * sc;
			}
			bool moved = false;
			for (int k = 0; k < 30; k++, t *= 0.5) {
				Vec3 q = unit(add(p, mul(d, t)));
				double E = energy(v, q);
				if (E < E0) {
					s[v] = q;
					E0 = E;
					moved = true;
					break;
				}
			}
			if (!moved)
				return;
		}
	}

	bool valid(int v, const Vec3 &p) const { return energy(v, p) < INF; }

	/* The alive vertices in classes no two of which share a face (greedy
	 * colouring): relax() reads v's ring and writes only v, so a class
	 * relaxes in parallel, and the result does not depend on the number
	 * of threads. */
	void colour(const std::vector<int> &alive, std::vector<std::vector<int>> &cls) const
	{
		std::vector<int> col(h.m.p.size(), -1);
		std::vector<char> used;
		cls.clear();
		for (int v : alive) {
			used.assign(cls.size() + 1, 0);
			for (int fi : h.vf[v])
				for (int w : h.f[fi])
					if (w != v && col[w] >= 0)
						used[col[w]] = 1;
			int c = 0;
			while (used[c])
				c++;
			if (c == (int)cls.size())
				cls.emplace_back();
			col[v] = c;
			cls[c].push_back(v);
		}
	}

	/* One Gauss–Seidel sweep, class by class (in parallel within one). */
	void sweep(const std::vector<std::vector<int>> &cls, int iters)
	{
		for (const std::vector<int> &c : cls) {
			/* a class too small to share is not worth a barrier (the
			 * coarse levels' classes hold a few vertices each) */
#pragma omp parallel for schedule(dynamic, 64) if (c.size() >= 256)
			for (size_t i = 0; i < c.size(); i++)
				relax(c[i], iters);
		}
	}

	/* Put the vertex c.v just split off c.u at a point of its ring's
	 * kernel: the ring's centroid if that is inside, else a point near u
	 * along the bisector of the ring's corner at u (the kernel contains
	 * the corner's wedge near u, since u saw the whole ring). */
	bool place(const Collapse &c)
	{
		int v = c.v, u = c.u;
		Vec3 sum = {0, 0, 0};
		std::vector<int> r;
		h.ring(v, r);
		for (int w : r)
			sum = add(sum, s[w]);
		Vec3 p = unit(sum);
		if (norm(sum) > 0 && valid(v, p)) {
			s[v] = p;
			return true;
		}
		auto third = [&](int fi) {
			for (int w : h.f[fi])
				if (w != u && w != v)
					return w;
			return u;
		};
		int a = third(c.fl), b = third(c.fr);
		const Vec3 &su = s[u];
		Vec3 da = sub(s[a], su), db = sub(s[b], su);
		da = sub(da, mul(su, dot(da, su)));
		db = sub(db, mul(su, dot(db, su)));
		double la = norm(da), lb = norm(db);
		Vec3 bis = add(mul(da, 1 / la), mul(db, 1 / lb));
		Vec3 e1 = mul(da, 1 / la), e2 = cross(su, e1);
		/* candidate directions: both bisectors and 48 around u; at each
		 * distance (halving) keep the candidate whose worst triangle is
		 * fattest, and stop at the first distance that has a valid one */
		std::vector<Vec3> dirs;
		if (norm(bis) > 1e-9)
			dirs.push_back(unit(bis)), dirs.push_back(mul(unit(bis), -1));
		for (int k = 0; k < 48; k++) {
			double ang = 2 * M_PI * (k + 0.5) / 48;
			dirs.push_back(add(mul(e1, std::cos(ang)), mul(e2, std::sin(ang))));
		}
		double eps = 0.5 * std::max(la, lb), fallback_best = 0;
		Vec3 fallback = su;
		for (int k = 0; k < 80; k++, eps *= 0.5) {
			double best = -INF;
			Vec3 bp = su;
			for (const Vec3 &d : dirs) {
				Vec3 q = unit(add(su, mul(d, eps)));
				double worst = INF;
				for (int fi : h.vf[v]) {
					const Tri &t = h.f[fi];
					Vec3 P[3];
					for (int i = 0; i < 3; i++)
						P[i] = t[i] == v ? q : s[t[i]];
					Vec3 x0 = sub(P[1], P[0]), x1 = sub(P[2], P[1]), x2 = sub(P[0], P[2]);
					double l = std::max(dot(x0, x0), std::max(dot(x1, x1), dot(x2, x2)));
					worst = std::min(worst, orient(P[0], P[1], P[2]) / l);
				}
				if (worst > best)
					best = worst, bp = q;
			}
			if (best > 6e-13 && valid(v, bp)) {
				s[v] = bp;
				return true;
			}
			if (best > fallback_best)
				fallback_best = best, fallback = bp;
		}
		if (fallback_best > 0) {
			/* no point with the margin, but one where nothing flips:
			 * take it; relax() moves v to a valid point when it can */
			s[v] = fallback;
			return true;
		}
		s[v] = su; /* no kernel point found: counted as a failure */
		return false;
	}
};

/* Embed the base tetrahedron (four vertices, four faces) on a regular
 * tetrahedron's corners, oriented like the mesh. */
static void embed_base(const Hier &h, std::vector<Vec3> &s)
{
	std::vector<int> verts;
	int f0 = -1;
	for (size_t fi = 0; fi < h.f.size(); fi++)
		if (h.falive[fi]) {
			if (f0 < 0)
				f0 = (int)fi;
			for (int v : h.f[fi])
				if (std::find(verts.begin(), verts.end(), v) == verts.end())
					verts.push_back(v);
		}
	const double r = 1 / std::sqrt(3.0);
	Vec3 T[4] = {{r, r, r}, {r, -r, -r}, {-r, r, -r}, {-r, -r, r}};
	const Tri &t = h.f[f0];
	int d = -1;
	for (int v : verts)
		if (v != t[0] && v != t[1] && v != t[2])
			d = v;
	s[t[0]] = T[0], s[t[1]] = T[1], s[t[2]] = T[2], s[d] = T[3];
	if (orient(s[t[0]], s[t[1]], s[t[2]]) < 0)
		std::swap(s[t[1]], s[t[2]]);
}

static void hierarchical(const Mesh &m, const ParamOptions &o, std::vector<Vec3> &s,
                         ParamStats &st)
{
	/* The inverse term's weight: stretch and inverse stretch count alike,
	 * times o.conformal, for a triangle mapped with the sphere's mean scale
	 * s0² = A / 4π (energy A3 s0² each); their ratio is then o.conformal. */
	double A = 0;
	for (const Tri &t : m.f)
		A += 0.5 * norm(cross(sub(m.p[t[1]], m.p[t[0]]), sub(m.p[t[2]], m.p[t[0]])));
	double s02 = A / (4 * M_PI);
	/* A split copy (no fade, below) weighs every curved face, twice as
	 * much: its fine levels cannot give the tips their samples otherwise
	 * (triceratops at level 7: Hausdorff 0.475% with the unsplit mesh's
	 * weights, 0.347% so; Praun–Hoppe 0.449%). */
	Hier h(m, o.fade ? importance(m, o.level, o.importance, 1)
	                 : importance(m, o.level, 2 * o.importance, 0));
	h.simplify(4);
	st.base_vertices = h.nalive;
	if (h.nalive != 4) /* cannot happen for a valid genus-0 input */
		throw std::runtime_error("simplification stopped at " + std::to_string(h.nalive) +
		                         " vertices");
	s.assign(m.p.size(), {0, 0, 0});
	embed_base(h, s);
	const double mu1 = o.conformal * s02 * s02 / 8;
	Optimizer opt(h, s, mu1, s02);
	if (o.guard > 0 && o.fade) { /* with the fade only: see below */
		opt.gk = 2; /* at M = 2 gm, twice a similar triangle's stretch */
		opt.gm = o.guard + 1 / o.guard;
	}
	/* The schedule.  The coarse levels share the sphere out between the
	 * parts of the surface, and the fine sweeps cannot move much of it
	 * (measured); there the inverse term and the importance give thin and
	 * curved parts their due.  From n0 = 0.3% of the vertices on, both
	 * fade (t = √(log(n / n0) / log(N / n0)), 0 → 1): the importance to
	 * half and the inverse term to a tenth, so the fine levels minimize
	 * stretch, and the guard keeps them from the slivers that fold the
	 * grid over.  Not on a 1-to-4 split copy (param_mesh): its fine levels
	 * are flat patches of the input's faces, with no detail for the fade
	 * to win stretch on, and faded they fold over (cactus, 1236 faces
	 * split three times, at level 7: 1076 fold-overs, 40 unfaded; Praun–
	 * Hoppe 807).  Unfaded, the full inverse term does the guard's work,
	 * and the guard only gets in its way (fandisk: 4 fold-overs with it,
	 * 0 without; Praun–Hoppe 0).  Measured at level 7 (stretch on spherical triangles,
	 * fold-overs; Praun–Hoppe 0.72 / 126, 0.42 / 809, 0.24 / 2524):
	 * bunny00, armadillo, man with the full weights throughout 0.703 / 0,
	 * 0.393 / 180, 0.220 / 1308; the inverse term faded to 8% and the
	 * importance to none, without the guard, 0.720 / 35,
	 * 0.429 / 904, 0.256 / 2878; with it, and 24 sweeps per step, see
	 * docs/bench/remesh.md. */
	const size_t N = m.p.size();
	const double n0 = std::max(8.0, 0.003 * (double)N);
	auto schedule = [&](size_t alive) {
		double t = 0;
		if (o.fade && (double)alive > n0)
			t = std::sqrt(std::min(1.0, std::log(alive / n0) / std::log(N / n0)));
		opt.mu = mu1 * (1 - 0.9 * t);
		opt.ia = 1 - 0.5 * t;
		opt.refresh_all();
	};
	schedule(4);
	std::vector<int> alive;
	for (size_t v = 0; v < m.p.size(); v++)
		if (h.valive[v])
			alive.push_back((int)v);
	std::vector<std::vector<int>> cls;
	opt.colour(alive, cls);
	for (int sweep = 0; sweep < 20; sweep++)
		opt.sweep(cls, 2);
	size_t nsplit = h.rec.size();
	double next = 8;
	long failures = 0;
	std::vector<int> ring;
	for (size_t k = nsplit; k-- > 0;) {
		const Collapse &c = h.rec[k];
		h.split(c);
		for (int fi : c.mod)
			opt.refresh(fi);
		opt.refresh(c.fl);
		opt.refresh(c.fr);
		alive.push_back(c.v);
		if (!opt.place(c))
			failures++;
		opt.relax(c.v, 4);
		h.ring(c.v, ring);
		for (int w : ring)
			opt.relax(w, 1);
		if (alive.size() >= next) {
			/* Praun–Hoppe optimize all vertices whenever the mesh has
			 * grown by a constant factor: linear total cost.  24 sweeps
			 * each time: the coarse levels decide how the sphere is
			 * shared out, which the fine sweeps cannot move far
			 * (measured, stretch efficiency of bunny00 / armadillo / man
			 * with the guard, 8 sweeps 0.719 / 0.431 / 0.247, 16 0.724 / 0.437 /
			 * 0.257, 24 0.726 / 0.441 / 0.261 — fold-overs grow with
			 * it; more sweeps at the end barely move it). */
			schedule(alive.size());
			opt.colour(alive, cls);
			for (int sweep = 0; sweep < 24; sweep++)
				opt.sweep(cls, 1);
			next = std::max(next * 1.3, next + 8);
		}
		if ((k & 511) == 0)
			progress("parameterize", 1.0 - (double)k / (double)nsplit);
	}
	schedule(alive.size());
	opt.colour(alive, cls);
	for (int sweep = 0; sweep < o.sweeps; sweep++) {
		opt.sweep(cls, 2);
		progress("optimize", (sweep + 1.0) / o.sweeps);
	}
	st.placement_failures = failures;
}

/* ---- the thesis' spring embedder ----------------------------------- */

static void spring(const Mesh &m, const ParamOptions &o, std::vector<Vec3> &s)
{
	size_t nv = m.p.size();
	Vec3 c = {0, 0, 0};
	for (const Vec3 &p : m.p)
		c = add(c, p);
	c = mul(c, 1.0 / nv);
	s.resize(nv);
	for (size_t v = 0; v < nv; v++) /* gnomonic projection of the mesh */
		s[v] = unit(sub(m.p[v], c));
	/* Edges with their two faces. */
	struct Edge { int a, b, f0, f1; };
	std::vector<Edge> edges;
	{
		std::unordered_map<uint64_t, int> idx;
		for (size_t fi = 0; fi < m.f.size(); fi++)
			for (int k = 0; k < 3; k++) {
				int a = m.f[fi][k], b = m.f[fi][(k + 1) % 3];
				uint64_t key = (uint64_t)(uint32_t)std::min(a, b) << 32 | (uint32_t)std::max(a, b);
				auto it = idx.find(key);
				if (it == idx.end()) {
					idx.emplace(key, (int)edges.size());
					edges.push_back({a, b, (int)fi, -1});
				} else {
					edges[it->second].f1 = (int)fi;
				}
			}
	}
	std::vector<double> k(edges.size(), 1), area(m.f.size());
	std::vector<Vec3> x(s), force(nv);
	std::vector<int> deg(nv, 0);
	for (const Edge &e : edges)
		deg[e.a]++, deg[e.b]++;
	const double dt = 0.2;
	for (int step = 0; step < o.spring_steps; step++) {
		if (step % 10 == 0) {
			/* eqs. 4.5–4.6: stiffness from the standardized areas of the
			 * edge's two faces (the thesis divides by the variance; the
			 * standard deviation is what standardizes), floored at 0.05
			 * so no spring pushes. */
			double mean = 0, var = 0;
			for (size_t fi = 0; fi < m.f.size(); fi++) {
				const Tri &t = m.f[fi];
				area[fi] = 0.5 * norm(cross(sub(x[t[1]], x[t[0]]), sub(x[t[2]], x[t[0]])));
				mean += area[fi];
			}
			mean /= m.f.size();
			for (double a : area)
				var += (a - mean) * (a - mean);
			double sd = std::sqrt(var / m.f.size());
			if (sd > 0)
				for (size_t e = 0; e < edges.size(); e++) {
					double z0 = (area[edges[e].f0] - mean) / sd,
					       z1 = (area[edges[e].f1] - mean) / sd;
					k[e] = std::max(0.05, 0.5 * (z0 + z1) + 1);
				}
		}
		if (o.relax) { /* eq. 4.7: each vertex to its neighbours' mean */
			std::vector<Vec3> avg(nv, Vec3{0, 0, 0});
			for (const Edge &e : edges)
				avg[e.a] = add(avg[e.a], x[e.b]), avg[e.b] = add(avg[e.b], x[e.a]);
			for (size_t v = 0; v < nv; v++)
				if (norm(avg[v]) > 1e-9 * deg[v]) /* neighbours all round: stay */
					x[v] = unit(avg[v]);
		}
		for (size_t v = 0; v < nv; v++)
			x[v] = mul(x[v], o.spring_c); /* eq. 4.4 */
		std::fill(force.begin(), force.end(), Vec3{0, 0, 0});
		for (size_t e = 0; e < edges.size(); e++) {
			Vec3 d = mul(sub(x[edges[e].b], x[edges[e].a]), k[e]);
			force[edges[e].a] = add(force[edges[e].a], d);
			force[edges[e].b] = sub(force[edges[e].b], d);
		}
		for (size_t v = 0; v < nv; v++) {
			double r = norm(x[v]);
			Vec3 ext = mul(x[v], (1 - r) / r); /* eq. 4.3 */
			x[v] = add(x[v], mul(add(mul(force[v], 1.0 / deg[v]), ext), dt));
			x[v] = unit(x[v]); /* the external field's limit: back on the sphere */
		}
		if (step % 16 == 0)
			progress("spring embedder", (step + 1.0) / o.spring_steps);
	}
	s = x;
}

} // namespace

int param_mesh(const Mesh &m, int level, Mesh &out)
{
	size_t faces = std::min<size_t>(100000, 2 * ndo_triangle_count(level));
	out = m;
	int times = 0;
	while (4 * out.f.size() <= faces) {
		Mesh next;
		next.p = out.p;
		std::unordered_map<uint64_t, int> mid;
		auto midpoint = [&](int a, int b) {
			uint64_t key = (uint64_t)(uint32_t)std::min(a, b) << 32 | (uint32_t)std::max(a, b);
			auto it = mid.find(key);
			if (it != mid.end())
				return it->second;
			int k = (int)next.p.size();
			next.p.push_back(mul(add(out.p[a], out.p[b]), 0.5));
			mid.emplace(key, k);
			return k;
		};
		for (const Tri &t : out.f) {
			int ab = midpoint(t[0], t[1]), bc = midpoint(t[1], t[2]), ca = midpoint(t[2], t[0]);
			next.f.push_back({t[0], ab, ca});
			next.f.push_back({ab, t[1], bc});
			next.f.push_back({ca, bc, t[2]});
			next.f.push_back({ab, bc, ca});
		}
		out = std::move(next);
		times++;
	}
	return times;
}

void parameterize(const Mesh &m, const ParamOptions &o, std::vector<Vec3> &s, ParamStats &st)
{
	if (o.method == ParamMethod::Spring)
		spring(m, o, s);
	else
		hierarchical(m, o, s, st);
	progress_done();
	param_measure(m, s, st);
}

} // namespace remesh
