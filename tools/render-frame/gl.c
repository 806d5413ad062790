/* gl.c — fill the OpenGL function table (gl.h). */
#include "gl.h"

#include "ndo/status.h"

rf_gl gl;

int rf_gl_load(rf_glproc (*getproc)(const char *name))
{
	/* The pointer types differ from rf_glproc only in their signatures;
	 * converting between function pointer types is defined behaviour as
	 * long as each is called through its own type. */
#define RF_GL_LOAD(type, name)                                               \
	if (!(gl.name = (type)getproc("gl" #name)))                              \
		return ndo__fail(NDO_ENOTFOUND, "OpenGL function gl%s is missing", #name);
	RF_GL_FUNCS(RF_GL_LOAD)
#undef RF_GL_LOAD
	return NDO_OK;
}
