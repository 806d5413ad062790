#!/usr/bin/env bash
# tests/bench/simulate-studies.sh — the studies behind docs/simulate-peer.md:
# the stability map (thesis figure 5.2), work-precision at levels 5-7,
# coarse simulation + subdivision against fine simulation, restiffening,
# penalty pins.  Tables to docs/bench/simulate-studies.md, figures to
# docs/simulate-peer/*.png (matplotlib).  Takes a few minutes.
set -euo pipefail
cd "$(dirname "$0")/../.."
B=${NDO_TESTBIN:-build/tests}
d=build/bench/simulate-studies
mkdir -p "$d" docs/bench docs/simulate-peer
"$B/bench_study" stability 3 >"$d/stability.csv"
{ "$B/bench_study" accuracy 5; "$B/bench_study" accuracy 6 | tail -n +2;
  "$B/bench_study" accuracy 7 | tail -n +2; } >"$d/accuracy.csv"
"$B/bench_study" levels 7 3 4 5 6 >"$d/levels.csv"
"$B/bench_study" restiffen 5 >"$d/restiffen.csv"
"$B/bench_study" penalty 4 >"$d/penalty.csv"
/usr/bin/python3 tests/bench/plot_simulate.py "$d" docs/simulate-peer

table() { # CSV to a markdown table
	awk -F, 'NR == 1 { h = "|"; s = "|"; for (i = 1; i <= NF; i++) { h = h " " $i " |"; s = s "---|" }
		print h; print s; next } { r = "|"; for (i = 1; i <= NF; i++) r = r " " $i " |"; print r }' "$1"
}
out=docs/bench/simulate-studies.md
{
	echo "# simulate-peer: studies"
	echo
	echo "Made by \`make bench\` (\`tests/bench/simulate-studies.sh\`, programs \`tests/bench/bench_study.c\`," \
		"figures \`tests/bench/plot_simulate.py\`) on $(date -u +%Y-%m-%d), $(nproc) cores" \
		"($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')); CPU times are of one" \
		"process on a shared machine.  Discussed in [docs/simulate-peer.md](../simulate-peer.md)."
	echo
	echo "## Stability map (level 3 wavy surface, damping γ = 1/s)"
	echo
	echo "Predicted: \`ndo_sim_critical\`.  Measured: the smallest step at which the run stops diverged" \
		"(seeded 1e-6 m perturbation, energy bound 1e6, N steps as listed, bisection to 0.3%)." \
		"bound: 1 oscillation, 2 damping (\`NDO_BOUND_*\`)."
	echo
	table "$d/stability.csv"
	echo
	echo "![stability](../simulate-peer/stability.png)"
	echo
	echo "## Work-precision (thesis scene, 1 s simulated; reference: rkf45 at tol 1e-11)"
	echo
	table "$d/accuracy.csv"
	echo
	echo "![work-precision](../simulate-peer/work-precision.png)"
	echo
	echo "## Coarse simulation, subdivided, against fine (thesis scene, RK4, 1 s)"
	echo
	table "$d/levels.csv"
	echo
	echo "![levels](../simulate-peer/levels.png)"
	echo
	echo "## Restiffening (level 5, thesis scene, RK4 at half the critical step, 2 s)"
	echo
	table "$d/restiffen.csv"
	echo
	echo "## Penalty pins (level 4, thesis scene, pins within 0.15 m of (0, 0.45, 0.89))"
	echo
	table "$d/penalty.csv"
	echo
	echo "![penalty](../simulate-peer/penalty.png)"
} >"$out"
cat "$out"
