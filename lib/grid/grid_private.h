/* grid_private.h — library-internal helpers for building grids. */
#ifndef NDO_GRID_PRIVATE_H
#define NDO_GRID_PRIVATE_H

#include "ndo/grid.h"

/* A level-`level` grid with no channels yet (callers add "position"). */
int ndo__grid_alloc(int level, ndo_grid **out);

#endif
