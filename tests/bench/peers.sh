#!/usr/bin/env bash
# peers — what a multi-peer run costs (issue 6; docs/peers.md):
#   1. the one-step boundary lag in lock-step, by method, step and boundary
#      (in one process: bench_peers lag);
#   2. free-running (realtime) peers, error by network delay (bench_peers
#      realtime);
#   3. over real LCM, in a private network namespace, 3 peers in lock-step
#      and in realtime under 0-30 % loss: divergence from the single
#      process, wall time, waits, timeouts, re-sends;
#   4. the speed of lock-step with 1, 2, 4 and 8 peers at levels 6 and 7,
#      against the single process, and the traffic per step.
set -euo pipefail
cd "$(dirname "$0")/../.."
if [ -z "${NDO_IN_NETNS:-}" ]; then
	NDO_IN_NETNS=1 exec unshare -n "$BASH" "$(realpath "$0")" "$@"
fi
ip link set lo up
ip route add 224.0.0.0/4 dev lo
export PATH=$PWD/bin:$PATH
out=docs/bench/peers.md
work=build/bench/peers
rm -rf "$work" && mkdir -p "$work"
SCENE=samples/thesis-fig5.3.scene
POIS=(0 3000 9000 14000 5000 11000 7000 1500)

lag_cmd="build/tests/bench_peers lag -l 6"
lag=$($lag_cmd)
rt_cmd="build/tests/bench_peers realtime -l 5"
rt=$($rt_cmd)

remesh --shape wavy -l 6 -o "$work/wavy6.tgrid" 2>/dev/null
remesh --shape wavy -l 7 -o "$work/wavy7.tgrid" 2>/dev/null

# relative difference of A from B (over B's largest displacement)
diff_rel() {
	/usr/bin/python3 - "$1" "$2" tests/e2e <<'PY'
import sys
sys.path.insert(0, sys.argv[3])
import numpy as np, tgrid
_, _, _, a = tgrid.read(sys.argv[1])
_, _, _, b = tgrid.read(sys.argv[2])
print(f"{np.abs(a['position'] - b['position']).max() / np.abs(b['position'] - b['rest']).max():.2e}")
PY
}

# peers N GRID OUT [owner options...] -- [options of every peer...]
peers() {
	local n=$1 grid=$2 outg=$3; shift 3
	local own=() all=()
	while [ $# -gt 0 ] && [ "$1" != -- ]; do own+=("$1"); shift; done
	[ $# -gt 0 ] && shift
	all=("$@")
	local pids=()
	simulate-peer --owner "$grid" -s "$SCENE" --peers "$n" -o "$outg" "${own[@]}" "${all[@]}" \
		2>"$work/owner.err" &
	pids+=($!)
	for ((k = 1; k < n; k++)); do
		simulate-peer -q --join --poi "${POIS[$k]}" "${all[@]}" 2>"$work/j$k.err" &
		pids+=($!)
	done
	local bad=0
	for p in "${pids[@]}"; do wait "$p" || bad=1; done
	return $bad
}

# fields of the owner's summary
field() { grep -o "$1" "$work/owner.err" | head -1 | grep -o '[0-9.e+-]*' | head -1; }

# 3. loss
simulate-peer -q "$work/wavy6.tgrid" -s "$SCENE" -t 2 -o "$work/solo6.tgrid"
loss="| clock | loss | divergence | wall time (s) | steps waited | timed out | re-sends | mean boundary lag (steps) |
|---|---|---|---|---|---|---|---|"
for clock in lockstep realtime; do
	for drop in 0 0.01 0.05 0.1 0.2 0.3; do
		if peers 3 "$work/wavy6.tgrid" "$work/loss.tgrid" -t 2 --clock "$clock" -- --drop "$drop"; then
			d=$(diff_rel "$work/loss.tgrid" "$work/solo6.tgrid")
			loss="$loss
| $clock | $drop | $d | $(field 'in [0-9.e+-]* s (') | $(field 'in [0-9]* steps,') | $(field '[0-9]* timed out') | $(field '[0-9]* re-sends') | $(field 'lag [0-9.e+-]* steps') |"
		else
			loss="$loss
| $clock | $drop | failed | | | | | |"
		fi
	done
done

# 4. speed of lock-step (no loss), level 6 (2 s, 105 steps) and 7 (0.5 s):
# the median of 3 runs of each (the machine is shared)
median() { tr ' ' '\n' | grep . | sort -g | awk '{v[NR] = $1} END {print v[int((NR + 1) / 2)]}'; }
speed="| level | peers | steps/s (wall) | vs one process | computing per step (ms) | waiting per step (ms) | messages per step per peer | kB per step per peer |
|---|---|---|---|---|---|---|---|"
for level in 6 7; do
	t=$([ $level = 6 ] && echo 2 || echo 0.5)
	walls=""
	for rep in 1 2 3; do
		t0=$EPOCHREALTIME
		simulate-peer -q "$work/wavy$level.tgrid" -s "$SCENE" -t "$t" -o "$work/solo.tgrid"
		walls="$walls $(awk "BEGIN{print $EPOCHREALTIME - $t0}")"
	done
	solo=$(echo "$walls" | median)
	steps=$(/usr/bin/python3 tests/e2e/tgrid.py "$work/solo.tgrid" step)
	solo_sps=$(awk "BEGIN{printf \"%.0f\", $steps / $solo}")
	speed="$speed
| $level | 1 process | $solo_sps | 1 | | | | |"
	for n in 1 2 4 8; do
		ws="" cs="" wt="" pb="" kbs=""
		for rep in 1 2 3; do
			peers "$n" "$work/wavy$level.tgrid" "$work/speed.tgrid" -t "$t" -- || continue
			ws="$ws $(field 'in [0-9.e+-]* s (')"
			cs="$cs $(field 'computing [0-9.e+-]* s')"
			wt="$wt $(field 'waiting [0-9.e+-]* s')"
			pb="$pb $(grep -o 'published [0-9]*' "$work/owner.err" | head -1 | grep -o '[0-9]*$')"
			kbs="$kbs $(field '([0-9.e+-]* kB a step)')"
		done
		[ -n "$ws" ] || continue
		wallt=$(echo "$ws" | median) comp=$(echo "$cs" | median) waitt=$(echo "$wt" | median)
		pub=$(echo "$pb" | median) kb=$(echo "$kbs" | median)
		speed="$speed
| $level | $n | $(awk "BEGIN{printf \"%.0f\", $steps / $wallt}") | $(awk "BEGIN{printf \"%.2f\", ($steps / $wallt) / $solo_sps}") | $(awk "BEGIN{printf \"%.2f\", 1e3 * $comp / $steps}") | $(awk "BEGIN{printf \"%.2f\", 1e3 * $waitt / $steps}") | $(awk "BEGIN{printf \"%.1f\", $pub / $steps}") | $kb |"
	done
done

{
	echo "# Peers: what splitting the surface costs"
	echo
	echo "The thesis' figure-5.3 scene (wavy surface, k = 1 N/m, b = 0.1, 2.4 N at 1 Hz"
	echo "on the faces within 0.2 m of the pole), split among peers, against the single"
	echo "process.  Divergence: the largest position difference over the largest"
	echo "displacement of the single-process run.  See docs/peers.md for what it means."
	echo
	echo "## 1. The one-step boundary lag (lock-step, no loss)"
	echo
	echo "Level 6, 1 s, in one process (an in-memory bus, fake clock: independent of"
	echo "the machine): \`$lag_cmd\`"
	echo
	echo "$lag"
	echo
	echo "## 2. Free-running peers (realtime, speed 1) by network delay"
	echo
	echo "Level 5, rk4, h = 0.01 s, 1 s, in one process with the delay injected:"
	echo "\`$rt_cmd\`"
	echo
	echo "$rt"
	echo
	echo "## 3. Loss, over LCM (3 peers, level 6, rk4 at 0.9 of its critical step, 2 s)"
	echo
	echo "Each peer drops each message it receives with the given probability"
	echo "(\`--drop\`); \`peers 3 wavy6.tgrid -t 2 --clock CLOCK -- --drop P\` in"
	echo "tests/bench/peers.sh.  Wall time, waits, timeouts, re-sends and lag are the"
	echo "owner's."
	echo
	echo "$loss"
	echo
	echo "## 4. The speed of lock-step (LCM, no loss)"
	echo
	echo "Level 6: 2 s simulated (105 steps); level 7: 0.5 s; medians of 3 runs.  All"
	echo "processes share the machine's $(nproc) cores (8 peers oversubscribe them), and"
	echo "other work on it.  Computing and waiting are the owner's; messages and kB are"
	echo "what the owner sent per step."
	echo
	echo "$speed"
	echo
	echo "Made by \`tests/bench/peers.sh\` on $(date -u +%Y-%m-%d), $(nproc) cores,"
	echo "$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')."
} >"$out"
cat "$out"
