#!/usr/bin/env bash
# peers — what a multi-peer run costs (issue 6; docs/peers.md):
#   1. the one-step boundary lag in lock-step, by method, step and boundary
#      (in one process: bench_peers lag);
#   2. realtime peers that roll back, by loss and delay, in one process
#      (bench_peers realtime);
#   3. over real LCM, in a private network namespace, 3 peers in lock-step
#      under 0-30 % loss (divergence from the single process, wall time,
#      waits, timeouts, re-sends), and realtime with rollback by loss (0, 5,
#      20 %) and delay (0, 10, 20 ms): divergence, pace, rollbacks,
#      recomputed steps, the error of the frames shown during the run;
#   4. the speed of lock-step with 1, 2, 4 and 8 peers at levels 5-9
#      (PEERS_LEVELS), against the single process, and the traffic per step;
#      PEERS_COUNTS picks the runs: N peers, Nnf without frames
#      (--publish-every 0), Nf10 with frames every 10 steps (the default
#      before 2026-12-01), Nq with --partition quadtree (the default from
#      level 3 is bands of whole rows), Nqnf both.
set -euo pipefail
cd "$(dirname "$0")/../.."
. tests/e2e/netns.bash
export PATH=$PWD/bin:$PATH
out=docs/bench/peers.md
work=build/bench/peers
rm -rf "$work" && mkdir -p "$work"
SCENE=samples/thesis-fig5.3.scene
POIS=(0 3000 9000 14000 5000 11000 7000 1500)

# PEERS_SECTIONS="4 5" runs only those sections (the others' tables are
# then left out of the report)
want() { [[ " ${PEERS_SECTIONS:-1 2 3 4 5} " == *" $1 "* ]]; }
lag_cmd="build/tests/bench_peers lag -l 6"
rt_cmd="build/tests/bench_peers realtime -l 6"
lag="(not run)" rt="(not run)" loss="(not run)" speed="(not run)" lat="(not run)" rtl="(not run)"
rtload0="" rtload1="" load3=""
want 1 && lag=$($lag_cmd)
want 2 && rt=$($rt_cmd)

remesh --shape wavy -l 6 -o "$work/wavy6.tgrid" 2>/dev/null

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
	local pids=() k
	simulate-peer --owner "$grid" -s "$SCENE" --peers "$n" -o "$outg" "${own[@]}" "${all[@]}" \
		2>"$work/owner.err" &
	pids+=($!)
	# the points of interest, scaled from level 6's faces to the grid's
	local lv
	lv=$(/usr/bin/python3 tests/e2e/tgrid.py "$grid" level)
	for ((k = 1; k < n; k++)); do
		simulate-peer ${JOINER_Q--q} --join --poi "$((POIS[k] * (4 << (2 * lv)) / 16384))" "${all[@]}" \
			2>"$work/j$k.err" &
		pids+=($!)
	done
	local bad=0
	for p in "${pids[@]}"; do wait "$p" || bad=1; done
	return $bad
}

# fields of the owner's summary
field() { grep -o "$1" "$work/owner.err" | head -1 | grep -o '[0-9.e+-]*' | head -1; }

# 3. loss
if want 3; then
simulate-peer -q "$work/wavy6.tgrid" -s "$SCENE" -t 2 -o "$work/solo6.tgrid"
load3=$(cut -d' ' -f1-3 /proc/loadavg)
loss="| clock | loss | divergence | wall time (s) | steps waited | timed out | re-sends | mean boundary lag (steps) |
|---|---|---|---|---|---|---|---|"
for clock in lockstep; do
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
fi
# realtime with rollback over LCM: every peer's report (joiners not quiet)
if want 3; then
rtl="| loss | delay (ms) | steps per exchange | divergence | exit statuses | wall time (s) | every step confirmed | rollbacks (owner) | recomputed steps per step (owner) | deepest rollback (steps, any peer) | frames shown wrong (all peers) | shown error (of the largest displacement) | computing (owner, s) |
|---|---|---|---|---|---|---|---|---|---|---|---|---|"
rtload0=$(cut -d' ' -f1-3 /proc/loadavg)
for drop in 0 0.05 0.2; do
	for dk in 0:1 10:1 20:1 20:2; do
		delay=${dk%:*} hk=${dk#*:}
		codes="all 0"
		JOINER_Q="" peers 3 "$work/wavy6.tgrid" "$work/rt.tgrid" -t 2 --clock realtime \
			--halo-steps "$hk" -- --drop "$drop" --delay "$delay" || codes="not all 0"
		errs=("$work/owner.err" "$work/j1.err" "$work/j2.err")
		d=$( [ -e "$work/rt.tgrid" ] && [ "$codes" = "all 0" ] && diff_rel "$work/rt.tgrid" "$work/solo6.tgrid" || echo -)
		rm -f "$work/rt.tgrid"
		conf=$(cat "${errs[@]}" | grep -c 'rollback: every step confirmed' || true)
		conf=${conf:-0}
		deep=$(cat "${errs[@]}" | grep -o 'the deepest [0-9]*' | awk '{if ($3 > m) m = $3} END {print m + 0}')
		shown=$(cat "${errs[@]}" | grep -o 'frames shown during the run: [0-9]* of [0-9]*' | awk '{w += $6; f += $8} END {print w + 0 " of " f + 0}')
		serr=$(cat "${errs[@]}" | grep -o 'by up to [0-9.e+-]* m ([0-9.e+-]* of the largest displacement, [0-9.e+-]* m)' |
			awk '{e = $4 + 0; if (e > me) me = e; if ($11 + 0 > md) md = $11 + 0} END {if (me == 0) print 0; else printf "%.2e", me / md}')
		wall=$(field 'in [0-9.e+-]* s (' || true) rolls=$(field '[0-9]* rollbacks' || true)
		rec=$(field '[0-9]* steps recomputed' || true) tak=$(field 'for [0-9]* taken' || true)
		comp=$(field 'computing [0-9.e+-]* s' || true)
		per=$(awk -v r="$rec" -v t="$tak" 'BEGIN{if (t > 0) printf "%.2f", r / t; else print "-"}')
		rtl="$rtl
| $drop | $delay | $hk | $d | $codes | $wall | $conf of 3 | $rolls | $per | $deep | $shown | $serr | $comp |"
		echo "realtime, loss $drop, delay $delay, $hk steps per exchange: $d" >&2
	done
done
rtload1=$(cut -d' ' -f1-3 /proc/loadavg)
fi

# 4. speed of exact lock-step (no loss), rk4, levels 5-9, 1/2/4/8 peers,
# against one single-threaded process; medians of 3 runs.  Steps per second
# of the stepping alone (the single process's "N steps ... in X s" line,
# the owner's "N steps to step S in X s"), so setup (remesh, the critical
# step's power iteration, the snapshot to joiners) is not counted.
median() { tr ' ' '\n' | grep . | sort -g | awk '{v[NR] = $1} END {print v[int((NR + 1) / 2)]}'; }
# long enough that the single process's first steps (its arrays touched
# for the first time) do not weigh: ~1000-2000 steps at levels 5-8
declare -A TL=([5]=20 [6]=20 [7]=10 [8]=4 [9]=0.5)
load0=$(cut -d' ' -f1-3 /proc/loadavg)
if want 4; then
speed="| level | peers | steps | steps/s | × one process | computing per step (ms) | waiting per step (ms) | halo kB per step per peer | whole-region kB per step per peer |
|---|---|---|---|---|---|---|---|---|"
# one single-threaded process: its steps/s (the stepping alone; without
# the error estimate, whose runs would go beside it on the other core:
# --no-estimate, since 2026-12-01)
solo() {
	simulate-peer --threads 1 --no-estimate "$work/wavy$1.tgrid" -s "$SCENE" -t "$2" -o "$work/solo.tgrid" 2>"$work/solo.err"
	grep -o 'in [0-9.e+-]* s: [0-9.e+-]* steps/s' "$work/solo.err" | awk '{print $4}'
}
# Each peer run is paired with a single-process run just before it: the
# ratio is the median of the pairs' ratios (a busy machine slows both runs
# of a pair alike; load that comes and goes between pairs cancels out).
# "2 (no frames)": whole regions only at the first and the last step
# (--publish-every 0), what the single process does not pay either.
for level in ${PEERS_LEVELS:-5 6 7 8 9}; do
	[ -e "$work/wavy$level.tgrid" ] || remesh --shape wavy -l "$level" -o "$work/wavy$level.tgrid" 2>/dev/null
	t=${TL[$level]}
	sps=""
	steps=""
	for n in ${PEERS_COUNTS:-1 2 2f10 2nf 4 8}; do
		rs="" ratios="" cs="" wt="" hb="" fb=""
		np=${n%nf} own=() kind=""
		[ "$n" != "$np" ] && own=(--publish-every 0) kind=" (no frames)"
		[ "${np%f10}" != "$np" ] && np=${np%f10} own=(--publish-every 10) kind=" (frames every 10 steps)"
		[ "${np%q}" != "$np" ] && np=${np%q} own+=(--partition quadtree) kind=" quad-tree$kind"
		for rep in $(seq "${PEERS_REPS:-3}"); do
			one=$(solo "$level" "$t")
			sps="$sps $one"
			[ -n "$steps" ] || steps=$(/usr/bin/python3 tests/e2e/tgrid.py "$work/solo.tgrid" step)
			peers "$np" "$work/wavy$level.tgrid" "$work/speed.tgrid" -t "$t" "${own[@]}" -- || continue
			wall=$(field 'in [0-9.e+-]* s (')
			r=$(awk "BEGIN{print $steps / $wall}")
			rs="$rs $r"
			ratios="$ratios $(awk "BEGIN{print $r / $one}")"
			cs="$cs $(field 'computing [0-9.e+-]* s')"
			wt="$wt $(field 'waiting [0-9.e+-]* s')"
			hb="$hb $(grep -o 'exchanges, [0-9.e+-]* kB' "$work/owner.err" | awk '{print $2}')"
			fb="$fb $(grep -o 'times, [0-9.e+-]* kB' "$work/owner.err" | awk '{print $2}')"
		done
		label=$np$kind
		[ -n "$rs" ] || { speed="$speed
| $level | $label | failed | | | | | | |"; continue; }
		r=$(echo "$rs" | median) ratio=$(echo "$ratios" | median)
		comp=$(echo "$cs" | median) waitt=$(echo "$wt" | median)
		speed="$speed
| $level | $label | $steps | $(printf %.0f "$r") | $(printf %.2f "$ratio") | $(awk "BEGIN{printf \"%.3f\", 1e3 * $comp / $steps}") | $(awk "BEGIN{printf \"%.3f\", 1e3 * $waitt / $steps}") | $(echo "$hb" | median) | $(echo "$fb" | median) |"
		echo "level $level, $label peers: $r steps/s, $ratio x one process" >&2
	done
	speed="$speed
| $level | 1 process | $steps | $(printf %.0f "$(echo "$sps" | median)") | 1 | | | | |"
done
/usr/bin/python3 tests/bench/peers_plot.py docs/bench/peers.svg <<<"$speed" || echo "no plot" >&2
fi

# 5. latency: one-way delay injected on every peer's receiving side, level 6,
# 2 peers, rk4, 2 s (105 steps): steps per second against the delay and
# the steps per halo exchange, against the thesis' scheme (--boundary hold:
# one exchange of whole regions every step, what lock-step did before)
if want 5; then
lat="| delay (ms) | scheme | steps/s | × held boundary | bit for bit |
|---|---|---|---|---|"
simulate-peer -q "$work/wavy6.tgrid" -s "$SCENE" -t 2 -o "$work/solo2.tgrid"
for delay in 0 5 20 50; do
	peers 2 "$work/wavy6.tgrid" "$work/lat.tgrid" -t 2 --boundary hold -- --delay "$delay" || true
	held=$(awk "BEGIN{print $(field '[0-9]* steps to step') / $(field 'in [0-9.e+-]* s (')}")
	lat="$lat
| $delay | held boundary (thesis) | $(printf %.0f "$held") | 1 | no ($(diff_rel "$work/lat.tgrid" "$work/solo2.tgrid")) |"
	for hk in 1 2 4 8 16 32; do
		if peers 2 "$work/wavy6.tgrid" "$work/lat.tgrid" -t 2 --halo-steps "$hk" -- --delay "$delay"; then
			r=$(awk "BEGIN{print $(field '[0-9]* steps to step') / $(field 'in [0-9.e+-]* s (')}")
			d=$(diff_rel "$work/lat.tgrid" "$work/solo2.tgrid")
			lat="$lat
| $delay | exact, $hk steps per exchange | $(printf %.0f "$r") | $(awk "BEGIN{printf \"%.1f\", $r / $held}") | $([ "$d" = 0.00e+00 ] && echo yes || echo "no ($d)") |"
		else
			lat="$lat
| $delay | exact, $hk steps per exchange | failed | | |"
		fi
	done
done
fi
load1=$(cut -d' ' -f1-3 /proc/loadavg)

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
	echo "## 2. Realtime peers that roll back, by loss and delay (in one process)"
	echo
	echo "Level 6, 3 peers, rk4 at h = 0.019 s (0.9 of its critical step), 2 s (105"
	echo "steps), in one process with a fake clock and the loss and delay injected"
	echo "on every peer's receiving side, one halo exchange a step and, at 20 ms,"
	echo "also one every 2 steps: \`$rt_cmd\`.  Difference: the owner's"
	echo "output against the single process, over its largest displacement."
	echo "Rollbacks: all three peers'; recomputed steps per step taken and the"
	echo "deepest rollback over the peers.  Frames shown: the whole regions sent"
	echo "every 10 steps (what observers and render-frame drew) against the"
	echo "confirmed state of their step; the error is the largest difference of"
	echo "a displacement component over the largest displacement component of"
	echo "those frames.  Held boundary: the thesis' scheme (\`--boundary hold\`,"
	echo "no rollback) under the same faults."
	echo
	echo "$rt"
	echo
	echo "## 3. Loss, over LCM (3 peers, level 6, rk4 at 0.9 of its critical step, 2 s)"
	echo
	echo "Each peer drops each message it receives with the given probability"
	echo "(\`--drop\`); \`peers 3 wavy6.tgrid -t 2 --clock lockstep -- --drop P\` in"
	echo "tests/bench/peers.sh.  Wall time, waits, timeouts, re-sends and lag are the"
	echo "owner's.  Load average before the lock-step runs: $load3."
	echo
	echo "$loss"
	echo
	echo "Realtime with rollback over LCM: the same 3 peers and 2 s,"
	echo "\`peers 3 wavy6.tgrid -t 2 --clock realtime --halo-steps K -- --drop P --delay MS\`; the"
	echo "wall time is the owner's from its first step to its last (the pace held:"
	echo "2 s); divergence, rollbacks and the frames' error as in §2, from every"
	echo "peer's report.  Load average (1, 5, 15 min) before: $rtload0, after:"
	echo "$rtload1."
	echo
	echo "$rtl"
	echo
	echo "## 4. The speed of exact lock-step (LCM, no loss)"
	echo
	echo "rk4, the thesis scene; simulated time per level: ${TL[5]}, ${TL[6]}, ${TL[7]}, ${TL[8]}, ${TL[9]} s"
	echo "for levels 5–9 (the steps column).  Steps per second of the stepping alone,"
	echo "medians of ${PEERS_REPS:-3} runs; each peer run follows a run of one single-threaded"
	echo "process (\`--no-estimate\`: no error estimate beside it on the other core),"
	echo "and *× one process* is the median of these pairs' ratios (the"
	echo "*1 process* row: the median of all its runs).  *2 (no frames)*: whole regions only"
	echo "at the first and the last step (\`--publish-every 0\`).  *quad-tree*: the owner's \`--partition quadtree\`"
	echo "(regions grown from the peers' POIs; the others: bands of whole rows, the default from level 3).  Each peer is one process with one thread; the machine has"
	echo "$(nproc) cores, so 4 and 8 peers oversubscribe them and must lose (they wait for"
	echo "the scheduler as much as for the network).  Load average (1, 5, 15 min) before:"
	echo "$load0, after: $load1 (the 4- and 8-peer runs load the machine themselves).  Computing and waiting"
	echo "are the owner's; halo and whole-region kB are what the owner sent per step"
	echo "(whole regions at the default \`--publish-rate 30\`: every N steps, at least 10, N"
	echo "fixed at the start from the run's predicted speed, about 30 frames a second here;"
	echo "*frames every 10 steps*: \`--publish-every 10\`, the default before 2026-12-01)."
	echo "From level 8 (65,536 nodes and more) the single process runs rk4 two steps at a time as one"
	echo "chain of its pipeline (lib/sim/rk4.c, since 2026-12-02: about 1.1x single steps there,"
	echo "docs/simulate-peer.md), which a peer, exchanging halos between its steps, does not."
	echo
	echo "$speed"
	echo
	echo "![speedup against level](peers.svg)"
	echo
	echo "## 5. Latency: steps per halo exchange (LCM, delay injected)"
	echo
	echo "Level 6, 2 peers, rk4, 2 s (105 steps); every peer delays what it receives by"
	echo "the given time (\`--delay\`).  Bit for bit: the owner's output equals the"
	echo "single process's."
	echo
	echo "$lat"
	echo
	echo "Made by \`tests/bench/peers.sh\` on $(date -u +%Y-%m-%d), $(nproc) cores,"
	echo "$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')."
} >"$work/report.md"
# A section not run keeps what the report had (PEERS_SECTIONS runs a part;
# sections the script does not make, such as §6 of checkpoints.sh, stay).
/usr/bin/python3 - "$work/report.md" "$out" "${PEERS_SECTIONS:-1 2 3 4 5}" <<'PY'
import re, sys
new, old, ran = open(sys.argv[1]).read(), sys.argv[2], sys.argv[3].split()
try:
    prev = open(old).read()
except OSError:
    prev = ""
# the footer's paragraphs ("Made by ...", "Sections ...: made by ..."), wherever they are
FOOT = re.compile(r"(?m)^(?:Sections [^\n]*: made by|Made by `tests/bench/peers\.sh`)[^\n]*\n(?:[^\n]+\n)*\n?")
def sections(text):
    foot = "".join(m.group(0) for m in FOOT.finditer(text))
    body = FOOT.sub("", text)
    parts = re.split(r"(?m)^(?=## \d+\. )", body)
    return parts[0], {p.split(".", 1)[0][3:]: p.rstrip() + "\n\n" for p in parts[1:]}, foot
head, secs, foot = sections(new)
_, olds, _ = sections(prev)
for k, text in olds.items():
    if k not in ran or k not in secs:
        secs[k] = text
kept = sorted(k for k in secs if k not in ran)
if kept:
    foot = foot.rstrip() + "  Sections run this time: " + ", ".join(sorted(ran, key=int)) + \
        "; sections " + ", ".join(kept) + " are kept from earlier runs (each says when and how it was made).\n"
open(old, "w").write(head + "".join(secs[k] for k in sorted(secs, key=int)) + foot)
PY
cat "$out"
