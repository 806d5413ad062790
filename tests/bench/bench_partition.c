/* bench_partition — the partition study (tests/bench/partition.sh,
 * docs/bench/partition.md): area imbalance (largest share / mean), cut
 * length and quad-tree leaves of the thesis' Table 4.1, the improved quad
 * tree and METIS, over many random points of interest for 2..8 peers.
 *
 *   bench_partition [-l LEVEL] [-r TRIALS] [-s SEED] [-d DUMPDIR]
 *
 * -d writes, for 3 and 5 peers of the first trial, each method's cell
 * labels as DUMPDIR/METHOD-kK.txt (one row of cells per line) and the
 * POIs' cells as DUMPDIR/pois-kK.txt, for tests/bench/partition_plot.py. */
#include "ndo/link.h"
#include "ndo/partition.h"
#include "ndo/quadtree.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static int cmp_d(const void *a, const void *b)
{
	double x = *(const double *)a, y = *(const double *)b;
	return (x > y) - (x < y);
}

static double median(double *v, int n)
{
	qsort(v, (size_t)n, sizeof *v, cmp_d);
	return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

static void dump(const char *dir, const char *name, int k, int level, const int32_t *cell)
{
	char path[512];
	snprintf(path, sizeof path, "%s/%s-k%d.txt", dir, name, k);
	FILE *f = fopen(path, "w");
	if (!f)
		return;
	int w = 2 << level, n = 1 << level;
	for (int j = 0; j < n; j++)
		for (int i = 0; i < w; i++)
			fprintf(f, "%d%c", cell[j * w + i], i + 1 < w ? ' ' : '\n');
	fclose(f);
}

int main(int argc, char **argv)
{
	int level = 6, trials = 100, c;
	uint64_t seed = 1;
	const char *dumpdir = NULL;
	while ((c = getopt(argc, argv, "l:r:s:d:")) != -1) {
		switch (c) {
		case 'l': level = atoi(optarg); break;
		case 'r': trials = atoi(optarg); break;
		case 's': seed = strtoull(optarg, NULL, 10); break;
		case 'd': dumpdir = optarg; break;
		default: return 2;
		}
	}
	if (level < 2 || level > 9 || trials < 1 || trials > 100000)
		return 2;
	size_t nc = ndo_cell_count(level);
	int32_t *cell = malloc(nc * sizeof *cell);
	double *imb[3], *cut[3], *ratio[2], *leaves[3], *secs[3];
	int cover[3];
	for (int m = 0; m < 3; m++) {
		imb[m] = malloc((size_t)trials * sizeof(double));
		cut[m] = malloc((size_t)trials * sizeof(double));
		leaves[m] = malloc((size_t)trials * sizeof(double));
		secs[m] = malloc((size_t)trials * sizeof(double));
	}
	ratio[0] = malloc((size_t)trials * sizeof(double));
	ratio[1] = malloc((size_t)trials * sizeof(double));
	const ndo_part_method methods[3] = {NDO_PART_TABLE41, NDO_PART_QUADTREE, NDO_PART_METIS};
	printf("| peers | method | imbalance median | imbalance max | trials ≤ 1.05 | cut median "
	       "| cut / METIS median | cut / METIS max | POI in own region | leaves median | ms median |\n");
	printf("|---|---|---|---|---|---|---|---|---|---|---|\n");
	for (int k = 2; k <= 8; k++) {
		uint64_t rng = seed * 1000 + (uint64_t)k;
		int ok[3] = {0, 0, 0};
		memset(cover, 0, sizeof cover);
		for (int t = 0; t < trials; t++) {
			int32_t poi[NDO_MAX_PEERS];
			for (int p = 0; p < k; p++)
				poi[p] = (int32_t)(ndo_rng_next(&rng) % (2 * nc));
			for (int m = 0; m < 3; m++) {
				double t0 = ndo_now();
				if (ndo_partition(level, methods[m], k, poi, cell, NULL) != 0) {
					fprintf(stderr, "bench_partition: %s failed\n",
					        ndo_part_method_name(methods[m]));
					return 1;
				}
				secs[m][t] = 1e3 * (ndo_now() - t0);
				imb[m][t] = ndo_partition_imbalance(level, cell, k);
				cut[m][t] = (double)ndo_cells_cut(level, cell);
				ok[m] += imb[m][t] <= 1.05 + 1e-12;
				int covered = 0;
				for (int p = 0; p < k; p++)
					covered += cell[ndo_face_cell(poi[p])] == p;
				cover[m] += covered;
				int32_t *codes, *labels;
				size_t nl = 0;
				if (ndo_quad_leaves(level, cell, 0, &codes, &labels, &nl) == 0) {
					free(codes);
					free(labels);
				}
				leaves[m][t] = (double)nl;
				if (dumpdir && t == 0 && (k == 3 || k == 5)) {
					dump(dumpdir, ndo_part_method_name(methods[m]), k, level, cell);
					if (m == 0) {
						int32_t *pc = calloc(nc, sizeof *pc);
						for (size_t q = 0; q < nc; q++)
							pc[q] = -1;
						for (int p = 0; p < k; p++)
							pc[ndo_face_cell(poi[p])] = p;
						dump(dumpdir, "pois", k, level, pc);
						free(pc);
					}
				}
			}
			ratio[0][t] = cut[0][t] / cut[2][t];
			ratio[1][t] = cut[1][t] / cut[2][t];
		}
		for (int m = 0; m < 3; m++) {
			double rmed = m < 2 ? median(ratio[m], trials) : 1.0;
			double rmax = m < 2 ? ratio[m][trials - 1] : 1.0; /* sorted by median() */
			double imax = 0;
			for (int t = 0; t < trials; t++)
				imax = imb[m][t] > imax ? imb[m][t] : imax;
			printf("| %d | %s | %.3f | %.3f | %d/%d | %.0f | %.3f | %.3f | %.1f %% | %.0f | %.2f |\n",
			       k, ndo_part_method_name(methods[m]), median(imb[m], trials), imax, ok[m],
			       trials, median(cut[m], trials), rmed, rmax,
			       100.0 * cover[m] / ((double)trials * k), median(leaves[m], trials),
			       median(secs[m], trials));
		}
	}
	free(cell);
	return 0;
}
