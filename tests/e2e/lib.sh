# tests/e2e/lib.sh — sourced by the end-to-end scripts.
#
# Each script runs the real binaries (on PATH: $NDO_BIN) in a fresh
# directory and reports one line per case with pass/fail.  Run alone
# (outside tests/run) a script finds the default build's binaries.
set -u
: "${NDO_ROOT:=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)}"
: "${NDO_BIN:=$NDO_ROOT/bin}"
: "${NDO_TMP:=$NDO_ROOT/build/test-tmp}"
export PATH=$NDO_BIN:$PATH
# The case's directory stays for its logs; tests/run empties $NDO_TMP when it
# starts, `make clean` removes it (never a stray folder in /tmp).
mkdir -p "$NDO_TMP" && T=$(mktemp -d "$NDO_TMP/$(basename "$0" .sh).XXXXXX") && cd "$T" || {
	echo "FAIL $(basename "$0" .sh): no scratch directory under $NDO_TMP"; exit 1; }
SCRIPT=$(basename "$0" .sh)

pass() { echo "PASS $SCRIPT: $1"; }
# A FAIL line also marks the script failed, so that run alone it exits 1
# (tests/run counts the lines either way); a file, since cases run in
# subshells and pipelines too.
FAILED_MARK=$T/.failed
fail() { echo "FAIL $SCRIPT: $1${2:+: $2}"; : >"$FAILED_MARK"; }
trap 'rc=$?; [ -e "$FAILED_MARK" ] && [ $rc -eq 0 ] && rc=1; exit $rc' EXIT

# check NAME CMD...: the command succeeds
check() {
	local name=$1; shift
	if "$@" >out.log 2>err.log; then pass "$name"; else
		fail "$name" "exit $? from: $*"; sed 's/^/    /' err.log | head -5; fi
}

# expect_error NAME CODE PATTERN CMD...: the command exits with CODE and
# prints exactly one line on stderr, matching the extended regex PATTERN
# (for usage errors, a second "Try ... --help" line is allowed).
expect_error() {
	local name=$1 code=$2 pattern=$3; shift 3
	"$@" >out.log 2>err.log
	local rc=$?
	local first lines
	first=$(head -n 1 err.log)
	lines=$(grep -vc "^Try '.* --help'\.$" err.log)
	if [ "$rc" -ne "$code" ]; then
		fail "$name" "expected exit $code, got $rc from: $*"; sed 's/^/    /' err.log | head -5
	elif [ "$lines" -ne 1 ]; then
		fail "$name" "expected one error line, got $lines"; sed 's/^/    /' err.log | head -5
	elif ! grep -Eq -- "$pattern" <<<"$first"; then
		fail "$name" "expected /$pattern/, got: $first"
	else
		pass "$name"
	fi
}
