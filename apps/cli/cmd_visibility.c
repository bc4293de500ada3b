/* cmd_visibility.c — `squall visibility`: Koschmieder visibility of a dust population from its
 * mass concentration, log-normal size distribution and refractive index (SPEC §2.4, §2.7), or the
 * inverse (the concentration for a given visibility). Bulk optics by exact Mie (default) or ADA
 * at one wavelength (default 550 nm). Units are explicit on every dimensional option. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "commands.h"
#include "squall/optics.h"

/* Representative urban (transported, fine) dust of docs/phen/sandstorm-optics.md: the
 * Dubovik/ecaeropt log-normal, r_m = 0.29 µm, sigma_g = 2.0. */
#define VIS_DEFAULT_RADIUS_M 0.29e-6
#define VIS_DEFAULT_SIGMA_G 2.0

typedef struct unit {
    const char *name;
    double to_si;
} unit;

static const unit conc_units[] = {
    {"kg/m3", 1.0}, {"g/m3", 1e-3}, {"mg/m3", 1e-6}, {"ug/m3", 1e-9}, {"µg/m3", 1e-9}, {NULL, 0}};
static const unit length_units[] = {
    {"m", 1.0}, {"mm", 1e-3}, {"um", 1e-6}, {"µm", 1e-6}, {"nm", 1e-9}, {NULL, 0}};
static const unit vis_units[] = {{"m", 1.0}, {"km", 1e3}, {NULL, 0}};
static const unit density_units[] = {{"kg/m3", 1.0}, {"g/cm3", 1e3}, {NULL, 0}};

static const char *const value_options[] = {
    "--concentration", "--visibility", "--median-radius", "--sigma-g", "--density", "--n-real",
    "--n-imag", "--wavelength", "--threshold", "--method", NULL};
static const char *const flag_options[] = {"--json", "--help", "-h", NULL};

static void usage(void)
{
    printf(
        "usage: squall visibility --concentration VALUE [options]\n"
        "       squall visibility --visibility VALUE [options]   (the inverse)\n\n"
        "Koschmieder visibility V = ln(1/threshold) / beta_ext of a log-normal dust population,\n"
        "with beta_ext = concentration x mass extinction k_ext from exact Mie (or ADA) at one\n"
        "wavelength (SPEC §2.4, §2.7). With --visibility it prints the concentration needed.\n\n"
        "options (units are part of the value, e.g. 5000ug/m3, 2um, 550nm):\n"
        "  --concentration VALUE  dust mass concentration; units kg/m3, g/m3, mg/m3, ug/m3\n"
        "                         (or µg/m3); required unless --visibility is given\n"
        "  --visibility VALUE     target visibility, units m or km (prints the concentration)\n"
        "  --median-radius VALUE  number median radius r_m; units m, mm, um (µm), nm;\n"
        "                         default 0.29um (transported fine dust, Dubovik et al. 2002)\n"
        "  --sigma-g VALUE        geometric standard deviation, > 1; default 2.0\n"
        "  --density VALUE        particle density, kg/m3 (default unit) or g/cm3; default 2650\n"
        "  --wavelength VALUE     units nm, um (µm), m; default 550nm\n"
        "  --n-real VALUE         real refractive index; default 1.53 (mineral dust)\n"
        "  --n-imag VALUE         absorbing part k >= 0 of m = n + ik; default dust at the\n"
        "                         wavelength (fresh Saharan dust): 0.00124 at 450nm, 0.0010 at\n"
        "                         550nm, 0.00076 at 650nm\n"
        "  --threshold VALUE      contrast threshold in (0, 1); default 0.05 (WMO MOR, S0);\n"
        "                         the Met Office UM and UPP use 0.02\n"
        "  --method mie|ada       exact Lorenz-Mie (default) or van de Hulst ADA\n"
        "  --json                 one JSON object: extinction_per_m, mass_extinction_m2_per_g,\n"
        "                         visibility_m, concentration_kg_m3, the inputs, albedo, g\n\n"
        "examples:\n"
        "  squall visibility --concentration 5000ug/m3 --median-radius 2um --sigma-g 2 --json\n"
        "  squall visibility --visibility 600m --median-radius 0.29um --sigma-g 2.0\n\n"
        "exit codes: 0 success, 2 bad option (the message names the option and the rule)\n");
}

static void unit_list(const unit *u, char *buf, size_t n)
{
    buf[0] = 0;
    for (int i = 0; u[i].name; i++) {
        strncat(buf, i ? ", " : "", n - strlen(buf) - 1);
        strncat(buf, u[i].name, n - strlen(buf) - 1);
    }
}

/* Parses "NUMBER[ ]UNIT" into SI. unit_required: a bare number is an error; otherwise a bare
 * number is in units[0]. Prints the error itself. */
static bool parse_quantity(const char *opt, const char *text, const unit *units,
                           bool unit_required, const char *example, double *out)
{
    char list[128];
    unit_list(units, list, sizeof list);
    char *end = NULL;
    const double v = strtod(text, &end);
    if (!*text || end == text || !isfinite(v)) {
        sq_cli_error("%s '%s': expected a number with a unit (%s), e.g. %s", opt, text, list,
                     example);
        return false;
    }
    while (*end == ' ') end++;
    if (!*end) {
        if (unit_required) {
            sq_cli_error("%s %s: a unit is required, one of %s (e.g. %s)", opt, text, list,
                         example);
            return false;
        }
        *out = v * units[0].to_si;
        return true;
    }
    /* accept "m^3" for "m3" */
    char u[32];
    size_t k = 0;
    for (const char *p = end; *p && k + 1 < sizeof u; p++)
        if (*p != '^') u[k++] = *p;
    u[k] = 0;
    for (int i = 0; units[i].name; i++)
        if (strcmp(u, units[i].name) == 0) {
            *out = v * units[i].to_si;
            return true;
        }
    sq_cli_error("%s %s: unknown unit '%s'; use one of %s (e.g. %s)", opt, text, end, list,
                 example);
    return false;
}

static bool parse_plain(const char *opt, const char *text, double *out)
{
    char *end = NULL;
    const double v = strtod(text, &end);
    if (!*text || end == text || *end || !isfinite(v)) {
        sq_cli_error("%s '%s': expected a number", opt, text);
        return false;
    }
    *out = v;
    return true;
}

static bool in_list(const char *s, const char *const *list)
{
    for (int i = 0; list[i]; i++) {
        const size_t n = strlen(list[i]);
        if (strcmp(s, list[i]) == 0 || (strncmp(s, list[i], n) == 0 && s[n] == '=')) return true;
    }
    return false;
}

int sq_cmd_visibility(int argc, char **argv)
{
    if (sq_cli_flag(argc, argv, "--help") || sq_cli_flag(argc, argv, "-h")) {
        usage();
        return SQ_EXIT_OK;
    }
    for (int i = 1; i < argc; i++) {
        if (in_list(argv[i], flag_options)) continue;
        if (in_list(argv[i], value_options)) {
            if (!strchr(argv[i], '=')) {
                if (i + 1 >= argc) {
                    sq_cli_error("%s needs a value (see squall visibility --help)", argv[i]);
                    return SQ_EXIT_USAGE;
                }
                i++;
            }
            continue;
        }
        sq_cli_error("unknown option '%s' (see squall visibility --help)", argv[i]);
        return SQ_EXIT_USAGE;
    }

    const char *conc_s = sq_cli_value(argc, argv, "--concentration");
    const char *vis_s = sq_cli_value(argc, argv, "--visibility");
    if (!conc_s == !vis_s) {
        sq_cli_error("--concentration or --visibility: give exactly one (e.g. --concentration "
                     "5000ug/m3); see squall visibility --help");
        return SQ_EXIT_USAGE;
    }
    double conc = 0, vis_target = 0;
    if (conc_s) {
        if (!parse_quantity("--concentration", conc_s, conc_units, true, "5000ug/m3", &conc))
            return SQ_EXIT_USAGE;
        if (conc < 0) {
            sq_cli_error("--concentration %s: must be >= 0", conc_s);
            return SQ_EXIT_USAGE;
        }
    } else {
        if (!parse_quantity("--visibility", vis_s, vis_units, true, "600m", &vis_target))
            return SQ_EXIT_USAGE;
        if (!(vis_target > 0)) {
            sq_cli_error("--visibility %s: must be > 0", vis_s);
            return SQ_EXIT_USAGE;
        }
    }

    double radius = VIS_DEFAULT_RADIUS_M, sigma_g = VIS_DEFAULT_SIGMA_G, density = 2650.0;
    double wavelength = 550e-9, threshold = SQ_VISIBILITY_CONTRAST_DEFAULT;
    const char *s;
    if ((s = sq_cli_value(argc, argv, "--median-radius"))) {
        if (!parse_quantity("--median-radius", s, length_units, true, "2um", &radius))
            return SQ_EXIT_USAGE;
        if (!(radius > 0)) {
            sq_cli_error("--median-radius %s: the median radius must be > 0", s);
            return SQ_EXIT_USAGE;
        }
    }
    if ((s = sq_cli_value(argc, argv, "--sigma-g"))) {
        if (!parse_plain("--sigma-g", s, &sigma_g)) return SQ_EXIT_USAGE;
        if (!(sigma_g > 1)) {
            sq_cli_error("--sigma-g %s: the geometric standard deviation must be > 1 (e.g. 2.0; "
                         "1 would be a single size)",
                         s);
            return SQ_EXIT_USAGE;
        }
    }
    if ((s = sq_cli_value(argc, argv, "--density"))) {
        if (!parse_quantity("--density", s, density_units, false, "2650kg/m3", &density))
            return SQ_EXIT_USAGE;
        if (!(density > 0)) {
            sq_cli_error("--density %s: the particle density must be > 0", s);
            return SQ_EXIT_USAGE;
        }
    }
    if ((s = sq_cli_value(argc, argv, "--wavelength"))) {
        if (!parse_quantity("--wavelength", s, length_units, true, "550nm", &wavelength))
            return SQ_EXIT_USAGE;
        if (!(wavelength > 0)) {
            sq_cli_error("--wavelength %s: must be > 0", s);
            return SQ_EXIT_USAGE;
        }
    }
    if ((s = sq_cli_value(argc, argv, "--threshold"))) {
        if (!parse_plain("--threshold", s, &threshold)) return SQ_EXIT_USAGE;
        if (!(threshold > 0 && threshold < 1)) {
            sq_cli_error("--threshold %s: the contrast threshold must be in (0, 1), e.g. 0.05",
                         s);
            return SQ_EXIT_USAGE;
        }
    }
    double n_real, n_imag;
    (void)sq_dust_refractive_index(wavelength, &n_real, &n_imag);
    if ((s = sq_cli_value(argc, argv, "--n-real"))) {
        if (!parse_plain("--n-real", s, &n_real)) return SQ_EXIT_USAGE;
        if (!(n_real > 0)) {
            sq_cli_error("--n-real %s: the real refractive index must be > 0", s);
            return SQ_EXIT_USAGE;
        }
    }
    if ((s = sq_cli_value(argc, argv, "--n-imag"))) {
        if (!parse_plain("--n-imag", s, &n_imag)) return SQ_EXIT_USAGE;
        if (!(n_imag >= 0)) {
            sq_cli_error("--n-imag %s: must be >= 0 (m = n + ik, k >= 0 absorbs; give the "
                         "magnitude for an n - ik convention)",
                         s);
            return SQ_EXIT_USAGE;
        }
    }
    sq_optics_method method = SQ_OPTICS_MIE;
    if ((s = sq_cli_value(argc, argv, "--method"))) {
        if (strcmp(s, "mie") == 0) method = SQ_OPTICS_MIE;
        else if (strcmp(s, "ada") == 0) method = SQ_OPTICS_ADA;
        else {
            sq_cli_error("--method %s: expected mie or ada", s);
            return SQ_EXIT_USAGE;
        }
    }

    sq_bulk_optics_desc bd = {.wavelength_m = wavelength,
                              .n_real = n_real,
                              .n_imag = n_imag,
                              .density_kg_m3 = density,
                              .method = method};
    sq_result r = sq_lognormal_make(radius, sigma_g, &bd.size);
    sq_bulk_optics b;
    if (r == SQ_OK) r = sq_bulk_optics_compute(&bd, &b);
    double vis = 0, beta = 0, number = 0;
    if (r == SQ_OK && vis_s)
        r = sq_concentration_for_visibility(vis_target, b.mass_extinction_m2_per_kg, threshold,
                                            &conc);
    if (r == SQ_OK) r = sq_visibility_from_concentration(conc, b.mass_extinction_m2_per_kg,
                                                         threshold, &vis);
    if (r == SQ_OK) r = sq_lognormal_number_density(&bd.size, conc, density, &number);
    if (r != SQ_OK) {
        sq_cli_error("%s", sq_last_error());
        return sq_cli_exit_code(r);
    }
    if (vis_s) vis = vis_target; /* exact round trip; avoid printing 599.9999 */
    beta = conc * b.mass_extinction_m2_per_kg;

    if (sq_cli_flag(argc, argv, "--json")) {
        sq_json j;
        sq_json_begin(&j);
        sq_json_num(&j, "extinction_per_m", beta);
        sq_json_num(&j, "mass_extinction_m2_per_g", b.mass_extinction_m2_per_kg * 1e-3);
        sq_json_num(&j, "visibility_m", vis);
        sq_json_num(&j, "concentration_kg_m3", conc);
        sq_json_num(&j, "median_radius_m", radius);
        sq_json_num(&j, "sigma_g", sigma_g);
        sq_json_num(&j, "density_kg_m3", density);
        sq_json_num(&j, "wavelength_m", wavelength);
        sq_json_num(&j, "n_real", n_real);
        sq_json_num(&j, "n_imag", n_imag);
        sq_json_num(&j, "threshold", threshold);
        sq_json_str(&j, "method", method == SQ_OPTICS_ADA ? "ada" : "mie");
        sq_json_num(&j, "single_scattering_albedo", b.single_scattering_albedo);
        sq_json_num(&j, "asymmetry", b.asymmetry);
        sq_json_num(&j, "effective_radius_m", b.effective_radius_m);
        sq_json_num(&j, "number_density_per_m3", number);
        sq_json_end(&j, stdout);
        return SQ_EXIT_OK;
    }
    printf("dust: r_m %.4g um, sigma_g %.4g, density %.4g kg/m3, m = %.4g + %.4gi at %.4g nm "
           "(%s)\n",
           radius * 1e6, sigma_g, density, n_real, n_imag, wavelength * 1e9,
           method == SQ_OPTICS_ADA ? "ADA" : "Mie");
    printf("mass extinction  %.4g m2/g   albedo %.4f   g %.4f   r_eff %.4g um\n",
           b.mass_extinction_m2_per_kg * 1e-3, b.single_scattering_albedo, b.asymmetry,
           b.effective_radius_m * 1e6);
    printf("concentration    %.4g kg/m3 (%.4g ug/m3, %.4g particles/cm3)\n", conc, conc * 1e9,
           number * 1e-6);
    printf("extinction       %.4g 1/m\n", beta);
    if (isfinite(vis))
        printf("visibility       %.4g m (contrast threshold %.3g)\n", vis, threshold);
    else
        printf("visibility       unlimited (no dust)\n");
    return SQ_EXIT_OK;
}
