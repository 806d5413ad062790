/* remesh — make a regular grid: from a procedural shape (--shape), the
 * grids the other tools and the tests start from.  The work is
 * ndo_shape_make() (lib/shapes.c). */
#include "ndo/ndo.h"

#include <getopt.h>
#include <stdlib.h>
#include <stdio.h>
#include <string.h>

static __attribute__((noreturn)) void usage(void)
{
	printf("Usage: %s --shape NAME [-l L] [-o OUT] [shape options]\n"
	       "Make a regular grid over the unfolded tetrahedron.\n"
	       "\n"
	       "  -s, --shape NAME      tetra, sphere, ellipsoid or wavy\n"
	       "  -l, --level L         grid level, 0..10 (default 5)\n"
	       "  -o, --output OUT      a grid file (.tgrid or no extension, '-' for\n"
	       "                        stdout; the default) or a mesh: .obj .ply .stl .glb .gltf\n"
	       "      --map MAP         tetrahedron → sphere: equal-area (default) or gnomonic\n"
	       "      --axes A,B,C      ellipsoid semi-axes along x, y, z (default 1.5,1,0.75)\n"
	       "      --amplitude A     wavy: radius 1 + A sin(Fx) sin(Fy) sin(Fz) (default 0.08)\n"
	       "      --frequency F     wavy: F (default 5)\n"
	       "  -h, --help            show this help and exit\n"
	       "      --version         show the version and exit\n"
	       "\n"
	       "Exit status: 0 success, 1 failed write, 2 usage error.\n",
	       ndo_progname);
	ndo_close_stdout();
	exit(NDO_EXIT_OK);
}

int main(int argc, char **argv)
{
	ndo_cli_init(argc, argv);
	ndo_shape_params sp;
	ndo_shape_defaults(&sp);
	const char *shape = NULL, *out = NULL;
	int level = 5;
	enum { OPT_MAP = 256, OPT_AXES, OPT_AMP, OPT_FREQ, OPT_VERSION };
	static const struct option opts[] = {
		{"shape", required_argument, 0, 's'},
		{"level", required_argument, 0, 'l'},
		{"output", required_argument, 0, 'o'},
		{"map", required_argument, 0, OPT_MAP},
		{"axes", required_argument, 0, OPT_AXES},
		{"amplitude", required_argument, 0, OPT_AMP},
		{"frequency", required_argument, 0, OPT_FREQ},
		{"help", no_argument, 0, 'h'},
		{"version", no_argument, 0, OPT_VERSION},
		{0, 0, 0, 0}};
	int c;
	while ((c = getopt_long(argc, argv, ":s:l:o:h", opts, NULL)) != -1) {
		switch (c) {
		case 's': shape = optarg; break;
		case 'l': level = ndo_opt_level("--level", optarg); break;
		case 'o': out = optarg; break;
		case OPT_MAP:
			if (strcmp(optarg, "equal-area") == 0)
				sp.map = NDO_MAP_EQUAL_AREA;
			else if (strcmp(optarg, "gnomonic") == 0)
				sp.map = NDO_MAP_GNOMONIC;
			else
				ndo_usage_error("--map: '%s' is not equal-area or gnomonic", optarg);
			break;
		case OPT_AXES: ndo_opt_doubles("--axes", optarg, 3, sp.axes, 1e-6, 1e6); break;
		case OPT_AMP: sp.amplitude = ndo_opt_double("--amplitude", optarg, -0.9, 0.9); break;
		case OPT_FREQ: sp.frequency = ndo_opt_double("--frequency", optarg, 0, 1000); break;
		case 'h': usage();
		case OPT_VERSION: ndo_print_version();
		default: ndo_bad_option(c);
		}
	}
	if (optind < argc)
		ndo_usage_error("'%s': reading meshes is not part of this build; use --shape",
		                argv[optind]);
	if (!shape)
		ndo_usage_error("no --shape given");
	ndo_cli_check_output(out);
	ndo_grid *g;
	if (ndo_shape_make(shape, level, &sp, &g) != NDO_OK)
		ndo_usage_error("--shape: %s", ndo_errdetail());
	ndo_cli_save(out, g);
	ndo_grid_destroy(g);
	ndo_close_stdout();
	return NDO_EXIT_OK;
}
