#!/usr/bin/env bash
# tests/bench/kernel-pair.sh BASELINE [ROUNDS] — the RK4 kernel of this
# build against another build's bench_simulate (BASELINE, e.g. a copy of
# main's build/tests/bench_simulate), in alternating runs: `kernel 5 6 7 8`
# (one thread, CPU time) and `pipeline 2 7 8` (the pipeline's steps/s
# of wall time on 2 threads), ROUNDS rounds (default 5) of this build then
# the baseline.  Prints a Markdown table: each build's median steps/s, the
# median of the rounds' ratios (this / baseline), and this build's share
# of the roofline tests/bench/simulate.sh computes (0.26 flop/byte times
# the L2 triad of `bench_simulate limits`, measured here once).
set -euo pipefail
cd "$(dirname "$0")/../.."
B=${NDO_TESTBIN:-build/tests}
base=${1:?usage: tests/bench/kernel-pair.sh BASELINE_BENCH_SIMULATE [ROUNDS]}
rounds=${2:-5}
[ -x "$base" ] || { echo "kernel-pair.sh: $base: not an executable" >&2; exit 1; }
t=$(mktemp -d)
trap 'rm -rf "$t"' EXIT
l2=$("$B/bench_simulate" limits | awk -F'|' '$2 ~ /triad, 256 KiB/ { gsub(/[^0-9.]/, "", $3); print $3 }')
for r in $(seq "$rounds"); do
	for who in new base; do
		bin=$B/bench_simulate
		[ "$who" = base ] && bin=$base
		"$bin" kernel 5 6 7 8 | awk -F'|' -v w="$who" -v r="$r" \
			'NR > 2 { gsub(/ /, ""); print r, w, "1", $2, $5, $6 }' >>"$t/runs"
		"$bin" pipeline 2 7 8 | awk -F'|' -v w="$who" -v r="$r" \
			'NR > 2 { gsub(/ /, ""); print r, w, "2", $2, $8, 0 }' >>"$t/runs"
	done
done
echo "| threads | level | baseline (steps/s) | this build (steps/s) | ratio | this build, % of the roofline |"
echo "|---:|---:|---:|---:|---:|---:|"
sort -s -k3,3n -k4,4n -k1,1n "$t/runs" | awk -v l2="$l2" '
	function median(a, n,    i, j, x) {
		for (i = 2; i <= n; i++)
			for (j = i; j > 1 && a[j - 1] > a[j]; j--) {
				x = a[j]; a[j] = a[j - 1]; a[j - 1] = x
			}
		return n % 2 ? a[(n + 1) / 2] : (a[n / 2] + a[n / 2 + 1]) / 2
	}
	function flush(    q, i) {
		if (key == "")
			return
		for (i = 1; i <= n; i++)
			q[i] = nw[i] / bs[i]
		split(key, kk, " ")
		roof = kk[1] == 1 ? sprintf("%.0f%%", 100 * median(gf, n) / (0.26 * l2)) : "-"
		printf "| %d | %d | %.4g | %.4g | %.3f | %s |\n", kk[1], kk[2], median(bs, n), median(nw, n), median(q, n), roof
		split("", nw); split("", bs); split("", gf); n = 0
	}
	{
		k = $3 " " $4
		if (k != key) { flush(); key = k }
		if ($2 == "new") { n++; nw[n] = $5; gf[n] = $6 } else bs[n] = $5
	}
	END { flush() }'
echo
echo "$rounds rounds, L2 triad $l2 GB/s, load average $(cut -d' ' -f1-3 /proc/loadavg) at the end."
