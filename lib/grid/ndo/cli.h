/* ndo/cli.h — what every ndo tool does the same way: its name in
 * messages, errors, numeric options with ranges, reading and writing grids,
 * closing standard output with a check.
 *
 * Exit codes shared by all tools: 0 success, 1 a runtime error (bad input
 * file, failed write), 2 a usage error (unknown option, value out of
 * range).  Tools document any further codes in their manual pages.
 */
#ifndef NDO_CLI_H
#define NDO_CLI_H

#include "ndo/grid.h"

#ifdef __cplusplus
extern "C" {
#endif

#define NDO_VERSION "0.1.0"

enum { NDO_EXIT_OK = 0, NDO_EXIT_FAIL = 1, NDO_EXIT_USAGE = 2 };

/* The tool's name, from argv[0]. */
extern const char *ndo_progname;

/* Call first in main(): records the program name and the command line
 * (for grid histories), and makes a write to a closed pipe an error
 * (EPIPE) rather than a silent death by SIGPIPE. */
void ndo_cli_init(int argc, char **argv);

/* The command line given to ndo_cli_init(). */
int ndo_cli_argc(void);
char **ndo_cli_argv(void);

/* "prog: message" on stderr, then exit(1) / exit(2).  The usage variant
 * adds "Try 'prog --help'.". */
void ndo_die(const char *fmt, ...) __attribute__((format(printf, 1, 2), noreturn));
void ndo_usage_error(const char *fmt, ...) __attribute__((format(printf, 1, 2), noreturn));
void ndo_warn(const char *fmt, ...) __attribute__((format(printf, 1, 2)));

/* The usage error for getopt_long's '?' (unknown option) or ':' (missing
 * value; put ':' first in the short-option string to get it), naming the
 * option as the user typed it. */
void ndo_bad_option(int c) __attribute__((noreturn));

/* Print "prog (ndo) VERSION" and exit 0. */
void ndo_print_version(void) __attribute__((noreturn));

/* Parse the value of option `opt` as an integer/double in [lo, hi]; on a
 * bad or out-of-range value, a usage error naming the option and range. */
long ndo_opt_long(const char *opt, const char *arg, long lo, long hi);
double ndo_opt_double(const char *opt, const char *arg, double lo, double hi);
/* A comma-separated list of exactly n doubles in [lo, hi]. */
void ndo_opt_doubles(const char *opt, const char *arg, int n, double *out,
                     double lo, double hi);
/* A grid level 0..NDO_MAX_LEVEL; beyond it the message says why. */
int ndo_opt_level(const char *opt, const char *arg);

/* Read the grid at `path` ("-" or NULL: stdin) or die with
 * "prog: path: what is wrong". */
ndo_grid *ndo_cli_load(const char *path);

/* Append this command line to the grid's history and write it where
 * `path` says (ndo_grid_export()), or die.  Call ndo_cli_check_output()
 * first, before any work, so a bad path fails early. */
void ndo_cli_save(const char *path, ndo_grid *g);
void ndo_cli_check_output(const char *path);
/* Die ("prog: what: cannot write path: …") unless a file written later
 * at `path` (through ndo_out_open) can be: its directory exists and is
 * writable, and it is not a directory.  Standard output, devices and
 * pipes pass unopened.  ndo_cli_check_output() ends with it. */
void ndo_cli_check_writable(const char *what, const char *path);

/* Flush and close stdout; on any write error, die (a full disk or a
 * closed pipe fails the pipeline instead of passing silently).  Call at
 * the end of main(). */
void ndo_close_stdout(void);

#ifdef __cplusplus
}
#endif
#endif
