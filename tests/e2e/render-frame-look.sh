#!/usr/bin/env bash
# render-frame: the pictures show what a person expects — size, a centred
# round sphere of the right size, the lit side brighter, peers' colours on
# the right sides, shading that matches a perfect sphere's also across the
# grid's seams, a colour bar; the same on both back ends.
. "$(dirname "$0")/lib.sh"
py=/usr/bin/python3
rc="$NDO_ROOT/tests/e2e/render_check.py"

remesh --shape sphere -l 4 -o s4.tgrid
remesh --shape sphere -l 5 -o s5.tgrid
$py "$rc" grid-owner s4.tgrid owned.tgrid x-sign >/dev/null

check "size is as asked" render-frame -s 320x240 s4.tgrid -o a.png
check "PNG is 320x240 RGB" $py "$rc" png-size a.png 320 240
check "odd size" render-frame -s 257x123 s4.tgrid -o odd.png
check "PNG is 257x123 RGB" $py "$rc" png-size odd.png 257 123
check "default size is 1024x768" render-frame s4.tgrid -o big.png
check "PNG is 1024x768 RGB" $py "$rc" png-size big.png 1024 768

# A fitted sphere: centred, covering what the field of view and margin
# say, round and mirror-symmetric, on both back ends.
for b in osmesa egl; do
	check "$b: sphere drawn" render-frame --backend $b -s 320x240 -k 1 s4.tgrid -o sphere-$b.png
	check "$b: sphere centred, fitted, round, symmetric" $py "$rc" sphere sphere-$b.png
done
check "osmesa and egl agree" $py "$rc" compare sphere-osmesa.png sphere-egl.png --mean 0.5 --p99 8
check "wide field of view, tall image" render-frame -s 200x300 --fov 60 -k 1 s4.tgrid -o tall.png
check "tall: sphere centred, fitted, round" $py "$rc" sphere tall.png --fov 60

# The light: from the left, right, top.
for side in left:-60,0 right:60,0 top:0,60 bottom:0,-60; do
	check "light from the ${side%%:*}" render-frame -s 160x120 --light "${side#*:}" s4.tgrid -o lit.png
	check "${side%%:*} half brighter" $py "$rc" lit lit.png "${side%%:*}"
done

# Two peers: owner 0 where x < 0, 1 where x ≥ 0.  From +y (azimuth 90)
# the camera's right is −x, from −y it is +x.  Colours go by the peers'
# places, the order the grid meets them from node (0, 0), which is at
# x ≥ 0 here: owner 1 is place 0 (blue), owner 0 place 1 (orange).
check "owners, camera on +y" render-frame -s 240x180 --azimuth 90 --elevation 0 owned.tgrid -o own-a.png
check "owner 1 (blue) left, 0 (orange) right" $py "$rc" owners own-a.png 0 1
check "owners, camera on -y" render-frame -s 240x180 --azimuth -90 --elevation 0 owned.tgrid -o own-b.png
check "owner 0 (orange) left, 1 (blue) right" $py "$rc" owners own-b.png 1 0
# Ids do not matter, places do: owners 7 and 17 (7 ≡ 17 mod 10, the old
# palette's collision) are blue and orange all the same.
/usr/bin/python3 - owned.tgrid owned2.tgrid "$NDO_ROOT/tests/e2e" <<'PY'
import sys
sys.path.insert(0, sys.argv[3])
import gridfile
g = gridfile.read(sys.argv[1])
ch = dict(g['channels'])
ch['owner'] = (7 + 10 * ch['owner']).astype(ch['owner'].dtype)
gridfile.write_grid(sys.argv[2], {**g, 'ch': ch})
PY
check "owners 7 and 17" render-frame -s 240x180 --azimuth 90 --elevation 0 owned2.tgrid -o own-c.png
check "owner 17 (blue) left, 7 (orange) right" $py "$rc" owners own-c.png 0 1
check "--color-by solid ignores owners" render-frame -s 160x120 --color-by solid owned.tgrid -o solid.png
check "solid matches the grid without owners" render-frame -s 160x120 s4.tgrid -o plain.png
check "solid == plain" $py "$rc" compare solid.png plain.png --mean 0 --p99 0

# Shading against a perfect sphere's, looking straight at each seam: the
# column seam (node (0, N/2)), the bottom fold (N/2, 0) and the top fold
# (N/2, N).  A normal computed without the ghost map (clamped at the
# rectangle's edge) misses by 8-9 levels there; a correct one by 2.
for node in "0 16 column" "16 0 bottom" "16 32 top"; do
	set -- $node
	eye=$($py "$rc" grid-node s5.tgrid "$1" "$2" 4)
	check "$3 seam in view" render-frame -s 320x240 --eye "$eye" --center 0,0,0 s5.tgrid -o seam-$3.png
	check "$3 seam: shading as a perfect sphere's" $py "$rc" analytic seam-$3.png s5.tgrid --eye "$eye" --tol 4
done
eye=$($py "$rc" grid-node s5.tgrid 0 16 4)
check "column seam on egl" render-frame --backend egl -s 320x240 --eye "$eye" --center 0,0,0 s5.tgrid -o seam-egl.png
check "column seam on egl: as a perfect sphere's" $py "$rc" analytic seam-egl.png s5.tgrid --eye "$eye" --tol 4

# A scalar: height, with a colour bar dark at the bottom, bright at the top.
check "colour by position:z" render-frame -s 400x300 --color-by position:z s4.tgrid -o z.png
check "colour bar runs dark to bright" $py "$rc" colorbar z.png
check "top of the sphere is bright" $py "$rc" lit z.png top

# Flat shading: the tetrahedron's faces are flat, each one colour; smooth
# shading gives each pixel its own.
remesh --shape tetra -l 0 -o t0.tgrid
check "--flat tetrahedron" render-frame -s 160x120 --flat t0.tgrid -o flat.png
check "flat: four colours cover the faces" $py "$rc" facets flat.png 4 yes
check "smooth tetrahedron" render-frame -s 160x120 t0.tgrid -o smooth.png
check "smooth: four colours do not" $py "$rc" facets smooth.png 4 no

# The default view a person would choose: a grid remeshed from a mesh file
# stands on +y (glTF's up, most scans') and is seen from its front and left;
# ndo's own shapes keep +z; what the user gives stays.
cat >box.off <<'MESH'
OFF
8 12 0
-1 -0.5 -0.3
1 -0.5 -0.3
1 0.5 -0.3
-1 0.5 -0.3
-1 -0.5 0.3
1 -0.5 0.3
1 0.5 0.3
-1 0.5 0.3
3 0 2 1
3 0 3 2
3 4 5 6
3 4 6 7
3 0 1 5
3 0 5 4
3 2 3 7
3 2 7 6
3 1 2 6
3 1 6 5
3 0 4 7
3 0 7 3
MESH
remesh box.off -l 3 -o box3.tgrid 2>/dev/null
render-frame -s 160x120 box3.tgrid -o box-default.png
render-frame -s 160x120 --up 0,1,0 --azimuth 240 box3.tgrid -o box-yup.png
render-frame -s 160x120 --up 0,0,1 --azimuth 30 box3.tgrid -o box-zup.png
render-frame -s 160x120 --up 0,0,1 box3.tgrid -o box-up-given.png
render-frame -s 160x120 s4.tgrid -o s4-default.png
render-frame -s 160x120 --up 0,0,1 --azimuth 30 s4.tgrid -o s4-zup.png
if $py "$rc" compare box-default.png box-yup.png --mean 0 --p99 0 >/dev/null &&
	! $py "$rc" compare box-default.png box-zup.png --mean 0 --p99 0 >/dev/null 2>&1 &&
	$py "$rc" compare box-up-given.png box-zup.png --mean 0 --p99 0 >/dev/null &&
	$py "$rc" compare s4-default.png s4-zup.png --mean 0 --p99 0 >/dev/null; then
	pass "default view: a remeshed mesh stands on +y, seen from its front; shapes keep +z; --up stays"
else
	fail "default view" "a remeshed mesh's default is not the +y front view, or a shape's not +z"
fi
# remesh run under a path ($NDO_BIN/remesh, ./bin/remesh) is remesh too, and
# -s, --shape's short form, makes a shape
"$NDO_BIN/remesh" box.off -l 3 -o box3-path.tgrid 2>/dev/null
render-frame -s 160x120 box3-path.tgrid -o box-path-default.png
check "default view: a mesh remeshed by \$NDO_BIN/remesh stands on +y" \
	$py "$rc" compare box-path-default.png box-yup.png --mean 0 --p99 0
remesh -s ellipsoid -l 3 -o e3.tgrid
render-frame -s 160x120 e3.tgrid -o e3-default.png
render-frame -s 160x120 --up 0,0,1 --azimuth 30 e3.tgrid -o e3-zup.png
check "default view: a shape made with -s keeps +z" \
	$py "$rc" compare e3-default.png e3-zup.png --mean 0 --p99 0
