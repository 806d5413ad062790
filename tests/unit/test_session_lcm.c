/* test_session_lcm — 2 to 4 peers as separate processes over real LCM
 * multicast, in a private network namespace (netns.h): each writes a
 * known value into the nodes it owns and publishes its region as tiles;
 * every peer must reassemble the whole grid with each node's value coming
 * from that node's owner; when the owner quits, the others end cleanly. */
#include "check.h"
#include "netns.h"
#include "ndo/link.h"
#include "ndo/ndo.h"
#include "ndo/session.h"

#include <lcm/lcm.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#define LEVEL 5

static void sleep_ms(int ms)
{
	struct timespec t = {0, ms * 1000000L};
	nanosleep(&t, NULL);
}

/* Nodes whose (x, y) is not (node/1000, owner id % 1000). */
static size_t misassembled(ndo_grid *g)
{
	const double *x = ndo_grid_f64(g, NDO_CH_POSITION, 3);
	const int32_t *own = ndo_grid_find(g, NDO_CH_OWNER)->data;
	size_t bad = 0;
	for (size_t k = 0; k < g->count; k++) {
		size_t c = ndo_canonical(LEVEL, (int)(k % (size_t)g->w), (int)(k / (size_t)g->w));
		bad += x[3 * c] != (double)c * 1e-3 || x[3 * c + 1] != (double)(own[c] % 1000);
	}
	return bad;
}

/* One peer's life; returns its exit status (0 ok). */
static int peer(int index, int32_t poi, double run_for)
{
	ndo_link *l;
	ndo_net *n;
	ndo_session *s;
	if (ndo_link_open_lcm(NULL, NDO_RECV_BUF_DEFAULT, "NT", 0, &l) ||
	    ndo_net_create(l, "NT", 100 + index, &n))
		return 10;
	ndo_grid *g = NULL;
	if (index == 0)
		ndo_grid_create(LEVEL, &g);
	ndo_session_opts o = {.role = index == 0 ? NDO_ROLE_OWNER : NDO_ROLE_JOINER,
	                      .poi = poi, .self_id = 100 + index, .timeout = 2.0};
	if (ndo_session_create(&o, n, g, &s))
		return 11;
	double t0 = ndo_now(), stable_since = t0, ready_at = -1;
	size_t bad = (size_t)-1;
	int checks = 0, ended = 0;
	char msg[300] = "";
	int64_t step = 0;
	while (ndo_now() - t0 < (index == 0 ? run_for : run_for + 4)) {
		double now = ndo_now();
		if (ndo_session_update(s, now))
			return 12;
		ndo_event e;
		while (ndo_session_event(s, &e)) {
			if (e.type == NDO_EV_PARTITION)
				stable_since = now;
			if (e.type == NDO_EV_READY)
				ready_at = now - t0;
			if (e.type == NDO_EV_ENDED) {
				ended = 1;
				snprintf(msg, sizeof msg, "%s", e.message);
			}
		}
		if (ended)
			break;
		ndo_grid *gr = ndo_session_grid(s);
		if (ndo_session_ready(s)) {
			if (now - stable_since > 0.7) { /* a settled partition: check */
				bad = misassembled(gr);
				checks++;
			}
			double *x = ndo_grid_f64(gr, NDO_CH_POSITION, 3);
			const int32_t *own = ndo_grid_find(gr, NDO_CH_OWNER)->data;
			for (size_t k = 0; k < gr->count; k++)
				if (own[k] == ndo_session_self(s)) {
					size_t c = ndo_canonical(LEVEL, (int)(k % (size_t)gr->w),
					                         (int)(k / (size_t)gr->w));
					x[3 * k] = (double)c * 1e-3;
					x[3 * k + 1] = (double)(ndo_session_self(s) % 1000);
					x[3 * k + 2] = (double)step;
				}
			ndo_session_publish(s, step, 0.01 * (double)step);
			step++;
		}
		sleep_ms(10);
	}
	char stats[512];
	ndo_net_stats_format(ndo_session_net(s), stats, sizeof stats);
	size_t owned = ndo_session_owned_nodes(s);
	int np = 0;
	ndo_session_cells(s, &np, NULL);
	printf("    peer %d: ready at %.2f s, %d simulating, owns %zu nodes, %d checks, last %zu "
	       "misassembled; %s%s%s\n", index, ready_at, np, owned, checks, bad, stats,
	       ended ? "; ended: " : "", msg);
	fflush(stdout);
	ndo_session_destroy(s, "test over");
	if (checks == 0 || bad != 0)
		return 1;
	if (index > 0 && (!ended || !strstr(msg, "owner quit")))
		return 2;
	return 0;
}

static void run_peers(int npeers, const int32_t *pois)
{
	pid_t pid[4];
	for (int i = 0; i < npeers; i++) {
		pid[i] = fork();
		if (pid[i] == 0) {
			if (i > 0)
				sleep_ms(300 * i); /* late joiners */
			_exit(peer(i, pois[i], 4.0));
		}
	}
	for (int i = 0; i < npeers; i++) {
		int st = 0;
		waitpid(pid[i], &st, 0);
		CHECK(WIFEXITED(st) && WEXITSTATUS(st) == 0, "%d peers: peer %d exit %d", npeers, i,
		      WIFEXITED(st) ? WEXITSTATUS(st) : -1);
	}
}

static void two_peers(void) { run_peers(2, (int32_t[]){-1, 3000}); }
static void four_peers_one_observer(void) { run_peers(4, (int32_t[]){10, 1500, 3500, -1}); }

/* A flood's datagrams, each taking its reader 2 ms. */
static void slow_reader(void *user, const char *channel, const void *data, size_t len)
{
	(void)channel, (void)data, (void)len;
	++*(int *)user;
	sleep_ms(2);
}

/* A poll reads for at most a twentieth of a second (link_lcm.c,
 * POLL_BUDGET), however fast datagrams come: once it read for as long as
 * they came, and a peer starved of the CPU at level 9, among 8 on 2
 * cores, read for 15 s without a heartbeat and was dropped.  A sender
 * publishes a datagram every 0.5 ms for 2 s to a reader that takes 2 ms
 * each: a poll that read until the socket was empty would take 8 s.
 * Nothing is lost by stopping: later polls read the rest. */
static void a_flood_does_not_hold_a_poll(void)
{
	ndo_link *l;
	CHECK(ndo_link_open_lcm(NULL, NDO_RECV_BUF_DEFAULT, "NDO", 0, &l) == 0, "open");
	if (!l)
		return;
	enum { SENT = 4000 };
	fflush(NULL);
	pid_t pid = fork();
	if (pid == 0) {
		lcm_t *lcm = lcm_create(NULL);
		char msg[64] = "flood";
		for (int k = 0; lcm && k < SENT; k++) {
			lcm_publish(lcm, "NDO_HEARTBEAT", msg, sizeof msg);
			struct timespec t = {0, 500000L};
			nanosleep(&t, NULL);
		}
		if (lcm)
			lcm_destroy(lcm);
		_exit(lcm ? 0 : 1);
	}
	int got = 0;
	sleep_ms(100); /* the flood under way */
	double t0 = ndo_now();
	int n = ndo_link_poll(l, 0, slow_reader, &got);
	double took = ndo_now() - t0;
	printf("    one poll in the flood: %d datagrams in %.3f s\n", n, took);
	CHECK(n > 0 && took < 1.0, "a poll took %.3f s (%d datagrams) while the flood went on", took, n);
	int status = 0;
	waitpid(pid, &status, 0);
	CHECK(WIFEXITED(status) && WEXITSTATUS(status) == 0, "the sender failed");
	for (double end = ndo_now() + 60; got < SENT && ndo_now() < end;)
		if (ndo_link_poll(l, 0, slow_reader, &got) == 0)
			sleep_ms(1);
	CHECK(got == SENT, "%d of %d datagrams read in the end", got, SENT);
	ndo_link_destroy(l);
}

int main(void)
{
	ck_program = "test_session_lcm";
	if (ck_private_netns() != 0) {
		printf("FAIL test_session_lcm: cannot make a private network namespace\n");
		return 1;
	}
	RUN(two_peers);
	RUN(four_peers_one_observer);
	RUN(a_flood_does_not_hold_a_poll);
	return ck_failed_cases != 0;
}
