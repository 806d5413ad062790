/* test_export.c — grids exported through assimp come back (read by assimp's
 * own importers) as closed, consistently outward-oriented meshes with
 * 2·4^n + 2 vertices and 4^(n+1) triangles, in every format; inside-out
 * grids are flipped; failed exports leave nothing behind. */
#include "check.h"
#include "ndo/ndo.h"

#include <assimp/cimport.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <stdint.h>
#include <stdlib.h>
#include <unistd.h>

static int cmp_u64(const void *a, const void *b)
{
	uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
	return x < y ? -1 : x > y;
}

/* Check an imported mesh: counts, closed and oriented, outward volume,
 * and every vertex within float precision of a grid vertex. */
/* STL stores a normal per face and no shared vertices: normals are dropped
 * on import so that identical positions join. */
static void check_import(const char *path, const ndo_grid *g, const char *what)
{
	const struct aiScene *s =
	    aiImportFile(path, aiProcess_DropNormals | aiProcess_JoinIdenticalVertices |
	                            aiProcess_Triangulate);
	CHECK(s != NULL, "%s: assimp cannot read it back: %s", what, aiGetErrorString());
	if (!s)
		return;
	CHECK(s->mNumMeshes == 1, "%s: %u meshes", what, s->mNumMeshes);
	const struct aiMesh *m = s->mMeshes[0];
	size_t nv = ndo_vertex_count(g->level), nt = ndo_triangle_count(g->level);
	CHECK(m->mNumVertices == nv, "%s: %u vertices, expected %zu", what, m->mNumVertices, nv);
	CHECK(m->mNumFaces == nt, "%s: %u faces, expected %zu", what, m->mNumFaces, nt);
	uint64_t *dir = malloc(3 * m->mNumFaces * sizeof *dir);
	double volume = 0;
	for (unsigned f = 0; f < m->mNumFaces; f++) {
		const unsigned *ix = m->mFaces[f].mIndices;
		for (int k = 0; k < 3; k++)
			dir[3 * f + k] = (uint64_t)ix[k] << 32 | ix[(k + 1) % 3];
		const struct aiVector3D *a = &m->mVertices[ix[0]], *b = &m->mVertices[ix[1]],
		                        *c = &m->mVertices[ix[2]];
		volume += a->x * (b->y * c->z - b->z * c->y) - a->y * (b->x * c->z - b->z * c->x) +
		          a->z * (b->x * c->y - b->y * c->x);
	}
	size_t ne = 3 * (size_t)m->mNumFaces;
	qsort(dir, ne, sizeof *dir, cmp_u64);
	int bad = 0;
	for (size_t k = 0; k < ne; k++) {
		uint64_t rev = dir[k] << 32 | dir[k] >> 32;
		bad += (k + 1 < ne && dir[k] == dir[k + 1]) ||
		       !bsearch(&rev, dir, ne, sizeof *dir, cmp_u64);
	}
	CHECK(bad == 0, "%s: %d edges not closed or not consistently oriented", what, bad);
	CHECK(volume > 0, "%s: faces point inwards (volume %g)", what, volume / 6);
	/* every vertex is a grid vertex (single precision) */
	int32_t *rep = malloc(nv * sizeof *rep), *vid = malloc(g->count * sizeof *vid);
	ndo_vertex_ids(g->level, vid, rep);
	const double *x = g->ch[0].data;
	int far = 0;
	for (unsigned v = 0; v < m->mNumVertices && v < nv; v++) {
		double best = 1e9;
		for (size_t u = 0; u < nv; u++) {
			const double *p = x + 3 * rep[u];
			double d = fabs(p[0] - m->mVertices[v].x) + fabs(p[1] - m->mVertices[v].y) +
			           fabs(p[2] - m->mVertices[v].z);
			best = fmin(best, d);
		}
		far += best > 1e-6;
	}
	CHECK(far == 0, "%s: %d vertices are not grid vertices", what, far);
	free(dir);
	free(rep);
	free(vid);
	aiReleaseImport(s);
}

static void every_format_reads_back_closed(void)
{
	char dir[] = "/tmp/ndo-export-XXXXXX";
	mkdtemp(dir);
	const char *exts[] = {"obj", "ply", "stl", "glb", "gltf"};
	ndo_grid *g;
	ndo_shape_make("wavy", 3, NULL, &g);
	for (int inside_out = 0; inside_out <= 1; inside_out++) {
		if (inside_out) { /* a mirror image: the same triangles now face in */
			double *x = g->ch[0].data;
			for (size_t k = 0; k < g->count; k++)
				x[3 * k] = -x[3 * k];
		}
		for (size_t e = 0; e < sizeof exts / sizeof exts[0]; e++) {
			char path[256], what[64];
			snprintf(path, sizeof path, "%s/m%d.%s", dir, inside_out, exts[e]);
			snprintf(what, sizeof what, "%s%s", exts[e], inside_out ? " (inside out)" : "");
			int rc = ndo_grid_export(path, g);
			CHECK(rc == NDO_OK, "%s: export failed: %s", what, ndo_errdetail());
			if (rc == NDO_OK)
				check_import(path, g, what);
		}
	}
	/* 10 meshes and the two .bin files of the .gltf ones, no temporaries */
	CHECK(count_entries(dir) == 12, "%d files in the output directory, expected 12",
	      count_entries(dir));
	char cmd[300];
	snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
	CHECK(system(cmd) == 0, "cleanup");
	ndo_grid_destroy(g);
}

static void failures_leave_nothing(void)
{
	char dir[] = "/tmp/ndo-export-XXXXXX";
	mkdtemp(dir);
	ndo_grid *g;
	ndo_shape_make("sphere", 2, NULL, &g);
	char path[256];
	snprintf(path, sizeof path, "%s/missing/x.obj", dir);
	CHECK(ndo_grid_export(path, g) != NDO_OK, "export into a missing directory must fail");
	CHECK(count_entries(dir) == 0, "a failed export left files");
	CHECK(ndo_mesh_format("a/b.OBJ") && !ndo_mesh_format("a.tgrid") && !ndo_mesh_format("-") &&
	          !ndo_mesh_format("dir.obj/grid") && !ndo_mesh_format(".obj"),
	      "extension detection");
	CHECK(ndo_unknown_extension("x.png") && !ndo_unknown_extension("x.tgrid") &&
	          !ndo_unknown_extension("x") && !ndo_unknown_extension("x.glb"),
	      "unknown extensions");
	rmdir(dir);
	ndo_grid_destroy(g);
}

int main(void)
{
	ck_program = "export";
	RUN(every_format_reads_back_closed);
	RUN(failures_leave_nothing);
	return ck_failed_cases != 0;
}
