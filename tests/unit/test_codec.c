/* test_codec — compact state tiles (ndo/codec.h): round trips of every
 * encoding within the stated error, EXACT nodes bit for bit, closed-loop
 * prediction without drift, keyframe recovery after a lost frame, skipped
 * frames and their implied values, and hostile payloads (corrupt,
 * truncated, a decompression bomb) as counted drops.
 *
 * The codec's parts (lib/net/codec_private.h) and the cases that hold each:
 *   codec_params.c   specs_and_description_lines, round_trips_within_...
 *   codec_predict.c  prediction_is_compact, keyframe_recovers_after_loss,
 *                    unchanged_frames_and_their_prediction
 *   codec_rows.c     fast_and_general_predictors_agree (byte for byte
 *                    against codec_predict.c's general predictor),
 *                    tiles_in_place
 *   codec_entropy.c  hostile_payloads_are_dropped (bombs, truncations),
 *                    hostile_predicted_payloads (symbols, escapes)
 *   codec.c          every case: encode and decode of a frame */
#include "check.h"
#include "ndo/codec.h"
#include "ndo/link.h"
#include "ndo/shapes.h"
#include "ndo/status.h"

#include <stdlib.h>
#include <string.h>
#include <zstd.h>

#define ROWS 17
#define COLS 33
#define NODES (ROWS * COLS)

/* A moving wavy patch: node n at step s. */
static void state(int64_t s, double *x, double *v, double amp)
{
	for (int j = 0; j < ROWS; j++)
		for (int i = 0; i < COLS; i++) {
			int n = j * COLS + i;
			double u = i / (double)(COLS - 1), w = j / (double)(ROWS - 1), t = 0.02 * (double)s;
			x[3 * n] = 2 * u - 1 + amp * sin(3 * w + t);
			x[3 * n + 1] = 2 * w - 1 + amp * cos(2 * u - t);
			x[3 * n + 2] = 0.3 * sin(4 * u) * cos(3 * w) + amp * sin(5 * u + 7 * w + 2 * t);
			v[3 * n] = 0.02 * amp * cos(3 * w + t);
			v[3 * n + 1] = 0.02 * amp * sin(2 * u - t);
			v[3 * n + 2] = 0.04 * amp * cos(5 * u + 7 * w + 2 * t);
		}
}

static void classes(uint8_t *cls)
{
	for (int n = 0; n < NODES; n++) {
		int i = n % COLS, j = n / COLS;
		cls[n] = i > 24 ? NDO_NODE_SKIP : i >= 22 || j == 5 ? NDO_NODE_EXACT : NDO_NODE_LOSSY;
	}
}

static ndo_codec_params params(const char *spec)
{
	ndo_codec_params p;
	if (ndo_codec_parse(spec, &p))
		printf("    parse %s: %s\n", spec, ndo_errdetail());
	for (int c = 0; c < 3; c++)
		p.lo[c] = -1.2, p.ext[c] = 2.4;
	return p;
}

typedef struct side {
	ndo_codec_hist h;
	ndo_codec_frame f;
	ndo_codec_hist fh; /* storage for f */
} side;

static void side_init(side *s)
{
	ndo_codec_hist_init(&s->h, NODES);
	ndo_codec_hist_init(&s->fh, NODES);
	s->f = s->fh.f[0];
}

static void side_free(side *s)
{
	ndo_codec_hist_free(&s->h);
	ndo_codec_hist_free(&s->fh);
}

/* Encode step s at the sender, decode at the receiver (unless `lose`):
 * returns the decode result and the largest LOSSY position error. */
static ndo_drop step(const ndo_codec_params *p, side *tx, side *rx, int64_t s, int intra,
                     int lose, double *err, size_t *bytes, int *unchanged)
{
	double x[3 * NODES], v[3 * NODES], xo[3 * NODES], vo[3 * NODES];
	uint8_t cls[NODES];
	state(s, x, v, 0.2);
	classes(cls);
	ndo_codec_input in = {ROWS, COLS, x, v, cls, s, 0.01 * (double)s, 0, 0};
	uint8_t *data;
	size_t len;
	int64_t base;
	int un;
	if (ndo_codec_encode(p, NULL, &tx->h, intra, &in, &data, &len, &base, &tx->f, &un) != 0)
		return NDO_DROP_N;
	if (base < 0 && intra != 2)
		ndo_codec_hist_clear(&tx->h); /* a keyframe starts the history again */
	ndo_codec_hist_put(&tx->h, &tx->f);
	if (bytes)
		*bytes += len;
	if (unchanged)
		*unchanged = un;
	ndo_drop r = NDO_DROP_NONE;
	*err = 0;
	if (!lose) {
		r = ndo_codec_decode(p, NULL, &rx->h, ROWS, COLS, data, len, s, 0.01 * (double)s, 0, base,
		                     xo, vo, &rx->f);
		if (r == NDO_DROP_NONE) {
			if (base < 0)
				ndo_codec_hist_clear(&rx->h);
			ndo_codec_hist_put(&rx->h, &rx->f);
			for (int n = 0; n < NODES; n++) {
				for (int d = 0; d < 3; d++) {
					if (cls[n] == NDO_NODE_EXACT &&
					    (xo[3 * n + d] != x[3 * n + d] || vo[3 * n + d] != v[3 * n + d]))
						*err = INFINITY; /* exact means bit for bit */
					if (cls[n] == NDO_NODE_SKIP && !isnan(xo[3 * n + d]))
						*err = INFINITY; /* not carried: NaN */
					/* the receiver holds what the sender says it does */
					double held[3];
					ndo_codec_frame_position(p, &tx->f, n, held);
					if (cls[n] != NDO_NODE_SKIP && xo[3 * n + d] != held[d])
						*err = INFINITY;
				}
				if (cls[n] == NDO_NODE_LOSSY) {
					double e = 0;
					for (int d = 0; d < 3; d++)
						e += (xo[3 * n + d] - x[3 * n + d]) * (xo[3 * n + d] - x[3 * n + d]);
					*err = fmax(*err, sqrt(e));
				}
			}
		}
	}
	free(data);
	return r;
}

static void round_trips_within_the_stated_error(void)
{
	const char *specs[] = {"float32",    "fixed:13",     "fixed:8",     "predict:13",
	                       "predict:6:4", "predict:20:1", "predict:1e-4", "fixed:3e-3",
	                       "predict:0.004:5", "hier:13", "hier:6:4", "hier:20:1", "hier:1e-4",
	                       "hier:0.004:5"};
	for (size_t k = 0; k < sizeof specs / sizeof *specs; k++) {
		ndo_codec_params p = params(specs[k]);
		double bound = ndo_codec_max_error(&p), worst = 0;
		side tx, rx;
		side_init(&tx), side_init(&rx);
		int ok = 1;
		for (int64_t s = 0; s < 60 && ok; s++) {
			double err;
			ndo_drop r = step(&p, &tx, &rx, s, 0, 0, &err, NULL, NULL);
			ok = r == NDO_DROP_NONE;
			CHECK(ok, "%s step %lld: decoded (got drop %s)", specs[k], (long long)s,
			      ndo_drop_name(r));
			worst = fmax(worst, err);
		}
		/* errors do not drift: the bound holds at every step */
		CHECK(worst <= bound * (1 + 1e-9), "%s: error %.3g within the stated %.3g", specs[k],
		      worst, bound);
		CHECK(bound > 0 && bound < 0.1, "%s: a positive small bound (%.3g)", specs[k], bound);
		side_free(&tx), side_free(&rx);
	}
	ndo_codec_params p = params("predict:13");
	CHECK_NEAR(ndo_codec_max_error(&p) / ndo_codec_diagonal(&p), 1.0 / 16384, 1e-12,
	           "13 bits: diag / 2^14");
}

static void prediction_is_compact(void)
{
	size_t fixed = 0, pred = 0;
	ndo_codec_params pf = params("fixed:13"), pp = params("predict:13:1000");
	side a, b, c, d;
	side_init(&a), side_init(&b), side_init(&c), side_init(&d);
	double err;
	for (int64_t s = 0; s < 40; s++) {
		step(&pf, &a, &b, s, 0, 0, &err, &fixed, NULL);
		step(&pp, &c, &d, s, 0, 0, &err, &pred, NULL);
	}
	CHECK(pred * 2 < fixed, "predict takes less than half of fixed: %zu vs %zu bytes", pred,
	      fixed);
	side_free(&a), side_free(&b), side_free(&c), side_free(&d);
}

static void keyframe_recovers_after_loss(void)
{
	for (int e = 0; e < 2; e++) {
	ndo_codec_params p = params(e ? "hier:13:8" : "predict:13:8");
	side tx, rx;
	side_init(&tx), side_init(&rx);
	double err;
	int nobase = 0, recovered = -1;
	for (int64_t s = 0; s < 40; s++) {
		int intra = s > 0 && s % 8 == 0; /* the tile layer's keyframes */
		ndo_drop r = step(&p, &tx, &rx, s, intra, s == 10, &err, NULL, NULL);
		if (s > 10 && r == NDO_DROP_NOBASE)
			nobase++;
		if (s > 10 && r == NDO_DROP_NONE && recovered < 0)
			recovered = (int)s;
		if (recovered >= 0 && s > 10)
			CHECK(r == NDO_DROP_NONE && err <= ndo_codec_max_error(&p) * (1 + 1e-9),
			      "after recovery, step %lld decodes within the bound", (long long)s);
	}
	CHECK(nobase == 5, "%s: steps 11-15 need the lost frame: %d nobase",
	      e ? "hier" : "predict", nobase);
	CHECK(recovered == 16, "the keyframe at step 16 recovers: %d", recovered);
	side_free(&tx), side_free(&rx);
	}
}

static void unchanged_frames_and_their_prediction(void)
{
	for (int enc = 0; enc < 2; enc++) {
	ndo_codec_params p = params(enc ? "hier:13" : "predict:13");
	double x[3 * NODES], v[3 * NODES], xo[3 * NODES];
	uint8_t cls[NODES];
	for (int n = 0; n < NODES; n++)
		cls[n] = NDO_NODE_LOSSY;
	side tx;
	side_init(&tx);
	int un = 0;
	for (int64_t s = 0; s < 5; s++) {
		state(0, x, v, 0.2); /* standing still */
		ndo_codec_input in = {ROWS, COLS, x, v, cls, s, 0.01 * (double)s, 0, 0};
		uint8_t *data;
		size_t len;
		int64_t base;
		ndo_codec_encode(&p, NULL, &tx.h, 0, &in, &data, &len, &base, &tx.f, &un);
		ndo_codec_hist_put(&tx.h, &tx.f);
		free(data);
	}
	CHECK(un, "a still tile is unchanged");
	/* the prediction of a skipped step is the frame a receiver makes */
	ndo_codec_frame f = tx.fh.f[1];
	CHECK(ndo_codec_implied(&p, &tx.h, ROWS, COLS, 5, 0.05, xo, &f) == 0, "implied");
	double e = 0;
	for (int k = 0; k < 3 * NODES; k++)
		e = fmax(e, fabs(xo[k] - x[k]));
	CHECK(e <= ndo_codec_max_error(&p), "%s: implied frame within the bound: %.3g",
	      enc ? "hier" : "predict", e);
	side_free(&tx);
	}
}

/* Hostile payloads: every one a counted drop, none a crash (the sanitizer
 * build runs this). */
static void hostile_payloads_are_dropped(void)
{
	ndo_codec_params p = params("predict:13");
	double x[3 * NODES], v[3 * NODES], xo[3 * NODES], vo[3 * NODES];
	uint8_t cls[NODES];
	state(3, x, v, 0.2);
	classes(cls);
	side tx, rx;
	side_init(&tx), side_init(&rx);
	ndo_codec_input in = {ROWS, COLS, x, v, cls, 3, 0.03, 0, 0};
	uint8_t *data;
	size_t len;
	int64_t base;
	int un;
	ndo_codec_encode(&p, NULL, &tx.h, 1, &in, &data, &len, &base, &tx.f, &un);
	CHECK(ndo_codec_decode(&p, NULL, &rx.h, ROWS, COLS, data, len, 3, 0.03, 0, base, xo, vo,
	                       &rx.f) == NDO_DROP_NONE, "the good payload decodes");
	int crashes_avoided = 0;
	for (size_t cut = 0; cut < len; cut += 1 + len / 40) {
		ndo_drop r = ndo_codec_decode(&p, NULL, &rx.h, ROWS, COLS, data, cut, 3, 0.03, 0, base,
		                              xo, vo, &rx.f);
		CHECK(r == NDO_DROP_CORRUPT, "truncated to %zu of %zu: corrupt (%s)", cut, len,
		      ndo_drop_name(r));
		crashes_avoided++;
	}
	uint64_t rng = 7;
	for (int trial = 0; trial < 300; trial++) {
		uint8_t *bad = malloc(len);
		memcpy(bad, data, len);
		for (int k = 0; k < 3; k++)
			bad[ndo_rng_next(&rng) % len] ^= (uint8_t)(1 + ndo_rng_next(&rng) % 255);
		ndo_drop r = ndo_codec_decode(&p, NULL, &rx.h, ROWS, COLS, bad, len, 3, 0.03, 0, base,
		                              xo, vo, &rx.f);
		CHECK(r == NDO_DROP_NONE || r == NDO_DROP_CORRUPT || r == NDO_DROP_NOBASE,
		      "flipped bytes: decoded or dropped (%s)", ndo_drop_name(r));
		free(bad);
	}
	/* a decompression bomb: 64 MB of zeros in a few kB */
	size_t big = 64u << 20;
	uint8_t *zeros = calloc(big, 1), *bomb = malloc(ZSTD_compressBound(big) + 1);
	bomb[0] = 4; /* intra, zstd */
	size_t z = ZSTD_compress(bomb + 1, ZSTD_compressBound(big), zeros, big, 1);
	CHECK(!ZSTD_isError(z) && z < 100000, "the bomb is small: %zu bytes", z);
	CHECK(ndo_codec_decode(&p, NULL, &rx.h, ROWS, COLS, bomb, z + 1, 3, 0.03, 0, -1, xo, vo,
	                       &rx.f) == NDO_DROP_CORRUPT, "a decompression bomb is corrupt");
	free(zeros), free(bomb);
	/* a predicted frame with no reference */
	CHECK(ndo_codec_decode(&p, NULL, &rx.h, ROWS, COLS, data, len, 5, 0.05, 0, 4, xo, vo,
	                       &rx.f) == NDO_DROP_CORRUPT, "an intra payload claiming a base");
	uint8_t pred[] = {1, 1, 1, 0};
	CHECK(ndo_codec_decode(&p, NULL, &rx.h, ROWS, COLS, pred, sizeof pred, 50, 0.5, 0, 40, xo,
	                       vo, &rx.f) == NDO_DROP_NOBASE, "a predicted frame without its base");
	CHECK(crashes_avoided > 10, "truncations tried");
	free(data);
	side_free(&tx), side_free(&rx);
}

/* Set by tests: every frame through the general predictor (lib/net/codec_predict.c). */
extern int ndo__codec_general_only;

/* Every node carried (LOSSY, a column of EXACT): the predictor's fast
 * loops.  They must give the general predictor's payload byte for byte,
 * and either decoder must read either's payload — keyframes, frames after
 * a keyframe, consecutive steps, steps after a gap, a tight bit depth
 * with residuals beyond the 2-bit symbols. */
static void fast_and_general_predictors_agree(void)
{
	const char *specs[] = {"predict:13:8", "predict:20:16", "predict:4:5"};
	/* with a column of EXACT nodes, and every node LOSSY (the row loops'
	 * flat case) */
	for (size_t qa = 0; qa < 2 * sizeof specs / sizeof *specs; qa++) {
		const size_t q = qa / 2;
		const int all = (int)(qa & 1);
		ndo_codec_params p = params(specs[q]);
		ndo_codec_hist ht[2], hr[2], fh;
		for (int k = 0; k < 2; k++)
			ndo_codec_hist_init(&ht[k], NODES), ndo_codec_hist_init(&hr[k], NODES);
		ndo_codec_hist_init(&fh, NODES);
		ndo_codec_hist f6;
		ndo_codec_hist_init(&f6, NODES);
		double x6[6 * NODES];
		double x[3 * NODES], v[3 * NODES], xo[3 * NODES], vo[3 * NODES], first[6 * NODES];
		uint8_t cls[NODES];
		for (int n = 0; n < NODES; n++)
			cls[n] = !all && n % COLS == 7 ? NDO_NODE_EXACT : NDO_NODE_LOSSY;
		int same = 1, decoded = 1, within = 1, frames = 0, outputs = 1;
		double bound = ndo_codec_max_error(&p);
		for (int64_t s = 0; s < 40; s++) {
			if (s == 12 || s == 13 || s == 25)
				continue; /* gaps: extrapolation over non-consecutive steps */
			state(s, x, v, 0.2);
			ndo_codec_input in = {ROWS, COLS, x, v, cls, s, 0.01 * (double)s, 0, 0};
			/* the fast encoder reads its rows in place, SW nodes apart (NaN
			 * between them: read, they would change the bytes) */
			enum { SW = COLS + 3 };
			double xs[3 * ROWS * SW], vs[3 * ROWS * SW];
			for (int k = 0; k < 3 * ROWS * SW; k++)
				xs[k] = vs[k] = NAN;
			for (int j = 0; j < ROWS; j++)
				memcpy(xs + 3 * j * SW, x + 3 * j * COLS, 3 * COLS * sizeof *x),
				    memcpy(vs + 3 * j * SW, v + 3 * j * COLS, 3 * COLS * sizeof *v);
			ndo_codec_input ins = in;
			ins.x = xs, ins.v = vs, ins.stride = SW;
			uint8_t *data[2];
			size_t len[2];
			int64_t base[2];
			int un;
			for (int k = 0; k < 2; k++) { /* k = 0: fast; 1: general */
				ndo__codec_general_only = k;
				ndo_codec_frame *f = &fh.f[k];
				int intra = s % 8 == 0;
				ndo_codec_encode(&p, NULL, &ht[k], intra, k ? &in : &ins, &data[k], &len[k],
				                 &base[k], f, &un);
				if (base[k] < 0)
					ndo_codec_hist_clear(&ht[k]);
				ndo_codec_hist_put(&ht[k], f);
			}
			same &= len[0] == len[1] && base[0] == base[1] && !memcmp(data[0], data[1], len[0]);
			/* decoder k reads encoder 1 − k's payload */
			for (int k = 0; k < 2; k++) {
				ndo__codec_general_only = k;
				ndo_codec_frame *f = &fh.f[2 + k];
				ndo_drop r = ndo_codec_decode(&p, NULL, &hr[k], ROWS, COLS, data[1 - k],
				                              len[1 - k], s, 0.01 * (double)s, 0, base[1 - k],
				                              xo, vo, f);
				decoded &= r == NDO_DROP_NONE;
				if (r != NDO_DROP_NONE)
					break;
				/* the same frame decoded into a tile's layout (a node's
				 * position and velocity together, 6 doubles): the same
				 * values, bit for bit */
				ndo_drop r6 = ndo_codec_decode_strided(
				    &p, NULL, &hr[k], ROWS, COLS, data[1 - k], len[1 - k], s, 0.01 * (double)s,
				    0, base[1 - k], x6, x6 + 3, 6, &f6.f[0]);
				decoded &= r6 == NDO_DROP_NONE;
				for (int n = 0; n < NODES; n++)
					outputs &= !memcmp(x6 + 6 * n, xo + 3 * n, 3 * sizeof *xo) &&
					           !memcmp(x6 + 6 * n + 3, vo + 3 * n, 3 * sizeof *vo);
				if (base[1 - k] < 0)
					ndo_codec_hist_clear(&hr[k]);
				ndo_codec_hist_put(&hr[k], f);
				/* both decoders put out the same positions and velocity
				 * estimates, bit for bit */
				if (k == 0) {
					memcpy(first, xo, sizeof xo);
					memcpy(first + 3 * NODES, vo, sizeof vo);
				} else {
					outputs &= !memcmp(first, xo, sizeof xo) &&
					           !memcmp(first + 3 * NODES, vo, sizeof vo);
				}
				for (int n = 0; n < NODES; n++) {
					double e2 = 0;
					for (int d = 0; d < 3; d++) {
						double e = xo[3 * n + d] - x[3 * n + d];
						e2 += e * e;
						if (cls[n] == NDO_NODE_EXACT)
							within &= e == 0 && vo[3 * n + d] == v[3 * n + d];
					}
					within &= sqrt(e2) <= bound * (1 + 1e-9);
				}
			}
			frames++;
			free(data[0]), free(data[1]);
		}
		ndo__codec_general_only = 0;
		CHECK(same, "%s%s: the fast predictor's payloads are the general one's", specs[q], all ? " (all LOSSY)" : "");
		CHECK(decoded, "%s%s: each decoder reads the other's payloads", specs[q], all ? " (all LOSSY)" : "");
		CHECK(outputs, "%s%s: and puts out the same positions and velocities", specs[q], all ? " (all LOSSY)" : "");
		CHECK(within, "%s%s: within the stated error, EXACT nodes bit for bit", specs[q], all ? " (all LOSSY)" : "");
		CHECK(frames == 37, "%s%s: 37 frames", specs[q], all ? " (all LOSSY)" : "");
		for (int k = 0; k < 2; k++)
			ndo_codec_hist_free(&ht[k]), ndo_codec_hist_free(&hr[k]);
		ndo_codec_hist_free(&fh), ndo_codec_hist_free(&f6);
	}
}

/* A predicted frame of a tile in the fast loops' case, cut short or with
 * bytes changed: dropped, or decoded — never read out of bounds. */
static void hostile_predicted_payloads(void)
{
	ndo_codec_params p = params("predict:10");
	double x[3 * NODES], v[3 * NODES], xo[3 * NODES], vo[3 * NODES];
	uint8_t cls[NODES];
	memset(cls, NDO_NODE_LOSSY, sizeof cls);
	side tx, rx;
	side_init(&tx), side_init(&rx);
	uint8_t *data = NULL;
	size_t len = 0;
	int64_t base = -1;
	int un;
	for (int64_t s = 0; s < 5; s++) {
		free(data);
		state(s, x, v, 0.2);
		ndo_codec_input in = {ROWS, COLS, x, v, cls, s, 0.01 * (double)s, 0, 0};
		ndo_codec_encode(&p, NULL, &tx.h, 0, &in, &data, &len, &base, &tx.f, &un);
		ndo_codec_hist_put(&tx.h, &tx.f);
		if (s < 4) {
			CHECK(ndo_codec_decode(&p, NULL, &rx.h, ROWS, COLS, data, len, s, 0.01 * (double)s,
			                       0, base, xo, vo, &rx.f) == NDO_DROP_NONE, "step %lld decodes",
			      (long long)s);
			ndo_codec_hist_put(&rx.h, &rx.f);
		}
	}
	CHECK(base == 3 && data[0] == (1 | 4), "a predicted zstd frame (base %lld, flags %d)",
	      (long long)base, data[0]);
	/* the body itself, uncompressed, cut at every length: corrupt */
	size_t blen = ZSTD_getFrameContentSize(data + 3, len - 3);
	uint8_t *body = malloc(blen), *plain = malloc(blen + 3);
	CHECK(ZSTD_decompress(body, blen, data + 3, len - 3) == blen, "the body decompresses");
	memcpy(plain, data, 3);
	plain[0] &= (uint8_t)~4; /* not zstd */
	memcpy(plain + 3, body, blen);
	CHECK(ndo_codec_decode(&p, NULL, &rx.h, ROWS, COLS, plain, blen + 3, 4, 0.04, 0, 3, xo, vo,
	                       &rx.f) == NDO_DROP_NONE, "the uncompressed body decodes");
	int all = 1;
	for (size_t cut = 3; cut < blen + 3; cut++)
		all &= ndo_codec_decode(&p, NULL, &rx.h, ROWS, COLS, plain, cut, 4, 0.04, 0, 3, xo, vo,
		                        &rx.f) == NDO_DROP_CORRUPT;
	CHECK(all, "every truncation of the %zu-byte body is corrupt", blen);
	uint8_t *longer = malloc(blen + 4);
	memcpy(longer, plain, blen + 3);
	longer[blen + 3] = 0;
	CHECK(ndo_codec_decode(&p, NULL, &rx.h, ROWS, COLS, longer, blen + 4, 4, 0.04, 0, 3, xo, vo,
	                       &rx.f) == NDO_DROP_CORRUPT, "a byte too many is corrupt");
	uint64_t rng = 11;
	int fine = 1;
	for (int trial = 0; trial < 500; trial++) {
		memcpy(longer, plain, blen + 3);
		longer[3 + ndo_rng_next(&rng) % blen] ^= (uint8_t)(1 + ndo_rng_next(&rng) % 255);
		ndo_drop r = ndo_codec_decode(&p, NULL, &rx.h, ROWS, COLS, longer, blen + 3, 4, 0.04, 0,
		                              3, xo, vo, &rx.f);
		fine &= r == NDO_DROP_NONE || r == NDO_DROP_CORRUPT;
	}
	CHECK(fine, "changed bytes: decoded or corrupt");
	free(body), free(plain), free(longer), free(data);
	side_free(&tx), side_free(&rx);
}

/* The header of sender 5's position and velocity tile q at step s. */
static ndo_msg_tile_t state_tile(int level, ndo_quad q, int64_t s)
{
	ndo_msg_tile_t t;
	memset(&t, 0, sizeof t);
	t.hdr.sender_id = 5;
	t.step = s;
	t.time = 0.1 * (double)s;
	int i0, j0, i1, j1;
	ndo_quad_range(level, q, &i0, &j0, &i1, &j1);
	t.depth = (int8_t)q.depth, t.i0 = i0, t.j0 = j0, t.i1 = i1, t.j1 = j1;
	t.channels = NDO_TILE_POSITION | NDO_TILE_VELOCITY;
	return t;
}

/* Whole tiles through the stateful layer: encode from a grid, decode in
 * place, skipped steps filled in. */
static void tiles_in_place(void)
{
	ndo_grid *g;
	ndo_shape_make("wavy", 4, NULL, &g);
	ndo_grid_add(g, NDO_CH_VELOCITY, NDO_F64, 3, NULL);
	ndo_codec_params p;
	ndo_codec_parse("predict", &p);
	double *x = ndo_grid_f64(g, NDO_CH_POSITION, 3);
	ndo_codec_box(x, g->count, p.lo, p.ext);
	ndo_codec *tx, *rx;
	CHECK(ndo_codec_create(&p, 4, &tx) == 0 && ndo_codec_create(&p, 4, &rx) == 0, "created");
	uint8_t *cls = malloc(g->count);
	memset(cls, NDO_NODE_LOSSY, g->count);
	ndo_quad q = {1, 0, 0};
	int sent = 0, skipped = 0, implied = 0;
	for (int64_t s = 0; s < 30; s++) {
		if (s < 10)
			for (size_t k = 0; k < 3 * g->count; k++)
				x[k] += 1e-3 * sin((double)k + 0.1 * (double)s);
		ndo_msg_tile_t t = state_tile(4, q, s);
		int rc = ndo_codec_encode_tile(tx, 5, g, cls, q, 0, &t);
		if (rc == 1) {
			skipped++;
			continue;
		}
		CHECK(rc == 0, "step %lld encoded", (long long)s);
		sent++;
		CHECK(ndo_codec_decode_tile(rx, &t) == NDO_DROP_NONE && t.encoding == NDO_ENC_RAW,
		      "step %lld decoded in place", (long long)s);
		implied += ndo_codec_skipped(rx, &t);
		if (ndo_codec_skipped(rx, &t)) {
			ndo_msg_tile_t o;
			CHECK(ndo_codec_skipped_tile(rx, &t, 0, &o) == 0 && o.step == t.step - ndo_codec_skipped(rx, &t),
			      "the first skipped step's tile");
			free(o.values);
		}
		free(t.values);
	}
	CHECK(skipped > 0 && sent > 0, "a still object's tiles are skipped: %d sent, %d skipped",
	      sent, skipped);
	CHECK(implied > 0, "the receiver learns of skipped steps: %d", implied);
	ndo_codec_stats st;
	ndo_codec_stats_get(tx, &st);
	CHECK(st.max_error <= ndo_codec_max_error(&p) * (1 + 1e-9), "encoder's error %.3g",
	      st.max_error);
	ndo_codec_destroy(tx), ndo_codec_destroy(rx);
	free(cls);
	ndo_grid_destroy(g);
}

/* A predict encoder of the wavy surface at `level` (its box the surface's),
 * the grid with a velocity channel in *g and every node LOSSY in *cls. */
static ndo_codec *wavy_encoder(int level, ndo_grid **g, uint8_t **cls)
{
	CHECK(ndo_shape_make("wavy", level, NULL, g) == 0, "level-%d wavy", level);
	ndo_grid_add(*g, NDO_CH_VELOCITY, NDO_F64, 3, NULL);
	ndo_codec_params p;
	ndo_codec_parse("predict", &p);
	ndo_codec_box(ndo_grid_f64(*g, NDO_CH_POSITION, 3), (*g)->count, p.lo, p.ext);
	ndo_codec *tx = NULL;
	CHECK(ndo_codec_create(&p, level, &tx) == 0, "created");
	*cls = malloc((*g)->count);
	memset(*cls, NDO_NODE_LOSSY, (*g)->count);
	return tx;
}

/* Every tile of a level-10 object keeps its history: after the first step's
 * keyframes, the next step's frames are predicted.  Until 2026-11-30 the
 * history of all tiles was capped at 256 MB, below a level-10 object's
 * (336 MB): each tile was forgotten just before its next frame, and every
 * frame was a keyframe (bench_codec -l 10: 4.8 bits a node, 0.4 after). */
static void a_level_10_object_keeps_every_tiles_history(void)
{
	const int level = 10;
	ndo_grid *g;
	uint8_t *cls;
	ndo_codec *tx = wavy_encoder(level, &g, &cls);
	double *x = ndo_grid_f64(g, NDO_CH_POSITION, 3);
	const int depth = ndo_tile_depth(level, NDO_TILE_POSITION | NDO_TILE_VELOCITY, "NDO_TILE");
	int cols, rows;
	ndo_quad_dims(depth, &cols, &rows);
	size_t tiles = 0, failed = 0;
	for (int64_t s = 0; s < 2; s++) {
		for (size_t k = 0; k < 3 * g->count; k++) /* every tile moves */
			x[k] += 1e-3 * sin((double)k + (double)s);
		for (int qj = 0; qj < rows; qj++)
			for (int qi = 0; qi < cols; qi++) {
				ndo_quad q = {depth, qi, qj};
				ndo_msg_tile_t t = state_tile(level, q, s);
				failed += ndo_codec_encode_tile(tx, 5, g, cls, q, 0, &t) != 0;
				free(t.values), free(t.data);
				tiles += s == 0;
			}
	}
	ndo_codec_stats st;
	ndo_codec_stats_get(tx, &st);
	CHECK(failed == 0 && tiles >= 256 && st.encoded == 2 * tiles && st.keyframes == tiles,
	      "level 10: %zu tiles, %zu failed, %llu frames, %llu keyframes (expected one a tile)",
	      tiles, failed, (unsigned long long)st.encoded, (unsigned long long)st.keyframes);
	ndo_codec_destroy(tx);
	free(cls);
	ndo_grid_destroy(g);
}

/* The histories beyond ndo_codec_set_memory go least recently used first,
 * and every other is still found, after thousands made and forgotten
 * (the index of (sender, tile) and the order of use, codec_tile.c): room
 * for 50 tiles' histories, the same tile under 2,000 senders, then 10 of
 * the newest 50 used again and 10 new ones — the 10 forgotten are the
 * oldest of the 40 not used again. */
static void least_used_histories_go_first(void)
{
	const int level = 3;
	ndo_grid *g;
	uint8_t *cls;
	ndo_codec *tx = wavy_encoder(level, &g, &cls);
	double *x = ndo_grid_f64(g, NDO_CH_POSITION, 3);
	const ndo_quad q = {2, 1, 0};
	int i0, j0, i1, j1;
	ndo_quad_range(level, q, &i0, &j0, &i1, &j1);
	const size_t nodes = (size_t)(i1 - i0 + 1) * (size_t)(j1 - j0 + 1);
	/* a tile's history: 40 bytes a node a frame (entry_size, codec_tile.c) */
	ndo_codec_set_memory(tx, 50 * nodes * 40 * NDO_CODEC_HISTORY);
	int keys = 0; /* of the last encode() */
#define ENCODE(id, step)                                                                  \
	do {                                                                              \
		ndo_msg_tile_t t_ = state_tile(level, q, step);                               \
		CHECK(ndo_codec_encode_tile(tx, id, g, cls, q, 0, &t_) == 0, "sender %d", id); \
		keys = t_.base_step < 0;                                                      \
		free(t_.values), free(t_.data);                                               \
	} while (0)
	for (int id = 1; id <= 2000; id++)
		ENCODE(id, 0);
	for (size_t k = 0; k < 3 * g->count; k++) /* every tile moves */
		x[k] += 1e-3;
	for (int id = 1951; id <= 1960; id++) { /* used again: kept */
		ENCODE(id, 1);
		CHECK(!keys, "sender %d, one of the newest 50: forgotten", id);
	}
	for (int id = 3001; id <= 3010; id++)
		ENCODE(id, 0);
	int kept = 0, forgotten = 0;
	for (size_t k = 0; k < 3 * g->count; k++)
		x[k] += 1e-3;
	for (int id = 1951; id <= 2000; id++) {
		ENCODE(id, id <= 1960 ? 2 : 1);
		if (id > 1960 && id <= 1970)
			forgotten += keys;
		else
			kept += !keys;
		if (id == 1960) /* room for the forgotten ones made again */
			ndo_codec_set_memory(tx, 200 * nodes * 40 * NDO_CODEC_HISTORY);
	}
	CHECK(forgotten == 10 && kept == 40,
	      "of the 10 least used, %d forgotten (10); of the other 40, %d kept (40)", forgotten,
	      kept);
#undef ENCODE
	ndo_codec_destroy(tx);
	free(cls);
	ndo_grid_destroy(g);
}

static void specs_and_description_lines(void)
{
	ndo_codec_params p;
	CHECK(ndo_codec_parse("zip", &p) == NDO_EINVAL, "unknown encoding");
	CHECK(ndo_codec_parse("fixed:0", &p) == NDO_EINVAL, "bits 0");
	CHECK(ndo_codec_parse("fixed:25", &p) == NDO_EINVAL, "bits 25");
	CHECK(ndo_codec_parse("float32:3", &p) == NDO_EINVAL, "float32 takes no bits");
	CHECK(ndo_codec_parse("fixed:12:4", &p) == NDO_EINVAL, "keyframes are predict's");
	CHECK(ndo_codec_parse("predict:12:5000", &p) == NDO_EINVAL, "keyframe 5000");
	CHECK(ndo_codec_parse("predict:11:64", &p) == 0 && p.bits == 11 && p.keyframe == 64,
	      "predict:11:64");
	CHECK(ndo_codec_parse("hier:1e-4:16", &p) == 0 && p.encoding == NDO_ENC_HIER &&
	          p.error == 1e-4 && p.keyframe == 16,
	      "hier:1e-4:16");
	char hn[64];
	ndo_codec_name(&p, hn, sizeof hn);
	CHECK(strcmp(hn, "hier:0.0001:16") == 0, "its name: %s", hn);
	CHECK(ndo_codec_parse("hier:0.5", &p) == NDO_EINVAL, "hier: a budget of half the diagonal");
	CHECK(ndo_codec_parse("hier:11:64", &p) == 0 && p.bits == 11, "hier:11:64");
	p.lo[0] = -1.5, p.lo[1] = 0.25, p.lo[2] = 1e-3, p.ext[0] = 3, p.ext[1] = 0.1, p.ext[2] = 7;
	char text[600] = "stiffness 1\n";
	size_t n = strlen(text);
	CHECK(ndo_codec_params_text(&p, text + n, sizeof text - n) > 0, "lines written");
	strcat(text, "damping 0.1\n");
	ndo_codec_params q;
	CHECK(ndo_codec_params_take(text, &q) == 0 && memcmp(&p, &q, sizeof p) == 0,
	      "the parameters come back exactly");
	CHECK(strcmp(text, "stiffness 1\ndamping 0.1\n") == 0, "the other lines stay: '%s'", text);
	char bad[] = "tile-encoding 3\ntile-bits 99\ntile-keyframe 1\ntile-box 0 0 0 1 1 1\n";
	CHECK(ndo_codec_params_take(bad, &q) == NDO_EINVAL, "bits 99 refused");
	char part[] = "tile-encoding 3\n";
	CHECK(ndo_codec_params_take(part, &q) == NDO_EINVAL, "incomplete lines refused");
	char none[] = "dt 0.1\n";
	CHECK(ndo_codec_params_take(none, &q) == 0 && q.encoding == NDO_ENC_RAW, "none: raw");
	/* an error budget instead of bits */
	CHECK(ndo_codec_parse("predict:1e-4", &p) == 0 && p.error == 1e-4 && p.keyframe == 32,
	      "predict:1e-4");
	CHECK(ndo_codec_parse("fixed:0.002", &p) == 0 && p.error == 0.002, "fixed:0.002");
	CHECK(ndo_codec_parse("predict:2.5e-5:8", &p) == 0 && p.error == 2.5e-5 && p.keyframe == 8,
	      "predict:2.5e-5:8");
	char name[64];
	ndo_codec_name(&p, name, sizeof name);
	CHECK(strcmp(name, "predict:2.5e-05:8") == 0, "its name: %s", name);
	CHECK(ndo_codec_parse(name, &q) == 0 && q.error == p.error, "the name parses back");
	CHECK(ndo_codec_parse("predict:0.5", &p) == NDO_EINVAL, "a budget of half the diagonal");
	CHECK(ndo_codec_parse("predict:1e-9", &p) == NDO_EINVAL, "a budget of 1e-9");
	CHECK(ndo_codec_parse("predict:1e-4x", &p) == NDO_EINVAL, "a budget with a tail");
	ndo_codec_parse("predict:1e-4", &p);
	p.lo[0] = -1.5, p.ext[0] = 3, p.ext[1] = 0.1, p.ext[2] = 7;
	text[0] = 0;
	CHECK(ndo_codec_params_text(&p, text, sizeof text) > 0 && strstr(text, "tile-error "),
	      "a tile-error line");
	CHECK(ndo_codec_params_take(text, &q) == 0 && memcmp(&p, &q, sizeof p) == 0 &&
	          ndo_codec_max_error(&q) == 1e-4 * ndo_codec_diagonal(&q),
	      "the budget comes back exactly, and is the stated error");
	char badbudget[] = "tile-encoding 3\ntile-bits 13\ntile-keyframe 1\n"
	                   "tile-box 0 0 0 1 1 1\ntile-error 0.5\n";
	CHECK(ndo_codec_params_take(badbudget, &q) == NDO_EINVAL, "a budget of 0.5 refused");
}

/* hier on a tile whose every node is LOSSY (codec.c's hier_far(),
 * hier_err() and hier_out(), without branches): the receiver's positions
 * what the sender holds, its velocities the difference from the previous
 * frame over the time between, the encoder's error what the codes it
 * holds are off by (summed in node order: the same doubles), and a NaN,
 * an infinite or a far position refused as in a tile with other classes. */
static void hier_all_lossy_tiles(void)
{
	ndo_codec_params p = params("hier:1e-4");
	ndo_codec_work *w = ndo_codec_work_create();
	side tx, rx;
	side_init(&tx), side_init(&rx);
	static double x[3 * NODES], v[3 * NODES], xo[3 * NODES], vo[3 * NODES], xp[3 * NODES];
	uint8_t cls[NODES];
	memset(cls, NDO_NODE_LOSSY, sizeof cls);
	int bad_x = 0, bad_v = 0, bad_e = 0;
	for (int64_t s = 0; s < 40; s++) {
		state(s, x, v, 0.2);
		ndo_codec_input in = {ROWS, COLS, x, v, cls, s, 0.01 * (double)s, 0, 0};
		uint8_t *data;
		size_t len;
		int64_t base;
		int un;
		int rc = ndo_codec_encode(&p, w, &tx.h, 0, &in, &data, &len, &base, &tx.f, &un);
		CHECK(rc == 0, "step %lld: encoded (%d)", (long long)s, rc);
		if (rc)
			break;
		if (base < 0)
			ndo_codec_hist_clear(&tx.h);
		ndo_codec_hist_put(&tx.h, &tx.f);
		double max2, sum2, m = 0, sum = 0;
		size_t cnt;
		ndo_codec_work_error(w, &max2, &sum2, &cnt);
		ndo_drop r = ndo_codec_decode(&p, NULL, &rx.h, ROWS, COLS, data, len, s,
		                              0.01 * (double)s, 0, base, xo, vo, &rx.f);
		free(data);
		CHECK(r == NDO_DROP_NONE, "step %lld: decoded (%s)", (long long)s, ndo_drop_name(r));
		if (r != NDO_DROP_NONE)
			break;
		if (base < 0)
			ndo_codec_hist_clear(&rx.h);
		ndo_codec_hist_put(&rx.h, &rx.f);
		const double inv = 1 / (0.01 * (double)s - 0.01 * (double)(s - 1));
		for (int n = 0; n < NODES; n++) {
			double held[3], e[3];
			ndo_codec_frame_position(&p, &tx.f, n, held);
			for (int d = 0; d < 3; d++) {
				bad_x += xo[3 * n + d] != held[d];
				const double want = s ? (xo[3 * n + d] - xp[3 * n + d]) * inv : NAN;
				bad_v += s ? vo[3 * n + d] != want : !isnan(vo[3 * n + d]);
				e[d] = held[d] - x[3 * n + d];
			}
			const double e2 = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
			sum += e2, m = e2 > m ? e2 : m;
		}
		bad_e += max2 != m || sum2 != sum || cnt != NODES;
		memcpy(xp, xo, sizeof xp);
	}
	CHECK(!bad_x && !bad_v && !bad_e,
	      "positions as held, velocities from the last frame, the encoder's errors: %d, %d, %d "
	      "values off", bad_x, bad_v, bad_e);
	const double far[3] = {NAN, INFINITY, 1e12};
	for (int k = 0; k < 3; k++) {
		state(40, x, v, 0.2);
		x[3 * (NODES / 2) + 1] = far[k];
		ndo_codec_input in = {ROWS, COLS, x, v, cls, 40, 0.4, 0, 0};
		uint8_t *data = NULL;
		size_t len;
		int64_t base;
		int un;
		ndo_codec_frame f = rx.fh.f[1];
		CHECK(ndo_codec_encode(&p, w, &tx.h, 0, &in, &data, &len, &base, &f, &un) == NDO_ERANGE,
		      "a position %g refused", far[k]);
		free(data);
	}
	ndo_codec_work_destroy(w);
	side_free(&tx), side_free(&rx);
}

int main(void)
{
	ck_program = "test_codec";
	RUN(round_trips_within_the_stated_error);
	RUN(prediction_is_compact);
	RUN(keyframe_recovers_after_loss);
	RUN(unchanged_frames_and_their_prediction);
	RUN(hostile_payloads_are_dropped);
	RUN(fast_and_general_predictors_agree);
	RUN(hostile_predicted_payloads);
	RUN(tiles_in_place);
	RUN(a_level_10_object_keeps_every_tiles_history);
	RUN(least_used_histories_go_first);
	RUN(specs_and_description_lines);
	RUN(hier_all_lossy_tiles);
	return ck_failed_cases != 0;
}
