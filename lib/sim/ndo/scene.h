/* ndo/scene.h — a simulation scene: material, forces, pins, integrator and
 * output settings, from a scene file and/or command-line options.
 *
 * The scene file is plain text, one setting per line, '#' starts a
 * comment; each line is a long option of simulate-peer without its
 * dashes, then its value:
 *
 *     # thesis figure 5.3: k = 1 N/m, b = 0.1, f = 2.4 N
 *     stiffness 1
 *     damping 0.1
 *     integrator rkf45
 *     dt 0.01
 *     time 10
 *     force face at=0,0,1 radius=0.25 amplitude=2.4 frequency=1
 *     pin at=0,0,-1 radius=0.2
 *
 * so every setting can also be given on the command line
 * (--force 'face at=0,0,1 ...'), where it overrides the file's value
 * (forces and pins add up).  The full list is in docs/simulate-peer.md and
 * simulate-peer(1).
 *
 * Forces (--force KIND key=value ...):
 *   KIND       face | point | pressure
 *   faces=T,…  triangle ids (ndo_triangles order), face forces
 *   nodes=I:J,…  grid nodes (column I, row J), point forces
 *   at=X,Y,Z   select by position on the rest shape instead: the faces
 *              whose centroid (nodes which) lie within radius=R metres of
 *              the point, or the nearest one when radius is 0 (default)
 *   amplitude=A  N (face: total over the faces; point: per node), Pa for
 *              pressure; default 1
 *   frequency=F  Hz, 0 (default) = constant
 *   phase=P    degrees, default 0
 *   direction=normal (default) | X,Y,Z
 * Pins (--pin SELECTION): nodes=I:J,…, faces=T,… (their three vertices)
 * or at=X,Y,Z radius=R (nodes).
 */
#ifndef NDO_SCENE_H
#define NDO_SCENE_H

#include <stdint.h>

#include "ndo/grid.h"
#include "ndo/sim.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Which items a force or pin applies to, before a grid is known. */
typedef struct ndo_selection {
	enum { NDO_SEL_NONE, NDO_SEL_FACES, NDO_SEL_NODES, NDO_SEL_AT } kind;
	int32_t *ids;   /* faces: triangle ids; nodes: pairs (I, J) */
	size_t count;   /* faces, or node pairs */
	double at[3], radius;
} ndo_selection;

typedef struct ndo_scene_force {
	ndo_force f;      /* items unset until resolved */
	ndo_selection sel;
} ndo_scene_force;

typedef struct ndo_scene {
	ndo_sim_params sim;   /* forces: see `forces`, resolved per grid */
	double dt;            /* s; ignored when dt_auto */
	int dt_auto;          /* dt = dt_safety × the critical step */
	double dt_safety;     /* default 0.9 */
	int64_t steps;        /* steps to take (default 100) ... */
	double duration;      /* ... or simulated seconds when > 0 */
	char *rest;           /* the rest shape's grid file, or NULL */
	char *output;         /* -o, or NULL for standard output */
	char *frames;         /* printf pattern with one integer conversion */
	int64_t frame_every;  /* default 1 */
	char *log;            /* CSV log, or NULL */
	int64_t log_every;    /* default 1 */
	double perturb;       /* seeded random displacement amplitude, m */
	uint64_t seed;
	ndo_scene_force *forces;
	int nforces;
	ndo_selection *pins;
	int npins;
	char *physics;        /* the physics settings applied so far, as lines
	                         (ndo_scene_physics) */
} ndo_scene;

/* Defaults: ndo_sim_defaults() with damping 0.1 (the thesis' b), rk4,
 * dt auto at 0.9 of the critical step, 100 steps, frames and log every
 * step when asked for. */
void ndo_scene_init(ndo_scene *sc);
void ndo_scene_free(ndo_scene *sc);

/* Apply one setting: key is a long option name without dashes ("stiffness",
 * "force", ...), value its argument (NULL for a flag).  NDO_ENOTFOUND for
 * an unknown key, NDO_ERANGE / NDO_EINVAL for a bad value, with a detail
 * that names the key and the accepted range. */
int ndo_scene_set(ndo_scene *sc, const char *key, const char *value);

/* The keys ndo_scene_set knows, NULL-terminated (each takes a value). */
extern const char *const ndo_scene_keys[];

/* Read a scene file and apply each line.  Errors carry "path:line: ". */
int ndo_scene_load(ndo_scene *sc, const char *path);

/* Apply scene text (lines "key value", '#' comments), e.g. a peer's
 * object description.  Errors carry "what:line: ". */
int ndo_scene_apply_text(ndo_scene *sc, const char *text, const char *what);

/* The settings that define the physical system — stiffness, density,
 * damping, mass-damping, integrator, dt, dt-safety, steps, time, tol,
 * restiffen, pins, penalty, force, energy-bound — as applied so far,
 * one "key value" line each in order: another process that applies this
 * text (ndo_scene_apply_text) simulates the same system.  Pins, the rest
 * shape and --perturb are not in it: they change the object itself, which
 * travels with it.  Never NULL. */
const char *ndo_scene_physics(const ndo_scene *sc);

/* Parse a force or pin specification (the value of --force / --pin). */
int ndo_scene_parse_force(const char *spec, ndo_scene_force *out);
int ndo_scene_parse_pin(const char *spec, ndo_selection *out);

/* Resolve the forces and pins against a level-`level` grid whose rest
 * positions are x (H × W × 3): *forces gets nforces ndo_force with their
 * items (free with ndo_scene_forces_free); pin (H × W bytes) gets 1 at
 * the canonical node of every pinned vertex (it is not cleared first).  NDO_ERANGE when a
 * selection names a face or node outside the grid. */
int ndo_scene_resolve(const ndo_scene *sc, int level, const double *x, ndo_force **forces,
                      uint8_t *pin);
void ndo_scene_forces_free(ndo_force *forces, int n);

#ifdef __cplusplus
}
#endif
#endif
