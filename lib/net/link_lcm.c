/* link_lcm.c — a link over LCM (ndo/link.h).
 *
 * Messages on "PREFIX_*" are handed up as raw bytes; decoding is ours
 * (ndo/msg.h), so a malformed message never reaches LCM's generated
 * decoders unchecked.  Sending is LCM's (lcm_publish).
 *
 * Receiving, for a udpm:// URL, is direct: LCM 1.3's UDP multicast
 * provider reads the socket in a thread of its own and wakes the caller
 * through a pipe, two thread wake-ups and a copy a message — at levels 5–6
 * a peer's whole step (docs/peers.md).  ndo never sends a message LCM
 * fragments (ndo_net_publish refuses more than one datagram), so the link
 * reads the multicast group itself, on the thread that polls: a socket
 * bound to the group's port (SO_REUSEADDR, as LCM's, so any number of
 * processes share it) and joined to the group, drained without blocking.
 * Each datagram is LCM's small-message form (the UDP multicast protocol
 * of LCM's documentation): "LC02" (big-endian 0x4c433032), a 32-bit
 * sequence number, the channel and a NUL, the payload.  Fragments of
 * larger messages ("LC03", from other LCM programs on the group) and
 * other channels are skipped, as a subscription to "PREFIX_.*" would not
 * see them either (a fragmented ndo message cannot exist).
 *
 * The socket's buffer is then the only queue while the thread steps: a
 * neighbour's level-8 frame (4.7 MB) overflowed 4 MiB (net.core.rmem_max
 * here) and lost 22-37 datagrams a run (commit 2023fef reverted this
 * receiver for it), so the link asks for DIRECT_BUF past rmem_max
 * (SO_RCVBUFFORCE, CAP_NET_ADMIN: root, as the peers' runs in a private
 * network namespace are) and receives directly only when it got it.
 * Otherwise, and for other URLs (memq://, file://), LCM's subscription,
 * drained with lcm_handle_timeout(lcm, 0) until nothing is pending. */
#include "link_private.h"
#include "ndo/status.h"

#include <arpa/inet.h>
#include <errno.h>
#include <lcm/lcm.h>
#include <netinet/in.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

/* DIRECT_BUF: the direct socket's buffer, the only queue while the thread
 * steps; a level-8 neighbour's frame is 4.7 MB (at 4 MiB, 22-37 datagrams
 * a run were lost) */
enum { LC02 = 0x4c433032, DGRAM_MAX = 65536, DIRECT_BUF = 64 << 20 };

/* POLL_BUDGET: the longest a poll reads (seconds).  A poll once read for
 * as long as datagrams came: 8 peers at level 9 on 2 busy cores, each
 * peer's whole region and the restarts' checkpoints arriving faster than
 * a starved peer took them, one poll read 9,173 datagrams in 15 s, and the
 * owner dropped the peer for its silence meanwhile (its heartbeat goes out
 * between polls), which restarted everyone and sent more (docs/peers.md,
 * "Joins, leaves").  A twentieth of a second is a quarter of the default
 * heartbeat. */
#define POLL_BUDGET 0.05

typedef struct lcm_link {
	ndo_link base;
	lcm_t *lcm;
	lcm_subscription_t *sub;
	ndo_link_fn fn; /* set for the duration of a poll */
	void *user;
	int handled;
	int fd;                 /* direct: the group's socket, else −1 */
	char prefix[72];        /* direct: "PREFIX_" */
	size_t nprefix;
	unsigned char *buf;     /* direct: one datagram */
	uint32_t drops;         /* direct: the socket's SO_RXQ_OVFL count, last seen */
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

/* SO_RXQ_OVFL: a datagram carries the socket's count of datagrams the
 * kernel dropped for a full buffer (32 bits, wrapping) when it was queued;
 * the link's count grows by what that count grew since the last one. */
static void overflow_seen(lcm_link *l, struct msghdr *mh)
{
	for (struct cmsghdr *c = CMSG_FIRSTHDR(mh); c; c = CMSG_NXTHDR(mh, c))
		if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SO_RXQ_OVFL &&
		    c->cmsg_len >= CMSG_LEN(sizeof(uint32_t))) {
			uint32_t drops;
			memcpy(&drops, CMSG_DATA(c), sizeof drops);
			l->base.overflowed += (uint32_t)(drops - l->drops);
			l->drops = drops;
		}
}

/* Direct: the datagrams pending on the socket, without blocking, for at
 * most POLL_BUDGET seconds: what is left waits in the socket for the next
 * poll, which a peer makes as soon as it has handled these and sent what
 * is due. */
static int direct_poll(lcm_link *l, ndo_link_fn fn, void *user)
{
	int handled = 0;
	const double t0 = ndo_now();
	for (int k = 0; k < 100000; k++) {
		if (k % 16 == 15 && ndo_now() - t0 > POLL_BUDGET)
			break;
		union {
			struct cmsghdr h;
			char b[CMSG_SPACE(sizeof(uint32_t))];
		} ctl;
		struct iovec io = {l->buf, DGRAM_MAX};
		struct msghdr mh = {.msg_iov = &io, .msg_iovlen = 1, .msg_control = &ctl,
		                    .msg_controllen = sizeof ctl};
		ssize_t n = recvmsg(l->fd, &mh, MSG_DONTWAIT);
		if (n >= 0)
			overflow_seen(l, &mh);
		if (n < 0) {
			if (errno == EINTR)
				continue;
			if (errno == EAGAIN || errno == EWOULDBLOCK)
				break;
			return ndo__fail(NDO_EIO, "LCM: receiving failed: %s", strerror(errno));
		}
		const unsigned char *b = l->buf;
		if (n < 9 || ((uint32_t)b[0] << 24 | (uint32_t)b[1] << 16 | (uint32_t)b[2] << 8 | b[3]) != LC02)
			continue; /* a fragment, or not LCM */
		const char *ch = (const char *)b + 8;
		const char *end = memchr(ch, 0, (size_t)n - 8);
		if (!end || (size_t)(end - ch) < l->nprefix || memcmp(ch, l->prefix, l->nprefix) != 0)
			continue;
		const unsigned char *data = (const unsigned char *)end + 1;
		handled++;
		fn(user, ch, data, (size_t)(b + n - data));
	}
	return handled;
}

static int lcm_poll_(ndo_link *base, double now, ndo_link_fn fn, void *user)
{
	lcm_link *l = (lcm_link *)base;
	(void)now;
	if (l->fd >= 0)
		return direct_poll(l, fn, user);
	l->fn = fn;
	l->user = user;
	l->handled = 0;
	const double t0 = ndo_now();
	for (int k = 0; k < 100000; k++) {
		if (k % 16 == 15 && ndo_now() - t0 > POLL_BUDGET)
			break;
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
	lcm_link *l = (lcm_link *)base;
	return l->fd >= 0 ? l->fd : lcm_get_fileno(l->lcm);
}

static void lcm_destroy_(ndo_link *base)
{
	lcm_link *l = (lcm_link *)base;
	if (l->sub)
		lcm_unsubscribe(l->lcm, l->sub);
	if (l->lcm)
		lcm_destroy(l->lcm);
	if (l->fd >= 0)
		close(l->fd);
	free(l->buf);
	free(l);
}

/* A udpm:// URL's group, port and receive buffer; 0 when the URL is one
 * (options other than ttl and recv_buf_size: not, LCM keeps it). */
static int udpm_parse(const char *url, struct in_addr *group, int *port, int *rcvbuf)
{
	char host[64];
	const char *p = url + 7, *colon;
	if (strncmp(url, "udpm://", 7) || !(colon = strchr(p, ':')) || colon - p >= (long)sizeof host)
		return -1;
	memcpy(host, p, (size_t)(colon - p));
	host[colon - p] = 0;
	char *e;
	long pt = strtol(colon + 1, &e, 10);
	if (e == colon + 1 || pt <= 0 || pt > 65535 || (*e && *e != '?') || inet_pton(AF_INET, host, group) != 1 ||
	    !IN_MULTICAST(ntohl(group->s_addr)))
		return -1;
	*port = (int)pt;
	*rcvbuf = 0;
	while (*e) { /* ?a=b&c=d */
		const char *k = e + 1, *v = strchr(k, '=');
		if (!v)
			return -1;
		char *next;
		long val = strtol(v + 1, &next, 10);
		if (next == v + 1 || (*next && *next != '&'))
			return -1;
		if ((size_t)(v - k) == 13 && !strncmp(k, "recv_buf_size", 13))
			*rcvbuf = val > 0 && val < (1L << 30) ? (int)val : 0;
		else if ((size_t)(v - k) != 3 || strncmp(k, "ttl", 3))
			return -1;
		e = next;
	}
	return 0;
}

/* The direct receiving socket (above); −1 with errno, or −2 when its
 * buffer cannot be made DIRECT_BUF (LCM's subscription then). */
static int udpm_socket(struct in_addr group, int port, int rcvbuf)
{
	int fd = socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
	if (fd < 0)
		return -1;
	int one = 1, want = rcvbuf > DIRECT_BUF ? rcvbuf : DIRECT_BUF, got = 0;
	socklen_t len = sizeof got;
	/* SO_RCVBUFFORCE passes net.core.rmem_max (CAP_NET_ADMIN); the kernel
	 * reports twice what it keeps for data */
	if (setsockopt(fd, SOL_SOCKET, SO_RCVBUFFORCE, &want, sizeof want))
		(void)setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &want, sizeof want);
	if (getsockopt(fd, SOL_SOCKET, SO_RCVBUF, &got, &len) || got / 2 < DIRECT_BUF) {
		close(fd);
		return -2;
	}
	struct sockaddr_in a = {.sin_family = AF_INET, .sin_port = htons((uint16_t)port),
	                        .sin_addr.s_addr = htonl(INADDR_ANY)};
	struct ip_mreq mr = {.imr_multiaddr = group, .imr_interface.s_addr = htonl(INADDR_ANY)};
	/* the kernel's count of datagrams it dropped for a full buffer, with
	 * each datagram (ndo_link_overflows); the count starts at 0 */
	if (setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one) ||
	    setsockopt(fd, SOL_SOCKET, SO_RXQ_OVFL, &one, sizeof one) ||
	    bind(fd, (struct sockaddr *)&a, sizeof a) ||
	    setsockopt(fd, IPPROTO_IP, IP_ADD_MEMBERSHIP, &mr, sizeof mr)) {
		int err = errno;
		close(fd);
		errno = err;
		return -1;
	}
	return fd;
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
	l->base = (ndo_link){.publish = lcm_publish_, .poll = lcm_poll_, .fileno = lcm_fileno_,
	                     .destroy = lcm_destroy_};
	l->fd = -1;
	l->lcm = lcm_create(full);
	if (!l->lcm) {
		free(l);
		return ndo__fail(NDO_EIO, "cannot open LCM at %s (no multicast route? try: ip "
		                 "route add 224.0.0.0/4 dev lo)", full);
	}
	struct in_addr group;
	int port, rcvbuf;
	if (udpm_parse(full, &group, &port, &rcvbuf) == 0) {
		snprintf(l->prefix, sizeof l->prefix, "%s_", prefix);
		l->nprefix = strlen(l->prefix);
		if (!(l->buf = malloc(DGRAM_MAX))) {
			lcm_destroy_(&l->base);
			return ndo__fail(NDO_ENOMEM, "out of memory");
		}
		l->fd = udpm_socket(group, port, rcvbuf);
		if (l->fd == -2) { /* not the buffer it needs: LCM's thread drains */
			l->fd = -1;
			free(l->buf);
			l->buf = NULL;
		} else if (l->fd < 0) {
			int err = errno;
			lcm_destroy_(&l->base);
			return ndo__fail(NDO_EIO, "cannot receive LCM at %s: %s (no multicast route? try: "
			                 "ip route add 224.0.0.0/4 dev lo)", full, strerror(err));
		} else {
			*out = &l->base;
			return 0;
		}
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
