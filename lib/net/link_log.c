/* link_log.c — a recorded run as a link (ndo/link.h): the events of an
 * LCM log file, in order, read with LCM's lcm_eventlog API. */
#include "link_private.h"
#include "ndo/status.h"

#include <errno.h>
#include <lcm/eventlog.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* LCM's log format (lcm/eventlog.c, docs "log file format"): each event
 * is a big-endian header — sync word 0xEDA1DA01, event number (8 bytes),
 * timestamp in µs (8), channel length (4), data length (4) — then the
 * channel and the data. */
#define LOG_SYNC 0xEDA1DA01u
#define LOG_HEADER 28

typedef struct log_link {
	ndo_link base;
	lcm_eventlog_t *log;
	char path[512];
	char prefix[72];
	size_t prefix_len;
	off_t size;
	int batch, ended;
} log_link;

static uint32_t be32(const uint8_t *b)
{
	return (uint32_t)b[0] << 24 | (uint32_t)b[1] << 16 | (uint32_t)b[2] << 8 | b[3];
}

/* Check the next event's header without consuming it: 1 an event, 0 the
 * end of the file, or a negative status. */
static int peek(log_link *l)
{
	FILE *f = l->log->f;
	off_t at = ftello(f);
	uint8_t h[LOG_HEADER];
	size_t got = fread(h, 1, sizeof h, f);
	if (fseeko(f, at, SEEK_SET) != 0)
		return ndo__fail(NDO_EIO, "%s: %s", l->path, strerror(errno));
	if (got == 0)
		return 0;
	if (got < sizeof h) { /* cut short: the events before it stand */
		snprintf(l->base.note, sizeof l->base.note, "cut short at byte %lld, inside an "
		         "event's header", (long long)at);
		return 0;
	}
	int32_t clen = (int32_t)be32(h + 20), dlen = (int32_t)be32(h + 24);
	if (be32(h) != LOG_SYNC)
		return ndo__fail(NDO_EFORMAT, "%s: no LCM event at byte %lld (not an LCM log, or "
		                 "corrupt)", l->path, (long long)at);
	if (clen <= 0 || clen >= 1000 || dlen < 0)
		return ndo__fail(NDO_EFORMAT, "%s: the event at byte %lld has a channel of %d and "
		                 "data of %d bytes", l->path, (long long)at, clen, dlen);
	if ((off_t)clen + dlen > l->size - at - LOG_HEADER) { /* cut short */
		snprintf(l->base.note, sizeof l->base.note, "cut short at byte %lld: an event of "
		         "%d bytes runs past the end (%lld bytes)", (long long)at,
		         LOG_HEADER + clen + dlen, (long long)l->size);
		return 0;
	}
	return 1;
}

static int log_poll(ndo_link *base, double now, ndo_link_fn fn, void *user)
{
	log_link *l = (log_link *)base;
	(void)now;
	int handed = 0;
	for (int k = 0; k < l->batch && !l->ended; k++) {
		int rc = peek(l);
		if (rc <= 0) {
			l->ended = 1;
			return rc < 0 ? rc : handed;
		}
		lcm_eventlog_event_t *e = lcm_eventlog_read_next_event(l->log);
		if (!e) {
			l->ended = 1;
			return ndo__fail(NDO_EIO, "%s: cannot read an event", l->path);
		}
		if (strncmp(e->channel, l->prefix, l->prefix_len) == 0) {
			fn(user, e->channel, e->data, (size_t)e->datalen);
			handed++;
		}
		lcm_eventlog_free_event(e);
	}
	return handed;
}

static int log_publish(ndo_link *base, const char *channel, const void *data, size_t len)
{
	(void)data, (void)len;
	return ndo__fail(NDO_EINVAL, "%s: a log is read-only (publish %s)",
	                 ((log_link *)base)->path, channel);
}

static int log_ended(const ndo_link *base) { return ((const log_link *)base)->ended; }

static void log_destroy(ndo_link *base)
{
	log_link *l = (log_link *)base;
	if (l->log)
		lcm_eventlog_destroy(l->log);
	free(l);
}

int ndo_link_open_log(const char *path, const char *prefix, int batch, ndo_link **out)
{
	ndo__clear_error();
	if (!prefix || !*prefix || strlen(prefix) > 64)
		return ndo__fail(NDO_EINVAL, "channel prefix '%s': 1..64 characters",
		                 prefix ? prefix : "");
	struct stat st;
	if (stat(path, &st) != 0)
		return ndo__fail(NDO_EIO, "%s: %s", path, strerror(errno));
	if (!S_ISREG(st.st_mode))
		return ndo__fail(NDO_EIO, "%s: not a regular file", path);
	log_link *l = calloc(1, sizeof *l);
	if (!l)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	l->base = (ndo_link){.publish = log_publish, .poll = log_poll, .destroy = log_destroy,
	                     .ended = log_ended};
	snprintf(l->path, sizeof l->path, "%s", path);
	snprintf(l->prefix, sizeof l->prefix, "%s_", prefix);
	l->prefix_len = strlen(l->prefix);
	l->size = st.st_size;
	l->batch = batch > 0 ? batch : 64;
	l->log = lcm_eventlog_create(path, "r");
	if (!l->log) {
		int e = errno;
		free(l);
		return ndo__fail(NDO_EIO, "%s: %s", path, strerror(e));
	}
	*out = &l->base;
	return 0;
}
