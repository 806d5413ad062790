/* link.c — the link interface, LCM URLs, the clock and the RNG
 * (ndo/link.h). */
#include "link_private.h"
#include "ndo/status.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

int ndo_link_publish(ndo_link *l, const char *channel, const void *data, size_t len)
{
	return l->publish(l, channel, data, len);
}

int ndo_link_poll(ndo_link *l, double now, ndo_link_fn fn, void *user)
{
	return l->poll(l, now, fn, user);
}

int ndo_link_fileno(ndo_link *l)
{
	return l->fileno ? l->fileno(l) : -1;
}

void ndo_link_destroy(ndo_link *l)
{
	if (l)
		l->destroy(l);
}

double ndo_link_next_due(const ndo_link *l)
{
	return l && l->next_due ? l->next_due(l) : INFINITY;
}

int ndo_link_ended(const ndo_link *l)
{
	return l && l->ended ? l->ended(l) : 0;
}

const char *ndo_link_note(const ndo_link *l)
{
	return l ? l->note : "";
}

uint64_t ndo_link_injected_drops(const ndo_link *l)
{
	return l ? l->injected : 0;
}

uint64_t ndo_link_overflows(const ndo_link *l)
{
	return l ? l->overflowed : 0;
}

int ndo_lcm_url(const char *url, int recv_buf, char *out, size_t size)
{
	if (!url || !*url)
		url = getenv("LCM_DEFAULT_URL");
	if (!url || !*url)
		url = NDO_LCM_DEFAULT_URL;
	int n;
	if (recv_buf > 0 && strncmp(url, "udpm://", 7) == 0 && !strstr(url, "recv_buf_size="))
		n = snprintf(out, size, "%s%crecv_buf_size=%d", url, strchr(url, '?') ? '&' : '?',
		             recv_buf);
	else
		n = snprintf(out, size, "%s", url);
	if (n < 0 || (size_t)n >= size)
		return ndo__fail(NDO_ERANGE, "LCM URL too long: %s", url);
	return 0;
}

double ndo_now(void)
{
	struct timespec t;
	clock_gettime(CLOCK_MONOTONIC, &t);
	return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

uint64_t ndo_rng_next(uint64_t *s)
{
	uint64_t z = (*s += 0x9e3779b97f4a7c15ull);
	z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
	z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
	return z ^ (z >> 31);
}

double ndo_rng_uniform(uint64_t *s)
{
	return (double)(ndo_rng_next(s) >> 11) * 0x1.0p-53;
}
