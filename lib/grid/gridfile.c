/* gridfile.c — reading and writing grid files (format in ndo/gridfile.h
 * and docs/grid-format.md). */
#include "ndo/gridfile.h"
#include "grid_private.h"
#include "ndo/io.h"
#include "ndo/status.h"
#include "ndo/topology.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#if !defined(__BYTE_ORDER__) || __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "the grid file reader assumes a little-endian host"
#endif

static const unsigned char magic[8] = {0x89, 'N', 'D', 'O', 0x0d, 0x0a, 0x1a, 0x0a};
static const unsigned char endmark[4] = {'E', 'N', 'D', '\n'};

enum { HEADER_SIZE = 64, ENTRY_SIZE = 32 };

static size_t pad8(size_t n)
{
	return (n + 7) & ~(size_t)7;
}

static uint32_t crc_update(uint32_t crc, const void *p, size_t n)
{
	const unsigned char *b = p;
	/* zlib takes uInt lengths: feed large buffers in pieces */
	while (n > 0) {
		uInt k = n > (1u << 30) ? (1u << 30) : (uInt)n;
		crc = (uint32_t)crc32(crc, b, k);
		b += k;
		n -= k;
	}
	return crc;
}

static size_t channel_bytes(const ndo_grid *g, const ndo_channel *c)
{
	return g->count * (size_t)c->comps * ndo_type_size(c->type);
}

/* ---- reading ---- */

typedef struct reader {
	FILE *f;
	uint32_t crc;
	size_t offset;
} reader;

static int take(reader *r, void *buf, size_t n, const char *what)
{
	size_t got = fread(buf, 1, n, r->f);
	r->offset += got;
	if (got != n) {
		if (ferror(r->f))
			return ndo__fail(NDO_EIO, "read error in %s: %s", what,
			                 strerror(errno));
		return ndo__fail(NDO_ETRUNC, "truncated in %s (file ends at byte %zu)",
		                 what, r->offset);
	}
	return NDO_OK;
}

static int take_crc(reader *r, void *buf, size_t n, const char *what)
{
	int rc = take(r, buf, n, what);
	if (rc == NDO_OK)
		r->crc = crc_update(r->crc, buf, n);
	return rc;
}

static uint16_t le16(const unsigned char *p) { uint16_t v; memcpy(&v, p, 2); return v; }
static uint32_t le32(const unsigned char *p) { uint32_t v; memcpy(&v, p, 4); return v; }
static uint64_t le64(const unsigned char *p) { uint64_t v; memcpy(&v, p, 8); return v; }

static int all_zero(const unsigned char *p, size_t n)
{
	for (size_t k = 0; k < n; k++)
		if (p[k])
			return 0;
	return 1;
}

static int read_body(reader *r, const unsigned char *hd, ndo_grid **out)
{
	uint32_t level = le32(hd + 12), nch = le32(hd + 16), hlen = le32(hd + 20);
	uint64_t payload = le64(hd + 40);
	if (le16(hd + 10) != HEADER_SIZE)
		return ndo__fail(NDO_EFORMAT, "header size %u, expected %d",
		                 le16(hd + 10), HEADER_SIZE);
	if (!all_zero(hd + 48, 12))
		return ndo__fail(NDO_EFORMAT, "reserved header bytes are not zero");
	if (level > NDO_MAX_LEVEL)
		return ndo__fail(NDO_ERANGE, "level %u is outside 0..%d", level,
		                 NDO_MAX_LEVEL);
	if (nch < 1 || nch > NDO_MAX_CHANNELS)
		return ndo__fail(NDO_ERANGE, "%u channels, expected 1..%d", nch,
		                 NDO_MAX_CHANNELS);
	if (hlen > NDO_HISTORY_MAX)
		return ndo__fail(NDO_ERANGE, "history of %u bytes exceeds %u", hlen,
		                 NDO_HISTORY_MAX);

	/* Read and check the channel table before allocating any data. */
	unsigned char table[NDO_MAX_CHANNELS * ENTRY_SIZE];
	int rc = take_crc(r, table, (size_t)nch * ENTRY_SIZE, "the channel table");
	if (rc)
		return rc;
	size_t w = (2u << level) + 1, h = (1u << level) + 1, expect = 0;
	int have_position = 0;
	for (uint32_t c = 0; c < nch; c++) {
		const unsigned char *e = table + c * ENTRY_SIZE;
		char name[NDO_NAME_LEN];
		memcpy(name, e, NDO_NAME_LEN);
		if (name[NDO_NAME_LEN - 1] != '\0' || name[0] == '\0')
			return ndo__fail(NDO_EFORMAT, "channel %u: bad name", c);
		size_t len = strlen(name);
		if (!all_zero(e + len, NDO_NAME_LEN - len) || !all_zero(e + 18, 14))
			return ndo__fail(NDO_EFORMAT, "channel %u: nonzero padding", c);
		ndo_type t = (ndo_type)e[16];
		int comps = e[17];
		if (ndo_type_size(t) == 0)
			return ndo__fail(NDO_EFORMAT, "channel '%s': unknown type %d", name,
			                 e[16]);
		if (comps < 1 || comps > 4)
			return ndo__fail(NDO_EFORMAT, "channel '%s': width %d outside 1..4",
			                 name, comps);
		for (uint32_t d = 0; d < c; d++)
			if (memcmp(table + d * ENTRY_SIZE, name, NDO_NAME_LEN) == 0)
				return ndo__fail(NDO_EFORMAT, "channel '%s' appears twice", name);
		if (strcmp(name, NDO_CH_POSITION) == 0) {
			if (comps != 3 || (t != NDO_F64 && t != NDO_F32))
				return ndo__fail(NDO_EFORMAT,
				                 "channel 'position' is %d × %s, expected 3 × f64 or f32",
				                 comps, ndo_type_name(t));
			have_position = 1;
		}
		expect += pad8(w * h * (size_t)comps * ndo_type_size(t));
	}
	if (!have_position)
		return ndo__fail(NDO_EFORMAT, "no 'position' channel");
	if (payload != expect)
		return ndo__fail(NDO_EFORMAT,
		                 "payload size %llu does not match its channels (%zu)",
		                 (unsigned long long)payload, expect);

	ndo_grid *g;
	if ((rc = ndo__grid_alloc((int)level, &g))) /* channels follow, in file order */
		return rc;
	g->step = (int64_t)le64(hd + 24);
	memcpy(&g->time, hd + 32, 8);

	size_t hpad = pad8(hlen);
	char *hist = malloc(hpad + 1);
	if (!hist) {
		ndo_grid_destroy(g);
		return ndo__fail(NDO_ENOMEM, "out of memory for the history");
	}
	if ((rc = take_crc(r, hist, hpad, "the history"))) {
		free(hist);
		ndo_grid_destroy(g);
		return rc;
	}
	if (memchr(hist, '\0', hlen) || !all_zero((unsigned char *)hist + hlen, hpad - hlen)) {
		free(hist);
		ndo_grid_destroy(g);
		return ndo__fail(NDO_EFORMAT, "history holds a NUL byte or bad padding");
	}
	hist[hlen] = '\0';
	free(g->history);
	g->history = hist;

	for (uint32_t c = 0; c < nch; c++) {
		const unsigned char *e = table + c * ENTRY_SIZE;
		ndo_channel *ch;
		if ((rc = ndo_grid_add(g, (const char *)e, (ndo_type)e[16], e[17], &ch)))
			break;
		size_t bytes = channel_bytes(g, ch);
		char what[64];
		snprintf(what, sizeof what, "channel '%s'", ch->name);
		if ((rc = take_crc(r, ch->data, bytes, what)))
			break;
		unsigned char zeros[8];
		size_t extra = pad8(bytes) - bytes;
		if ((rc = take_crc(r, zeros, extra, what)))
			break;
		if (!all_zero(zeros, extra)) {
			rc = ndo__fail(NDO_EFORMAT, "%s: nonzero padding", what);
			break;
		}
	}
	unsigned char tail[8];
	if (rc == NDO_OK)
		rc = take(r, tail, 8, "the trailer");
	if (rc == NDO_OK && le32(tail) != r->crc)
		rc = ndo__fail(NDO_ECORRUPT,
		               "data checksum mismatch (stored %08x, computed %08x)",
		               le32(tail), r->crc);
	if (rc == NDO_OK && memcmp(tail + 4, endmark, 4) != 0)
		rc = ndo__fail(NDO_EFORMAT, "bad end marker");
	if (rc) {
		ndo_grid_destroy(g);
		return rc;
	}
	*out = g;
	return NDO_OK;
}

int ndo_grid_read(FILE *f, ndo_grid **out)
{
	unsigned char hd[HEADER_SIZE];
	reader r = {f, 0, 0};
	*out = NULL;
	ndo__clear_error();
	size_t got = fread(hd, 1, sizeof hd, f);
	r.offset = got;
	if (ferror(f))
		return ndo__fail(NDO_EIO, "read error: %s", strerror(errno));
	if (got == 0)
		return NDO_EEOF;
	if (got < 8 || memcmp(hd, magic, 8) != 0)
		return got < 8 && memcmp(hd, magic, got) == 0
		           ? ndo__fail(NDO_ETRUNC, "truncated in the header (%zu of 64 bytes)", got)
		           : ndo__fail(NDO_EFORMAT, "not an ndo grid file (bad magic)");
	if (got < sizeof hd)
		return ndo__fail(NDO_ETRUNC, "truncated in the header (%zu of 64 bytes)", got);
	if (le32(hd + 60) != crc_update(0, hd, 60))
		return ndo__fail(NDO_ECORRUPT, "header checksum mismatch");
	if (le16(hd + 8) != NDO_FILE_VERSION)
		return ndo__fail(NDO_EVERSION, "format version %u; this build reads version %d",
		                 le16(hd + 8), NDO_FILE_VERSION);
	return read_body(&r, hd, out);
}

/* ---- writing ---- */

typedef struct writer {
	FILE *f;
	uint32_t crc;
	int failed;
} writer;

static void put(writer *w, const void *p, size_t n, int checksum)
{
	if (w->failed || n == 0)
		return;
	if (fwrite(p, 1, n, w->f) != n)
		w->failed = errno ? errno : EIO;
	if (checksum)
		w->crc = crc_update(w->crc, p, n);
}

int ndo_grid_write(FILE *f, const ndo_grid *g)
{
	static const unsigned char zeros[8];
	size_t hlen = strlen(g->history);
	if (hlen > NDO_HISTORY_MAX)
		return ndo__fail(NDO_ERANGE, "history of %zu bytes exceeds %u", hlen,
		                 NDO_HISTORY_MAX);
	uint64_t payload = 0;
	for (int c = 0; c < g->nchannels; c++)
		payload += pad8(channel_bytes(g, &g->ch[c]));

	unsigned char hd[HEADER_SIZE] = {0};
	uint16_t version = NDO_FILE_VERSION, hsize = HEADER_SIZE;
	uint32_t level = (uint32_t)g->level, nch = (uint32_t)g->nchannels,
	         hl = (uint32_t)hlen;
	memcpy(hd, magic, 8);
	memcpy(hd + 8, &version, 2);
	memcpy(hd + 10, &hsize, 2);
	memcpy(hd + 12, &level, 4);
	memcpy(hd + 16, &nch, 4);
	memcpy(hd + 20, &hl, 4);
	memcpy(hd + 24, &g->step, 8);
	memcpy(hd + 32, &g->time, 8);
	memcpy(hd + 40, &payload, 8);
	uint32_t hcrc = crc_update(0, hd, 60);
	memcpy(hd + 60, &hcrc, 4);

	writer w = {f, 0, 0};
	errno = 0;
	put(&w, hd, sizeof hd, 0);
	for (int c = 0; c < g->nchannels; c++) {
		unsigned char e[ENTRY_SIZE] = {0};
		memcpy(e, g->ch[c].name, strlen(g->ch[c].name));
		e[16] = (unsigned char)g->ch[c].type;
		e[17] = (unsigned char)g->ch[c].comps;
		put(&w, e, sizeof e, 1);
	}
	put(&w, g->history, hlen, 1);
	put(&w, zeros, pad8(hlen) - hlen, 1);
	for (int c = 0; c < g->nchannels; c++) {
		size_t bytes = channel_bytes(g, &g->ch[c]);
		put(&w, g->ch[c].data, bytes, 1);
		put(&w, zeros, pad8(bytes) - bytes, 1);
	}
	uint32_t crc = w.crc;
	put(&w, &crc, 4, 0);
	put(&w, endmark, 4, 0);
	if (w.failed)
		return ndo__fail(NDO_EIO, "write error: %s", strerror(w.failed));
	return NDO_OK;
}

int ndo_grid_load(const char *path, ndo_grid **out)
{
	*out = NULL;
	ndo__clear_error();
	FILE *f = ndo_is_stdio(path) ? stdin : fopen(path, "rb");
	if (!f)
		return ndo__fail(NDO_EIO, "cannot open: %s", strerror(errno));
	int rc = ndo_grid_read(f, out);
	if (rc == NDO_EEOF)
		rc = ndo__fail(NDO_ETRUNC, "empty input: no grid");
	if (rc == NDO_OK) {
		/* One grid, and nothing after it: a second grid or trailing bytes
		 * would otherwise be ignored without a word. */
		unsigned char more[8];
		size_t n = fread(more, 1, sizeof more, f);
		if (n > 0) {
			rc = n == sizeof more && memcmp(more, magic, 8) == 0
			         ? ndo__fail(NDO_EFORMAT, "a second grid follows the first; this "
			                                  "tool reads one")
			         : ndo__fail(NDO_EFORMAT, "bytes follow the end of the grid "
			                                  "(trailing garbage)");
			ndo_grid_destroy(*out);
			*out = NULL;
		} else if (ferror(f)) {
			rc = ndo__fail(NDO_EIO, "read error: %s", strerror(errno));
			ndo_grid_destroy(*out);
			*out = NULL;
		}
	}
	if (f != stdin)
		fclose(f);
	return rc;
}

int ndo_grid_save(const char *path, const ndo_grid *g)
{
	ndo_outfile o;
	ndo__clear_error();
	int rc = ndo_out_open(path, &o);
	if (rc)
		return rc;
	if ((rc = ndo_grid_write(o.f, g))) {
		ndo_out_abort(&o);
		return rc;
	}
	return ndo_out_commit(&o);
}
