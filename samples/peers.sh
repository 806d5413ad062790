#!/usr/bin/env bash
# samples/peers.sh [-n N] GRID SCENE OUT — script a multi-peer run: N
# simulate-peer processes (default 2: the owner and N-1 joiners, each asking
# for a share around its own point of interest) simulate GRID with SCENE
# over LCM, inside a private network namespace so that the traffic stays on
# this machine and other runs don't hear it.  The owner writes the whole
# object with its owner channel to OUT/end.tgrid and a frame every $EVERY
# steps (default 20) to OUT/frames/; each peer's report goes to
# OUT/peer-K.log.  $OWNER_ARGS (optional) adds options to the owner's
# command line, e.g. OWNER_ARGS='-t 0.5 -i symplectic-euler'.  Exits with
# the first non-zero peer status.
set -euo pipefail
n=2
if [ "${1:-}" = -n ]; then n=$2; shift 2; fi
[ $# -eq 3 ] || { echo "usage: samples/peers.sh [-n N] GRID SCENE OUT" >&2; exit 2; }
grid=$(realpath "$1") scene=$(realpath "$2") out=$3
root=$(cd "$(dirname "$0")/.." && pwd)
PATH=${NDO_BIN:-$root/bin}:$PATH

# Re-run inside a private network namespace (as root: unshare -n; as a
# user: also a user namespace, -r), with the loopback up and multicast
# routed to it.
if [ -z "${NDO_IN_NETNS:-}" ]; then
	flags=-n
	[ "$(id -u)" = 0 ] || flags=-rn
	NDO_IN_NETNS=1 exec unshare $flags "$BASH" "$(realpath "$0")" -n "$n" "$grid" "$scene" "$out"
fi
ip link set lo up
ip route add 224.0.0.0/4 dev lo

mkdir -p "$out/frames"
# Points of interest spread along the unfolded strip: face k·T/N + T/2N of
# the T = 4^(level+1) faces, one per peer.
level=$(head -c 16 "$grid" | od -An -tu4 -j12 -N4 | tr -d ' ')
faces=$((4 ** (level + 1)))
pids=()
simulate-peer --owner "$grid" -s "$scene" --peers "$n" --name owner \
	--frames "$out/frames/f%04d.tgrid" --frame-every "${EVERY:-20}" \
	-o "$out/end.tgrid" ${OWNER_ARGS:-} 2>"$out/peer-0.log" &
pids+=($!)
for ((k = 1; k < n; k++)); do
	simulate-peer --join --poi $((k * faces / n + faces / (2 * n))) --name "peer-$k" \
		2>"$out/peer-$k.log" &
	pids+=($!)
done
status=0
for k in "${!pids[@]}"; do
	wait "${pids[$k]}" || { rc=$?; [ $status -ne 0 ] || status=$rc; echo "peers: peer $k exited $rc (see $out/peer-$k.log)" >&2; }
done
exit $status
