#!/usr/bin/env bash
# net — what the peers' traffic costs, by level and tile encoding, beside
# the thesis' Table 5.2 (issue 7; docs/net-bench.md):
#   1. net-bench's whole table (levels 4-8 x raw, float32, fixed, predict;
#      2 peers and an observer in lock-step, the thesis' scene for 5 s) and
#      its loss sweep;
#   2. the goal: levels 4-7 with predict and predict:1e-4 (the step from
#      the error budget), 1 simulating peer (the owner streaming to an
#      observer: Table 5.2's setting) and 2: payload, steady state on the
#      wire, the whole run with joins; the error;
#   3. the encodings alone (bench_codec, one process, no network): a full
#      state's encoding and decoding time at levels 4-7, and zstd's level
#      against bits and time at level 7.
# The machine is shared: everything runs under nice; compare within a run.
set -euo pipefail
cd "$(dirname "$0")/../.."
export PATH=$PWD/bin:$PATH
out=docs/bench/net.md
work=build/bench/net
rm -rf "$work" && mkdir -p "$work"
make -s build/tests/bench_codec bin/net-bench >/dev/null
N="nice -n 5"

cmd1="net-bench --csv $work/table.csv"
$N $cmd1 >"$work/table.md" 2>"$work/table.err"

# CSV fields (net-bench --help, tools/net-bench.1): 8 wire bits (steady), 9
# payload bits, 10 whole-run bits, 21 max error, 22 RMS error, 7 exact nodes
goal_rows() {
	for enc in predict predict:1e-4; do
		for l in 4 5 6 7; do
			for p in 1 2; do
				c="net-bench -l $l -e $enc --peers $p --csv -"
				r=$($N $c 2>/dev/null | tail -1)
				IFS=, read -r -a f <<<"$r"
				echo "| $l | $enc | $p | ${f[8]} | ${f[7]} | ${f[9]} | ${f[20]} | ${f[21]} | ${f[6]} | \`$c\` |"
			done
		done
	done
}
goal_rows >"$work/goal.md"

codec_rows() {
	for enc in predict predict:1e-4; do
		for l in 4 5 6 7; do
			for p in 1 2; do
				c="build/tests/bench_codec -l $l -e $enc -p $p -t 5"
				line=$($N $c)
				bits=$(sed -n 's/.*steps: \([0-9.]*\) bits.*/\1/p' <<<"$line")
				times=$(sed -n 's/.*encode \([0-9.]*\) ms, decode \([0-9.]*\) ms (medians; CPU time \([0-9.]*\) + \([0-9.]*\) ms).*/\1 | \2 | \3 + \4/p' <<<"$line")
				err=$(sed -n 's/.*max error \([0-9.e-]*\) of.*/\1/p' <<<"$line")
				echo "| $l | $enc | $p | $bits | $times | $err | \`$c\` |"
			done
		done
	done
}
codec_rows >"$work/codec.md"

zstd_rows() {
	for z in -5 -1 1 3; do
		c="build/tests/bench_codec -l 7 -e predict -p 1 -t 5 -z $z"
		line=$($N $c)
		bits=$(sed -n 's/.*steps: \([0-9.]*\) bits.*/\1/p' <<<"$line")
		times=$(sed -n 's/.*encode \([0-9.]*\) ms, decode \([0-9.]*\) ms.*/\1 | \2/p' <<<"$line")
		echo "| $z | $bits | $times | \`$c\` |"
	done
}
zstd_rows >"$work/zstd.md"

{
	echo "# Network cost of the peers' state (net-bench)"
	echo
	echo "Made by \`tests/bench/net.sh\` on $(date -u +%Y-%m-%d), $(nproc) cores,"
	echo "$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), shared with other work"
	echo "(load average at the end: $(cut -d' ' -f1-3 /proc/loadavg)): times are inflated by it."
	echo "Every net-bench run: the thesis' scene (figure 5.3, the wavy surface, rk4 at 0.9 x its"
	echo "critical step, 5 s), peers in one process over real LCM in a private network"
	echo "namespace, in lock-step, and an observer. \"thesis Mbit/s\" is Table 5.2 (uncompressed)."
	echo "Bits per node per update are over W x H nodes and the owner's steps, as a listener on"
	echo "every channel sees them: *payload* is the state tiles' payload alone, *wire* every"
	echo "message with its message, LCM, UDP and IPv4 headers, both in the steady state (after"
	echo "the last join, before the last step, which goes exact); *whole run* adds the joins"
	echo "(the raw snapshot for a joiner, descriptions) and the exact last step over the run's"
	echo "steps (5 s: a fixed cost that a longer run spreads thinner)."
	echo
	echo "## The table: \`$cmd1\`"
	echo
	cat "$work/table.md"
	echo
	echo "## The goal (issue 7): level 6, ≤ 8 bits per node per update, error ≤ 1e-4 of the diagonal"
	echo
	echo "1 peer is the owner streaming to an observer (Table 5.2's setting: one server, viewers);"
	echo "with 2 the boundary nodes each peer integrates with travel exact (doubles)."
	echo
	echo "| level | encoding | peers | payload bits/node/update | wire (steady) | whole run | max error / diag | RMS error / diag | exact nodes | command |"
	echo "|---:|---|---:|---:|---:|---:|---:|---:|---:|---|"
	cat "$work/goal.md"
	echo
	echo "## The encodings alone: encoding and decoding a full state"
	echo
	echo "\`bench_codec\`: the same scene in one process, no network; sender 1's tiles encoded"
	echo "as the session does and decoded by a receiver, every step; medians over the steps of"
	echo "the sender's whole region (1 peer: the full state), wall clock and this thread's CPU"
	echo "time; bits are sender 1's payload alone (with 2 peers, about half the traffic)."
	echo
	echo "| level | encoding | peers | payload bits/node/update | encode ms | decode ms | CPU ms (enc + dec) | max error / diag | command |"
	echo "|---:|---|---:|---:|---:|---:|---:|---:|---|"
	cat "$work/codec.md"
	echo
	echo "## zstd's level (level 7, predict, 1 peer)"
	echo
	echo "| zstd level | payload bits/node/update | encode ms | decode ms | command |"
	echo "|---:|---:|---:|---:|---|"
	cat "$work/zstd.md"
	echo
	echo "CSV: \`$work/table.csv\` (columns in \`net-bench --help\` and tools/net-bench.1)."
} >"$out"
cat "$out"
