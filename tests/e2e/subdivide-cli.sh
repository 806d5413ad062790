#!/usr/bin/env bash
# subdivide and remesh --shape as a user runs them: pipes, files, formats,
# the history a grid keeps, and every expected failure (one line, the
# right exit code, no output file left behind).
. "$(dirname "$0")/lib.sh"

# -- what works --
check "pipe remesh into subdivide" bash -c 'remesh --shape sphere -l 3 | subdivide -l 2 >s5.tgrid'
check "file to file" subdivide -l 1 s5.tgrid -o s6.tgrid
check "dash means stdin and stdout" bash -c 'subdivide -l 1 - -o - <s5.tgrid >s6b.tgrid'
if cmp -s s6.tgrid s6b.tgrid; then fail "stdin/stdout output differs from file output"; else :; fi
# the two differ only in the history line (the command), so compare sizes of data instead
if [ "$(stat -c %s s6.tgrid)" -gt 100000 ]; then pass "level 6 output has the expected size"; else fail "level 6 output too small"; fi
if grep -aq 'remesh --shape sphere -l 3' s6.tgrid && grep -aq 'subdivide -l 1 s5.tgrid -o s6.tgrid' s6.tgrid; then
	pass "history records every command line"
else
	fail "history records every command line"
fi
check "level 0 copies" subdivide -l 0 s5.tgrid -o s5copy.tgrid
check "thesis corners" subdivide --corners thesis s5.tgrid -o s6t.tgrid
for ext in obj ply stl glb gltf; do
	check "export .$ext" subdivide -l 0 s5.tgrid -o "s5.$ext"
done
# a .gltf's buffer goes beside it, as the manual says (it did not say so)
if [ -s s5.bin ] && grep -q 'NAME.*\.bin' "$NDO_ROOT/tools/subdivide.1"; then
	pass ".gltf: its buffer beside it, as NAME.bin, and the manual says so"
else fail ".gltf's buffer" "s5.bin missing or tools/subdivide.1 silent about it"; fi
if [ "$(grep -c '^v ' s5.obj)" = 2050 ] && [ "$(grep -c '^f ' s5.obj)" = 4096 ]; then
	pass "obj has 2·4^5+2 vertices and 4^6 faces"
else
	fail "obj counts" "$(grep -c '^v ' s5.obj) vertices, $(grep -c '^f ' s5.obj) faces"
fi
if subdivide --help | grep -q -- '--corners' && subdivide --help | grep -q -- '--levels' &&
	subdivide --version | grep -Eq '^subdivide \(ndo\) [0-9]'; then
	pass "--help and --version"
else
	fail "--help and --version"
fi
v=$(subdivide -v -l 1 s5.tgrid -o /dev/null 2>&1)
if grep -q 'level 5 → 6: 2145 → 8385 stored nodes' <<<"$v"; then pass "--verbose says what it did"; else fail "--verbose" "$v"; fi

# -- what fails, with one line and the right code --
expect_error "unknown option" 2 "unknown option '--frobnicate'" subdivide --frobnicate s5.tgrid
expect_error "unknown short option" 2 "unknown option '-x'" subdivide -x s5.tgrid
expect_error "option without its value" 2 "option '-o' needs a value" subdivide s5.tgrid -o
expect_error "level 11 refused, saying why" 2 "level 11 is outside 0\.\.10 \(it would store" subdivide -l 11 s5.tgrid
expect_error "negative level" 2 "level -1 is outside" subdivide -l -1 s5.tgrid
expect_error "non-numeric level" 2 "'two' is not an integer" subdivide -l two s5.tgrid
expect_error "result beyond level 10" 2 "level 5 \+ 6 exceeds the largest level, 10" subdivide -l 6 s5.tgrid
expect_error "bad corner rule" 2 "--corners: 'loop' is not zorin or thesis" subdivide --corners loop s5.tgrid
expect_error "missing input" 1 "^subdivide: nothing\.tgrid: cannot open: No such file" subdivide nothing.tgrid
expect_error "two inputs" 2 "more than one input" subdivide s5.tgrid s6.tgrid
head -c 5000 s5.tgrid >cut.tgrid
expect_error "truncated input" 1 "cut\.tgrid: truncated in channel 'position'" subdivide cut.tgrid -o never.tgrid
printf 'hello, I am not a grid\n' >text.tgrid
expect_error "not a grid" 1 "text\.tgrid: not an ndo grid file" subdivide text.tgrid -o never.tgrid
cp s5.tgrid flip.tgrid
printf '\x01' | dd of=flip.tgrid bs=1 seek=3000 conv=notrunc status=none
expect_error "corrupt data" 1 "flip\.tgrid: data checksum mismatch" subdivide flip.tgrid -o never.tgrid
expect_error "empty input" 1 "standard input: empty input" subdivide </dev/null
if [ ! -e never.tgrid ]; then pass "no output file after a failed read"; else fail "a failed run left never.tgrid"; fi
cp s6.tgrid keep.tgrid
subdivide cut.tgrid -o keep.tgrid 2>/dev/null
if cmp -s s6.tgrid keep.tgrid; then pass "a failed run leaves an existing output untouched"; else fail "existing output clobbered"; fi
expect_error "unknown output extension" 2 "x\.png: unknown output extension" subdivide s5.tgrid -o x.png
expect_error "missing output directory" 1 "no/such/dir/x\.tgrid: cannot write" subdivide s5.tgrid -o no/such/dir/x.tgrid
if [ -w /dev/full ]; then
	expect_error "full disk" 1 "/dev/full: write error.*No space left" subdivide s5.tgrid -o /dev/full
	expect_error "full disk on stdout" 1 "No space left on device" bash -c 'subdivide s5.tgrid >/dev/full'
fi
subdivide -l 3 s6.tgrid 2>pipe.err | head -c 100 >/dev/null
codes=("${PIPESTATUS[@]}")
if [ "${codes[0]}" = 1 ] && grep -q 'Broken pipe' pipe.err && [ "$(wc -l <pipe.err)" = 1 ]; then
	pass "closed pipe: one line, exit 1"
else
	fail "closed pipe" "exit ${codes[0]}: $(cat pipe.err)"
fi
if ls ./*.tmp.* >/dev/null 2>&1; then fail "temporary files left behind" "$(ls ./*.tmp.*)"; else pass "no temporary files left"; fi

expect_error "remesh: unknown shape" 2 "unknown shape 'cube'" remesh --shape cube -o x.tgrid
expect_error "remesh: level 11" 2 "level 11 is outside" remesh --shape sphere -l 11
expect_error "remesh: bad axes" 2 "--axes: '1,2' is not 3 comma-separated numbers" remesh --shape ellipsoid --axes 1,2
expect_error "remesh: zero axis" 2 "--axes: 0 is outside" remesh --shape ellipsoid --axes 1,0,1
expect_error "remesh: nothing on stdin" 1 "empty" remesh -l 3

# One grid on standard input, and nothing after it: a second grid or
# trailing bytes are refused, not ignored.
expect_error "a second grid on stdin" 1 "standard input: a second grid follows the first" \
	bash -c 'cat s5.tgrid s5.tgrid | subdivide -o never.tgrid'
expect_error "trailing garbage on stdin" 1 "standard input: bytes follow the end of the grid" \
	bash -c '{ cat s5.tgrid; echo junk; } | subdivide -o never.tgrid'
{ cat s5.tgrid; printf 'x'; } >trailing.tgrid
expect_error "trailing garbage in a file" 1 "trailing\.tgrid: bytes follow the end of the grid" \
	subdivide trailing.tgrid -o never.tgrid
[ ! -e never.tgrid ] && pass "nothing written for refused input" || fail "never.tgrid written"

# Stored duplicates that disagree (a grid from other software): a warning
# naming the first, and the canonical values used.
PYTHONPATH=$NDO_ROOT/tests/e2e /usr/bin/python3 - <<'PYEOF'
import gridfile
g = gridfile.read("s5.tgrid")
x = g["channels"]["position"].copy()
n = x.shape[0] - 1
x[3, 2 * n] += 0.5  # (2N, 3) repeats (0, 3): the column seam
gridfile.write_grid("seam.tgrid", {"level": g["level"], "step": 0, "time": 0.0, "history": "",
                                   "ch": {"position": x}})
PYEOF
if subdivide seam.tgrid -o seam6.tgrid 2>seam.err && [ "$(wc -l <seam.err)" -eq 1 ] &&
	grep -q "seam\.tgrid: 1 stored duplicate disagrees .*first: position at (64, 3)" seam.err &&
	PYTHONPATH=$NDO_ROOT/tests/e2e /usr/bin/python3 -c '
import gridfile, numpy as np, sys
a, b = (gridfile.read(f)["channels"]["position"] for f in ("seam6.tgrid", "s6.tgrid"))
sys.exit(not np.array_equal(a, b))'; then
	pass "disagreeing seam duplicates: warned, canonical values used"
else fail "disagreeing seam duplicates" "$(head -2 seam.err)"; fi
if subdivide s5.tgrid -o /dev/null 2>quiet.err && [ ! -s quiet.err ]; then pass "no warning for a grid ndo wrote"
else fail "warning for a grid ndo wrote" "$(head -1 quiet.err)"; fi

# A position that is not finite spreads over the butterfly's reach: named
# at the file's node and refused (simulate-peer and render-frame refuse it
# too), nothing written; and finite positions that refine beyond ±DBL_MAX.
PYTHONPATH=$NDO_ROOT/tests/e2e /usr/bin/python3 - <<'PYEOF'
import gridfile, numpy as np
g = gridfile.read("s5.tgrid")
x = g["channels"]["position"].copy()
x[2, 3, 1] = np.nan
gridfile.write_grid("nan.tgrid", {"level": g["level"], "step": 0, "time": 0.0, "history": "",
                                  "ch": {"position": x}})
x = g["channels"]["position"].astype('<f4')
x[1, 5, 2] = np.inf
gridfile.write_grid("inf32.tgrid", {"level": g["level"], "step": 0, "time": 0.0, "history": "",
                                    "ch": {"position": x}})
gridfile.write_grid("huge.tgrid", {"level": g["level"], "step": 0, "time": 0.0, "history": "",
                                   "ch": {"position": g["channels"]["position"] * 1.7e308}})
PYEOF
expect_error "a NaN position" 1 "^subdivide: nan\.tgrid: position of node \(3, 2\) is not finite$" \
	subdivide nan.tgrid -o never.obj
expect_error "an infinite f32 position, from a pipe" 1 \
	"^subdivide: standard input: position of node \(5, 1\) is not finite$" \
	bash -c 'subdivide <inf32.tgrid >never.tgrid'
expect_error "positions refined beyond the doubles" 1 \
	"huge\.tgrid: position of node \([0-9]+, [0-9]+\) of the grid refined by 2 levels is not finite" \
	subdivide -l 2 huge.tgrid -o never.tgrid
rm -f never.tgrid
if [ ! -e never.obj ] && ! ls ./*.tmp.* >/dev/null 2>&1; then pass "nothing written for a position that is not finite"
else fail "a refused position left a file" "$(ls never.obj ./*.tmp.* 2>&1)"; fi
