/* test_pool — the thread pool (ndo/pool.h): every chunk of every loop runs
 * exactly once, on any thread count (more threads than processors too),
 * loop after loop, with workers that wake late; a loop on no pool runs in
 * order; bad counts are refused. */
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
	RUN(bad_counts_are_refused);
	return ck_failed_cases != 0;
}
