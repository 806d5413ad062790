# lib/lcmtypes/build.mk — the LCM message types (docs/protocol.md).
#
# lcm-gen turns lib/lcmtypes/*.lcm into C under build/gen/ndo_msg/ (both
# build variants share it: the generated code is the same); the C is
# compiled into libndo.  --c-no-pubsub: ndo publishes encoded bytes itself
# (lib/net/link_lcm.c), so the generated code needs only lcm_coretypes.h.
# --c-typeinfo: the field tables that lib/net/msg.c walks to check a
# message's lengths before LCM's decoder trusts them.

LCM_TYPES := $(sort $(wildcard lib/lcmtypes/*.lcm))
LCM_GEN_DIR := build/gen
LCM_GEN_SRCS := $(patsubst lib/lcmtypes/%.lcm,$(LCM_GEN_DIR)/ndo_msg/ndo_msg_%.c,$(LCM_TYPES))
LCM_GEN_STAMP := $(LCM_GEN_DIR)/ndo_msg/.stamp

$(LCM_GEN_STAMP): $(LCM_TYPES)
	@mkdir -p $(@D)
	rm -f $(@D)/*.c $(@D)/*.h
	lcm-gen -c --c-no-pubsub --c-typeinfo --c-cpath $(@D) --c-hpath $(@D) \
	    --cinclude ndo_msg $(LCM_TYPES)
	touch $@
$(LCM_GEN_SRCS): $(LCM_GEN_STAMP)
	@test -f $@ || { echo "lcm-gen did not make $@" >&2; exit 1; }

LIB_OBJS += $(LCM_GEN_SRCS:%=$(OBJ)/%.o)
# The generated code is not ours to warn about.  LCM 1.3.1's
# lcm_coretypes.h copies zero-length arrays with memcpy(NULL, src, 0)
# (lcm_malloc(0) returns NULL): formally undefined, harmless, and not
# ours to change, so UBSan's nonnull check is off for these files only.
$(LCM_GEN_DIR)/ndo_msg_CPPFLAGS := -w $(if $(filter 1,$(SAN)),-fno-sanitize=nonnull-attribute)
# Generate before compiling anything.  The C of the network layer, the
# tools and the tests may include a generated header (through ndo/msg.h):
# those objects are compiled again when the messages change (a normal
# prerequisite: the headers their .d files name are rewritten by the
# stamp's rule, which make does not know, so it would keep objects built
# against the old layout).  The grid and sim layers and the C++ include
# none (the layers' rule, tests/layers.py).
LCM_GEN_USERS := $(wildcard lib/net/*.c tools/*/*.c tests/unit/*.c tests/bench/*.c)
LCM_GEN_OTHERS := $(filter-out $(LCM_GEN_USERS:%=$(OBJ)/%.o),$(LIB_OBJS)) \
    $(patsubst %,$(OBJ)/%.o,$(wildcard tools/*/*.cpp tests/unit/*.cpp tests/bench/*.cpp))
$(LCM_GEN_USERS:%=$(OBJ)/%.o): $(LCM_GEN_STAMP)
$(LCM_GEN_OTHERS): | $(LCM_GEN_STAMP)

NDO_LIBS += -llcm -lmetis
DEBS_TOOLS += liblcm-dev liblcm-bin libmetis-dev
