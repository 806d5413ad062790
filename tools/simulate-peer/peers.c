/* peers.c — simulate-peer as one of several peers sharing one surface
 * over LCM (thesis §4.4–4.5; docs/peers.md).  The owner sets up its object
 * as the single process does (main.c), then the library's peer
 * (ndo/peer.h) keeps the session and the simulation; this file reads the
 * options, waits on the network, writes frames, the log and the result,
 * and reports. */
#include "simulate.h"

#include "ndo/partition.h"

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
	c->partition = NDO_PART_QUADTREE;
	c->clock = NDO_CLOCK_LOCKSTEP;
	c->speed = 1;
	c->step_timeout = 0.5;
	c->peer_timeout = 2;
	c->start_timeout = 60;
	c->gather_timeout = 10;
	c->peers = 1;
}

/* Options only the owner decides; a joiner takes them from it. */
static const char *const owner_only[] = {"partition", "clock", "speed", "peers", "boundary",
                                         "step-timeout", "gather-timeout", "encoding", NULL};
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
			ndo_usage_error("--partition: '%s' is not quadtree, table41 or metis", arg);
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
		if (strcmp(arg, "hold") == 0)
			c->hold_boundary = 1;
		else if (strcmp(arg, "extrapolate") == 0)
			c->hold_boundary = 0;
		else
			ndo_usage_error("--boundary: '%s' is not extrapolate or hold", arg);
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
	} else if (strcmp(name, "fault-seed") == 0) {
		c->faults.seed = (uint64_t)ndo_opt_long(opt, arg, 0, LONG_MAX);
		c->fault_seed_set = 1;
	}
}

void peer_check(const peer_cli *c, const char *scene, const char *in, int n,
                const char *const *keys)
{
	if (!c->role) {
		if (given || c->poi >= 0 || c->lcm || c->name || c->faults.drop > 0 ||
		    c->faults.delay_ms > 0 || c->faults.jitter_ms > 0 || c->faults.reorder > 0 ||
		    c->fault_seed_set || strcmp(c->prefix, "NDO") != 0)
			ndo_usage_error("the peers' options need --owner or --join");
		return;
	}
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
	return n;
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
	ndo_grid *g = ndo_peer_grid(pr->p);
	if (ndo_mkdir_parents(path) || ndo_grid_export(path, g))
		ndo_die("%s: %s", path, ndo_errdetail());
}

/* After a step: the log row and the frame that are due. */
static void stepped(peer_run *pr)
{
	run *r = pr->r;
	int64_t k = ndo_peer_step(pr->p) - ndo_peer_first_step(pr->p);
	if (r->logging && (k % r->sc.log_every == 0 || ndo_peer_step(pr->p) == ndo_peer_final_step(pr->p)))
		log_row(r, ndo_peer_sim(pr->p), ndo_peer_step(pr->p));
	if (r->sc.frames && k % r->sc.frame_every == 0)
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
	if (role == NDO_ROLE_OWNER)
		return "owner";
	return ndo_peer_simulating(p) ? "peer" : "observer";
}

static void summary(peer_run *pr, const char *how)
{
	run *r = pr->r;
	ndo_peer *p = pr->p;
	ndo_peer_stats st;
	ndo_peer_stats_get(p, &st);
	char net[512];
	ndo_net_stats_format(ndo_session_net(ndo_peer_session(p)), net, sizeof net);
	double el = st.end_time - st.start_time;
	int np = 0;
	ndo_session_cells(ndo_peer_session(p), &np, NULL);
	clear_progress(pr);
	fprintf(stderr, "%s: %s %d done (%s): %s, %d peer%s at the end; %lld steps to step %lld "
	        "in %.3g s (computing %.3g s, waiting %.3g s in %lld steps, %lld timed out); "
	        "boundary lag %.3g steps on average, %.3g at most; %lld re-sends\n",
	        ndo_progname, role_name(p, r->net.role), ndo_session_self(ndo_peer_session(p)), how,
	        ndo_clock_name(ndo_peer_clock(p)), np, np == 1 ? "" : "s", (long long)st.steps,
	        (long long)ndo_peer_step(p), el, st.compute_seconds, st.wait_seconds,
	        (long long)st.waited, (long long)st.timeouts,
	        st.steps ? st.lag_sum / (double)st.steps : 0.0, st.lag_max, (long long)st.resends);
	if (st.ungathered)
		fprintf(stderr, "%s: %lld nodes of the output are not of the last step (their peers' "
		        "last tiles did not arrive)\n", ndo_progname, (long long)st.ungathered);
	if (st.behind)
		fprintf(stderr, "%s: %lld steps were taken late: the simulation cannot keep up with "
		        "--speed\n", ndo_progname, (long long)st.behind);
	const ndo_net_stats *ns = ndo_net_stats_get(ndo_session_net(ndo_peer_session(p)));
	fprintf(stderr, "%s: network: %s; sent %.3g MB (%.3g kB a step)\n", ndo_progname, net,
	        (double)ns->bytes_out / 1e6,
	        st.steps ? (double)ns->bytes_out / 1e3 / (double)st.steps : 0.0);
}

static __attribute__((noreturn)) void leave(peer_run *pr, int code, const char *fmt, ...)
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
	ndo_peer_destroy(pr->p, msg);
	ndo_close_stdout();
	exit(code);
}

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
		plan(r);
		if (r->info) {
			ndo_close_stdout();
			return NDO_EXIT_OK;
		}
		g = owner_object(r, &sim);
		if (c->poi >= (int64_t)ndo_triangle_count(g->level))
			ndo_usage_error("--poi: face %d is outside 0..%zu for a level-%d grid", c->poi,
			                ndo_triangle_count(g->level) - 1, g->level);
	}
	ndo_peer_opts o = {
		.session = {.role = owner ? NDO_ROLE_OWNER : NDO_ROLE_JOINER, .name = c->name,
		            .poi = c->poi, .partition = (ndo_part_method)c->partition,
		            .timeout = c->peer_timeout, .codec = &c->codec},
		.clock = c->clock, .step_timeout = c->step_timeout, .speed = c->speed,
		.peers = c->peers, .hold_boundary = c->hold_boundary,
		.start_timeout = c->start_timeout, .gather_timeout = c->gather_timeout,
		.note = on_note, .note_user = &pr};
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
			leave(&pr, EXIT_ENDED, "the session ended at step %lld: %s",
			      (long long)ndo_peer_step(pr.p), ndo_peer_message(pr.p));
		wait_for(&pr);
	}
	if (r->logging && ndo_out_commit(&r->log))
		ndo_die("%s: %s", r->sc.log, ndo_errdetail());
	r->logging = 0;
	ndo_grid *out = ndo_peer_grid(pr.p);
	if (owner || r->sc.output) {
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
	if (!r->quiet)
		summary(&pr, owner ? "run complete" : ndo_peer_message(pr.p));
	ndo_peer_destroy(pr.p, NULL);
	ndo_scene_free(&r->sc);
	free(r->pins);
	free(r->allpins);
	ndo_close_stdout();
	return NDO_EXIT_OK;
}
