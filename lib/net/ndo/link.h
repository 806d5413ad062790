/* ndo/link.h — moving encoded messages: LCM, an in-memory bus for tests,
 * and fault injection in between (docs/protocol.md, "Transport").
 *
 * A link publishes (channel, bytes) and, when polled, hands every message
 * that has arrived to a callback, without blocking.  One thread uses a
 * link (LCM: only one thread may call lcm_handle).  Links own what they
 * allocate; ndo_link_destroy() accepts NULL.
 */
#ifndef NDO_LINK_H
#define NDO_LINK_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ndo_link ndo_link;

/* Called by ndo_link_poll() for each message; `data` is valid only during
 * the call. */
typedef void (*ndo_link_fn)(void *user, const char *channel, const void *data,
                            size_t len);

/* LCM's default provider when neither the caller nor LCM_DEFAULT_URL gives
 * one (the value LCM 1.3.1 itself uses). */
#define NDO_LCM_DEFAULT_URL "udpm://239.255.76.67:7667?ttl=0"
/* Kernel receive buffer asked for by default: 8 MiB.  Linux caps it at
 * net.core.rmem_max (4 MiB on Debian 12) unless raised. */
#define NDO_RECV_BUF_DEFAULT (8 << 20)

/* The URL to use: `url` if not NULL/empty, else $LCM_DEFAULT_URL, else
 * NDO_LCM_DEFAULT_URL; with recv_buf_size=BYTES added to a udpm:// URL
 * that does not set it (recv_buf ≤ 0: leave it alone).  Writes at most
 * `size` bytes to `out`; NDO_ERANGE when it does not fit. */
int ndo_lcm_url(const char *url, int recv_buf, char *out, size_t size);

/* Open LCM at `url` (as ndo_lcm_url() resolves it) and subscribe to every
 * channel "PREFIX_*".  queue: the subscription's queue capacity in
 * messages (LCM drops the newest beyond it; ≤ 0: 10,000). */
int ndo_link_open_lcm(const char *url, int recv_buf, const char *prefix, int queue,
                      ndo_link **out);

/* An in-memory bus: every link opened on it receives what any link on it
 * publishes (its own messages included, as with LCM multicast), in
 * order.  The bus must outlive its links. */
typedef struct ndo_bus ndo_bus;
int ndo_bus_create(ndo_bus **out);
void ndo_bus_destroy(ndo_bus *b);
int ndo_link_open_mem(ndo_bus *b, ndo_link **out);
/* Everything published on the bus that the in-memory link `l` has not
 * read is lost to it (a test's burst of loss: what this link would have
 * received until now).  Nothing for a link of another kind. */
void ndo_link_mem_lose(ndo_link *l);

/* The same loss, counted as an overflow (ndo_link_overflows): what a
 * socket whose buffer filled while its reader was busy loses, and knows
 * it lost. */
void ndo_link_mem_overflow(ndo_link *l);
/* Fault injection on the receiving side (the application's netem): each
 * message is dropped with probability `drop`; the others are held for
 * delay_ms + U(0, jitter_ms) and, with probability `reorder`, held further
 * until the next message is released (so the two swap).  Same seed, same
 * decisions.  wrap takes ownership of `inner`. */
typedef struct ndo_faults {
	double drop;      /* 0..1 */
	double delay_ms;  /* ≥ 0 */
	double jitter_ms; /* ≥ 0 */
	double reorder;   /* 0..1 */
	uint64_t seed;
} ndo_faults;
int ndo_link_faults(ndo_link *inner, const ndo_faults *f, ndo_link **out);
/* The earliest time (the clock of ndo_link_poll) at which a message held
 * back by fault injection is due, or INFINITY: how long a caller waiting
 * on ndo_link_fileno() may sleep at most. */
double ndo_link_next_due(const ndo_link *l);

/* 1 when the link will never hand over another message (a log file read
 * to its end, ndo_link_open_log), else 0. */
int ndo_link_ended(const ndo_link *l);

/* A recorded run: the events of an LCM log file (lcm-logger's format,
 * read with LCM's lcm_eventlog API) on channels "PREFIX_*", in their
 * order, at most `batch` (≤ 0: 64) per poll, as fast as the caller polls;
 * ndo_link_ended() says when all are read.  Publishing is refused
 * (NDO_EINVAL): a log is read-only.  Before LCM reads an event its header
 * is checked against the file (sync word, channel length 1..999, data
 * length within what is left of the file), since LCM's reader would
 * allocate whatever a corrupt length says.  A log that ends inside its
 * last event (cut short: lcm-logger killed, a copy interrupted) ends there
 * like a whole one, every event before the cut handed over, and
 * ndo_link_note() says where it was cut; a header without LCM's sync word
 * ends it with an error from ndo_link_poll (NDO_EFORMAT, naming the byte
 * offset). */
int ndo_link_open_log(const char *path, const char *prefix, int batch, ndo_link **out);

/* Why a link ended early ("" when it did not): a log cut short says where
 * ("cut short at byte 500000: an event of 52366 bytes runs past the end"). */
const char *ndo_link_note(const ndo_link *l);

/* Messages the fault layer dropped, and delayed, so far (0 for other links). */
uint64_t ndo_link_injected_drops(const ndo_link *l);

/* Messages lost before the link read them, so far, where the link can
 * know: LCM's udpm:// group read directly (docs/protocol.md, "LCM
 * facts"), the datagrams the kernel dropped because the socket's buffer
 * was full (SO_RXQ_OVFL; learnt with the next datagram that arrives);
 * ndo_link_mem_overflow's; a fault link, its inner link's.  0 where it
 * cannot be known (LCM's own receiving thread, a log) — not "nothing
 * lost".  A peer's silence during such a loss is no sign that it is dead
 * (ndo_session_update). */
uint64_t ndo_link_overflows(const ndo_link *l);
/* Publish: 0, or NDO_EIO (the provider refused; errno-level detail). */
int ndo_link_publish(ndo_link *l, const char *channel, const void *data, size_t len);

/* Hand every message that has arrived (and, with faults, whose delay has
 * passed by `now`, seconds on any monotonic clock) to fn.  Never blocks.
 * Returns the number of messages handed over, or NDO_EIO. */
int ndo_link_poll(ndo_link *l, double now, ndo_link_fn fn, void *user);

/* A file descriptor that becomes readable when a message arrives (for
 * select/poll in a tool's main loop), or −1. */
int ndo_link_fileno(ndo_link *l);

void ndo_link_destroy(ndo_link *l);

/* Seconds on CLOCK_MONOTONIC: what tools pass as `now`. */
double ndo_now(void);

/* The project's small seeded RNG (splitmix64), for fault injection, ids
 * and tests: same seed, same numbers on every machine. */
uint64_t ndo_rng_next(uint64_t *state);
double ndo_rng_uniform(uint64_t *state); /* [0, 1) */

#ifdef __cplusplus
}
#endif
#endif
