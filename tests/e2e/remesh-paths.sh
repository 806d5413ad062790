#!/usr/bin/env bash
# remesh: the option paths on small meshes, the expected failures, stdin
# and export, and the --shape grids the other tools start from (accuracy
# on real meshes is remesh.sh; the two run side by side).
. "$(dirname "$0")/remesh.bash"

remesh_ok octahedron 3 octa.off
remesh_ok icosahedron 3 "$M/icosahedron.off" --rotations 8
# cow.off has coincident vertices that are distinct: merging by position
# would break it; kept apart it is a closed genus-0 surface
remesh_ok cow-coincident-vertices 2 "$M/cow.off" --rotations 4
remesh_ok oblong-gnomonic 3 "$M/oblong.off" --map gnomonic --rotations 8
remesh_ok part-spring-domain 3 "$M/part.off" --map spring --rotations 8
remesh_ok oblong-no-rotation 3 "$M/oblong.off" --no-rotation
# the plain objective (L2 stretch alone, no importance) on the equal-area map
remesh_ok icosahedron-plain-stretch 3 "$M/icosahedron.off" --map equal-area --conformal 0 --importance 0 --rotations 4
ALLOW_FLIPS=1 remesh_ok octahedron-spring-embedder 3 octa.off --param spring --spring-steps 50

# inward orientation is fixed and said
if remesh inward.off -l 2 -o inward.tgrid --json=inward.json 2>inward.err \
	&& grep -q "oriented inward; reversed" inward.err && [ "$(json inward.json flips)" = 0 ]; then
	pass "inward-orientation-fixed"
else fail "inward-orientation-fixed" "$(head -2 inward.err)"; fi

# polygons are triangulated
remesh_ok quads-triangulated 3 "$M/cube_quad.off"
grep -q "triangulated 6 polygons into 12 triangles" quads-triangulated.err \
	&& pass "quads-triangulated-said" || fail "quads-triangulated-said" "$(head -1 quads-triangulated.err)"

# stdin in, stdout out, export by extension, pipes into the next tool
if remesh -l 2 <octa.off >stdin.tgrid 2>stdin.err && [ -s stdin.tgrid ] \
	&& subdivide -l 1 stdin.tgrid >sub.tgrid 2>>stdin.err; then pass "stdin-stdout-pipe"
else fail "stdin-stdout-pipe" "$(head -2 stdin.err)"; fi
check export-obj remesh octa.off -l 2 -o octa.obj
if [ "$(grep -c '^v ' octa.obj)" -ge 34 ]; then pass "export-obj-vertices"
else fail "export-obj-vertices" "$(grep -c '^v ' octa.obj) vertices"; fi
check report remesh "$M/icosahedron.off" -l 3 -o /dev/null --report
grep -q "Hausdorff" err.log && grep -q "stretch efficiency" err.log \
	&& pass "report-readable" || fail "report-readable" "$(head -3 err.log)"
remesh octa.off -l 2 -o o.tgrid --json=- >json.out 2>/dev/null
[ "$(json json.out flips)" = 0 ] && pass "json-to-stdout" || fail "json-to-stdout" "$(head -c 200 json.out)"

# expected failures: one line, exit 1, naming the defect
expect_error elephant-genus3 1 'elephant\.off: genus 3 \(Euler characteristic -4\); remesh needs genus 0$' \
	remesh "$M/elephant.off" -o out.tgrid
expect_error femur-genus2 1 'femur\.off: genus 2 \(Euler characteristic -2\); remesh needs genus 0$' \
	remesh "$M/femur.off" -o out.tgrid
expect_error head-open 1 'head\.off: open surface: 58 boundary edges' remesh "$M/head.off" -o out.tgrid
expect_error bones-components 1 'bones\.off: 26 connected components; remesh needs one' \
	remesh "$M/bones.off" -o out.tgrid
expect_error non-manifold 1 'nonmanifold\.off: not manifold: 1 edge shared by more than two faces' \
	remesh nonmanifold.off -o out.tgrid
expect_error empty 1 'empty\.off: empty file' remesh empty.off -o out.tgrid
expect_error truncated 1 'truncated\.off: ' remesh truncated.off -o out.tgrid
expect_error missing 1 'nosuch\.off: No such file' remesh nosuch.off -o out.tgrid
[ ! -e out.tgrid ] && pass "no-output-on-failure" || fail "no-output-on-failure" "out.tgrid written"
# a bad output fails before the work, as ndo/cli.h promises (bunny00 to
# level 7 takes seconds; the check, milliseconds), and an empty -o "$OUT"
# is a usage error, not 'cannot rename onto :' after the work
expect_error missing-output-dir-first 1 'nodir/x\.tgrid: cannot write nodir/x\.tgrid: No such file or directory$' \
	timeout 3 remesh "$M/bunny00.off" -l 7 -o nodir/x.tgrid
mkdir -p adir
expect_error output-is-directory-first 1 'adir: cannot write adir: Is a directory$' \
	timeout 3 remesh "$M/bunny00.off" -l 7 -o adir
expect_error empty-output-name 2 '--output: an empty file name$' remesh octa.off -o ''
# and so does --json's file (it failed after the work)
expect_error json-missing-dir-first 1 '^remesh: --json: cannot write nodir/j\.json: No such file or directory$' \
	timeout 3 remesh "$M/bunny00.off" -l 7 --json=nodir/j.json -o x.tgrid
[ ! -e x.tgrid ] || fail "json-missing-dir-first" "x.tgrid written"
expect_error empty-json-name 2 '^remesh: --json=: an empty file name$' remesh octa.off --json= -o x.tgrid
# a pipe is not probed (opening it would wait for a reader): the JSON goes
# through it after the work
mkfifo json.fifo
cat json.fifo >fifo.json &
if timeout 20 remesh octa.off -l 2 --rotations 4 --json=json.fifo -o fifo.tgrid 2>fifo.err && wait $! &&
	grep -q '"closed_manifold": true' fifo.json; then pass "--json into a named pipe"
else fail "--json into a named pipe" "$(cat fifo.err)"; fi
expect_error bad-param 2 "--param: 'x' is not hierarchical or spring" remesh octa.off --param x
expect_error bad-sweeps 2 '--sweeps' remesh octa.off --sweeps 1000
expect_error two-inputs 2 'one input mesh at a time' remesh octa.off octa.off
expect_error spring-shape 2 '--map: spring is for meshes' remesh --shape sphere --map spring
expect_error blend-shape 2 '--map: blend is for meshes' remesh --shape sphere --map blend
expect_error bad-map 2 "--map: 'x' is not" remesh octa.off --map x
expect_error bad-blend 2 '--blend' remesh octa.off --blend 1.5
expect_error bad-conformal 2 '--conformal' remesh octa.off --conformal -1
expect_error bad-importance 2 '--importance' remesh octa.off --importance 11
expect_error bad-guard 2 '--guard: 0.5 is below 1' remesh octa.off --guard 0.5
expect_error big-guard 2 '--guard' remesh octa.off --guard 1001
expect_error bad-rotations 2 '--rotations' remesh octa.off --rotations 100001

# the procedural shapes keep working, every option
check shape-sphere remesh --shape sphere -l 3 -o sphere.tgrid
check shape-ellipsoid remesh --shape ellipsoid --axes 2,1,0.5 -l 2 --map gnomonic -o e.tgrid
check shape-wavy remesh --shape wavy --amplitude 0.1 --frequency 3 -l 2 -o w.obj
check shape-tetra remesh --shape tetra -l 1 -o t.tgrid
expect_error shape-unknown 2 '--shape' remesh --shape cube
# --report and --json measure the grid against an input mesh: with a shape
# there is none (they printed nothing, exit 0)
expect_error shape-report 2 '^remesh: --report measures the grid against an input mesh: not with --shape' \
	remesh --shape sphere -l 2 --report -o s.tgrid
expect_error shape-json 2 '^remesh: --json measures the grid against an input mesh: not with --shape' \
	remesh --shape sphere -l 2 --json=s.json -o s.tgrid

# --json stays JSON whatever bytes the input's name holds (a name that is
# not UTF-8 made it unreadable): such a byte is U+FFFD, UTF-8 passes as it is
cp octa.off "$(printf 'o\xe9\xff.off')" && cp octa.off "oé.off"
if remesh "$(printf 'o\xe9\xff.off')" -l 2 --rotations 4 --json=latin.json -o latin.tgrid 2>latin.err &&
	remesh "oé.off" -l 2 --rotations 4 --json=utf8.json -o utf8.tgrid 2>>latin.err &&
	[ "$(/usr/bin/python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["input"], json.load(open(sys.argv[2]))["input"])' latin.json utf8.json)" = "o��.off oé.off" ]; then
	pass "--json of a file name that is not UTF-8 is JSON"
else
	fail "--json and a name that is not UTF-8" "$(cat latin.err; head -c 200 latin.json)"
fi
