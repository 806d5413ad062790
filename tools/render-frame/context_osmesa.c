/* context_osmesa.c — the OSMesa back end (context.h): Mesa's off-screen
 * library, a core-profile context made current on a 1×1 buffer (the
 * picture itself goes to a framebuffer object). */
#include "context.h"

#include "ndo/status.h"

#include <GL/osmesa.h>
#include <dlfcn.h>
#include <stdlib.h>

#define OSMESA_LIB "libOSMesa.so.8" /* NDO_OSMESA_LIB overrides */

typedef struct osmesa {
	void *lib;
	OSMesaContext ctx;
	unsigned char buffer[4];
	__typeof__(&OSMesaDestroyContext) destroy;
	__typeof__(&OSMesaMakeCurrent) make_current;
} osmesa;

static __typeof__(&OSMesaGetProcAddress) get_proc_address;

static rf_glproc getproc(const char *name)
{
	return (rf_glproc)get_proc_address(name);
}

static void destroy(void *handle)
{
	osmesa *o = handle;
	if (!o)
		return;
	if (o->ctx) {
		o->make_current(NULL, NULL, 0, 0, 0); /* releases the buffer */
		o->destroy(o->ctx);
	}
	/* The library stays loaded: Mesa registers exit-time handlers and
	 * keeps thread-local state, which dlclose() would pull from under
	 * them. */
	free(o);
}

static int create(void **handle, rf_getproc_fn *gp)
{
	const char *name = getenv("NDO_OSMESA_LIB");
	if (!name || !*name)
		name = OSMESA_LIB;
	void *lib = dlopen(name, RTLD_NOW | RTLD_LOCAL);
	if (!lib)
		return ndo__fail(NDO_ENOTFOUND, "cannot load %s (Debian package libosmesa6)", name);
	__typeof__(&OSMesaCreateContextAttribs) create_attribs =
		(__typeof__(&OSMesaCreateContextAttribs))dlsym(lib, "OSMesaCreateContextAttribs");
	__typeof__(&OSMesaMakeCurrent) make_current =
		(__typeof__(&OSMesaMakeCurrent))dlsym(lib, "OSMesaMakeCurrent");
	osmesa *o = calloc(1, sizeof *o);
	if (!o)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	o->lib = lib;
	o->make_current = make_current;
	o->destroy = (__typeof__(&OSMesaDestroyContext))dlsym(lib, "OSMesaDestroyContext");
	get_proc_address = (__typeof__(&OSMesaGetProcAddress))dlsym(lib, "OSMesaGetProcAddress");
	if (!create_attribs || !make_current || !o->destroy || !get_proc_address) {
		free(o);
		return ndo__fail(NDO_ENOTFOUND, "%s lacks OSMesaCreateContextAttribs", name);
	}
	static const int attribs[] = {
		OSMESA_FORMAT, OSMESA_RGBA,
		OSMESA_DEPTH_BITS, 0,
		OSMESA_PROFILE, OSMESA_CORE_PROFILE,
		OSMESA_CONTEXT_MAJOR_VERSION, 3,
		OSMESA_CONTEXT_MINOR_VERSION, 3,
		0};
	o->ctx = create_attribs(attribs, NULL);
	if (!o->ctx) {
		free(o);
		return ndo__fail(NDO_ENOTFOUND, "OSMesa gives no OpenGL 3.3 core context");
	}
	if (!make_current(o->ctx, o->buffer, GL_UNSIGNED_BYTE, 1, 1)) {
		destroy(o);
		return ndo__fail(NDO_ENOTFOUND, "OSMesaMakeCurrent failed");
	}
	*handle = o;
	*gp = getproc;
	return NDO_OK;
}

const rf_backend rf_backend_osmesa = {"osmesa", create, destroy};
