# lib/net/build.mk — what the network layer links besides LCM
# (lib/lcmtypes/build.mk): libsodium, for the keyed sessions' message
# authentication (lib/net/auth.c, docs/protocol.md "Keyed sessions").
NDO_LIBS += -lsodium
DEBS_TOOLS += libsodium-dev
