/* watch_stream.h — an owner streaming a wavy surface to a watch on an
 * in-memory bus with a fake clock (ndo/session.h, ndo/watch.h), through
 * injected faults: for test_session and bench_peers keyframes. */
#ifndef NDO_TEST_WATCH_STREAM_H
#define NDO_TEST_WATCH_STREAM_H

#include "ndo/ndo.h"
#include "ndo/session.h"
#include "ndo/watch.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* An owner of the wavy surface at `level` (its rest shape the position) in
 * encoding cp, sending at `coarse_levels` below, on `bus`, and a watch on
 * `wbus` (the same bus, or another that a test relays to) whose link has
 * faults f (or none), both nets under `key` (or none), the watch's net in
 * *wnet (or NULL); the box's diagonal.  0, or −1 (said on stderr). */
static int wavy_owner_and_watch_on(ndo_bus *bus, ndo_bus *wbus, const ndo_codec_params *cp,
                                   int64_t object, int level, int coarse_levels,
                                   const ndo_faults *f, const ndo_key *key, ndo_session **s,
                                   ndo_watch **w, ndo_net **wnet, double *diag)
{
	ndo_link *l, *lw;
	ndo_net *n, *nw;
	ndo_grid *g;
	ndo_link_open_mem(bus, &l);
	ndo_net_create(l, "T", 11, &n);
	if (key)
		ndo_net_set_key(n, key);
	ndo_shape_make("wavy", level, NULL, &g);
	ndo_channel *rest;
	ndo_grid_add(g, NDO_CH_REST, NDO_F64, 3, &rest);
	memcpy(rest->data, g->ch[0].data, 3 * g->count * sizeof(double));
	ndo_session_opts o = {.role = NDO_ROLE_OWNER, .poi = -1, .self_id = 11, .object_id = object,
	                      .scene = "", .heartbeat = 0.1, .codec = cp,
	                      .coarse_levels = coarse_levels};
	*s = NULL;
	if (ndo_session_create(&o, n, g, s)) {
		fprintf(stderr, "owner: %s\n", ndo_errdetail());
		return -1;
	}
	ndo_link_open_mem(wbus, &lw);
	if (f)
		ndo_link_faults(lw, f, &lw);
	ndo_net_create(lw, "T", 12, &nw);
	if (key)
		ndo_net_set_key(nw, key);
	ndo_watch_opts wo = {0};
	ndo_watch_create(nw, &wo, w);
	if (wnet)
		*wnet = nw;
	const double *x0 = ndo_grid_f64(ndo_session_grid(*s), NDO_CH_REST, 3);
	double lo[3], ext[3];
	ndo_codec_box(x0, ndo_session_grid(*s)->count, lo, ext);
	*diag = sqrt(ext[0] * ext[0] + ext[1] * ext[1] + ext[2] * ext[2]);
	return 0;
}

/* The same, owner and watch on one bus. */
static int wavy_owner_and_watch(ndo_bus *bus, const ndo_codec_params *cp, int64_t object,
                                int level, int coarse_levels, const ndo_faults *f,
                                const ndo_key *key, ndo_session **s, ndo_watch **w,
                                ndo_net **wnet, double *diag)
{
	return wavy_owner_and_watch_on(bus, bus, cp, object, level, coarse_levels, f, key, s, w,
	                               wnet, diag);
}

/* 300 steps of a wavy level-6 owner streaming `spec` to a watch through
 * faults f, both polled every dt seconds of the fake clock (every step a
 * frame; `ask` STREAM_ASK: the watch asks for keyframes; STREAM_FORGED: a
 * forger on the bus, under the owner's own id, asks for tiles 0..63 of
 * the owner every step; STREAM_FLOOD: a rogue sends 128 copies of the
 * owner's last tile every step, predicted from steps that never come,
 * under its own id (STREAM_FLOOD_IDS: a new id each); a keyed session
 * under `key`): the frames the watch gave (seen[step] set for each), the
 * largest distance of one from the owner's positions at its step (of the
 * diagonal), and both ends' statistics; a line on stdout unless `quiet`.
 * 0, or −1. */
enum {
	STREAM_STEPS = 300,
	STREAM_ASK = 1,
	STREAM_FORGED = 2,
	STREAM_FLOOD = 4,
	STREAM_FLOOD_IDS = 8
};

/* What a spy on the bus saw last on T_TILE. */
typedef struct stream_spy {
	uint8_t buf[1 << 16];
	size_t len;
} stream_spy;

static void stream_spy_take(void *user, const char *channel, const void *data, size_t len)
{
	stream_spy *sp = user;
	if (strcmp(channel, "T_TILE") == 0 && len <= sizeof sp->buf) {
		memcpy(sp->buf, data, len);
		sp->len = len;
	}
}

/* The rogue of STREAM_FLOOD: 128 copies of the spied tile, each predicted
 * from a step that never comes. */
static void stream_flood(ndo_link *rogue, const stream_spy *sp, int ids, int64_t *seq)
{
	ndo_msg m;
	if (!sp->len || ndo_msg_decode(NDO_MSG_TILE, sp->buf, sp->len, &m) != NDO_DROP_NONE)
		return;
	for (int k = 0; k < 128; k++, (*seq)++) {
		m.u.tile.hdr.sender_id = ids ? (int32_t)(1000 + *seq) : 777;
		m.u.tile.hdr.seq = *seq;
		m.u.tile.step = 100000 + *seq;
		m.u.tile.base_step = 99999 + *seq;
		uint8_t *buf;
		size_t len;
		if (ndo_msg_encode(NDO_MSG_TILE, &m.u.tile, &buf, &len) == 0) {
			ndo_link_publish(rogue, "T_TILE", buf, len);
			free(buf);
		}
	}
	ndo_msg_free(&m);
}
typedef struct streamed {
	int frames;
	int64_t last;
	double worst;
	uint8_t seen[STREAM_STEPS];
	ndo_net_stats net;      /* the watch's */
	ndo_codec_stats enc;    /* the owner's encoder */
} streamed;

static int stream_to_watch(const char *spec, const ndo_faults *f, int ask, const ndo_key *key,
                           double dt, int quiet, streamed *out)
{
	memset(out, 0, sizeof *out);
	out->last = -1;
	ndo_bus *bus;
	ndo_bus_create(&bus);
	ndo_codec_params cp;
	ndo_codec_parse(spec, &cp);
	ndo_session *s;
	ndo_watch *w;
	double diag;
	ndo_net *nw;
	if (wavy_owner_and_watch(bus, &cp, 79, 6, 0, f, key, &s, &w, &nw, &diag)) {
		ndo_bus_destroy(bus);
		return -1;
	}
	ndo_net_ask_keys(nw, ask & STREAM_ASK);
	ndo_net *forger = NULL;
	int32_t codes[64];
	for (int k = 0; k < 64; k++)
		codes[k] = k;
	if (ask & STREAM_FORGED) {
		ndo_link *fl;
		ndo_link_open_mem(bus, &fl);
		ndo_net_create(fl, "T", 11, &forger);
		ndo_net_attach(forger, 79, 6);
	}
	ndo_link *spyl = NULL, *rogue = NULL;
	stream_spy *sp = NULL;
	int64_t rseq = 0;
	if (ask & (STREAM_FLOOD | STREAM_FLOOD_IDS)) {
		ndo_link_open_mem(bus, &spyl);
		ndo_link_open_mem(bus, &rogue);
		sp = calloc(1, sizeof *sp);
	}
	ndo_grid *og = ndo_session_grid(s);
	double *x = ndo_grid_f64(og, NDO_CH_POSITION, 3);
	const double *x0 = ndo_grid_f64(og, NDO_CH_REST, 3);
	double t = 0;
	ndo_session_update(s, t);
	ndo_watch_update(w, t);
	for (int64_t step = 0; step < STREAM_STEPS + 20; step++) {
		/* the owner hears what the watch said after the last frame before
		 * it sends the next, as it would with a round trip shorter than a
		 * step */
		t += dt;
		ndo_session_update(s, t);
		if (step < STREAM_STEPS) {
			for (size_t k = 0; k < og->count; k++)
				for (int d = 0; d < 3; d++)
					x[3 * k + d] = x0[3 * k + d] + 0.01 * (double)step * sin(3 * x0[3 * k + (d + 1) % 3]);
			ndo_grid_sync(og);
			ndo_session_publish(s, step, 0.01 * (double)step);
		}
		if (sp) {
			ndo_link_poll(spyl, t, stream_spy_take, sp);
			stream_flood(rogue, sp, (ask & STREAM_FLOOD_IDS) != 0, &rseq);
		}
		if (forger) {
			ndo_msg_key_request_t r = {.sender = 11, .ntiles = 64, .codes = codes};
			ndo_net_publish(forger, NDO_MSG_KEY_REQUEST, &r);
			ndo_net_poll(forger, t);
			ndo_msg m;
			while (ndo_net_next(forger, &m))
				ndo_msg_free(&m);
		}
		ndo_watch_update(w, t);
		ndo_grid *fr;
		while (ndo_watch_next(w, &fr) == 1) {
			out->frames++;
			out->last = fr->step > out->last ? fr->step : out->last;
			if (fr->step >= 0 && fr->step < STREAM_STEPS)
				out->seen[fr->step] = 1;
			const double *fx = ndo_grid_f64(fr, NDO_CH_POSITION, 3);
			const double st = (double)fr->step;
			for (size_t k = 0; k < fr->count; k++)
				for (int d = 0; d < 3; d++) {
					double want = x0[3 * k + d] + 0.01 * st * sin(3 * x0[3 * k + (d + 1) % 3]);
					out->worst = fmax(out->worst, fabs(fx[3 * k + d] - want) / diag);
				}
			ndo_grid_destroy(fr);
		}
	}
	out->net = *ndo_net_stats_get(nw);
	ndo_codec_stats dec;
	ndo_session_codec_stats(s, &out->enc, &dec);
	if (!quiet) {
		char buf[600];
		ndo_net_stats_format(nw, buf, sizeof buf);
		printf("    %s, %g %% lost, %g %% late%s: %d frames of %d, the last of step %lld; %s; "
		       "the owner sent %llu keyframes, %llu of them asked for\n", spec, 100 * f->drop,
		       100 * f->reorder,
		       (ask & STREAM_FORGED)      ? ", asking, a forger asking too"
		       : (ask & STREAM_FLOOD_IDS) ? ", a rogue flooding under new ids"
		       : (ask & STREAM_FLOOD)     ? ", a rogue flooding"
		       : ask                      ? ", asking"
		                                  : "",
		       out->frames, STREAM_STEPS,
		       (long long)out->last, buf, (unsigned long long)out->enc.keyframes,
		       (unsigned long long)out->enc.keys_forced);
	}
	ndo_session_destroy(s, NULL);
	ndo_watch_destroy(w);
	ndo_net_destroy(forger);
	ndo_link_destroy(spyl);
	ndo_link_destroy(rogue);
	free(sp);
	ndo_bus_destroy(bus);
	return 0;
}

#endif
