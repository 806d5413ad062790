#!/usr/bin/env bash
# net-fuzz — 20 s of libFuzzer on every message decoder and validator and
# on the receive path (tests/fuzz/fuzz_msg.c): no crash, no leak, no UB.
. "$(dirname "$0")/lib.sh"
fz=${NDO_TESTBIN:-$NDO_ROOT/build/asan/tests}/fuzz_msg
if [ ! -x "$fz" ]; then
	fail "fuzz_msg built" "missing $fz (make SAN=1 check-build builds it)"
	exit 0
fi
mkdir -p corpus
if "$fz" -max_total_time=20 -print_final_stats=1 -rss_limit_mb=1024 corpus >fuzz.log 2>&1; then
	pass "20 s of random messages: no crash ($(grep -o 'stat::number_of_executed_units: *[0-9]*' fuzz.log | grep -o '[0-9]*$' || echo '?') runs)"
else
	fail "fuzz_msg found a problem" "$(grep -m1 -E 'ERROR|SUMMARY' fuzz.log)"
fi
