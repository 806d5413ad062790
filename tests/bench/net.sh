#!/usr/bin/env bash
# net — what the peers' traffic costs, by level and tile encoding, beside
# the thesis' Table 5.2 (issue 7; docs/net-bench.md):
#   1. net-bench's whole table (levels 4-8 x raw, float32, fixed, predict;
#      2 peers and an observer in lock-step, the thesis' scene for 5 s) and
#      its loss sweep;
#   2. the goal: level 6 with predict, 1 and 2 simulating peers (bits per
#      node per update, error), and a full level-7 state's encoding plus
#      decoding time (1 peer: every node encoded once and decoded once).
set -euo pipefail
cd "$(dirname "$0")/../.."
export PATH=$PWD/bin:$PATH
out=docs/bench/net.md
work=build/bench/net
rm -rf "$work" && mkdir -p "$work"

cmd1="net-bench --csv $work/table.csv"
$cmd1 >"$work/table.md" 2>"$work/table.err"
cmd2="net-bench -l 6 -e predict --peers 1 --csv -"
$cmd2 2>/dev/null | tail -1 >"$work/goal1.csv"
cmd3="net-bench -l 6 -e predict --peers 2 --csv -"
$cmd3 2>/dev/null | tail -1 >"$work/goal2.csv"
cmd4="net-bench -l 7 -e predict --peers 1 --csv -"
$cmd4 2>/dev/null | tail -1 >"$work/goal3.csv"
field() { cut -d, -f"$2" "$1"; } # 8 bits, 11 max error, 13 encode ms, 14 decode ms
{
	echo "# Network cost of the peers' state (net-bench)"
	echo
	echo "Made by \`tests/bench/net.sh\` on $(date -u +%Y-%m-%d), $(nproc) cores,"
	echo "$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), shared with other work."
	echo "Every run: the thesis' scene (figure 5.3, the wavy surface, rk4 at 0.9 x its"
	echo "critical step, 5 s), peers in one process over real LCM in a private network"
	echo "namespace, in lock-step. \"thesis Mbit/s\" is Table 5.2 (uncompressed)."
	echo
	echo "## The table: \`$cmd1\`"
	echo
	cat "$work/table.md"
	echo
	echo "## The goal (issue 7)"
	echo
	echo "| figure | goal | measured | command |"
	echo "|---|---|---|---|"
	echo "| level 6, predict, 1 peer: bits per node per update | ≤ 8 | $(field "$work/goal1.csv" 8) | \`$cmd2\` |"
	echo "| ... its largest position error / diagonal | ≤ 1e-4 | $(field "$work/goal1.csv" 11) | |"
	echo "| level 6, predict, 2 peers: bits per node per update | ≤ 8 | $(field "$work/goal2.csv" 8) ($(field "$work/goal2.csv" 7) boundary nodes exact) | \`$cmd3\` |"
	echo "| ... its largest position error / diagonal | ≤ 1e-4 | $(field "$work/goal2.csv" 11) | |"
	echo "| level 7, predict: encoding + decoding a full state, ms | < 1 | $(field "$work/goal3.csv" 13) + $(field "$work/goal3.csv" 14) | \`$cmd4\` |"
	echo
	echo "CSV: \`$work/table.csv\` (columns in docs/net-bench.md)."
} >"$out"
cat "$out"
