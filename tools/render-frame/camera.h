/* camera.h — where the camera looks from, fitted to the object or given
 * explicitly, and the light, as the matrices the renderer takes.
 *
 * World axes: +z is up by default (--up); azimuth is measured in the xy
 * plane from +x towards +y, elevation upwards from that plane.  The light
 * is given relative to the camera, so it stays where it is when the camera
 * moves: azimuth 0, elevation 0 is a headlight; positive azimuth moves it
 * to the right, positive elevation up. */
#ifndef RF_CAMERA_H
#define RF_CAMERA_H

#include "renderer.h"

#include <stddef.h>

typedef struct rf_camera {
	double azimuth, elevation;  /* degrees */
	double distance;            /* from the centre; 0: fit the object */
	double fov;                 /* vertical field of view, degrees */
	double margin;              /* fit: bounding sphere radius × margin fills the view */
	int have_eye, have_center;  /* explicit look-at */
	int have_up, have_azimuth;  /* given: the mesh's default view leaves them */
	double eye[3], center[3], up[3];
	double light_azimuth, light_elevation; /* degrees, relative to the camera */
	int cull;                   /* skip back faces when the eye is outside the
	                               bounding sphere (they are hidden then) */
} rf_camera;

/* Defaults: azimuth 30, elevation 20, fitted distance, 30° field of view,
 * margin 1.1, up +z, light from the upper left (−30, 30), culling. */
void rf_camera_defaults(rf_camera *c);

/* The view a person would choose for a grid: one remeshed from a mesh file
 * (its history's first command is remesh of a file, not --shape) stands on
 * +y, the up of glTF and of most scans (the Stanford bunny, armadillo ...),
 * and is seen from its front (+z) and a little to the left (azimuth 240);
 * ndo's own shapes and the thesis scenes keep +z.  What the user gave
 * (--up, --azimuth) stays.  1 if the view changed. */
int rf_camera_for_grid(rf_camera *c, const char *history);

/* The centre of the axis-aligned bounding box of n points (3 floats
 * each, stride `stride` floats) and the largest distance from it. */
void rf_bounds(const float *p, size_t n, size_t stride, double center[3], double *radius);

/* The view for an image of aspect width/height, looking at an object
 * whose bounding sphere is (center, radius). */
void rf_camera_view(const rf_camera *c, const double center[3], double radius, double aspect,
                    rf_view *out);

#endif
