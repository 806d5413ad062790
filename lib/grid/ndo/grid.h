/* ndo/grid.h — the regular grid over the unfolded tetrahedron (DESIGN.md,
 * "The regular grid"; thesis §4.2.1, figure 4.3).
 *
 * A level-n grid stores H × W nodes, W = 2N+1 columns and H = N+1 rows with
 * N = 2^n.  Node (i, j), 0 ≤ i ≤ 2N, 0 ≤ j ≤ N, lives at index j*W + i
 * ("row-major"; ndo_node()).  Every per-node quantity is a channel: an
 * H × W × comps array of one scalar type over the same index, so the grid
 * is a geometry image and a tile is a rectangle of indices.
 *
 * The topology (seams, ghost map, triangles, distinct vertices) is in
 * ndo/topology.h; this header is the container.
 */
#ifndef NDO_GRID_H
#define NDO_GRID_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Levels 0..10.  Level 10 stores 2049 × 1025 = 2,100,225 nodes (50 MB per
 * 3-vector of doubles); level 11 would store 8.4 million and subdividing
 * into it with the usual channels needs about 1 GB, beyond what any tool
 * here is meant for. */
#define NDO_MAX_LEVEL 10
#define NDO_MAX_CHANNELS 16
#define NDO_NAME_LEN 16 /* channel name buffer, including the NUL */

/* Scalar types of a channel.  The numeric values are the file format's. */
typedef enum ndo_type {
	NDO_F64 = 1, /* IEEE double */
	NDO_F32 = 2, /* IEEE float */
	NDO_U8 = 3,  /* unsigned byte: masks (pin) */
	NDO_I32 = 4  /* signed 32-bit: labels (owner) */
} ndo_type;

/* Names of the channels every tool understands.  Any other name
 * ([a-z0-9_.-], 1..15 characters) is carried along untouched. */
#define NDO_CH_POSITION "position" /* 3 × f64 or f32, always present, metres */
#define NDO_CH_VELOCITY "velocity" /* 3 × f64 or f32, m/s */
#define NDO_CH_REST "rest"         /* 3 × f64 or f32, rest shape X */
#define NDO_CH_PIN "pin"           /* 1 × u8, nonzero = pinned */
#define NDO_CH_OWNER "owner"       /* 1 × i32, id of the peer owning the node */

typedef struct ndo_channel {
	char name[NDO_NAME_LEN];
	ndo_type type;
	int comps;  /* values per node, 1..4 */
	void *data; /* count × comps values of `type`, owned by the grid */
} ndo_channel;

/* A grid.  Fields are read-only for callers except the channel data, time,
 * step and history, which tools update in place. */
typedef struct ndo_grid {
	int level;      /* n */
	int n;          /* N = 2^n */
	int w, h;       /* W = 2N+1 columns, H = N+1 rows */
	size_t count;   /* W*H stored nodes */
	int nchannels;
	ndo_channel ch[NDO_MAX_CHANNELS];
	double time;    /* simulated time in seconds (0 if never simulated) */
	int64_t step;   /* simulation step count (0 if never simulated) */
	char *history;  /* the command lines that made this grid, oldest first,
	                   one per line; NUL-terminated, owned; never NULL */
} ndo_grid;

static inline size_t ndo_node(int w, int i, int j)
{
	return (size_t)j * (size_t)w + (size_t)i;
}

/* Bytes of one value of a type (0 for an unknown type), and its name
 * ("f64", "f32", "u8", "i32"; "?" if unknown). */
size_t ndo_type_size(ndo_type t);
const char *ndo_type_name(ndo_type t);

/* Create a level-`level` grid holding one channel, "position" (3 × f64,
 * all zero).  Fails with NDO_ERANGE outside 0..NDO_MAX_LEVEL. */
int ndo_grid_create(int level, ndo_grid **out);

/* Free a grid and all its channels.  Accepts NULL. */
void ndo_grid_destroy(ndo_grid *g);

/* A deep copy (channels, time, step, history). */
int ndo_grid_copy(const ndo_grid *g, ndo_grid **out);

/* The channel called `name`, or NULL. */
ndo_channel *ndo_grid_find(const ndo_grid *g, const char *name);

/* Add a zero-filled channel, or return the existing one when it already
 * has this type and width (NDO_EINVAL if it exists with another).  Names
 * are 1..15 characters of [a-z0-9_.-].  On success *out (if not NULL)
 * points to the channel, valid until the next add or remove. */
int ndo_grid_add(ndo_grid *g, const char *name, ndo_type type, int comps,
                 ndo_channel **out);

/* Drop a channel ("position" cannot be dropped).  No-op when absent. */
void ndo_grid_remove(ndo_grid *g, const char *name);

/* Convert a channel's values to another scalar type in place (floats are
 * rounded to nearest; to integer types, truncated and clamped). */
int ndo_grid_convert(ndo_grid *g, const char *name, ndo_type type);

/* The data of a channel as doubles with `comps` values per node: converts
 * an f32 channel to f64 in place.  NULL if the channel is absent, has
 * another width, is an integer channel, or memory runs out. */
double *ndo_grid_f64(ndo_grid *g, const char *name, int comps);

/* The first stored node (row by row) with a value of channel `name` (f64
 * or f32) that is NaN or infinite: 1, and its (i, j) when those pointers
 * are not NULL; 0 when every value is finite, or the channel is absent
 * or holds integers. */
int ndo_grid_nonfinite(const ndo_grid *g, const char *name, int *i, int *j);

/* Append one command line (argv, shell-quoted where needed) to the
 * grid's history.  Over NDO_HISTORY_MAX bytes (ndo/gridfile.h), the first
 * line stays, a line "# N earlier lines dropped: ..." follows, then the
 * newest lines that fit (a newest line over the cap alone: its tail). */
int ndo_grid_add_history(ndo_grid *g, int argc, char *const argv[]);

#ifdef __cplusplus
}
#endif
#endif
