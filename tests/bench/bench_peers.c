/* bench_peers — what splitting the surface among peers costs in accuracy,
 * in one process (the peers on an in-memory bus with a fake clock, so the
 * numbers do not depend on the machine): the thesis' figure-5.3 scene
 * against the single process.
 *
 *   bench_peers lag [-l LEVEL]       the one-step boundary lag in lock-step
 *                                    (h = 0.01, 0.005, 0.0025 s):
 *                                    error by method, step, boundary (held as
 *                                    in the thesis, or extrapolated) and peers
 *   bench_peers realtime [-l LEVEL]  realtime peers that roll back, 3 peers\n *                                    by loss and delay: difference, rollbacks,\n *                                    recomputed steps, the frames' error
 *   bench_peers split [-l LEVEL]     rkf45 and the implicit methods split
 *                                    exactly (docs/peers.md): difference
 *                                    (from a CHOLMOD single process),
 *                                    exchanges (rounds of messages) and bytes
 *                                    a step, rkf45's attempts, the solve's
 *                                    iterations with the region's block or
 *                                    the diagonal as the preconditioner
 *   bench_peers keyframes            a watch that asks for the keyframes of
 *                                    the tiles it lost a frame of, and one
 *                                    that does not (level 6, hier:1e-4, 300
 *                                    steps, 16 seeds a row): frames, bytes,
 *                                    keyframes asked for, by loss; and with
 *                                    reordering alone (docs/protocol.md,
 *                                    "Keyframe requests")
 *   bench_peers halo-bits [-l LEVEL] (level 6 unless given; the others
 *                                    default to 5) what the exact rk4 halo
 *                                    of 2 bands holds: the bits a value left after
 *                                    each prediction the receiver could
 *                                    make (docs/peers.md, "Not done")
 *   bench_peers flood [-l LEVEL]     (level 6 unless given) a receiver's
 *                                    time a message under a flood of
 *                                    valid keyframes of its smallest tile,
 *                                    a new sender id each (hier:1e-4;
 *                                    docs/protocol.md, "Keyframe requests")
 */
#include "../unit/peer_world.h"
#include "../unit/watch_stream.h"

#include "ndo/partition.h"
#include "ndo/quadtree.h"
#include "ndo/topology.h"

#include <time.h>
#include <unistd.h>

static double run_split(setup *su, int n, ndo_peer_stats *st)
{
	int ok;
	double d = split_run(su, n, st, &ok);
	return ok ? d : NAN;
}

static void lag(int level)
{
	static const char *methods[] = {"symplectic-euler", "midpoint", "rk4", "rkf45",
	                                "trapezoid"};
	/* level 6: symplectic Euler's critical step is 0.015 s, rk4's 0.021 s */
	static const double hs[] = {0.01, 0.005, 0.0025};
	printf("| method | h (s) | peers | boundary held (thesis) | boundary extrapolated |\n");
	printf("|---|---|---|---|---|\n");
	for (int m = 0; m < 5; m++)
		for (int k = 0; k < 3; k++)
			for (int n = 2; n <= 4; n += 2) {
				setup su = {.integrator = methods[m], .dt = hs[k],
				            .steps = (int64_t)(1.0 / hs[k] + 0.5),
				            .clock = NDO_CLOCK_LOCKSTEP, .peers = n, .level = level,
				            .extra = m == 3 ? "tol 1e-6" : NULL};
				ndo_peer_stats st;
				su.hold = 1;
				double held = run_split(&su, n, &st);
				su.hold = 0;
				double ext = run_split(&su, n, &st);
				printf("| %s | %g | %d | %.2e | %.2e |\n", methods[m], hs[k], n, held, ext);
				fflush(stdout);
			}
}

/* Realtime peers that roll back (docs/peers.md, "Realtime"): 3 peers, rk4
 * at 0.019 s (0.9 of its critical step at level 6), 2 s, by loss and
 * delay: the final difference, the rollbacks and recomputed steps, and
 * what the frames shown during the run (every 10 steps) differed from the
 * confirmed states, against the thesis' held boundary with the same
 * faults (no rollback). */
static void realtime(int level)
{
	/* the last: 20 ms with a halo exchange every 2 steps (38 ms) */
	static const double drops[] = {0, 0.05, 0.2}, delays[] = {0, 10, 20, 20};
	printf("| loss | delay (ms) | steps per exchange | difference | every step confirmed | rollbacks (3 peers) | "
	       "recomputed steps per step | deepest rollback (steps) | frames shown wrong | "
	       "shown error (of the largest displacement) | held boundary: difference |\n");
	printf("|---|---|---|---|---|---|---|---|---|---|---|\n");
	for (int a = 0; a < 3; a++)
		for (int b = 0; b < 4; b++) {
			setup su = {.integrator = "rk4", .dt = 0.019, .steps = 105,
			            .clock = NDO_CLOCK_REALTIME, .peers = 3, .level = level,
			            .halo_steps = b == 3 ? 2 : 1};
			su.faults = (ndo_faults){.drop = drops[a], .delay_ms = delays[b], .seed = 1};
			world *w = world_new();
			int rc = add_owner(w, &su);
			for (int i = 1; i < 3 && !rc; i++)
				rc = add_joiner(w, &su, POIS[i - 1] * (4 << (2 * level)) / 16384);
			int ok = !rc && run(w, 60) == 0;
			double *x = solo(&su);
			double d = ok ? difference(ndo_peer_grid(w->p[0]), x) : NAN;
			int64_t rolls = 0, recomputed = 0, steps = 0, depth = 0, wrong = 0, frames = 0;
			double err = 0, disp = 0;
			int confirmed = ok;
			for (int i = 0; i < w->n; i++) {
				ndo_peer_stats st;
				ndo_peer_stats_get(w->p[i], &st);
				confirmed &= st.confirmed && w->state[i] == NDO_PEER_DONE;
				rolls += st.rollbacks;
				recomputed += st.recomputed;
				steps += st.steps;
				depth = st.rollback_depth > depth ? st.rollback_depth : depth;
				wrong += st.shown_wrong;
				frames += st.shown_frames;
				err = fmax(err, st.shown_error);
				disp = fmax(disp, st.shown_disp);
			}
			free(x);
			world_free(w);
			su.hold = 1;
			ndo_peer_stats hs;
			double held = run_split(&su, 3, &hs);
			printf("| %g | %g | %d | %.2g | %s | %lld | %.2f | %lld | %lld of %lld | %.2e | %.2e |\n",
			       drops[a], delays[b], b == 3 ? 2 : 1, d, confirmed ? "yes" : "no", (long long)rolls,
			       steps ? (double)recomputed / (double)steps : 0.0, (long long)depth,
			       (long long)wrong, (long long)frames, disp > 0 ? err / disp : 0.0, held);
			fflush(stdout);
		}
}

static void split(int level)
{
	printf("| method | h (s) | peers | preconditioner | difference | exchanges a step | "
	       "halo kB a step (owner) | rkf45: attempts a step / solve: iterations a solve |\n");
	printf("|---|---|---|---|---|---|---|---|\n");
	static const char *methods[] = {"rkf45", "backward-euler", "trapezoid"};
	static const double hs[] = {0.02, 0.1};
	for (int m = 0; m < 3; m++)
		for (int k = 0; k < 2; k++)
			for (int n = 2; n <= 4; n += 2)
				for (int jac = 0; jac <= (m > 0); jac++) {
					setup su = {.integrator = methods[m], .dt = hs[k],
					            .steps = (int64_t)(1.0 / hs[k] + 0.5),
					            .clock = NDO_CLOCK_LOCKSTEP, .peers = n, .level = level,
					            .block = !jac,
					            .extra = m == 0 ? "tol 1e-6" : "solver cholmod"};
					ndo_peer_stats st;
					double d = run_split(&su, n, &st);
					double per = m ? (st.solves ? (double)st.iterations / (double)st.solves : 0)
					               : (double)st.attempts / (double)st.steps;
					printf("| %s | %g | %d | %s | %.2g | %.1f | %.1f | %.1f |\n", methods[m],
					       hs[k], n, m == 0 ? "" : jac ? "diagonal" : "region's block", d,
					       (double)st.exchanges / (double)st.steps,
					       (double)st.halo_bytes / 1e3 / (double)st.steps, per);
					fflush(stdout);
				}
}

/* The length of a lossless code of t given a prediction p: the bits of
 * |t − p| as integers (the doubles' bit patterns, which order same-signed
 * doubles) and a sign; 64 where the signs differ.  No coder's overhead. */
static int residual_bits(double t, double p)
{
	int64_t a, b;
	memcpy(&a, &t, sizeof a);
	memcpy(&b, &p, sizeof b);
	if ((a < 0) != (b < 0))
		return 64;
	const uint64_t d = a > b ? (uint64_t)(a - b) : (uint64_t)(b - a);
	return d ? 65 - __builtin_clzll(d) : 0;
}

/* halo_rings' BFS: ring[c] for canonical node c, the stencil distance
 * from the nodes of peer `from` (0 for them, −1 beyond `far`) */
static void rings_from(int level, const int32_t *own, int32_t from, int far, int *ring)
{
	const int N = 1 << level, w = 2 * N + 1, h = N + 1;
	for (int j = 0; j < h; j++)
		for (int i = 0; i < w; i++)
			ring[ndo_node(w, i, j)] = own[ndo_canonical(level, i, j)] == from ? 0 : -1;
	for (int d = 1; d <= far; d++)
		for (int j = 0; j < h; j++)
			for (int i = 0; i < w; i++) {
				const size_t c = ndo_canonical(level, i, j);
				if (c != ndo_node(w, i, j) || ring[c] != -1)
					continue;
				size_t nb[6];
				ndo_neighbors(level, i, j, nb);
				for (int q = 0; q < 6; q++)
					if (ring[ndo_canonical(level, (int)(nb[q] % (size_t)w),
					                       (int)(nb[q] / (size_t)w))] == d - 1)
						ring[c] = d;
			}
}

/* What an exact rk4 halo holds (docs/peers.md, "Not done": is the 10 kB
 * goal a matter of coding?).  Two bands; the receiver holds its own rows,
 * the sender's rings 1-2 of the step before, and the sender's rings 1-2
 * (u and v: what the halo's 12 doubles a column carry) must come out bit
 * for bit.  The predictions: the last exchange's values; their linear
 * extrapolation in time; and rk4's own step of the sender's rings 1-2,
 * from every value the receiver holds, with the rings beyond (3-4, which
 * a step of rings 1-2 reads) guessed from rings 1-2 along the grid's
 * columns — held, linear or quadratic — or (the check) given exactly. */
static void halo_bits(int level)
{
	enum { WARM = 100, STEPS = 100, NP = 6 };
	static const char *names[NP] = {
	    "the last exchange's value", "linear in time (2 last − the one before)",
	    "rk4 step, rings 3-4 held at ring 2's", "rk4 step, rings 3-4 linear across rows",
	    "rk4 step, rings 3-4 quadratic across rows", "rk4 step, rings 3-4 exact (check: 0)"};
	setup su = {.integrator = "rk4", .dt = 0.01, .steps = 1, .clock = NDO_CLOCK_LOCKSTEP,
	            .level = level};
	ndo_scene sc, sc2;
	ndo_grid *g, *g2;
	ndo_sim *sim = object(&su, &sc, &g), *scr = object(&su, &sc2, &g2);
	ndo_critical crit;
	ndo_sim_critical(sim, &crit);
	const double h = 0.9 * crit.h_crit;
	const int N = 1 << level, w = 2 * N + 1;
	const size_t n = g->count;
	int32_t *all = malloc(n * sizeof *all), *own = malloc(n * sizeof *own);
	int32_t *cells = malloc(ndo_cell_count(level) * sizeof *cells);
	int32_t used[2], ids[2] = {1, 2}, pois[2] = {-1, (int32_t)(ndo_triangle_count(level) / 2)};
	for (size_t k = 0; k < n; k++)
		all[k] = (int32_t)k;
	ndo_partition(level, NDO_PART_BANDS, 2, pois, cells, used);
	ndo_partition_node_owner(level, cells, ids, own);
	int *ring = malloc(n * sizeof *ring);
	double *s[6]; /* u, v now; u, v after the step; u, v the step before */
	for (int k = 0; k < 6; k++)
		s[k] = malloc(3 * n * sizeof **s);
	double *ug = malloc(3 * n * sizeof *ug), *vg = malloc(3 * n * sizeof *vg);
	double *up = malloc(3 * n * sizeof *up), *vp = malloc(3 * n * sizeof *vp);
	printf("Level %d, rk4 at 0.9 of its critical step (%.4g s), 2 bands; steps %d-%d of the "
	       "thesis scene; bits a value (u and v, 3 coordinates each) of rings 1 and 2, and "
	       "the kB a step that many bits make (the raw halo: 8 bytes a value).\n\n",
	       level, h, WARM + 1, WARM + STEPS);
	printf("| sender | prediction | ring 1 | ring 2 | kB a step (raw) |\n|---|---|---:|---:|---:|\n");
	for (int32_t from = 1; from <= 2; from++) {
		rings_from(level, own, from, 4, ring);
		/* the columns run away from the receiver in +j or −j */
		int dir = 0;
		for (size_t c = 0; c < n && !dir; c++)
			if (ring[c] == 1 && c / (size_t)w > 0 && c / (size_t)w < (size_t)N)
				dir = ring[ndo_canonical(level, (int)(c % (size_t)w), (int)(c / (size_t)w) - 1)] == 0
				          ? 1
				          : -1;
		ndo_sim_destroy(sim);
		ndo_grid_destroy(g);
		ndo_scene_free(&sc);
		sim = object(&su, &sc, &g);
		for (int t = 0; t < WARM; t++)
			ndo_sim_step(sim, h);
		ndo_sim_get_nodes(sim, n, all, NULL, s[4], s[5]);
		ndo_sim_step(sim, h);
		double bits[NP][2] = {{0}}, values[2] = {0};
		for (int t = 0; t < STEPS; t++) {
			ndo_sim_get_nodes(sim, n, all, NULL, s[0], s[1]);
			const double t0 = ndo_sim_time(sim);
			const int64_t k0 = ndo_sim_step_count(sim);
			ndo_sim_step(sim, h);
			ndo_sim_get_nodes(sim, n, all, NULL, s[2], s[3]);
			for (int m = 2; m < NP; m++) {
				memcpy(ug, s[0], 3 * n * sizeof *ug);
				memcpy(vg, s[1], 3 * n * sizeof *vg);
				for (size_t c = 0; m < 5 && c < n; c++) {
					if (ring[c] < 3)
						continue;
					const int i = (int)(c % (size_t)w), j = (int)(c / (size_t)w), d = ring[c];
					const size_t a2 = ndo_canonical(level, i, j - dir * (d - 2)),
					             a1 = ndo_canonical(level, i, j - dir * (d - 1)),
					             a0 = ndo_canonical(level, i, j - dir * d);
					const double e = d - 2;
					for (int q = 0; q < 6; q++) {
						const double *y = s[q / 3];
						double *gq = q < 3 ? ug : vg;
						const double y2 = y[3 * a2 + q % 3], y1 = y[3 * a1 + q % 3],
						             y0 = y[3 * a0 + q % 3];
						gq[3 * c + q % 3] = m == 2 ? y2
						                    : m == 3 ? y2 + e * (y2 - y1)
						                             : y2 + e * (y2 - y1) +
						                                   0.5 * e * (e + 1) * (y2 - 2 * y1 + y0);
					}
				}
				ndo_sim_set_displacements(scr, n, all, ug, vg);
				ndo_sim_set_time(scr, t0, k0);
				ndo_sim_step(scr, h);
				ndo_sim_get_nodes(scr, n, all, NULL, up, vp);
				for (size_t c = 0; c < n; c++)
					if (ring[c] == 1 || ring[c] == 2)
						for (int q = 0; q < 3; q++)
							bits[m][ring[c] - 1] += residual_bits(s[2][3 * c + q], up[3 * c + q]) +
							                        residual_bits(s[3][3 * c + q], vp[3 * c + q]);
			}
			for (size_t c = 0; c < n; c++)
				if (ring[c] == 1 || ring[c] == 2) {
					const int r = ring[c] - 1;
					values[r] += 6;
					for (int q = 0; q < 3; q++) {
						const size_t o = 3 * c + (size_t)q;
						bits[0][r] += residual_bits(s[2][o], s[0][o]) + residual_bits(s[3][o], s[1][o]);
						bits[1][r] += residual_bits(s[2][o], 2 * s[0][o] - s[4][o]) +
						              residual_bits(s[3][o], 2 * s[1][o] - s[5][o]);
					}
				}
			memcpy(s[4], s[0], 3 * n * sizeof **s);
			memcpy(s[5], s[1], 3 * n * sizeof **s);
		}
		for (int m = 0; m < NP; m++)
			printf("| %d | %s | %.1f | %.1f | %.2f (%.2f) |\n", from == 1 ? 2 : 1, names[m],
			       bits[m][0] / values[0], bits[m][1] / values[1],
			       (bits[m][0] + bits[m][1]) / 8e3 / STEPS, 8 * (values[0] + values[1]) / 1e3 / STEPS);
	}
	ndo_sim_destroy(sim);
	ndo_sim_destroy(scr);
	ndo_grid_destroy(g);
	ndo_grid_destroy(g2);
	ndo_scene_free(&sc);
	ndo_scene_free(&sc2);
	for (int k = 0; k < 6; k++)
		free(s[k]);
	free(ug), free(vg), free(up), free(vp), free(ring), free(all), free(own), free(cells);
}

/* One row: `seeds` streams asking and as many not, with faults f (its seed
 * 1, 2, ...), polled every dt seconds. */
static void keyframes_row(const char *what, ndo_faults f, double dt, int seeds)
{
	double fa = 0, fs = 0, bytes = 0, forced = 0, nobase[2] = {0, 0};
	int n = 0;
	for (int seed = 1; seed <= seeds; seed++) {
		f.seed = (uint64_t)seed;
		streamed a, b;
		if (stream_to_watch("hier:1e-4", &f, 1, NULL, dt, 1, &a) ||
		    stream_to_watch("hier:1e-4", &f, 0, NULL, dt, 1, &b))
			continue;
		fa += a.frames, fs += b.frames, forced += (double)a.enc.keys_forced;
		bytes += (double)a.enc.payload_bytes / (double)b.enc.payload_bytes;
		nobase[0] += (double)a.net.dropped[NDO_DROP_NOBASE];
		nobase[1] += (double)b.net.dropped[NDO_DROP_NOBASE];
		n++;
	}
	if (!n)
		return;
	printf("| %s | %.1f | %.1f | %.1f | %.1f | %.1f | %.3f |\n", what, fa / n, fs / n,
	       nobase[0] / n, nobase[1] / n, forced / n, bytes / n);
}

static void keyframes(void)
{
	enum { SEEDS = 16 };
	printf("A level-6 owner streaming hier:1e-4 to a watch, every step a frame (two tiles), "
	       "%d steps; the means over %d seeds of the faults (the same for both watches of a "
	       "seed): frames the watch gave, tiles dropped as nobase, keyframes the owner sent "
	       "because the watch asked, and the owner's payload asking over not.\n\n",
	       STREAM_STEPS, SEEDS);
	printf("| faults (the watch's link; delay 2 ms + 0-2 ms) | frames, asking | frames, not "
	       "asking | nobase, asking | nobase, not | keyframes asked for | bytes, asking / not "
	       "|\n|---|---:|---:|---:|---:|---:|---:|\n");
	const double drops[] = {0, 0.01, 0.05, 0.2};
	for (int k = 0; k < 4; k++) {
		char what[64];
		snprintf(what, sizeof what, "%g %% lost, polled every 10 ms", 100 * drops[k]);
		keyframes_row(what, (ndo_faults){.drop = drops[k], .delay_ms = 2, .jitter_ms = 2},
		              0.01, SEEDS);
	}
	/* reordered messages 13-17 ms late, polled every 2 ms: a frame waits held
	 * over several polls for its late reference */
	keyframes_row("5 % late (13-17 ms), polled every 2 ms",
	              (ndo_faults){.reorder = 0.05, .delay_ms = 2, .jitter_ms = 2}, 0.002, SEEDS);
}

static double mono_s(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* The resident set in MB (/proc/self/statm), or NaN. */
static double rss_mb(void)
{
	FILE *f = fopen("/proc/self/statm", "r");
	long pages = 0, res = -1;
	if (f) {
		if (fscanf(f, "%ld %ld", &pages, &res) != 2)
			res = -1;
		fclose(f);
	}
	return res < 0 ? NAN : (double)res * (double)sysconf(_SC_PAGESIZE) / 1048576.0;
}

static void flood(int level)
{
	enum { BATCH = 20000, BATCHES = 15 };
	ndo_grid *g;
	if (ndo_shape_make("wavy", level, NULL, &g) || ndo_grid_add(g, NDO_CH_VELOCITY, NDO_F64, 3, NULL))
		return;
	ndo_codec_params p;
	ndo_codec_parse("hier:1e-4", &p);
	ndo_codec_box(ndo_grid_f64(g, NDO_CH_POSITION, 3), g->count, p.lo, p.ext);
	ndo_codec *tx;
	uint8_t *cls = malloc(g->count);
	memset(cls, NDO_NODE_LOSSY, g->count);
	const ndo_quad q = {level + 1, 0, 0}; /* one cell */
	int i0, j0, i1, j1;
	ndo_quad_range(level, q, &i0, &j0, &i1, &j1);
	ndo_msg_tile_t t;
	memset(&t, 0, sizeof t);
	t.hdr = (ndo_msg_header_t){NDO_PROTOCOL_VERSION, 79, 5, 0, 0};
	t.depth = (int8_t)q.depth, t.i0 = i0, t.j0 = j0, t.i1 = i1, t.j1 = j1;
	t.channels = NDO_TILE_POSITION | NDO_TILE_VELOCITY;
	if (ndo_codec_create(&p, level, &tx) || ndo_codec_encode_tile(tx, 5, g, cls, q, 0, &t)) {
		fprintf(stderr, "bench_peers flood: %s\n", ndo_errdetail());
		return;
	}
	ndo_bus *bus;
	ndo_link *l, *evil;
	ndo_net *n;
	ndo_bus_create(&bus);
	ndo_link_open_mem(bus, &l);
	ndo_link_open_mem(bus, &evil);
	ndo_net_create(l, "T", 11, &n);
	ndo_net_attach(n, 79, level);
	ndo_net_set_codec(n, &p, level);
	printf("A level-%d receiver (hier:1e-4) fed keyframes of a one-cell tile (%d nodes, %d "
	       "bytes of payload), a new sender id each, in batches of %d; the time of its polls "
	       "(decode included) a message, and its resident memory.\n\n",
	       level, (i1 - i0 + 1) * (j1 - j0 + 1), t.nbytes, BATCH);
	printf("| messages | µs a message, this batch | decoded | RSS (MB) |\n|---:|---:|---:|---:|\n");
	int32_t id = 1000;
	for (int b = 0; b < BATCHES; b++) {
		double took = 0;
		for (int k = 0; k < BATCH; k++, id++) {
			t.hdr.sender_id = id;
			uint8_t *buf;
			size_t len;
			if (ndo_msg_encode(NDO_MSG_TILE, &t, &buf, &len) == 0) {
				ndo_link_publish(evil, "T_TILE", buf, len);
				free(buf);
			}
			if (k % 1000 == 999) {
				double t0 = mono_s();
				ndo_net_poll(n, 0.001 * (double)id);
				ndo_msg *tiles;
				size_t nt;
				if (ndo_net_take_tiles(n, &tiles, &nt) == 0) {
					for (size_t m = 0; m < nt; m++)
						ndo_msg_free(&tiles[m]);
					free(tiles);
				}
				took += mono_s() - t0;
			}
		}
		ndo_codec_stats st;
		ndo_codec_stats_get(ndo_net_codec(n), &st);
		printf("| %d | %.2f | %llu | %.0f |\n", (b + 1) * BATCH, 1e6 * took / BATCH,
		       (unsigned long long)st.decoded, rss_mb());
		fflush(stdout);
	}
	ndo_net_destroy(n);
	ndo_link_destroy(evil);
	ndo_bus_destroy(bus);
	ndo_codec_destroy(tx);
	free(t.data);
	free(cls);
	ndo_grid_destroy(g);
}

int main(int argc, char **argv)
{
	int level = argc > 3 && strcmp(argv[2], "-l") == 0 ? atoi(argv[3]) : 5;
	if (argc > 1 && strcmp(argv[1], "lag") == 0)
		lag(level);
	else if (argc > 1 && strcmp(argv[1], "realtime") == 0)
		realtime(level);
	else if (argc > 1 && strcmp(argv[1], "split") == 0)
		split(level);
	else if (argc > 1 && strcmp(argv[1], "keyframes") == 0)
		keyframes();
	else if (argc > 1 && strcmp(argv[1], "halo-bits") == 0)
		halo_bits(argc > 3 ? level : 6);
	else if (argc > 1 && strcmp(argv[1], "flood") == 0)
		flood(argc > 3 ? level : 6);
	else {
		fprintf(stderr, "usage: bench_peers lag|realtime|split|keyframes|halo-bits|flood "
		                "[-l LEVEL]  (LEVEL: 6 for halo-bits and flood, 5 for the others, "
		                "unless given)\n");
		return 2;
	}
	return 0;
}
