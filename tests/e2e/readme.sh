#!/usr/bin/env bash
# README.md is true: its examples' inputs are made by an earlier line, a
# frame pattern's directory is made, a failed run leaves no temporary file.
. "$(dirname "$0")/lib.sh"
R=$NDO_ROOT/README.md

# Every grid file a README line reads (an argument ending in .tgrid that is
# not the value of -o or a pattern) is written by an earlier line (-o FILE).
missing=$(awk '/^```sh/ { on = 1; next } /^```/ { on = 0 } on && !/^#/' "$R" | sed 's/\\$//' | awk '
	{ for (i = 1; i <= NF; i++) {
		if (($i == "-o" || $i == "--output") && i < NF) { made[$(i + 1)] = 1; i++; continue }
		if ($i ~ /\.tgrid$/ && $i !~ /[%*]/ && $(i - 1) != "--frames" && !($i in made)) print $i
	} }' | sort -u | tr '\n' ' ')
if [ -z "$missing" ]; then pass "every grid a README example reads is made by an earlier line"
else fail "README inputs" "read before any line makes them: $missing"; fi

# The README's frame example, small: out/ does not exist beforehand.
remesh --shape wavy -l 2 -o wavy.tgrid
if simulate-peer -q -s "$NDO_ROOT/samples/thesis-fig5.3.scene" wavy.tgrid -n 20 \
	--frames 'out/f%04d.tgrid' --frame-every 10 --log run.csv -o end.tgrid 2>sim.err &&
	[ -s out/f0002.tgrid ] && [ -s run.csv ] && [ -s end.tgrid ]; then
	pass "--frames 'out/f%04d.tgrid' makes out/"
else fail "--frames into a new directory" "$(head -2 sim.err)"; fi
if render-frame -s 64x48 -o 'pics/deep/f%04d.png' out/f0000.tgrid out/f0001.tgrid 2>rf.err &&
	[ -s pics/deep/f0001.png ]; then pass "render-frame -o 'pics/deep/f%04d.png' makes pics/deep/"
else fail "render-frame into a new directory" "$(head -2 rf.err)"; fi

# A run that fails after it opened its log leaves no run.csv.tmp.* behind
# (a file stands where the frames' directory should be).
: >blocked
expect_error "frames under a file: one line" 1 'blocked' simulate-peer -q wavy.tgrid -n 5 \
	--frames 'blocked/f%04d.tgrid' --log failed.csv -o never.tgrid
left=$(ls -a | grep -E '\.tmp\.' | tr '\n' ' ')
if [ -z "$left" ] && [ ! -e never.tgrid ]; then pass "a failed run leaves no temporary file"
else fail "a failed run leaves no temporary file" "left: $left"; fi
