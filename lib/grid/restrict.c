/* restrict.c — the grid one level coarser by sampling every other node
 * (ndo/restrict.h). */
#include "ndo/restrict.h"

#include "grid_private.h"
#include "ndo/status.h"

#include <stdlib.h>
#include <string.h>

void ndo_restrict_nodes(int level, size_t node_bytes, const void *in, void *out)
{
	int n = 1 << level, w = 2 * n + 1, h = n + 1;
	int wc = n + 1, hc = n / 2 + 1;
	const unsigned char *src = in;
	unsigned char *dst = out;
	(void)h;
	for (int j = 0; j < hc; j++)
		for (int i = 0; i < wc; i++)
			memcpy(dst + ndo_node(wc, i, j) * node_bytes,
			       src + ndo_node(w, 2 * i, 2 * j) * node_bytes, node_bytes);
}

int ndo_restrict(const ndo_grid *g, int k, ndo_grid **out)
{
	*out = NULL;
	if (k < 0 || k > g->level)
		return ndo__fail(NDO_ERANGE, "cannot restrict a level-%d grid by %d levels", g->level, k);
	if (k == 0)
		return ndo_grid_copy(g, out);
	ndo_grid *c;
	int rc = ndo__grid_alloc(g->level - k, &c);
	if (rc)
		return rc;
	c->time = g->time;
	c->step = g->step;
	free(c->history);
	c->history = strdup(g->history);
	if (!c->history) {
		free(c);
		return ndo__fail(NDO_ENOMEM, "out of memory restricting a grid");
	}
	for (int q = 0; q < g->nchannels; q++) {
		const ndo_channel *s = &g->ch[q];
		size_t nb = (size_t)s->comps * ndo_type_size(s->type);
		ndo_channel *d;
		void *a = NULL, *b = NULL;
		if ((rc = ndo_grid_add(c, s->name, s->type, s->comps, &d)) ||
		    (k > 1 && (!(a = malloc(nb * g->count)) || !(b = malloc(nb * g->count))))) {
			free(a);
			free(b);
			ndo_grid_destroy(c);
			return rc ? rc : ndo__fail(NDO_ENOMEM, "out of memory restricting a grid");
		}
		/* k levels: sample into scratch, then down to the target. */
		const void *from = s->data;
		for (int l = g->level; l > c->level; l--) {
			void *to = l - 1 == c->level ? d->data : (from == a ? b : a);
			ndo_restrict_nodes(l, nb, from, to);
			from = to;
		}
		free(a);
		free(b);
	}
	*out = c;
	return NDO_OK;
}
