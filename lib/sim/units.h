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

#endif
