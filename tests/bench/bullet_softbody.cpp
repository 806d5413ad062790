// bullet_softbody — Debian's Bullet soft bodies on the same closed surface
// as simulate-peer, for the speed comparison in tests/bench/simulate.sh.
//
//   bullet_softbody LEVEL...
//
// For each level: the wavy grid's distinct vertices and triangles
// (ndo_vertex_ids, ndo_triangles) become one soft body (as
// btSoftBodyHelpers::CreateFromTriMesh makes it), stepped with a
// fixed 1 ms step without gravity or collisions, in two of Bullet's modes:
//   softbody      btSoftBody in a btSoftRigidDynamicsWorld with one
//                 position-solver iteration (its cheapest setting)
//   deformable    btDeformableMultiBodyDynamicsWorld, explicit
//                 (setImplicit(false)), a btDeformableMassSpringForce on
//                 the mesh edges — Bullet's explicit FEM-style pipeline
// Bullet is built in double precision here (bullet-float64), like ndo.
// Prints markdown rows: mode, level, nodes, median steps/s, node-steps/s.
#include "ndo/ndo.h"

#include <btBulletDynamicsCommon.h>
#include <BulletSoftBody/btDeformableBodySolver.h>
#include <BulletSoftBody/btDeformableMassSpringForce.h>
#include <BulletSoftBody/btDeformableMultiBodyConstraintSolver.h>
#include <BulletSoftBody/btDeformableMultiBodyDynamicsWorld.h>
#include <BulletSoftBody/btSoftBodyHelpers.h>
#include <BulletSoftBody/btSoftBodyRigidBodyCollisionConfiguration.h>
#include <BulletSoftBody/btSoftRigidDynamicsWorld.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <utility>
#include <vector>

namespace {

double now()
{
	using namespace std::chrono;
	return duration<double>(steady_clock::now().time_since_epoch()).count();
}

struct Mesh {
	std::vector<btScalar> xyz;
	std::vector<int> tri;
	int nodes = 0;
};

Mesh grid_mesh(int level)
{
	ndo_grid *g;
	if (ndo_shape_make("wavy", level, nullptr, &g)) {
		std::fprintf(stderr, "bullet_softbody: %s\n", ndo_errdetail());
		std::exit(1);
	}
	size_t nv = ndo_vertex_count(level), nt = ndo_triangle_count(level);
	std::vector<int32_t> vid(g->count), rep(nv), tri(3 * nt);
	ndo_vertex_ids(level, vid.data(), rep.data());
	ndo_triangles(level, tri.data());
	Mesh m;
	m.nodes = (int)nv;
	const double *x = static_cast<const double *>(g->ch[0].data);
	for (size_t v = 0; v < nv; v++)
		for (int c = 0; c < 3; c++)
			m.xyz.push_back(x[3 * (size_t)rep[v] + c]);
	for (size_t k = 0; k < 3 * nt; k++)
		m.tri.push_back(vid[(size_t)tri[k]]);
	ndo_grid_destroy(g);
	return m;
}

// Median steps per second over 7 runs of at least 0.1 s.
template <class Step> double steps_per_second(Step step)
{
	for (int k = 0; k < 5; k++)
		step();
	long n = 1;
	for (;;) {
		double t0 = now();
		for (long k = 0; k < n; k++)
			step();
		double el = now() - t0;
		if (el > 0.1)
			break;
		n = el > 0.01 ? (long)(n * 0.12 / el) + 1 : n * 10;
	}
	std::vector<double> r;
	for (int k = 0; k < 7; k++) {
		double t0 = now();
		for (long q = 0; q < n; q++)
			step();
		r.push_back((double)n / (now() - t0));
	}
	std::sort(r.begin(), r.end());
	return r[3];
}

const btScalar dt = 1e-3;

// What btSoftBodyHelpers::CreateFromTriMesh builds — a node per vertex, a
// link per edge, a face per triangle — without its n² table of visited
// edges (1 GB at level 7, out of memory at level 8).
btSoftBody *make_body(btSoftBodyWorldInfo &info, const Mesh &m)
{
	std::vector<btVector3> x;
	for (int v = 0; v < m.nodes; v++)
		x.emplace_back(m.xyz[3 * v], m.xyz[3 * v + 1], m.xyz[3 * v + 2]);
	btSoftBody *sb = new btSoftBody(&info, m.nodes, x.data(), nullptr);
	std::vector<std::pair<int, int>> edges;
	for (size_t t = 0; t < m.tri.size(); t += 3)
		for (int e = 0; e < 3; e++) {
			int a = m.tri[t + e], b = m.tri[t + (e + 1) % 3];
			edges.emplace_back(std::min(a, b), std::max(a, b));
		}
	std::sort(edges.begin(), edges.end());
	edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
	for (auto &e : edges)
		sb->appendLink(e.first, e.second);
	for (size_t t = 0; t < m.tri.size(); t += 3)
		sb->appendFace(m.tri[t], m.tri[t + 1], m.tri[t + 2]);
	sb->randomizeConstraints();
	return sb;
}

double classic(const Mesh &m)
{
	btSoftBodyRigidBodyCollisionConfiguration config;
	btCollisionDispatcher dispatcher(&config);
	btDbvtBroadphase broadphase;
	btSequentialImpulseConstraintSolver solver;
	btSoftRigidDynamicsWorld world(&dispatcher, &broadphase, &solver, &config);
	world.setGravity(btVector3(0, 0, 0));
	btSoftBodyWorldInfo &info = world.getWorldInfo();
	info.m_gravity.setZero();
	info.m_sparsesdf.Initialize();
	btSoftBody *sb = make_body(info, m);
	sb->m_cfg.piterations = 1;
	sb->m_cfg.collisions = 0;
	sb->m_cfg.kDP = 0.01;
	sb->m_materials[0]->m_kLST = 0.5;
	sb->setTotalMass(4 * SIMD_PI);
	sb->addForce(btVector3(0, 0, 2.4), 0); // a push, so that there is motion
	world.addSoftBody(sb);
	double sps = steps_per_second([&] { world.stepSimulation(dt, 0, dt); });
	world.removeSoftBody(sb);
	delete sb;
	return sps;
}

double deformable(const Mesh &m)
{
	btSoftBodyRigidBodyCollisionConfiguration config;
	btCollisionDispatcher dispatcher(&config);
	btDbvtBroadphase broadphase;
	btDeformableBodySolver body_solver;
	btDeformableMultiBodyConstraintSolver solver;
	solver.setDeformableSolver(&body_solver);
	btDeformableMultiBodyDynamicsWorld world(&dispatcher, &broadphase, &solver, &config,
	                                         &body_solver);
	world.setGravity(btVector3(0, 0, 0));
	world.setImplicit(false);
	btSoftBodyWorldInfo &info = world.getWorldInfo();
	info.m_gravity.setZero();
	info.m_sparsesdf.Initialize();
	btSoftBody *sb = make_body(info, m);
	sb->m_cfg.collisions = 0;
	sb->setTotalMass(4 * SIMD_PI);
	world.addSoftBody(sb);
	btDeformableMassSpringForce spring(1, 0.01, true);
	world.addForce(sb, &spring);
	sb->addForce(btVector3(0, 0, 2.4), 0);
	double sps = steps_per_second([&] { world.stepSimulation(dt, 0, dt); });
	world.removeSoftBody(sb);
	delete sb;
	return sps;
}

} // namespace

int main(int argc, char **argv)
{
	if (argc < 2) {
		std::fprintf(stderr, "usage: bullet_softbody LEVEL...\n");
		return 2;
	}
	std::printf("| Bullet mode | level | nodes | steps/s | node-steps/s |\n");
	std::printf("|---|---:|---:|---:|---:|\n");
	for (int a = 1; a < argc; a++) {
		int level = std::atoi(argv[a]);
		Mesh m = grid_mesh(level);
		double c = classic(m);
		std::printf("| softbody (1 iteration) | %d | %d | %.4g | %.3g |\n", level, m.nodes, c,
		            c * m.nodes);
		std::fflush(stdout);
		double d = deformable(m);
		std::printf("| deformable, explicit | %d | %d | %.4g | %.3g |\n", level, m.nodes, d,
		            d * m.nodes);
		std::fflush(stdout);
	}
	return 0;
}
