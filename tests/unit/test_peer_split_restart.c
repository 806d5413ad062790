/* test_peer_split_restart — test_peer.c's restarts of the methods whose
 * steps take several exchanges (rkf45, backward Euler, the trapezoid): a
 * killed peer, a leave and a join, with and without loss, and without
 * checkpoints, which must differ.  A program of its own so that each of
 * the four takes a quarter of the time or less (test_peer.c says why). */
#define PEER_PROGRAM 1
#include "test_peer.c"
