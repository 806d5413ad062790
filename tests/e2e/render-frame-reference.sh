#!/usr/bin/env bash
# render-frame: the figures of docs/render-frame.md, made again, match the
# ones in docs/ (the reference images) within a tolerance: llvmpipe's output
# may change a little between Mesa versions, a broken shader or camera
# changes much more.
. "$(dirname "$0")/lib.sh"
py=/usr/bin/python3
rc="$NDO_ROOT/tests/e2e/render_check.py"
ref="$NDO_ROOT/docs/render-frame"

if "$ref/figures.sh" "$PWD/figs" >figures.log 2>&1; then pass "figures made again"; else
	fail "figures made again" "$(tail -1 figures.log)"; fi
for f in sphere cloth peers displacement wireframe; do
	check "$f.png as the reference" $py "$rc" compare "figs/$f.png" "$ref/$f.png" --mean 1.0 --p99 16
done
