/* io.c — atomic output files (ndo/io.h). */
#include "ndo/io.h"
#include "ndo/status.h"

#include <errno.h>
#include <fcntl.h>
#include <stdlib.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

int ndo_is_stdio(const char *path)
{
	return path == NULL || strcmp(path, "-") == 0;
}

/* Temporary files not yet committed or aborted.  A tool that exits on an
 * error (ndo_die(), a divergence, a signal handled by exit()) before it
 * commits must not leave "run.csv.tmp.XXXXXX" behind: the exit handler
 * removes whatever is still pending.  A tool holds a few outputs at once. */
enum { PENDING_MAX = 64 };
static char *pending[PENDING_MAX];

static void remove_pending(void)
{
	for (int k = 0; k < PENDING_MAX; k++)
		if (pending[k]) {
			unlink(pending[k]);
			pending[k] = NULL;
		}
}

static void track(const char *tmp, int on)
{
	static int registered;
	if (on && !registered)
		registered = atexit(remove_pending) == 0;
	for (int k = 0; k < PENDING_MAX; k++)
		if (on ? pending[k] == NULL : pending[k] == tmp) {
			pending[k] = on ? (char *)tmp : NULL;
			return;
		}
}

int ndo_mkdir_parents(const char *path)
{
	const char *slash = strrchr(path, '/');
	if (!slash || slash == path)
		return NDO_OK;
	size_t len = (size_t)(slash - path);
	char *dir = malloc(len + 1);
	if (!dir)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	memcpy(dir, path, len);
	dir[len] = '\0';
	for (char *p = dir + 1;; p++) {
		if (*p != '/' && *p != '\0')
			continue;
		char c = *p;
		*p = '\0';
		struct stat st;
		if (mkdir(dir, 0777) != 0 && errno != EEXIST) {
			int e = errno;
			int rc = ndo__fail(NDO_EIO, "cannot create directory %s: %s", dir, strerror(e));
			free(dir);
			return rc;
		}
		if (stat(dir, &st) != 0 || !S_ISDIR(st.st_mode)) {
			int rc = ndo__fail(NDO_EIO, "cannot create directory %s: %s", dir,
			                   strerror(ENOTDIR));
			free(dir);
			return rc;
		}
		*p = c;
		if (c == '\0')
			break;
	}
	free(dir);
	return NDO_OK;
}

int ndo_out_open(const char *path, ndo_outfile *o)
{
	memset(o, 0, sizeof *o);
	if (ndo_is_stdio(path)) {
		o->f = stdout;
		return NDO_OK;
	}
	o->path = strdup(path);
	if (!o->path)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	struct stat st;
	if (stat(path, &st) == 0 && !S_ISREG(st.st_mode)) {
		o->f = fopen(path, "wb");
		if (!o->f) {
			int e = errno;
			free(o->path);
			o->path = NULL;
			return ndo__fail(NDO_EIO, "cannot write %s: %s", path, strerror(e));
		}
		return NDO_OK;
	}
	size_t len = strlen(path);
	o->tmp = malloc(len + 16);
	if (!o->tmp) {
		free(o->path);
		o->path = NULL;
		return ndo__fail(NDO_ENOMEM, "out of memory");
	}
	snprintf(o->tmp, len + 16, "%s.tmp.XXXXXX", path);
	int fd = mkstemp(o->tmp);
	if (fd < 0) {
		int e = errno;
		free(o->tmp);
		free(o->path);
		o->tmp = o->path = NULL;
		return ndo__fail(NDO_EIO, "cannot write %s: %s", path, strerror(e));
	}
	/* mkstemp makes 0600; give the file the mode a plain fopen would. */
	mode_t mask = umask(0);
	umask(mask);
	fchmod(fd, 0666 & ~mask);
	o->f = fdopen(fd, "wb");
	if (!o->f) {
		close(fd);
		unlink(o->tmp);
		free(o->tmp);
		free(o->path);
		o->tmp = o->path = NULL;
		return ndo__fail(NDO_ENOMEM, "out of memory");
	}
	track(o->tmp, 1);
	return NDO_OK;
}

int ndo_out_commit(ndo_outfile *o)
{
	int rc = NDO_OK;
	const char *name = o->path ? o->path : "standard output";
	if (fflush(o->f) != 0 || ferror(o->f))
		rc = ndo__fail(NDO_EIO, "write error on %s: %s", name, strerror(errno));
	if (o->f != stdout && fclose(o->f) != 0 && rc == NDO_OK)
		rc = ndo__fail(NDO_EIO, "write error on %s: %s", name, strerror(errno));
	o->f = NULL;
	if (o->tmp) {
		track(o->tmp, 0);
		if (rc == NDO_OK && rename(o->tmp, o->path) != 0)
			rc = ndo__fail(NDO_EIO, "cannot rename onto %s: %s", o->path,
			               strerror(errno));
		if (rc != NDO_OK)
			unlink(o->tmp);
	}
	free(o->tmp);
	free(o->path);
	o->tmp = o->path = NULL;
	return rc;
}

void ndo_out_abort(ndo_outfile *o)
{
	if (o->f && o->f != stdout)
		fclose(o->f);
	if (o->tmp) {
		track(o->tmp, 0);
		unlink(o->tmp);
	}
	free(o->tmp);
	free(o->path);
	memset(o, 0, sizeof *o);
}

int ndo_lines_take(char *text, const char *prefix, int (*fn)(void *ctx, const char *line),
                   void *ctx)
{
	const size_t np = strlen(prefix);
	int rc = 0;
	char *w = text;
	for (char *line = text; *line;) {
		char *end = strchr(line, '\n');
		size_t len = end ? (size_t)(end - line) + 1 : strlen(line);
		if (strncmp(line, prefix, np) != 0) {
			memmove(w, line, len);
			w += len;
			line += len;
			continue;
		}
		char l[256];
		snprintf(l, sizeof l, "%.*s", (int)(end ? len - 1 : len), line);
		line += len;
		if (!rc) /* after an error the lines are only taken out */
			rc = fn(ctx, l);
	}
	*w = 0;
	return rc;
}
