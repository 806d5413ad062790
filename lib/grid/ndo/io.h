/* ndo/io.h — output files that are never left half-written.
 *
 * ndo_out_open() opens a temporary file beside the destination;
 * ndo_out_commit() flushes, checks every write and renames it over the
 * destination; ndo_out_abort() removes it.  A path of "-" (or NULL) means
 * standard output, which is flushed and checked on commit.  A destination
 * that exists and is not a regular file (a FIFO, /dev/null, /dev/full) is
 * written in place: renaming over a device would replace the device.
 * A temporary file still open when the process exits (an error path that
 * calls exit() before commit) is removed by an exit handler.
 */
#ifndef NDO_IO_H
#define NDO_IO_H

#include <stdio.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ndo_outfile {
	FILE *f;         /* write here */
	char *path;      /* destination (NULL for stdout) */
	char *tmp;       /* temporary name, NULL when writing in place */
} ndo_outfile;

/* 1 when `path` means standard input/output ("-" or NULL). */
int ndo_is_stdio(const char *path);

int ndo_out_open(const char *path, ndo_outfile *o);
int ndo_out_commit(ndo_outfile *o);
void ndo_out_abort(ndo_outfile *o);

/* Create the directories leading to `path` ("out/f%04d.png" → out/), as
 * mkdir -p does; an existing directory is fine.  NDO_EIO naming the
 * directory when one cannot be made (or a file stands in its place). */
int ndo_mkdir_parents(const char *path);

/* Take out of `text` (a string of lines) every line that starts with
 * `prefix`: each is passed, without its newline (at most 255 bytes), to
 * fn(ctx, line), and the other lines close up in place.  Returns 0, or the
 * first nonzero value fn returned (after it fn is not called again; every
 * matching line is still taken out). */
int ndo_lines_take(char *text, const char *prefix, int (*fn)(void *ctx, const char *line),
                   void *ctx);

#ifdef __cplusplus
}
#endif
#endif
