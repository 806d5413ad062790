# ndo — network deformable objects.
#
#   make            build lib/libndo.a and every tool into bin/
#   make deps       install the Debian packages ndo needs (only those missing)
#   make test       build with ASan + UBSan under build/asan/ (and the threaded
#                   unit tests with TSan under build/tsan/) and run every test
#   make bench      build optimized and run the speed benchmarks (docs/bench/)
#   make report     regenerate every figure and table in docs/ (minutes)
#   make demo       the main job, end to end (output in build/demo/)
#   make install    PREFIX=/usr/local: binaries, shaders, headers, library,
#                   pkg-config file, manual pages
#   make clean      remove everything make made
#
# Each tool's sources and libraries are listed in tools/NAME/build.mk; the
# tests' in tests/build.mk.

.DEFAULT_GOAL := all
VERSION := 0.1.0
PREFIX ?= /usr/local
DESTDIR ?=
CC := gcc
CXX := g++

# Debian packages (make deps).  Grouped by who needs them.
DEBS_BUILD := build-essential pkg-config zlib1g-dev libzstd-dev libassimp-dev iproute2
DEBS_TEST := python3 python3-numpy clang libclang-rt-14-dev libopenmesh-dev libtsan2
# Recursive: the tools' build.mk fragments, included below, add DEBS_TOOLS.
DEBS = $(DEBS_BUILD) $(DEBS_TEST) $(DEBS_TOOLS)

# Two variants.  The default puts lib/libndo.a and bin/ in the tree; SAN=1
# (what `make test` uses) builds everything again with AddressSanitizer and
# UndefinedBehaviorSanitizer under build/asan/.  Its debug information is
# line tables (-g1: what a sanitizer's report names), not variables, and
# GCC's pointer-overflow check is left out: lib/sim/accel.c took 28-32 s
# to compile with -g and the check, 16-19 with -g1, 9-11 with neither
# (2026-11-29, 3 rounds alternated).  With the C++ flags below, a clean
# sanitizer build went from 5 min 28 s (616 s of CPU) to 3 min 23 s (387 s)
# on a 2-core AMD EPYC.  The fuzz targets (clang) keep every check on the
# readers and decoders.
ifeq ($(SAN),1)
OUT := build/asan
LIBNDO := build/asan/lib/libndo.a
OPTFLAGS := -O1 -g1 -fno-omit-frame-pointer \
            -fsanitize=address,undefined -fno-sanitize=pointer-overflow \
            -fno-sanitize-recover=all
# In C++ (CGAL's and OpenMesh's templates, instantiated in their thousands)
# neither are UBSan's null, alignment and vptr checks: they made remesh's
# load.cpp 129-132 s of CPU against 88-90 without them (2 rounds).  ASan
# still stops at a null dereference, with the stack; ndo's own C++ has no
# virtual classes.
SAN_CXXFLAGS := -fno-sanitize=null,alignment,vptr
else ifeq ($(SAN),thread)
# SAN=thread: the library and the unit tests whose threads share work
# (TSAN_PROGS) with ThreadSanitizer, under build/tsan/, which
# tests/e2e/threads-tsan.sh runs (`make test` builds them).
OUT := build/tsan
LIBNDO := build/tsan/lib/libndo.a
OPTFLAGS := -O1 -g1 -fno-omit-frame-pointer -fsanitize=thread
else
OUT := build
LIBNDO := lib/libndo.a
OPTFLAGS := -O2 -g
endif
OBJ := $(OUT)/obj
BIN := $(if $(filter 1,$(SAN)),build/asan/bin,$(if $(filter thread,$(SAN)),build/tsan/bin,bin))
TBIN := $(OUT)/tests

WARN := -Wall -Wextra -Wno-unused-parameter
# The library's layers, lowest first (lib/LAYER/, public headers in
# lib/LAYER/ndo/, included as "ndo/NAME.h"): grid and geometry, physics,
# network.  A layer's sources see only their own headers and those of the
# layers below (LAYER_INC); tools and tests see every layer.
# tests/e2e/layers.sh checks the same rule on the #include lines and that
# no two files call each other.
LAYERS := grid sim net
grid_INC := -Ilib/grid
sim_INC := -Ilib/sim $(grid_INC)
net_INC := -Ilib/net $(sim_INC)
lib/grid_CPPFLAGS = $(grid_INC)
lib/sim_CPPFLAGS = $(sim_INC)
lib/net_CPPFLAGS = $(net_INC) -I$(LCM_GEN_DIR)
ALL_INC := $(net_INC)
CPPFLAGS += -D_GNU_SOURCE -MMD -MP
CFLAGS += -std=c11 $(OPTFLAGS) $(WARN)
CXXFLAGS += -std=c++17 $(OPTFLAGS) $(SAN_CXXFLAGS) $(WARN)
LDFLAGS += $(filter -fsanitize=%,$(OPTFLAGS))
# What a program linking lib/libndo.a links besides (ndo.pc says the same).
NDO_LIBS := -lassimp -lz -lzstd -lm

LIB_SRCS := $(sort $(foreach l,$(LAYERS),$(wildcard lib/$(l)/*.c)))
LIB_OBJS := $(LIB_SRCS:%=$(OBJ)/%.o)

TOOLS :=
include $(sort $(wildcard lib/*/build.mk tools/*/build.mk))
include tests/build.mk

ALL_OBJS := $(LIB_OBJS)
define tool_rules
$(1)_OBJS := $$($(1)_SRCS:%=$(OBJ)/%.o)
ALL_OBJS += $$($(1)_OBJS)
$(BIN)/$(1): $$($(1)_OBJS) $(LIBNDO)
	@mkdir -p $$(@D)
	$$(if $$(filter %.cpp,$$($(1)_SRCS)),$(CXX),$(CC)) $(LDFLAGS) -o $$@ \
	    $$($(1)_OBJS) $(LIBNDO) $$($(1)_LIBS) $(NDO_LIBS)
endef
$(foreach t,$(TOOLS),$(eval $(call tool_rules,$(t))))

.PHONY: all deps test check-build tsan-build bench bench-progs report demo install clean help
all: $(LIBNDO) $(TOOLS:%=$(BIN)/%)

$(LIBNDO): $(LIB_OBJS)
	@mkdir -p $(@D)
	rm -f $@
	ar rcs $@ $^

# A directory's own flags ($(DIR)_CPPFLAGS) or, outside lib/, every layer.
dir_cppflags = $(if $(filter lib/%,$(1)),$($(1)_CPPFLAGS),$(ALL_INC) -I$(LCM_GEN_DIR) $($(1)_CPPFLAGS))

$(OBJ)/%.c.o: %.c
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS) $(CFLAGS) $(call dir_cppflags,$(<D)) -c -o $@ $<

# forces.c's batch of face normals vectorizes only with a sqrt that sets no
# errno (its argument, a sum of squares, is never negative), and GCC 12
# takes that from the command line alone, not from an optimize attribute.
$(OBJ)/lib/sim/forces.c.o: CFLAGS += -fno-math-errno

$(OBJ)/%.cpp.o: %.cpp
	@mkdir -p $(@D)
	$(CXX) $(CPPFLAGS) $(CXXFLAGS) $(call dir_cppflags,$(<D)) -c -o $@ $<

# Install the packages that are missing; `apt-get update` first when the
# package lists are empty (a fresh machine) or an install fails.
deps:
	@missing=; for p in $(sort $(DEBS)); do \
	  dpkg-query -W -f='$${Status}\n' $$p 2>/dev/null | grep -q '^install ok installed' \
	    || missing="$$missing $$p"; \
	done; \
	if [ -z "$$missing" ]; then echo "deps: all $(words $(sort $(DEBS))) packages present"; exit 0; fi; \
	sudo=; [ "$$(id -u)" = 0 ] || sudo=sudo; \
	echo "deps: installing$$missing"; \
	apt="$$sudo env DEBIAN_FRONTEND=noninteractive apt-get -y -q"; \
	if [ -z "$$(ls /var/lib/apt/lists 2>/dev/null | grep -v -e lock -e partial -e auxfiles)" ]; then \
	  $$apt update || exit 1; fi; \
	$$apt install --no-install-recommends $$missing \
	  || { $$apt update && $$apt install --no-install-recommends $$missing; }

# The test suite runs against the sanitizer build (and, for the threads'
# shared work, the ThreadSanitizer one: tests/e2e/threads-tsan.sh).
test: deps
	$(MAKE) -j$(shell nproc) SAN=1 check-build
	$(MAKE) -j$(shell nproc) SAN=thread tsan-build
	tests/run build/asan

check-build: all $(TEST_PROGS)

# The unit tests whose threads share work: the pool, the steps on the
# threads (test_sim), the error estimate's and the choice's runs beside
# each other and beside a run (test_accuracy).
TSAN_PROGS := $(addprefix $(TBIN)/,test_pool test_sim test_accuracy)
tsan-build: $(LIBNDO) $(TSAN_PROGS)

# The speed benchmarks; `make report` runs them and every study too.
BENCH_SPEED := subdivide render simulate threads
bench: deps
	$(MAKE) bench-progs
	tests/bench/run $(BENCH_SPEED)

# What the benchmark scripts run (tests/bench/run makes it first, so that
# a script run by hand never times a program older than the sources).
bench-progs: all $(BENCH_PROGS)

# Every figure and table in docs/: benchmarks, studies (stability maps,
# work-precision, remesh quality, partitions, sphere maps) and the
# rendered figures.
report: deps
	$(MAKE) bench-progs
	tests/bench/run
	docs/render-frame/figures.sh

# The demo builds quietly (the compiler's lines go to build/demo-build.log,
# shown only when the build fails) and then shows its own stages.
demo: deps
	@mkdir -p build
	@echo "demo: building the tools (log: build/demo-build.log)"
	@$(MAKE) -j$(shell nproc) all >build/demo-build.log 2>&1 || \
	  { tail -n 20 build/demo-build.log; echo "demo: the build failed: build/demo-build.log"; exit 1; }
	@samples/demo.sh

install: all
	install -d $(DESTDIR)$(PREFIX)/bin $(DESTDIR)$(PREFIX)/lib/pkgconfig \
	    $(DESTDIR)$(PREFIX)/include/ndo $(DESTDIR)$(PREFIX)/share/man/man1 \
	    $(DESTDIR)$(PREFIX)/share/ndo/shaders
	install -m 755 $(TOOLS:%=$(BIN)/%) $(DESTDIR)$(PREFIX)/bin
	install -m 644 $(LIBNDO) $(DESTDIR)$(PREFIX)/lib/libndo.a
	install -m 644 $(foreach l,$(LAYERS),lib/$(l)/ndo/*.h) $(DESTDIR)$(PREFIX)/include/ndo
	install -d $(DESTDIR)$(PREFIX)/include/ndo_msg
	install -m 644 $(LCM_GEN_DIR)/ndo_msg/*.h $(DESTDIR)$(PREFIX)/include/ndo_msg
	install -m 644 $(wildcard tools/*.1) $(DESTDIR)$(PREFIX)/share/man/man1
	$(if $(wildcard shaders/*),install -m 644 $(wildcard shaders/*) $(DESTDIR)$(PREFIX)/share/ndo/shaders)
	printf '%s\n' 'prefix=$(PREFIX)' 'libdir=$${prefix}/lib' \
	    'includedir=$${prefix}/include' '' 'Name: ndo' \
	    'Description: network deformable objects: regular grids, butterfly subdivision, grid files' \
	    'Version: $(VERSION)' 'Libs: -L$${libdir} -lndo $(NDO_LIBS)' \
	    'Cflags: -I$${includedir}' > $(DESTDIR)$(PREFIX)/lib/pkgconfig/ndo.pc

clean:
	rm -rf build bin lib/libndo.a

help:
	@sed -n '3,12s/^# //p' Makefile

-include $(ALL_OBJS:.o=.d) $(TEST_OBJS:.o=.d)
