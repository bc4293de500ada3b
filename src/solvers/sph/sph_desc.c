/* sph_desc.c — the SPH desc: defaults (resolve), validation with messages that name the
 * field, memory cost, and the rheology models of SPEC §7.4 (Newtonian, power law eq. 3.26,
 * Cross eq. 3.29 with μ₀ ≥ μ∞ — the OCR's reversed bound is not copied — and the
 * Papanastasiou-regularised Bingham model replacing the discontinuous eqs 3.27–3.28). */
#include <math.h>
#include <string.h>

#include "solvers/sph/sph_internal.h"

#define MOD "sph"

/* ---- rheology ------------------------------------------------------------------------------ */

sq_sph_rheology sq__sph_rheology_resolve(const sq_sph_rheology *in)
{
    sq_sph_rheology r = *in;
    if (r.kind == SQ_SPH_RHEOLOGY_DEFAULT) r.kind = SQ_SPH_RHEOLOGY_NEWTONIAN;
    if (r.bingham_m_s == 0.0) r.bingham_m_s = 100.0;
    if (r.shear_rate_min_per_s == 0.0) r.shear_rate_min_per_s = 1e-3;
    return r;
}

static double rheology_mu(const sq_sph_rheology *r, double g)
{
    double mu;
    if (!(g >= 0.0)) g = 0.0;
    switch (r->kind) {
    case SQ_SPH_RHEOLOGY_POWER_LAW: {
        double gg = g > r->shear_rate_min_per_s ? g : r->shear_rate_min_per_s;
        mu = r->k * pow(gg, r->n - 1.0);
        break;
    }
    case SQ_SPH_RHEOLOGY_CROSS:
        mu = r->mu_inf_pa_s + (r->mu0_pa_s - r->mu_inf_pa_s) / (1.0 + pow(r->k * g, r->n));
        break;
    case SQ_SPH_RHEOLOGY_BINGHAM: {
        double mg = r->bingham_m_s * g;
        /* (1 − e^(−mγ))/γ = m (1 − mγ/2 + (mγ)²/6 ...) for small mγ */
        double f = mg < 1e-4 ? r->bingham_m_s * (1.0 - 0.5 * mg) : -expm1(-mg) / g;
        mu = r->k + r->yield_stress_pa * f;
        break;
    }
    default: mu = r->mu_pa_s; break;
    }
    if (r->mu_max_pa_s > 0.0 && mu > r->mu_max_pa_s) mu = r->mu_max_pa_s;
    return mu;
}

double sq_sph_rheology_viscosity(const sq_sph_rheology *r, double shear_rate_per_s)
{
    if (!r) return 0.0;
    sq_sph_rheology rr = sq__sph_rheology_resolve(r);
    return rheology_mu(&rr, shear_rate_per_s);
}

void sq__sph_rheo_init(sq__sph_rheo *r, const sq_sph_rheology *in)
{
    sq_sph_rheology x = sq__sph_rheology_resolve(in);
    memset(r, 0, sizeof *r);
    r->kind = (int)x.kind;
    r->mu = (float)x.mu_pa_s;
    r->k = (float)x.k;
    r->n = (float)x.n;
    r->mu0 = (float)x.mu0_pa_s;
    r->mu_inf = (float)x.mu_inf_pa_s;
    r->tau_y = (float)x.yield_stress_pa;
    r->m = (float)x.bingham_m_s;
    r->gmin = (float)x.shear_rate_min_per_s;
    r->mu_cap = (float)x.mu_max_pa_s;
}

float sq__sph_rheo_mu(const sq__sph_rheo *r, float g)
{
    float mu;
    switch (r->kind) {
    case SQ_SPH_RHEOLOGY_POWER_LAW: {
        float gg = g > r->gmin ? g : r->gmin;
        mu = r->k * powf(gg, r->n - 1.0f);
        break;
    }
    case SQ_SPH_RHEOLOGY_CROSS: {
        float kg = r->k * g;
        float t = r->n == 2.0f ? kg * kg : powf(kg, r->n);
        mu = r->mu_inf + (r->mu0 - r->mu_inf) / (1.0f + t);
        break;
    }
    case SQ_SPH_RHEOLOGY_BINGHAM: {
        float mg = r->m * g;
        float f = mg < 1e-3f ? r->m * (1.0f - 0.5f * mg) : -expm1f(-mg) / g;
        mu = r->k + r->tau_y * f;
        break;
    }
    default: mu = r->mu; break;
    }
    if (r->mu_cap > 0.0f && mu > r->mu_cap) mu = r->mu_cap;
    return mu;
}

sq_result sq_sph_rheology_preset(const char *name, sq_sph_rheology *out)
{
    sq_sph_rheology r;
    memset(&r, 0, sizeof r);
    if (out) memset(out, 0, sizeof *out);
    if (!name || !out) return sq__set_error(SQ_ERR_INVALID_ARG, "sph rheology preset: NULL argument");
    if (strcmp(name, "s2-avalanche") == 0) {
        r.kind = SQ_SPH_RHEOLOGY_CROSS;
        r.mu_inf_pa_s = 1.0;
        r.mu0_pa_s = 100.0;
        r.n = 2.0;
        r.k = 3000.0;
    } else if (strcmp(name, "s2-cross-curve") == 0) {
        r.kind = SQ_SPH_RHEOLOGY_CROSS;
        r.mu_inf_pa_s = 1.0;
        r.mu0_pa_s = 200.0;
        r.n = 1.0;
        r.k = 300.0;
    } else if (strcmp(name, "water") == 0) {
        r.kind = SQ_SPH_RHEOLOGY_NEWTONIAN;
        r.mu_pa_s = 1.0e-3;
    } else {
        return sq__set_error(SQ_ERR_NOT_FOUND,
                             "sph rheology preset \"%s\" unknown; known: s2-avalanche, "
                             "s2-cross-curve, water",
                             name);
    }
    *out = r;
    return SQ_OK;
}

/* ---- desc ------------------------------------------------------------------------------- */

static double gravity_extent(const sq_sph_desc *d)
{
    double g2 = d->gravity_mps2[0] * d->gravity_mps2[0] + d->gravity_mps2[1] * d->gravity_mps2[1] +
                d->gravity_mps2[2] * d->gravity_mps2[2];
    if (!(g2 > 0.0)) return 0.0;
    double g = sqrt(g2), L = 0.0;
    for (int a = 0; a < 3; a++) L += fabs(d->gravity_mps2[a]) / g * (d->domain_max_m[a] - d->domain_min_m[a]);
    return L;
}

sq_sph_desc sq_sph_desc_resolve(const sq_sph_desc *in)
{
    sq_sph_desc d;
    if (in) d = *in;
    else memset(&d, 0, sizeof d);
    if (d.support_radius_m == 0.0) d.support_radius_m = 2.0 * d.spacing_m;
    if (d.rest_density_kgm3 == 0.0) d.rest_density_kgm3 = 1000.0;
    if (d.eos == SQ_SPH_EOS_DEFAULT) d.eos = SQ_SPH_EOS_LINEAR;
    if (d.kernel == SQ_SPH_KERNEL_DEFAULT) d.kernel = SQ_SPH_KERNEL_CUBIC;
    if (d.gradient == SQ_SPH_GRADIENT_DEFAULT) d.gradient = SQ_SPH_GRADIENT_CORRECTED;
    if (d.viscous == SQ_SPH_VISCOUS_DEFAULT) d.viscous = SQ_SPH_VISCOUS_MORRIS;
    d.rheology = sq__sph_rheology_resolve(&d.rheology);
    if (d.xsph_off) d.xsph_epsilon = 0.0;
    else if (d.xsph_epsilon == 0.0) d.xsph_epsilon = 0.5;
    for (int f = 0; f < 6; f++)
        if (d.boundary[f] == SQ_SPH_BOUNDARY_DEFAULT) d.boundary[f] = SQ_SPH_BOUNDARY_NO_SLIP;
    if (d.max_speed_mps == 0.0) {
        double gl = 0.0;
        double g2 = d.gravity_mps2[0] * d.gravity_mps2[0] + d.gravity_mps2[1] * d.gravity_mps2[1] +
                    d.gravity_mps2[2] * d.gravity_mps2[2];
        gl = gravity_extent(&d);
        d.max_speed_mps = (g2 > 0.0 && gl > 0.0) ? sqrt(2.0 * sqrt(g2) * gl) : 1.0;
    }
    if (d.speed_of_sound_mps == 0.0) d.speed_of_sound_mps = 10.0 * d.max_speed_mps;
    if (d.collision_radius_m == 0.0) d.collision_radius_m = 0.5 * d.spacing_m;
    if (d.max_substeps == 0) d.max_substeps = 100000;
    if (d.neighbour_capacity == 0 && d.spacing_m > 0.0 && d.support_radius_m > 0.0) {
        double ratio = d.support_radius_m / d.spacing_m;
        double expected = 4.0 / 3.0 * 3.14159265358979 * ratio * ratio * ratio;
        double c = 1.6 * expected + 8.0;
        if (c > 65000.0) c = 65000.0;
        int ci = (int)ceil(c);
        d.neighbour_capacity = (ci + 7) / 8 * 8;
    }
    return d;
}

static bool finite3(const double v[3])
{
    return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]);
}

static const char *face_name(int f)
{
    static const char *const names[6] = {"xmin", "xmax", "ymin", "ymax", "zmin", "zmax"};
    return names[f];
}

static sq_result validate_rheology(sq_context *ctx, const sq_sph_rheology *r)
{
    switch (r->kind) {
    case SQ_SPH_RHEOLOGY_NEWTONIAN:
        if (!(r->mu_pa_s >= 0.0) || !isfinite(r->mu_pa_s))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                            "rheology.mu_pa_s = %g; must be >= 0 (dynamic viscosity, Pa s)",
                            r->mu_pa_s);
        break;
    case SQ_SPH_RHEOLOGY_POWER_LAW:
        if (!(r->k > 0.0) || !isfinite(r->k))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                            "rheology.k = %g; the power-law consistency K must be > 0 (Pa s^n)",
                            r->k);
        if (!(r->n > 0.0) || !isfinite(r->n))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                            "rheology.n = %g; the power-law index n must be > 0", r->n);
        if (!(r->shear_rate_min_per_s > 0.0) || !isfinite(r->shear_rate_min_per_s))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                            "rheology.shear_rate_min_per_s = %g; must be > 0 (1/s)",
                            r->shear_rate_min_per_s);
        break;
    case SQ_SPH_RHEOLOGY_CROSS:
        if (!(r->mu_inf_pa_s >= 0.0) || !isfinite(r->mu_inf_pa_s))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                            "rheology.mu_inf_pa_s = %g; must be >= 0 (Pa s)", r->mu_inf_pa_s);
        if (!(r->mu0_pa_s >= r->mu_inf_pa_s) || !isfinite(r->mu0_pa_s))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                            "rheology.mu0_pa_s = %g < mu_inf_pa_s = %g; the Cross model needs "
                            "mu0 >= mu_inf (zero-shear viscosity above the infinite-shear one; "
                            "the thesis's reversed bound is an OCR error, SPEC 7.4)",
                            r->mu0_pa_s, r->mu_inf_pa_s);
        if (!(r->k > 0.0) || !isfinite(r->k))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                            "rheology.k = %g; the Cross time constant K must be > 0 (s)", r->k);
        if (!(r->n > 0.0) || !isfinite(r->n))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                            "rheology.n = %g; the Cross exponent n must be > 0", r->n);
        break;
    case SQ_SPH_RHEOLOGY_BINGHAM:
        if (!(r->k >= 0.0) || !isfinite(r->k))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                            "rheology.k = %g; the Bingham plastic viscosity must be >= 0 (Pa s)",
                            r->k);
        if (!(r->yield_stress_pa >= 0.0) || !isfinite(r->yield_stress_pa))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                            "rheology.yield_stress_pa = %g; must be >= 0 (Pa)", r->yield_stress_pa);
        if (!(r->bingham_m_s > 0.0) || !isfinite(r->bingham_m_s))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                            "rheology.bingham_m_s = %g; the Papanastasiou exponent must be > 0 (s)",
                            r->bingham_m_s);
        break;
    default:
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "rheology.kind = %d; must be one of NEWTONIAN, POWER_LAW, CROSS, BINGHAM",
                        (int)r->kind);
    }
    if (!(r->mu_max_pa_s >= 0.0) || !isfinite(r->mu_max_pa_s))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "rheology.mu_max_pa_s = %g; must be >= 0 (0 = no cap)", r->mu_max_pa_s);
    return SQ_OK;
}

/* Cells per axis for the neighbour grid (cell size >= H); with a terrain-following grid n[2] is
 * the cells of one column (sq__sph_column_cells). */
static void grid_dims(const sq_sph_desc *d, uint64_t n[3])
{
    for (int a = 0; a < 3; a++) {
        double L = d->domain_max_m[a] - d->domain_min_m[a];
        double c = floor(L / d->support_radius_m);
        if (!(c >= 1.0)) c = 1.0;
        if (c > 4e9) c = 4e9;
        n[a] = (uint64_t)c;
    }
    if (d->terrain_layer_m > 0.0) {
        const double cz = (d->domain_max_m[2] - d->domain_min_m[2]) / (double)n[2];
        const uint64_t nc = (uint64_t)sq__sph_column_cells(d->terrain_layer_m, cz);
        if (nc < n[2]) n[2] = nc;
    }
}

int sq__sph_column_cells(double layer_m, double cell_z)
{
    /* the layer, the terrain's relief under one column and its neighbours (one cell below the
     * lowest terrain), and a cell of margin */
    double c = ceil(layer_m / cell_z) + 3.0;
    return c > 1e6 ? 1000000 : (int)c;
}

sq_result sq__sph_validate(sq_context *ctx, const sq_sph_desc *in)
{
    if (!in) return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "desc is NULL");
    if (!(in->spacing_m > 0.0) || !isfinite(in->spacing_m))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "spacing_m = %g; the particle spacing must be > 0 (m)", in->spacing_m);
    if (!(in->support_radius_m >= 0.0) || !isfinite(in->support_radius_m))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "support_radius_m = %g; the kernel support must be > 0 (m; 0 = 2 x spacing)",
                        in->support_radius_m);
    sq_sph_desc d = sq_sph_desc_resolve(in);
    double ratio = d.support_radius_m / d.spacing_m;
    if (!(ratio >= 1.5 && ratio <= 8.0))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "support_radius_m = %g is %.3g x spacing_m = %g; must be 1.5 to 8 x the "
                        "spacing (about 14 to 2100 neighbours)",
                        d.support_radius_m, ratio, d.spacing_m);
    if (!(d.rest_density_kgm3 > 0.0) || !isfinite(d.rest_density_kgm3))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "rest_density_kgm3 = %g; must be > 0 (kg/m3)", d.rest_density_kgm3);
    if (d.eos != SQ_SPH_EOS_LINEAR && d.eos != SQ_SPH_EOS_TAIT)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "eos = %d; must be LINEAR or TAIT", (int)d.eos);
    if (!(d.max_speed_mps > 0.0) || !isfinite(d.max_speed_mps))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "max_speed_mps = %g; must be > 0 (m/s; 0 = from gravity and domain)",
                        in->max_speed_mps);
    if (!(d.speed_of_sound_mps > 0.0) || !isfinite(d.speed_of_sound_mps))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "speed_of_sound_mps = %g; must be > 0 (m/s; 0 = 10 x max_speed_mps)",
                        in->speed_of_sound_mps);
    if (d.kernel != SQ_SPH_KERNEL_MULLER && d.kernel != SQ_SPH_KERNEL_CUBIC)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "kernel = %d; must be MULLER or CUBIC",
                        (int)d.kernel);
    if (d.gradient != SQ_SPH_GRADIENT_CORRECTED && d.gradient != SQ_SPH_GRADIENT_PLAIN)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "gradient = %d; must be CORRECTED or PLAIN",
                        (int)d.gradient);
    if (d.viscous != SQ_SPH_VISCOUS_MORRIS && d.viscous != SQ_SPH_VISCOUS_MULLER &&
        d.viscous != SQ_SPH_VISCOUS_TENSOR)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "viscous = %d; must be MORRIS, MULLER or TENSOR",
                        (int)d.viscous);
    sq_result r = validate_rheology(ctx, &d.rheology);
    if (r != SQ_OK) return r;
    if (!(d.background_pressure_pa >= 0.0) || !isfinite(d.background_pressure_pa))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "background_pressure_pa = %g; must be >= 0 (Pa)", d.background_pressure_pa);
    if (!(d.artificial_viscosity >= 0.0 && d.artificial_viscosity <= 1.0))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "artificial_viscosity = %g; Monaghan's alpha must be in [0, 1]",
                        d.artificial_viscosity);
    if (!(d.xsph_epsilon >= 0.0 && d.xsph_epsilon <= 1.0))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "xsph_epsilon = %g; must be in [0, 1] (S2 uses 0.5)", d.xsph_epsilon);
    if (!finite3(d.gravity_mps2))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "gravity_mps2 is not finite");
    if (!finite3(d.domain_min_m) || !finite3(d.domain_max_m))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "domain_min_m/domain_max_m not finite");
    for (int a = 0; a < 3; a++) {
        const char *ax = a == 0 ? "x" : a == 1 ? "y" : "z";
        double L = d.domain_max_m[a] - d.domain_min_m[a];
        if (!(L > 0.0))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                            "domain %s: min %g >= max %g; every axis needs max > min (m)", ax,
                            d.domain_min_m[a], d.domain_max_m[a]);
        for (int s = 0; s < 2; s++) {
            int f = 2 * a + s;
            if (d.boundary[f] < SQ_SPH_BOUNDARY_NO_SLIP || d.boundary[f] > SQ_SPH_BOUNDARY_PERIODIC)
                return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                                "boundary[%s] = %d; must be NO_SLIP, FREE_SLIP, OPEN or PERIODIC",
                                face_name(f), (int)d.boundary[f]);
        }
        int p0 = d.boundary[2 * a] == SQ_SPH_BOUNDARY_PERIODIC;
        int p1 = d.boundary[2 * a + 1] == SQ_SPH_BOUNDARY_PERIODIC;
        if (p0 != p1)
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                            "boundary[%s] is %speriodic but boundary[%s] is %s; periodic must be "
                            "set on both faces of an axis",
                            face_name(2 * a), p0 ? "" : "not ", face_name(2 * a + 1),
                            p1 ? "periodic" : "not");
        if (p0 && L < 3.0 * d.support_radius_m)
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                            "domain %s length %g m with periodic boundaries; must be >= 3 x "
                            "support_radius_m = %g m (three neighbour cells)",
                            ax, L, 3.0 * d.support_radius_m);
        int wall = d.boundary[2 * a] <= SQ_SPH_BOUNDARY_FREE_SLIP ||
                   d.boundary[2 * a + 1] <= SQ_SPH_BOUNDARY_FREE_SLIP;
        if (wall && L < 2.0 * d.support_radius_m)
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                            "domain %s length %g m with walls; must be >= 2 x support_radius_m = "
                            "%g m (a particle may see one wall per axis)",
                            ax, L, 2.0 * d.support_radius_m);
    }
    if (!(d.collision_radius_m >= 0.0) || !isfinite(d.collision_radius_m))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "collision_radius_m = %g; must be >= 0 (m)", d.collision_radius_m);
    if (d.max_particles < 1)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "max_particles = 0; must be >= 1 (the capacity allocated at create)");
    if (d.max_particles > SQ__SPH_MAX_PARTICLES)
        return sq__fail(ctx, SQ_ERR_TOO_LARGE, MOD,
                        "max_particles = %zu; the implementation limit is %zu (29-bit indices)",
                        d.max_particles, SQ__SPH_MAX_PARTICLES);
    if (d.neighbour_capacity < 8 || d.neighbour_capacity > 65000)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "neighbour_capacity = %d; must be 8 to 65000 (0 = automatic)",
                        d.neighbour_capacity);
    if (d.max_substeps < 1)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "max_substeps = %d; must be >= 1",
                        d.max_substeps);
    if (!(d.dt_max_s >= 0.0) || !isfinite(d.dt_max_s))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "dt_max_s = %g; must be >= 0 (s)", d.dt_max_s);
    if (!(d.terrain_layer_m >= 0.0) || !isfinite(d.terrain_layer_m))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "terrain_layer_m = %g; must be >= 0 (m; 0 = a dense box grid)",
                        d.terrain_layer_m);
    if (d.terrain_layer_m > 0.0)
        for (int f = 0; f < 6; f++)
            if (d.boundary[f] != SQ_SPH_BOUNDARY_OPEN)
                return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                                "terrain_layer_m = %g m needs every face OPEN; boundary[%s] is "
                                "not", d.terrain_layer_m, face_name(f));
    uint64_t n[3];
    grid_dims(&d, n);
    double cells = (double)n[0] * (double)n[1] * (double)n[2];
    if (cells > 2.0e9)
        return sq__fail(ctx, SQ_ERR_TOO_LARGE, MOD,
                        "neighbour grid %llux%llux%llu = %.3g cells (domain / support_radius_m); "
                        "the limit is 2e9 cells: shrink the domain or enlarge the support",
                        (unsigned long long)n[0], (unsigned long long)n[1],
                        (unsigned long long)n[2], cells);
    return SQ_OK;
}

sq_result sq_sph_desc_validate(const sq_sph_desc *desc) { return sq__sph_validate(NULL, desc); }

/* Floats per particle in the state arrays (see struct sq_sph). */
enum { SPH_FLOATS_PER_PARTICLE = 3 * 5 + 4 + 6 + 2 + 8 /* packed record */,
       SPH_FLOATS_TENSOR = 9 + 6 /* G and τ, only for the TENSOR viscous form */ };

uint64_t sq_sph_memory_bytes(const sq_sph_desc *desc, size_t particles)
{
    if (!desc || !(desc->spacing_m > 0.0)) return 0;
    sq_sph_desc d = sq_sph_desc_resolve(desc);
    if (!(d.support_radius_m > 0.0)) return 0;
    for (int a = 0; a < 3; a++)
        if (!(d.domain_max_m[a] > d.domain_min_m[a])) return 0;
    uint64_t n[3];
    grid_dims(&d, n);
    uint64_t cells = n[0] * n[1] * n[2];
    uint64_t np = (uint64_t)particles;
    int cap = d.neighbour_capacity > 0 ? d.neighbour_capacity : 64;
    const uint64_t floats = SPH_FLOATS_PER_PARTICLE +
                            (d.viscous == SQ_SPH_VISCOUS_TENSOR ? SPH_FLOATS_TENSOR : 0);
    uint64_t per = 4u * floats /* state */
                   + 4u /* id */ + 4u + 4u /* cellid, perm */ + 44u /* reorder targets */
                   + 2u + 2u /* neighbour counts */ + 4u * (uint64_t)cap;
    uint64_t grid = 2u * 4u * (cells + 2u); /* cell_start + histogram */
    return np * per + grid + 64u * 64u /* reductions, alignment */;
}
