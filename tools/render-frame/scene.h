/* scene.h — from a grid to what the renderer draws: refine it, pad its
 * positions with ghost cells, pick its colours. */
#ifndef RF_SCENE_H
#define RF_SCENE_H

#include "renderer.h"

#include "ndo/grid.h"

/* What to colour by (--color-by). */
typedef struct rf_coloring {
	int mode;          /* RF_COLOR_*, or −1: owner when the grid has one, else solid */
	int displacement;  /* RF_COLOR_SCALAR: |position − rest| */
	char channel[16];  /* RF_COLOR_SCALAR: the channel */
	int component;     /* its component, or −1 for the magnitude */
} rf_coloring;

/* Parse a --color-by value: solid, owner, displacement, CHANNEL (its
 * magnitude) or CHANNEL:K / CHANNEL:x|y|z|w (one component).  0 on
 * success, −1 when it is none of these. */
int rf_coloring_parse(const char *spec, rf_coloring *out);

/* The scalar's name for the colour bar ("displacement", "velocity",
 * "position:z"). */
void rf_coloring_name(const rf_coloring *c, char *buf, size_t size);

/* A prepared frame and the buffers behind it (reused from frame to
 * frame). */
typedef struct rf_scene {
	rf_frame frame;
	double center[3], radius; /* bounding sphere of the drawn grid, in the
	                           * uploaded (re-centred, scaled) coordinates */
	double origin[3], unit;   /* uploaded = (world − origin) / unit */
	float *position;          /* padded positions */
	int32_t *owner;
	float *scalar;
	size_t position_cap, owner_cap, scalar_cap; /* in elements */
} rf_scene;

/* Prepare grid `g` (refined by `subdivide` levels of butterfly first)
 * coloured as `c` says (mode already resolved, not −1).  Fails with a
 * detail when the grid lacks a channel the colouring needs, has
 * non-finite positions, or the refined level exceeds NDO_MAX_LEVEL.
 *
 * Positions go to the GPU as floats, re-centred and scaled first: with
 * `refit` (the first frame, or --refit) origin and unit become the grid's
 * bounding-box centre and bounding-sphere radius, so the object lies in
 * the unit sphere whatever its place and size (an object 1e8 m from the
 * origin, uploaded as is, kept 8 bits of its shape in a float and drew
 * blank); without, the last frame's origin and unit are kept so that a
 * sequence moves.  Only what does not fit a float even then is refused. */
int rf_scene_prepare(rf_scene *s, const ndo_grid *g, int subdivide, const rf_coloring *c,
                     int refit);
void rf_scene_free(rf_scene *s);

#endif
