/* ndo/status.h — the one status type of the ndo library.
 *
 * Every fallible library call returns an int: 0 (NDO_OK) on success or one of
 * the negative codes below.  ndo_strerror() names the code; ndo_errdetail()
 * returns the detail recorded by the most recent failing call in this thread
 * ("channel 'velocity': truncated after 1200 of 3072 bytes"), so a tool can
 * print one line "prog: file: detail" and exit.
 */
#ifndef NDO_STATUS_H
#define NDO_STATUS_H

#ifdef __cplusplus
extern "C" {
#endif

enum {
	NDO_OK = 0,
	NDO_ENOMEM = -1,    /* allocation failed */
	NDO_EIO = -2,       /* read or write failed (errno-level problem) */
	NDO_ETRUNC = -3,    /* input ended early */
	NDO_EFORMAT = -4,   /* not an ndo grid, or a malformed field */
	NDO_ECORRUPT = -5,  /* checksum mismatch */
	NDO_EVERSION = -6,  /* a format version this build does not read */
	NDO_ERANGE = -7,    /* a value outside its documented range */
	NDO_EINVAL = -8,    /* a bad argument from the caller */
	NDO_ENOTFOUND = -9, /* a named thing (channel, format) does not exist */
	NDO_EEXPORT = -10,  /* the mesh exporter (assimp) failed */
	NDO_EEOF = -11,     /* clean end of a stream: no more grids */
	NDO_EDIVERGED = -12,/* a simulation lost stability (NaN, energy, size) */
	NDO_EPACE = -13     /* a realtime peer cannot keep the wall clock's pace */
};

/* A short, static name for a status code ("truncated input"). */
const char *ndo_strerror(int code);

/* The detail of the last failure recorded in this thread, or the
 * ndo_strerror() text when no detail was recorded.  Valid until the next
 * library call in the same thread. */
const char *ndo_errdetail(void);

/* Record a detail for the current failure and return code, so that a
 * failing function can end with `return ndo__fail(NDO_ETRUNC, "...")`.
 * The arguments may include ndo_errdetail() itself, to add context to a
 * callee's detail. */
int ndo__fail(int code, const char *fmt, ...)
	__attribute__((format(printf, 2, 3)));

/* Forget any recorded detail (called at the start of public entry points
 * that may fail). */
void ndo__clear_error(void);

#ifdef __cplusplus
}
#endif
#endif
