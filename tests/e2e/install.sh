#!/usr/bin/env bash
# make install into a scratch prefix, then build a program against the
# installed headers and library with pkg-config, as a user of the library
# would, and run the installed tools.
. "$(dirname "$0")/lib.sh"
san=0 sanflags=
case $NDO_BIN in */build/asan/bin) san=1 sanflags="-fsanitize=address,undefined" ;; esac
prefix=$T/prefix
if make -s -C "$NDO_ROOT" SAN=$san install PREFIX="$prefix" >make.log 2>&1; then
	pass "make install PREFIX=…"
else
	fail "make install" "$(tail -3 make.log)"
	exit 0
fi
missing=
for f in bin/subdivide bin/remesh bin/simulate-peer bin/render-frame lib/libndo.a \
	include/ndo/ndo.h include/ndo/grid.h include/ndo_msg/ndo_msg_tile_t.h share/ndo/shaders/surface.vert \
	lib/pkgconfig/ndo.pc share/man/man1/subdivide.1; do
	[ -e "$prefix/$f" ] || missing="$missing $f"
done
if [ -z "$missing" ]; then pass "installed files in place"; else fail "installed files" "missing:$missing"; fi
cat >user.c <<'C'
#include <ndo/ndo.h>
#include <ndo/msg.h> /* includes the generated LCM message headers */
#include <stdio.h>
int main(void)
{
	ndo_grid *g;
	if (ndo_shape_make("sphere", 3, NULL, &g) || ndo_grid_save("user.tgrid", g))
		return 1;
	printf("%zu vertices\n", ndo_vertex_count(g->level));
	ndo_grid_destroy(g);
	return 0;
}
C
export PKG_CONFIG_PATH=$prefix/lib/pkgconfig
# shellcheck disable=SC2046
if gcc -std=c11 $sanflags $(pkg-config --cflags ndo) user.c $(pkg-config --libs ndo) -o user 2>cc.log &&
	[ "$(./user)" = "130 vertices" ]; then
	pass "a program builds and runs against the installed library (pkg-config ndo)"
else
	fail "building against the installed library" "$(head -3 cc.log)"
fi
if "$prefix/bin/subdivide" -l 1 user.tgrid -o user4.obj && [ "$(grep -c '^v ' user4.obj)" = 514 ]; then
	pass "the installed subdivide reads what the program wrote"
else
	fail "installed subdivide"
fi
