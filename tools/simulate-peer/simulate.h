/* simulate.h — what simulate-peer's files share: the run's settings, its
 * setup, plan and log (run.c), used by the single process (main.c) and by
 * the peers of a shared run (peers.c). */
#ifndef SIMULATE_PEER_H
#define SIMULATE_PEER_H

#include "ndo/ndo.h"
#include "ndo/link.h"
#include "ndo/peer.h"

enum { EXIT_DIVERGED = 3, EXIT_ENDED = 4, EXIT_PACE = 5, EXIT_INTERRUPTED = 130 };

/* The peers' command line (docs/peers.md). */
typedef struct peer_cli {
	int role;              /* 0: one process; NDO_ROLE_OWNER, NDO_ROLE_JOINER */
	int32_t poi;           /* --poi, −1 none */
	const char *lcm;       /* --lcm URL, NULL: LCM_DEFAULT_URL, LCM's default */
	const char *prefix;    /* --channel */
	const char *name;      /* --name */
	int partition;         /* --partition */
	ndo_clock clock;       /* --clock */
	double speed, step_timeout, peer_timeout, start_timeout, gather_timeout;
	int peers, hold_boundary, boundary_inexact; /* --boundary extrapolate or hold */
	int halo_steps, publish_every, publish_every_set, checkpoint_every;
	int block;             /* --precondition block */
	double publish_seconds; /* --publish-every Ts: every T s of simulated time */
	double publish_rate;    /* --publish-rate R (0: not given) */
	int send_level; /* −1: the simulated level */
	ndo_codec_params codec; /* --encoding (raw by default) */
	ndo_faults faults;     /* --drop --delay --jitter --reorder --fault-seed */
	int fault_seed_set;
	const char *key_file;  /* --key FILE (else $NDO_KEY, else none) */
	const char *new_key;   /* --new-key FILE: a new key, written there */
	const char *physics;   /* the first physics option given (a joiner's error) */
} peer_cli;

typedef struct run {
	ndo_scene sc;
	const char *in;
	int quiet, info;
	int no_estimate;    /* --no-estimate */
	ndo_grid *g;       /* the input, then the output */
	ndo_grid *frame;   /* frames: a copy carrying this command in its history */
	ndo_sim *sim;
	ndo_critical crit;
	double dt;
	int64_t steps;
	ndo_outfile log;
	int logging;
	uint8_t *pins;     /* from --pin, or NULL */
	/* Work arrays, kept here so that they stay reachable when an error
	 * exits (the leak checker of the sanitizer build). */
	const char **keys, **vals;
	double *rest, *x0;
	uint8_t *pin;
	ndo_force *forces;
	uint8_t *allpins;  /* peers' owner: every pinned node (grid and --pin) */
	peer_cli net;      /* the peers' options (role 0: a single process) */
	int threads;       /* --threads; 0: every processor alone, 1 as a peer */
	size_t max_memory; /* --max-memory; 0: what the machine has available */
	/* accuracy.c: --accuracy E (0: none; metres: E in metres) and the
	 * scene at every level coarser than the input (error estimates). */
	double accuracy;
	int accuracy_metres;
	int energy_bound_set; /* --energy-bound on the command line (the chosen run's test) */
	ndo_acc *acc;
	double *coarse;    /* a coarser run's output work array */
	/* --sleep D (metres; 0: off); sleep_set: given on the command line */
	double sleep;
	int sleep_set;
} run;

/* run.c: load the input, rest shape, pins and forces; create the
 * simulation. */
void setup(run *r);
/* The critical step, the step size and the step count (prints them; with
 * --accuracy only the input level's top mode, the rest is the choice's). */
void plan(run *r);
/* --log: open the CSV log with its header (nothing without --log); one row
 * of `sim`'s energies at `step`. */
void log_open(run *r);
void log_row(run *r, ndo_sim *sim, int64_t step);
/* accuracy.c: --accuracy's argument; the choice (after plan: replaces the
 * simulation by the chosen one, prints it, refuses with exit 2 what the
 * input cannot reach); the largest displacement, sampled during the run;
 * the error estimate, printed and appended to the log (before the log is
 * committed); storing a run coarser than the input at the input's level
 * (subdivided). */
void accuracy_option(run *r, const char *arg);
void accuracy_plan(run *r);
void accuracy_sample(run *r, int64_t k);
/* The next step after k that accuracy_sample() samples at (INT64_MAX: none). */
int64_t accuracy_next(const run *r, int64_t k);
/* The error estimate's companions started beside the run where it steps on
 * one thread (before its first step); accuracy_report takes them. */
void accuracy_begin(run *r);
void accuracy_report(run *r);
void accuracy_print(void);
int accuracy_store(run *r, ndo_grid *g);
void accuracy_free(run *r);
/* accuracy.c: --sleep's argument; sleeping tiles on the simulation (with
 * --accuracy and no --sleep: a tenth of the target); the summary line. */
void sleep_option(run *r, const char *arg);
void sleep_apply(run *r);
void sleep_report(const run *r);
/* peers.c: the peers' options: defaults, one option (a usage error when bad), and
 * the checks once all are read (scene: the -s file or NULL; in: the input
 * or NULL; the n settings keys given on the command line). */
void peer_defaults(peer_cli *c);
void peer_option(peer_cli *c, const char *name, const char *arg);
void peer_check(const peer_cli *c, const char *scene, const char *in, int n,
                const char *const *keys);
/* The run as one of several peers; returns the exit status. */
int peers_main(run *r);

#endif
