/* test_par_lbm.c — the D3Q15 lattice split in slabs over the ranks of `mpirun -np N` gives the
 * one-rank solver's answer bit for bit: rank 0 also steps an undivided lattice (no
 * collectives) through the same calls and compares the gathered views, the friction velocity
 * and the totals exactly. Cases: a recycled box driven by the controlled body force with
 * obstacles across the slab faces (solid cells turning fluid next to a slab face), and an
 * inflow/outflow channel (boundary links at the corners of slab faces). Also: bad input in
 * one slab stops every rank with that slab's message. Run under mpirun by
 * tests/CMakeLists.txt (2 and 4 ranks); alone it compares one rank with itself. */
#include <stdint.h>

#include "sq_test.h"
#include "squall/lbm.h"
#include "squall/par.h"

SQ_LABEL(unit)

static sq_lbm_desc base_desc(void)
{
    sq_lbm_desc d;
    memset(&d, 0, sizeof d);
    d.cells = (sq_dims){20, 12, 16};
    d.cell_size_m = 1;
    d.viscosity_m2s = 0.01;
    d.collision = SQ_LBM_COLLISION_SMAGORINSKY;
    d.wind.speed_mps = 5;
    d.wind.heading_deg = 20;
    d.wind.beaufort = 4;
    d.wind.roughness_m = 0.01;
    d.wind.ref_height_m = 7.5; /* plane 7: inside a middle slab at 2 and 4 ranks */
    d.bc[SQ_LBM_FACE_ZMIN] = SQ_LBM_BC_WALL;
    d.bc[SQ_LBM_FACE_ZMAX] = SQ_LBM_BC_FREE_SLIP;
    d.check_interval = 8;
    return d;
}

/* A house and a fence: solid cells on both sides of every slab face of 2 and 4 ranks. */
static void obstacles(uint8_t *mask, sq_dims n)
{
    for (int k = 0; k < n.nz; k++)
        for (int j = 0; j < n.ny; j++)
            for (int i = 0; i < n.nx; i++) {
                const bool house = i >= 6 && i < 10 && j >= 3 && j < 8 && k < 9;
                const bool fence = i == 14 && j >= 2 && j < 10 && k < 5;
                mask[i + n.nx * (j + n.ny * k)] = house || fence || k == 0;
            }
}

static int64_t compare_views(sq_lbm *dist, sq_lbm *ref, sq_dims n, const char *when)
{
    sq_lbm_views a, b;
    int64_t bad = 0;
    SQ_CHECK_OK(sq_lbm_get_views(dist, &a));
    if (!ref) return 0;
    SQ_CHECK_OK(sq_lbm_get_views(ref, &b));
    const sq_field_view *va[4] = {&a.density, &a.u[0], &a.u[1], &a.u[2]};
    const sq_field_view *vb[4] = {&b.density, &b.u[0], &b.u[1], &b.u[2]};
    for (int f = 0; f < 4; f++)
        for (int k = 0; k < n.nz; k++)
            for (int j = 0; j < n.ny; j++)
                for (int i = 0; i < n.nx; i++) {
                    const float x = sq_view_get(va[f], i, j, k), y = sq_view_get(vb[f], i, j, k);
                    if (memcmp(&x, &y, sizeof x) != 0 && bad++ < 5)
                        SQ_FAIL_AT("%s, %d ranks: view %d at (%d,%d,%d): %.9g, one rank %.9g",
                                   when, sq_par_size(), f, i, j, k, (double)x, (double)y);
                }
    return bad;
}

/* The same calls on the split lattice (every rank) and the whole one (rank 0). */
static void run_case(sq_lbm_desc d, bool edit)
{
    SQ_CHECK_OK(sq_par_init(NULL, NULL));
    const bool root = sq_par_rank() == 0;
    sq_context *ctx = NULL;
    sq_context_desc cd = {.threads = 1, .seed = 7};
    SQ_CHECK_OK(sq_context_create(&cd, &ctx));
    sq_lbm *dist = NULL, *ref = NULL;
    d.decompose = true;
    SQ_CHECK_OK(sq_lbm_create(ctx, &d, &dist));
    if (root) {
        sq_lbm_desc r = d;
        r.decompose = false;
        SQ_CHECK_OK(sq_lbm_create(ctx, &r, &ref));
    }
    const sq_dims n = d.cells;
    const size_t cells = (size_t)n.nx * n.ny * n.nz;
    uint8_t *mask = (uint8_t *)calloc(cells, 1);
    obstacles(mask, n);
    SQ_CHECK_OK(sq_lbm_set_solid_mask(dist, mask));
    if (ref) SQ_CHECK_OK(sq_lbm_set_solid_mask(ref, mask));
    for (int s = 0; s < 3; s++) { /* step by step first: even and odd layouts */
        SQ_CHECK_OK(sq_lbm_step(dist, 1));
        if (ref) SQ_CHECK_OK(sq_lbm_step(ref, 1));
        char w[32];
        snprintf(w, sizeof w, "step %d", s + 1);
        SQ_CHECK(compare_views(dist, ref, n, w) == 0);
    }
    SQ_CHECK_OK(sq_lbm_step(dist, 37));
    if (ref) SQ_CHECK_OK(sq_lbm_step(ref, 37));
    SQ_CHECK(compare_views(dist, ref, n, "after 37 steps") == 0);
    if (edit) {
        /* the house's roof and walls open up on every plane (slab faces included), a block
         * turns solid, then the remaining house goes at once through the mask */
        for (int k = 1; k < 9; k++) {
            SQ_CHECK_OK(sq_lbm_set_solid(dist, 6, 3, k, false));
            if (ref) SQ_CHECK_OK(sq_lbm_set_solid(ref, 6, 3, k, false));
            SQ_CHECK_OK(sq_lbm_set_solid(dist, 17, 6, k, true));
            if (ref) SQ_CHECK_OK(sq_lbm_set_solid(ref, 17, 6, k, true));
        }
        SQ_CHECK(compare_views(dist, ref, n, "after set_solid") == 0);
        SQ_CHECK_OK(sq_lbm_step(dist, 21));
        if (ref) SQ_CHECK_OK(sq_lbm_step(ref, 21));
        for (size_t c = 0; c < cells; c++) {
            const int i = (int)(c % (size_t)n.nx), j = (int)((c / (size_t)n.nx) % (size_t)n.ny);
            if (i >= 6 && i < 10 && j >= 3 && j < 8) mask[c] = (c / ((size_t)n.nx * n.ny)) == 0;
        }
        SQ_CHECK_OK(sq_lbm_set_solid_mask(dist, mask));
        if (ref) SQ_CHECK_OK(sq_lbm_set_solid_mask(ref, mask));
        SQ_CHECK_OK(sq_lbm_step(dist, 16));
        if (ref) SQ_CHECK_OK(sq_lbm_step(ref, 16));
        const double v[3] = {0.3, -0.2, 0.0};
        SQ_CHECK_OK(sq_lbm_inject(dist, v, NULL));
        if (ref) SQ_CHECK_OK(sq_lbm_inject(ref, v, NULL));
        SQ_CHECK_OK(sq_lbm_step(dist, 9));
        if (ref) SQ_CHECK_OK(sq_lbm_step(ref, 9));
    }
    SQ_CHECK(compare_views(dist, ref, n, "at the end") == 0);
    /* friction velocity and totals: global on every rank, equal to one rank's */
    sq_field_view us;
    SQ_CHECK_OK(sq_lbm_get_friction_velocity(dist, &us));
    sq_lbm_totals td, tr;
    SQ_CHECK_OK(sq_lbm_get_totals(dist, &td));
    if (ref) {
        sq_field_view ur;
        SQ_CHECK_OK(sq_lbm_get_friction_velocity(ref, &ur));
        int64_t bad = 0, wall = 0;
        for (int k = 0; k < n.nz; k++)
            for (int j = 0; j < n.ny; j++)
                for (int i = 0; i < n.nx; i++) {
                    const float a = sq_view_get(&us, i, j, k), b = sq_view_get(&ur, i, j, k);
                    bad += memcmp(&a, &b, sizeof a) != 0;
                    wall += b > 0;
                }
        SQ_CHECK(bad == 0);
        SQ_CHECK(wall > 100); /* the ground and the obstacles' sides have u* */
        SQ_CHECK_OK(sq_lbm_get_totals(ref, &tr));
        SQ_CHECK(memcmp(&td.mass_kg, &tr.mass_kg, sizeof td.mass_kg) == 0);
        SQ_CHECK(td.fluid_cells == tr.fluid_cells);
        for (int a = 0; a < 3; a++)
            SQ_CHECK(memcmp(&td.momentum_kgmps[a], &tr.momentum_kgmps[a], sizeof(double)) == 0);
        /* and it is a flow: the wind came up to a few m/s (the periodic box: a drift) */
        sq_lbm_views v;
        SQ_CHECK_OK(sq_lbm_get_views(ref, &v));
        SQ_CHECK(fabs(sq_view_get(&v.u[0], 2, 6, 12)) > (d.wind.speed_mps > 0 ? 1.0 : 0.1));
    }
    free(mask);
    sq_lbm_destroy(dist);
    sq_lbm_destroy(ref);
    sq_context_destroy(ctx);
    sq_par_finalize();
}

SQ_TEST(recycled_box_bit_identical)
{
    sq_lbm_desc d = base_desc();
    d.bc[SQ_LBM_FACE_XMIN] = SQ_LBM_BC_RECYCLE;
    d.bc[SQ_LBM_FACE_YMIN] = SQ_LBM_BC_RECYCLE;
    run_case(d, true);
}

SQ_TEST(inflow_outflow_bit_identical)
{
    sq_lbm_desc d = base_desc();
    d.bc[SQ_LBM_FACE_XMIN] = SQ_LBM_BC_INFLOW;
    d.bc[SQ_LBM_FACE_XMAX] = SQ_LBM_BC_OUTFLOW;
    d.bc[SQ_LBM_FACE_YMIN] = SQ_LBM_BC_FREE_SLIP;
    d.bc[SQ_LBM_FACE_YMAX] = SQ_LBM_BC_FREE_SLIP;
    d.wind.heading_deg = 0;
    run_case(d, true);
}

SQ_TEST(periodic_box_bit_identical)
{
    sq_lbm_desc d = base_desc();
    for (int f = 0; f < 6; f++) d.bc[f] = SQ_LBM_BC_PERIODIC;
    d.wind.speed_mps = 0;
    d.body_accel_mps2[0] = 5.0;
    d.body_accel_mps2[2] = 1.0;
    d.collision = SQ_LBM_COLLISION_TRT;
    run_case(d, false);
}

/* Bad input in the top slab only (a non-finite initial velocity): every rank fails with the
 * message naming that cell, nobody waits for the others. */
SQ_TEST(bad_input_in_one_slab)
{
    SQ_CHECK_OK(sq_par_init(NULL, NULL));
    sq_context *ctx = NULL;
    sq_context_desc cd = {.threads = 1};
    SQ_CHECK_OK(sq_context_create(&cd, &ctx));
    sq_lbm_desc d = base_desc();
    d.decompose = true;
    sq_lbm *l = NULL;
    SQ_CHECK_OK(sq_lbm_create(ctx, &d, &l));
    const sq_dims n = d.cells;
    const size_t cells = (size_t)n.nx * n.ny * n.nz;
    float *ux = (float *)calloc(cells, sizeof(float));
    ux[3 + (size_t)n.nx * (4 + (size_t)n.ny * 15)] = NAN;
    SQ_CHECK_ERR(sq_lbm_init_fields(l, NULL, ux, NULL, NULL), SQ_ERR_INVALID_ARG,
                 "init_fields: cell (3, 4, 15)");
    /* the lattice still steps on every rank afterwards (no rank was left behind) */
    SQ_CHECK_OK(sq_lbm_step(l, 3));
    free(ux);
    sq_lbm_destroy(l);
    sq_context_destroy(ctx);
    sq_par_finalize();
}
