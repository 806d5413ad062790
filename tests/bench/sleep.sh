#!/usr/bin/env bash
# tests/bench/sleep.sh — sleeping tiles (simulate-peer --sleep, issue 18):
# on scenes where the motion stays local and where it reaches everywhere,
# level 7, rk4, one thread: the node-steps saved, the CPU time against the
# same run with every tile awake (medians of RUNS alternating pairs, the
# stepping's seconds from the run's summary), and the error added (the largest
# distance to the every-node run over its largest displacement), for D a
# share 1e-3, 1e-5, 1e-7 of that displacement.  Writes docs/bench/sleep.md.
#   RUNS=5 tests/bench/sleep.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
export PATH=${NDO_BIN:-$PWD/bin}:$PATH
RUNS=${RUNS:-5}
w=build/bench/sleep
out=docs/bench/sleep.md
mkdir -p "$w" docs/bench
TG="/usr/bin/python3 tests/e2e/tgrid.py"
export PYTHONPATH=$PWD/tests/e2e
remesh --shape sphere -l 7 -o "$w/sphere7.tgrid" 2>/dev/null
remesh --shape wavy -l 7 -o "$w/wavy7.tgrid" 2>/dev/null
# a state where everything moves: the thesis scene after 6 s
simulate-peer -q --threads 1 "$w/wavy7.tgrid" -s samples/thesis-fig5.3.scene -t 6 -o "$w/moving7.tgrid"
scenes=("tap|$w/sphere7.tgrid|tests/bench/sleep/tap.scene|4"
	"poke|$w/sphere7.tgrid|tests/bench/accuracy/poke.scene|2"
	"fig5.3|$w/wavy7.tgrid|samples/thesis-fig5.3.scene|5"
	"fig5.3 moving|$w/moving7.tgrid|samples/thesis-fig5.3.scene|2")
median() { sort -g | awk '{ a[NR] = $1 } END { print (NR % 2) ? a[(NR + 1) / 2] : (a[NR / 2] + a[NR / 2 + 1]) / 2 }'; }
cpu() { # cpu OUT ARGS...: the seconds of one run's stepping (its summary line)
	local o=$1; shift
	simulate-peer --threads 1 "$@" -o "$o" 2>&1 | sed -n 's/.* steps to t = .* in \([0-9.e+-]*\) s: .*/\1/p'
}
load0=$(cut -d' ' -f1-3 /proc/loadavg)
rows=""
for sc in "${scenes[@]}"; do
	IFS='|' read -r name grid scene t <<<"$sc"
	simulate-peer -q --threads 1 "$grid" -s "$scene" -t "$t" -o "$w/awake.tgrid"
	big=$($TG "$w/awake.tgrid" "float(abs(position - rest).max())")
	for share in 1e-3 1e-5 1e-7; do
		d=$(awk -v b="$big" -v s="$share" 'BEGIN { printf "%.3g", b * s }')
		simulate-peer --threads 1 "$grid" -s "$scene" -t "$t" --sleep "$d" -o "$w/asleep.tgrid" 2>"$w/log"
		saved=$(sed -n 's/.*node-steps taken (\([0-9.]*\)% saved).*/\1/p' "$w/log")
		off=$($TG "$w/asleep.tgrid" "float(abs(position - __import__('tgrid').read('$w/awake.tgrid')[3]['position']).max() / $big)")
		: >"$w/ratios"
		for ((r = 0; r < RUNS; r++)); do
			a=$(cpu "$w/a.tgrid" "$grid" -s "$scene" -t "$t")
			s=$(cpu "$w/s.tgrid" "$grid" -s "$scene" -t "$t" --sleep "$d")
			awk -v a="$a" -v s="$s" 'BEGIN { if (a > 0) print s / a }' >>"$w/ratios"
		done
		rows="$rows
| $name | $share | $d | $saved% | $(printf %.2f "$(median <"$w/ratios")") | $(printf %.2g "$off") |"
		echo "$name, D = $share of $big m: $saved% saved" >&2
	done
done
load1=$(cut -d' ' -f1-3 /proc/loadavg)
{
	echo "# Sleeping tiles: what \`--sleep\` saves and costs"
	echo
	echo "\`RUNS=$RUNS $0\`, $(date -u +%Y-%m-%dT%H:%MZ), $(nproc) cores; load average"
	echo "before $load0, after $load1.  Level 7 (32,770 vertices), rk4 at its automatic step, one"
	echo "thread.  D: \`--sleep\`'s bound, as a share of the every-node run's largest displacement."
	echo "Time ratio: the stepping's seconds (the summary line's, setup and output excluded) with"
	echo "\`--sleep D\` over the same run with every tile awake, median of $RUNS alternating pairs."
	echo "Error added: the largest distance to the every-node run, over its largest displacement."
	echo
	echo "| scene | D (share) | D (m) | node-steps saved | time ratio | error added |"
	echo "|---|---|---|---|---|---|$rows"
} >"$out.tmp"
mv "$out.tmp" "$out"
cat "$out"
