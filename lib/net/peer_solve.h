/* peer_solve.h — a lock-step step that takes more than one exchange
 * (private to lib/net; ndo/peer.h, docs/peers.md "rkf45 and the implicit
 * methods"): rkf45's sub-steps, whose error the peers reduce so that all
 * take the single process's sub-steps, and backward Euler's and the
 * trapezoid's system, solved by conjugate gradients over the peers.
 *
 * The peer (peer.c) owns the region's sets — its canonical nodes, the
 * halo (rings 1..W around them, W = ndo__ps_rings) and the strip (its
 * nodes that the neighbours' halos hold) — and calls ndo__ps_advance
 * until the step is done.  Every exchange of a step is one solve_t phase
 * from every simulating peer: its strip's state or a vector, and its
 * partial sums.  Nothing here waits or reads a clock. */
#ifndef NDO_NET_PEER_SOLVE_H
#define NDO_NET_PEER_SOLVE_H

#include <stddef.h>
#include <stdint.h>

#include "ndo/session.h"
#include "ndo/sim.h"

typedef struct ndo__ps ndo__ps;

/* 1 for the methods whose step this splits: rkf45, backward Euler,
 * trapezoid. */
int ndo__ps_method(ndo_method m);
/* The halo's width for such a method: rkf45 a sub-step's reach (3) and
 * one ring held still; the implicit methods the stencil's 1 ring. */
int ndo__ps_rings(ndo_method m);

/* The region's sets (canonical stored indices; `mask`: H × W bytes, the
 * stored nodes of the region).  The arrays stay the caller's and must
 * live until the next call or ndo__ps_destroy. */
typedef struct ndo__ps_region {
	const int32_t *own;   /* the region's canonical nodes */
	size_t nown;
	const int32_t *halo;
	size_t nhalo;
	const int32_t *strip;
	size_t nstrip;
	const uint8_t *mask;
} ndo__ps_region;

/* jacobi: the implicit methods' solve preconditioned with A's diagonal
 * instead of the region's block (ndo_sim_implicit_precondition). */
int ndo__ps_create(ndo_session *s, ndo_sim *sim, int jacobi, ndo__ps **out);
void ndo__ps_destroy(ndo__ps *ps);

/* Before the region changes: a step under way is given up and the
 * simulation put back where it began (its state, time and rkf45 sub-step). */
void ndo__ps_abort(ndo__ps *ps);
/* The new region (after ndo_sim_set_active). */
void ndo__ps_set_region(ndo__ps *ps, const ndo__ps_region *r);

/* Another peer's message (the session's solve_fn). */
void ndo__ps_receive(ndo__ps *ps, const ndo_msg_solve_t *m);

/* Go on with step `step` of size h as far as the messages allow: 1 the
 * step is done (the simulation is at step + 1), 0 waiting for the
 * others, or a negative status (ndo_errdetail()). */
int ndo__ps_advance(ndo__ps *ps, int64_t step, double h);

/* 1 when this peer is the partition's only one: its steps need nobody
 * (the caller takes them with ndo_sim_step, the single process's). */
int ndo__ps_alone(const ndo__ps *ps);

/* 1 when another peer of this partition was last heard of at a step
 * before `step`: it is behind, and will come (a peer that waits for it
 * does not give up: the one behind does, and catches up). */
int ndo__ps_behind(const ndo__ps *ps, int64_t step);

/* Send the last three phases again (another peer may have lost one; SLOTS
 * in peer_solve.c says why three). */
int ndo__ps_resend(ndo__ps *ps);

/* Bytes its stash of later phases holds (tests: peer_test.h). */
size_t ndo__ps_stash_bytes(const ndo__ps *ps);

typedef struct ndo__ps_stats {
	int64_t phases;      /* exchanges sent */
	int64_t messages;    /* their messages */
	uint64_t bytes;      /* ... and bytes */
	int64_t attempts;    /* rkf45: sub-steps attempted */
	int64_t rejected;    /* ... rejected */
	int64_t iterations;  /* implicit: conjugate-gradient iterations */
	int64_t solves;      /* ... and solves */
} ndo__ps_stats;
void ndo__ps_stats_get(const ndo__ps *ps, ndo__ps_stats *st);

#endif
