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

# libFuzzer targets: clang, with the library's sources compiled in.
FUZZ_SRCS := $(sort $(wildcard tests/fuzz/fuzz_*.c))
ifeq ($(SAN),1)
TEST_PROGS += $(FUZZ_SRCS:tests/fuzz/%.c=$(TBIN)/%)
endif
# LCM_GEN_SRCS/DIR/STAMP: the generated message code (lib/lcmtypes/build.mk).
# The generated code is compiled apart, without UBSan's nonnull check, for
# the reason lib/lcmtypes/build.mk gives.
FUZZ_CC := clang -std=c11 -D_GNU_SOURCE $(ALL_INC) $(if $(LCM_GEN_DIR),-I$(LCM_GEN_DIR)) -g -O1
$(TBIN)/fuzz_%: tests/fuzz/fuzz_%.c $(LIB_SRCS) $(LCM_GEN_STAMP) $(wildcard lib/*/ndo/*.h lib/*/*.h tests/fuzz/*.h)
	@mkdir -p $(@D)/fuzz-gen-$*
	for s in $(LCM_GEN_SRCS); do \
	  $(FUZZ_CC) -w -fsanitize=fuzzer-no-link,address,undefined -fno-sanitize=nonnull-attribute \
	    -c $$s -o $(@D)/fuzz-gen-$*/$$(basename $$s .c).o || exit 1; done
	$(FUZZ_CC) -fsanitize=fuzzer,address,undefined -o $@ $< $(LIB_SRCS) \
	    $(patsubst %.c,$(@D)/fuzz-gen-$*/%.o,$(notdir $(LCM_GEN_SRCS))) $(NDO_LIBS)

BENCH_SRCS := $(sort $(wildcard tests/bench/bench_*.c tests/bench/bench_*.cpp))
BENCH_PROGS := $(foreach s,$(BENCH_SRCS),$(TBIN)/$(basename $(notdir $(s))))
TEST_OBJS += $(BENCH_SRCS:%=$(OBJ)/%.o)
$(foreach s,$(BENCH_SRCS),$(eval $(call unit_rule,$(s))))

# OpenMesh's headers trip g++ 12's -Wmaybe-uninitialized inside std::vector.
$(OBJ)/tests/unit/%.cpp.o: CXXFLAGS += -Wno-maybe-uninitialized
# Benchmarks compare against OpenMesh and Bullet at their release settings:
# assertions off, -O3.
$(OBJ)/tests/bench/%.cpp.o: CXXFLAGS += -O3 -DNDEBUG -Wno-maybe-uninitialized
