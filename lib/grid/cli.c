/* cli.c — shared command-line behaviour (ndo/cli.h). */
#include "ndo/cli.h"
#include "ndo/export.h"
#include "ndo/gridfile.h"
#include "ndo/io.h"
#include "ndo/status.h"

#include <errno.h>
#include <getopt.h>
#include <limits.h>
#include <math.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

const char *ndo_progname = "ndo";
static int saved_argc;
static char **saved_argv;
static char **cli_argv_live; /* the array getopt permutes */

void ndo_cli_init(int argc, char **argv)
{
	if (argc > 0 && argv[0]) {
		const char *slash = strrchr(argv[0], '/');
		ndo_progname = slash ? slash + 1 : argv[0];
	}
	/* getopt_long permutes argv: keep the order the user typed */
	cli_argv_live = argv;
	saved_argc = argc;
	saved_argv = calloc((size_t)argc + 1, sizeof *saved_argv);
	if (saved_argv)
		memcpy(saved_argv, argv, (size_t)argc * sizeof *argv);
	else
		saved_argc = 0;
	opterr = 0; /* ndo_bad_option() words the message */
	signal(SIGPIPE, SIG_IGN);
}

void ndo_bad_option(int c)
{
	char **argv = cli_argv_live;
	const char *opt = optind > 0 && argv ? argv[optind - 1] : "?";
	if (c == ':')
		ndo_usage_error("option '%s' needs a value", opt);
	if (optopt && opt[0] == '-' && opt[1] != '-')
		ndo_usage_error("unknown option '-%c'", optopt);
	ndo_usage_error("unknown option '%s'", opt);
}

int ndo_cli_argc(void) { return saved_argc; }
char **ndo_cli_argv(void) { return saved_argv; }

static void vmessage(const char *fmt, va_list ap)
{
	fflush(stdout);
	fprintf(stderr, "%s: ", ndo_progname);
	vfprintf(stderr, fmt, ap);
	fputc('\n', stderr);
}

void ndo_die(const char *fmt, ...)
{
	va_list ap;
	va_start(ap, fmt);
	vmessage(fmt, ap);
	va_end(ap);
	exit(NDO_EXIT_FAIL);
}

void ndo_usage_error(const char *fmt, ...)
{
	va_list ap;
	va_start(ap, fmt);
	vmessage(fmt, ap);
	va_end(ap);
	fprintf(stderr, "Try '%s --help'.\n", ndo_progname);
	exit(NDO_EXIT_USAGE);
}

void ndo_warn(const char *fmt, ...)
{
	va_list ap;
	va_start(ap, fmt);
	vmessage(fmt, ap);
	va_end(ap);
}

void ndo_print_version(void)
{
	printf("%s (ndo) %s\n", ndo_progname, NDO_VERSION);
	ndo_close_stdout();
	exit(NDO_EXIT_OK);
}

long ndo_opt_long(const char *opt, const char *arg, long lo, long hi)
{
	char *end;
	errno = 0;
	long v = strtol(arg, &end, 10);
	if (end == arg || *end != '\0' || errno == ERANGE)
		ndo_usage_error("%s: '%s' is not an integer", opt, arg);
	if (v < lo || v > hi)
		ndo_usage_error("%s: %ld is outside %ld..%ld", opt, v, lo, hi);
	return v;
}

double ndo_opt_double(const char *opt, const char *arg, double lo, double hi)
{
	char *end;
	errno = 0;
	double v = strtod(arg, &end);
	if (end == arg || *end != '\0' || !isfinite(v))
		ndo_usage_error("%s: '%s' is not a finite number", opt, arg);
	if (v < lo || v > hi)
		ndo_usage_error("%s: %g is outside [%g, %g]", opt, v, lo, hi);
	return v;
}

void ndo_opt_doubles(const char *opt, const char *arg, int n, double *out,
                     double lo, double hi)
{
	const char *p = arg;
	for (int k = 0; k < n; k++) {
		char *end;
		errno = 0;
		out[k] = strtod(p, &end);
		if (end == p || !isfinite(out[k]) || (k + 1 < n ? *end != ',' : *end != '\0'))
			ndo_usage_error("%s: '%s' is not %d comma-separated numbers", opt, arg, n);
		if (out[k] < lo || out[k] > hi)
			ndo_usage_error("%s: %g is outside [%g, %g]", opt, out[k], lo, hi);
		p = end + 1;
	}
}

int ndo_opt_level(const char *opt, const char *arg)
{
	char *end;
	errno = 0;
	long v = strtol(arg, &end, 10);
	if (end == arg || *end != '\0' || errno == ERANGE)
		ndo_usage_error("%s: '%s' is not an integer", opt, arg);
	if (v > NDO_MAX_LEVEL) {
		double nodes = (double)((2L << (v > 30 ? 30 : v)) + 1) * (double)((1L << (v > 30 ? 30 : v)) + 1);
		ndo_usage_error("%s: level %ld is outside 0..%d (it would store %.3g nodes, "
		                "%.3g GB per 3-vector channel)",
		                opt, v, NDO_MAX_LEVEL, nodes, nodes * 24 / 1e9);
	}
	if (v < 0)
		ndo_usage_error("%s: level %ld is outside 0..%d", opt, v, NDO_MAX_LEVEL);
	return (int)v;
}

ndo_grid *ndo_cli_load(const char *path)
{
	ndo_grid *g;
	if (ndo_grid_load(path, &g) != NDO_OK)
		ndo_die("%s: %s", ndo_is_stdio(path) ? "standard input" : path,
		        ndo_errdetail());
	return g;
}

void ndo_cli_check_output(const char *path)
{
	if (path && !*path)
		ndo_usage_error("--output: an empty file name");
	if (!ndo_is_stdio(path) && ndo_unknown_extension(path))
		ndo_usage_error("%s: unknown output extension (use .tgrid, .obj, .ply, "
		                ".stl, .glb or .gltf)", path);
	if (ndo_is_stdio(path) && isatty(STDOUT_FILENO))
		ndo_usage_error("refusing to write a binary grid to a terminal "
		                "(use -o FILE or a pipe)");
	ndo_cli_check_writable(path, path);
}

void ndo_cli_check_writable(const char *what, const char *path)
{
	if (ndo_is_stdio(path))
		return;
	/* Before the work, which may take minutes: a missing directory, a
	 * directory or a place the user cannot write fails now, with the
	 * message the write would give.  The probe is the temporary file
	 * the write will make beside the destination, removed at once;
	 * devices and pipes are left alone (opening one may consume it, or
	 * wait for a reader). */
	struct stat st;
	if (stat(path, &st) == 0 && !S_ISREG(st.st_mode)) {
		if (S_ISDIR(st.st_mode))
			ndo_die("%s: cannot write %s: %s", what, path, strerror(EISDIR));
		return;
	}
	ndo_outfile o;
	if (ndo_out_open(path, &o) != NDO_OK)
		ndo_die("%s: %s", what, ndo_errdetail());
	ndo_out_abort(&o);
}

void ndo_cli_save(const char *path, ndo_grid *g)
{
	if (ndo_grid_add_history(g, saved_argc, saved_argv) != NDO_OK ||
	    ndo_grid_export(path, g) != NDO_OK)
		ndo_die("%s: %s", ndo_is_stdio(path) ? "standard output" : path,
		        ndo_errdetail());
}

void ndo_close_stdout(void)
{
	int bad = fflush(stdout) != 0 || ferror(stdout);
	int e = errno;
	if (fclose(stdout) != 0 && !bad) {
		bad = 1;
		e = errno;
	}
	if (bad) {
		fprintf(stderr, "%s: write error on standard output: %s\n", ndo_progname,
		        strerror(e ? e : EIO));
		exit(NDO_EXIT_FAIL);
	}
}
