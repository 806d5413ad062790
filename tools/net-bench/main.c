/* net-bench — what the peers' traffic costs, by level and tile encoding,
 * through real LCM (docs/net-bench.md).  The work is bench.c: each row
 * runs the thesis' scene with peers in this process. */
#include "bench.h"

#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static __attribute__((noreturn)) void usage(void)
{
	printf("Usage: %s [-l L] [-e ENCODING] [-o FILE] [--csv FILE] [--lcm URL] [options]\n"
	       "Measure the peers' traffic on the thesis' scene (figure 5.3: the wavy surface,\n"
	       "k = 1 N/m, b = 0.1, 2.4 N at 1 Hz, rk4) through real LCM: an owner and\n"
	       "joiners in lock-step and a passive observer, in this process, in a private\n"
	       "network namespace (or on --lcm URL).  With no -l and no -e, the whole table\n"
	       "(levels 4-8 x raw, float32, fixed, predict, hier) and a loss sweep; otherwise\n"
	       "the rows asked for.  Prints a Markdown table beside the thesis' Table 5.2.\n"
	       "\n"
	       "  -l, --level L       the grid level, 1..8 (default: 4 to 8)\n"
	       "  -e, --encoding E    raw, float32, fixed[:BITS], predict[:BITS[:KEYFRAME]]\n"
	       "                      or hier[:BITS[:KEYFRAME]] (default: all five; bits\n"
	       "                      1..24, default 13; or instead of bits an error\n"
	       "                      budget over the box's diagonal, 1e-7..0.01, e.g.\n"
	       "                      predict:1e-4)\n"
	       "  -o, --output FILE   write the table to FILE (default: standard output)\n"
	       "      --csv FILE      write the rows as CSV too ('-': standard output,\n"
	       "                      instead of the table)\n"
	       "      --lcm URL       use this LCM URL as it is, no private namespace\n"
	       "      --key FILE      keyed sessions: every message sealed with this key\n"
	       "                      (48 bytes more each; default: $NDO_KEY, else none)\n"
	       "  -t, --time S        simulated seconds per run, 0.05..60 (default 5)\n"
	       "      --peers N       simulating peers, 1..8 (default 2)\n"
	       "  -s, --send-level LIST  whole-region state at these levels (the owner's\n"
	       "                      --send-level), each 0..8, comma-separated; a row per\n"
	       "                      level at or below the row's level (default: the\n"
	       "                      row's level)\n"
	       "      --loss LIST     drop rates for the loss sweep, each 0..0.9, comma-\n"
	       "                      separated, or 'none' (default: 0.01,0.05,0.1,0.2,0.3\n"
	       "                      for the whole table at level 5 with predict, none for\n"
	       "                      chosen rows)\n"
	       "      --timeout S     wall seconds one run may take, 1..3600 (default 300)\n"
	       "  -q, --quiet         no progress on standard error\n"
	       "  -h, --help          show this help and exit\n"
	       "      --version       show the version and exit\n"
	       "\n"
	       "Columns, as a listener on every channel of the run sees the traffic: bits\n"
	       "per node per update (over W x H nodes and the owner's steps) of the state\n"
	       "tiles' payload alone and of every message on the wire (with message, LCM,\n"
	       "UDP and IPv4 headers; the simulating peers' halos apart, in the CSV's\n"
	       "halo_bits), both in the steady state (after the last join,\n"
	       "before the last step, which goes exact), and of the whole run with the\n"
	       "joins and the last step; Mbit/s of the steady state at the rate the run\n"
	       "went, the position error the encoding introduced (max and RMS over the\n"
	       "bounding-box diagonal), encoding and decoding ms per step for the whole\n"
	       "object, publish-to-receive latency (p50, p99), kernel drops (/proc/net/udp);\n"
	       "the send level, the wire bits over the level's distinct vertices (2·4^L + 2)\n"
	       "instead of W x H, and the error at the simulated level of what an observer\n"
	       "holds, refined by the butterfly (max and RMS over the diagonal; without a\n"
	       "send level below the row's, the encoding's); the CSV adds that error for\n"
	       "a receiver that refines the displacement onto the rest shape instead.\n"
	       "\n"
	       "Exit status: 0 success, 1 a run failed or the CSV could not be written, 2\n"
	       "usage error.\n",
	       ndo_progname);
	ndo_close_stdout();
	exit(NDO_EXIT_OK);
}

/* Thesis Table 5.2 (uncompressed), Mbit/s by level 4..7. */
static double thesis_mbit(int level)
{
	static const double t[] = {0.735, 2.75, 10.75, 42.49};
	return level >= 4 && level <= 7 ? t[level - 4] : NAN;
}

static const char *const header =
	"level,encoding,loss,peers,steps,nodes,exact_nodes,bits_per_node_update,"
	"payload_bits_per_node_update,total_bits_per_node_update,encoded_tile_bits,raw_tile_bits,"
	"rest_tile_bits,final_tile_bits,heartbeat_bits,control_bits,tiles_per_step,steady_steps,mbit_s,"
	"steps_per_s,max_error_rel,rms_error_rel,encode_ms,decode_ms,latency_p50_us,"
	"latency_p99_us,kernel_drops,messages,resends,nobase,corrupt,observer_frames,"
	"observer_incomplete,divergence,thesis_mbit_s,send_level,vertices,bits_per_vertex_update,"
	"level_max_error_rel,level_rms_error_rel,disp_max_error_rel,disp_rms_error_rel,halo_bits";

static void csv_row(FILE *f, const nb_row *r)
{
	double nu = (double)r->nodes * (double)r->steady_steps, b[NB_KINDS];
	for (int k = 0; k < NB_KINDS; k++)
		b[k] = nu > 0 ? 8 * r->steady.bytes[k] / nu : NAN;
	double tiles = r->steady_steps > 0 ? (double)(r->steady.messages[NB_ENCODED] +
	                                              r->steady.messages[NB_RAW_STATE]) /
	                                         (double)r->steady_steps
	                                   : NAN;
	fprintf(f, "%d,%s,%g,%d,%lld,%zu,%zu,%.4g,%.4g,%.4g,%.4g,%.4g,%.4g,%.4g,%.4g,%.4g,%.4g,%lld,"
	        "%.4g,%.4g,%.3g,%.3g,%.4g,%.4g,%.4g,%.4g,%ld,"
	        "%llu,%llu,%llu,%llu,%lld,%lld,%.3g,%.4g,%d,%zu,%.4g,%.3g,%.3g,%.3g,%.3g,%.4g\n",
	        r->level, r->encoding, r->loss, r->peers, (long long)r->steps, r->nodes,
	        r->exact_nodes, r->bits_per_node_update, r->payload_bits, r->total_bits,
	        b[NB_ENCODED], b[NB_RAW_STATE], b[NB_REST], b[NB_FINAL], b[NB_HEARTBEAT],
	        b[NB_CONTROL], tiles,
	        (long long)r->steady_steps, r->mbit_s, r->steps_per_s,
	        r->max_error_rel, r->rms_error_rel, r->encode_ms, r->decode_ms, r->latency_p50_us,
	        r->latency_p99_us, r->kernel_drops, (unsigned long long)r->messages,
	        (unsigned long long)r->resends, (unsigned long long)r->nobase,
	        (unsigned long long)r->corrupt, (long long)r->frames, (long long)r->incomplete,
	        r->divergence, thesis_mbit(r->level), r->send_level, r->vertices, r->bits_per_vertex,
	        r->level_max_rel, r->level_rms_rel, r->disp_max_rel, r->disp_rms_rel, b[NB_HALO]);
}

static void table_head(FILE *f)
{
	fprintf(f, "| level | nodes | encoding | send level | peers | payload bits/node/update "
	       "| wire bits/node/update | wire bits/vertex/update | whole run incl. joins | Mbit/s "
	       "| steps/s | thesis Mbit/s | max error | RMS error | max error at level | RMS at level "
	       "| encode ms | decode ms | latency p50 µs | p99 µs | kernel drops |\n"
	       "|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
	       "---:|---:|---:|---:|\n");
}

static void table_row(FILE *f, const nb_row *r)
{
	double th = thesis_mbit(r->level);
	char ths[32] = "–";
	if (!isnan(th))
		snprintf(ths, sizeof ths, "%.4g", th);
	fprintf(f, "| %d | %zu | %s | %d | %d | %.3g | %.3g | %.3g | %.3g | %.3g | %.0f | %s | %.2g | "
	       "%.2g | %.2g | %.2g | %.3g | %.3g | %.0f | %.0f | %ld |\n",
	       r->level, r->nodes, r->encoding, r->send_level, r->peers, r->payload_bits,
	       r->bits_per_node_update, r->bits_per_vertex, r->total_bits, r->mbit_s, r->steps_per_s,
	       ths, r->max_error_rel, r->rms_error_rel, r->level_max_rel, r->level_rms_rel,
	       r->encode_ms, r->decode_ms,
	       r->latency_p50_us, r->latency_p99_us, r->kernel_drops);
	fflush(f);
}

/* A comma-separated list of drop rates (0..0.9) or of send levels (0..8). */
static int parse_list(const char *arg, int levels, double *out, int max)
{
	const char *opt = levels ? "--send-level" : "--loss";
	int n = 0;
	char *copy = strdup(arg), *save = NULL;
	if (!copy)
		ndo_die("out of memory");
	for (char *tok = strtok_r(copy, ",", &save); tok; tok = strtok_r(NULL, ",", &save)) {
		if (n == max)
			ndo_usage_error("%s: at most %d %s", opt, max, levels ? "levels" : "rates");
		out[n++] = levels ? (double)ndo_opt_long(opt, tok, 0, 8)
		                  : ndo_opt_double(opt, tok, 0, 0.9);
	}
	free(copy);
	if (!n)
		ndo_usage_error("%s: '%s': give %s", opt, arg,
		                levels ? "levels like 4,5,6" : "rates like 0.05,0.2 or 'none'");
	return n;
}

int main(int argc, char **argv)
{
	ndo_cli_init(argc, argv);
	nb_opts o = {.url = NULL, .time = 5, .peers = 2, .timeout = 300, .send_level = -1};
	int level = -1, nloss = -1, nsend = 0;
	double sends[16];
	const char *csv = NULL, *output = NULL;
	ndo_codec_params one;
	int have_enc = 0;
	double losses[16];
	enum { OPT_CSV = 256, OPT_LCM, OPT_PEERS, OPT_LOSS, OPT_TIMEOUT, OPT_VERSION, OPT_KEY };
	const char *key_file = NULL;
	static const struct option opts[] = {
		{"level", required_argument, 0, 'l'},
		{"encoding", required_argument, 0, 'e'},
		{"output", required_argument, 0, 'o'},
		{"csv", required_argument, 0, OPT_CSV},
		{"lcm", required_argument, 0, OPT_LCM},
		{"key", required_argument, 0, OPT_KEY},
		{"time", required_argument, 0, 't'},
		{"peers", required_argument, 0, OPT_PEERS},
		{"send-level", required_argument, 0, 's'},
		{"loss", required_argument, 0, OPT_LOSS},
		{"timeout", required_argument, 0, OPT_TIMEOUT},
		{"quiet", no_argument, 0, 'q'},
		{"help", no_argument, 0, 'h'},
		{"version", no_argument, 0, OPT_VERSION},
		{0, 0, 0, 0}};
	int c;
	while ((c = getopt_long(argc, argv, ":l:e:o:t:s:qh", opts, NULL)) != -1) {
		switch (c) {
		case 'l': level = (int)ndo_opt_long("--level", optarg, 1, 8); break;
		case 'e':
			if (ndo_codec_parse(optarg, &one))
				ndo_usage_error("--encoding: %s", ndo_errdetail());
			have_enc = 1;
			break;
		case 'o': output = optarg; break;
		case OPT_CSV: csv = optarg; break;
		case OPT_LCM:
			if (!*optarg)
				ndo_usage_error("--lcm: an empty URL");
			o.url = optarg;
			break;
		case OPT_KEY: key_file = optarg; break;
		case 't': o.time = ndo_opt_double("--time", optarg, 0.05, 60); break;
		case OPT_PEERS: o.peers = (int)ndo_opt_long("--peers", optarg, 1, 8); break;
		case 's': nsend = parse_list(optarg, 1, sends, 16); break;
		case OPT_LOSS:
			nloss = strcmp(optarg, "none") == 0 ? 0 : parse_list(optarg, 0, losses, 16);
			break;
		case OPT_TIMEOUT: o.timeout = ndo_opt_double("--timeout", optarg, 1, 3600); break;
		case 'q': o.quiet = 1; break;
		case 'h': usage();
		case OPT_VERSION: ndo_print_version();
		default: ndo_bad_option(c);
		}
	}
	if (optind < argc)
		ndo_usage_error("unexpected argument '%s'", argv[optind]);
	/* Every usage error before anything is written or the namespace made:
	 * a send level above -l's printed the table's head on standard output
	 * first, and without root the namespace's error hid it. */
	if (level >= 0)
		for (int k = 0; k < nsend; k++)
			if (sends[k] > level)
				ndo_usage_error("--send-level: %d is above the level %d (0..%d)",
				                (int)sends[k], level, level);
	if (csv && output && !ndo_is_stdio(csv) && !ndo_is_stdio(output) &&
	    strcmp(csv, output) == 0)
		ndo_usage_error("--csv %s: that is the table's file (-o) too", csv);
	static ndo_key key;
	int keyed = ndo_key_resolve(key_file, &key);
	if (keyed < 0)
		ndo_die("%s%s", key_file ? "--key: " : "", ndo_errdetail());
	o.key = keyed ? &key : NULL;
	int whole = level < 0 && !have_enc;
	if (nloss < 0) { /* the default sweep with the whole table */
		nloss = 0;
		if (whole) {
			const double d[] = {0.01, 0.05, 0.1, 0.2, 0.3};
			memcpy(losses, d, sizeof d);
			nloss = 5;
		}
	}
	/* the CSV on standard output takes the place of the table there */
	int csv_stdout = csv && ndo_is_stdio(csv);
	int table = !(csv_stdout && ndo_is_stdio(output));
	ndo_outfile cout, tout;
	FILE *cf = NULL, *tf = NULL;
	if (csv && !csv_stdout && ndo_out_open(csv, &cout))
		ndo_die("%s: %s", csv, ndo_errdetail());
	if (csv)
		cf = csv_stdout ? stdout : cout.f;
	if (table && ndo_out_open(output, &tout)) {
		if (csv && !csv_stdout)
			ndo_out_abort(&cout);
		ndo_die("%s: %s", output, ndo_errdetail());
	}
	if (table)
		tf = tout.f;
	if (!o.url) {
		char why[300];
		if (nb_private_netns(why, sizeof why))
			ndo_die("%s", why);
	}
	int lo = level < 0 ? 4 : level, hi = level < 0 ? 8 : level;
	ndo_codec_params encs[5];
	int nenc = 0;
	if (have_enc) {
		encs[nenc++] = one;
	} else {
		const char *names[] = {"raw", "float32", "fixed", "predict", "hier"};
		for (int k = 0; k < 5; k++)
			ndo_codec_parse(names[k], &encs[nenc++]);
	}
	if (cf)
		fprintf(cf, "%s\n", header);
	if (tf)
		table_head(tf);
	int failed = 0;
	if (!nsend) /* the row's own level */
		sends[nsend++] = -1;
	for (int l = lo; l <= hi && !failed; l++)
		for (int e = 0; e < nenc && !failed; e++)
			for (int sl = 0; sl < nsend && !failed; sl++) {
				nb_row r;
				if (sends[sl] > l)
					continue; /* the whole table: levels above a row's are not its */
				o.send_level = (int)sends[sl];
				if (!o.quiet) {
					char name[32];
					ndo_codec_name(&encs[e], name, sizeof name);
					fprintf(stderr, "%s: level %d, %s, send level %d ...\n", ndo_progname, l, name,
					        sends[sl] < 0 ? l : (int)sends[sl]);
				}
				if (nb_run(&o, l, &encs[e], 0, &r)) {
					ndo_warn("level %d: %s", l, ndo_errdetail());
					failed = 1;
				} else {
					if (tf)
						table_row(tf, &r);
					if (cf)
						csv_row(cf, &r);
				}
				nb_row_free(&r);
			}
	if (nloss > 0 && !failed) {
		/* the loss sweep: each lossy run against the same run with no loss */
		int sl = level < 0 ? 5 : level;
		ndo_codec_params se = encs[have_enc ? 0 : 3];
		o.send_level = -1; /* the loss sweep: at the row's level */
		nb_row ref;
		if (!o.quiet)
			fprintf(stderr, "%s: loss sweep, level %d ...\n", ndo_progname, sl);
		if (nb_run(&o, sl, &se, 0, &ref)) {
			ndo_warn("loss sweep: %s", ndo_errdetail());
			failed = 1;
		}
		if (!failed && tf)
			fprintf(tf, "\nLoss sweep (level %d, %s, %d peers, drop on every peer's receiving "
			       "side):\n\n| drop | divergence | steps/s | resends | nobase drops | "
			       "observer frames | incomplete |\n|---:|---:|---:|---:|---:|---:|---:|\n",
			       sl, ref.encoding, o.peers);
		for (int k = 0; k < nloss && !failed; k++) {
			nb_row r;
			if (nb_run(&o, sl, &se, losses[k], &r)) {
				ndo_warn("loss %g: %s", losses[k], ndo_errdetail());
				failed = 1;
			} else {
				if (r.final_x && ref.final_x)
					r.divergence = nb_divergence(r.final_x, ref.final_x, ref.rest, r.nodes);
				if (tf)
					fprintf(tf, "| %g | %.3g | %.0f | %llu | %llu | %lld | %lld |\n", r.loss,
					       r.divergence, r.steps_per_s, (unsigned long long)r.resends,
					       (unsigned long long)r.nobase, (long long)r.frames,
					       (long long)r.incomplete);
				if (cf)
					csv_row(cf, &r);
			}
			nb_row_free(&r);
		}
		nb_row_free(&ref);
	}
	/* a failed run leaves no half-written file behind */
	if (csv && !csv_stdout) {
		if (failed)
			ndo_out_abort(&cout);
		else if (ndo_out_commit(&cout))
			ndo_die("%s: %s", csv, ndo_errdetail());
	}
	if (tf && !ndo_is_stdio(output)) {
		if (failed)
			ndo_out_abort(&tout);
		else if (ndo_out_commit(&tout))
			ndo_die("%s: %s", output, ndo_errdetail());
	}
	ndo_close_stdout();
	return failed ? NDO_EXIT_FAIL : NDO_EXIT_OK;
}
