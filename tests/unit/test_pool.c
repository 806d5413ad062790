/* test_pool — the thread pool (ndo/pool.h): every chunk of every loop runs
 * exactly once, on any thread count (more threads than processors too),
 * loop after loop, with workers that wake late, in the caller's floating-
 * point control; a loop on no pool runs in order; bad counts are refused. */
#include "check.h"
#include "ndo/machine.h"
#include "ndo/pool.h"
#include "ndo/status.h"

#include <stdatomic.h>
#include <stdlib.h>
#include <time.h>

typedef struct loop {
	_Atomic int *hits;
	int gen;
	int slow;
} loop;

static void hit(void *arg, int k)
{
	loop *l = arg;
	if (l->slow && k % 7 == 0) { /* a chunk that takes a while */
		struct timespec t = {0, 20000};
		nanosleep(&t, NULL);
	}
	atomic_fetch_add(&l->hits[k], l->gen);
}

static void every_chunk_runs_once(void)
{
	enum { N = 97, LOOPS = 3000 };
	for (int threads = 1; threads <= 5; threads += 2) {
		ndo_pool *p;
		CHECK(ndo_pool_create(threads, &p) == NDO_OK, "%d threads: %s", threads, ndo_errdetail());
		CHECK(ndo_pool_threads(p) == threads, "threads %d, expected %d", ndo_pool_threads(p),
		      threads);
		_Atomic int *hits = calloc(N, sizeof *hits);
		long bad = 0;
		for (int g = 1; g <= LOOPS; g++) {
			/* a fresh weight per loop: a chunk run with an old loop's
			 * arguments, or twice, or not at all, shows in its sum */
			loop l = {hits, g, g % 50 == 0};
			int n = 1 + g % N;
			for (int k = 0; k < N; k++)
				atomic_store(&hits[k], 0);
			ndo_pool_run(p, n, hit, &l);
			for (int k = 0; k < N; k++)
				bad += atomic_load(&hits[k]) != (k < n ? g : 0);
		}
		CHECK(bad == 0, "%d threads: %ld chunks run the wrong number of times", threads, bad);
		free(hits);
		ndo_pool_destroy(p);
	}
}

/* Each chunk's floating-point control as its thread saw it. */
static void control(void *arg, int k)
{
	unsigned *seen_fp = arg;
	if (k % 5 == 0) { /* slow, so that the workers take chunks too */
		struct timespec t = {0, 50000};
		nanosleep(&t, NULL);
	}
	seen_fp[k] = ndo_fp_get();
}

/* The workers run a loop in the caller's floating-point control (with
 * subnormals flushed or not: lib/sim's steps flush them and must give
 * the same bits on any thread count), and keep their own between loops;
 * ndo_fp_flush returns the control before it and ndo_fp_set restores it. */
static void workers_take_the_callers_control(void)
{
	enum { N = 64 };
	ndo_pool *p;
	CHECK(ndo_pool_create(3, &p) == NDO_OK, "3 threads: %s", ndo_errdetail());
	unsigned seen_fp[N];
	const unsigned plain = ndo_fp_get();
	for (int round = 0; round < 4; round++) {
		const int flush = round % 2 == 0;
		unsigned before = flush ? ndo_fp_flush() : ndo_fp_get();
		CHECK(before == plain, "round %d: the control before, %#x, is not the plain %#x", round,
		      before, plain);
		const unsigned want = ndo_fp_get();
		ndo_pool_run(p, N, control, seen_fp);
		int off = 0;
		for (int k = 0; k < N; k++)
			off += seen_fp[k] != want;
		CHECK(off == 0, "round %d (%s): %d of %d chunks ran in another control than %#x", round,
		      flush ? "flushed" : "plain", off, N, want);
		ndo_fp_set(before);
		CHECK(ndo_fp_get() == plain, "round %d: the control %#x after ndo_fp_set, not %#x", round,
		      ndo_fp_get(), plain);
	}
#if defined(__x86_64__)
	unsigned before = ndo_fp_flush();
	CHECK((ndo_fp_get() & 0x8040u) == 0x8040u && (before & 0x8040u) == 0,
	      "x86-64: FTZ and DAZ on after ndo_fp_flush (%#x, before %#x)", ndo_fp_get(), before);
	ndo_fp_set(before);
#endif
	ndo_pool_destroy(p);
}

static int order[8], seen;
static void record(void *arg, int k)
{
	(void)arg;
	order[seen++] = k;
}

static void no_pool_runs_in_order(void)
{
	seen = 0;
	ndo_pool_run(NULL, 5, record, NULL);
	CHECK(seen == 5, "%d chunks run, expected 5", seen);
	for (int k = 0; k < seen; k++)
		CHECK(order[k] == k, "chunk %d ran %d-th", order[k], k);
	ndo_pool_run(NULL, 0, record, NULL);
	CHECK(seen == 5, "an empty loop ran a chunk");
	CHECK(ndo_pool_threads(NULL) == 1, "no pool: %d threads", ndo_pool_threads(NULL));
	ndo_pool_destroy(NULL);
}

static void bad_counts_are_refused(void)
{
	ndo_pool *p = (ndo_pool *)1;
	CHECK(ndo_pool_create(0, &p) == NDO_ERANGE && !p, "0 threads accepted");
	CHECK(ndo_pool_create(NDO_POOL_MAX + 1, &p) == NDO_ERANGE && !p, "%d threads accepted",
	      NDO_POOL_MAX + 1);
	CHECK(ndo_cpu_count() >= 1, "%d processors", ndo_cpu_count());
}

int main(void)
{
	ck_program = "test_pool";
	RUN(every_chunk_runs_once);
	RUN(no_pool_runs_in_order);
	RUN(workers_take_the_callers_control);
	RUN(bad_counts_are_refused);
	return ck_failed_cases != 0;
}
