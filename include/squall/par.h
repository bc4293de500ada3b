/* squall/par.h — distributed runs (MPI): the process group, the decomposition of a lattice into
 * blocks (one per rank) and the halo exchange of fields with ghost layers (docs/mpi.md).
 *
 * Under `mpirun -np N` (a build with MPI, feature "mpi") the group is MPI_COMM_WORLD, once
 * sq_par_init has been called. Without MPI, or before sq_par_init, there is one rank and every
 * call below is its serial equivalent (the exchange fills ghosts as sq_field3_fill_ghosts does).
 *
 * Collective calls (marked so) must be made by every rank in the same order. */
#ifndef SQ_PAR_H
#define SQ_PAR_H

#include <stdbool.h>
#include <stdint.h>

#include "squall/core.h"
#include "squall/field.h"

#ifdef __cplusplus
extern "C" {
#endif

/* One rank's block of a global lattice. Faces are numbered x−, x+, y−, y+, z−, z+. */
typedef struct sq_par_block {
    sq_dims global;    /* the whole lattice */
    int grid[3];       /* blocks per axis; grid[0]*grid[1]*grid[2] = size */
    int coord[3];      /* this block's place in the block grid */
    int lo[3];         /* global index of the block's first cell per axis */
    sq_dims n;         /* cells of the block */
    int periodic[3];   /* the global lattice wraps along this axis */
    int neighbour[6];  /* rank across each face; -1 where the global lattice ends (closed face);
                        * this rank itself where a periodic axis is not split */
    int rank, size;
} sq_par_block;

/* Joins the process group (MPI_Init_thread, funneled: OpenMP threads inside a rank, MPI calls
 * from the main thread). Harmless to call without mpirun (one rank) or twice. */
SQ_API sq_result sq_par_init(int *argc, char ***argv);
/* Leaves it (MPI_Finalize); no sq_par call may follow except sq_par_rank/size. */
SQ_API void sq_par_finalize(void);
SQ_API int sq_par_rank(void);
SQ_API int sq_par_size(void);
/* Whether this build can run distributed (compiled with MPI). */
SQ_API bool sq_par_compiled(void);

/* Collective: every rank passes its own result; all get the result of the lowest-numbered
 * failing rank (SQ_OK if none), and that rank's error text becomes every rank's
 * sq_last_error(). A rank that fails on its own block thus ends every rank with one message
 * instead of leaving the others waiting in the next exchange. */
SQ_API sq_result sq_par_agree(sq_result r);

/* Chooses the block grid for `size` ranks: the factorisation size = gx gy gz with the least
 * halo surface per block, splitting only the axes with split[a] != 0, every block at least
 * min_cells wide along a split axis (blocks of one axis differ by at most one cell). Fails
 * with SQ_ERR_INVALID_ARG naming the lattice and the rank count when no grid fits. Not
 * collective (a pure function of its arguments). */
SQ_API sq_result sq_par_decompose(sq_dims global, const int split[3], const int periodic[3],
                                  int min_cells, int size, int rank, sq_par_block *out);

/* Collective: fills the ghost layers of f (a field of the block's size) from the neighbouring
 * blocks with non-blocking sends and receives, axis by axis (x, y, z; an axis' range includes
 * the ghosts filled before, which carries edges and corners). Closed faces get the nearest
 * interior value (zero gradient), as sq_field3_fill_ghosts. Fails if f does not match b. */
SQ_API sq_result sq_par_halo_exchange(const sq_par_block *b, sq_field3 *f);

/* Between neighbours: sends sbuf[s] (bytes[s]) to rank nb[s] and receives rbuf[s]
 * (rbytes[s]) from it, s = 0 the minus side, 1 the plus side, all four transfers non-blocking
 * at once. What this rank sends to its plus side arrives in that rank's rbuf[0]. nb[s] < 0:
 * nothing on that side; nb[s] = this rank: sbuf[1 - s] is copied into rbuf[s] (periodic). */
SQ_API sq_result sq_par_exchange_pair(const int nb[2], const void *const sbuf[2],
                                      const size_t bytes[2], void *const rbuf[2],
                                      const size_t rbytes[2]);

/* The same in two halves, so that work can be done while the data travels: begin posts the
 * four transfers (the buffers must stay untouched until end), end waits for them. */
typedef struct sq_par_exchange {
    unsigned char requests[128]; /* MPI requests (opaque) */
    int count;
} sq_par_exchange;
/* Posts the transfers of sq_par_exchange_pair into x; errors as sq_par_exchange_pair. */
SQ_API sq_result sq_par_exchange_begin(const int nb[2], const void *const sbuf[2],
                                       const size_t bytes[2], void *const rbuf[2],
                                       const size_t rbytes[2], sq_par_exchange *x);
/* Waits until the transfers posted into x are complete (their buffers may then be used). */
SQ_API void sq_par_exchange_end(sq_par_exchange *x);

/* Collective reductions over all ranks (in place). Integer sums are exact; a double sum's
 * rounding may depend on the rank count (use per-block partials gathered in a fixed order
 * where results must not). */
SQ_API void sq_par_sum_i64(int64_t *v, int n);
SQ_API void sq_par_sum_f64(double *v, int n);
SQ_API void sq_par_sum_f32(float *v, int n);
SQ_API void sq_par_max_f64(double *v, int n);
SQ_API void sq_par_min_i64(int64_t *v, int n);
/* Collective, one meeting: v[0 .. nsum) become their sums over the ranks (added in rank
 * order) and v[nsum .. nsum + nmax) their largest values; every rank passes the same counts.
 * Several small sums and maxima of one stage in one message. */
SQ_API void sq_par_sum_max_f64(double *v, int nsum, int nmax);
/* Collective: rank `root` sends `bytes` at data to every rank. */
SQ_API void sq_par_broadcast(void *data, size_t bytes, int root);
/* Collective: concatenates every rank's `counts[rank]` floats (rank order) into out on every
 * rank (out holds the sum of counts). */
SQ_API sq_result sq_par_allgather_f32(const float *mine, const int64_t *counts, float *out);
/* Collective: the same into out on rank 0 only (out may be NULL on the other ranks). */
SQ_API sq_result sq_par_gather_f32(const float *mine, const int64_t *counts, float *out);
/* Collective: the same as sq_par_allgather_f32 for doubles. */
SQ_API sq_result sq_par_allgather_f64(const double *mine, const int64_t *counts, double *out);
/* Collective: the same for 64-bit integers (on every rank), and for unsigned 32-bit integers
 * and bytes (on rank 0 only, as sq_par_gather_f32). */
SQ_API sq_result sq_par_allgather_i64(const int64_t *mine, const int64_t *counts, int64_t *out);
SQ_API sq_result sq_par_gather_u32(const uint32_t *mine, const int64_t *counts, uint32_t *out);
SQ_API sq_result sq_par_gather_u8(const uint8_t *mine, const int64_t *counts, uint8_t *out);

/* Bytes this rank sent through sq_par calls since sq_par_init (communication volume for the
 * benchmarks). */
SQ_API uint64_t sq_par_bytes_sent(void);
/* Meetings this rank took part in since sq_par_init: every collective (sum, maximum,
 * broadcast, gather, agreement) and every exchange with a neighbouring rank counts one; a
 * meeting waits for the slowest partner, so their number per step is what a contended or
 * high-latency network pays (benchmarks). */
SQ_API uint64_t sq_par_meetings(void);

#ifdef __cplusplus
}
#endif
#endif
