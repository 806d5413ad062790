/* test_hostile — a keyed session under attack (issue 16), over real LCM in
 * a private network namespace.  Two simulate-peer processes (owner and
 * joiner, level 4, thesis scene, 100 lock-step rk4 steps) share a session
 * key; this program listens on the group as an attacker would and, for
 * every message the peers publish, publishes hostile copies:
 *
 *   poison    a tile with one coordinate moved by 1 m, the tag kept   → forged
 *   poison-   the same without the trailer                            → unsigned
 *   flip      one random bit of the message flipped                   → forged
 *   inflate   a tile whose value count grew by 3000                   → forged
 *   foreign   another sender id (or object id), the tag kept          → forged
 *   foreign-  the same without the trailer                            → unsigned
 *   otherkey  a poisoned tile sealed properly under another key       → wrongkey
 *   replay    the message again, at once and 40 messages later        → replay
 *   random    random bytes on a random channel                        → unsigned
 *
 * The owner publishes whole regions every step (--publish-every 1), so
 * tiles to poison pass as often as the halo messages, which the kinds
 * that copy any message (flip, foreign, replay) attack too.
 *
 * It attacks from the first tile it hears after both peers have spoken
 * until a tile of step 75, while both peers are listening (every message
 * a peer receives is held 2 ms, --delay 2: lock-step then takes at least
 * 2 ms a step, so the attacker, which answers within microseconds, is done
 * well before the peers are), so each of them must count every hostile
 * message under its cause, exactly; and the owner's result must be bit
 * for bit that of the same run undisturbed. */
#include "check.h"
#include "netns.h"
#include "ndo/auth.h"
#include "ndo/link.h"
#include "ndo/ndo.h"
#include "ndo/msg.h"

#include <lcm/lcm.h>
#include <signal.h>
#include <spawn.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

extern char **environ;
static char dir[256];

enum { POISON, POISON_U, FLIP, INFLATE, FOREIGN, FOREIGN_U, OTHERKEY, REPLAY, RANDOM, NKINDS };
static const char *kind_name[NKINDS] = {"poison", "poison-unsigned", "flip", "inflate",
                                        "foreign", "foreign-unsigned", "otherkey", "replay",
                                        "random"};

static pid_t spawn(const char *cmd)
{
	char *argv[] = {"sh", "-c", (char *)cmd, NULL};
	pid_t pid;
	if (posix_spawn(&pid, "/bin/sh", NULL, NULL, argv, environ) != 0)
		return -1;
	return pid;
}

static int run(const char *cmd)
{
	pid_t p = spawn(cmd);
	int st;
	if (p < 0 || waitpid(p, &st, 0) != p)
		return -1;
	return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
}

/* ---- the attacker ------------------------------------------------------- */
typedef struct attacker {
	lcm_t *lcm;
	ndo_auth *other; /* a key of its own */
	uint64_t rng;
	int on, done;
	int32_t heard[2]; /* the first two senders: both peers are listening */
	uint64_t sent[NKINDS];
	uint64_t mine[4096]; /* hashes of what it sent (LCM loops them back) */
	size_t nmine;
	struct { char ch[64]; uint8_t *b; size_t n; } old[40]; /* for late replays */
	size_t nold;
} attacker;

static uint64_t hash(const void *d, size_t n)
{
	const uint8_t *p = d;
	uint64_t h = 1469598103934665603ull;
	for (size_t k = 0; k < n; k++)
		h = (h ^ p[k]) * 1099511628211ull;
	return h;
}

static void send_(attacker *a, int kind, const char *ch, const void *d, size_t n)
{
	a->mine[a->nmine++ % 4096] = hash(d, n);
	if (lcm_publish(a->lcm, ch, d, (unsigned)n) == 0)
		a->sent[kind]++;
}

static int is_mine(const attacker *a, const void *d, size_t n)
{
	uint64_t h = hash(d, n);
	size_t m = a->nmine < 4096 ? a->nmine : 4096;
	for (size_t k = 0; k < m; k++)
		if (a->mine[k] == h)
			return 1;
	return 0;
}

/* Re-encode a decoded message and append `trailer` (NULL: none). */
static void send_msg(attacker *a, int kind, const char *ch, ndo_msg_type t, const void *msg,
                     const uint8_t *trailer)
{
	uint8_t *b;
	size_t n;
	if (ndo_msg_encode(t, msg, &b, &n) != 0)
		return;
	uint8_t *c = realloc(b, n + NDO_AUTH_TRAILER);
	if (!c) {
		free(b);
		return;
	}
	if (trailer)
		memcpy(c + n, trailer, NDO_AUTH_TRAILER);
	send_(a, kind, ch, c, trailer ? n + NDO_AUTH_TRAILER : n);
	free(c);
}

static void on_message(const lcm_recv_buf_t *rb, const char *ch, void *user)
{
	attacker *a = user;
	const uint8_t *d = rb->data;
	size_t n = (size_t)rb->data_size;
	if (is_mine(a, d, n) || n < NDO_AUTH_TRAILER)
		return;
	int t = ndo_msg_type_of("NDO", ch);
	if (t < 0)
		return;
	size_t len = n - NDO_AUTH_TRAILER;
	const uint8_t *trailer = d + len;
	ndo_msg m;
	if (ndo_msg_decode((ndo_msg_type)t, d, len, &m) != NDO_DROP_NONE)
		return;
	int32_t from = m.hdr->sender_id;
	if (!a->heard[0])
		a->heard[0] = from;
	else if (!a->heard[1] && from != a->heard[0])
		a->heard[1] = from;
	if (t == NDO_MSG_TILE && a->heard[1]) {
		a->on = 1;
		if (m.u.tile.step >= 75)
			a->done = 1;
	}
	if (!a->on || a->done) {
		ndo_msg_free(&m);
		return;
	}
	if (t == NDO_MSG_TILE && m.u.tile.nvalues > 0) {
		ndo_msg_tile_t *tl = &m.u.tile;
		tl->values[0] += 1.0; /* one coordinate moved 1 m */
		send_msg(a, POISON, ch, NDO_MSG_TILE, tl, trailer);
		send_msg(a, POISON_U, ch, NDO_MSG_TILE, tl, NULL);
		uint8_t *b;
		size_t bn;
		if (ndo_msg_encode(NDO_MSG_TILE, tl, &b, &bn) == 0) { /* sealed under another key */
			uint8_t *c = realloc(b, bn + NDO_AUTH_TRAILER);
			if (c) {
				ndo_auth_seal(a->other, ch, c, bn);
				send_(a, OTHERKEY, ch, c, bn + NDO_AUTH_TRAILER);
				b = c;
			}
			free(b);
		}
		tl->values[0] -= 1.0;
		double *more = realloc(tl->values, ((size_t)tl->nvalues + 3000) * sizeof *more);
		if (more) {
			memset(more + tl->nvalues, 0, 3000 * sizeof *more);
			tl->values = more;
			tl->nvalues += 3000;
			send_msg(a, INFLATE, ch, NDO_MSG_TILE, tl, trailer);
			tl->nvalues -= 3000;
		}
	}
	ndo_msg_header_t *h = (ndo_msg_header_t *)&m.u; /* every type starts with it */
	int32_t sender = h->sender_id;
	if (ndo_rng_next(&a->rng) & 1)
		h->sender_id = (int32_t)(ndo_rng_next(&a->rng) | 1) & 0x7fffffff;
	else
		h->object_id ^= 0x10;
	send_msg(a, FOREIGN, ch, (ndo_msg_type)t, &m.u, trailer);
	send_msg(a, FOREIGN_U, ch, (ndo_msg_type)t, &m.u, NULL);
	h->sender_id = sender;
	ndo_msg_free(&m);

	uint8_t *c = malloc(n);
	if (!c)
		return;
	memcpy(c, d, n);
	size_t bit = ndo_rng_next(&a->rng) % (8 * len);
	c[bit / 8] ^= (uint8_t)(1u << (bit % 8));
	send_(a, FLIP, ch, c, n);
	memcpy(c, d, n);
	send_(a, REPLAY, ch, c, n);
	/* a late replay: the message of 40 messages ago */
	size_t slot = a->nold++ % 40;
	if (a->nold > 40) {
		send_(a, REPLAY, a->old[slot].ch, a->old[slot].b, a->old[slot].n);
		free(a->old[slot].b);
	}
	snprintf(a->old[slot].ch, sizeof a->old[slot].ch, "%s", ch);
	a->old[slot].b = c;
	a->old[slot].n = n;
	uint8_t junk[600];
	size_t jn = 1 + ndo_rng_next(&a->rng) % sizeof junk;
	for (size_t k = 0; k < jn; k++)
		junk[k] = (uint8_t)ndo_rng_next(&a->rng);
	char rch[64];
	snprintf(rch, sizeof rch, "NDO_%s",
	         ndo_msg_suffix((ndo_msg_type)(ndo_rng_next(&a->rng) % NDO_MSG_NTYPES)));
	send_(a, RANDOM, rch, junk, jn);
}

/* ---- the runs ----------------------------------------------------------- */
/* Owner and joiner; with an attacker when `a`.  0 when both exit 0. */
static int session(const char *out, attacker *a, const char *tag)
{
	char cmd[2048];
	snprintf(cmd, sizeof cmd,
	         "exec simulate-peer --owner %s/w4.tgrid -s %s/samples/thesis-fig5.3.scene --dt 0.01 "
	         "-t 1 --peers 2 --publish-every 1 --key %s/k.key --start-timeout 30 --delay 2 "
	         "-o %s 2>%s/%s-owner.err",
	         dir, getenv("NDO_ROOT"), dir, out, dir, tag);
	pid_t owner = spawn(cmd);
	snprintf(cmd, sizeof cmd,
	         "exec simulate-peer --join --poi 100 --key %s/k.key --start-timeout 30 --delay 2 "
	         "2>%s/%s-joiner.err", dir, dir, tag);
	pid_t joiner = spawn(cmd);
	int st[2] = {-1, -1}, left = 2;
	pid_t pids[2] = {owner, joiner};
	while (left) {
		if (a)
			lcm_handle_timeout(a->lcm, 20);
		else
			usleep(20000);
		for (int k = 0; k < 2; k++) {
			int s;
			if (st[k] < 0 && waitpid(pids[k], &s, WNOHANG) == pids[k]) {
				st[k] = WIFEXITED(s) ? WEXITSTATUS(s) : 128 + WTERMSIG(s);
				left--;
			}
		}
	}
	CHECK(st[0] == 0 && st[1] == 0, "%s run: owner exit %d, joiner exit %d", tag, st[0], st[1]);
	return st[0] || st[1];
}

/* The drops a peer reports on its "network:" line, by reason. */
static void reported(const char *path, uint64_t *by)
{
	FILE *f = fopen(path, "r");
	char line[2048];
	memset(by, 0, NDO_DROP_N * sizeof *by);
	while (f && fgets(line, sizeof line, f)) {
		char *p = strstr(line, "network: ");
		if (!p)
			continue;
		for (int r = 1; r < NDO_DROP_N; r++) {
			char key[40];
			snprintf(key, sizeof key, "%s ", ndo_drop_name((ndo_drop)r));
			for (char *q = strstr(p, key); q; q = strstr(q + 1, key))
				if (q[-1] == '(' || q[-1] == ' ')
					by[r] = strtoull(q + strlen(key), NULL, 10);
		}
	}
	if (f)
		fclose(f);
}

static void attacked_equals_undisturbed(void)
{
	char cmd[1024], a_out[300], b_out[300];
	snprintf(cmd, sizeof cmd, "remesh --shape wavy -l 4 -o %s/w4.tgrid 2>/dev/null && "
	         "simulate-peer --new-key %s/k.key 2>/dev/null", dir, dir);
	if (run(cmd) != 0) {
		CHECK(0, "remesh or --new-key failed");
		return;
	}
	snprintf(a_out, sizeof a_out, "%s/quiet.tgrid", dir);
	snprintf(b_out, sizeof b_out, "%s/attacked.tgrid", dir);
	if (session(a_out, NULL, "quiet"))
		return;

	static attacker a;
	a.rng = 0x5eed;
	a.lcm = lcm_create(NULL);
	ndo_key other;
	ndo_key_parse("0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef", 64, &other);
	ndo_auth_create(&other, &a.other);
	if (!a.lcm || !lcm_subscribe(a.lcm, "NDO_.*", on_message, &a)) {
		CHECK(0, "the attacker cannot open LCM");
		return;
	}
	int bad = session(b_out, &a, "attacked");
	uint64_t total = 0;
	printf("    hostile messages:");
	for (int k = 0; k < NKINDS; k++) {
		printf(" %s %llu", kind_name[k], (unsigned long long)a.sent[k]);
		total += a.sent[k];
	}
	printf("\n");
	CHECK(a.sent[POISON] > 50 && a.sent[REPLAY] > 50 && a.sent[RANDOM] > 50,
	      "the attacker sent too little to tell");
	uint64_t want[NDO_DROP_N] = {0};
	want[NDO_DROP_FORGED] = a.sent[POISON] + a.sent[FLIP] + a.sent[INFLATE] + a.sent[FOREIGN];
	want[NDO_DROP_UNSIGNED] = a.sent[POISON_U] + a.sent[FOREIGN_U] + a.sent[RANDOM];
	want[NDO_DROP_WRONGKEY] = a.sent[OTHERKEY];
	want[NDO_DROP_REPLAY] = a.sent[REPLAY];
	const char *who[2] = {"owner", "joiner"};
	for (int p = 0; p < 2; p++) {
		char path[300];
		uint64_t by[NDO_DROP_N];
		snprintf(path, sizeof path, "%s/attacked-%s.err", dir, who[p]);
		reported(path, by);
		uint64_t counted = 0;
		for (int r = 1; r < NDO_DROP_N; r++)
			counted += by[r];
		printf("    %s counted %llu of %llu (forged %llu, unsigned %llu, wrongkey %llu, "
		       "replay %llu)\n", who[p], (unsigned long long)counted,
		       (unsigned long long)total, (unsigned long long)by[NDO_DROP_FORGED],
		       (unsigned long long)by[NDO_DROP_UNSIGNED], (unsigned long long)by[NDO_DROP_WRONGKEY],
		       (unsigned long long)by[NDO_DROP_REPLAY]);
		for (int r = 1; r < NDO_DROP_N; r++)
			CHECK(by[r] == want[r], "%s: %s %llu, expected %llu", who[p],
			      ndo_drop_name((ndo_drop)r), (unsigned long long)by[r],
			      (unsigned long long)want[r]);
	}
	ndo_auth_destroy(a.other);
	for (size_t k = 0; k < 40 && k < a.nold; k++)
		free(a.old[k].b);
	lcm_destroy(a.lcm);
	if (bad)
		return;
	ndo_grid *ga, *gb;
	if (ndo_grid_load(a_out, &ga) || ndo_grid_load(b_out, &gb)) {
		CHECK(0, "cannot read the results: %s", ndo_errdetail());
		return;
	}
	const double *xa = ndo_grid_f64(ga, NDO_CH_POSITION, 3),
	             *xb = ndo_grid_f64(gb, NDO_CH_POSITION, 3),
	             *ra = ndo_grid_f64(ga, NDO_CH_REST, 3);
	CHECK(xa && xb && ga->count == gb->count && ga->step == gb->step && ga->step == 100,
	      "both results of step 100 (%lld, %lld)", (long long)ga->step, (long long)gb->step);
	size_t differ = 0;
	double moved = 0;
	for (size_t k = 0; xa && xb && k < 3 * ga->count; k++) {
		differ += memcmp(&xa[k], &xb[k], sizeof xa[k]) != 0;
		if (ra)
			moved = fmax(moved, fabs(xa[k] - ra[k]));
	}
	CHECK(differ == 0, "attacked result: %zu coordinates differ from the undisturbed run", differ);
	CHECK(moved > 1e-3, "the run moved (%g): a test of nothing otherwise", moved);
	printf("    attacked result = undisturbed result, bit for bit (%zu nodes, largest "
	       "displacement %.3g)\n", ga->count, moved);
	ndo_grid_destroy(ga);
	ndo_grid_destroy(gb);
}

int main(void)
{
	ck_program = "test_hostile";
	if (ck_private_netns() != 0) {
		printf("FAIL test_hostile: no private network namespace\n");
		return 1;
	}
	const char *tmp = getenv("NDO_TMP");
	snprintf(dir, sizeof dir, "%s/hostile.XXXXXX", tmp && *tmp ? tmp : "/tmp");
	if (!getenv("NDO_ROOT") || !mkdtemp(dir)) {
		printf("FAIL test_hostile: needs NDO_ROOT and bin/ on PATH (tests/run sets them)\n");
		return 1;
	}
	RUN(attacked_equals_undisturbed);
	char cmd[400];
	snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
	if (!ck_failed_cases)
		run(cmd);
	return ck_failed_cases != 0;
}
