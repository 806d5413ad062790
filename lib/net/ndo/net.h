/* ndo/net.h — typed messages over a link: publish with a header, drain
 * without blocking, validate, count, keep the latest tile per range
 * (docs/protocol.md, "Transport").
 *
 * ndo_net_poll() drains everything the link has (LCM: lcm_handle_timeout
 * 0 until empty), and for each message: decode (ndo_msg_decode), drop own
 * messages, validate (ndo_msg_validate against ndo_net_ctx()), then check
 * its sequence number against the sender's last one on that channel —
 * older or equal is stale, a jump is a gap (counted).  Tiles are kept per
 * (sender, quad-tree node, channels), newest only, until taken with
 * ndo_net_take_tiles(); every other message waits in arrival order for
 * ndo_net_next().  One thread only.
 */
#ifndef NDO_NET_H
#define NDO_NET_H

#include <stdint.h>

#include "ndo/auth.h"
#include "ndo/codec.h"
#include "ndo/link.h"
#include "ndo/msg.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ndo_net ndo_net;

typedef struct ndo_net_stats {
	uint64_t received;             /* messages the link handed over */
	uint64_t accepted;             /* passed every check */
	uint64_t own;                  /* our own, looped back (not drops) */
	uint64_t dropped[NDO_DROP_N];  /* by reason; [NDO_DROP_INJECTED] from faults */
	uint64_t gaps;                 /* messages missing by sequence numbers */
	uint64_t overflowed;           /* datagrams the kernel dropped before this
	                                  receiver read them, its socket's buffer
	                                  full (ndo_link_overflows) */
	uint64_t late;                 /* accepted after a later one of its sender
	                                  (reordered; an encoded tile that came before
	                                  its reference counts in `held`, and here too
	                                  when it is released after a later message of
	                                  its sender was accepted) */
	uint64_t superseded;           /* tiles replaced by a newer one before use */
	uint64_t held;                 /* encoded tiles that came before their reference
	                                  frame, held for it (decoded once it came; `nobase`
	                                  when it cannot come any more, after 1 s, or
	                                  pushed out of 64 held: docs/protocol.md) */
	uint64_t holding;              /* of those, held now */
	uint64_t keys_asked;           /* tiles this receiver asked a keyframe of
	                                  (ndo_net_ask_keys) */
	uint64_t unwanted;             /* tiles passed over undecoded (ndo_net_set_tile_want) */
	uint64_t published, publish_failed;
	uint64_t bytes_in, bytes_out;
	/* another owner on these channels, who was there first: the sender of
	 * a well-formed description of another object whose heartbeats (one
	 * each 0.2 s since it started) outnumber this peer's (on a tie, the
	 * smaller object id); 0 none */
	int32_t foreign_owner;
	int64_t foreign_object;
	/* the table of (sender, tile) pairs kept for stale checks: its size
	 * in slots (at least twice the pairs kept; the pairs of senders
	 * forgotten — beyond the 64 heard most lately — go when it fills) */
	uint64_t tile_slots;
} ndo_net_stats;

/* Take ownership of `link`; channels are PREFIX_SUFFIX (ndo_msg_suffix).
 * self_id: this peer's nonzero sender id. */
int ndo_net_create(ndo_link *link, const char *prefix, int32_t self_id, ndo_net **out);
void ndo_net_destroy(ndo_net *n);

/* A keyed session from now on (docs/protocol.md, "Keyed sessions"): every
 * message published is sealed (ndo/auth.h), and every message received
 * must carry a valid tag under `key` (else dropped as unsigned, wrongkey
 * or forged) and a counter its sender has not used (else replay), before
 * it is decoded.  key NULL: back to an open session, where a sealed
 * message is dropped as `keyed`.  Call it before the first publish.  0,
 * or NDO_ENOMEM/NDO_EIO. */
int ndo_net_set_key(ndo_net *n, const ndo_key *key);
/* 1 in a keyed session. */
int ndo_net_keyed(const ndo_net *n);

/* The validation context (object id, level, self id): the session updates
 * it once it knows the object. */
ndo_msg_ctx *ndo_net_ctx(ndo_net *n);

/* The receiver now belongs to object `object_id` at `level`: set the
 * context and look again at the messages that arrived for it before (they
 * were kept, up to 32 MiB, rather than dropped as unknown). */
void ndo_net_attach(ndo_net *n, int64_t object_id, int level);

/* Fill msg's header (version, object id from the context, sender, the next
 * sequence number of this channel, utime) and publish it.  `msg` is the
 * generated struct of type t.  0, or NDO_EIO/NDO_ENOMEM; a tile too large
 * for one datagram is NDO_ERANGE (never sent fragmented). */
int ndo_net_publish(ndo_net *n, ndo_msg_type t, void *msg);

/* Drain the link (see above).  now: seconds, monotonic (fault delays).
 * Returns messages accepted, or NDO_EIO. */
int ndo_net_poll(ndo_net *n, double now);

/* The next accepted non-tile message, in arrival order: 1 and *m (free it
 * with ndo_msg_free), or 0 when none is left. */
int ndo_net_next(ndo_net *n, ndo_msg *m);

/* The newest tile of every (sender, node, channels) received since the
 * last call: *tiles is a malloc'd array of *count messages; free each with
 * ndo_msg_free() and the array with free(). 0 or NDO_ENOMEM. */
int ndo_net_take_tiles(ndo_net *n, ndo_msg **tiles, size_t *count);

/* Keep every tile (on ≠ 0): accepted tiles then wait in arrival order
 * with the other messages for ndo_net_next(), none superseded and none
 * judged stale by sequence number, so a caller that orders tiles by their
 * step (a lock-step peer, which also receives steps sent again; a
 * renderer of every step) sees each one and decides.  Gaps are still
 * counted.  ndo_net_take_tiles() then returns nothing. */
void ndo_net_keep_all_tiles(ndo_net *n, int on);

/* Decode encoded tiles (ndo/codec.h) with these parameters from now on,
 * for an object of `level` (the session and the watch call it with the
 * owner's description, before ndo_net_attach): every accepted tile is then
 * raw, NaN where it carries nothing (ndo/tile.h).  Without a codec an
 * encoded tile is dropped as `encoding`.  Raw parameters remove the codec.
 * 0, or NDO_EINVAL/NDO_ENOMEM. */
int ndo_net_set_codec(ndo_net *n, const ndo_codec_params *p, int level);
/* The codec (NULL: none): its statistics. */
const ndo_codec *ndo_net_codec(const ndo_net *n);
/* The owner's send level (ndo/codec.h, "send-level"): tiles with
 * NDO_TILE_COARSE are validated and decoded as tiles of a level-send_level
 * grid (after ndo_net_set_codec, which resets it).  0, NDO_EINVAL (not
 * 0..level), NDO_ENOMEM.  The decoder of those tiles (NULL when raw). */
int ndo_net_set_send_level(ndo_net *n, int send_level, int level);
const ndo_codec *ndo_net_coarse_codec(const ndo_net *n);
/* With keep-all tiles on: a predicted tile that follows skipped steps of
 * its range (ndo/codec.h) is preceded by one tile per skipped step, its
 * prediction (a watch needs every step of every node). */
void ndo_net_skipped_tiles(ndo_net *n, int on);

/* Tiles the receiver does not use: want(user, sender, step, channels) is
 * asked for every raw tile of another sender before it is decoded, and a
 * tile it returns 0 for is passed over (counted as `unwanted`, not a drop;
 * its sequence number still counts, and in a keyed session its counter,
 * so a copy replayed later is still a replay).  An encoded tile is always
 * decoded: it is the reference of the sender's next ones.  want NULL: every
 * tile (the default). */
typedef int (*ndo_net_tile_want_fn)(void *user, int32_t sender, int64_t step, int channels);
void ndo_net_set_tile_want(ndo_net *n, ndo_net_tile_want_fn want, void *user);

/* Ask for keyframes (on ≠ 0; off by default): a tile still held (above)
 * when a poll has drained the link, and held longer than reordered messages
 * come late here (1.5 times the longest lateness of a message that filled a
 * gap in its sender's sequence numbers, fading by e every 10 s; at most
 * NDO_NET_ASK_AGAIN; 0 until the network reorders anything) — its reference
 * lost, not late — has its keyframe asked of its sender in a key_request_t
 * (ndo/msg.h; the sender's session answers it, ndo/codec.h
 * ndo_codec_want_key).  While no frame of a tile asked for has decoded,
 * it is asked for again — counting the requests other receivers made,
 * which are multicast too, but not one that names the tile's sender as its
 * own sender (a forgery: the sender drops it as its own) — only once twice
 * the usual wait from a request to its keyframe has passed (smoothed over
 * the keyframes that came, as TCP times its round trips; within
 * NDO_NET_ASK_MIN..NDO_NET_ASK_AGAIN seconds): the request or the keyframe
 * was lost.  Once a frame of it decodes, its next loss is asked for
 * without that wait.  A tile lost then costs the frames of a
 * round trip, not those up to its next periodic keyframe.  Off: the receiver publishes nothing of
 * its own accord (a recorded log, a silent observer). */
#define NDO_NET_ASK_MIN 0.01
#define NDO_NET_ASK_AGAIN 0.25
void ndo_net_ask_keys(ndo_net *n, int on);

/* A random nonzero sender id (from the system's entropy): a receiver that
 * publishes (above) needs one of its own — a keyed session counts each
 * sender's messages (ndo/auth.h), so two receivers with one id would drop
 * each other's as replays. */
int32_t ndo_net_new_id(void);

/* Forget a sender's sequence numbers and pending tiles (it left; if it
 * comes back with the same id its numbers start again). */
void ndo_net_forget(ndo_net *n, int32_t sender);

const ndo_net_stats *ndo_net_stats_get(const ndo_net *n);
/* "received 120, accepted 118, dropped 2 (stale 1, range 1), gaps 0" */
void ndo_net_stats_format(const ndo_net *n, char *buf, size_t size);

/* The link underneath (owned by the net). */
ndo_link *ndo_net_link(const ndo_net *n);

/* The channel name of a type under this net's prefix. */
const char *ndo_net_channel(const ndo_net *n, ndo_msg_type t);

#ifdef __cplusplus
}
#endif
#endif
