#!/usr/bin/env bash
# render-frame draws an object wherever it is and whatever its size: the
# positions are re-centred and scaled before they go to the GPU as floats,
# so a sphere 1e8 m from the origin, or 1e-9 m or 1e12 m across, looks
# like the unit sphere at the origin (fitted, round, shaded the same).
. "$(dirname "$0")/lib.sh"
py=/usr/bin/python3
rc="$NDO_ROOT/tests/e2e/render_check.py"

remesh --shape sphere -l 4 -o s4.tgrid
PYTHONPATH=$NDO_ROOT/tests/e2e $py - <<'PYEOF'
import gridfile
g = gridfile.read("s4.tgrid")
x = g["channels"]["position"]
for name, y in (("far", x + [1e8, -2e8, 3e7]), ("tiny", x * 1e-9), ("huge", x * 1e12),
                ("tiny-far", x * 1e-6 + 1e3), ("huge-far", x * 1e12 + 1e14)):
    gridfile.write_grid(name + ".tgrid", {"level": g["level"], "step": 0, "time": 0.0,
                                          "history": "", "ch": {"position": y}})
PYEOF
check "unit sphere drawn" render-frame -s 320x240 s4.tgrid -o unit.png
for s in far tiny huge tiny-far huge-far; do
	if render-frame -s 320x240 "$s.tgrid" -o "$s.png" 2>"$s.err" &&
		$py "$rc" sphere "$s.png" >"$s.chk" 2>&1 && $py "$rc" compare "$s.png" unit.png --mean 0.5 --p99 8 >>"$s.chk" 2>&1; then
		pass "$s: fitted, round and shaded as the unit sphere"
	else fail "$s" "$(cat "$s.err" "$s.chk" | tail -2)"; fi
done
# a camera given in world units still works far from the origin: the
# sphere (radius 1) seen from 10 m covers a few percent of the picture
if render-frame -s 320x240 --center 1e8,-2e8,3e7 --eye 1.00000006e8,-2.00000008e8,3.0000000e7 far.tgrid \
	-o far-eye.png 2>eye.err && $py -c '
import sys; from PIL import Image; import numpy as np
a = np.asarray(Image.open("far-eye.png").convert("RGB")).astype(int)
bg = a[0, 0]; share = (np.abs(a - bg).sum(axis=2) > 30).mean()
print(share); sys.exit(not 0.02 < share < 0.3)' >eye.chk 2>&1; then pass "explicit eye and centre in world units, 1e8 m out"
else fail "explicit camera far out" "$(cat eye.err eye.chk | tail -2)"; fi
