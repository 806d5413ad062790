#!/usr/bin/env bash
# The libFuzzer targets (tests/fuzz/), each for a bounded time, from seeds
# made by the real tools where there are any: fuzz_gridfile (the grid file
# reader), fuzz_msg (every LCM message decoder and validator, and the
# receive path).  A crash, a sanitizer report or a round-trip
# mismatch fails the case and leaves the input in the log.
. "$(dirname "$0")/lib.sh"
secs=${NDO_FUZZ_SECONDS:-20}
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
