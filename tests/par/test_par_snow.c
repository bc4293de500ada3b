/* test_par_snow.c — the snow model split in z slabs over the ranks of `mpirun -np N`
 * (snowdrift_split.c) moves the one-rank flakes bit for bit: every rank steps its slab, rank 0
 * also steps the whole lattice (sq__snow_step without a wind lattice) from the same wind,
 * friction velocity and static solids, and the gathered air, deposit and kind of every cell
 * and the budget must be equal. The wind blows up and down across the slab faces (flakes are
 * handed over both ways, asserted), the snowfall fills cells above the threshold (snow-solid
 * cells, asserted) and the friction velocity erodes them again (asserted). The global integer
 * budget closes exactly: fallen = airborne + deposited + left. Run under mpirun by
 * tests/CMakeLists.txt (2 and 4 ranks); alone it compares one slab with the whole lattice. */
#include <math.h>
#include <stdint.h>

#include "phen/snowdrift/snowdrift_internal.h"
#include "sq_test.h"
#include "squall/par.h"

SQ_LABEL(unit)
SQ_REQUIRES(snowdrift)

enum { NX = 12, NY = 10, NZ = 16 };

/* static solids: the ground plane, a hill, and a house whose roof crosses the slab faces of 2
 * and 4 ranks (planes 4 and 8) */
static bool solid_at(int i, int j, int k)
{
    const int hill = (i - 3) * (i - 3) + (j - 5) * (j - 5) < 6 ? 2 : 0;
    const bool house = i >= 7 && i < 10 && j >= 2 && j < 6 && k < 9;
    return k == 0 || k < hill || house;
}

/* the wind (m/s) and friction velocity at a global cell and step: up- and downdraughts */
static void wind_at(int i, int j, int k, int step, float u[4])
{
    const double t = 0.37 * step;
    u[0] = (float)(2.0 + 1.5 * sin(0.9 * j + 0.5 * k + t));
    u[1] = (float)(1.0 * cos(0.7 * i - 0.3 * k + 0.5 * t));
    u[2] = (float)(2.2 * sin(0.8 * i + 0.6 * j + 0.9 * k - t));
    u[3] = (float)(0.35 + 0.2 * sin(0.5 * i + 0.4 * j + t));
}

static sq__snow_params params(void)
{
    sq__snow_params p;
    memset(&p, 0, sizeof p);
    p.dx_m = 1.0;
    p.dt_s = 0.4;
    p.fall_speed_mps = 1.0;
    p.threshold = 4;
    p.snowfall_mmh = 40.0;
    p.speedup = 3000.0;
    p.ustar_threshold_mps = 0.3;
    p.saltation_kgm3 = 0.02;
    p.periodic[0] = true;
    p.seed = 11;
    return p;
}

SQ_TEST(snow_slabs_bit_identical)
{
    SQ_CHECK_OK(sq_par_init(NULL, NULL));
    const bool root = sq_par_rank() == 0;
    sq_context *ctx = NULL;
    sq_context_desc cd = {.threads = 1, .seed = 7};
    SQ_CHECK_OK(sq_context_create(&cd, &ctx));
    const sq_dims n = {NX, NY, NZ};
    const sq__snow_params p = params();
    sq__snow_slab *sl = NULL;
    SQ_CHECK_OK(sq__snow_slab_create(ctx, n, &p, &sl));
    sq__snow *ref = NULL;
    if (root) SQ_CHECK_OK(sq__snow_create(ctx, n, &p, &ref));
    int lo, own, l0;
    sq__snow_slab_range(sl, &lo, &own, &l0);
    sq__snow *s = sq__snow_slab_snow(sl);
    const int lnz = s->nz; /* own planes and the neighbours' edge planes */
    const size_t P = (size_t)NX * NY, lc = P * (size_t)lnz, gc = P * NZ;
    for (int k = 0; k < lnz; k++)
        for (int j = 0; j < NY; j++)
            for (int i = 0; i < NX; i++)
                if (solid_at(i, j, k - l0 + lo)) sq__snow_set_static(s, i, j, k, true);
    if (ref)
        for (int k = 0; k < NZ; k++)
            for (int j = 0; j < NY; j++)
                for (int i = 0; i < NX; i++)
                    if (solid_at(i, j, k)) sq__snow_set_static(ref, i, j, k, true);
    float *lw = (float *)calloc(4 * lc, sizeof(float)), *gw = (float *)calloc(4 * gc, sizeof(float));
    SQ_CHECK(lw && gw);
    const int steps = 120;
    uint64_t eroded_seen = 0;
    for (int st = 0; st < steps; st++) {
        for (int k = 0; k < lnz; k++)
            for (size_t q = 0; q < P; q++) {
                float u[4];
                wind_at((int)(q % NX), (int)(q / NX), k - l0 + lo, st, u);
                for (int a = 0; a < 4; a++) lw[a * lc + (size_t)k * P + q] = u[a];
            }
        const size_t w0 = (size_t)l0 * P; /* the wind of the own planes, as the lattice's slab */
        SQ_CHECK_OK(sq__snow_slab_step(sl, lw + w0, lw + lc + w0, lw + 2 * lc + w0, lw + 3 * lc));
        if (ref) {
            for (int k = 0; k < NZ; k++)
                for (size_t q = 0; q < P; q++) {
                    float u[4];
                    wind_at((int)(q % NX), (int)(q / NX), k, st, u);
                    for (int a = 0; a < 4; a++) gw[a * gc + (size_t)k * P + q] = u[a];
                }
            sq_field_view u[3], us;
            for (int a = 0; a < 4; a++) {
                sq_field_view *v = a < 3 ? &u[a] : &us;
                *v = (sq_field_view){gw + a * gc, n, 1, NX, (ptrdiff_t)P};
            }
            SQ_CHECK_OK(sq__snow_step(ref, u, &us, NULL));
            eroded_seen = ref->eroded;
        }
        /* the budget every step: global, exact, the whole lattice's */
        sq__snow_budget b, rb;
        sq__snow_slab_budget(sl, &b);
        SQ_CHECK(b.fallen == b.airborne + b.deposited + b.left);
        if (ref) {
            sq__snow_get_budget(ref, &rb);
            if (memcmp(&b, &rb, sizeof b) != 0) {
                SQ_FAIL_AT("step %d, %d ranks: budget fallen %llu airborne %llu deposited %llu "
                           "left %llu eroded %llu solid %lld; one lattice %llu %llu %llu %llu "
                           "%llu %lld", st, sq_par_size(), (unsigned long long)b.fallen,
                           (unsigned long long)b.airborne, (unsigned long long)b.deposited,
                           (unsigned long long)b.left, (unsigned long long)b.eroded,
                           (long long)b.solid_cells, (unsigned long long)rb.fallen,
                           (unsigned long long)rb.airborne, (unsigned long long)rb.deposited,
                           (unsigned long long)rb.left, (unsigned long long)rb.eroded,
                           (long long)rb.solid_cells);
                break;
            }
        }
    }
    /* every cell: the slabs' own planes gathered (counts as doubles: exact) */
    const int nr = sq_par_size();
    int64_t *cnt = (int64_t *)calloc((size_t)nr, sizeof(int64_t));
    double *mine = (double *)calloc(3 * P * (size_t)own, sizeof(double));
    double *all = (double *)calloc(3 * gc, sizeof(double));
    SQ_CHECK(cnt && mine && all);
    for (int r = 0; r < nr; r++) {
        sq_par_block bl;
        const int split[3] = {0, 0, 1};
        SQ_CHECK_OK(sq_par_decompose(n, split, NULL, 2, nr, r, &bl));
        cnt[r] = 3 * (int64_t)P * bl.n.nz;
    }
    for (size_t c = 0; c < P * (size_t)own; c++) {
        const size_t lc0 = (size_t)l0 * P + c;
        mine[3 * c] = s->air[lc0];
        mine[3 * c + 1] = s->dep[lc0];
        mine[3 * c + 2] = s->kind[lc0];
    }
    SQ_CHECK_OK(sq_par_allgather_f64(mine, cnt, all));
    int64_t handed[1] = {(int64_t)sq__snow_slab_handed(sl)};
    sq_par_sum_i64(handed, 1);
    if (ref) {
        int64_t bad = 0, solid = 0;
        for (size_t c = 0; c < gc; c++) {
            const double w[3] = {ref->air[c], ref->dep[c], ref->kind[c]};
            for (int f = 0; f < 3; f++)
                if (all[3 * c + f] != w[f] && bad++ < 5)
                    SQ_FAIL_AT("%d ranks, cell (%d,%d,%d): %s %g, one lattice %g", nr,
                               (int)(c % NX), (int)(c / NX % NY), (int)(c / P),
                               f == 0 ? "air" : f == 1 ? "dep" : "kind", all[3 * c + f], w[f]);
            solid += ref->kind[c] == SQ_SNOW_SOLID;
        }
        SQ_CHECK(bad == 0);
        /* not a vacuous comparison: snow-solid cells formed and erosion lifted flakes */
        SQ_CHECK(solid > 50);
        SQ_CHECK(eroded_seen > 500);
    }
    /* flakes crossed the slab faces */
    if (nr > 1) SQ_CHECK(handed[0] > 100);
    free(cnt);
    free(mine);
    free(all);
    free(lw);
    free(gw);
    sq__snow_slab_destroy(sl);
    sq__snow_destroy(ref);
    sq_context_destroy(ctx);
    sq_par_finalize();
}
