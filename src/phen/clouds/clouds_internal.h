/* clouds_internal.h — the clouds phenomenon's private types and kernels (SPEC §8, S4; issue 10):
 * the structured-particle clustering (clouds_cluster.c), the cloud field with its time series,
 * optics and sub-grid structure (clouds_field.c), cloud segmentation (clouds_segment.c), the
 * particle system (clouds_particles.c) and the phenomenon object (clouds.c). */
#ifndef SQ_CLOUDS_INTERNAL_H
#define SQ_CLOUDS_INTERNAL_H

#include <stdbool.h>
#include <stdint.h>

#include "core/core_internal.h"
#include "squall/clouds.h"
#include "squall/drawable.h"
#include "squall/optics.h"

/* ==== structured particles: similarity and leader clustering (clouds_cluster.c) ============= */

#define SQ__MAX_SYMBOLS 4   /* values of the symbolic attribute (hydrometeor phase) */
#define SQ__MAX_CLASSES 64  /* classes d of measure (3) (clouds; larger ids share the last) */

/* Probabilities for measure (3): p_joint[v * classes + k] = P(a = v and d = k), p_class[k] =
 * P(d = k), estimated from the particles. */
typedef struct sq__symbolic_table {
    int classes;
    float p_joint[SQ__MAX_SYMBOLS * SQ__MAX_CLASSES];
    float p_class[SQ__MAX_CLASSES];
} sq__symbolic_table;

/* Measure (1): continuous attribute with range [amin, amax]; 1 when amax == amin. */
float sq__sim_continuous(float vi, float vj, float amin, float amax);
/* Measure (2): ordinal attribute, ranks ri, rj of t sorted values; 1 when t <= 1. */
float sq__sim_ordinal(int ri, int rj, int t);
/* Measure (3) as S4 prints it, empty classes skipped, clamped to [0, 1]. */
float sq__sim_symbolic(const sq__symbolic_table *s, int vi, int vj);
/* The normalised value-difference metric 1 - 1/2 sum_k |P(d=k|v_i) - P(d=k|v_j)| (SPEC 8.3). */
float sq__sim_symbolic_vdm(const sq__symbolic_table *s, int vi, int vj);
/* Fills p_joint, p_class from n (value, class) pairs; s->classes must be set (<= 64). */
void sq__symbolic_table_build(sq__symbolic_table *s, const uint8_t *value, const int32_t *cls,
                              int n);

/* The attributes of n particles (all borrowed). */
typedef struct sq__cluster_input {
    int n;
    const float *pos;       /* 3n: x, y, z (continuous) */
    const float *density;   /* n: local extinction relative to the maximum (continuous) */
    const uint8_t *stage;   /* n: life stage rank 0..stages-1 (ordinal) */
    const uint8_t *phase;   /* n: hydrometeor phase 0..SQ__MAX_SYMBOLS-1 (symbolic) */
    const int32_t *cls;     /* n: class label d of measure (3): the particle's cloud */
    int stages;
    const sq__symbolic_table *symbols;
} sq__cluster_input;

/* Thresholds sigma(a) in [0, 1] per attribute and the seed of the leader order. */
typedef struct sq__cluster_params {
    float sigma_pos[3];
    float sigma_density;
    float sigma_stage;
    float sigma_phase;
    bool symbolic_vdm; /* measure (3) as the value-difference metric instead of S4's form */
    uint64_t seed;
} sq__cluster_params;

/* max(a), min(a) of the continuous attributes: x, y, z, density. */
typedef struct sq__cluster_ranges {
    float lo[4], hi[4];
} sq__cluster_ranges;

void sq__cluster_ranges_compute(const sq__cluster_input *in, sq__cluster_ranges *rg);
/* Global similarity: every attribute's measure >= its threshold. */
bool sq__particles_similar(const sq__cluster_input *in, const sq__cluster_params *p,
                           const sq__cluster_ranges *rg, int i, int j);

/* Workspace and result of a clustering: label[i] in [0, clusters). */
typedef struct sq__clustering {
    int n, cap, clusters;
    int32_t *label, *order, *sorted, *bucket_of, *bucket_start;
    int bucket_cap;
    int dims[3];
    float bsize[3];
    sq__cluster_ranges ranges;
    uint64_t comparisons; /* similarity tests made (for the benchmark) */
} sq__clustering;

sq_result sq__cluster_reserve(sq_context *ctx, sq__clustering *c, int n);
void sq__cluster_free(sq_context *ctx, sq__clustering *c);
/* Leader clustering (S4 §2.2 step 3) with a deterministic seed order; use_grid selects the
 * bucketed scan (same result as the naive O(N x clusters) scan). */
sq_result sq__cluster_leader(sq_context *ctx, sq__clustering *c, const sq__cluster_input *in,
                             const sq__cluster_params *p, bool use_grid);

/* One structured particle per cluster (arrays of c->clusters entries, caller-owned). */
typedef struct sq__structured {
    float *pos;     /* 3m: optical-cross-section-weighted centroid */
    float *radius;  /* m: sqrt of the weighted second moment of the members' discs */
    float *tau;     /* m: centre optical depth keeping sum tau r² */
    float *density; /* m: weighted mean */
    float *weight;  /* m: sum tau r² */
    int32_t *members;
    int32_t *cloud; /* cloud of the first member */
} sq__structured;

void sq__cluster_aggregate(const sq__clustering *c, const sq__cluster_input *in,
                           const float *radius, const float *tau, sq__structured *out);

#endif
