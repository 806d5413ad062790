/* context.h — an off-screen OpenGL 3.3+ core context, from one of two back
 * ends chosen at run time.
 *
 * A back end is two functions: create (make a context current in this
 * thread and say how to look up GL functions) and destroy.  Both back ends
 * are Mesa's llvmpipe on this machine: OSMesa (libOSMesa.so.8; removed
 * from upstream Mesa in 25.1) and EGL on the surfaceless platform
 * (EGL_MESA_platform_surfaceless; works without a GPU or a display).  The
 * libraries are dlopen()ed (libOSMesa.so.8 and libEGL.so.1, or the files
 * NDO_OSMESA_LIB and NDO_EGL_LIB name), so a missing one is an error at run
 * time that names it, and `auto` falls back to the other.  Rendering goes to a
 * framebuffer object (renderer.c), so neither back end needs a window or a
 * window-system buffer. */
#ifndef RF_CONTEXT_H
#define RF_CONTEXT_H

typedef void (*rf_glproc)(void);
typedef rf_glproc (*rf_getproc_fn)(const char *name);

typedef struct rf_backend {
	const char *name;
	/* Create a context and make it current; *getproc looks up GL
	 * functions for it.  Status as in ndo/status.h, with a detail. */
	int (*create)(void **ctx, rf_getproc_fn *getproc);
	/* Release and free the context.  Accepts NULL. */
	void (*destroy)(void *ctx);
} rf_backend;

extern const rf_backend rf_backend_osmesa;
extern const rf_backend rf_backend_egl;

/* The current context and where it came from. */
typedef struct rf_context {
	const rf_backend *backend;
	void *handle;
	char renderer[128]; /* GL_RENDERER, e.g. "llvmpipe (LLVM 15.0.6, 256 bits)" */
	char version[128];  /* GL_VERSION */
} rf_context;

/* Open a context from the back end called `name`: "osmesa", "egl", or
 * "auto" (OSMesa, else EGL), and load the GL function table (gl.h).
 * Fails (with a detail naming every back end tried) when none gives an
 * OpenGL 3.3 core context. */
int rf_context_open(const char *name, rf_context *out);
void rf_context_close(rf_context *c);

#endif
