/* scene_tables.c — parameter tables of the scene-file sections world, world.obstacles[],
 * camera, camera.path[] and output. Keys, units, defaults, ranges and docs. */
#include <stddef.h>
#include <string.h>

#include "scene_internal.h"

#define F(key, field, unit, def, lo, hi, doc)                                                  \
    {key, SQ_PARAM_FLOAT, unit, offsetof(S, field), def, lo, hi, NULL, NULL, 0, 0, 0, doc}
#define FZ(key, field, unit, def, lo, hi, doc)                                                 \
    {key, SQ_PARAM_FLOAT, unit, offsetof(S, field), def, lo, hi, NULL, NULL, 0, 0,            \
     SQ_PARAM_ZERO_IS_PHYSICAL, doc}
#define D(key, field, unit, def, lo, hi, doc)                                                  \
    {key, SQ_PARAM_DOUBLE, unit, offsetof(S, field), def, lo, hi, NULL, NULL, 0, 0, 0, doc}
#define I(key, field, unit, def, lo, hi, doc)                                                  \
    {key, SQ_PARAM_INT, unit, offsetof(S, field), def, lo, hi, NULL, NULL, 0, 0, 0, doc}
#define U64(key, field, def, doc)                                                              \
    {key, SQ_PARAM_U64, "", offsetof(S, field), def, 0, 0, NULL, NULL, 0, 0, 0, doc}
#define B(key, field, def, doc)                                                                \
    {key, SQ_PARAM_BOOL, "", offsetof(S, field), def, 0, 1, NULL, NULL, 0, 0, 0, doc}
#define E(key, field, def, choices, doc)                                                       \
    {key, SQ_PARAM_ENUM, "", offsetof(S, field), def, 0, 0, NULL, choices, 0, 0, 0, doc}
#define V3(key, field, unit, deftext, lo, hi, doc)                                             \
    {key, SQ_PARAM_VEC3, unit, offsetof(S, field), 0, lo, hi, deftext, NULL, 0, 0, 0, doc}
#define FL(key, field, cnt, unit, deftext, maxc, lo, hi, doc)                                  \
    {key, SQ_PARAM_FLOATS, unit, offsetof(S, field), 0, lo, hi, deftext, NULL, maxc,          \
     offsetof(S, cnt), 0, doc}
#define STR(key, field, deftext, doc)                                                          \
    {key, SQ_PARAM_STRING, "", offsetof(S, field), 0, 0, 0, deftext, NULL, 0, 0, 0, doc}
/* live entries (SQ_PARAM_LIVE): a change may apply to a running scene (camera, rendering) */
#define F_LIVE(key, field, unit, def, lo, hi, doc)                                             \
    {key, SQ_PARAM_FLOAT, unit, offsetof(S, field), def, lo, hi, NULL, NULL, 0, 0, SQ_PARAM_LIVE, doc}
#define FZ_LIVE(key, field, unit, def, lo, hi, doc)                                            \
    {key, SQ_PARAM_FLOAT, unit, offsetof(S, field), def, lo, hi, NULL, NULL, 0, 0,            \
     SQ_PARAM_ZERO_IS_PHYSICAL | SQ_PARAM_LIVE, doc}
#define I_LIVE(key, field, unit, def, lo, hi, doc)                                             \
    {key, SQ_PARAM_INT, unit, offsetof(S, field), def, lo, hi, NULL, NULL, 0, 0, SQ_PARAM_LIVE, doc}
#define B_LIVE(key, field, def, doc)                                                           \
    {key, SQ_PARAM_BOOL, "", offsetof(S, field), def, 0, 1, NULL, NULL, 0, 0, SQ_PARAM_LIVE, doc}
#define V3_LIVE(key, field, unit, deftext, lo, hi, doc)                                        \
    {key, SQ_PARAM_VEC3, unit, offsetof(S, field), 0, lo, hi, deftext, NULL, 0, 0, SQ_PARAM_LIVE, doc}

#define S sq__world_section
const sq_param sq__world_params[] = {
    E("terrain.kind", terrain_kind, 2, "default|flat|hills|dunes|mountain|heightmap|dem|wrf",
      "Terrain generator: flat, hills (fBm noise), dunes (transverse dunes with slip faces), "
      "mountain (a release slope into a run-out plain), heightmap (16-bit PNG), dem (any "
      "raster GDAL reads, reprojected to a metric CRS; see terrain.dem) or wrf (the terrain "
      "height HGT of a WRF file, georeferenced, with the sun of its times; see terrain.wrf)."),
    E("terrain.material", terrain_material, 0, "default|sand|snow|rock|grass|asphalt",
      "Ground cover: default follows the kind (sand on dunes, meadow elsewhere); snow for winter "
      "scenes, asphalt for cities."),
    FL("terrain.size_m", size_m, size_count, "m", "2000 2000", 2, 1, 1e6,
       "Extent of a procedural terrain along x (east) and y (north)."),
    FL("terrain.resolution", resolution, resolution_count, "1", "257 257", 2, 2, 8192,
       "Height samples along x and y of a procedural terrain."),
    FL("terrain.origin_m", origin_m, origin_count, "m", "", 2, -1e7, 1e7,
       "World x, y of the south-west corner; empty = terrain centred on the origin."),
    FZ("terrain.base_m", base_m, "m", 0, -1e4, 1e4, "Base elevation added everywhere."),
    F("terrain.relief_m", relief_m, "m", 60, 0, 1e4,
      "Height amplitude of procedural terrain (dune height for dunes)."),
    F("terrain.feature_m", feature_m, "m", 400, 1, 1e6,
      "Horizontal feature size: noise wavelength, dune spacing."),
    I("terrain.octaves", octaves, "1", 5, 1, 12, "Noise octaves (frequency x2, amplitude x1/2)."),
    F("terrain.slope_deg", slope_deg, "deg", 35, 1, 60,
      "Mountain terrain: inclination of the release slope (wet-snow avalanches start on "
      "slopes > 30 deg, S2 ch. 3)."),
    FZ("terrain.dune_dir_deg", dune_dir_deg, "deg", 0, -360, 360,
       "Dunes: azimuth of the crest normal (dominant wind direction), degrees from east."),
    U64("terrain.seed", terrain_seed, 1, "Seed of the terrain noise."),
    STR("terrain.heightmap", heightmap, "",
        "16-bit greyscale PNG heightmap (path relative to the scene file); row 0 is north."),
    F("terrain.metres_per_px", metres_per_px, "m", 10, 1e-3, 1e5, "Heightmap pixel size."),
    STR("terrain.wrf", wrf, "",
        "WRF output file (wrfout, path relative to the scene file) for terrain.kind = wrf: HGT "
        "of its first time on the model grid (x east, y north along the map projection, origin "
        "at the domain centre); the sun follows the file's times over the domain centre unless "
        "sun.direction or sun.date is given. docs/wrf.md."),
    F("terrain.snow_line_m", snow_line_m, "m", 0, 0, 9000,
      "With terrain.material snow: the snow line (m above sea level): snow above it, alpine "
      "meadow and scree below (a ~100 m band roughened by noise); rock on faces steeper than "
      "~45 deg at every altitude. 0 = snow everywhere (rock on the steep faces)."),
    F("terrain.vertical_exaggeration", vertical_exaggeration, "1", 1, 0.1, 100,
      "Multiplies every terrain height (for real terrain: a WRF domain is hundreds of km wide "
      "and a few km high); phenomena placed by height above sea level use the same factor."),
    FZ("terrain.height_min_m", height_min_m, "m", 0, -1e4, 1e4, "Height of heightmap value 0."),
    F("terrain.height_max_m", height_max_m, "m", 500, -1e4, 1e5,
      "Height of heightmap value 65535."),
    STR("terrain.dem", dem, "",
        "DEM file (GeoTIFF, ESRI ASCII grid, any raster GDAL reads; path relative to the scene "
        "file), band 1 in metres. Reprojected to terrain.crs, cropped to terrain.roi."),
    FL("terrain.roi", roi, roi_count, "1", "", 4, -1e8, 1e8,
       "DEM region of interest [xmin, ymin, xmax, ymax] in the DEM's own CRS (degrees for a "
       "geographic DEM); empty = the whole DEM. Must lie inside the DEM."),
    STR("terrain.crs", crs, "",
        "Metric CRS of the world for a DEM (e.g. EPSG:32632); empty = the DEM's own if it is "
        "projected in metres, else the UTM zone (WGS 84) of the region's centre; 'utm' forces "
        "that."),
    STR("terrain.dem_crs", dem_crs, "",
        "CRS of a DEM file that carries none (e.g. EPSG:4326); a DEM without a CRS is refused "
        "otherwise."),
    FZ("terrain.cell_m", cell_m, "m", 0, 0, 1e5,
       "DEM sample spacing after reprojection; 0 = the DEM's finer pixel side in metres."),
    E("terrain.nodata", nodata, 0, "fill|fail",
      "DEM samples without data: fill (inverse-distance interpolation from the valid samples; "
      "they stay marked, and avalanche releases on them are refused) or fail."),
    E("terrain.resampling", resampling, 0, "cubic|bilinear|cubicspline|nearest",
      "Resampling of the DEM onto the metric grid (cubic keeps slopes smooth)."),
    FL("terrain.crs_origin_m", crs_origin, crs_origin_count, "m", "", 2, -1e8, 1e8,
       "DEM: the CRS coordinates (easting, northing) that become world (0, 0); empty = the "
       "terrain's centre rounded to 100 m. Every world x, y (camera, release) is relative to "
       "it; outputs are georeferenced back."),
    V3("sun.direction", sun_direction, "1", "0 0 0", -1, 1,
       "Direction toward the sun (normalised); [0, 0, 0] = from day, hour and latitude."),
    I_LIVE("sun.day_of_year", day_of_year, "1", 172, 1, 366, "Day of the year for the sun position."),
    FZ_LIVE("sun.hour", hour, "h", 15, 0, 24, "Local solar time for the sun position."),
    FZ_LIVE("sun.latitude_deg", latitude_deg, "deg", 40, -90, 90, "Latitude for the sun position."),
    STR("sun.date", sun_date, "",
        "UTC date and time 'YYYY-MM-DD hh:mm:ss' at scene time 0: the sun then moves with the "
        "scene clock (precise position with the equation of time at latitude_deg, "
        "longitude_deg; day_of_year and hour are ignored). Empty = a fixed sun."),
    FZ("sun.longitude_deg", longitude_deg, "deg", 0, -180, 180,
       "Longitude (east) for the sun position with sun.date."),
    F_LIVE("sun.clock_scale", clock_scale, "1", 1, 1e-3, 1e6,
      "Seconds of sun time per second of scene time with sun.date (e.g. 1800: half an hour "
      "per second)."),
    F_LIVE("sun.irradiance_w_m2", irradiance, "W/m2", 1000, 1, 1500,
      "Direct normal solar irradiance at the ground (scales the light)."),
    F_LIVE("sky.turbidity", turbidity, "1", 3, 1.5, 12,
           "Haze of the analytic sky (2 clear, 10 hazy); the aerosol it adds falls off with a "
           "1.5 km scale height above sea level."),
    {"city.rows", SQ_PARAM_INT, "1", offsetof(S, city_rows), 0, 0, 32, NULL, NULL, 0, 0,
     SQ_PARAM_ZERO_IS_PHYSICAL, "Procedural city: rows of blocks (0 = no city)."},
    {"city.cols", SQ_PARAM_INT, "1", offsetof(S, city_cols), 0, 0, 32, NULL, NULL, 0, 0,
     SQ_PARAM_ZERO_IS_PHYSICAL, "Procedural city: columns of blocks."},
    F("city.block_m", city_block_m, "m", 40, 2, 1000, "Procedural city: building footprint."),
    F("city.street_m", city_street_m, "m", 20, 1, 1000, "Procedural city: street width."),
    F("city.height_min_m", city_height_min_m, "m", 10, 2, 500, "Lowest building."),
    F("city.height_max_m", city_height_max_m, "m", 60, 2, 800, "Tallest building."),
    V3("city.center", city_center, "m", "0 0 0", -1e7, 1e7, "Centre of the city (x, y; z unused)."),
    U64("city.seed", city_seed, 1, "Seed of the building heights."),
    E("place.kind", place_kind, 0, "none|suburb|town",
      "Procedural place built from meshes: suburb (houses with gable and hip roofs on garden "
      "plots, trees, cars, fences, a park with a pavilion) or town (blocks of town houses and "
      "apartment buildings, shops, street trees, a square); none = no place."),
    FL("place.size_m", place_size_m, place_size_count, "m", "1000 1000", 2, 100, 50000,
       "Extent of the place along x and y; it must lie on the terrain."),
    FL("place.center", place_center, place_center_count, "m", "0 0", 2, -1e7, 1e7,
       "Centre of the place (x, y)."),
    U64("place.seed", place_seed, 1, "Seed of the place: the same seed builds the same place."),
    F("place.tree_density", place_tree_density, "1", 1, 0.01, 10,
      "Multiplier of the trees per garden, park and street."),
};
const size_t sq__world_param_count = sizeof sq__world_params / sizeof sq__world_params[0];
#undef S

#define S sq__obstacle_item
const sq_param sq__obstacle_params[] = {
    E("kind", kind, 0, "box|house|fence", "box (building block), house (gable roof), fence."),
    FL("center", center, center_count, "m", "0 0", 3, -1e7, 1e7,
       "Footprint centre [x, y] (base on the terrain) or [x, y, z] (base at z)."),
    V3("size", size, "m", "10 10 10", 0.01, 1e4, "Footprint x, y and wall height z."),
    FZ("roof_m", roof_m, "m", 0, 0, 1e3, "house: ridge height above the walls (ridge along x)."),
    FZ("yaw_deg", yaw_deg, "deg", 0, -360, 360, "Rotation about the vertical axis."),
    V3("albedo", albedo, "1", "0 0 0", 0, 1, "Surface albedo; [0, 0, 0] = default per kind."),
};
const size_t sq__obstacle_param_count = sizeof sq__obstacle_params / sizeof sq__obstacle_params[0];
#undef S

#define S sq__mesh_item
const sq_param sq__mesh_params[] = {
    STR("file", file, "",
        "Mesh file (glTF 2.0 .gltf/.glb, OBJ, FBX, PLY), relative to the scene file."),
    FL("position", position, position_count, "m", "0 0", 3, -1e7, 1e7,
       "Where the mesh origin goes: [x, y] (on the terrain: the lowest ground under the "
       "footprint) or [x, y, z]."),
    FZ("yaw_deg", yaw_deg, "deg", 0, -360, 360,
       "Heading: rotation about the vertical axis, counter-clockwise seen from above."),
    FL("scale", scale, scale_count, "1", "1", 3, 1e-4, 1e4,
       "Scale factor: one number, or [x, y, z] along the mesh's own axes."),
    I("lods", lods, "1", 4, 1, 4,
      "Levels of detail: a file's single level is simplified by vertex clustering up to this "
      "many (1 = none)."),
    E("up", up, 0, "default|y|z",
      "The file's up axis: default = y for glTF, OBJ and FBX, z for PLY."),
    V3("color", color, "1", "0 0 0", 0, 1,
       "Colour for the mesh's tintable materials; [0, 0, 0] = the file's colours."),
};
const size_t sq__mesh_param_count = sizeof sq__mesh_params / sizeof sq__mesh_params[0];
#undef S

#define S sq__area_item
const sq_param sq__area_params[] = {
    STR("name", name, "", "Name the phenomena use (e.g. an avalanche's release.area)."),
    STR("file", file, "",
        "Vector file OGR reads (GeoJSON, Shapefile, GeoPackage; its polygons) or a raster mask "
        "GDAL reads (pixels neither 0 nor no-data); path relative to the scene file."),
    STR("attribute", attribute, "thickness",
        "Numeric attribute read per polygon (e.g. an avalanche release thickness in m); a "
        "polygon without it uses the phenomenon's default."),
    STR("layer", layer, "", "Vector layer; empty = the first."),
    STR("crs", crs, "", "CRS of a file that carries none (e.g. EPSG:4326)."),
};
const size_t sq__area_param_count = sizeof sq__area_params / sizeof sq__area_params[0];
#undef S

#define S sq__camera_section
const sq_param sq__camera_params[] = {
    V3_LIVE("position", position, "m", "-600 -600 120", -1e7, 1e7, "Eye position."),
    V3_LIVE("target", target, "m", "0 0 40", -1e7, 1e7, "Point looked at."),
    V3_LIVE("up", up, "1", "0 0 1", -1, 1, "Up direction."),
    F_LIVE("fov_deg", fov_deg, "deg", 50, 1, 170, "Vertical field of view."),
    F_LIVE("near_m", near_m, "m", 0.5, 1e-3, 1e4, "Near clipping distance."),
    F_LIVE("far_m", far_m, "m", 20000, 1, 1e7, "Far clipping distance."),
};
const size_t sq__camera_param_count = sizeof sq__camera_params / sizeof sq__camera_params[0];
#undef S

#define S sq__camera_key_item
const sq_param sq__camera_key_params[] = {
    D("t", t, "s", 0, 0, 1e7, "Time of this key (video seconds)."),
    V3("position", position, "m", "0 0 100", -1e7, 1e7, "Eye position at t."),
    V3("target", target, "m", "0 0 0", -1e7, 1e7, "Point looked at at t."),
    FZ("fov_deg", fov_deg, "deg", 0, 0, 170, "Field of view at t (0 = the camera's)."),
};
const size_t sq__camera_key_param_count =
    sizeof sq__camera_key_params / sizeof sq__camera_key_params[0];
#undef S

#define S sq_scene_output
const sq_param sq__output_params[] = {
    I("width", width, "px", 640, 16, 65536, "Frame width (even for MP4); the GL limit is checked when rendering."),
    I("height", height, "px", 360, 16, 65536, "Frame height (even for MP4); the GL limit is checked when rendering."),
    I("fps", fps, "1/s", 24, 1, 240, "Frames per second of the video."),
    D("duration_s", duration_s, "s", 10, 0.01, 36000, "Video length (frames = duration * fps)."),
    {"frames", SQ_PARAM_INT, "1", offsetof(S, frames), 0, 0, 1000000, NULL, NULL, 0, 0,
     SQ_PARAM_ZERO_IS_PHYSICAL, "Frame count; 0 = from duration_s."},
    I("steps_per_frame", steps_per_frame, "1", 1, 1, 1000,
      "Simulation steps per frame (each layer also sub-cycles to its stable step)."),
    D("time_scale", time_scale, "1", 1, 1e-3, 1e4,
      "Simulated seconds per video second (> 1 = time-lapse)."),
    {"warmup_s", SQ_PARAM_DOUBLE, "s", offsetof(S, warmup_s), 0, 0, 1e6, NULL, NULL, 0, 0,
     SQ_PARAM_ZERO_IS_PHYSICAL, "Simulated time stepped before the first frame."},
    STR("video", video, "out/squall.mp4", "H.264 MP4 output path (\"\" = no video)."),
    STR("frames_dir", frames_dir, "", "Directory for PNG frames frame_00000.png... (\"\" = none)."),
    STR("metrics", metrics, "", "Per-frame metrics CSV path (\"\" = none)."),
    STR("fields", fields, "",
        "Field output prefix: writes PREFIX_00012.nc / .vti (\"\" = none)."),
    {"fields_every", SQ_PARAM_INT, "1", offsetof(S, fields_every), 0, 0, 1000000, NULL, NULL, 0,
     0, SQ_PARAM_ZERO_IS_PHYSICAL, "Write fields every N frames; 0 = last frame only."},
    E("fields_format", fields_format, 0, "netcdf|vtk|both", "Field file format."),
    F_LIVE("exposure", exposure, "1", 1, 0.01, 100, "Linear exposure before tone mapping."),
    I_LIVE("volume_slices", volume_slices, "1", 128, 8, 1024, "Half-angle slices for volumes."),
    I_LIVE("light_buffer", light_buffer, "px", 256, 32, 4096, "Light buffer resolution for volumes."),
    B_LIVE("volume_noise", volume_noise, 1,
      "Perturb volume texture coordinates with noise for detail (S0 Fig. 3.12)."),
    {"shadow_cascades", SQ_PARAM_INT, "1", offsetof(S, shadow_cascades), 3, 0, 4, NULL, NULL, 0,
     0, SQ_PARAM_ZERO_IS_PHYSICAL,
     "Cascaded sun shadow maps of opaque geometry (docs/meshes.md); 0 = no opaque shadows."},
    I("shadow_map_size", shadow_map_size, "px", 2048, 64, 16384, "Texels per side of a cascade."),
    F("shadow_distance_m", shadow_distance_m, "m", 1500, 1, 1e6,
      "Opaque shadows up to this view depth, fading out over the last 15 %."),
    F("lod_pixels", lod_pixels, "px", 1, 0.1, 100,
      "World meshes: the coarsest level of detail whose geometric error projects below this."),
    F("cull_pixels", cull_pixels, "px", 0.5, 0.01, 100,
      "World meshes: instances whose bounding sphere projects below this radius are skipped."),
    {"mesh_distance_m", SQ_PARAM_FLOAT, "m", offsetof(S, mesh_distance_m), 0, 0, 1e7, NULL, NULL,
     0, 0, SQ_PARAM_ZERO_IS_PHYSICAL,
     "World meshes farther than this from the camera are not drawn (haze or falling snow hides "
     "them); 0 = no limit."},
};
const size_t sq__output_param_count = sizeof sq__output_params / sizeof sq__output_params[0];
#undef S

const sq_param *sq_scene_section_params(const char *section, size_t *count)
{
    struct {
        const char *name;
        const sq_param *p;
        size_t n;
    } t[] = {{"world", sq__world_params, sizeof sq__world_params / sizeof sq__world_params[0]},
             {"obstacle", sq__obstacle_params,
              sizeof sq__obstacle_params / sizeof sq__obstacle_params[0]},
             {"mesh", sq__mesh_params, sizeof sq__mesh_params / sizeof sq__mesh_params[0]},
             {"area", sq__area_params, sizeof sq__area_params / sizeof sq__area_params[0]},
             {"camera", sq__camera_params, sizeof sq__camera_params / sizeof sq__camera_params[0]},
             {"camera-key", sq__camera_key_params,
              sizeof sq__camera_key_params / sizeof sq__camera_key_params[0]},
             {"output", sq__output_params, sizeof sq__output_params / sizeof sq__output_params[0]}};
    for (size_t i = 0; i < sizeof t / sizeof t[0]; i++) {
        if (section && strcmp(section, t[i].name) == 0) {
            if (count) *count = t[i].n;
            return t[i].p;
        }
    }
    if (count) *count = 0;
    return NULL;
}
