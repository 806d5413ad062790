/* checkpoint.h — exact lock-step's checkpoints (private to lib/net;
 * ndo/peer.h, docs/peers.md "Joins, leaves, a dead peer"): every C steps
 * each simulating peer sends its region's integrated state (velocity and
 * displacement, as a halo carries it: halo_t with checkpoint = 1) and
 * keeps it; the owner keeps every peer's, so that it holds whole the
 * state of some recent step.  When the partition changes during the run,
 * the owner names the newest step it holds whole (partition_t.restart)
 * and every simulating peer goes back to it: its new region and halo
 * from the checkpoint (what it lacks, the owner sends), so the run goes
 * on as the single process's.
 *
 * A store keeps NDO__CK_SLOTS steps, per node the state and whether it is
 * held.  Values are indexed by stored node index; only canonical nodes
 * are kept. */
#ifndef NDO_NET_CHECKPOINT_H
#define NDO_NET_CHECKPOINT_H

#include <stddef.h>
#include <stdint.h>

#include "ndo/session.h"

#define NDO__CK_SLOTS 3

typedef struct ndo__ck ndo__ck;

/* A store for the grid of a level-`level` object (its stored nodes; of
 * them, only the canonical ones are kept: a seam's duplicates are
 * ignored).  0 or NDO_ENOMEM. */
int ndo__ck_create(int level, ndo__ck **out);
void ndo__ck_destroy(ndo__ck *ck);

/* Keep the state of n canonical nodes at `step` (u, v: 3 per node) and
 * what the method's controller carries to the next step (`substep`:
 * rkf45's next sub-step size, ndo_sim_rkf45_substep; 0 for the others —
 * the same on every peer, since all take the same sub-steps).  A step
 * older than every slot, when none is free, is not kept; the newest whole
 * step is never evicted. */
void ndo__ck_put(ndo__ck *ck, int64_t step, double time, double substep, size_t n,
                 const int32_t *nodes, const double *u, const double *v);
/* ... from a checkpoint message (runs of node indices); owner: per stored
 * node its peer, and only the sender's nodes are kept (NULL: any). */
void ndo__ck_put_msg(ndo__ck *ck, const ndo_msg_halo_t *h, const int32_t *owner);

/* The newest step whose every canonical node is held, −1: none. */
int64_t ndo__ck_whole(const ndo__ck *ck);
/* How many of the n nodes are not held at `step` (n when the step is not
 * kept). */
size_t ndo__ck_missing(const ndo__ck *ck, int64_t step, size_t n, const int32_t *nodes);
/* The state of n nodes at `step` (u, v: 3 per node), its time and
 * sub-step size: 0, or −1 when some node is not held. */
int ndo__ck_get(const ndo__ck *ck, int64_t step, size_t n, const int32_t *nodes, double *u,
                double *v, double *time, double *substep);
/* Forget every step after `step` (they are recomputed). */
void ndo__ck_drop_after(ndo__ck *ck, int64_t step);

/* Send the held nodes among n (increasing canonical indices) at `step` as
 * checkpoint messages of the session's epoch; *bytes grows by what went
 * out.  0 or a negative status. */
int ndo__ck_send(ndo__ck *ck, ndo_session *s, int64_t step, size_t n, const int32_t *nodes,
                 uint64_t *bytes);

#endif
