/* test_auth — keyed sessions (ndo/auth.h, ndo/net.h): keys from text,
 * files and the environment; every message sealed and opened; every
 * altered byte, another key, a missing trailer and a replay dropped under
 * its own reason; the replay window across reordering; two nets on an
 * in-memory bus, keyed and not; the object's box on decoded state. */
#include "check.h"
#include "ndo/auth.h"
#include "ndo/ndo.h"
#include "ndo/net.h"
#include "ndo/tile.h"

#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static const char *HEX = "000102030405060708090a0b0c0d0e0f101112131415161718191a1b1c1d1e1f";
static char dir[256];

static void keys(void)
{
	ndo_key k, k2;
	CHECK(ndo_key_parse(HEX, strlen(HEX), &k) == 0, "64 hex digits: a key");
	CHECK(k.k[0] == 0 && k.k[31] == 31, "the key's bytes: %d %d", k.k[0], k.k[31]);
	char padded[80];
	snprintf(padded, sizeof padded, "  %s\n", HEX);
	CHECK(ndo_key_parse(padded, strlen(padded), &k2) == 0 && memcmp(k.id, k2.id, 4) == 0,
	      "white space around a key is fine, same id");
	CHECK(ndo_key_parse(HEX, 63, &k2) == NDO_EINVAL, "63 digits: not a key");
	char bad[65];
	memcpy(bad, HEX, 65);
	bad[10] = 'g';
	CHECK(ndo_key_parse(bad, 64, &k2) == NDO_EINVAL, "a non-hex digit: not a key");

	char path[300], id[9];
	snprintf(path, sizeof path, "%s/k.key", dir);
	unlink(path);
	CHECK(ndo_key_generate(path, &k) == 0, "generate: %s", ndo_errdetail());
	struct stat st;
	CHECK(stat(path, &st) == 0 && (st.st_mode & 0777) == 0600, "a new key file is mode 600: %o",
	      (unsigned)(st.st_mode & 0777));
	CHECK(ndo_key_generate(path, &k2) == NDO_EIO, "a new key never overwrites a file");
	CHECK(ndo_key_load(path, &k2) == 0 && memcmp(k.k, k2.k, 32) == 0, "load what was written: %s",
	      ndo_errdetail());
	ndo_key_id_text(&k, id);
	CHECK(strlen(id) == 8, "the id as 8 hex digits: '%s'", id);
	chmod(path, 0644);
	CHECK(ndo_key_load(path, &k2) == NDO_EINVAL && strstr(ndo_errdetail(), "chmod 600"),
	      "a key others may read is refused: %s", ndo_errdetail());
	unlink(path);
	CHECK(ndo_key_load(path, &k2) == NDO_EIO, "a missing key file");

	unsetenv(NDO_KEY_ENV);
	CHECK(ndo_key_from_env(&k2) == 0, "no $NDO_KEY: no key");
	setenv(NDO_KEY_ENV, HEX, 1);
	CHECK(ndo_key_from_env(&k2) == 1 && k2.k[5] == 5, "$NDO_KEY: the key");
	setenv(NDO_KEY_ENV, "xyz", 1);
	CHECK(ndo_key_from_env(&k2) == NDO_EINVAL, "a bad $NDO_KEY is an error");
	unsetenv(NDO_KEY_ENV);
}

static void seal_open(void)
{
	ndo_key k, other;
	ndo_key_parse(HEX, 64, &k);
	other = k;
	other.k[0] ^= 1;
	ndo_key_parse("ff0102030405060708090a0b0c0d0e0f101112131415161718191a1b1c1d1e1f", 64, &other);
	ndo_auth *a, *b, *c;
	CHECK(ndo_auth_create(&k, &a) == 0 && ndo_auth_create(&k, &b) == 0 &&
	      ndo_auth_create(&other, &c) == 0, "create");
	uint8_t msg[100 + NDO_AUTH_TRAILER];
	for (int q = 0; q < 100; q++)
		msg[q] = (uint8_t)(q * 7);
	CHECK(ndo_auth_seal(a, "T_TILE", msg, 100) == 0, "seal");
	size_t len;
	ndo_auth_from from;
	CHECK(ndo_auth_open(b, "T_TILE", msg, sizeof msg, &len, &from) == NDO_DROP_NONE && len == 100,
	      "another holder of the key opens it");
	CHECK(from.counter == 0, "the first counter is 0: %llu", (unsigned long long)from.counter);
	CHECK(ndo_auth_open(b, "T_POI", msg, sizeof msg, &len, &from) == NDO_DROP_FORGED,
	      "on another channel it is forged");
	CHECK(ndo_auth_open(c, "T_TILE", msg, sizeof msg, &len, &from) == NDO_DROP_WRONGKEY,
	      "another key: wrongkey");
	CHECK(ndo_auth_open(b, "T_TILE", msg, 100, &len, &from) == NDO_DROP_UNSIGNED,
	      "no trailer: unsigned");
	/* every bit of every byte but the magic and key id (those are
	 * unsigned and wrongkey) */
	int forged = 0, total = 0;
	for (size_t q = 0; q < sizeof msg; q++)
		for (int bit = 0; bit < 8; bit++) {
			if (q >= 100 && q < 108)
				continue;
			msg[q] ^= (uint8_t)(1 << bit);
			forged += ndo_auth_open(b, "T_TILE", msg, sizeof msg, &len, &from) == NDO_DROP_FORGED;
			total++;
			msg[q] ^= (uint8_t)(1 << bit);
		}
	CHECK(forged == total, "every flipped bit is forged: %d of %d", forged, total);
	CHECK(ndo_auth_open(b, "T_TILE", msg, sizeof msg, &len, &from) == NDO_DROP_NONE,
	      "restored, it opens again");

	/* the replay window: new, repeated, reordered within, too old */
	ndo_auth_from f = from;
	CHECK(ndo_auth_fresh(b, 5, &f, 0) == 1, "first: fresh");
	CHECK(ndo_auth_fresh(b, 5, &f, 0) == 0, "again: a replay");
	f.counter = 10;
	CHECK(ndo_auth_fresh(b, 5, &f, 0) == 1, "a jump: fresh");
	f.counter = 4;
	CHECK(ndo_auth_fresh(b, 5, &f, 0) == 1, "a late one within the window: fresh");
	CHECK(ndo_auth_fresh(b, 5, &f, 0) == 0, "and once only");
	CHECK(ndo_auth_fresh(b, 6, &f, 0) == 1, "another sender has its own window");
	f.counter = 10 + NDO_REPLAY_WINDOW;
	CHECK(ndo_auth_fresh(b, 5, &f, 0) == 1, "a window further: fresh");
	f.counter = 11;
	CHECK(ndo_auth_fresh(b, 5, &f, 0) == 0, "older than the window: refused");
	/* its depth, as auth.h and protocol.md state it: the
	 * NDO_REPLAY_WINDOW − 64 counters below the newest (until 2026-12-01
	 * one fewer: the 8,128th below was refused) */
	const uint64_t newest = 100000, deep = NDO_REPLAY_WINDOW - 64;
	f.counter = newest;
	CHECK(ndo_auth_fresh(b, 9, &f, 0) == 1, "sender 9's newest: fresh");
	f.counter = newest - deep;
	CHECK(ndo_auth_fresh(b, 9, &f, 0) == 1, "the %llu-th below the newest: fresh",
	      (unsigned long long)deep);
	CHECK(ndo_auth_fresh(b, 9, &f, 0) == 0, "and once only");
	f.counter = newest - deep - 1;
	CHECK(ndo_auth_fresh(b, 9, &f, 0) == 0, "one more below: older than the window");
	for (uint64_t q = 20000; q < 20000 + 3 * NDO_REPLAY_WINDOW; q += 3) {
		f.counter = q;
		if (!ndo_auth_fresh(b, 5, &f, 0)) {
			CHECK(0, "counter %llu refused", (unsigned long long)q);
			break;
		}
	}
	f.counter = 20000 + 3 * NDO_REPLAY_WINDOW - 3 - 600; /* seen: q steps by 3 from 20000 */
	CHECK(ndo_auth_fresh(b, 5, &f, 0) == 0, "seen within the window after wrapping: refused");
	f.counter += 1;
	CHECK(ndo_auth_fresh(b, 5, &f, 0) == 1, "not seen within the window after wrapping: fresh");
	f.instance[0] ^= 1;
	f.counter = 0;
	CHECK(ndo_auth_fresh(b, 5, &f, 1) == 0,
	      "another instance of a sender heard within NDO_AUTH_KEEP: refused");
	CHECK(ndo_auth_fresh(b, 5, &f, NDO_AUTH_KEEP + 1) == 1,
	      "a restarted sender (new instance), silent NDO_AUTH_KEEP: a new window");
	/* a live sender's window survives a flood of other senders' messages
	 * (replays of old sealed messages of many ids, as one without the key
	 * could send): the table takes as many as it has room for, refuses
	 * the rest while its senders are heard, and 5's replay stays one */
	ndo_auth_from g = f;
	g.counter = 100;
	const double t0 = 2 * NDO_AUTH_KEEP;
	CHECK(ndo_auth_fresh(b, 5, &g, t0) == 1, "5 heard at t0");
	int took = 0;
	for (int32_t id = 1000; id < 1000 + 2 * NDO_AUTH_SENDERS; id++) {
		ndo_auth_from o = g;
		o.counter = 1;
		took += ndo_auth_fresh(b, id, &o, t0 + 1);
	}
	CHECK(took == NDO_AUTH_SENDERS - 1,
	      "%d of %d new senders took a window beside 5's (6's among them: silent since 0)",
	      took, 2 * NDO_AUTH_SENDERS);
	CHECK(ndo_auth_fresh(b, 5, &g, t0 + 2) == 0, "5's replay after the flood: still refused");
	g.counter = 101;
	CHECK(ndo_auth_fresh(b, 5, &g, t0 + 2) == 1, "5's next message: fresh");
	/* once the flood's senders are silent NDO_AUTH_KEEP, a new one takes
	 * the least recently heard window */
	ndo_auth_from o = g;
	o.counter = 1;
	CHECK(ndo_auth_fresh(b, 77777, &o, t0 + 2) == 0, "a new sender while the table is full of "
	      "senders heard lately: refused");
	CHECK(ndo_auth_fresh(b, 77777, &o, t0 + 2 + NDO_AUTH_KEEP) == 1,
	      "a new sender once they are silent: a window");
	ndo_auth_destroy(a);
	ndo_auth_destroy(b);
	ndo_auth_destroy(c);
	ndo_auth_destroy(NULL);
}

/* Two nets on a bus: A publishes, B receives. */
static void nets(int key_a, int key_b, int want_accept, ndo_drop want_drop)
{
	ndo_bus *bus;
	ndo_link *la, *lb;
	ndo_net *a, *b;
	ndo_key k, k2;
	ndo_key_parse(HEX, 64, &k);
	ndo_key_parse("ff0102030405060708090a0b0c0d0e0f101112131415161718191a1b1c1d1e1f", 64, &k2);
	ndo_bus_create(&bus);
	ndo_link_open_mem(bus, &la);
	ndo_link_open_mem(bus, &lb);
	ndo_net_create(la, "T", 11, &a);
	ndo_net_create(lb, "T", 22, &b);
	if (key_a)
		ndo_net_set_key(a, key_a == 1 ? &k : &k2);
	if (key_b)
		ndo_net_set_key(b, &k);
	CHECK(ndo_net_keyed(b) == !!key_b, "keyed");
	ndo_msg_hello_t h = {.role = 2, .name = "x"};
	for (int q = 0; q < 3; q++)
		CHECK(ndo_net_publish(a, NDO_MSG_HELLO, &h) == 0, "publish");
	ndo_net_poll(b, 0);
	const ndo_net_stats *s = ndo_net_stats_get(b);
	CHECK((int)s->accepted == want_accept, "A keyed %d, B keyed %d: accepted %llu, expected %d",
	      key_a, key_b, (unsigned long long)s->accepted, want_accept);
	if (want_drop)
		CHECK(s->dropped[want_drop] == 3, "dropped as %s: %llu", ndo_drop_name(want_drop),
		      (unsigned long long)s->dropped[want_drop]);
	ndo_msg m;
	while (ndo_net_next(b, &m))
		ndo_msg_free(&m);
	/* A hears itself: own, whatever the keys */
	ndo_net_poll(a, 0);
	CHECK(ndo_net_stats_get(a)->own == 3, "own messages: %llu",
	      (unsigned long long)ndo_net_stats_get(a)->own);
	ndo_net_destroy(a);
	ndo_net_destroy(b);
	ndo_bus_destroy(bus);
}

static void net_keyed(void) { nets(1, 1, 3, NDO_DROP_NONE); }
static void net_open(void) { nets(0, 0, 3, NDO_DROP_NONE); }
static void net_unsigned(void) { nets(0, 1, 0, NDO_DROP_UNSIGNED); }
static void net_keyed_to_open(void) { nets(1, 0, 0, NDO_DROP_KEYED); }
static void net_wrong_key(void) { nets(2, 1, 0, NDO_DROP_WRONGKEY); }

/* The object's box: a tile with one node more than
 * 1 + 2 · NDO_SIM_DEFORM_MAX diagonals from the others, a position past
 * the drift bound, a wild velocity, or NaN is dropped; a tile that has
 * drifted whole by 1000 diagonals is taken, as is one just inside the
 * spread (a body deformed as far as the simulation lets it) or just inside
 * the drift bound with that deformation. */
static void box(void)
{
	ndo_msg_ctx c = {.object_id = 1, .level = 2, .self_id = 9};
	double lo[3] = {-1, -1, -1}, hi[3] = {1, 1, 1};
	CHECK(ndo_msg_set_box(&c, lo, hi) == 0, "set the box");
	char text[512] = "sigma 1\n", line[256];
	double pts[6] = {-1, -1, -1, 1, 1, 1};
	int n = ndo_msg_box_text(pts, 2, line, sizeof line);
	CHECK(n > 0, "box text");
	strcat(text, line);
	strcat(text, "rho 1\n");
	ndo_msg_ctx c2 = {0};
	CHECK(ndo_msg_box_take(text, &c2) == 1 && strcmp(text, "sigma 1\nrho 1\n") == 0,
	      "the box line is taken out: '%s'", text);
	CHECK(c2.has_box && c2.hi[0] == c.hi[0] && c2.vmax == c.vmax, "the same bound from the text");
	char badtext[] = "object-box 1 2 3\n";
	CHECK(ndo_msg_box_take(badtext, &c2) == NDO_EINVAL, "a bad box line");

	ndo_grid *g;
	ndo_grid_create(2, &g);
	double *x = ndo_grid_f64(g, NDO_CH_POSITION, 3);
	for (size_t k = 0; k < 3 * g->count; k++)
		x[k] = 0.5;
	ndo_quad q = {0, 0, 0};
	ndo_msg m;
	memset(&m, 0, sizeof m);
	m.type = NDO_MSG_TILE;
	m.hdr = (const ndo_msg_header_t *)&m.u;
	ndo_tile_pack(g, q, NDO_TILE_POSITION | NDO_TILE_VELOCITY, &m.u.tile);
	m.u.tile.hdr.version = NDO_PROTOCOL_VERSION;
	m.u.tile.hdr.object_id = 1;
	m.u.tile.hdr.sender_id = 3;
	CHECK(ndo_msg_validate(&m, &c) == NDO_DROP_NONE, "inside: %s",
	      ndo_drop_name(ndo_msg_validate(&m, &c)));
	double diag = sqrt(12.0);
	m.u.tile.values[6] = 0.5 + 200.9 * diag; /* a position 200.9 diagonals from the others */
	CHECK(ndo_msg_validate(&m, &c) == NDO_DROP_NONE, "201 diagonals' spread is the bound: %s",
	      ndo_drop_name(ndo_msg_validate(&m, &c)));
	m.u.tile.values[6] = 0.5 + 201.1 * diag;
	CHECK(ndo_msg_validate(&m, &c) == NDO_DROP_BOX, "one node outside the spread: %s",
	      ndo_drop_name(ndo_msg_validate(&m, &c)));
	const int vpn = ndo_tile_values_per_node(m.u.tile.channels);
	for (int32_t k = 0; k < m.u.tile.nvalues; k += vpn) /* the body drifted whole */
		m.u.tile.values[k + 2] = 0.5 + 1000 * diag;
	m.u.tile.values[6] = 0.5;
	CHECK(ndo_msg_validate(&m, &c) == NDO_DROP_NONE, "drifted whole by 1000 diagonals: %s",
	      ndo_drop_name(ndo_msg_validate(&m, &c)));
	for (int32_t k = 0; k < m.u.tile.nvalues; k += vpn)
		m.u.tile.values[k + 2] = 1 + (NDO_DRIFT_MAX + NDO_SIM_DEFORM_MAX - 0.1) * diag;
	CHECK(ndo_msg_validate(&m, &c) == NDO_DROP_NONE,
	      "drifted to the bound and deformed as far as the simulation lets it: %s",
	      ndo_drop_name(ndo_msg_validate(&m, &c)));
	for (int32_t k = 0; k < m.u.tile.nvalues; k += vpn)
		m.u.tile.values[k + 2] = 1 + (NDO_DRIFT_MAX + NDO_SIM_DEFORM_MAX + 0.1) * diag;
	CHECK(ndo_msg_validate(&m, &c) == NDO_DROP_BOX, "past the drift bound: %s",
	      ndo_drop_name(ndo_msg_validate(&m, &c)));
	for (int32_t k = 0; k < m.u.tile.nvalues; k += vpn)
		m.u.tile.values[k + 2] = 0.5;
	m.u.tile.values[6] = 0.5;
	m.u.tile.values[4] = 2e9 * diag; /* a velocity */
	CHECK(ndo_msg_validate(&m, &c) == NDO_DROP_BOX, "a wild velocity: %s",
	      ndo_drop_name(ndo_msg_validate(&m, &c)));
	m.u.tile.values[4] = 0;
	m.u.tile.values[1] = 1e300; /* an exponent bit flipped */
	CHECK(ndo_msg_validate(&m, &c) == NDO_DROP_BOX, "1e300");
	m.u.tile.values[1] = 0.5;
	/* a decoded tile: NaN marks a vector it does not carry */
	m.u.tile.values[0] = NAN;
	CHECK(ndo_msg_check_box(&m.u.tile, &c) == NDO_DROP_NONE, "a NaN-marked vector is skipped");
	m.u.tile.values[0] = 0.5;
	m.u.tile.values[2] = NAN;
	CHECK(ndo_msg_check_box(&m.u.tile, &c) == NDO_DROP_NONFINITE, "NaN after a value: nonfinite");
	ndo_msg_free(&m);
	ndo_grid_destroy(g);
}

int main(void)
{
	ck_program = "test_auth";
	const char *tmp = getenv("NDO_TMP");
	snprintf(dir, sizeof dir, "%s/auth.XXXXXX", tmp && *tmp ? tmp : "/tmp");
	if (!mkdtemp(dir)) {
		printf("FAIL test_auth: cannot make %s\n", dir);
		return 1;
	}
	RUN(keys);
	RUN(seal_open);
	RUN(net_keyed);
	RUN(net_open);
	RUN(net_unsigned);
	RUN(net_keyed_to_open);
	RUN(net_wrong_key);
	RUN(box);
	rmdir(dir);
	return ck_failed_cases != 0;
}
