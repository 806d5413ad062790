/* scene.c — scene files and the settings they share with simulate-peer's
 * command line (ndo/scene.h). */
#include "ndo/scene.h"
#include "ndo/status.h"
#include "ndo/topology.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void ndo_scene_init(ndo_scene *sc)
{
	memset(sc, 0, sizeof *sc);
	ndo_sim_defaults(&sc->sim);
	sc->sim.material.damping = 0.1; /* the thesis' b in every experiment */
	sc->dt_auto = 1;
	sc->dt_safety = 0.9;
	sc->steps = 100;
	sc->frame_every = 1;
	sc->log_every = 1;
}

static void selection_free(ndo_selection *s)
{
	free(s->ids);
	memset(s, 0, sizeof *s);
}

void ndo_scene_free(ndo_scene *sc)
{
	free(sc->physics);
	free(sc->rest);
	free(sc->output);
	free(sc->frames);
	free(sc->log);
	for (int k = 0; k < sc->nforces; k++)
		selection_free(&sc->forces[k].sel);
	free(sc->forces);
	for (int k = 0; k < sc->npins; k++)
		selection_free(&sc->pins[k]);
	free(sc->pins);
	memset(sc, 0, sizeof *sc);
}

/* ---- values ------------------------------------------------------------ */

static int number(const char *key, const char *v, double lo, double hi, int lo_open,
                  double *out)
{
	char *end;
	errno = 0;
	double x = v ? strtod(v, &end) : 0;
	if (!v || end == v || *end != '\0' || !isfinite(x))
		return ndo__fail(NDO_EINVAL, "%s: '%s' is not a finite number", key, v ? v : "");
	if ((lo_open ? !(x > lo) : !(x >= lo)) || x > hi)
		return ndo__fail(NDO_ERANGE, "%s: %g is outside %s%g, %g]", key, x,
		                 lo_open ? "(" : "[", lo, hi);
	*out = x;
	return NDO_OK;
}

static int integer(const char *key, const char *v, int64_t lo, int64_t hi, int64_t *out)
{
	char *end;
	errno = 0;
	long long x = v ? strtoll(v, &end, 10) : 0;
	if (!v || end == v || *end != '\0' || errno == ERANGE)
		return ndo__fail(NDO_EINVAL, "%s: '%s' is not an integer", key, v ? v : "");
	if (x < lo || x > hi)
		return ndo__fail(NDO_ERANGE, "%s: %lld is outside %lld..%lld", key, x, (long long)lo,
		                 (long long)hi);
	*out = x;
	return NDO_OK;
}

static int string(const char *key, const char *v, char **out)
{
	if (!v || !*v)
		return ndo__fail(NDO_EINVAL, "%s: needs a file name", key);
	char *c = strdup(v);
	if (!c)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	free(*out);
	*out = c;
	return NDO_OK;
}

/* A comma-separated list of exactly n finite numbers. */
static int vector(const char *key, const char *v, int n, double *out)
{
	const char *p = v;
	for (int k = 0; k < n; k++) {
		char *end;
		out[k] = strtod(p, &end);
		if (end == p || !isfinite(out[k]) || (k + 1 < n ? *end != ',' : *end != '\0'))
			return ndo__fail(NDO_EINVAL, "%s: '%s' is not %d comma-separated numbers", key, v, n);
		p = end + 1;
	}
	return NDO_OK;
}

/* faces=T,T,… or nodes=I:J,I:J,… */
static int id_list(const char *key, const char *v, int pairs, ndo_selection *sel)
{
	size_t cap = 8, n = 0;
	int32_t *ids = malloc(cap * sizeof *ids);
	if (!ids)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	const char *p = v;
	for (;;) {
		for (int k = 0; k < (pairs ? 2 : 1); k++) {
			char *end;
			errno = 0;
			long x = strtol(p, &end, 10);
			char want = pairs && k == 0 ? ':' : 0;
			if (end == p || errno == ERANGE || x < 0 || x > INT32_MAX ||
			    (want ? *end != want : (*end != ',' && *end != '\0'))) {
				free(ids);
				return ndo__fail(NDO_EINVAL, "%s: '%s' is not a list of %s", key, v,
				                 pairs ? "nodes I:J separated by commas"
				                       : "face numbers separated by commas");
			}
			if (n == cap) {
				int32_t *q = realloc(ids, 2 * cap * sizeof *ids);
				if (!q) {
					free(ids);
					return ndo__fail(NDO_ENOMEM, "out of memory");
				}
				ids = q;
				cap *= 2;
			}
			ids[n++] = (int32_t)x;
			p = end + (*end != '\0');
			if (*end == '\0' && (!pairs || k == 1)) {
				selection_free(sel);
				sel->kind = pairs ? NDO_SEL_NODES : NDO_SEL_FACES;
				sel->ids = ids;
				sel->count = pairs ? n / 2 : n;
				return NDO_OK;
			}
		}
	}
}

/* The key=value words of a force or pin specification. */
typedef int (*word_fn)(void *ctx, const char *key, const char *value);

static int words(const char *spec, const char *what, void *ctx, word_fn fn)
{
	char *copy = strdup(spec);
	if (!copy)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	int rc = NDO_OK;
	char *save = NULL;
	for (char *w = strtok_r(copy, " \t", &save); w && rc == NDO_OK;
	     w = strtok_r(NULL, " \t", &save)) {
		char *eq = strchr(w, '=');
		if (!eq) {
			rc = ndo__fail(NDO_EINVAL, "%s: '%s' is not key=value", what, w);
			break;
		}
		*eq = '\0';
		rc = fn(ctx, w, eq + 1);
	}
	free(copy);
	return rc;
}

static int selection_word(ndo_selection *sel, const char *what, const char *k,
                          const char *v, int *used)
{
	*used = 1;
	char key[64];
	snprintf(key, sizeof key, "%s %s", what, k);
	if (strcmp(k, "faces") == 0)
		return id_list(key, v, 0, sel);
	if (strcmp(k, "nodes") == 0)
		return id_list(key, v, 1, sel);
	if (strcmp(k, "at") == 0) {
		double at[3];
		int rc = vector(key, v, 3, at);
		if (rc)
			return rc;
		double r = sel->kind == NDO_SEL_AT ? sel->radius : 0;
		selection_free(sel);
		sel->kind = NDO_SEL_AT;
		memcpy(sel->at, at, sizeof at);
		sel->radius = r;
		return NDO_OK;
	}
	if (strcmp(k, "radius") == 0) {
		double r;
		int rc = number(key, v, 0, 1e12, 0, &r);
		if (rc)
			return rc;
		if (sel->kind != NDO_SEL_AT)
			return ndo__fail(NDO_EINVAL, "%s: radius= goes after at=X,Y,Z", what);
		sel->radius = r;
		return NDO_OK;
	}
	*used = 0;
	return NDO_OK;
}

static int force_word(void *ctx, const char *k, const char *v)
{
	ndo_scene_force *f = ctx;
	int used, rc = selection_word(&f->sel, "force", k, v, &used);
	if (rc || used)
		return rc;
	char key[64];
	snprintf(key, sizeof key, "force %s", k);
	if (strcmp(k, "amplitude") == 0)
		return number(key, v, -1e12, 1e12, 0, &f->f.amplitude);
	if (strcmp(k, "frequency") == 0)
		return number(key, v, 0, 1e9, 0, &f->f.frequency);
	if (strcmp(k, "phase") == 0) {
		double deg;
		if ((rc = number(key, v, -1e6, 1e6, 0, &deg)))
			return rc;
		f->f.phase = deg * M_PI / 180;
		return NDO_OK;
	}
	if (strcmp(k, "direction") == 0) {
		if (strcmp(v, "normal") == 0) {
			f->f.normal = 1;
			return NDO_OK;
		}
		if ((rc = vector(key, v, 3, f->f.dir)))
			return rc;
		if (f->f.dir[0] == 0 && f->f.dir[1] == 0 && f->f.dir[2] == 0)
			return ndo__fail(NDO_ERANGE, "%s: the direction must not be zero", key);
		f->f.normal = 0;
		return NDO_OK;
	}
	return ndo__fail(NDO_EINVAL, "force: unknown key '%s' (faces, nodes, at, radius, "
	                 "amplitude, frequency, phase, direction)", k);
}

int ndo_scene_parse_force(const char *spec, ndo_scene_force *out)
{
	memset(out, 0, sizeof *out);
	out->f.amplitude = 1;
	out->f.normal = 1;
	while (*spec == ' ' || *spec == '\t')
		spec++;
	size_t len = strcspn(spec, " \t");
	if (len == 4 && strncmp(spec, "face", 4) == 0)
		out->f.kind = NDO_FORCE_FACE;
	else if (len == 5 && strncmp(spec, "point", 5) == 0)
		out->f.kind = NDO_FORCE_POINT;
	else if (len == 8 && strncmp(spec, "pressure", 8) == 0)
		out->f.kind = NDO_FORCE_PRESSURE;
	else
		return ndo__fail(NDO_EINVAL, "force: '%.*s' is not face, point or pressure", (int)len,
		                 spec);
	int rc = words(spec + len, "force", out, force_word);
	if (rc == NDO_OK) {
		int k = out->f.kind, s = out->sel.kind;
		if (k == NDO_FORCE_PRESSURE && s != NDO_SEL_NONE)
			rc = ndo__fail(NDO_EINVAL, "force pressure: acts on the whole surface; "
			               "faces=, nodes= and at= do not apply");
		else if (k == NDO_FORCE_FACE && s != NDO_SEL_FACES && s != NDO_SEL_AT)
			rc = ndo__fail(NDO_EINVAL, "force face: give faces=T,... or at=X,Y,Z");
		else if (k == NDO_FORCE_POINT && s != NDO_SEL_NODES && s != NDO_SEL_AT)
			rc = ndo__fail(NDO_EINVAL, "force point: give nodes=I:J,... or at=X,Y,Z");
	}
	if (rc)
		selection_free(&out->sel);
	return rc;
}

static int pin_word(void *ctx, const char *k, const char *v)
{
	int used, rc = selection_word(ctx, "pin", k, v, &used);
	if (rc || used)
		return rc;
	return ndo__fail(NDO_EINVAL, "pin: unknown key '%s' (nodes, faces, at, radius)", k);
}

int ndo_scene_parse_pin(const char *spec, ndo_selection *out)
{
	memset(out, 0, sizeof *out);
	int rc = words(spec, "pin", out, pin_word);
	if (rc == NDO_OK && out->kind == NDO_SEL_NONE)
		rc = ndo__fail(NDO_EINVAL, "pin: give nodes=I:J,..., faces=T,... or at=X,Y,Z");
	if (rc)
		selection_free(out);
	return rc;
}

/* ---- settings ------------------------------------------------------------ */

const char *const ndo_scene_keys[] = {
	"stiffness", "density", "damping", "mass-damping", "integrator", "dt", "dt-safety",
	"steps", "time", "tol", "restiffen", "pins", "penalty", "pin", "force", "rest",
	"output", "frames", "frame-every", "log", "log-every", "perturb", "seed",
	"energy-bound", "solver", NULL};

static int scene_set(ndo_scene *sc, const char *key, const char *v)
{
	ndo_material *m = &sc->sim.material;
	int rc;
	int64_t n;
	if (!v)
		return ndo__fail(NDO_EINVAL, "%s: needs a value", key);
	if (strcmp(key, "stiffness") == 0)
		return number(key, v, 0, 1e12, 1, &m->stiffness);
	if (strcmp(key, "density") == 0)
		return number(key, v, 0, 1e12, 1, &m->density);
	if (strcmp(key, "damping") == 0)
		return number(key, v, 0, 1e12, 0, &m->damping);
	if (strcmp(key, "mass-damping") == 0)
		return number(key, v, 0, 1e12, 0, &m->mass_damping);
	if (strcmp(key, "integrator") == 0) {
		if (ndo_method_parse(v, &sc->sim.method))
			return ndo__fail(NDO_EINVAL, "integrator: '%s' is not euler, symplectic-euler, "
			                 "midpoint, rk4, rkf45, backward-euler or trapezoid", v);
		return NDO_OK;
	}
	if (strcmp(key, "solver") == 0) {
		if (ndo_solver_parse(v, &sc->sim.solver))
			return ndo__fail(NDO_EINVAL, "solver: '%s' is not auto, multigrid or cholmod", v);
		return NDO_OK;
	}
	if (strcmp(key, "dt") == 0) {
		if (strcmp(v, "auto") == 0) {
			sc->dt_auto = 1;
			return NDO_OK;
		}
		if ((rc = number(key, v, 0, 1e6, 1, &sc->dt))) {
			char d[256];
			snprintf(d, sizeof d, "%s", ndo_errdetail());
			return ndo__fail(rc, "%s (or auto)", d);
		}
		sc->dt_auto = 0;
		return NDO_OK;
	}
	if (strcmp(key, "dt-safety") == 0)
		return number(key, v, 0, 1, 1, &sc->dt_safety);
	if (strcmp(key, "steps") == 0) {
		if ((rc = integer(key, v, 0, (int64_t)1e12, &sc->steps)))
			return rc;
		sc->duration = 0;
		return NDO_OK;
	}
	if (strcmp(key, "time") == 0)
		return number(key, v, 0, 1e9, 1, &sc->duration);
	if (strcmp(key, "tol") == 0)
		return number(key, v, 1e-14, 0.1, 0, &sc->sim.tol);
	if (strcmp(key, "restiffen") == 0) {
		if ((rc = integer(key, v, 0, 1000000000, &n)))
			return rc;
		sc->sim.restiffen = (int)n;
		return NDO_OK;
	}
	if (strcmp(key, "pins") == 0) {
		if (strcmp(v, "project") == 0)
			sc->sim.pin_mode = NDO_PINS_PROJECT;
		else if (strcmp(v, "penalty") == 0)
			sc->sim.pin_mode = NDO_PINS_PENALTY;
		else
			return ndo__fail(NDO_EINVAL, "pins: '%s' is not project or penalty", v);
		return NDO_OK;
	}
	if (strcmp(key, "penalty") == 0)
		return number(key, v, 0, 1e15, 1, &sc->sim.penalty);
	if (strcmp(key, "energy-bound") == 0)
		return number(key, v, 0, 1e12, 0, &sc->sim.energy_bound);
	if (strcmp(key, "pin") == 0) {
		ndo_selection sel;
		if ((rc = ndo_scene_parse_pin(v, &sel)))
			return rc;
		ndo_selection *q = realloc(sc->pins, (size_t)(sc->npins + 1) * sizeof *q);
		if (!q) {
			selection_free(&sel);
			return ndo__fail(NDO_ENOMEM, "out of memory");
		}
		sc->pins = q;
		sc->pins[sc->npins++] = sel;
		return NDO_OK;
	}
	if (strcmp(key, "force") == 0) {
		ndo_scene_force f;
		if ((rc = ndo_scene_parse_force(v, &f)))
			return rc;
		ndo_scene_force *q = realloc(sc->forces, (size_t)(sc->nforces + 1) * sizeof *q);
		if (!q) {
			selection_free(&f.sel);
			return ndo__fail(NDO_ENOMEM, "out of memory");
		}
		sc->forces = q;
		sc->forces[sc->nforces++] = f;
		return NDO_OK;
	}
	if (strcmp(key, "rest") == 0)
		return string(key, v, &sc->rest);
	if (strcmp(key, "output") == 0)
		return string(key, v, &sc->output);
	if (strcmp(key, "log") == 0)
		return string(key, v, &sc->log);
	if (strcmp(key, "frames") == 0) {
		/* Exactly one integer conversion, nothing else: the frame number
		 * is the only argument the pattern gets. */
		int conv = 0, bad = 0;
		for (const char *p = v; *p; p++) {
			if (*p != '%')
				continue;
			if (p[1] == '%') {
				p++;
				continue;
			}
			p++;
			while (*p && strchr("0123456789-+ #", *p))
				p++;
			if (*p == 'd' || *p == 'i' || *p == 'u')
				conv++;
			else
				bad = 1;
			if (!*p)
				break;
		}
		if (conv != 1 || bad)
			return ndo__fail(NDO_EINVAL, "frames: '%s' needs exactly one %%d-style "
			                 "conversion for the frame number (e.g. out/f%%05d.tgrid)", v);
		return string(key, v, &sc->frames);
	}
	if (strcmp(key, "frame-every") == 0)
		return integer(key, v, 1, (int64_t)1e12, &sc->frame_every);
	if (strcmp(key, "log-every") == 0)
		return integer(key, v, 1, (int64_t)1e12, &sc->log_every);
	if (strcmp(key, "perturb") == 0)
		return number(key, v, 0, 1e6, 0, &sc->perturb);
	if (strcmp(key, "seed") == 0) {
		if ((rc = integer(key, v, 0, INT64_MAX, &n)))
			return rc;
		sc->seed = (uint64_t)n;
		return NDO_OK;
	}
	return ndo__fail(NDO_ENOTFOUND, "unknown setting '%s'", key);
}

/* The settings that make the physical system (what a joining peer must
 * simulate the same way); the others are files, output, or applied by
 * the owner to the object itself (pin, rest, perturb, seed). */
static int is_physics(const char *key)
{
	static const char *const keys[] = {"stiffness", "density", "damping", "mass-damping",
	                                   "integrator", "dt", "dt-safety", "steps", "time",
	                                   "tol", "restiffen", "pins", "penalty", "force",
	                                   "energy-bound", NULL};
	for (int k = 0; keys[k]; k++)
		if (strcmp(key, keys[k]) == 0)
			return 1;
	return 0;
}

int ndo_scene_set(ndo_scene *sc, const char *key, const char *v)
{
	ndo__clear_error();
	if (v && strchr(v, '\n'))
		return ndo__fail(NDO_EINVAL, "%s: a value must not hold a line break", key);
	int rc = scene_set(sc, key, v);
	if (rc || !is_physics(key))
		return rc;
	/* Record it: replayed in order, the lines give the same settings
	 * (later values win, forces add up). */
	size_t old = sc->physics ? strlen(sc->physics) : 0, add = strlen(key) + strlen(v) + 2;
	char *p = realloc(sc->physics, old + add + 1);
	if (!p)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	snprintf(p + old, add + 1, "%s %s\n", key, v);
	sc->physics = p;
	return NDO_OK;
}

const char *ndo_scene_physics(const ndo_scene *sc)
{
	return sc->physics ? sc->physics : "";
}

/* One line of a scene: strip the comment and blanks, split "key value",
 * apply.  `where` prefixes an error ("file:3"). */
static int scene_line(ndo_scene *sc, char *line, const char *where)
{
	char *hash = strchr(line, '#');
	if (hash)
		*hash = '\0';
	char *p = line;
	while (*p == ' ' || *p == '\t')
		p++;
	char *end = p + strlen(p);
	while (end > p && strchr(" \t\r\n", end[-1]))
		*--end = '\0';
	if (!*p)
		return NDO_OK;
	char *key = p;
	while (*p && *p != ' ' && *p != '\t')
		p++;
	if (*p)
		*p++ = '\0';
	while (*p == ' ' || *p == '\t')
		p++;
	int rc = ndo_scene_set(sc, key, *p ? p : NULL);
	if (rc) {
		char d[384];
		snprintf(d, sizeof d, "%s", ndo_errdetail());
		rc = ndo__fail(rc, "%s: %s", where, d);
	}
	return rc;
}

int ndo_scene_apply_text(ndo_scene *sc, const char *text, const char *what)
{
	ndo__clear_error();
	char *copy = strdup(text);
	if (!copy)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	int rc = NDO_OK, lineno = 0;
	char *save = NULL;
	for (char *line = copy; line && rc == NDO_OK; line = save) {
		save = strchr(line, '\n');
		if (save)
			*save++ = '\0';
		char where[256];
		snprintf(where, sizeof where, "%s:%d", what, ++lineno);
		rc = scene_line(sc, line, where);
	}
	free(copy);
	return rc;
}

int ndo_scene_load(ndo_scene *sc, const char *path)
{
	ndo__clear_error();
	FILE *f = fopen(path, "r");
	if (!f)
		return ndo__fail(NDO_EIO, "%s: %s", path, strerror(errno));
	char *line = NULL;
	size_t cap = 0;
	ssize_t len;
	int lineno = 0, rc = NDO_OK;
	while (rc == NDO_OK && (len = getline(&line, &cap, f)) >= 0) {
		char where[4200];
		snprintf(where, sizeof where, "%s:%d", path, ++lineno);
		rc = scene_line(sc, line, where);
	}
	if (rc == NDO_OK && ferror(f))
		rc = ndo__fail(NDO_EIO, "%s: read error", path);
	free(line);
	fclose(f);
	return rc;
}

/* ---- resolving selections -------------------------------------------------- */

static void tri_nodes(int level, size_t t, int32_t v[3])
{
	int n = 1 << level, w = 2 * n + 1;
	size_t cell = t / 2;
	int i = (int)(cell % (size_t)(2 * n)), j = (int)(cell / (size_t)(2 * n));
	int32_t a = (int32_t)ndo_node(w, i, j), b = a + 1, c = a + w, d = c + 1;
	if (t % 2 == 0)
		v[0] = a, v[1] = b, v[2] = c;
	else
		v[0] = b, v[1] = d, v[2] = c;
}

static double dist2(const double *a, const double *b)
{
	return (a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
	       (a[2] - b[2]) * (a[2] - b[2]);
}

/* The items a selection names: triangle ids (faces) or stored indices
 * (nodes).  *out is malloc'ed. */
static int select_items(const ndo_selection *sel, int faces, int level, const double *x,
                        int32_t **out, size_t *count, const char *what)
{
	int n = 1 << level, w = 2 * n + 1;
	size_t ntri = ndo_triangle_count(level), cnt = (size_t)w * (size_t)(n + 1);
	size_t total = faces ? ntri : cnt;
	int32_t *ids = malloc((total + 1) * sizeof *ids);
	if (!ids)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	size_t k = 0;
	if (sel->kind == NDO_SEL_FACES) {
		if (!faces)
			for (size_t q = 0; q < sel->count; q++) {
				if ((size_t)sel->ids[q] >= ntri) {
					free(ids);
					return ndo__fail(NDO_ERANGE, "%s: face %d is outside 0..%zu", what,
					                 (int)sel->ids[q], ntri - 1);
				}
				int32_t v[3];
				tri_nodes(level, (size_t)sel->ids[q], v);
				for (int d = 0; d < 3 && k < total; d++)
					ids[k++] = v[d];
			}
		else
			for (size_t q = 0; q < sel->count && k < total; q++) {
				if ((size_t)sel->ids[q] >= ntri) {
					free(ids);
					return ndo__fail(NDO_ERANGE, "%s: face %d is outside 0..%zu", what,
					                 (int)sel->ids[q], ntri - 1);
				}
				ids[k++] = sel->ids[q];
			}
	} else if (sel->kind == NDO_SEL_NODES) {
		for (size_t q = 0; q < sel->count && k < total; q++) {
			int i = sel->ids[2 * q], j = sel->ids[2 * q + 1];
			if (i > 2 * n || j > n) {
				free(ids);
				return ndo__fail(NDO_ERANGE, "%s: node %d:%d is outside the level-%d grid "
				                 "(0..%d):(0..%d)", what, i, j, level, 2 * n, n);
			}
			ids[k++] = (int32_t)ndo_node(w, i, j);
		}
	} else if (sel->kind == NDO_SEL_AT) {
		double r2 = sel->radius * sel->radius, best = INFINITY;
		int32_t nearest = 0;
		for (size_t q = 0; q < total; q++) {
			double c[3];
			if (faces) {
				int32_t v[3];
				tri_nodes(level, q, v);
				for (int d = 0; d < 3; d++)
					c[d] = (x[3 * (size_t)v[0] + d] + x[3 * (size_t)v[1] + d] +
					        x[3 * (size_t)v[2] + d]) / 3;
			} else {
				if (ndo_canonical(level, (int)(q % (size_t)w), (int)(q / (size_t)w)) != q)
					continue;
				memcpy(c, x + 3 * q, sizeof c);
			}
			double d2 = dist2(c, sel->at);
			if (d2 < best) {
				best = d2;
				nearest = (int32_t)q;
			}
			if (sel->radius > 0 && d2 <= r2)
				ids[k++] = (int32_t)q;
		}
		if (k == 0)
			ids[k++] = nearest; /* no radius, or nothing within it */
	}
	*out = ids;
	*count = k;
	return NDO_OK;
}

void ndo_scene_forces_free(ndo_force *forces, int n)
{
	if (!forces)
		return;
	for (int k = 0; k < n; k++)
		free(forces[k].items);
	free(forces);
}

int ndo_scene_resolve(const ndo_scene *sc, int level, const double *x, ndo_force **forces,
                      uint8_t *pin)
{
	ndo__clear_error();
	*forces = NULL;
	ndo_force *fs = calloc((size_t)sc->nforces + 1, sizeof *fs);
	if (!fs)
		return ndo__fail(NDO_ENOMEM, "out of memory");
	int rc = NDO_OK;
	for (int k = 0; k < sc->nforces && rc == NDO_OK; k++) {
		fs[k] = sc->forces[k].f;
		fs[k].items = NULL;
		fs[k].count = 0;
		if (fs[k].kind == NDO_FORCE_PRESSURE)
			continue;
		char what[32];
		snprintf(what, sizeof what, "force %d", k + 1);
		rc = select_items(&sc->forces[k].sel, fs[k].kind == NDO_FORCE_FACE, level, x,
		                  &fs[k].items, &fs[k].count, what);
	}
	for (int k = 0; k < sc->npins && rc == NDO_OK; k++) {
		int32_t *ids;
		size_t count;
		char what[32];
		snprintf(what, sizeof what, "pin %d", k + 1);
		if ((rc = select_items(&sc->pins[k], 0, level, x, &ids, &count, what)))
			break;
		int w = (2 << level) + 1;
		for (size_t q = 0; q < count; q++)
			pin[ndo_canonical(level, ids[q] % w, ids[q] / w)] = 1;
		free(ids);
	}
	if (rc) {
		ndo_scene_forces_free(fs, sc->nforces);
		return rc;
	}
	*forces = fs;
	return NDO_OK;
}
