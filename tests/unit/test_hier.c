/* test_hier — the hierarchical coder (ndo/codec.h "hier",
 * lib/net/codec_hier.c): its range coder against a slow reference of its
 * model (the ideal adaptive code length) and round trips, whole tiles of a
 * moving wavy grid within the error bound at every node with the
 * receiver's frame the sender's, the interior stencil against the general
 * one byte for byte (quad-tree tiles and tiles of other shapes), fewer bytes than predict, and hostile payloads
 * (every truncation, changed bytes, bytes added) as drops, never a read
 * out of bounds (the sanitizer build runs this). */
#include "check.h"
#include "codec_private.h"
#include "ndo/codec.h"
#include "ndo/shapes.h"
#include "ndo/status.h"
#include "ndo/topology.h"

#include <stdlib.h>
#include <string.h>

extern int ndo__codec_hier_general;

static uint64_t rng_state = 12345;
static uint64_t rnd(void)
{
	rng_state ^= rng_state << 13, rng_state ^= rng_state >> 7, rng_state ^= rng_state << 17;
	return rng_state;
}

/* The model's adaptation, written again: P(0) in 1/2048, moved by 1/32
 * of the way to the bit's side. */
static double ref_cost(uint16_t *p, int bit)
{
	double c = -log2((bit ? 2048.0 - *p : (double)*p) / 2048.0);
	*p = bit ? (uint16_t)(*p - (*p >> 5)) : (uint16_t)(*p + ((2048 - *p) >> 5));
	return c;
}

static void range_coder_round_trips(void)
{
	enum { N = 200000, CTX = 8 };
	static uint8_t bits[N], ctx[N], direct[N];
	const double p1[CTX] = {0.001, 0.02, 0.1, 0.3, 0.5, 0.7, 0.95, 0.999};
	for (int k = 0; k < N; k++) {
		ctx[k] = (uint8_t)(rnd() % CTX);
		direct[k] = rnd() % 5 == 0;
		bits[k] = (double)(rnd() % 1000000) / 1e6 < (direct[k] ? 0.5 : p1[ctx[k]]);
	}
	wbuf b = {0};
	rcenc e;
	uint16_t pe[CTX], pr[CTX], pd[CTX];
	for (int c = 0; c < CTX; c++)
		pe[c] = pr[c] = pd[c] = 1024;
	ndo__rc_enc_init(&e, &b);
	double ideal = 0;
	for (int k = 0; k < N; k++) {
		if (direct[k]) {
			ndo__rc_enc_direct(&e, bits[k]);
			ideal += 1;
		} else {
			ndo__rc_enc_bit(&e, &pe[ctx[k]], bits[k]);
			ideal += ref_cost(&pr[ctx[k]], bits[k]);
		}
	}
	ndo__rc_enc_flush(&e);
	CHECK(!b.fail, "encoded");
	CHECK(memcmp(pe, pr, sizeof pe) == 0, "the coder's model adapts as the reference's");
	CHECK(8.0 * (double)b.n <= ideal * 1.001 + 64 && 8.0 * (double)b.n >= ideal - 64,
	      "%zu bytes against the ideal %.0f bits' %.0f", b.n, ideal, ideal / 8);
	rcdec d;
	ndo__rc_dec_init(&d, b.p, b.n);
	int same = 1;
	for (int k = 0; k < N && same; k++)
		same = (direct[k] ? ndo__rc_dec_direct(&d) : ndo__rc_dec_bit(&d, &pd[ctx[k]])) == bits[k];
	CHECK(same && d.pos == b.n && d.over == 0, "decoded every bit, read every byte (%zu of %zu)",
	      d.pos, b.n);
	/* cut short: the decoder asks for bytes past the end, and gets none */
	for (size_t cut = 0; cut < b.n; cut += 1 + b.n / 50) {
		for (int c = 0; c < CTX; c++)
			pd[c] = 1024;
		ndo__rc_dec_init(&d, b.p, cut);
		for (int k = 0; k < N; k++)
			direct[k] ? ndo__rc_dec_direct(&d) : ndo__rc_dec_bit(&d, &pd[ctx[k]]);
		CHECK(d.over > 0 && d.pos == cut, "cut to %zu: %zu bytes missing", cut, d.over);
	}
	/* an empty stream of no bits: 5 bytes */
	wbuf z = {0};
	ndo__rc_enc_init(&e, &z);
	ndo__rc_enc_flush(&e);
	CHECK(z.n == 5 && z.p[0] == 0, "an empty stream: %zu bytes", z.n);
	free(b.p), free(z.p);
}

/* A level-5 wavy grid moving; its tile (the depth-2 quad at qi, qj:
 * 17 x 17 nodes) at step s. */
#define LEVEL 5
static void moving(ndo_grid *g, const double *rest, int64_t s)
{
	double *x = ndo_grid_f64(g, NDO_CH_POSITION, 3), *v = ndo_grid_f64(g, NDO_CH_VELOCITY, 3);
	const double t = 0.01 * (double)s;
	for (size_t n = 0; n < g->count; n++) {
		const double *r = rest + 3 * n;
		for (int d = 0; d < 3; d++) {
			x[3 * n + d] = r[d] + 0.05 * sin(3 * r[(d + 1) % 3] + 4 * t) * cos(2 * r[(d + 2) % 3] - t);
			v[3 * n + d] = 0.2 * cos(3 * r[(d + 1) % 3] + 4 * t);
		}
	}
}

typedef struct run {
	size_t bytes;
	double worst;
	int decoded, same, frames;
	uint32_t crc;
} run;

/* Tiles of every depth 1..3 (all LOSSY, or with SKIP and EXACT nodes),
 * 40 steps, keyframes every 16, one frame lost at step 20. */
static run tiles(const char *spec, int mixed)
{
	run out = {0, 0, 1, 1, 0, 0};
	ndo_grid *g;
	ndo_shape_make("wavy", LEVEL, NULL, &g);
	ndo_grid_add(g, NDO_CH_VELOCITY, NDO_F64, 3, NULL);
	double *rest = malloc(3 * g->count * sizeof *rest);
	memcpy(rest, ndo_grid_f64(g, NDO_CH_POSITION, 3), 3 * g->count * sizeof *rest);
	ndo_codec_params p;
	ndo_codec_parse(spec, &p);
	ndo_codec_box(rest, g->count, p.lo, p.ext);
	const double bound = ndo_codec_max_error(&p);
	uint8_t *cls = malloc(g->count);
	for (size_t n = 0; n < g->count; n++) {
		const int i = (int)(n % (size_t)g->w), j = (int)(n / (size_t)g->w);
		cls[n] = !mixed ? NDO_NODE_LOSSY
		         : i > 40 && j > 20 ? NDO_NODE_SKIP
		         : i == 40 || j == 9 ? NDO_NODE_EXACT
		                              : NDO_NODE_LOSSY;
	}
	ndo_codec *tx, *rx;
	ndo_codec_create(&p, LEVEL, &tx);
	ndo_codec_create(&p, LEVEL, &rx);
	for (int64_t s = 0; s < 40; s++) {
		moving(g, rest, s);
		const double *x = ndo_grid_f64(g, NDO_CH_POSITION, 3);
		for (int depth = 1; depth <= 3; depth++) {
			int qc, qr;
			ndo_quad_dims(depth, &qc, &qr);
			for (int qj = 0; qj < qr; qj++)
				for (int qi = 0; qi < qc; qi++) {
					ndo_quad q = {depth, qi, qj};
					ndo_msg_tile_t t;
					memset(&t, 0, sizeof t);
					int i0, j0, i1, j1;
					ndo_quad_range(LEVEL, q, &i0, &j0, &i1, &j1);
					t.hdr.sender_id = 3;
					t.depth = (int8_t)depth, t.i0 = i0, t.j0 = j0, t.i1 = i1, t.j1 = j1;
					t.channels = NDO_TILE_POSITION | NDO_TILE_VELOCITY;
					t.step = s, t.time = 0.01 * (double)s;
					int rc = ndo_codec_encode_tile(tx, 3, g, cls, q, 0, &t);
					if (rc == 1)
						continue;
					if (rc) {
						out.decoded = 0;
						continue;
					}
					out.bytes += (size_t)t.nbytes;
					for (int k = 0; k < t.nbytes; k++)
						out.crc = out.crc * 31 + t.data[k];
					const int cols = i1 - i0 + 1, nodes = cols * (j1 - j0 + 1);
					double *sent = malloc(3 * (size_t)nodes * sizeof *sent);
					ndo_codec_last_positions(tx, sent);
					if (s == 20 && depth == 2) { /* lost */
						free(t.data), free(sent);
						continue;
					}
					ndo_drop r = ndo_codec_decode_tile(rx, &t);
					if (r == NDO_DROP_NOBASE) {
						free(t.data), free(sent);
						continue;
					}
					out.decoded &= r == NDO_DROP_NONE;
					out.frames++;
					for (int m = 0; r == NDO_DROP_NONE && m < nodes; m++) {
						const size_t n = ndo_node(g->w, i0 + m % cols, j0 + m / cols);
						if (cls[n] == NDO_NODE_SKIP)
							continue;
						double e2 = 0;
						for (int d = 0; d < 3; d++) {
							const double got = t.values[6 * m + d];
							e2 += (got - x[3 * n + d]) * (got - x[3 * n + d]);
							out.same &= got == sent[3 * m + d];
						}
						if (cls[n] == NDO_NODE_EXACT && e2 != 0)
							out.worst = INFINITY;
						out.worst = fmax(out.worst, sqrt(e2) / bound);
					}
					free(t.values), free(sent);
				}
		}
	}
	ndo_codec_destroy(tx), ndo_codec_destroy(rx);
	free(cls), free(rest);
	ndo_grid_destroy(g);
	return out;
}

static void tiles_within_the_bound_at_every_node(void)
{
	const char *specs[] = {"hier:1e-4:16", "hier:1e-3:16", "hier:13:16", "hier:1e-6:16"};
	for (size_t k = 0; k < sizeof specs / sizeof *specs; k++)
		for (int mixed = 0; mixed < 2; mixed++) {
			run r = tiles(specs[k], mixed);
			CHECK(r.decoded && r.frames > 100, "%s%s: every frame decoded (%d)", specs[k],
			      mixed ? " (SKIP, EXACT)" : "", r.frames);
			CHECK(r.same, "%s%s: the receiver holds what the sender says", specs[k],
			      mixed ? " (SKIP, EXACT)" : "");
			CHECK(r.worst <= 1, "%s%s: the largest error %.6f of the bound", specs[k],
			      mixed ? " (SKIP, EXACT)" : "", r.worst);
		}
}

static void interior_and_general_stencils_agree(void)
{
	for (int mixed = 0; mixed < 2; mixed++) {
		run fast = tiles("hier:1e-4:16", mixed);
		ndo__codec_hier_general = 1;
		run slow = tiles("hier:1e-4:16", mixed);
		ndo__codec_hier_general = 0;
		CHECK(fast.bytes == slow.bytes && fast.crc == slow.crc && slow.same && slow.decoded &&
		          fast.same && fast.decoded,
		      "%s: the same payloads (%zu and %zu bytes)", mixed ? "mixed" : "all LOSSY",
		      fast.bytes, slow.bytes);
	}
}

/* Frames of tiles of any shape (not only the quad-tree's 2^k + 1), all
 * LOSSY and with EXACT nodes: the fast paths (predict_compact(),
 * collect_sampled(), encode_zeros()) write the general path's payloads,
 * and the receiver holds what the sender says.  (A 5 x 1 tile once
 * counted a node past its one column.) */
static void odd_shapes_agree(void)
{
	static const int sizes[][2] = {{13, 22}, {7, 9}, {3, 40}, {1, 5}, {2, 2}, {5, 1},
	                               {6, 6},   {33, 17}, {9, 65}, {4, 3}};
	for (size_t z = 0; z < sizeof sizes / sizeof *sizes; z++)
		for (int mixed = 0; mixed < 2; mixed++) {
			const int R = sizes[z][0], C = sizes[z][1], N = R * C;
			ndo_codec_params p;
			ndo_codec_parse("hier:1e-4:16", &p);
			for (int c = 0; c < 3; c++)
				p.lo[c] = -1.5, p.ext[c] = 3;
			ndo_codec_hist h[2], fh[2], rh, rfh;
			ndo_codec_frame f[2], rf;
			for (int k = 0; k < 2; k++) {
				ndo_codec_hist_init(&h[k], (size_t)N), ndo_codec_hist_init(&fh[k], (size_t)N);
				f[k] = fh[k].f[0];
			}
			ndo_codec_hist_init(&rh, (size_t)N), ndo_codec_hist_init(&rfh, (size_t)N);
			rf = rfh.f[0];
			double *x = malloc(3 * (size_t)N * sizeof *x), *v = malloc(3 * (size_t)N * sizeof *v),
			       *xo = malloc(3 * (size_t)N * sizeof *xo), *vo = malloc(3 * (size_t)N * sizeof *vo);
			uint8_t *cls = malloc((size_t)N);
			for (int n = 0; n < N; n++)
				cls[n] = mixed && n % 7 == 3 ? NDO_NODE_EXACT : NDO_NODE_LOSSY;
			int same = 1, held = 1, ok = 1;
			for (int64_t s = 0; s < 40; s++) {
				for (int n = 0; n < N; n++) {
					const int i = n % C, j = n / C;
					const double u = i / (double)(C > 1 ? C - 1 : 1),
					             w = j / (double)(R > 1 ? R - 1 : 1), t = 0.02 * (double)s;
					x[3 * n] = 2 * u - 1 + 0.2 * sin(3 * w + t + 0.3 * i * j);
					x[3 * n + 1] = 2 * w - 1 + 0.2 * cos(2 * u - t);
					x[3 * n + 2] = 0.3 * sin(4 * u) * cos(3 * w) + 0.2 * sin(5 * u + 7 * w + 2 * t);
					v[3 * n] = v[3 * n + 1] = v[3 * n + 2] = 0.01;
				}
				uint8_t *data[2];
				size_t len[2];
				int64_t base[2];
				int un;
				for (int k = 0; k < 2; k++) {
					ndo__codec_hier_general = k;
					ndo_codec_input in = {R, C, x, v, cls, s, 0.01 * (double)s, 0, 0};
					ok &= ndo_codec_encode(&p, NULL, &h[k], 0, &in, &data[k], &len[k], &base[k],
					                       &f[k], &un) == 0;
					if (base[k] < 0)
						ndo_codec_hist_clear(&h[k]);
					ndo_codec_hist_put(&h[k], &f[k]);
				}
				ndo__codec_hier_general = 0;
				same &= len[0] == len[1] && !memcmp(data[0], data[1], len[0]);
				ndo_drop r = ndo_codec_decode(&p, NULL, &rh, R, C, data[0], len[0], s,
				                              0.01 * (double)s, 0, base[0], xo, vo, &rf);
				ok &= r == NDO_DROP_NONE;
				if (r == NDO_DROP_NONE) {
					if (base[0] < 0)
						ndo_codec_hist_clear(&rh);
					ndo_codec_hist_put(&rh, &rf);
					for (int n = 0; n < N; n++) {
						double at[3];
						ndo_codec_frame_position(&p, &f[0], n, at);
						for (int d = 0; d < 3; d++)
							held &= xo[3 * n + d] == at[d];
					}
				}
				free(data[0]), free(data[1]);
			}
			CHECK(ok && same && held, "%d x %d, %s: the same payloads %d, held %d, decoded %d", R, C,
			      mixed ? "mixed" : "all LOSSY", same, held, ok);
			for (int k = 0; k < 2; k++)
				ndo_codec_hist_free(&h[k]), ndo_codec_hist_free(&fh[k]);
			ndo_codec_hist_free(&rh), ndo_codec_hist_free(&rfh);
			free(x), free(v), free(xo), free(vo), free(cls);
		}
}

static void fewer_bytes_than_predict(void)
{
	run h = tiles("hier:1e-4:16", 0), p = tiles("predict:1e-4:16", 0);
	CHECK(h.bytes < p.bytes, "hier %zu bytes, predict %zu", h.bytes, p.bytes);
	printf("    hier %zu bytes, predict %zu (%.2fx)\n", h.bytes, p.bytes,
	       (double)h.bytes / (double)p.bytes);
}

/* A frame of a 17 x 33 patch with EXACT and SKIP nodes, predicted from
 * two before: every truncation is corrupt, a byte added is corrupt,
 * changed bytes are dropped or decoded. */
static void hostile_payloads(void)
{
	enum { R = 17, C = 33, NN = R * C };
	ndo_codec_params p;
	ndo_codec_parse("hier:1e-4", &p);
	for (int d = 0; d < 3; d++)
		p.lo[d] = -1.5, p.ext[d] = 3;
	static double x[3 * NN], v[3 * NN], xo[3 * NN], vo[3 * NN];
	uint8_t cls[NN];
	for (int n = 0; n < NN; n++)
		cls[n] = n % C > 28 ? NDO_NODE_SKIP : n % C == 5 ? NDO_NODE_EXACT : NDO_NODE_LOSSY;
	ndo_codec_hist ht, hr, ft, fr;
	ndo_codec_hist_init(&ht, NN), ndo_codec_hist_init(&hr, NN);
	ndo_codec_hist_init(&ft, NN), ndo_codec_hist_init(&fr, NN);
	uint8_t *data = NULL;
	size_t len = 0;
	int64_t base = -1;
	for (int64_t s = 0; s < 4; s++) {
		for (int n = 0; n < NN; n++)
			for (int d = 0; d < 3; d++) {
				x[3 * n + d] = sin(0.1 * n + d + 0.03 * (double)s);
				v[3 * n + d] = cos(0.1 * n + d);
			}
		ndo_codec_input in = {R, C, x, v, cls, s, 0.1 * (double)s, 0, 0};
		int un;
		free(data);
		CHECK(ndo_codec_encode(&p, NULL, &ht, 0, &in, &data, &len, &base, &ft.f[0], &un) == 0,
		      "step %lld encoded", (long long)s);
		ndo_codec_hist_put(&ht, &ft.f[0]);
		if (s < 3) {
			CHECK(ndo_codec_decode(&p, NULL, &hr, R, C, data, len, s, 0.1 * (double)s, 0, base,
			                       xo, vo, &fr.f[0]) == NDO_DROP_NONE, "step %lld decoded",
			      (long long)s);
			ndo_codec_hist_put(&hr, &fr.f[0]);
		}
	}
	CHECK(base == 2, "a predicted frame (base %lld)", (long long)base);
	CHECK(ndo_codec_decode(&p, NULL, &hr, R, C, data, len, 3, 0.3, 0, base, xo, vo, &fr.f[0]) ==
	          NDO_DROP_NONE, "it decodes");
	int all = 1;
	for (size_t cut = 0; cut < len; cut++)
		all &= ndo_codec_decode(&p, NULL, &hr, R, C, data, cut, 3, 0.3, 0, base, xo, vo,
		                        &fr.f[0]) == NDO_DROP_CORRUPT;
	CHECK(all, "every truncation of the %zu bytes is corrupt", len);
	uint8_t *bad = malloc(len + 1);
	memcpy(bad, data, len);
	bad[len] = 0;
	CHECK(ndo_codec_decode(&p, NULL, &hr, R, C, bad, len + 1, 3, 0.3, 0, base, xo, vo,
	                       &fr.f[0]) == NDO_DROP_CORRUPT, "a byte added is corrupt");
	int fine = 1, dropped = 0;
	for (int trial = 0; trial < 2000; trial++) {
		memcpy(bad, data, len);
		for (int k = 0; k < 1 + trial % 3; k++)
			bad[rnd() % len] ^= (uint8_t)(1 + rnd() % 255);
		ndo_drop r = ndo_codec_decode(&p, NULL, &hr, R, C, bad, len, 3, 0.3, 0, base, xo, vo,
		                              &fr.f[0]);
		fine &= r == NDO_DROP_NONE || r == NDO_DROP_CORRUPT;
		dropped += r == NDO_DROP_CORRUPT;
	}
	CHECK(fine && dropped > 1000, "changed bytes: decoded or corrupt (%d of 2000 corrupt)",
	      dropped);
	/* random bytes after a valid header: a frame with a huge residual
	 * stream of ones (the exponent's unary code never ends) */
	for (int trial = 0; trial < 200; trial++) {
		for (size_t k = 3; k < len; k++)
			bad[k] = (uint8_t)rnd();
		ndo_drop r = ndo_codec_decode(&p, NULL, &hr, R, C, bad, len, 3, 0.3, 0, base, xo, vo,
		                              &fr.f[0]);
		fine &= r == NDO_DROP_NONE || r == NDO_DROP_CORRUPT;
	}
	CHECK(fine, "random bodies: decoded or corrupt");
	free(bad), free(data);
	ndo_codec_hist_free(&ht), ndo_codec_hist_free(&hr);
	ndo_codec_hist_free(&ft), ndo_codec_hist_free(&fr);
}

/* codec.c checks the range of the positions hier codes by a product
 * (no code of them made), those near the range's ends or past them again
 * as code_of() does: a frame is refused exactly when a LOSSY position's
 * nearest code (its division) is out of range, NaN and infinities too.
 * (Within a step q below the top, hier itself may refuse one: its codes
 * there, p + 16 r, may have none in range within the bound; not tried.) */
static void positions_at_the_codes_range(void)
{
	enum { R = 3, C = 3, NN = R * C };
	ndo_codec_params p;
	ndo_codec_parse("hier:1e-4", &p);
	for (int d = 0; d < 3; d++)
		p.lo[d] = -1.5, p.ext[d] = 3;
	const quant z = ndo__codec_quant_of(&p);
	const double M = CODE_MAX, T[] = {M - 17, M - 16.75, M - 0.25, M, M + 3, -M + 1, -M + 0.75, -M,
	                                  M / 2 - 1, M / 2, M / 2 + 0.25, -M / 2 + 0.5, -M / 2 - 1,
	                                  2 * M, 0.5};
	enum { NT = sizeof T / sizeof *T };
	double xs[NT + 3];
	for (int k = 0; k < NT; k++) /* t = (x − lo) / q + 0.5 near T */
		xs[k] = z.lo[0] + (T[k] - 0.5) * z.q[0];
	xs[NT] = NAN, xs[NT + 1] = INFINITY, xs[NT + 2] = -INFINITY;
	uint8_t cls[NN];
	memset(cls, NDO_NODE_LOSSY, sizeof cls);
	int agree = 1, refused = 0, taken = 0;
	for (int k = 0; k < NT + 3; k++)
		for (int node = 0; node < NN; node += 4) { /* a corner (the top level), the middle, ... */
			double x[3 * NN], v[3 * NN];
			for (int n = 0; n < 3 * NN; n++)
				x[n] = 0.01 * n, v[n] = 0;
			x[3 * node] = xs[k];
			const double t = (xs[k] - z.lo[0]) / z.q[0] + 0.5;
			const int out = !(t >= -CODE_MAX + 1 && t < CODE_MAX);
			const int either = !out && t > CODE_MAX - 16; /* M − 0.25: no crash */
			ndo_codec_hist h;
			ndo_codec_hist_init(&h, NN);
			ndo_codec_input in = {R, C, x, v, cls, 0, 0, 0, 0};
			uint8_t *data = NULL;
			size_t len = 0;
			int64_t base;
			int un;
			const int rc = ndo_codec_encode(&p, NULL, NULL, 1, &in, &data, &len, &base, &h.f[0], &un);
			if ((!either && (rc != 0) != out) || (rc && !strstr(ndo_errdetail(), "out of the codes' range"))) {
				printf("    x %.17g (t %.17g), node %d: rc %d, %s\n", xs[k], t, node, rc,
				       rc ? ndo_errdetail() : "");
				agree = 0;
			}
			refused += rc != 0, taken += rc == 0;
			free(data);
			ndo_codec_hist_free(&h);
		}
	CHECK(agree && refused > 0 && taken > 0,
	      "refused exactly the positions out of the codes' range (%d refused, %d taken)", refused,
	      taken);
}

int main(void)
{
	ck_program = "test_hier";
	RUN(range_coder_round_trips);
	RUN(tiles_within_the_bound_at_every_node);
	RUN(interior_and_general_stencils_agree);
	RUN(odd_shapes_agree);
	RUN(fewer_bytes_than_predict);
	RUN(hostile_payloads);
	RUN(positions_at_the_codes_range);
	return ck_failed_cases != 0;
}
