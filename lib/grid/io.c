/* io.c — atomic output files (ndo/io.h). */
#include "ndo/io.h"
#include "ndo/status.h"

#include <errno.h>
#include <fcntl.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

int ndo_is_stdio(const char *path)
{
	return path == NULL || strcmp(path, "-") == 0;
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
	if (o->tmp)
		unlink(o->tmp);
	free(o->tmp);
	free(o->path);
	memset(o, 0, sizeof *o);
}
