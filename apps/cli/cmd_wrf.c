/* cmd_wrf.c — `squall wrf info FILE...` (domain, projection, times, hydrometeors, value ranges;
 * text or --json) and `squall wrf export FILE... --time N -o OUT.nc` (the derived fields of one
 * time as CF-1.8 NetCDF). Several files form one time series. Bad input: exit 2 with one line
 * naming the file and the variable, nothing written. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "commands.h"
#include "squall/wrf.h"

#define MAX_FILES 4096

static const char *const value_options[] = {"--time", "--at", "-o", "--output", "--threads", NULL};
static const char *const flag_options[] = {"--json", "--overwrite", "--quiet", "--verbose",
                                           "--help", "-h", NULL};

static void usage(FILE *f)
{
    fprintf(f,
            "usage: squall wrf info FILE... [--json]\n"
            "       squall wrf export FILE... (--time N | --at SECONDS) -o OUT.nc [--overwrite]\n\n"
            "WRF model output (wrfout, netCDF-3 or netCDF-4). Several files, or several times in\n"
            "one file, form one time series ordered by their Times.\n\n"
            "info    grid, map projection (MAP_PROJ, PROJ string), domain centre, the stored times\n"
            "        with the sun over the centre, the hydrometeors present and the value ranges of\n"
            "        the derived fields over every time (reads and checks every value)\n"
            "export  the derived fields of stored time N (0-based over the series), or of the time\n"
            "        SECONDS after the first (interpolated between stored times), as CF-1.8 NetCDF:\n"
            "        z (m), height_above_ground, pressure (Pa), theta, temperature (K), air_density,\n"
            "        qvapor, u, v, w, cloud_water, cloud_ice, snow, rain, graupel (g m-3; those the\n"
            "        file has), extinction (m-1), terrain_height and cloud_optical_depth on\n"
            "        (bottom_top, south_north, west_east) with lat/lon and the grid mapping\n\n"
            "options:\n"
            "  --json          info: one JSON object on stdout\n"
            "  --time N        export: stored time index (see wrf info)\n"
            "  --at SECONDS    export: seconds after the first stored time\n"
            "  -o, --output F  export: output file (written to a temporary name, then renamed)\n"
            "  --overwrite     export: replace an existing output\n"
            "  --threads N, --quiet, --verbose\n\n"
            "examples:\n"
            "  squall wrf info data/wrf/wrf_d01_allvars_cropped.nc\n"
            "  squall wrf export data/wrf/wrf_d01_allvars_cropped.nc --time 2 -o t2.nc\n"
            "  squall wrf info wrfout_d01_2020-06-21_* --json\n\n"
            "Formulas and units: docs/wrf.md. Exit codes: 0 success, 2 bad input or option.\n");
}

static bool in_list(const char *s, const char *const *list)
{
    for (int i = 0; list[i]; i++)
        if (strcmp(s, list[i]) == 0) return true;
    return false;
}

/* Collects the positional FILE arguments after the sub-command; rejects unknown options. */
static bool collect_files(int argc, char **argv, const char **files, int *count)
{
    *count = 0;
    for (int i = 2; i < argc; i++) {
        const char *a = argv[i];
        if (a[0] == '-' && a[1]) {
            const char *eq = strchr(a, '=');
            char name[64];
            snprintf(name, sizeof name, "%.*s", eq ? (int)(eq - a) : (int)strlen(a), a);
            if (in_list(name, value_options)) {
                if (!eq) i++;
                continue;
            }
            if (in_list(a, flag_options)) continue;
            sq_cli_error("wrf %s: unknown option '%s' (see squall wrf --help)", argv[1], a);
            return false;
        }
        if (*count >= MAX_FILES) {
            sq_cli_error("wrf %s: more than %d files", argv[1], MAX_FILES);
            return false;
        }
        files[(*count)++] = a;
    }
    if (*count == 0) {
        sq_cli_error("wrf %s: no WRF file given (usage: squall wrf %s FILE...)", argv[1], argv[1]);
        return false;
    }
    return true;
}

static void print_json_string(const char *s)
{
    putchar('"');
    for (; s && *s; s++) {
        const unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\')
            printf("\\%c", c);
        else if (c < 0x20)
            printf("\\u%04x", c);
        else
            putchar(c);
    }
    putchar('"');
}

static void json_range(const char *key, sq_wrf_range r, bool comma)
{
    printf("%s\"%s\": [%.9g, %.9g]", comma ? ", " : "", key, r.min, r.max);
}

static void print_info_json(const sq_wrf_info *in, const sq_wrf_ranges *g, sq_wrf *w,
                            const char **files, int nfiles)
{
    printf("{\"files\": [");
    for (int i = 0; i < nfiles; i++) {
        if (i) printf(", ");
        print_json_string(files[i]);
    }
    printf("], \"title\": ");
    print_json_string(in->title);
    printf(", \"nx\": %d, \"ny\": %d, \"nz\": %d, \"dx_m\": %.9g, \"dy_m\": %.9g", in->nx, in->ny,
           in->nz, in->dx_m, in->dy_m);
    printf(", \"map_proj\": %d, \"projection\": ", in->map_proj);
    print_json_string(in->projection_name);
    printf(", \"truelat1\": %.9g, \"truelat2\": %.9g, \"stand_lon\": %.9g, \"moad_cen_lat\": %.9g"
           ", \"pole_lat\": %.9g, \"pole_lon\": %.9g",
           in->truelat1_deg, in->truelat2_deg, in->stand_lon_deg, in->moad_cen_lat_deg,
           in->pole_lat_deg, in->pole_lon_deg);
    printf(", \"proj_string\": ");
    print_json_string(in->proj_string);
    printf(", \"center_lat\": %.9g, \"center_lon\": %.9g, \"north_rotation_deg\": %.9g",
           in->center_lat_deg, in->center_lon_deg, in->north_rotation_deg);
    printf(", \"crs_offset_m\": [%.9g, %.9g]", in->crs_offset_m[0], in->crs_offset_m[1]);
    printf(", \"mp_physics\": %d, \"hydrometeors\": [", in->mp_physics);
    int k = 0;
    for (int s = 0; s < SQ_WRF_SPECIES_COUNT; s++)
        if (in->has_species[s]) {
            if (k++) printf(", ");
            print_json_string(sq_wrf_species_name((sq_wrf_species)s));
        }
    printf("], \"ice_number\": %s, \"rain_number\": %s", in->has_ice_number ? "true" : "false",
           in->has_rain_number ? "true" : "false");
    printf(", \"times\": [");
    for (int t = 0; t < in->time_count; t++) {
        sq_sun_position p;
        sq_wrf_sun(w, in->times_s[t], &p, NULL);
        printf("%s{\"index\": %d, \"time\": ", t ? ", " : "", t);
        print_json_string(in->time_strings[t]);
        printf(", \"seconds\": %.9g, \"sun_elevation_deg\": %.4f, \"sun_azimuth_deg\": %.4f}",
               in->times_s[t], p.elevation_deg, p.azimuth_deg);
    }
    printf("], \"ranges\": {");
    json_range("z_m", g->z_m, false);
    json_range("height_above_ground_m", g->height_agl_m, true);
    json_range("pressure_pa", g->p_pa, true);
    json_range("theta_k", g->theta_k, true);
    json_range("temperature_k", g->t_k, true);
    json_range("air_density_kg_m3", g->rho_kg_m3, true);
    json_range("qvapor_kg_kg", g->qv_kg_kg, true);
    json_range("u_mps", g->u_mps, true);
    json_range("v_mps", g->v_mps, true);
    json_range("w_mps", g->w_mps, true);
    json_range("terrain_m", g->terrain_m, true);
    json_range("lat_deg", g->lat_deg, true);
    json_range("lon_deg", g->lon_deg, true);
    for (int s = 0; s < SQ_WRF_SPECIES_COUNT; s++)
        if (in->has_species[s]) {
            char key[48];
            snprintf(key, sizeof key, "%s_g_m3", sq_wrf_species_name((sq_wrf_species)s));
            json_range(key, g->q_g_m3[s], true);
        }
    if (in->has_cloud_fraction) json_range("cloud_fraction", g->cloud_fraction, true);
    printf("}, \"z_top_m\": %.9g, \"cloudy_fraction\": %.9g, \"clamped_negative\": %lld, "
           "\"cloud_fraction_is_flag\": %s}\n",
           g->z_top_m, g->cloudy_fraction, (long long)g->clamped_negative,
           in->has_cloud_fraction && g->cloud_fraction_is_flag ? "true" : "false");
}

static void text_range(const char *label, const char *unit, sq_wrf_range r)
{
    printf("  %-22s %12.6g .. %-12.6g %s\n", label, r.min, r.max, unit);
}

static void print_info_text(const sq_wrf_info *in, const sq_wrf_ranges *g, sq_wrf *w,
                            const char **files, int nfiles)
{
    printf("files:        %d (%s%s)\n", nfiles, files[0], nfiles > 1 ? ", ..." : "");
    if (in->title && *in->title) printf("title:        %s\n", in->title);
    printf("grid:         %d x %d mass points x %d levels, DX = %g m, DY = %g m (%.0f x %.0f km)\n",
           in->nx, in->ny, in->nz, in->dx_m, in->dy_m, (in->nx - 1) * in->dx_m / 1000.0,
           (in->ny - 1) * in->dy_m / 1000.0);
    printf("projection:   %s (MAP_PROJ %d): TRUELAT1 %g, TRUELAT2 %g, STAND_LON %g, "
           "MOAD_CEN_LAT %g%s\n",
           in->projection_name, in->map_proj, in->truelat1_deg, in->truelat2_deg,
           in->stand_lon_deg, in->moad_cen_lat_deg, in->map_proj == 6 ? "" : "");
    printf("PROJ:         %s\n", in->proj_string);
    printf("centre:       %.4f %s, %.4f %s; true north is %.3f deg %s of grid north\n",
           fabs(in->center_lat_deg), in->center_lat_deg >= 0 ? "N" : "S",
           fabs(in->center_lon_deg), in->center_lon_deg >= 0 ? "E" : "W",
           fabs(in->north_rotation_deg), in->north_rotation_deg >= 0 ? "east" : "west");
    printf("hydrometeors:");
    for (int s = 0; s < SQ_WRF_SPECIES_COUNT; s++)
        if (in->has_species[s])
            printf(" %s (%s)", sq_wrf_species_name((sq_wrf_species)s),
                   sq_wrf_species_variable((sq_wrf_species)s));
    if (in->has_ice_number || in->has_rain_number)
        printf("; numbers:%s%s", in->has_ice_number ? " QNICE" : "",
               in->has_rain_number ? " QNRAIN" : "");
    if (in->mp_physics >= 0) printf("; MP_PHYSICS %d", in->mp_physics);
    if (in->has_cloud_fraction) printf("; cloud fraction: CLDFRA");
    printf("\ntimes:        %d, %s .. %s UTC\n", in->time_count, in->time_strings[0],
           in->time_strings[in->time_count - 1]);
    for (int t = 0; t < in->time_count; t++) {
        sq_sun_position p;
        sq_wrf_sun(w, in->times_s[t], &p, NULL);
        const int minutes = (int)lround(p.true_solar_time_h * 60.0) % 1440;
        char dt[32];
        snprintf(dt, sizeof dt, "+%.0f s", in->times_s[t]);
        printf("  %4d  %s  %-10s  sun elevation %6.2f deg, azimuth %6.2f deg, true solar time "
               "%02d:%02d\n",
               t, in->time_strings[t], dt, p.elevation_deg, p.azimuth_deg, minutes / 60,
               minutes % 60);
    }
    printf("ranges over all times:\n");
    text_range("z", "m above sea level", g->z_m);
    text_range("height above ground", "m", g->height_agl_m);
    text_range("terrain (HGT)", "m", g->terrain_m);
    text_range("pressure", "Pa", g->p_pa);
    text_range("theta", "K", g->theta_k);
    text_range("temperature", "K", g->t_k);
    text_range("air density", "kg m-3", g->rho_kg_m3);
    text_range("QVAPOR", "kg kg-1", g->qv_kg_kg);
    text_range("u (grid x)", "m s-1", g->u_mps);
    text_range("v (grid y)", "m s-1", g->v_mps);
    text_range("w", "m s-1", g->w_mps);
    for (int s = 0; s < SQ_WRF_SPECIES_COUNT; s++)
        if (in->has_species[s]) text_range(sq_wrf_species_name((sq_wrf_species)s), "g m-3",
                                           g->q_g_m3[s]);
    if (in->has_cloud_fraction)
        text_range("cloud fraction (CLDFRA)",
                   g->cloud_fraction_is_flag ? "(only 0 and 1: a cloud flag)" : "1",
                   g->cloud_fraction);
    printf("  model top %.1f m; cloud water + ice > 1e-3 g m-3 in %.2f %% of cells; %lld tiny "
           "negative mixing ratios set to 0\n",
           g->z_top_m, 100.0 * g->cloudy_fraction, (long long)g->clamped_negative);
}

static int wrf_info(int argc, char **argv)
{
    const char **files = (const char **)calloc(MAX_FILES, sizeof(char *));
    int n = 0;
    if (!files || !collect_files(argc, argv, files, &n)) {
        free(files);
        return SQ_EXIT_USAGE;
    }
    sq_context *ctx = NULL;
    if (sq_cli_context(argc, argv, &ctx) != SQ_OK) {
        free(files);
        return SQ_EXIT_USAGE;
    }
    sq_wrf *w = NULL;
    sq_result r = sq_wrf_open(ctx, files, n, &w);
    sq_wrf_ranges g;
    if (r == SQ_OK) r = sq_wrf_scan(w, &g);
    if (r == SQ_OK) {
        sq_wrf_info in;
        sq_wrf_get_info(w, &in);
        if (sq_cli_flag(argc, argv, "--json"))
            print_info_json(&in, &g, w, files, n);
        else
            print_info_text(&in, &g, w, files, n);
    } else {
        sq_cli_error("%s", sq_last_error());
    }
    sq_wrf_close(w);
    sq_context_destroy(ctx);
    free(files);
    return sq_cli_exit_code(r);
}

static int wrf_export(int argc, char **argv)
{
    const char *out = sq_cli_value(argc, argv, "-o");
    if (!out) out = sq_cli_value(argc, argv, "--output");
    const char *time_s = sq_cli_value(argc, argv, "--time");
    const char *at_s = sq_cli_value(argc, argv, "--at");
    if (!out || !*out) {
        sq_cli_error("wrf export: no output file; give -o OUT.nc");
        return SQ_EXIT_USAGE;
    }
    if (!time_s == !at_s) {
        sq_cli_error("wrf export: give exactly one of --time N (stored time index) and --at "
                     "SECONDS");
        return SQ_EXIT_USAGE;
    }
    sq_wrf_export_desc d = {0};
    d.path = out;
    d.overwrite = sq_cli_flag(argc, argv, "--overwrite");
    char *end = NULL;
    if (time_s) {
        const long v = strtol(time_s, &end, 10);
        if (!*time_s || *end || v < 0 || v > 1000000000L) {
            sq_cli_error("wrf export: --time %s: expected a stored time index, a whole number "
                         ">= 0 (see squall wrf info)",
                         time_s);
            return SQ_EXIT_USAGE;
        }
        d.index = (int)v;
    } else {
        d.index = -1;
        d.time_s = strtod(at_s, &end);
        if (!*at_s || *end || !isfinite(d.time_s)) {
            sq_cli_error("wrf export: --at %s: expected seconds after the first stored time",
                         at_s);
            return SQ_EXIT_USAGE;
        }
    }
    const char **files = (const char **)calloc(MAX_FILES, sizeof(char *));
    int n = 0;
    if (!files || !collect_files(argc, argv, files, &n)) {
        free(files);
        return SQ_EXIT_USAGE;
    }
    sq_context *ctx = NULL;
    if (sq_cli_context(argc, argv, &ctx) != SQ_OK) {
        free(files);
        return SQ_EXIT_USAGE;
    }
    sq_wrf *w = NULL;
    sq_result r = sq_wrf_open(ctx, files, n, &w);
    if (r == SQ_OK) r = sq_wrf_export_netcdf(w, &d);
    if (r != SQ_OK) sq_cli_error("%s", sq_last_error());
    sq_wrf_close(w);
    sq_context_destroy(ctx);
    free(files);
    return sq_cli_exit_code(r);
}

int sq_cmd_wrf(int argc, char **argv)
{
    if (argc < 2 || strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0) {
        usage(argc < 2 ? stderr : stdout);
        return argc < 2 ? SQ_EXIT_USAGE : SQ_EXIT_OK;
    }
    if (sq_cli_flag(argc, argv, "--help") || sq_cli_flag(argc, argv, "-h")) {
        usage(stdout);
        return SQ_EXIT_OK;
    }
    if (strcmp(argv[1], "info") == 0) return wrf_info(argc, argv);
    if (strcmp(argv[1], "export") == 0) return wrf_export(argc, argv);
    sq_cli_error("wrf: unknown sub-command '%s'; use info or export (see squall wrf --help)",
                 argv[1]);
    return SQ_EXIT_USAGE;
}
