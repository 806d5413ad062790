#!/usr/bin/env bash
# tests/bench/render.sh — render-frame's speed (docs/bench/render.md).
#
# Per level 4..8 at 1024x768 (wavy surface, default options): the time per
# frame of a long-running render-frame (a stream of grids, PNGs written),
# the wall time of a one-frame process (start-up, context, shader compile,
# drawing, PNG), and the minimal llvmpipe program bench_render_llvmpipe
# drawing the same triangles (with glibc's default malloc, and keeping
# freed memory as render-frame does).  Then, at level 7: llvmpipe's thread
# count (LP_NUM_THREADS), multisampling, PNG compression levels, culling,
# the EGL back end.
#
# The machine is shared: every figure is measured in ROUNDS rounds whose
# runs are interleaved, and reported as the median over rounds and the best
# round (the least disturbed), with the CPU time per frame of all threads,
# which other users' load disturbs much less than the wall time.
set -euo pipefail
cd "$(dirname "$0")/../.."
PATH=$PWD/bin:$PATH
tb=${NDO_TESTBIN:-build/tests}
rounds=${ROUNDS:-5}
frames=${FRAMES:-40}
oneshots=${ONESHOTS:-5}
dir=build/bench/render
rm -rf "$dir" && mkdir -p "$dir"
md=docs/bench/render.md
mkdir -p docs/bench

# thesis Table 5.1 (full resolution rows): fps on a Quadro FX3400
declare -A thesis=([4]=66.67 [5]=66.67 [6]=21.27 [7]=5.81 [8]="")

for l in 4 5 6 7 8; do
	remesh --shape wavy -l $l -o "$dir/wavy-$l.tgrid"
	for ((k = 0; k < frames; k++)); do cat "$dir/wavy-$l.tgrid"; done > "$dir/stream-$l.tgrids"
done

median() { sort -g | awk '{v[NR] = $1} END {if (NR % 2) print v[(NR + 1) / 2]; else print (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }
best() { sort -g | head -1; }
# stream L CMD...: "wall cpu": render-frame's median ms per frame over a
# stream, and its CPU ms per frame after the first
stream() {
	local l=$1; shift
	"$@" -v -o "$dir/f-%03d.png" "$dir/stream-$l.tgrids" 2>&1 >/dev/null |
		sed -n 's/.*median \([0-9.]*\) ms per frame.*CPU \([0-9.]*\) ms per frame.*/\1 \2/p'
}
# oneshot L: wall ms of one render-frame process, the median of $oneshots
oneshot() {
	local l=$1
	for ((k = 0; k < oneshots; k++)); do
		local t0=$(date +%s%N)
		render-frame -o "$dir/one.png" "$dir/wavy-$l.tgrid"
		local t1=$(date +%s%N)
		awk -v a=$t0 -v b=$t1 'BEGIN {print (b - a) / 1e6}'
	done | median
}
# minimal L M: "wall cpu" of bench_render_llvmpipe
minimal() {
	"$tb/bench_render_llvmpipe" -l "$1" -n "$frames" -m "$2" |
		sed -n 's/.*median \([0-9.]*\) ms.*CPU \([0-9.]*\) ms per frame.*/\1 \2/p'
}
# field N "a b c": the N-th column of "wall cpu" pairs, one per line
field() { awk -v n=$1 '{for (i = n; i <= NF; i += 2) print $i}' <<<"$2"; }

variants=("default|env render-frame"
          "LP_NUM_THREADS=0 (llvmpipe draws on the main thread)|env LP_NUM_THREADS=0 render-frame"
          "LP_NUM_THREADS=1|env LP_NUM_THREADS=1 render-frame"
          "LP_NUM_THREADS=2 (the default here: one per core)|env LP_NUM_THREADS=2 render-frame"
          "LP_NUM_THREADS=4|env LP_NUM_THREADS=4 render-frame"
          "--msaa 4|env render-frame --msaa 4"
          "--compression 0 (stored)|env render-frame --compression 0"
          "--compression 6 (zlib's default)|env render-frame --compression 6"
          "--compression 9|env render-frame --compression 9"
          "--no-cull (back faces drawn too)|env render-frame --no-cull"
          "--backend egl|env render-frame --backend egl"
          "--cloth --wireframe|env render-frame --cloth --wireframe")
# One round measures everything once, so that a busy spell of the machine
# falls on one round of every figure rather than on all rounds of a few.
declare -A S O M0 M1 X
for ((r = 0; r < rounds; r++)); do
	for l in 4 5 6 7 8; do
		S[$l]+="$(stream $l env render-frame) "
		O[$l]+="$(oneshot $l) "
		M0[$l]+="$(minimal $l 0) "
		M1[$l]+="$(minimal $l 1) "
	done
	for v in "${variants[@]}"; do
		read -r -a cmd <<<"${v#*|}"
		X[$v]+="$(stream 7 "${cmd[@]}") "
	done
done
declare -A SIZE
for c in 0 1 6 9; do
	render-frame --compression $c -o "$dir/c$c.png" "$dir/wavy-7.tgrid"
	SIZE[$c]=$(stat -c %s "$dir/c$c.png")
done

fps() { awk -v s=$1 'BEGIN {printf "%.0f", 1000 / s}'; }
{
	gl=$(render-frame -v -o /dev/null "$dir/wavy-4.tgrid" 2>&1 | sed -n 's/.*back end, \(.*\); context.*/\1/p' | head -1)
	echo "# render-frame: speed"
	echo
	echo "Made by \`tests/bench/render.sh\` (\`make bench\`), $(date -u '+%Y-%m-%d %H:%M UTC'), on"
	echo "$(nproc) cores of $(lscpu | sed -n 's/^Model name: *//p' | head -1), $gl."
	echo "The machine is shared with other engineers' builds (load average at the end:"
	echo "$(cut -d' ' -f1-3 /proc/loadavg)): every figure was measured in $rounds rounds whose runs were"
	echo "interleaved; *median* is over the rounds, *best* the least disturbed round, *CPU* the"
	echo "processor time per frame of all threads (median over rounds), which other users' load"
	echo "disturbs much less than the wall time.  A wavy surface at 1024x768, $frames frames per"
	echo "stream, default options (no multisampling, PNG zlib level 1, back faces culled)."
	echo
	echo "## Frame time per level"
	echo
	echo "| level | triangles | thesis Table 5.1 | minimal llvmpipe, glibc malloc: median / best | minimal, memory kept: median / best, CPU | **render-frame streaming**: median / best, CPU | best fps | CPU render-frame / minimal | **render-frame one-shot** (process): median / best |"
	echo "|---|---|---|---|---|---|---|---|---|"
	for l in 4 5 6 7 8; do
		th=${thesis[$l]}
		if [ -n "$th" ]; then th="$th fps ($(awk -v f=$th 'BEGIN{printf "%.1f", 1000 / f}') ms)"; else th="—"; fi
		sw=$(field 1 "${S[$l]}" | median); sb=$(field 1 "${S[$l]}" | best); sc=$(field 2 "${S[$l]}" | median)
		m0=$(field 1 "${M0[$l]}" | median); m0b=$(field 1 "${M0[$l]}" | best)
		m1=$(field 1 "${M1[$l]}" | median); m1b=$(field 1 "${M1[$l]}" | best); m1c=$(field 2 "${M1[$l]}" | median)
		o=$(field 1 "${O[$l]}" | median); ob=$(field 1 "${O[$l]}" | best)
		printf '| %d | %d | %s | %.1f / %.1f ms | %.1f / %.1f ms, CPU %.1f ms | **%.1f / %.1f ms**, CPU %.1f ms | **%s** | %.2f | **%.0f / %.0f ms** |\n' \
			$l $((4 ** (l + 1))) "$th" "$m0" "$m0b" "$m1" "$m1b" "$m1c" "$sw" "$sb" "$sc" \
			"$(fps $sb)" "$(awk -v a=$sc -v b=$m1c 'BEGIN {print a / b}')" "$o" "$ob"
	done
	echo
	echo "- Streaming: \`render-frame -v -o 'f-%03d.png' stream.tgrids\` on $frames grids: its own median"
	echo "  time per frame (read, upload, draw, read back; the PNGs are encoded by a second thread"
	echo "  meanwhile) and its CPU time per frame after the first."
	echo "- One-shot: the wall time of \`render-frame -o one.png wavy-L.tgrid\`, median of $oneshots runs per"
	echo "  round: process start, OpenGL context, shader compile, llvmpipe's first-draw JIT, PNG."
	echo "- Minimal: \`$tb/bench_render_llvmpipe -l L -m 0|1\` ([source](../../tests/bench/bench_render_llvmpipe.c)):"
	echo "  clear, one glDrawElements of the same triangles with precomputed vertex normals and a"
	echo "  one-line shader, glReadPixels; no culling, no PNG.  \`-m 1\` keeps freed memory as"
	echo "  render-frame does."
	echo "- Thesis: Table 5.1, an NVIDIA Quadro FX3400 GPU on a dual Xeon 3.4 GHz (2006)."
	echo
	echo "## Level 7 (65,536 triangles), variations"
	echo
	echo "| render-frame, level-7 stream | median / best ms per frame | best fps | CPU ms per frame |"
	echo "|---|---|---|---|"
	for v in "${variants[@]}"; do
		w=$(field 1 "${X[$v]}" | median); b=$(field 1 "${X[$v]}" | best); c=$(field 2 "${X[$v]}" | median)
		printf '| %s | %.1f / %.1f | %s | %.1f |\n' "${v%%|*}" "$w" "$b" "$(fps $b)" "$c"
	done
	echo
	echo "PNG size of the level-7 frame: zlib level 0 ${SIZE[0]} bytes, 1 ${SIZE[1]}, 6 ${SIZE[6]}, 9 ${SIZE[9]}."
} > "$md.tmp"
mv "$md.tmp" "$md"
cat "$md"
