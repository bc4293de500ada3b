/* avalanche_desc.c — the avalanche desc: defaults (resolve), validation with messages that name
 * the key (layers.avalanche.<key>), its value and the rule, and the plan that everything else
 * derives from the desc and the world before anything is allocated: the release slab on the
 * terrain (SPEC §7.7 terrain, S2 §3.6 release), the fall line, the domain box, the SPH desc
 * (SPEC §7.2–7.5 through include/squall/sph.h), the deposit and powder grids, the particle
 * count and the memory it needs. */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "avalanche_internal.h"
#include "world/world_struct.h"

#define MOD "avalanche"
#define P "sq_avalanche_desc." /* the scene shows it as layers.<name>. */

sq_result sq_avalanche_desc_resolve(const sq_avalanche_desc *in, sq_avalanche_desc *out)
{
    sq_avalanche_desc d;
    memset(&d, 0, sizeof d);
    if (in) d = *in;
    if (d.spacing_m == 0.0) d.spacing_m = 1.0;
    if (d.density_kgm3 == 0.0) d.density_kgm3 = 300.0;
    if (d.release_length_m == 0.0) d.release_length_m = 40.0;
    if (d.release_width_m == 0.0) d.release_width_m = 30.0;
    if (d.release_depth_m == 0.0) d.release_depth_m = 2.0;
    if (d.mu_pa_s == 0.0) d.mu_pa_s = 1.0;
    if (d.mu0_pa_s == 0.0) d.mu0_pa_s = 100.0;
    if (d.mu_inf_pa_s == 0.0) d.mu_inf_pa_s = 1.0;
    if (d.cross_k_s == 0.0) d.cross_k_s = 3000.0;
    if (d.cross_n == 0.0) d.cross_n = 2.0;
    if (d.power_k == 0.0) d.power_k = 1.5;
    if (d.power_n == 0.0) d.power_n = 0.5;
    if (d.bingham_mu_pa_s == 0.0) d.bingham_mu_pa_s = 1.5;
    if (d.xsph_epsilon == 0.0) d.xsph_epsilon = 0.5;
    if (d.artificial_viscosity == 0.0) d.artificial_viscosity = 0.1;
    if (d.friction == 0.0) d.friction = 0.2;
    if (d.moving_speed_mps == 0.0) d.moving_speed_mps = 0.5;
    if (d.front_percentile == 0.0) d.front_percentile = 0.99;
    if (d.airborne_m == 0.0) d.airborne_m = 2.0;
    if (d.radius_factor == 0.0) d.radius_factor = 0.6;
    if (d.albedo == 0.0) d.albedo = 0.9;
    if (d.powder_speed_mps == 0.0) d.powder_speed_mps = 10.0;
    if (d.powder_cell_m == 0.0) d.powder_cell_m = 2.0;
    if (d.powder_box_m == 0.0) d.powder_box_m = 256.0;
    if (d.powder_shed == 0.0) d.powder_shed = 2.0e-5;
    if (d.release_reference_altitude_m == 0.0) d.release_reference_altitude_m = 2000.0;
    if (out) *out = d;
    return SQ_OK;
}

#define BAD(...) return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, __VA_ARGS__)

static bool pos_finite(double v) { return v > 0.0 && isfinite(v); }

/* Scalar rules (before the world is looked at). */
static sq_result check_scalars(sq_context *ctx, const sq_avalanche_desc *d)
{
    if (!pos_finite(d->spacing_m))
        BAD("%sparticles.spacing_m = %g; the particle spacing must be > 0 m", P, d->spacing_m);
    if (!(d->support_radius_m >= 0.0) || !isfinite(d->support_radius_m))
        BAD("%sparticles.support_radius_m = %g; the kernel support must be > 0 m (0 = 2 x "
            "spacing)", P, d->support_radius_m);
    if (d->support_radius_m > 0.0) {
        double ratio = d->support_radius_m / d->spacing_m;
        if (!(ratio >= 1.5 && ratio <= 4.0))
            BAD("%sparticles.support_radius_m = %g m is %.3g x the spacing %g m; must be 1.5 to "
                "4 x the spacing (about 14 to 270 neighbours)", P, d->support_radius_m, ratio,
                d->spacing_m);
    }
    if (!pos_finite(d->density_kgm3))
        BAD("%ssnow.density_kgm3 = %g; the rest density must be > 0 kg/m3", P, d->density_kgm3);
    if (!(d->speed_of_sound_mps >= 0.0) || !isfinite(d->speed_of_sound_mps))
        BAD("%snumerics.speed_of_sound_mps = %g; must be > 0 m/s (0 = auto)", P,
            d->speed_of_sound_mps);
    if (!isfinite(d->release_x_m) || !isfinite(d->release_y_m))
        BAD("%srelease.x_m, %srelease.y_m = (%g, %g); must be finite", P, P, d->release_x_m,
            d->release_y_m);
    if (!pos_finite(d->release_length_m))
        BAD("%srelease.length_m = %g; must be > 0 m", P, d->release_length_m);
    if (!pos_finite(d->release_width_m))
        BAD("%srelease.width_m = %g; must be > 0 m", P, d->release_width_m);
    if (!pos_finite(d->release_depth_m))
        BAD("%srelease.depth_m = %g; the slab thickness must be > 0 m", P, d->release_depth_m);
    if (!isfinite(d->release_gradient_m) || !isfinite(d->release_reference_altitude_m))
        BAD("%srelease.gradient_m, release.reference_altitude_m: not finite", P);
    if (d->domain_layer_m < 0.0 || !isfinite(d->domain_layer_m))
        BAD("%sdomain.layer_m = %g; must be > 0 m (0 = auto)", P, d->domain_layer_m);
    if (!(d->hazard_cell_m >= 0.0) || !isfinite(d->hazard_cell_m))
        BAD("%shazard.cell_m = %g; must be > 0 m (0 = the terrain's spacing)", P,
            d->hazard_cell_m);
    if (!d->release_area[0] &&
        (d->release_length_m < d->spacing_m || d->release_width_m < d->spacing_m ||
         d->release_depth_m < d->spacing_m))
        BAD("%srelease: %g x %g m, %g m deep, is smaller than one particle spacing (%g m) along "
            "an axis; enlarge the slab or lower particles.spacing_m", P, d->release_length_m,
            d->release_width_m, d->release_depth_m, d->spacing_m);
    switch (d->rheology) {
    case SQ_AVALANCHE_RHEOLOGY_CROSS:
        if (!(d->mu_inf_pa_s >= 0.0) || !isfinite(d->mu_inf_pa_s))
            BAD("%srheology.mu_inf_pa_s = %g; the infinite-shear viscosity must be >= 0 Pa s", P,
                d->mu_inf_pa_s);
        if (!(d->mu0_pa_s >= d->mu_inf_pa_s) || !isfinite(d->mu0_pa_s))
            BAD("%srheology.mu0_pa_s = %g is below %srheology.mu_inf_pa_s = %g; the Cross model "
                "needs mu0 >= mu_inf (zero-shear above infinite-shear viscosity; SPEC §7.4 ⚠ "
                "corrects the reversed bound of the OCR)", P, d->mu0_pa_s, P, d->mu_inf_pa_s);
        if (!pos_finite(d->cross_k_s))
            BAD("%srheology.cross_k_s = %g; the Cross time constant must be > 0 s", P,
                d->cross_k_s);
        if (!pos_finite(d->cross_n))
            BAD("%srheology.cross_n = %g; the Cross exponent must be > 0", P, d->cross_n);
        break;
    case SQ_AVALANCHE_RHEOLOGY_NEWTONIAN:
        if (!(d->mu_pa_s >= 0.0) || !isfinite(d->mu_pa_s))
            BAD("%srheology.mu_pa_s = %g; the viscosity must be >= 0 Pa s", P, d->mu_pa_s);
        break;
    case SQ_AVALANCHE_RHEOLOGY_POWER_LAW:
        if (!pos_finite(d->power_k))
            BAD("%srheology.power_k = %g; the consistency must be > 0 Pa s^n", P, d->power_k);
        if (!pos_finite(d->power_n))
            BAD("%srheology.power_n = %g; the flow index must be > 0", P, d->power_n);
        break;
    case SQ_AVALANCHE_RHEOLOGY_BINGHAM:
        if (!(d->bingham_mu_pa_s >= 0.0) || !isfinite(d->bingham_mu_pa_s))
            BAD("%srheology.bingham_mu_pa_s = %g; the plastic viscosity must be >= 0 Pa s", P,
                d->bingham_mu_pa_s);
        if (!(d->yield_stress_pa >= 0.0) || !isfinite(d->yield_stress_pa))
            BAD("%srheology.yield_stress_pa = %g; the yield stress must be >= 0 Pa", P,
                d->yield_stress_pa);
        break;
    default:
        BAD("%srheology.model = %d; must be cross (0), newtonian (1), power-law (2) or bingham (3)",
            P, d->rheology);
    }
    if (!(d->mu_max_pa_s >= 0.0) || !isfinite(d->mu_max_pa_s))
        BAD("%srheology.mu_max_pa_s = %g; must be >= 0 Pa s (0 = no cap)", P, d->mu_max_pa_s);
    if (d->kernel < 0 || d->kernel > 1)
        BAD("%snumerics.kernel = %d; must be cubic (0) or muller (1)", P, d->kernel);
    if (d->viscous < 0 || d->viscous > 2)
        BAD("%snumerics.viscous = %d; must be morris (0), muller (1) or tensor (2)", P, d->viscous);
    if (!(d->xsph_epsilon >= 0.0 && d->xsph_epsilon <= 1.0))
        BAD("%snumerics.xsph_epsilon = %g; must be in [0, 1] (S2 uses 0.5)", P, d->xsph_epsilon);
    if (!(d->artificial_viscosity >= 0.0 && d->artificial_viscosity <= 1.0))
        BAD("%snumerics.artificial_viscosity = %g; Monaghan's alpha must be in [0, 1]", P,
            d->artificial_viscosity);
    if (!(d->dt_max_s >= 0.0) || !isfinite(d->dt_max_s))
        BAD("%snumerics.dt_max_s = %g; must be >= 0 s (0 = none)", P, d->dt_max_s);
    if (!(d->friction >= 0.0) || !isfinite(d->friction))
        BAD("%sterrain.friction = %g; the kinetic Coulomb coefficient must be >= 0", P,
            d->friction);
    if (!(d->turbulent_friction_mps2 >= 0.0) || !isfinite(d->turbulent_friction_mps2))
        BAD("%sterrain.turbulent_friction_mps2 = %g; must be >= 0 m/s2 (0 = none)", P,
            d->turbulent_friction_mps2);
    if (d->turbulent_friction_mps2 > 0.0 && !d->column_friction)
        BAD("%sterrain.turbulent_friction_mps2 = %g needs terrain.column_friction: true (the "
            "Voellmy drag acts on the flow column)", P, d->turbulent_friction_mps2);
    if (!(d->restitution >= 0.0 && d->restitution <= 1.0))
        BAD("%sterrain.restitution = %g; must be in [0, 1]", P, d->restitution);
    if (!(d->deposit_cell_m >= 0.0) || !isfinite(d->deposit_cell_m))
        BAD("%sdeposit.cell_m = %g; must be > 0 m (0 = 2 x spacing)", P, d->deposit_cell_m);
    if (!pos_finite(d->moving_speed_mps))
        BAD("%smetrics.moving_speed_mps = %g; must be > 0 m/s", P, d->moving_speed_mps);
    if (!(d->front_percentile > 0.0 && d->front_percentile <= 1.0))
        BAD("%smetrics.front_percentile = %g; must be in (0, 1]", P, d->front_percentile);
    if (!pos_finite(d->airborne_m))
        BAD("%smetrics.airborne_m = %g; must be > 0 m", P, d->airborne_m);
    if (!pos_finite(d->radius_factor))
        BAD("%srender.radius_factor = %g; must be > 0", P, d->radius_factor);
    if (!(d->albedo > 0.0 && d->albedo <= 1.0))
        BAD("%srender.albedo = %g; must be in (0, 1]", P, d->albedo);
    if (!pos_finite(d->powder_speed_mps))
        BAD("%spowder.speed_mps = %g; must be > 0 m/s", P, d->powder_speed_mps);
    if (!pos_finite(d->powder_shed))
        BAD("%spowder.shed = %g; must be > 0", P, d->powder_shed);
    if (!pos_finite(d->powder_cell_m))
        BAD("%spowder.cell_m = %g; must be > 0 m", P, d->powder_cell_m);
    if (!pos_finite(d->powder_box_m) || d->powder_box_m < 2.0 * d->powder_cell_m)
        BAD("%spowder.box_m = %g; must be finite and at least 2 powder.cell_m (%g m)", P,
            d->powder_box_m, 2.0 * d->powder_cell_m);
    for (int a = 0; a < 3; a++)
        if (!isfinite(d->domain_min_m[a]) || !isfinite(d->domain_max_m[a]))
            BAD("%sdomain.min_m/max_m: not finite", P);
    return SQ_OK;
}

static sq_sph_rheology rheology_of(const sq_avalanche_desc *d)
{
    sq_sph_rheology r;
    memset(&r, 0, sizeof r);
    switch (d->rheology) {
    case SQ_AVALANCHE_RHEOLOGY_NEWTONIAN:
        r.kind = SQ_SPH_RHEOLOGY_NEWTONIAN;
        r.mu_pa_s = d->mu_pa_s;
        break;
    case SQ_AVALANCHE_RHEOLOGY_POWER_LAW:
        r.kind = SQ_SPH_RHEOLOGY_POWER_LAW;
        r.k = d->power_k;
        r.n = d->power_n;
        break;
    case SQ_AVALANCHE_RHEOLOGY_BINGHAM:
        r.kind = SQ_SPH_RHEOLOGY_BINGHAM;
        r.k = d->bingham_mu_pa_s;
        r.yield_stress_pa = d->yield_stress_pa;
        break;
    default:
        r.kind = SQ_SPH_RHEOLOGY_CROSS;
        r.mu0_pa_s = d->mu0_pa_s;
        r.mu_inf_pa_s = d->mu_inf_pa_s;
        r.k = d->cross_k_s;
        r.n = d->cross_n;
        break;
    }
    r.mu_max_pa_s = d->mu_max_pa_s;
    return r;
}

sq_result sq__avalanche_plan(sq_context *ctx, const sq_avalanche_desc *desc, const sq_world *w,
                             sq__aval_plan *out)
{
    sq__aval_plan pl;
    memset(&pl, 0, sizeof pl);
    if (!desc) BAD("desc is NULL");
    if (!w || !w->heights || w->nx < 2 || w->ny < 2)
        BAD("%sthe avalanche needs a world with a terrain heightfield", P);
    sq_avalanche_desc_resolve(desc, &pl.d);
    const sq_avalanche_desc *d = &pl.d;
    sq_result r = check_scalars(ctx, d);
    if (r != SQ_OK) return r;
    pl.spacing = d->spacing_m;
    pl.support = d->support_radius_m > 0.0 ? d->support_radius_m : 2.0 * d->spacing_m;

    /* the release region must lie on the terrain */
    sq_vec3 lo, hi;
    sq_world_bounds(w, &lo, &hi);
    if (d->release_area[0]) {
        pl.area = sq_world_area_find(w, d->release_area);
        if (!pl.area) {
            char names[256] = "";
            for (int k = 0; k < w->area_count; k++) {
                strncat(names, k ? ", " : "", sizeof names - strlen(names) - 1);
                strncat(names, w->areas[k].name, sizeof names - strlen(names) - 1);
            }
            BAD("%srelease.area = '%s': no such area in world.areas (%s)", P, d->release_area,
                names[0] ? names : "the world has none");
        }
        const double *b = pl.area->bounds;
        const int outside = b[2] < (double)lo.x || b[0] > (double)hi.x || b[3] < (double)lo.y ||
                            b[1] > (double)hi.y;
        if (outside || b[0] < (double)lo.x || b[2] > (double)hi.x || b[1] < (double)lo.y ||
            b[3] > (double)hi.y)
            BAD("%srelease.area = '%s' ('%s'): its polygons span x [%.1f, %.1f] m, y [%.1f, %.1f] m "
                "and %s the terrain (DEM) x [%g, %g] m, y [%g, %g] m (world coordinates); the "
                "release must lie on the terrain", P, d->release_area, pl.area->source, b[0], b[2],
                b[1], b[3], outside ? "lie outside" : "reach outside", (double)lo.x, (double)hi.x,
                (double)lo.y, (double)hi.y);
        for (int f = 0; f < pl.area->feature_count; f++) {
            const double v = pl.area->feature_value[f];
            if (isfinite(v) && !(v > 0.0))
                BAD("%srelease.area = '%s' ('%s'): polygon %d has thickness %g m; a release "
                    "thickness must be > 0 m", P, d->release_area, pl.area->source, f, v);
        }
        memcpy(pl.release_lo, b, 2 * sizeof(double));
        memcpy(pl.release_hi, b + 2, 2 * sizeof(double));
    } else {
        pl.release_lo[0] = d->release_x_m - 0.5 * d->release_length_m;
        pl.release_hi[0] = d->release_x_m + 0.5 * d->release_length_m;
        pl.release_lo[1] = d->release_y_m - 0.5 * d->release_width_m;
        pl.release_hi[1] = d->release_y_m + 0.5 * d->release_width_m;
        if (pl.release_lo[0] < (double)lo.x || pl.release_hi[0] > (double)hi.x ||
            pl.release_lo[1] < (double)lo.y || pl.release_hi[1] > (double)hi.y)
            BAD("%srelease: x [%g, %g] m, y [%g, %g] m (release.x_m = %g, release.y_m = %g, "
                "release.length_m = %g, release.width_m = %g) lies outside the terrain x [%g, %g] "
                "m, y [%g, %g] m",
                P, pl.release_lo[0], pl.release_hi[0], pl.release_lo[1], pl.release_hi[1],
                d->release_x_m, d->release_y_m, d->release_length_m, d->release_width_m,
                (double)lo.x, (double)hi.x, (double)lo.y, (double)hi.y);
    }

    /* volume, count, fall line, top and crown from a coarse pass over the region (O(cells)) */
    r = sq__aval_release_estimate(ctx, &pl, w);
    if (r != SQ_OK) return r;
    if (pl.columns > 4.0 * pl.count_estimate + 1e6)
        BAD("%srelease: %.4g m3 over %.4g m2 is thinner than the particle spacing %g m on "
            "average (%.3g columns for %.3g particles); lower particles.spacing_m or thicken the "
            "release", P, pl.volume_m3, pl.release_area_m2, pl.spacing, pl.columns,
            pl.count_estimate);
    const double hx = 0.5 * (pl.release_hi[0] - pl.release_lo[0]);
    const double hy = 0.5 * (pl.release_hi[1] - pl.release_lo[1]);
    const double cx = 0.5 * (pl.release_hi[0] + pl.release_lo[0]);
    const double cy = 0.5 * (pl.release_hi[1] + pl.release_lo[1]);
    const double reach = fabs(pl.fall_dir[0]) * hx + fabs(pl.fall_dir[1]) * hy;
    pl.edge_s = cx * pl.fall_dir[0] + cy * pl.fall_dir[1] + reach;
    if (!pl.area) {
        /* the rectangle's crown: the centre of its upslope edge */
        pl.crown[0] = cx - pl.fall_dir[0] * reach;
        pl.crown[1] = cy - pl.fall_dir[1] * reach;
        pl.crown[2] = sq_world_height_at(w, (float)pl.crown[0], (float)pl.crown[1]);
    }
    /* capacity: the estimate's count with the dither's and the coarse pass's slack */
    pl.count = (size_t)ceil(pl.count_estimate * 1.03 + 64.0);

    /* the domain box; the neighbour grid follows the terrain (layer) or fills the box */
    double dmin[3], dmax[3];
    bool auto_domain = true;
    for (int a = 0; a < 3; a++)
        auto_domain = auto_domain && d->domain_min_m[a] == 0.0f && d->domain_max_m[a] == 0.0f;
    pl.layer_m = d->domain_layer_m;
    const double auto_layer = pl.max_column_m + 20.0 + 10.0 * pl.support;
    if (auto_domain) {
        dmin[0] = lo.x;
        dmax[0] = hi.x;
        dmin[1] = lo.y;
        dmax[1] = hi.y;
        dmin[2] = (double)w->height_min - 2.0 * pl.support;
        dmax[2] = (double)w->height_max + auto_layer + 2.0 * pl.support;
    } else {
        for (int a = 0; a < 3; a++) {
            dmin[a] = d->domain_min_m[a];
            dmax[a] = d->domain_max_m[a];
            if (!(dmax[a] > dmin[a]))
                BAD("%sdomain.min_m[%d] = %g >= %sdomain.max_m[%d] = %g; every axis needs max > "
                    "min", P, a, dmin[a], P, a, dmax[a]);
        }
        const double top = pl.release_top_z + 0.5 * pl.spacing;
        if (pl.release_lo[0] < dmin[0] || pl.release_hi[0] > dmax[0] ||
            pl.release_lo[1] < dmin[1] || pl.release_hi[1] > dmax[1] || top > dmax[2] ||
            (double)sq_world_height_at(w, (float)cx, (float)cy) < dmin[2])
            BAD("%sdomain: [%g, %g] x [%g, %g] x [%g, %g] m does not hold the release slab "
                "(x [%g, %g], y [%g, %g], top z %g m)", P, dmin[0], dmax[0], dmin[1], dmax[1],
                dmin[2], dmax[2], pl.release_lo[0], pl.release_hi[0], pl.release_lo[1],
                pl.release_hi[1], top);
    }
    if (pl.layer_m == 0.0) {
        /* auto: the terrain-following grid when it needs less than half the box's cells */
        const double H = pl.support;
        const double box = floor((dmax[2] - dmin[2]) / H);
        if (auto_domain || ceil(auto_layer / H) + 3.0 < 0.5 * box) pl.layer_m = auto_layer;
    }

    /* speed of sound: 5 x the free-fall speed over the possible drop (Mach <= 0.2,
     * density fluctuations ~ Ma² <= 4 %) unless given */
    double drop = pl.release_top_z - (double)w->height_min;
    if (drop < pl.spacing) drop = pl.spacing;
    const double v_fall = sqrt(2.0 * SQ_AVAL_GRAVITY * drop);
    const double c_s = d->speed_of_sound_mps > 0.0 ? d->speed_of_sound_mps : 5.0 * v_fall;

    sq_sph_desc *s = &pl.sph;
    memset(s, 0, sizeof *s);
    s->spacing_m = pl.spacing;
    s->support_radius_m = pl.support;
    s->rest_density_kgm3 = d->density_kgm3;
    s->eos = SQ_SPH_EOS_LINEAR;
    s->tensile_pressure = d->cohesion;
    s->speed_of_sound_mps = c_s;
    s->max_speed_mps = v_fall;
    s->kernel = d->kernel == 1 ? SQ_SPH_KERNEL_MULLER : SQ_SPH_KERNEL_CUBIC;
    s->gradient = SQ_SPH_GRADIENT_CORRECTED;
    s->viscous = d->viscous == 1   ? SQ_SPH_VISCOUS_MULLER
                 : d->viscous == 2 ? SQ_SPH_VISCOUS_TENSOR
                                   : SQ_SPH_VISCOUS_MORRIS;
    s->rheology = rheology_of(d);
    s->artificial_viscosity = d->no_artificial_viscosity ? 0.0 : d->artificial_viscosity;
    s->xsph_epsilon = d->xsph_epsilon;
    s->gravity_mps2[2] = -SQ_AVAL_GRAVITY;
    for (int a = 0; a < 3; a++) {
        s->domain_min_m[a] = dmin[a];
        s->domain_max_m[a] = dmax[a];
    }
    for (int f = 0; f < 6; f++) s->boundary[f] = SQ_SPH_BOUNDARY_OPEN;
    s->terrain_layer_m = pl.layer_m;
    s->max_particles = pl.count;
    s->dt_max_s = d->dt_max_s;
    if (sq_sph_desc_validate(s) != SQ_OK) {
        char why[512];
        snprintf(why, sizeof why, "%s", sq_last_error());
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "%sparticles.spacing_m = %g m (support %g m): the release makes about "
                        "%.0f particles and the SPH solver refuses the set-up: %s",
                        P, pl.spacing, pl.support, pl.count_estimate, why);
    }

    if (pl.layer_m > 0.0) {
        /* a terrain-following grid of cells_x x cells_y columns: refuse a footprint whose
         * columns alone would not fit, naming what bounds it */
        const double cols = floor((dmax[0] - dmin[0]) / pl.support) *
                            floor((dmax[1] - dmin[1]) / pl.support);
        const double cells = cols * (ceil(pl.layer_m / pl.support) + 3.0);
        if (cells > 512.0 * 1024 * 1024)
            BAD("%sdomain: the neighbour grid over x [%g, %g] m, y [%g, %g] m with cells of %g m "
                "and a %g m layer would need %.3g cells (at most 5.4e8); bound the flow's "
                "footprint with domain.min_m / domain.max_m", P, dmin[0], dmax[0], dmin[1],
                dmax[1], pl.support, pl.layer_m, cells);
    }

    /* deposit grid over the domain's footprint (auto: 2 dx, coarser to stay under 16 Mi cells) */
    pl.dep_cell = d->deposit_cell_m > 0.0 ? d->deposit_cell_m : 2.0 * pl.spacing;
    if (d->deposit_cell_m == 0.0) {
        const double need = sqrt((dmax[0] - dmin[0]) * (dmax[1] - dmin[1]) / (15.0 * 1024 * 1024));
        if (need > pl.dep_cell) pl.dep_cell = need;
    }
    double nxd = ceil((dmax[0] - dmin[0]) / pl.dep_cell), nyd = ceil((dmax[1] - dmin[1]) / pl.dep_cell);
    if (nxd * nyd > 16.0 * 1024 * 1024 || nxd < 1 || nyd < 1)
        BAD("%sdeposit.cell_m = %g m gives a %.0f x %.0f deposit grid over the domain; at most "
            "16 Mi cells", P, pl.dep_cell, nxd, nyd);
    pl.dep_nx = nxd < 2 ? 2 : (int)nxd;
    pl.dep_ny = nyd < 2 ? 2 : (int)nyd;
    pl.dep_origin[0] = dmin[0];
    pl.dep_origin[1] = dmin[1];

    /* hazard maps: cells centred on the terrain's samples (or of hazard.cell_m) over the whole
     * terrain, so that the rasters line up with the DEM */
    pl.hz_cell = d->hazard_cell_m > 0.0 ? d->hazard_cell_m : (double)w->dx;
    pl.hz_origin[0] = (double)w->origin.x - 0.5 * (double)w->dx;
    pl.hz_origin[1] = (double)w->origin.y - 0.5 * (double)w->dy;
    {
        const double nxh = ceil((double)w->nx * (double)w->dx / pl.hz_cell - 1e-9);
        const double nyh = ceil((double)w->ny * (double)w->dy / pl.hz_cell - 1e-9);
        if (nxh * nyh > 64.0 * 1024 * 1024)
            BAD("%shazard.cell_m = %g m gives a %.0f x %.0f grid over the terrain; at most 64 Mi "
                "cells", P, pl.hz_cell, nxh, nyh);
        pl.hz_nx = (int)nxh;
        pl.hz_ny = (int)nyh;
    }

    /* powder box: a cube of powder.box_m around the release that follows the flow (at most
     * 128 cells per axis: the cell grows to fit); its lowest quarter below the release top */
    if (d->powder) {
        double c = d->powder_cell_m;
        if (d->powder_box_m / 128.0 > c) c = d->powder_box_m / 128.0;
        const int n = (int)ceil(d->powder_box_m / c - 1e-9);
        pl.pw_cell = c;
        const double centre[3] = {0.5 * (pl.release_lo[0] + pl.release_hi[0]),
                                  0.5 * (pl.release_lo[1] + pl.release_hi[1]), pl.release_top_z};
        for (int a = 0; a < 3; a++) {
            pl.pw_n[a] = n < 2 ? 2 : n;
            pl.pw_origin[a] = centre[a] - (a == 2 ? 0.25 : 0.5) * pl.pw_n[a] * c;
        }
    }
    *out = pl;
    return SQ_OK;
}

static uint64_t plan_bytes(const sq__aval_plan *pl)
{
    uint64_t b = sq_sph_memory_bytes(&pl->sph, pl->count);
    const uint64_t cells = (uint64_t)pl->dep_nx * (uint64_t)pl->dep_ny;
    b += cells * (8u + 5u * 4u);
    b += (uint64_t)pl->hz_nx * (uint64_t)pl->hz_ny * (8u + 6u * 4u); /* hazard maps */
    b += (uint64_t)pl->count * (4u + 12u + 16u); /* scratch, positions, travel tracking */
    /* powder: density, its scratch and the drawn density; per column the ground index, the
     * carrier velocity and its smoothing scratch */
    b += 3u * 4u * (uint64_t)pl->pw_n[0] * (uint64_t)pl->pw_n[1] * (uint64_t)pl->pw_n[2];
    b += (4u + 6u * 4u) * (uint64_t)pl->pw_n[0] * (uint64_t)pl->pw_n[1];
    return b + 4096u;
}

size_t sq_avalanche_release_count(const sq_avalanche_desc *desc, const sq_world *world,
                                  double *volume_m3)
{
    sq__aval_plan pl;
    if (volume_m3) *volume_m3 = 0.0;
    if (sq__avalanche_plan(NULL, desc, world, &pl) != SQ_OK) return 0;
    size_t n = 0;
    double vol = 0.0;
    if (sq__aval_release_place(NULL, &pl, world, NULL, 0, &n, &vol, NULL) != SQ_OK) return 0;
    if (volume_m3) *volume_m3 = vol;
    return n;
}

uint64_t sq_avalanche_memory_bytes(const sq_avalanche_desc *desc, const sq_world *world)
{
    sq__aval_plan pl;
    if (sq__avalanche_plan(NULL, desc, world, &pl) != SQ_OK) return 0;
    return plan_bytes(&pl);
}

/* Plans (O(cells), no particle is counted one by one) and refuses a release the memory limit
 * cannot hold, before allocating. */
static sq_result validate_plan(sq_context *ctx, const sq_avalanche_desc *desc, const sq_world *w,
                               sq__aval_plan *pl)
{
    sq_result r = sq__avalanche_plan(ctx, desc, w, pl);
    if (r != SQ_OK) return r;
    const uint64_t bytes = plan_bytes(pl);
    char what[256];
    snprintf(what, sizeof what,
             P "particles.spacing_m = %g m: a release of %.4g m3 makes about %.0f "
             "particles, which",
             pl->spacing, pl->volume_m3, pl->count_estimate);
    return sq_context_check_memory(ctx, bytes, what);
}

sq_result sq_avalanche_validate(sq_context *ctx, const sq_avalanche_desc *desc,
                                const sq_world *world)
{
    sq__aval_plan pl;
    return validate_plan(ctx, desc, world, &pl);
}
