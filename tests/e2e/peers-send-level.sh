#!/usr/bin/env bash
# A send level (issue 20), over real LCM in a private network namespace: an
# owner simulating level 6 sends whole regions at level 4; an observer's
# frames are level-4 grids (17 x 33 nodes) whose refinement by the butterfly
# is within the error the owner reports of the exact run (the single
# process: the owner simulates alone); the owner's -o stays
# exact at level 6 and its frames are level 4; net-bench's send-level row;
# a killed peer's region taken over from its coarse frames; the usage errors.
. "$(dirname "$0")/netns.bash"
. "$(dirname "$0")/lib.sh"

SCENE=$NDO_ROOT/samples/thesis-fig5.3.scene
remesh --shape wavy -l 6 -o wavy6.tgrid 2>/dev/null || fail "remesh"

# the exact run: one process, a frame every 10 steps, at level 6
simulate-peer -q wavy6.tgrid -s "$SCENE" --dt 0.004 -t 0.4 --frames 'ref/f%03d.tgrid' \
	--frame-every 10 -o ref.tgrid || fail "the single process"

for enc in raw predict:1e-4 hier:1e-4; do
	rm -rf obs own
	mkdir -p obs
	simulate-peer --join --frames 'obs/f%03d.tgrid' --frame-every 10 -o observed.tgrid 2>obs.err &
	observer=$!
	sleep 0.5
	# realtime: the observer has the time to join (alone, the owner's run is
	# the single process's, and its whole region travels every step).  The
	# pace is not what this checks: under load (the sanitizer build beside 4
	# busy loops, load 6-8 on 2 cores) the owner fell the default 0.5 s
	# behind its 4 ms steps by step 16-32 and stopped (exit 5) in 5 of 6
	# runs, so it may fall 30 s behind
	simulate-peer --owner wavy6.tgrid -s "$SCENE" --dt 0.004 -t 0.4 --send-level 4 --encoding $enc \
		--clock realtime --step-timeout 30 --frames 'own/f%03d.tgrid' --frame-every 10 \
		-o owner.tgrid 2>owner.err
	ro=$?
	wait $observer; rv=$?
	# the owner's reported error at level 6 (max, of the diagonal)
	bound=$(sed -n 's/.*send level 4 of 6: .* max \([0-9.e+-]*\), RMS.*/\1/p' owner.err | head -1)
	verdict=$(/usr/bin/python3 - "$NDO_ROOT/tests/e2e" "${bound:-nan}" <<'PY'
import glob, os, subprocess, sys
sys.path.insert(0, sys.argv[1])
import numpy as np, tgrid
bound = float(sys.argv[2])
why, worst, n = [], 0.0, 0
_, _, _, ref_end = tgrid.read("ref.tgrid")
lo, hi = ref_end["rest"].reshape(-1, 3).min(0), ref_end["rest"].reshape(-1, 3).max(0)
diag = float(np.linalg.norm(hi - lo))
for f in sorted(glob.glob("obs/f*.tgrid")):
    level, step, _, ch = tgrid.read(f)
    if level != 4 or ch["position"].shape != (17, 33, 3):
        why.append(f"{f}: level {level}, {ch['position'].shape}")
        continue
    ref = "ref/f%03d.tgrid" % (step // 10)
    if not os.path.exists(ref):
        continue
    fine = f + ".l6.tgrid"
    subprocess.run(["subdivide", "-l", "2", f, "-o", fine], check=True)
    _, _, _, a = tgrid.read(fine)
    _, _, _, b = tgrid.read(ref)
    e = float(np.linalg.norm(a["position"] - b["position"], axis=2).max()) / diag
    worst, n = max(worst, e), n + 1
    # the coarse nodes themselves: the exact ones (raw) or within the encoding's bound
    c = float(np.abs(ch["position"] - b["position"][::4, ::4]).max())
    if c > 1e-4 * diag:
        why.append(f"{f}: a coarse node off by {c / diag:.3g} of the diagonal")
if n < 3: why.append(f"only {n} frames compared")
if not worst <= bound * (1 + 5e-3): why.append(f"error {worst:.4g} above the reported {bound:.4g} (printed to 3 digits)")
if not worst > 1e-3: why.append(f"error {worst:.4g}: level 4 cannot be that close")
lv, st, _, o = tgrid.read("owner.tgrid")
_, _, _, r = tgrid.read("ref.tgrid")
if lv != 6 or not np.array_equal(o["position"], r["position"]): why.append("the owner's -o is not the exact run's")
lv, st, _, ob = tgrid.read("observed.tgrid")
if lv != 4 or not np.array_equal(ob["position"], r["position"][::4, ::4]): why.append("the observer's -o is not the exact last step sampled")
own = sorted(glob.glob("own/f*.tgrid"))
if not own or any(tgrid.read(f)[0] != 4 for f in own): why.append("the owner's frames are not level 4")
print("ok" if not why else "; ".join(why), f"{n} frames, error {worst:.3g} <= reported {bound:.3g}")
PY
)
	read -r v rest <<<"$verdict"
	if [ $ro = 0 ] && [ $rv = 0 ] && [ "$v" = ok ]; then
		pass "$enc at send level 4 of 6: observer frames at level 4, refined $rest; -o exact"
	else
		fail "$enc at send level 4 of 6" "exits $ro $rv: $verdict"
		tail -n 3 owner.err | sed 's/^/    /'
		tail -n 3 obs.err | sed 's/^/    /'
	fi
done

# net-bench: the send level's row, its bits below the level's own
if net-bench -q -l 5 -e predict:1e-4 --peers 1 -s 3,5 -t 0.5 --csv rows.csv -o table.md 2>nb.err; then
	verdict=$(/usr/bin/python3 - rows.csv <<'PY'
import csv, sys
rows = {int(r["send_level"]): r for r in csv.DictReader(open(sys.argv[1]))}
why = []
if sorted(rows) != [3, 5]: why.append(f"send levels {sorted(rows)}")
else:
    a, b = rows[3], rows[5]
    if not int(a["vertices"]) == 2 * 4 ** 5 + 2: why.append("vertices")
    if not float(a["bits_per_vertex_update"]) < float(b["bits_per_vertex_update"]): why.append("bits")
    if not float(b["level_max_error_rel"]) <= 1e-4: why.append("level 5's own error")
    if not float(a["level_max_error_rel"]) > 1e-3: why.append("level 3's error")
    if not 0 < float(a["level_rms_error_rel"]) <= float(a["level_max_error_rel"]): why.append("RMS")
print("ok" if not why else "; ".join(why))
PY
)
	[ "$verdict" = ok ] && grep -q '| 5 | 2145 | predict:0.0001:32 | 3 | 1 |' table.md &&
		pass "net-bench -s 3,5: a row per send level, fewer bits and a larger error at level 3" ||
		fail "net-bench -s 3,5" "$verdict"
else
	fail "net-bench -s 3,5" "exit $?: $(tail -2 nb.err)"
fi

# A peer killed mid-run (exact lock-step, 3 peers, level 5 sent at level 4):
# the region it leaves is taken over from its whole regions as they travelled,
# refined (ndo_session_refine_others), not from the values of its first step.
# Over 7 runs here the owner's result was within 0.06-0.15 of the largest
# displacement of the single process's (without a send level: 0.07-0.12;
# taking over from the first step's values: 0.34-0.68).
remesh --shape wavy -l 5 -o wavy5.tgrid 2>/dev/null
simulate-peer -q wavy5.tgrid -s "$SCENE" --dt 0.002 -t 20 -o single5.tgrid
simulate-peer --owner wavy5.tgrid -s "$SCENE" --dt 0.002 -t 20 --peers 3 --peer-timeout 1 \
	--step-timeout 0.2 --send-level 4 -o killed.tgrid 2>kowner.err &
owner=$!
simulate-peer -q --join --poi 1200 --peer-timeout 1 2>/dev/null &
j1=$!
simulate-peer -q --join --poi 3600 --peer-timeout 1 2>/dev/null &
j2=$!
for _ in $(seq 600); do grep -q 'starting: step' kowner.err && break; sleep 0.05; done
sleep 0.5
{ kill -KILL $j2 && wait $j2; } 2>/dev/null
wait $owner; ro=$?
wait $j1; r1=$?
verdict=$(/usr/bin/python3 - "$NDO_ROOT/tests/e2e" <<'PY'
import sys
sys.path.insert(0, sys.argv[1])
import numpy as np, tgrid
_, sa, _, a = tgrid.read("killed.tgrid")
_, sb, _, b = tgrid.read("single5.tgrid")
d = np.linalg.norm(a["position"] - b["position"], axis=2).max()
u = np.linalg.norm(b["position"] - b["rest"], axis=2).max()
owners = len(np.unique(a["owner"]))
print("ok" if sa == sb and owners == 2 and d / u < 0.25 else "bad", f"{d / u:.3g} of the largest displacement, {owners} owners")
PY
)
read -r v rest <<<"$verdict"
if [ $ro = 0 ] && [ $r1 = 0 ] && [ "$v" = ok ] && grep -q 'left: no heartbeat' kowner.err; then
	pass "a killed peer's region taken over from its coarse frames: the result within $rest"
else
	fail "a killed peer at a send level" "exits $ro $r1: $verdict"
fi

# usage errors
expect_error "a send level above the simulated one" 2 \
	"^simulate-peer: --send-level: 7 is above the simulated level 6" \
	simulate-peer -q --owner wavy6.tgrid -s "$SCENE" -t 0.01 --send-level 7
expect_error "a negative send level" 2 "^simulate-peer: --send-level: " \
	simulate-peer --owner wavy6.tgrid -s "$SCENE" -t 0.01 --send-level -1
expect_error "a joiner's send level" 2 "^simulate-peer: --send-level: the owner decides it" \
	simulate-peer --join --send-level 3
expect_error "net-bench: a send level above the row's" 2 "^net-bench: --send-level: 7 is above the level 6" \
	net-bench -l 6 -s 7
expect_error "net-bench: a negative send level" 2 "^net-bench: --send-level: " net-bench -l 6 -s -1
