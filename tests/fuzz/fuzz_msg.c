/* fuzz_msg — random bytes into every decoder and validator (ndo/msg.h)
 * and through ndo_net's receive path (sequence checks, tile store).
 * The first byte picks the message type ((byte & 0x7f) % NDO_MSG_NTYPES);
 * with its high bit set a second byte follows, and the receiver decodes
 * tiles in encoding 1 + b % 4 at level (b / 4) % 8 and takes the message's
 * object as its own, so a recorded tile is accepted (tests/e2e/fuzz.sh
 * seeds the corpus from recorded runs: 129 then 12, 13, 14 and 15 are a
 * level-3 float32, fixed, predict and hier tile).  The receiver's send level is one
 * level below the object's (tiles with NDO_TILE_COARSE go through its
 * second decoder).  The rest is the message.
 *   build/asan/tests/fuzz_msg -max_total_time=60 */
#include "ndo/msg.h"
#include "ndo/net.h"

#include "drain.h"

#include <stdlib.h>
#include <string.h>

/* The receiver passes over raw tiles of odd steps (ndo_net_set_tile_want:
 * their bytes peeked, not decoded) and decodes the others. */
static int even_steps(void *user, int32_t sender, int64_t step, int channels)
{
	(void)user, (void)sender, (void)channels;
	return (step & 1) == 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	if (size < 1)
		return 0;
	ndo_msg_type t = (ndo_msg_type)((data[0] & 0x7f) % NDO_MSG_NTYPES);
	const int coded = (data[0] & 0x80) && size >= 2;
	const uint8_t how = coded ? data[1] : 0;
	const size_t skip = coded ? 2 : 1;
	ndo_msg m;
	int64_t object = 42;
	if (ndo_msg_decode(t, data + skip, size - skip, &m) == NDO_DROP_NONE) {
		object = m.hdr->object_id;
		for (int level = -1; level <= 10; level += 3) {
			ndo_msg_ctx c = {.object_id = m.hdr->object_id, .level = level, .self_id = 99,
			                 .coarse = level > 0 ? level % 3 : 0};
			ndo_msg_validate(&m, &c);
		}
		ndo_msg_free(&m);
	}
	/* the same bytes as they would arrive from LCM */
	static ndo_bus *bus;
	static ndo_link *tx;
	static ndo_net *rx;
	if (!bus) {
		ndo_link *l;
		ndo_bus_create(&bus);
		ndo_link_open_mem(bus, &tx);
		ndo_link_open_mem(bus, &l);
		ndo_net_create(l, "F", 99, &rx);
		ndo_net_set_tile_want(rx, even_steps, NULL);
		ndo_net_ask_keys(rx, 1); /* held tiles: keyframe requests published */
	}
	char ch[32];
	strcpy(ch, "F_");
	strcat(ch, ndo_msg_suffix(t));
	ndo_link_publish(tx, ch, data + skip, size - skip);
	if (coded) {
		/* encoded tiles go through the decoder (ndo/codec.h) */
		const int level = (how / 4) % 8;
		ndo_codec_params cp = {.encoding = 1 + how % 4, .bits = 13, .keyframe = 32,
		                       .lo = {-1, -1, -1}, .ext = {2, 2, 2}};
		ndo_net_set_codec(rx, &cp, level);
		ndo_net_set_send_level(rx, level > 0 ? level - 1 : 0, level);
		ndo_net_attach(rx, object, level);
	}
	fuzz_drain(rx, tx);
	return 0;
}
