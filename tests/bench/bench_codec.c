/* bench_codec — the tile encodings alone (ndo/codec.h), in one process, on
 * the thesis' scene (figure 5.3: the wavy surface, k = 1 N/m, b = 0.1,
 * 2.4 N at 1 Hz near the pole, rk4 at 0.9 x its critical step, as
 * net-bench runs it): every step of the run, the sender's tiles are
 * encoded as the session does (one quad-tree depth coarser than a raw
 * tile, its region's cover) and decoded by a receiver, which must
 * reconstruct exactly what the encoder says it will.
 *
 *   bench_codec [-l LEVEL] [-e ENCODING] [-p PEERS] [-t SECONDS | -n STEPS] [-z ZSTD_LEVEL]
 *               [-v 1|2] [-d DUMP_FILE]    (-h: this usage; an unknown option: it, exit 2)
 *
 * Prints one line: payload bits per node per update (over W x H nodes,
 * the thesis' count; without message headers), the share of the EXACT
 * nodes' bytes, median encode and decode ms per step (the sender's whole
 * region), the largest position error over the box's diagonal.  Times:
 * the codec's workspace warm (kept from step to step, as in a session);
 * the decoder mallocs each tile's values (ndo_codec_decode_tile()).
 * With -v 1 and hier, where the bits go: per level group, the nodes, the
 * share of them with every residual 0, the values' zero share and the
 * ideal bits (the range coder's model) of the node flags, zero flags and
 * nonzero values, then the slope shares' bits and the rest (headers,
 * classes, the coder's own overhead).  With -v 2 and hier, where the time
 * goes (the means over the steps of the ms of each phase per level, wall clock;
 * apart from -v 1, whose ideal costs take time themselves). */
#include "ndo/ndo.h"
#include "ndo/codec.h"
#include "ndo/partition.h"
#include "ndo/quadtree.h"
#include "codec_private.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <zlib.h>

static double now(void)
{
	struct timespec t;
	clock_gettime(CLOCK_MONOTONIC, &t);
	return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* this thread's CPU time: what the codec costs, apart from the waits of
 * a shared machine (the wall-clock medians are printed too) */
static double cpu(void)
{
	struct timespec t;
	clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
	return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static int cmp(const void *a, const void *b)
{
	double x = *(const double *)a, y = *(const double *)b;
	return x < y ? -1 : x > y;
}

static double median(double *v, size_t n)
{
	qsort(v, n, sizeof *v, cmp);
	return n ? v[n / 2] : NAN;
}

static const char scene_text[] = /* tools/net-bench/bench.c */
	"stiffness 1\ndensity 1\ndamping 0.1\nintegrator rk4\ndt auto\n"
	"force face at=0,0,1 radius=0.2 amplitude=2.4 frequency=1\n";

int main(int argc, char **argv)
{
	int level = 6, peers = 1;
	double seconds = 5;
	long long nsteps = 0;
	const char *spec = "predict", *dump = NULL;
	static const char usage[] =
	    "usage: bench_codec [-l LEVEL] [-e ENCODING] [-p PEERS] [-t SECONDS | -n STEPS]\n"
	    "                   [-z ZSTD_LEVEL] [-v 1|2] [-d DUMP_FILE]\n";
	for (int a = 1; a < argc; a += 2) {
		const char *o = argv[a];
		int known = o[0] == '-' && o[1] && !o[2] && strchr("lepdvtnz", o[1]);
		if (!known || a + 1 >= argc) {
			int help = !strcmp(o, "-h") || !strcmp(o, "--help");
			if (!help)
				fprintf(stderr, "bench_codec: '%s': %s\n", o,
				        known ? "an option without its value" : "not an option");
			fputs(usage, help ? stdout : stderr);
			return help ? 0 : 2;
		}
		if (!strcmp(argv[a], "-l"))
			level = atoi(argv[a + 1]);
		else if (!strcmp(argv[a], "-e"))
			spec = argv[a + 1];
		else if (!strcmp(argv[a], "-p"))
			peers = atoi(argv[a + 1]);
		else if (!strcmp(argv[a], "-d")) /* every step's positions, f64, to a file */
			dump = argv[a + 1];
		else if (!strcmp(argv[a], "-v") && atoi(argv[a + 1]) == 2) {
			static hier_times ht;
			ndo__codec_hier_times = &ht;
		} else if (!strcmp(argv[a], "-v") && atoi(argv[a + 1]) > 0) {
			static hier_stats hs;
			ndo__codec_hier_stats = &hs;
		} else if (!strcmp(argv[a], "-t"))
			seconds = atof(argv[a + 1]);
		else if (!strcmp(argv[a], "-n")) /* steps, at the auto step (instead of -t) */
			nsteps = atoll(argv[a + 1]);
		else if (!strcmp(argv[a], "-z")) { /* zstd's level (lib/net/codec_entropy.c) */
			extern int ndo__codec_zstd_level;
			ndo__codec_zstd_level = atoi(argv[a + 1]);
		}
	}
	ndo_codec_params p;
	if (ndo_codec_parse(spec, &p)) {
		fprintf(stderr, "bench_codec: %s\n", ndo_errdetail());
		return 2;
	}
	/* the object and its simulation */
	ndo_grid *g;
	ndo_scene sc;
	ndo_sim *sim = NULL;
	ndo_shape_make("wavy", level, NULL, &g);
	ndo_scene_init(&sc);
	ndo_scene_apply_text(&sc, scene_text, "scene");
	double *x = ndo_grid_f64(g, NDO_CH_POSITION, 3);
	uint8_t *pin = calloc(g->count, 1);
	ndo_force *forces;
	ndo_scene_resolve(&sc, level, x, &forces, pin);
	ndo_sim_params prm = sc.sim;
	prm.forces = forces;
	prm.nforces = sc.nforces;
	if (ndo_sim_create(level, x, NULL, x, pin, &prm, &sim)) {
		fprintf(stderr, "bench_codec: %s\n", ndo_errdetail());
		return 1;
	}
	ndo_critical crit;
	ndo_sim_critical(sim, &crit);
	double h = sc.dt_safety * crit.h_crit;
	int64_t steps = (int64_t)ceil(seconds / h - 1e-9);
	if (nsteps > 0)
		steps = nsteps;
	else
		h = seconds / (double)steps;
	ndo_grid_add(g, NDO_CH_VELOCITY, NDO_F64, 3, NULL);
	ndo_sim_store(sim, g);
	x = ndo_grid_f64(g, NDO_CH_POSITION, 3);
	double *v = ndo_grid_f64(g, NDO_CH_VELOCITY, 3);
	ndo_codec_box(x, g->count, p.lo, p.ext);
	double diag = ndo_codec_diagonal(&p);
	/* the partition (points of interest as net-bench spreads them) and
	 * sender 1's classes and tiles */
	int32_t *cells = malloc(ndo_cell_count(level) * sizeof *cells), used[8], ids[8], pois[8];
	int32_t *own = malloc(g->count * sizeof *own);
	const double frac[8] = {0, 0.55, 0.3, 0.8, 0.15, 0.65, 0.4, 0.9};
	for (int k = 0; k < peers; k++)
		ids[k] = k + 1, pois[k] = k ? (int32_t)(frac[k] * (double)ndo_triangle_count(level)) : -1;
	ndo_partition(level, NDO_PART_QUADTREE, peers, pois, cells, used);
	ndo_partition_node_owner(level, cells, ids, own);
	uint8_t *cls = malloc(g->count);
	size_t nexact = ndo_codec_classify(level, own, 1, cls);
	int depth = ndo_tile_depth(level, NDO_TILE_POSITION | NDO_TILE_VELOCITY, "NDO_TILE");
	depth = depth > 0 ? depth - 1 : 0;
	int32_t *codes;
	size_t ntiles;
	ndo_quad_cover(level, cells, 0, depth, 0.5, &codes, &ntiles);
	ndo_codec *enc, *dec;
	ndo_codec_create(&p, level, &enc);
	ndo_codec_create(&p, level, &dec);
	double *te = malloc((size_t)steps * sizeof *te), *td = malloc((size_t)steps * sizeof *td);
	double *ce = malloc((size_t)steps * sizeof *ce), *cd = malloc((size_t)steps * sizeof *cd);
	uint64_t bytes = 0, exact_bytes = 0;
	unsigned long crc = crc32(0, Z_NULL, 0); /* every payload, in order: "same bytes" checks */
	double maxerr = 0;
	int bad = 0;
	FILE *df = dump ? fopen(dump, "wb") : NULL;
	for (int64_t s = 0; s < steps && !bad; s++) {
		if (s > 0 && ndo_sim_step(sim, h)) {
			fprintf(stderr, "bench_codec: %s\n", ndo_errdetail());
			return 1;
		}
		ndo_sim_get(sim, x, v);
		if (df)
			fwrite(x, sizeof *x, 3 * g->count, df);
		double enc_t = 0, dec_t = 0, enc_c = 0, dec_c = 0;
		for (size_t q = 0; q < ntiles; q++) {
			ndo_quad qd;
			ndo_quad_decode(level, codes[q], &qd);
			ndo_msg_tile_t t;
			memset(&t, 0, sizeof t);
			int i0, j0, i1, j1;
			ndo_quad_range(level, qd, &i0, &j0, &i1, &j1);
			t.hdr.sender_id = 1;
			t.depth = (int8_t)qd.depth;
			t.i0 = i0, t.j0 = j0, t.i1 = i1, t.j1 = j1;
			t.channels = NDO_TILE_POSITION | NDO_TILE_VELOCITY;
			t.step = s;
			t.time = (double)s * h;
			double t0 = now(), c0 = cpu();
			int rc = ndo_codec_encode_tile(enc, 1, g, cls, qd, 0, &t);
			double t1 = now();
			enc_t += t1 - t0;
			enc_c += cpu() - c0;
			if (rc == 1)
				continue; /* unchanged: not sent */
			if (rc) {
				fprintf(stderr, "bench_codec: encode: %s\n", ndo_errdetail());
				return 1;
			}
			bytes += (uint64_t)t.nbytes;
			if (t.nbytes > 0)
				crc = crc32(crc, t.data, (uInt)t.nbytes);
			t0 = now(), c0 = cpu();
			ndo_drop r = ndo_codec_decode_tile(dec, &t);
			dec_t += now() - t0;
			dec_c += cpu() - c0;
			if (r != NDO_DROP_NONE) {
				fprintf(stderr, "bench_codec: step %lld: decode: %s\n", (long long)s,
				        ndo_drop_name(r));
				bad = 1;
				break;
			}
			/* the receiver's positions against the truth */
			for (int j = j0, k = 0; j <= j1; j++)
				for (int i = i0; i <= i1; i++, k += 6) {
					size_t n = ndo_node(g->w, i, j);
					if (cls[n] == NDO_NODE_SKIP)
						continue;
					double d2 = 0;
					for (int c = 0; c < 3; c++) {
						double e = t.values[k + c] - x[3 * n + c];
						d2 += e * e;
					}
					if (cls[n] == NDO_NODE_EXACT && d2 != 0)
						bad = 2;
					maxerr = fmax(maxerr, sqrt(d2));
				}
			free(t.values);
		}
		te[s] = enc_t;
		td[s] = dec_t;
		ce[s] = enc_c;
		cd[s] = dec_c;
	}
	(void)exact_bytes;
	if (df)
		fclose(df);
	ndo_codec_stats es, ds;
	ndo_codec_stats_get(enc, &es);
	ndo_codec_stats_get(dec, &ds);
	printf("level %d, %s, %d peer%s (sender 1: %zu exact of %zu stored nodes, %zu tiles), %lld "
	       "steps: %.3f bits/node/update (payload), encode %.3f ms, decode %.3f ms (medians; "
	       "CPU time %.3f + %.3f ms), "
	       "max error %.3g of the diagonal (bound %.3g), keyframes %llu, skipped %llu, "
	       "payload CRC-32 %08lx%s\n",
	       level, spec, peers, peers == 1 ? "" : "s", nexact, g->count, ntiles, (long long)steps,
	       8.0 * (double)bytes / ((double)g->count * (double)steps), 1e3 * median(te, (size_t)steps),
	       1e3 * median(td, (size_t)steps), 1e3 * median(ce, (size_t)steps),
	       1e3 * median(cd, (size_t)steps), maxerr / diag, ndo_codec_max_error(&p) / diag,
	       (unsigned long long)es.keyframes, (unsigned long long)es.skipped, crc,
	       bad == 1 ? " DECODE FAILED" : bad == 2 ? " EXACT NODE CHANGED" : "");
	if (ndo__codec_hier_stats && ndo__codec_hier_stats->frames > 0) {
		const hier_stats *hs = ndo__codec_hier_stats;
		const char *name[5] = {"level 1", "level 2", "level 4", "level 8+", "top/none"};
		const double total = 8.0 * (double)bytes, upd = (double)g->count * (double)steps;
		double coded = hs->beta_bits, all = 0;
		for (int k = 0; k < 5; k++)
			all += hs->nodes[k];
		printf("where the bits go (bits per node per update over W x H; share of the payload):\n");
		for (int k = 0; k < 5; k++) {
			const double b = hs->node_bits[k] + hs->zero_bits[k] + hs->value_bits[k];
			coded += b;
			if (hs->nodes[k] == 0)
				continue;
			printf("  %-8s %5.1f%% of the nodes, %5.1f%% all 0, values %5.1f%% 0; node flags "
			       "%.3f, zero flags %.3f, nonzero values %.3f = %.3f (%.1f%%)\n",
			       name[k], 100 * hs->nodes[k] / all,
			       100 * hs->zero_nodes[k] / hs->nodes[k], 100 * hs->zeros[k] / hs->values[k],
			       hs->node_bits[k] / upd, hs->zero_bits[k] / upd, hs->value_bits[k] / upd,
			       b / upd, 100 * b / total);
		}
		printf("  slope shares %.4f; headers, classes and the coder's overhead %.3f (%.1f%%)\n",
		       hs->beta_bits / upd, (total - coded) / upd, 100 * (total - coded) / total);
	}
	if (ndo__codec_hier_times) {
		const hier_times *ht = ndo__codec_hier_times;
		/* means over the steps (the line above has medians) */
		double me = 0, md = 0;
		for (int64_t s = 0; s < steps; s++)
			me += ce[s], md += cd[s];
		const double ns = (double)steps;
		const double(*ms)[3] = ht->ms;
		printf("where the time goes (ms a step, means; wall clock in the phases): encode %.3f, of it hier %.3f: setup %.3f, "
		       "predict %.3f/%.3f/%.3f, slope costs %.3f/%.3f/%.3f, choose and code %.3f/%.3f/%.3f "
		       "(levels 1/2/coarser)\n",
		       1e3 * me / ns, ht->whole[0] / ns, ms[5][2] / ns, ms[0][0] / ns, ms[0][1] / ns,
		       ms[0][2] / ns, ms[1][0] / ns, ms[1][1] / ns, ms[1][2] / ns, ms[2][0] / ns,
		       ms[2][1] / ns, ms[2][2] / ns);
		printf("  decode %.3f, of it hier %.3f: setup %.3f, predict %.3f/%.3f/%.3f, decode "
		       "%.3f/%.3f/%.3f\n",
		       1e3 * md / ns, ht->whole[1] / ns, ms[6][2] / ns, ms[3][0] / ns, ms[3][1] / ns,
		       ms[3][2] / ns, ms[4][0] / ns, ms[4][1] / ns, ms[4][2] / ns);
	}
	ndo_codec_destroy(enc);
	ndo_codec_destroy(dec);
	ndo_sim_destroy(sim);
	ndo_grid_destroy(g);
	ndo_scene_forces_free(forces, sc.nforces);
	ndo_scene_free(&sc);
	free(pin), free(cells), free(own), free(cls), free(codes), free(te), free(td), free(ce), free(cd);
	return bad != 0;
}
