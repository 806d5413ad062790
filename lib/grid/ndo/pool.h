/* ndo/pool.h — a small pool of threads that share the chunks of one loop.
 *
 * The calling thread and the pool's workers take the chunks 0..n−1 of a
 * loop in whatever order they reach them; each chunk runs exactly once.
 * A loop whose chunks are fixed by the data (not by the thread count) and
 * whose partial results are combined in chunk order gives the same bits
 * with any number of threads.
 *
 * Nobody spins: a worker with nothing to do sleeps on a condition
 * variable, and the caller never waits for a worker that has not started a
 * chunk — on a loaded machine, where a worker may not run for a while, the
 * caller takes every chunk itself and is no slower than alone. */
#ifndef NDO_POOL_H
#define NDO_POOL_H

#include <stdint.h>

typedef struct ndo_pool ndo_pool;

/* The most threads a pool takes (the caller and 255 workers). */
#define NDO_POOL_MAX 256

/* A pool of `threads` threads in all, the caller included (threads − 1
 * workers), 1..NDO_POOL_MAX.  NDO_ERANGE for a count outside, NDO_ENOMEM
 * when a thread cannot be started.  One thread: no workers, loops run in
 * the caller. */
int ndo_pool_create(int threads, ndo_pool **out);

/* Stops and joins the workers.  Accepts NULL. */
void ndo_pool_destroy(ndo_pool *p);

/* The thread count the pool was created with (1 for NULL). */
int ndo_pool_threads(const ndo_pool *p);

/* fn(ctx, k) for every k in 0..n−1, once each, on the caller and the
 * workers; returns when all have returned.  p may be NULL (the caller runs
 * them in order).  A worker runs the chunks in the caller's floating-point
 * control (ndo_fp_get: subnormals flushed or not, the rounding), so a
 * chunk gives the same bits whichever thread takes it.  Not reentrant: fn
 * must not call ndo_pool_run on the same pool, and one thread at a time
 * runs loops on a pool. */
void ndo_pool_run(ndo_pool *p, int n, void (*fn)(void *ctx, int k), void *ctx);

/* The loops ndo_pool_run has handed to the workers so far (not those it
 * ran in the caller alone: one thread, NULL, or one chunk); 0 for NULL.
 * For tests: which code ran on the threads. */
uint64_t ndo_pool_loops(const ndo_pool *p);

/* The calling thread's floating-point control (x86-64: MXCSR; elsewhere
 * 0 and nothing is changed), set back with ndo_fp_set. */
unsigned ndo_fp_get(void);
void ndo_fp_set(unsigned control);
/* Subnormal numbers flushed to zero, as results and as operands (x86-64:
 * MXCSR's FTZ and DAZ), in the calling thread from now on; returns the
 * control before, for ndo_fp_set.  An arithmetic operation on a subnormal
 * costs a hundred cycles or more on x86: a simulation started from rest
 * carries a front of them outwards from the force (lib/sim flushes them
 * while it computes: docs/simulate-peer.md, "Speed"). */
unsigned ndo_fp_flush(void);

#endif
