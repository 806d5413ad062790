#!/usr/bin/env bash
# render-frame: inputs and outputs — many grids in one process, streams on
# standard input and output, numbered and replaced frames, PNG metadata —
# and every bad input, option or output giving one line and a non-zero
# exit, with no file left half-written.
. "$(dirname "$0")/lib.sh"
py=/usr/bin/python3
rc="$NDO_ROOT/tests/e2e/render_check.py"

remesh --shape sphere -l 3 -o a.tgrid
remesh --shape wavy -l 3 -o b.tgrid
remesh --shape tetra -l 2 -o c.tgrid
opts=(-s 96x72)

# Many inputs in one process, numbered from 0 or --start-number.
check "three files" render-frame "${opts[@]}" -o 'frame-%04d.png' a.tgrid b.tgrid c.tgrid
if [ -f frame-0000.png ] && [ -f frame-0001.png ] && [ -f frame-0002.png ] && [ ! -e frame-0003.png ]
then pass "frame-0000..0002.png written"; else fail "frame-0000..0002.png written" "$(ls)"; fi
check "frames differ" bash -c '! cmp -s frame-0000.png frame-0001.png'
check "--start-number" render-frame "${opts[@]}" --start-number 7 -o 'n%d.png' a.tgrid b.tgrid
if [ -f n7.png ] && [ -f n8.png ]; then pass "n7.png, n8.png written"; else fail "n7.png, n8.png written" "$(ls n*.png)"; fi

# A stream of grids on standard input; a file holding a stream.
cat a.tgrid b.tgrid c.tgrid > abc.tgrids
check "stream on stdin" bash -c "render-frame ${opts[*]} -o 's-%02d.png' < abc.tgrids"
if [ -f s-02.png ] && [ ! -e s-03.png ]; then pass "three frames from stdin"; else fail "three frames from stdin" "$(ls s-*)"; fi
same() { $py "$rc" compare "$1" "$2" --mean 0 --p99 0; }
check "first frame from stdin as from a file" same s-00.png frame-0000.png
check "third frame from stdin as from a file" same s-02.png frame-0002.png
check "stream file and '-'" bash -c "render-frame ${opts[*]} -o 'm-%d.png' abc.tgrids - < a.tgrid"
if [ -f m-3.png ] && [ ! -e m-4.png ]; then pass "four frames from a stream file and stdin"; else fail "four frames from a stream file and stdin" "$(ls m-*)"; fi
check "without %d each frame replaces OUT" render-frame "${opts[@]}" -o latest.png abc.tgrids
check "OUT holds the last frame" same latest.png frame-0002.png

# Standard output: PNGs back to back.
check "PNG on stdout" bash -c "render-frame ${opts[*]} a.tgrid > out.png"
check "stdout PNG is the file's" same out.png frame-0000.png
check "two PNGs on stdout" bash -c "render-frame ${opts[*]} a.tgrid b.tgrid > two.png"
n=$(grep -c $'IEND' two.png)
if [ "$n" -eq 2 ]; then pass "two PNG streams back to back"; else fail "two PNG streams back to back" "$n IEND chunks"; fi

# Subdivision, wireframe, cloth, f32 input, options; where the picture
# came from.
check "--subdivide 3 --wireframe --cloth" render-frame "${opts[@]}" -k 3 --wireframe --cloth a.tgrid -o k.png
check "PNG records its making" bash -c "grep -a -q 'remesh --shape sphere' k.png && grep -a -q 'render-frame -s 96x72 -k 3' k.png"
$py "$rc" grid-f32 a.tgrid a32.tgrid >/dev/null
check "f32 positions" render-frame "${opts[@]}" a32.tgrid -o a32.png
check "f32 and f64 grids look the same" $py "$rc" compare a32.png frame-0000.png --mean 0.05 --p99 1
check "--msaa 4" render-frame "${opts[@]}" --msaa 4 a.tgrid -o ms.png
check "--no-cull draws the same sphere" bash -c "render-frame ${opts[*]} --no-cull a.tgrid -o nc.png && $py $rc compare nc.png frame-0000.png --mean 0.2 --p99 2"
check "--background, --color, --material" render-frame "${opts[@]}" --background 0,0,0 --color '#ff0000' --material 0.1,0.9,0,1 a.tgrid -o red.png
check "explicit camera" render-frame "${opts[@]}" --eye 3,0,0 --center 0,0,0 --up 0,0,1 a.tgrid -o eye.png
check "--refit, --range" bash -c "render-frame ${opts[*]} --refit --color-by position:z --range -1,1 --no-colorbar -o 'r%d.png' a.tgrid b.tgrid"

# Bad options: one line, exit 2.
expect_error "size 0" 2 "^render-frame: --size: 0x0: width and height must be 1\.\.16384$" render-frame -s 0x0 a.tgrid -o x.png
expect_error "size 100000" 2 "--size: 100000x768: width and height must be 1\.\.16384" render-frame -s 100000x768 a.tgrid -o x.png
expect_error "size not WxH" 2 "--size: 'big' is not WIDTHxHEIGHT" render-frame -s big a.tgrid -o x.png
expect_error "msaa 3" 2 "--msaa: 3 is not 1, 2, 4, 8 or 16" render-frame --msaa 3 a.tgrid -o x.png
expect_error "elevation 91" 2 "--elevation: 91 is outside \[-90, 90\]" render-frame --elevation 91 a.tgrid -o x.png
expect_error "unknown back end" 2 "--backend: 'vulkan' is not auto, osmesa or egl" render-frame --backend vulkan a.tgrid -o x.png
expect_error "bad colour" 2 "--background: '#12345' is not #rrggbb or r,g,b" render-frame --background '#12345' a.tgrid -o x.png
expect_error "bad --color-by" 2 "--color-by: 'Velocity' is not" render-frame --color-by Velocity a.tgrid -o x.png
expect_error "empty range" 2 "--range: 1,0: LO must be below HI" render-frame --range 1,0 a.tgrid -o x.png
expect_error "--eye with --azimuth" 2 "give either --eye or --azimuth" render-frame --eye 1,2,3 --azimuth 10 a.tgrid -o x.png
expect_error "%s in OUT" 2 "--output: 'f%s.png': only %d, %0Nd and %% may follow a %" render-frame a.tgrid -o 'f%s.png'
expect_error "two %d in OUT" 2 "has 2 %d conversions" render-frame a.tgrid -o 'f%d-%d.png'
expect_error "two inputs, no %d" 2 "--output: 'x.png' has no %d to number the frames of 2 inputs" render-frame a.tgrid b.tgrid -o x.png
expect_error "subdivide 11" 2 "--subdivide: 11 is outside 0\.\.10" render-frame -k 11 a.tgrid -o x.png
expect_error "--passive without --lcm" 2 "--passive, --lcm-timeout and --key go with --lcm" \
	render-frame --passive a.tgrid -o x.png

# Bad input, output or installation: one line, exit 1, nothing written.
head -c 300 a.tgrid > short.tgrid
expect_error "truncated grid" 1 "^render-frame: short\.tgrid: truncated in channel 'position'" render-frame short.tgrid -o x.png
printf 'not a grid at all, just some text that is long enough to have a header\n' > junk.tgrid
expect_error "not a grid" 1 "^render-frame: junk\.tgrid: " render-frame junk.tgrid -o x.png
: > empty.tgrid
expect_error "empty file" 1 "^render-frame: empty\.tgrid: holds no grid" render-frame empty.tgrid -o x.png
expect_error "missing file" 1 "^render-frame: nosuch\.tgrid: No such file" render-frame nosuch.tgrid -o x.png
cat a.tgrid short.tgrid > broken-stream.tgrid
expect_error "second grid of a stream truncated" 1 "broken-stream\.tgrid, grid 2: truncated" render-frame "${opts[@]}" broken-stream.tgrid -o 'bs-%d.png'
if [ -f bs-0.png ] && [ ! -e bs-1.png ]; then pass "frames before the bad grid kept"; else fail "frames before the bad grid kept" "$(ls bs-*)"; fi
expect_error "unwritable output" 1 "^render-frame: cannot write nodir/x\.png: No such file or directory$" render-frame "${opts[@]}" a.tgrid -o nodir/x.png
expect_error "full disk" 1 "/dev/full" render-frame "${opts[@]}" a.tgrid -o /dev/full
# The output is a PNG, and its name must say so: -o x.jpg wrote a PNG there,
# and -o naming the input grid replaced it with a picture of it.
expect_error "-o x.jpg" 2 "^render-frame: --output: 'x\.jpg' is not a \.png name" \
	render-frame "${opts[@]}" a.tgrid -o x.jpg
cp a.tgrid keep.tgrid
expect_error "-o the input grid" 2 "^render-frame: --output: 'keep\.tgrid' is not a \.png name" \
	render-frame "${opts[@]}" keep.tgrid -o keep.tgrid
check "the input grid is kept" cmp -s a.tgrid keep.tgrid
[ ! -e x.jpg ] || fail "-o x.jpg wrote x.jpg"
check "-o X.PNG (any case)" render-frame "${opts[@]}" a.tgrid -o X.PNG
expect_error "no owner channel" 1 "^render-frame: a\.tgrid: no owner channel" render-frame --color-by owner a.tgrid -o x.png
expect_error "no such channel" 1 "no channel 'velocity' to colour by" render-frame --color-by velocity a.tgrid -o x.png
expect_error "no rest channel" 1 "no rest channel .* displacement" render-frame --color-by displacement a.tgrid -o x.png
expect_error "position:w" 1 "channel 'position' has 3 components, no 'w'" render-frame --color-by position:w a.tgrid -o x.png
$py "$rc" grid-poke a.tgrid nan.tgrid 3 2 nan >/dev/null
expect_error "NaN position" 1 "^render-frame: nan\.tgrid: position of node \(3, 2\) is not finite" render-frame nan.tgrid -o x.png
# refined, the file's node is named (and the refined grid is not read after it is freed)
expect_error "NaN position, refined" 1 "^render-frame: nan\.tgrid: position of node \(3, 2\) is not finite$" render-frame -k 1 nan.tgrid -o x.png
expect_error "level + K > 10" 1 "level 3 refined by 8 exceeds the largest level, 10" render-frame -k 8 a.tgrid -o x.png
expect_error "more samples than llvmpipe has" 1 "16 samples per pixel: this OpenGL .* has at most" render-frame --msaa 16 a.tgrid -o x.png
expect_error "missing shader directory" 1 "shader /nonexistent/surface\.vert: not found \(NDO_SHADER_DIR\)" env NDO_SHADER_DIR=/nonexistent render-frame a.tgrid -o x.png
# Back ends: without OSMesa (Mesa >= 25.1), auto falls back to EGL.
if env NDO_OSMESA_LIB=/nonexistent/libOSMesa.so.8 render-frame -v "${opts[@]}" a.tgrid -o fb.png 2>fb.log &&
   grep -q "egl back end" fb.log; then pass "no OSMesa: auto falls back to EGL"; else
	fail "no OSMesa: auto falls back to EGL" "$(head -2 fb.log)"; fi
expect_error "no OSMesa, --backend osmesa" 1 "^render-frame: back end osmesa: cannot load /nonexistent/libOSMesa\.so\.8" env NDO_OSMESA_LIB=/nonexistent/libOSMesa.so.8 render-frame --backend osmesa a.tgrid -o x.png
expect_error "no OpenGL at all" 1 "^render-frame: no OpenGL 3\.3 context: osmesa: cannot load .*; egl: cannot load /nonexistent/libEGL\.so\.1" env NDO_OSMESA_LIB=/nonexistent/libOSMesa.so.8 NDO_EGL_LIB=/nonexistent/libEGL.so.1 render-frame a.tgrid -o x.png
mkdir -p bad-shaders
cp "$NDO_ROOT"/shaders/normals.* "$NDO_ROOT/shaders/surface.vert" bad-shaders/
expect_error "missing fragment shader" 1 "shader bad-shaders/surface\.frag: No such file" env NDO_SHADER_DIR=bad-shaders render-frame a.tgrid -o x.png
sed 's/vec3 n = normalize(v_normal);/vec3 n = normalise(v_normal);/' "$NDO_ROOT/shaders/surface.frag" > bad-shaders/surface.frag
expect_error "broken shader" 1 "shader bad-shaders/surface\.frag: .*normalise" env NDO_SHADER_DIR=bad-shaders render-frame a.tgrid -o x.png
if [ ! -e x.png ] && [ -z "$(ls | grep '\.tmp\.')" ]; then pass "no output left by the failures"; else fail "no output left by the failures" "$(ls)"; fi
