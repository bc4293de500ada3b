/* geo_internal.h — helpers shared by the GDAL/OGR readers and writers of src/io/geo_*.c: GDAL's
 * error text captured instead of printed, and the CRS helpers. Only included where GDAL is. */
#ifndef SQ_GEO_INTERNAL_H
#define SQ_GEO_INTERNAL_H

#include <cpl_error.h>
#include <gdal.h>
#include <ogr_srs_api.h>

#include "core/core_internal.h"
#include "squall/geo.h"

/* GDAL errors on this thread go to a quiet handler between begin and end; sq__geo_reason()
 * returns the last message ("no reason given" when GDAL left none). GDAL's handler stack is
 * per thread, so this is safe with other threads using GDAL. */
void sq__geo_quiet_begin(void);
void sq__geo_quiet_end(void);
const char *sq__geo_reason(void);

/* A spatial reference from any user text (EPSG:n, WKT, PROJ), longitude/latitude axis order.
 * NULL with the reason in sq__geo_reason() when GDAL does not know it. */
OGRSpatialReferenceH sq__geo_srs_from_user(const char *text);
/* The same with traditional GIS axis order set on a copy of srs (NULL if srs is NULL). */
OGRSpatialReferenceH sq__geo_srs_clone(OGRSpatialReferenceH srs);
/* True when srs is NULL or defines nothing. */
int sq__geo_srs_empty(OGRSpatialReferenceH srs);
/* True when srs is projected with metres as its linear unit. */
int sq__geo_srs_is_metric(OGRSpatialReferenceH srs);

#endif
