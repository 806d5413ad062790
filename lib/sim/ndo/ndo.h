/* ndo/ndo.h — the whole ndo library.  Link with -lndo (pkg-config ndo). */
#ifndef NDO_NDO_H
#define NDO_NDO_H

#include "ndo/status.h"
#include "ndo/grid.h"
#include "ndo/topology.h"
#include "ndo/domain.h"
#include "ndo/shapes.h"
#include "ndo/gridfile.h"
#include "ndo/io.h"
#include "ndo/export.h"
#include "ndo/subdivide.h"
#include "ndo/restrict.h"
#include "ndo/levels.h"
#include "ndo/cli.h"
#include "ndo/machine.h"
#include "ndo/pool.h"
#include "ndo/membrane.h"
#include "ndo/sim.h"
#include "ndo/scene.h"
#include "ndo/accuracy.h"

#endif
