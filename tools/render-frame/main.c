/* render-frame — draw grids into PNG images off-screen.  The work is in
 * this directory: source (grids in), scene (grid → frame), camera,
 * renderer (OpenGL through context.c), colorbar, png (out). */
#include "colorbar.h"
#include "context.h"
#include "options.h"
#include "png.h"
#include "renderer.h"
#include "scene.h"
#include "shaders.h"
#include "source.h"
#include "writer.h"

#include "ndo/ndo.h"

#include <limits.h>
#include <malloc.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/resource.h>
#include <time.h>

static double now(void)
{
	struct timespec t;
	clock_gettime(CLOCK_MONOTONIC, &t);
	return t.tv_sec + 1e-9 * t.tv_nsec;
}

/* llvmpipe allocates and frees its bins, several MB, every frame; glibc's
 * default is to hand such memory back to the kernel (trim the heap, unmap
 * large blocks) and fault it in again on the next frame, which cost 40 %
 * of a level-7 frame here (docs/bench/render.md).  Keep it instead. */
static void keep_freed_memory(void)
{
#ifdef __GLIBC__
	mallopt(M_MMAP_THRESHOLD, 32 << 20);
	mallopt(M_TRIM_THRESHOLD, 512 << 20);
	mallopt(M_TOP_PAD, 64 << 20);
#endif
}

/* Under LeakSanitizer (make test): Mesa keeps a few hundred bytes per
 * context until the process ends (OSMesa's buffer list, the DRI driver's
 * screen), which are not render-frame's to free. */
const char *__lsan_default_suppressions(void);
const char *__lsan_default_suppressions(void)
{
	return "leak:libOSMesa.so\nleak:libEGL_mesa.so\nleak:swrast_dri.so\nleak:libgallium\n";
}
/* ... quietly: a failing run's one line of error stays one line. */
const char *__lsan_default_options(void);
const char *__lsan_default_options(void)
{
	return "print_suppressions=0";
}

/* CPU seconds used by the whole process (all threads) so far. */
static double cpu_seconds(void)
{
	struct rusage u;
	getrusage(RUSAGE_SELF, &u);
	return u.ru_utime.tv_sec + u.ru_stime.tv_sec +
	       1e-6 * (double)(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

static int by_value(const void *a, const void *b)
{
	double x = *(const double *)a, y = *(const double *)b;
	return (x > y) - (x < y);
}

static double median(double *v, long n)
{
	qsort(v, (size_t)n, sizeof *v, by_value);
	return n ? (n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2])) : 0;
}

/* What stays from the first frame to the last. */
typedef struct state {
	rf_context ctx;
	rf_renderer *renderer;
	rf_writer *writer;
	rf_font *font;
	rf_scene scene;
	char shader_dir[PATH_MAX];
	rf_view view;
	double t_start, t_last;  /* the program's start, the last frame's end */
	double cpu_first;        /* CPU time at the end of the first frame */
	double *times;           /* each frame's time, end to end */
	long frames, cap;
} state;

/* The first grid decides the colouring (auto), so the context and the
 * shaders are made when it arrives. */
static void start(state *st, rf_options *o, const ndo_grid *g)
{
	if (o->coloring.mode < 0)
		o->coloring.mode = ndo_grid_find(g, NDO_CH_OWNER) ? RF_COLOR_OWNER : RF_COLOR_SOLID;
	o->style.color_mode = o->coloring.mode;
	double t0 = now();
	if (rf_context_open(o->backend, &st->ctx) != NDO_OK)
		ndo_die("%s", ndo_errdetail());
	double t1 = now();
	if (rf_renderer_create(&o->style, st->shader_dir, &st->renderer) != NDO_OK)
		ndo_die("%s", ndo_errdetail());
	double t2 = now();
	if (rf_writer_create(o->style.width, o->style.height, o->compression, &st->writer) != NDO_OK)
		ndo_die("%s", ndo_errdetail());
	if (o->coloring.mode == RF_COLOR_SCALAR && o->colorbar &&
	    rf_font_open(o->font, &st->font) != NDO_OK)
		ndo_die("%s", ndo_errdetail());
	if (o->verbose)
		fprintf(stderr, "%s: %s back end, %s, OpenGL %s; context %.1f ms, shaders (%s) %.1f ms\n",
		        ndo_progname, st->ctx.backend->name, st->ctx.renderer, st->ctx.version,
		        1e3 * (t1 - t0), st->shader_dir, 1e3 * (t2 - t1));
}

/* Draw grid `g` (from `where`) and hand its picture to the PNG writer. */
static void draw_one(state *st, rf_options *o, ndo_grid *g, const char *where, long number)
{
	double t0 = now();
	if (!st->renderer)
		start(st, o, g);
	rf_scene *scene = &st->scene;
	int refit = st->frames == 0 || o->refit;
	if (rf_scene_prepare(scene, g, o->subdivide, &o->coloring, refit) != NDO_OK)
		ndo_die("%s: %s", where, ndo_errdetail());
	if (refit) {
		/* the camera's points and distance, given in world units, in the
		 * uploaded coordinates */
		rf_camera cam = o->camera;
		if (rf_camera_for_grid(&cam, g->history) && o->verbose && st->frames == 0)
			fprintf(stderr, "%s: %s was remeshed from a mesh file: up +y, seen from its "
			        "front (+z) and the left (--up, --azimuth to change)\n", ndo_progname, where);
		for (int k = 0; k < 3; k++) {
			cam.eye[k] = (cam.eye[k] - scene->origin[k]) / scene->unit;
			cam.center[k] = (cam.center[k] - scene->origin[k]) / scene->unit;
		}
		cam.distance /= scene->unit;
		rf_camera_view(&cam, scene->center, scene->radius,
		               (double)o->style.width / o->style.height, &st->view);
	}
	if (o->have_range)
		scene->frame.range[0] = (float)o->range[0], scene->frame.range[1] = (float)o->range[1];
	double t1 = now();
	uint8_t *pixels = rf_writer_buffer(st->writer);
	double t2 = now();
	if (rf_renderer_draw(st->renderer, &scene->frame, &st->view, pixels) != NDO_OK)
		ndo_die("%s: %s", where, ndo_errdetail());
	if (st->font) {
		char name[64];
		rf_coloring_name(&o->coloring, name, sizeof name);
		rf_colorbar_draw(pixels, o->style.width, o->style.height, o->style.colormap,
		                 scene->frame.range[0], scene->frame.range[1], name,
		                 o->style.background, st->font);
	}
	char out[PATH_MAX];
	rf_output_name(o, number >= 0 ? number : o->start_number + st->frames, out, sizeof out);
	/* a numbered sequence goes where its pattern says: make the directory */
	if (o->numbered && ndo_mkdir_parents(out) != NDO_OK)
		ndo_die("%s: %s", out, ndo_errdetail());
	if (ndo_grid_add_history(g, ndo_cli_argc(), ndo_cli_argv()) != NDO_OK ||
	    rf_writer_submit(st->writer, out, g->history) != NDO_OK)
		ndo_die("%s", ndo_errdetail());
	double t3 = now();

	if (st->frames == st->cap) {
		st->cap = st->cap ? 2 * st->cap : 64;
		double *t = realloc(st->times, (size_t)st->cap * sizeof *t);
		if (!t)
			ndo_die("out of memory");
		st->times = t;
	}
	st->times[st->frames] = t3 - st->t_last;
	st->t_last = t3;
	if (st->frames == 0)
		st->cpu_first = cpu_seconds();
	if (o->verbose)
		fprintf(stderr, "%s: frame %ld (%s): level %d, %zu triangles: prepare %.1f ms, "
		        "wait for a buffer %.1f ms, draw %.1f ms -> %s\n", ndo_progname,
		        o->start_number + st->frames, where, scene->frame.level,
		        ndo_triangle_count(scene->frame.level), 1e3 * (t1 - t0), 1e3 * (t2 - t1),
		        1e3 * (t3 - t2), ndo_is_stdio(out) ? "standard output" : out);
	st->frames++;
}

/* -v: the median time per frame, and the CPU per frame after the first
 * (no start-up, no JIT; all threads): what a frame costs on an otherwise
 * idle machine. */
static void report(state *st)
{
	long n = st->frames;
	fprintf(stderr, "%s: %ld frame%s, median %.2f ms per frame, %.3f s in all", ndo_progname,
	        n, n == 1 ? "" : "s", 1e3 * median(st->times, n), now() - st->t_start);
	if (n > 1)
		fprintf(stderr, ", CPU %.2f ms per frame after the first",
		        1e3 * (cpu_seconds() - st->cpu_first) / (double)(n - 1));
	fputc('\n', stderr);
}

int main(int argc, char **argv)
{
	ndo_cli_init(argc, argv);
	keep_freed_memory();
	rf_options o;
	rf_options_parse(argc, argv, &o);
	state st = {.t_start = now()};
	st.t_last = st.t_start;
	if (rf_shader_dir("surface.vert", st.shader_dir, sizeof st.shader_dir) != NDO_OK)
		ndo_die("%s", ndo_errdetail());
	rf_source *src;
	if ((o.use_lcm ? rf_source_lcm(&o.lcm, &src) : rf_source_files(o.ninputs, o.inputs, &src)) !=
	    NDO_OK)
		ndo_die("%s", ndo_errdetail());
	ndo_grid *g;
	int rc;
	while ((rc = rf_source_next(src, &g)) == NDO_OK) {
		draw_one(&st, &o, g, src->where, src->number);
		ndo_grid_destroy(g);
	}
	if (rc != NDO_EEOF) {
		/* The frames drawn before the bad grid are kept: the writer
		 * commits them before the exit removes uncommitted files. */
		char why[1024];
		snprintf(why, sizeof why, "%s", ndo_errdetail());
		if (st.writer)
			rf_writer_finish(st.writer);
		ndo_die("%s", why);
	}
	if (o.use_lcm) {
		char what[1024];
		rf_source_lcm_report(src, what, sizeof what);
		if (st.frames == 0)
			ndo_die("%s: no complete frame: %s", o.lcm.url ? o.lcm.url : "LCM", what);
		/* always: a frame skipped or a log cut short is never silent */
		fprintf(stderr, "%s: %s: %s\n", ndo_progname, o.lcm.url ? o.lcm.url : "LCM", what);
	}
	if (st.writer && rf_writer_finish(st.writer) != NDO_OK)
		ndo_die("%s", ndo_errdetail());
	if (o.verbose)
		report(&st);
	free(st.times);
	rf_scene_free(&st.scene);
	rf_font_close(st.font);
	rf_writer_destroy(st.writer);
	rf_renderer_destroy(st.renderer);
	rf_context_close(&st.ctx);
	rf_source_destroy(src);
	ndo_close_stdout();
	return NDO_EXIT_OK;
}
