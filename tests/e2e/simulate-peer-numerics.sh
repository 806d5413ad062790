#!/usr/bin/env bash
# simulate-peer at the edges of its numbers: symplectic Euler is not called
# diverged while stable, the critical step holds at any accepted stiffness
# and density, implicit methods keep the centre of mass, and scales that
# overflow are refused naming the node.
. "$(dirname "$0")/lib.sh"
PY=/usr/bin/python3
export PYTHONPATH=$NDO_ROOT/tests/e2e

remesh --shape ellipsoid -l 3 -o egg.tgrid
remesh --shape sphere -l 3 -o ball.tgrid

# Symplectic Euler's energy swings by (1 + hω/2)/(1 − hω/2) on a mode of
# frequency ω: 19× at 0.95 × the critical step.  A state in the top mode
# (forward Euler without damping amplifies it most: a power iteration),
# released at rest, is stable and must run to the end ...
simulate-peer -q -i euler --energy-bound 0 -b 0 --perturb 1e-6 --dt 0.03 -n 100 ball.tgrid -o grown.tgrid
$PY -c '
import gridfile
g = gridfile.read("grown.tgrid")
gridfile.write_grid("top.tgrid", {"level": g["level"], "step": 0, "time": 0.0, "history": "",
                                  "ch": {"position": g["channels"]["position"]}})'
for sf in 0.9 0.95 0.99; do
	check "symplectic Euler from the top mode at $sf × the critical step runs 500 steps" \
		simulate-peer -q -i symplectic-euler --rest ball.tgrid -b 0 --dt-safety $sf -n 500 top.tgrid -o se.tgrid
done
# ... and the bound still catches a step beyond the critical one
hc=$(simulate-peer -i symplectic-euler --rest ball.tgrid -b 0 --info top.tgrid 2>&1 |
	sed -n 's/.*critical step \([0-9.e+-]*\) s.*/\1/p')
big=$(awk -v h="$hc" 'BEGIN { print 1.02 * h }')
simulate-peer -q -i symplectic-euler --rest ball.tgrid -b 0 --dt "$big" -n 2000 top.tgrid -o se-big.tgrid 2>se-big.err
rc=$?
if [ $rc -eq 3 ] && [ ! -e se-big.tgrid ]; then pass "symplectic Euler at 1.02 × the critical step diverges (exit 3)"
else fail "symplectic Euler beyond the critical step" "exit $rc at dt $big (critical $hc): $(head -1 se-big.err)"; fi

# λ_max(M⁻¹K) = (σ/ρ) × its value at σ = ρ = 1, at every accepted σ and ρ
lam() { simulate-peer --info "$@" egg.tgrid 2>&1 | sed -n 's/.*lambda_max(M^-1 K) = \([0-9.e+-]*\) .*/\1/p'; }
l1=$(lam)
for kr in "-k 1e-200:1e-200" "--density 1e-160:1e160" "-k 1e12 --density 1e-200:1e212" "--density 1e12:1e-12" "-k 1e-290 --density 1e12:1e-302"; do
	opts=${kr%%:*}; ratio=${kr##*:}
	# shellcheck disable=SC2086
	l=$(lam $opts)
	if awk -v a="$l" -v b="$l1" -v r="$ratio" 'BEGIN { x = a / (b * r); exit !(x > 0.999 && x < 1.001) }' 2>/dev/null; then
		pass "lambda_max scales as sigma/rho ($opts)"
	else fail "lambda_max at $opts" "got $l, expected $ratio × $l1"; fi
done
# and at those scales the auto step is stable: no false "stable at any step"
if simulate-peer -q --density 1e-160 -n 200 --rest ball.tgrid egg.tgrid -o tiny-rho.tgrid 2>tr.err; then
	pass "density 1e-160: the auto step runs"
else fail "density 1e-160" "$(head -1 tr.err)"; fi
if simulate-peer -q -k 1e-200 -b 0 -n 200 --rest ball.tgrid egg.tgrid -o tiny-k.tgrid 2>tk.err; then
	pass "stiffness 1e-200: the auto step runs"
else fail "stiffness 1e-200" "$(head -1 tk.err)"; fi

# Implicit methods at a huge stiffness: the mass-weighted centre (Σ m x,
# lumped masses of the rest shape) does not move; no forces act.
centre() { $PY - "$1" <<'PYEOF'
import sys, numpy as np, gridfile
g = gridfile.read(sys.argv[1]); r = gridfile.read("ball.tgrid")
x = g["channels"]["position"]; X = r["channels"]["position"]
H, W = x.shape[:2]
c = np.zeros(3); msum = 0.0
for j in range(H - 1):
    for i in range(W - 1):
        for t in (((i, j), (i + 1, j), (i, j + 1)), ((i + 1, j), (i + 1, j + 1), (i, j + 1))):
            P = [X[b, a] for a, b in t]
            A = 0.5 * np.linalg.norm(np.cross(P[1] - P[0], P[2] - P[0]))
            c += A / 3 * sum(x[b, a] for a, b in t); msum += A
print(*(c / msum))
PYEOF
}
c0=$(centre egg.tgrid)
for m in trapezoid backward-euler; do
	for k in 1e10 1e12; do
		if simulate-peer -q -i $m -k "$k" --dt 1 -n 500 --rest ball.tgrid egg.tgrid -o "$m-$k.tgrid" 2>imp.err; then
			c=$(centre "$m-$k.tgrid")
			d=$(awk -v a="$c0" -v b="$c" 'BEGIN { split(a, p, " "); split(b, q, " ");
				print sqrt((p[1]-q[1])^2 + (p[2]-q[2])^2 + (p[3]-q[3])^2) }')
			if awk -v d="$d" 'BEGIN { exit !(d < 1e-9) }'; then pass "$m, sigma $k, 500 steps of 1 s: centre of mass moves $d m"
			else fail "$m, sigma $k: centre of mass" "moved $d m (want < 1e-9; object size ~3 m)"; fi
		else fail "$m, sigma $k" "$(head -1 imp.err)"; fi
	done
done

# Scales that overflow: refused, naming the node; not "zero area", not
# "diverged at step 0".
$PY - <<'PYEOF'
import gridfile
g = gridfile.read("egg.tgrid")
ch = dict(g["channels"])
big = {"level": g["level"], "step": 0, "time": 0.0, "history": "", "ch": {"position": ch["position"] * 1e160}}
gridfile.write_grid("huge.tgrid", big)
far = ch["position"].copy(); far[2, 5] = [1e200, 0, 0]
gridfile.write_grid("far-node.tgrid", {"level": g["level"], "step": 0, "time": 0.0, "history": "", "ch": {"position": far}})
PYEOF
expect_error "an object 1e160 m across is refused as out of range" 1 \
	'huge\.tgrid: node \([0-9]+, [0-9]+\): position .*e\+1(59|60) m is beyond' simulate-peer -q huge.tgrid -o o.tgrid
expect_error "a node at 1e200 m is refused, named as in the file" 1 \
	'far-node\.tgrid: node \(5, 2\): position 1e\+200 m is beyond' simulate-peer -q far-node.tgrid -o o.tgrid
