/* context_egl.c — the EGL back end (context.h): an OpenGL core context on
 * Mesa's surfaceless platform, no window system and no surface. */
#include "context.h"

#include "ndo/status.h"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <dlfcn.h>
#include <stdlib.h>

#define EGL_LIB "libEGL.so.1" /* NDO_EGL_LIB overrides */

typedef struct egl {
	EGLDisplay dpy;
	EGLContext ctx;
} egl;

static PFNEGLGETPROCADDRESSPROC get_proc_address;
static PFNEGLMAKECURRENTPROC make_current;
static PFNEGLDESTROYCONTEXTPROC destroy_context;
static PFNEGLTERMINATEPROC terminate;
static PFNEGLRELEASETHREADPROC release_thread;

static rf_glproc getproc(const char *name)
{
	return (rf_glproc)get_proc_address(name);
}

static void destroy(void *handle)
{
	egl *e = handle;
	if (!e)
		return;
	make_current(e->dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
	if (e->ctx != EGL_NO_CONTEXT)
		destroy_context(e->dpy, e->ctx);
	/* No eglTerminate(): the display is the process's, and terminating
	 * it unloads Mesa's driver, whose few still-allocated bytes a leak
	 * checker could then no longer tell from ours (main.c). */
	release_thread();
	free(e);
}

static int create(void **handle, rf_getproc_fn *gp)
{
	const char *name = getenv("NDO_EGL_LIB");
	if (!name || !*name)
		name = EGL_LIB;
	void *lib = dlopen(name, RTLD_NOW | RTLD_LOCAL);
	if (!lib)
		return ndo__fail(NDO_ENOTFOUND, "cannot load %s (Debian package libegl1)", name);
	get_proc_address = (PFNEGLGETPROCADDRESSPROC)dlsym(lib, "eglGetProcAddress");
	PFNEGLINITIALIZEPROC initialize = (PFNEGLINITIALIZEPROC)dlsym(lib, "eglInitialize");
	PFNEGLBINDAPIPROC bind_api = (PFNEGLBINDAPIPROC)dlsym(lib, "eglBindAPI");
	PFNEGLCREATECONTEXTPROC create_context =
		(PFNEGLCREATECONTEXTPROC)dlsym(lib, "eglCreateContext");
	PFNEGLGETERRORPROC get_error = (PFNEGLGETERRORPROC)dlsym(lib, "eglGetError");
	make_current = (PFNEGLMAKECURRENTPROC)dlsym(lib, "eglMakeCurrent");
	destroy_context = (PFNEGLDESTROYCONTEXTPROC)dlsym(lib, "eglDestroyContext");
	terminate = (PFNEGLTERMINATEPROC)dlsym(lib, "eglTerminate");
	release_thread = (PFNEGLRELEASETHREADPROC)dlsym(lib, "eglReleaseThread");
	if (!get_proc_address || !initialize || !bind_api || !create_context || !get_error ||
	    !make_current || !destroy_context || !terminate || !release_thread)
		return ndo__fail(NDO_ENOTFOUND, "%s lacks EGL 1.4 functions", name);
	PFNEGLGETPLATFORMDISPLAYEXTPROC get_platform_display =
		(PFNEGLGETPLATFORMDISPLAYEXTPROC)get_proc_address("eglGetPlatformDisplayEXT");
	if (!get_platform_display)
		return ndo__fail(NDO_ENOTFOUND, "EGL lacks eglGetPlatformDisplayEXT");

	EGLDisplay dpy = get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, NULL);
	EGLint major, minor;
	if (dpy == EGL_NO_DISPLAY || !initialize(dpy, &major, &minor))
		return ndo__fail(NDO_ENOTFOUND, "no EGL surfaceless display (error 0x%x)",
		                 (unsigned)get_error());
	if (!bind_api(EGL_OPENGL_API)) {
		terminate(dpy);
		return ndo__fail(NDO_ENOTFOUND, "EGL cannot bind the OpenGL API");
	}
	static const EGLint attribs[] = {
		EGL_CONTEXT_MAJOR_VERSION, 3,
		EGL_CONTEXT_MINOR_VERSION, 3,
		EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
		EGL_NONE};
	/* No config: EGL_KHR_no_config_context, which Mesa has; nothing is
	 * drawn to an EGL surface. */
	EGLContext ctx = create_context(dpy, EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT, attribs);
	if (ctx == EGL_NO_CONTEXT) {
		EGLint err = get_error();
		terminate(dpy);
		return ndo__fail(NDO_ENOTFOUND, "EGL gives no OpenGL 3.3 core context (error 0x%x)",
		                 (unsigned)err);
	}
	egl *e = malloc(sizeof *e);
	if (!e) {
		destroy_context(dpy, ctx);
		terminate(dpy);
		return ndo__fail(NDO_ENOMEM, "out of memory");
	}
	e->dpy = dpy;
	e->ctx = ctx;
	if (!make_current(dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, ctx)) {
		destroy(e);
		return ndo__fail(NDO_ENOTFOUND, "eglMakeCurrent without a surface failed");
	}
	*handle = e;
	*gp = getproc;
	return NDO_OK;
}

const rf_backend rf_backend_egl = {"egl", create, destroy};
