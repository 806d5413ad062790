/* link_faults.c — loss, delay, jitter and reordering injected on the
 * receiving side of a link (ndo/link.h).  tc netem is not available to
 * the tests, and injecting here also makes every run reproducible from
 * its seed. */
#include "link_private.h"
#include "ndo/status.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct held {
	double release; /* seconds */
	uint64_t order; /* arrival order, to keep equal release times stable */
	char *channel;
	uint8_t *data;
	size_t len;
} held;

typedef struct fault_link {
	ndo_link base;
	ndo_link *inner;
	ndo_faults f;
	uint64_t rng, arrivals;
	held *q;
	size_t count, cap;
	double now;
	int failed;
} fault_link;

static int fault_publish(ndo_link *base, const char *channel, const void *data, size_t len)
{
	return ndo_link_publish(((fault_link *)base)->inner, channel, data, len);
}

static void take(void *user, const char *channel, const void *data, size_t len)
{
	fault_link *l = user;
	if (ndo_rng_uniform(&l->rng) < l->f.drop) {
		l->base.injected++;
		return;
	}
	double ms = l->f.delay_ms + l->f.jitter_ms * ndo_rng_uniform(&l->rng);
	/* a reordered message waits long enough for later ones to pass it */
	if (l->f.reorder > 0 && ndo_rng_uniform(&l->rng) < l->f.reorder)
		ms += 2 * (l->f.delay_ms + l->f.jitter_ms) + 5;
	if (l->count == l->cap) {
		size_t cap = l->cap ? 2 * l->cap : 64;
		held *q = realloc(l->q, cap * sizeof *q);
		if (!q) {
			l->failed = 1;
			return;
		}
		l->q = q;
		l->cap = cap;
	}
	held *h = &l->q[l->count];
	h->channel = strdup(channel);
	h->data = malloc(len ? len : 1);
	if (!h->channel || !h->data) {
		free(h->channel);
		free(h->data);
		l->failed = 1;
		return;
	}
	memcpy(h->data, data, len);
	h->len = len;
	h->release = l->now + ms * 1e-3;
	h->order = l->arrivals++;
	l->count++;
}

static int by_release(const void *a, const void *b)
{
	const held *x = a, *y = b;
	if (x->release != y->release)
		return x->release < y->release ? -1 : 1;
	return x->order < y->order ? -1 : x->order > y->order;
}

static int fault_poll(ndo_link *base, double now, ndo_link_fn fn, void *user)
{
	fault_link *l = (fault_link *)base;
	l->now = now;
	int rc = ndo_link_poll(l->inner, now, take, l);
	l->base.overflowed = l->inner->overflowed;
	if (rc < 0)
		return rc;
	if (l->failed) {
		l->failed = 0;
		return ndo__fail(NDO_ENOMEM, "fault injection: out of memory");
	}
	if (l->count)
		qsort(l->q, l->count, sizeof *l->q, by_release);
	size_t k = 0;
	while (k < l->count && l->q[k].release <= now) {
		fn(user, l->q[k].channel, l->q[k].data, l->q[k].len);
		free(l->q[k].channel);
		free(l->q[k].data);
		k++;
	}
	if (k)
		memmove(l->q, l->q + k, (l->count - k) * sizeof *l->q);
	l->count -= k;
	return (int)k;
}

static int fault_fileno(ndo_link *base)
{
	return ndo_link_fileno(((fault_link *)base)->inner);
}

static double fault_next_due(const ndo_link *base)
{
	const fault_link *l = (const fault_link *)base;
	double due = INFINITY;
	for (size_t k = 0; k < l->count; k++)
		if (l->q[k].release < due)
			due = l->q[k].release;
	double inner = ndo_link_next_due(l->inner);
	return inner < due ? inner : due;
}

static int fault_ended(const ndo_link *base)
{
	const fault_link *l = (const fault_link *)base;
	return l->count == 0 && ndo_link_ended(l->inner);
}

static void fault_destroy(ndo_link *base)
{
	fault_link *l = (fault_link *)base;
	for (size_t k = 0; k < l->count; k++) {
		free(l->q[k].channel);
		free(l->q[k].data);
	}
	free(l->q);
	ndo_link_destroy(l->inner);
	free(l);
}

int ndo_link_faults(ndo_link *inner, const ndo_faults *f, ndo_link **out)
{
	if (!(f->drop >= 0 && f->drop <= 1) || !(f->reorder >= 0 && f->reorder <= 1) ||
	    !(f->delay_ms >= 0) || !(f->jitter_ms >= 0)) {
		ndo_link_destroy(inner);
		return ndo__fail(NDO_ERANGE, "fault injection: probabilities in 0..1, times >= 0");
	}
	fault_link *l = calloc(1, sizeof *l);
	if (!l) {
		ndo_link_destroy(inner);
		return ndo__fail(NDO_ENOMEM, "out of memory");
	}
	l->base = (ndo_link){.publish = fault_publish, .poll = fault_poll, .fileno = fault_fileno,
	                     .destroy = fault_destroy, .next_due = fault_next_due,
	                     .ended = fault_ended};
	l->inner = inner;
	l->f = *f;
	l->rng = f->seed;
	*out = &l->base;
	return 0;
}
