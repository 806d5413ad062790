/* partition_metis.c — METIS k-way on the cell graph (ndo/partition.h). */
#include "ndo/partition.h"
#include "ndo/quadtree.h"
#include "ndo/status.h"

#include <metis.h>
#include <stdlib.h>

int ndo_partition_metis(int level, int k, int32_t *cell)
{
	idx_t nv = (idx_t)ndo_cell_count(level), ncon = 1, nparts = k, objval = 0;
	if (k == 1) {
		for (idx_t c = 0; c < nv; c++)
			cell[c] = 0;
		return 0;
	}
	idx_t *xadj = malloc(((size_t)nv + 1) * sizeof *xadj);
	idx_t *adj = malloc((size_t)nv * 4 * sizeof *adj);
	idx_t *part = malloc((size_t)nv * sizeof *part);
	if (!xadj || !adj || !part) {
		free(xadj), free(adj), free(part);
		return ndo__fail(NDO_ENOMEM, "METIS: out of memory");
	}
	int w = 2 << level, n = 1 << level;
	for (int j = 0; j < n; j++)
		for (int i = 0; i < w; i++) {
			int32_t nb[4];
			ndo_cell_neighbors(level, i, j, nb);
			idx_t c = j * w + i;
			xadj[c] = 4 * c;
			for (int q = 0; q < 4; q++)
				adj[4 * c + q] = nb[q];
		}
	xadj[nv] = 4 * nv;
	idx_t opt[METIS_NOPTIONS];
	METIS_SetDefaultOptions(opt);
	opt[METIS_OPTION_UFACTOR] = 50; /* 1.05: the goal the quad tree is held to */
	opt[METIS_OPTION_SEED] = 1;
	opt[METIS_OPTION_CONTIG] = 1;
	int rc = METIS_PartGraphKway(&nv, &ncon, xadj, adj, NULL, NULL, NULL, &nparts, NULL,
	                             NULL, opt, &objval, part);
	for (idx_t c = 0; c < nv; c++)
		cell[c] = (int32_t)part[c];
	free(xadj), free(adj), free(part);
	return rc == METIS_OK ? 0 : ndo__fail(NDO_EINVAL, "METIS failed (%d)", rc);
}
