#!/usr/bin/env bash
# The NumPy reader printed in docs/grid-format.md, run on files the tools
# write: it must read them, see what the format promises, and reject
# damaged ones.  Uses Debian's python3 (with python3-numpy).
. "$(dirname "$0")/lib.sh"
py=/usr/bin/python3
if ! $py -c 'import numpy' 2>/dev/null; then
	fail "python3-numpy is not installed (make deps installs it)"
	exit 0
fi
awk '/<!-- numpy-reader -->/ { on = 1; next } on && /^```python/ { grab = 1; next }
     grab && /^```/ { exit } grab { print }' "$NDO_ROOT/docs/grid-format.md" >reader.py
if [ "$(wc -l <reader.py)" -ge 10 ]; then pass "the doc holds a reader"; else fail "no reader found in docs/grid-format.md"; fi

remesh --shape tetra -l 1 -o tetra1.tgrid
remesh --shape sphere -l 3 -o sphere3.tgrid
subdivide -l 1 sphere3.tgrid -o sphere4.tgrid
cat tetra1.tgrid sphere3.tgrid >stream.tgrid
head -c 700 sphere3.tgrid >cut.tgrid

cat >check.py <<'PY'
import sys, numpy as np
from reader import read_grid
ok = True
def case(name, cond):
    global ok
    print(('PASS' if cond else 'FAIL') + ' grid-format: ' + name)
    ok &= bool(cond)

g = read_grid(open('tetra1.tgrid', 'rb'))
x = g['channels']['position']
case('tetra level 1 is 3 x 5 x 3', x.shape == (3, 5, 3) and g['level'] == 1)
r = 1 / np.sqrt(3)
case('tetra corners A B C D where lib/grid/ndo/domain.h says',
     np.allclose(x[0, 0], [r, r, r]) and np.allclose(x[0, 2], [r, -r, -r]) and
     np.allclose(x[2, 0], [-r, r, -r]) and np.allclose(x[2, 2], [-r, -r, r]))
case('history names the command', 'remesh --shape tetra -l 1' in g['history'])

s3 = read_grid(open('sphere3.tgrid', 'rb'))['channels']['position']
s4 = read_grid(open('sphere4.tgrid', 'rb'))
case('sphere nodes have unit radius', np.allclose(np.linalg.norm(s3, axis=2), 1, atol=1e-15))
p = s4['channels']['position']
case('subdivision keeps the old nodes bit for bit', np.array_equal(p[::2, ::2], s3))
N = 2 ** s4['level']
case('seam duplicates agree', np.array_equal(p[:, 0], p[:, 2 * N]) and
     np.array_equal(p[0, :], p[0, ::-1]) and np.array_equal(p[N, :], p[N, ::-1]))
case('history keeps both commands', 'remesh --shape sphere -l 3' in s4['history']
     and 'subdivide -l 1 sphere3.tgrid -o sphere4.tgrid' in s4['history'])

with open('stream.tgrid', 'rb') as f:
    a, b = read_grid(f), read_grid(f)
    case('a stream of two grids', a['level'] == 1 and b['level'] == 3 and f.read() == b'')
try:
    read_grid(open('cut.tgrid', 'rb'))
    case('a truncated file is rejected', False)
except ValueError:
    case('a truncated file is rejected', True)
sys.exit(0 if ok else 1)
PY
$py check.py || true
