# tests/e2e/remesh.bash — sourced by remesh.sh and remesh-paths.sh (it sources
# lib.sh first): the libcgal-demo meshes, small meshes made here, helpers.
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
