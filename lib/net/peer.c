/* peer.c — a simulating peer: session + simulation + time keeping
 * (ndo/peer.h; docs/peers.md). */
#include "ndo/peer.h"
#include "ndo/scene.h"
#include "ndo/status.h"
#include "ndo/tile.h"
#include "ndo/topology.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define RESEND_MAX 0.2      /* s: the longest gap between re-sends */
#define IDLE_WAIT 0.05      /* s: the longest a caller sleeps (protocol timers) */
#define STASH_MAX 8192      /* tiles kept for later steps or partitions */

struct ndo_peer {
	ndo_peer_opts o;
	ndo_session *s;
	ndo_sim *sim;
	int owner;
	/* the run */
	char *scene;           /* owner: the description text */
	double dt, speed, step_timeout;
	ndo_clock clock;
	int hold;              /* the boundary stands still during a step */
	int peers_needed;
	int64_t first, final;
	/* the object */
	int level;
	size_t count, ncanon;
	int32_t *canon;        /* stored index → canonical index */
	int32_t *canons;       /* the canonical indices */
	int64_t *nstep;        /* per canonical node: the step of the value held,
	                          −1 unknown */
	uint8_t *mask;         /* stored nodes this peer integrates */
	int32_t *halo;         /* canonical nodes next to the region, not in it */
	size_t nhalo, nowned;
	double *hx, *hv, *xs, *vs;
	ndo_grid *prev;        /* position/velocity at prev_step (re-sends) */
	int prev_valid;
	int64_t prev_step;
	double prev_time;
	/* where this peer is */
	int announced, started, simulating, ended, done;
	int32_t epoch_done;    /* the partition the region was last made for */
	int64_t cur;
	double tcur;
	int64_t fill_step, max_seen;
	double fill_time;
	struct { int64_t step; double time; } times[64]; /* a step's time, from tiles */
	double created, wall0;
	int64_t sched0;        /* realtime: the step at wall0 */
	/* waiting and re-sending */
	int blocked;
	double block_t0, next_resend, resend_gap;
	double gather_t0;
	int notes_missed;
	/* tiles for later */
	ndo_msg_tile_t *stash;
	size_t nstash, capstash;
	int failed;
	double now;
	char message[320];
	ndo_peer_stats st;
};

const char *ndo_clock_name(ndo_clock s)
{
	return s == NDO_CLOCK_REALTIME ? "realtime" : "lockstep";
}

int ndo_clock_parse(const char *s)
{
	if (strcmp(s, "lockstep") == 0 || strcmp(s, "lock-step") == 0)
		return NDO_CLOCK_LOCKSTEP;
	if (strcmp(s, "realtime") == 0 || strcmp(s, "real-time") == 0)
		return NDO_CLOCK_REALTIME;
	return -1;
}

static void note(ndo_peer *p, const char *fmt, ...)
{
	if (!p->o.note)
		return;
	char buf[512];
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(buf, sizeof buf, fmt, ap);
	va_end(ap);
	p->o.note(p->o.note_user, buf);
}

static int32_t *owner_channel(ndo_peer *p)
{
	return ndo_grid_find(ndo_session_grid(p->s), NDO_CH_OWNER)->data;
}

/* ---- the object's arrays (once its level is known) --------------------- */
static int arrays(ndo_peer *p)
{
	if (p->canon)
		return 0;
	ndo_grid *g = ndo_session_grid(p->s);
	p->level = g->level;
	p->count = g->count;
	p->canon = malloc(p->count * sizeof *p->canon);
	p->canons = malloc(p->count * sizeof *p->canons);
	p->nstep = malloc(p->count * sizeof *p->nstep);
	p->mask = calloc(p->count, 1);
	p->halo = malloc(p->count * sizeof *p->halo);
	p->hx = malloc(3 * p->count * sizeof *p->hx);
	p->hv = malloc(3 * p->count * sizeof *p->hv);
	p->xs = malloc(3 * p->count * sizeof *p->xs);
	p->vs = malloc(3 * p->count * sizeof *p->vs);
	if (!p->canon || !p->canons || !p->nstep || !p->mask || !p->halo || !p->hx || !p->hv ||
	    !p->xs || !p->vs || ndo_grid_create(p->level, &p->prev) ||
	    ndo_grid_add(p->prev, NDO_CH_VELOCITY, NDO_F64, 3, NULL))
		return ndo__fail(NDO_ENOMEM, "out of memory");
	p->ncanon = 0;
	for (size_t k = 0; k < p->count; k++) {
		int i = (int)(k % (size_t)g->w), j = (int)(k / (size_t)g->w);
		p->canon[k] = (int32_t)ndo_canonical(p->level, i, j);
		if ((size_t)p->canon[k] == k)
			p->canons[p->ncanon++] = (int32_t)k;
		p->nstep[k] = -1;
	}
	return 0;
}

/* ---- tiles in ------------------------------------------------------------ */
/* Write a tile's values into the nodes `take` accepts. */
static void write_tile(ndo_peer *p, const ndo_msg_tile_t *t, int fill)
{
	ndo_grid *g = ndo_session_grid(p->s);
	double *x = ndo_grid_f64(g, NDO_CH_POSITION, 3), *v = ndo_grid_f64(g, NDO_CH_VELOCITY, 3);
	const int32_t *own = owner_channel(p);
	const int32_t from = t->hdr.sender_id;
	const int hasx = t->channels & NDO_TILE_POSITION, hasv = t->channels & NDO_TILE_VELOCITY;
	const int partitioned = ndo_session_cells(p->s, NULL, NULL) != NULL;
	size_t k = 0, taken = 0;
	for (int j = t->j0; j <= t->j1; j++)
		for (int i = t->i0; i <= t->i1; i++) {
			size_t node = ndo_node(g->w, i, j), c = (size_t)p->canon[node];
			int mine = own[c] == from && (partitioned || !fill);
			/* the sender's own nodes when newer; a snapshot fills what is
			 * not known otherwise (its other values are the owner's view:
			 * of no known step) */
			int take = mine ? t->step >= p->nstep[c] : fill && p->nstep[c] < 0;
			/* a decoded tile's NaN: a node it does not carry (ndo/codec.h) */
			if (hasx && isnan(t->values[k]))
				take = 0;
			if (take) {
				if (hasx)
					memcpy(x + 3 * node, &t->values[k], 3 * sizeof *x);
				if (hasv && !isnan(t->values[k + (hasx ? 3 : 0)]))
					memcpy(v + 3 * node, &t->values[k + (hasx ? 3 : 0)], 3 * sizeof *v);
				if (mine && node == c) {
					p->nstep[c] = t->step;
					taken++;
				}
			}
			k += (size_t)(hasx ? 3 : 0) + (hasv ? 3 : 0);
		}
	if (!taken) /* nothing of its sender's: says nothing about the run */
		return;
	if (t->step > p->max_seen)
		p->max_seen = t->step;
	p->times[t->step & 63].step = t->step;
	p->times[t->step & 63].time = t->time;
}

static int stash_tile(ndo_peer *p, const ndo_msg_tile_t *t)
{
	if (p->nstash == STASH_MAX) { /* drop the oldest */
		free(p->stash[0].values);
		memmove(p->stash, p->stash + 1, (p->nstash - 1) * sizeof *p->stash);
		p->nstash--;
		p->st.stale++;
	}
	if (p->nstash == p->capstash) {
		size_t cap = p->capstash ? 2 * p->capstash : 64;
		ndo_msg_tile_t *q = realloc(p->stash, cap * sizeof *q);
		if (!q)
			return NDO_ENOMEM;
		p->stash = q;
		p->capstash = cap;
	}
	if (ndo_tile_copy(t, &p->stash[p->nstash]))
		return NDO_ENOMEM;
	p->nstash++;
	p->st.stashed++;
	return 0;
}

/* Is tile t for later: of a partition this peer has not installed yet, or
 * (lock-step, running) of a step it has not reached? */
static int later(const ndo_peer *p, const ndo_msg_tile_t *t)
{
	if (t->epoch > ndo_session_epoch(p->s))
		return 1;
	return p->clock == NDO_CLOCK_LOCKSTEP && p->announced && p->simulating && t->step > p->cur;
}

/* Is `id` one of the peers of the partition in force? */
static int member(const ndo_peer *p, int32_t id)
{
	int n = 0;
	const int32_t *ids;
	if (!ndo_session_cells(p->s, &n, &ids))
		return 0;
	for (int k = 0; k < n; k++)
		if (ids[k] == id)
			return 1;
	return 0;
}

/* The session's tile_fn: every position/velocity tile of another peer. */
static void on_tile(void *user, const ndo_msg_tile_t *t, int fill)
{
	ndo_peer *p = user;
	int rc = arrays(p);
	if (rc) {
		p->failed = rc;
		return;
	}
	if (fill) {
		write_tile(p, t, 1);
		if (t->step >= p->fill_step) {
			p->fill_step = t->step;
			p->fill_time = t->time;
		}
		return;
	}
	if (t->epoch < ndo_session_epoch(p->s) ||
	    (t->epoch == ndo_session_epoch(p->s) && !member(p, t->hdr.sender_id))) {
		p->st.stale++; /* an old partition's, or from a peer outside this one */
		return;
	}
	if (later(p, t)) {
		if ((rc = stash_tile(p, t)))
			p->failed = rc;
		return;
	}
	write_tile(p, t, 0);
}

/* Use what the stash holds for now; drop what is too old. */
static void unstash(ndo_peer *p)
{
	size_t keep = 0;
	int32_t epoch = ndo_session_epoch(p->s);
	int wrote = 0;
	for (size_t k = 0; k < p->nstash; k++) {
		ndo_msg_tile_t *t = &p->stash[k];
		if (t->epoch < epoch) {
			p->st.stale++;
			free(t->values);
		} else if (!later(p, t)) {
			write_tile(p, t, 0);
			free(t->values);
			wrote = 1;
		} else {
			p->stash[keep++] = *t;
		}
	}
	p->nstash = keep;
	if (wrote)
		ndo_grid_sync(ndo_session_grid(p->s));
}

/* ---- the region ---------------------------------------------------------- */
/* Mask, halo and owned count from the owner channel. */
static int region(ndo_peer *p)
{
	ndo_grid *g = ndo_session_grid(p->s);
	const int32_t *own = owner_channel(p);
	int32_t self = ndo_session_self(p->s);
	uint8_t *was = malloc(p->count);
	if (!was)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	memcpy(was, p->mask, p->count);
	p->nowned = 0;
	for (size_t k = 0; k < p->count; k++) {
		p->mask[k] = own[p->canon[k]] == self;
		p->nowned += p->mask[k] && (size_t)p->canon[k] == k;
	}
	/* halo: the 1-ring (through the ghost map) of the region, outside it —
	 * what the 7-point stencil and the face forces read */
	uint8_t *inh = calloc(p->count, 1);
	if (!inh) {
		free(was);
		return ndo__fail(NDO_ENOMEM, "out of memory");
	}
	p->nhalo = 0;
	for (size_t q = 0; q < p->ncanon; q++) {
		size_t c = (size_t)p->canons[q];
		if (!p->mask[c])
			continue;
		size_t nb[6];
		ndo_neighbors(p->level, (int)(c % (size_t)g->w), (int)(c / (size_t)g->w), nb);
		for (int d = 0; d < 6; d++) {
			size_t h = (size_t)p->canon[nb[d]];
			if (!p->mask[h] && !inh[h]) {
				inh[h] = 1;
				p->halo[p->nhalo++] = (int32_t)h;
			}
		}
	}
	free(inh);
	/* nodes that came to this peer: the simulation takes their newest
	 * values (it held them, perhaps at older ones) */
	if (p->sim) {
		double *x = ndo_grid_f64(g, NDO_CH_POSITION, 3), *v = ndo_grid_f64(g, NDO_CH_VELOCITY, 3);
		int32_t *nodes = malloc(p->ncanon * sizeof *nodes);
		if (!nodes) {
			free(was);
			return ndo__fail(NDO_ENOMEM, "out of memory");
		}
		size_t n = 0;
		for (size_t q = 0; q < p->ncanon; q++) {
			size_t c = (size_t)p->canons[q];
			if (p->mask[c] && !was[c]) {
				memcpy(p->xs + 3 * n, x + 3 * c, 3 * sizeof *x);
				memcpy(p->vs + 3 * n, v + 3 * c, 3 * sizeof *v);
				nodes[n++] = (int32_t)c;
			}
		}
		if (n)
			ndo_sim_set(p->sim, n, nodes, p->xs, p->vs);
		free(nodes);
		ndo_sim_set_held_motion(p->sim, !p->hold);
		int rc = ndo_sim_set_active(p->sim, p->mask);
		if (rc) {
			free(was);
			return rc;
		}
	}
	free(was);
	p->simulating = p->nowned > 0;
	return 0;
}

/* ---- tiles out ----------------------------------------------------------- */
static int publish(ndo_peer *p)
{
	int rc = ndo_session_publish(p->s, p->cur, p->tcur);
	return rc < 0 ? rc : 0;
}

/* The last two steps again: a neighbour that lost one of them may be
 * waiting for it (it can be one step behind or one ahead). */
static int resend(ndo_peer *p)
{
	int rc;
	if (p->prev_valid && (rc = ndo_session_publish_from(p->s, p->prev, p->prev_step,
	                                                    p->prev_time)) < 0)
		return rc;
	p->st.resends++;
	return publish(p);
}

/* Send again when the next re-send is due (the gap doubling up to
 * RESEND_MAX): NDO_PEER_WAITING or a negative status. */
static int resend_due(ndo_peer *p)
{
	if (p->now < p->next_resend)
		return NDO_PEER_WAITING;
	int rc = resend(p);
	if (rc)
		return rc;
	p->resend_gap = fmin(2 * p->resend_gap, RESEND_MAX);
	p->next_resend = p->now + p->resend_gap;
	return NDO_PEER_WAITING;
}

/* ---- starting -------------------------------------------------------------- */
static int npeers(const ndo_peer *p)
{
	int n = 0;
	if (!ndo_session_cells(p->s, &n, NULL))
		return 0;
	return n;
}

/* A joiner reads the owner's description: physics for ndo_scene, "peer-*"
 * lines for itself. */
static int read_description(ndo_peer *p, ndo_scene *sc)
{
	const char *text = ndo_session_scene(p->s);
	size_t len = strlen(text);
	char *phys = malloc(len + 1), *copy = strdup(text);
	if (!phys || !copy) {
		free(phys), free(copy);
		return ndo__fail(NDO_ENOMEM, "out of memory");
	}
	size_t n = 0;
	int have_final = 0, rc = 0;
	char *save = NULL;
	for (char *line = strtok_r(copy, "\n", &save); line && !rc; line = strtok_r(NULL, "\n", &save)) {
		if (strncmp(line, "peer-", 5) != 0) {
			n += (size_t)sprintf(phys + n, "%s\n", line);
			continue;
		}
		char key[32];
		double val;
		if (sscanf(line, "%31s %lf", key, &val) != 2 || !isfinite(val)) {
			rc = ndo__fail(NDO_EINVAL, "the owner's description: bad line '%s'", line);
		} else if (strcmp(key, "peer-clock") == 0) {
			p->clock = val == NDO_CLOCK_REALTIME ? NDO_CLOCK_REALTIME : NDO_CLOCK_LOCKSTEP;
		} else if (strcmp(key, "peer-hold-boundary") == 0) {
			p->hold = val != 0;
		} else if (strcmp(key, "peer-step-timeout") == 0 && val > 0) {
			p->step_timeout = val;
		} else if (strcmp(key, "peer-speed") == 0 && val > 0) {
			p->speed = val;
		} else if (strcmp(key, "peer-peers") == 0 && val >= 1 && val <= NDO_MAX_PEERS) {
			p->peers_needed = (int)val;
		} else if (strcmp(key, "peer-first-step") == 0 && val >= 0 && val < 1e15) {
			p->first = (int64_t)val;
		} else if (strcmp(key, "peer-final-step") == 0 && val >= 0 && val < 1e15) {
			p->final = (int64_t)val;
			have_final = 1;
		} else {
			rc = ndo__fail(NDO_EINVAL, "the owner's description: unknown or bad '%s'", line);
		}
	}
	phys[n] = 0;
	free(copy);
	if (!rc && !have_final)
		rc = ndo__fail(NDO_EINVAL, "the owner's description names no final step "
		               "(not a simulate-peer owner?)");
	if (!rc)
		rc = ndo_scene_apply_text(sc, phys, "the owner's description");
	free(phys);
	if (!rc && sc->dt_auto)
		rc = ndo__fail(NDO_EINVAL, "the owner's description gives no step size");
	return rc;
}

/* Joiner, READY: build the simulation from the description and the grid. */
static int joiner_ready(ndo_peer *p)
{
	int rc = arrays(p);
	if (rc)
		return rc;
	ndo_scene sc;
	ndo_scene_init(&sc);
	if ((rc = read_description(p, &sc))) {
		ndo_scene_free(&sc);
		return rc;
	}
	/* the last step's tiles are exact: what the owner gathers (ndo/codec.h) */
	ndo_session_set_exact_step(p->s, p->final);
	p->dt = sc.dt;
	ndo_grid *g = ndo_session_grid(p->s);
	double *rest = ndo_grid_f64(g, NDO_CH_REST, 3);
	uint8_t *pins = calloc(g->count, 1);
	ndo_force *forces = NULL;
	if (!pins) {
		ndo_scene_free(&sc);
		return ndo__fail(NDO_ENOMEM, "out of memory");
	}
	if ((rc = ndo_scene_resolve(&sc, g->level, rest, &forces, pins)) == 0) {
		ndo_sim_params prm = sc.sim;
		prm.forces = forces;
		prm.nforces = sc.nforces;
		rc = ndo_sim_from_grid(g, &prm, &p->sim);
		ndo_scene_forces_free(forces, sc.nforces);
	}
	free(pins);
	ndo_scene_free(&sc);
	if (rc) {
		char d[400];
		snprintf(d, sizeof d, "%s", ndo_errdetail());
		return ndo__fail(rc, "the owner's object: %s", d);
	}
	return region(p);
}

/* A joiner that starts to simulate: the step its neighbours are at.
 * Lock-step: the oldest step its halo holds (a neighbour further on waits
 * for this peer; one behind would not have let the others on).  Realtime:
 * the newest.  At least the snapshot's. */
static void join_point(ndo_peer *p)
{
	int64_t at = -1;
	int newest = p->clock == NDO_CLOCK_REALTIME; /* realtime: catch up */
	for (size_t k = 0; k < p->nhalo; k++) {
		int64_t s = p->nstep[p->halo[k]];
		if (s >= 0 && (at < 0 || (newest ? s > at : s < at)))
			at = s;
	}
	if (at < p->fill_step)
		at = p->fill_step;
	p->cur = at;
	p->tcur = p->times[at & 63].step == at ? p->times[at & 63].time
	                                        : p->fill_time + (double)(at - p->fill_step) * p->dt;
	if (p->sim)
		ndo_sim_set_time(p->sim, p->tcur, p->cur);
	for (size_t q = 0; q < p->ncanon; q++)
		if (p->mask[p->canons[q]])
			p->nstep[p->canons[q]] = p->cur;
	p->wall0 = p->now;
	p->sched0 = p->cur;
	p->prev_valid = 0;
}

/* The first state: this peer's region at the step it starts from, sent
 * to the others. */
static int announce(ndo_peer *p)
{
	ndo_grid *g = ndo_session_grid(p->s);
	int rc = region(p);
	if (rc)
		return rc;
	p->epoch_done = ndo_session_epoch(p->s);
	if (p->owner) {
		if (p->sim)
			ndo_sim_set_time(p->sim, p->tcur, p->cur);
		for (size_t q = 0; q < p->ncanon; q++)
			if (p->mask[p->canons[q]])
				p->nstep[p->canons[q]] = p->cur;
	} else {
		join_point(p);
	}
	g->step = p->cur;
	g->time = p->tcur;
	p->announced = 1;
	p->resend_gap = p->o.resend;
	p->next_resend = p->now + p->resend_gap;
	return p->simulating ? publish(p) : 0;
}

/* Every node holds the run's first step: the peers' clocks start. */
static int all_at(const ndo_peer *p, int64_t step)
{
	for (size_t q = 0; q < p->ncanon; q++)
		if (p->nstep[p->canons[q]] < step)
			return 0;
	return 1;
}

static void go(ndo_peer *p)
{
	p->started = 1;
	p->st.start_time = p->now;
	p->wall0 = p->now;
	p->sched0 = p->cur;
	int np = npeers(p);
	if (p->simulating)
		note(p, "%s: step %lld, %d peer%s simulate%s, this one %zu of %zu nodes; %s to step "
		     "%lld", p->cur == p->first ? "starting" : "joining the run", (long long)p->cur, np,
		     np == 1 ? "" : "s", np == 1 ? "s" : "", p->nowned, p->ncanon,
		     ndo_clock_name(p->clock), (long long)p->final);
	else
		note(p, "observing from step %lld: %d peer%s simulate%s, %s to step %lld",
		     (long long)(p->max_seen > p->cur ? p->max_seen : p->cur), np, np == 1 ? "" : "s",
		     np == 1 ? "s" : "", ndo_clock_name(p->clock), (long long)p->final);
}

/* Before the run: announce when this peer can, start when everyone has
 * (a joiner that comes when the run is under way starts at once). */
static int starting(ndo_peer *p)
{
	double now = p->now;
	int np = npeers(p);
	if (!p->announced) {
		int ready = p->owner || (p->sim && ndo_session_ready(p->s));
		if (ready && np >= p->peers_needed) {
			int rc = announce(p);
			if (rc)
				return rc;
		}
	}
	if (p->announced) {
		int late = !p->owner && (p->max_seen > p->first || p->fill_step > p->first);
		if (late || !p->simulating || all_at(p, p->first)) {
			go(p);
			return NDO_PEER_WAITING;
		}
		int rc = resend_due(p); /* an announcement may be lost */
		if (rc < 0)
			return rc;
	}
	if (now - p->created > p->o.start_timeout) {
		if (p->owner)
			snprintf(p->message, sizeof p->message, "only %d of %d peers came within %.3g s",
			         np, p->peers_needed, p->o.start_timeout);
		else if (!p->sim)
			snprintf(p->message, sizeof p->message, "no object %s within %.3g s",
			         ndo_session_grid(p->s) ? "arrived whole" : "was described",
			         p->o.start_timeout);
		if (p->owner || !p->sim) {
			p->ended = 1;
			return NDO_PEER_ENDED;
		}
	}
	return NDO_PEER_WAITING;
}

/* ---- a step ---------------------------------------------------------------- */
static double wall(void) { return ndo_now(); }

/* Halo nodes that do not hold the value of step `cur`. */
static size_t missing(const ndo_peer *p)
{
	size_t n = 0;
	for (size_t k = 0; k < p->nhalo; k++)
		n += p->nstep[p->halo[k]] < p->cur;
	return n;
}

static int step(ndo_peer *p)
{
	ndo_grid *g = ndo_session_grid(p->s);
	double *x = ndo_grid_f64(g, NDO_CH_POSITION, 3), *v = ndo_grid_f64(g, NDO_CH_VELOCITY, 3);
	/* the held boundary: the others' values, as new as this peer has them;
	 * a value of another step (a miss, or a free-running neighbour) is
	 * carried along its velocity by at most one step unless the boundary is
	 * held.  Further, linear extrapolation overshoots the stiff modes (by
	 * |1 + i·a·hω| for a value a steps old) and a lossy realtime run blew
	 * up (docs/peers.md). */
	double age = 0;
	int64_t late = 0;
	for (size_t k = 0; k < p->nhalo; k++) {
		size_t c = (size_t)p->halo[k];
		int64_t a = p->nstep[c] < 0 ? p->cur - p->first + 1 : p->cur - p->nstep[c];
		double tau = p->hold || p->nstep[c] < 0 ? 0 : fmax(-1.0, fmin(1.0, (double)a)) * p->dt;
		for (int d = 0; d < 3; d++) {
			p->hx[3 * k + d] = x[3 * c + d] + tau * v[3 * c + d];
			p->hv[3 * k + d] = v[3 * c + d];
		}
		if (a != 0) {
			late += a > 0;
			age += fabs((double)a);
			if (fabs((double)a) > p->st.lag_max)
				p->st.lag_max = fabs((double)a);
		}
	}
	if (p->nhalo) {
		ndo_sim_set(p->sim, p->nhalo, p->halo, p->hx, p->hv);
		p->st.lag_sum += age / (double)p->nhalo;
	}
	p->st.missed += late;
	/* keep this step for re-sends */
	memcpy(ndo_grid_f64(p->prev, NDO_CH_POSITION, 3), x, 3 * p->count * sizeof *x);
	memcpy(ndo_grid_f64(p->prev, NDO_CH_VELOCITY, 3), v, 3 * p->count * sizeof *v);
	p->prev_step = p->cur;
	p->prev_time = p->tcur;
	p->prev_valid = 1;
	double t0 = wall();
	int rc = ndo_sim_step(p->sim, p->dt);
	p->st.compute_seconds += wall() - t0;
	if (rc)
		return rc;
	ndo_sim_get(p->sim, p->xs, p->vs);
	for (size_t k = 0; k < p->count; k++)
		if (p->mask[k]) {
			memcpy(x + 3 * k, p->xs + 3 * k, 3 * sizeof *x);
			memcpy(v + 3 * k, p->vs + 3 * k, 3 * sizeof *v);
		}
	p->cur++;
	p->tcur = ndo_sim_time(p->sim);
	for (size_t q = 0; q < p->ncanon; q++)
		if (p->mask[p->canons[q]])
			p->nstep[p->canons[q]] = p->cur;
	if (p->blocked)
		p->st.wait_seconds += p->now - p->block_t0;
	p->blocked = 0;
	p->st.steps++;
	p->st.end_time = p->now;
	if ((rc = publish(p)))
		return rc;
	unstash(p);
	return NDO_PEER_STEPPED;
}

/* Lock-step: step when the halo holds step `cur`; otherwise wait,
 * re-send, and after step_timeout go on. */
static int lockstep(ndo_peer *p)
{
	size_t miss = missing(p);
	if (miss == 0)
		return step(p);
	double now = p->now;
	if (!p->blocked) {
		p->blocked = 1;
		p->block_t0 = now;
		p->resend_gap = p->o.resend;
		p->next_resend = now + p->resend_gap;
		p->st.waited++;
	}
	if (now - p->block_t0 >= p->step_timeout) {
		p->st.timeouts++;
		if (p->notes_missed++ < 5) {
			const int32_t *own = owner_channel(p);
			char who[64] = "";
			int n = 0;
			for (size_t k = 0; k < p->nhalo && n < 3; k++) {
				int32_t id = own[p->halo[k]];
				if (p->nstep[p->halo[k]] < p->cur && !strstr(who, "?")) {
					char one[16];
					snprintf(one, sizeof one, "%d", id);
					if (!strstr(who, one)) {
						snprintf(who + strlen(who), sizeof who - strlen(who), "%s%s",
						         n ? ", " : "", one);
						n++;
					}
				}
			}
			note(p, "step %lld: no step %lld from peer %s for %.2g s (%zu boundary node%s): "
			     "going on with older values%s", (long long)p->cur, (long long)p->cur, who,
			     now - p->block_t0, miss, miss == 1 ? "" : "s",
			     p->notes_missed == 5 ? " (no more such messages)" : "");
		}
		return step(p);
	}
	return resend_due(p);
}

/* Realtime: step k at wall0 + (k − sched0)·dt/speed with whatever values
 * are there.  A peer that started later (its first state announced later,
 * over a lossy link) or fell behind catches up: while another peer's
 * newest step is ahead of its own it steps at once, and its schedule
 * restarts from there — so the peers keep the earliest starter's pace
 * instead of a permanent offset. */
static int realtime(ndo_peer *p)
{
	double due = p->wall0 + (double)(p->cur + 1 - p->sched0) * p->dt / p->speed;
	if (p->now >= due) {
		if (p->now > due + p->dt / p->speed)
			p->st.behind++;
		return step(p);
	}
	if (p->max_seen > p->cur) {
		int rc = step(p);
		p->wall0 = p->now;
		p->sched0 = p->cur;
		p->st.behind++;
		return rc;
	}
	return NDO_PEER_WAITING;
}

/* After the last step: the owner gathers, a joiner keeps its last steps
 * available until the owner ends the session. */
static int finishing(ndo_peer *p)
{
	double now = p->now;
	if (p->gather_t0 < 0) {
		p->gather_t0 = now;
		p->resend_gap = p->o.resend;
		p->next_resend = now + p->resend_gap;
	}
	if (p->owner) {
		size_t behind = 0;
		for (size_t q = 0; q < p->ncanon; q++)
			behind += p->nstep[p->canons[q]] < p->final;
		if (behind == 0 || now - p->gather_t0 >= p->o.gather_timeout) {
			p->st.ungathered = (int64_t)behind;
			if (behind)
				note(p, "step %lld: %zu nodes of the others did not arrive within %.3g s: "
				     "the output holds their newest values", (long long)p->final, behind,
				     p->o.gather_timeout);
			p->done = 1;
			return NDO_PEER_DONE;
		}
	}
	return p->simulating ? resend_due(p) : NDO_PEER_WAITING;
}

/* ---- events ------------------------------------------------------------------ */
static int on_partition(ndo_peer *p)
{
	if (!p->canon || (!p->owner && !p->sim))
		return 0; /* the region is made at the start */
	if (ndo_session_epoch(p->s) == p->epoch_done)
		return 0; /* several events, one partition in force */
	p->epoch_done = ndo_session_epoch(p->s);
	size_t before = p->nowned;
	int was = p->simulating;
	int rc = region(p);
	if (rc)
		return rc;
	int np = npeers(p);
	if (p->announced && !was && p->simulating && !p->owner && p->cur < p->final) {
		join_point(p);
		note(p, "simulating from step %lld: %zu of %zu nodes (partition %d, %d peers)",
		     (long long)p->cur, p->nowned, p->ncanon, ndo_session_epoch(p->s), np);
		return publish(p);
	}
	if (p->announced) {
		if (p->started) {
			p->st.repartitions++;
			note(p, "partition %d at step %lld: %d peer%s, this one %zu nodes (was %zu)",
			     ndo_session_epoch(p->s), (long long)p->cur, np, np == 1 ? "" : "s",
			     p->nowned, before);
		}
		for (size_t q = 0; q < p->ncanon; q++)
			if (p->mask[p->canons[q]] && p->nstep[p->canons[q]] < p->cur)
				p->nstep[p->canons[q]] = p->cur;
		unstash(p);
		p->blocked = 0;
		if (p->simulating)
			return publish(p);
	}
	return 0;
}

static int events(ndo_peer *p)
{
	ndo_event e;
	int rc = 0;
	while (!rc && ndo_session_event(p->s, &e)) {
		switch (e.type) {
		case NDO_EV_READY:
			if (!p->owner) {
				rc = joiner_ready(p);
				note(p, "joined object %llx (owner %d): level %d, %s",
				     (unsigned long long)ndo_session_object(p->s), ndo_session_owner_id(p->s),
				     p->level, ndo_clock_name(p->clock));
			}
			break;
		case NDO_EV_PARTITION: rc = on_partition(p); break;
		case NDO_EV_JOINED: note(p, "peer %d joined", e.peer); break;
		case NDO_EV_LEFT:
			note(p, "peer %d left%s%s", e.peer, *e.message ? ": " : "", e.message);
			break;
		case NDO_EV_ENDED:
			p->ended = 1;
			snprintf(p->message, sizeof p->message, "%s", e.message);
			break;
		default: break;
		}
	}
	return rc;
}

/* ---- the public calls ----------------------------------------------------------- */
int ndo_peer_update(ndo_peer *p, double now)
{
	ndo__clear_error();
	p->now = now;
	if (p->created < 0)
		p->created = now;
	if (p->done)
		return NDO_PEER_DONE;
	if (p->ended)
		return NDO_PEER_ENDED;
	int rc = ndo_session_update(p->s, now);
	if (rc < 0)
		return rc;
	if (p->failed)
		return ndo__fail(p->failed, "out of memory");
	if ((rc = events(p)))
		return rc;
	if (p->ended) {
		int complete = p->started && (p->simulating ? p->cur >= p->final : p->max_seen >= p->final);
		if (complete) {
			p->done = 1;
			return NDO_PEER_DONE;
		}
		return NDO_PEER_ENDED;
	}
	if (!p->started)
		return starting(p);
	if (p->cur >= p->final)
		return finishing(p);
	if (!p->simulating)
		return NDO_PEER_WAITING;
	return p->clock == NDO_CLOCK_REALTIME ? realtime(p) : lockstep(p);
}

double ndo_peer_deadline(const ndo_peer *p)
{
	double now = p->now, d = now + IDLE_WAIT;
	if (p->done || p->ended || !p->started)
		return d;
	if (p->cur >= p->final) {
		if (p->owner)
			d = fmin(d, p->gather_t0 + p->o.gather_timeout);
		return p->simulating ? fmin(d, p->next_resend) : d;
	}
	if (!p->simulating)
		return d;
	if (p->clock == NDO_CLOCK_REALTIME)
		return p->max_seen > p->cur ? now
		                            : fmin(d, p->wall0 + (double)(p->cur + 1 - p->sched0) *
		                                                     p->dt / p->speed);
	if (!p->blocked)
		return now; /* it may step: ask again at once */
	return fmin(d, fmin(p->next_resend, p->block_t0 + p->step_timeout));
}

int ndo_peer_create(const ndo_peer_opts *o, ndo_net *net, ndo_grid *grid, ndo_sim *sim,
                    const ndo_peer_run *run, ndo_peer **out)
{
	ndo__clear_error();
	int owner = o->session.role == NDO_ROLE_OWNER;
	ndo_peer *p = calloc(1, sizeof *p);
	if (!p || (owner && (!grid || !sim || !run || !(run->dt > 0) || run->steps < 0)) ||
	    (!owner && (grid || sim || run))) {
		ndo_net_destroy(net);
		ndo_grid_destroy(grid);
		ndo_sim_destroy(sim);
		free(p);
		return p ? ndo__fail(NDO_EINVAL, "peer: an owner needs a grid, its simulation and "
		                     "a run; a joiner none") : ndo__fail(NDO_ENOMEM, "out of memory");
	}
	p->o = *o;
	if (!(p->o.step_timeout > 0)) p->o.step_timeout = 0.5;
	if (!(p->o.speed > 0)) p->o.speed = 1;
	if (!(p->o.start_timeout > 0)) p->o.start_timeout = 60;
	if (!(p->o.resend > 0)) p->o.resend = 0.01;
	if (!(p->o.gather_timeout > 0)) p->o.gather_timeout = 10;
	p->owner = owner;
	p->clock = o->clock ? o->clock : NDO_CLOCK_LOCKSTEP;
	p->step_timeout = p->o.step_timeout;
	p->hold = o->hold_boundary != 0;
	p->speed = p->o.speed;
	p->peers_needed = o->peers > 1 ? o->peers : 1;
	p->sim = sim;
	p->gather_t0 = -1;
	p->fill_step = -1;
	p->max_seen = -1;
	p->created = -1;
	ndo_session_opts so = o->session;
	if (!(so.retry > 0))
		so.retry = 0.25; /* a joiner asks again soon: the snapshot is many tiles */
	so.tile_fn = on_tile;
	so.tile_user = p;
	if (owner) {
		p->dt = run->dt;
		p->cur = p->first = grid->step;
		p->tcur = grid->time;
		p->final = grid->step + run->steps;
		char peer_lines[320];
		snprintf(peer_lines, sizeof peer_lines,
		         "dt %.17g\nsteps %lld\npeer-clock %d\npeer-hold-boundary %d\n"
		         "peer-step-timeout %.17g\n"
		         "peer-speed %.17g\npeer-peers %d\npeer-first-step %lld\n"
		         "peer-final-step %lld\n",
		         run->dt, (long long)run->steps, (int)p->clock, p->hold, p->step_timeout, p->speed,
		         p->peers_needed, (long long)p->first, (long long)p->final);
		size_t len = strlen(run->physics) + strlen(peer_lines) + 1;
		if (len > NDO_MAX_SCENE + 1) {
			ndo_net_destroy(net);
			ndo_grid_destroy(grid);
			ndo_peer_destroy(p, NULL);
			return ndo__fail(NDO_ERANGE, "the physics settings take %zu bytes; a description "
			                 "holds %d", len - 1, NDO_MAX_SCENE);
		}
		p->scene = malloc(len);
		if (!p->scene) {
			ndo_net_destroy(net);
			ndo_grid_destroy(grid);
			ndo_peer_destroy(p, NULL);
			return ndo__fail(NDO_ENOMEM, "out of memory");
		}
		snprintf(p->scene, len, "%s%s", run->physics, peer_lines);
		so.scene = p->scene;
	}
	int rc = ndo_session_create(&so, net, grid, &p->s);
	if (rc) {
		p->s = NULL;
		ndo_peer_destroy(p, NULL);
		return rc;
	}
	if (owner)
		ndo_session_set_exact_step(p->s, p->final);
	if (owner && ((rc = arrays(p)) || (rc = region(p)))) {
		ndo_peer_destroy(p, NULL);
		return rc;
	}
	*out = p;
	return 0;
}

void ndo_peer_destroy(ndo_peer *p, const char *message)
{
	if (!p)
		return;
	if (p->s) {
		char msg[128];
		if (!message && p->owner && p->done)
			snprintf(msg, sizeof msg, "run complete at step %lld", (long long)p->final);
		else
			snprintf(msg, sizeof msg, "%s", message ? message : "");
		ndo_session_destroy(p->s, msg);
	}
	ndo_sim_destroy(p->sim);
	ndo_grid_destroy(p->prev);
	for (size_t k = 0; k < p->nstash; k++)
		free(p->stash[k].values);
	free(p->stash);
	free(p->scene);
	free(p->canon), free(p->canons), free(p->nstep), free(p->mask), free(p->halo);
	free(p->hx), free(p->hv), free(p->xs), free(p->vs);
	free(p);
}

ndo_grid *ndo_peer_grid(ndo_peer *p) { return ndo_session_grid(p->s); }
ndo_sim *ndo_peer_sim(ndo_peer *p) { return p->sim; }
ndo_session *ndo_peer_session(ndo_peer *p) { return p->s; }
int64_t ndo_peer_step(const ndo_peer *p) { return p->cur; }
int64_t ndo_peer_first_step(const ndo_peer *p) { return p->first; }
int64_t ndo_peer_final_step(const ndo_peer *p) { return p->final; }
double ndo_peer_dt(const ndo_peer *p) { return p->dt; }
ndo_clock ndo_peer_clock(const ndo_peer *p) { return p->clock; }
const char *ndo_peer_message(const ndo_peer *p) { return p->message; }
int ndo_peer_simulating(const ndo_peer *p) { return p->simulating; }
int ndo_peer_started(const ndo_peer *p) { return p->started; }
void ndo_peer_stats_get(const ndo_peer *p, ndo_peer_stats *st) { *st = p->st; }
