/* export.c — grids to mesh files through assimp's C API, written
 * atomically through a custom assimp file system (ndo/export.h). */
#include "ndo/export.h"
#include "ndo/gridfile.h"
#include "ndo/io.h"
#include "ndo/status.h"
#include "ndo/topology.h"

#include <assimp/cexport.h>
#include <assimp/cfileio.h>
#include <assimp/cimport.h>
#include <assimp/scene.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

static const struct {
	const char *ext, *format;
} formats[] = {
	{".obj", "objnomtl"}, {".ply", "plyb"}, {".stl", "stlb"},
	{".glb", "glb2"},     {".gltf", "gltf2"},
};

static const char *extension(const char *path)
{
	if (ndo_is_stdio(path))
		return NULL;
	const char *slash = strrchr(path, '/'), *dot = strrchr(path, '.');
	if (!dot || (slash && dot < slash) || dot == path || (slash && dot == slash + 1))
		return NULL;
	return dot;
}

const char *ndo_mesh_format(const char *path)
{
	const char *ext = extension(path);
	for (size_t k = 0; ext && k < sizeof formats / sizeof formats[0]; k++)
		if (strcasecmp(ext, formats[k].ext) == 0)
			return formats[k].format;
	return NULL;
}

int ndo_unknown_extension(const char *path)
{
	const char *ext = extension(path);
	return ext && !ndo_mesh_format(path) && strcasecmp(ext, ".tgrid") != 0;
}

/* ---- an assimp file system writing through ndo_outfile ---- */

enum { MAX_FILES = 8 };

typedef struct exportfs {
	ndo_outfile out[MAX_FILES];
	int n;
	int failed;
} exportfs;

static size_t fs_write(C_STRUCT aiFile *f, const char *buf, size_t size, size_t count)
{
	return fwrite(buf, size, count, (FILE *)f->UserData);
}

static size_t fs_read(C_STRUCT aiFile *f, char *buf, size_t size, size_t count)
{
	(void)f, (void)buf, (void)size, (void)count;
	return 0;
}

static size_t fs_tell(C_STRUCT aiFile *f)
{
	long p = ftell((FILE *)f->UserData);
	return p < 0 ? 0 : (size_t)p;
}

static size_t fs_size(C_STRUCT aiFile *f)
{
	FILE *fp = (FILE *)f->UserData;
	long here = ftell(fp);
	fseek(fp, 0, SEEK_END);
	long end = ftell(fp);
	fseek(fp, here, SEEK_SET);
	return end < 0 ? 0 : (size_t)end;
}

static void fs_flush(C_STRUCT aiFile *f)
{
	fflush((FILE *)f->UserData);
}

static C_ENUM aiReturn fs_seek(C_STRUCT aiFile *f, size_t off, C_ENUM aiOrigin o)
{
	int whence = o == aiOrigin_SET ? SEEK_SET : o == aiOrigin_CUR ? SEEK_CUR : SEEK_END;
	return fseek((FILE *)f->UserData, (long)off, whence) == 0 ? aiReturn_SUCCESS
	                                                         : aiReturn_FAILURE;
}

static C_STRUCT aiFile *fs_open(C_STRUCT aiFileIO *io, const char *name, const char *mode)
{
	exportfs *fs = (exportfs *)io->UserData;
	if (!strchr(mode, 'w') || fs->n == MAX_FILES)
		return NULL; /* exporters only write; nothing here is read back */
	C_STRUCT aiFile *f = calloc(1, sizeof *f);
	if (!f)
		return NULL;
	if (ndo_out_open(name, &fs->out[fs->n]) != NDO_OK) {
		free(f);
		fs->failed = 1;
		return NULL;
	}
	f->UserData = (aiUserData)fs->out[fs->n].f;
	fs->n++;
	f->WriteProc = fs_write;
	f->ReadProc = fs_read;
	f->TellProc = fs_tell;
	f->FileSizeProc = fs_size;
	f->FlushProc = fs_flush;
	f->SeekProc = fs_seek;
	return f;
}

static void fs_close(C_STRUCT aiFileIO *io, C_STRUCT aiFile *f)
{
	(void)io;
	free(f); /* the stream stays open until the export is committed */
}

/* ---- the scene ---- */

int ndo_export_mesh(const char *path, const char *format, const ndo_grid *g)
{
	ndo__clear_error();
	const ndo_channel *pc = ndo_grid_find(g, NDO_CH_POSITION);
	if (!pc || pc->comps != 3)
		return ndo__fail(NDO_EINVAL, "grid has no 3-vector positions");
	size_t nv = ndo_vertex_count(g->level), nt = ndo_triangle_count(g->level);
	int32_t *vid = malloc(g->count * sizeof *vid), *rep = malloc(nv * sizeof *rep),
	        *tri = malloc(3 * nt * sizeof *tri);
	C_STRUCT aiVector3D *pos = calloc(nv, sizeof *pos), *nrm = calloc(nv, sizeof *nrm);
	C_STRUCT aiFace *faces = calloc(nt, sizeof *faces);
	unsigned int *idx = malloc(3 * nt * sizeof *idx);
	double *acc = calloc(3 * nv, sizeof *acc);
	int rc = NDO_OK;
	if (!vid || !rep || !tri || !pos || !nrm || !faces || !idx || !acc) {
		rc = ndo__fail(NDO_ENOMEM, "out of memory exporting a mesh");
		goto done;
	}
	ndo_vertex_ids(g->level, vid, rep);
	ndo_triangles(g->level, tri);
	double (*p)[3] = malloc(nv * sizeof *p);
	if (!p) {
		rc = ndo__fail(NDO_ENOMEM, "out of memory exporting a mesh");
		goto done;
	}
	for (size_t v = 0; v < nv; v++)
		for (int c = 0; c < 3; c++)
			p[v][c] = pc->type == NDO_F64 ? ((const double *)pc->data)[3 * (size_t)rep[v] + c]
			                              : ((const float *)pc->data)[3 * (size_t)rep[v] + c];
	/* Signed volume by the divergence theorem: negative means the
	 * triangles face inwards, so every one is flipped. */
	double volume = 0;
	for (size_t t = 0; t < nt; t++) {
		const double *a = p[vid[tri[3 * t]]], *b = p[vid[tri[3 * t + 1]]],
		             *c = p[vid[tri[3 * t + 2]]];
		volume += a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
		          a[2] * (b[0] * c[1] - b[1] * c[0]);
	}
	int flip = volume < 0;
	for (size_t t = 0; t < nt; t++) {
		unsigned int a = (unsigned)vid[tri[3 * t]], b = (unsigned)vid[tri[3 * t + 1]],
		             c = (unsigned)vid[tri[3 * t + 2]];
		if (flip) {
			unsigned int s = b;
			b = c;
			c = s;
		}
		idx[3 * t] = a, idx[3 * t + 1] = b, idx[3 * t + 2] = c;
		faces[t].mNumIndices = 3;
		faces[t].mIndices = idx + 3 * t;
		double u[3], w[3], n[3];
		for (int k = 0; k < 3; k++) {
			u[k] = p[b][k] - p[a][k];
			w[k] = p[c][k] - p[a][k];
		}
		n[0] = u[1] * w[2] - u[2] * w[1];
		n[1] = u[2] * w[0] - u[0] * w[2];
		n[2] = u[0] * w[1] - u[1] * w[0];
		for (int k = 0; k < 3; k++)
			acc[3 * a + k] += n[k], acc[3 * b + k] += n[k], acc[3 * c + k] += n[k];
	}
	for (size_t v = 0; v < nv; v++) {
		double r = sqrt(acc[3 * v] * acc[3 * v] + acc[3 * v + 1] * acc[3 * v + 1] +
		                acc[3 * v + 2] * acc[3 * v + 2]);
		if (r == 0)
			r = 1;
		pos[v].x = (float)p[v][0], pos[v].y = (float)p[v][1], pos[v].z = (float)p[v][2];
		nrm[v].x = (float)(acc[3 * v] / r), nrm[v].y = (float)(acc[3 * v + 1] / r),
		nrm[v].z = (float)(acc[3 * v + 2] / r);
	}
	free(p);

	C_STRUCT aiMesh mesh;
	C_STRUCT aiMaterial material;
	C_STRUCT aiNode root;
	C_STRUCT aiScene scene;
	memset(&mesh, 0, sizeof mesh);
	memset(&material, 0, sizeof material);
	memset(&root, 0, sizeof root);
	memset(&scene, 0, sizeof scene);
	C_STRUCT aiMesh *meshes[1] = {&mesh};
	C_STRUCT aiMaterial *materials[1] = {&material};
	unsigned int meshidx[1] = {0};
	mesh.mPrimitiveTypes = aiPrimitiveType_TRIANGLE;
	mesh.mNumVertices = (unsigned)nv;
	mesh.mVertices = pos;
	mesh.mNormals = nrm;
	mesh.mNumFaces = (unsigned)nt;
	mesh.mFaces = faces;
	strcpy(mesh.mName.data, "ndo-grid");
	mesh.mName.length = (ai_uint32)strlen(mesh.mName.data);
	strcpy(root.mName.data, "ndo");
	root.mName.length = 3;
	root.mTransformation.a1 = root.mTransformation.b2 = root.mTransformation.c3 =
	    root.mTransformation.d4 = 1;
	root.mNumMeshes = 1;
	root.mMeshes = meshidx;
	scene.mRootNode = &root;
	scene.mNumMeshes = 1;
	scene.mMeshes = meshes;
	scene.mNumMaterials = 1;
	scene.mMaterials = materials;
	/* vertices are shared between faces ("non-verbose"): exporters that
	 * need one vertex per corner convert a copy */
	scene.mFlags = AI_SCENE_FLAGS_NON_VERBOSE_FORMAT;

	exportfs fs = {0};
	C_STRUCT aiFileIO io = {fs_open, fs_close, (aiUserData)&fs};
	aiReturn ar = aiExportSceneEx(&scene, format, path, &io, 0);
	int committed = 0;
	if (ar != aiReturn_SUCCESS || fs.failed || fs.n == 0) {
		const char *why = aiGetErrorString();
		rc = fs.failed ? NDO_EIO
		               : ndo__fail(NDO_EEXPORT, "assimp could not write %s: %s",
		                           format, why && *why ? why : "unknown error");
	}
	for (int k = 0; k < fs.n; k++) {
		if (rc == NDO_OK)
			rc = ndo_out_commit(&fs.out[k]), committed++;
		else
			ndo_out_abort(&fs.out[k]);
	}
	(void)committed;
done:
	free(vid);
	free(rep);
	free(tri);
	free(pos);
	free(nrm);
	free(faces);
	free(idx);
	free(acc);
	return rc;
}

int ndo_grid_export(const char *path, const ndo_grid *g)
{
	const char *format = ndo_mesh_format(path);
	if (!format)
		return ndo_grid_save(path, g);
	return ndo_export_mesh(path, format, g);
}
