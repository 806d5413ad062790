/* renderer.h — draw one grid into an off-screen framebuffer and read the
 * pixels back.  Needs a current context (context.h).
 *
 * Per frame the CPU uploads the positions (ghost-padded float texture),
 * the owner ids or the scalar; the shaders (shaders/surface.vert,
 * surface.frag) do the rest: normals from the neighbours, Blinn–Phong,
 * cloth, wireframe. */
#ifndef RF_RENDERER_H
#define RF_RENDERER_H

#include <stdint.h>

enum { RF_COLOR_SOLID = 0, RF_COLOR_OWNER = 1, RF_COLOR_SCALAR = 2 };

/* How everything looks; fixed for the life of a renderer (the shaders are
 * compiled for it). */
/* Colours for the peers: as many as peers may simulate (NDO_MAX_PEERS). */
#define RF_PALETTE 8

typedef struct rf_style {
	int width, height;      /* pixels */
	int msaa;               /* samples per pixel: 1 (off), 2, 4, ... */
	int color_mode;         /* RF_COLOR_* */
	float background[3];    /* 0..1 */
	float color[3];         /* solid colour */
	float material[4];      /* ambient, diffuse, specular, shininess */
	float palette[RF_PALETTE][3]; /* a peer's place (scene.c) mod RF_PALETTE → colour */
	float unowned[3];       /* owner < 0 */
	float colormap[256][3]; /* scalar 0..1 → colour */
	int flat;               /* facets: each triangle's own normal */
	int cloth;              /* procedural cloth on/off */
	float cloth_threads;    /* threads across the grid's height (N lattice units) */
	int wireframe;          /* grid lines on/off */
	float wire_width;       /* pixels */
	float wire_color[4];    /* rgb, opacity */
} rf_style;

/* One frame's data, on the CPU. */
typedef struct rf_frame {
	int level;
	const float *position; /* (W+2)(H+2)·3 floats: ndo_pad(level, 1) of the positions */
	const int32_t *owner;  /* W·H ids (RF_COLOR_OWNER) */
	const float *scalar;   /* W·H values (RF_COLOR_SCALAR) */
	float range[2];        /* scalar values drawn at the colour map's ends */
	float wire_step;       /* lattice units between grid lines */
} rf_frame;

/* Where the camera and the light are. */
typedef struct rf_view {
	float modelview[16];  /* column-major, rigid */
	float projection[16]; /* column-major */
	float light[3];       /* unit vector towards the light, eye space */
	int cull;             /* skip triangles facing away (counter-clockwise is
	                         front: the grid's triangles seen from outside) */
} rf_view;

typedef struct rf_renderer rf_renderer;

/* Compile the shaders found in `shader_dir` and make the framebuffer.
 * Fails (with a detail: the file, or the compiler's first message) on a
 * missing or broken shader, or a size or sample count this OpenGL does
 * not support. */
int rf_renderer_create(const rf_style *style, const char *shader_dir, rf_renderer **out);
void rf_renderer_destroy(rf_renderer *r);

/* Draw a frame and read it into `rgba`: width·height RGBA bytes, bottom
 * row first (OpenGL's order).  Blocks until done. */
int rf_renderer_draw(rf_renderer *r, const rf_frame *f, const rf_view *v, uint8_t *rgba);

#endif
