/* test_peer_lost — test_peer.c's cases of peers and the owner lost: at
 * the start, during a restart and at the end; lost checkpoints and last
 * words.  A program of its own so that each of the four takes a quarter
 * of the time or less (test_peer.c says why). */
#define PEER_PROGRAM 2
#include "test_peer.c"
