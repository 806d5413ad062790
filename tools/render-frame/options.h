/* options.h — render-frame's command line. */
#ifndef RF_OPTIONS_H
#define RF_OPTIONS_H

#include "camera.h"
#include "renderer.h"
#include "scene.h"
#include "source.h"

typedef struct rf_options {
	const char *output;      /* NULL: standard output */
	int numbered;            /* output holds one %d conversion */
	long start_number;
	const char *backend;     /* auto, osmesa, egl */
	int compression;         /* zlib level */
	int subdivide;           /* levels of butterfly before drawing */
	rf_coloring coloring;
	int have_range;
	double range[2];
	int colorbar;
	const char *font;        /* NULL: fontconfig's sans-serif */
	int refit;               /* fit the camera to every grid */
	int verbose;
	rf_camera camera;
	rf_style style;          /* size, msaa, colours, cloth, wireframe */
	int ninputs;
	char **inputs;           /* "-" for standard input */
	rf_lcm_options lcm;      /* url set: draw the peers' LCM state */
	int use_lcm;
} rf_options;

/* Parse argv into *o, or exit with a usage error (2) naming the option
 * and its range; --help and --version print and exit 0. */
void rf_options_parse(int argc, char **argv, rf_options *o);

/* The name of frame `number` (o->output with its %d filled in). */
void rf_output_name(const rf_options *o, long number, char *buf, size_t size);

#endif
