/* clouds_cluster.c — structured particles (SPEC 8.3; S4 §2.1–2.2, eqs 1–3): the per-attribute
 * similarity measures, the global similarity with per-attribute thresholds sigma(a), the
 * "leader" clustering, and the aggregation of a cluster into one structured particle.
 *
 * Measures, with the SPEC's guards:
 *   (1) continuous  lambda = 1 - |v_i - v_j| / (max(a) - min(a)); max = min -> 1 (one value);
 *   (2) ordinal     lambda = 1 - |i - j| / (t - 1) on ranks of t sorted values; t = 1 -> 1;
 *   (3) symbolic    lambda = 1 - sum_k |P(a = v_i, d = k) - P(a = v_j, d = k)| / P(d = k),
 *       classes with P(d = k) = 0 skipped, clamped to [0, 1] (the sum can exceed 1), or the
 *       normalised value-difference metric 1 - 1/2 sum_k |P(d=k | v_i) - P(d=k | v_j)|.
 * Two particles are similar iff every attribute's lambda >= sigma(a).
 *
 * Leader clustering (S4 §2.2 step 3): particle 0 is the first seed; every unmarked particle
 * similar to the seed joins its cluster; the next seed is the next unmarked particle of a
 * FIXED pseudo-random order (Philox, params seed) — deterministic, unlike S4's random pick.
 * The naive algorithm scans all particles per seed, O(N x clusters). The grid pre-pass
 * buckets particles by position with buckets at least as large as the position thresholds
 * allow (|x_i - x_j| <= (1 - sigma_x)(max x - min x)), so a seed only scans the 3x3x3 buckets
 * around it: O(N x particles per neighbourhood). Both give identical clusters: membership is
 * decided by the seed alone, so the scan order does not matter (tests/clouds check it). */
#include <math.h>
#include <string.h>

#include "clouds_internal.h"
#include "squall/rng.h"

#define CLUSTER_RNG_STREAM 0x636c75737465ull /* "cluste" */
#define BUCKET_MARGIN 1.001f                 /* buckets slightly larger than the threshold */

/* ---- measures (1)–(3) -------------------------------------------------------------------- */
float sq__sim_continuous(float vi, float vj, float amin, float amax)
{
    const float range = amax - amin;
    if (!(range > 0.0f)) return 1.0f; /* guard: one value only */
    const float l = 1.0f - fabsf(vi - vj) / range;
    return l < 0.0f ? 0.0f : (l > 1.0f ? 1.0f : l);
}

float sq__sim_ordinal(int ri, int rj, int t)
{
    if (t <= 1) return 1.0f;
    const int d = ri > rj ? ri - rj : rj - ri;
    const float l = 1.0f - (float)d / (float)(t - 1);
    return l < 0.0f ? 0.0f : l;
}

float sq__sim_symbolic(const sq__symbolic_table *s, int vi, int vj)
{
    if (vi == vj) return 1.0f;
    double sum = 0.0;
    for (int k = 0; k < s->classes; k++) {
        const double pk = (double)s->p_class[k];
        if (!(pk > 0.0)) continue; /* guard: an empty class contributes nothing */
        sum += fabs((double)s->p_joint[vi * s->classes + k] - (double)s->p_joint[vj * s->classes + k]) / pk;
    }
    const double l = 1.0 - sum;
    return l < 0.0 ? 0.0f : (l > 1.0 ? 1.0f : (float)l);
}

float sq__sim_symbolic_vdm(const sq__symbolic_table *s, int vi, int vj)
{
    if (vi == vj) return 1.0f;
    double pvi = 0.0, pvj = 0.0;
    for (int k = 0; k < s->classes; k++) {
        pvi += (double)s->p_joint[vi * s->classes + k];
        pvj += (double)s->p_joint[vj * s->classes + k];
    }
    double sum = 0.0;
    for (int k = 0; k < s->classes; k++) {
        const double a = pvi > 0.0 ? (double)s->p_joint[vi * s->classes + k] / pvi : 0.0;
        const double b = pvj > 0.0 ? (double)s->p_joint[vj * s->classes + k] / pvj : 0.0;
        sum += fabs(a - b);
    }
    const double l = 1.0 - 0.5 * sum;
    return l < 0.0 ? 0.0f : (l > 1.0 ? 1.0f : (float)l);
}

void sq__symbolic_table_build(sq__symbolic_table *s, const uint8_t *value, const int32_t *cls,
                              int n)
{
    memset(s->p_joint, 0, sizeof s->p_joint);
    memset(s->p_class, 0, sizeof s->p_class);
    if (n <= 0) return;
    const float w = 1.0f / (float)n;
    for (int i = 0; i < n; i++) {
        const int v = value[i] < SQ__MAX_SYMBOLS ? value[i] : SQ__MAX_SYMBOLS - 1;
        int k = cls[i];
        if (k < 0) k = 0;
        if (k >= s->classes) k = s->classes - 1;
        s->p_joint[v * s->classes + k] += w;
        s->p_class[k] += w;
    }
}

/* ---- global similarity -------------------------------------------------------------------- */
bool sq__particles_similar(const sq__cluster_input *in, const sq__cluster_params *p,
                           const sq__cluster_ranges *rg, int i, int j)
{
    for (int a = 0; a < 3; a++)
        if (sq__sim_continuous(in->pos[3 * i + a], in->pos[3 * j + a], rg->lo[a], rg->hi[a]) <
            p->sigma_pos[a])
            return false;
    if (sq__sim_continuous(in->density[i], in->density[j], rg->lo[3], rg->hi[3]) <
        p->sigma_density)
        return false;
    if (sq__sim_ordinal(in->stage[i], in->stage[j], in->stages) < p->sigma_stage) return false;
    const float ls = p->symbolic_vdm ? sq__sim_symbolic_vdm(in->symbols, in->phase[i], in->phase[j])
                                     : sq__sim_symbolic(in->symbols, in->phase[i], in->phase[j]);
    return ls >= p->sigma_phase;
}

void sq__cluster_ranges_compute(const sq__cluster_input *in, sq__cluster_ranges *rg)
{
    for (int a = 0; a < 4; a++) {
        rg->lo[a] = INFINITY;
        rg->hi[a] = -INFINITY;
    }
    for (int i = 0; i < in->n; i++) {
        for (int a = 0; a < 3; a++) {
            rg->lo[a] = fminf(rg->lo[a], in->pos[3 * i + a]);
            rg->hi[a] = fmaxf(rg->hi[a], in->pos[3 * i + a]);
        }
        rg->lo[3] = fminf(rg->lo[3], in->density[i]);
        rg->hi[3] = fmaxf(rg->hi[3], in->density[i]);
    }
    if (in->n == 0)
        for (int a = 0; a < 4; a++) rg->lo[a] = rg->hi[a] = 0.0f;
}

/* ---- workspace ------------------------------------------------------------------------------ */
sq_result sq__cluster_reserve(sq_context *ctx, sq__clustering *c, int n)
{
    if (n <= c->cap) return SQ_OK;
    sq__cluster_free(ctx, c);
    const size_t cap = (size_t)n + (size_t)n / 4 + 64;
    const size_t nb = 4 * cap + 64; /* buckets: at most ~4 per particle (see grid_setup) */
    c->label = sq_alloc(ctx, cap * sizeof(int32_t));
    c->order = sq_alloc(ctx, cap * sizeof(int32_t));
    c->sorted = sq_alloc(ctx, cap * sizeof(int32_t));
    c->bucket_of = sq_alloc(ctx, cap * sizeof(int32_t));
    c->bucket_start = sq_alloc(ctx, (nb + 1) * sizeof(int32_t));
    if (!c->label || !c->order || !c->sorted || !c->bucket_of || !c->bucket_start) {
        sq__cluster_free(ctx, c);
        return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "clouds", "no memory to cluster %d particles",
                        n);
    }
    c->cap = (int)cap;
    c->bucket_cap = (int)nb;
    return SQ_OK;
}

void sq__cluster_free(sq_context *ctx, sq__clustering *c)
{
    sq_free(ctx, c->label);
    sq_free(ctx, c->order);
    sq_free(ctx, c->sorted);
    sq_free(ctx, c->bucket_of);
    sq_free(ctx, c->bucket_start);
    memset(c, 0, sizeof *c);
}

/* Seed order: particle 0 first (S4: "take particle 1 as the seed"), then a Fisher–Yates
 * permutation of the others from Philox with the given seed. */
static void seed_order(int32_t *order, int n, uint64_t seed)
{
    for (int i = 0; i < n; i++) order[i] = i;
    for (int i = n - 1; i > 1; i--) {
        const uint32_t u = (uint32_t)(sq_rng_uniform_d(seed, CLUSTER_RNG_STREAM, (uint64_t)i) *
                                      (double)i); /* in [0, i-1] */
        const int j = 1 + (int)(u < (uint32_t)i ? u : (uint32_t)(i - 1)); /* in [1, i] */
        const int32_t t = order[i];
        order[i] = order[j];
        order[j] = t;
    }
}

/* Bucket sizes >= the position thresholds, grown until the grid has at most bucket_cap
 * buckets. */
static void grid_setup(sq__clustering *c, const sq__cluster_params *p,
                       const sq__cluster_ranges *rg)
{
    for (int a = 0; a < 3; a++) {
        const float range = rg->hi[a] - rg->lo[a];
        const float h = (1.0f - p->sigma_pos[a]) * range;
        c->bsize[a] = range > 0.0f ? fmaxf(h * BUCKET_MARGIN, range * 1e-4f) : 1.0f;
    }
    for (;;) {
        long long total = 1;
        for (int a = 0; a < 3; a++) {
            const float range = rg->hi[a] - rg->lo[a];
            c->dims[a] = range > 0.0f ? (int)floorf(range / c->bsize[a]) + 1 : 1;
            if (c->dims[a] < 1) c->dims[a] = 1;
            total *= c->dims[a];
        }
        if (total <= c->bucket_cap) break;
        for (int a = 0; a < 3; a++) c->bsize[a] *= 1.26f;
    }
}

static int bucket_coord(const sq__clustering *c, const sq__cluster_ranges *rg, float v, int a)
{
    int b = (int)floorf((v - rg->lo[a]) / c->bsize[a]);
    if (b < 0) b = 0;
    if (b >= c->dims[a]) b = c->dims[a] - 1;
    return b;
}

/* Counting sort of the particles by bucket. */
static void grid_fill(sq__clustering *c, const sq__cluster_input *in, const sq__cluster_ranges *rg)
{
    const int nb = c->dims[0] * c->dims[1] * c->dims[2];
    memset(c->bucket_start, 0, (size_t)(nb + 1) * sizeof(int32_t));
    for (int i = 0; i < in->n; i++) {
        const int bx = bucket_coord(c, rg, in->pos[3 * i + 0], 0);
        const int by = bucket_coord(c, rg, in->pos[3 * i + 1], 1);
        const int bz = bucket_coord(c, rg, in->pos[3 * i + 2], 2);
        const int b = (bz * c->dims[1] + by) * c->dims[0] + bx;
        c->bucket_of[i] = b;
        c->bucket_start[b + 1]++;
    }
    for (int b = 0; b < nb; b++) c->bucket_start[b + 1] += c->bucket_start[b];
    /* stable placement with bucket_start as the cursor, shifted back afterwards */
    for (int i = 0; i < in->n; i++) {
        const int b = c->bucket_of[i];
        c->sorted[c->bucket_start[b]++] = i;
    }
    for (int b = nb; b > 0; b--) c->bucket_start[b] = c->bucket_start[b - 1];
    c->bucket_start[0] = 0;
}

static void join_if_similar(sq__clustering *c, const sq__cluster_input *in,
                            const sq__cluster_params *p, const sq__cluster_ranges *rg, int s,
                            int j, int id)
{
    if (c->label[j] >= 0) return;
    if (sq__particles_similar(in, p, rg, s, j)) c->label[j] = id;
}

sq_result sq__cluster_leader(sq_context *ctx, sq__clustering *c, const sq__cluster_input *in,
                             const sq__cluster_params *p, bool use_grid)
{
    sq_result res = sq__cluster_reserve(ctx, c, in->n);
    if (res != SQ_OK) return res;
    const int n = in->n;
    c->n = n;
    c->clusters = 0;
    c->comparisons = 0;
    sq__cluster_ranges_compute(in, &c->ranges);
    const sq__cluster_ranges *rg = &c->ranges;
    if (c->order_n != n || c->order_seed != p->seed) {
        seed_order(c->order, n, p->seed);
        c->order_n = n;
        c->order_seed = p->seed;
    }
    if (use_grid) {
        grid_setup(c, p, rg);
        grid_fill(c, in, rg);
    }
    for (int i = 0; i < n; i++) c->label[i] = -1;
    for (int q = 0; q < n; q++) {
        const int s = c->order[q];
        if (c->label[s] >= 0) continue;
        const int id = c->clusters++;
        c->label[s] = id;
        if (!use_grid) {
            for (int j = 0; j < n; j++) join_if_similar(c, in, p, rg, s, j, id);
            c->comparisons += (uint64_t)n;
            continue;
        }
        const int bx = bucket_coord(c, rg, in->pos[3 * s + 0], 0);
        const int by = bucket_coord(c, rg, in->pos[3 * s + 1], 1);
        const int bz = bucket_coord(c, rg, in->pos[3 * s + 2], 2);
        for (int z = bz - 1; z <= bz + 1; z++) {
            if (z < 0 || z >= c->dims[2]) continue;
            for (int y = by - 1; y <= by + 1; y++) {
                if (y < 0 || y >= c->dims[1]) continue;
                for (int x = bx - 1; x <= bx + 1; x++) {
                    if (x < 0 || x >= c->dims[0]) continue;
                    const int b = (z * c->dims[1] + y) * c->dims[0] + x;
                    for (int k = c->bucket_start[b]; k < c->bucket_start[b + 1]; k++)
                        join_if_similar(c, in, p, rg, s, c->sorted[k], id);
                    c->comparisons += (uint64_t)(c->bucket_start[b + 1] - c->bucket_start[b]);
                }
            }
        }
    }
    return SQ_OK;
}

/* ---- structured particles ---------------------------------------------------------------- */
void sq__cluster_aggregate(const sq__clustering *c, const sq__cluster_input *in,
                           const float *radius, const float *tau, sq__structured *out)
{
    const int m = c->clusters;
    for (int k = 0; k < m; k++) {
        out->pos[3 * k] = out->pos[3 * k + 1] = out->pos[3 * k + 2] = 0.0f;
        out->radius[k] = out->tau[k] = out->density[k] = 0.0f;
        out->weight[k] = 0.0f;
        out->members[k] = 0;
        out->cloud[k] = -1;
    }
    /* optical cross-section weights w = tau r² (integral of the splat's optical depth) */
    for (int i = 0; i < in->n; i++) {
        const int k = c->label[i];
        const float w = tau[i] * radius[i] * radius[i] + 1e-30f;
        out->weight[k] += w;
        for (int a = 0; a < 3; a++) out->pos[3 * k + a] += w * in->pos[3 * i + a];
        out->density[k] += w * in->density[i];
        out->members[k]++;
        if (out->cloud[k] < 0) out->cloud[k] = in->cls[i];
    }
    for (int k = 0; k < m; k++) {
        const float inv = 1.0f / out->weight[k];
        for (int a = 0; a < 3; a++) out->pos[3 * k + a] *= inv;
        out->density[k] *= inv;
    }
    /* second moment: r_c² = sum w (r_i² + |x_i - c|²) / sum w, so the cluster covers its
     * members' spread; tau_c keeps the total cross-section: tau_c r_c² = sum tau_i r_i² */
    for (int i = 0; i < in->n; i++) {
        const int k = c->label[i];
        const float w = tau[i] * radius[i] * radius[i] + 1e-30f;
        float d2 = 0.0f;
        for (int a = 0; a < 3; a++) {
            const float d = in->pos[3 * i + a] - out->pos[3 * k + a];
            d2 += d * d;
        }
        out->radius[k] += w * (radius[i] * radius[i] + d2);
    }
    for (int k = 0; k < m; k++) {
        const float r2 = out->radius[k] / out->weight[k];
        out->radius[k] = sqrtf(r2);
        out->tau[k] = out->weight[k] / r2;
    }
}
