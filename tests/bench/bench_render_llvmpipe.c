/* bench_render_llvmpipe — the floor for render-frame: the least an OpenGL
 * program must do to draw a level-L grid's triangles at W×H with llvmpipe
 * and get the pixels back.  Positions and normals are plain vertex
 * attributes computed once on the CPU, the shaders do one diffuse term
 * per vertex, nothing is uploaded per frame; each frame is clear, one
 * glDrawElements and glReadPixels (RGBA, which llvmpipe copies without
 * conversion).  OSMesa, core profile, a framebuffer object like
 * render-frame's.
 *
 *   bench_render_llvmpipe [-l LEVEL] [-n FRAMES] [-s WxH] [-m 0|1]
 *
 * -m 1 keeps freed memory in the process as render-frame does (glibc's
 * mallopt: no heap trimming, no mmap for blocks under 32 MB); -m 0, the
 * default, leaves glibc's defaults, which give llvmpipe's per-frame bins
 * back to the kernel and fault them in again.
 *
 * prints one line: level, triangles, size, median and quartiles of the
 * per-frame time in ms, and the CPU time per frame of all threads.  Self-contained (dlopen()s libOSMesa itself), so
 * it shares no code with render-frame. */
#include "ndo/ndo.h"

#include <GL/glcorearb.h>
#include <dlfcn.h>
#include <malloc.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>

/* The OSMesa API (GL/osmesa.h, which drags in the compatibility gl.h). */
#define OSMESA_FORMAT 0x22
#define OSMESA_PROFILE 0x33
#define OSMESA_CORE_PROFILE 0x34
#define OSMESA_CONTEXT_MAJOR_VERSION 0x36
#define OSMESA_CONTEXT_MINOR_VERSION 0x37
typedef struct osmesa_context *OSMesaContext;
typedef OSMesaContext (*create_fn)(const int *attribs, OSMesaContext share);
typedef GLboolean (*make_current_fn)(OSMesaContext, void *, GLenum, GLsizei, GLsizei);
typedef void (*(*getproc_fn)(const char *))(void);

#define F(type, name) static type p##name;
#define FUNCS(X)                                                             \
	X(PFNGLGENFRAMEBUFFERSPROC, glGenFramebuffers)                           \
	X(PFNGLBINDFRAMEBUFFERPROC, glBindFramebuffer)                           \
	X(PFNGLGENRENDERBUFFERSPROC, glGenRenderbuffers)                         \
	X(PFNGLBINDRENDERBUFFERPROC, glBindRenderbuffer)                         \
	X(PFNGLRENDERBUFFERSTORAGEPROC, glRenderbufferStorage)                   \
	X(PFNGLFRAMEBUFFERRENDERBUFFERPROC, glFramebufferRenderbuffer)           \
	X(PFNGLGENBUFFERSPROC, glGenBuffers)                                     \
	X(PFNGLBINDBUFFERPROC, glBindBuffer)                                     \
	X(PFNGLBUFFERDATAPROC, glBufferData)                                     \
	X(PFNGLGENVERTEXARRAYSPROC, glGenVertexArrays)                           \
	X(PFNGLBINDVERTEXARRAYPROC, glBindVertexArray)                           \
	X(PFNGLVERTEXATTRIBPOINTERPROC, glVertexAttribPointer)                   \
	X(PFNGLENABLEVERTEXATTRIBARRAYPROC, glEnableVertexAttribArray)           \
	X(PFNGLCREATESHADERPROC, glCreateShader)                                 \
	X(PFNGLSHADERSOURCEPROC, glShaderSource)                                 \
	X(PFNGLCOMPILESHADERPROC, glCompileShader)                               \
	X(PFNGLCREATEPROGRAMPROC, glCreateProgram)                               \
	X(PFNGLATTACHSHADERPROC, glAttachShader)                                 \
	X(PFNGLLINKPROGRAMPROC, glLinkProgram)                                   \
	X(PFNGLUSEPROGRAMPROC, glUseProgram)                                     \
	X(PFNGLGETPROGRAMIVPROC, glGetProgramiv)                                 \
	X(PFNGLGETUNIFORMLOCATIONPROC, glGetUniformLocation)                     \
	X(PFNGLUNIFORMMATRIX4FVPROC, glUniformMatrix4fv)                         \
	X(PFNGLVIEWPORTPROC, glViewport)                                         \
	X(PFNGLENABLEPROC, glEnable)                                             \
	X(PFNGLCLEARCOLORPROC, glClearColor)                                     \
	X(PFNGLCLEARPROC, glClear)                                               \
	X(PFNGLDRAWELEMENTSPROC, glDrawElements)                                 \
	X(PFNGLREADPIXELSPROC, glReadPixels)                                     \
	X(PFNGLGETERRORPROC, glGetError)
FUNCS(F)

static const char *vs =
	"#version 330 core\n"
	"layout(location = 0) in vec3 p;\n"
	"layout(location = 1) in vec3 n;\n"
	"uniform mat4 mvp;\n"
	"out vec3 c;\n"
	"void main() {\n"
	"  c = vec3(0.2) + 0.8 * max(dot(normalize(n), normalize(vec3(-1, 1, 2))), 0.0) * vec3(0.8, 0.65, 0.5);\n"
	"  gl_Position = mvp * vec4(p, 1.0);\n"
	"}\n";
static const char *fs =
	"#version 330 core\n"
	"in vec3 c;\n"
	"out vec4 o;\n"
	"void main() { o = vec4(c, 1.0); }\n";

static double now(void)
{
	struct timespec t;
	clock_gettime(CLOCK_MONOTONIC, &t);
	return t.tv_sec + 1e-9 * t.tv_nsec;
}

static double cpu_seconds(void)
{
	struct rusage u;
	getrusage(RUSAGE_SELF, &u);
	return u.ru_utime.tv_sec + u.ru_stime.tv_sec +
	       1e-6 * (double)(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

static int cmp(const void *a, const void *b)
{
	double x = *(const double *)a, y = *(const double *)b;
	return (x > y) - (x < y);
}

int main(int argc, char **argv)
{
	int level = 7, frames = 40, w = 1024, h = 768, keep = 0;
	for (int k = 1; k + 1 < argc; k += 2) {
		if (!strcmp(argv[k], "-l")) level = atoi(argv[k + 1]);
		else if (!strcmp(argv[k], "-n")) frames = atoi(argv[k + 1]);
		else if (!strcmp(argv[k], "-s")) sscanf(argv[k + 1], "%dx%d", &w, &h);
		else if (!strcmp(argv[k], "-m")) keep = atoi(argv[k + 1]);
	}
	if (keep) {
		mallopt(M_MMAP_THRESHOLD, 32 << 20);
		mallopt(M_TRIM_THRESHOLD, 512 << 20);
		mallopt(M_TOP_PAD, 64 << 20);
	}
	if (level < 0 || level > 9 || frames < 1 || w < 1 || h < 1) {
		fprintf(stderr, "usage: %s [-l 0..9] [-n FRAMES] [-s WxH] [-m 0|1]\n", argv[0]);
		return 2;
	}
	void *lib = dlopen("libOSMesa.so.8", RTLD_NOW);
	if (!lib) {
		fprintf(stderr, "%s: cannot load libOSMesa.so.8\n", argv[0]);
		return 1;
	}
	create_fn create = (create_fn)dlsym(lib, "OSMesaCreateContextAttribs");
	make_current_fn make_current = (make_current_fn)dlsym(lib, "OSMesaMakeCurrent");
	getproc_fn getproc = (getproc_fn)dlsym(lib, "OSMesaGetProcAddress");
	if (!create || !make_current || !getproc)
		return 1;
	static const int attribs[] = {OSMESA_FORMAT, GL_RGBA, OSMESA_PROFILE, OSMESA_CORE_PROFILE,
	                              OSMESA_CONTEXT_MAJOR_VERSION, 3, OSMESA_CONTEXT_MINOR_VERSION, 3, 0};
	OSMesaContext ctx = create(attribs, NULL);
	static unsigned char dummy[4];
	if (!ctx || !make_current(ctx, dummy, GL_UNSIGNED_BYTE, 1, 1)) {
		fprintf(stderr, "%s: no OSMesa core context\n", argv[0]);
		return 1;
	}
#define L(type, name) p##name = (type)getproc(#name);
	FUNCS(L)

	/* The same surface render-frame's benchmark draws: wavy at `level`,
	 * area-weighted vertex normals from the triangles. */
	ndo_grid *g;
	if (ndo_shape_make("wavy", level, NULL, &g) != NDO_OK)
		return 1;
	size_t nt = ndo_triangle_count(level), nv = g->count;
	int32_t *tri = malloc(nt * 3 * sizeof *tri);
	float *attr = calloc(nv * 6, sizeof *attr);
	ndo_triangles(level, tri);
	const double *x = ndo_grid_f64(g, "position", 3);
	for (size_t v = 0; v < nv; v++)
		for (int c = 0; c < 3; c++)
			attr[6 * v + c] = (float)x[3 * v + c];
	for (size_t t = 0; t < nt; t++) {
		const double *a = x + 3 * tri[3 * t], *b = x + 3 * tri[3 * t + 1], *c = x + 3 * tri[3 * t + 2];
		double e[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, f[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
		double n[3] = {e[1] * f[2] - e[2] * f[1], e[2] * f[0] - e[0] * f[2], e[0] * f[1] - e[1] * f[0]};
		for (int k = 0; k < 3; k++)
			for (int d = 0; d < 3; d++)
				attr[6 * tri[3 * t + k] + 3 + d] += (float)n[d];
	}

	GLuint fbo, rb[2];
	pglGenFramebuffers(1, &fbo);
	pglBindFramebuffer(GL_FRAMEBUFFER, fbo);
	pglGenRenderbuffers(2, rb);
	pglBindRenderbuffer(GL_RENDERBUFFER, rb[0]);
	pglRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, w, h);
	pglFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, rb[0]);
	pglBindRenderbuffer(GL_RENDERBUFFER, rb[1]);
	pglRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, w, h);
	pglFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, rb[1]);

	GLuint vao, buf[2];
	pglGenVertexArrays(1, &vao);
	pglBindVertexArray(vao);
	pglGenBuffers(2, buf);
	pglBindBuffer(GL_ARRAY_BUFFER, buf[0]);
	pglBufferData(GL_ARRAY_BUFFER, (GLsizeiptr)(nv * 6 * sizeof *attr), attr, GL_STATIC_DRAW);
	pglVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 24, (void *)0);
	pglVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 24, (void *)12);
	pglEnableVertexAttribArray(0);
	pglEnableVertexAttribArray(1);
	pglBindBuffer(GL_ELEMENT_ARRAY_BUFFER, buf[1]);
	pglBufferData(GL_ELEMENT_ARRAY_BUFFER, (GLsizeiptr)(nt * 3 * sizeof *tri), tri, GL_STATIC_DRAW);

	GLuint prog = pglCreateProgram();
	const char *src[2] = {vs, fs};
	GLenum type[2] = {GL_VERTEX_SHADER, GL_FRAGMENT_SHADER};
	for (int k = 0; k < 2; k++) {
		GLuint s = pglCreateShader(type[k]);
		pglShaderSource(s, 1, &src[k], NULL);
		pglCompileShader(s);
		pglAttachShader(prog, s);
	}
	pglLinkProgram(prog);
	GLint ok;
	pglGetProgramiv(prog, GL_LINK_STATUS, &ok);
	if (!ok)
		return 1;
	pglUseProgram(prog);
	/* The unit-ish sphere fills the view like render-frame's fit: a
	 * scale-and-translate projection is enough for a floor. */
	float s = 0.75f, aspect = (float)w / (float)h;
	float mvp[16] = {s / aspect, 0, 0, 0, 0, s, 0, 0, 0, 0, -0.4f, 0, 0, 0, 0, 1};
	pglUniformMatrix4fv(pglGetUniformLocation(prog, "mvp"), 1, GL_FALSE, mvp);
	pglViewport(0, 0, w, h);
	pglEnable(GL_DEPTH_TEST);
	pglClearColor(1, 1, 1, 1);
	unsigned char *pixels = malloc((size_t)w * h * 4);
	double *t = malloc((size_t)frames * sizeof *t);
	double cpu0 = 0;
	for (int f = -3; f < frames; f++) { /* 3 frames to warm up (shader JIT) */
		if (f == 0)
			cpu0 = cpu_seconds();
		double t0 = now();
		pglClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
		pglDrawElements(GL_TRIANGLES, (GLsizei)(nt * 3), GL_UNSIGNED_INT, NULL);
		pglReadPixels(0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE, pixels);
		if (f >= 0)
			t[f] = now() - t0;
	}
	double cpu = (cpu_seconds() - cpu0) / frames;
	if (pglGetError() != GL_NO_ERROR)
		return 1;
	qsort(t, (size_t)frames, sizeof *t, cmp);
	printf("level %d, %zu triangles, %dx%d: median %.2f ms (quartiles %.2f, %.2f) over %d frames, "
	       "CPU %.2f ms per frame\n", level, nt, w, h, 1e3 * t[frames / 2], 1e3 * t[frames / 4],
	       1e3 * t[3 * frames / 4], frames, 1e3 * cpu);
	return 0;
}
