/* ndo/session.h — one peer of a shared object: roles, joins, leaves,
 * heartbeats, partitioning, tiles in and out (thesis §4.4–4.5, figure
 * 4.14; docs/protocol.md "A session").  No physics: the caller integrates
 * the nodes it owns and calls this once per step.
 *
 * The session owns the object's grid (ndo_session_grid()): channels
 * position, velocity, rest (3 × f64), pin (u8) and owner (i32, the sender
 * id of the peer that integrates each node).  A step of a peer:
 *
 *     ndo_session_update(s, ndo_now());        // drain, protocol, timers,
 *                                              // others' tiles → grid
 *     while (ndo_session_event(s, &ev)) ...    // READY, PARTITION, LEFT, ENDED
 *     if (ndo_session_ready(s)) {
 *         integrate nodes with owner == ndo_session_self(s), using the
 *         grid's values of the other nodes (last step's boundary);
 *         ndo_session_publish(s, step, time);  // own region as tiles
 *     }
 *
 * Time is whatever monotonic clock the caller passes (tests pass a fake
 * one).  One thread per session.
 */
#ifndef NDO_SESSION_H
#define NDO_SESSION_H

#include <stdint.h>

#include "ndo/codec.h"
#include "ndo/grid.h"
#include "ndo/msg.h"
#include "ndo/net.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ndo_session ndo_session;

typedef enum ndo_role { NDO_ROLE_OWNER = 1, NDO_ROLE_JOINER = 2 } ndo_role;

/* leave_t.reason */
enum { NDO_LEAVE_QUIT = 1, NDO_LEAVE_OWNER_QUIT = 2, NDO_LEAVE_TIMEOUT = 3,
       NDO_LEAVE_ERROR = 4 };

typedef struct ndo_session_opts {
	ndo_role role;
	const char *name;          /* shown to others; NULL: "peer" */
	int32_t poi;               /* face asked for, −1: observe (owner: "anywhere") */
	ndo_part_method partition; /* owner: the method (0: quadtree) */
	double heartbeat;          /* seconds between heartbeats (0: 0.2) */
	double timeout;            /* silence after which a peer is gone (0: 2.0) */
	double outside_timeout;    /* owner: the same for a member outside the
	                              partition in force — an observer, or a joiner
	                              that takes in the object and builds its
	                              simulation before it asks for a share
	                              (0 or less than timeout: timeout) */
	double retry;              /* joiner: re-ask for the description (0: 1.0) */
	int64_t object_id;         /* owner: 0 = random; joiner: 0 = the first owner heard */
	int32_t self_id;           /* 0 = random */
	const char *scene;         /* owner: text for the description (≤ 8192 B) */
	uint64_t seed;             /* for random ids (0: from time and pid) */
	/* Optional: position/velocity tiles of other peers go to tile_fn, every
	 * one in arrival order (ndo_net_keep_all_tiles), instead of being
	 * written into the grid by the session — for a caller that keeps time
	 * by the tiles' steps (ndo/peer.h).  `flags`: NDO_TILE_FN_FILL, a tile
	 * of the owner's snapshot before READY, whose values stand for every
	 * node in its range (not only the owner's); NDO_TILE_FN_DECODED, a tile
	 * that travelled encoded (its values may be lossy).  The grid exists
	 * when it is called; the session makes stored duplicates agree after
	 * each update. */
	void (*tile_fn)(void *user, const ndo_msg_tile_t *t, int flags);
	/* Optional: other peers' halos (halo_t, exact lock-step: ndo/peer.h),
	 * every one in arrival order, once the object is described. */
	void (*halo_fn)(void *user, const ndo_msg_halo_t *h);
	/* Optional: other peers' parts of a split step (solve_t: rkf45's
	 * sub-steps, the implicit methods' distributed solve; ndo/peer.h),
	 * every one in arrival order, once the object is described. */
	void (*solve_fn)(void *user, const ndo_msg_solve_t *m);
	void *tile_user; /* for tile_fn, halo_fn and solve_fn */
	/* Owner: the encoding of position/velocity tiles (ndo/codec.h; NULL:
	 * raw).  A box with ext[0] == 0 is the grid's rest shape's (its
	 * positions' without one).  The description carries it; a joiner and
	 * an observer take it from there. */
	const ndo_codec_params *codec;
	/* Owner: whole-region state travels this many levels below the
	 * object's (0: at its level; docs/protocol.md "Send level"): the
	 * description's send-level line, tiles with NDO_TILE_COARSE.  Raw
	 * snapshots for joiners, the exact step (ndo_session_set_exact_step)
	 * and tiles another simulating peer integrates with (no exact halos:
	 * ndo_session_set_exact_halos) stay at the object's level. */
	int coarse_levels;
} ndo_session_opts;

enum { NDO_TILE_FN_FILL = 1, NDO_TILE_FN_DECODED = 2 }; /* tile_fn's flags */

typedef enum ndo_event_type {
	NDO_EV_READY = 1,   /* the grid holds the whole object: simulate/render */
	NDO_EV_PARTITION,   /* a new partition: owner channel changed */
	NDO_EV_JOINED,      /* peer `peer` joined */
	NDO_EV_LEFT,        /* peer `peer` left (reason: NDO_LEAVE_*) */
	NDO_EV_FORCE,       /* forces from a peer: force.faces/forces */
	NDO_EV_ENDED,       /* the session is over (owner quit, timed out, ...) */
	NDO_EV_OWNER        /* the owner fell silent: peer `peer` owns the session
	                       now (ndo_session_set_succession; this one when
	                       `peer` is ndo_session_self) */
} ndo_event_type;

typedef struct ndo_event {
	ndo_event_type type;
	int32_t peer;
	int reason;
	int32_t epoch;
	char message[256];
	/* NDO_EV_FORCE: valid until the next ndo_session_event() call */
	int nforces;
	const int32_t *faces;
	const double (*forces)[3];
	int64_t step;
} ndo_event;

/* Create a session on `net` (taken over).  Owner: `grid` (taken over) is
 * the object, with at least a position channel; the others are added.
 * Joiner: grid must be NULL; it arrives with the description.  The owner
 * starts with the whole grid as its region. */
int ndo_session_create(const ndo_session_opts *o, ndo_net *net, ndo_grid *grid,
                       ndo_session **out);

/* Announce leaving (owner: the session ends for everyone) and free.
 * message may be NULL.  Accepts NULL. */
void ndo_session_destroy(ndo_session *s, const char *message);

/* Announce leaving now, as ndo_session_destroy does, and keep the session
 * (its grid and state stay readable; it takes part in nothing more, and
 * destroy announces nothing again).  Accepts NULL. */
void ndo_session_leave(ndo_session *s, const char *message);

/* One step of protocol: drain the network, handle hellos, POIs, leaves,
 * partitions, descriptions; apply the newest tiles of other peers to the
 * nodes they own; send heartbeats (and the owner's periodic partition,
 * peer list and description); time out silent peers.  0, or a negative
 * status on a failed link. */
int ndo_session_update(ndo_session *s, double now);

/* The next event: 1 and *ev, or 0. */
int ndo_session_event(ndo_session *s, ndo_event *ev);

/* Publish this peer's region (its quad-tree leaves, split to the depth
 * that fits a datagram) with position and velocity at `step`, `time`.
 * Returns the number of tiles sent, or a negative status. */
int ndo_session_publish(ndo_session *s, int64_t step, double time);

/* The same from another grid of the object's level (f64 position and
 * velocity): to send the state of an earlier step again. */
int ndo_session_publish_from(ndo_session *s, const ndo_grid *src, int64_t step, double time);

/* Send a halo the caller filled (runs, values, step, time): the session
 * sets the epoch in force.  0 or a negative status. */
int ndo_session_send_halo(ndo_session *s, ndo_msg_halo_t *h);

/* Send the state of nodes[0..n) as halo messages like *h (its step, time
 * and flags; the session fills in the runs, the values and the epoch):
 * runs of consecutive node indices, as many per datagram as fit.  Node
 * nodes[k]'s 6 values (velocity, displacement) are at vals + 6·idx[k]
 * (idx NULL: vals + 6·nodes[k]); a node with have[nodes[k]] == 0 is left
 * out (have may be NULL).  Scratch: rs and rl of n ints, buf of 6 n
 * doubles.  Returns the messages sent (≥ 0) or a negative status. */
int ndo_session_send_nodes(ndo_session *s, ndo_msg_halo_t *h, size_t n, const int32_t *nodes,
                           const double *vals, const int32_t *idx, const uint8_t *have,
                           int32_t *rs, int32_t *rl, double *buf);

/* The same for a solve_t (ndo_msg.h): the session sets the epoch. */
int ndo_session_send_solve(ndo_session *s, ndo_msg_solve_t *m);

/* Tiles of `step` carry every node this peer simulates at full precision
 * (the run's last step: what the owner gathers is exact); −1: none. */
void ndo_session_set_exact_step(ndo_session *s, int64_t step);

/* The silence tolerated, at least, before a joiner's session ends ("the
 * owner timed out") or the owner drops a member ("no heartbeat"); 0: the
 * timeout alone.  Peers waiting for the run to start set their start
 * timeout here, so that a peer stalled for longer than the timeout before
 * the start (an owner, or a joiner still taking in the object on a loaded
 * machine) does not end the session or lose its place. */
void ndo_session_set_grace(ndo_session *s, double seconds);
/* Succession (docs/peers.md "The owner's death"; ndo/peer.h turns it on
 * while a run is under way): when the owner falls silent for the timeout, the first
 * simulating peer of the partition in force other than it (skipping owners
 * lost before and peers heard to leave) owns the session: a joiner or
 * observer follows it (NDO_EV_OWNER), the successor itself becomes the
 * owner — partitions without the silent owner, restarting from the step
 * ndo_session_set_restart names — and an owner that hears a newer
 * partition of its object from a peer that simulates in its own gives
 * way (NDO_EV_ENDED).  Without it (the default) the owner's silence ends
 * the session. */
void ndo_session_set_succession(ndo_session *s, int on);
/* Owner: the members silent for longer than the timeout (outside the
 * partition: outside_timeout), grace or not. */
int ndo_session_silent(const ndo_session *s);

/* The simulating peers exchange exact halos (ndo/peer.h): whole-region
 * tiles are frames only, and go at the send level even with several
 * simulating peers (without: only while this peer simulates alone). */
void ndo_session_set_exact_halos(ndo_session *s, int on);
/* The send level (the object's level when none below it; −1 before the
 * description). */
int ndo_session_send_level(const ndo_session *s);
/* The send level's cost and error: `frames` whole-region publications at
 * the send level; the error at the object's level of what receivers
 * hold — this peer's coarse nodes as they reconstruct them (the others'
 * as received), refined by the butterfly, against this peer's exact
 * positions — over its own nodes of every such frame, relative to the
 * rest shape's box diagonal (largest; sum of squares and count for the
 * RMS); `_disp` the same for a receiver that refines the displacement
 * (position − rest) and adds it to the rest shape at the object's level
 * (which observers do not do), measured only after
 * ndo_session_measure_displacement(s, 1) (0 otherwise); `enc` the coarse
 * tiles' encoder statistics (zero when raw).  Measuring costs a
 * refinement and a pass over the object's nodes per coarse frame (level 7
 * from 5: ~0.2 ms here, ~0.35 ms with the displacement). */
typedef struct ndo_session_level_stats {
	int level, send_level;
	int64_t frames;
	double max_error, sum_sq_error;
	double max_error_disp, sum_sq_error_disp;
	uint64_t error_nodes;
	ndo_codec_stats enc;
} ndo_session_level_stats;
void ndo_session_level_stats_get(const ndo_session *s, ndo_session_level_stats *st);
void ndo_session_measure_displacement(ndo_session *s, int on);
/* With a send level below the object's: the send level's state — each
 * coarse node as it last travelled when that is newer than the grid's
 * value (nstep[node], the step of each canonical node's value, −1 none),
 * else as the grid holds it — refined by the butterfly, position and
 * velocity, into every node whose value is older than the oldest coarse
 * node taken, whose nstep becomes that step.  What a peer taking over a
 * region starts from when the others' whole regions travelled coarse (its
 * own and its halo's nodes are newer and stay).  Returns the nodes taken
 * (0 without a send level, or when no coarse node is newer). */
int64_t ndo_session_refine_others(ndo_session *s, int64_t *nstep);
/* The object at the send level (*out, the caller's): every channel of this
 * peer's grid sampled, the others' positions and velocities replaced by
 * their newest coarse tiles (frames of a run that sends a level).  0,
 * NDO_EINVAL (no object yet), NDO_ENOMEM. */
int ndo_session_frame(ndo_session *s, ndo_grid **out);

/* The tile encoding in force (raw until a joiner has the description),
 * and its statistics: `enc` this peer's encoder (its tiles and keyframes,
 * encoded and keyframes, and keyframe requests, keys_asked and
 * keys_forced, with those of the send level's encoder; the rest the
 * object's encoder's alone: ndo_session_level_stats_get has the send
 * level's), `dec` the decoder of the others' tiles (either may be NULL). */
const ndo_codec_params *ndo_session_codec(const ndo_session *s);
void ndo_session_codec_stats(const ndo_session *s, ndo_codec_stats *enc, ndo_codec_stats *dec);
/* Nodes (stored) this peer sends at full precision in every step: its
 * nodes next to another simulating peer's region. */
size_t ndo_session_exact_nodes(const ndo_session *s);

/* Ask for a share of the work at face `face` (−1: withdraw, observe). */
int ndo_session_set_poi(ndo_session *s, int32_t face);

/* Send forces on faces to every peer (user interaction). */
int ndo_session_send_forces(ndo_session *s, int64_t step, int n, const int32_t *faces,
                            const double (*forces)[3]);

ndo_grid *ndo_session_grid(ndo_session *s);      /* NULL before the description */
int ndo_session_ready(const ndo_session *s);      /* grid whole and partition known */
int ndo_session_ended(const ndo_session *s);
int32_t ndo_session_self(const ndo_session *s);
int64_t ndo_session_object(const ndo_session *s);
int32_t ndo_session_owner_id(const ndo_session *s);
/* Who would own the session if the owner fell silent now (the first
 * simulating peer of the partition in force after it; with succession on,
 * ndo_session_set_succession), 0: none. */
int32_t ndo_session_successor(ndo_session *s);
const char *ndo_session_scene(const ndo_session *s); /* the description's text */
/* The current partition: epoch, peers (ids) and the cell slots (2N × N,
 * ndo/partition.h); NULL before one is known. */
int32_t ndo_session_epoch(const ndo_session *s);
/* The restart step of the partition in force (partition_t.restart): the
 * step exact lock-step peers go back to under it, −1: none.  The owner
 * sets what its next partitions carry (−1: none; ndo/peer.h keeps it at
 * the newest checkpoint step it holds whole). */
int64_t ndo_session_restart(const ndo_session *s);
void ndo_session_set_restart(ndo_session *s, int64_t step);
const int32_t *ndo_session_cells(const ndo_session *s, int *npeers, const int32_t **peers);
/* Nodes this peer integrates (owner == self). */
size_t ndo_session_owned_nodes(const ndo_session *s);
ndo_net *ndo_session_net(ndo_session *s);

#ifdef __cplusplus
}
#endif
#endif
