/* remesh — a regular grid from a closed genus-0 triangle mesh (thesis
 * §4.2.2, DESIGN.md "Remeshing"), or from a procedural shape (--shape:
 * the grids the other tools and the tests start from; ndo_shape_make()).
 *
 * The mesh path: load (load.cpp) → validate with CGAL → spherical
 * parameterization (param.cpp) → domain map and its rotation, resampling
 * (resample.cpp) → quality report (quality.cpp) → write. */
#include "remesh.h"

#include <getopt.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <string>

using namespace remesh;

static __attribute__((noreturn)) void usage(void)
{
	printf("Usage: %s [INPUT] [-l L] [-o OUT] [options]\n"
	       "       %s --shape NAME [-l L] [-o OUT] [shape options]\n"
	       "Make a regular grid over the unfolded tetrahedron: from a closed genus-0\n"
	       "triangle mesh (INPUT, any format assimp reads; '-' or none: stdin), or from\n"
	       "a procedural shape.\n"
	       "\n"
	       "  -l, --level L         grid level, 0..10 (default 5)\n"
	       "  -o, --output OUT      a grid file (.tgrid or no extension, '-' for\n"
	       "                        stdout; the default) or a mesh: .obj .ply .stl .glb .gltf\n"
	       "      --map MAP         tetrahedron → sphere: equal-area (shapes' default),\n"
	       "                        gnomonic, or for meshes blend (their default: equal-area\n"
	       "                        moved --blend of the way to gnomonic) or spring (the\n"
	       "                        thesis' stretch-optimized gnomonic projection)\n"
	       "Meshes:\n"
	       "      --blend T         blend map: the gnomonic share, 0..1 (default 0.3)\n"
	       "      --param METHOD    spherical parameterization: hierarchical (default;\n"
	       "                        coarse-to-fine stretch minimization, never flips) or\n"
	       "                        spring (the thesis' spring embedder; may flip)\n"
	       "      --sweeps N        hierarchical: final optimization sweeps, 0..100 (default 6)\n"
	       "      --conformal W     hierarchical: weight of the inverse map's stretch, which\n"
	       "                        keeps parameter triangles round (fewer fold-overs), 0..10,\n"
	       "                        at the coarse levels, a tenth of it at the finest\n"
	       "                        (default 0.35; 0: L2 stretch alone)\n"
	       "      --guard T         hierarchical: the anisotropy (ratio of a triangle's\n"
	       "                        stretches) above which the energy rises, 0 or 1..1000\n"
	       "                        (default 12; 0: off); fewer fold-overs, less stretch\n"
	       "      --importance B    hierarchical: extra samples where the surface is curved\n"
	       "                        at the grid's scale (half of it at the finest level),\n"
	       "                        0..10 (default 0.5; 0: none)\n"
	       "      --spring-steps N  spring: time steps, 1..100000 (default 400)\n"
	       "      --no-relax        spring: without the relaxation step (eq. 4.7)\n"
	       "      --rotations N     random domain rotations screened, 0..100000 (default 96);\n"
	       "                        with the identity and small turns around the best\n"
	       "                        ones the report counts every candidate evaluated\n"
	       "      --no-rotation     keep the domain's rotation (default: optimized)\n"
	       "      --no-weld         keep coincident vertices apart (default: weld an\n"
	       "                        open surface's coincident border edges, as UV-seam\n"
	       "                        splits leave them, and say so)\n"
	       "      --report          print timings and quality on stderr (Hausdorff and\n"
	       "                        RMS distance, fold-overs, self-intersections, stretch;\n"
	       "                        a mesh's: not with --shape)\n"
	       "      --json[=FILE]     the same as JSON, on stderr or into FILE ('-': stdout)\n"
	       "Shapes:\n"
	       "  -s, --shape NAME      tetra, sphere, ellipsoid or wavy\n"
	       "      --axes A,B,C      ellipsoid semi-axes along x, y, z (default 1.5,1,0.75)\n"
	       "      --amplitude A     wavy: radius 1 + A sin(Fx) sin(Fy) sin(Fz) (default 0.08)\n"
	       "      --frequency F     wavy: F (default 5)\n"
	       "  -h, --help            show this help and exit\n"
	       "      --version         show the version and exit\n"
	       "\n"
	       "Exit status: 0 success, 1 bad input mesh or failed write, 2 usage error.\n",
	       ndo_progname, ndo_progname);
	ndo_close_stdout();
	exit(NDO_EXIT_OK);
}

/* ---- the report ---------------------------------------------------- */

struct Report {
	std::string input;
	size_t in_vertices = 0, in_faces = 0;
	long input_selfintersect = 0;
	int level = 0;
	const char *param = "", *map = "";
	ParamStats ps;
	bool rotated = false;
	int rotations = 0; /* random rotations screened (--rotations) */
	RotationResult rot;
	double diag = 0;
	Quality q;
	double t_load = 0, t_validate = 0, t_param = 0, t_rotation = 0, t_resample = 0,
	       t_quality = 0;
	std::vector<std::string> notes;
};

/* The length of the well-formed UTF-8 sequence at s[i] (RFC 3629: no
 * overlong forms, no surrogates, nothing past U+10FFFF), or 0. */
static size_t utf8_len(const std::string &s, size_t i)
{
	const unsigned char c = (unsigned char)s[i];
	size_t n = c < 0x80 ? 1 : c >= 0xc2 && c <= 0xdf ? 2 : c >= 0xe0 && c <= 0xef ? 3
	         : c >= 0xf0 && c <= 0xf4 ? 4 : 0;
	if (n == 0 || i + n > s.size())
		return 0;
	for (size_t k = 1; k < n; k++)
		if (((unsigned char)s[i + k] & 0xc0) != 0x80)
			return 0;
	const unsigned char d = (unsigned char)s[i + 1];
	if ((c == 0xe0 && d < 0xa0) || (c == 0xed && d > 0x9f) || (c == 0xf0 && d < 0x90) ||
	    (c == 0xf4 && d > 0x8f))
		return 0;
	return n;
}

/* A JSON string: quotes and backslashes escaped, control characters as
 * blanks, and a byte that is not UTF-8 (a file name may hold any) as
 * U+FFFD, so that the document stays JSON (until 2026-12 such a name made
 * --json's output unreadable). */
static std::string json_str(const std::string &s)
{
	std::string o = "\"";
	for (size_t i = 0; i < s.size();) {
		const char c = s[i];
		const size_t n = utf8_len(s, i);
		if (n == 0)
			o += "\\ufffd", i++;
		else if (c == '"' || c == '\\')
			o += '\\', o += c, i++;
		else if ((unsigned char)c < 0x20)
			o += ' ', i++;
		else
			o.append(s, i, n), i += n;
	}
	return o + "\"";
}

static void print_json(FILE *f, const Report &r)
{
	fprintf(f, "{\"input\": %s, \"input_vertices\": %zu, \"input_faces\": %zu, \"level\": %d,\n",
	        json_str(r.input).c_str(), r.in_vertices, r.in_faces, r.level);
	fprintf(f, " \"param\": \"%s\", \"map\": \"%s\", \"rotation_optimized\": %s,\n", r.param,
	        r.map, r.rotated ? "true" : "false");
	if (r.rotated)
		fprintf(f, " \"rotation_level\": %d, \"rotations_random\": %d, \"rotations_evaluated\": %d, "
		           "\"estimated_hausdorff_rel_before\": %.6g, \"estimated_hausdorff_rel\": %.6g, "
		           "\"estimated_flipped_before\": %ld, \"estimated_flipped\": %ld,\n",
		        r.rot.level, r.rotations, r.rot.evaluated, r.rot.hausdorff_before / r.diag,
		        r.rot.hausdorff_after / r.diag, r.rot.flipped_before, r.rot.flipped_after);
	fprintf(f, " \"stretch_efficiency\": %.6g, \"stretch_efficiency_sphere\": %.6g, \"flips\": %ld,"
	           " \"sliver_share\": %.6g, \"subdivided\": %d, \"param_faces\": %zu,\n",
	        r.ps.efficiency, r.ps.efficiency_sphere, r.ps.flips, r.ps.sliver_share, r.ps.subdivided,
	        r.ps.faces);
	fprintf(f, " \"remesh_stretch_efficiency\": %.6g, \"area_ratio\": %.6g, \"degenerate\": %ld,\n",
	        r.q.efficiency, r.q.area_ratio, r.q.degenerate);
	fprintf(f, " \"hausdorff_rel\": %.6g, \"rms_rel\": %.6g, \"flipped\": %ld, \"selfintersect\": %ld,\n",
	        r.q.hausdorff, r.q.rms, r.q.flipped, r.q.selfintersect);
	fprintf(f, " \"input_selfintersect\": %ld,", r.input_selfintersect);
	fprintf(f, " \"diagonal\": %.9g, \"closed_manifold\": %s, \"euler\": %d,\n", r.q.diag,
	        r.q.closed_manifold ? "true" : "false", r.q.euler);
	fprintf(f, " \"seconds\": {\"load\": %.3f, \"validate\": %.3f, \"parameterize\": %.3f, "
	           "\"rotation\": %.3f, \"resample\": %.3f, \"quality\": %.3f},\n",
	        r.t_load, r.t_validate, r.t_param, r.t_rotation, r.t_resample, r.t_quality);
	fprintf(f, " \"notes\": [");
	for (size_t i = 0; i < r.notes.size(); i++)
		fprintf(f, "%s%s", i ? ", " : "", json_str(r.notes[i]).c_str());
	fprintf(f, "]}\n");
}

/* "1 fold-over", "2 fold-overs" */
static std::string count(long n, const char *one, const char *many)
{
	return std::to_string(n) + " " + (n == 1 ? one : many);
}

static void print_report(FILE *f, const Report &r)
{
	size_t nv = ndo_vertex_count(r.level), nt = ndo_triangle_count(r.level);
	fprintf(f, "%s: %zu vertices, %zu faces → level %d grid (%zu vertices, %zu triangles)\n",
	        r.input.c_str(), r.in_vertices, r.in_faces, r.level, nv, nt);
	fprintf(f, "  input             %s\n",
	        count(r.input_selfintersect, "self-intersecting face pair",
	              "self-intersecting face pairs").c_str());
	fprintf(f, "  parameterization  %s: L2 stretch efficiency %.3f (on spherical triangles %.3f),\n"
	           "                    %s, %.2f%% of the surface mapped\n"
	           "                    with anisotropy over 10\n",
	        r.param, r.ps.efficiency, r.ps.efficiency_sphere,
	        count(r.ps.flips, "flipped spherical triangle", "flipped spherical triangles").c_str(),
	        100 * r.ps.sliver_share);
	if (r.ps.subdivided)
		fprintf(f, "                    (of the input split 1-to-4 %d× first: %zu faces)\n",
		        r.ps.subdivided, r.ps.faces);
	if (r.rotated)
		fprintf(f, "  domain            %s map, rotation optimized: %d random rotations screened,\n"
		           "                    %d candidates evaluated in all; estimated at\n"
		           "                    level %d, Hausdorff %.4f%% → %.4f%%, fold-overs %ld → %ld\n",
		        r.map, r.rotations, r.rot.evaluated, r.rot.level, 100 * r.rot.hausdorff_before / r.diag,
		        100 * r.rot.hausdorff_after / r.diag, r.rot.flipped_before, r.rot.flipped_after);
	else
		fprintf(f, "  domain            %s map, rotation not optimized\n", r.map);
	fprintf(f, "  distance          Hausdorff %.4f%%, RMS %.5f%% of the bounding-box diagonal %.6g\n",
	        100 * r.q.hausdorff, 100 * r.q.rms, r.q.diag);
	fprintf(f, "  remesh            %s, %s, %ld degenerate\n",
	        count(r.q.flipped, "fold-over", "fold-overs").c_str(),
	        count(r.q.selfintersect, "self-intersecting face pair",
	              "self-intersecting face pairs").c_str(), r.q.degenerate);
	fprintf(f, "                    triangle area min/max %.4f, L2 stretch efficiency %.3f\n",
	        r.q.area_ratio, r.q.efficiency);
	fprintf(f, "                    %s, Euler characteristic %d\n",
	        r.q.closed_manifold ? "closed manifold" : "NOT a closed manifold", r.q.euler);
	fprintf(f, "  seconds           load %.2f, validate %.2f, parameterize %.2f, rotation %.2f, "
	           "resample %.2f, quality %.2f\n",
	        r.t_load, r.t_validate, r.t_param, r.t_rotation, r.t_resample, r.t_quality);
}

/* ---- main ---------------------------------------------------------- */

struct MeshOptions {
	ParamOptions po;
	Domain dom;
	int rotations = 96;
	bool rotate = true, report = false, json = false, weld = true;
	const char *json_path = nullptr;
};

/* The power of two that brings the mesh's largest extent into [1, 2):
 * the pipeline's tolerances are a unit-sized mesh's, and far from it they
 * failed (hand.off scaled by 1e-100: a NaN in CGAL's Hausdorff distance,
 * SIGFPE; by 1e-200: the diagonal's square underflowed to 0, "-nan%";
 * by 1e40 or 1e60: a grid 2.7-4.6 times as far from the mesh).  Scaling by
 * 2^e is exact for every coordinate that stays a normal double, so the
 * grid scaled back is what a unit-sized copy gives (the pipeline gives
 * the same grid at any power-of-two scale).  Capped so that the largest
 * |coordinate| stays under 2^1000: 0 for a mesh with no extent. */
static int unit_exponent(const Mesh &m)
{
	if (m.p.empty())
		return 0;
	double ext = 0, big = 0;
	for (int k = 0; k < 3; k++) {
		double lo = m.p[0][k], hi = lo;
		for (const Vec3 &p : m.p)
			lo = std::min(lo, p[k]), hi = std::max(hi, p[k]);
		ext = std::max(ext, hi - lo);
		big = std::max(big, std::max(std::fabs(lo), std::fabs(hi)));
	}
	if (!(ext > 0) || !std::isfinite(ext) || !std::isfinite(big))
		return 0;
	int e = -std::ilogb(ext);
	if (big > 0)
		e = std::min(e, 1000 - std::ilogb(big));
	return e;
}

static void scale_mesh(Mesh &m, int e)
{
	for (Vec3 &p : m.p)
		for (int k = 0; k < 3; k++)
			p[k] = std::ldexp(p[k], e);
}

static ndo_grid *remesh_file(const char *path, int level, const MeshOptions &o, Report &r)
{
	r.input = path && strcmp(path, "-") != 0 ? path : "stdin";
	r.level = level;
	double t = now_seconds();
	Mesh m;
	std::string why;
	if (!load(path ? path : "-", m, o.weld, r.notes, why))
		ndo_die("%s: %s", r.input.c_str(), why.c_str());
	double t1 = now_seconds();
	r.t_load = t1 - t;
	if (!validate(m, o.weld, r.notes, why, &r.input_selfintersect))
		ndo_die("%s: %s", r.input.c_str(), why.c_str());
	for (const std::string &n : r.notes)
		ndo_warn("%s: %s", r.input.c_str(), n.c_str());
	r.in_vertices = m.p.size(), r.in_faces = m.f.size();
	const int e = unit_exponent(m);
	if (e)
		scale_mesh(m, e);
	double t2 = now_seconds();
	r.t_validate = t2 - t1;
	std::vector<Vec3> s;
	ParamOptions po = o.po;
	po.level = level;
	Mesh mr;
	int sub = o.po.method == ParamMethod::Hierarchical ? param_mesh(m, level, mr) : 0;
	const Mesh &mp = sub ? mr : m;
	po.fade = sub == 0;
	parameterize(mp, po, s, r.ps);
	r.ps.subdivided = sub, r.ps.faces = mp.f.size();
	if (r.ps.placement_failures)
		r.notes.push_back(std::to_string(r.ps.placement_failures) +
		                  " vertex splits found no kernel point (flips possible)");
	double t3 = now_seconds();
	r.t_param = t3 - t2;
	SphereLocator *loc = locator_create(mp, s);
	double R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
	r.diag = bbox_diagonal(m);
	if (o.rotate) {
		optimize_rotation(loc, o.dom, level, o.rotations, R, r.rot);
		r.rotations = o.rotations;
		progress_done();
		r.rotated = true;
	}
	double t4 = now_seconds();
	r.t_rotation = t4 - t3;
	ndo_grid *g;
	if (ndo_grid_create(level, &g) != NDO_OK)
		ndo_die("%s", ndo_errdetail());
	resample(loc, o.dom, R, g);
	progress_done();
	locator_destroy(loc);
	double t5 = now_seconds();
	r.t_resample = t5 - t4;
	if (o.report || o.json) {
		measure_quality(m, g, true, true, r.q);
		r.q.diag = std::ldexp(r.q.diag, -e); /* the input's own units (the rest are shares) */
		r.t_quality = now_seconds() - t5;
	}
	if (e) {
		double *pos = ndo_grid_f64(g, NDO_CH_POSITION, 3);
		for (size_t k = 0; pos && k < 3 * g->count; k++)
			pos[k] = std::ldexp(pos[k], -e);
	}
	return g;
}

/* The sanitizer build's leak checker: assimp 5.2's PLY loader leaks its
 * face lists when a file ends early (the importer frees its scene, not
 * those).  Not remesh's to fix; suppressed so that the tests see remesh's
 * own leaks.  (Only the sanitizer runtime calls this.) */
extern "C" const char *__lsan_default_suppressions(void);
extern "C" const char *__lsan_default_suppressions(void)
{
	return "leak:libassimp.so\n";
}
extern "C" const char *__lsan_default_options(void);
extern "C" const char *__lsan_default_options(void)
{
	return "print_suppressions=0";
}

/* OpenMP threads that wait for work spin by default (libgomp: some 10^5
 * iterations at every barrier before they sleep).  On a shared machine the
 * spinning takes the CPU the working thread needs: bunny00 to level 7 ran
 * in 31.6 s with 2 threads against 22.5 s with one.  libgomp reads
 * OMP_WAIT_POLICY once, while the program loads, so remesh sets it to
 * passive and starts itself again (once; a user's own setting is kept). */
static void passive_wait(char **argv)
{
	if (getenv("OMP_WAIT_POLICY"))
		return;
	if (setenv("OMP_WAIT_POLICY", "passive", 1) != 0)
		return;
	execv("/proc/self/exe", argv);
	/* exec failed (no /proc): run on with the default policy */
}

int main(int argc, char **argv)
{
	passive_wait(argv);
	ndo_cli_init(argc, argv);
	ndo_shape_params sp;
	ndo_shape_defaults(&sp);
	const char *shape = NULL, *out = NULL;
	int level = 5;
	MeshOptions mo;
	const char *map_name = nullptr;
	enum { OPT_MAP = 256, OPT_AXES, OPT_AMP, OPT_FREQ, OPT_VERSION, OPT_PARAM, OPT_SWEEPS,
	       OPT_SPRING_STEPS, OPT_NO_RELAX, OPT_NO_ROT, OPT_REPORT, OPT_JSON, OPT_BLEND,
	       OPT_CONFORMAL, OPT_IMPORTANCE, OPT_ROTATIONS, OPT_GUARD, OPT_NO_WELD };
	static const struct option opts[] = {
		{"shape", required_argument, 0, 's'},
		{"level", required_argument, 0, 'l'},
		{"output", required_argument, 0, 'o'},
		{"map", required_argument, 0, OPT_MAP},
		{"axes", required_argument, 0, OPT_AXES},
		{"amplitude", required_argument, 0, OPT_AMP},
		{"frequency", required_argument, 0, OPT_FREQ},
		{"param", required_argument, 0, OPT_PARAM},
		{"sweeps", required_argument, 0, OPT_SWEEPS},
		{"spring-steps", required_argument, 0, OPT_SPRING_STEPS},
		{"no-relax", no_argument, 0, OPT_NO_RELAX},
		{"no-rotation", no_argument, 0, OPT_NO_ROT},
		{"rotations", required_argument, 0, OPT_ROTATIONS},
		{"blend", required_argument, 0, OPT_BLEND},
		{"conformal", required_argument, 0, OPT_CONFORMAL},
		{"importance", required_argument, 0, OPT_IMPORTANCE},
		{"guard", required_argument, 0, OPT_GUARD},
		{"report", no_argument, 0, OPT_REPORT},
		{"no-weld", no_argument, 0, OPT_NO_WELD},
		{"json", optional_argument, 0, OPT_JSON},
		{"help", no_argument, 0, 'h'},
		{"version", no_argument, 0, OPT_VERSION},
		{0, 0, 0, 0}};
	int c;
	while ((c = getopt_long(argc, argv, ":s:l:o:h", opts, NULL)) != -1) {
		switch (c) {
		case 's': shape = optarg; break;
		case 'l': level = ndo_opt_level("--level", optarg); break;
		case 'o': out = optarg; break;
		case OPT_MAP:
			map_name = optarg;
			if (strcmp(optarg, "equal-area") == 0)
				sp.map = NDO_MAP_EQUAL_AREA, mo.dom.map = DomainMap::EqualArea;
			else if (strcmp(optarg, "gnomonic") == 0)
				sp.map = NDO_MAP_GNOMONIC, mo.dom.map = DomainMap::Gnomonic;
			else if (strcmp(optarg, "blend") == 0)
				mo.dom.map = DomainMap::Blend;
			else if (strcmp(optarg, "spring") == 0)
				mo.dom.map = DomainMap::Spring;
			else
				ndo_usage_error("--map: '%s' is not equal-area, gnomonic, blend or spring", optarg);
			break;
		case OPT_BLEND: mo.dom.blend = ndo_opt_double("--blend", optarg, 0, 1); break;
		case OPT_CONFORMAL: mo.po.conformal = ndo_opt_double("--conformal", optarg, 0, 10); break;
		case OPT_IMPORTANCE: mo.po.importance = ndo_opt_double("--importance", optarg, 0, 10); break;
		case OPT_GUARD:
			mo.po.guard = ndo_opt_double("--guard", optarg, 0, 1000);
			if (mo.po.guard > 0 && mo.po.guard < 1)
				ndo_usage_error("--guard: %s is below 1 (Γ/γ ≥ 1); 0 turns the guard off", optarg);
			break;
		case OPT_ROTATIONS: mo.rotations = (int)ndo_opt_long("--rotations", optarg, 0, 100000); break;
		case OPT_AXES: ndo_opt_doubles("--axes", optarg, 3, sp.axes, 1e-6, 1e6); break;
		case OPT_AMP: sp.amplitude = ndo_opt_double("--amplitude", optarg, -0.9, 0.9); break;
		case OPT_FREQ: sp.frequency = ndo_opt_double("--frequency", optarg, 0, 1000); break;
		case OPT_PARAM:
			if (strcmp(optarg, "hierarchical") == 0)
				mo.po.method = ParamMethod::Hierarchical;
			else if (strcmp(optarg, "spring") == 0)
				mo.po.method = ParamMethod::Spring;
			else
				ndo_usage_error("--param: '%s' is not hierarchical or spring", optarg);
			break;
		case OPT_SWEEPS: mo.po.sweeps = (int)ndo_opt_long("--sweeps", optarg, 0, 100); break;
		case OPT_SPRING_STEPS:
			mo.po.spring_steps = (int)ndo_opt_long("--spring-steps", optarg, 1, 100000);
			break;
		case OPT_NO_RELAX: mo.po.relax = 0; break;
		case OPT_NO_ROT: mo.rotate = false; break;
		case OPT_REPORT: mo.report = true; break;
		case OPT_NO_WELD: mo.weld = false; break;
		case OPT_JSON: mo.json = true, mo.json_path = optarg; break;
		case 'h': usage();
		case OPT_VERSION: ndo_print_version();
		default: ndo_bad_option(c);
		}
	}
	const char *input = NULL;
	if (optind < argc)
		input = argv[optind++];
	if (optind < argc)
		ndo_usage_error("'%s': one input mesh at a time", argv[optind]);
	if (shape && input)
		ndo_usage_error("'%s': give an input mesh or --shape, not both", input);
	if (shape && (mo.dom.map == DomainMap::Spring || mo.dom.map == DomainMap::Blend) && map_name)
		ndo_usage_error("--map: %s is for meshes; shapes use equal-area or gnomonic", map_name);
	if (shape && (mo.report || mo.json))
		ndo_usage_error("--%s measures the grid against an input mesh: not with --shape",
		                mo.report ? "report" : "json");
	ndo_cli_check_output(out);
	bool to_stdout = !out || strcmp(out, "-") == 0;
	if (mo.json && mo.json_path && strcmp(mo.json_path, "-") == 0 && to_stdout)
		ndo_usage_error("--json=-: standard output already carries the grid; use -o");
	if (mo.json && mo.json_path) { /* before the work, as the grid's -o */
		if (!*mo.json_path)
			ndo_usage_error("--json=: an empty file name");
		ndo_cli_check_writable("--json", mo.json_path);
	}
	ndo_grid *g;
	if (shape) {
		if (ndo_shape_make(shape, level, &sp, &g) != NDO_OK)
			ndo_usage_error("--shape: %s", ndo_errdetail());
	} else {
		if (!input && isatty(STDIN_FILENO))
			ndo_usage_error("no input mesh and no --shape (standard input is a terminal)");
		Report r;
		r.param = mo.po.method == ParamMethod::Spring ? "spring" : "hierarchical";
		r.map = map_name ? map_name : "blend";
		try {
			g = remesh_file(input, level, mo, r);
		} catch (const std::bad_alloc &) {
			ndo_die("%s: out of memory", r.input.c_str());
		} catch (const std::exception &e) {
			ndo_die("%s: %s", r.input.c_str(), e.what());
		}
		if (mo.report)
			print_report(stderr, r);
		if (mo.json) {
			if (!mo.json_path) {
				print_json(stderr, r);
			} else if (strcmp(mo.json_path, "-") == 0) {
				print_json(stdout, r);
			} else {
				/* a temporary file renamed over FILE: never half a document */
				ndo_outfile f;
				if (ndo_out_open(mo.json_path, &f) != NDO_OK)
					ndo_die("--json: %s", ndo_errdetail());
				print_json(f.f, r);
				if (ndo_out_commit(&f) != NDO_OK)
					ndo_die("--json: %s", ndo_errdetail());
			}
		}
	}
	ndo_cli_save(out, g);
	ndo_grid_destroy(g);
	ndo_close_stdout();
	return NDO_EXIT_OK;
}
