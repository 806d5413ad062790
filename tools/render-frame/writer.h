/* writer.h — PNG files written by a thread of their own, so that encoding
 * frame k overlaps drawing frame k+1 (a level-7 frame at 1024×768 takes
 * about as long to compress as to draw; docs/bench/render.md).
 *
 * Two image buffers take turns: the caller fills the one rf_writer_buffer()
 * gives and hands it over with rf_writer_submit(); the next call to
 * rf_writer_buffer() returns the other, waiting if it is still being
 * written.  Files are written in submission order. */
#ifndef RF_WRITER_H
#define RF_WRITER_H

#include <stdint.h>

typedef struct rf_writer rf_writer;

/* Images of width × height, zlib level `compression` (png.h). */
int rf_writer_create(int width, int height, int compression, rf_writer **out);

/* A buffer for the next image (width·height RGBA, bottom row first). */
uint8_t *rf_writer_buffer(rf_writer *w);

/* Queue the buffer last returned by rf_writer_buffer() for `path` with
 * `description` (both copied).  Returns the failure of an earlier write,
 * if any (with its detail), so the caller can stop early. */
int rf_writer_submit(rf_writer *w, const char *path, const char *description);

/* Wait for every queued file; the first failure, if any. */
int rf_writer_finish(rf_writer *w);

/* Finish and free.  Accepts NULL. */
void rf_writer_destroy(rf_writer *w);

#endif
