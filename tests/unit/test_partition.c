/* test_partition.c — the band partition (ndo/partition.h, NDO_PART_BANDS):
 * whole cell rows, contiguous bands, each cut one row boundary (2N cell
 * edges), each boundary the one nearest its share of the stored nodes as
 * ndo_partition_node_owner() counts them (not the partition's own count),
 * every peer in the band of its POI, and k > N refused. */
#include "check.h"
#include "ndo/ndo.h"
#include "ndo/partition.h"
#include "ndo/quadtree.h"

#include <stdint.h>
#include <stdlib.h>

/* The stored nodes each slot owns, by the owner channel. */
static void owned(int level, const int32_t *cell, int k, long *count)
{
	int n = 1 << level, w = 2 * n + 1;
	int32_t ids[NDO_MAX_PEERS], *own = malloc((size_t)w * (n + 1) * sizeof *own);
	for (int p = 0; p < k; p++)
		ids[p] = p, count[p] = 0;
	ndo_partition_node_owner(level, cell, ids, own);
	for (int j = 0; j <= n; j++)
		for (int i = 0; i < w; i++)
			if (ndo_canonical(level, i, j) == (size_t)j * w + i)
				count[own[j * w + i]]++;
	free(own);
}

static void bands_are_whole_rows_balanced_and_short(void)
{
	for (int level = 1; level <= 7; level++) {
		const int n = 1 << level, w = 2 * n;
		int32_t *cell = malloc((size_t)w * n * sizeof *cell);
		int32_t *one = malloc((size_t)w * n * sizeof *one);
		for (int k = 2; k <= NDO_MAX_PEERS && k <= n; k++) {
			int32_t poi[NDO_MAX_PEERS];
			for (int p = 0; p < k; p++)
				poi[p] = -1;
			int rc = ndo_partition(level, NDO_PART_BANDS, k, poi, cell, NULL);
			CHECK(rc == 0, "level %d, %d bands: rc %d (%s)", level, k, rc, ndo_errdetail());
			if (rc)
				continue;
			/* whole rows; each slot one run of rows; every slot used */
			int order[NDO_MAX_PEERS], nb = 0, whole = 1;
			for (int j = 0; j < n; j++) {
				for (int i = 0; i < w; i++)
					whole &= cell[j * w + i] == cell[j * w];
				if (j == 0 || cell[j * w] != cell[(j - 1) * w])
					order[nb < k ? nb : k - 1] = cell[j * w], nb++;
			}
			CHECK(whole, "level %d, %d bands: a row split", level, k);
			CHECK(nb == k, "level %d: %d bands, %d runs of rows", level, k, nb);
			long cut = ndo_cells_cut(level, cell);
			CHECK(cut == (long)(k - 1) * w, "level %d, %d bands: cut %ld, expected %ld", level,
			      k, cut, (long)(k - 1) * w);
			/* each boundary nearest its share: the owner channel's counts
			 * of the bands so far against those with the boundary a row
			 * up or down */
			long count[NDO_MAX_PEERS], total = 0, before = 0;
			owned(level, cell, k, count);
			for (int p = 0; p < k; p++)
				total += count[p];
			CHECK(total == (long)ndo_vertex_count(level), "level %d: %ld nodes owned of %zu",
			      level, total, ndo_vertex_count(level));
			/* bnd[b]: the first row of band b (in row order) */
			int bnd[NDO_MAX_PEERS + 1], nbnd = 0;
			for (int j = 0; j < n; j++)
				if (j == 0 || cell[j * w] != cell[(j - 1) * w])
					bnd[nbnd < k ? nbnd : k - 1] = j, nbnd++;
			bnd[k] = n;
			for (int b = 0; b + 1 < k && nb == k; b++) {
				before += count[order[b]];
				long want = total * (b + 1) / k;
				for (int d = -1; d <= 1; d += 2) {
					/* the boundary a row down or up, where the partition
					 * could have put it (bands of one row at least) */
					int r = bnd[b + 1] + d;
					if (r <= bnd[b] || r > n - (k - 1 - b))
						continue;
					for (int j = 0; j < n; j++)
						for (int i = 0; i < w; i++)
							one[j * w + i] = j < r ? 0 : 1;
					long c2[2];
					owned(level, one, 2, c2);
					CHECK(labs(before - want) <= labs(c2[0] - want),
					      "level %d, %d bands, boundary %d at row %d: %ld nodes below, "
					      "row %d would give %ld (want %ld)",
					      level, k, b, bnd[b + 1], before, r, c2[0], want);
				}
			}
		}
		free(cell), free(one);
	}
}

static void bands_go_to_the_peers_of_their_pois(void)
{
	const int level = 5, n = 1 << level, w = 2 * n;
	int32_t *cell = malloc((size_t)w * n * sizeof *cell);
	/* POIs in the top, bottom and middle rows, in that order: peer 0 must
	 * get the top band, 1 the bottom one, 2 the middle */
	int rows[3] = {n - 1, 0, n / 2};
	int32_t poi[3];
	for (int p = 0; p < 3; p++)
		poi[p] = 2 * (rows[p] * w + 7); /* face 2c lies in cell c */
	CHECK(ndo_partition(level, NDO_PART_BANDS, 3, poi, cell, NULL) == 0, "3 bands: %s",
	      ndo_errdetail());
	for (int p = 0; p < 3; p++)
		CHECK(cell[ndo_face_cell(poi[p])] == p, "peer %d's POI in slot %d's band", p,
		      cell[ndo_face_cell(poi[p])]);
	/* two POIs in one band: the second peer gets the band left */
	poi[1] = poi[0];
	poi[0] = 2 * ((n - 2) * w + 3);
	CHECK(ndo_partition(level, NDO_PART_BANDS, 2, poi, cell, NULL) == 0, "2 bands: %s",
	      ndo_errdetail());
	CHECK(cell[ndo_face_cell(poi[0])] == 0 && cell[0] == 1, "peer 0 the top band, 1 the other");
	free(cell);
}

static void more_bands_than_rows_refused(void)
{
	int32_t cell[2 * 4 * 4], poi[5] = {-1, -1, -1, -1, -1};
	CHECK(ndo_partition(2, NDO_PART_BANDS, 5, poi, cell, NULL) == NDO_EINVAL,
	      "5 bands of 4 rows: expected NDO_EINVAL");
	CHECK(ndo_partition(2, NDO_PART_BANDS, 4, poi, cell, NULL) == 0, "4 bands of 4 rows");
	CHECK(ndo_part_method_parse("bands") == NDO_PART_BANDS, "'bands' parses");
}

int main(void)
{
	ck_program = "partition";
	RUN(bands_are_whole_rows_balanced_and_short);
	RUN(bands_go_to_the_peers_of_their_pois);
	RUN(more_bands_than_rows_refused);
	return ck_failed_cases != 0;
}
