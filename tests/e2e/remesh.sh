#!/usr/bin/env bash
# remesh on real meshes: accuracy (Hausdorff, stretch, the anisotropy
# guard, the rotation search, a split copy of a coarse input).  The option
# paths, expected failures and shapes are in remesh-paths.sh.
. "$(dirname "$0")/remesh.bash"

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


# A mesh of any size within the coordinates' range is remeshed as its
# unit-sized copy (a power of two, exact, and back): hand.off scaled by
# 1e-100 stopped with SIGFPE (a NaN in CGAL's Hausdorff distance), by
# 1e-200 reported "-nan%" (the diagonal's square underflowed), and by 1e40
# gave a grid 2.7 times as far from the mesh.
remesh_ok hand-unit 4 "$M/hand.off" --rotations 4
hu=$(json hand-unit.json hausdorff_rel) du=$(json hand-unit.json diagonal)
for f in 1e-100 1e-200 1e40; do
	awk -v f="$f" 'NF == 0 || /^#/ { print; next } !h { h = 1; print; next }
		!n { n = $1; print; next } v < n { v++; printf "%.17g %.17g %.17g\n", $1 * f, $2 * f, $3 * f; next }
		{ print }' "$M/hand.off" >"hand$f.off"
	remesh_ok "hand-scaled-$f" 4 "hand$f.off" --rotations 4 || continue
	hs=$(json "hand-scaled-$f.json" hausdorff_rel) ds=$(json "hand-scaled-$f.json" diagonal)
	if [ "$hs" = "$hu" ] && awk -v a="$ds" -v b="$du" -v f="$f" 'BEGIN { r = a / (b * f); exit !(r > 0.999999 && r < 1.000001) }'; then
		pass "hand scaled by $f: the unit copy's Hausdorff $hs, diagonal $ds"
	else
		fail "hand scaled by $f" "Hausdorff $hs (unit $hu), diagonal $ds (unit $du)"
	fi
done
