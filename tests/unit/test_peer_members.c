/* test_peer_members — test_peer.c's cases of rk4's restarts after a
 * member is killed, leaves or joins, and of members' (and strangers')
 * stray, wild, forged and far messages.  A program of its own so that
 * each of the four takes a quarter of the time or less (test_peer.c says
 * why). */
#define PEER_PROGRAM 3
#include "test_peer.c"
