/* pool.c — threads that share the chunks of a loop (ndo/pool.h).
 *
 * A loop is a generation: the caller publishes fn, ctx and n under the
 * lock, bumps the generation and wakes the workers.  Chunks are claimed
 * from one 64-bit word holding (generation << 32 | next chunk) with a
 * compare-and-swap, so a worker that wakes late, after the caller has
 * finished the loop and started another, cannot take a chunk of the new
 * loop with the old one's function: its claim fails on the generation.
 * The caller waits only for chunks already claimed (the count of finished
 * chunks reaching n), never for a worker to wake up. */
#include "ndo/pool.h"
#include "ndo/status.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdlib.h>
#if defined(__x86_64__) || defined(__SSE2__)
#include <xmmintrin.h>
#define NDO_HAVE_MXCSR 1
#endif

unsigned ndo_fp_get(void)
{
#ifdef NDO_HAVE_MXCSR
	return _mm_getcsr();
#else
	return 0;
#endif
}

void ndo_fp_set(unsigned control)
{
#ifdef NDO_HAVE_MXCSR
	_mm_setcsr(control);
#else
	(void)control;
#endif
}

unsigned ndo_fp_flush(void)
{
	unsigned before = ndo_fp_get();
#ifdef NDO_HAVE_MXCSR
	ndo_fp_set(before | 0x8040u); /* FTZ (bit 15) and DAZ (bit 6) */
#endif
	return before;
}

struct ndo_pool {
	int threads;
	pthread_t *tid;
	pthread_mutex_t lock;
	pthread_cond_t go;    /* a new loop (or quit) for the workers */
	pthread_cond_t done;  /* the last chunk of a loop finished */
	uint32_t gen;         /* the loop's generation, under lock */
	uint64_t loops;       /* loops handed to the workers (ndo_pool_loops) */
	int quit;
	void (*fn)(void *, int);
	void *ctx;
	int n;
	unsigned fp;             /* the caller's floating-point control */
	_Atomic uint64_t claim;  /* gen << 32 | the next chunk */
	_Atomic int finished;    /* chunks of this loop finished */
};

/* Take and run chunks of generation g until none is left. */
static void run_chunks(ndo_pool *p, uint32_t g, void (*fn)(void *, int), void *ctx, int n)
{
	for (;;) {
		uint64_t c = atomic_load_explicit(&p->claim, memory_order_acquire);
		if ((uint32_t)(c >> 32) != g || (int)(uint32_t)c >= n)
			return;
		if (!atomic_compare_exchange_weak_explicit(&p->claim, &c, c + 1,
		                                           memory_order_acq_rel,
		                                           memory_order_acquire))
			continue;
		fn(ctx, (int)(uint32_t)c);
		if (atomic_fetch_add_explicit(&p->finished, 1, memory_order_acq_rel) + 1 == n) {
			pthread_mutex_lock(&p->lock);
			pthread_cond_signal(&p->done);
			pthread_mutex_unlock(&p->lock);
		}
	}
}

static void *worker(void *arg)
{
	ndo_pool *p = arg;
	uint32_t seen = 0;
	pthread_mutex_lock(&p->lock);
	for (;;) {
		while (p->gen == seen && !p->quit)
			pthread_cond_wait(&p->go, &p->lock);
		if (p->quit)
			break;
		seen = p->gen;
		void (*fn)(void *, int) = p->fn;
		void *ctx = p->ctx;
		int n = p->n;
		unsigned fp = p->fp;
		pthread_mutex_unlock(&p->lock);
		const unsigned mine = ndo_fp_get();
		ndo_fp_set(fp);
		run_chunks(p, seen, fn, ctx, n);
		ndo_fp_set(mine);
		pthread_mutex_lock(&p->lock);
	}
	pthread_mutex_unlock(&p->lock);
	return NULL;
}

int ndo_pool_create(int threads, ndo_pool **out)
{
	*out = NULL;
	if (threads < 1 || threads > NDO_POOL_MAX)
		return ndo__fail(NDO_ERANGE, "%d threads: must be 1..%d", threads, NDO_POOL_MAX);
	ndo_pool *p = calloc(1, sizeof *p);
	if (!p || !(p->tid = calloc((size_t)threads, sizeof *p->tid))) {
		free(p);
		return ndo__fail(NDO_ENOMEM, "out of memory for a thread pool");
	}
	pthread_mutex_init(&p->lock, NULL);
	pthread_cond_init(&p->go, NULL);
	pthread_cond_init(&p->done, NULL);
	p->threads = 1;
	for (int k = 1; k < threads; k++) {
		if (pthread_create(&p->tid[k], NULL, worker, p)) {
			ndo_pool_destroy(p);
			return ndo__fail(NDO_ENOMEM, "could not start thread %d of %d", k + 1, threads);
		}
		p->threads++;
	}
	*out = p;
	return NDO_OK;
}

void ndo_pool_destroy(ndo_pool *p)
{
	if (!p)
		return;
	pthread_mutex_lock(&p->lock);
	p->quit = 1;
	pthread_cond_broadcast(&p->go);
	pthread_mutex_unlock(&p->lock);
	for (int k = 1; k < p->threads; k++)
		pthread_join(p->tid[k], NULL);
	pthread_cond_destroy(&p->go);
	pthread_cond_destroy(&p->done);
	pthread_mutex_destroy(&p->lock);
	free(p->tid);
	free(p);
}

int ndo_pool_threads(const ndo_pool *p)
{
	return p ? p->threads : 1;
}

void ndo_pool_run(ndo_pool *p, int n, void (*fn)(void *ctx, int k), void *ctx)
{
	if (n <= 0)
		return;
	if (!p || p->threads == 1 || n == 1) {
		for (int k = 0; k < n; k++)
			fn(ctx, k);
		return;
	}
	pthread_mutex_lock(&p->lock);
	if (++p->gen == 0) /* 0 is a worker's "seen nothing yet" */
		p->gen = 1;
	p->loops++;
	uint32_t g = p->gen;
	p->fn = fn, p->ctx = ctx, p->n = n;
	p->fp = ndo_fp_get();
	atomic_store_explicit(&p->finished, 0, memory_order_relaxed);
	atomic_store_explicit(&p->claim, (uint64_t)g << 32, memory_order_release);
	pthread_cond_broadcast(&p->go);
	pthread_mutex_unlock(&p->lock);
	run_chunks(p, g, fn, ctx, n);
	if (atomic_load_explicit(&p->finished, memory_order_acquire) < n) {
		pthread_mutex_lock(&p->lock);
		while (atomic_load_explicit(&p->finished, memory_order_acquire) < n)
			pthread_cond_wait(&p->done, &p->lock);
		pthread_mutex_unlock(&p->lock);
	}
}

uint64_t ndo_pool_loops(const ndo_pool *p)
{
	return p ? p->loops : 0;
}
