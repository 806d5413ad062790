/* source_files.c — grids from files and standard input (source.h). */
#include "source.h"

#include "ndo/gridfile.h"
#include "ndo/io.h"
#include "ndo/status.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct files {
	rf_source base;
	int n, index;     /* paths, and the one being read */
	char *const *paths;
	FILE *f;          /* open stream of paths[index], or NULL */
	int grids;        /* grids read from it so far */
} files;

static const char *display_name(const char *path)
{
	return ndo_is_stdio(path) ? "standard input" : path;
}

static int next(rf_source *base, ndo_grid **out)
{
	files *s = (files *)base;
	*out = NULL;
	for (;;) {
		if (s->index >= s->n)
			return NDO_EEOF;
		const char *path = s->paths[s->index];
		if (!s->f) {
			if (ndo_is_stdio(path)) {
				s->f = stdin;
			} else if (!(s->f = fopen(path, "rb"))) {
				return ndo__fail(NDO_EIO, "%s: %s", path, strerror(errno));
			}
			s->grids = 0;
		}
		int rc = ndo_grid_read(s->f, out);
		if (rc == NDO_OK) {
			s->grids++;
			if (s->grids == 1)
				snprintf(s->base.where, sizeof s->base.where, "%s", display_name(path));
			else
				snprintf(s->base.where, sizeof s->base.where, "%s, grid %d",
				         display_name(path), s->grids);
			return NDO_OK;
		}
		if (rc != NDO_EEOF || s->grids == 0) {
			/* ndo__fail() formats into the buffer ndo_errdetail() points
			 * to: copy the detail first. */
			char what[256];
			snprintf(what, sizeof what, "%s", rc == NDO_EEOF ? "holds no grid" : ndo_errdetail());
			if (s->grids > 0)
				return ndo__fail(rc, "%s, grid %d: %s", display_name(path), s->grids + 1, what);
			return ndo__fail(rc == NDO_EEOF ? NDO_ETRUNC : rc, "%s: %s", display_name(path),
			                 what);
		}
		if (s->f != stdin)
			fclose(s->f);
		s->f = NULL;
		s->index++;
	}
}

static void destroy(rf_source *base)
{
	files *s = (files *)base;
	if (s->f && s->f != stdin)
		fclose(s->f);
	free(s);
}

int rf_source_files(int n, char *const paths[], rf_source **out)
{
	files *s = calloc(1, sizeof *s);
	if (!s)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	s->base.next = next;
	s->base.destroy = destroy;
	s->base.number = -1;
	s->n = n;
	s->paths = paths;
	*out = &s->base;
	return NDO_OK;
}
