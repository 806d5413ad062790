/* rollback.h — a realtime peer that rolls back (private to lib/net;
 * ndo/peer.h, docs/peers.md "Realtime"), as peer-to-peer game netcode
 * does: the peer steps on the wall clock with its neighbours' halos where
 * they have come and a prediction where they have not; when a halo of an
 * earlier step arrives that differs (bitwise) from what the step used, it
 * restores that step's state and recomputes up to the present with what it
 * now holds.  A step's state is *confirmed* (final) once the state before
 * it was and every halo value it used was its sender's confirmed one; the
 * halos a peer sends say whether the state they come from is confirmed
 * (halo_t.confirmed), so confirmation travels from peer to peer one step
 * at a time, and a confirmed state is the lock-step (and single-process)
 * state bit for bit: the same arithmetic on the same values.
 *
 * The peer (peer.c) owns the region's sets — its stored nodes, the halo
 * (rings 1..W around them, canonical), the strip (its canonical nodes the
 * neighbours' halos hold) and the integrated set — as in exact lock-step
 * with K steps per exchange.  This keeps, per step of a window, the
 * region's state (velocity and displacement: the integrated state itself)
 * and, at the exchange steps, the halo values the step used; it sends the
 * strip of every exchange step it computes.  Nothing here waits; `now` (the caller's clock) only times
 * the re-sends. */
#ifndef NDO_NET_ROLLBACK_H
#define NDO_NET_ROLLBACK_H

#include <stddef.h>
#include <stdint.h>

#include "ndo/session.h"
#include "ndo/sim.h"

typedef struct ndo__rb ndo__rb;

/* The most steps a window keeps (fewer when they would take more than
 * NDO__RB_MEMORY bytes, never fewer than 8). */
#define NDO__RB_WINDOW 256
#define NDO__RB_MEMORY ((size_t)256 << 20)

typedef struct ndo__rb_region {
	const int32_t *own;   /* stored nodes of the region (duplicates too) */
	size_t nown;
	const int32_t *halo;  /* canonical nodes of rings 1..W */
	size_t nhalo;
	const int32_t *strip; /* canonical nodes of the region within W rings of
	                         another peer's */
	size_t nstrip;
	const uint8_t *act;   /* per stored node: integrated (region and rings
	                         1..W−1); the halo's outermost ring is held */
	const int32_t *owner; /* per stored node: the peer that owns it */
	const int32_t *canon; /* per stored node: its canonical node */
	int K;                /* steps per halo exchange (≥ 1): halos travel and
	                         are taken at the steps first + j·K, and the
	                         halo is wide enough for K steps */
	int64_t first;        /* the run's first step */
} ndo__rb_region;

/* resend: the first re-send's delay (doubling up to 0.2 s); the arrays of
 * the region stay the caller's until the next ndo__rb_set_region. */
int ndo__rb_create(ndo_session *s, ndo_sim *sim, size_t count, double resend, ndo__rb **out);
void ndo__rb_destroy(ndo__rb *rb);

/* The region (after ndo_sim_set_active); follow with ndo__rb_restart. */
int ndo__rb_set_region(ndo__rb *rb, const ndo__rb_region *r);

/* Start the window at `step` from the simulation's state (which is at
 * that step) and send its strip.  exact 1: that state is the run's own
 * (the first step: confirmed); 0: it is not (a new partition during the
 * run, a joiner that came late: the region was taken over from frames),
 * and from now on no step is confirmed: rollbacks go on, but nothing
 * waits for confirmation and the window slides freely. */
int ndo__rb_restart(ndo__rb *rb, int64_t step, int exact);

/* Another peer's halo (of the partition in force).  Returns the halo
 * nodes of its sender it holds (0: none, or a step outside the window:
 * dropped). */
int ndo__rb_receive(ndo__rb *rb, const ndo_msg_halo_t *h, double now);

/* What arrived since the last call: roll back and recompute to the
 * present if an input of an earlier step changed, confirm the steps whose
 * inputs are all confirmed (sending their strips again, now confirmed).
 * Returns the steps recomputed (≥ 0) or a negative status
 * (NDO_EDIVERGED). */
int ndo__rb_catch_up(ndo__rb *rb);

/* One step of size h from the newest state (the simulation's): the halo
 * as received, predicted where it has not come; the new state kept and
 * sent.  0, NDO_EPACE when the window is full of unconfirmed steps
 * (ndo_errdetail()), or the step's status (NDO_EDIVERGED). */
int ndo__rb_step(ndo__rb *rb, double h);

/* The newest step (the simulation's), the oldest unconfirmed one's
 * predecessor (every step up to it is confirmed), and whether `step` is
 * confirmed. */
int64_t ndo__rb_newest(const ndo__rb *rb);
int64_t ndo__rb_frontier(const ndo__rb *rb);
int ndo__rb_confirmed(const ndo__rb *rb, int64_t step);
/* 1 when every halo value of the window's first step is confirmed (the
 * run may start). */
int ndo__rb_ready(const ndo__rb *rb);

/* A frame of the newest state went out: when it is confirmed, the
 * difference is measured (ndo__rb_stats.shown_error). */
int ndo__rb_published(ndo__rb *rb);

/* Send again, at `now`, the confirmed strips a neighbour that has not
 * confirmed its steps for a while may lack; force: now, whatever the
 * timers say.  0 or a negative status. */
int ndo__rb_resend(ndo__rb *rb, double now, int force);
/* When ndo__rb_resend has something to do (+∞: nothing). */
double ndo__rb_next_resend(const ndo__rb *rb);

typedef struct ndo__rb_stats {
	int64_t rollbacks;    /* times the state was restored to an earlier step */
	int64_t recomputed;   /* steps taken again */
	int64_t depth_max;    /* the most steps one rollback went back */
	int64_t predicted;    /* halo node-steps first taken with a prediction */
	int64_t dropped;      /* halo messages beyond the window (or before it) */
	int64_t resends;      /* strips sent again */
	int64_t strips;       /* strips sent (every one: new, recomputed, again) */
	int64_t messages;     /* ... their halo messages */
	uint64_t bytes;       /* ... and bytes (LCM payloads) */
	int window;           /* steps the window holds */
	int exact;            /* confirmation in force (ndo__rb_restart) */
	/* The frames sent (ndo__rb_published) against the confirmed state of
	 * their step, over this peer's nodes: the largest difference of a
	 * displacement component (m), the largest displacement component of
	 * those confirmed frames, and how many frames were compared (those
	 * sent confirmed count, with no difference) and how many differed. */
	double shown_error, shown_disp;
	int64_t shown_frames, shown_wrong;
} ndo__rb_stats;
void ndo__rb_stats_get(const ndo__rb *rb, ndo__rb_stats *st);

#endif
