#!/usr/bin/env bash
# The peers' options refused with one line and exit 2, before any network
# traffic: a joiner does not take physics, input or the owner's choices;
# values out of range; peer options without a role; render-frame's LCM
# options; session keys (made, refused, named), and a keyed recording
# replayed with, without and with another key.
. "$(dirname "$0")/lib.sh"

remesh --shape sphere -l 3 -o s3.tgrid 2>/dev/null || fail "remesh"

expect_error "--owner and --join" 2 'one or the other' simulate-peer --owner --join s3.tgrid
expect_error "a joiner with an input" 2 "s3.tgrid': a joiner receives the object" \
	simulate-peer --join s3.tgrid
expect_error "a joiner with physics" 2 '^simulate-peer: --stiffness: a joiner takes the physics' \
	simulate-peer --join -k 2
expect_error "a joiner with a scene" 2 '^simulate-peer: --scene: a joiner takes the physics' \
	simulate-peer --join -s "$NDO_ROOT/samples/thesis-fig5.3.scene"
expect_error "a joiner choosing the clock" 2 '^simulate-peer: --clock: the owner decides it' \
	simulate-peer --join --clock realtime
expect_error "peer options alone" 2 'the peers. options need --owner or --join' \
	simulate-peer --poi 3 s3.tgrid
expect_error "--drop out of range" 2 '--drop' simulate-peer --owner s3.tgrid --drop 1.5
expect_error "--peers out of range" 2 '--peers' simulate-peer --owner s3.tgrid --peers 9
expect_error "--checkpoint-every negative" 2 '--checkpoint-every' \
	simulate-peer --owner s3.tgrid --checkpoint-every -1
expect_error "a joiner choosing checkpoints" 2 '^simulate-peer: --checkpoint-every: the owner decides it' \
	simulate-peer --join --checkpoint-every 5
expect_error "--publish-every 0s" 2 '--publish-every: 0 is outside' \
	simulate-peer --owner s3.tgrid --publish-every 0s
expect_error "--publish-every in seconds without the s" 2 \
	"--publish-every: '0.05' is not a whole number of steps \(seconds of simulated time: 0.05s\)" \
	simulate-peer --owner s3.tgrid --publish-every 0.05
expect_error "--publish-every not a number" 2 "--publish-every: 'x' is not a finite number" \
	simulate-peer --owner s3.tgrid --publish-every xs
# a rate: the nearest whole number of steps, at least one
for case in "0.05s 5 steps" "0.034s 3 steps" "0.004s 1 step"; do
	set -- $case
	out=$(simulate-peer --owner s3.tgrid --dt 0.01 --publish-every "$1" --info 2>&1)
	if grep -q "whole regions every $2 $3 " <<<"$out"; then
		pass "--publish-every $1 at a step of 0.01 s: every $2 $3"
	else
		fail "--publish-every $1" "$out"
	fi
done
# --publish-rate (30 by default, at least 10 steps): the steps of 1/R s at the
# run's predicted speed, rounded up; the prediction is counted (rk4: 33 ns a
# node-step, times the peers), so these are exact on any machine.  With the
# owner's --frames every F steps, a divisor of F (F when the largest under the
# rate's is less than half of it), so that the owner's frames are whole.
expect_error "--publish-rate 0" 2 '--publish-rate: 0 is outside' \
	simulate-peer --owner s3.tgrid --publish-rate 0
expect_error "--publish-rate with --publish-every" 2 '^simulate-peer: --publish-every and --publish-rate: one or the other' \
	simulate-peer --owner s3.tgrid --publish-rate 5 --publish-every 3
expect_error "a joiner choosing the frame rate" 2 '^simulate-peer: --publish-rate: the owner decides it' \
	simulate-peer --join --publish-rate 5
# interval_case GRID NAME "OPTIONS::WANT": the owner's --info with OPTIONS
# prints "whole regions every WANT"
interval_case() {
	local opts=${3%%::*} want=${3#*::} out
	# shellcheck disable=SC2086
	out=$(simulate-peer --owner "$1" $opts --info 2>&1)
	if grep -qF "whole regions every $want" <<<"$out"; then
		pass "$2${opts:+, $opts}: every $want"
	else
		fail "$2${opts:+, $opts}" "$out"
	fi
}
for case in "::6602 steps (about 30 a second at the predicted 1.98e+05 steps/s" \
	"--peers 2::13204 steps (about 30 a second at the predicted 3.96e+05" \
	"--publish-rate 1e6::1 step (about 1.98e+05 a second" \
	"--clock realtime --dt 0.01 --publish-rate 20::5 steps (about 20 a second at the predicted 100 steps/s" \
	"--frames f/%d.tgrid --frame-every 20::20 steps (about 9.9e+03 a second at the predicted 1.98e+05 steps/s, up to 80 MB a second; --publish-rate 30, to suit --frame-every)" \
	"--frames f/%d.tgrid --frame-every 100000::6250 steps (about 31.7 a second" \
	"--frames f/%d.tgrid --frame-every 999999937::999999937 steps (" \
	"--frames f/%d.tgrid --frame-every 30 --publish-rate 1e5::2 steps ("; do
	interval_case s3.tgrid "--publish-rate, level 3" "$case"
done
# and by default at most 100 MB a second of whole regions over the object,
# counted as its nodes (of --send-level) times a node's bytes in the
# encoding, and a tenth more: level 8 (131,074 nodes) raw at 1.1 × 48 bytes a
# node is 6.92 MB a frame, 30 a second would be 200 MB/s with 2 peers
remesh --shape wavy -l 8 -o w8.tgrid 2>/dev/null || fail "remesh"
for case in "::16 steps (about 14.4 a second at the predicted 230 steps/s, up to 100 MB a second; --publish-rate 30, and by default at most 100 MB a second)" \
	"--peers 2::32 steps (about 14.4 a second at the predicted 460 steps/s, up to 100 MB a second; --publish-rate 30, and by default at most 100 MB a second)" \
	"--peers 8::128 steps (" \
	"--peers 2 --publish-rate 30::16 steps (about 28.7 a second at the predicted 460 steps/s, up to 200 MB a second; --publish-rate 30)" \
	"--peers 2 --encoding float32::16 steps (about 28.7 a second at the predicted 460 steps/s, up to 50 MB a second; --publish-rate 30)" \
	"--peers 8 --encoding fixed:1e-4::62 steps (about 29.7 a second at the predicted 1.84e+03 steps/s, up to 24.2 MB a second; --publish-rate 30)" \
	"--peers 8 --send-level 7::62 steps (about 29.7 a second at the predicted 1.84e+03 steps/s, up to 51.6 MB a second; --publish-rate 30)"; do
	interval_case w8.tgrid "the frames' byte budget, level 8" "$case"
done
# realtime at 100 steps/s: 4 steps would do, the default keeps 10 (no line)
out=$(simulate-peer --owner s3.tgrid --clock realtime --dt 0.01 --info 2>&1)
if grep -q "whole regions every" <<<"$out"; then
	fail "the default frame interval's floor of 10 steps" "$out"
else
	pass "the default frame interval's floor of 10 steps (realtime, 100 steps/s)"
fi
expect_error "--partition unknown" 2 "--partition: 'spiral' is not quadtree, table41, metis or bands" \
	simulate-peer --owner s3.tgrid --partition spiral
expect_error "--clock unknown" 2 "--clock: 'wall' is not lockstep or realtime" \
	simulate-peer --owner s3.tgrid --clock wall
expect_error "--boundary unknown" 2 "--boundary: 'fixed' is not exact, extrapolate or hold" \
	simulate-peer --owner s3.tgrid --boundary fixed
expect_error "--precondition unknown" 2 "--precondition: 'ilu' is not diagonal or block" \
	simulate-peer --join --precondition ilu
# realtime rolls back the fixed-step explicit methods only: the others are
# refused unless an inexact boundary is asked for
expect_error "realtime trapezoid" 2 '^simulate-peer: --clock realtime: trapezoid does not roll back' \
	simulate-peer --owner s3.tgrid -i trapezoid --clock realtime --info
expect_error "realtime rkf45, exact asked" 2 '^simulate-peer: --clock realtime: rkf45 does not roll back' \
	simulate-peer --owner s3.tgrid -i rkf45 --clock realtime --boundary exact --info
check "realtime trapezoid with --boundary extrapolate" \
	simulate-peer -q --owner s3.tgrid -i trapezoid --dt 0.01 --clock realtime --boundary extrapolate --info
expect_error "--channel with a regex" 2 "--channel: 'A.B'" simulate-peer --owner s3.tgrid --channel A.B
expect_error "--poi beyond the grid" 2 '--poi: face 256 is outside 0..255 for a level-3 grid' \
	simulate-peer -q --owner s3.tgrid --poi 256 -o x.tgrid

expect_error "render-frame: --lcm not a URL" 2 "--lcm: 'run.lcmlog' is not udpm://" \
	render-frame --lcm run.lcmlog -o x.png
expect_error "render-frame: --lcm and files" 2 "'s3.tgrid': --lcm draws the peers' state" \
	render-frame --lcm file://x.lcmlog -o x.png s3.tgrid
expect_error "render-frame: --every without --lcm" 2 'go with --lcm' \
	render-frame --every 5 -o x.png s3.tgrid
expect_error "render-frame: --every 0" 2 '--every' render-frame --lcm default --every 0 -o x.png

# Session keys (issue 16): refused before any traffic, with the cause.
rm -f new.key
check "--new-key alone writes a key" simulate-peer --new-key new.key
if [ "$(stat -c %a new.key)" = 600 ] && grep -Eqx '[0-9a-f]{64}' new.key; then
	pass "the new key: 64 hex digits, mode 600"
else
	fail "the new key" "mode $(stat -c %a new.key), $(wc -c <new.key) bytes"
fi
expect_error "--new-key never overwrites" 1 'new.key: File exists' simulate-peer --new-key new.key
expect_error "a joiner making a key" 2 "--new-key: a joiner uses the owner's key" \
	simulate-peer --join --new-key other.key
expect_error "--key without a role" 2 'the peers. options need --owner or --join' \
	simulate-peer --key new.key s3.tgrid
cp new.key open.key && chmod 644 open.key
expect_error "a key others may read" 1 'open.key: others may read this key \(mode 644\): chmod 600' \
	simulate-peer -q --owner s3.tgrid --key open.key -o x.tgrid
printf 'not a key\n' >bad.key && chmod 600 bad.key
expect_error "a key file without a key" 1 'bad.key: not a session key' \
	simulate-peer -q --owner s3.tgrid --key bad.key -o x.tgrid
expect_error "a bad \$NDO_KEY" 1 'NDO_KEY: not a session key' \
	env NDO_KEY=1234 simulate-peer -q --owner s3.tgrid -o x.tgrid
rm -f other.key; simulate-peer --new-key other.key 2>/dev/null
expect_error "render-frame: --key without --lcm" 2 'go with --lcm' \
	render-frame --key new.key -o x.png s3.tgrid

# Open and keyed sessions, recorded by LCM's file provider (no network).
simulate-peer --lcm "file://$PWD/open.lcmlog?mode=w" --owner s3.tgrid -n 3 -o x.tgrid 2>open.err
if [ "$(grep -c 'no session key (--key FILE or \$NDO_KEY): anyone on the network can join' open.err)" = 1 ]; then
	pass "an open session says once that anyone can join and write"
else
	fail "an open session's warning" "$(grep -c anyone open.err) times"
fi
simulate-peer --lcm "file://$PWD/keyed.lcmlog?mode=w" --owner s3.tgrid -n 3 --key new.key -o x.tgrid 2>keyed.err
id=$(grep -o 'keyed session (key id [0-9a-f]*' keyed.err | grep -o '[0-9a-f]*$')
if [ -n "$id" ] && ! grep -q anyone keyed.err && ! grep -qf new.key keyed.err; then
	pass "a keyed session names its key id ($id), never the key"
else
	fail "a keyed session's note" "$(head -3 keyed.err)"
fi
expect_error "render-frame: a keyed log without the key" 1 'give its key \(--key FILE or \$NDO_KEY\)' \
	render-frame --lcm "file://$PWD/keyed.lcmlog" -o 'k%d.png'
check "render-frame: a keyed log with its key" render-frame --lcm "file://$PWD/keyed.lcmlog" --key new.key -o 'k%d.png'
if ls k*.png >/dev/null 2>&1; then pass "the keyed log's frames drawn"; else fail "the keyed log's frames"; fi
expect_error "render-frame: a keyed log with another key" 1 'failed authentication \(unsigned 0, wrong key [1-9]' \
	render-frame --lcm "file://$PWD/keyed.lcmlog" --key other.key -o 'o%d.png'
