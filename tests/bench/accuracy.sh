#!/usr/bin/env bash
# tests/bench/accuracy.sh — simulate-peer's error estimates and --accuracy
# (issue 18) against a reference two levels finer, on six scenes: the
# thesis figures 5.3, 5.4, 5.7, the bunny, the ellipsoid free vibration, a
# pinned sphere poked locally; inputs at levels 5 and 6.  Tables to
# docs/bench/accuracy.md, figures to docs/simulate-peer/accuracy-N.png.
# About ten minutes of CPU (10.5 on 2026-11-25; the level-8 references, the sweeps; the
# pilot study 40 s more).  The
# summary: tests/bench/summarize_accuracy.py; it also rewrites the blocks
# between "<!-- accuracy-bench: PART -->" and "<!-- /accuracy-bench -->" in
# docs/simulate-peer.md (PART: estimates, choices, tallies, misses).
set -euo pipefail
cd "$(dirname "$0")/../.."
B=${NDO_TESTBIN:-build/tests}
LEVELS=${ACCURACY_LEVELS:-5 6} # the inputs' levels; each reference is N + 2
T=${ACCURACY_TIME:-1}    # simulated seconds
PARTS=" ${ACCURACY_PARTS:-estimates choose pilot cost} "
part() { [[ $PARTS == *" $1 "* ]]; }
d=build/bench/accuracy
mkdir -p "$d" docs/bench docs/simulate-peer
S=samples A=tests/bench/accuracy
# ACCURACY_REPORT_ONLY=1: only rewrite the report from the CSV files of an
# earlier run (build/bench/accuracy/).  ACCURACY_PARTS: the programs to run
# (default all: "estimates choose pilot cost"; the others' CSV files of an
# earlier run are kept and reported; "predictors" and "timeorder", the
# diagnostics of the chooser's space errors and of the time estimate's
# order and growth, about 3 minutes more, run only when named).  cost (the chooser's cost model
# against measured CPU time per step, about a minute) runs at the last of
# LEVELS only.
# a mode of bench_accuracy over SCENES... at input level N: its command
# noted, its table (MODE-N.csv) and log kept
mode() {
	local m=$1
	shift
	echo "bench_accuracy $m $N $T $*" >>"$d/commands-$N"
	"$B/bench_accuracy" "$m" "$N" "$T" "$@" >"$d/$m-$N.csv" 2>"$d/$m-$N.log"
}
for N in $LEVELS; do
	[ "${ACCURACY_REPORT_ONLY:-0}" = 1 ] && break
	# The bunny at the reference level, remeshed once (libcgal-demo's bunny00.off).
	bunny=$d/bunny$((N + 2)).tgrid
	if [ ! -s "$bunny" ]; then
		tar -xzf /usr/share/doc/libcgal-dev/data.tar.gz -C "$d" data/meshes/bunny00.off
		${NDO_BIN:-bin}/remesh "$d/data/meshes/bunny00.off" -l $((N + 2)) -o "$bunny"
	fi
	scenes=(fig5.3=wavy:$S/thesis-fig5.3.scene fig5.4=tetra:$S/thesis-fig5.4.scene
		fig5.7=sphere:$S/thesis-fig5.7.scene bunny=$bunny:$S/bunny.scene
		ellipsoid=ellipsoid:$A/ellipsoid.scene:sphere poke=sphere:$A/poke.scene)
	# A run of some parts adds its commands and loads to the earlier run's.
	if part estimates && part choose && part pilot; then
		: >"$d/commands-$N"
		: >"$d/load-$N"
	fi
	what=$(echo $PARTS | sed 's/ cost//; s/^cost$//')
	if [ -n "$what" ]; then
		echo "load average at the start ($what, $(date -u +%H:%M) UTC): $(cut -d' ' -f1-3 /proc/loadavg)" >>"$d/load-$N"
	fi
	if part estimates; then mode estimates "${scenes[@]}"; fi
	if part choose; then mode choose "${scenes[@]}"; fi
	# What a pilot at the input level would tell of level N - 1 (the cost
	# misses' candidate), on the two scenes whose misses are decided there.
	if part pilot; then mode pilot "${scenes[2]}" "${scenes[5]}"; fi
	# The chooser's space-error measures at every top pilot level, and the
	# time error's order and growth (ACCURACY_PARTS only).
	if part predictors; then mode predictors "${scenes[@]}"; fi
	if part timeorder; then mode timeorder "${scenes[@]}"; fi
	if part choose; then
		grep '^point,' "$d/choose-$N.log" | sed '1i point,scene,level,method,step_s,cpu_s,error' >"$d/sweep-$N.csv"
		grep '^level,' "$d/choose-$N.log" | cut -d, -f2- |
			sed '1i scene,level,pilots,predicted_space,true_space,ratio,true_symplectic_euler,true_rk4' >"$d/levels-$N.csv"
		/usr/bin/python3 tests/bench/plot_accuracy.py "$d" "$N" docs/simulate-peer/accuracy-$N.png
	fi
	if [ -n "$what" ]; then
		echo "load average at the end ($what, $(date -u +%H:%M) UTC): $(cut -d' ' -f1-3 /proc/loadavg)" >>"$d/load-$N"
	fi
	# The chooser's cost model (ndo_acc_work) against measured CPU time per
	# step: every scene at levels 2..N, both candidates.
	if part cost && [ "$N" = "${LEVELS##* }" ]; then
		echo "bench_accuracy cost $N $T ${scenes[*]}" >"$d/cost-commands"
		echo "load average at the start: $(cut -d' ' -f1-3 /proc/loadavg)" >"$d/cost-load"
		"$B/bench_accuracy" cost "$N" "$T" "${scenes[@]}" >"$d/cost.csv" 2>"$d/cost.log"
		echo "load average at the end: $(cut -d' ' -f1-3 /proc/loadavg)" >>"$d/cost-load"
	fi
done

table() { # CSV to a markdown table
	awk -F, 'NR == 1 { h = "|"; s = "|"; for (i = 1; i <= NF; i++) { h = h " " $i " |"; s = s "---|" }
		print h; print s; next } { r = "|"; for (i = 1; i <= NF; i++) r = r " " $i " |"; print r }' "$1"
}
out=docs/bench/accuracy.md
{
	echo "# simulate-peer: error estimates and --accuracy"
	echo
	echo "Made by \`tests/bench/run accuracy\` (\`tests/bench/accuracy.sh\`, program" \
		"\`tests/bench/bench_accuracy.c\`, figures \`tests/bench/plot_accuracy.py\`) on $(date -u +%Y-%m-%d)," \
		"$(nproc) cores ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//'));" \
		"load averages below, per input level (a shared machine: CPU times are process CPU times," \
		"medians of 3 trials, each repeating the run until it has taken 20 ms).  Discussed in [docs/simulate-peer.md](../simulate-peer.md#asking-for-an-accuracy)."
	echo
	echo "Inputs at level N, restricted from level N + 2; reference: level N + 2, RK4 at 0.2 × its" \
		"critical step, $T s simulated.  Errors: the largest node distance at the end, at level N," \
		"relative to the reference's largest displacement over the run."
	echo
	echo "## Summary"
	echo
	/usr/bin/python3 tests/bench/summarize_accuracy.py "$d" all $LEVELS
	echo "The runs that cost more than 2× the sweep's cheapest configuration (its error: the" \
		"sweep's; * where taken from the level table, that method at 0.9 × its critical step;" \
		"its level's predicted space error: the chooser's for the cheapest's level; with choosing:" \
		"the chosen run's CPU time plus choose_cpu_s, over the cheapest's):"
	echo
	/usr/bin/python3 tests/bench/summarize_accuracy.py "$d" misses $LEVELS
	for N in $LEVELS; do
		echo
		echo "## Input level $N"
		echo
		echo '```'
		cat "$d/commands-$N"
		echo '```'
		echo
		[ -f "$d/load-$N" ] && sed 's/$/;/' "$d/load-$N" | tr '\n' ' ' && echo
		echo
		echo "### Estimates against the truth (a run at 0.9 × the critical step)"
		echo
		echo "time_true: against the same level at RK4, 0.1 × critical; space_true: that run against" \
			"the reference; ratios estimated / true (the goal: within 3)."
		echo
		table "$d/estimates-$N.csv"
		echo
		echo "### --accuracy E against an exhaustive sweep"
		echo
		echo "The sweep: levels 2..$N, symplectic Euler and RK4 at 0.9 × the critical step and halvings" \
			"(until the error stops falling).  cheapest: the sweep's cheapest configuration whose true" \
			"error is ≤ E; ratio: the chosen run's CPU time over it; ratio_with_overhead: choosing" \
			"(pilots, critical steps) and the estimate included (choose_cpu_s: ndo_acc_choose's CPU" \
			"time, once; a scene's later targets reuse the critical steps of its first; the" \
			"sweep's configurations are timed without their critical step, which a plain run" \
			"also computes).  reachable 0: refused before any run" \
			"(level: the level that would be needed; predicted: the input level's predicted error)."
		echo
		table "$d/choose-$N.csv"
		echo
		echo "### Each level's predicted space error against the sweep's"
		echo
		echo "predicted_space: the chooser's (ndo_acc_choice.level_m; the E whose pilots went" \
			"furthest), measured against the pilots' extrapolation u* up to their finest level," \
			"extrapolated by r = 4 per level above; true_space: the sweep's RK4 at its smallest step" \
			"at that level; true_symplectic_euler, true_rk4: each at 0.9 × its critical step; all" \
			"relative to the reference's largest displacement."
		echo
		[ -f "$d/levels-$N.csv" ] && table "$d/levels-$N.csv"
		if [ -f "$d/pilot-$N.csv" ]; then
			echo
			echo "### What a pilot at the input level would tell of level $((N - 1))"
			echo
			echo "At t = T/8, T/4, T/2, T: true_below, true_input: the true errors of levels $((N - 1))" \
				"and $N (symplectic Euler at 0.9 × critical); predicted_below: the pilots' D / 3 from" \
				"levels $((N - 2)) and $((N - 1)); pilot_difference: level $((N - 1))'s pilot against one at" \
				"level $N (RK4 at half its critical step); all relative to the reference's largest" \
				"displacement up to t (largest_m)."
			echo
			table "$d/pilot-$N.csv"
		fi
		if [ -f "$d/predictors-$N.csv" ]; then
			echo
			echo "### The chooser's space-error measures at every top pilot level"
			echo
			echo "The pilots (RK4 at half the critical step) at levels 2..$N; for each top pilot level and" \
				"each level q up to it: true, q's pilot against the reference (at level $N); all_nodes, q's" \
				"pilot against u* = u_top + (u_top − S u_top−1) / 3 over all of top's nodes (what" \
				"ndo_acc_choose measures); shared_nodes, the same over level top − 1's nodes only (as a" \
				"run's estimate measures its space error); D_all_top, D_shared_top: |u_top − S u_top−1|" \
				"both ways; all relative to the reference's largest displacement."
			echo
			table "$d/predictors-$N.csv"
		fi
		if [ -f "$d/timeorder-$N.csv" ]; then
			echo
			echo "### The time error's order and growth"
			echo
			echo "Levels $((N - 1)) and $N, each method at fraction × its critical step (0.9 and halvings)" \
				"against RK4 at 0.05 ×, at t = T/8 and T: error relative to that run's largest" \
				"displacement; observed_order: log2 of the error's fall from the step before;" \
				"estimate: the run's time estimate at 0.9 (ndo_acc_estimate_run), the same share."
			echo
			table "$d/timeorder-$N.csv"
			echo
			echo '```'
			sed 's/^bench_accuracy: //' "$d/timeorder-$N.log"
			echo '```'
		fi
		echo
		echo "![accuracy, level $N](../simulate-peer/accuracy-$N.png)"
	done
	if [ -f "$d/cost.csv" ]; then
		echo
		echo "## The cost model"
		echo
		echo "ndo_acc_choose weighs a candidate by counted work, not by a timing (ndo_acc_work," \
			"lib/sim/accuracy.c): steps × (A + B × vertices + C × integrated vertices) per method," \
			"the integrated vertices being the distinct unpinned ones.  Each scene at levels 2 to" \
			"the input's, each method at 0.9 × its critical step: CPU time per step (the median of 3" \
			"trials of at least 20 ms) against the model (model_us), and a least-squares fit of the" \
			"three constants to these measurements (the constants in the code are such a fit, of" \
			"the run of 2026-11-25 16:36 UTC at load 1.2-2.5)."
		echo
		echo '```'
		cat "$d/cost-commands"
		echo '```'
		echo
		sed 's/$/;/' "$d/cost-load" | tr '\n' ' ' && echo
		echo
		/usr/bin/python3 tests/bench/summarize_accuracy.py "$d" cost
		echo
		table "$d/cost.csv"
	fi
} >"$out"
cat "$out"

# The blocks of docs/simulate-peer.md that show these results.
/usr/bin/python3 - "$d" $LEVELS <<'PY'
import re, subprocess, sys
doc = "docs/simulate-peer.md"
text = open(doc).read()
def block(m):
    out = subprocess.run(["/usr/bin/python3", "tests/bench/summarize_accuracy.py", sys.argv[1],
                          m.group(1)] + sys.argv[2:], check=True, capture_output=True, text=True)
    return f"<!-- accuracy-bench: {m.group(1)} -->\n{out.stdout.strip()}\n<!-- /accuracy-bench -->"
text = re.sub(r"<!-- accuracy-bench: (\w+) -->.*?<!-- /accuracy-bench -->", block, text, flags=re.S)
open(doc, "w").write(text)
PY
