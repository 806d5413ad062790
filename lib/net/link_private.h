/* link_private.h — what a link implementation provides (ndo/link.h). */
#ifndef NDO_LINK_PRIVATE_H
#define NDO_LINK_PRIVATE_H

#include "ndo/link.h"

struct ndo_link {
	int (*publish)(ndo_link *, const char *channel, const void *data, size_t len);
	int (*poll)(ndo_link *, double now, ndo_link_fn fn, void *user);
	int (*fileno)(ndo_link *);
	void (*destroy)(ndo_link *);
	uint64_t injected;
	/* optional (NULL: nothing held, never ends) */
	double (*next_due)(const ndo_link *);
	int (*ended)(const ndo_link *);
	char note[200]; /* why it ended early, "" if it did not (ndo_link_note) */
	/* messages lost before this link read them, as the operating system
	 * (or ndo_link_mem_overflow) counted them: ndo_link_overflows */
	uint64_t overflowed;
};

#endif
