/* bench.h — one row of net-bench: peers of the thesis' scene over real LCM,
 * in this process, and what their traffic costs (docs/net-bench.md). */
#ifndef NET_BENCH_H
#define NET_BENCH_H

#include "ndo/ndo.h"
#include "ndo/codec.h"

#include "ndo/auth.h"

typedef struct nb_opts {
	const char *url;   /* LCM URL; NULL: the default, in a private namespace */
	double time;       /* simulated seconds of the scene (default 5) */
	int peers;         /* simulating peers (default 2) */
	double timeout;    /* wall seconds a row may take */
	int quiet;
	const ndo_key *key; /* --key: every peer's and the listener's messages sealed */
	int send_level;    /* whole-region state at this level (< 0 or ≥ the row's: the row's) */
} nb_opts;

/* Traffic on the bus by kind of message, as a listener sees it: bytes on
 * the wire (message, LCM, UDP and IPv4 headers), and for state tiles the
 * bytes of their payload alone (encoded: data[]; raw: the doubles). */
enum {
	NB_ENCODED,   /* encoded state tiles */
	NB_RAW_STATE, /* raw state tiles (every one with raw; snapshots for a joiner,
	                 fallbacks otherwise) */
	NB_REST,      /* rest shape and pins (a joiner's) */
	NB_FINAL,     /* the last step's state tiles: exact, whatever the encoding */
	NB_HEARTBEAT,
	NB_CONTROL,   /* descriptions, partitions, hellos, peers, POIs, leaves, forces */
	NB_HALO,      /* halos between simulating peers (exact lock-step): not what a
	                 viewer receives, so not in bits per node per update */
	NB_KINDS
};
typedef struct nb_traffic {
	uint64_t messages[NB_KINDS];
	double bytes[NB_KINDS], payload[NB_KINDS];
} nb_traffic;

typedef struct nb_row {
	int level, peers;
	char encoding[32];
	double loss;
	int64_t steps;
	size_t nodes;              /* stored nodes, W × H (the thesis' count) */
	size_t vertices;           /* distinct vertices of the level, 2·4^level + 2 */
	int send_level;            /* the level the state travelled at */
	size_t exact_nodes;        /* sent at full precision every step */
	/* bits per node per update (over nodes × steps): */
	double bits_per_node_update; /* every message on the wire, steady state (after
	                                the last join: the observer's first frame;
	                                before the last step) */
	double payload_bits;         /* state tiles' payload alone, steady state */
	double total_bits;           /* every message of the whole run, joins included */
	nb_traffic whole, steady;    /* the whole run; the steady state */
	int64_t steady_steps;
	double mbit_s, steps_per_s;  /* Mbit/s: steady state, at the rate the run went */
	double max_error_rel, rms_error_rel; /* the encoding's, at the nodes it sent */
	double bits_per_vertex;    /* bits_per_node_update over the distinct vertices */
	double level_max_rel, level_rms_rel; /* at the simulated level: what receivers
	                                        hold, refined, against the exact state */
	double disp_max_rel, disp_rms_rel;   /* the same, the displacement refined onto
	                                        the rest shape (ndo/session.h) */
	double encode_ms, decode_ms; /* per step, the whole object */
	double latency_p50_us, latency_p99_us;
	long kernel_drops;
	double divergence;         /* the owner's final state vs the row it is compared with */
	uint64_t nobase, corrupt, messages, resends;
	int64_t frames, incomplete; /* the observer's */
	double wall;
	double *final_x;           /* the owner's final positions (malloc'd) */
	double *rest;              /* the rest positions (malloc'd) */
} nb_row;

/* Enter a private network namespace with multicast on the loopback (needs
 * root or CAP_SYS_ADMIN).  0, or −1 with a message in *why. */
int nb_private_netns(char *why, size_t size);

/* Run one row: level, encoding, drop probability on every peer's
 * receiving side (0: none).  0, or a negative status (ndo_errdetail()). */
int nb_run(const nb_opts *o, int level, const ndo_codec_params *enc, double loss,
           nb_row *row);
void nb_row_free(nb_row *r);

/* The largest position difference of a from b over b's largest
 * displacement from `rest` (n nodes). */
double nb_divergence(const double *a, const double *b, const double *rest, size_t n);

#endif
