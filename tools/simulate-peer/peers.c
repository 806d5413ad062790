/* peers.c — simulate-peer as one of several peers sharing one surface
 * over LCM (thesis §4.4–4.5; docs/peers.md).  The owner sets up its object
 * as the single process does (main.c), then the library's peer
 * (ndo/peer.h) keeps the session and the simulation; this file reads the
 * options, waits on the network, writes frames, the log and the result,
 * and reports. */
#include "simulate.h"

#include "ndo/partition.h"
#include "ndo/watch.h"

#include <getopt.h>
#include <limits.h>
#include <math.h>
#include <poll.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* ---- options ---------------------------------------------------------------- */

void peer_defaults(peer_cli *c)
{
	memset(c, 0, sizeof *c);
	c->poi = -1;
	c->prefix = "NDO";
	c->partition = 0; /* bands where every peer count fits (owner_partition) */
	c->clock = NDO_CLOCK_LOCKSTEP;
	c->speed = 1;
	c->step_timeout = 0.5;
	c->peer_timeout = 2;
	c->start_timeout = 60;
	c->gather_timeout = 10;
	c->peers = 1;
	c->send_level = -1;
}

/* The owner's partition method: the one asked for, or bands of whole rows
 * (the faster steps, docs/peers.md) where the grid has a cell row for each
 * of NDO_MAX_PEERS peers, the quad-tree's regions on the coarser grids. */
static ndo_part_method owner_partition(const peer_cli *c, int level)
{
	if (c->partition)
		return (ndo_part_method)c->partition;
	return (1 << level) >= NDO_MAX_PEERS ? NDO_PART_BANDS : NDO_PART_QUADTREE;
}

/* Options only the owner decides; a joiner takes them from it. */
static const char *const owner_only[] = {"partition", "clock", "speed", "peers", "boundary",
                                         "step-timeout", "gather-timeout", "encoding",
                                         "halo-steps", "publish-every", "send-level",
                                         "checkpoint-every", "publish-rate", NULL};
static uint32_t given; /* bit k: owner_only[k] was given */

void peer_option(peer_cli *c, const char *name, const char *arg)
{
	for (int k = 0; owner_only[k]; k++)
		if (strcmp(name, owner_only[k]) == 0)
			given |= 1u << k;
	char opt[64];
	snprintf(opt, sizeof opt, "--%s", name);
	if (strcmp(name, "owner") == 0 || strcmp(name, "join") == 0) {
		int role = name[0] == 'o' ? NDO_ROLE_OWNER : NDO_ROLE_JOINER;
		if (c->role && c->role != role)
			ndo_usage_error("--owner and --join: a peer is one or the other");
		c->role = role;
	} else if (strcmp(name, "poi") == 0) {
		c->poi = (int32_t)ndo_opt_long(opt, arg, -1, INT32_MAX);
	} else if (strcmp(name, "lcm") == 0) {
		c->lcm = arg;
	} else if (strcmp(name, "channel") == 0) {
		if (!*arg || strlen(arg) > 64 || strpbrk(arg, ".*?[]()|\\^$+{} "))
			ndo_usage_error("--channel: '%s': 1..64 characters, no spaces or regex operators",
			                arg);
		c->prefix = arg;
	} else if (strcmp(name, "name") == 0) {
		c->name = arg;
	} else if (strcmp(name, "partition") == 0) {
		if ((c->partition = ndo_part_method_parse(arg)) < 0)
			ndo_usage_error("--partition: '%s' is not quadtree, table41, metis or bands", arg);
	} else if (strcmp(name, "clock") == 0) {
		int k = ndo_clock_parse(arg);
		if (k < 0)
			ndo_usage_error("--clock: '%s' is not lockstep or realtime", arg);
		c->clock = (ndo_clock)k;
	} else if (strcmp(name, "speed") == 0) {
		c->speed = ndo_opt_double(opt, arg, 1e-6, 1e6);
	} else if (strcmp(name, "peers") == 0) {
		c->peers = (int)ndo_opt_long(opt, arg, 1, NDO_MAX_PEERS);
	} else if (strcmp(name, "boundary") == 0) {
		/* exact (lock-step) and extrapolate (realtime) are each clock's
		 * default: both mean "not held" */
		if (strcmp(arg, "hold") == 0)
			c->hold_boundary = 1;
		else if (strcmp(arg, "exact") == 0 || strcmp(arg, "extrapolate") == 0)
			c->hold_boundary = 0;
		else
			ndo_usage_error("--boundary: '%s' is not exact, extrapolate or hold", arg);
		c->boundary_inexact = strcmp(arg, "exact") != 0;
	} else if (strcmp(name, "halo-steps") == 0) {
		c->halo_steps = (int)ndo_opt_long(opt, arg, 1, 1000);
	} else if (strcmp(name, "publish-every") == 0) {
		size_t n = strlen(arg);
		if (n > 1 && arg[n - 1] == 's') { /* seconds of simulated time: a rate */
			char t[64];
			if (n > sizeof t)
				ndo_usage_error("%s: '%s' is not N steps or T seconds (Ts)", opt, arg);
			memcpy(t, arg, n - 1);
			t[n - 1] = '\0';
			c->publish_seconds = ndo_opt_double(opt, t, 1e-9, 1e9);
			c->publish_every = 0;
		} else {
			if (strpbrk(arg, ".eE"))
				ndo_usage_error("%s: '%s' is not a whole number of steps (seconds of "
				                "simulated time: %ss)", opt, arg, arg);
			c->publish_every = (int)ndo_opt_long(opt, arg, 0, 1000000000);
			c->publish_seconds = 0;
		}
		c->publish_every_set = 1;
	} else if (strcmp(name, "publish-rate") == 0) {
		c->publish_rate = ndo_opt_double(opt, arg, 1e-6, 1e6);
	} else if (strcmp(name, "checkpoint-every") == 0) {
		/* 0: none (the library's 0 is its default, its < 0 none) */
		c->checkpoint_every = (int)ndo_opt_long(opt, arg, 0, 1000000000);
		if (c->checkpoint_every == 0)
			c->checkpoint_every = -1;
	} else if (strcmp(name, "precondition") == 0) {
		if (strcmp(arg, "diagonal") != 0 && strcmp(arg, "block") != 0)
			ndo_usage_error("--precondition: '%s' is not diagonal or block", arg);
		c->block = strcmp(arg, "block") == 0;
	} else if (strcmp(name, "send-level") == 0) {
		c->send_level = (int)ndo_opt_long(opt, arg, 0, NDO_MAX_LEVEL);
	} else if (strcmp(name, "encoding") == 0) {
		if (ndo_codec_parse(arg, &c->codec))
			ndo_usage_error("--encoding: %s", ndo_errdetail());
	} else if (strcmp(name, "step-timeout") == 0) {
		c->step_timeout = ndo_opt_double(opt, arg, 1e-3, 3600);
	} else if (strcmp(name, "peer-timeout") == 0) {
		c->peer_timeout = ndo_opt_double(opt, arg, 0.1, 3600);
	} else if (strcmp(name, "start-timeout") == 0) {
		c->start_timeout = ndo_opt_double(opt, arg, 0.1, 1e6);
	} else if (strcmp(name, "gather-timeout") == 0) {
		c->gather_timeout = ndo_opt_double(opt, arg, 0.01, 3600);
	} else if (strcmp(name, "drop") == 0) {
		c->faults.drop = ndo_opt_double(opt, arg, 0, 1);
	} else if (strcmp(name, "delay") == 0) {
		c->faults.delay_ms = ndo_opt_double(opt, arg, 0, 1e6);
	} else if (strcmp(name, "jitter") == 0) {
		c->faults.jitter_ms = ndo_opt_double(opt, arg, 0, 1e6);
	} else if (strcmp(name, "reorder") == 0) {
		c->faults.reorder = ndo_opt_double(opt, arg, 0, 1);
	} else if (strcmp(name, "key") == 0) {
		c->key_file = arg;
	} else if (strcmp(name, "new-key") == 0) {
		c->new_key = arg;
	} else if (strcmp(name, "fault-seed") == 0) {
		c->faults.seed = (uint64_t)ndo_opt_long(opt, arg, 0, LONG_MAX);
		c->fault_seed_set = 1;
	}
}

void peer_check(const peer_cli *c, const char *scene, const char *in, int n,
                const char *const *keys)
{
	if (c->key_file && c->new_key)
		ndo_usage_error("--key and --new-key: one key or the other");
	if (c->new_key && c->role == NDO_ROLE_JOINER)
		ndo_usage_error("--new-key: a joiner uses the owner's key (--key FILE)");
	if (!c->role && c->new_key) { /* write a key and exit */
		ndo_key k;
		char id[9];
		if (ndo_key_generate(c->new_key, &k))
			ndo_die("--new-key: %s", ndo_errdetail());
		ndo_key_id_text(&k, id);
		fprintf(stderr, "%s: a new session key (id %s) in %s\n", ndo_progname, id, c->new_key);
		ndo_close_stdout();
		exit(NDO_EXIT_OK);
	}
	if (!c->role) {
		if (given || c->key_file || c->poi >= 0 || c->lcm || c->name || c->faults.drop > 0 ||
		    c->faults.delay_ms > 0 || c->faults.jitter_ms > 0 || c->faults.reorder > 0 ||
		    c->fault_seed_set || strcmp(c->prefix, "NDO") != 0)
			ndo_usage_error("the peers' options need --owner or --join");
		return;
	}
	if (c->publish_rate > 0 && c->publish_every_set)
		ndo_usage_error("--publish-every and --publish-rate: one or the other");
	if (c->role != NDO_ROLE_JOINER)
		return;
	for (int k = 0; owner_only[k]; k++)
		if (given & (1u << k))
			ndo_usage_error("--%s: the owner decides it; a joiner takes it from the owner",
			                owner_only[k]);
	if (scene)
		ndo_usage_error("--scene: a joiner takes the physics from the owner");
	if (in)
		ndo_usage_error("'%s': a joiner receives the object from the owner (no input)", in);
	static const char *const own[] = {"output", "frames", "frame-every", "log", "log-every",
	                                  NULL};
	for (int k = 0; k < n; k++) {
		int ok = 0;
		for (int q = 0; own[q]; q++)
			ok |= strcmp(keys[k], own[q]) == 0;
		if (!ok)
			ndo_usage_error("--%s: a joiner takes the physics from the owner", keys[k]);
	}
}

/* ---- the run ------------------------------------------------------------------- */

static volatile sig_atomic_t interrupted;
static void on_signal(int sig) { interrupted = sig; }

typedef struct peer_run {
	run *r;
	ndo_peer *p;
	ndo_link *link;     /* the outermost link (faults), owned by the net */
	int show;           /* progress on a terminal */
	/* an observer's frames: a watch on a second link assembles each step
	 * whole (ndo/watch.h), as render-frame --lcm does */
	ndo_watch *watch;
	ndo_grid *last;     /* its last frame: the observer's output */
	int64_t frames;     /* frames written */
	int progress_shown;
	double shown;
} peer_run;

static void clear_progress(peer_run *pr)
{
	if (pr->progress_shown) {
		fputs("\r\033[K", stderr);
		pr->progress_shown = 0;
	}
}

static void on_note(void *user, const char *msg)
{
	peer_run *pr = user;
	if (pr->r->quiet)
		return;
	clear_progress(pr);
	fprintf(stderr, "%s: %s\n", ndo_progname, msg);
}

static ndo_net *open_net(peer_run *pr)
{
	peer_cli *c = &pr->r->net;
	ndo_link *l;
	ndo_net *n;
	if (ndo_link_open_lcm(c->lcm, NDO_RECV_BUF_DEFAULT, c->prefix, 0, &l))
		ndo_die("LCM: %s", ndo_errdetail());
	ndo_faults *f = &c->faults;
	if (f->drop > 0 || f->delay_ms > 0 || f->jitter_ms > 0 || f->reorder > 0) {
		if (!c->fault_seed_set)
			f->seed = (uint64_t)getpid() * 0x9e3779b97f4a7c15ull ^ (uint64_t)(ndo_now() * 1e9);
		if (ndo_link_faults(l, f, &l))
			ndo_die("fault injection: %s", ndo_errdetail());
	}
	pr->link = l;
	if (ndo_net_create(l, c->prefix, 1, &n))
		ndo_die("%s", ndo_errdetail());
	ndo_key k;
	int keyed;
	if (c->new_key) {
		if ((keyed = ndo_key_generate(c->new_key, &k)) != 0)
			ndo_die("--new-key: %s", ndo_errdetail());
		keyed = 1;
	} else if ((keyed = ndo_key_resolve(c->key_file, &k)) < 0) {
		ndo_die("%s%s", c->key_file ? "--key: " : "", ndo_errdetail());
	}
	if (keyed && ndo_net_set_key(n, &k))
		ndo_die("%s", ndo_errdetail());
	char id[9] = "";
	if (keyed)
		ndo_key_id_text(&k, id);
	ndo_key_wipe(&k);
	if (pr->r->quiet)
		return n;
	if (keyed)
		fprintf(stderr, "%s: keyed session (key id %s%s%s): only peers with the key take "
		        "part\n", ndo_progname, id, c->new_key ? ", new, in " : "",
		        c->new_key ? c->new_key : "");
	else
		fprintf(stderr, "%s: no session key (--key FILE or $%s): anyone on the network can "
		        "join this session and write its state\n", ndo_progname, NDO_KEY_ENV);
	return n;
}

/* An observer's watch: its own LCM link on the same channels and key. */
static void open_watch(peer_run *pr)
{
	peer_cli *c = &pr->r->net;
	ndo_link *l;
	ndo_net *n;
	ndo_key k;
	int keyed;
	if (ndo_link_open_lcm(c->lcm, NDO_RECV_BUF_DEFAULT, c->prefix, 0, &l) ||
	    ndo_net_create(l, c->prefix, 0x7ffffffe, &n))
		ndo_die("LCM: %s", ndo_errdetail());
	if ((keyed = ndo_key_resolve(c->key_file, &k)) < 0 || (keyed && ndo_net_set_key(n, &k)))
		ndo_die("%s", ndo_errdetail());
	ndo_key_wipe(&k);
	ndo_watch_opts wo = {.every = 1, .window = 32};
	if (ndo_watch_create(n, &wo, &pr->watch))
		ndo_die("%s", ndo_errdetail());
}

/* An observer: write the frames asked for as the watch completes them,
 * each with its own step and time; keep the last for the output. */
static void observe(peer_run *pr, double now)
{
	run *r = pr->r;
	if (ndo_watch_update(pr->watch, now))
		ndo_die("%s", ndo_errdetail());
	ndo_grid *f;
	while (ndo_watch_next(pr->watch, &f) == 1) {
		int64_t k = f->step - ndo_peer_first_step(pr->p);
		if (r->sc.frames && k >= 0 && k % r->sc.frame_every == 0) {
			char path[4096];
			int len = snprintf(path, sizeof path, r->sc.frames, (int)(k / r->sc.frame_every));
			if (len < 0 || (size_t)len >= sizeof path)
				ndo_die("--frames: the path for frame %lld is too long",
				        (long long)(k / r->sc.frame_every));
			if (ndo_grid_export(path, f))
				ndo_die("%s: %s", path, ndo_errdetail());
			pr->frames++;
		}
		ndo_grid_destroy(pr->last);
		pr->last = f;
	}
}

/* The default --publish-rate: whole regions about this many times a second
 * of wall time, at least PUBLISH_EVERY_MIN steps apart, and at most
 * PUBLISH_BYTES a second of them over the whole object (a gigabit link's
 * 125 MB/s, less room for the halos): at level 9, 8 peers at 30 frames a
 * second would send 750 MB/s, which starved the peers that read it on 2
 * cores (docs/peers.md, "Whole regions"). */
enum { PUBLISH_RATE = 30, PUBLISH_EVERY_MIN = 10 };
#define PUBLISH_BYTES 100e6

/* A whole object's frame in bytes, at most: the nodes (of --send-level,
 * where asked) times a node's bytes in the session's encoding — raw 48
 * (position and velocity), float32 12, fixed 3 × (bits + 2) bits, which
 * predict and hier only shrink, so theirs too (an error budget E: the bits
 * of a step of 2E of the box, ⌈log2(1 / 2E)⌉) — and a tenth more for the
 * tiles' headers and their shared edges (a level-7 raw frame: 51.5 bytes
 * a node). */
static double frame_bytes(const peer_cli *c, size_t nodes, int level)
{
	const ndo_codec_params *p = &c->codec;
	double node = 48;
	if (p->encoding == NDO_ENC_FLOAT32) {
		node = 12;
	} else if (p->encoding != NDO_ENC_RAW) {
		double bits = p->error > 0 ? ceil(log2(0.5 / p->error)) : p->bits;
		node = 3 * (bits + 2) / 8;
	}
	double n = (double)nodes;
	if (c->send_level >= 0 && c->send_level < level)
		n /= pow(4, level - c->send_level);
	return 1.1 * node * n;
}

/* The run's steps per second of wall time as the owner predicts them, for
 * --publish-rate: realtime's is --speed / dt; lock-step's the peers' count
 * times one thread's on this method and grid, at the single-thread rates
 * of docs/bench/threads.md and docs/bench/multigrid.md (2-core Intel Xeon,
 * 2026-11-30; rkf45 at its sub-steps of the thesis' scene) — counted, not
 * timed, so that one command sends the same frames on any machine and at
 * any load (frame k is step k·N: a recording's frames, and the watches'
 * lost-frame counts, must not depend on how busy the machine was). */
static double predicted_rate(const run *r, const peer_cli *c, size_t nodes)
{
	if (c->clock == NDO_CLOCK_REALTIME)
		return (c->speed > 0 ? c->speed : 1) / r->dt;
	double ns; /* a node-step's nanoseconds */
	switch (r->sc.sim.method) {
	case NDO_EULER:
	case NDO_SYMPLECTIC_EULER: ns = 7; break;
	case NDO_MIDPOINT: ns = 15; break;
	case NDO_RK4: ns = 33; break;
	case NDO_RKF45: ns = 200; break;
	default: ns = 120; break; /* backward-euler, trapezoid: multigrid */
	}
	return (c->peers > 1 ? c->peers : 1) / (ns * 1e-9 * (double)(nodes ? nodes : 1));
}

/* --publish-every, from --publish-rate (or its default) where not given:
 * the steps of 1/rate seconds at the predicted speed, rounded up (at most
 * that rate), at least PUBLISH_EVERY_MIN by default and 1 when asked; by
 * default also at most PUBLISH_BYTES a second. */
static void publish_interval(run *r, peer_cli *c, size_t nodes, int level)
{
	if (c->publish_every_set)
		return;
	double rate = c->publish_rate > 0 ? c->publish_rate : PUBLISH_RATE;
	double speed = predicted_rate(r, c, nodes), q = ceil(speed / rate);
	double bytes = frame_bytes(c, nodes, level);
	int capped = 0;
	if (c->publish_rate <= 0 && ceil(speed * bytes / PUBLISH_BYTES) > q) {
		q = ceil(speed * bytes / PUBLISH_BYTES);
		capped = 1;
	}
	int least = c->publish_rate > 0 ? 1 : PUBLISH_EVERY_MIN;
	c->publish_every = q < least ? least : q > 1e9 ? 1000000000 : (int)q;
	/* the owner's own --frames (every F steps) show the others' regions as
	 * they travelled: a divisor of F keeps every one of them whole — the
	 * largest at most the rate's, unless under half of it (F prime, say):
	 * then F itself, fewer than the rate */
	int64_t f = r->sc.frames ? r->sc.frame_every : 0, n = c->publish_every, d = 1;
	if (f > 0 && f <= 1000000000 && f % n) {
		for (int64_t i = 1; i * i <= f; i++)
			if (f % i == 0) {
				if (i <= n && i > d)
					d = i;
				if (f / i <= n && f / i > d)
					d = f / i;
			}
		c->publish_every = (int)(2 * d < n ? f : d);
	}
	ndo_method m = r->sc.sim.method;
	int every_step = c->hold_boundary || (c->clock == NDO_CLOCK_REALTIME &&
	                                      (m == NDO_RKF45 || ndo_method_is_implicit(m)));
	char cap[64] = "";
	if (capped)
		snprintf(cap, sizeof cap, ", and by default at most %g MB a second", 1e-6 * PUBLISH_BYTES);
	if (!r->quiet && !every_step && (c->publish_rate > 0 || c->publish_every != PUBLISH_EVERY_MIN))
		fprintf(stderr, "%s: whole regions every %d step%s (about %.3g a second at the "
		        "predicted %.3g steps/s, up to %.3g MB a second; --publish-rate %g%s%s)\n",
		        ndo_progname, c->publish_every, c->publish_every == 1 ? "" : "s",
		        speed / c->publish_every, speed, 1e-6 * bytes * speed / c->publish_every,
		        rate, cap, c->publish_every != n ? ", to suit --frame-every" : "");
}

/* The owner's object: the single process's setup, as a grid with every
 * channel a peer needs, and its simulation. */
static ndo_grid *owner_object(run *r, ndo_sim **sim)
{
	ndo_grid *g = r->g;
	ndo_channel *pc;
	if (ndo_sim_store(r->sim, g))
		ndo_die("%s", ndo_errdetail());
	ndo_grid_remove(g, NDO_CH_PIN);
	ndo_grid_remove(g, NDO_CH_OWNER);
	if (ndo_grid_add(g, NDO_CH_PIN, NDO_U8, 1, &pc))
		ndo_die("%s", ndo_errdetail());
	memcpy(pc->data, r->allpins, g->count);
	*sim = r->sim;
	r->sim = NULL;
	r->g = NULL;
	return g;
}

/* Frame k is step first + k·frame-every, on every peer (and as in a single
 * process). */
static void write_frame(peer_run *pr, int64_t k)
{
	char path[4096];
	int len = snprintf(path, sizeof path, pr->r->sc.frames, (int)k);
	if (len < 0 || (size_t)len >= sizeof path)
		ndo_die("--frames: the path for frame %lld is too long", (long long)k);
	ndo_session *s = ndo_peer_session(pr->p);
	ndo_grid *g = ndo_peer_grid(pr->p), *coarse = NULL;
	/* a run that sends a level: frames at that level, the others' nodes as
	 * they travelled (the last step's -o stays exact at the simulated level) */
	if (ndo_session_send_level(s) < g->level && ndo_session_frame(s, &coarse))
		ndo_die("%s", ndo_errdetail());
	if (ndo_mkdir_parents(path) || ndo_grid_export(path, coarse ? coarse : g))
		ndo_die("%s: %s", path, ndo_errdetail());
	ndo_grid_destroy(coarse);
}

/* After a step: the log row and the frame that are due. */
static void stepped(peer_run *pr)
{
	run *r = pr->r;
	int64_t k = ndo_peer_step(pr->p) - ndo_peer_first_step(pr->p);
	if (r->logging && (k % r->sc.log_every == 0 || ndo_peer_step(pr->p) == ndo_peer_final_step(pr->p)))
		log_row(r, ndo_peer_sim(pr->p), ndo_peer_step(pr->p));
	if (r->sc.frames && k % r->sc.frame_every == 0 && !pr->watch)
		write_frame(pr, k / r->sc.frame_every);
	if (pr->show && ndo_now() - pr->shown > 0.25) {
		pr->shown = ndo_now();
		fprintf(stderr, "\r%s: step %lld/%lld\033[K", ndo_progname,
		        (long long)ndo_peer_step(pr->p), (long long)ndo_peer_final_step(pr->p));
		pr->progress_shown = 1;
	}
}

/* Sleep until the peer's deadline, a message on the link, or a delayed
 * message of the fault layer falling due. */
static void wait_for(peer_run *pr)
{
	double now = ndo_now();
	double due = fmin(ndo_peer_deadline(pr->p), ndo_link_next_due(pr->link));
	if (due <= now)
		return;
	int ms = (int)ceil(fmin(due - now, 0.05) * 1e3);
	struct pollfd pfd = {ndo_link_fileno(pr->link), POLLIN, 0};
	poll(&pfd, pfd.fd >= 0 ? 1 : 0, ms);
}

static const char *role_name(const ndo_peer *p, int role)
{
	ndo_peer_stats st;
	ndo_peer_stats_get(p, &st);
	if (role == NDO_ROLE_OWNER)
		return "owner";
	if (st.took_over)
		return "successor of the owner";
	return ndo_peer_simulating(p) ? "peer" : "observer";
}

static void summary(peer_run *pr, const char *how)
{
	run *r = pr->r;
	ndo_peer *p = pr->p;
	ndo_peer_stats st;
	ndo_peer_stats_get(p, &st);
	char net[1024];
	ndo_net_stats_format(ndo_session_net(ndo_peer_session(p)), net, sizeof net);
	/* an observer takes no step: its time runs to now */
	double el = (st.end_time > st.start_time ? st.end_time : ndo_now()) - st.start_time;
	int np = 0;
	ndo_session_cells(ndo_peer_session(p), &np, NULL);
	clear_progress(pr);
	const long long to = (long long)(pr->last ? pr->last->step : ndo_peer_step(p));
	if (!st.steps && !ndo_peer_simulating(p)) /* an observer: no step of its own */
		fprintf(stderr, "%s: %s %d done (%s): %s, %d peer%s at the end; watched to step %lld "
		        "in %.3g s\n", ndo_progname, role_name(p, r->net.role),
		        ndo_session_self(ndo_peer_session(p)), how, ndo_clock_name(ndo_peer_clock(p)), np,
		        np == 1 ? "" : "s", to, el);
	else
		fprintf(stderr, "%s: %s %d done (%s): %s, %d peer%s at the end; %lld steps to step %lld "
		        "in %.3g s (computing %.3g s, waiting %.3g s in %lld steps, %lld timed out); "
		        "boundary lag %.3g steps on average, %.3g at most; %lld re-sends\n",
		        ndo_progname, role_name(p, r->net.role), ndo_session_self(ndo_peer_session(p)),
		        how, ndo_clock_name(ndo_peer_clock(p)), np, np == 1 ? "" : "s",
		        (long long)st.steps, to, el, st.compute_seconds, st.wait_seconds,
		        (long long)st.waited, (long long)st.timeouts,
		        st.steps ? st.lag_sum / (double)st.steps : 0.0, st.lag_max, (long long)st.resends);
	if (st.ungathered)
		fprintf(stderr, "%s: %lld nodes of the output are not of the last step (their peers' "
		        "last tiles did not arrive)\n", ndo_progname, (long long)st.ungathered);
	if (st.behind)
		fprintf(stderr, "%s: %lld steps were taken late: the simulation cannot keep up with "
		        "--speed\n", ndo_progname, (long long)st.behind);
	if (st.exact && st.steps) {
		char ahead[64] = ""; /* rk4 with bands: ndo/sim.h, ndo_sim_step_begin */
		if (st.ahead)
			snprintf(ahead, sizeof ahead, "; %lld steps begun ahead of it", (long long)st.ahead);
		fprintf(stderr, "%s: exact: a halo of %d rings in %lld exchanges, %.3g kB a step "
		        "(%.3g tiles)%s; whole regions %lld times, %.3g kB a step\n", ndo_progname,
		        st.halo_rings, (long long)st.exchanges,
		        (double)st.halo_bytes / 1e3 / (double)st.steps,
		        (double)st.halo_tiles / (double)st.steps, ahead, (long long)st.frames,
		        (double)st.frame_bytes / 1e3 / (double)st.steps);
	}
	if (st.exact && st.inexact_at >= 0) {
		char where[32] = "here";
		if (st.inexact_peer)
			snprintf(where, sizeof where, "at peer %d", st.inexact_peer);
		fprintf(stderr, "%s: NOT exact: from step %lld the state holds values taken after a "
		        "step timeout, or a region taken over from frames (%s), and no restart "
		        "followed: the result is not the single process's\n", ndo_progname,
		        (long long)st.inexact_at, where);
	}
	if (st.checkpoints || st.restarts)
		fprintf(stderr, "%s: restarts: %lld checkpoints kept, %.3g kB of them sent; %lld "
		        "restarts from a checkpoint (new partitions), %lld steps taken again\n",
		        ndo_progname, (long long)st.checkpoints, (double)st.checkpoint_bytes / 1e3,
		        (long long)st.restarts, (long long)st.restart_steps);
	if (st.checkpoint_asks)
		fprintf(stderr, "%s: restarts: asked %lld time%s for parts of a checkpoint again (lost "
		        "on the way)\n", ndo_progname, (long long)st.checkpoint_asks,
		        st.checkpoint_asks == 1 ? "" : "s");
	if (st.rollback && st.steps)
		fprintf(stderr, "%s: rollback: %s; %lld rollbacks (the deepest %lld steps), %lld steps "
		        "recomputed for %lld taken; %lld halo node-steps first predicted; frames shown "
		        "during the run: %lld of %lld differed from their confirmed steps, by up to "
		        "%.3g m (%.3g of the largest displacement, %.3g m); window %d steps\n",
		        ndo_progname, st.confirmed ? "every step confirmed (the lock-step result)"
		                                   : "NOT confirmed (the result is not exact)",
		        (long long)st.rollbacks, (long long)st.rollback_depth,
		        (long long)st.recomputed, (long long)st.steps, (long long)st.predicted,
		        (long long)st.shown_wrong, (long long)st.shown_frames, st.shown_error,
		        st.shown_disp > 0 ? st.shown_error / st.shown_disp : 0.0, st.shown_disp,
		        st.window);
	ndo_session_level_stats ls;
	ndo_session_level_stats_get(ndo_peer_session(p), &ls);
	if (ls.send_level >= 0 && ls.send_level < ls.level && ls.frames > 0)
		fprintf(stderr, "%s: send level %d of %d: %lld whole-region frames sent at level %d; the "
		        "error at level %d of what receivers hold (refined), over this peer's nodes: "
		        "max %.3g, RMS %.3g of the diagonal\n", ndo_progname, ls.send_level, ls.level,
		        (long long)ls.frames, ls.send_level, ls.level, ls.max_error,
		        ls.error_nodes ? sqrt(ls.sum_sq_error / (double)ls.error_nodes) : 0.0);
	if (pr->watch) {
		ndo_watch_stats ws;
		ndo_watch_stats_get(pr->watch, &ws);
		fprintf(stderr, "%s: observed %lld whole steps, the last %lld (%lld frames written), "
		        "%lld skipped incomplete (lost tiles)\n", ndo_progname, (long long)ws.frames,
		        pr->last ? (long long)pr->last->step : -1LL, (long long)pr->frames,
		        (long long)ws.incomplete);
	}
	ndo_codec_stats enc, dec;
	ndo_session_codec_stats(ndo_peer_session(p), &enc, &dec);
	if (enc.keys_asked)
		fprintf(stderr, "%s: receivers that lost frames asked for the keyframes of %lld tiles; "
		        "%lld keyframes sent early for them (of %lld keyframes in %lld tiles sent)\n",
		        ndo_progname, (long long)enc.keys_asked, (long long)enc.keys_forced,
		        (long long)enc.keyframes, (long long)enc.encoded);
	const ndo_net_stats *ns = ndo_net_stats_get(ndo_session_net(ndo_peer_session(p)));
	fprintf(stderr, "%s: network: %s; sent %.3g MB (%.3g kB a step)\n", ndo_progname, net,
	        (double)ns->bytes_out / 1e6,
	        st.steps ? (double)ns->bytes_out / 1e3 / (double)st.steps : 0.0);
}

/* Print the message, say `said` to the others with this peer's leave (NULL:
 * the message itself) and exit with code. */
static __attribute__((noreturn, format(printf, 4, 5))) void
leave_saying(peer_run *pr, int code, const char *said, const char *fmt, ...)
{
	char msg[300];
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(msg, sizeof msg, fmt, ap);
	va_end(ap);
	clear_progress(pr);
	fprintf(stderr, "%s: %s\n", ndo_progname, msg);
	if (pr->r->logging && ndo_out_commit(&pr->r->log))
		ndo_warn("%s: %s", pr->r->sc.log, ndo_errdetail());
	ndo_peer_destroy(pr->p, said ? said : msg);
	ndo_close_stdout();
	exit(code);
}
#define leave(pr, code, ...) leave_saying(pr, code, NULL, __VA_ARGS__)

int peers_main(run *r)
{
	peer_cli *c = &r->net;
	int owner = c->role == NDO_ROLE_OWNER;
	static peer_run pr;
	pr.r = r;
	ndo_sim *sim = NULL;
	ndo_grid *g = NULL;
	if (owner) {
		setup(r);
		ndo_method m = r->sc.sim.method;
		if (c->clock == NDO_CLOCK_REALTIME && !c->boundary_inexact &&
		    (m == NDO_RKF45 || ndo_method_is_implicit(m)))
			ndo_usage_error("--clock realtime: %s does not roll back (its steps need the "
			                "others' state within each step), so it would not end on the single "
			                "process's result: run it lock-step, or ask for an extrapolated or "
			                "held boundary with --boundary extrapolate or hold",
			                ndo_method_names[m]);
		if (c->clock == NDO_CLOCK_REALTIME && !c->boundary_inexact && r->sc.sim.restiffen > 0)
			ndo_usage_error("--clock realtime: --restiffen does not roll back (a rollback "
			                "would need K as it was at an earlier step), so it would not end on "
			                "the single process's result: run it lock-step, or ask for an "
			                "extrapolated or held boundary with --boundary extrapolate or hold");
		plan(r);
		if (c->publish_seconds > 0) {
			/* every T s: the nearest whole number of steps, at least one */
			double q = c->publish_seconds / r->dt;
			c->publish_every = q < 1.5 ? 1 : q > 1e9 ? 1000000000 : (int)llround(q);
			if (!r->quiet)
				fprintf(stderr, "%s: whole regions every %d step%s (%.6g s of simulated "
				        "time; --publish-every %gs)\n", ndo_progname, c->publish_every,
				        c->publish_every == 1 ? "" : "s", c->publish_every * r->dt,
				        c->publish_seconds);
		}
		publish_interval(r, c, r->g->count, r->g->level);
		if (r->info) {
			ndo_close_stdout();
			return NDO_EXIT_OK;
		}
		g = owner_object(r, &sim);
		if (c->send_level > g->level)
			ndo_usage_error("--send-level: %d is above the simulated level %d (0..%d)",
			                c->send_level, g->level, g->level);
		if (c->poi >= (int64_t)ndo_triangle_count(g->level))
			ndo_usage_error("--poi: face %d is outside 0..%zu for a level-%d grid", c->poi,
			                ndo_triangle_count(g->level) - 1, g->level);
	}
	ndo_peer_opts o = {
		.session = {.role = owner ? NDO_ROLE_OWNER : NDO_ROLE_JOINER, .name = c->name,
		            .poi = c->poi, .partition = owner ? owner_partition(c, g->level) : 0,
		            .timeout = c->peer_timeout, .codec = &c->codec,
		            .coarse_levels = owner && c->send_level >= 0 ? g->level - c->send_level : 0},
		.clock = c->clock, .step_timeout = c->step_timeout, .speed = c->speed,
		.peers = c->peers, .hold_boundary = c->hold_boundary,
		.halo_steps = c->halo_steps, .checkpoint_every = c->checkpoint_every, .block = c->block,
		.publish_every = c->publish_every == 0 && c->publish_every_set ? -1 : c->publish_every,
		.start_timeout = c->start_timeout, .gather_timeout = c->gather_timeout,
		.keep_tiles = r->sc.frames != NULL, .note = on_note, .note_user = &pr};
	ndo_peer_run run_ = {owner ? ndo_scene_physics(&r->sc) : NULL, r->dt, r->steps};
	ndo_net *net = open_net(&pr);
	if (ndo_peer_create(&o, net, g, sim, owner ? &run_ : NULL, &pr.p))
		ndo_die("%s", ndo_errdetail());
	if (!r->quiet && owner)
		fprintf(stderr, "%s: owner of object %llx as peer %d on %s (channels %s_*)%s\n",
		        ndo_progname, (unsigned long long)ndo_session_object(ndo_peer_session(pr.p)),
		        ndo_session_self(ndo_peer_session(pr.p)), c->lcm ? c->lcm : "LCM's default URL",
		        c->prefix, c->peers > 1 ? "; waiting for the other peers" : "");
	else if (!r->quiet)
		fprintf(stderr, "%s: peer %d looking for an object on %s (channels %s_*)\n",
		        ndo_progname, ndo_session_self(ndo_peer_session(pr.p)),
		        c->lcm ? c->lcm : "LCM's default URL", c->prefix);
	log_open(r);
	if (!owner && c->poi < 0 && (r->sc.frames || r->sc.output))
		open_watch(&pr);
	pr.show = !r->quiet && isatty(STDERR_FILENO);
	struct sigaction sa = {0};
	sa.sa_handler = on_signal;
	sigaction(SIGINT, &sa, NULL);
	sigaction(SIGTERM, &sa, NULL);
	int state, started = 0;
	for (;;) {
		if (interrupted)
			leave(&pr, EXIT_INTERRUPTED, "interrupted at step %lld", (long long)ndo_peer_step(pr.p));
		state = ndo_peer_update(pr.p, ndo_now());
		if (pr.watch)
			observe(&pr, ndo_now());
		if (owner && !started) {
			/* an elder owner's description (every 1 s) before the run: it was
			 * here first, and joiners' hellos would go to both */
			const ndo_net_stats *ns = ndo_net_stats_get(ndo_session_net(ndo_peer_session(pr.p)));
			if (ns->foreign_owner)
				leave(&pr, EXIT_ENDED, "another owner (peer %d, object %llx) is already on %s, "
				      "channels %s_*: use another --channel or --lcm", ns->foreign_owner,
				      (unsigned long long)ns->foreign_object,
				      c->lcm ? c->lcm : "LCM's default URL", c->prefix);
		}
		if (!owner && c->poi >= 0) { /* the face exists only once the object is known */
			ndo_grid *og = ndo_session_grid(ndo_peer_session(pr.p));
			if (og && (size_t)c->poi >= ndo_triangle_count(og->level))
				leave(&pr, NDO_EXIT_USAGE, "--poi: face %d is outside 0..%zu: the object "
				      "(level %d) has %zu faces", c->poi, ndo_triangle_count(og->level) - 1,
				      og->level, ndo_triangle_count(og->level));
		}
		if (state == NDO_EPACE)
			leave(&pr, EXIT_PACE, "cannot keep the pace at step %lld: %s; %s",
			      (long long)ndo_peer_step(pr.p), ndo_errdetail(),
			      r->sc.output ? "the output was not written" : "no output");
		if (state == NDO_EDIVERGED)
			leave(&pr, EXIT_DIVERGED, "diverged at step %lld (t = %.6g s): %s; %s",
			      (long long)ndo_peer_step(pr.p),
			      ndo_peer_sim(pr.p) ? ndo_sim_time(ndo_peer_sim(pr.p)) : 0.0,
			      ndo_errdetail(), r->sc.output ? "the output was not written" : "no output");
		if (state < 0)
			leave(&pr, NDO_EXIT_FAIL, "%s", ndo_errdetail());
		if (!started && ndo_peer_started(pr.p)) { /* the state it starts from */
			started = 1;
			r->dt = ndo_peer_dt(pr.p);
			stepped(&pr);
		}
		if (state == NDO_PEER_STEPPED) {
			stepped(&pr);
			continue;
		}
		if (state == NDO_PEER_DONE)
			break;
		if (state == NDO_PEER_ENDED)
			/* the others hear the reason, not this peer's "the session
			 * ended at step N" (an owner's start timeout read "the session
			 * ended at step 0: the owner quit: the session ended at step
			 * 0: only 2 of 3 peers came within 60 s") */
			leave_saying(&pr, EXIT_ENDED, ndo_peer_message(pr.p),
			             "the session ended at step %lld: %s",
			             (long long)ndo_peer_step(pr.p), ndo_peer_message(pr.p));
		wait_for(&pr);
	}
	if (r->logging && ndo_out_commit(&r->log))
		ndo_die("%s: %s", r->sc.log, ndo_errdetail());
	r->logging = 0;
	if (pr.watch) { /* the frames still open when the owner ended (at most 1 s) */
		double t0 = ndo_now();
		while (!ndo_watch_ended(pr.watch) && ndo_now() - t0 < 1) {
			observe(&pr, ndo_now());
			struct pollfd pfd = {ndo_link_fileno(pr.link), POLLIN, 0};
			poll(&pfd, pfd.fd >= 0 ? 1 : 0, 10);
		}
		observe(&pr, ndo_now());
	}
	ndo_grid *out = pr.watch ? pr.last : ndo_peer_grid(pr.p);
	if (!out)
		leave(&pr, NDO_EXIT_FAIL, "no complete step arrived to write");
	if (owner || r->sc.output) {
		if (!pr.watch) /* a watch's frame carries its own step and time */
			out->step = ndo_peer_step(pr.p);
		if (ndo_peer_sim(pr.p))
			out->time = ndo_sim_time(ndo_peer_sim(pr.p));
		if (ndo_grid_add_history(out, ndo_cli_argc(), ndo_cli_argv()) ||
		    ndo_grid_export(r->sc.output ? r->sc.output : "-", out)) {
			char why[300];
			snprintf(why, sizeof why, "%s: %s", r->sc.output ? r->sc.output : "standard output",
			         ndo_errdetail());
			leave(&pr, NDO_EXIT_FAIL, "%s", why);
		}
	}
	ndo_peer_stats st;
	ndo_peer_stats_get(pr.p, &st);
	if (!r->quiet)
		summary(&pr, owner || st.took_over ? "run complete" : ndo_peer_message(pr.p));
	if (st.took_over && !r->sc.output) /* what the owner's -o would have held */
		fprintf(stderr, "%s: this peer succeeded the owner and gathered the result, but has no "
		        "-o to write it to (give every joiner -o)\n", ndo_progname);
	ndo_peer_destroy(pr.p, NULL);
	ndo_watch_destroy(pr.watch);
	ndo_grid_destroy(pr.last);
	ndo_scene_free(&r->sc);
	free(r->pins);
	free(r->allpins);
	ndo_close_stdout();
	return NDO_EXIT_OK;
}
