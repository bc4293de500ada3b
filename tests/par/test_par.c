/* test_par.c — decomposition and halo exchange (squall/par.h). Run alone (one rank) and under
 * `mpirun -np 2` / `-np 4` (tests/CMakeLists.txt): the cases hold for any rank count. */
#include "sq_test.h"
#include "squall/field.h"
#include "squall/par.h"

SQ_LABEL(unit)

/* The known pattern: the value of global cell (i, j, k), exact in float for these sizes. */
static float pattern(int i, int j, int k) { return (float)(i + 100 * j + 10000 * k); }

static int wrap_or_clamp(int i, int n, int periodic)
{
    if (periodic) return ((i % n) + n) % n;
    return i < 0 ? 0 : i >= n ? n - 1 : i;
}

SQ_TEST(decompose_choices)
{
    const int all[3] = {1, 1, 1}, zonly[3] = {0, 0, 1}, per[3] = {1, 1, 0};
    sq_par_block b;
    /* least surface: a cube of 32 splits into 2x2x2 for 8 ranks */
    SQ_CHECK_OK(sq_par_decompose((sq_dims){32, 32, 32}, all, per, 1, 8, 5, &b));
    SQ_CHECK(b.grid[0] == 2 && b.grid[1] == 2 && b.grid[2] == 2);
    SQ_CHECK(b.coord[0] == 1 && b.coord[1] == 0 && b.coord[2] == 1);
    SQ_CHECK(b.lo[0] == 16 && b.lo[1] == 0 && b.lo[2] == 16 && b.n.nx == 16);
    /* 256x128x16 for 4 ranks: slabs across the longest axis cut 4 x 2048 cells of face per
     * block, 2x2 columns 2 x 2048 + 2 x 1024 */
    SQ_CHECK_OK(sq_par_decompose((sq_dims){256, 128, 16}, all, per, 1, 4, 0, &b));
    SQ_CHECK(b.grid[0] == 4 && b.grid[1] == 1 && b.grid[2] == 1);
    SQ_CHECK(b.n.nx == 64 && b.n.ny == 128 && b.n.nz == 16);
    /* neighbours: periodic x wraps (rank 0's lower neighbour is rank 3), closed z has none */
    SQ_CHECK(b.neighbour[0] == 3 && b.neighbour[1] == 1);
    SQ_CHECK(b.neighbour[2] == 0 && b.neighbour[3] == 0);
    SQ_CHECK(b.neighbour[4] == -1 && b.neighbour[5] == -1);
    /* 512x512x16 for 4 ranks: 2x2 columns (2 x 2 x 256 x 16 < 2 x 512 x 16) */
    SQ_CHECK_OK(sq_par_decompose((sq_dims){512, 512, 16}, all, per, 1, 4, 3, &b));
    SQ_CHECK(b.grid[0] == 2 && b.grid[1] == 2 && b.grid[2] == 1);
    SQ_CHECK(b.coord[0] == 1 && b.coord[1] == 1 && b.lo[0] == 256 && b.lo[1] == 256);
    /* slabs: only z may be split; 10 planes over 3 ranks: 3, 3, 4 planes, all covered */
    int covered = 0;
    for (int r = 0; r < 3; r++) {
        SQ_CHECK_OK(sq_par_decompose((sq_dims){8, 8, 10}, zonly, per, 2, 3, r, &b));
        SQ_CHECK(b.grid[2] == 3 && b.grid[0] == 1 && b.grid[1] == 1);
        SQ_CHECK(b.lo[2] == covered);
        covered += b.n.nz;
        SQ_CHECK(b.neighbour[4] == (r == 0 ? -1 : r - 1));
        SQ_CHECK(b.neighbour[5] == (r == 2 ? -1 : r + 1));
        SQ_CHECK(b.neighbour[0] == r); /* periodic x, unsplit: itself */
    }
    SQ_CHECK(covered == 10);
    /* too many ranks for the slabs: refused, naming the lattice and the rank count */
    SQ_CHECK_ERR(sq_par_decompose((sq_dims){8, 8, 10}, zonly, per, 2, 6, 0, &b),
                 SQ_ERR_INVALID_ARG, "8x8x10 lattice cannot be split into 6 blocks along z");
}

/* Every rank fills its block's interior with the pattern, exchanges, and checks every ghost
 * cell against the pattern at the wrapped (periodic) or clamped (closed) global position. */
static void halo_case(sq_dims global, const int split[3], const int periodic[3], int ghost)
{
    SQ_CHECK_OK(sq_par_init(NULL, NULL));
    sq_context *ctx = NULL;
    SQ_CHECK_OK(sq_context_create(NULL, &ctx));
    sq_par_block b;
    SQ_CHECK_OK(sq_par_decompose(global, split, periodic, ghost, sq_par_size(), sq_par_rank(),
                                 &b));
    sq_field3 f;
    SQ_CHECK_OK(sq_field3_create(ctx, b.n, ghost, &f));
    sq_field3_fill(&f, -1.0f);
    for (int k = 0; k < b.n.nz; k++)
        for (int j = 0; j < b.n.ny; j++)
            for (int i = 0; i < b.n.nx; i++)
                *sq_field3_at(&f, i, j, k) = pattern(b.lo[0] + i, b.lo[1] + j, b.lo[2] + k);
    SQ_CHECK_OK(sq_par_halo_exchange(&b, &f));
    const int gn[3] = {global.nx, global.ny, global.nz};
    int64_t bad = 0, checked = 0;
    for (int k = -ghost; k < b.n.nz + ghost; k++)
        for (int j = -ghost; j < b.n.ny + ghost; j++)
            for (int i = -ghost; i < b.n.nx + ghost; i++) {
                const int p[3] = {b.lo[0] + i, b.lo[1] + j, b.lo[2] + k};
                int q[3];
                for (int a = 0; a < 3; a++) q[a] = wrap_or_clamp(p[a], gn[a], periodic[a]);
                const float want = pattern(q[0], q[1], q[2]);
                const float got = *sq_field3_at(&f, i, j, k);
                checked++;
                if (got != want && bad++ < 5)
                    SQ_FAIL_AT("rank %d of %d (grid %dx%dx%d): cell (%d,%d,%d) holds %g, "
                               "expected %g", sq_par_rank(), sq_par_size(), b.grid[0],
                               b.grid[1], b.grid[2], i, j, k, (double)got, (double)want);
            }
    SQ_CHECK(bad == 0);
    /* the blocks tile the lattice */
    int64_t cells = (int64_t)b.n.nx * b.n.ny * b.n.nz;
    sq_par_sum_i64(&cells, 1);
    SQ_CHECK(cells == (int64_t)gn[0] * gn[1] * gn[2]);
    sq_field3_destroy(ctx, &f);
    sq_context_destroy(ctx);
    sq_par_finalize();
}

SQ_TEST(halo_blocks)
{
    const int all[3] = {1, 1, 1}, per[3] = {1, 0, 1};
    halo_case((sq_dims){13, 10, 7}, all, per, 2);
}

SQ_TEST(halo_slabs)
{
    const int zonly[3] = {0, 0, 1}, per[3] = {1, 1, 0};
    halo_case((sq_dims){9, 6, 11}, zonly, per, 1);
}

/* One rank fails (the last): every rank gets its code and its message. */
SQ_TEST(agree_on_failure)
{
    SQ_CHECK_OK(sq_par_init(NULL, NULL));
    const int me = sq_par_rank(), last = sq_par_size() - 1;
    SQ_CHECK_OK(sq_par_agree(SQ_OK));
    sq_result r = SQ_OK;
    if (me == last) r = sq_set_error(SQ_ERR_INVALID_ARG, "block %d: value 7 must be < 5", last);
    char want[64];
    snprintf(want, sizeof want, "block %d: value 7 must be < 5", last);
    SQ_CHECK_ERR(sq_par_agree(r), SQ_ERR_INVALID_ARG, want);
    sq_par_finalize();
}
