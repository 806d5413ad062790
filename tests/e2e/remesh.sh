#!/usr/bin/env bash
# remesh on real meshes: accuracy (Hausdorff, stretch, the anisotropy
# guard, the rotation search, a split copy of a coarse input).  The option
# paths, expected failures and shapes are in remesh-paths.sh.
. "$(dirname "$0")/lib.sh"

# The libcgal-demo meshes, extracted at test time (never committed).
# remesh.sh and remesh-paths.sh run side by side: one extracts, under a lock.
DATA=$NDO_TMP/cgal-data
mkdir -p "$NDO_TMP"
(
	flock 9
	if [ ! -f "$DATA/done" ]; then
		mkdir -p "$DATA"
		tar -xzf /usr/share/doc/libcgal-dev/data.tar.gz -C "$DATA" data/meshes 2>/dev/null && : >"$DATA/done"
	fi
) 9>"$NDO_TMP/cgal-data.lock"
M=$DATA/data/meshes
[ -f "$M/cow.off" ] || { fail "libcgal-demo data" "no $M/cow.off (install libcgal-demo)"; exit 1; }

# json FILE KEY: the value of a flat key in remesh's --json output.
json() { sed -n "s/.*\"$2\": \([^,}]*\).*/\1/p" "$1" | head -n 1; }
# below A B: A < B as numbers.
below() { awk -v a="$1" -v b="$2" 'BEGIN { exit !(a + 0 < b + 0) }'; }

# Small closed meshes written here.
offfile() { # offfile NV NF "x y z ..." "a b c ...": one vertex, one face a line
	echo OFF; echo "$1 $2 0"
	echo "$3" | xargs -n 3; echo "$4" | xargs -n 3 | sed 's/^/3 /'
}
offfile 6 8 "1 0 0  -1 0 0  0 1 0  0 -1 0  0 0 1  0 0 -1" \
	"0 2 4  2 1 4  1 3 4  3 0 4  2 0 5  1 2 5  3 1 5  0 3 5" >octa.off
# the same, every face turned inward
awk 'NR > 2 && NF == 4 { print $1, $2, $4, $3; next } { print }' octa.off >inward.off
# two tetrahedra sharing one edge: four faces on edge 0–1
offfile 6 8 "0 0 0  1 0 0  0 1 0  0 0 1  0 -1 0  0 0 -1" \
	"0 2 1  0 1 3  0 3 2  1 2 3  0 1 4  0 5 1  0 4 5  1 5 4" >nonmanifold.off
: >empty.off
head -c 100 "$M/cow.off" >truncated.off

# remesh_ok NAME LEVEL INPUT [OPTIONS...]: succeeds, reports 0 flips, a
# closed manifold grid with Euler characteristic 2, and no degenerate
# triangle; leaves NAME.json and NAME.tgrid.
remesh_ok() {
	local name=$1 level=$2 in=$3; shift 3
	remesh "$in" -l "$level" -o "$name.tgrid" --json="$name.json" "$@" 2>"$name.err"
	local rc=$?
	if [ $rc -ne 0 ]; then
		fail "$name" "exit $rc from remesh $in -l $level $*"; sed 's/^/    /' "$name.err" | head -5
		return 1
	fi
	local flips closed euler degen
	flips=$(json "$name.json" flips); closed=$(json "$name.json" closed_manifold)
	euler=$(json "$name.json" euler); degen=$(json "$name.json" degenerate)
	if [ "$closed" != true ] || [ "$euler" != 2 ] || [ "$degen" != 0 ]; then
		fail "$name" "grid closed=$closed euler=$euler degenerate=$degen"
	elif [ "$flips" != 0 ] && [ "${ALLOW_FLIPS:-0}" = 0 ]; then
		fail "$name" "expected 0 flipped spherical triangles, got $flips"
	else
		pass "$name"
	fi
}

remesh_ok hand 5 "$M/hand.off"

# accuracy on a real mesh: hand (1197 vertices) at level 5 is within 3%
# of the diagonal (Hausdorff; Praun-Hoppe's level 6 is 1.1%) and keeps
# more than half of the ideal stretch
h=$(json hand.json hausdorff_rel); e=$(json hand.json stretch_efficiency)
es=$(json hand.json stretch_efficiency_sphere)
if below "$h" 0.03 && below 0.0 "$h" && below 0.5 "$e"; then pass "hand-accuracy"
else fail "hand-accuracy" "Hausdorff $h (want < 0.03), stretch efficiency $e (want > 0.5)"; fi
# Praun-Hoppe's measure (spherical triangles) is an efficiency too: in (0.5, 1]
if below 0.5 "$es" && below "$es" 1.000001; then pass "hand-stretch-sphere"
else fail "hand-stretch-sphere" "stretch efficiency on the sphere $es (want in (0.5, 1])"; fi
# the anisotropy guard does what it says: hand at level 4 (parameterized as
# it is, not split) has less of its surface mapped with anisotropy over 10
# with --guard 6 than without (measured 0 vs 0.095%), and a tight guard
# costs stretch
remesh_ok hand-guard-off 4 "$M/hand.off" --guard 0 --rotations 4
remesh_ok hand-guard-6 4 "$M/hand.off" --guard 6 --rotations 4
remesh_ok hand-guard-3 4 "$M/hand.off" --guard 3 --rotations 4
g0=$(json hand-guard-off.json sliver_share); g6=$(json hand-guard-6.json sliver_share)
e0=$(json hand-guard-off.json stretch_efficiency_sphere); e3=$(json hand-guard-3.json stretch_efficiency_sphere)
if below "$g6" "$g0" && below "$e3" "$e0"; then pass "hand-guard-slivers"
else fail "hand-guard-slivers" "sliver share without guard $g0, guard 6 $g6; stretch without $e0, guard 3 $e3"; fi
# the same mesh at a higher level is closer
remesh_ok hand-level3 3 "$M/hand.off"
h3=$(json hand-level3.json hausdorff_rel)
if below "$h" "$h3"; then pass "hand-finer-is-closer"
else fail "hand-finer-is-closer" "level 5 Hausdorff $h not below level 3's $h3"; fi
# (the comparison with Praun-Hoppe at levels 6 and 7 is the remesh
# benchmark's, tests/bench/remesh.sh and docs/remesh.md: under the
# sanitizers a level-6 quality measurement alone took a minute)
# the rotation search: its estimate never above the unrotated domain's, and
# within a factor 1.5 of the Hausdorff distance CGAL measures (level 5)
h6=$h
eb=$(json hand.json estimated_hausdorff_rel_before); ea=$(json hand.json estimated_hausdorff_rel)
if ! below "$eb" "$ea" && below "$ea" "$(awk -v h="$h6" 'BEGIN { print 1.5 * h }')" \
	&& below "$h6" "$(awk -v e="$ea" 'BEGIN { print 1.5 * e }')"; then pass "rotation-estimate"
else fail "rotation-estimate" "estimated $eb -> $ea, measured $h6"; fi

# a mesh much coarser than the grid is parameterized on a 1-to-4 split copy
# (the same surface): cactus' 1236 faces for a level-5 grid's 4096 triangles
remesh_ok cactus-subdivided 5 "$M/cactus.off"
hc=$(json cactus-subdivided.json hausdorff_rel)
if [ "$(json cactus-subdivided.json subdivided)" = 1 ] && [ "$(json cactus-subdivided.json param_faces)" = 4944 ] \
	&& below "$hc" 0.02; then pass "cactus-subdivided-close"
else fail "cactus-subdivided-close" "subdivided $(json cactus-subdivided.json subdivided), Hausdorff $hc"; fi

