/* test_scene — scene files and settings (lib/sim/scene.c): every value is
 * validated with a message naming the setting, files report their line,
 * force and pin selections resolve on the grid. */
#include "check.h"
#include "ndo/ndo.h"

#include <stdlib.h>
#include <unistd.h>

static void settings_are_parsed_and_checked(void)
{
	ndo_scene sc;
	ndo_scene_init(&sc);
	CHECK(sc.sim.material.damping == 0.1 && sc.dt_auto && sc.steps == 100, "defaults");
	CHECK(ndo_scene_set(&sc, "stiffness", "6.25") == 0 && sc.sim.material.stiffness == 6.25,
	      "stiffness");
	CHECK(ndo_scene_set(&sc, "integrator", "rkf45") == 0 && sc.sim.method == NDO_RKF45,
	      "integrator");
	CHECK(ndo_scene_set(&sc, "dt", "0.01") == 0 && !sc.dt_auto && sc.dt == 0.01, "dt");
	CHECK(ndo_scene_set(&sc, "dt", "auto") == 0 && sc.dt_auto, "dt auto");
	CHECK(ndo_scene_set(&sc, "time", "2.5") == 0 && sc.duration == 2.5, "time");
	CHECK(ndo_scene_set(&sc, "steps", "7") == 0 && sc.steps == 7 && sc.duration == 0,
	      "steps replaces time");
	CHECK(ndo_scene_set(&sc, "pins", "penalty") == 0 && sc.sim.pin_mode == NDO_PINS_PENALTY,
	      "pins");
	/* Bad values: the message names the setting and the range. */
	struct {
		const char *key, *value, *want;
	} bad[] = {{"stiffness", "0", "stiffness: 0 is outside (0, 1e+12]"},
	           {"stiffness", "abc", "stiffness: 'abc' is not a finite number"},
	           {"density", "-1", "density"},
	           {"damping", "nan", "damping: 'nan' is not a finite number"},
	           {"integrator", "verlet", "integrator: 'verlet' is not euler"},
	           {"dt", "-0.1", "dt"},
	           {"steps", "1.5", "steps: '1.5' is not an integer"},
	           {"tol", "1", "tol: 1 is outside"},
	           {"pins", "glue", "pins: 'glue' is not project or penalty"},
	           {"frames", "out.tgrid", "exactly one %d-style"},
	           {"frames", "f%d_%d.tgrid", "exactly one"},
	           {"frames", "f%s.tgrid", "exactly one"},
	           {"force", "spring faces=1", "is not face, point or pressure"},
	           {"force", "face", "give faces=T,... or at=X,Y,Z"},
	           {"force", "face faces=1,x", "is not a list of face numbers"},
	           {"force", "point nodes=1,2", "is not a list of nodes I:J"},
	           {"force", "face faces=1 colour=red", "unknown key 'colour'"},
	           {"force", "face faces=1 direction=0,0,0", "must not be zero"},
	           {"force", "pressure faces=3", "acts on the whole surface"},
	           {"force", "face radius=2", "radius= goes after at="},
	           {"pin", "", "give nodes="},
	           {"gravity", "9.81", "unknown setting 'gravity'"}};
	for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
		int rc = ndo_scene_set(&sc, bad[k].key, bad[k].value);
		CHECK(rc != 0 && strstr(ndo_errdetail(), bad[k].want),
		      "%s '%s': status %d, detail '%s', want '%s'", bad[k].key, bad[k].value, rc,
		      ndo_errdetail(), bad[k].want);
	}
	CHECK(sc.nforces == 0 && sc.npins == 0, "failed settings leave nothing behind");
	ndo_scene_free(&sc);
}

static void forces_and_pins_parse(void)
{
	ndo_scene_force f;
	CHECK(ndo_scene_parse_force("face at=0,0,1 radius=0.25 amplitude=2.4 frequency=1 phase=90",
	                            &f) == 0, "face force: %s", ndo_errdetail());
	CHECK(f.f.kind == NDO_FORCE_FACE && f.sel.kind == NDO_SEL_AT && f.sel.radius == 0.25 &&
	      f.f.amplitude == 2.4 && f.f.frequency == 1 && f.f.normal, "face force fields");
	CHECK_NEAR(f.f.phase, M_PI / 2, 1e-15, "phase in degrees");
	free(f.sel.ids);
	CHECK(ndo_scene_parse_force("point nodes=3:4,5:6 direction=0,0,-2 amplitude=1", &f) == 0,
	      "point force: %s", ndo_errdetail());
	CHECK(f.sel.kind == NDO_SEL_NODES && f.sel.count == 2 && f.sel.ids[2] == 5 &&
	      f.sel.ids[3] == 6 && !f.f.normal && f.f.dir[2] == -2, "point force fields");
	free(f.sel.ids);
	ndo_selection s;
	CHECK(ndo_scene_parse_pin("faces=1,2,3", &s) == 0 && s.kind == NDO_SEL_FACES && s.count == 3,
	      "pin faces");
	free(s.ids);
}

static void scene_file_reports_its_line(void)
{
	char path[] = "/tmp/ndo-scene-XXXXXX";
	int fd = mkstemp(path);
	FILE *f = fdopen(fd, "w");
	fputs("# thesis figure 5.4\n"
	      "stiffness 6.25   # N/m\n"
	      "\n"
	      "   damping 0.1\n"
	      "force face faces=10,11 amplitude=1.2 frequency=0.5\n"
	      "integrator trapezoid\n",
	      f);
	fclose(f);
	ndo_scene sc;
	ndo_scene_init(&sc);
	CHECK(ndo_scene_load(&sc, path) == 0, "load: %s", ndo_errdetail());
	CHECK(sc.sim.material.stiffness == 6.25 && sc.sim.method == NDO_TRAPEZOID && sc.nforces == 1 &&
	      sc.forces[0].sel.count == 2, "scene values");
	f = fopen(path, "a");
	fputs("stiffness -3\n", f);
	fclose(f);
	CHECK(ndo_scene_load(&sc, path) != 0, "a bad line fails");
	char want[128];
	snprintf(want, sizeof want, "%s:7: stiffness: -3 is outside", path);
	CHECK(strstr(ndo_errdetail(), want), "detail '%s', want '%s'", ndo_errdetail(), want);
	ndo_scene_free(&sc);
	unlink(path);
	ndo_scene_init(&sc);
	CHECK(ndo_scene_load(&sc, "/nonexistent/scene") == NDO_EIO &&
	      strstr(ndo_errdetail(), "/nonexistent/scene"), "missing file: %s", ndo_errdetail());
	ndo_scene_free(&sc);
}

static void selections_resolve_on_the_grid(void)
{
	ndo_grid *g;
	ndo_shape_make("sphere", 3, NULL, &g);
	ndo_scene sc;
	ndo_scene_init(&sc);
	ndo_scene_set(&sc, "force", "face at=0,0,1 radius=0.3");
	ndo_scene_set(&sc, "force", "point at=1,0,0");
	ndo_scene_set(&sc, "force", "pressure amplitude=5");
	ndo_scene_set(&sc, "pin", "nodes=16:3");   /* a duplicate of 0:3 */
	ndo_scene_set(&sc, "pin", "faces=0");
	uint8_t *pin = calloc(g->count, 1);
	ndo_force *fs;
	CHECK(ndo_scene_resolve(&sc, 3, g->ch[0].data, &fs, pin) == 0, "resolve: %s",
	      ndo_errdetail());
	const double *x = g->ch[0].data;
	CHECK(fs[0].count >= 2, "faces near the pole: %zu", fs[0].count);
	for (size_t k = 0; k < fs[0].count; k++) {
		int32_t t = fs[0].items[k];
		int i = (t / 2) % 16, j = (t / 2) / 16;
		const double *a = x + 3 * ndo_node(g->w, i, j);
		CHECK(a[2] > 0.6, "face %d is not near (0,0,1): z = %g", t, a[2]);
	}
	CHECK(fs[1].count == 1, "point force: the nearest node");
	const double *q = x + 3 * (size_t)fs[1].items[0];
	CHECK(q[0] > 0.95, "nearest node to (1,0,0) is at x = %g", q[0]);
	CHECK(pin[ndo_node(g->w, 0, 3)] && !pin[ndo_node(g->w, 16, 3)], "a pinned duplicate pins "
	      "its canonical node");
	CHECK(pin[0] && pin[1] && pin[g->w], "face 0 pins its three vertices");
	ndo_scene_forces_free(fs, sc.nforces);
	ndo_scene_free(&sc);
	ndo_scene_init(&sc);
	ndo_scene_set(&sc, "force", "face faces=99999");
	CHECK(ndo_scene_resolve(&sc, 3, g->ch[0].data, &fs, pin) == NDO_ERANGE &&
	      strstr(ndo_errdetail(), "face 99999 is outside 0..255"), "bad face: %s",
	      ndo_errdetail());
	ndo_scene_free(&sc);
	ndo_scene_init(&sc);
	ndo_scene_set(&sc, "pin", "nodes=17:0");
	CHECK(ndo_scene_resolve(&sc, 3, g->ch[0].data, &fs, pin) == NDO_ERANGE &&
	      strstr(ndo_errdetail(), "node 17:0 is outside"), "bad node: %s", ndo_errdetail());
	ndo_scene_free(&sc);
	free(pin);
	ndo_grid_destroy(g);
}

int main(void)
{
	ck_program = "test_scene";
	RUN(settings_are_parsed_and_checked);
	RUN(forces_and_pins_parse);
	RUN(scene_file_reports_its_line);
	RUN(selections_resolve_on_the_grid);
	return ck_failed_cases != 0;
}
