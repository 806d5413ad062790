#!/usr/bin/env bash
# The library's layers (README "Layout"): each layer of lib/ includes only
# its own headers and those of the layers below it, and no two files call
# each other, in lib/ or in a tool.  The checker (tests/layers.py) is first
# shown to catch a violation of each kind in a small tree made here.
. "$(dirname "$0")/lib.sh"
check=$NDO_ROOT/tests/layers.py
objdir=$(dirname "${NDO_TESTBIN:-$NDO_ROOT/build/tests}")/obj

# The checker catches an include that goes up and one across to another
# layer's private header.
mkdir -p bad/lib/grid/ndo bad/lib/sim/ndo bad/lib/net/ndo
echo '#include "ndo/sim.h"' >bad/lib/grid/grid.c
echo '' >bad/lib/grid/ndo/grid.h
echo '#include "ndo/grid.h"' >bad/lib/sim/ndo/sim.h
echo '#include "sim_private.h"' >bad/lib/net/peer.c
echo '' >bad/lib/sim/sim_private.h
python3 "$check" includes bad >got.txt
if [ $? -eq 1 ] && grep -q 'lib/grid/grid.c includes ndo/sim.h' got.txt &&
   grep -q 'lib/net/peer.c includes "sim_private.h"' got.txt && [ "$(wc -l <got.txt)" -eq 2 ]; then
	pass "the include check finds an include up a layer and one of another layer's private header"
else
	fail "the include check missed a planted violation" "$(tr '\n' ' ' <got.txt)"
fi

# The checker catches two object files that call each other.
mkdir -p objs/lib
printf 'int b(int);\nint a(int x) { return x ? b(x - 1) : 0; }\n' >objs/lib/a.c
printf 'int a(int);\nint b(int x) { return x ? a(x - 1) : 1; }\n' >objs/lib/b.c
printf 'int a(int);\nint c(int x) { return a(x); }\n' >objs/lib/c.c
mkdir -p objs/lib/grid objs/lib/sim objs/obj/lib/grid objs/obj/lib/sim
printf 'int v(void);\nint u(void) { return v(); }\n' >objs/lib/grid/u.c
printf 'int v(void) { return 1; }\n' >objs/lib/sim/v.c
for f in a b c grid/u sim/v; do gcc -c objs/lib/$f.c -o objs/obj/lib/$f.c.o; done
python3 "$check" circles objs/obj objs lib >got.txt
if [ $? -eq 1 ] && grep -q 'lib/a.c -> lib/b.c (b)' got.txt && ! grep -q 'lib/c.c' got.txt &&
   grep -q 'lib/grid/u.c calls up a layer into lib/sim/v.c (v)' got.txt; then
	pass "the circle check finds two object files that call each other (and only them) and a call up a layer"
else
	fail "the circle check missed a planted circle" "$(tr '\n' ' ' <got.txt)"
fi

if python3 "$check" includes "$NDO_ROOT" >got.txt; then
	pass "every include in lib/ names its own layer or one below (grid < sim < net)"
else
	fail "includes against the layering" "$(head -5 got.txt | tr '\n' ' ')"
fi
for d in lib $(cd "$NDO_ROOT" && ls -d tools/*/); do
	d=${d%/}
	if python3 "$check" circles "$objdir" "$NDO_ROOT" "$d" >got.txt; then
		pass "no two files of $d call each other"
	else
		fail "files of $d call each other" "$(head -3 got.txt | tr '\n' ' ')"
	fi
done
