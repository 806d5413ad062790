/* rotation.cpp — the domain's rotation against the parameterization.
 *
 * Praun & Hoppe choose the rotation that minimizes the stretch of the
 * combined map.  Here the rotation is chosen for what the benchmark
 * measures: the Hausdorff distance between the input and the grid at the
 * requested level, and the grid's fold-overs.  Both are estimated through
 * the parameterization in a few tens of milliseconds per rotation (exact
 * Hausdorff distances with CGAL take seconds), and the estimate ranks
 * rotations the way CGAL's distance does (docs/remesh.md): the Hausdorff
 * distance of one mesh varies by up to 2× over rotations, mostly by how
 * the grid's nodes fall on the tips of thin parts. */
#include "sphere.h"

#include <algorithm>
#include <cmath>
#include <random>

namespace remesh {

namespace {

/* The level-L grid's chord triangles on the sphere (unrotated domain),
 * with what the walks and distances below need. */
struct DomainIndex {
	int level;
	std::vector<Vec3> d;           /* domain point of every stored node */
	std::vector<int32_t> tri, vid; /* triangles (stored nodes); vertex id of each node */
	std::vector<Vec3> en;          /* per triangle edge (opposite corner e): P × Q of its ends */
	std::vector<int> ring, ring_start; /* per triangle: the triangles around its corners */
	SphereIndex idx;

	DomainIndex(const Domain &dom, int lev) : level(lev)
	{
		domain_points(dom, lev, d);
		tri.resize(3 * ndo_triangle_count(lev));
		ndo_triangles(lev, tri.data());
		vid.resize(d.size());
		ndo_vertex_ids(lev, vid.data(), nullptr);
		idx.build(d.data(), tri.data(), tri.size() / 3, vid.data());
		en.resize(tri.size());
		for (size_t t = 0; t < tri.size(); t += 3)
			for (int e = 0; e < 3; e++) {
				const Vec3 &P = d[tri[t + (e + 1) % 3]], &Q = d[tri[t + (e + 2) % 3]];
				en[t + e] = {P[1] * Q[2] - P[2] * Q[1], P[2] * Q[0] - P[0] * Q[2],
				             P[0] * Q[1] - P[1] * Q[0]};
			}
		std::vector<std::vector<int>> vt(ndo_vertex_count(lev));
		for (size_t t = 0; t < tri.size(); t += 3)
			for (int k = 0; k < 3; k++)
				vt[vid[tri[t + k]]].push_back((int)(t / 3));
		ring_start.push_back(0);
		for (size_t t = 0; t < tri.size(); t += 3) {
			size_t st = ring.size();
			for (int k = 0; k < 3; k++)
				for (int u : vt[vid[tri[t + k]]])
					if (u != (int)(t / 3) && std::find(ring.begin() + st, ring.end(), u) == ring.end())
						ring.push_back(u);
			ring_start.push_back((int)ring.size());
		}
	}
};

/* Squared distance from p to the triangle a b c (Ericson, Real-Time
 * Collision Detection, §5.1.5). */
double point_triangle_sq(const double p[3], const double a[3], const double b[3], const double c[3])
{
	double ab[3], ac[3], ap[3], bp[3], cp[3];
	for (int k = 0; k < 3; k++)
		ab[k] = b[k] - a[k], ac[k] = c[k] - a[k], ap[k] = p[k] - a[k], bp[k] = p[k] - b[k],
		cp[k] = p[k] - c[k];
	auto dt = [](const double *u, const double *v) { return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]; };
	auto at = [&](double u, double v, double w) {
		double s = 0;
		for (int k = 0; k < 3; k++) {
			double d = u * a[k] + v * b[k] + w * c[k] - p[k];
			s += d * d;
		}
		return s;
	};
	double d1 = dt(ab, ap), d2 = dt(ac, ap);
	if (d1 <= 0 && d2 <= 0)
		return at(1, 0, 0);
	double d3 = dt(ab, bp), d4 = dt(ac, bp);
	if (d3 >= 0 && d4 <= d3)
		return at(0, 1, 0);
	double vc = d1 * d4 - d3 * d2;
	if (vc <= 0 && d1 >= 0 && d3 <= 0) {
		double v = d1 / (d1 - d3);
		return at(1 - v, v, 0);
	}
	double d5 = dt(ab, cp), d6 = dt(ac, cp);
	if (d6 >= 0 && d5 <= d6)
		return at(0, 0, 1);
	double vb = d5 * d2 - d1 * d6;
	if (vb <= 0 && d2 >= 0 && d6 <= 0) {
		double w = d2 / (d2 - d6);
		return at(1 - w, 0, w);
	}
	double va = d3 * d6 - d5 * d4;
	if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
		double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
		return at(0, 1 - w, w);
	}
	double den = 1 / (va + vb + vc), v = vb * den, w = vc * den;
	return at(1 - v - w, v, w);
}

struct Deviation {
	double in = 0, out = 0; /* largest distance input → grid, grid → input */
	long folds = 0;         /* grid triangles against the input's normals */
};

/* How far the grid resampled with rotation R is from the input, both
 * ways.  Where input and grid are both linear — on the cells of the
 * overlay of the input's parameter triangles and the grid's domain
 * triangles — the distance between corresponding points is linear too, so
 * its largest values are at the cells' corners: the input's vertices and
 * the crossings of input edges with grid edges, found by walking along
 * each input edge's arc through the grid's triangles.  At each such point
 * the distance to the other mesh is measured to the triangles there and
 * around (an upper bound of the distance to the whole mesh, which is what
 * CGAL measures; equal where the nearest point is nearby, which is where
 * the distances are largest).  |x − y| of corresponding points bounds both,
 * so a point is looked at closely only when it could raise a maximum.
 * Fold-overs: grid triangles whose normal opposes the sum of the input
 * normals at their corners (the benchmark takes the input face nearest to
 * the centroid; the counts agree within a few percent). */
Deviation deviation(const SphereLocator *l, const DomainIndex &di, const double R[9],
                    std::vector<double> &pos, std::vector<int> &faces)
{
	const Mesh &m = l->m;
	int n = 1 << di.level, w = 2 * n + 1;
	pos.resize(3 * (size_t)w * (n + 1));
	faces.resize((size_t)w * (n + 1));
	sample(l, di.level, di.d, R, pos.data(), faces.data(), false);
	Deviation dv;
	for (size_t t = 0; t < di.tri.size(); t += 3) {
		const double *a = &pos[3 * di.tri[t]], *b = &pos[3 * di.tri[t + 1]], *c = &pos[3 * di.tri[t + 2]];
		double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
		double ng[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
		double s = 0;
		for (int k = 0; k < 3; k++) {
			const Vec3 &nf = l->normal[faces[di.tri[t + k]]];
			s += ng[0] * nf[0] + ng[1] * nf[1] + ng[2] * nf[2];
		}
		dv.folds += s < 0;
	}
	double mi = 0, mo = 0; /* squared maxima: input → grid, grid → input */
	auto grid_sq = [&](const double x[3], int t) { /* x against grid triangle t and around */
		const int32_t *g = &di.tri[3 * t];
		double e2 = point_triangle_sq(x, &pos[3 * g[0]], &pos[3 * g[1]], &pos[3 * g[2]]);
		for (int r = di.ring_start[t]; r < di.ring_start[t + 1] && e2 > mi; r++) {
			const int32_t *h = &di.tri[3 * di.ring[r]];
			e2 = std::min(e2, point_triangle_sq(x, &pos[3 * h[0]], &pos[3 * h[1]], &pos[3 * h[2]]));
		}
		mi = std::max(mi, e2);
	};
	auto face_sq = [&](const double x[3], int f) {
		const Tri &t = m.f[f];
		return point_triangle_sq(x, m.p[t[0]].data(), m.p[t[1]].data(), m.p[t[2]].data());
	};
	auto input_sq = [&](const double x[3], int f0, int f1, int u, int v) { /* faces f0 f1, around u v */
		double e2 = std::min(face_sq(x, f0), f1 >= 0 ? face_sq(x, f1) : INFINITY);
		for (int c : {u, v})
			for (size_t r = 0; r < l->vf[c].size() && e2 > mo; r++)
				e2 = std::min(e2, face_sq(x, l->vf[c][r]));
		mo = std::max(mo, e2);
	};
	/* the input's vertices, breadth first so that each walks from its
	 * predecessor's grid triangle */
	std::vector<int> vt(m.p.size(), -1);
	std::vector<Vec3> q(m.p.size());
	for (int v : l->order) {
		double b[3], x[3], d2 = 0;
		q[v] = unrotate(R, l->s[v]);
		int t = di.idx.find(q[v], b, l->parent[v] >= 0 ? vt[l->parent[v]] : -1);
		vt[v] = t;
		const int32_t *g = &di.tri[3 * t];
		for (int k = 0; k < 3; k++) {
			x[k] = b[0] * pos[3 * g[0] + k] + b[1] * pos[3 * g[1] + k] + b[2] * pos[3 * g[2] + k];
			d2 += (x[k] - m.p[v][k]) * (x[k] - m.p[v][k]);
		}
		if (d2 > mi)
			grid_sq(m.p[v].data(), t);
		if (d2 > mo)
			input_sq(x, l->vf[v][0], -1, v, v);
	}
	/* the crossings */
	for (size_t f = 0; f < m.f.size(); f++)
		for (int k = 0; k < 3; k++) {
			int u = m.f[f][k], v = m.f[f][(k + 1) % 3];
			if (u > v) /* each edge once */
				continue;
			int fo = l->idx.adj[f][(k + 2) % 3]; /* the face across the edge */
			const Vec3 &q0 = q[u], &q1 = q[v];
			int T = vt[u], from = -1;
			double tcur = 0;
			for (int step = 0; step < 4096 && T >= 0; step++) {
				/* leave T where the arc q0 → q1 crosses an edge plane first */
				const int32_t *g = &di.tri[3 * T];
				int ke = -1;
				double te = INFINITY;
				for (int e = 0; e < 3; e++) {
					if (di.idx.adj[T][e] == from)
						continue;
					const Vec3 &N = di.en[3 * T + e];
					double g1 = q1[0] * N[0] + q1[1] * N[1] + q1[2] * N[2];
					if (g1 >= 0)
						continue;
					double g0 = q0[0] * N[0] + q0[1] * N[1] + q0[2] * N[2], tx = g0 > 0 ? g0 / (g0 - g1) : 0;
					if (tx < te)
						te = tx, ke = e;
				}
				if (ke < 0)
					break; /* q1 is in T */
				te = std::max(te, tcur);
				/* the crossing: y on the input edge, x on the grid edge A B
				 * (q ∝ (1 − wb) A + wb B: wb = |q × A| / (|q × A| + |q × B|)) */
				int A = g[(ke + 1) % 3], B = g[(ke + 2) % 3];
				Vec3 qx = {(1 - te) * q0[0] + te * q1[0], (1 - te) * q0[1] + te * q1[1],
				           (1 - te) * q0[2] + te * q1[2]};
				const Vec3 &dA = di.d[A], &dB = di.d[B];
				double ca[3] = {qx[1] * dA[2] - qx[2] * dA[1], qx[2] * dA[0] - qx[0] * dA[2],
				                qx[0] * dA[1] - qx[1] * dA[0]};
				double cb[3] = {qx[1] * dB[2] - qx[2] * dB[1], qx[2] * dB[0] - qx[0] * dB[2],
				                qx[0] * dB[1] - qx[1] * dB[0]};
				double la = std::sqrt(ca[0] * ca[0] + ca[1] * ca[1] + ca[2] * ca[2]),
				       lb = std::sqrt(cb[0] * cb[0] + cb[1] * cb[1] + cb[2] * cb[2]);
				double wb = la + lb > 0 ? la / (la + lb) : 0.5, x[3], y[3], d2 = 0;
				for (int j = 0; j < 3; j++) {
					y[j] = (1 - te) * m.p[u][j] + te * m.p[v][j];
					x[j] = (1 - wb) * pos[3 * A + j] + wb * pos[3 * B + j];
					d2 += (x[j] - y[j]) * (x[j] - y[j]);
				}
				int T2 = di.idx.adj[T][ke];
				if (d2 > mi) {
					grid_sq(y, T);
					if (T2 >= 0)
						grid_sq(y, T2);
				}
				if (d2 > mo)
					input_sq(x, (int)f, fo, u, v);
				from = T, T = T2, tcur = te;
			}
		}
	dv.in = std::sqrt(mi);
	dv.out = std::sqrt(mo);
	return dv;
}

void mat_mul(const double A[9], const double B[9], double C[9])
{
	double T[9];
	for (int r = 0; r < 3; r++)
		for (int c = 0; c < 3; c++)
			T[3 * r + c] = A[3 * r] * B[c] + A[3 * r + 1] * B[3 + c] + A[3 * r + 2] * B[6 + c];
	std::copy(T, T + 9, C);
}

void axis_angle(int axis, double ang, double R[9])
{
	double c = std::cos(ang), s = std::sin(ang);
	std::fill(R, R + 9, 0.0);
	int a = (axis + 1) % 3, b = (axis + 2) % 3;
	R[3 * axis + axis] = 1;
	R[3 * a + a] = c, R[3 * a + b] = -s;
	R[3 * b + a] = s, R[3 * b + b] = c;
}

/* A uniformly random rotation: a normalized Gaussian quaternion. */
void random_rotation(std::mt19937 &rng, double R[9])
{
	std::normal_distribution<double> g(0, 1);
	double q[4] = {g(rng), g(rng), g(rng), g(rng)};
	double r = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
	double w = q[0] / r, x = q[1] / r, y = q[2] / r, z = q[3] / r;
	R[0] = 1 - 2 * (y * y + z * z), R[1] = 2 * (x * y - w * z), R[2] = 2 * (x * z + w * y);
	R[3] = 2 * (x * y + w * z), R[4] = 1 - 2 * (x * x + z * z), R[5] = 2 * (y * z - w * x);
	R[6] = 2 * (x * z - w * y), R[7] = 2 * (y * z + w * x), R[8] = 1 - 2 * (x * x + y * y);
}

} // namespace

void optimize_rotation(const SphereLocator *l, const Domain &dom, int level, int rotations,
                       double R[9], RotationResult &res)
{
	/* The estimates at the requested level (at most 7: finer grids only
	 * get closer, and 4× dearer per level), the screening one level
	 * coarser at a third of the cost. */
	const int top = 4, refine = 24;
	int lf = std::min(level, 7), ls = std::max(0, lf - 1);
	DomainIndex ds(dom, ls);
	DomainIndex *df = lf == ls ? &ds : new DomainIndex(dom, lf);
	std::vector<double> pos;
	std::vector<int> faces;
	/* One number to minimize: the larger one-way distance, raised by the
	 * share of folded triangles (1% folded counts as 30% farther). */
	auto score_in = [&](const DomainIndex &di, const double M[9], Deviation *out,
	                    std::vector<double> &p, std::vector<int> &f) {
		Deviation dv = deviation(l, di, M, p, f);
		if (out)
			*out = dv;
		return std::max(dv.in, dv.out) * (1 + 30.0 * dv.folds / (double)(di.tri.size() / 3));
	};
	auto score = [&](const DomainIndex &di, const double M[9], Deviation *out) {
		return score_in(di, M, out, pos, faces);
	};
	const double I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
	int total = rotations + 1 + top + refine, done = 0;
	/* 1. the identity and `rotations` random rotations (fixed seed), at
	 * the coarser level */
	std::vector<std::pair<double, std::array<double, 9>>> cand(rotations + 1);
	std::mt19937 rng(12345);
	for (int k = 0; k <= rotations; k++) {
		std::array<double, 9> &M = cand[k].second;
		if (k == 0)
			std::copy(I, I + 9, M.begin());
		else
			random_rotation(rng, M.data());
	}
	/* independent: in parallel, each thread with its own buffers (the
	 * locator's walks and its AABB tree are read-only) */
#pragma omp parallel
	{
		std::vector<double> p;
		std::vector<int> f;
#pragma omp for schedule(dynamic, 1)
		for (int k = 0; k <= rotations; k++)
			cand[k].first = score_in(ds, cand[k].second.data(), nullptr, p, f);
	}
	done += rotations + 1;
	progress("rotation", (double)done / total);
	/* 2. the identity (so the result is never estimated worse) and the
	 * best few at the requested level */
	std::stable_sort(cand.begin(), cand.end(),
	                 [](const auto &a, const auto &b) { return a.first < b.first; });
	Deviation dv;
	double best = score(*df, I, &dv);
	std::copy(I, I + 9, R);
	res.level = lf;
	res.hausdorff_before = std::max(dv.in, dv.out), res.flipped_before = dv.folds;
	for (int k = 0; k < top && k < (int)cand.size(); k++) {
		double E = score(*df, cand[k].second.data(), nullptr);
		if (E < best)
			best = E, std::copy(cand[k].second.begin(), cand[k].second.end(), R);
		progress("rotation", (double)++done / total);
	}
	/* 3. coordinate descent over small turns about the axes, halving the
	 * angle from 0.08 rad when no turn helps */
	int evals = 0;
	for (double step = 0.08; step > 0.009 && evals < refine; step *= 0.5) {
		bool improved = true;
		while (improved && evals < refine) {
			improved = false;
			for (int axis = 0; axis < 3 && evals < refine; axis++)
				for (int sign = -1; sign <= 1 && evals < refine; sign += 2) {
					double A[9], M[9];
					axis_angle(axis, sign * step, A);
					mat_mul(A, R, M);
					double E = score(*df, M, nullptr);
					evals++;
					progress("rotation", (double)++done / total);
					if (E < best) {
						best = E, std::copy(M, M + 9, R);
						improved = true;
					}
				}
		}
	}
	score(*df, R, &dv);
	res.hausdorff_after = std::max(dv.in, dv.out), res.flipped_after = dv.folds;
	res.evaluated = rotations + 1 + std::min(top, (int)cand.size()) + evals;
	if (df != &ds)
		delete df;
}

} // namespace remesh
