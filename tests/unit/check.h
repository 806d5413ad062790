/* check.h — the unit tests' few macros.
 *
 * A test program runs cases with RUN(fn); each prints "PASS name" or the
 * first few failed checks and "FAIL name", which tests/run counts.  A
 * failing check says where, what was expected and what was found. */
#ifndef NDO_TEST_CHECK_H
#define NDO_TEST_CHECK_H

#include <dirent.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int ck_case_failures, ck_failed_cases;
static const char *ck_program = "test";

static void ck_fail(const char *file, int line, const char *fmt, ...)
{
	if (ck_case_failures++ < 8) {
		va_list ap;
		va_start(ap, fmt);
		printf("    %s:%d: ", file, line);
		vprintf(fmt, ap);
		printf("\n");
		va_end(ap);
	}
}

/* CHECK(cond, "printf-style message of what was expected and found") */
#define CHECK(cond, ...) ((cond) ? (void)0 : ck_fail(__FILE__, __LINE__, __VA_ARGS__))

/* |a − b| ≤ tol, printing both */
#define CHECK_NEAR(a, b, tol, what)                                               \
	do {                                                                          \
		double ck_a = (a), ck_b = (b);                                            \
		CHECK(fabs(ck_a - ck_b) <= (tol), "%s: expected %.17g, got %.17g (tolerance %g)", \
		      what, ck_b, ck_a, (double)(tol));                                   \
	} while (0)

/* CHECK_ONLY=WORD in the environment: only the cases whose name holds
 * WORD run (while working on one). */
static void ck_run(const char *name, void (*fn)(void))
{
	const char *only = getenv("CHECK_ONLY");
	if (only && *only && !strstr(name, only))
		return;
	ck_case_failures = 0;
	fn();
	if (ck_case_failures > 8)
		printf("    ... and %d more failed checks\n", ck_case_failures - 8);
	printf("%s %s: %s\n", ck_case_failures ? "FAIL" : "PASS", ck_program, name);
	fflush(stdout);
	if (ck_case_failures)
		ck_failed_cases++;
}

#define RUN(fn) ck_run(#fn, fn)

/* Entries of a directory other than . and .. (files left behind). */
static inline int count_entries(const char *dir)
{
	DIR *d = opendir(dir);
	int n = 0;
	for (struct dirent *e; d && (e = readdir(d));)
		n += e->d_name[0] != '.';
	if (d)
		closedir(d);
	return n;
}

#endif
