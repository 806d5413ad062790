/* units.h — the states of a pipeline's units (pass, chunk) during a run
 * on the threads, as rk4.c's RK4 pipeline and wave.c's steps keep them
 * (the plans, chunks.c): a thread claims a unit before running it, marks
 * it done after, and waits for a unit another thread is running on a
 * condition variable, never spinning; the waker broadcasts only when
 * someone sleeps. */
#ifndef NDO_SIM_UNITS_H
#define NDO_SIM_UNITS_H

#include <pthread.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdlib.h>

enum { NDO__UNIT_FREE, NDO__UNIT_CLAIMED, NDO__UNIT_DONE };

typedef struct ndo__units {
	_Atomic int *state;   /* each unit's: free, claimed, done (the plan sizes it) */
	_Atomic int sleepers; /* threads waiting for a unit */
	pthread_mutex_t lock;
	pthread_cond_t cond;
} ndo__units;

static inline void ndo__units_init(ndo__units *U)
{
	pthread_mutex_init(&U->lock, NULL);
	pthread_cond_init(&U->cond, NULL);
}

/* The lock and the condition destroyed, the states freed. */
static inline void ndo__units_destroy(ndo__units *U)
{
	free((void *)U->state);
	U->state = NULL;
	pthread_mutex_destroy(&U->lock);
	pthread_cond_destroy(&U->cond);
}

/* Returns once unit idx is done. */
static inline void ndo__unit_wait(ndo__units *U, int idx)
{
	if (atomic_load_explicit(&U->state[idx], memory_order_acquire) == NDO__UNIT_DONE)
		return;
	pthread_mutex_lock(&U->lock);
	atomic_fetch_add(&U->sleepers, 1);
	while (atomic_load(&U->state[idx]) != NDO__UNIT_DONE)
		pthread_cond_wait(&U->cond, &U->lock);
	atomic_fetch_sub(&U->sleepers, 1);
	pthread_mutex_unlock(&U->lock);
}

static inline void ndo__unit_done(ndo__units *U, int idx)
{
	atomic_store(&U->state[idx], NDO__UNIT_DONE);
	if (atomic_load(&U->sleepers)) {
		pthread_mutex_lock(&U->lock);
		pthread_cond_broadcast(&U->cond);
		pthread_mutex_unlock(&U->lock);
	}
}

/* Whether this thread claimed unit idx (it was free). */
static inline int ndo__unit_claim(ndo__units *U, int idx)
{
	int free_ = NDO__UNIT_FREE;
	return atomic_load_explicit(&U->state[idx], memory_order_relaxed) == NDO__UNIT_FREE &&
	       atomic_compare_exchange_strong(&U->state[idx], &free_, NDO__UNIT_CLAIMED);
}

/* A pipeline's run on the threads: thread `who` of T walks the units
 * (pass p, chunk c), unit p·C + c of np·C, and takes (claims, then runs
 * with what it reads: take) every one it claims, skipping those others
 * claimed and those marked in skip (NULL: none).  In wavefront order —
 * pass p of chunk c at c + p·L, so that any unit it reads (pass p − 1,
 * chunks ≤ c + L − 1) comes on an earlier diagonal — the even threads
 * upward from the bottom of their pair's share of the chunks, the odd ones
 * downward from its top, round the ends to the rest; or (tests: shuffled)
 * in an order shuffled by the thread and the step (seed), where a thread
 * that finds no memory for it runs none: the caller takes what is left
 * (ndo__units_rest). */
typedef void ndo__unit_take_fn(void *run, int p, int c);

static inline void ndo__units_walk(ndo__units *U, int C, int L, int np, int T, int who,
                                   const uint8_t *skip, int shuffled, uint64_t seed,
                                   ndo__unit_take_fn *take, void *run)
{
	if (shuffled) {
		const int n = np * C;
		int *ord = malloc((size_t)n * sizeof *ord);
		if (!ord)
			return;
		for (int i = 0; i < n; i++)
			ord[i] = i;
		uint64_t x = 0x9E3779B97F4A7C15u * (uint64_t)(who + 1) + seed;
		for (int i = n - 1; i > 0; i--) {
			x = x * 6364136223846793005u + 1442695040888963407u;
			int r = (int)((x >> 33) % (uint64_t)(i + 1));
			int tmp = ord[i];
			ord[i] = ord[r], ord[r] = tmp;
		}
		for (int i = 0; i < n; i++)
			if (!(skip && skip[ord[i]]) && ndo__unit_claim(U, ord[i]))
				take(run, ord[i] / C, ord[i] % C);
		free(ord);
		return;
	}
	const int pairs = (T + 1) / 2, pair = who / 2, up = who % 2 == 0;
	const int start = up ? (int)((long)C * pair / pairs) : (int)((long)C * (pair + 1) / pairs) - 1;
	for (int diag = 0; diag < C + (np - 1) * L; diag++)
		for (int p = np - 1; p >= 0; p--) {
			int c = diag - p * L;
			if (c < 0 || c >= C)
				continue;
			c = up ? (start + c) % C : (start - c + C) % C;
			if (!(skip && skip[p * C + c]) && ndo__unit_claim(U, p * C + c))
				take(run, p, c);
		}
}

/* After a shuffled walk: the units no thread took (out of memory). */
static inline void ndo__units_rest(ndo__units *U, int n, int C, ndo__unit_take_fn *take, void *run)
{
	for (int i = 0; i < n; i++)
		if (ndo__unit_claim(U, i))
			take(run, i / C, i % C);
}

#endif
