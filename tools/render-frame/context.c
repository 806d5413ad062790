/* context.c — choose a back end and load OpenGL through it (context.h). */
#include "context.h"
#include "gl.h"

#include "ndo/status.h"

#include <stdio.h>
#include <string.h>

static int open_one(const rf_backend *b, rf_context *out)
{
	rf_getproc_fn getproc;
	void *handle;
	int rc = b->create(&handle, &getproc);
	if (rc != NDO_OK)
		return rc;
	if ((rc = rf_gl_load(getproc)) != NDO_OK) {
		b->destroy(handle);
		return rc;
	}
	GLint major = 0, minor = 0;
	gl.GetIntegerv(GL_MAJOR_VERSION, &major);
	gl.GetIntegerv(GL_MINOR_VERSION, &minor);
	if (major * 10 + minor < 33) {
		b->destroy(handle);
		return ndo__fail(NDO_ENOTFOUND, "OpenGL %d.%d, not 3.3 or later", major, minor);
	}
	const char *r = (const char *)gl.GetString(GL_RENDERER);
	const char *v = (const char *)gl.GetString(GL_VERSION);
	snprintf(out->renderer, sizeof out->renderer, "%s", r ? r : "?");
	snprintf(out->version, sizeof out->version, "%s", v ? v : "?");
	out->backend = b;
	out->handle = handle;
	return NDO_OK;
}

int rf_context_open(const char *name, rf_context *out)
{
	memset(out, 0, sizeof *out);
	if (strcmp(name, "osmesa") == 0 || strcmp(name, "egl") == 0) {
		const rf_backend *b = name[0] == 'o' ? &rf_backend_osmesa : &rf_backend_egl;
		int rc = open_one(b, out);
		if (rc != NDO_OK) {
			char why[256]; /* ndo__fail() overwrites the detail */
			snprintf(why, sizeof why, "%s", ndo_errdetail());
			return ndo__fail(rc, "back end %s: %s", b->name, why);
		}
		return NDO_OK;
	}
	if (strcmp(name, "auto") != 0)
		return ndo__fail(NDO_EINVAL, "unknown back end '%s'", name);
	char first[256], second[256];
	if (open_one(&rf_backend_osmesa, out) == NDO_OK)
		return NDO_OK;
	snprintf(first, sizeof first, "%s", ndo_errdetail());
	if (open_one(&rf_backend_egl, out) == NDO_OK)
		return NDO_OK;
	snprintf(second, sizeof second, "%s", ndo_errdetail());
	return ndo__fail(NDO_ENOTFOUND, "no OpenGL 3.3 context: osmesa: %s; egl: %s", first,
	                 second);
}

void rf_context_close(rf_context *c)
{
	if (c->backend)
		c->backend->destroy(c->handle);
	memset(c, 0, sizeof *c);
}
