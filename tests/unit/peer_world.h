/* peer_world.h — simulating peers in one process, for test_peer and
 * bench_peers: an owner and joiners on an in-memory bus (ndo/link.h) with
 * a fake clock, running the thesis' figure-5.3 scene on the wavy surface,
 * and the single-process run of the same scene to compare with. */
#ifndef NDO_TEST_PEER_WORLD_H
#define NDO_TEST_PEER_WORLD_H

#include "ndo/ndo.h"
#include "ndo/peer.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define TICK 0.001 /* s of fake time per round */

typedef struct world {
	ndo_bus *bus;
	ndo_peer *p[8];
	int state[8];
	ndo_link *link[8]; /* each peer's in-memory link (owned by its net) */
	int deaf[8];       /* this peer loses everything sent to it (ndo_link_mem_lose) */
	int64_t last_step[8];
	double step_at[8]; /* when its step last changed (fake time) */
	double done_at[8]; /* when it was first DONE (0: not yet) */
	int n;
	double t;
	/* notes, for the timing tests */
	char last_note[8][512];
	double note_at[8];
} world;

typedef struct setup {
	const char *integrator;
	double dt;
	int64_t steps;
	ndo_clock clock;
	int peers;
	ndo_faults faults; /* on every peer's receiving side when drop > 0 */
	double step_timeout;
	int level;         /* 0: 4 */
	int hold;          /* the thesis' held boundary */
	int halo_steps;    /* steps per halo exchange (0: 1) */
	int publish_every; /* whole regions every N steps (0: the default) */
	const char *extra; /* another scene line ("tol 1e-6"), or NULL */
	int block;         /* the implicit methods' solve preconditioned with each
	                      region's block (ndo_peer_opts.block) */
	double *keep;      /* split_run: the owner's positions at the end, 3 × the
	                      grid's nodes, or NULL */
	int checkpoint_every; /* ndo_peer_opts.checkpoint_every (0: the default) */
	int bands;         /* --partition bands (0: the quad-tree) */
} setup;

static int level_of(const setup *su) { return su->level ? su->level : 4; }

static world *W; /* for the note callback */
static void (*on_tick)(world *w); /* called every round, when set */
static int leave_lost = -1;        /* this peer, done, leaves unheard (its LEAVEs lost) */

static void on_note(void *user, const char *msg)
{
	int i = (int)(intptr_t)user;
	snprintf(W->last_note[i], sizeof W->last_note[i], "%s", msg);
	W->note_at[i] = W->t;
	if (getenv("TEST_PEER_VERBOSE"))
		printf("    [%.3f] peer %d: %s\n", W->t, i, msg);
}

static void scene(ndo_scene *sc, const setup *su)
{
	ndo_scene_init(sc);
	char dt[32], steps[32];
	snprintf(dt, sizeof dt, "%.17g", su->dt);
	snprintf(steps, sizeof steps, "%lld", (long long)su->steps);
	/* thesis figure 5.3: k = 1 N/m, b = 0.1, 2.4 N at 1 Hz near the pole */
	const char *kv[][2] = {{"stiffness", "1"}, {"damping", "0.1"},
	                       {"integrator", su->integrator}, {"dt", dt}, {"steps", steps},
	                       {"force", "face at=0,0,1 radius=0.3 amplitude=2.4 frequency=1"}};
	for (size_t k = 0; k < sizeof kv / sizeof *kv; k++)
		if (ndo_scene_set(sc, kv[k][0], kv[k][1]))
			printf("scene: %s\n", ndo_errdetail());
	if (su->extra && ndo_scene_apply_text(sc, su->extra, "extra"))
		printf("scene: %s\n", ndo_errdetail());
}

/* The object and its simulation, as simulate-peer's owner makes them. */
static ndo_sim *object(const setup *su, ndo_scene *sc, ndo_grid **out)
{
	ndo_grid *g;
	ndo_shape_make("wavy", level_of(su), NULL, &g);
	scene(sc, su);
	double *x = ndo_grid_f64(g, NDO_CH_POSITION, 3);
	uint8_t *pin = calloc(g->count, 1);
	ndo_force *forces;
	ndo_scene_resolve(sc, level_of(su), x, &forces, pin);
	ndo_sim_params prm = sc->sim;
	prm.forces = forces;
	prm.nforces = sc->nforces;
	ndo_sim *sim = NULL;
	ndo_sim_create(level_of(su), x, NULL, x, pin, &prm, &sim);
	ndo_scene_forces_free(forces, sc->nforces);
	ndo_sim_store(sim, g);
	ndo_channel *pc;
	ndo_grid_add(g, NDO_CH_PIN, NDO_U8, 1, &pc);
	memcpy(pc->data, pin, g->count);
	free(pin);
	*out = g;
	return sim;
}

/* The single-process run: positions after su->steps steps. */
static double *solo(const setup *su)
{
	ndo_scene sc;
	ndo_grid *g;
	ndo_sim *sim = object(su, &sc, &g);
	for (int64_t k = 0; k < su->steps; k++)
		ndo_sim_step(sim, su->dt);
	double *x = malloc(3 * g->count * sizeof *x);
	ndo_sim_get(sim, x, NULL);
	ndo_sim_destroy(sim);
	ndo_grid_destroy(g);
	ndo_scene_free(&sc);
	return x;
}

static ndo_net *net(world *w, int32_t id, const setup *su, int index)
{
	ndo_link *l;
	ndo_net *n;
	if (ndo_link_open_mem(w->bus, &l))
		return NULL;
	w->link[index] = l;
	if (su->faults.drop > 0 || su->faults.delay_ms > 0) {
		ndo_faults f = su->faults;
		f.seed += (uint64_t)index * 7919;
		if (ndo_link_faults(l, &f, &l))
			return NULL;
	}
	return ndo_net_create(l, "T", id, &n) ? NULL : n;
}

static ndo_peer_opts opts(ndo_role role, int32_t id, int32_t poi, const setup *su, int index)
{
	ndo_peer_opts o = {.session = {.role = role, .poi = poi, .self_id = id,
	                               .object_id = role == NDO_ROLE_OWNER ? 77 : 0,
	                               .heartbeat = 0.1, .timeout = 1.0, .retry = 0.3},
	                   .clock = su->clock, .peers = su->peers, .hold_boundary = su->hold,
	                   .halo_steps = su->halo_steps, .publish_every = su->publish_every,
	                   .step_timeout = su->step_timeout, .block = su->block,
	                   .checkpoint_every = su->checkpoint_every, .note = on_note,
	                   .note_user = (void *)(intptr_t)index};
	if (su->bands)
		o.session.partition = NDO_PART_BANDS;
	return o;
}

static int add_owner(world *w, const setup *su)
{
	ndo_scene sc;
	ndo_grid *g;
	ndo_sim *sim = object(su, &sc, &g);
	ndo_peer_run run = {ndo_scene_physics(&sc), su->dt, su->steps};
	ndo_peer_opts o = opts(NDO_ROLE_OWNER, 1, -1, su, w->n);
	int rc = ndo_peer_create(&o, net(w, 1, su, w->n), g, sim, &run, &w->p[w->n]);
	ndo_scene_free(&sc);
	if (rc)
		return rc;
	w->n++;
	return 0;
}

static int add_joiner(world *w, const setup *su, int32_t poi)
{
	int32_t id = 10 + w->n;
	ndo_peer_opts o = opts(NDO_ROLE_JOINER, id, poi, su, w->n);
	int rc = ndo_peer_create(&o, net(w, id, su, w->n), NULL, NULL, NULL, &w->p[w->n]);
	if (rc)
		return rc;
	w->n++;
	return 0;
}

/* Run rounds until every live peer is DONE or ENDED, or `until` (fake
 * seconds).  A peer whose slot is NULL is dead (silent). */
static int run(world *w, double until)
{
	for (; w->t < until; w->t += TICK) {
		int busy = 0;
		for (int i = 0; i < w->n; i++) {
			if (!w->p[i] || w->state[i] == NDO_PEER_DONE || w->state[i] == NDO_PEER_ENDED)
				continue;
			if (w->deaf[i])
				ndo_link_mem_lose(w->link[i]);
			/* at most one step per peer per round: a step takes a tick */
			int r = ndo_peer_update(w->p[i], w->t);
			if (r < 0) {
				printf("    peer %d: status %d: %s\n", i, r, ndo_errdetail());
				return r;
			}
			w->state[i] = r;
			if (ndo_peer_step(w->p[i]) != w->last_step[i]) {
				w->last_step[i] = ndo_peer_step(w->p[i]);
				w->step_at[i] = w->t;
			}
			if (r == NDO_PEER_DONE && w->done_at[i] == 0)
				w->done_at[i] = w->t;
			/* done: it leaves, as simulate-peer does once its -o is written
			 * (the owner ends the session for everyone) */
			if (r == NDO_PEER_DONE && i != leave_lost)
				ndo_peer_leave(w->p[i], NULL);
			busy |= r != NDO_PEER_DONE && r != NDO_PEER_ENDED;
		}
		if (on_tick)
			on_tick(w);
		if (!busy)
			return 0;
	}
	return 1;
}

/* Largest position difference to x, relative to the largest displacement
 * of x from the rest shape. */
static double difference(ndo_grid *g, const double *x)
{
	const double *y = ndo_grid_f64(g, NDO_CH_POSITION, 3), *r = ndo_grid_f64(g, NDO_CH_REST, 3);
	double d = 0, m = 0;
	for (size_t k = 0; k < 3 * g->count; k++) {
		d = fmax(d, fabs(y[k] - x[k]));
		m = fmax(m, fabs(x[k] - r[k]));
	}
	return d / m;
}

static void world_free(world *w)
{
	for (int i = 0; i < w->n; i++)
		ndo_peer_destroy(w->p[i], NULL);
	ndo_bus_destroy(w->bus);
	free(w);
}

static world *world_new(void)
{
	world *w = calloc(1, sizeof *w);
	ndo_bus_create(&w->bus);
	W = w;
	return w;
}

static const int32_t POIS[] = {100, 400, 700, 1000, 250, 550, 850};

/* n peers from the start, to the end; the owner's grid against solo. */
static double split_run(const setup *su, int n, ndo_peer_stats *owner_stats, int *ok)
{
	world *w = world_new();
	int rc = add_owner(w, su);
	for (int i = 1; i < n && !rc; i++)
		rc = add_joiner(w, su, POIS[i - 1]);
	*ok = !rc && run(w, 60) == 0;
	for (int i = 0; i < w->n && *ok; i++)
		if (w->state[i] != NDO_PEER_DONE) {
			printf("    peer %d ended in state %d: %s\n", i, w->state[i],
			       ndo_peer_message(w->p[i]));
			*ok = 0;
		}
	double *x = solo(su);
	ndo_grid *g = ndo_peer_grid(w->p[0]);
	double d = difference(g, x);
	if (su->keep)
		memcpy(su->keep, ndo_grid_f64(g, NDO_CH_POSITION, 3), 3 * g->count * sizeof(double));
	ndo_peer_stats_get(w->p[0], owner_stats);
	int np = 0;
	ndo_session_cells(ndo_peer_session(w->p[0]), &np, NULL);
	if (np != n) {
		printf("    %d peers simulated, not %d\n", np, n);
		*ok = 0;
	}
	free(x);
	world_free(w);
	return d;
}

#endif
