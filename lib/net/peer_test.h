/* peer_test.h — what test_peer reaches inside a peer (peer.c) to make a
 * case that a network rarely makes on its own.  Not for other callers. */
#ifndef NDO_PEER_TEST_H
#define NDO_PEER_TEST_H

#include "ndo/peer.h"

/* The peer hears no checkpoint message before `until` (the clock of
 * ndo_peer_update): after a new partition it waits that long for the
 * checkpoint nodes of the restart step, sending no halo of the partition
 * (restart_wait). */
void ndo__peer_deaf_to_checkpoints(ndo_peer *p, double until);

/* The peer sends an ask for checkpoint `step` now, whatever it holds (as
 * the owner does for a part it lacks; from a joiner, anyone could). */
int ndo__peer_ask_checkpoint(ndo_peer *p, int64_t step);

/* Bytes the peer's stashes hold (tiles, halos and a split step's phases
 * kept for later, stash_size's count, arrays and bookkeeping). */
size_t ndo__peer_stash_bytes(const ndo_peer *p);

/* The session forgets every member, as a joiner that had not yet had a
 * peer list when the owner died (session.c): the owner's successor is
 * still the partition's (a successor chosen among the members was every
 * such joiner itself). */
void ndo__session_forget_members(ndo_session *s);

/* Non-zero: peers created from now on whose implicit solve is
 * preconditioned with the diagonal take the general recurrences
 * (peer_solve.c's cg_update, u and q kept as vectors, the sums in the
 * entries' order) instead of the fast path (cg_update_jacobi): the
 * reference that test_peer compares it with. */
extern int ndo__ps_reference;

#endif
