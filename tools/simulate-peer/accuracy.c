/* accuracy.c — simulate-peer's error report and --accuracy (issue 18;
 * docs/simulate-peer.md, "How accurate a run is", "Asking for an
 * accuracy").  The estimates and the choice are the library's
 * (ndo/accuracy.h); this file reads the option, prints, and stores a run
 * made at a coarser level at the input's level. */
#include "simulate.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void accuracy_option(run *r, const char *arg)
{
	char *end;
	errno = 0;
	double e = strtod(arg, &end);
	int metres = end != arg && strcmp(end, "m") == 0;
	/* strtod's ERANGE is a number beyond a double's range, not none:
	 * 1e400 (inf) is outside the range below, 1e-320 (subnormal) and
	 * 1e-1000 (0) under the normal doubles */
	int range = errno == ERANGE;
	if (end == arg || (*end && !metres) || (!range && !isfinite(e)))
		ndo_usage_error("--accuracy: '%s' is not a number (E, a share of the largest "
		                "displacement in (0, 1), or Em, metres)", arg);
	if (range && fabs(e) < 1)
		ndo_usage_error("--accuracy: %s is outside the range: under 2.2e-308, the smallest "
		                "normal double", arg);
	if (metres ? !(e > 0 && e <= 1e6) : !(e > 0 && e < 1))
		ndo_usage_error("--accuracy: %s is outside %s", arg,
		                metres ? "(0, 1e6] metres" : "(0, 1) (a share of the largest displacement)");
	r->accuracy = e;
	r->accuracy_metres = metres;
}

/* "R of the largest displacement, U m" — or, where nothing moved (U = 0),
 * "the largest displacement is 0 m": a share of nothing is not printed (it
 * was NaN or inf). */
static const char *share(char *buf, size_t n, double m, double umax, const char *ufmt)
{
	char u[32];
	snprintf(u, sizeof u, ufmt, umax);
	if (umax > 0)
		snprintf(buf, n, "%.3g of the largest displacement, %s m", m / umax, u);
	else
		snprintf(buf, n, "the largest displacement is 0 m");
	return buf;
}

/* The run's initial state as the accuracy machinery's scene. */
static void make_acc(run *r)
{
	ndo_grid *g;
	if (ndo_grid_create(r->g->level, &g) || ndo_sim_store(r->sim, g))
		ndo_die("%s", ndo_errdetail());
	const uint8_t *pin = r->pins;
	ndo_channel *pc = ndo_grid_find(r->g, NDO_CH_PIN);
	if (!pin && pc && pc->type == NDO_U8 && pc->comps == 1)
		pin = pc->data;
	if (ndo_acc_create(&r->sc, g->level, ndo_grid_find(g, NDO_CH_POSITION)->data,
	                   ndo_grid_find(g, NDO_CH_VELOCITY)->data,
	                   ndo_grid_find(g, NDO_CH_REST)->data, pin, ndo_sim_time(r->sim), &r->acc))
		ndo_die("%s", ndo_errdetail());
	ndo_grid_destroy(g);
	/* plan() has the input level's top mode: no second power iteration
	 * (nor a second simulation of the input's size) for it. */
	ndo_acc_set_critical(r->acc, r->g->level, r->crit.omega_max, r->crit.gamma);
	ndo_acc_set_max_memory(r->acc, r->max_memory);
	/* the estimate's window beside its coarse companions where the run
	 * may have the cores (as run.c gives the run its threads) */
	ndo_acc_set_threads(r->acc, r->threads ? r->threads : r->net.role ? 1 : ndo_cpu_count());
}

void accuracy_plan(run *r)
{
	/* Nobody reads an estimate of a quiet run without a log: skip its cost. */
	if (!r->accuracy && (r->info || r->no_estimate || (r->quiet && !r->sc.log)))
		return;
	make_acc(r);
	if (!r->accuracy)
		return;
	int n = r->g->level;
	double T = r->sc.duration; /* options() refuses --accuracy without it */
	ndo_acc_choice ch;
	int rc = ndo_acc_choose(r->acc, r->accuracy, r->accuracy_metres, T, &ch);
	const char *want = r->accuracy_metres ? " m" : " of the largest displacement";
	if (rc == NDO_EINVAL) {
		fprintf(stderr, "%s: --accuracy: %s\n", ndo_progname, ndo_errdetail());
		exit(NDO_EXIT_USAGE);
	}
	if (rc)
		ndo_die("--accuracy: %s", ndo_errdetail());
	if (!ch.reachable) {
		char need[64];
		if (ch.level_needed > NDO_MAX_LEVEL)
			snprintf(need, sizeof need, "a level finer than %d, the finest grid,", NDO_MAX_LEVEL);
		else
			snprintf(need, sizeof need, "level %d", ch.level_needed);
		char sh[96];
		fprintf(stderr, "%s: --accuracy %g%s: out of reach at level %d: its space error alone is "
		        "about %.3g m (%s; estimated from levels %d and %d); this input allows %.2g%s at "
		        "best, and %s would be needed\n",
		        ndo_progname, r->accuracy, want, n, ch.best_m,
		        share(sh, sizeof sh, ch.best_m, ch.umax, "%.3g"), ch.pilot_top - 1, ch.pilot_top,
		        r->accuracy_metres ? ch.best_m : ch.best_m / ch.umax, r->accuracy_metres ? " m" : "",
		        need);
		ndo_close_stdout();
		exit(NDO_EXIT_USAGE);
	}
	if (!r->quiet) {
		double pred = ch.error_m;
		char rel[32] = ""; /* the share, where something moves */
		if (ch.umax > 0)
			snprintf(rel, sizeof rel, "%.3g: ", pred / ch.umax);
		fprintf(stderr, "%s: --accuracy %g%s = %.3g m (largest displacement %.3g m, predicted): "
		        "level %d, %s, step %.4g s, %lld steps; predicted error %.3g m (%stime %.3g m, "
		        "space %.3g m), cost %.3g node-evaluations, about %.3g s CPU; choosing took %.3g "
		        "s (%.3g s CPU; pilots at levels up to %d)\n",
		        ndo_progname, r->accuracy, want, ch.target_m, ch.umax, ch.c.level,
		        ndo_method_names[ch.c.method], ch.c.h, (long long)ch.c.steps, pred, rel,
		        ch.time_m, ch.space_m, ch.node_evals, ch.cpu, ch.pilot_wall, ch.pilot_cpu,
		        ch.pilot_top);
		if (ch.c.level < n)
			fprintf(stderr, "%s: level %d is subdivided to the input's level %d for the output "
			        "and the frames\n", ndo_progname, ch.c.level, n);
	}
	if (r->info)
		return;
	/* The input's simulation goes before the chosen one is made: two of
	 * the input's size at once would double a plain run's memory. */
	double t = ndo_sim_time(r->sim);
	int64_t k = ndo_sim_step_count(r->sim);
	ndo_sim_destroy(r->sim);
	r->sim = NULL;
	/* The chosen run as a plain run: every core, the memory limit (the
	 * pilots and the estimate's companions keep the scene's settings);
	 * like the choice's own runs, no energy test unless --energy-bound
	 * asks for one: its step is at most 0.9 × a critical step, where a
	 * linear scene cannot diverge (the test's false alarm at steps a large
	 * part of a force's period, when its work was the power at the steps'
	 * ends, stopped figure 5.3 from level 2 at 0.9, rk4 at 0.5 s at level
	 * 1, until 2026-11-30: docs/simulate-peer.md). */
	ndo_sim_params keep = r->sc.sim;
	r->sc.sim.threads = r->threads ? r->threads : ndo_cpu_count();
	r->sc.sim.max_memory = r->max_memory ? r->max_memory : ndo_memory_available();
	if (!r->energy_bound_set)
		r->sc.sim.energy_bound = 0;
	int rc2 = ndo_acc_sim(r->acc, ch.c.level, ch.c.method, ch.c.tol, &r->sim);
	r->sc.sim = keep;
	if (rc2)
		ndo_die("%s", ndo_errdetail());
	ndo_sim_set_time(r->sim, t, k);
	if (ch.c.level == n) /* the same top mode as plan()'s */
		r->crit.h_crit = ndo_stable_step(ch.c.method, r->crit.omega_max, r->crit.gamma,
		                                 &r->crit.bound);
	else if (ndo_sim_critical(r->sim, &r->crit))
		ndo_die("critical step: %s", ndo_errdetail());
	r->dt = ch.c.h;
	r->steps = ch.c.steps;
	/* a tenth of the target for the still tiles (docs/simulate-peer.md) */
	if (!r->sleep_set && ch.c.method != NDO_RKF45 && !ndo_method_is_implicit(ch.c.method))
		r->sleep = ch.target_m / 10;
}

void sleep_option(run *r, const char *arg)
{
	char *end;
	errno = 0;
	double d = strtod(arg, &end);
	int range = errno == ERANGE; /* a number beyond a double's range (as --accuracy's) */
	if (end == arg || (*end && strcmp(end, "m") != 0) || (!range && !isfinite(d)))
		ndo_usage_error("--sleep: '%s' is not a distance in metres", arg);
	if (range && fabs(d) < 1)
		ndo_usage_error("--sleep: %s is outside the range: under 2.2e-308, the smallest "
		                "normal double", arg);
	if (!(d >= 0 && d <= 1e6))
		ndo_usage_error("--sleep: %s is outside [0, 1e6] metres", arg);
	r->sleep = d;
	r->sleep_set = 1;
}

void sleep_apply(run *r)
{
	if (!(r->sleep > 0) || r->info)
		return;
	if (ndo_sim_set_sleep(r->sim, r->sleep, r->sleep / (8 * r->dt))) {
		fprintf(stderr, "%s: --sleep: %s\n", ndo_progname, ndo_errdetail());
		exit(NDO_EXIT_USAGE);
	}
}

void sleep_report(const run *r)
{
	ndo_sim_sleep_stats st;
	ndo_sim_sleep_stats_get(r->sim, &st);
	if (!st.on)
		return;
	fprintf(stderr, "%s: sleeping tiles (%.3g m): %.4g of %.4g node-steps taken (%.1f%% saved); "
	        "%d of %d tiles awake at the end, %lld fell asleep, %lld woke\n",
	        ndo_progname, r->sleep, st.node_steps, st.node_steps_all,
	        st.node_steps_all > 0 ? 100 * (1 - st.node_steps / st.node_steps_all) : 0, st.awake,
	        st.tiles, (long long)st.sleeps, (long long)st.wakes);
}

static int64_t sample_every(const run *r)
{
	return r->steps / 64 > 1 ? r->steps / 64 : 1;
}

void accuracy_sample(run *r, int64_t k)
{
	if (r->acc && (k % sample_every(r) == 0 || k == r->steps))
		ndo_acc_sample(r->acc, r->sim);
}

int64_t accuracy_next(const run *r, int64_t k)
{
	if (!r->acc)
		return INT64_MAX;
	int64_t e = sample_every(r);
	return (k / e + 1) * e;
}

/* The estimate's line, printed after the run's summary (accuracy_print). */
static char report[1024];

/* The estimate's companions running beside the run (accuracy_begin): an
 * exit on any path (a divergence, an error, an interrupt) stops them
 * first. */
static ndo_acc *running;

static void stop_running(void)
{
	ndo_acc_estimate_cancel(running);
	running = NULL;
}

/* The estimate's configuration: the run as simulated. */
static ndo_acc_config estimated(const run *r)
{
	return (ndo_acc_config){ndo_sim_level(r->sim), ndo_sim_method(r->sim), r->dt, r->steps,
	                        r->sc.sim.tol};
}

void accuracy_begin(run *r)
{
	/* A run that steps on one thread (levels up to 6, a single process)
	 * leaves the other cores to the estimate's companions, which need
	 * nothing of it: they run beside it rather than after it (the same
	 * figures; ndo_acc_estimate_begin).  A run on the threads keeps the
	 * cores, and the estimate comes after it, as before. */
	if (!r->acc || (r->quiet && !r->logging) || ndo_sim_threads(r->sim) > 1)
		return;
	ndo_acc_config c = estimated(r);
	if (ndo_acc_estimate_begin(r->acc, &c))
		ndo_die("error estimate: %s", ndo_errdetail());
	if (!running)
		atexit(stop_running);
	running = r->acc;
}

void accuracy_print(void)
{
	fputs(report, stderr);
	report[0] = '\0';
}

void accuracy_report(run *r)
{
	/* --accuracy makes the machinery for the choice; its estimate of a
	 * quiet run without a log would be read by nobody. */
	if (!r->acc || (r->quiet && !r->logging))
		return;
	int level = ndo_sim_level(r->sim);
	ndo_acc_config c = estimated(r);
	size_t bytes = 3 * sizeof(double) * (size_t)((2 << level) + 1) * (size_t)((1 << level) + 1);
	double *u = r->coarse = malloc(bytes);
	if (!u)
		ndo_die("out of memory");
	ndo_acc_displacement(r->acc, r->sim, u);
	double umax = ndo_acc_sampled(r->acc);
	ndo_acc_estimate e;
	if (ndo_acc_estimate_end(r->acc, &c, u, umax, &e))
		ndo_die("error estimate: %s", ndo_errdetail());
	free(u);
	r->coarse = NULL;
	double rel = umax > 0 ? 1 / umax : NAN, tot = e.total_m;
	if (!r->quiet) {
		if (isnan(e.time_m) && isnan(e.space_m)) {
			snprintf(report, sizeof report, "%s: error estimate: none (%s)\n", ndo_progname, e.why);
		} else {
			/* a part not estimated says so (its why follows), and the
			 * total is then the other's; shares only of some motion */
			char sh[96], how[320], tpart[400], spart[160];
			double shown = isnan(tot) ? (isnan(e.time_m) ? e.space_m : e.time_m) : tot;
			snprintf(how, sizeof how, "against level %d, %g per level", level - 1, e.rate);
			const double m[2] = {e.time_m, e.space_m};
			const char *hows[2] = {e.time_how, how};
			char *part[2] = {tpart, spart};
			size_t size[2] = {sizeof tpart, sizeof spart};
			for (int k = 0; k < 2; k++) {
				if (isnan(m[k]))
					snprintf(part[k], size[k], "not estimated");
				else if (umax > 0)
					snprintf(part[k], size[k], "%.3g m (%.3g; %s)", m[k], m[k] * rel, hows[k]);
				else
					snprintf(part[k], size[k], "%.3g m (%s)", m[k], hows[k]);
			}
			snprintf(report, sizeof report, "%s: error estimate: %.3g m (%s): time %s, space "
			         "%s%s%s; estimating took %.3g s CPU\n",
			         ndo_progname, shown, share(sh, sizeof sh, shown, umax, "%.4g"), tpart, spart,
			         *e.why ? "; not estimated: " : "", e.why, e.cpu);
		}
	}
	if (r->logging)
		fprintf(r->log.f, "# error_estimate time_m=%.6g space_m=%.6g total_m=%.6g "
		        "largest_displacement_m=%.6g time_relative=%.6g space_relative=%.6g "
		        "total_relative=%.6g rate=%.4g\n",
		        e.time_m, e.space_m, tot, umax, e.time_m * rel, e.space_m * rel, tot * rel,
		        e.rate);
}

int accuracy_store(run *r, ndo_grid *g)
{
	int level = ndo_sim_level(r->sim);
	if (level == g->level)
		return ndo_sim_store(r->sim, g);
	/* A coarser run: its displacements and velocities, subdivided, over
	 * the input's rest shape (the input level's own geometry, not the
	 * coarse shape's subdivision). */
	ndo_grid *c;
	int rc = ndo_grid_create(level, &c);
	if (rc || (rc = ndo_sim_store(r->sim, c))) {
		ndo_grid_destroy(c);
		return rc;
	}
	double *x = ndo_grid_find(c, NDO_CH_POSITION)->data, *X = ndo_grid_find(c, NDO_CH_REST)->data,
	       *v = ndo_grid_find(c, NDO_CH_VELOCITY)->data, *uf = NULL, *vf = NULL;
	for (size_t q = 0; q < 3 * c->count; q++)
		x[q] -= X[q];
	ndo_channel *pc, *vc, *rc2;
	if ((rc = ndo_acc_prolong(level, g->level, x, &uf)) ||
	    (rc = ndo_acc_prolong(level, g->level, v, &vf)) ||
	    (rc = ndo_grid_add(g, NDO_CH_VELOCITY, NDO_F64, 3, &vc)) ||
	    (rc = ndo_grid_add(g, NDO_CH_REST, NDO_F64, 3, &rc2))) {
		free(uf), free(vf);
		ndo_grid_destroy(c);
		return rc;
	}
	/* The input level's rest shape: the machinery keeps it. */
	const double *rest = ndo_acc_rest(r->acc, g->level);
	pc = ndo_grid_find(g, NDO_CH_POSITION);
	memcpy(rc2->data, rest, 3 * g->count * sizeof *rest);
	memcpy(vc->data, vf, 3 * g->count * sizeof *vf);
	double *xf = pc->data;
	for (size_t q = 0; q < 3 * g->count; q++)
		xf[q] = rest[q] + uf[q];
	g->time = ndo_sim_time(r->sim);
	g->step = ndo_sim_step_count(r->sim);
	free(uf), free(vf);
	ndo_grid_destroy(c);
	return NDO_OK;
}

void accuracy_free(run *r)
{
	if (running == r->acc)
		running = NULL;
	ndo_acc_destroy(r->acc);
	r->acc = NULL;
}
