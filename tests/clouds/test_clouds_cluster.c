/* test_clouds_cluster.c — structured particles (SPEC 8.3, S4 §2.1–2.2): the similarity measures
 * (1)–(3) with the SPEC's guards and clamp, the global similarity, and the leader clustering:
 * every cluster obeys the leader rule, the grid pre-pass gives exactly the naive algorithm's
 * clusters with fewer comparisons, and the result is deterministic for a seed. */
#include "phen/clouds/clouds_internal.h"
#include "sq_test.h"
#include "squall/rng.h"

SQ_LABEL(unit)

SQ_TEST(continuous_measure)
{
    SQ_CHECK_NEAR(sq__sim_continuous(2.0f, 5.0f, 0.0f, 10.0f), 0.7f, 1e-6);
    SQ_CHECK_NEAR(sq__sim_continuous(5.0f, 2.0f, 0.0f, 10.0f), 0.7f, 1e-6); /* symmetric */
    SQ_CHECK(sq__sim_continuous(3.0f, 3.0f, 0.0f, 10.0f) == 1.0f);         /* reflexive */
    SQ_CHECK(sq__sim_continuous(0.0f, 10.0f, 0.0f, 10.0f) == 0.0f);
    /* guard max(a) = min(a): one value, all similar (no division by zero, no NaN) */
    SQ_CHECK(sq__sim_continuous(4.0f, 4.0f, 4.0f, 4.0f) == 1.0f);
    /* outside the stated range (a stale range): clamped, never negative */
    SQ_CHECK(sq__sim_continuous(-50.0f, 50.0f, 0.0f, 10.0f) == 0.0f);
}

SQ_TEST(ordinal_measure)
{
    /* four life stages (birth, motion, growth, death): t = 4 */
    SQ_CHECK_NEAR(sq__sim_ordinal(0, 1, 4), 2.0f / 3.0f, 1e-6);
    SQ_CHECK_NEAR(sq__sim_ordinal(3, 1, 4), 1.0f / 3.0f, 1e-6);
    SQ_CHECK(sq__sim_ordinal(0, 3, 4) == 0.0f);
    SQ_CHECK(sq__sim_ordinal(2, 2, 4) == 1.0f);
    SQ_CHECK(sq__sim_ordinal(0, 0, 1) == 1.0f); /* guard t - 1 = 0 */
}

/* Measure (3) on a hand-made table: two classes with P(d) = 0.5 each. Value 0 occurs with
 * P(a=0,d=0) = 0.3, P(a=0,d=1) = 0.1; value 1 with 0.1, 0.3; value 2 with 0.1, 0.1.
 *   lambda(0,1) = 1 - (0.2/0.5 + 0.2/0.5) = 0.2;  lambda(0,2) = 1 - (0.2/0.5 + 0) = 0.6.
 * A table where the printed sum exceeds 1 gives a negative value: clamped to 0. The VDM form:
 *   P(d|a=0) = (.75, .25), P(d|a=1) = (.25, .75): 1 - 1/2 (0.5 + 0.5) = 0.5. */
SQ_TEST(symbolic_measure)
{
    sq__symbolic_table t;
    memset(&t, 0, sizeof t);
    t.classes = 2;
    const float pj[6] = {0.3f, 0.1f, 0.1f, 0.3f, 0.1f, 0.1f};
    memcpy(t.p_joint, pj, sizeof pj);
    t.p_class[0] = t.p_class[1] = 0.5f;
    SQ_CHECK_NEAR(sq__sim_symbolic(&t, 0, 1), 0.2f, 1e-6);
    SQ_CHECK_NEAR(sq__sim_symbolic(&t, 1, 0), 0.2f, 1e-6);
    SQ_CHECK_NEAR(sq__sim_symbolic(&t, 0, 2), 0.6f, 1e-6);
    SQ_CHECK(sq__sim_symbolic(&t, 1, 1) == 1.0f);
    SQ_CHECK_NEAR(sq__sim_symbolic_vdm(&t, 0, 1), 0.5f, 1e-6);
    /* raw (3) below zero: 1 - (0.4/0.5 + 0.4/0.5) = -0.6 -> clamped */
    const float pk[4] = {0.45f, 0.05f, 0.05f, 0.45f};
    memcpy(t.p_joint, pk, sizeof pk);
    SQ_CHECK(sq__sim_symbolic(&t, 0, 1) == 0.0f);
    SQ_CHECK(sq__sim_symbolic_vdm(&t, 0, 1) >= 0.0f);
    /* an empty class (P(d) = 0) is skipped, not divided by */
    t.classes = 3;
    memset(t.p_joint, 0, sizeof t.p_joint);
    t.p_joint[0 * 3 + 0] = 0.5f;
    t.p_joint[1 * 3 + 0] = 0.5f;
    t.p_class[0] = 1.0f;
    t.p_class[1] = 0.0f;
    t.p_class[2] = 0.0f;
    const float l = sq__sim_symbolic(&t, 0, 1);
    SQ_CHECK(l == 1.0f);
    /* table from data: three particles */
    const uint8_t v[3] = {0, 1, 0};
    const int32_t c[3] = {0, 0, 1};
    t.classes = 2;
    sq__symbolic_table_build(&t, v, c, 3);
    SQ_CHECK_NEAR(t.p_class[0], 2.0f / 3.0f, 1e-6);
    SQ_CHECK_NEAR(t.p_joint[0 * 2 + 1], 1.0f / 3.0f, 1e-6);
}

/* A random particle set in a 100 x 100 x 20 box with stages, phases and clouds. */
typedef struct pset {
    int n;
    float *pos, *density, *radius, *tau;
    uint8_t *stage, *phase;
    int32_t *cls;
    sq__symbolic_table sym;
    sq__cluster_input in;
} pset;

static void pset_make(pset *s, int n, uint64_t seed)
{
    s->n = n;
    s->pos = malloc(sizeof(float) * 3 * (size_t)n);
    s->density = malloc(sizeof(float) * (size_t)n);
    s->radius = malloc(sizeof(float) * (size_t)n);
    s->tau = malloc(sizeof(float) * (size_t)n);
    s->stage = malloc((size_t)n);
    s->phase = malloc((size_t)n);
    s->cls = malloc(sizeof(int32_t) * (size_t)n);
    for (int i = 0; i < n; i++) {
        float u[4], w[4];
        sq_rng_uniform4(seed, 1, (uint64_t)i, u);
        sq_rng_uniform4(seed, 2, (uint64_t)i, w);
        s->pos[3 * i + 0] = 100.0f * u[0];
        s->pos[3 * i + 1] = 100.0f * u[1];
        s->pos[3 * i + 2] = 20.0f * u[2];
        s->density[i] = u[3];
        s->radius[i] = 1.0f + w[0];
        s->tau[i] = 0.5f + w[1];
        s->stage[i] = (uint8_t)(w[2] * 4.0f);
        s->phase[i] = (uint8_t)(w[3] * 3.0f);
        s->cls[i] = s->pos[3 * i] < 50.0f ? 0 : 1;
    }
    memset(&s->sym, 0, sizeof s->sym);
    s->sym.classes = 2;
    sq__symbolic_table_build(&s->sym, s->phase, s->cls, n);
    s->in.n = n;
    s->in.pos = s->pos;
    s->in.density = s->density;
    s->in.stage = s->stage;
    s->in.phase = s->phase;
    s->in.cls = s->cls;
    s->in.stages = 4;
    s->in.symbols = &s->sym;
}

static void pset_free(pset *s)
{
    free(s->pos);
    free(s->density);
    free(s->radius);
    free(s->tau);
    free(s->stage);
    free(s->phase);
    free(s->cls);
}

static sq__cluster_params params_default(void)
{
    sq__cluster_params p;
    memset(&p, 0, sizeof p);
    p.sigma_pos[0] = p.sigma_pos[1] = 0.95f; /* 5 m of 100 */
    p.sigma_pos[2] = 0.75f;                  /* 5 m of 20 */
    p.sigma_density = 0.5f;
    p.sigma_stage = 0.6f;
    p.sigma_phase = 0.3f;
    p.seed = 42;
    return p;
}

static sq_context *ctx_new(void)
{
    sq_context_desc cd = {0};
    cd.log_level = SQ_LOG_NONE;
    sq_context *ctx = NULL;
    SQ_CHECK_OK(sq_context_create(&cd, &ctx));
    return ctx;
}

/* Every cluster satisfies the leader rule: it has a member (its seed) similar to every other
 * member, and no particle of a later cluster was similar to an earlier seed (it would have been
 * taken). Checked by brute force on the result. */
SQ_TEST(leader_rule_holds)
{
    sq_context *ctx = ctx_new();
    pset s;
    pset_make(&s, 1500, 7);
    sq__cluster_params p = params_default();
    sq__clustering c;
    memset(&c, 0, sizeof c);
    SQ_CHECK_OK(sq__cluster_leader(ctx, &c, &s.in, &p, true));
    SQ_CHECK(c.clusters > 1 && c.clusters < s.n);
    /* seeds in order of cluster id: the first member in the leader order */
    int32_t *seed = malloc(sizeof(int32_t) * (size_t)c.clusters);
    for (int k = 0; k < c.clusters; k++) seed[k] = -1;
    for (int q = 0; q < s.n; q++) {
        const int i = c.order[q];
        if (seed[c.label[i]] < 0) seed[c.label[i]] = i;
    }
    SQ_CHECK(c.order[0] == 0 && c.label[0] == 0); /* particle 1 is the first seed */
    int bad = 0;
    for (int i = 0; i < s.n; i++) {
        const int k = c.label[i];
        if (!sq__particles_similar(&s.in, &p, &c.ranges, seed[k], i)) bad++;
        for (int e = 0; e < k; e++)
            if (sq__particles_similar(&s.in, &p, &c.ranges, seed[e], i)) bad++;
    }
    SQ_CHECK_MSG(bad == 0, "%d violations of the leader rule", bad);
    free(seed);
    sq__cluster_free(ctx, &c);
    pset_free(&s);
    sq_context_destroy(ctx);
}

/* The grid pre-pass returns the naive algorithm's labels exactly, with far fewer comparisons;
 * also at the extremes sigma = 1 (only identical positions cluster) and sigma = 0. */
SQ_TEST(grid_equals_naive)
{
    sq_context *ctx = ctx_new();
    pset s;
    pset_make(&s, 3000, 11);
    const float sig[3] = {0.95f, 1.0f, 0.0f};
    for (int t = 0; t < 3; t++) {
        sq__cluster_params p = params_default();
        p.sigma_pos[0] = p.sigma_pos[1] = p.sigma_pos[2] = sig[t];
        if (t == 2) p.sigma_density = p.sigma_stage = p.sigma_phase = 0.0f;
        sq__clustering a, b;
        memset(&a, 0, sizeof a);
        memset(&b, 0, sizeof b);
        SQ_CHECK_OK(sq__cluster_leader(ctx, &a, &s.in, &p, false));
        SQ_CHECK_OK(sq__cluster_leader(ctx, &b, &s.in, &p, true));
        SQ_CHECK(a.clusters == b.clusters);
        int diff = 0;
        for (int i = 0; i < s.n; i++) diff += a.label[i] != b.label[i];
        SQ_CHECK_MSG(diff == 0, "sigma_pos %g: %d labels differ", (double)sig[t], diff);
        printf("sigma_pos %.2f: %d clusters, comparisons naive %llu, grid %llu\n", (double)sig[t],
               a.clusters, (unsigned long long)a.comparisons, (unsigned long long)b.comparisons);
        if (t == 0) SQ_CHECK(b.comparisons * 10 < a.comparisons);
        if (t == 1) SQ_CHECK(a.clusters == s.n); /* distinct random positions */
        if (t == 2) SQ_CHECK(a.clusters == 1);   /* everything similar */
        sq__cluster_free(ctx, &a);
        sq__cluster_free(ctx, &b);
    }
    pset_free(&s);
    sq_context_destroy(ctx);
}

/* Same input and seed: identical labels (and a different seed changes the order, not the
 * rule). The order is a permutation with particle 0 first. */
SQ_TEST(clustering_deterministic)
{
    sq_context *ctx = ctx_new();
    pset s;
    pset_make(&s, 2000, 3);
    sq__cluster_params p = params_default();
    sq__clustering a, b, d;
    memset(&a, 0, sizeof a);
    memset(&b, 0, sizeof b);
    memset(&d, 0, sizeof d);
    SQ_CHECK_OK(sq__cluster_leader(ctx, &a, &s.in, &p, true));
    SQ_CHECK_OK(sq__cluster_leader(ctx, &b, &s.in, &p, true));
    SQ_CHECK(a.clusters == b.clusters);
    SQ_CHECK(memcmp(a.label, b.label, sizeof(int32_t) * (size_t)s.n) == 0);
    p.seed = 43;
    SQ_CHECK_OK(sq__cluster_leader(ctx, &d, &s.in, &p, true));
    SQ_CHECK(memcmp(a.order, d.order, sizeof(int32_t) * (size_t)s.n) != 0);
    char *seen = calloc((size_t)s.n, 1);
    int dup = 0;
    for (int i = 0; i < s.n; i++) dup += seen[d.order[i]]++ != 0;
    SQ_CHECK(dup == 0 && d.order[0] == 0);
    free(seen);
    sq__cluster_free(ctx, &a);
    sq__cluster_free(ctx, &b);
    sq__cluster_free(ctx, &d);
    pset_free(&s);
    sq_context_destroy(ctx);
}

/* A structured particle keeps its members' optical cross-section sum tau r² and sits at their
 * weighted centroid; a singleton cluster is its particle. */
SQ_TEST(structured_particle_aggregate)
{
    sq_context *ctx = ctx_new();
    pset s;
    pset_make(&s, 800, 5);
    sq__cluster_params p = params_default();
    sq__clustering c;
    memset(&c, 0, sizeof c);
    SQ_CHECK_OK(sq__cluster_leader(ctx, &c, &s.in, &p, true));
    const int m = c.clusters;
    sq__structured st;
    st.pos = malloc(sizeof(float) * 3 * (size_t)m);
    st.radius = malloc(sizeof(float) * (size_t)m);
    st.tau = malloc(sizeof(float) * (size_t)m);
    st.density = malloc(sizeof(float) * (size_t)m);
    st.weight = malloc(sizeof(float) * (size_t)m);
    st.members = malloc(sizeof(int32_t) * (size_t)m);
    st.cloud = malloc(sizeof(int32_t) * (size_t)m);
    sq__cluster_aggregate(&c, &s.in, s.radius, s.tau, &st);
    double total_p = 0, total_c = 0;
    int members = 0;
    for (int i = 0; i < s.n; i++) total_p += (double)s.tau[i] * s.radius[i] * s.radius[i];
    for (int k = 0; k < m; k++) {
        total_c += (double)st.tau[k] * st.radius[k] * st.radius[k];
        members += st.members[k];
    }
    SQ_CHECK_REL(total_c, total_p, 1e-4);
    SQ_CHECK(members == s.n);
    for (int i = 0; i < s.n; i++) {
        const int k = c.label[i];
        if (st.members[k] != 1) continue;
        SQ_CHECK_NEAR(st.pos[3 * k], s.pos[3 * i], 1e-4);
        SQ_CHECK_NEAR(st.radius[k], s.radius[i], 1e-4);
        SQ_CHECK_NEAR(st.tau[k], s.tau[i], 1e-4);
    }
    free(st.pos);
    free(st.radius);
    free(st.tau);
    free(st.density);
    free(st.weight);
    free(st.members);
    free(st.cloud);
    sq__cluster_free(ctx, &c);
    pset_free(&s);
    sq_context_destroy(ctx);
}
