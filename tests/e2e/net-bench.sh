#!/usr/bin/env bash
# net-bench and compact state tiles (issue 7), in a private network
# namespace: one small net-bench row and its CSV's columns and sanity; the
# expected failures; 2-peer simulate-peer runs with each compact encoding
# against the raw run (the boundary and the last step travel exact, so the
# owner's result is the raw run's bit for bit) and that against the 1-peer
# run; and render-frame's observer decoding them.
. "$(dirname "$0")/netns.bash"
. "$(dirname "$0")/lib.sh"

# 1. one row: level 4, predict, 1 s
SECONDS=0
if net-bench -q -l 4 -e predict -t 1 --csv row.csv -o table.txt >stdout.txt 2>err.txt; then
	/usr/bin/python3 - row.csv <<'PY' >check.txt
import csv, math, sys
rows = list(csv.DictReader(open(sys.argv[1])))
need = "level encoding bits_per_node_update mbit_s max_error_rel rms_error_rel encode_ms decode_ms latency_p50_us latency_p99_us kernel_drops halo_bits".split()
r = rows[0] if rows else {}
bad = [c for c in need if c not in r]
if len(rows) != 1 or bad:
    print(f"rows {len(rows)}, missing {bad}"); sys.exit()
f = {k: float(r[k]) for k in need if k != "encoding"}
why = []
if r["level"] != "4" or not r["encoding"].startswith("predict"): why.append("level/encoding")
if not 0.5 < f["bits_per_node_update"] < 96:
    # what they were (each over the steady state's nodes x steps)
    parts = " ".join(f"{k} {r.get(k + '_bits', '?')}" for k in ("encoded_tile", "raw_tile", "rest_tile", "heartbeat", "control"))
    why.append(f"bits {f['bits_per_node_update']} ({parts}; {r.get('steady_steps', '?')} steady steps of {r.get('steps', '?')})")
if not f["mbit_s"] > 0: why.append("mbit_s")
if not 0 < f["max_error_rel"] <= 1 / 16384 * 1.000001: why.append(f"max error {f['max_error_rel']}")
if not 0 < f["rms_error_rel"] <= f["max_error_rel"]: why.append("rms error")
if not (f["encode_ms"] > 0 and f["decode_ms"] > 0): why.append("times")
if not 0 < f["latency_p50_us"] <= f["latency_p99_us"] < 1e6: why.append("latency")
if f["kernel_drops"] != 0: why.append(f"kernel drops {f['kernel_drops']}")
# the 2 peers' halos: counted apart from the wire's bits (not a viewer's)
if not f["halo_bits"] > 0: why.append(f"halo bits {f['halo_bits']}")
print("ok" if not why else "; ".join(why),
      f"{f['bits_per_node_update']:.3g} bits/node/update, max error {f['max_error_rel']:.3g}")
PY
	read -r verdict rest <check.txt
	if [ "$verdict" = ok ] && grep -q '| 4 | 561 | predict' table.txt && [ ! -s stdout.txt ]; then
		pass "one row (level 4, predict): CSV columns and values sane: $rest (${SECONDS}s)"
	else
		fail "one row" "$(cat check.txt)"
	fi
else
	fail "one row" "exit $?: $(tail -2 err.txt)"
fi

# 2. expected failures
expect_error "bad level" 2 "^net-bench: --level: .*1\.\.8" net-bench -l 12
expect_error "unknown encoding" 2 "^net-bench: --encoding: 'zip': unknown encoding" net-bench -e zip
expect_error "bad loss" 2 "^net-bench: --loss" net-bench --loss 2
expect_error "unwritable CSV" 1 "^net-bench: no/such/dir/x.csv: " net-bench -l 4 -e raw --csv no/such/dir/x.csv
expect_error "unwritable table" 1 "^net-bench: no/such/dir/x.md: " net-bench -l 4 -e raw -o no/such/dir/x.md
expect_error "stray argument" 2 "^net-bench: unexpected argument" net-bench extra
# A usage error before anything is written: a send level above -l's
# printed the table's head on standard output first (and, run without
# root, the namespace's error came instead of it).
expect_error "send level above the level: nothing on stdout" 2 \
	"^net-bench: --send-level: 5 is above the level 4 \(0\.\.4\)$" net-bench -q -l 4 -s 5
[ -s out.log ] && fail "send level above the level: nothing on stdout" "$(head -c 100 out.log)"
expect_error "send level above the level, unprivileged" 2 "^net-bench: --send-level: 5 is above" \
	setpriv --reuid=65534 --regid=65534 --clear-groups "$NDO_BIN/net-bench" -q -l 4 -s 5
expect_error "the CSV and the table in one file" 2 "^net-bench: --csv t\.txt: that is the table's file" \
	net-bench -q -l 4 -e raw --csv t.txt -o t.txt
[ ! -e no/such/dir ] || fail "unwritable CSV or table" "a file appeared"

# 3. 2 peers, each compact encoding RUNS times, against the raw 2-peer run
# (bit for bit: the boundary and the last step travel exact) and that
# against the 1-peer run (close: the partitioned scheme holds its boundary
# over a step).  A joiner that counted the owner's encoded step-0 tiles as
# its snapshot became READY before the raw snapshot came and started its
# region from zeros, ~0.86 off: about one run in two, hence several runs
# (issue 7).
SCENE=$NDO_ROOT/samples/thesis-fig5.3.scene
RUNS=${NET_BENCH_RUNS:-4}
remesh --shape wavy -l 5 -o w5.tgrid 2>/dev/null || fail "remesh"
run2() { # run2 ENCODING OUT: 0 when both peers succeed
	simulate-peer --owner w5.tgrid -s "$SCENE" --dt 0.01 -t 0.6 --peers 2 --encoding "$1" \
		--start-timeout 30 -o "$2" 2>owner.err &
	local o=$!
	simulate-peer --join --poi 1000 --start-timeout 30 2>joiner.err &
	local j=$!
	wait $o && wait $j || { wait; return 1; }
}
# maxdiff REFERENCE FILE...: per FILE, the largest difference of position
# and velocity from REFERENCE
maxdiff() {
	/usr/bin/python3 - "$NDO_ROOT/tests/e2e" "$@" <<'PY'
import sys
sys.path.insert(0, sys.argv[1])
import numpy as np, tgrid
ref = tgrid.read(sys.argv[2])[3]
for f in sys.argv[3:]:
    c = tgrid.read(f)[3]
    print(repr(max(float(np.abs(c[k] - ref[k]).max()) for k in ("position", "velocity"))))
PY
}
if simulate-peer --owner w5.tgrid -s "$SCENE" --dt 0.01 -t 0.6 -q -o one.tgrid && run2 raw two-raw.tgrid; then
	d=$(maxdiff one.tgrid two-raw.tgrid)
	if /usr/bin/python3 -c "import sys; sys.exit(not float(sys.argv[1]) < 1e-2)" "$d"; then
		pass "2 peers, raw: within $d of the 1-peer run"
	else
		fail "2 peers, raw" "differs from the 1-peer run by $d"
	fi
	for enc in float32 fixed:13 predict hier:1e-4; do
		outs=() failed=
		for ((r = 1; r <= RUNS; r++)); do
			if run2 "$enc" "two-$enc-$r.tgrid"; then
				outs+=("two-$enc-$r.tgrid")
			else
				failed="run $r: a peer failed: $(tail -1 owner.err) / $(tail -1 joiner.err)"
				break
			fi
		done
		sent=$(grep -o 'sent [0-9.e+-]* MB' owner.err | head -1)
		if [ -n "$failed" ]; then
			fail "2 peers, $enc" "$failed"
			continue
		fi
		ds=$(maxdiff two-raw.tgrid "${outs[@]}" | tr '\n' ' ')
		if [ "$(wc -w <<<"$ds")" = "$RUNS" ] && ! grep -qv '^0\.0$' <<<"$(tr ' ' '\n' <<<"${ds% }")"; then
			pass "2 peers, $enc: $RUNS runs, each owner's result equals the raw run's exactly ($sent by the owner)"
		else
			fail "2 peers, $enc" "differences from the raw run in $RUNS runs: $ds"
		fi
	done
else
	fail "2 peers, raw" "a run failed: $(tail -1 owner.err)"
fi

# 4. the observer decodes: render-frame --lcm draws predict and hier tiles as it
# draws raw ones (predict's with --passive: nothing is lost here, so asking
# for keyframes or not, the same frames)
URL='udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304'
for enc in raw predict hier; do
	mkdir -p "f-$enc"
	passive=()
	[ $enc = predict ] && passive=(--passive)
	render-frame --lcm "$URL" --lcm-timeout 3 "${passive[@]}" -s 96x72 -o "f-$enc/f%04d.png" \
		2>"rf-$enc.err" &
	rf=$!
	sleep 0.5
	simulate-peer --lcm "$URL" --owner w5.tgrid -s "$SCENE" --dt 0.01 -t 0.2 --encoding "$enc" \
		--publish-every 1 -q -o /dev/null
	wait $rf
done
nr=$(ls f-raw | wc -l)
for enc in predict hier; do
	np=$(ls f-$enc | wc -l)
	if [ "$nr" -gt 15 ] && [ "$np" = "$nr" ]; then
		pass "render-frame --lcm draws $np frames of $enc tiles (raw: $nr)"
	else
		fail "render-frame --lcm, $enc" "frames: raw $nr, $enc $np; $(tail -1 rf-$enc.err)"
	fi
done
