/* ndo/gridfile.h — the grid file format (.tgrid), version 1.
 *
 * Self-describing, little-endian, checksummed, streamable: a reader needs
 * no seeking and reads exactly one grid's bytes, so several grids can
 * follow one another through a pipe.  The byte-by-byte description, with
 * a NumPy reader, is docs/grid-format.md; in short:
 *
 *   offset  bytes  field
 *   0       8      magic 89 'N' 'D' 'O' 0D 0A 1A 0A
 *   8       2      version (u16) = 1
 *   10      2      header size (u16) = 64
 *   12      4      level n (u32), 0..10
 *   16      4      channel count C (u32), 1..16
 *   20      4      history length L in bytes (u32), ≤ 1 MiB
 *   24      8      step (i64)
 *   32      8      time in seconds (f64)
 *   40      8      payload size P (u64): bytes of all channel data, padded
 *   48      12     zero
 *   60      4      CRC-32 of bytes 0..59 (zlib's crc32)
 *   64      32·C   channel table: name (16 bytes, NUL-padded), type (u8:
 *                  1 f64, 2 f32, 3 u8, 4 i32), width (u8, 1..4), 14 zero
 *   ...     L      history: the command lines that made the grid (UTF-8),
 *                  then zeros to a multiple of 8
 *   ...     P      each channel's H × W × width values, row-major (node
 *                  (i, j) at j·W + i, components interleaved), each
 *                  channel zero-padded to a multiple of 8 bytes
 *   ...     4      CRC-32 of everything from offset 64 to here
 *   ...     4      'E' 'N' 'D' '\n'
 *
 * Every header field is range-checked before anything is allocated, so a
 * hostile file can neither make a reader allocate more than its declared
 * (and checksummed) size nor read out of bounds.
 */
#ifndef NDO_GRIDFILE_H
#define NDO_GRIDFILE_H

#include <stdio.h>

#include "ndo/grid.h"

#ifdef __cplusplus
extern "C" {
#endif

#define NDO_FILE_VERSION 1
#define NDO_HISTORY_MAX (1u << 20)

/* Read one grid from a stream.  Returns NDO_EEOF (and *out = NULL) when
 * the stream ends cleanly before the first byte; NDO_ETRUNC, NDO_EFORMAT,
 * NDO_ECORRUPT, NDO_EVERSION or NDO_ERANGE, with a detail in
 * ndo_errdetail(), when the bytes are not a valid grid.  The caller owns
 * *out. */
int ndo_grid_read(FILE *f, ndo_grid **out);

/* Write one grid to a stream; NDO_EIO if a write fails. */
int ndo_grid_write(FILE *f, const ndo_grid *g);

/* Read the grid file at `path` ("-" or NULL: standard input).  A file
 * holding nothing is an error here (NDO_ETRUNC), not NDO_EEOF; so is
 * anything after the grid (NDO_EFORMAT: a second grid, or trailing
 * bytes) — ndo_grid_read() reads a stream of grids one at a time. */
int ndo_grid_load(const char *path, ndo_grid **out);

/* Write a grid file to `path` ("-" or NULL: standard output) through a
 * temporary file renamed on success (ndo/io.h). */
int ndo_grid_save(const char *path, const ndo_grid *g);

#ifdef __cplusplus
}
#endif
#endif
