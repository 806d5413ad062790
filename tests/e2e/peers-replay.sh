#!/usr/bin/env bash
# Record and replay, in a private network namespace: lcm-logger records a
# two-peer run while render-frame draws it live from the channel; then
# render-frame draws the recorded log; the frames must be the same,
# pixel for pixel, and coloured by owner.  The replay always reports what
# it drew and skipped; a log cut short plays up to its last complete step;
# a corrupt or foreign log is an error of one line.
. "$(dirname "$0")/netns.bash"
. "$(dirname "$0")/lib.sh"

SCENE=$NDO_ROOT/samples/thesis-fig5.3.scene
CHECK="/usr/bin/python3 $NDO_ROOT/tests/e2e/render_check.py"
URL='udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304'
remesh --shape wavy -l 4 -o wavy4.tgrid 2>/dev/null || fail "remesh"
mkdir -p live replay owner

# Debian 12's lcm-logger wants --lcm-url=URL (its -l is not recognised)
lcm-logger -q --lcm-url="$URL" -f run.lcmlog >logger.err 2>&1 &
logger=$!
render-frame --lcm "$URL" --every 5 -s 200x150 -o 'live/f%04d.png' -v 2>live.err &
live=$!
sleep 0.3 # both listening before the owner speaks
# The thesis' reference mode (every step's whole regions): lcm-logger (LCM
# 1.3.1, a subscription queue of 30 messages) loses tiles of an exact
# lock-step run, whose halos come faster than it writes — two loggers side
# by side lose different ones, while render-frame gets all (docs/peers.md).
simulate-peer -q --lcm "$URL" --owner wavy4.tgrid -s "$SCENE" -t 2 --peers 2 -o run.tgrid \
	--boundary hold \
	2>owner.err &
owner=$!
simulate-peer -q --lcm "$URL" --join --poi 300 2>joiner.err &
joiner=$!
wait $owner; ro=$?
wait $joiner; rj=$?
wait $live; rl=$?
kill -INT $logger; wait $logger 2>/dev/null
[ $ro = 0 ] && [ $rj = 0 ] && [ $rl = 0 ] && [ -s run.lcmlog ] &&
	pass "a run recorded by lcm-logger and drawn live: $(ls live | wc -l) frames" ||
	fail "record" "owner $ro, joiner $rj, live render-frame $rl, log $(stat -c %s run.lcmlog 2>/dev/null)"

check "replay the log" render-frame --lcm file://run.lcmlog --every 5 -s 200x150 \
	-o 'replay/f%04d.png'
n=0 same=0
for f in live/*.png; do
	n=$((n + 1))
	$CHECK compare "$f" "replay/$(basename "$f")" --mean 0 --p99 0 >/dev/null && same=$((same + 1))
done
[ "$(ls replay | wc -l)" = "$n" ] && [ $n -ge 3 ] && [ $same = $n ] &&
	pass "the replayed log renders the live frames, pixel for pixel ($n frames, steps $(ls live | sed 's/^f0*\([0-9]\)/\1/; s/\.png$//' | tr '\n' ' '| sed 's/ $//'))" ||
	fail "replay = live" "$same of $n live frames equal; replay made $(ls replay | wc -l)"

# coloured by owner: the default is the owner colouring, not a solid colour
render-frame --lcm file://run.lcmlog --every 10 -s 200x150 --color-by owner -o 'owner/o%04d.png' &&
	render-frame --lcm file://run.lcmlog --every 10 -s 200x150 --color-by solid -o 'owner/s%04d.png'
if $CHECK compare owner/o0010.png replay/f0010.png --mean 0 --p99 0 >/dev/null &&
	! $CHECK compare owner/s0010.png replay/f0010.png --mean 1 --p99 20 >/dev/null 2>&1; then
	pass "frames from LCM are coloured by owner"
else
	fail "frames from LCM are coloured by owner"
fi

# the last frame holds the owner's result
step=$(/usr/bin/python3 "$NDO_ROOT/tests/e2e/tgrid.py" run.tgrid step)
if [ $((step % 5)) = 0 ]; then last=$step; else last=$((step / 5 * 5)); fi
[ -e "live/f$(printf %04d "$last").png" ] && pass "frames up to step $last of $step" ||
	fail "frames up to the last step" "no live/f$(printf %04d "$last").png"

# the replay always says how many frames it drew and skipped, and why it ended
mkdir -p again
render-frame --lcm file://run.lcmlog --every 5 -s 200x150 -o 'again/f%04d.png' 2>again.err
if grep -Eq "^render-frame: file://run.lcmlog: $n frames of object [0-9a-f]+, 0 skipped incomplete \(lost tiles\); the owner quit" again.err; then
	pass "the replay reports its frames, those skipped and why it ended, without -v"
else
	fail "the replay's report" "$(cat again.err)"
fi

# a log that missed 20 state tiles in a row: by default those steps are
# skipped and counted; --hold-lost draws them too, the lost nodes at the last
# frame's values, and says for each what share was held
/usr/bin/python3 - run.lcmlog lossy.lcmlog <<'PY'
import struct, sys
data = open(sys.argv[1], 'rb').read()
out, pos, tiles = bytearray(), 0, 0
while pos + 28 <= len(data):
    sync, num, ts, clen, dlen = struct.unpack('>IqqII', data[pos:pos + 28])
    end = pos + 28 + clen + dlen
    chan = data[pos + 28:pos + 28 + clen]
    if chan.endswith(b'_TILE'):
        tiles += 1
        if 20 <= tiles < 40:
            pos = end
            continue
    out += data[pos:end]
    pos = end
open(sys.argv[2], 'wb').write(out)
PY
render-frame --lcm file://lossy.lcmlog --every 5 -s 200x150 -o 'lossy/f%04d.png' 2>lossy.err
render-frame --lcm file://lossy.lcmlog --every 5 --hold-lost -s 200x150 -o 'held/f%04d.png' 2>held.err
skipped=$(sed -n 's/.* \([0-9]*\) skipped incomplete.*/\1/p' lossy.err)
drawn=$(ls lossy/*.png 2>/dev/null | wc -l) held=$(ls held/*.png 2>/dev/null | wc -l)
lines=$(grep -c 'lost tiles: [0-9.]*% of the nodes held at an earlier frame' held.err)
if [ "${skipped:-0}" -ge 1 ] && [ $((drawn + skipped)) = "$n" ] && [ "$held" = "$n" ] &&
	[ "$lines" = "$skipped" ] && grep -q "drawn with lost tiles held" held.err; then
	pass "lost tiles: $skipped of $n steps skipped and counted; --hold-lost draws all $n, the share held printed"
else
	fail "--hold-lost" "skipped '$skipped', drawn $drawn, held $held of $n, $lines lines: $(tail -1 held.err)"
fi

# a log cut short (lcm-logger killed, a copy interrupted) plays up to its
# last complete step, the same frames as the whole log, and says where it
# was cut
size=$(stat -c %s run.lcmlog)
head -c $((size * 6 / 10)) run.lcmlog >cut60.lcmlog
mkdir -p cut
render-frame --lcm file://cut60.lcmlog --every 5 -s 200x150 -o 'cut/f%04d.png' 2>cut.err; rc=$?
k=0 same=0
for f in cut/*.png; do
	k=$((k + 1))
	$CHECK compare "$f" "replay/$(basename "$f")" --mean 0 --p99 0 >/dev/null && same=$((same + 1))
done
if [ $rc = 0 ] && [ $k -ge 1 ] && [ $k -lt $n ] && [ $same = $k ] &&
	grep -q "the end of the log, cut short at byte" cut.err; then
	pass "a log cut at 60 %: $k of $n frames, each the whole log's, and where it was cut"
else
	fail "a log cut at 60 %" "exit $rc, $k frames ($same equal) of $n: $(tail -1 cut.err)"
fi
head -c 3000 run.lcmlog >cut.lcmlog
printf 'garbage that is no LCM log at all' >bad.lcmlog
expect_error "a log cut before its first frame" 1 'no complete frame: .*cut short at byte' \
	render-frame --lcm file://cut.lcmlog -o x.png
expect_error "not a log" 1 'bad.lcmlog: no LCM event at byte 0' \
	render-frame --lcm file://bad.lcmlog -o x.png
expect_error "a missing log" 1 'missing.lcmlog: No such file' \
	render-frame --lcm file://missing.lcmlog -o x.png
lcm-logger -q --lcm-url="$URL" -f empty.lcmlog >/dev/null 2>&1 & logger=$!
sleep 0.3; kill -INT $logger; wait $logger 2>/dev/null
expect_error "a log without a run" 1 'no complete frame' \
	render-frame --lcm file://empty.lcmlog -o x.png
