/* source_lcm.c — grids from the peers' LCM traffic (source.h): a live
 * channel, or a log recorded by lcm-logger (file://PATH), assembled step
 * by step by a watch (ndo/watch.h), which sends nothing. */
#include "source.h"

#include "ndo/auth.h"
#include "ndo/cli.h"
#include "ndo/link.h"
#include "ndo/net.h"
#include "ndo/status.h"
#include "ndo/watch.h"

#include <math.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct lcm_source {
	rf_source base;
	ndo_watch *watch;
	ndo_link *link; /* owned by the watch's net */
	ndo_net *net;   /* owned by the watch */
	int log;        /* file:// : read as fast as frames are drawn */
	char url[300];
} lcm_source;

static int next(rf_source *base, ndo_grid **out)
{
	lcm_source *s = (lcm_source *)base;
	*out = NULL;
	for (;;) {
		int rc = ndo_watch_update(s->watch, ndo_now());
		if (rc < 0)
			return ndo__fail(rc, "%s: %s", s->url, ndo_errdetail());
		ndo_grid *g;
		if (ndo_watch_next(s->watch, &g)) {
			snprintf(s->base.where, sizeof s->base.where, "%s, step %lld", s->url,
			         (long long)g->step);
			s->base.number = (long)g->step;
			double stale = ndo_watch_stale(s->watch);
			if (stale > 0)
				fprintf(stderr, "%s: %s, step %lld: lost tiles: %.1f%% of the nodes held at "
				        "an earlier frame's values\n", ndo_progname, s->url,
				        (long long)g->step, 100 * stale);
			*out = g;
			return NDO_OK;
		}
		if (ndo_watch_ended(s->watch))
			return NDO_EEOF;
		if (!s->log) { /* live: wait for traffic */
			struct pollfd p = {ndo_link_fileno(s->link), POLLIN, 0};
			poll(&p, p.fd >= 0 ? 1 : 0, 50);
		}
	}
}

static void destroy(rf_source *base)
{
	lcm_source *s = (lcm_source *)base;
	ndo_watch_destroy(s->watch);
	free(s);
}

int rf_source_lcm(const rf_lcm_options *o, rf_source **out)
{
	lcm_source *s = calloc(1, sizeof *s);
	if (!s)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	s->base.next = next;
	s->base.destroy = destroy;
	s->base.number = -1;
	snprintf(s->url, sizeof s->url, "%s", o->url ? o->url : "LCM's default URL");
	ndo_link *l;
	int rc;
	if (o->url && strncmp(o->url, "file://", 7) == 0) {
		const char *path = o->url + 7;
		char *q = strchr(path, '?'); /* LCM's file:// options do not apply */
		char file[4096];
		snprintf(file, sizeof file, "%.*s", q ? (int)(q - path) : (int)strlen(path), path);
		s->log = 1;
		rc = ndo_link_open_log(file, o->prefix, 0, &l);
	} else {
		rc = ndo_link_open_lcm(o->url, NDO_RECV_BUF_DEFAULT, o->prefix, 0, &l);
	}
	if (rc) {
		free(s);
		return rc;
	}
	s->link = l;
	ndo_net *n;
	/* a placeholder sender id: a live watch takes a random one of its own
	 * for its keyframe requests, a log's publishes nothing */
	if ((rc = ndo_net_create(l, o->prefix, 0x7ffffffe, &n))) {
		free(s);
		return rc;
	}
	ndo_key key; /* a keyed session's messages are checked, as a peer does */
	int keyed = ndo_key_resolve(o->key, &key);
	if (keyed > 0)
		rc = ndo_net_set_key(n, &key);
	ndo_key_wipe(&key);
	if (keyed < 0 || rc) {
		if (keyed < 0 && o->key)
			ndo__fail(keyed, "--key: %s", ndo_errdetail());
		ndo_net_destroy(n);
		free(s);
		return keyed < 0 ? keyed : rc;
	}
	s->net = n;
	ndo_watch_opts wo = {.object_id = o->object_id, .every = o->every,
	                     .timeout = s->log ? 0 : o->timeout, .hold_lost = o->hold_lost,
	                     .passive = s->log || o->passive};
	if ((rc = ndo_watch_create(n, &wo, &s->watch))) {
		free(s);
		return rc;
	}
	*out = &s->base;
	return NDO_OK;
}

void rf_source_lcm_report(rf_source *base, char *buf, size_t size)
{
	lcm_source *s = (lcm_source *)base;
	ndo_watch_stats st;
	ndo_watch_stats_get(s->watch, &st);
	char held[160] = "";
	if (st.held)
		snprintf(held, sizeof held, ", %lld drawn with lost tiles held (%.1f%% of the nodes "
		         "on average, %.1f%% at most)", (long long)st.held,
		         100 * st.stale_sum / (double)st.held, 100 * st.stale_max);
	int n = snprintf(buf, size, "%lld frames of object %llx%s, %lld skipped incomplete (lost "
	                 "tiles); %s", (long long)st.frames, (unsigned long long)st.object_id, held,
	                 (long long)st.incomplete,
	                 *ndo_watch_why(s->watch) ? ndo_watch_why(s->watch) : "");
	const ndo_net_stats *ns = ndo_net_stats_get(s->net);
	if (n > 0 && (size_t)n < size && ns->dropped[NDO_DROP_KEYED])
		snprintf(buf + n, size - (size_t)n, "; %llu messages of a keyed session ignored: "
		         "give its key (--key FILE or $%s)",
		         (unsigned long long)ns->dropped[NDO_DROP_KEYED], NDO_KEY_ENV);
	else if (n > 0 && (size_t)n < size && ndo_net_keyed(s->net)) {
		uint64_t bad = ns->dropped[NDO_DROP_UNSIGNED] + ns->dropped[NDO_DROP_WRONGKEY] +
		               ns->dropped[NDO_DROP_FORGED] + ns->dropped[NDO_DROP_REPLAY];
		if (bad)
			snprintf(buf + n, size - (size_t)n, "; %llu messages failed authentication "
			         "(unsigned %llu, wrong key %llu, forged %llu, replayed %llu)",
			         (unsigned long long)bad,
			         (unsigned long long)ns->dropped[NDO_DROP_UNSIGNED],
			         (unsigned long long)ns->dropped[NDO_DROP_WRONGKEY],
			         (unsigned long long)ns->dropped[NDO_DROP_FORGED],
			         (unsigned long long)ns->dropped[NDO_DROP_REPLAY]);
	}
}
