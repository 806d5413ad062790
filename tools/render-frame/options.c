/* options.c — render-frame's options, parsed and validated (options.h). */
#include "options.h"
#include "colorbar.h"

#include "ndo/cli.h"
#include "ndo/io.h"

#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

#define MAX_SIZE 16384 /* llvmpipe's largest framebuffer */

static __attribute__((noreturn)) void usage(void)
{
	printf("Usage: %s [-o OUT] [options] [IN ...]\n"
	       "Draw grids into PNG images without a display (OpenGL through OSMesa or EGL).\n"
	       "Reads the grid files IN, each holding one grid or several back to back\n"
	       "(default, or '-': standard input), and writes one PNG per grid.\n"
	       "\n"
	       "Output:\n"
	       "  -o, --output OUT      a PNG file (OUT ends in .png); with a %%d (frame-%%04d.png)\n"
	       "                        one numbered file per grid (its directory made when\n"
	       "                        missing); without, each grid of a stream replaces OUT\n"
	       "                        (the latest frame).  Default: standard output, PNGs\n"
	       "                        back to back\n"
	       "      --start-number N  number of the first frame, 0..999999999 (default 0)\n"
	       "  -s, --size WxH        image size in pixels, each 1..%d (default 1024x768)\n"
	       "      --msaa N          samples per pixel: 1 (off, the default), 2, 4, 8, 16;\n"
	       "                        4 for figures (llvmpipe has at most 4)\n"
	       "      --compression N   PNG (zlib) level, 0..9 (default 1: fast)\n"
	       "Camera (the object is fitted to the view by default):\n"
	       "      --azimuth DEG     around the up axis, from +x towards +y (default 30;\n"
	       "                        240 for a grid remeshed from a mesh file: below)\n"
	       "      --elevation DEG   above the horizontal plane, -90..90 (default 20)\n"
	       "      --distance D      from the centre (default: fit the bounding sphere)\n"
	       "      --fov DEG         vertical field of view, 1..170 (default 30)\n"
	       "      --eye X,Y,Z       look from this point (instead of azimuth, elevation\n"
	       "                        and distance)\n"
	       "      --center X,Y,Z    look at this point (default: the bounding box's centre)\n"
	       "      --up X,Y,Z        the up direction (default 0,0,1; 0,1,0 for a grid\n"
	       "                        remeshed from a mesh file, the up of glTF and of\n"
	       "                        most scans, seen from its front, +z, and the left)\n"
	       "      --no-cull         draw triangles facing away too (default: skip them\n"
	       "                        when the eye is outside the object's bounding sphere)\n"
	       "      --refit           fit every grid (default: fit the first, then keep the\n"
	       "                        camera still, so a sequence does not jitter)\n"
	       "Look:\n"
	       "      --light AZ,EL     light direction from the camera in degrees: 0,0 is a\n"
	       "                        headlight, +AZ right, +EL up (default -30,30)\n"
	       "      --background C    #rrggbb or r,g,b in 0..1 (default #ffffff)\n"
	       "      --color C         the surface's colour (default #d2aa82)\n"
	       "      --material A,D,S,E  ambient, diffuse, specular (0..2), shininess\n"
	       "                        exponent 1..1000 (default 0.2,0.75,0.25,40)\n"
	       "      --color-by WHAT   auto (default: owner when the grid has an owner channel,\n"
	       "                        else solid), solid, owner (one colour per peer),\n"
	       "                        displacement (|position - rest|), CHANNEL (its\n"
	       "                        magnitude), CHANNEL:x|y|z|w (one component)\n"
	       "                        owner: each peer by its place in the partition (the\n"
	       "                        order the grid meets the peers, row by row from node\n"
	       "                        (0,0)), Okabe-Ito colours, safe for colour-blind\n"
	       "                        eyes: 1 blue, 2 orange, 3 bluish green, 4 vermilion,\n"
	       "                        5 sky blue, 6 reddish purple, 7 yellow, 8 light grey\n"
	       "                        (then again); nodes nobody owns dark grey\n"
	       "      --range LO,HI     scalar values at the colour map's ends (default: each\n"
	       "                        grid's smallest and largest)\n"
	       "      --no-colorbar     no colour bar when colouring by a scalar\n"
	       "      --font FILE       font for the colour bar's labels (default: fontconfig's\n"
	       "                        sans-serif)\n"
	       "      --flat            flat shading: each triangle's own normal (the facets)\n"
	       "      --cloth           a woven cloth texture (thesis figure 5.1b)\n"
	       "      --cloth-threads N threads across the grid's height, 1..4096 (default 48)\n"
	       "      --wireframe       draw the grid's edges (the input grid's when refined)\n"
	       "      --wire-width PX   line width in pixels, 0.5..20 (default 1)\n"
	       "Peers (LCM; docs/peers.md):\n"
	       "      --lcm URL         draw the object the peers simulate, one frame per step\n"
	       "                        as its last tile arrives (coloured by owner): live\n"
	       "                        from udpm://... ('default': LCM_DEFAULT_URL, else LCM's\n"
	       "                        default), or from a log of lcm-logger, file://PATH;\n"
	       "                        with a %%d in OUT the frame number is the step\n"
	       "      --lcm-channel P   the peers' channel prefix (default NDO)\n"
	       "      --key FILE        a keyed session's key (default: $NDO_KEY): only\n"
	       "                        messages it authenticates are drawn\n"
	       "      --every N         only the steps that are multiples of N, 1..1e9\n"
	       "                        (default 1)\n"
	       "      --hold-lost       draw a step whose tiles were lost too, its missing\n"
	       "                        nodes at the last frame's values (the share held is\n"
	       "                        printed for each such frame; default: skip it)\n"
	       "      --passive         live: publish nothing; by default a tile whose frame\n"
	       "                        was lost has its keyframe asked of its sender\n"
	       "                        (encoded sessions; docs/protocol.md), which a\n"
	       "                        passive watch waits for its next periodic one\n"
	       "      --lcm-timeout S   live: stop after S seconds without traffic, 0..1e6\n"
	       "                        (default 30; 0: wait for ever); it also stops when the\n"
	       "                        owner ends the session (it follows the owner's\n"
	       "                        successor when a silent owner is succeeded)\n"
	       "Grid:\n"
	       "  -k, --subdivide K     refine by K levels of butterfly subdivision before\n"
	       "                        drawing, 0..10 (level + K at most 10; default 0)\n"
	       "Program:\n"
	       "      --backend B       auto (default: osmesa, else egl), osmesa or egl\n"
	       "  -v, --verbose         print the back end and each frame's timings to stderr\n"
	       "  -h, --help            show this help and exit\n"
	       "      --version         show the version and exit\n"
	       "\n"
	       "Environment: NDO_SHADER_DIR, the directory of the shaders (surface.* and\n"
	       "normals.*; default: PREFIX/share/ndo/shaders beside PREFIX/bin, or the\n"
	       "source tree's shaders/).  NDO_OSMESA_LIB, NDO_EGL_LIB: the libraries to load\n"
	       "(default libOSMesa.so.8, libEGL.so.1).\n"
	       "Exit status: 0 success, 1 bad input, failed write or no OpenGL, 2 usage error.\n",
	       ndo_progname, MAX_SIZE);
	ndo_close_stdout();
	exit(NDO_EXIT_OK);
}

static void parse_size(const char *arg, rf_style *s)
{
	char *end;
	long w = strtol(arg, &end, 10), h = -1;
	if (end != arg && (*end == 'x' || *end == 'X')) {
		const char *p = end + 1;
		h = strtol(p, &end, 10);
		if (end == p || *end)
			h = -1;
	}
	if (end == arg || h < 0 || w < 0)
		ndo_usage_error("--size: '%s' is not WIDTHxHEIGHT (e.g. 1024x768)", arg);
	if (w < 1 || w > MAX_SIZE || h < 1 || h > MAX_SIZE)
		ndo_usage_error("--size: %ldx%ld: width and height must be 1..%d", w, h, MAX_SIZE);
	s->width = (int)w;
	s->height = (int)h;
}

static void parse_color(const char *opt, const char *arg, float out[3])
{
	if (arg[0] == '#') {
		unsigned v;
		int n;
		if (strlen(arg) != 7 || sscanf(arg + 1, "%6x%n", &v, &n) != 1 || n != 6)
			ndo_usage_error("%s: '%s' is not #rrggbb or r,g,b", opt, arg);
		out[0] = (float)((v >> 16) & 255) / 255.0f;
		out[1] = (float)((v >> 8) & 255) / 255.0f;
		out[2] = (float)(v & 255) / 255.0f;
		return;
	}
	double c[3];
	ndo_opt_doubles(opt, arg, 3, c, 0, 1);
	for (int k = 0; k < 3; k++)
		out[k] = (float)c[k];
}

/* OUT may hold one integer conversion, %d or %0Nd (N ≤ 12), and %%; any
 * other % is refused, so OUT is safe to hand to snprintf. */
static int check_pattern(const char *out)
{
	int conversions = 0;
	for (const char *p = out; *p; p++) {
		if (*p != '%')
			continue;
		if (p[1] == '%') {
			p++;
			continue;
		}
		const char *q = p + 1;
		if (*q == '0')
			q++;
		int digits = 0;
		while (*q >= '0' && *q <= '9')
			q++, digits++;
		if (*q != 'd' || digits > 2)
			ndo_usage_error("--output: '%s': only %%d, %%0Nd and %%%% may follow a %%", out);
		conversions++;
		p = q;
	}
	if (conversions > 1)
		ndo_usage_error("--output: '%s' has %d %%d conversions; one numbers the frames", out,
		                conversions);
	return conversions;
}

/* The output is a PNG, so its name says .png: `-o x.jpg` wrote a PNG
 * under a name that says otherwise, and `render-frame x.tgrid -o x.tgrid`
 * replaced the input with a picture of it (until 2026-12).  A device or
 * a pipe (/dev/null, a FIFO) takes what comes. */
static void check_png_name(const char *out)
{
	struct stat st;
	if (stat(out, &st) == 0 && !S_ISREG(st.st_mode) && !S_ISDIR(st.st_mode))
		return;
	size_t n = strlen(out);
	if (n < 4 || strcasecmp(out + n - 4, ".png") != 0)
		ndo_usage_error("--output: '%s' is not a .png name (render-frame writes PNG images)",
		                out);
}

void rf_output_name(const rf_options *o, long number, char *buf, size_t size)
{
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wformat-nonliteral"
	if (o->numbered)
		snprintf(buf, size, o->output, (int)number); /* checked by check_pattern() */
	else
		snprintf(buf, size, "%s", o->output ? o->output : "-");
#pragma GCC diagnostic pop
}

static void defaults(rf_options *o)
{
	memset(o, 0, sizeof *o);
	o->backend = "auto";
	o->compression = 1;
	o->colorbar = 1;
	o->coloring.mode = -1;
	o->coloring.component = -1;
	rf_camera_defaults(&o->camera);
	rf_style *s = &o->style;
	s->width = 1024;
	s->height = 768;
	s->msaa = 1;
	for (int k = 0; k < 3; k++)
		s->background[k] = 1;
	s->color[0] = 0xd2 / 255.0f, s->color[1] = 0xaa / 255.0f, s->color[2] = 0x82 / 255.0f;
	s->material[0] = 0.2f, s->material[1] = 0.75f, s->material[2] = 0.25f, s->material[3] = 40;
	/* Okabe & Ito (2002), "Color Universal Design": eight colours told
	 * apart with every common colour-vision deficiency; their black is a
	 * light grey here (a shaded black surface shows nothing), lighter than
	 * the unowned nodes' dark grey.  The most distinct pair comes first:
	 * two peers are blue and orange. */
	static const unsigned palette[RF_PALETTE] = {0x0072b2, 0xe69f00, 0x009e73, 0xd55e00,
	                                             0x56b4e9, 0xcc79a7, 0xf0e442, 0x999999};
	for (int k = 0; k < RF_PALETTE; k++)
		for (int c = 0; c < 3; c++)
			s->palette[k][c] = (float)((palette[k] >> (16 - 8 * c)) & 255) / 255.0f;
	s->unowned[0] = s->unowned[1] = s->unowned[2] = 0.35f;
	rf_viridis(s->colormap);
	s->cloth_threads = 48;
	s->wire_width = 1;
	s->wire_color[3] = 0.7f; /* black at 70 % */
	o->lcm.timeout = -1; /* not given */
}

void rf_options_parse(int argc, char **argv, rf_options *o)
{
	defaults(o);
	rf_camera *cam = &o->camera;
	rf_style *s = &o->style;
	int have_angles = 0;
	enum { OPT_START = 256, OPT_MSAA, OPT_COMPRESSION, OPT_AZIMUTH, OPT_ELEVATION,
	       OPT_DISTANCE, OPT_FOV, OPT_EYE, OPT_CENTER, OPT_UP, OPT_NO_CULL, OPT_REFIT, OPT_LIGHT,
	       OPT_BACKGROUND, OPT_COLOR, OPT_MATERIAL, OPT_COLOR_BY, OPT_RANGE, OPT_NO_COLORBAR,
	       OPT_FONT, OPT_FLAT, OPT_CLOTH, OPT_CLOTH_THREADS, OPT_WIREFRAME, OPT_WIRE_WIDTH, OPT_BACKEND,
	       OPT_VERSION, OPT_LCM, OPT_LCM_CHANNEL, OPT_EVERY, OPT_LCM_TIMEOUT, OPT_KEY, OPT_HOLD_LOST,
	       OPT_PASSIVE };
	static const struct option opts[] = {
		{"output", required_argument, 0, 'o'},
		{"start-number", required_argument, 0, OPT_START},
		{"size", required_argument, 0, 's'},
		{"msaa", required_argument, 0, OPT_MSAA},
		{"compression", required_argument, 0, OPT_COMPRESSION},
		{"azimuth", required_argument, 0, OPT_AZIMUTH},
		{"elevation", required_argument, 0, OPT_ELEVATION},
		{"distance", required_argument, 0, OPT_DISTANCE},
		{"fov", required_argument, 0, OPT_FOV},
		{"eye", required_argument, 0, OPT_EYE},
		{"center", required_argument, 0, OPT_CENTER},
		{"up", required_argument, 0, OPT_UP},
		{"no-cull", no_argument, 0, OPT_NO_CULL},
		{"refit", no_argument, 0, OPT_REFIT},
		{"light", required_argument, 0, OPT_LIGHT},
		{"background", required_argument, 0, OPT_BACKGROUND},
		{"color", required_argument, 0, OPT_COLOR},
		{"material", required_argument, 0, OPT_MATERIAL},
		{"color-by", required_argument, 0, OPT_COLOR_BY},
		{"range", required_argument, 0, OPT_RANGE},
		{"no-colorbar", no_argument, 0, OPT_NO_COLORBAR},
		{"font", required_argument, 0, OPT_FONT},
		{"flat", no_argument, 0, OPT_FLAT},
		{"cloth", no_argument, 0, OPT_CLOTH},
		{"cloth-threads", required_argument, 0, OPT_CLOTH_THREADS},
		{"wireframe", no_argument, 0, OPT_WIREFRAME},
		{"wire-width", required_argument, 0, OPT_WIRE_WIDTH},
		{"subdivide", required_argument, 0, 'k'},
		{"backend", required_argument, 0, OPT_BACKEND},
		{"lcm", required_argument, 0, OPT_LCM},
		{"key", required_argument, 0, OPT_KEY},
		{"lcm-channel", required_argument, 0, OPT_LCM_CHANNEL},
		{"every", required_argument, 0, OPT_EVERY},
		{"lcm-timeout", required_argument, 0, OPT_LCM_TIMEOUT},
		{"hold-lost", no_argument, 0, OPT_HOLD_LOST},
		{"passive", no_argument, 0, OPT_PASSIVE},
		{"verbose", no_argument, 0, 'v'},
		{"help", no_argument, 0, 'h'},
		{"version", no_argument, 0, OPT_VERSION},
		{0, 0, 0, 0}};
	int c;
	double v[4];
	while ((c = getopt_long(argc, argv, ":o:s:k:vh", opts, NULL)) != -1) {
		switch (c) {
		case 'o': o->output = optarg; break;
		case OPT_START: o->start_number = ndo_opt_long("--start-number", optarg, 0, 999999999); break;
		case 's': parse_size(optarg, s); break;
		case OPT_MSAA:
			s->msaa = (int)ndo_opt_long("--msaa", optarg, 1, 16);
			if (s->msaa & (s->msaa - 1))
				ndo_usage_error("--msaa: %d is not 1, 2, 4, 8 or 16", s->msaa);
			break;
		case OPT_COMPRESSION: o->compression = (int)ndo_opt_long("--compression", optarg, 0, 9); break;
		case OPT_AZIMUTH:
			cam->azimuth = ndo_opt_double("--azimuth", optarg, -360, 360);
			have_angles = cam->have_azimuth = 1;
			break;
		case OPT_ELEVATION: cam->elevation = ndo_opt_double("--elevation", optarg, -90, 90); have_angles = 1; break;
		case OPT_DISTANCE: cam->distance = ndo_opt_double("--distance", optarg, 1e-9, 1e12); have_angles = 1; break;
		case OPT_FOV: cam->fov = ndo_opt_double("--fov", optarg, 1, 170); break;
		case OPT_EYE: ndo_opt_doubles("--eye", optarg, 3, cam->eye, -1e12, 1e12); cam->have_eye = 1; break;
		case OPT_CENTER: ndo_opt_doubles("--center", optarg, 3, cam->center, -1e12, 1e12); cam->have_center = 1; break;
		case OPT_UP:
			ndo_opt_doubles("--up", optarg, 3, cam->up, -1e12, 1e12);
			if (cam->up[0] == 0 && cam->up[1] == 0 && cam->up[2] == 0)
				ndo_usage_error("--up: the zero vector has no direction");
			cam->have_up = 1;
			break;
		case OPT_NO_CULL: cam->cull = 0; break;
		case OPT_REFIT: o->refit = 1; break;
		case OPT_LIGHT:
			ndo_opt_doubles("--light", optarg, 2, v, -360, 360);
			cam->light_azimuth = v[0];
			cam->light_elevation = v[1];
			if (v[1] < -90 || v[1] > 90)
				ndo_usage_error("--light: elevation %g is outside [-90, 90]", v[1]);
			break;
		case OPT_BACKGROUND: parse_color("--background", optarg, s->background); break;
		case OPT_COLOR: parse_color("--color", optarg, s->color); break;
		case OPT_MATERIAL:
			ndo_opt_doubles("--material", optarg, 4, v, 0, 1000);
			for (int k = 0; k < 3; k++)
				if (v[k] > 2)
					ndo_usage_error("--material: %g is outside [0, 2]", v[k]);
			if (v[3] < 1)
				ndo_usage_error("--material: shininess %g is outside [1, 1000]", v[3]);
			for (int k = 0; k < 4; k++)
				s->material[k] = (float)v[k];
			break;
		case OPT_COLOR_BY:
			if (rf_coloring_parse(optarg, &o->coloring) != 0)
				ndo_usage_error("--color-by: '%s' is not auto, solid, owner, displacement, "
				                "CHANNEL or CHANNEL:x|y|z|w", optarg);
			break;
		case OPT_RANGE:
			ndo_opt_doubles("--range", optarg, 2, o->range, -1e30, 1e30);
			if (!(o->range[1] > o->range[0]))
				ndo_usage_error("--range: %g,%g: LO must be below HI", o->range[0], o->range[1]);
			o->have_range = 1;
			break;
		case OPT_NO_COLORBAR: o->colorbar = 0; break;
		case OPT_FONT: o->font = optarg; break;
		case OPT_FLAT: s->flat = 1; break;
		case OPT_CLOTH: s->cloth = 1; break;
		case OPT_CLOTH_THREADS: s->cloth_threads = (float)ndo_opt_double("--cloth-threads", optarg, 1, 4096); break;
		case OPT_WIREFRAME: s->wireframe = 1; break;
		case OPT_WIRE_WIDTH: s->wire_width = (float)ndo_opt_double("--wire-width", optarg, 0.5, 20); break;
		case 'k': o->subdivide = (int)ndo_opt_long("--subdivide", optarg, 0, NDO_MAX_LEVEL); break;
		case OPT_BACKEND:
			if (strcmp(optarg, "auto") && strcmp(optarg, "osmesa") && strcmp(optarg, "egl"))
				ndo_usage_error("--backend: '%s' is not auto, osmesa or egl", optarg);
			o->backend = optarg;
			break;
		case OPT_LCM:
			if (strncmp(optarg, "udpm://", 7) && strncmp(optarg, "file://", 7) &&
			    strcmp(optarg, "default"))
				ndo_usage_error("--lcm: '%s' is not udpm://..., file://PATH or default", optarg);
			if (strcmp(optarg, "file://") == 0)
				ndo_usage_error("--lcm: file:// needs a path (file://run.lcmlog)");
			o->lcm.url = strcmp(optarg, "default") ? optarg : NULL;
			o->use_lcm = 1;
			break;
		case OPT_LCM_CHANNEL:
			if (!*optarg || strlen(optarg) > 64 || strpbrk(optarg, ".*?[]()|\\^$+{} "))
				ndo_usage_error("--lcm-channel: '%s': 1..64 characters, no spaces or regex "
				                "operators", optarg);
			o->lcm.prefix = optarg;
			break;
		case OPT_KEY: o->lcm.key = optarg; break;
		case OPT_HOLD_LOST: o->lcm.hold_lost = 1; break;
		case OPT_PASSIVE: o->lcm.passive = 1; break;
		case OPT_EVERY: o->lcm.every = ndo_opt_long("--every", optarg, 1, 1000000000); break;
		case OPT_LCM_TIMEOUT: o->lcm.timeout = ndo_opt_double("--lcm-timeout", optarg, 0, 1e6); break;
		case 'v': o->verbose = 1; break;
		case 'h': usage();
		case OPT_VERSION: ndo_print_version();
		default: ndo_bad_option(c);
		}
	}
	if (cam->have_eye && have_angles)
		ndo_usage_error("--eye: give either --eye or --azimuth/--elevation/--distance");
	o->inputs = argv + optind;
	o->ninputs = argc - optind;
	static char *stdin_only[] = {"-"};
	if (o->use_lcm && o->ninputs)
		ndo_usage_error("'%s': --lcm draws the peers' state; no input files with it",
		                o->inputs[0]);
	if (!o->use_lcm && (o->lcm.prefix || o->lcm.every || o->lcm.timeout >= 0 || o->lcm.key ||
	                    o->lcm.hold_lost || o->lcm.passive))
		ndo_usage_error("--lcm-channel, --every, --hold-lost, --passive, --lcm-timeout and "
		                "--key go with --lcm");
	if (!o->lcm.prefix)
		o->lcm.prefix = "NDO";
	if (o->lcm.timeout < 0)
		o->lcm.timeout = 30;
	if (o->use_lcm) {
		if (o->output && !ndo_is_stdio(o->output)) {
			o->numbered = check_pattern(o->output);
			check_png_name(o->output);
		} else if (isatty(STDOUT_FILENO))
			ndo_usage_error("standard output is a terminal: give -o OUT.png");
		return;
	}
	if (o->ninputs == 0) {
		o->inputs = stdin_only;
		o->ninputs = 1;
	}
	for (int k = 0; k < o->ninputs; k++)
		if (ndo_is_stdio(o->inputs[k]) && isatty(STDIN_FILENO))
			ndo_usage_error("no input: give a grid file or pipe one in");
	if (o->output && !ndo_is_stdio(o->output)) {
		o->numbered = check_pattern(o->output);
		check_png_name(o->output);
		if (!o->numbered && o->ninputs > 1)
			ndo_usage_error("--output: '%s' has no %%d to number the frames of %d inputs "
			                "(e.g. frame-%%04d.png)", o->output, o->ninputs);
	} else {
		o->output = NULL;
		if (isatty(STDOUT_FILENO))
			ndo_usage_error("standard output is a terminal: give -o OUT.png");
	}
}
