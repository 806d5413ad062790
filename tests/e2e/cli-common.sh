#!/usr/bin/env bash
# What every tool does the same way (ndo/cli.h): --help, --version, an
# unknown option and an option without its value, each a one-line error
# naming the option with exit status 2, and a manual page beside it.
. "$(dirname "$0")/lib.sh"
for bin in "$NDO_BIN"/*; do
	[ -x "$bin" ] || continue
	t=$(basename "$bin")
	if "$t" --help >help.txt 2>&1 && grep -q -- '--version' help.txt && grep -qi 'exit status' help.txt; then
		pass "$t --help lists --version and the exit status"
	else
		fail "$t --help"
	fi
	if [[ $("$t" --version) =~ ^$t\ \(ndo\)\ [0-9]+\.[0-9]+\.[0-9]+$ ]]; then pass "$t --version"; else fail "$t --version" "$("$t" --version)"; fi
	expect_error "$t: unknown long option" 2 "^$t: unknown option '--no-such-option'$" "$t" --no-such-option
	expect_error "$t: unknown short option" 2 "^$t: unknown option '-Z'$" "$t" -Z
	expect_error "$t: option without its value" 2 "^$t: option '-o' needs a value$" "$t" -o
	if [ -f "$NDO_ROOT/tools/$t.1" ] && grep -q '^\.SH EXIT STATUS' "$NDO_ROOT/tools/$t.1"; then
		pass "$t has a manual page with its exit status"
	else
		fail "$t manual page" "tools/$t.1 missing or without EXIT STATUS"
	fi
	# the manual lists every option --help lists (man pages spell - as \-)
	missing=
	for o in $(grep -oE -- '--[a-z][a-z0-9-]*' help.txt | sort -u); do
		grep -qE -- "$(sed 's/-/\\\\?-/g' <<<"$o")([^a-z0-9-]|$)" "$NDO_ROOT/tools/$t.1" 2>/dev/null || missing="$missing $o"
	done
	if [ -z "$missing" ]; then pass "$t manual page lists every option of --help"
	else fail "$t manual page lists every option of --help" "missing:$missing"; fi
done
