/* auth.c — session keys, sealed messages, the replay window (ndo/auth.h).
 * Every primitive is libsodium's: BLAKE2b (crypto_generichash) for the
 * key id and the per-channel subkeys, XChaCha20-Poly1305 (IETF AEAD,
 * additional data only) for the tag, randombytes for keys and instances,
 * sodium_memzero for wiping. */
#include "ndo/auth.h"
#include "ndo/status.h"

#include <errno.h>
#include <fcntl.h>
#include <sodium.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define MAGIC "nda1"

typedef struct window {
	int32_t sender; /* 0: empty */
	uint8_t instance[16];
	uint64_t top; /* newest counter seen + 1 (0: none yet) */
	uint64_t bits[NDO_REPLAY_WINDOW / 64]; /* bit c % W: counter c seen */
	uint64_t used; /* the clock at its last message taken: the least
	                  recently heard of the windows that may go is taken */
	double heard;  /* when a fresh message last came */
} window;

struct ndo_auth {
	ndo_key key;
	uint8_t instance[16];
	uint64_t counter;
	window w[NDO_AUTH_SENDERS];
	uint64_t clock;
};

static int sodium_ready(void)
{
	if (sodium_init() < 0)
		return ndo__fail(NDO_EIO, "libsodium cannot initialise");
	return 0;
}

static void key_id(ndo_key *k)
{
	uint8_t h[16];
	static const char what[] = "ndo key id";
	crypto_generichash(h, sizeof h, (const uint8_t *)what, sizeof what - 1, k->k, sizeof k->k);
	memcpy(k->id, h, sizeof k->id);
}

int ndo_key_parse(const char *text, size_t len, ndo_key *out)
{
	ndo__clear_error();
	int rc = sodium_ready();
	if (rc)
		return rc;
	while (len && (*text == ' ' || *text == '\t' || *text == '\n' || *text == '\r'))
		text++, len--;
	while (len && (text[len - 1] == ' ' || text[len - 1] == '\t' || text[len - 1] == '\n' ||
	               text[len - 1] == '\r'))
		len--;
	size_t bin = 0;
	const char *end = NULL;
	if (len != 2 * NDO_KEY_BYTES ||
	    sodium_hex2bin(out->k, sizeof out->k, text, len, NULL, &bin, &end) != 0 ||
	    bin != NDO_KEY_BYTES) {
		sodium_memzero(out, sizeof *out);
		return ndo__fail(NDO_EINVAL, "not a session key (%d hexadecimal digits)",
		                 2 * NDO_KEY_BYTES);
	}
	key_id(out);
	return 0;
}

int ndo_key_load(const char *path, ndo_key *out)
{
	ndo__clear_error();
	int fd = open(path, O_RDONLY | O_CLOEXEC);
	if (fd < 0)
		return ndo__fail(NDO_EIO, "%s: %s", path, strerror(errno));
	struct stat st;
	if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
		close(fd);
		return ndo__fail(NDO_EINVAL, "%s: not a regular file", path);
	}
	if (st.st_mode & 077) {
		close(fd);
		return ndo__fail(NDO_EINVAL, "%s: others may read this key (mode %03o): chmod 600 %s",
		                 path, (unsigned)(st.st_mode & 0777), path);
	}
	char buf[2 * NDO_KEY_BYTES + 16];
	ssize_t n = read(fd, buf, sizeof buf);
	close(fd);
	if (n < 0)
		return ndo__fail(NDO_EIO, "%s: %s", path, strerror(errno));
	int rc = ndo_key_parse(buf, (size_t)n, out);
	sodium_memzero(buf, sizeof buf);
	if (rc)
		return ndo__fail(rc, "%s: not a session key (%d hexadecimal digits, as "
		                 "simulate-peer --new-key writes)", path, 2 * NDO_KEY_BYTES);
	return 0;
}

int ndo_key_generate(const char *path, ndo_key *out)
{
	ndo__clear_error();
	int rc = sodium_ready();
	if (rc)
		return rc;
	int fd = open(path, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
	if (fd < 0)
		return ndo__fail(NDO_EIO, "%s: %s%s", path, strerror(errno),
		                 errno == EEXIST ? " (a new key never overwrites a file)" : "");
	randombytes_buf(out->k, sizeof out->k);
	key_id(out);
	char hex[2 * NDO_KEY_BYTES + 2];
	sodium_bin2hex(hex, sizeof hex, out->k, sizeof out->k);
	hex[2 * NDO_KEY_BYTES] = '\n';
	ssize_t n = write(fd, hex, 2 * NDO_KEY_BYTES + 1);
	sodium_memzero(hex, sizeof hex);
	if (n != 2 * NDO_KEY_BYTES + 1 || fsync(fd) != 0 || close(fd) != 0) {
		int e = errno;
		unlink(path);
		return ndo__fail(NDO_EIO, "%s: %s", path, strerror(e));
	}
	return 0;
}

int ndo_key_from_env(ndo_key *out)
{
	ndo__clear_error();
	const char *v = getenv(NDO_KEY_ENV);
	if (!v || !*v)
		return 0;
	int rc = ndo_key_parse(v, strlen(v), out);
	if (rc)
		return ndo__fail(rc, "$%s: not a session key (%d hexadecimal digits)", NDO_KEY_ENV,
		                 2 * NDO_KEY_BYTES);
	return 1;
}

int ndo_key_resolve(const char *path, ndo_key *out)
{
	if (path) {
		int rc = ndo_key_load(path, out);
		return rc ? rc : 1;
	}
	return ndo_key_from_env(out);
}

void ndo_key_wipe(ndo_key *k)
{
	sodium_memzero(k, sizeof *k);
}

void ndo_key_id_text(const ndo_key *k, char out[9])
{
	sodium_bin2hex(out, 9, k->id, sizeof k->id);
}

int ndo_auth_create(const ndo_key *key, ndo_auth **out)
{
	ndo__clear_error();
	int rc = sodium_ready();
	if (rc)
		return rc;
	ndo_auth *a = sodium_malloc(sizeof *a); /* guarded pages, wiped on free */
	if (!a)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	memset(a, 0, sizeof *a);
	a->key = *key;
	randombytes_buf(a->instance, sizeof a->instance);
	*out = a;
	return 0;
}

void ndo_auth_destroy(ndo_auth *a)
{
	if (a)
		sodium_free(a); /* zeroes the memory first */
}

static void subkey(const ndo_auth *a, const char *channel, uint8_t k[32])
{
	crypto_generichash(k, 32, (const uint8_t *)channel, strlen(channel), a->key.k,
	                   sizeof a->key.k);
}

static void put64(uint8_t *p, uint64_t v)
{
	for (int k = 7; k >= 0; k--, v >>= 8)
		p[k] = (uint8_t)v;
}

static uint64_t get64(const uint8_t *p)
{
	uint64_t v = 0;
	for (int k = 0; k < 8; k++)
		v = v << 8 | p[k];
	return v;
}

int ndo_auth_seal(ndo_auth *a, const char *channel, uint8_t *msg, size_t len)
{
	if (a->counter == UINT64_MAX)
		return ndo__fail(NDO_EINVAL, "the message counter ran out");
	uint8_t *t = msg + len, k[32];
	memcpy(t, MAGIC, 4);
	memcpy(t + 4, a->key.id, 4);
	memcpy(t + 8, a->instance, 16);
	put64(t + 24, a->counter++);
	subkey(a, channel, k);
	uint8_t none[1] = {0}; /* no plaintext: libsodium still wants the pointers */
	crypto_aead_xchacha20poly1305_ietf_encrypt_detached(none, t + 32, NULL, none, 0, msg,
	                                                    len + 32, NULL, t + 8, k);
	sodium_memzero(k, sizeof k);
	return 0;
}

int ndo_auth_looks_sealed(const uint8_t *buf, size_t len)
{
	return len >= NDO_AUTH_TRAILER && memcmp(buf + len - NDO_AUTH_TRAILER, MAGIC, 4) == 0;
}

ndo_drop ndo_auth_open(const ndo_auth *a, const char *channel, const uint8_t *buf, size_t len,
                       size_t *msg_len, ndo_auth_from *from)
{
	if (!ndo_auth_looks_sealed(buf, len))
		return NDO_DROP_UNSIGNED;
	size_t n = len - NDO_AUTH_TRAILER;
	const uint8_t *t = buf + n;
	if (memcmp(t + 4, a->key.id, 4) != 0)
		return NDO_DROP_WRONGKEY;
	uint8_t k[32];
	subkey(a, channel, k);
	uint8_t none[1] = {0};
	int bad = crypto_aead_xchacha20poly1305_ietf_decrypt_detached(none, NULL, none, 0, t + 32,
	                                                              buf, n + 32, t + 8, k);
	sodium_memzero(k, sizeof k);
	if (bad)
		return NDO_DROP_FORGED;
	*msg_len = n;
	memcpy(from->instance, t + 8, 16);
	from->counter = get64(t + 24);
	return NDO_DROP_NONE;
}

/* A window that may go to another sender or instance: empty, or its
 * sender silent for longer than NDO_AUTH_KEEP. */
static int may_go(const window *w, double now)
{
	return w->sender == 0 || !(now - w->heard <= NDO_AUTH_KEEP);
}

int ndo_auth_fresh(ndo_auth *a, int32_t sender, const ndo_auth_from *from, double now)
{
	window *w = NULL, *lru = NULL;
	for (int k = 0; k < NDO_AUTH_SENDERS && !w; k++) {
		if (a->w[k].sender == sender)
			w = &a->w[k];
		else if (may_go(&a->w[k], now) && (!lru || a->w[k].used < lru->used))
			lru = &a->w[k]; /* empty slots have used == 0: taken first */
	}
	if (!w || memcmp(w->instance, from->instance, 16) != 0) {
		if (w && !may_go(w, now))
			return 0; /* another instance of a sender heard lately */
		if (!w && !(w = lru))
			return 0; /* every window's sender heard lately */
		memset(w, 0, sizeof *w);
		w->sender = sender;
		memcpy(w->instance, from->instance, 16);
	}
	uint64_t c = from->counter;
	uint64_t *word = &w->bits[(c / 64) % (NDO_REPLAY_WINDOW / 64)];
	uint64_t bit = 1ull << (c % 64);
	if (c >= w->top) { /* newer than any: clear the words it moves past */
		uint64_t from_word = (w->top - 1) / 64, to_word = c / 64; /* words past top − 1's */
		if (w->top == 0)
			from_word = 0, memset(w->bits, 0, sizeof w->bits);
		else if (to_word - from_word >= NDO_REPLAY_WINDOW / 64)
			memset(w->bits, 0, sizeof w->bits);
		else
			for (uint64_t q = from_word + 1; q <= to_word; q++)
				w->bits[q % (NDO_REPLAY_WINDOW / 64)] = 0;
		w->top = c + 1;
		*word |= bit;
		w->heard = now;
		w->used = ++a->clock;
		return 1;
	}
	/* older than the window remembers: NDO_REPLAY_WINDOW − 64 below the
	 * newest (top − 1), whose word is never one the newest's moves have
	 * cleared (until 2026-12-01 `top − c`, one fewer than auth.h says) */
	if (w->top - 1 - c > NDO_REPLAY_WINDOW - 64)
		return 0;
	if (*word & bit)
		return 0;
	*word |= bit;
	w->heard = now;
	w->used = ++a->clock;
	return 1;
}
