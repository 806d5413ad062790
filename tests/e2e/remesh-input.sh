#!/usr/bin/env bash
# remesh and every input a user can throw at it: bad numbers named by the
# vertex, formats on files and on standard input, seams welded, surfaces
# that cross themselves warned about, junk refused in one line of its own.
. "$(dirname "$0")/lib.sh"
PY=/usr/bin/python3
# json FILE KEY: the value of a flat key in remesh's --json output.
json() { sed -n "s/.*\"$2\": \([^,}]*\).*/\1/p" "$1" | head -n 1; }
ok() { # ok NAME LEVEL INPUT [OPTIONS]: succeeds with a closed grid
	local name=$1 level=$2 in=$3; shift 3
	if remesh "$in" -l "$level" --rotations 4 -o "$name.tgrid" --json="$name.json" "$@" 2>"$name.err" &&
		[ "$(json "$name.json" closed_manifold)" = true ]; then pass "$name"
	else fail "$name" "$(head -2 "$name.err")"; fi
}

# The octahedron in every format, with one vertex that can be spoiled.
$PY - <<'PYEOF'
import struct
V = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]
F = [(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)]
def off(name, V, F):
    with open(name, "w") as f:
        f.write("OFF\n%d %d 0\n" % (len(V), len(F)))
        f.writelines("%r %r %r\n" % v for v in V)
        f.writelines("3 %d %d %d\n" % t for t in F)
def obj(name, V, F):
    with open(name, "w") as f:
        f.writelines("v %r %r %r\n" % v for v in V)
        f.writelines("f %d %d %d\n" % tuple(i + 1 for i in t) for t in F)
def ply(name, V, F, strips=False):
    head = "ply\nformat binary_little_endian 1.0\nelement vertex %d\n" % len(V)
    head += "property double x\nproperty double y\nproperty double z\n"
    if strips:
        head += "element tristrips %d\nproperty list uchar int vertex_indices\n" % len(F)
    else:
        head += "element face %d\nproperty list uchar int vertex_indices\n" % len(F)
    head += "end_header\n"
    with open(name, "wb") as f:
        f.write(head.encode())
        for v in V: f.write(struct.pack("<3d", *v))
        for t in F: f.write(struct.pack("<B%di" % len(t), len(t), *t))
def stl(name, V, F):
    with open(name, "wb") as f:
        f.write(b"solid but binary".ljust(80, b" ") + struct.pack("<I", len(F)))
        for t in F:
            f.write(struct.pack("<3f", 0, 0, 0))
            for i in t: f.write(struct.pack("<3f", *V[i]))
            f.write(b"\0\0")
for bad, tag in ((float("nan"), "nan"), (float("inf"), "inf"), (1e300, "big")):
    W = list(V); W[3] = (0, bad, 0)
    off("%s.off" % tag, W, F); obj("%s.obj" % tag, W, F); ply("%s.ply" % tag, W, F)
    if tag != "big": stl("%s.stl" % tag, W, F)  # a float holds no 1e300
off("octa.off", V, F); ply("strips.ply", V, F, strips=True); stl("octa.stl", V, F)
# UV seams: vertex 0 split in two along the edges 4-0 and 0-5 (the faces
# on vertex 3's side use the copy, 6), as exporters of textured models do
obj("seams.obj", V + [V[0]], [tuple(6 if (i == 0 and 3 in t) else i for i in t) for t in F])
# OBJ faces as written (the octahedron's lines 1-6 vertices, 7-14 faces,
# its third face on line 9 spoiled): a vertex 0, one past the last, a
# word, two corners, a relative reference (-3: the fourth of six) that
# repeats a corner; a 0 on line 1 before any vertex (CGAL took it as the
# first vertex); a relative one before the first vertex (line 4, after
# three); valid relative references and tab-separated ones
def objtext(name, lines):
    with open(name, "w") as f: f.write("".join(l + "\n" for l in lines))
OV = ["v %r %r %r" % v for v in V]
OF = ["f %d %d %d" % tuple(i + 1 for i in t) for t in F]
for tag, face in (("zero", "f 2 4 0"), ("onepast", "f 2 4 7"), ("word", "f 2 4 x"),
                  ("twocorners", "f 2 4"), ("relrepeat", "f 2 4 -3")):
    objtext("%s.obj" % tag, OV + OF[:2] + [face] + OF[3:])
objtext("zerofirst.obj", ["f 0 3 5"] + OF[1:] + OV)
objtext("relbefore.obj", OV[:3] + ["f -3 -1 -5"] + OV[3:] + OF)
objtext("relative.obj", OV + ["f %d %d %d" % tuple(i - 6 for i in t) for t in F])
objtext("tabs.obj", OV + [l.replace(" ", "\t") for l in OF])
# OFF and PLY count from 0: a vertex past the last, -1, a repeated corner,
# two corners in their third face (line 11 of the OFF)
for tag, t in (("past", (1, 3, 6)), ("minus", (1, 3, -1)), ("repeat", (1, 3, 3)),
               ("twocorners", (1, 3))):
    G = list(F); G[2] = t
    ply("%s.ply" % tag, V, G)
    with open("%s.off" % tag, "w") as f:
        f.write("OFF\n%d %d 0\n" % (len(V), len(G)))
        f.writelines("%r %r %r\n" % v for v in V)
        f.writelines("%d %s\n" % (len(u), " ".join(map(str, u))) for u in G)
# a non-manifold edge (four faces on the edge 1-2 of remesh.bash's), after
# an unreferenced vertex: named as the file numbers it, not as renumbered
NV = [(9, 9, 9), (0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 1), (-1, -1, -1)]
NF = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3), (0, 1, 4), (0, 5, 1), (0, 4, 5), (1, 5, 4)]
NF = [tuple(i + 1 for i in t) for t in NF]
off("nonmanifold.off", NV, NF); obj("nonmanifold.obj", NV, NF)
# an octahedron whose top passed through its bottom: crosses itself
off("crossed.off", [(-1.5, 0.5, 0.3)] + V[1:], F)
# a tetrahedron written as two quads (a pillow): triangulating both by
# the same diagonal would put four faces on it
with open("pillow.off", "w") as f:
    f.write("OFF\n4 2 0\n1 1 1\n1 -1 -1\n-1 1 -1\n-1 -1 1\n4 0 1 2 3\n4 3 2 1 0\n")
PYEOF

# Coordinates that are not finite or far out of range: exit 1, one line,
# the vertex as the file numbers it (OBJ counts from 1)
for f in nan.off inf.off big.off; do
	expect_error "$f: bad coordinate named" 1 "^remesh: $f: vertex 3.*coordinate" remesh "$f" -o out.tgrid
done
for f in nan.obj inf.obj big.obj; do
	expect_error "$f: bad coordinate named" 1 "^remesh: $f: vertex 4.*coordinate" remesh "$f" -o out.tgrid
done
for f in nan.ply inf.ply big.ply; do
	expect_error "$f (binary): bad coordinate named" 1 "^remesh: $f: vertex 3: coordinate .* (not finite|beyond)" \
		remesh "$f" -o out.tgrid --report
done
for f in nan.stl inf.stl; do
	expect_error "$f (binary): bad coordinate named" 1 "^remesh: $f: facet [0-9]+, corner [0-9]: coordinate .* not finite" \
		remesh "$f" -o out.tgrid --report
done
[ ! -e out.tgrid ] && pass "no grid written for bad coordinates" || fail "bad coordinates" "out.tgrid written"

# Faces: a bad vertex reference named as the file numbers faces and
# vertices — OBJ from 1, the face by its place among the faces and its
# line, a relative reference as written; OFF and PLY from 0.  A 0 in an
# OBJ face was "face 2 refers to vertex 6 of 6", and before any vertex it
# was taken as the first
while read -r f msg; do
	expect_error "$f: the face named as the file has it" 1 "^remesh: $f: $msg\$" remesh "$f" -o out.tgrid
done <<'FACES'
zero.obj face 3 \(line 9\) refers to vertex 0: OBJ numbers vertices from 1
zerofirst.obj face 1 \(line 1\) refers to vertex 0: OBJ numbers vertices from 1
onepast.obj face 3 \(line 9\) refers to vertex 7 of 6
word.obj face 3 \(line 9\): 'x' is not a vertex reference
twocorners.obj face 3 \(line 9\) has 2 vertices
relrepeat.obj face 3 \(line 9\) repeats vertex 4 \(written -3\) \(degenerate face\)
relbefore.obj face 1 \(line 4\) refers to vertex -5, before the first: 3 vertices come before its line
nonmanifold.obj not manifold: 1 edge shared by more than two faces \(first: vertices 2–3\)
past.off face 2 \(line 11\) refers to vertex 6 of 6
minus.off face 2 \(line 11\) refers to vertex -1 of 6
repeat.off face 2 repeats vertex 3 \(degenerate face\)
twocorners.off face 2 has 2 vertices
nonmanifold.off not manifold: 1 edge shared by more than two faces \(first: vertices 1–2\)
past.ply face 2 refers to vertex 6 of 6
minus.ply face 2 refers to vertex -1 of 6
repeat.ply face 2 repeats vertex 3 \(degenerate face\)
twocorners.ply face 2 has 2 vertices
FACES
[ ! -e out.tgrid ] && pass "no grid written for bad faces" || fail "bad faces" "out.tgrid written"
ok obj-relative-references 2 relative.obj
ok obj-tab-separated 2 tabs.obj

# Formats: PLY triangle strips; glTF with its .bin beside it (remesh's own
# -o x.gltf); binary STL, GLB and glTF on standard input
ok ply-triangle-strips 2 strips.ply
remesh --shape sphere -l 2 -o ball.gltf 2>/dev/null
[ -s ball.bin ] || fail "remesh -o ball.gltf" "no ball.bin beside it"
ok gltf-external-bin 2 ball.gltf
remesh --shape sphere -l 2 -o ball.glb 2>/dev/null
for f in octa.stl ball.glb octa.off; do
	if remesh -l 2 --rotations 4 <"$f" >"stdin-$f.tgrid" 2>stdin.err && [ -s "stdin-$f.tgrid" ]; then
		pass "$f on standard input recognized"
	else fail "$f on standard input" "$(head -1 stdin.err)"; fi
done

# A surface split along UV seams is welded, and says so; --no-weld keeps it open
ok uv-seams-welded 2 seams.obj
grep -q "welded" uv-seams-welded.err && pass "welding said" || fail "welding said" "$(cat uv-seams-welded.err)"
expect_error "--no-weld: open, naming the option" 1 'seams\.obj: open surface: 4 boundary edges \(--no-weld' \
	remesh seams.obj --no-weld -o out.tgrid

# Self-intersections: counted, warned, in the report; none on a clean mesh
ok crossed-accepted 2 crossed.off
n=$(json crossed-accepted.json input_selfintersect)
if [ "${n:-0}" -gt 0 ] && grep -q "intersects itself: $n pair" crossed-accepted.err; then
	pass "self-intersections warned with their count ($n)"
else fail "self-intersections" "count '$n': $(head -2 crossed-accepted.err)"; fi
remesh octa.off -l 2 -o /dev/null --report 2>report.err
if grep -q "input  *0 self-intersecting face pairs" report.err && ! grep -q "intersects itself" report.err; then
	pass "a clean mesh: 0 self-intersecting pairs in the report"
else fail "clean mesh self-intersections" "$(grep -i intersect report.err)"; fi

# Quads triangulated without a non-manifold edge
ok pillow-quads 2 pillow.off

# --help and the report count rotations the same way; counts agree in number
remesh --help >help.txt
grep -q "rotations N .*(default 96)" help.txt && grep -q "96 random rotations screened" report.err &&
	pass "--help and the report: 96 random rotations" || fail "rotations" "$(grep -i rotation report.err | head -2)"
if grep -Eq '(^|[^0-9.])1 (fold-overs|self-intersecting face pairs|flipped spherical triangles)' report.err crossed-accepted.err; then
	fail "singular counts" "$(grep -E '(^|[^0-9.])1 [a-z-]+s\b' report.err | head -1)"
else pass "no '1 fold-overs'"; fi

# Junk: one line of remesh's own naming the file and the problem
mkdir adir
head -c 3000 /dev/urandom >junk.off; cp junk.off junk.ply; cp junk.off junk.stl; cp junk.off junk.obj
head -c 3000 /dev/urandom >junk.gltf; cp junk.off junk.xyz
head -c 200 strips.ply >cut.ply; head -c 500 ball.glb >cut.glb
expect_error "a directory" 1 '^remesh: adir: is a directory' remesh adir -o out.tgrid
for f in junk.off junk.ply junk.stl junk.obj junk.gltf junk.xyz cut.ply cut.glb; do
	expect_error "$f: one line of remesh's own" 1 "^remesh: $f: [a-z]" remesh "$f" -o out.tgrid
done
expect_error "junk on standard input" 1 '^remesh: stdin: ' bash -c 'remesh -o out.tgrid <junk.off'
if grep -l -E 'basic_filebuf|Error: incorrect|terminate called' *.log *.err 2>/dev/null | grep -q .; then
	fail "library text leaked" "$(grep -h -E 'basic_filebuf|Error: incorrect' *.log *.err | head -1)"
else pass "no library text on standard error"; fi
