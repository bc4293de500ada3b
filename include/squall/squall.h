/* squall/squall.h — the whole public API of libsquall in one include. Every header below is also
 * self-contained and may be included alone. tests/package/headers.sh checks that this list names
 * every header of include/squall/. */
#ifndef SQ_SQUALL_H
#define SQ_SQUALL_H

/* core: context, results and errors, logging, memory; math; fields; noise and random numbers */
#include "squall/core.h"
#include "squall/field.h"
#include "squall/noise.h"
#include "squall/par.h"
#include "squall/rng.h"
#include "squall/sqmath.h"

/* solvers (weather-agnostic numerics) */
#include "squall/grid.h"
#include "squall/lbm.h"
#include "squall/optics.h"
#include "squall/sph.h"

/* the world and its meshes, phenomena (generic handle, plug-ins and the typed APIs), scenes */
#include "squall/avalanche.h"
#include "squall/clouds.h"
#include "squall/snowcover.h"
#include "squall/drawable.h"
#include "squall/mesh.h"
#include "squall/phenomenon.h"
#include "squall/plugin.h"
#include "squall/sandstorm.h"
#include "squall/scene.h"
#include "squall/snowdrift.h"
#include "squall/world.h"

/* rendering, the frame loop, files */
#include "squall/geo.h"
#include "squall/image.h"
#include "squall/io.h"
#include "squall/render.h"
#include "squall/run.h"
#include "squall/wrf.h"

#endif
