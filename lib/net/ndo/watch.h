/* ndo/watch.h — a passive observer of a peers' session: the whole object,
 * step by step, assembled from the tiles the simulating peers publish
 * (docs/peers.md, "Record and replay").
 *
 * A watch sends nothing.  It attaches to the first object described on
 * its net (or the one asked for), keeps the owner's partitions by epoch,
 * and builds the frame of a step s from the tiles of step s: each node
 * from the tile of the peer that owns it in the partition that tile was
 * simulated under.  A frame is complete when every node has its value of
 * step s; frames are handed out in step order, a complete one once no
 * older frame is still open.  An open frame is given up (a tile was lost)
 * when `window` later frames are open too, or at the end; it is counted,
 * and not shown — unless `hold_lost` is set: then it is handed out with
 * every node it lacks at that node's value in the last frame handed out
 * (ndo_watch_stale() says what share that was; a frame lost before any
 * was handed out is still skipped).  With no loss the frames depend only on which tiles were
 * published, not on their timing or order: a recorded run
 * (ndo_link_open_log) gives the frames of the live one.
 *
 * Frames are grids with position, owner (the partition in force at that
 * step), and rest and pin when the owner has sent them (it does when a
 * peer joins), step and time.  They are at the level the state travels
 * at: the owner's send level (ndo/codec.h "send-level"; the object's
 * level when it sends none below it), every 2^k-th node of the object's;
 * a caller that needs more refines them (ndo/levels.h, ndo/subdivide.h).
 * One thread.
 */
#ifndef NDO_WATCH_H
#define NDO_WATCH_H

#include <stdint.h>

#include "ndo/grid.h"
#include "ndo/net.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ndo_watch_opts {
	int64_t object_id; /* 0: the first object described */
	int64_t every;     /* frames of the steps that are multiples of this
	                      (≤ 1: every step) */
	int window;        /* steps assembled at once (0: 16) */
	double timeout;    /* end when nothing is heard for this many seconds
	                      (0: never) */
	int hold_lost;     /* 1: hand out incomplete frames, the lost nodes held
	                      at their last values */
	int passive;       /* 1: publish nothing (a recorded log; a silent
	                      observer); 0: ask the senders of encoded tiles
	                      for the keyframes of the frames lost
	                      (ndo_net_ask_keys), under a random sender id of
	                      the watch's own (ndo_net_new_id) */
} ndo_watch_opts;

typedef struct ndo_watch ndo_watch;

/* Watch `net` (taken over; ndo_net_keep_all_tiles is turned on). */
int ndo_watch_create(ndo_net *net, const ndo_watch_opts *o, ndo_watch **out);
void ndo_watch_destroy(ndo_watch *w); /* accepts NULL */

/* Drain the net and assemble.  `now`: seconds, monotonic (for the
 * timeout).  0, or NDO_EIO/NDO_EFORMAT/... from the link (a log that
 * turns out corrupt), NDO_ENOMEM. */
int ndo_watch_update(ndo_watch *w, double now);

/* The next complete frame, in step order: 1 and *frame (the caller owns
 * it), or 0 when none is ready. */
int ndo_watch_next(ndo_watch *w, ndo_grid **frame);

/* The share of the canonical nodes of the frame ndo_watch_next() last
 * handed out that hold an earlier frame's value (0: complete; hold_lost). */
double ndo_watch_stale(const ndo_watch *w);

/* 1 when no frame will come any more: the owner ended the session, the
 * link ended (the log was read), or the timeout passed; ndo_watch_why()
 * says which. */
int ndo_watch_ended(const ndo_watch *w);
const char *ndo_watch_why(const ndo_watch *w);

typedef struct ndo_watch_stats {
	int64_t frames;      /* handed out */
	int64_t incomplete;  /* given up: a tile never came (with hold_lost: and
	                        not handed out, no earlier frame to hold from) */
	int64_t held;        /* hold_lost: handed out with lost nodes held */
	double stale_sum;    /* ... the sum of their stale shares */
	double stale_max;    /* ... and the largest */
	int64_t tiles;       /* state tiles used */
	int64_t unused;      /* state tiles of steps not watched, done, or too old */
	int64_t unknown;     /* tiles whose partition never came (kept until it
	                        does, up to 4096) */
	int64_t object_id;   /* the object watched (0: none yet) */
	int level;           /* its level (−1: none yet) */
	int send_level;      /* the level its state travels at, the frames' */
} ndo_watch_stats;
void ndo_watch_stats_get(const ndo_watch *w, ndo_watch_stats *st);

#ifdef __cplusplus
}
#endif
#endif
