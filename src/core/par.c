/* par.c — the process group (MPI_COMM_WORLD), block decomposition and halo exchange of
 * squall/par.h. Without MPI (or before sq_par_init) there is one rank and the calls reduce to
 * their serial equivalents. */
#include <limits.h>
#include <stdlib.h>
#include <string.h>

#include "core/core_internal.h"
#include "squall/par.h"

#if SQ_HAVE_MPI
#include <mpi.h>
#endif

static int par_rank = 0, par_size = 1;
static bool par_active = false; /* sq_par_init joined MPI_COMM_WORLD */
static uint64_t par_sent = 0;
static uint64_t par_meetings = 0; /* collectives and neighbour exchanges with another rank */

bool sq_par_compiled(void) { return SQ_HAVE_MPI != 0; }
int sq_par_rank(void) { return par_rank; }
int sq_par_size(void) { return par_size; }
uint64_t sq_par_bytes_sent(void) { return par_sent; }
uint64_t sq_par_meetings(void) { return par_meetings; }

#if SQ_HAVE_MPI
static void meet(void) { par_meetings++; }
#endif

sq_result sq_par_init(int *argc, char ***argv)
{
#if SQ_HAVE_MPI
    int inited = 0;
    MPI_Initialized(&inited);
    if (!inited) {
        int provided = 0;
        if (MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS)
            return sq_set_error(SQ_ERR_UNSUPPORTED, "MPI_Init_thread failed");
    }
    MPI_Comm_rank(MPI_COMM_WORLD, &par_rank);
    MPI_Comm_size(MPI_COMM_WORLD, &par_size);
    par_active = true;
#else
    (void)argc;
    (void)argv;
#endif
    return SQ_OK;
}

void sq_par_finalize(void)
{
#if SQ_HAVE_MPI
    if (!par_active) return;
    int fin = 0;
    MPI_Finalized(&fin);
    if (!fin) MPI_Finalize();
    par_active = false;
#endif
}

sq_result sq_par_agree(sq_result r)
{
#if SQ_HAVE_MPI
    if (!par_active || par_size == 1) return r;
    int mine = r != SQ_OK ? par_rank : par_size, first = par_size;
    meet();
    MPI_Allreduce(&mine, &first, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    if (first == par_size) return SQ_OK;
    struct {
        int code;
        char text[1024];
    } msg;
    memset(&msg, 0, sizeof msg);
    if (par_rank == first) {
        msg.code = (int)r;
        const char *e = sq_last_error();
        strncpy(msg.text, e ? e : "", sizeof msg.text - 1);
    }
    meet();
    MPI_Bcast(&msg, (int)sizeof msg, MPI_BYTE, first, MPI_COMM_WORLD);
    if (par_rank != first) {
        if (msg.text[0])
            sq_set_error((sq_result)msg.code, "%s", msg.text);
        else
            sq_set_error((sq_result)msg.code, "rank %d failed (%s)", first,
                         sq_result_name((sq_result)msg.code));
    }
    return (sq_result)msg.code;
#else
    return r;
#endif
}

/* ---- decomposition ------------------------------------------------------------------------ */

sq_result sq_par_decompose(sq_dims global, const int split[3], const int periodic[3],
                           int min_cells, int size, int rank, sq_par_block *out)
{
    memset(out, 0, sizeof *out);
    const int n[3] = {global.nx, global.ny, global.nz};
    if (size < 1 || rank < 0 || rank >= size || n[0] < 1 || n[1] < 1 || n[2] < 1)
        return sq_set_error(SQ_ERR_INVALID_ARG, "decompose: %d ranks (rank %d) of a %dx%dx%d "
                            "lattice", size, rank, n[0], n[1], n[2]);
    if (min_cells < 1) min_cells = 1;
    /* every factorisation gx gy gz = size: the least surface of one block wins (ties: the
     * split of the slowest axis first, which keeps the blocks' memory contiguous) */
    double best = -1;
    int g[3] = {0, 0, 0};
    for (int gz = 1; gz <= size; gz++) {
        if (size % gz) continue;
        for (int gy = 1; gy <= size / gz; gy++) {
            if ((size / gz) % gy) continue;
            const int gx = size / gz / gy;
            const int gg[3] = {gx, gy, gz};
            bool ok = true;
            for (int a = 0; a < 3; a++) {
                if (gg[a] > 1 && !(split && split[a])) ok = false;
                if (gg[a] > 1 && n[a] / gg[a] < min_cells) ok = false;
            }
            if (!ok) continue;
            const double b[3] = {(double)n[0] / gx, (double)n[1] / gy, (double)n[2] / gz};
            /* the faces exchanged, then (ties) the whole surface: the most compact block */
            double surf = 0, all = 0;
            for (int a = 0; a < 3; a++) {
                const double face = 2.0 * b[(a + 1) % 3] * b[(a + 2) % 3];
                if (gg[a] > 1) surf += face;
                all += face;
            }
            surf += 1e-6 * all;
            if (best < 0 || surf < best) {
                best = surf;
                g[0] = gx;
                g[1] = gy;
                g[2] = gz;
            }
        }
    }
    if (best < 0) {
        static const char *const names = "xyz";
        char axes[8] = "";
        int na = 0;
        for (int a = 0; a < 3; a++)
            if (split && split[a]) axes[na++] = names[a];
        axes[na] = 0;
        return sq_set_error(SQ_ERR_INVALID_ARG,
                            "a %dx%dx%d lattice cannot be split into %d blocks along %s with at "
                            "least %d cells per block; run with fewer ranks (mpirun -np)",
                            n[0], n[1], n[2], size, na ? axes : "no axis", min_cells);
    }
    out->global = global;
    out->rank = rank;
    out->size = size;
    const int c[3] = {rank % g[0], (rank / g[0]) % g[1], rank / (g[0] * g[1])};
    int nb[3];
    for (int a = 0; a < 3; a++) {
        out->grid[a] = g[a];
        out->coord[a] = c[a];
        out->periodic[a] = periodic && periodic[a] ? 1 : 0;
        const int lo = (int)((int64_t)c[a] * n[a] / g[a]);
        const int hi = (int)((int64_t)(c[a] + 1) * n[a] / g[a]);
        out->lo[a] = lo;
        nb[a] = hi - lo;
    }
    out->n = (sq_dims){nb[0], nb[1], nb[2]};
    for (int a = 0; a < 3; a++)
        for (int s = 0; s < 2; s++) {
            int cc[3] = {c[0], c[1], c[2]};
            cc[a] += s ? 1 : -1;
            if (cc[a] < 0 || cc[a] >= g[a]) {
                if (!out->periodic[a]) {
                    out->neighbour[2 * a + s] = -1;
                    continue;
                }
                cc[a] = (cc[a] + g[a]) % g[a];
            }
            out->neighbour[2 * a + s] = cc[0] + g[0] * (cc[1] + g[1] * cc[2]);
        }
    return SQ_OK;
}

/* ---- halo exchange ------------------------------------------------------------------------ */

/* The box of one face slab: [lo, lo+len) per axis (block-local, ghosts negative). */
typedef struct box {
    int lo[3], len[3];
} box;

static int64_t box_count(const box *b) { return (int64_t)b->len[0] * b->len[1] * b->len[2]; }

static void box_copy_out(const sq_field3 *f, const box *b, float *buf)
{
    int64_t q = 0;
    for (int k = 0; k < b->len[2]; k++)
        for (int j = 0; j < b->len[1]; j++) {
            const float *src = sq_field3_at(f, b->lo[0], b->lo[1] + j, b->lo[2] + k);
            memcpy(buf + q, src, (size_t)b->len[0] * sizeof(float));
            q += b->len[0];
        }
}

static void box_copy_in(sq_field3 *f, const box *b, const float *buf)
{
    int64_t q = 0;
    for (int k = 0; k < b->len[2]; k++)
        for (int j = 0; j < b->len[1]; j++) {
            float *dst = sq_field3_at(f, b->lo[0], b->lo[1] + j, b->lo[2] + k);
            memcpy(dst, buf + q, (size_t)b->len[0] * sizeof(float));
            q += b->len[0];
        }
}

/* Face slabs of axis a: send (interior layers next to face s) and receive (ghost layers beyond
 * it); the other axes span the ghosts of axes exchanged before a. */
static void face_boxes(const sq_field3 *f, int a, int s, int w, box *send, box *recv)
{
    const int n[3] = {f->n.nx, f->n.ny, f->n.nz};
    for (int b = 0; b < 3; b++) {
        const int g = b < a ? f->ghost : 0;
        send->lo[b] = recv->lo[b] = -g;
        send->len[b] = recv->len[b] = n[b] + 2 * g;
    }
    send->len[a] = recv->len[a] = w;
    send->lo[a] = s ? n[a] - w : 0;
    recv->lo[a] = s ? n[a] : -w;
}

/* Zero-gradient fill of the ghost slab beyond face s of axis a. */
static void clamp_fill(sq_field3 *f, const box *recv, int a, int s)
{
    const int n[3] = {f->n.nx, f->n.ny, f->n.nz};
    for (int k = 0; k < recv->len[2]; k++)
        for (int j = 0; j < recv->len[1]; j++)
            for (int i = 0; i < recv->len[0]; i++) {
                int p[3] = {recv->lo[0] + i, recv->lo[1] + j, recv->lo[2] + k};
                int q[3] = {p[0], p[1], p[2]};
                q[a] = s ? n[a] - 1 : 0;
                *sq_field3_at(f, p[0], p[1], p[2]) = *sq_field3_at(f, q[0], q[1], q[2]);
            }
}

sq_result sq_par_halo_exchange(const sq_par_block *b, sq_field3 *f)
{
    if (!b || !f) return sq_set_error(SQ_ERR_INVALID_ARG, "halo exchange: NULL argument");
    if (f->n.nx != b->n.nx || f->n.ny != b->n.ny || f->n.nz != b->n.nz)
        return sq_set_error(SQ_ERR_INVALID_ARG,
                            "halo exchange: field %dx%dx%d does not match the block %dx%dx%d",
                            f->n.nx, f->n.ny, f->n.nz, b->n.nx, b->n.ny, b->n.nz);
    const int g = f->ghost;
    if (g == 0) return SQ_OK;
    const int n[3] = {f->n.nx, f->n.ny, f->n.nz};
    for (int a = 0; a < 3; a++)
        if (n[a] < g && (b->grid[a] > 1 || b->periodic[a]))
            return sq_set_error(SQ_ERR_INVALID_ARG,
                                "halo exchange: block width %d along axis %d is below the %d "
                                "ghost layers", n[a], a, g);
    for (int a = 0; a < 3; a++) {
        box send[2], recv[2];
        int64_t cnt[2];
        for (int s = 0; s < 2; s++) {
            face_boxes(f, a, s, g, &send[s], &recv[s]);
            cnt[s] = box_count(&send[s]);
        }
        if (cnt[0] > INT_MAX)
            return sq_set_error(SQ_ERR_TOO_LARGE, "halo exchange: a face of %lld values",
                                (long long)cnt[0]);
        float *buf = (float *)malloc((size_t)(4 * cnt[0]) * sizeof(float));
        if (!buf) return sq_set_error(SQ_ERR_OUT_OF_MEMORY, "halo exchange buffers");
        float *sb[2] = {buf, buf + cnt[0]}, *rb[2] = {buf + 2 * cnt[0], buf + 3 * cnt[0]};
#if SQ_HAVE_MPI
        MPI_Request req[4];
        int nreq = 0;
#endif
        bool got[2] = {false, false};
        for (int s = 0; s < 2; s++) {
            const int nbr = b->neighbour[2 * a + s];
            if (nbr < 0) continue;
            box_copy_out(f, &send[s], sb[s]);
            if (nbr == b->rank) { /* periodic, unsplit: this rank's opposite face */
                memcpy(rb[1 - s], sb[s], (size_t)cnt[s] * sizeof(float));
                got[1 - s] = true;
                continue;
            }
#if SQ_HAVE_MPI
            /* tag: the face the data enters (the receiver's face 1 − s) */
            MPI_Irecv(rb[s], (int)cnt[s], MPI_FLOAT, nbr, 2 * a + s, MPI_COMM_WORLD,
                      &req[nreq++]);
            MPI_Isend(sb[s], (int)cnt[s], MPI_FLOAT, nbr, 2 * a + (1 - s), MPI_COMM_WORLD,
                      &req[nreq++]);
            par_sent += (uint64_t)cnt[s] * sizeof(float);
            got[s] = true;
#endif
        }
#if SQ_HAVE_MPI
        if (nreq) meet();
        if (nreq) MPI_Waitall(nreq, req, MPI_STATUSES_IGNORE);
#endif
        for (int s = 0; s < 2; s++) {
            if (got[s])
                box_copy_in(f, &recv[s], rb[s]);
            else
                clamp_fill(f, &recv[s], a, s);
        }
        free(buf);
    }
    return SQ_OK;
}

sq_result sq_par_exchange_begin(const int nb[2], const void *const sbuf[2],
                                const size_t bytes[2], void *const rbuf[2], const size_t rbytes[2],
                                sq_par_exchange *x)
{
    x->count = 0;
    for (int s = 0; s < 2; s++)
        if (bytes[s] > INT_MAX || rbytes[s] > INT_MAX)
            return sq_set_error(SQ_ERR_TOO_LARGE, "exchange: a message of %zu bytes",
                                bytes[s] > rbytes[s] ? bytes[s] : rbytes[s]);
#if SQ_HAVE_MPI
    _Static_assert(4 * sizeof(MPI_Request) <= sizeof x->requests, "sq_par_exchange too small");
    MPI_Request req[4];
#endif
    for (int s = 0; s < 2; s++) {
        if (nb[s] < 0) continue;
        if (nb[s] == par_rank) {
            if (nb[1 - s] == par_rank && rbytes[s] == bytes[1 - s])
                memcpy(rbuf[s], sbuf[1 - s], rbytes[s]);
            continue;
        }
#if SQ_HAVE_MPI
        /* tag: the direction of travel (1 toward plus, 0 toward minus) */
        MPI_Irecv(rbuf[s], (int)rbytes[s], MPI_BYTE, nb[s], 1 - s, MPI_COMM_WORLD,
                  &req[x->count++]);
        MPI_Isend(sbuf[s], (int)bytes[s], MPI_BYTE, nb[s], s, MPI_COMM_WORLD, &req[x->count++]);
        par_sent += bytes[s];
#endif
    }
#if SQ_HAVE_MPI
    memcpy(x->requests, req, (size_t)x->count * sizeof(MPI_Request));
#endif
    return SQ_OK;
}

void sq_par_exchange_end(sq_par_exchange *x)
{
#if SQ_HAVE_MPI
    if (x->count > 0) {
        MPI_Request req[4];
        memcpy(req, x->requests, (size_t)x->count * sizeof(MPI_Request));
        meet();
        MPI_Waitall(x->count, req, MPI_STATUSES_IGNORE);
    }
#endif
    x->count = 0;
}

sq_result sq_par_exchange_pair(const int nb[2], const void *const sbuf[2],
                               const size_t bytes[2], void *const rbuf[2], const size_t rbytes[2])
{
    sq_par_exchange x;
    const sq_result r = sq_par_exchange_begin(nb, sbuf, bytes, rbuf, rbytes, &x);
    sq_par_exchange_end(&x);
    return r;
}

/* ---- reductions and gathers --------------------------------------------------------------- */

void sq_par_sum_i64(int64_t *v, int n)
{
#if SQ_HAVE_MPI
    if (par_active && par_size > 1) {
        meet();
        MPI_Allreduce(MPI_IN_PLACE, v, n, MPI_INT64_T, MPI_SUM, MPI_COMM_WORLD);
    }
#else
    (void)v;
    (void)n;
#endif
}

void sq_par_sum_f64(double *v, int n)
{
#if SQ_HAVE_MPI
    if (par_active && par_size > 1) {
        meet();
        MPI_Allreduce(MPI_IN_PLACE, v, n, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
    }
#else
    (void)v;
    (void)n;
#endif
}

void sq_par_sum_f32(float *v, int n)
{
#if SQ_HAVE_MPI
    if (par_active && par_size > 1) {
        meet();
        MPI_Allreduce(MPI_IN_PLACE, v, n, MPI_FLOAT, MPI_SUM, MPI_COMM_WORLD);
    }
#else
    (void)v;
    (void)n;
#endif
}

void sq_par_max_f64(double *v, int n)
{
#if SQ_HAVE_MPI
    if (par_active && par_size > 1) {
        meet();
        MPI_Allreduce(MPI_IN_PLACE, v, n, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    }
#else
    (void)v;
    (void)n;
#endif
}

void sq_par_min_i64(int64_t *v, int n)
{
#if SQ_HAVE_MPI
    if (par_active && par_size > 1) {
        meet();
        MPI_Allreduce(MPI_IN_PLACE, v, n, MPI_INT64_T, MPI_MIN, MPI_COMM_WORLD);
    }
#else
    (void)v;
    (void)n;
#endif
}

void sq_par_sum_max_f64(double *v, int nsum, int nmax)
{
#if SQ_HAVE_MPI
    const int n = nsum + nmax;
    if (!par_active || par_size == 1 || n <= 0) return;
    /* every rank's values to every rank, reduced here in rank order (the same numbers on
     * every rank whatever the MPI's reduction tree); long vectors: two reductions */
    enum { STACK = 4096 };
    if ((int64_t)n * par_size > STACK) {
        sq_par_sum_f64(v, nsum);
        sq_par_max_f64(v + nsum, nmax);
        return;
    }
    double all[STACK];
    meet();
    par_sent += (uint64_t)n * sizeof(double) * (uint64_t)(par_size - 1);
    MPI_Allgather(v, n, MPI_DOUBLE, all, n, MPI_DOUBLE, MPI_COMM_WORLD);
    for (int i = 0; i < n; i++) {
        double x = all[i];
        for (int r = 1; r < par_size; r++) {
            const double y = all[(size_t)r * (size_t)n + (size_t)i];
            x = i < nsum ? x + y : (y > x ? y : x);
        }
        v[i] = x;
    }
#else
    (void)v;
    (void)nsum;
    (void)nmax;
#endif
}

void sq_par_broadcast(void *data, size_t bytes, int root)
{
#if SQ_HAVE_MPI
    if (par_active && par_size > 1 && bytes > 0) {
        if (par_rank == root) par_sent += (uint64_t)bytes * (uint64_t)(par_size - 1);
        meet();
        MPI_Bcast(data, (int)bytes, MPI_BYTE, root, MPI_COMM_WORLD);
    }
#else
    (void)data;
    (void)bytes;
    (void)root;
#endif
}

/* Allgatherv (root < 0) or Gatherv to root (out needed on root only) of elements of `elem`
 * bytes: 1 (bytes), 4 (floats, or unsigned 32-bit integers when `integer`), 8 (doubles, or
 * signed 64-bit integers when `integer`). */
static sq_result gather(const void *mine, const int64_t *counts, void *out, size_t elem, int root,
                        bool integer)
{
    (void)integer; /* unused without MPI */
    (void)root; /* unused without MPI */
    if (par_size == 1 || !par_active) {
        if (out && out != mine) memmove(out, mine, (size_t)counts[0] * elem);
        return SQ_OK;
    }
#if SQ_HAVE_MPI
    int *cnt = (int *)malloc(2 * (size_t)par_size * sizeof(int));
    if (!cnt) return sq_set_error(SQ_ERR_OUT_OF_MEMORY, "gather counts");
    int *disp = cnt + par_size;
    int64_t at = 0;
    for (int r = 0; r < par_size; r++) {
        if (counts[r] > INT_MAX || at > INT_MAX) {
            free(cnt);
            return sq_set_error(SQ_ERR_TOO_LARGE,
                                "gather: %lld values per rank exceed MPI's int counts",
                                (long long)counts[r]);
        }
        cnt[r] = (int)counts[r];
        disp[r] = (int)at;
        at += counts[r];
    }
    const MPI_Datatype t = elem == 1   ? MPI_UINT8_T
                           : elem == 4 ? (integer ? MPI_UINT32_T : MPI_FLOAT)
                                       : (integer ? MPI_INT64_T : MPI_DOUBLE);
    if (root < 0) {
        par_sent += (uint64_t)counts[par_rank] * elem * (uint64_t)(par_size - 1);
        meet();
        MPI_Allgatherv(mine, cnt[par_rank], t, out, cnt, disp, t, MPI_COMM_WORLD);
    } else {
        if (par_rank != root) par_sent += (uint64_t)counts[par_rank] * elem;
        meet();
        MPI_Gatherv(mine, cnt[par_rank], t, out, cnt, disp, t, root, MPI_COMM_WORLD);
    }
    free(cnt);
#endif
    return SQ_OK;
}

sq_result sq_par_allgather_f32(const float *mine, const int64_t *counts, float *out)
{
    return gather(mine, counts, out, sizeof(float), -1, false);
}

sq_result sq_par_gather_f32(const float *mine, const int64_t *counts, float *out)
{
    return gather(mine, counts, out, sizeof(float), 0, false);
}

sq_result sq_par_allgather_f64(const double *mine, const int64_t *counts, double *out)
{
    return gather(mine, counts, out, sizeof(double), -1, false);
}

sq_result sq_par_allgather_i64(const int64_t *mine, const int64_t *counts, int64_t *out)
{
    return gather(mine, counts, out, sizeof(int64_t), -1, true);
}

sq_result sq_par_gather_u32(const uint32_t *mine, const int64_t *counts, uint32_t *out)
{
    return gather(mine, counts, out, sizeof(uint32_t), 0, true);
}

sq_result sq_par_gather_u8(const uint8_t *mine, const int64_t *counts, uint8_t *out)
{
    return gather(mine, counts, out, 1, 0, true);
}
