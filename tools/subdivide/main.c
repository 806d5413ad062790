/* subdivide — refine a grid by modified butterfly subdivision.
 * The work is ndo_subdivide_levels() (lib/grid/subdivide.c). */
#include "ndo/ndo.h"

#include <getopt.h>
#include <stdlib.h>
#include <stdio.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

static __attribute__((noreturn)) void usage(void)
{
	printf("Usage: %s [-l K] [-o OUT] [--corners RULE] [IN]\n"
	       "Refine a grid by K levels of modified butterfly subdivision. Reads IN\n"
	       "(default: standard input), writes OUT (default: standard output).\n"
	       "Every channel is refined; level n nodes keep their values exactly.\n"
	       "\n"
	       "  -l, --levels K     levels to add, 0..10, result at most level 10 (default 1)\n"
	       "  -o, --output OUT   a grid file (.tgrid or no extension, '-' for stdout)\n"
	       "                     or a mesh: .obj .ply .stl .glb .gltf\n"
	       "      --corners RULE rule at the four valence-3 corners: zorin (Zorin et\n"
	       "                     al. 1996, the default) or thesis (duplicated edges)\n"
	       "  -v, --verbose      print levels, node counts and time to stderr\n"
	       "  -h, --help         show this help and exit\n"
	       "      --version      show the version and exit\n"
	       "\n"
	       "Exit status: 0 success, 1 bad input (also a position that is not finite)\n"
	       "or failed write, 2 usage error.\n",
	       ndo_progname);
	ndo_close_stdout();
	exit(NDO_EXIT_OK);
}

static double now(void)
{
	struct timespec t;
	clock_gettime(CLOCK_MONOTONIC, &t);
	return t.tv_sec + 1e-9 * t.tv_nsec;
}

int main(int argc, char **argv)
{
	ndo_cli_init(argc, argv);
	int levels = 1, verbose = 0;
	const char *out = NULL;
	ndo_corner_rule rule = NDO_CORNERS_ZORIN;
	enum { OPT_CORNERS = 256, OPT_VERSION };
	static const struct option opts[] = {
		{"levels", required_argument, 0, 'l'},
		{"output", required_argument, 0, 'o'},
		{"corners", required_argument, 0, OPT_CORNERS},
		{"verbose", no_argument, 0, 'v'},
		{"help", no_argument, 0, 'h'},
		{"version", no_argument, 0, OPT_VERSION},
		{0, 0, 0, 0}};
	int c;
	while ((c = getopt_long(argc, argv, ":l:o:vh", opts, NULL)) != -1) {
		switch (c) {
		case 'l': levels = ndo_opt_level("--levels", optarg); break;
		case 'o': out = optarg; break;
		case 'v': verbose = 1; break;
		case OPT_CORNERS:
			if (strcmp(optarg, "zorin") == 0)
				rule = NDO_CORNERS_ZORIN;
			else if (strcmp(optarg, "thesis") == 0)
				rule = NDO_CORNERS_THESIS;
			else
				ndo_usage_error("--corners: '%s' is not zorin or thesis", optarg);
			break;
		case 'h': usage();
		case OPT_VERSION: ndo_print_version();
		default: ndo_bad_option(c);
		}
	}
	if (optind + 1 < argc)
		ndo_usage_error("more than one input: '%s'", argv[optind + 1]);
	const char *in = optind < argc ? argv[optind] : NULL;
	if (ndo_is_stdio(in) && isatty(STDIN_FILENO))
		ndo_usage_error("no input: give a grid file or pipe one in");
	ndo_cli_check_output(out);

	ndo_grid *g = ndo_cli_load(in);
	/* Stored duplicates are one vertex: subdivision reads the canonical
	 * copy.  Copies that disagree (a grid written by other software) would
	 * otherwise be overwritten without a word. */
	const char *chn = "";
	int di = 0, dj = 0;
	size_t bad = ndo_grid_unsynced(g, &chn, &di, &dj);
	if (bad) {
		ndo_warn("warning: %s: %zu %s (first: %s at (%d, %d)); the canonical values are used",
		         ndo_is_stdio(in) ? "standard input" : in, bad,
		         bad == 1 ? "stored duplicate disagrees with the node it repeats"
		                  : "stored duplicates disagree with the nodes they repeat",
		         chn, di, dj);
		ndo_grid_sync(g);
	}
	/* A NaN or an infinity spreads over the butterfly's reach and makes a
	 * mesh no viewer draws; simulate-peer and render-frame refuse it, so
	 * subdivide names it at the file's node rather than pass it on. */
	const char *name = ndo_is_stdio(in) ? "standard input" : in;
	int bi, bj;
	if (ndo_grid_nonfinite(g, NDO_CH_POSITION, &bi, &bj)) {
		ndo_grid_destroy(g);
		ndo_die("%s: position of node (%d, %d) is not finite", name, bi, bj);
	}
	if (g->level + levels > NDO_MAX_LEVEL)
		ndo_usage_error("--levels: level %d + %d exceeds the largest level, %d",
		                g->level, levels, NDO_MAX_LEVEL);
	double t0 = now();
	ndo_grid *fine;
	if (ndo_subdivide_levels(g, levels, rule, &fine) != NDO_OK)
		ndo_die("%s", ndo_errdetail());
	/* Finite positions near ±DBL_MAX can refine beyond it (the mask's
	 * weights sum to 1 but its positive ones to 1.25). */
	if (ndo_grid_nonfinite(fine, NDO_CH_POSITION, &bi, &bj)) {
		ndo_grid_destroy(g);
		ndo_grid_destroy(fine);
		ndo_die("%s: position of node (%d, %d) of the grid refined by %d level%s is not "
		        "finite: the input's positions are too large", name, bi, bj, levels,
		        levels == 1 ? "" : "s");
	}
	double t1 = now();
	if (verbose)
		fprintf(stderr, "%s: level %d → %d: %zu → %zu stored nodes, %d channels, %.3f ms\n",
		        ndo_progname, g->level, fine->level, g->count, fine->count,
		        fine->nchannels, 1e3 * (t1 - t0));
	ndo_cli_save(out, fine);
	ndo_grid_destroy(g);
	ndo_grid_destroy(fine);
	ndo_close_stdout();
	return NDO_EXIT_OK;
}
