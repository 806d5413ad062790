/* ndo/peer.h — one simulating peer: a session (ndo/session.h) and a
 * simulation (ndo/sim.h) kept in time with the other peers (thesis §4.4–
 * 4.5; docs/peers.md).
 *
 * Every peer integrates the nodes the partition gives it (the owner
 * channel names it), holding the others at the values their peers last
 * published: the thesis' one-step boundary lag.  Time is kept in one of
 * two ways, chosen by the owner for the whole session:
 *
 *   NDO_CLOCK_LOCKSTEP  a peer steps t → t+1 once it holds, for every node
 *                      next to its region (its halo), the value of step t
 *                      from that node's peer.  Tiles of later steps wait
 *                      in a stash until the peer gets there, so the result
 *                      does not depend on timing: with no loss, exact
 *                      halos (hold_boundary 0) make it the single-process
 *                      run — bit for bit for the explicit methods, rkf45
 *                      included, and to the distributed solve's tolerance
 *                      for the implicit ones (ndo_peer_halo_rings); the
 *                      thesis' held boundary has an O(h) lag error for the
 *                      multi-stage methods.
 *                      A peer that waits sends its own last two steps
 *                      again (after `resend`, doubling up to 0.2 s), which
 *                      recovers lost tiles; after `step_timeout` it goes
 *                      on with the newest values it has and counts the
 *                      miss (a dead or unreachable neighbour) — with
 *                      restarts (checkpoint_every), only when some missing
 *                      neighbour sent no halo for the session's peer
 *                      timeout (at least step_timeout) — for rkf45 and
 *                      the implicit methods, when some other peer sent no
 *                      phase that shows it alive (docs/peers.md, "rkf45
 *                      and the implicit methods").
 *   NDO_CLOCK_REALTIME  a peer steps on the wall clock, step k at
 *                      start + k·dt/speed; nobody waits.  A peer that sees
 *                      another one further on catches up at once (the
 *                      earliest starter sets the pace).  The explicit
 *                      methods of a fixed reach (hold_boundary 0) exchange
 *                      exact halos as in lock-step, predict those that have
 *                      not come and roll back when one of an earlier step
 *                      turns out different (lib/net/rollback.h): the run
 *                      ends on the lock-step result once every step is
 *                      confirmed (ndo_peer_stats.confirmed).  A peer that
 *                      falls step_timeout behind the wall clock, or whose
 *                      window of unconfirmed steps fills, fails with
 *                      NDO_EPACE.  rkf45, the implicit methods and the held
 *                      boundary integrate with whatever values have come:
 *                      the lag is what the network costs.
 *
 * The run: the owner starts when `peers` peers (itself included) are in
 * the partition, from its grid's step s0, and every peer takes `steps`
 * steps, to s0 + steps.  A joiner learns the physics, dt, the step count,
 * the time keeping and the start condition from the owner's description
 * (scene text, ndo_scene_physics plus "peer-*" lines).  At the end the
 * owner gathers every node's last step (the whole object: -o), then ends
 * the session; a joiner keeps sending its last steps until the owner
 * ends it.
 *
 * Nothing here sleeps, and no decision reads a clock: the caller passes
 * `now` (seconds, monotonic; tests use a fake clock) and waits until
 * ndo_peer_deadline() or until the link's file descriptor is readable
 * (only compute_seconds is measured on CLOCK_MONOTONIC).  One thread.
 */
#ifndef NDO_PEER_H
#define NDO_PEER_H

#include <stdint.h>

#include "ndo/grid.h"
#include "ndo/net.h"
#include "ndo/session.h"
#include "ndo/sim.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum ndo_clock { NDO_CLOCK_LOCKSTEP = 1, NDO_CLOCK_REALTIME = 2 } ndo_clock;

/* How far (in rings of the 7-point stencil, through the ghost map) one
 * step of `m` reaches: a node's new state depends only on the states of
 * nodes at most this many rings away — 1 for forward and symplectic Euler
 * and midpoint, 2 for rk4 (a stage's displacement reads only its own
 * node's velocity, so the reach grows every second stage), 3 for one
 * rkf45 sub-step.  0 for the implicit methods (they reach everywhere).
 * Exact lock-step exchanges a halo this wide every step, its outermost
 * ring held, moving along its velocity for midpoint and rk4 (their first
 * stage's own arithmetic: the stages a neighbour reads are exact);
 * realtime with rollback one ring more, held still.  rkf45 and the implicit
 * methods exchange within each step instead (lib/net/peer_solve.h): rkf45
 * a 4-ring halo and its error at every attempted sub-step, the implicit
 * methods a 1-ring halo and the vectors and sums of a conjugate-gradient
 * solve over the peers. */
int ndo_peer_halo_rings(ndo_method m);

/* "lockstep", "realtime"; parse: −1 if unknown. */
const char *ndo_clock_name(ndo_clock s);
int ndo_clock_parse(const char *s);

typedef struct ndo_peer_opts {
	/* role, name, poi, partition, heartbeat, timeout, ids (tile_fn is
	 * the peer's own) */
	ndo_session_opts session;
	/* The owner's choices for the session (a joiner takes the owner's): */
	ndo_clock clock;        /* 0: lock-step */
	double step_timeout;    /* lock-step: seconds a step waits for the halo,
	                           then goes on with the newest values; realtime:
	                           the most a peer may fall behind the wall
	                           clock (NDO_EPACE) (0: 0.5) */
	double speed;           /* realtime: simulated seconds per wall-clock
	                           second (0: 1) */
	int peers;              /* start when this many peers simulate, the
	                           owner included (≤ 1: at once) */
	int halo_steps;         /* exact halos (lock-step, realtime with
	                           rollback): steps per halo exchange, k
	                           (0: 1); the halo is k times as wide as one
	                           step's stages reach (ndo_peer_halo_rings) and
	                           its overlap is recomputed by both sides */
	int publish_every;      /* exact halos: whole-region tiles (for
	                           observers, render-frame, the owner's gather)
	                           every this many steps, and at the last step
	                           (0: 10; < 0: only at the first and last) */
	int hold_boundary;      /* 1: the others' nodes stand still during a
	                           step, at the values received (the thesis);
	                           0 (default): they move with their
	                           velocities (ndo_sim_set_held_motion: the
	                           lag's error O(h²) instead of O(h)), and a
	                           value of another step is first carried
	                           along its velocity, by one step at most */
	int checkpoint_every;   /* exact lock-step, every method: every
	                           simulating peer keeps its region's state
	                           (rkf45: and its next sub-step size) every
	                           this many steps (a multiple of halo_steps,
	                           rounded up) and sends it to the owner, which
	                           holds every node's: a new partition during
	                           the run (a join, a leave, a dropped peer)
	                           restarts every peer from the newest step the
	                           owner holds whole, and the run stays exact
	                           (backward Euler and the trapezoid: to the
	                           solve's tolerance) (0: the owner's object's
	                           ndo_peer_checkpoint_default(); < 0: none,
	                           the new partition takes over from the newest
	                           values held, not exact) */
	int block;              /* exact backward Euler and trapezoid: this peer
	                           preconditions the distributed solve with its
	                           region's block of the system, factored by
	                           CHOLMOD, instead of the diagonal (Jacobi, the
	                           default): fewer iterations, each a block
	                           solve (docs/peers.md: slower from level 5) */
	/* Each peer's own: */
	int keep_tiles;         /* 1: the caller reads the others' nodes of the
	                           grid between the first and the last step (it
	                           writes frames of it): every tile is taken.
	                           0: a simulating peer in exact lock-step passes
	                           over the others' whole-region tiles between
	                           (it needs only their last step's) */
	double start_timeout;   /* owner: end the session (NDO_PEER_ENDED) when
	                           `peers` have not joined within this; joiner:
	                           end when no object arrived within it (0: 60 s) */
	double resend;          /* first re-send of own tiles while waiting
	                           (0: 0.01 s) */
	double gather_timeout;  /* owner: after the last step, wait at most this
	                           for the others' last tiles (0: 10 s) */
	/* Progress messages ("peer 5 joined", "partition 3: ...", misses);
	 * may be NULL. */
	void (*note)(void *user, const char *msg);
	void *note_user;
} ndo_peer_opts;

/* What the owner runs: its physics settings (ndo_scene_physics()), the
 * step (resolved, seconds) and the number of steps. */
typedef struct ndo_peer_run {
	const char *physics;
	double dt;
	int64_t steps;
} ndo_peer_run;

typedef struct ndo_peer ndo_peer;

/* Create a peer on `net` (taken over).  Owner: `grid` holds the object
 * (position, velocity, rest f64; pin u8) in the state `sim` starts from,
 * at grid->step and grid->time; both are taken over; `run` is required.
 * Joiner: grid, sim and run are NULL; they come with the description.
 * NDO_EINVAL for an inconsistent call, NDO_ENOMEM. */
int ndo_peer_create(const ndo_peer_opts *o, ndo_net *net, ndo_grid *grid, ndo_sim *sim,
                    const ndo_peer_run *run, ndo_peer **out);

/* The owner's checkpoint interval when ndo_peer_opts.checkpoint_every is
 * 0, for an object of `level`: 20 steps up to level 4, twice as many each
 * level above, 160 from level 7.  A checkpoint is the region's whole state
 * (48 bytes a node) and rk4's halo two rings of it, so checkpoints every
 * 20 steps at level 7 sent more than the halo (40 against 25 kB a step, 2
 * peers: 1.42x one process in paired runs, 1.56x with 160); this keeps
 * them near a fifth of the halo's bytes at levels 5-7, and a restart takes
 * at most 160 steps again (docs/peers.md, "Restarts"). */
int ndo_peer_checkpoint_default(int level);

/* Leave (the owner: end the session for everyone, with `message`) and
 * free.  Accepts NULL. */
void ndo_peer_destroy(ndo_peer *p, const char *message);

/* Leave now, as ndo_peer_destroy does, keeping the peer readable (its
 * grid, step and stats): a caller that writes the owner's output first
 * and announces the end after it.  Until the owner's end is heard, the
 * others of an exact lock-step run with checkpoints take its silence
 * after the last step for a death, and its successor gathers the result
 * again. */
void ndo_peer_leave(ndo_peer *p, const char *message);

typedef enum ndo_peer_state {
	NDO_PEER_WAITING = 0, /* nothing to report: call again by the deadline */
	NDO_PEER_STEPPED,     /* one step taken (state at ndo_peer_step()) */
	NDO_PEER_DONE,        /* the run is complete: owner, every node of the
	                         last step gathered (or gather_timeout passed:
	                         see ndo_peer_stats.ungathered); joiner, the
	                         owner ended the session after its last step
	                         (ungathered: the nodes it holds at older
	                         steps), or it holds every node's last step */
	NDO_PEER_ENDED        /* the session ended before the run completed
	                         (owner quit or fell silent, this peer was
	                         dropped, the owner's peers did not come; a
	                         joiner past its last step whose silent owner
	                         nobody succeeds, without every node's last
	                         step): ndo_peer_message() says why */
} ndo_peer_state;

/* Do what is due at `now`: the session's protocol, the others' tiles, at
 * most one step, re-sends.  Returns an ndo_peer_state, or a negative
 * status: NDO_EDIVERGED (the simulation diverged: ndo_errdetail()), NDO_EPACE
 * (realtime: this peer cannot keep the pace: ndo_errdetail()), NDO_EIO
 * (the link failed), NDO_ERANGE/NDO_EINVAL (a joiner cannot use the
 * owner's description: ndo_errdetail()), NDO_ENOMEM. */
int ndo_peer_update(ndo_peer *p, double now);

/* The latest time by which ndo_peer_update() should be called again (it
 * may be called any time before; messages arriving on the link are a
 * reason too). */
double ndo_peer_deadline(const ndo_peer *p);

/* The object as this peer holds it: its own region at ndo_peer_step(),
 * the others' newest values; channels position, velocity, rest, pin,
 * owner (ndo_session_grid).  NULL before the description. */
ndo_grid *ndo_peer_grid(ndo_peer *p);
/* The simulation (NULL before it starts, and for an observer). */
ndo_sim *ndo_peer_sim(ndo_peer *p);
ndo_session *ndo_peer_session(ndo_peer *p);
/* The step this peer's region is at, and the run's first and last step. */
int64_t ndo_peer_step(const ndo_peer *p);
int64_t ndo_peer_first_step(const ndo_peer *p);
int64_t ndo_peer_final_step(const ndo_peer *p);
double ndo_peer_dt(const ndo_peer *p);
ndo_clock ndo_peer_clock(const ndo_peer *p);
/* Why the session ended (NDO_PEER_ENDED, or a joiner's NDO_PEER_DONE). */
const char *ndo_peer_message(const ndo_peer *p);
/* 1 once the run has started here (this peer's clock runs). */
int ndo_peer_started(const ndo_peer *p);
/* 1 if this peer simulates (is in the partition). */
int ndo_peer_simulating(const ndo_peer *p);

typedef struct ndo_peer_stats {
	int64_t steps;          /* steps taken */
	int64_t waited;         /* lock-step: steps that waited for the halo */
	double wait_seconds;    /* time spent waiting for it */
	int64_t ahead;          /* exact lock-step, rk4: steps begun while their
	                           halo was in flight (the units that read none
	                           of it, ndo_sim_step_begin), waiting included */
	double compute_seconds; /* time in ndo_sim_step (CLOCK_MONOTONIC) */
	int64_t timeouts;       /* steps that went on after step_timeout */
	int64_t missed;         /* halo node-steps integrated with an older step's
	                           value (lock-step: after a timeout) */
	double lag_sum;         /* Σ over steps of the halo's mean |age| in steps
	                           (0 when every value is of the step itself;
	                           realtime values can be of a later step) */
	double lag_max;         /* the largest |age| of a halo value used */
	int64_t resends;        /* times this peer sent its tiles again */
	int64_t behind;         /* realtime: steps taken late (the schedule had
	                           passed) or to catch up with a peer further on */
	int64_t stale;          /* tiles not used: of an older step or partition */
	int64_t stashed;        /* tiles kept for a later step or partition */
	int64_t repartitions;   /* partitions this peer simulated under, after
	                           the first */
	int64_t ungathered;     /* nodes not at the last step when the run ended:
	                           the owner's after gather_timeout; a joiner's
	                           when the owner's leave came first (the
	                           others' last tiles lost) */
	int took_over;          /* a joiner that succeeded the owner when it fell
	                           silent (ndo_session_set_succession): the owner
	                           since */
	int exact;              /* lock-step with exchanged halos: the single
	                           process's result (0: the boundary lag) */
	int64_t inexact_at;     /* exact lock-step: −1 when the state this peer
	                           holds is the single process's as far as it
	                           knows; else the first step of it that is not:
	                           a step taken with older values after a step
	                           timeout, or a region taken over from frames (a
	                           new partition without a restart), here or at
	                           a peer whose halo said so, that no restart
	                           undid (docs/peers.md, "Exact, or not") */
	int32_t inexact_peer;   /* ... the peer where it began (0: this one) */
	int unsaid;             /* owner, exact lock-step: peers whose last word
	                           (exact or not) had not come when the run ended
	                           (after gather_timeout) */
	int halo_rings;         /* the halo's width (exact) */
	int64_t exchanges;      /* halo exchanges sent */
	int64_t halo_tiles;     /* ... their tiles */
	uint64_t halo_bytes;    /* ... and bytes (LCM payloads) */
	int64_t attempts;       /* exact rkf45: sub-steps attempted (each one
	                           reduction of the error over the peers) */
	int64_t rejected;       /* ... of them rejected */
	int64_t solves;         /* exact implicit methods: distributed solves */
	int64_t iterations;     /* ... their conjugate-gradient iterations */
	int64_t frames;         /* whole-region publications */
	uint64_t frame_bytes;   /* ... their bytes */
	/* realtime with exact halos (rollback, docs/peers.md "Realtime"): */
	int rollback;           /* 1: this peer rolls back */
	int64_t rollbacks;      /* times it went back to an earlier step */
	int64_t recomputed;     /* steps taken again */
	int64_t rollback_depth; /* the most steps one rollback went back */
	int64_t predicted;      /* halo node-steps first taken with a prediction
	                           (the true value had not come) */
	int window;             /* steps kept for rolling back */
	int confirmed;          /* the last step is confirmed: every input of the
	                           run was its sender's confirmed value, and the
	                           result is the lock-step one */
	int64_t frontier;       /* the newest step up to which all are confirmed */
	double shown_error;     /* the frames this peer sent against the confirmed
	                           state of their steps, over its nodes: the
	                           largest difference of a displacement component
	                           (m; what viewers saw during the run) */
	double shown_disp;      /* ... the largest displacement component of those
	                           frames' confirmed states (m) */
	int64_t shown_frames;   /* ... frames compared, */
	int64_t shown_wrong;    /* ... and how many of them differed */
	/* exact lock-step restarts (checkpoint_every): */
	int64_t checkpoints;    /* checkpoint steps this peer kept */
	uint64_t checkpoint_bytes; /* ... bytes it sent (the owner: re-sends) */
	int64_t checkpoint_asks; /* owner: times it asked for parts of its newest
	                            checkpoint again (one of them lost) */
	int64_t restarts;       /* times it went back to a partition's restart step */
	int64_t restart_steps;  /* ... the steps it took again */
	double start_time;      /* caller's clock at the first step */
	double end_time;        /* ... at the last */
} ndo_peer_stats;
void ndo_peer_stats_get(const ndo_peer *p, ndo_peer_stats *st);

#ifdef __cplusplus
}
#endif
#endif
