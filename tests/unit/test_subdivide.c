/* test_subdivide.c — butterfly subdivision: the fast convolution over the
 * ghost-padded grid against a slow per-edge reference that walks the mesh
 * (a different code path: triangle adjacency, no lattice, no ghost map),
 * on a catalogue of shapes; interpolation bit for bit; stored duplicates
 * agreeing; the corner rules differing exactly where they should.
 *
 * Why not bitwise: the reference sums the same terms in another order, so
 * results agree to a few ulps of the coordinates' scale (tolerance below). */
#include "check.h"
#include "ndo/ndo.h"

#include <float.h>
#include <stdint.h>
#include <stdlib.h>

/* ---- the slow reference: modified butterfly on a triangle mesh ---- */

typedef struct refmesh {
	size_t nv, nt;
	int32_t *tri;   /* distinct vertex ids, oriented */
	int32_t *opp;   /* per directed edge slot: see find_opp */
	int *valence;
} refmesh;

/* A quicker lookup: per vertex, its outgoing directed edges. */
typedef struct adjacency {
	size_t *start;
	int32_t *to, *third;
} adjacency;

static adjacency build_adjacency(const refmesh *m)
{
	adjacency a;
	a.start = calloc(m->nv + 1, sizeof *a.start);
	a.to = malloc(3 * m->nt * sizeof *a.to);
	a.third = malloc(3 * m->nt * sizeof *a.third);
	for (size_t k = 0; k < 3 * m->nt; k++)
		a.start[m->tri[k] + 1]++;
	for (size_t v = 0; v < m->nv; v++)
		a.start[v + 1] += a.start[v];
	size_t *fill = calloc(m->nv, sizeof *fill);
	for (size_t t = 0; t < m->nt; t++)
		for (int k = 0; k < 3; k++) {
			int32_t u = m->tri[3 * t + k];
			size_t s = a.start[u] + fill[u]++;
			a.to[s] = m->tri[3 * t + (k + 1) % 3];
			a.third[s] = m->tri[3 * t + (k + 2) % 3];
		}
	free(fill);
	return a;
}

static int32_t opp(const adjacency *a, int32_t u, int32_t v)
{
	for (size_t s = a->start[u]; s < a->start[u + 1]; s++)
		if (a->to[s] == v)
			return a->third[s];
	return -1;
}

/* Zorin et al. 1996 for an edge from extraordinary vertex e (valence k) to
 * o: (3/4) e + Σ s_j n_j, n_0 = o, n_j walking around e. */
static double extraordinary(const adjacency *a, const double *p, int C, int q, int32_t e,
                            int32_t o, int k)
{
	double s = 0.75 * p[(size_t)e * C + q];
	int32_t n = o;
	for (int j = 0; j < k; j++) {
		double w;
		if (k == 3)
			w = j == 0 ? 5.0 / 12 : -1.0 / 12;
		else if (k == 4)
			w = j == 0 ? 3.0 / 8 : j == 2 ? -1.0 / 8 : 0;
		else
			w = (0.25 + cos(2 * M_PI * j / k) + 0.5 * cos(4 * M_PI * j / k)) / k;
		s += w * p[(size_t)n * C + q];
		n = opp(a, e, n); /* the next neighbour around e */
	}
	return s;
}

static double reference_edge(const adjacency *a, const int *valence, const double *p, int C,
                             int q, int32_t va, int32_t vb, ndo_corner_rule rule)
{
	int ka = valence[va], kb = valence[vb];
	if (rule == NDO_CORNERS_ZORIN && (ka != 6 || kb != 6)) {
		double s = 0;
		int n = 0;
		if (ka != 6)
			s += extraordinary(a, p, C, q, va, vb, ka), n++;
		if (kb != 6)
			s += extraordinary(a, p, C, q, vb, va, kb), n++;
		return s / n;
	}
	int32_t c = opp(a, va, vb), d = opp(a, vb, va);
	int32_t x = opp(a, c, vb), y = opp(a, va, c), z = opp(a, d, va), u = opp(a, vb, d);
#define P(v) p[(size_t)(v) * C + q]
	return 0.5 * (P(va) + P(vb)) + 0.125 * (P(c) + P(d)) -
	       0.0625 * (P(x) + P(y) + P(z) + P(u));
#undef P
}

/* Compare ndo_subdivide on every channel of type f64 against the
 * reference; returns the largest error relative to the data's scale. */
static double compare_with_reference(const ndo_grid *g, ndo_corner_rule rule)
{
	int level = g->level, w = g->w;
	refmesh m = {ndo_vertex_count(level), ndo_triangle_count(level), 0, 0, 0};
	int32_t *vid = malloc(g->count * sizeof *vid), *rep = malloc(m.nv * sizeof *rep);
	int32_t *stri = malloc(3 * m.nt * sizeof *stri);
	m.tri = malloc(3 * m.nt * sizeof *m.tri);
	ndo_vertex_ids(level, vid, rep);
	ndo_triangles(level, stri);
	for (size_t k = 0; k < 3 * m.nt; k++)
		m.tri[k] = vid[stri[k]];
	int *valence = calloc(m.nv, sizeof *valence);
	for (size_t k = 0; k < 3 * m.nt; k++)
		valence[m.tri[k]]++;
	adjacency a = build_adjacency(&m);
	ndo_grid *fine;
	ndo_subdivide(g, rule, &fine);
	double worst = 0;
	for (int c = 0; c < g->nchannels; c++) {
		const ndo_channel *ch = &g->ch[c];
		if (ch->type != NDO_F64)
			continue;
		int C = ch->comps;
		double *p = malloc(m.nv * (size_t)C * sizeof *p), scale = 0;
		for (size_t v = 0; v < m.nv; v++)
			for (int q = 0; q < C; q++) {
				p[v * C + q] = ((const double *)ch->data)[(size_t)rep[v] * C + q];
				scale = fmax(scale, fabs(p[v * C + q]));
			}
		const double *out = ndo_grid_find(fine, ch->name)->data;
		for (size_t t = 0; t < m.nt; t++)
			for (int k = 0; k < 3; k++) {
				int32_t s0 = stri[3 * t + k], s1 = stri[3 * t + (k + 1) % 3];
				int i = s0 % w + s1 % w, j = s0 / w + s1 / w; /* the midpoint, fine lattice */
				size_t f = ndo_canonical(level + 1, i, j);
				for (int q = 0; q < C; q++) {
					double r = reference_edge(&a, valence, p, C, q, vid[s0], vid[s1], rule);
					worst = fmax(worst, fabs(out[f * C + q] - r) / (scale > 0 ? scale : 1));
				}
			}
		free(p);
	}
	ndo_grid_destroy(fine);
	free(vid);
	free(rep);
	free(stri);
	free(m.tri);
	free(valence);
	free(a.start);
	free(a.to);
	free(a.third);
	return worst;
}

static uint64_t rng = 12345;
static double uniform(void)
{
	rng ^= rng << 13, rng ^= rng >> 7, rng ^= rng << 17;
	return (double)(rng >> 11) / 9007199254740992.0;
}

/* The catalogue: every procedural shape, both sphere maps, and random
 * positions (no smoothness to hide behind), each with a random 2-channel
 * field added. */
static ndo_grid *catalogue(int which, int level, const char **name)
{
	static const char *names[] = {"tetra", "sphere", "sphere", "ellipsoid", "wavy", "random"};
	ndo_shape_params sp;
	ndo_shape_defaults(&sp);
	sp.map = which == 2 ? NDO_MAP_GNOMONIC : NDO_MAP_EQUAL_AREA;
	ndo_grid *g;
	ndo_shape_make(which == 5 ? "sphere" : names[which], level, &sp, &g);
	*name = which == 2 ? "sphere(gnomonic)" : names[which];
	double *x = g->ch[0].data;
	if (which == 5)
		for (size_t k = 0; k < 3 * g->count; k++)
			x[k] = uniform() * 2 - 1;
	ndo_channel *f;
	ndo_grid_add(g, "field", NDO_F64, 2, &f);
	for (size_t k = 0; k < 2 * g->count; k++)
		((double *)f->data)[k] = uniform() * 100;
	ndo_grid_sync(g);
	return g;
}

static void fast_matches_slow_reference(void)
{
	for (int rule = 0; rule <= 1; rule++)
		for (int which = 0; which < 6; which++)
			for (int level = 0; level <= 4; level++) {
				const char *name;
				ndo_grid *g = catalogue(which, level, &name);
				double err = compare_with_reference(g, (ndo_corner_rule)rule);
				CHECK(err <= 1e-14, "%s level %d, %s corners: relative error %.3g > 1e-14", name,
				      level, rule ? "thesis" : "zorin", err);
				ndo_grid_destroy(g);
			}
}

static void interpolates_bit_for_bit_and_duplicates_agree(void)
{
	for (int level = 0; level <= 7; level++) {
		const char *name;
		ndo_grid *g = catalogue(4, level, &name), *fine;
		ndo_channel *c;
		ndo_grid_add(g, "v32", NDO_F32, 3, &c);
		for (size_t k = 0; k < 3 * g->count; k++)
			((float *)c->data)[k] = (float)uniform();
		ndo_grid_add(g, NDO_CH_PIN, NDO_U8, 1, &c);
		for (size_t k = 0; k < g->count; k++)
			((uint8_t *)c->data)[k] = uniform() < 0.3;
		ndo_grid_add(g, NDO_CH_OWNER, NDO_I32, 1, &c);
		for (size_t k = 0; k < g->count; k++)
			((int32_t *)c->data)[k] = (int32_t)(uniform() * 5);
		ndo_grid_sync(g);
		CHECK(ndo_subdivide(g, NDO_CORNERS_ZORIN, &fine) == NDO_OK, "subdivide level %d", level);
		CHECK(fine->nchannels == g->nchannels, "channels lost");
		int32_t *vid = malloc(fine->count * sizeof *vid),
		        *rep = malloc(ndo_vertex_count(fine->level) * sizeof *rep);
		ndo_vertex_ids(fine->level, vid, rep);
		for (int ch = 0; ch < g->nchannels; ch++) {
			size_t nb = (size_t)g->ch[ch].comps * ndo_type_size(g->ch[ch].type);
			const unsigned char *a = g->ch[ch].data, *b = fine->ch[ch].data;
			int moved = 0, disagree = 0;
			for (int j = 0; j < g->h; j++)
				for (int i = 0; i < g->w; i++)
					moved += memcmp(a + ndo_node(g->w, i, j) * nb,
					                b + ndo_node(fine->w, 2 * i, 2 * j) * nb, nb) != 0;
			for (size_t k = 0; k < fine->count; k++)
				disagree += memcmp(b + k * nb, b + (size_t)rep[vid[k]] * nb, nb) != 0;
			CHECK(moved == 0, "level %d, channel %s: %d old nodes changed", level,
			      g->ch[ch].name, moved);
			CHECK(disagree == 0, "level %d, channel %s: %d duplicates disagree", level,
			      g->ch[ch].name, disagree);
		}
		free(vid);
		free(rep);
		ndo_grid_destroy(g);
		ndo_grid_destroy(fine);
	}
}

/* The corner rules differ exactly on the fine vertices of the 12 edges at
 * the four corners, and nowhere else. */
static void corner_rules_differ_only_at_corners(void)
{
	for (int level = 1; level <= 5; level++) {
		const char *name;
		ndo_grid *g = catalogue(1, level, &name), *z, *t;
		ndo_subdivide(g, NDO_CORNERS_ZORIN, &z);
		ndo_subdivide(g, NDO_CORNERS_THESIS, &t);
		int32_t *vid = malloc(z->count * sizeof *vid);
		ndo_vertex_ids(z->level, vid, NULL);
		const double *a = z->ch[0].data, *b = t->ch[0].data;
		char *differs = calloc(ndo_vertex_count(z->level), 1);
		double biggest = 0;
		for (size_t k = 0; k < z->count; k++)
			if (memcmp(a + 3 * k, b + 3 * k, 24)) {
				differs[vid[k]] = 1;
				for (int c = 0; c < 3; c++)
					biggest = fmax(biggest, fabs(a[3 * k + c] - b[3 * k + c]));
			}
		int count = 0, expected_place = 1;
		for (size_t v = 0; v < ndo_vertex_count(z->level); v++)
			count += differs[v];
		int n = 1 << level;
		int cc[4][2] = {{0, 0}, {n, 0}, {0, n}, {n, n}};
		for (int c = 0; c < 4; c++)
			for (int d = 0; d < 6; d++)
				expected_place &= differs[vid[ndo_canonical(z->level, 2 * cc[c][0] + ndo_dirs[d][0],
				                                           2 * cc[c][1] + ndo_dirs[d][1])]];
		CHECK(count == 12, "level %d: %d vertices differ between the rules, expected 12", level, count);
		CHECK(expected_place, "level %d: the differing vertices are not the corner edges'", level);
		CHECK(biggest > 1e-6, "level %d: the rules should differ visibly (max %.3g)", level, biggest);
		free(vid);
		free(differs);
		ndo_grid_destroy(g);
		ndo_grid_destroy(z);
		ndo_grid_destroy(t);
	}
}

/* Why the default is Zorin's rule: refining the tetrahedron, the three
 * triangles at a corner must flatten out (a C¹ limit surface: the spread
 * of their normals halves with each level), while the thesis' duplicated
 * edges keep the corner a sharp cone for ever (docs/subdivide.md). */
static double corner_normal_spread(const ndo_grid *f)
{
	int n = f->n;
	const double *x = f->ch[0].data, *c = x + 3 * ndo_node(f->w, n, 0); /* corner B */
	size_t nb[6];
	ndo_neighbors(f->level, n, 0, nb);
	double nrm[3][3], worst = 0;
	for (int k = 0; k < 3; k++) {
		const double *a = x + 3 * nb[k], *b = x + 3 * nb[k + 1];
		double u[3], v[3];
		for (int q = 0; q < 3; q++)
			u[q] = a[q] - c[q], v[q] = b[q] - c[q];
		nrm[k][0] = u[1] * v[2] - u[2] * v[1];
		nrm[k][1] = u[2] * v[0] - u[0] * v[2];
		nrm[k][2] = u[0] * v[1] - u[1] * v[0];
		double r = sqrt(nrm[k][0] * nrm[k][0] + nrm[k][1] * nrm[k][1] + nrm[k][2] * nrm[k][2]);
		for (int q = 0; q < 3; q++)
			nrm[k][q] /= r;
	}
	for (int a = 0; a < 3; a++)
		for (int b = 0; b < a; b++)
			worst = fmax(worst, acos(fmin(1, nrm[a][0] * nrm[b][0] + nrm[a][1] * nrm[b][1] +
			                                     nrm[a][2] * nrm[b][2])));
	return worst * 180 / M_PI;
}

static void zorin_corners_smooth_thesis_corners_stay_sharp(void)
{
	ndo_grid *g;
	ndo_shape_make("tetra", 1, NULL, &g);
	double prev = 0;
	for (int level = 4; level <= 7; level++) {
		ndo_grid *z, *t;
		ndo_subdivide_levels(g, level - 1, NDO_CORNERS_ZORIN, &z);
		ndo_subdivide_levels(g, level - 1, NDO_CORNERS_THESIS, &t);
		double sz = corner_normal_spread(z), st = corner_normal_spread(t);
		CHECK(st > 109 && st < 110, "level %d: thesis corner spread %.2f°, expected the "
		      "tetrahedron's 109.47° for ever", level, st);
		if (level > 4)
			CHECK(sz < 0.55 * prev, "level %d: Zorin corner spread %.2f° did not halve from %.2f°",
			      level, sz, prev);
		prev = sz;
		ndo_grid_destroy(z);
		ndo_grid_destroy(t);
	}
	CHECK(prev < 5, "Zorin corner spread at level 7 is %.2f°", prev);
	ndo_grid_destroy(g);
}

static void constants_and_labels(void)
{
	ndo_grid *g, *f;
	ndo_grid_create(3, &g);
	double *x = g->ch[0].data;
	for (size_t k = 0; k < 3 * g->count; k++)
		x[k] = 3.7;
	ndo_channel *c;
	ndo_grid_add(g, NDO_CH_OWNER, NDO_I32, 1, &c);
	int32_t *own = c->data;
	for (int j = 0; j < g->h; j++)
		for (int i = 0; i < g->w; i++)
			own[ndo_node(g->w, i, j)] = i < g->n ? 1 : 2;
	ndo_grid_sync(g);
	ndo_subdivide(g, NDO_CORNERS_ZORIN, &f);
	double worst = 0;
	const double *y = f->ch[0].data;
	for (size_t k = 0; k < 3 * f->count; k++)
		worst = fmax(worst, fabs(y[k] - 3.7));
	CHECK(worst <= 4 * DBL_EPSILON * 3.7, "a constant field moved by %.3g", worst);
	const int32_t *o = ndo_grid_find(f, NDO_CH_OWNER)->data;
	int bad = 0;
	for (int j = 0; j < f->h; j++)
		for (int i = 0; i < f->w; i++) {
			int32_t v = o[ndo_node(f->w, i, j)];
			bad += v != 1 && v != 2;
			/* a node between owner-2 nodes stays 2 (away from the seams,
			 * where the canonical owner-1 copies win) */
			if (i > f->n + 1 && i < 2 * f->n - 1 && j > 1 && j < f->n - 1)
				bad += v != 2;
		}
	CHECK(bad == 0, "%d labels invented or lost", bad);
	ndo_grid_destroy(g);
	ndo_grid_destroy(f);
}

/* f32 channels are refined in single precision, to within float rounding
 * of the double computation. */
static void float_channels_follow_doubles(void)
{
	const char *name;
	ndo_grid *g = catalogue(4, 4, &name), *f;
	ndo_channel *c;
	ndo_grid_add(g, "p32", NDO_F32, 3, &c);
	const double *x = g->ch[0].data;
	for (size_t k = 0; k < 3 * g->count; k++)
		((float *)c->data)[k] = (float)x[k];
	ndo_subdivide(g, NDO_CORNERS_ZORIN, &f);
	const double *y = f->ch[0].data;
	const float *z = ndo_grid_find(f, "p32")->data;
	double worst = 0;
	for (size_t k = 0; k < 3 * f->count; k++)
		worst = fmax(worst, fabs(y[k] - z[k]));
	CHECK(worst < 1e-6, "float channel off by %.3g", worst);
	ndo_grid_destroy(g);
	ndo_grid_destroy(f);
}

static void reused_buffers_and_limits(void)
{
	const char *name;
	ndo_grid *g = catalogue(3, 5, &name), *f;
	ndo_subdivide(g, NDO_CORNERS_ZORIN, &f);
	size_t fine_n = 3 * f->count;
	double *out = malloc(fine_n * sizeof *out),
	       *scratch = malloc(ndo_butterfly_scratch(5, 3) * sizeof *scratch);
	for (int rep = 0; rep < 2; rep++) {
		memset(out, 0xff, fine_n * sizeof *out);
		ndo_butterfly_f64(5, 3, g->ch[0].data, out, scratch, NDO_CORNERS_ZORIN);
		CHECK(memcmp(out, f->ch[0].data, fine_n * sizeof *out) == 0,
		      "the buffer kernel differs from ndo_subdivide (pass %d)", rep);
	}
	ndo_grid *two, *step;
	CHECK(ndo_subdivide_levels(g, 2, NDO_CORNERS_ZORIN, &two) == NDO_OK, "two levels");
	ndo_subdivide(f, NDO_CORNERS_ZORIN, &step);
	CHECK(two->level == 7 && memcmp(two->ch[0].data, step->ch[0].data, 24 * two->count) == 0,
	      "two levels at once differ from one after another");
	ndo_grid_destroy(two);
	ndo_grid_destroy(f);
	CHECK(ndo_subdivide_levels(g, 6, NDO_CORNERS_ZORIN, &two) == NDO_ERANGE && !two,
	      "level 11 refused");
	ndo_grid *top;
	ndo_grid_create(NDO_MAX_LEVEL, &top);
	CHECK(ndo_subdivide(top, NDO_CORNERS_ZORIN, &f) == NDO_ERANGE && f == NULL,
	      "refining level %d must fail", NDO_MAX_LEVEL);
	ndo_grid_destroy(top);
	ndo_grid_destroy(step);
	free(out);
	free(scratch);
	ndo_grid_destroy(g);
}

int main(void)
{
	ck_program = "subdivide";
	RUN(fast_matches_slow_reference);
	RUN(interpolates_bit_for_bit_and_duplicates_agree);
	RUN(corner_rules_differ_only_at_corners);
	RUN(zorin_corners_smooth_thesis_corners_stay_sharp);
	RUN(constants_and_labels);
	RUN(float_channels_follow_doubles);
	RUN(reused_buffers_and_limits);
	return ck_failed_cases != 0;
}
