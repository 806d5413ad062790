# Test and benchmark programs (included by the Makefile).
#
# tests/unit/test_*.c and *.cpp: one program each, linked with libndo;
# *.cpp files may use OpenMesh (the independent reference).
# tests/fuzz/fuzz_*.c: libFuzzer targets, built with clang in the
# sanitizer variant only.
# tests/bench/bench_*.c/cpp: benchmark programs, built optimized.

UNIT_SRCS := $(sort $(wildcard tests/unit/test_*.c tests/unit/test_*.cpp))
TEST_PROGS := $(foreach s,$(UNIT_SRCS),$(TBIN)/$(basename $(notdir $(s))))
TEST_OBJS := $(UNIT_SRCS:%=$(OBJ)/%.o)
OPENMESH_LIBS := -lOpenMeshCore

define unit_rule
$(TBIN)/$(basename $(notdir $(1))): $(OBJ)/$(1).o $(LIBNDO)
	@mkdir -p $$(@D)
	$(if $(filter %.cpp,$(1)),$(CXX),$(CC)) $(LDFLAGS) -o $$@ $$< $(LIBNDO) \
	    $(if $(filter %.cpp,$(1)),$(OPENMESH_LIBS)) $(NDO_LIBS)
endef
$(foreach s,$(UNIT_SRCS),$(eval $(call unit_rule,$(s))))

# libFuzzer targets: clang.  The library's sources they reach and the
# generated message code are compiled once, with coverage and the
# sanitizers (fuzzer-no-link), into $(OUT)/fuzz-obj/ and linked into every
# target: each target used to compile the whole library again, serially
# (3 x 200 s of the sanitizer build's 15 min of CPU).  FUZZ_LIB_SRCS: what
# the targets reach — the grid file reader, the messages, their codecs and
# the session's authentication — the closure of what the linker took from
# an archive of the whole library (its map, 2026-11-29); the simulation and
# the peers' state machines are not compiled for them (the whole library
# took 203 s of CPU under these flags, these sources 72 s).  A target that
# comes to call another source fails to link, naming the symbol: add its
# source here.
FUZZ_LIB_SRCS := $(addprefix lib/grid/,grid.c gridfile.c io.c status.c topology.c) \
                 $(addprefix lib/net/,auth.c codec.c codec_entropy.c codec_hier.c \
                   codec_params.c codec_predict.c codec_rows.c codec_tile.c link.c \
                   link_mem.c msg.c net.c quadtree.c)
FUZZ_SRCS := $(sort $(wildcard tests/fuzz/fuzz_*.c))
ifeq ($(SAN),1)
TEST_PROGS += $(FUZZ_SRCS:tests/fuzz/%.c=$(TBIN)/%)
endif
# LCM_GEN_SRCS/DIR/STAMP: the generated message code (lib/lcmtypes/build.mk).
# The generated code is compiled without UBSan's nonnull check, for the
# reason lib/lcmtypes/build.mk gives.
FUZZ_CC := clang -std=c11 -D_GNU_SOURCE $(ALL_INC) $(if $(LCM_GEN_DIR),-I$(LCM_GEN_DIR)) -g -O1
FUZZ_OBJ := $(OUT)/fuzz-obj
FUZZ_LIB_OBJS := $(FUZZ_LIB_SRCS:%.c=$(FUZZ_OBJ)/%.o)
FUZZ_GEN_OBJS := $(LCM_GEN_SRCS:%.c=$(FUZZ_OBJ)/%.o)
$(FUZZ_LIB_OBJS): $(FUZZ_OBJ)/%.o: %.c | $(LCM_GEN_STAMP)
	@mkdir -p $(@D)
	$(FUZZ_CC) -MMD -MP -fsanitize=fuzzer-no-link,address,undefined -c $< -o $@
$(FUZZ_GEN_OBJS): $(FUZZ_OBJ)/%.o: %.c $(LCM_GEN_STAMP)
	@mkdir -p $(@D)
	$(FUZZ_CC) -w -fsanitize=fuzzer-no-link,address,undefined -fno-sanitize=nonnull-attribute \
	    -c $< -o $@
-include $(FUZZ_LIB_OBJS:.o=.d)
# the network layer's objects again when the messages change (as the
# library's, lib/lcmtypes/build.mk)
$(filter $(FUZZ_OBJ)/lib/net/%,$(FUZZ_LIB_OBJS)): $(LCM_GEN_STAMP)
$(TBIN)/fuzz_%: tests/fuzz/fuzz_%.c $(FUZZ_LIB_OBJS) $(FUZZ_GEN_OBJS) \
    $(wildcard lib/*/ndo/*.h lib/*/*.h tests/fuzz/*.h)
	@mkdir -p $(@D)
	$(FUZZ_CC) -fsanitize=fuzzer,address,undefined -o $@ $< $(FUZZ_LIB_OBJS) $(FUZZ_GEN_OBJS) $(NDO_LIBS)

BENCH_SRCS := $(sort $(wildcard tests/bench/bench_*.c tests/bench/bench_*.cpp))
BENCH_PROGS := $(foreach s,$(BENCH_SRCS),$(TBIN)/$(basename $(notdir $(s))))
TEST_OBJS += $(BENCH_SRCS:%=$(OBJ)/%.o)
$(foreach s,$(BENCH_SRCS),$(eval $(call unit_rule,$(s))))

# OpenMesh's headers trip g++ 12's -Wmaybe-uninitialized inside std::vector.
$(OBJ)/tests/unit/%.cpp.o: CXXFLAGS += -Wno-maybe-uninitialized
# Benchmarks compare against OpenMesh and Bullet at their release settings:
# assertions off, -O3.
$(OBJ)/tests/bench/%.cpp.o: CXXFLAGS += -O3 -DNDEBUG -Wno-maybe-uninitialized
