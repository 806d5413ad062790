/* renderer.c — shaders, textures, framebuffer, one draw call per frame
 * (renderer.h). */
#include "renderer.h"
#include "gl.h"

#include "ndo/status.h"
#include "ndo/topology.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct rf_renderer {
	rf_style style;
	GLuint program, vao, index_buffer;
	GLuint normal_program, normal_fbo;    /* the normal pass (normals.frag) */
	GLuint tex_position, tex_normal, tex_owner, tex_scalar, tex_colormap;
	GLuint fbo, color_rb, depth_rb;       /* drawn into (multisampled if msaa > 1) */
	GLuint resolve_fbo, resolve_rb;       /* msaa > 1: resolved into */
	int level;                            /* of the uploaded index buffer, −1 none */
	GLsizei index_count;
	struct { GLint position, normal, width, modelview, projection, owner, palette, unowned,
	         scalar, range, colormap, light, material, color, cloth_period,
	         wire_step, wire_width, wire_color; } u;
};

/* The whole file at dir/name, NUL-terminated. */
static int read_source(const char *dir, const char *name, char **out)
{
	char path[4096];
	snprintf(path, sizeof path, "%s/%s", dir, name);
	FILE *f = fopen(path, "rb");
	if (!f)
		return ndo__fail(NDO_ENOTFOUND, "shader %s: %s", path, strerror(errno));
	size_t cap = 1 << 14, len = 0;
	char *s = malloc(cap);
	for (;;) {
		if (!s) {
			fclose(f);
			return ndo__fail(NDO_ENOMEM, "out of memory");
		}
		len += fread(s + len, 1, cap - 1 - len, f);
		if (len < cap - 1)
			break;
		char *t = cap < (1 << 24) ? realloc(s, cap *= 2) : NULL;
		if (!t) {
			free(s);
			fclose(f);
			return ndo__fail(NDO_ERANGE, "shader %s: larger than 8 MB", path);
		}
		s = t;
	}
	int bad = ferror(f);
	fclose(f);
	if (bad) {
		free(s);
		return ndo__fail(NDO_EIO, "shader %s: read error", path);
	}
	s[len] = '\0';
	*out = s;
	return NDO_OK;
}

/* Compile dir/name with `defines` inserted after its #version line. */
static int compile(GLenum type, const char *dir, const char *name, const char *defines,
                   GLuint *out)
{
	char *src = NULL;
	int rc = read_source(dir, name, &src);
	if (rc != NDO_OK)
		return rc;
	char *version = strstr(src, "#version");
	if (!version) {
		free(src);
		return ndo__fail(NDO_EFORMAT, "shader %s/%s: no #version line", dir, name);
	}
	char *body = strchr(version, '\n');
	body = body ? body + 1 : version + strlen(version);
	/* "#line" keeps the compiler's line numbers those of the file. */
	int version_line = 1;
	for (const char *p = src; p < body; p++)
		version_line += *p == '\n';
	char line[32];
	snprintf(line, sizeof line, "#line %d\n", version_line);
	const GLchar *parts[4] = {src, defines, line, body};
	GLint lens[4] = {(GLint)(body - src), -1, -1, -1};
	GLuint sh = gl.CreateShader(type);
	gl.ShaderSource(sh, 4, parts, lens);
	gl.CompileShader(sh);
	free(src);
	GLint ok;
	gl.GetShaderiv(sh, GL_COMPILE_STATUS, &ok);
	if (!ok) {
		char log[1024] = "";
		gl.GetShaderInfoLog(sh, sizeof log, NULL, log);
		log[strcspn(log, "\n")] = '\0';
		gl.DeleteShader(sh);
		return ndo__fail(NDO_EFORMAT, "shader %s/%s: %s", dir, name, log);
	}
	*out = sh;
	return NDO_OK;
}

/* Compile and link dir/vert + dir/frag into *out. */
static int link_program(const char *dir, const char *vert, const char *frag,
                        const char *defines, GLuint *out)
{
	GLuint vs, fs;
	int rc = compile(GL_VERTEX_SHADER, dir, vert, defines, &vs);
	if (rc != NDO_OK)
		return rc;
	if ((rc = compile(GL_FRAGMENT_SHADER, dir, frag, defines, &fs)) != NDO_OK) {
		gl.DeleteShader(vs);
		return rc;
	}
	GLuint prog = gl.CreateProgram();
	gl.AttachShader(prog, vs);
	gl.AttachShader(prog, fs);
	gl.LinkProgram(prog);
	gl.DeleteShader(vs);
	gl.DeleteShader(fs);
	GLint ok;
	gl.GetProgramiv(prog, GL_LINK_STATUS, &ok);
	if (!ok) {
		char log[1024] = "";
		gl.GetProgramInfoLog(prog, sizeof log, NULL, log);
		log[strcspn(log, "\n")] = '\0';
		gl.DeleteProgram(prog);
		return ndo__fail(NDO_EFORMAT, "shaders %s/%s and %s do not link: %s", dir, vert, frag,
		                 log);
	}
	*out = prog;
	return NDO_OK;
}

static int build_program(rf_renderer *r, const char *dir)
{
	const rf_style *s = &r->style;
	char defines[256];
	snprintf(defines, sizeof defines,
	         "#define COLOR_MODE %d\n#define CLOTH %d\n#define WIREFRAME %d\n#define FLAT %d\n",
	         s->color_mode, s->cloth ? 1 : 0, s->wireframe ? 1 : 0, s->flat ? 1 : 0);
	int rc = link_program(dir, "normals.vert", "normals.frag", "", &r->normal_program);
	if (rc == NDO_OK)
		rc = link_program(dir, "surface.vert", "surface.frag", defines, &r->program);
	if (rc != NDO_OK)
		return rc;
	gl.UseProgram(r->normal_program);
	gl.Uniform1i(gl.GetUniformLocation(r->normal_program, "u_position"), 0);
#define U(name) r->u.name = gl.GetUniformLocation(r->program, "u_" #name)
	U(position); U(normal); U(width); U(modelview); U(projection); U(owner); U(palette);
	U(unowned); U(scalar); U(range); U(colormap); U(light); U(material); U(color);
	U(cloth_period); U(wire_step); U(wire_width); U(wire_color);
#undef U
	return NDO_OK;
}

static GLuint new_texture(GLenum filter)
{
	GLuint t;
	gl.GenTextures(1, &t);
	gl.BindTexture(GL_TEXTURE_2D, t);
	gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, filter);
	gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, filter);
	gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
	gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
	return t;
}

static GLuint renderbuffer(int samples, GLenum format, int w, int h)
{
	GLuint rb;
	gl.GenRenderbuffers(1, &rb);
	gl.BindRenderbuffer(GL_RENDERBUFFER, rb);
	if (samples > 1)
		gl.RenderbufferStorageMultisample(GL_RENDERBUFFER, samples, format, w, h);
	else
		gl.RenderbufferStorage(GL_RENDERBUFFER, format, w, h);
	return rb;
}

static int build_framebuffer(rf_renderer *r)
{
	const rf_style *s = &r->style;
	GLint max_size = 0, max_samples = 0;
	gl.GetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &max_size);
	gl.GetIntegerv(GL_MAX_SAMPLES, &max_samples);
	if (s->width > max_size || s->height > max_size)
		return ndo__fail(NDO_ERANGE, "%dx%d is larger than this OpenGL's %dx%d", s->width,
		                 s->height, max_size, max_size);
	if (s->msaa > 1 && s->msaa > max_samples)
		return ndo__fail(NDO_ERANGE, "%d samples per pixel: this OpenGL (%s) has at most %d",
		                 s->msaa, (const char *)gl.GetString(GL_RENDERER), max_samples);
	gl.GenFramebuffers(1, &r->fbo);
	gl.BindFramebuffer(GL_FRAMEBUFFER, r->fbo);
	r->color_rb = renderbuffer(s->msaa, GL_RGBA8, s->width, s->height);
	r->depth_rb = renderbuffer(s->msaa, GL_DEPTH_COMPONENT24, s->width, s->height);
	gl.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, r->color_rb);
	gl.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, r->depth_rb);
	if (gl.CheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
		return ndo__fail(NDO_ERANGE, "cannot make a %dx%d framebuffer with %d samples",
		                 s->width, s->height, s->msaa);
	if (s->msaa > 1) {
		gl.GenFramebuffers(1, &r->resolve_fbo);
		gl.BindFramebuffer(GL_FRAMEBUFFER, r->resolve_fbo);
		r->resolve_rb = renderbuffer(1, GL_RGBA8, s->width, s->height);
		gl.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER,
		                           r->resolve_rb);
		if (gl.CheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
			return ndo__fail(NDO_ERANGE, "cannot make a %dx%d framebuffer", s->width, s->height);
	}
	return NDO_OK;
}

int rf_renderer_create(const rf_style *style, const char *shader_dir, rf_renderer **out)
{
	*out = NULL;
	rf_renderer *r = calloc(1, sizeof *r);
	if (!r)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	r->style = *style;
	r->level = -1;
	int rc = build_program(r, shader_dir);
	if (rc == NDO_OK)
		rc = build_framebuffer(r);
	if (rc != NDO_OK) {
		rf_renderer_destroy(r);
		return rc;
	}
	gl.GenVertexArrays(1, &r->vao);
	gl.GenBuffers(1, &r->index_buffer);
	gl.GenFramebuffers(1, &r->normal_fbo);
	r->tex_position = new_texture(GL_NEAREST);
	r->tex_normal = new_texture(GL_NEAREST);
	r->tex_owner = new_texture(GL_NEAREST);
	r->tex_scalar = new_texture(GL_NEAREST);
	r->tex_colormap = new_texture(GL_LINEAR);
	gl.PixelStorei(GL_UNPACK_ALIGNMENT, 1);
	gl.PixelStorei(GL_PACK_ALIGNMENT, 1);
	uint8_t cmap[256][3];
	for (int k = 0; k < 256; k++)
		for (int c = 0; c < 3; c++)
			cmap[k][c] = (uint8_t)(style->colormap[k][c] * 255.0f + 0.5f);
	gl.TexImage2D(GL_TEXTURE_2D, 0, GL_RGB8, 256, 1, 0, GL_RGB, GL_UNSIGNED_BYTE, cmap);

	gl.UseProgram(r->program);
	gl.Uniform1i(r->u.position, 0);
	gl.Uniform1i(r->u.owner, 1);
	gl.Uniform1i(r->u.scalar, 2);
	gl.Uniform1i(r->u.colormap, 3);
	gl.Uniform1i(r->u.normal, 4);
	gl.Uniform4f(r->u.material, style->material[0], style->material[1], style->material[2],
	             style->material[3]);
	gl.Uniform3f(r->u.color, style->color[0], style->color[1], style->color[2]);
	for (int k = 0; k < RF_PALETTE; k++) {
		char name[32];
		snprintf(name, sizeof name, "u_palette[%d]", k);
		GLint loc = gl.GetUniformLocation(r->program, name);
		gl.Uniform3f(loc, style->palette[k][0], style->palette[k][1], style->palette[k][2]);
	}
	gl.Uniform3f(r->u.unowned, style->unowned[0], style->unowned[1], style->unowned[2]);
	gl.Uniform1f(r->u.wire_width, style->wire_width);
	gl.Uniform4f(r->u.wire_color, style->wire_color[0], style->wire_color[1],
	             style->wire_color[2], style->wire_color[3]);
	gl.Enable(GL_DEPTH_TEST);
	if (style->msaa > 1)
		gl.Enable(GL_MULTISAMPLE);
	if (gl.GetError() != GL_NO_ERROR) {
		rf_renderer_destroy(r);
		return ndo__fail(NDO_EINVAL, "OpenGL error while setting up");
	}
	*out = r;
	return NDO_OK;
}

void rf_renderer_destroy(rf_renderer *r)
{
	if (!r)
		return;
	GLuint tex[] = {r->tex_position, r->tex_normal, r->tex_owner, r->tex_scalar, r->tex_colormap};
	gl.DeleteTextures(5, tex);
	GLuint rbs[] = {r->color_rb, r->depth_rb, r->resolve_rb};
	gl.DeleteRenderbuffers(3, rbs);
	GLuint fbos[] = {r->fbo, r->resolve_fbo, r->normal_fbo};
	gl.DeleteFramebuffers(3, fbos);
	gl.DeleteBuffers(1, &r->index_buffer);
	gl.DeleteVertexArrays(1, &r->vao);
	if (r->program)
		gl.DeleteProgram(r->program);
	if (r->normal_program)
		gl.DeleteProgram(r->normal_program);
	free(r);
}

/* A new level: the triangles of the grid (the same for every frame of a
 * level) as the element buffer, and a W × H float texture for the
 * normal pass to draw into. */
static int set_level(rf_renderer *r, int level)
{
	size_t ntri = ndo_triangle_count(level);
	int32_t *tri = malloc(ntri * 3 * sizeof *tri);
	if (!tri)
		return ndo__fail(NDO_ENOMEM, "out of memory for %zu triangles", ntri);
	ndo_triangles(level, tri);
	gl.BindVertexArray(r->vao);
	gl.BindBuffer(GL_ELEMENT_ARRAY_BUFFER, r->index_buffer);
	gl.BufferData(GL_ELEMENT_ARRAY_BUFFER, (GLsizeiptr)(ntri * 3 * sizeof *tri), tri,
	              GL_STATIC_DRAW);
	free(tri);
	int w = (2 << level) + 1, h = (1 << level) + 1;
	gl.ActiveTexture(GL_TEXTURE4);
	gl.BindTexture(GL_TEXTURE_2D, r->tex_normal);
	gl.TexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, w, h, 0, GL_RGBA, GL_FLOAT, NULL);
	gl.BindFramebuffer(GL_FRAMEBUFFER, r->normal_fbo);
	gl.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, r->tex_normal, 0);
	if (gl.CheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
		return ndo__fail(NDO_EINVAL, "cannot draw into a %dx%d float texture", w, h);
	r->level = level;
	r->index_count = (GLsizei)(ntri * 3);
	return NDO_OK;
}

int rf_renderer_draw(rf_renderer *r, const rf_frame *f, const rf_view *v, uint8_t *rgba)
{
	const rf_style *s = &r->style;
	int rc;
	if (f->level != r->level && (rc = set_level(r, f->level)) != NDO_OK)
		return rc;
	int w = (2 << f->level) + 1, h = (1 << f->level) + 1;

	gl.ActiveTexture(GL_TEXTURE0);
	gl.BindTexture(GL_TEXTURE_2D, r->tex_position);
	gl.TexImage2D(GL_TEXTURE_2D, 0, GL_RGB32F, w + 2, h + 2, 0, GL_RGB, GL_FLOAT, f->position);
	if (s->color_mode == RF_COLOR_OWNER) {
		gl.ActiveTexture(GL_TEXTURE1);
		gl.BindTexture(GL_TEXTURE_2D, r->tex_owner);
		gl.TexImage2D(GL_TEXTURE_2D, 0, GL_R32I, w, h, 0, GL_RED_INTEGER, GL_INT, f->owner);
	} else if (s->color_mode == RF_COLOR_SCALAR) {
		gl.ActiveTexture(GL_TEXTURE2);
		gl.BindTexture(GL_TEXTURE_2D, r->tex_scalar);
		gl.TexImage2D(GL_TEXTURE_2D, 0, GL_R32F, w, h, 0, GL_RED, GL_FLOAT, f->scalar);
		gl.ActiveTexture(GL_TEXTURE3);
		gl.BindTexture(GL_TEXTURE_2D, r->tex_colormap);
	}
	/* The normal pass: one fragment per node. */
	gl.BindFramebuffer(GL_FRAMEBUFFER, r->normal_fbo);
	gl.Viewport(0, 0, w, h);
	gl.Disable(GL_DEPTH_TEST);
	gl.Disable(GL_CULL_FACE);
	gl.UseProgram(r->normal_program);
	gl.BindVertexArray(r->vao);
	gl.DrawArrays(GL_TRIANGLES, 0, 3);
	gl.ActiveTexture(GL_TEXTURE4);
	gl.BindTexture(GL_TEXTURE_2D, r->tex_normal);

	gl.UseProgram(r->program);
	gl.Enable(GL_DEPTH_TEST);
	float lo = f->range[0], hi = f->range[1];
	if (!(hi > lo)) /* a constant scalar: the middle of the map */
		lo -= 1, hi += 1;
	gl.Uniform2f(r->u.range, lo, hi);
	gl.Uniform1i(r->u.width, w);
	gl.UniformMatrix4fv(r->u.modelview, 1, GL_FALSE, v->modelview);
	gl.UniformMatrix4fv(r->u.projection, 1, GL_FALSE, v->projection);
	gl.Uniform3f(r->u.light, v->light[0], v->light[1], v->light[2]);
	gl.Uniform1f(r->u.wire_step, f->wire_step);
	gl.Uniform1f(r->u.cloth_period, (float)(1 << f->level) / s->cloth_threads);

	gl.BindFramebuffer(GL_FRAMEBUFFER, r->fbo);
	gl.Viewport(0, 0, s->width, s->height);
	gl.ClearColor(s->background[0], s->background[1], s->background[2], 1.0f);
	gl.Clear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
	if (v->cull)
		gl.Enable(GL_CULL_FACE);
	else
		gl.Disable(GL_CULL_FACE);
	gl.BindVertexArray(r->vao);
	gl.DrawElements(GL_TRIANGLES, r->index_count, GL_UNSIGNED_INT, NULL);
	if (s->msaa > 1) {
		gl.BindFramebuffer(GL_READ_FRAMEBUFFER, r->fbo);
		gl.BindFramebuffer(GL_DRAW_FRAMEBUFFER, r->resolve_fbo);
		gl.BlitFramebuffer(0, 0, s->width, s->height, 0, 0, s->width, s->height,
		                   GL_COLOR_BUFFER_BIT, GL_NEAREST);
		gl.BindFramebuffer(GL_READ_FRAMEBUFFER, r->resolve_fbo);
	}
	gl.ReadPixels(0, 0, s->width, s->height, GL_RGBA, GL_UNSIGNED_BYTE, rgba);
	GLenum err = gl.GetError();
	if (err != GL_NO_ERROR)
		return ndo__fail(err == GL_OUT_OF_MEMORY ? NDO_ENOMEM : NDO_EINVAL,
		                 "OpenGL error 0x%x while drawing", (unsigned)err);
	return NDO_OK;
}
