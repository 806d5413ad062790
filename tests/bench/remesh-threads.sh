#!/usr/bin/env bash
# tests/bench/remesh-threads.sh — remesh with 1 and 2 OpenMP threads, on a
# quiet machine and under load (LOADERS busy loops beside it), bunny00 to
# level 7: medians of RUNS runs, the load average printed with each row.
# Writes docs/bench/remesh-threads.md.  Issue 17's goals: 2 threads never
# slower than 1 at any load; bunny00 to level 7 in at most 10 s.
#   RUNS=5 LOADERS="0 2" MESH=bunny00 LEVEL=7 tests/bench/remesh-threads.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
NDO_BIN=${NDO_BIN:-$PWD/bin}
RUNS=${RUNS:-3}
LOADERS=${LOADERS:-0 2}
MESH=${MESH:-bunny00}
LEVEL=${LEVEL:-7}
out=${OUT:-docs/bench/remesh-threads.md}
work=build/bench/remesh-threads
mkdir -p "$work" "$(dirname "$out")"
[ -d build/bench/cgal-data/data/meshes ] || {
	mkdir -p build/bench/cgal-data
	tar -xzf /usr/share/doc/libcgal-dev/data.tar.gz -C build/bench/cgal-data data/meshes
}
in=build/bench/cgal-data/data/meshes/$MESH.off
median() { sort -g | awk '{ a[NR] = $1 } END { print (NR % 2) ? a[(NR + 1) / 2] : (a[NR / 2] + a[NR / 2 + 1]) / 2 }'; }
pids=()
stop_load() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; pids=(); }
trap 'stop_load; rm -f "$out.tmp"' EXIT
{
	echo "# remesh: 1 and 2 threads, quiet and loaded"
	echo
	echo "\`$0\` (RUNS=$RUNS, LOADERS=\"$LOADERS\"), $(date -u +%Y-%m-%dT%H:%MZ), $(nproc) cores"
	echo "($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //')); $MESH.off to level $LEVEL, wall seconds"
	echo "from start to the grid written (remesh -l $LEVEL, no --report), median of $RUNS; load"
	echo "average (1 min) read before each row; LOADERS busy loops run beside remesh."
	echo
	echo "| extra busy loops | load before | 1 thread | 2 threads | 2 threads / 1 |"
	echo "|---|---|---|---|---|"
} >"$out.tmp"
for n in $LOADERS; do
	stop_load
	for ((k = 0; k < n; k++)); do (while :; do :; done) & pids+=($!); done
	load=$(cut -d' ' -f1 /proc/loadavg)
	declare -A med
	for t in 1 2; do
		for ((r = 0; r < RUNS; r++)); do
			s=$(date +%s.%N)
			OMP_NUM_THREADS=$t "$NDO_BIN/remesh" "$in" -l "$LEVEL" -o "$work/out.tgrid" 2>/dev/null
			e=$(date +%s.%N)
			echo "$e - $s" | bc
		done >"$work/t$t-l$n.txt"
		med[$t]=$(median <"$work/t$t-l$n.txt")
		echo "loaders $n, $t thread(s): $(tr '\n' ' ' <"$work/t$t-l$n.txt")-> median ${med[$t]} s (load $load)" >&2
	done
	printf '| %s | %s | %.2f | %.2f | %.2f |\n' "$n" "$load" "${med[1]}" "${med[2]}" \
		"$(echo "${med[2]} / ${med[1]}" | bc -l)" >>"$out.tmp"
done
stop_load
mv "$out.tmp" "$out"
cat "$out"
