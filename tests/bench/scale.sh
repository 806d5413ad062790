#!/usr/bin/env bash
# tests/bench/scale.sh — every tool at levels 6-10: wall time and peak
# memory (the largest resident set, /usr/bin/time) of whole processes, as
# a user runs them, and the cost per node against the node count (O(n) is
# a flat line).  Writes docs/bench/scale.md and docs/bench/scale.png.
#
#   remesh         a dense scan (bunny00 remeshed to level 7 and refined to a
#                  mesh of level 8: 131,074 vertices) to levels 8 and 9
#   subdivide      level L-1 → L, file to file
#   simulate-peer  rk4 (both threads) and backward Euler (CHOLMOD): the
#                  steps/s of its summary line, after the setup
#   render-frame   one frame, process to PNG; streaming: a stream of 4 grids
#   net-bench      a full state encoded and decoded (bench_codec, predict),
#                  up to level CODEC_MAX (default 10; 31 s and 1.1 GB at level 10
#                  on 2026-11-25, loaded)
#
# LEVELS (default 6 7 8 9 10) chooses the levels.  The machine is shared:
# the load is printed before and after; every process runs once (memory is
# exact, times are one sample each — the slopes, not the digits, are the
# result).
set -euo pipefail
cd "$(dirname "$0")/../.."
PATH=$PWD/bin:$PATH
tb=${NDO_TESTBIN:-build/tests}
levels=${LEVELS:-6 7 8 9 10}
dir=build/bench/scale
rm -rf "$dir" && mkdir -p "$dir"
md=docs/bench/scale.md
rows=$dir/rows.tsv
load0=$(cut -d' ' -f1-3 /proc/loadavg)
printf 'tool\tlevel\tnodes\tseconds\tpeak_kB\tper_unit\n' >"$rows"

nodes() { echo $((2 * (1 << (2 * $1)) + 2)); } # 2·4^L + 2 vertices
# run TOOL LEVEL CMD...: one process; its wall time and peak memory
run() {
	local tool=$1 level=$2
	shift 2
	/usr/bin/time -f '%e %M' -o "$dir/time" "$@" >"$dir/out" 2>"$dir/err" ||
		{ echo "scale.sh: $tool at level $level failed: $(tail -1 "$dir/err")" >&2; return 1; }
	read -r secs kb <"$dir/time"
	printf '%s\t%s\t%s\t%s\t%s\t%s\n' "$tool" "$level" "$(nodes "$level")" "$secs" "$kb" "${PER:-}" >>"$rows"
}

# The dense scan.
tar -xzf /usr/share/doc/libcgal-dev/data.tar.gz -C "$dir" data/meshes/bunny00.off
remesh "$dir/data/meshes/bunny00.off" -l 7 -o "$dir/bunny7.tgrid" 2>/dev/null
subdivide -l 1 "$dir/bunny7.tgrid" -o "$dir/scan.obj"
scan_v=$(grep -c '^v ' "$dir/scan.obj")

first=${levels%% *}
for L in $((first - 1)) $levels; do
	remesh --shape wavy -l "$L" -o "$dir/w$L.tgrid"
done
for L in $levels; do
	if [ "$L" -ge 8 ] && [ "$L" -le 9 ]; then
		run remesh "$L" remesh "$dir/scan.obj" -l "$L" -o "$dir/r$L.tgrid"
	fi
	run subdivide "$L" subdivide -l 1 "$dir/w$((L - 1)).tgrid" -o "$dir/s$L.tgrid"
	# steps: about 2 s of rk4 on 2 threads, a few implicit steps
	n=$((2 ** (2 * (11 - L)) / 2 + 3))
	run simulate-peer-rk4 "$L" simulate-peer -s samples/thesis-fig5.3.scene -n "$n" \
		"$dir/w$L.tgrid" -o "$dir/o.tgrid"
	sps=$(grep -o '[0-9.e+]* steps/s' "$dir/err" | cut -d' ' -f1)
	sed -i '$ s/\t$/\t'"$sps"' steps\/s/' "$rows"
	run simulate-peer-implicit "$L" simulate-peer -s samples/thesis-fig5.3.scene -i backward-euler \
		--dt 0.01 -n 5 "$dir/w$L.tgrid" -o "$dir/o.tgrid"
	sps=$(grep -o '[0-9.e+]* steps/s' "$dir/err" | cut -d' ' -f1)
	sed -i '$ s/\t$/\t'"$sps"' steps\/s/' "$rows"
	run render-frame "$L" render-frame -o "$dir/f.png" "$dir/w$L.tgrid"
	cat "$dir/w$L.tgrid" "$dir/w$L.tgrid" "$dir/w$L.tgrid" "$dir/w$L.tgrid" >"$dir/stream.tgrid"
	run render-frame-stream "$L" render-frame -o "$dir/f%d.png" "$dir/stream.tgrid"
	if [ -x "$tb/bench_codec" ] && [ "$L" -le "${CODEC_MAX:-10}" ]; then
		run net-bench-codec "$L" "$tb/bench_codec" -l "$L" -e predict -n 12
		ms=$(grep -o 'CPU time [0-9.]* + [0-9.]* ms' "$dir/out" | awk '{ print $3 + $5 }')
		sed -i '$ s/\t$/\t'"$ms"' ms encode+decode/' "$rows"
	fi
done
load1=$(cut -d' ' -f1-3 /proc/loadavg)

/usr/bin/python3 - "$rows" docs/bench/scale.png <<'PY'
import csv, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
rows = list(csv.DictReader(open(sys.argv[1]), delimiter="\t"))
tools = []
for r in rows:
    if r["tool"] not in tools:
        tools.append(r["tool"])
fig, ax = plt.subplots(figsize=(7.5, 4.8))
for t in tools:
    pts = [(int(r["nodes"]), float(r["seconds"])) for r in rows if r["tool"] == t]
    ax.loglog([p[0] for p in pts], [p[1] for p in pts], "o-", label=t)
n0 = min(int(r["nodes"]) for r in rows)
n1 = max(int(r["nodes"]) for r in rows)
t0 = min(float(r["seconds"]) for r in rows if int(r["nodes"]) == n0)
ax.loglog([n0, n1], [t0, t0 * n1 / n0], "k--", lw=1, label="O(n)")
ax.set_xlabel("grid vertices")
ax.set_ylabel("wall seconds (one process)")
ax.set_title("Every tool from level 6 to 10")
ax.legend(fontsize=7)
ax.grid(True, which="both", alpha=0.3)
fig.tight_layout()
fig.savefig(sys.argv[2], dpi=110)
PY

{
	echo "# Every tool at levels 6-10: time and memory"
	echo
	echo "Made by \`tests/bench/run scale\` (\`tests/bench/scale.sh\`) on $(date -u +%Y-%m-%d), $(nproc) cores" \
		"($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')), load average $load0 before" \
		"and $load1 after.  One process per row, as a user runs it: wall seconds (one sample each, on a shared" \
		"machine) and peak resident memory (\`/usr/bin/time\`, exact).  remesh's input is a dense scan:" \
		"bunny00 remeshed to level 7 and refined to a mesh of $scan_v vertices, remeshed to levels 8 and 9."
	echo
	echo "![cost against nodes](scale.png)"
	echo
	echo "| tool | level | vertices | wall (s) | peak memory (MB) | |"
	echo "|---|---:|---:|---:|---:|---|"
	tail -n +2 "$rows" | awk -F'\t' '{ printf "| %s | %s | %s | %s | %.0f | %s |\n", $1, $2, $3, $4, $5 / 1024, $6 }'
} >"$md"
cat "$md"
