/* fuzz_auth — the keyed receive path (ndo/auth.h, ndo/net.h): bytes into a
 * receiver that holds the session key.
 *
 * Byte 0 is flags: bit 0 seals the rest with the key first (so the input
 * gets past the tag to the decoder, the replay window, validation, the
 * codec and the object's box); bit 1 makes the receiver take the
 * message's object and decode tiles (as fuzz_msg's high bit) in encoding
 * 1 + (bits 2-3): float32, fixed, predict or hier.  Byte 1 is b: the type
 * b % (message types) and, with the codec, the level (b / (message
 * types)) % 8; the rest is the message.  Two properties trap:
 *   - unsealed bytes are never accepted (nobody without the key writes);
 *   - a sealed message delivered twice is dropped the second time as a
 *     replay, exactly once more.
 * tests/e2e/fuzz.sh seeds it from recorded runs.
 *   build/asan/tests/fuzz_auth -max_total_time=60 */
#include "ndo/auth.h"
#include "ndo/msg.h"
#include "ndo/net.h"

#include "drain.h"

#include <stdlib.h>
#include <string.h>

static ndo_bus *bus;
static ndo_link *tx;
static ndo_net *rx;
static ndo_auth *sealer;

static void drain(void) { fuzz_drain(rx, tx); }

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	if (size < 2)
		return 0;
	if (!bus) {
		ndo_key key;
		ndo_link *l;
		static const char hex[] =
		    "5f3c0e1d2a4b6c7d8e9fa0b1c2d3e4f5061728394a5b6c7d8e9f0a1b2c3d4e5f";
		ndo_key_parse(hex, 64, &key);
		ndo_bus_create(&bus);
		ndo_link_open_mem(bus, &tx);
		ndo_link_open_mem(bus, &l);
		ndo_net_create(l, "F", 99, &rx);
		ndo_net_ask_keys(rx, 1); /* held tiles: keyframe requests published */
		ndo_net_set_key(rx, &key);
		ndo_auth_create(&key, &sealer);
	}
	int seal = data[0] & 1, codec = data[0] & 2;
	uint8_t b1 = data[1];
	ndo_msg_type t = (ndo_msg_type)(b1 % NDO_MSG_NTYPES);
	const uint8_t *msg = data + 2;
	size_t len = size - 2;
	if (codec) {
		int64_t object = 42;
		ndo_msg m;
		if (ndo_msg_decode(t, msg, len, &m) == NDO_DROP_NONE) {
			object = m.hdr->object_id;
			ndo_msg_free(&m);
		}
		/* the rest of byte 1: the level; bits 2-3 of byte 0: the encoding */
		const int level = (b1 / NDO_MSG_NTYPES) % 8;
		ndo_codec_params cp = {.encoding = 1 + (data[0] >> 2 & 3), .bits = 13, .keyframe = 32,
		                       .lo = {-1, -1, -1}, .ext = {2, 2, 2}};
		ndo_net_set_codec(rx, &cp, level);
		ndo_net_attach(rx, object, level);
		double lo[3] = {-1, -1, -1}, hi[3] = {1, 1, 1};
		ndo_msg_set_box(ndo_net_ctx(rx), lo, hi);
	}
	char ch[32];
	strcpy(ch, "F_");
	strcat(ch, ndo_msg_suffix(t));
	const ndo_net_stats *st = ndo_net_stats_get(rx);
	uint64_t accepted = st->accepted;
	if (!seal) {
		ndo_link_publish(tx, ch, msg, len);
		drain();
		if (st->accepted != accepted)
			__builtin_trap(); /* accepted without the key */
		return 0;
	}
	uint8_t *buf = malloc(len + NDO_AUTH_TRAILER);
	if (!buf)
		return 0;
	if (len)
		memcpy(buf, msg, len);
	ndo_auth_seal(sealer, ch, buf, len);
	ndo_link_publish(tx, ch, buf, len + NDO_AUTH_TRAILER);
	drain();
	uint64_t replays = st->dropped[NDO_DROP_REPLAY];
	ndo_link_publish(tx, ch, buf, len + NDO_AUTH_TRAILER);
	drain();
	free(buf);
	/* the copy is a replay (our own messages too) — unless the message
	 * does not decode: then it never reaches the window (malformed) */
	ndo_msg m;
	int decodes = ndo_msg_decode(t, msg, len, &m) == NDO_DROP_NONE;
	if (decodes)
		ndo_msg_free(&m);
	if (decodes && st->dropped[NDO_DROP_REPLAY] != replays + 1)
		__builtin_trap();
	return 0;
}
