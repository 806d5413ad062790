#!/usr/bin/env bash
# net-bench and compact state tiles (issue 7), in a private network
# namespace: one small net-bench row and its CSV's columns and sanity; the
# expected failures; a 2-peer simulate-peer run with each compact encoding
# against the raw run (the boundary and the last step travel exact, so the
# owner's result is the raw run's bit for bit), and render-frame's
# observer decoding them.
. "$(dirname "$0")/netns.bash"
. "$(dirname "$0")/lib.sh"

# 1. one row: level 4, predict, 1 s
SECONDS=0
if net-bench -q -l 4 -e predict -t 1 --csv row.csv -o table.txt >stdout.txt 2>err.txt; then
	/usr/bin/python3 - row.csv <<'PY' >check.txt
import csv, math, sys
rows = list(csv.DictReader(open(sys.argv[1])))
need = "level encoding bits_per_node_update mbit_s max_error_rel rms_error_rel encode_ms decode_ms latency_p50_us latency_p99_us kernel_drops".split()
r = rows[0] if rows else {}
bad = [c for c in need if c not in r]
if len(rows) != 1 or bad:
    print(f"rows {len(rows)}, missing {bad}"); sys.exit()
f = {k: float(r[k]) for k in need if k != "encoding"}
why = []
if r["level"] != "4" or not r["encoding"].startswith("predict"): why.append("level/encoding")
if not 0.5 < f["bits_per_node_update"] < 96: why.append(f"bits {f['bits_per_node_update']}")
if not f["mbit_s"] > 0: why.append("mbit_s")
if not 0 < f["max_error_rel"] <= 1 / 16384 * 1.000001: why.append(f"max error {f['max_error_rel']}")
if not 0 < f["rms_error_rel"] <= f["max_error_rel"]: why.append("rms error")
if not (f["encode_ms"] > 0 and f["decode_ms"] > 0): why.append("times")
if not 0 < f["latency_p50_us"] <= f["latency_p99_us"] < 1e6: why.append("latency")
if f["kernel_drops"] != 0: why.append(f"kernel drops {f['kernel_drops']}")
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
[ ! -e no/such/dir ] || fail "unwritable CSV or table" "a file appeared"

# 3. 2 peers, each compact encoding against raw
SCENE=$NDO_ROOT/samples/thesis-fig5.3.scene
remesh --shape wavy -l 5 -o w5.tgrid 2>/dev/null || fail "remesh"
run2() { # run2 ENCODING OUT
	simulate-peer --owner w5.tgrid -s "$SCENE" --dt 0.01 -t 0.6 --peers 2 --encoding "$1" \
		--start-timeout 30 -o "$2" 2>owner.err &
	local o=$!
	simulate-peer --join --poi 1000 --start-timeout 30 2>joiner.err &
	local j=$!
	wait $o && wait $j
}
if run2 raw two-raw.tgrid; then
	for enc in float32 fixed:13 predict; do
		if run2 "$enc" two-enc.tgrid; then
			d=$(/usr/bin/python3 "$NDO_ROOT/tests/e2e/tgrid.py" two-enc.tgrid \
				"float(abs(position - __import__('tgrid').read('two-raw.tgrid')[3]['position']).max())" 2>/dev/null ||
				/usr/bin/python3 - two-enc.tgrid two-raw.tgrid "$NDO_ROOT/tests/e2e" <<'PY'
import sys
sys.path.insert(0, sys.argv[3])
import numpy as np, tgrid
a = tgrid.read(sys.argv[1])[3]; b = tgrid.read(sys.argv[2])[3]
print(float(max(np.abs(a["position"] - b["position"]).max(), np.abs(a["velocity"] - b["velocity"]).max())))
PY
)
			sent=$(grep -o 'sent [0-9.e+-]* MB' owner.err | head -1)
			if [ "$d" = 0.0 ]; then
				pass "2 peers, $enc: the owner's result equals the raw run's exactly ($sent by the owner)"
			else
				fail "2 peers, $enc" "differs from raw by $d"
			fi
		else
			fail "2 peers, $enc" "a peer failed: $(tail -1 owner.err)"
		fi
	done
else
	fail "2 peers, raw" "a peer failed: $(tail -1 owner.err)"
fi

# 4. the observer decodes: render-frame --lcm draws predict tiles as it draws raw ones
URL='udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304'
for enc in raw predict; do
	mkdir -p "f-$enc"
	render-frame --lcm "$URL" --lcm-timeout 3 -s 96x72 -o "f-$enc/f%04d.png" 2>"rf-$enc.err" &
	rf=$!
	sleep 0.5
	simulate-peer --lcm "$URL" --owner w5.tgrid -s "$SCENE" --dt 0.01 -t 0.2 --encoding "$enc" \
		-q -o /dev/null
	wait $rf
done
nr=$(ls f-raw | wc -l); np=$(ls f-predict | wc -l)
if [ "$nr" -gt 15 ] && [ "$np" = "$nr" ]; then
	pass "render-frame --lcm draws $np frames of predict tiles (raw: $nr)"
else
	fail "render-frame --lcm" "frames: raw $nr, predict $np; $(tail -1 rf-predict.err)"
fi
