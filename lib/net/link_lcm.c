/* link_lcm.c — a link over LCM (ndo/link.h).
 *
 * One subscription to "PREFIX_.*" hands raw bytes up; decoding is ours
 * (ndo/msg.h), so a malformed message never reaches LCM's generated
 * decoders unchecked.  Draining: lcm_handle_timeout(lcm, 0) until nothing
 * is pending, from the one thread that owns the link. */
#include "link_private.h"
#include "ndo/status.h"

#include <errno.h>
#include <lcm/lcm.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct lcm_link {
	ndo_link base;
	lcm_t *lcm;
	lcm_subscription_t *sub;
	ndo_link_fn fn; /* set for the duration of a poll */
	void *user;
	int handled;
} lcm_link;

static void on_message(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
	lcm_link *l = user;
	l->handled++;
	if (l->fn)
		l->fn(l->user, channel, rbuf->data, (size_t)rbuf->data_size);
}

static int lcm_publish_(ndo_link *base, const char *channel, const void *data, size_t len)
{
	lcm_link *l = (lcm_link *)base;
	if (len > (1u << 30))
		return ndo__fail(NDO_EINVAL, "publish %s: %zu bytes is too large", channel, len);
	if (lcm_publish(l->lcm, channel, data, (unsigned)len) != 0)
		return ndo__fail(NDO_EIO, "publish %s: LCM refused (%s)", channel, strerror(errno));
	return 0;
}

static int lcm_poll_(ndo_link *base, double now, ndo_link_fn fn, void *user)
{
	lcm_link *l = (lcm_link *)base;
	(void)now;
	l->fn = fn;
	l->user = user;
	l->handled = 0;
	/* bounded: a flood of messages cannot keep a step from ending */
	for (int k = 0; k < 100000; k++) {
		int r = lcm_handle_timeout(l->lcm, 0);
		if (r < 0) {
			l->fn = NULL;
			return ndo__fail(NDO_EIO, "LCM: receiving failed");
		}
		if (r == 0)
			break;
	}
	l->fn = NULL;
	return l->handled;
}

static int lcm_fileno_(ndo_link *base)
{
	return lcm_get_fileno(((lcm_link *)base)->lcm);
}

static void lcm_destroy_(ndo_link *base)
{
	lcm_link *l = (lcm_link *)base;
	if (l->sub)
		lcm_unsubscribe(l->lcm, l->sub);
	if (l->lcm)
		lcm_destroy(l->lcm);
	free(l);
}

int ndo_link_open_lcm(const char *url, int recv_buf, const char *prefix, int queue,
                      ndo_link **out)
{
	ndo__clear_error();
	char full[1024], pattern[256];
	int rc = ndo_lcm_url(url, recv_buf, full, sizeof full);
	if (rc)
		return rc;
	if (!prefix || !*prefix || strlen(prefix) > 64 || strpbrk(prefix, ".*?[]()|\\^$+{}"))
		return ndo__fail(NDO_EINVAL, "channel prefix '%s': 1..64 characters, no regex "
		                 "operators", prefix ? prefix : "");
	snprintf(pattern, sizeof pattern, "%s_.*", prefix);
	lcm_link *l = calloc(1, sizeof *l);
	if (!l)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	l->base = (ndo_link){lcm_publish_, lcm_poll_, lcm_fileno_, lcm_destroy_, 0, NULL, NULL, ""};
	l->lcm = lcm_create(full);
	if (!l->lcm) {
		free(l);
		return ndo__fail(NDO_EIO, "cannot open LCM at %s (no multicast route? try: ip "
		                 "route add 224.0.0.0/4 dev lo)", full);
	}
	l->sub = lcm_subscribe(l->lcm, pattern, on_message, l);
	if (!l->sub) {
		lcm_destroy_(&l->base);
		return ndo__fail(NDO_EIO, "cannot subscribe to %s", pattern);
	}
	lcm_subscription_set_queue_capacity(l->sub, queue > 0 ? queue : 10000);
	*out = &l->base;
	return 0;
}
