/* ndo/auth.h — keyed sessions: the session key, the authentication tag on
 * every message and the replay window (docs/protocol.md, "Keyed
 * sessions").  All the cryptography is libsodium's.
 *
 * A sealed message is the LCM-encoded message followed by a 48-byte
 * trailer:
 *
 *   offset  bytes  field
 *   0       4      magic "nda1" (the trailer's format)
 *   4       4      key id: the first 4 bytes of BLAKE2b-128 keyed with
 *                  the session key over "ndo key id" (tells a wrong key
 *                  from a forgery; it proves nothing)
 *   8       16     instance: random, fixed for a sender's life
 *   24      8      counter: big-endian, 0, 1, 2, … per sender, every
 *                  message on every channel
 *   32      16     tag: XChaCha20-Poly1305 (IETF) with nonce = instance ‖
 *                  counter, no plaintext, additional data = the message
 *                  and trailer bytes 0..31, under the channel's subkey
 *                  BLAKE2b-256(key = session key, message = channel name)
 *
 * The nonce never repeats under one key (16 random bytes per sender, a
 * counter per message), the subkey binds the channel, and the counter
 * orders a sender's messages for the replay window.  The state is not
 * encrypted: anyone on the network can read it, nobody without the key
 * can write it.
 */
#ifndef NDO_AUTH_H
#define NDO_AUTH_H

#include <stddef.h>
#include <stdint.h>

#include "ndo/msg.h"

#ifdef __cplusplus
extern "C" {
#endif

#define NDO_KEY_BYTES 32
/* Messages a sender may be reordered by and still count as new: a bitmap
 * of this many counters per sender (IPsec's window), of which the
 * NDO_REPLAY_WINDOW − 64 below the newest are remembered (the newest's
 * word is partly ahead of it). */
#define NDO_REPLAY_WINDOW 8192
/* The environment variable that may hold the key (64 hex digits). */
#define NDO_KEY_ENV "NDO_KEY"

typedef struct ndo_key {
	uint8_t k[NDO_KEY_BYTES];
	uint8_t id[4];
} ndo_key;

/* 64 hexadecimal digits (surrounding white space allowed) → key.
 * 0, or NDO_EINVAL naming what is wrong. */
int ndo_key_parse(const char *text, size_t len, ndo_key *out);
/* Read a key file (64 hex digits and a newline, as ndo_key_generate
 * writes it).  Refused, like ssh does, when others may read it (mode
 * bits 077): NDO_EINVAL "chmod 600".  0, or NDO_EIO/NDO_EINVAL. */
int ndo_key_load(const char *path, ndo_key *out);
/* A new random key, written to a new file `path` (mode 0600, refused if
 * the file exists).  0, or NDO_EIO. */
int ndo_key_generate(const char *path, ndo_key *out);
/* $NDO_KEY: 1 and *out when set, 0 when unset or empty, NDO_EINVAL when
 * it is not a key. */
int ndo_key_from_env(ndo_key *out);
/* The key a tool uses: the file `path` when given (ndo_key_load), else
 * $NDO_KEY: 1 and *out, 0 for none, or an error. */
int ndo_key_resolve(const char *path, ndo_key *out);
/* Forget a key (zeroed so that the compiler keeps the zeroing). */
void ndo_key_wipe(ndo_key *k);
/* The key id as 8 hex digits (what the tools print: never the key). */
void ndo_key_id_text(const ndo_key *k, char out[9]);

/* Sealing and opening messages under one key.  Owns copies of the key;
 * ndo_auth_destroy() wipes them and accepts NULL. */
typedef struct ndo_auth ndo_auth;
int ndo_auth_create(const ndo_key *key, ndo_auth **out);
void ndo_auth_destroy(ndo_auth *a);

/* Append the trailer to `msg` (len bytes, room for len +
 * NDO_AUTH_TRAILER) for `channel`, with the next counter.  0, or
 * NDO_EINVAL (the counter ran out: 2^64 messages). */
int ndo_auth_seal(ndo_auth *a, const char *channel, uint8_t *msg, size_t len);

/* Who sealed a message: its instance and counter. */
typedef struct ndo_auth_from {
	uint8_t instance[16];
	uint64_t counter;
} ndo_auth_from;

/* Check a received message on `channel`: NDO_DROP_NONE with *msg_len the
 * message's length without the trailer and *from filled; else
 * NDO_DROP_UNSIGNED (no trailer), NDO_DROP_WRONGKEY (another key's id) or
 * NDO_DROP_FORGED (the tag does not verify: altered, or made without
 * the key). */
ndo_drop ndo_auth_open(const ndo_auth *a, const char *channel, const uint8_t *buf, size_t len,
                       size_t *msg_len, ndo_auth_from *from);

/* 1 when `buf` ends in something shaped like a trailer (a receiver
 * without a key then knows the session has one). */
int ndo_auth_looks_sealed(const uint8_t *buf, size_t len);

/* The replay check, for a message from `sender` (its header's sender id)
 * that ndo_auth_open accepted, at `now` (seconds, any monotonic origin): 1
 * and the counter marked as seen when it is new (newer than any, or within
 * the window and not seen), 0 for a replay or a counter older than the
 * window.  Keeps up to NDO_AUTH_SENDERS senders' windows.  A sender's
 * window, once it has been heard within the last NDO_AUTH_KEEP seconds, is
 * neither evicted for a new sender nor restarted by another instance of
 * the same id: such a message gets 0 (replays of old sealed messages of
 * many other ids, or of another process's, would otherwise clear a live
 * sender's window, and a replay of its own messages would then pass).  A
 * sender silent longer may lose its window to a new one (the least
 * recently heard first), and one seen with another instance starts a new
 * window (a restarted process with the same id). */
#define NDO_AUTH_SENDERS 256
#define NDO_AUTH_KEEP 10.0
int ndo_auth_fresh(ndo_auth *a, int32_t sender, const ndo_auth_from *from, double now);

#ifdef __cplusplus
}
#endif
#endif
