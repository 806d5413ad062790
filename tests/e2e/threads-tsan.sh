#!/usr/bin/env bash
# The threads' shared work under ThreadSanitizer: the unit tests that run
# work on several threads at once (the pool, a step's passes and pipelines
# on the threads, rk4's step begun ahead, runs of steps, the error estimate's and the
# choice's runs beside each other and beside a run), built by `make test`
# with SAN=thread under build/tsan/ (Makefile, TSAN_PROGS), must pass with
# no report.  A racy program made here first shows that the detector and
# these options do report a race.
. "$(dirname "$0")/lib.sh"
tb=$NDO_ROOT/build/tsan/tests
# OpenMP's runtime (CHOLMOD's threads) is not built with TSan: its own
# synchronization is invisible to the detector, which then reports its
# memsets as races.  Those reports alone are suppressed.
cat >tsan.supp <<'EOF'
called_from_lib:libgomp.so.1
EOF
export TSAN_OPTIONS="halt_on_error=1 exitcode=66 suppressions=$PWD/tsan.supp"
# Without address-space randomization: TSan's shadow memory wants fixed
# ranges, which a kernel with more random bits may not leave free.
norand=()
if setarch "$(uname -m)" -R true 2>/dev/null; then norand=(setarch "$(uname -m)" -R); fi

cat >race.c <<'EOF'
#include <pthread.h>
static int shared;
static void *bump(void *arg) { (void)arg; for (int k = 0; k < 1000; k++) shared++; return 0; }
int main(void)
{
	pthread_t t;
	pthread_create(&t, 0, bump, 0);
	bump(0);
	pthread_join(t, 0);
	return shared == -1;
}
EOF
if ! gcc -O1 -g -fsanitize=thread race.c -o race 2>cc.log; then
	fail "a racy program" "could not build it with -fsanitize=thread: $(head -n 1 cc.log)"
else
	"${norand[@]}" ./race >race.log 2>&1
	rc=$?
	if [ $rc -eq 66 ] && grep -q 'WARNING: ThreadSanitizer: data race' race.log; then
		pass "a racy program is reported (exit $rc)"
	else
		fail "a racy program" "exit $rc, $(grep -c 'ThreadSanitizer' race.log) reports"
	fi
fi

# run_tsan NAME PROGRAM [CHECK_ONLY word]: every case passes, no report
run_tsan() {
	local name=$1 prog=$tb/$2 only=${3:-}
	if [ ! -x "$prog" ]; then
		fail "$name" "$prog is not built (make test builds it: make SAN=thread tsan-build)"
		return
	fi
	CHECK_ONLY=$only "${norand[@]}" "$prog" >"$2$only.log" 2>&1
	local rc=$? passed failed reports
	passed=$(grep -c '^PASS ' "$2$only.log")
	failed=$(grep -c '^FAIL ' "$2$only.log")
	reports=$(grep -c 'WARNING: ThreadSanitizer' "$2$only.log")
	if [ $rc -eq 0 ] && [ "$passed" -gt 0 ] && [ "$failed" -eq 0 ] && [ "$reports" -eq 0 ]; then
		pass "$name: $passed case$([ "$passed" = 1 ] || echo s), no report"
	else
		fail "$name" "exit $rc, $passed passed, $failed failed, $reports reports"
		grep -A12 -m1 'WARNING: ThreadSanitizer' "$2$only.log" | sed 's/^/    /'
	fi
}

run_tsan "the pool" test_pool
run_tsan "every explicit method's steps on 1, 2 and 3 threads" test_sim threads_give_the_same_bits
run_tsan "rk4's step begun ahead on the threads" test_sim rk4_begun_ahead
run_tsan "runs of steps (rk4's chain, with pins too; symplectic Euler's wave) on 2 threads" test_sim steps_on_threads
run_tsan "the error estimate and the choice, their runs side by side and beside a run" \
	test_accuracy
