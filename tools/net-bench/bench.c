/* bench.c — one row of net-bench: an owner, joiners and a passive
 * observer of the thesis' figure-5.3 scene on the wavy surface, each with
 * its own LCM instance, stepped in this thread; a second thread listens to
 * the tiles and stamps their arrival (publish-to-receive latency). */
#include "bench.h"

#include "ndo/peer.h"
#include "ndo/watch.h"

#include <arpa/inet.h>
#include <errno.h>
#include <lcm/lcm.h>
#include <math.h>
#include <net/if.h>
#include <net/route.h>
#include <poll.h>
#include <pthread.h>
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

/* IPv4 + UDP headers and LCM's short-message header, per datagram. */
#define WIRE_OVERHEAD (20 + 8 + 8)

int nb_private_netns(char *why, size_t size)
{
	if (unshare(CLONE_NEWNET) != 0) {
		snprintf(why, size, "cannot make a private network namespace (unshare: %s; needs "
		         "root or CAP_SYS_ADMIN): give --lcm URL to use a network as it is",
		         strerror(errno));
		return -1;
	}
	int fd = socket(AF_INET, SOCK_DGRAM, 0);
	struct ifreq ifr;
	memset(&ifr, 0, sizeof ifr);
	snprintf(ifr.ifr_name, sizeof ifr.ifr_name, "lo");
	int ok = fd >= 0 && ioctl(fd, SIOCGIFFLAGS, &ifr) == 0;
	ifr.ifr_flags |= IFF_UP | IFF_RUNNING;
	ok = ok && ioctl(fd, SIOCSIFFLAGS, &ifr) == 0;
	/* multicast (224.0.0.0/4) to the loopback */
	struct rtentry rt;
	memset(&rt, 0, sizeof rt);
	struct sockaddr_in *dst = (struct sockaddr_in *)&rt.rt_dst,
	                   *mask = (struct sockaddr_in *)&rt.rt_genmask;
	dst->sin_family = mask->sin_family = AF_INET;
	dst->sin_addr.s_addr = htonl(0xe0000000u);
	mask->sin_addr.s_addr = htonl(0xf0000000u);
	rt.rt_flags = RTF_UP;
	char dev[] = "lo";
	rt.rt_dev = dev;
	ok = ok && ioctl(fd, SIOCADDRT, &rt) == 0;
	if (!ok)
		snprintf(why, size, "cannot route multicast to the loopback in the private "
		         "namespace: %s", strerror(errno));
	if (fd >= 0)
		close(fd);
	return ok ? 0 : -1;
}

/* The kernel's drop counters of every UDP socket (/proc/net/udp, the last
 * field), in this network namespace. */
static long kernel_drops(void)
{
	long sum = 0;
	const char *files[] = {"/proc/net/udp", "/proc/net/udp6"};
	for (int f = 0; f < 2; f++) {
		FILE *fp = fopen(files[f], "r");
		if (!fp)
			continue;
		char line[512];
		if (!fgets(line, sizeof line, fp)) { /* the header */
			fclose(fp);
			continue;
		}
		while (fgets(line, sizeof line, fp)) {
			char *last = strrchr(line, ' ');
			if (last)
				sum += strtol(last + 1, NULL, 10);
		}
		fclose(fp);
	}
	return sum;
}

/* ---- the wire: a listener thread -------------------------------------------- */
/* Every message on the run's channels, as any receiver on the bus sees it:
 * its bytes by kind (bench.h, nb_traffic) and, for tiles, the
 * publish-to-receive latency.  The steady state's traffic is told from the
 * joins' by when each message was published (its header's utime), not by
 * when this thread got to it: under load the thread lags, and the messages
 * still in its socket when the steady state began (a joiner's raw snapshot
 * and rest shape among them) were counted as the steady state's. */
typedef struct listener {
	lcm_t *lcm;
	pthread_t thread;
	volatile int stop;
	char prefix[32];
	int64_t final_step; /* the run's last step */
	double *lat; /* µs */
	size_t n, cap;
	nb_traffic tr;
	nb_traffic before; /* published before `mark` (all of it while mark is 0) */
	int64_t mark;      /* µs since the epoch: the steady state's start (0: not yet) */
	pthread_mutex_t mu;
} listener;

/* Now, as the header's utime counts it: µs since the epoch. */
static int64_t utime_now(void)
{
	struct timeval tv;
	gettimeofday(&tv, NULL);
	return (int64_t)tv.tv_sec * 1000000 + tv.tv_usec;
}

static void on_message(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
	listener *l = user;
	struct timeval tv;
	gettimeofday(&tv, NULL);
	int type = ndo_msg_type_of(l->prefix, channel);
	double wire = (double)rbuf->data_size + WIRE_OVERHEAD + (double)strlen(channel) + 1;
	ndo_msg m;
	int kind = NB_CONTROL;
	double payload = 0;
	if (type == NDO_MSG_HEARTBEAT) {
		kind = NB_HEARTBEAT;
	} else if (type == NDO_MSG_HALO) {
		kind = NB_HALO;
	} else if (type == NDO_MSG_TILE &&
	           (ndo_msg_decode(NDO_MSG_TILE, rbuf->data, (size_t)rbuf->data_size, &m) ==
	                NDO_DROP_NONE ||
	            /* keyed: the message without its trailer (only counted here) */
	            (ndo_auth_looks_sealed(rbuf->data, (size_t)rbuf->data_size) &&
	             ndo_msg_decode(NDO_MSG_TILE, rbuf->data,
	                            (size_t)rbuf->data_size - NDO_AUTH_TRAILER, &m) == NDO_DROP_NONE))) {
		const ndo_msg_tile_t *t = &m.u.tile;
		if (t->step >= l->final_step) {
			kind = NB_FINAL;
		} else if (t->encoding != NDO_ENC_RAW) {
			kind = NB_ENCODED;
			payload = t->nbytes;
		} else if (t->channels & (NDO_TILE_REST | NDO_TILE_PIN)) {
			kind = NB_REST;
		} else {
			kind = NB_RAW_STATE;
			payload = 8.0 * t->nvalues;
		}
		ndo_msg_free(&m);
	}
	/* every message: type hash (8), then header_t: version (2), object
	 * (8), sender (4), seq (8), utime (8, big-endian µs) */
	double lat = NAN;
	int64_t ut = 0;
	if (rbuf->data_size >= 38) {
		const uint8_t *b = rbuf->data;
		for (int k = 30; k < 38; k++)
			ut = ut << 8 | b[k];
		if (type == NDO_MSG_TILE)
			lat = (double)((int64_t)tv.tv_sec * 1000000 + tv.tv_usec - ut);
	}
	pthread_mutex_lock(&l->mu);
	l->tr.messages[kind]++;
	l->tr.bytes[kind] += wire;
	l->tr.payload[kind] += payload;
	/* the peers publish on the thread that sets the mark, so a message
	 * published after it carries a later utime; one without a header
	 * (too short) goes with the steady state once it began */
	if (!l->mark || (rbuf->data_size >= 38 && ut < l->mark)) {
		l->before.messages[kind]++;
		l->before.bytes[kind] += wire;
		l->before.payload[kind] += payload;
	}
	if (!isnan(lat)) {
		if (l->n == l->cap && l->cap < 4000000) {
			size_t cap = l->cap ? 2 * l->cap : 4096;
			double *q = realloc(l->lat, cap * sizeof *q);
			if (q)
				l->lat = q, l->cap = cap;
		}
		if (l->n < l->cap)
			l->lat[l->n++] = lat;
	}
	pthread_mutex_unlock(&l->mu);
}

/* The steady state begins now: what is published from now on is its
 * traffic (l->tr − l->before once the thread stopped). */
static void listener_mark(listener *l)
{
	pthread_mutex_lock(&l->mu);
	l->mark = utime_now();
	pthread_mutex_unlock(&l->mu);
}

static void *listen_loop(void *user)
{
	listener *l = user;
	while (!l->stop)
		lcm_handle_timeout(l->lcm, 50);
	/* what is still in the socket: published before the stop, as much the
	 * run's as what came earlier (the kernel delivered it to the socket
	 * as it was sent) */
	while (lcm_handle_timeout(l->lcm, 0) > 0)
		;
	return NULL;
}

static int listener_start(listener *l, const char *url, const char *prefix, int64_t final_step)
{
	char full[512], chan[96];
	memset(l, 0, sizeof *l);
	l->final_step = final_step;
	snprintf(l->prefix, sizeof l->prefix, "%s", prefix);
	if (ndo_lcm_url(url, NDO_RECV_BUF_DEFAULT, full, sizeof full))
		return ndo__fail(NDO_ERANGE, "the LCM URL is too long");
	if (!(l->lcm = lcm_create(full)))
		return ndo__fail(NDO_EIO, "LCM: cannot open %s", full);
	snprintf(chan, sizeof chan, "%s_.*", prefix);
	lcm_subscribe(l->lcm, chan, on_message, l);
	pthread_mutex_init(&l->mu, NULL);
	if (pthread_create(&l->thread, NULL, listen_loop, l)) {
		lcm_destroy(l->lcm);
		return ndo__fail(NDO_EIO, "cannot start a thread");
	}
	return 0;
}

static int cmp_double(const void *a, const void *b)
{
	double x = *(const double *)a, y = *(const double *)b;
	return x < y ? -1 : x > y;
}

static void listener_stop(listener *l, double *p50, double *p99)
{
	l->stop = 1;
	pthread_join(l->thread, NULL);
	lcm_destroy(l->lcm);
	pthread_mutex_destroy(&l->mu);
	*p50 = *p99 = NAN;
	if (l->n) { /* after the thread: no lock needed */
		qsort(l->lat, l->n, sizeof *l->lat, cmp_double);
		*p50 = l->lat[(l->n - 1) / 2];
		*p99 = l->lat[(size_t)floor(0.99 * (double)(l->n - 1))];
	}
	free(l->lat);
}

/* ---- the object ------------------------------------------------------------------ */
/* Thesis figure 5.3 (samples/thesis-fig5.3.scene): k = 1 N/m, b = 0.1,
 * 2.4 N at 1 Hz on the faces within 0.2 m of the pole, rk4 at 0.9 x its
 * critical step. */
static const char scene_text[] =
	"stiffness 1\ndensity 1\ndamping 0.1\nintegrator rk4\ndt auto\n"
	"force face at=0,0,1 radius=0.2 amplitude=2.4 frequency=1\n";

static int object(int level, double duration, ndo_scene *sc, ndo_grid **gout, ndo_sim **simout,
                  double *dt, int64_t *steps)
{
	ndo_grid *g;
	int rc = ndo_shape_make("wavy", level, NULL, &g);
	if (rc)
		return rc;
	ndo_scene_init(sc);
	if ((rc = ndo_scene_apply_text(sc, scene_text, "the thesis' scene"))) {
		ndo_grid_destroy(g);
		return rc;
	}
	double *x = ndo_grid_f64(g, NDO_CH_POSITION, 3);
	uint8_t *pin = calloc(g->count, 1);
	ndo_force *forces = NULL;
	ndo_sim *sim = NULL;
	if (!pin) {
		ndo_grid_destroy(g);
		return ndo__fail(NDO_ENOMEM, "out of memory");
	}
	rc = ndo_scene_resolve(sc, level, x, &forces, pin);
	if (!rc) {
		ndo_sim_params prm = sc->sim;
		prm.forces = forces;
		prm.nforces = sc->nforces;
		rc = ndo_sim_create(level, x, NULL, x, pin, &prm, &sim);
		ndo_scene_forces_free(forces, sc->nforces);
	}
	ndo_critical crit;
	if (!rc && !(rc = ndo_sim_critical(sim, &crit))) {
		double h = sc->dt_safety * crit.h_crit;
		*steps = (int64_t)fmax(1, ceil(duration / h - 1e-9));
		*dt = duration / (double)*steps;
		rc = ndo_sim_store(sim, g);
	}
	ndo_channel *pc;
	if (!rc && !(rc = ndo_grid_add(g, NDO_CH_PIN, NDO_U8, 1, &pc)))
		memcpy(pc->data, pin, g->count);
	free(pin);
	if (rc) {
		ndo_sim_destroy(sim);
		ndo_grid_destroy(g);
		return rc;
	}
	*gout = g;
	*simout = sim;
	return 0;
}

static ndo_link *open_link(const nb_opts *o, const char *prefix, double loss, uint64_t seed)
{
	ndo_link *l;
	if (ndo_link_open_lcm(o->url, NDO_RECV_BUF_DEFAULT, prefix, 0, &l))
		return NULL;
	if (loss > 0) {
		ndo_faults f = {.drop = loss, .seed = seed};
		if (ndo_link_faults(l, &f, &l))
			return NULL;
	}
	return l;
}

double nb_divergence(const double *a, const double *b, const double *rest, size_t n)
{
	double d = 0, m = 0;
	for (size_t k = 0; k < 3 * n; k++) {
		d = fmax(d, fabs(a[k] - b[k]));
		m = fmax(m, fabs(b[k] - rest[k]));
	}
	return m > 0 ? d / m : d;
}

void nb_row_free(nb_row *r)
{
	free(r->final_x);
	free(r->rest);
	r->final_x = r->rest = NULL;
}

/* ---- a row ------------------------------------------------------------------------ */
#define MAXP 8

int nb_run(const nb_opts *o, int level, const ndo_codec_params *enc, double loss, nb_row *row)
{
	static int rows; /* each row on channels of its own */
	char prefix[32];
	snprintf(prefix, sizeof prefix, "NB%d_%d", (int)getpid() % 10000, ++rows);
	memset(row, 0, sizeof *row);
	row->level = level;
	row->peers = o->peers;
	row->loss = loss;
	ndo_codec_name(enc, row->encoding, sizeof row->encoding);
	row->divergence = NAN;

	ndo_scene sc;
	ndo_grid *g = NULL;
	ndo_sim *sim = NULL;
	double dt = 0;
	int64_t steps = 0;
	int rc = object(level, o->time, &sc, &g, &sim, &dt, &steps);
	if (rc)
		return rc;
	row->nodes = g->count;
	row->vertices = ((size_t)2 << (2 * level)) + 2;
	row->send_level = o->send_level >= 0 && o->send_level < level ? o->send_level : level;
	row->rest = malloc(3 * g->count * sizeof *row->rest);
	if (!row->rest) {
		ndo_grid_destroy(g), ndo_sim_destroy(sim), ndo_scene_free(&sc);
		return ndo__fail(NDO_ENOMEM, "out of memory");
	}
	memcpy(row->rest, ndo_grid_f64(g, NDO_CH_REST, 3), 3 * g->count * sizeof *row->rest);
	double diag;
	{
		double lo[3], ext[3];
		ndo_codec_box(row->rest, g->count, lo, ext);
		diag = sqrt(ext[0] * ext[0] + ext[1] * ext[1] + ext[2] * ext[2]);
	}
	long drops0 = kernel_drops();
	listener lis;
	if ((rc = listener_start(&lis, o->url, prefix, steps))) {
		ndo_grid_destroy(g), ndo_sim_destroy(sim), ndo_scene_free(&sc);
		return rc;
	}

	ndo_peer *p[MAXP] = {0};
	int np = o->peers, state[MAXP] = {0}, started[MAXP] = {0};
	uint64_t msgs0[MAXP] = {0};
	ndo_watch *w = NULL;
	ndo_net *wnet = NULL;
	uint64_t seed = 0x9e3779b97f4a7c15ull * (uint64_t)(level * 131 + (int)(loss * 1000) + 7);
	/* points of interest spread over the faces (thesis Table 4.1 needs one
	 * each); the owner's "anywhere" */
	size_t faces = ndo_triangle_count(level);
	const double frac[MAXP] = {0, 0.55, 0.3, 0.8, 0.15, 0.65, 0.4, 0.9};
	ndo_peer_run run = {ndo_scene_physics(&sc), dt, steps};
	for (int k = 0; k < np && !rc; k++) {
		ndo_link *l = open_link(o, prefix, loss, seed + (uint64_t)k);
		ndo_net *n = NULL;
		if (!l || (rc = ndo_net_create(l, prefix, 1, &n)) ||
		    (o->key && (rc = ndo_net_set_key(n, o->key)))) {
			rc = rc ? rc : ndo__fail(NDO_EIO, "LCM: %s", ndo_errdetail());
			ndo_net_destroy(n);
			break;
		}
		ndo_peer_opts po = {
			.session = {.role = k ? NDO_ROLE_JOINER : NDO_ROLE_OWNER, .name = "net-bench",
			            .poi = k ? (int32_t)(frac[k] * (double)faces) : -1,
			            .codec = k ? NULL : enc, .seed = seed + 17 * (uint64_t)k + 1,
			            .coarse_levels = k ? 0 : level - row->send_level},
			.clock = NDO_CLOCK_LOCKSTEP, .peers = np, .start_timeout = o->timeout,
			.gather_timeout = 10, .resend = 0.25, .step_timeout = 2,
			/* what a viewer costs: the whole state every step */
			.publish_every = 1};
		rc = ndo_peer_create(&po, n, k ? NULL : g, k ? NULL : sim, k ? NULL : &run, &p[k]);
		if (!rc) /* the error of refining the displacement too (CSV) */
			ndo_session_measure_displacement(ndo_peer_session(p[k]), 1);
		if (k == 0)
			g = NULL, sim = NULL; /* taken over */
	}
	if (!rc) {
		ndo_link *l = open_link(o, prefix, 0, 0);
		ndo_watch_opts wo = {.window = 32};
		if (!l || (rc = ndo_net_create(l, prefix, 0x7ffffffe, &wnet)) ||
		    (o->key && (rc = ndo_net_set_key(wnet, o->key))) ||
		    (rc = ndo_watch_create(wnet, &wo, &w)))
			rc = rc ? rc : ndo__fail(NDO_EIO, "LCM: %s", ndo_errdetail());
	}
	ndo_grid_destroy(g);
	ndo_sim_destroy(sim);
	double t0 = ndo_now(), owner_done = -1;
	int64_t step0 = -1; /* the owner's step when the steady state began */
	nb_traffic tr0; /* the traffic published before the steady state */
	memset(&tr0, 0, sizeof tr0);
	while (!rc) {
		double now = ndo_now();
		if (now - t0 > o->timeout) {
			rc = ndo__fail(NDO_EIO, "level %d, %s: the run did not end within %g s (step %lld "
			               "of %lld)", level, row->encoding, o->timeout,
			               (long long)ndo_peer_step(p[0]), (long long)ndo_peer_final_step(p[0]));
			break;
		}
		int busy = 0;
		for (int k = 0; k < np && !rc; k++) {
			if (!p[k] || state[k] == NDO_PEER_DONE || state[k] == NDO_PEER_ENDED)
				continue;
			int s = ndo_peer_update(p[k], now);
			if (s < 0) {
				char d[300];
				snprintf(d, sizeof d, "%s", ndo_errdetail());
				rc = ndo__fail(s, "peer %d: %s", k, d);
				break;
			}
			state[k] = s;
			busy |= s == NDO_PEER_STEPPED;
			if (!started[k] && ndo_peer_started(p[k])) {
				const ndo_net_stats *ns = ndo_net_stats_get(ndo_session_net(ndo_peer_session(p[k])));
				started[k] = 1;
				msgs0[k] = ns->published;
			}
		}
		if (rc)
			break;
		if ((rc = ndo_watch_update(w, now)) < 0)
			break;
		rc = 0;
		ndo_grid *f;
		while (ndo_watch_next(w, &f)) {
			ndo_grid_destroy(f);
			int all = p[0] != NULL;
			for (int k = 0; k < np; k++)
				all &= started[k];
			if (step0 < 0 && all) { /* every join is over: the steady state */
				step0 = ndo_peer_step(p[0]);
				listener_mark(&lis);
			}
		}
		if (state[0] == NDO_PEER_DONE && owner_done < 0) {
			owner_done = now;
			/* the traffic of the run, and what it cost */
			ndo_peer_stats st;
			ndo_peer_stats_get(p[0], &st);
			row->steps = st.steps;
			double el = st.end_time - st.start_time;
			row->steps_per_s = el > 0 ? (double)st.steps / el : 0;
			uint64_t msgs = 0;
			double enc_s = 0, sum_sq = 0, max_e = 0, lsum = 0, lmax = 0, dsum = 0, dmax = 0;
			uint64_t err_n = 0, lnodes = 0;
			for (int k = 0; k < np; k++) {
				ndo_session *s = ndo_peer_session(p[k]);
				const ndo_net_stats *ns = ndo_net_stats_get(ndo_session_net(s));
				msgs += ns->published - msgs0[k];
				ndo_codec_stats es, ds;
				ndo_session_codec_stats(s, &es, &ds);
				ndo_session_level_stats ls;
				ndo_session_level_stats_get(s, &ls);
				if (ls.send_level < ls.level) { /* the coarse tiles' encoding */
					es.encode_seconds += ls.enc.encode_seconds;
					es.sum_sq_error += ls.enc.sum_sq_error;
					es.error_nodes += ls.enc.error_nodes;
					es.max_error = fmax(es.max_error, ls.enc.max_error);
				}
				lsum += ls.sum_sq_error;
				lnodes += ls.error_nodes;
				lmax = fmax(lmax, ls.max_error);
				dsum += ls.sum_sq_error_disp;
				dmax = fmax(dmax, ls.max_error_disp);
				enc_s += es.encode_seconds;
				sum_sq += es.sum_sq_error;
				err_n += es.error_nodes;
				max_e = fmax(max_e, es.max_error);
				row->nobase += ds.nobase;
				row->corrupt += ds.corrupt;
				row->exact_nodes += ndo_session_exact_nodes(s);
				ndo_peer_stats pst;
				ndo_peer_stats_get(p[k], &pst);
				row->resends += (uint64_t)pst.resends;
			}
			row->messages = msgs;
			row->max_error_rel = max_e / diag;
			row->rms_error_rel = err_n ? sqrt(sum_sq / (double)err_n) / diag : 0;
			/* at the simulated level: the encoding's error alone without a send
			 * level; the sessions' refined-coarse error with one */
			row->level_max_rel = row->send_level < level ? lmax : row->max_error_rel;
			row->level_rms_rel = row->send_level < level
			                         ? (lnodes ? sqrt(lsum / (double)lnodes) : 0)
			                         : row->rms_error_rel;
			row->disp_max_rel = row->send_level < level ? dmax : row->max_error_rel;
			row->disp_rms_rel = row->send_level < level
			                        ? (lnodes ? sqrt(dsum / (double)lnodes) : 0)
			                        : row->rms_error_rel;
			row->encode_ms = row->steps ? 1e3 * enc_s / (double)row->steps : 0;
			ndo_grid *og = ndo_peer_grid(p[0]);
			row->final_x = malloc(3 * og->count * sizeof *row->final_x);
			if (row->final_x)
				memcpy(row->final_x, ndo_grid_f64(og, NDO_CH_POSITION, 3),
				       3 * og->count * sizeof *row->final_x);
			row->kernel_drops = kernel_drops() - drops0;
			ndo_peer_destroy(p[0], NULL); /* ends the session */
			p[0] = NULL;
		}
		if (owner_done >= 0) {
			int all = 1;
			for (int k = 1; k < np; k++)
				all &= !p[k] || state[k] == NDO_PEER_DONE || state[k] == NDO_PEER_ENDED;
			if ((all && ndo_watch_ended(w)) || now - owner_done > 3)
				break;
		}
		if (!busy) { /* wait for traffic, at most 1 ms */
			struct pollfd pf[MAXP + 1];
			int nf = 0;
			for (int k = 0; k < np; k++)
				if (p[k])
					pf[nf++] = (struct pollfd){
						ndo_link_fileno(ndo_net_link(ndo_session_net(ndo_peer_session(p[k])))),
						POLLIN, 0};
			poll(pf, (nfds_t)nf, 1);
		}
	}
	if (w) {
		ndo_watch_stats ws;
		ndo_watch_stats_get(w, &ws);
		row->frames = ws.frames;
		row->incomplete = ws.incomplete;
		/* decoding: the observer decodes the whole object every step */
		const ndo_codec *cs[2] = {ndo_net_codec(wnet), ndo_net_coarse_codec(wnet)};
		for (int k = 0; k < 2; k++)
			if (cs[k] && row->steps) {
				ndo_codec_stats ds;
				ndo_codec_stats_get(cs[k], &ds);
				row->decode_ms += 1e3 * ds.decode_seconds / (double)row->steps;
			}
	}
	for (int k = 0; k < np; k++)
		ndo_peer_destroy(p[k], NULL);
	ndo_watch_destroy(w);
	listener_stop(&lis, &row->latency_p50_us, &row->latency_p99_us);
	/* what went over the wire: the whole run, and the steady state (the
	 * owner's steps after the last join) */
	row->whole = lis.tr;
	row->steady = lis.tr;
	tr0 = lis.before;
	if (step0 < 0) /* the observer saw no frame: the whole run */
		step0 = 0, memset(&tr0, 0, sizeof tr0);
	row->steady_steps = row->steps - 1 - step0; /* the last step apart */
	for (int k = 0; k < NB_KINDS; k++) {
		row->steady.messages[k] -= tr0.messages[k];
		row->steady.bytes[k] -= tr0.bytes[k];
		row->steady.payload[k] -= tr0.payload[k];
	}
	double wsum = 0, ssum = 0, spay = 0;
	for (int k = 0; k < NB_KINDS; k++) {
		wsum += row->whole.bytes[k];
		if (k != NB_FINAL && k != NB_HALO)
			ssum += row->steady.bytes[k], spay += row->steady.payload[k];
	}
	double nu = (double)row->nodes * (double)row->steady_steps;
	row->total_bits = row->steps ? 8 * wsum / ((double)row->nodes * (double)row->steps) : NAN;
	row->bits_per_node_update = nu > 0 ? 8 * ssum / nu : NAN;
	row->payload_bits = nu > 0 ? 8 * spay / nu : NAN;
	row->bits_per_vertex = nu > 0 ? 8 * ssum / ((double)row->vertices * (double)row->steady_steps)
	                              : NAN;
	row->mbit_s = row->steady_steps > 0 && row->steps_per_s > 0
	                  ? 8 * ssum / ((double)row->steady_steps / row->steps_per_s) / 1e6
	                  : NAN;
	ndo_scene_free(&sc);
	row->wall = ndo_now() - t0;
	return rc;
}
