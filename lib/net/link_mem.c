/* link_mem.c — an in-memory bus of links, for tests (ndo/link.h).  Every
 * published message is appended to the bus; each link reads the bus from
 * its own position, so all links see all messages in publication order. */
#include "link_private.h"
#include "ndo/status.h"

#include <stdlib.h>
#include <string.h>

typedef struct bus_msg {
	char *channel;
	uint8_t *data;
	size_t len;
} bus_msg;

struct ndo_bus {
	bus_msg *msgs;
	size_t count, cap;
	size_t base; /* messages [0, base) were freed after every link read them */
	struct mem_link **links;
	int nlinks;
};

typedef struct mem_link {
	ndo_link base;
	ndo_bus *bus;
	size_t next; /* index of the next message to read */
} mem_link;

int ndo_bus_create(ndo_bus **out)
{
	*out = calloc(1, sizeof **out);
	return *out ? 0 : ndo__fail(NDO_ENOMEM, "out of memory");
}

void ndo_bus_destroy(ndo_bus *b)
{
	if (!b)
		return;
	for (size_t k = b->base; k < b->count; k++) {
		free(b->msgs[k - b->base].channel);
		free(b->msgs[k - b->base].data);
	}
	free(b->msgs);
	free(b->links);
	free(b);
}

/* Free messages every link has read. */
static void compact(ndo_bus *b)
{
	size_t low = b->count;
	for (int k = 0; k < b->nlinks; k++)
		if (b->links[k]->next < low)
			low = b->links[k]->next;
	if (low <= b->base)
		return;
	size_t drop = low - b->base;
	for (size_t k = 0; k < drop; k++) {
		free(b->msgs[k].channel);
		free(b->msgs[k].data);
	}
	memmove(b->msgs, b->msgs + drop, (b->count - low) * sizeof *b->msgs);
	b->base = low;
}

static int mem_publish(ndo_link *base, const char *channel, const void *data, size_t len)
{
	ndo_bus *b = ((mem_link *)base)->bus;
	size_t used = b->count - b->base;
	if (used == b->cap) {
		size_t cap = b->cap ? 2 * b->cap : 64;
		bus_msg *m = realloc(b->msgs, cap * sizeof *m);
		if (!m)
			return ndo__fail(NDO_ENOMEM, "out of memory");
		b->msgs = m;
		b->cap = cap;
	}
	bus_msg *m = &b->msgs[used];
	m->channel = strdup(channel);
	m->data = malloc(len ? len : 1);
	if (!m->channel || !m->data) {
		free(m->channel);
		free(m->data);
		return ndo__fail(NDO_ENOMEM, "out of memory");
	}
	if (len)
		memcpy(m->data, data, len);
	m->len = len;
	b->count++;
	return 0;
}

static int mem_poll(ndo_link *base, double now, ndo_link_fn fn, void *user)
{
	mem_link *l = (mem_link *)base;
	ndo_bus *b = l->bus;
	int n = 0;
	/* only what was published before this poll began */
	size_t end = b->count;
	while (l->next < end) {
		bus_msg *m = &b->msgs[l->next - b->base];
		l->next++;
		fn(user, m->channel, m->data, m->len);
		n++;
	}
	compact(b);
	return n;
}

void ndo_link_mem_lose(ndo_link *base)
{
	if (!base || base->poll != mem_poll)
		return;
	mem_link *l = (mem_link *)base;
	l->next = l->bus->count;
	compact(l->bus);
}

void ndo_link_mem_overflow(ndo_link *base)
{
	if (!base || base->poll != mem_poll)
		return;
	base->overflowed += ((mem_link *)base)->bus->count - ((mem_link *)base)->next;
	ndo_link_mem_lose(base);
}

static void mem_destroy(ndo_link *base)
{
	mem_link *l = (mem_link *)base;
	ndo_bus *b = l->bus;
	for (int k = 0; k < b->nlinks; k++)
		if (b->links[k] == l) {
			b->links[k] = b->links[--b->nlinks];
			break;
		}
	compact(b);
	free(l);
}

int ndo_link_open_mem(ndo_bus *b, ndo_link **out)
{
	mem_link *l = calloc(1, sizeof *l);
	mem_link **links = realloc(b->links, (size_t)(b->nlinks + 1) * sizeof *links);
	if (!l || !links) {
		free(l);
		if (links)
			b->links = links;
		return ndo__fail(NDO_ENOMEM, "out of memory");
	}
	b->links = links;
	l->base = (ndo_link){.publish = mem_publish, .poll = mem_poll, .destroy = mem_destroy};
	l->bus = b;
	l->next = b->count; /* a new link hears only what comes after it */
	b->links[b->nlinks++] = l;
	*out = &l->base;
	return 0;
}
