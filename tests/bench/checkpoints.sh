#!/usr/bin/env bash
# checkpoints — what exact restarts cost when nothing happens (docs/peers.md,
# "Joins, leaves, a dead peer"; docs/bench/peers.md §6): 3 peers over LCM in
# a private network namespace, lock-step rk4, the thesis' scene at level L
# (default 6) for 5 s, --checkpoint-every 20 against 0 (none), REPS runs
# each (default 3), alternating: the owner's stepping time and the bytes a
# joiner sent, of which checkpoints.
#   tests/bench/checkpoints.sh [L] [REPS]
set -uo pipefail
cd "$(dirname "$0")/../.."
. tests/e2e/netns.bash
L=${1:-6} REPS=${2:-3}
root=$PWD
export PATH=$root/bin:$PATH
T=$(mktemp -d)
cd "$T" || exit 1
remesh --shape wavy -l "$L" -o wavy.tgrid 2>/dev/null || exit 1
faces=$((4 << (2 * L)))
echo "load before: $(cat /proc/loadavg)"
for ((rep = 1; rep <= REPS; rep++)); do
	for c in 20 0; do
		simulate-peer --owner wavy.tgrid -s "$root/samples/thesis-fig5.3.scene" --peers 3 \
			--checkpoint-every $c -o out.tgrid 2>owner.err &
		o=$!
		simulate-peer --join --poi $((faces / 5)) 2>j1.err &
		a=$!
		simulate-peer --join --poi $((faces * 3 / 4)) 2>j2.err &
		b=$!
		wait $o $a $b
		t=$(grep -o 'steps to step [0-9]* in [0-9.]* s' owner.err | awk '{print $6}')
		sent=$(grep -o 'sent [0-9.]* MB' j1.err | awk '{print $2}')
		ck=$(grep -o '[0-9.e+]* kB of them sent' j1.err | awk '{print $1}')
		echo "level $L, C $c, run $rep: owner stepping $t s; joiner 1 sent $sent MB, checkpoints ${ck:-0} kB"
	done
done
echo "load after: $(cat /proc/loadavg)"
rm -rf "$T"
