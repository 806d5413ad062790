/* test_topology.c — the grid's facts from DESIGN.md, proven for levels 0–8:
 * closed, manifold, consistently oriented, Euler characteristic 2,
 * valence 6 except four valence-3 corners; the ghost map gives exactly the
 * mesh neighbours (and the exact 2-ring away from the corners); stored
 * duplicates are what the seams say and sync makes them agree. */
#include "check.h"
#include "ndo/ndo.h"

#include <stdint.h>
#include <stdlib.h>

enum { MAX_TEST_LEVEL = 8 };

static int cmp_u64(const void *a, const void *b)
{
	uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
	return x < y ? -1 : x > y;
}

static uint64_t key(int32_t a, int32_t b)
{
	return (uint64_t)(uint32_t)a << 32 | (uint32_t)b;
}

/* The mesh of a level as distinct-vertex triangles. */
typedef struct mesh {
	int level;
	size_t nv, nt, count;
	int32_t *vid, *rep, *tri; /* tri: distinct vertex ids */
} mesh;

static mesh make_mesh(int level)
{
	mesh m = {level, ndo_vertex_count(level), ndo_triangle_count(level), 0, 0, 0, 0};
	int n = 1 << level;
	m.count = (size_t)(2 * n + 1) * (size_t)(n + 1);
	m.vid = malloc(m.count * sizeof *m.vid);
	m.rep = malloc(m.nv * sizeof *m.rep);
	m.tri = malloc(3 * m.nt * sizeof *m.tri);
	ndo_vertex_ids(level, m.vid, m.rep);
	ndo_triangles(level, m.tri);
	for (size_t k = 0; k < 3 * m.nt; k++)
		m.tri[k] = m.vid[m.tri[k]];
	return m;
}

static void free_mesh(mesh *m)
{
	free(m->vid);
	free(m->rep);
	free(m->tri);
}

/* Every directed edge once (consistent orientation), its reverse present
 * (closed, two faces per edge): then E = 3F/2 and χ = V − E + F. */
static void closed_oriented_euler(void)
{
	for (int level = 0; level <= MAX_TEST_LEVEL; level++) {
		mesh m = make_mesh(level);
		size_t ne = 3 * m.nt;
		uint64_t *dir = malloc(ne * sizeof *dir);
		int degenerate = 0;
		for (size_t t = 0; t < m.nt; t++)
			for (int k = 0; k < 3; k++) {
				int32_t a = m.tri[3 * t + k], b = m.tri[3 * t + (k + 1) % 3];
				degenerate += a == b;
				dir[3 * t + k] = key(a, b);
			}
		qsort(dir, ne, sizeof *dir, cmp_u64);
		size_t repeated = 0, unpaired = 0;
		for (size_t k = 0; k + 1 < ne; k++)
			repeated += dir[k] == dir[k + 1];
		for (size_t k = 0; k < ne; k++) {
			uint64_t rev = key((int32_t)(dir[k] & 0xffffffffu), (int32_t)(dir[k] >> 32));
			unpaired += bsearch(&rev, dir, ne, sizeof *dir, cmp_u64) == NULL;
		}
		long chi = (long)m.nv - (long)(ne / 2) + (long)m.nt;
		CHECK(degenerate == 0, "level %d: %d degenerate triangles", level, degenerate);
		CHECK(repeated == 0, "level %d: %zu directed edges repeated (orientation not consistent)",
		      level, repeated);
		CHECK(unpaired == 0, "level %d: %zu edges without a reverse (not closed)", level, unpaired);
		CHECK(m.nv == 2 * ((size_t)1 << (2 * level)) + 2, "level %d: %zu vertices", level, m.nv);
		CHECK(m.nt == (size_t)1 << (2 * level + 2), "level %d: %zu triangles", level, m.nt);
		CHECK(chi == 2, "level %d: Euler characteristic %ld, expected 2", level, chi);
		free(dir);
		free_mesh(&m);
	}
}

/* Valence from the triangles; each vertex's link is one cycle (manifold). */
static void valence_and_manifold_vertices(void)
{
	for (int level = 0; level <= MAX_TEST_LEVEL; level++) {
		mesh m = make_mesh(level);
		int *deg = calloc(m.nv, sizeof *deg);
		for (size_t t = 0; t < 3 * m.nt; t++)
			deg[m.tri[t]]++;
		/* link: for vertex v in triangle (v, a, b), the link edge a→b; a
		 * manifold vertex's link edges chain into one cycle of length deg */
		int32_t *next = malloc(3 * m.nt * sizeof *next);
		size_t *start = calloc(m.nv + 1, sizeof *start);
		for (size_t v = 0; v < m.nv; v++)
			start[v + 1] = start[v] + (size_t)deg[v];
		size_t *fill = calloc(m.nv, sizeof *fill);
		int32_t *from = malloc(3 * m.nt * sizeof *from);
		for (size_t t = 0; t < m.nt; t++)
			for (int k = 0; k < 3; k++) {
				int32_t v = m.tri[3 * t + k];
				size_t s = start[v] + fill[v]++;
				from[s] = m.tri[3 * t + (k + 1) % 3];
				next[s] = m.tri[3 * t + (k + 2) % 3];
			}
		int bad_link = 0, corners = 0, bad_valence = 0;
		for (size_t v = 0; v < m.nv; v++) {
			int d = deg[v];
			if (d == 3)
				corners++;
			else if (d != 6)
				bad_valence++;
			/* walk from the first link edge: must return after exactly d steps */
			int32_t cur = next[start[v]];
			int steps = 1;
			while (cur != from[start[v]] && steps <= d) {
				size_t s = start[v];
				while (s < start[v + 1] && from[s] != cur)
					s++;
				if (s == start[v + 1])
					break;
				cur = next[s];
				steps++;
			}
			bad_link += !(cur == from[start[v]] && steps == d);
		}
		CHECK(corners == 4, "level %d: %d vertices of valence 3, expected 4", level, corners);
		CHECK(bad_valence == 0, "level %d: %d vertices neither valence 6 nor 3", level, bad_valence);
		CHECK(bad_link == 0, "level %d: %d vertices whose link is not one cycle", level, bad_link);
		int n = 1 << level;
		int cc[4][2] = {{0, 0}, {n, 0}, {0, n}, {n, n}};
		for (int c = 0; c < 4; c++) {
			int32_t v = m.vid[ndo_node(2 * n + 1, cc[c][0], cc[c][1])];
			CHECK(deg[v] == 3, "level %d: corner %c has valence %d", level, "ABCD"[c], deg[v]);
			CHECK(ndo_is_corner(level, cc[c][0], cc[c][1]), "corner flag");
		}
		free(deg);
		free(next);
		free(start);
		free(fill);
		free(from);
		free_mesh(&m);
	}
}

/* The ghost map's six neighbours are the mesh neighbours: distinct and in
 * counter-clockwise order (consecutive pairs are triangles of the mesh,
 * with the node, in the mesh's orientation) for valence 6, each twice for
 * the corners. */
static void ghost_neighbours_are_mesh_neighbours(void)
{
	for (int level = 0; level <= 7; level++) {
		mesh m = make_mesh(level);
		size_t ne = 3 * m.nt;
		uint64_t *faces = malloc(ne * sizeof *faces);
		/* each oriented triangle as (v, a) → b, keyed by v and a */
		for (size_t t = 0; t < m.nt; t++)
			for (int k = 0; k < 3; k++)
				faces[3 * t + k] = key(m.tri[3 * t + k], m.tri[3 * t + (k + 1) % 3]);
		qsort(faces, ne, sizeof *faces, cmp_u64);
		int n = 1 << level, w = 2 * n + 1, bad = 0, badcorner = 0;
		for (int j = 0; j <= n; j++)
			for (int i = 0; i <= 2 * n; i++) {
				size_t nb[6];
				ndo_neighbors(level, i, j, nb);
				int32_t v = m.vid[ndo_node(w, i, j)], u[6];
				for (int k = 0; k < 6; k++)
					u[k] = m.vid[nb[k]];
				/* consecutive neighbours (u_k, u_k+1) must be an oriented
				 * triangle v → u_k → u_k+1 of the mesh */
				for (int k = 0; k < 6; k++) {
					uint64_t e = key(v, u[k]);
					if (!bsearch(&e, faces, ne, sizeof *faces, cmp_u64))
						bad++;
				}
				int distinct = 0;
				for (int k = 0; k < 6; k++) {
					int seen = 0;
					for (int q = 0; q < k; q++)
						seen |= u[q] == u[k];
					distinct += !seen && u[k] != v;
				}
				if (ndo_is_corner(level, i, j)) {
					badcorner += distinct != 3;
					for (int k = 0; k < 3; k++)
						badcorner += u[k] != u[k + 3];
				} else {
					bad += distinct != 6;
				}
			}
		CHECK(bad == 0, "level %d: %d wrong ghost neighbours", level, bad);
		CHECK(badcorner == 0, "level %d: corners' neighbours do not come twice", level);
		free(faces);
		free_mesh(&m);
	}
}

/* Breadth-first graph distances from the four corners. */
static int *corner_distance(const mesh *m)
{
	int n = 1 << m->level, w = 2 * n + 1;
	int *dist = malloc(m->nv * sizeof *dist), *queue = malloc(m->nv * sizeof *queue);
	for (size_t v = 0; v < m->nv; v++)
		dist[v] = -1;
	int head = 0, tail = 0;
	int cc[4][2] = {{0, 0}, {n, 0}, {0, n}, {n, n}};
	for (int c = 0; c < 4; c++) {
		int32_t v = m->vid[ndo_node(w, cc[c][0], cc[c][1])];
		dist[v] = 0;
		queue[tail++] = v;
	}
	while (head < tail) {
		int32_t v = queue[head++];
		size_t s = (size_t)m->rep[v];
		size_t nb[6];
		ndo_neighbors(m->level, (int)(s % (size_t)w), (int)(s / (size_t)w), nb);
		for (int k = 0; k < 6; k++) {
			int32_t u = m->vid[nb[k]];
			if (dist[u] < 0) {
				dist[u] = dist[v] + 1;
				queue[tail++] = u;
			}
		}
	}
	free(queue);
	return dist;
}

/* DESIGN.md: for nodes at graph distance ≥ 3 from every corner the ghost
 * map reproduces the 2-ring exactly: the 12 lattice points at lattice
 * distance 2 are 12 distinct vertices, none of them in the 1-ring. */
static void ghost_two_ring_away_from_corners(void)
{
	static const int ring2[12][2] = {{2, 0}, {1, 1}, {0, 2}, {-1, 2}, {-2, 2}, {-2, 1},
	                                 {-2, 0}, {-1, -1}, {0, -2}, {1, -2}, {2, -2}, {2, -1}};
	for (int level = 3; level <= 6; level++) {
		mesh m = make_mesh(level);
		int *dist = corner_distance(&m);
		int n = 1 << level, w = 2 * n + 1, bad = 0, checked = 0;
		for (int j = 0; j <= n; j++)
			for (int i = 0; i <= 2 * n; i++) {
				int32_t v = m.vid[ndo_node(w, i, j)];
				if (dist[v] < 3)
					continue;
				checked++;
				size_t nb[6];
				ndo_neighbors(level, i, j, nb);
				int32_t r[12];
				for (int k = 0; k < 12; k++) {
					int a = i + ring2[k][0], b = j + ring2[k][1];
					ndo_ghost(level, &a, &b);
					r[k] = m.vid[ndo_node(w, a, b)];
					for (int q = 0; q < k; q++)
						bad += r[q] == r[k];
					for (int q = 0; q < 6; q++)
						bad += m.vid[nb[q]] == r[k];
					bad += r[k] == v;
					/* and every one is a neighbour of the 1-ring */
					int adjacent = 0;
					for (int q = 0; q < 6; q++) {
						size_t s = nb[q], nn[6];
						ndo_neighbors(level, (int)(s % (size_t)w), (int)(s / (size_t)w), nn);
						for (int z = 0; z < 6; z++)
							adjacent |= m.vid[nn[z]] == r[k];
					}
					bad += !adjacent;
				}
			}
		CHECK(checked > 0, "level %d: no node far from the corners", level);
		CHECK(bad == 0, "level %d: %d 2-ring mismatches away from the corners", level, bad);
		free(dist);
		free_mesh(&m);
	}
}

/* The duplicates are the identifications of DESIGN.md, the canonical one
 * is the lowest index, and the ghost map lands inside the rectangle. */
static void duplicates_and_canonical(void)
{
	for (int level = 0; level <= MAX_TEST_LEVEL; level++) {
		int n = 1 << level, w = 2 * n + 1;
		mesh m = make_mesh(level);
		size_t nd = ndo_duplicate_count(level);
		size_t *pairs = malloc(2 * nd * sizeof *pairs);
		ndo_duplicates(level, pairs);
		CHECK(m.count - m.nv == nd, "level %d: %zu stored − %zu vertices ≠ %zu duplicates",
		      level, m.count, m.nv, nd);
		int bad = 0;
		for (size_t k = 0; k < nd; k++)
			bad += m.vid[pairs[2 * k]] != m.vid[pairs[2 * k + 1]] || pairs[2 * k + 1] >= pairs[2 * k];
		CHECK(bad == 0, "level %d: %d bad duplicate pairs", level, bad);
		for (int j = 0; j <= n; j++) {
			CHECK(m.vid[ndo_node(w, 0, j)] == m.vid[ndo_node(w, 2 * n, j)],
			      "level %d: (0,%d) ≢ (2N,%d)", level, j, j);
		}
		for (int i = 0; i <= 2 * n; i++) {
			CHECK(m.vid[ndo_node(w, i, 0)] == m.vid[ndo_node(w, 2 * n - i, 0)], "bottom fold");
			CHECK(m.vid[ndo_node(w, i, n)] == m.vid[ndo_node(w, 2 * n - i, n)], "top fold");
		}
		for (int b = -3; b <= n + 3; b++)
			for (int a = -3; a <= 2 * n + 3; a++) {
				int i = a, j = b;
				ndo_ghost(level, &i, &j);
				bad += i < 0 || i > 2 * n || j < 0 || j > n;
				size_t c = ndo_canonical(level, a, b);
				bad += (size_t)m.rep[m.vid[c]] != c;
			}
		CHECK(bad == 0, "level %d: ghost map or canonical index wrong", level);
		free(pairs);
		free_mesh(&m);
	}
}

/* ndo_pad's ghost cells hold the ghost-mapped node's values. */
static void pad_holds_ghost_values(void)
{
	for (int level = 0; level <= 5; level++) {
		int n = 1 << level, w = 2 * n + 1, h = n + 1;
		for (int pad = 1; pad <= 3; pad++) {
			int pw = w + 2 * pad, ph = h + 2 * pad;
			int32_t *src = malloc((size_t)w * h * sizeof *src),
			        *dst = malloc((size_t)pw * ph * sizeof *dst);
			for (int k = 0; k < w * h; k++)
				src[k] = k;
			ndo_pad(level, pad, src, sizeof *src, dst);
			int bad = 0;
			for (int j = -pad; j < h + pad; j++)
				for (int i = -pad; i < w + pad; i++) {
					int a = i, b = j;
					if (i < 0 || i >= w || j < 0 || j >= h)
						ndo_ghost(level, &a, &b);
					bad += dst[(j + pad) * pw + i + pad] != (int32_t)ndo_node(w, a, b);
				}
			CHECK(bad == 0, "level %d pad %d: %d wrong cells", level, pad, bad);
			free(src);
			free(dst);
		}
	}
}

/* After sync every set of stored duplicates holds the canonical bytes. */
static void sync_makes_duplicates_agree(void)
{
	for (int level = 0; level <= 6; level++) {
		ndo_grid *g;
		ndo_grid_create(level, &g);
		ndo_channel *pin, *own;
		ndo_grid_add(g, NDO_CH_PIN, NDO_U8, 1, &pin);
		ndo_grid_add(g, NDO_CH_OWNER, NDO_I32, 1, &own);
		srand(7 + level);
		double *x = ndo_grid_find(g, NDO_CH_POSITION)->data;
		pin = ndo_grid_find(g, NDO_CH_PIN);
		own = ndo_grid_find(g, NDO_CH_OWNER);
		for (size_t k = 0; k < g->count; k++) {
			for (int c = 0; c < 3; c++)
				x[3 * k + c] = rand() / (double)RAND_MAX;
			((uint8_t *)pin->data)[k] = (uint8_t)rand();
			((int32_t *)own->data)[k] = rand();
		}
		size_t canon_before = ndo_canonical(level, 1, 0);
		double keep = x[3 * canon_before];
		ndo_grid_sync(g);
		int32_t *vid = malloc(g->count * sizeof *vid), *rep = malloc(ndo_vertex_count(level) * sizeof *rep);
		ndo_vertex_ids(level, vid, rep);
		int bad = 0;
		for (size_t k = 0; k < g->count; k++) {
			size_t r = (size_t)rep[vid[k]];
			bad += memcmp(&x[3 * k], &x[3 * r], 24) != 0;
			bad += ((uint8_t *)pin->data)[k] != ((uint8_t *)pin->data)[r];
			bad += ((int32_t *)own->data)[k] != ((int32_t *)own->data)[r];
		}
		CHECK(bad == 0, "level %d: %d duplicates disagree after sync", level, bad);
		CHECK(x[3 * canon_before] == keep, "level %d: sync changed a canonical node", level);
		free(vid);
		free(rep);
		ndo_grid_destroy(g);
	}
}

/* ndo_sync for any node size (its fast paths for 1, 4, 8, 12 and 24 bytes
 * and the general one) against the slow reference: every duplicate pair of
 * ndo_duplicates() copied with memcpy, in the pairs' order; and
 * ndo_duplicate_of against the same pairs. */
static void sync_sizes_are_the_reference(void)
{
	const size_t sizes[] = {1, 2, 4, 8, 12, 16, 24, 40};
	for (int level = 0; level <= 6; level++) {
		size_t count = ndo_vertex_count(level) + ndo_duplicate_count(level);
		size_t npairs = ndo_duplicate_count(level);
		size_t *pairs = malloc(2 * npairs * sizeof *pairs);
		ndo_duplicates(level, pairs);
		/* ndo_duplicate_of: each pair's canonical node names its duplicate,
		 * and no other node has one */
		long *dup = malloc(count * sizeof *dup);
		for (size_t k = 0; k < count; k++)
			dup[k] = -1;
		int bad = 0;
		for (size_t k = 0; k < npairs; k++) {
			bad += dup[pairs[2 * k + 1]] != -1; /* a second duplicate */
			dup[pairs[2 * k + 1]] = (long)pairs[2 * k];
		}
		for (size_t k = 0; k < count; k++)
			bad += ndo_duplicate_of(level, k) != dup[k];
		CHECK(bad == 0, "level %d: ndo_duplicate_of differs from ndo_duplicates at %d nodes", level,
		      bad);
		free(dup);
		for (size_t z = 0; z < sizeof sizes / sizeof *sizes; z++) {
			size_t nb = sizes[z];
			unsigned char *fast = malloc(count * nb), *slow = malloc(count * nb);
			srand((unsigned)(11 * level + (int)nb));
			for (size_t k = 0; k < count * nb; k++)
				fast[k] = slow[k] = (unsigned char)rand();
			ndo_sync(level, fast, nb);
			for (size_t k = 0; k < npairs; k++)
				memcpy(slow + pairs[2 * k] * nb, slow + pairs[2 * k + 1] * nb, nb);
			CHECK(memcmp(fast, slow, count * nb) == 0, "level %d, %zu-byte nodes: ndo_sync "
			      "differs from the pairs copied one by one", level, nb);
			free(fast);
			free(slow);
		}
		free(pairs);
	}
}

int main(void)
{
	ck_program = "topology";
	RUN(closed_oriented_euler);
	RUN(valence_and_manifold_vertices);
	RUN(ghost_neighbours_are_mesh_neighbours);
	RUN(ghost_two_ring_away_from_corners);
	RUN(duplicates_and_canonical);
	RUN(pad_holds_ghost_values);
	RUN(sync_makes_duplicates_agree);
	RUN(sync_sizes_are_the_reference);
	return ck_failed_cases != 0;
}
