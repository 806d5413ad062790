/* gl.h — the OpenGL 3.3 core functions render-frame calls, as a table of
 * pointers filled at run time from the current context's back end.
 *
 * Why not link libGL/libOpenGL: OSMesa is its own GL library (not
 * dispatched by libglvnd), so a binary linked against both it and libEGL
 * would have two definitions of every gl* symbol.  Each back end is
 * dlopen()ed instead (context.c) and its get-proc-address fills this table;
 * the binary then also starts on a system without libOSMesa (upstream Mesa
 * removed it in 25.1) and falls back to EGL.  Call as gl.Clear(...). */
#ifndef RF_GL_H
#define RF_GL_H

#include <GL/glcorearb.h>

#define RF_GL_FUNCS(X)                                                       \
	X(PFNGLGETERRORPROC, GetError)                                           \
	X(PFNGLGETSTRINGPROC, GetString)                                         \
	X(PFNGLGETINTEGERVPROC, GetIntegerv)                                     \
	X(PFNGLENABLEPROC, Enable)                                             \
	X(PFNGLDISABLEPROC, Disable)                                             \
	X(PFNGLVIEWPORTPROC, Viewport)                                           \
	X(PFNGLCLEARCOLORPROC, ClearColor)                                       \
	X(PFNGLCLEARPROC, Clear)                                                 \
	X(PFNGLFINISHPROC, Finish)                                               \
	X(PFNGLPIXELSTOREIPROC, PixelStorei)                                     \
	X(PFNGLREADPIXELSPROC, ReadPixels)                                       \
	X(PFNGLREADBUFFERPROC, ReadBuffer)                                       \
	X(PFNGLGENTEXTURESPROC, GenTextures)                                     \
	X(PFNGLDELETETEXTURESPROC, DeleteTextures)                               \
	X(PFNGLBINDTEXTUREPROC, BindTexture)                                     \
	X(PFNGLACTIVETEXTUREPROC, ActiveTexture)                                 \
	X(PFNGLTEXIMAGE2DPROC, TexImage2D)                                       \
	X(PFNGLTEXSUBIMAGE2DPROC, TexSubImage2D)                                 \
	X(PFNGLTEXPARAMETERIPROC, TexParameteri)                                 \
	X(PFNGLGENBUFFERSPROC, GenBuffers)                                       \
	X(PFNGLDELETEBUFFERSPROC, DeleteBuffers)                                 \
	X(PFNGLBINDBUFFERPROC, BindBuffer)                                       \
	X(PFNGLBUFFERDATAPROC, BufferData)                                       \
	X(PFNGLGENVERTEXARRAYSPROC, GenVertexArrays)                             \
	X(PFNGLDELETEVERTEXARRAYSPROC, DeleteVertexArrays)                       \
	X(PFNGLBINDVERTEXARRAYPROC, BindVertexArray)                             \
	X(PFNGLDRAWELEMENTSPROC, DrawElements)                                   \
	X(PFNGLDRAWARRAYSPROC, DrawArrays)                                       \
	X(PFNGLCREATESHADERPROC, CreateShader)                                   \
	X(PFNGLDELETESHADERPROC, DeleteShader)                                   \
	X(PFNGLSHADERSOURCEPROC, ShaderSource)                                   \
	X(PFNGLCOMPILESHADERPROC, CompileShader)                                 \
	X(PFNGLGETSHADERIVPROC, GetShaderiv)                                     \
	X(PFNGLGETSHADERINFOLOGPROC, GetShaderInfoLog)                           \
	X(PFNGLCREATEPROGRAMPROC, CreateProgram)                                 \
	X(PFNGLDELETEPROGRAMPROC, DeleteProgram)                                 \
	X(PFNGLATTACHSHADERPROC, AttachShader)                                   \
	X(PFNGLLINKPROGRAMPROC, LinkProgram)                                     \
	X(PFNGLGETPROGRAMIVPROC, GetProgramiv)                                   \
	X(PFNGLGETPROGRAMINFOLOGPROC, GetProgramInfoLog)                         \
	X(PFNGLUSEPROGRAMPROC, UseProgram)                                       \
	X(PFNGLGETUNIFORMLOCATIONPROC, GetUniformLocation)                       \
	X(PFNGLUNIFORM1IPROC, Uniform1i)                                         \
	X(PFNGLUNIFORM1FPROC, Uniform1f)                                         \
	X(PFNGLUNIFORM2FPROC, Uniform2f)                                         \
	X(PFNGLUNIFORM3FPROC, Uniform3f)                                         \
	X(PFNGLUNIFORM4FPROC, Uniform4f)                                         \
	X(PFNGLUNIFORMMATRIX3FVPROC, UniformMatrix3fv)                           \
	X(PFNGLUNIFORMMATRIX4FVPROC, UniformMatrix4fv)                           \
	X(PFNGLGENFRAMEBUFFERSPROC, GenFramebuffers)                             \
	X(PFNGLDELETEFRAMEBUFFERSPROC, DeleteFramebuffers)                       \
	X(PFNGLBINDFRAMEBUFFERPROC, BindFramebuffer)                             \
	X(PFNGLFRAMEBUFFERRENDERBUFFERPROC, FramebufferRenderbuffer)             \
	X(PFNGLFRAMEBUFFERTEXTURE2DPROC, FramebufferTexture2D)                   \
	X(PFNGLCHECKFRAMEBUFFERSTATUSPROC, CheckFramebufferStatus)               \
	X(PFNGLBLITFRAMEBUFFERPROC, BlitFramebuffer)                             \
	X(PFNGLGENRENDERBUFFERSPROC, GenRenderbuffers)                           \
	X(PFNGLDELETERENDERBUFFERSPROC, DeleteRenderbuffers)                     \
	X(PFNGLBINDRENDERBUFFERPROC, BindRenderbuffer)                           \
	X(PFNGLRENDERBUFFERSTORAGEPROC, RenderbufferStorage)                     \
	X(PFNGLRENDERBUFFERSTORAGEMULTISAMPLEPROC, RenderbufferStorageMultisample)

typedef struct rf_gl {
#define RF_GL_MEMBER(type, name) type name;
	RF_GL_FUNCS(RF_GL_MEMBER)
#undef RF_GL_MEMBER
} rf_gl;

extern rf_gl gl;

typedef void (*rf_glproc)(void);

/* Fill `gl` through getproc.  NDO_ENOTFOUND naming the first function the
 * back end does not provide. */
int rf_gl_load(rf_glproc (*getproc)(const char *name));

#endif
