/* run.c — what both halves of simulate-peer do with a run's settings: load
 * the input and create the simulation (setup), choose the step (plan), and
 * the CSV log (log_open, log_row).  The single process (main.c) and the
 * owner and peers of a shared run (peers.c) call them. */
#include "simulate.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void perturb(run *r, double *x)
{
	uint64_t z = r->sc.seed;
	for (size_t p = 0; p < r->g->count; p++)
		for (int c = 0; c < 3; c++) {
			/* splitmix64: a fixed, documented sequence for a seed */
			uint64_t q = (z += 0x9e3779b97f4a7c15ULL);
			q = (q ^ (q >> 30)) * 0xbf58476d1ce4e5b9ULL;
			q = (q ^ (q >> 27)) * 0x94d049bb133111ebULL;
			q ^= q >> 31;
			x[3 * p + c] += r->sc.perturb * (2 * ((double)(q >> 11) / 9007199254740992.0) - 1);
		}
	ndo_sync(r->g->level, x, 3 * sizeof *x);
}

/* Load the input (and rest grid), resolve forces and pins, create the
 * simulation. */
void setup(run *r)
{
	ndo_grid *g = r->g = ndo_cli_load(r->in);
	double *x = ndo_grid_f64(g, NDO_CH_POSITION, 3);
	if (!x)
		ndo_die("%s: the position channel is not 3 floating-point values",
		        ndo_is_stdio(r->in) ? "standard input" : r->in);
	size_t bytes = 3 * g->count * sizeof(double);
	double *rest = r->rest = malloc(bytes), *x0 = r->x0 = malloc(bytes);
	if (!rest || !x0)
		ndo_die("out of memory");
	memcpy(x0, x, bytes);
	if (r->sc.rest) {
		ndo_grid *rg = ndo_cli_load(r->sc.rest);
		double *rx = ndo_grid_f64(rg, NDO_CH_POSITION, 3);
		if (rg->level != g->level || !rx)
			ndo_die("%s: the rest grid must be level %d with 3-value positions (it is level %d)",
			        r->sc.rest, g->level, rg->level);
		memcpy(rest, rx, bytes);
		ndo_grid_destroy(rg);
	} else if (ndo_grid_find(g, NDO_CH_REST)) {
		double *rx = ndo_grid_f64(g, NDO_CH_REST, 3);
		if (!rx)
			ndo_die("%s: the rest channel is not 3 floating-point values",
			        ndo_is_stdio(r->in) ? "standard input" : r->in);
		memcpy(rest, rx, bytes);
	} else {
		memcpy(rest, x, bytes);
	}
	if (r->sc.perturb > 0)
		perturb(r, x0);
	/* Pins: the grid's pin channel plus --pin. */
	uint8_t *pin = r->pin = calloc(g->count, 1);
	if (!pin)
		ndo_die("out of memory");
	ndo_channel *pc = ndo_grid_find(g, NDO_CH_PIN);
	if (pc && pc->type == NDO_U8 && pc->comps == 1)
		for (size_t p = 0; p < g->count; p++)
			pin[p] = ((uint8_t *)pc->data)[p] != 0;
	else if (pc)
		ndo_die("the pin channel is not 1 x u8");
	if (ndo_scene_resolve(&r->sc, g->level, rest, &r->forces, pin))
		ndo_usage_error("%s", ndo_errdetail());
	if (r->sc.npins)
		r->pins = pin;
	if (r->net.role == NDO_ROLE_OWNER) {
		r->allpins = malloc(g->count);
		if (!r->allpins)
			ndo_die("out of memory");
		memcpy(r->allpins, pin, g->count);
	}
	ndo_sim_params p = r->sc.sim;
	/* With --accuracy this simulation only gives the initial state and
	 * the input level's top mode (plan): the method is the choice's, and
	 * an implicit one's solver is not made for nothing. */
	if (r->accuracy)
		p.method = NDO_RK4;
	/* Peers share the work between processes already: one thread each
	 * unless asked. */
	p.threads = r->threads ? r->threads : r->net.role ? 1 : ndo_cpu_count();
	p.max_memory = r->max_memory ? r->max_memory : ndo_memory_available();
	p.forces = r->forces;
	p.nforces = r->sc.nforces;
	ndo_channel *vc = ndo_grid_find(g, NDO_CH_VELOCITY);
	const double *v = vc ? ndo_grid_f64(g, NDO_CH_VELOCITY, 3) : NULL;
	if (vc && !v)
		ndo_die("the velocity channel is not 3 floating-point values");
	if (ndo_sim_create(g->level, x0, v, rest, pin, &p, &r->sim))
		ndo_die("%s: %s", ndo_is_stdio(r->in) ? "standard input" : r->in, ndo_errdetail());
	ndo_sim_set_time(r->sim, g->time, g->step);
	ndo_scene_forces_free(r->forces, r->sc.nforces);
	free(rest);
	free(x0);
	if (!r->pins)
		free(pin);
	r->forces = NULL, r->rest = r->x0 = NULL, r->pin = NULL;
}

static const char *bound_name(int b)
{
	switch (b) {
	case NDO_BOUND_OSCILLATION: return "oscillation bound: the imaginary-axis interval";
	case NDO_BOUND_DAMPING: return "damping bound: no imaginary-axis interval";
	case NDO_BOUND_REAL: return "overdamped: the negative real-axis interval";
	default: return "unconditionally stable";
	}
}

/* The critical step, the step size and the step count (with --accuracy,
 * the top mode alone: the integrator and step are the choice's). */
void plan(run *r)
{
	ndo_method m = ndo_sim_method(r->sim);
	const char *name = ndo_method_names[m];
	if (ndo_sim_critical(r->sim, &r->crit))
		ndo_die("critical step: %s", ndo_errdetail());
	ndo_critical *c = &r->crit;
	if (!r->quiet)
		fprintf(stderr, "%s: level %d, %zu vertices: lambda_max(M^-1 K) = %.4g 1/s^2 "
		        "(omega_max = %.4g rad/s, %d power iterations), damping rate %.4g 1/s\n",
		        ndo_progname, r->g->level, ndo_vertex_count(r->g->level), c->lambda_max,
		        c->omega_max, c->iterations, c->gamma);
	if (r->accuracy)
		return;
	if (!r->quiet) {
		if (isinf(c->h_crit))
			fprintf(stderr, "%s: %s: stable at any step\n", ndo_progname, name);
		else if (c->h_crit == 0)
			fprintf(stderr, "%s: %s: unstable at every step without damping\n", ndo_progname,
			        name);
		else
			fprintf(stderr, "%s: %s: critical step %.4g s (%s; h omega_max = %.3f)\n",
			        ndo_progname, name, c->h_crit, bound_name(c->bound),
			        c->h_crit * c->omega_max);
	}
	if (r->sc.dt_auto) {
		if (isinf(c->h_crit))
			ndo_usage_error("--dt auto: %s is stable at any step; give --dt H", name);
		if (c->h_crit == 0)
			ndo_usage_error("--dt auto: %s has no stable step without damping; give "
			                "--damping or --mass-damping, or --dt H", name);
		r->dt = r->sc.dt_safety * c->h_crit;
	} else {
		r->dt = r->sc.dt;
	}
	r->steps = r->sc.steps;
	if (r->sc.duration > 0) {
		double n = ceil(r->sc.duration / r->dt - 1e-9);
		if (n > 1e12)
			ndo_usage_error("--time %g at a step of %g s needs more than 1e12 steps",
			                r->sc.duration, r->dt);
		r->steps = (int64_t)fmax(1, n);
		r->dt = r->sc.duration / (double)r->steps;
	}
	/* The steps run with subnormal numbers flushed to zero (ndo_fp_flush:
	 * they cost 100 times a normal one), so a step under the smallest
	 * normal double is a step of 0, refused by the first step as "not
	 * positive" after the setup: --dt 1e-320, -t 1e-310, --dt-safety
	 * 1e-310. */
	if (r->dt < DBL_MIN)
		ndo_usage_error("the step %g s is under 2.2e-308 s, the smallest normal double, "
		                "which the steps take as 0 (--dt, -t or --dt-safety)", r->dt);
	if (!r->quiet)
		fprintf(stderr, "%s: step %.4g s%s, %lld steps to t = %.6g s\n", ndo_progname, r->dt,
		        r->sc.dt_auto ? " (auto)" : "", (long long)r->steps,
		        ndo_sim_time(r->sim) + r->dt * (double)r->steps);
	if (r->dt > c->h_crit && !r->quiet) {
		if (c->h_crit > 0)
			ndo_warn("warning: the step %.4g s is %.3g x the critical step %.4g s: %s will "
			         "diverge", r->dt, r->dt / c->h_crit, c->h_crit, name);
		else
			ndo_warn("warning: %s has no stable step without damping: it will diverge", name);
	}
}

void log_open(run *r)
{
	if (!r->sc.log)
		return;
	if (ndo_out_open(r->sc.log, &r->log))
		ndo_die("%s: %s", r->sc.log, ndo_errdetail());
	r->logging = 1;
	fprintf(r->log.f, "step,time_s,dt_s,kinetic_J,potential_J,work_J,"
	                  "max_displacement_m,substeps,rejected\n");
}

void log_row(run *r, ndo_sim *sim, int64_t step)
{
	ndo_sim_energy e;
	ndo_sim_stats st;
	ndo_sim_energy_get(sim, &e);
	ndo_sim_stats_get(sim, &st);
	fprintf(r->log.f, "%lld,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%lld,%lld\n",
	        (long long)step, ndo_sim_time(sim), r->dt, e.kinetic, e.potential, e.work,
	        e.max_displacement, (long long)st.substeps, (long long)st.rejected);
}
