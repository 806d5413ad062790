#!/usr/bin/env bash
# tests/bench/simulate.sh — simulate-peer's speed: node-steps per second of
# every integrator at levels 5-8, Bullet's soft bodies on the same mesh in
# the same run, and how close the RK4 stencil kernel comes to this
# machine's memory bandwidth and arithmetic limits.  Writes
# docs/bench/simulate.md.
set -euo pipefail
cd "$(dirname "$0")/../.."
B=${NDO_TESTBIN:-build/tests}
out=docs/bench/simulate.md
mkdir -p docs/bench build/bench
t=build/bench/simulate
# The kernel three times, spread over the run (one call's seven trials
# fall within a second or two, and this shared machine's speed drifts over
# longer times: one level-8 call gave 169 steps/s where the next gave
# 224-245), each level's row the one with the median steps/s.
"$B/bench_simulate" kernel 5 6 7 8 >"$t-kernel1.md"
"$B/bench_simulate" speed 5 6 7 8 >"$t-speed.md"
"$B/bench_simulate" kernel 5 6 7 8 >"$t-kernel2.md"
"$B/bullet_softbody" 5 6 7 8 >"$t-bullet.md"
"$B/bench_simulate" limits >"$t-limits.md"
"$B/bench_simulate" kernel 5 6 7 8 >"$t-kernel3.md"
{
	head -n 2 "$t-kernel1.md"
	for l in 5 6 7 8; do
		cat "$t-kernel1.md" "$t-kernel2.md" "$t-kernel3.md" |
			awk -F'|' -v l="$l" '$2 == " " l " " { v = $5; gsub(/ /, "", v); print v "\t" $0 }' |
			sort -g | sed -n 2p | cut -f2-
	done
} >"$t-kernel.md"

# The goal and the ratios, from the tables of this run.
rk4_6=$(awk -F'|' '$2 ~ /^ rk4 $/ && $3 == " 6 " { gsub(/ /, "", $6); print $6 }' "$t-speed.md")
cell() { awk -F'|' -v k="$2" '$2 ~ k { gsub(/ [A-Za-z\/]+ *$/, "", $3); gsub(/ /, "", $3); print $3 }' "$1"; }
l2=$(cell "$t-limits.md" 'triad, 256 KiB')
l3=$(cell "$t-limits.md" 'triad, 2 MiB')
# a core's own L2 (level 6's 1.9 MiB of state fit it on some machines, not on others)
l2core=$(cat /sys/devices/system/cpu/cpu0/cache/index2/size 2>/dev/null || echo "?")
avx2=$(cell "$t-limits.md" 'FMA, AVX2')
sse2=$(cell "$t-limits.md" 'SSE2')
kern() { awk -F'|' -v l="$1" -v c="$2" '$2 == " " l " " { gsub(/ /, "", $c); print $c }' "$t-kernel.md"; }
summary=$(awk -v s="$rk4_6" -v l2="$l2" -v l3="$l3" -v avx2="$avx2" -v sse2="$sse2" -v l2core="$l2core" \
	-v g5="$(kern 5 6)" -v b5="$(kern 5 7)" -v g6="$(kern 6 6)" -v b6="$(kern 6 7)" \
	-v g7="$(kern 7 6)" -v g8="$(kern 8 6)" 'BEGIN {
	printf "- Goal: rk4 at level 6 (8,194 nodes) at 2,000 steps/s or more on one core.  Measured: **%.0f steps/s** (%.3g node-steps/s): %s.\n",
		s, s * 8194, (s >= 2000 ? "met" : "NOT met")
	printf "- The RK4 kernel at level 5 (its 0.5 MiB of state in L2) moves %.1f GB/s, %.0f%% of the STREAM-like triad from L2 (%.1f GB/s), and computes %.1f GFLOP/s, %.0f%% of the AVX2 FMA peak (%.1f GFLOP/s).\n",
		b5, 100 * b5 / l2, l2, g5, 100 * g5 / avx2, avx2
	printf "- At level 6 (1.9 MiB of state; a core'"'"'s L2 here: %s) it moves %.1f GB/s, %.0f%% of the triad over 2 MiB arrays (%.1f GB/s), at %.1f GFLOP/s (%.0f%% of the AVX2 peak; %.0f%% of the SSE2 peak, the baseline build).\n",
		l2core, b6, 100 * b6 / l3, l3, g6, 100 * g6 / avx2, 100 * g6 / sse2
	r = 0.26 * l2
	printf "- Roofline: a node-step streams about 1.3 KB (41 doubles per pass, 4 passes) for 342 flops, 0.26 flop/byte, below this machine'"'"'s balance of %.2f flop/byte (AVX2 peak / L2 triad): the kernel is on the memory-bound side, where %.1f GFLOP/s would be attainable from L2.  It reaches **%.0f%%** of that at level 5, **%.0f%%** at 6, **%.0f%%** at 7 and **%.0f%%** at 8 (issue 19: 60%% or more at levels 6-8: %s).\n",
		avx2 / l2, r, 100 * g5 / r, 100 * g6 / r, 100 * g7 / r, 100 * g8 / r,
		(g6 >= 0.6 * r && g7 >= 0.6 * r && g8 >= 0.6 * r ? "met" : "NOT met")
}')

# Dated notes (changes measured in paired runs, by hand) are kept from
# the last file.
notes=$(awk '/^## Notes \(dated\)/ { f = 1 } f' "$out" 2>/dev/null || true)

{
	echo "# simulate-peer: speed"
	echo
	echo "Made by \`make bench\` (\`tests/bench/simulate.sh\`) on $(date -u +%Y-%m-%d), $(nproc) cores" \
		"($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')), one thread," \
		"load average $(cut -d' ' -f1-3 /proc/loadavg) at the end (the machine is shared: medians of 7 runs, ratios within this run)."
	if awk -v l="$(cut -d' ' -f1 /proc/loadavg)" -v n="$(nproc)" 'BEGIN { exit !(l > n) }'; then
		echo "The load was above the core count: the wall-clock tables (integrators, Bullet) and the goal line"
		echo "measure the share of a core this run got, not the code; the machine limits and the RK4 kernel are in CPU time."
	fi
	echo
	echo "## Summary"
	echo
	echo "$summary"
	echo
	echo "## Integrators"
	echo
	echo "The thesis scene (figure 5.3: the wavy surface, k = 1 N/m, b = 0.1, a 2.4 N sinusoidal force on the faces around (0, 0, 1)); each explicit method at half its own critical step, the implicit ones at half RK4's.  Nodes are distinct vertices."
	echo
	cat "$t-speed.md"
	echo
	echo "## Bullet soft bodies on the same mesh"
	echo
	echo "\`tests/bench/bullet_softbody.cpp\`: Debian's Bullet 3.24 (double precision), the same distinct vertices and triangles, 1 ms steps, no gravity, no collisions."
	echo
	cat "$t-bullet.md"
	echo
	echo "## Machine limits, measured in the same run"
	echo
	echo "STREAM-like loops compiled for AVX2 (copy counts 16 bytes per element, triad 24) and multiply-add chains in registers, timed in CPU time."
	echo
	cat "$t-limits.md"
	echo
	echo "## The RK4 kernel"
	echo
	echo "342 flops and 1,312 bytes of compulsory traffic per node-step (counted in \`tests/bench/bench_simulate.c\`), times the steps per second of CPU time, like the machine limits above (a busy machine takes the core away, which would otherwise count against the kernel); each level's row is the one with the median steps/s of three calls of \`bench_simulate kernel\`, at the start, in the middle and at the end of this run, each call the median of 7 trials of at least 0.1 s.  One thread; where every node is integrated, as here, the four stages run as one pipeline over chunks of rows (\`lib/sim/rk4.c\`)."
	echo
	cat "$t-kernel.md"
	if [ -n "$notes" ]; then
		echo
		echo "$notes"
	fi
} >"$out"
cat "$out"
