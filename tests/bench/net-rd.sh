#!/usr/bin/env bash
# net-rd — rate against distortion over real LCM (issue 20): bits per
# vertex per update on the wire (steady state, every header) against the
# error at the simulated level (max and RMS over the rest shape's box
# diagonal) for every encoding — float32, fixed, predict and hier at error
# budgets 1e-3 ... 1e-6 — and send level (the simulated level and one and
# two below), the thesis' scene for 5 s, levels 6 and 7, one simulating
# peer streaming to an observer (Table 5.2's setting).  Writes
# docs/bench/net-rd.md (every row with its command) and docs/bench/net-rd.svg.
# The machine is shared: everything runs under nice; the bits and errors do
# not depend on the load (times are not reported here).
set -euo pipefail
cd "$(dirname "$0")/../.."
export PATH=$PWD/bin:$PATH
out=docs/bench/net-rd.md
work=build/bench/net-rd
rm -rf "$work" && mkdir -p "$work"
make -s bin/net-bench >/dev/null
N="nice -n 5"
encs="float32 fixed:1e-3 fixed:1e-4 fixed:1e-5 fixed:1e-6 predict:1e-3 predict:1e-4 predict:1e-5
predict:1e-6 hier:1e-3 hier:1e-4 hier:1e-5 hier:1e-6"
: >"$work/rows.csv"
: >"$work/commands.txt"
for l in 6 7; do
	for e in $encs; do
		c="net-bench -l $l -e $e --peers 1 -s $((l - 2)),$((l - 1)),$l --csv -"
		echo "$c" >>"$work/commands.txt"
		$N $c 2>"$work/err.txt" >"$work/one.csv" || { cat "$work/err.txt" >&2; exit 1; }
		if [ ! -s "$work/rows.csv" ]; then head -1 "$work/one.csv" >"$work/rows.csv"; fi
		tail -n +2 "$work/one.csv" >>"$work/rows.csv"
	done
done
load=$(cat /proc/loadavg)
/usr/bin/python3 tests/bench/net_rd_plot.py "$work/rows.csv" docs/bench/net-rd.svg >"$work/table.md"
{
	echo "# Rate against distortion: encodings and send levels (net-bench)"
	echo
	echo "Made by \`tests/bench/net-rd.sh\` on $(date -u +%Y-%m-%d), $(nproc) cores,"
	echo "$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), shared with other work"
	echo "(load average at the end: $load).  Every row: \`net-bench -l L -e E --peers 1"
	echo "-s L-2,L-1,L --csv -\` (the commands below), the thesis' scene (figure 5.3) for 5 s, the"
	echo "owner streaming whole regions every step to an observer over real LCM in a private"
	echo "network namespace.  *bits/vertex* are the steady state's bits on the wire, every"
	echo "header included, over the distinct vertices of the simulated level (2·4^L + 2) and"
	echo "the owner's steps; *max* and *RMS* the error at the simulated level of what the"
	echo "observer holds (the coarse nodes as it decodes them, refined by the butterfly)"
	echo "against the exact state, over the rest shape's box diagonal; *disp* the same for a"
	echo "receiver that refines the displacement onto the rest shape instead (net-bench's CSV)."
	echo
	echo "![bits per vertex per update against the error](net-rd.svg)"
	echo
	cat "$work/table.md"
	echo
	echo "Commands:"
	echo
	sed 's/^/    /' "$work/commands.txt"
} >"$out"
cat "$work/table.md"
