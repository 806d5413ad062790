/* test_lcm_facts — what Debian 12's LCM 1.3.1 really does with large
 * messages, small receive buffers and full queues (issue 6's claims),
 * measured in a private network namespace.  Prints the numbers that
 * docs/protocol.md quotes ("LCM facts, measured"). */
#include "check.h"
#include "netns.h"
#include "ndo/msg.h"

#include <arpa/inet.h>
#include <lcm/lcm.h>
#include <netinet/in.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#define GROUP "239.255.76.67"
#define PORT 7667

static void sleep_ms(int ms)
{
	struct timespec t = {ms / 1000, (long)(ms % 1000) * 1000000L};
	nanosleep(&t, NULL);
}

/* A plain UDP socket in the LCM group: sees every datagram LCM sends. */
static int sniffer(void)
{
	int s = socket(AF_INET, SOCK_DGRAM, 0);
	int one = 1, big = 16 << 20;
	setsockopt(s, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
	setsockopt(s, SOL_SOCKET, SO_RCVBUFFORCE, &big, sizeof big);
	struct sockaddr_in a = {.sin_family = AF_INET, .sin_port = htons(PORT)};
	a.sin_addr.s_addr = htonl(INADDR_ANY);
	if (bind(s, (struct sockaddr *)&a, sizeof a) != 0)
		perror("bind");
	struct ip_mreq m;
	inet_aton(GROUP, &m.imr_multiaddr);
	m.imr_interface.s_addr = htonl(INADDR_ANY);
	setsockopt(s, IPPROTO_IP, IP_ADD_MEMBERSHIP, &m, sizeof m);
	return s;
}

/* Datagrams waiting on the sniffer: count, and their sizes into sizes[]. */
static int sniff(int s, uint8_t (*keep)[70000], int *sizes, int max)
{
	int n = 0;
	static uint8_t buf[70000];
	for (;;) {
		ssize_t r = recv(s, buf, sizeof buf, MSG_DONTWAIT);
		if (r < 0)
			break;
		if (n < max) {
			sizes[n] = (int)r;
			if (keep)
				memcpy(keep[n], buf, (size_t)r);
		}
		n++;
	}
	return n;
}

typedef struct counter {
	int count;
	int ids[256];
	long bytes;
} counter;

static void on_msg(const lcm_recv_buf_t *rb, const char *ch, void *user)
{
	counter *c = user;
	if (c->count < 256)
		c->ids[c->count] = -1;
	if (c->count < 256 && rb->data_size >= 4)
		memcpy(&c->ids[c->count], rb->data, sizeof(int));
	c->count++;
	c->bytes += rb->data_size;
}

static void drain(lcm_t *l)
{
	while (lcm_handle_timeout(l, 0) > 0)
		;
}

static uint8_t *payload(size_t n, int id)
{
	uint8_t *p = calloc(n, 1);
	memcpy(p, &id, sizeof id);
	return p;
}

static lcm_t *open_lcm(const char *query)
{
	char url[256];
	snprintf(url, sizeof url, "udpm://" GROUP ":%d?ttl=0%s", PORT, query);
	return lcm_create(url);
}

/* 1. Where fragmentation starts: a message goes as one datagram while
 * channel + 1 (NUL) + payload ≤ 65,499 bytes. */
static void fragmentation_threshold(void)
{
	int s = sniffer();
	lcm_t *pub = open_lcm("");
	CHECK(pub != NULL, "LCM opens");
	if (!pub)
		return;
	const char *ch = "FRAG";
	size_t edge = NDO_LCM_SHORT_MAX - 1 - strlen(ch); /* largest one-datagram */
	CHECK(edge == ndo_msg_max_payload(ch), "ndo_msg_max_payload(\"FRAG\") = %zu, expected %zu",
	      ndo_msg_max_payload(ch), edge);
	int sizes[64];
	/* scan past the edge: the first payload that needs two datagrams */
	size_t first_frag = 0;
	for (size_t n = edge - 4; n <= edge + 64 && !first_frag; n++) {
		uint8_t *p = payload(n, 0);
		int rc = lcm_publish(pub, ch, p, (unsigned)n);
		free(p);
		CHECK(rc == 0, "lcm_publish %zu B: %d", n, rc);
		sleep_ms(5);
		int d = sniff(s, NULL, sizes, 64);
		if (d > 1)
			first_frag = n;
	}
	printf("    fact: on channel '%s' the largest one-datagram payload is %zu B "
	       "(datagram %zu B); %zu B goes in fragments\n", ch, first_frag - 1,
	       first_frag - 1 + 8 + strlen(ch) + 1, first_frag);
	CHECK(first_frag == edge + 1, "first fragmented payload %zu B, expected %zu B", first_frag,
	      edge + 1);
	lcm_destroy(pub);
	close(s);
}

/* 2. One lost or out-of-order fragment loses the message: capture LCM's
 * own fragments, replay them from another socket complete, with one
 * missing, and with two swapped. */
static void lost_fragment_loses_message(void)
{
	int s = sniffer();
	lcm_t *pub = open_lcm("");
	lcm_t *sub = open_lcm("&recv_buf_size=4194304");
	counter c = {0};
	lcm_subscribe(sub, "BIG", on_msg, &c);
	static uint8_t frag[16][70000];
	int sizes[16];
	uint8_t *p = payload(200000, 7);
	lcm_publish(pub, "BIG", p, 200000);
	free(p);
	sleep_ms(100);
	int nf = sniff(s, frag, sizes, 16);
	drain(sub);
	printf("    fact: a 200,000 B message goes out as %d fragments; received whole: %d\n",
	       nf, c.count);
	CHECK(nf >= 4 && nf <= 16, "fragments: %d", nf);
	CHECK(c.count == 1, "the intact message arrives (%d)", c.count);

	int tx = socket(AF_INET, SOCK_DGRAM, 0);
	unsigned char ttl = 0, loop = 1;
	setsockopt(tx, IPPROTO_IP, IP_MULTICAST_TTL, &ttl, sizeof ttl);
	setsockopt(tx, IPPROTO_IP, IP_MULTICAST_LOOP, &loop, sizeof loop);
	struct sockaddr_in to = {.sin_family = AF_INET, .sin_port = htons(PORT)};
	inet_aton(GROUP, &to.sin_addr);
	const char *what[3] = {"complete, in order", "fragment 1 missing", "fragments 1,2 swapped"};
	int expect[3] = {1, 0, 0};
	for (int mode = 0; mode < 3 && nf >= 4; mode++) {
		c.count = 0;
		int order[16];
		for (int k = 0; k < nf; k++)
			order[k] = k;
		if (mode == 2) {
			order[1] = 2;
			order[2] = 1;
		}
		for (int k = 0; k < nf; k++) {
			if (mode == 1 && k == 1)
				continue;
			uint8_t *f = frag[order[k]];
			uint32_t seq = htonl(1000u + (uint32_t)mode); /* a new message each time */
			memcpy(f + 4, &seq, 4);
			sendto(tx, f, (size_t)sizes[order[k]], 0, (struct sockaddr *)&to, sizeof to);
		}
		sleep_ms(100);
		drain(sub);
		sniff(s, NULL, sizes + 0, 0);
		printf("    fact: replayed fragments %s: %d message(s) delivered\n", what[mode], c.count);
		CHECK(c.count == expect[mode], "%s: %d delivered, expected %d", what[mode], c.count,
		      expect[mode]);
	}
	close(tx);
	lcm_destroy(pub);
	lcm_destroy(sub);
	close(s);
}

/* 3. The default receive buffer (net.core.rmem_default, 208 KiB) loses
 * messages bigger than it while lcm_publish returns 0; recv_buf_size
 * fixes it. */
static void receive_buffer(void)
{
	lcm_t *pub = open_lcm("");
	lcm_t *def = open_lcm("");
	lcm_t *big = open_lcm("&recv_buf_size=4194304");
	counter cd = {0}, cb = {0};
	lcm_subscribe(def, "RB", on_msg, &cd);
	lcm_subscribe(big, "RB", on_msg, &cb);
	FILE *f = fopen("/proc/sys/net/core/rmem_default", "r");
	long rmem = 0;
	if (f) {
		if (fscanf(f, "%ld", &rmem) != 1)
			rmem = 0;
		fclose(f);
	}
	printf("    fact: net.core.rmem_default = %ld B\n", rmem);
	size_t sizes[] = {60000, 150000, 300000, 1000000, 2000000};
	for (int k = 0; k < 5; k++) {
		cd.count = cb.count = 0;
		int fails = 0;
		uint8_t *p = payload(sizes[k], k);
		for (int r = 0; r < 10; r++) {
			if (lcm_publish(pub, "RB", p, (unsigned)sizes[k]) != 0)
				fails++;
			sleep_ms(30);
			drain(def);
			drain(big);
		}
		free(p);
		sleep_ms(50);
		drain(def);
		drain(big);
		printf("    fact: %7zu B x10: lcm_publish failures %d; received with the default "
		       "buffer %2d, with recv_buf_size=4 MiB %2d\n", sizes[k], fails, cd.count, cb.count);
		CHECK(fails == 0, "lcm_publish reports success (%d failures)", fails);
		CHECK(cb.count == 10, "%zu B: 4 MiB buffer receives all (%d)", sizes[k], cb.count);
		if ((long)sizes[k] > 2 * rmem)
			CHECK(cd.count < 10, "%zu B: default buffer loses some (%d of 10)", sizes[k],
			      cd.count);
	}
	lcm_destroy(pub);
	lcm_destroy(def);
	lcm_destroy(big);
}

/* 4. A full subscription queue drops the newest messages. */
static void full_queue_drops_newest(void)
{
	lcm_t *pub = open_lcm("");
	lcm_t *sub = open_lcm("&recv_buf_size=4194304");
	counter c = {0};
	lcm_subscription_t *h = lcm_subscribe(sub, "Q", on_msg, &c);
	lcm_subscription_set_queue_capacity(h, 30);
	for (int id = 0; id < 100; id++) {
		uint8_t *p = payload(100, id);
		lcm_publish(pub, "Q", p, 100);
		free(p);
	}
	sleep_ms(200);
	drain(sub);
	int first = c.count ? c.ids[0] : -1, last = c.count ? c.ids[c.count < 256 ? c.count - 1 : 255] : -1;
	printf("    fact: 100 messages into a queue of 30, handled late: %d received, ids %d..%d\n",
	       c.count, first, last);
	/* LCM 1.3.1 keeps the capacity plus the one message it is about to
	 * dispatch: the oldest 31; the 69 newest are lost */
	int consecutive = 1;
	for (int k = 0; k < c.count && k < 256; k++)
		consecutive &= c.ids[k] == k;
	CHECK((c.count == 30 || c.count == 31) && consecutive,
	      "expected the oldest 30 or 31 (ids 0..), got %d (ids %d..%d)", c.count, first, last);
	lcm_destroy(pub);
	lcm_destroy(sub);
}

/* 5. A process hears its own messages (multicast loopback). */
static void own_messages_loop_back(void)
{
	lcm_t *l = open_lcm("&recv_buf_size=1048576");
	counter c = {0};
	lcm_subscribe(l, "SELF", on_msg, &c);
	uint8_t *p = payload(64, 1);
	lcm_publish(l, "SELF", p, 64);
	free(p);
	lcm_handle_timeout(l, 500);
	printf("    fact: a publisher receives its own message: %s\n", c.count ? "yes" : "no");
	CHECK(c.count == 1, "own message heard %d times", c.count);
	lcm_destroy(l);
}

int main(void)
{
	ck_program = "test_lcm_facts";
	if (ck_private_netns() != 0) {
		printf("FAIL test_lcm_facts: cannot make a private network namespace\n");
		return 1;
	}
	RUN(fragmentation_threshold);
	RUN(lost_fragment_loses_message);
	RUN(receive_buffer);
	RUN(full_queue_drops_newest);
	RUN(own_messages_loop_back);
	return ck_failed_cases != 0;
}
