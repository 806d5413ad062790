#!/usr/bin/env bash
# tests/bench/accuracy.sh — simulate-peer's error estimates and --accuracy
# (issue 18) against a reference two levels finer, on six scenes: the
# thesis figures 5.3, 5.4, 5.7, the bunny, the ellipsoid free vibration, a
# pinned sphere poked locally.  Table to docs/bench/accuracy.md, figure to
# docs/simulate-peer/accuracy.png.  About two minutes of CPU.
set -euo pipefail
cd "$(dirname "$0")/../.."
B=${NDO_TESTBIN:-build/tests}
N=${ACCURACY_LEVEL:-5}   # the inputs' level; the reference is N + 2
T=${ACCURACY_TIME:-1}    # simulated seconds
d=build/bench/accuracy
mkdir -p "$d" docs/bench docs/simulate-peer
# The bunny at the reference level, remeshed once (libcgal-demo's bunny00.off).
bunny=$d/bunny$((N + 2)).tgrid
if [ ! -s "$bunny" ]; then
	tar -xzf /usr/share/doc/libcgal-dev/data.tar.gz -C "$d" data/meshes/bunny00.off
	${NDO_BIN:-bin}/remesh "$d/data/meshes/bunny00.off" -l $((N + 2)) -o "$bunny"
fi
S=samples A=tests/bench/accuracy
scenes=(fig5.3=wavy:$S/thesis-fig5.3.scene fig5.4=tetra:$S/thesis-fig5.4.scene
	fig5.7=sphere:$S/thesis-fig5.7.scene bunny=$bunny:$S/bunny.scene
	ellipsoid=ellipsoid:$A/ellipsoid.scene:sphere poke=sphere:$A/poke.scene)
load0=$(cut -d' ' -f1-3 /proc/loadavg)
"$B/bench_accuracy" estimates "$N" "$T" "${scenes[@]}" >"$d/estimates.csv" 2>"$d/estimates.log"
"$B/bench_accuracy" choose "$N" "$T" "${scenes[@]}" >"$d/choose.csv" 2>"$d/choose.log"
grep '^point,' "$d/choose.log" | sed '1i point,scene,level,method,step_s,cpu_s,error' >"$d/sweep.csv"
load1=$(cut -d' ' -f1-3 /proc/loadavg)
/usr/bin/python3 tests/bench/plot_accuracy.py "$d" docs/simulate-peer/accuracy.png

table() { # CSV to a markdown table
	awk -F, 'NR == 1 { h = "|"; s = "|"; for (i = 1; i <= NF; i++) { h = h " " $i " |"; s = s "---|" }
		print h; print s; next } { r = "|"; for (i = 1; i <= NF; i++) r = r " " $i " |"; print r }' "$1"
}
out=docs/bench/accuracy.md
{
	echo "# simulate-peer: error estimates and --accuracy"
	echo
	echo "Made by \`tests/bench/run accuracy\` (\`tests/bench/accuracy.sh\`, program" \
		"\`tests/bench/bench_accuracy.c\`, figure \`tests/bench/plot_accuracy.py\`) on $(date -u +%Y-%m-%d)," \
		"$(nproc) cores ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//'));" \
		"load average $load0 at the start, $load1 at the end (a shared machine).  Commands:"
	echo
	echo '```'
	echo "bench_accuracy estimates $N $T ${scenes[*]}"
	echo "bench_accuracy choose $N $T ${scenes[*]}"
	echo '```'
	echo
	echo "Inputs at level $N, restricted from level $((N + 2)); reference: level $((N + 2)), RK4 at 0.2 ×" \
		"its critical step, $T s simulated.  Errors: the largest node distance at the end, at level $N," \
		"relative to the reference's largest displacement over the run.  Discussed in" \
		"[docs/simulate-peer.md](../simulate-peer.md#asking-for-an-accuracy)."
	echo
	echo "## Estimates against the truth (a run at 0.9 × the critical step)"
	echo
	echo "time_true: against the same level at RK4, 0.1 × critical; space_true: that run against the" \
		"reference; ratios estimated / true (the goal: within 3)."
	echo
	table "$d/estimates.csv"
	echo
	echo "## --accuracy E against an exhaustive sweep"
	echo
	echo "The sweep: levels 2..$N, symplectic Euler and RK4 at 0.9 × the critical step and halvings" \
		"(until the error stops falling), each timed as the median CPU time of 3 runs, as is the chosen" \
		"run.  cheapest: the sweep's cheapest configuration whose true error is ≤ E; ratio: the chosen" \
		"run's CPU time over it; ratio_with_overhead: choosing (pilots, critical steps) and the" \
		"estimate included.  reachable 0: refused (the level column is then the level that would be" \
		"needed, predicted the predicted best error)."
	echo
	table "$d/choose.csv"
	echo
	echo "![accuracy](../simulate-peer/accuracy.png)"
} >"$out"
cat "$out"
