/* progress.cpp — the progress bar on a terminal's stderr (remesh.h), for
 * every stage of remesh: only when stderr is a terminal, at most ten
 * redraws a second. */
#include "remesh.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>

static int progress_on = -1;
static double progress_last = 0;

void remesh::progress(const char *phase, double f)
{
	if (progress_on < 0)
		progress_on = isatty(STDERR_FILENO);
	if (!progress_on)
		return;
	double t = now_seconds();
	if (t - progress_last < 0.1 && f < 1)
		return;
	progress_last = t;
	int w = 30, k = (int)(std::min(1.0, std::max(0.0, f)) * w);
	fprintf(stderr, "\r%-14s [%.*s%*s] %3d%%", phase, k, "##############################",
	        w - k, "", (int)(100 * f));
}

void remesh::progress_done()
{
	if (progress_on > 0)
		fprintf(stderr, "\r\033[K");
}
