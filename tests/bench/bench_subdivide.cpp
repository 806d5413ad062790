/* bench_subdivide.cpp — butterfly subdivision speed, ndo beside OpenMesh's
 * ModifiedButterflyT on the same meshes in the same run.
 *
 * For each step L → L+1 (L = 5..8) on the wavy sphere:
 *   kernel     ndo_butterfly_f64 on positions, buffers reused (the
 *              in-memory cost a renderer or simulator pays per refine)
 *   grid       ndo_subdivide: a new grid allocated and filled
 *   openmesh   ModifiedButterflyT::operator()(1) on a fresh copy of the
 *              coarse mesh (the copy is not timed)
 *   process    the whole `subdivide -l 1 IN -o OUT` command, file to file
 *              (start-up, read, refine, write, rename)
 * Each figure is the median of repeated runs.  Output: a Markdown table on
 * stdout.  Usage: bench_subdivide SUBDIVIDE_BINARY TMPDIR */
#include "ndo/ndo.h"

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Tools/Subdivider/Uniform/ModifiedButterFlyT.hh>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <spawn.h>
#include <string>
#include <sys/wait.h>
#include <vector>

extern char **environ;

struct Traits : OpenMesh::DefaultTraits {
	typedef OpenMesh::Vec3d Point;
};
typedef OpenMesh::TriMesh_ArrayKernelT<Traits> Mesh;

static double now()
{
	return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

static double median(std::vector<double> v)
{
	std::sort(v.begin(), v.end());
	size_t n = v.size();
	return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* Run fn repeatedly for at least `budget` seconds (and at least `min`
 * times); the median of the timings. */
template <class F> static double timed(F fn, double budget, int min = 5)
{
	std::vector<double> t;
	double start = now();
	while ((int)t.size() < min || now() - start < budget) {
		double a = now();
		fn();
		t.push_back(now() - a);
		if (t.size() > 2000)
			break;
	}
	return median(t);
}

static Mesh to_openmesh(const ndo_grid *g)
{
	std::vector<int32_t> vid(g->count), rep(ndo_vertex_count(g->level)),
	    tri(3 * ndo_triangle_count(g->level));
	ndo_vertex_ids(g->level, vid.data(), rep.data());
	ndo_triangles(g->level, tri.data());
	Mesh m;
	std::vector<Mesh::VertexHandle> vh;
	const double *x = (const double *)g->ch[0].data;
	for (int32_t r : rep)
		vh.push_back(m.add_vertex(Mesh::Point(x[3 * r], x[3 * r + 1], x[3 * r + 2])));
	for (size_t t = 0; t < tri.size(); t += 3)
		m.add_face(vh[vid[tri[t]]], vh[vid[tri[t + 1]]], vh[vid[tri[t + 2]]]);
	return m;
}

static double run_process(const char *bin, const std::string &in, const std::string &out)
{
	std::vector<double> t;
	for (int k = 0; k < 11; k++) {
		const char *argv[] = {bin, "-l", "1", in.c_str(), "-o", out.c_str(), nullptr};
		double a = now();
		pid_t pid;
		if (posix_spawn(&pid, bin, nullptr, nullptr, (char **)argv, environ) != 0)
			return -1;
		int status;
		waitpid(pid, &status, 0);
		if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
			return -1;
		t.push_back(now() - a);
	}
	return median(t);
}

int main(int argc, char **argv)
{
	if (argc != 3) {
		fprintf(stderr, "usage: bench_subdivide SUBDIVIDE_BINARY TMPDIR\n");
		return 2;
	}
	printf("| step | stored nodes out | vertices out | ndo kernel | ns/node | ndo grid | "
	       "OpenMesh | ns/vertex | OpenMesh / ndo kernel | `subdivide` process | "
	       "OpenMesh / process |\n");
	printf("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
	for (int level = 5; level <= 8; level++) {
		ndo_grid *g;
		ndo_shape_make("wavy", level, nullptr, &g);
		size_t fine_nodes = (size_t)(4 << level | 1) * (size_t)(2 << level | 1);
		size_t fine_vertices = ndo_vertex_count(level + 1);
		std::vector<double> out(3 * fine_nodes), scratch(ndo_butterfly_scratch(level, 3));
		double budget = 0.6;
		double t_kernel = timed([&] {
			ndo_butterfly_f64(level, 3, (const double *)g->ch[0].data, out.data(), scratch.data(),
			                  NDO_CORNERS_ZORIN);
		}, budget);
		double t_grid = timed([&] {
			ndo_grid *f;
			ndo_subdivide(g, NDO_CORNERS_ZORIN, &f);
			ndo_grid_destroy(f);
		}, budget);
		Mesh coarse = to_openmesh(g);
		std::vector<double> tom;
		double start = now();
		while (tom.size() < 5 || (now() - start < 2 * budget && tom.size() < 200)) {
			Mesh m = coarse;
			OpenMesh::Subdivider::Uniform::ModifiedButterflyT<Mesh> sub;
			sub.attach(m);
			double a = now();
			sub(1);
			tom.push_back(now() - a);
			sub.detach();
		}
		double t_om = median(tom);
		std::string in = std::string(argv[2]) + "/in.tgrid", outp = std::string(argv[2]) + "/out.tgrid";
		ndo_grid_save(in.c_str(), g);
		double t_proc = run_process(argv[1], in, outp);
		printf("| %d → %d | %zu | %zu | %.3f ms | %.1f | %.3f ms | %.2f ms | %.0f | %.1f× | %.2f ms | %.1f× |\n",
		       level, level + 1, fine_nodes, fine_vertices, 1e3 * t_kernel, 1e9 * t_kernel / fine_nodes,
		       1e3 * t_grid, 1e3 * t_om, 1e9 * t_om / fine_vertices, t_om / t_kernel, 1e3 * t_proc,
		       t_om / t_proc);
		fflush(stdout);
		ndo_grid_destroy(g);
	}
	return 0;
}
