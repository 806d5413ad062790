#!/usr/bin/env bash
# split — what rkf45 and the implicit methods cost when peers split them
# exactly (docs/peers.md, "rkf45 and the implicit methods"):
#   1. in one process on the in-memory link (fake clock: counts that do not
#      depend on the machine): difference from the single process,
#      exchanges and halo bytes a step, rkf45's attempts, the solve's
#      iterations with each region's block or the diagonal as the
#      preconditioner (bench_peers split -l 6);
#   2. over real LCM in a private network namespace, 2 peers (each one
#      thread) against one single-threaded process, thesis scene, level
#      SPLIT_LEVELS (default "5 6 7"): the steps per second of the stepping,
#      medians of SPLIT_RUNS (default 3) runs, and the difference.
set -euo pipefail
cd "$(dirname "$0")/../.."
. tests/e2e/netns.bash
NDO_ROOT=$PWD
. tests/e2e/peers.bash # compare
export PATH=$PWD/bin:$PATH
out=docs/bench/split.md
work=build/bench/split
rm -rf "$work" && mkdir -p "$work"
SCENE=samples/thesis-fig5.3.scene
RUNS=${SPLIT_RUNS:-3}
LEVELS=${SPLIT_LEVELS:-5 6 7}

counts_cmd="build/tests/bench_peers split -l 6"
counts=$($counts_cmd)

physics() { # METHOD: rkf45 has no stable step to pick, the implicit ones any
	case $1 in
	rkf45) echo "-i rkf45 --dt 0.02 -t 2" ;;
	*) echo "-i $1 --dt 0.05 -t 5" ;;
	esac
}

median() { sort -g | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)] }'; }

rows=""
for level in $LEVELS; do
	grid=$work/wavy$level.tgrid
	remesh --shape wavy -l "$level" -o "$grid" 2>/dev/null
	poi=$((3 * 4 ** (level + 1) / 4)) # a face on the far side of the owner's
	for m in rkf45 backward-euler trapezoid; do
		one=() two=() blk=() d=""
		for ((r = 0; r < RUNS; r++)); do
			# shellcheck disable=SC2046
			simulate-peer --threads 1 --no-estimate "$grid" -s "$SCENE" $(physics "$m") -o "$work/one.tgrid" \
				2>"$work/one.err"
			one+=("$(grep -o '[0-9.]* steps/s' "$work/one.err" | head -1 | cut -d' ' -f1)")
			# the implicit methods twice: preconditioned by the diagonal (the
			# default), then by each region's block (--precondition block)
			for pc in diagonal block; do
				[ "$m" = rkf45 ] && [ $pc = block ] && continue
				# shellcheck disable=SC2046
				simulate-peer --owner "$grid" -s "$SCENE" $(physics "$m") --peers 2 \
					--step-timeout 30 --precondition $pc -o "$work/two-$pc.tgrid" \
					2>"$work/owner-$pc.err" &
				local_owner=$!
				simulate-peer --join --poi "$poi" --precondition $pc 2>"$work/joiner.err"
				wait "$local_owner"
				# "N steps to step S in T s"
				read -r n t < <(sed -n 's/.* \([0-9]*\) steps to step [0-9]* in \([0-9.e-]*\) s.*/\1 \2/p' \
					"$work/owner-$pc.err" | head -1)
				if [ $pc = diagonal ]; then two+=("$(awk "BEGIN{print $n / $t}")"); else blk+=("$(awk "BEGIN{print $n / $t}")"); fi
			done
			d=$(compare "$work/two-diagonal.tgrid" "$work/one.tgrid" | cut -d" " -f1)
		done
		o=$(printf '%s\n' "${one[@]}" | median)
		w=$(printf '%s\n' "${two[@]}" | median)
		b="" bx=""
		if [ "$m" != rkf45 ]; then
			b=$(printf '%.0f' "$(printf '%s\n' "${blk[@]}" | median)")
			bx=$(awk "BEGIN{printf \"%.1f\", $(grep -o 'in [0-9]* exchanges' "$work/owner-block.err" | head -1 | cut -d' ' -f2) / $(sed -n 's/.* \([0-9]*\) steps to step .*/\1/p' "$work/owner-block.err" | head -1)}")
		fi
		ex=$(grep -o 'in [0-9]* exchanges' "$work/owner-diagonal.err" | head -1 | cut -d' ' -f2)
		kb=$(grep -o '[0-9.]* kB a step' "$work/owner-diagonal.err" | head -1 | cut -d' ' -f1)
		steps=$(sed -n 's/.* \([0-9]*\) steps to step .*/\1/p' "$work/owner-diagonal.err" | head -1)
		rows+="| $level | $m | $(printf '%.0f' "$o") | $(printf '%.0f' "$w") | $(awk "BEGIN{printf \"%.2f\", $w / $o}") | $(awk "BEGIN{printf \"%.1f\", $ex / $steps}") | $kb | $d | $b | $bx |"$'\n'
		echo "level $level $m: one $o, two $w steps/s (block: ${b:-—}), difference $d" >&2
	done
done

load=$(cut -d' ' -f1-3 /proc/loadavg)
cat >"$out" <<EOF
# rkf45 and the implicit methods split exactly: what it costs

Made by \`tests/bench/run split\` (tests/bench/split.sh) on $(date -u +%Y-%m-%d), $(nproc) cores,
load average at the end $load (the machine may be shared: ratios within one run mean more
than absolute speeds).

## 1. Counts (one process, in-memory link, fake clock)

\`$counts_cmd\`: 1 s of the thesis scene (figure 5.3) at level 6; "exchanges a step" are
rounds of messages every peer waits for; "difference" the largest position difference from
the single process over its largest displacement — for the implicit methods a single process
solving with CHOLMOD (scene \`solver cholmod\`): the peers' own solve's accuracy.

$counts

## 2. Speed over LCM (2 peers in a private network namespace, one thread each)

Steps per second of the stepping (the owner's report), against one single-threaded process
(\`--threads 1\`) in the same run, medians of $RUNS; rkf45 at --dt 0.02 for 2 s, the implicit methods at
--dt 0.05 for 5 s; the difference is the last run's, against the single process as a user
runs it (\`--solver auto\`: multigrid from level 6, to a relative residual of 10⁻¹² a step,
so from level 6 it includes the multigrid's own error).  The implicit methods' solve over the
peers is preconditioned by the diagonal (the default); the last two columns: the same runs
with \`--precondition block\` on both peers (each region's block, factored by CHOLMOD).

| level | method | one process, steps/s | 2 peers, steps/s | × one process | exchanges a step | halo kB a step (owner) | difference | 2 peers, block, steps/s | its exchanges a step |
|---|---|---:|---:|---:|---:|---:|---:|---:|---:|
$rows
Reading: rkf45 pays one round of messages per attempted sub-step (2–3 a step here) and a
4-ring halo, and 2 peers still outrun one process; the implicit methods replace
the single process's solve (multigrid or CHOLMOD) by conjugate gradients over the peers,
each iteration a round of messages that every peer waits for: with the diagonal an
iteration costs a product over the region's rows and one pass over its vectors (block by
block, while the product's block is in the cache), with the region's block also a solve
with its CHOLMOD factor (three right-hand sides, mostly BLAS), which takes longer than the
rounds it saves.  So the split implicit methods gain where a region's rows take longer to
compute than a round of messages and lose where they take less: compare the levels above
(the single process's solver also needs fewer iterations than Jacobi's, the peers more
rounds as h grows, §1).
EOF
cat "$out"
