#!/usr/bin/env bash
# The libFuzzer targets (tests/fuzz/), each for a bounded time, from seeds
# made by the real tools: fuzz_gridfile (the grid file reader), fuzz_msg
# (every LCM message decoder and validator, and the receive path with the
# tile decoder, from recorded runs in each tile encoding), fuzz_auth (the
# same behind a session key: unsealed bytes never accepted, a sealed
# message delivered twice dropped once as a replay).  A crash, a
# sanitizer report or a round-trip mismatch fails the case and leaves the
# input in the log.
. "$(dirname "$0")/lib.sh"
# 10 s a target keeps `make test` under its ten minutes (with its sanitizer
# builds remade it took 9 min 28 s with 20 s, 8 min 48 s with 10, on
# 2026-11-30); longer runs: NDO_FUZZ_SECONDS=600.
secs=${NDO_FUZZ_SECONDS:-10}
# record_messages DIR PREFIX FORM: every message of four short owner runs
# (written by LCM's file provider, no network; whole regions every step),
# one per tile encoding, as seeds in DIR: PREFIX (hex, fuzz_auth's flags
# byte), then the bytes that pick the type and, for a tile, the receiver's
# level-3 decoder of that encoding — FORM msg: fuzz_msg.c's (129, then 12,
# 13, 14 or 15 for a tile), auth: fuzz_auth.c's one byte (40 with 13 message
# types: a tile, level 3; the encoding is in PREFIX's bits 2-3, 0-3 for
# float32, fixed, predict and hier) — then the message.  For fuzz_msg a fifth run sends at level 2 (predict,
# --send-level 2): its tiles go through the receiver's coarse decoder.
record_messages() {
	[ -f hier.lcmlog ] || {
		remesh --shape wavy -l 3 -o w3.tgrid
		for enc in float32 fixed predict hier; do
			simulate-peer --lcm "file://$PWD/$enc.lcmlog?mode=w" --owner w3.tgrid \
				-s "$NDO_ROOT/samples/thesis-fig5.3.scene" --dt 0.01 -n 40 --encoding $enc \
				--publish-every 1 -q -o /dev/null
		done
		simulate-peer --lcm "file://$PWD/coarse.lcmlog?mode=w" --owner w3.tgrid \
			-s "$NDO_ROOT/samples/thesis-fig5.3.scene" --dt 0.01 -n 40 --encoding predict \
			--send-level 2 --publish-every 1 -q -o /dev/null
	}
	/usr/bin/python3 - "$1" "$2" "$3" <<'PY' || fail "$(basename "$1") seeds" "no recorded messages"
import struct, sys
suffixes = "DESC TILE POI PARTITION HELLO PEERS LEAVE HEARTBEAT DESC_REQUEST FORCE HALO SOLVE KEY_REQUEST".split()
if sys.argv[3] == "msg":  # 129 then b: level b / 4 = 3, encoding 1 + b % 4
    tile = {"float32": bytes([129, 12]), "fixed": bytes([129, 13]), "predict": bytes([129, 14]),
            "hier": bytes([129, 15]), "coarse": bytes([129, 14])}  # the receiver's send level is 2
else:  # one byte b: type b % (message types) = 1, level b / (message types) = 3
    tile = {enc: bytes([1 + len(suffixes) * 3]) for enc in ("float32", "fixed", "predict", "hier")}
prefix = bytes.fromhex(sys.argv[2])
encs = ["float32", "fixed", "predict", "hier"]
n = 0
for enc, tb in tile.items():
    b = open(f"{enc}.lcmlog", "rb").read()
    o = 0
    while o + 28 <= len(b):
        _, _, _, cl, dl = struct.unpack(">IqqII", b[o:o + 28])
        ch = b[o + 28:o + 28 + cl].decode()
        data = b[o + 28 + cl:o + 28 + cl + dl]
        o += 28 + cl + dl
        t = suffixes.index(ch.split("_", 1)[1])
        # fuzz_auth: the flags byte's bits 2-3 pick the receiver's encoding
        pre = bytes([prefix[0] | encs.index(enc) << 2]) if prefix and enc in encs else prefix
        with open(f"{sys.argv[1]}/{enc}-{n:03d}", "wb") as f:
            f.write(pre + (tb if t == 1 else bytes([t])) + data)
        n += 1
sys.exit(n < len(tile) * 40)
PY
}

for target in "$NDO_TESTBIN"/fuzz_*; do
	[ -x "$target" ] || continue
	name=$(basename "$target")
	mkdir -p "corpus-$name"
	case $name in
	fuzz_gridfile)
		remesh --shape tetra -l 0 -o corpus-$name/tetra0.tgrid
		remesh --shape sphere -l 1 -o corpus-$name/sphere1.tgrid
		remesh --shape wavy -l 2 | subdivide -l 0 -o corpus-$name/wavy2.tgrid
		cat corpus-$name/tetra0.tgrid corpus-$name/sphere1.tgrid >corpus-$name/stream.tgrid
		;;
	fuzz_msg) record_messages "corpus-$name" "" msg ;;
	fuzz_auth) record_messages "corpus-$name" 03 auth ;;  # sealed, the receiver decodes tiles
	esac
	if "$target" -max_total_time="$secs" -max_len=8192 -rss_limit_mb=2048 \
		-print_final_stats=1 "corpus-$name" >fuzz.log 2>&1; then
		runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' fuzz.log | grep -o '[0-9]*$')
		pass "$name: ${runs:-?} inputs in ${secs}s, no crash"
	else
		fail "$name" "crashed or reported a bug"
		grep -E 'ERROR|SUMMARY|Test unit written|runtime error' fuzz.log | head -8 | sed 's/^/    /'
	fi
done
