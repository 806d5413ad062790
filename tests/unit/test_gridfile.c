/* test_gridfile.c — grid files: bit-exact round trips for every channel
 * type, streams of grids, and rejection (never a crash) of every
 * truncation, every single-bit flip and hand-crafted hostile headers. */
#include "check.h"
#include "ndo/ndo.h"

#include <stdint.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

static uint64_t rng = 0x9e3779b97f4a7c15u;
static uint64_t next_random(void)
{
	rng ^= rng << 13, rng ^= rng >> 7, rng ^= rng << 17;
	return rng;
}

static void fill_random(ndo_channel *c, size_t count)
{
	size_t bytes = count * (size_t)c->comps * ndo_type_size(c->type);
	unsigned char *p = c->data;
	for (size_t k = 0; k < bytes; k++)
		p[k] = (unsigned char)next_random();
}

/* A grid with one channel of every type and width 1..4, random bits
 * (so NaNs with payloads, infinities, −0 and denormals all occur). */
static ndo_grid *sample_grid(int level)
{
	ndo_grid *g;
	ndo_grid_create(level, &g);
	static const struct { const char *name; ndo_type t; int comps; } chans[] = {
		{"velocity", NDO_F32, 3}, {"rest", NDO_F64, 3}, {"pin", NDO_U8, 1},
		{"owner", NDO_I32, 1},   {"rgba", NDO_F32, 4}, {"s", NDO_F64, 1},
		{"uv.2", NDO_U8, 2},     {"tag_3-x", NDO_I32, 3}};
	for (size_t k = 0; k < sizeof chans / sizeof chans[0]; k++) {
		ndo_channel *c;
		ndo_grid_add(g, chans[k].name, chans[k].t, chans[k].comps, &c);
	}
	for (int c = 0; c < g->nchannels; c++)
		fill_random(&g->ch[c], g->count);
	g->time = 1.25;
	g->step = -42;
	char *argv[] = {"remesh", "--shape", "it's", "a b", "x\ny"};
	ndo_grid_add_history(g, 5, argv);
	return g;
}

static int same_grid(const ndo_grid *a, const ndo_grid *b)
{
	if (a->level != b->level || a->nchannels != b->nchannels || a->step != b->step ||
	    memcmp(&a->time, &b->time, sizeof a->time) != 0 || strcmp(a->history, b->history) != 0)
		return 0;
	for (int c = 0; c < a->nchannels; c++) {
		const ndo_channel *x = &a->ch[c], *y = &b->ch[c];
		if (strcmp(x->name, y->name) || x->type != y->type || x->comps != y->comps ||
		    memcmp(x->data, y->data, a->count * (size_t)x->comps * ndo_type_size(x->type)))
			return 0;
	}
	return 1;
}

/* The bytes of a grid file in memory. */
static unsigned char *serialize(const ndo_grid *g, size_t *len)
{
	char *buf = NULL;
	FILE *f = open_memstream(&buf, len);
	ndo_grid_write(f, g);
	fclose(f);
	return (unsigned char *)buf;
}

static int parse(const unsigned char *buf, size_t len, ndo_grid **out)
{
	*out = NULL;
	FILE *f = len ? fmemopen((void *)buf, len, "rb") : fopen("/dev/null", "rb");
	int rc = ndo_grid_read(f, out);
	fclose(f);
	return rc;
}

static void round_trip_every_type_bit_exact(void)
{
	for (int level = 0; level <= 6; level++) {
		ndo_grid *g = sample_grid(level), *h = NULL;
		size_t len;
		unsigned char *buf = serialize(g, &len);
		int rc = parse(buf, len, &h);
		CHECK(rc == NDO_OK, "level %d: read failed: %s", level, ndo_errdetail());
		CHECK(h && same_grid(g, h), "level %d: the round trip changed the grid", level);
		CHECK(len % 8 == 0, "level %d: file length %zu not a multiple of 8", level, len);
		ndo_grid_destroy(g);
		ndo_grid_destroy(h);
		free(buf);
	}
}

static void stream_of_grids(void)
{
	FILE *f = tmpfile();
	ndo_grid *g[3];
	for (int k = 0; k < 3; k++) {
		g[k] = sample_grid(k * 2);
		CHECK(ndo_grid_write(f, g[k]) == NDO_OK, "write %d", k);
	}
	rewind(f);
	for (int k = 0; k < 3; k++) {
		ndo_grid *h;
		int rc = ndo_grid_read(f, &h);
		CHECK(rc == NDO_OK && same_grid(g[k], h), "grid %d of the stream: %s", k, ndo_errdetail());
		ndo_grid_destroy(h);
		ndo_grid_destroy(g[k]);
	}
	ndo_grid *h;
	CHECK(ndo_grid_read(f, &h) == NDO_EEOF && h == NULL, "the stream should end cleanly");
	fclose(f);
}

static void every_truncation_rejected(void)
{
	ndo_grid *g = sample_grid(1);
	size_t len;
	unsigned char *buf = serialize(g, &len);
	int bad = 0;
	for (size_t cut = 0; cut < len; cut++) {
		ndo_grid *h;
		int rc = parse(buf, cut, &h);
		int expect_eof = cut == 0;
		if (expect_eof ? rc != NDO_EEOF : (rc == NDO_OK || rc == NDO_EEOF || h != NULL)) {
			if (bad++ < 3)
				printf("    cut at %zu: status %d (%s)\n", cut, rc, ndo_errdetail());
		}
		if (cut > 0 && rc == NDO_ETRUNC && !strstr(ndo_errdetail(), "truncated"))
			bad++;
		ndo_grid_destroy(h);
	}
	CHECK(bad == 0, "%d of %zu truncations not rejected as such", bad, len);
	ndo_grid_destroy(g);
	free(buf);
}

/* CRC-32 catches every single-bit error: all bits of a small file, a
 * sample of a level-5 file. */
static void single_bit_flips_rejected(void)
{
	for (int level = 1; level <= 5; level += 4) {
		ndo_grid *g = sample_grid(level);
		size_t len;
		unsigned char *buf = serialize(g, &len);
		size_t stride = level == 1 ? 1 : 997, tried = 0;
		int accepted = 0;
		for (size_t bit = 0; bit < 8 * len; bit += stride) {
			buf[bit / 8] ^= (unsigned char)(1u << (bit % 8));
			ndo_grid *h;
			int rc = parse(buf, len, &h);
			if (rc == NDO_OK) {
				if (accepted++ < 3)
					printf("    bit %zu flipped and accepted\n", bit);
				ndo_grid_destroy(h);
			}
			buf[bit / 8] ^= (unsigned char)(1u << (bit % 8));
			tried++;
		}
		CHECK(accepted == 0, "level %d: %d of %zu bit flips accepted", level, accepted, tried);
		ndo_grid *h;
		CHECK(parse(buf, len, &h) == NDO_OK, "the unflipped file must still read");
		ndo_grid_destroy(h);
		ndo_grid_destroy(g);
		free(buf);
	}
}

static void set32(unsigned char *p, uint32_t v) { memcpy(p, &v, 4); }

static void rehash_header(unsigned char *buf)
{
	set32(buf + 60, (uint32_t)crc32(0, buf, 60));
}

static void rehash_body(unsigned char *buf, size_t len)
{
	set32(buf + len - 8, (uint32_t)crc32(0, buf + 64, (uInt)(len - 72)));
}

/* Headers and tables forged with valid checksums: the range checks, not
 * the CRC, must catch them, before anything is allocated. */
static void forged_headers_rejected(void)
{
	ndo_grid *g = sample_grid(2);
	size_t len;
	unsigned char *orig = serialize(g, &len), *buf = malloc(len);
	struct {
		const char *what;
		size_t off;
		uint32_t value;
		int width;
		int body;   /* rehash the body checksum too */
		int expect;
		const char *message; /* what the detail must say */
	} cases[] = {
		{"level 11", 12, 11, 4, 0, NDO_ERANGE, "level 11 is outside 0..10"},
		{"level 2^31", 12, 0x80000000u, 4, 0, NDO_ERANGE, "level 2147483648 is outside"},
		{"no channels", 16, 0, 4, 0, NDO_ERANGE, "0 channels"},
		{"17 channels", 16, 17, 4, 0, NDO_ERANGE, "17 channels"},
		{"huge history", 20, 0xfffffff0u, 4, 0, NDO_ERANGE, "history of"},
		{"version 2", 8, 2, 2, 0, NDO_EVERSION, "format version 2"},
		{"header size 72", 10, 72, 2, 0, NDO_EFORMAT, "header size 72"},
		{"reserved bytes", 50, 1, 1, 0, NDO_EFORMAT, "reserved"},
		{"payload size", 40, 8, 4, 0, NDO_EFORMAT, "payload size 8"},
		{"unknown type", 64 + 32 + 16, 9, 1, 1, NDO_EFORMAT, "unknown type 9"},
		{"width 0", 64 + 32 + 17, 0, 1, 1, NDO_EFORMAT, "width 0"},
		{"width 5", 64 + 32 + 17, 5, 1, 1, NDO_EFORMAT, "width 5"},
		{"position width 1", 64 + 17, 1, 1, 1, NDO_EFORMAT, "'position' is 1"},
		{"position as u8", 64 + 16, 3, 1, 1, NDO_EFORMAT, "'position' is 3 × u8"},
		{"duplicate name", 64 + 32, 'p', 1, 1, NDO_EFORMAT, "appears twice"},
		{"unterminated name", 64 + 15, 'x', 1, 1, NDO_EFORMAT, "bad name"},
		{"garbage after name", 64 + 12, 'x', 1, 1, NDO_EFORMAT, "padding"},
		{"bad end marker", 0, 'X', 1, 0, NDO_EFORMAT, "end marker"},
	};
	for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
		memcpy(buf, orig, len);
		size_t off = cases[k].off ? cases[k].off : len - 4;
		if (strcmp(cases[k].what, "duplicate name") == 0)
			memcpy(buf + off, "position", 9); /* the second entry renamed */
		else
			memcpy(buf + off, &cases[k].value, (size_t)cases[k].width);
		rehash_header(buf);
		if (cases[k].body)
			rehash_body(buf, len);
		ndo_grid *h;
		int rc = parse(buf, len, &h);
		CHECK(rc == cases[k].expect, "%s: expected status %d, got %d (%s)", cases[k].what,
		      cases[k].expect, rc, ndo_errdetail());
		CHECK(strstr(ndo_errdetail(), cases[k].message) != NULL,
		      "%s: expected a message with '%s', got '%s'", cases[k].what, cases[k].message,
		      ndo_errdetail());
		CHECK(strchr(ndo_errdetail(), '\n') == NULL, "%s: the message must be one line",
		      cases[k].what);
		ndo_grid_destroy(h);
	}
	/* the same file with its checksums intact reads */
	memcpy(buf, orig, len);
	ndo_grid *h;
	CHECK(parse(buf, len, &h) == NDO_OK, "the pristine file: %s", ndo_errdetail());
	ndo_grid_destroy(h);
	/* not a grid at all */
	CHECK(parse((const unsigned char *)"P6\n3 2\n255\nxxxxxxxxxxxxxxxxxx", 29, &h) == NDO_EFORMAT,
	      "a PPM file must be 'not an ndo grid'");
	ndo_grid_destroy(g);
	free(orig);
	free(buf);
}

static void save_is_atomic(void)
{
	char dir[] = "/tmp/ndo-gridfile-XXXXXX";
	CHECK(mkdtemp(dir) != NULL, "mkdtemp");
	char path[256], missing[256];
	snprintf(path, sizeof path, "%s/a.tgrid", dir);
	snprintf(missing, sizeof missing, "%s/no/such/dir/a.tgrid", dir);
	ndo_grid *g = sample_grid(3), *h;
	umask(022);
	CHECK(ndo_grid_save(path, g) == NDO_OK, "save: %s", ndo_errdetail());
	struct stat st;
	CHECK(stat(path, &st) == 0 && (st.st_mode & 0777) == 0644, "mode %o, expected 644",
	      st.st_mode & 0777);
	CHECK(ndo_grid_load(path, &h) == NDO_OK && same_grid(g, h), "load after save");
	ndo_grid_destroy(h);
	/* overwrite in place with another grid */
	ndo_grid *g2 = sample_grid(1);
	CHECK(ndo_grid_save(path, g2) == NDO_OK, "overwrite");
	CHECK(ndo_grid_load(path, &h) == NDO_OK && same_grid(g2, h), "load after overwrite");
	ndo_grid_destroy(h);
	CHECK(count_entries(dir) == 1, "temporary files left behind: %d entries", count_entries(dir));
	CHECK(ndo_grid_save(missing, g) == NDO_EIO, "saving into a missing directory must fail");
	CHECK(count_entries(dir) == 1, "a failed save left files behind");
	if (access("/dev/full", W_OK) == 0) {
		CHECK(ndo_grid_save("/dev/full", g) == NDO_EIO, "a full disk must fail the save");
		struct stat sf;
		CHECK(stat("/dev/full", &sf) == 0 && S_ISCHR(sf.st_mode), "/dev/full must stay a device");
	}
	CHECK(ndo_grid_load(missing, &h) == NDO_EIO && strstr(ndo_errdetail(), "cannot open"),
	      "loading a missing file: %s", ndo_errdetail());
	char empty[256];
	snprintf(empty, sizeof empty, "%s/empty", dir);
	fclose(fopen(empty, "w"));
	CHECK(ndo_grid_load(empty, &h) == NDO_ETRUNC, "an empty file is truncated, not EOF");
	unlink(empty);
	unlink(path);
	rmdir(dir);
	ndo_grid_destroy(g);
	ndo_grid_destroy(g2);
}

/* A history at NDO_HISTORY_MAX (a grid through thousands of tools) takes
 * one more command line: the first line stays, the oldest after it go,
 * the newest is last, and the grid is written and read back.  It was
 * written longer than the cap, and no tool could write the grid any more
 * ("history of 1048593 bytes exceeds 1048576", after simulate-peer's run). */
static void a_full_history_keeps_its_first_and_newest_lines(void)
{
	ndo_grid *g, *h = NULL;
	ndo_grid_create(1, &g);
	const char *first = "remesh bunny.off -l 6\n";
	size_t cap = NDO_HISTORY_MAX;
	char *hist = malloc(cap + 1);
	strcpy(hist, first);
	size_t n = strlen(first);
	for (int k = 0; n + 40 < cap - 7; k++)
		n += (size_t)sprintf(hist + n, "simulate-peer -n 10 s.tgrid -o s.tgrid\n");
	while (n < cap - 7)
		hist[n++] = 'y';
	hist[n++] = '\n';
	hist[n] = 0;
	free(g->history);
	g->history = hist;
	char *argv[] = {"subdivide", "-l", "1", "s.tgrid"};
	CHECK(ndo_grid_add_history(g, 4, argv) == NDO_OK, "add: %s", ndo_errdetail());
	size_t len = strlen(g->history);
	CHECK(len <= cap, "history of %zu bytes, over %zu", len, cap);
	CHECK(strncmp(g->history, first, strlen(first)) == 0, "the first line kept");
	CHECK(strstr(g->history, "earlier lines dropped") != NULL, "the drop said");
	const char *tail = "\nsubdivide -l 1 s.tgrid\n";
	CHECK(len > strlen(tail) && strcmp(g->history + len - strlen(tail), tail) == 0,
	      "the newest line last");
	char path[] = "/tmp/ndo-history-XXXXXX";
	int fd = mkstemp(path);
	CHECK(fd >= 0, "mkstemp");
	close(fd);
	CHECK(ndo_grid_save(path, g) == NDO_OK, "save: %s", ndo_errdetail());
	CHECK(ndo_grid_load(path, &h) == NDO_OK && same_grid(g, h), "load after save");
	ndo_grid_destroy(h);
	/* a newest line that alone is over the cap: its tail */
	size_t big = cap + cap / 2;
	char *arg = malloc(big + 1);
	memset(arg, 'z', big);
	arg[big] = 0;
	char *argv2[] = {arg};
	CHECK(ndo_grid_add_history(g, 1, argv2) == NDO_OK, "add a huge line");
	CHECK(strlen(g->history) <= cap, "history of %zu bytes after a huge line",
	      strlen(g->history));
	CHECK(ndo_grid_save(path, g) == NDO_OK, "save after a huge line: %s", ndo_errdetail());
	free(arg);
	unlink(path);
	ndo_grid_destroy(g);
}

int main(void)
{
	ck_program = "gridfile";
	RUN(round_trip_every_type_bit_exact);
	RUN(stream_of_grids);
	RUN(every_truncation_rejected);
	RUN(single_bit_flips_rejected);
	RUN(forged_headers_rejected);
	RUN(save_is_atomic);
	RUN(a_full_history_keeps_its_first_and_newest_lines);
	return ck_failed_cases != 0;
}
