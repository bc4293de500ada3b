/* test_core.c — core units: context, errors, allocation, RNG, noise, fields, math. */
#include <string.h>

#include "sq_test.h"
#include "squall/field.h"
#include "squall/noise.h"
#include "squall/rng.h"
#include "squall/sqmath.h"

SQ_LABEL(unit)

SQ_TEST(context_defaults)
{
    sq_context *ctx = NULL;
    SQ_CHECK_OK(sq_context_create(NULL, &ctx));
    SQ_CHECK(ctx != NULL);
    SQ_CHECK(sq_context_threads(ctx) >= 1);
    SQ_CHECK(sq_context_memory_limit(ctx) > 0);
    sq_context_destroy(ctx);
    sq_context_destroy(NULL);
}

SQ_TEST(context_rejects_negative_threads)
{
    sq_context *ctx = (sq_context *)1;
    sq_context_desc d = {.threads = -3};
    SQ_CHECK_ERR(sq_context_create(&d, &ctx), SQ_ERR_INVALID_ARG, "threads = -3");
    SQ_CHECK(ctx == NULL);
}

static int log_calls;
static char log_last[256];
static void test_logger(void *user, sq_log_level level, const char *module, const char *msg)
{
    (void)user;
    (void)level;
    log_calls++;
    snprintf(log_last, sizeof log_last, "%s: %s", module, msg);
}

SQ_TEST(logger_receives_errors)
{
    sq_context *ctx = NULL;
    sq_context_desc d = {.log = test_logger, .memory_limit_bytes = 1 << 20};
    SQ_CHECK_OK(sq_context_create(&d, &ctx));
    log_calls = 0;
    SQ_CHECK_ERR(sq_context_check_memory(ctx, 10u << 20, "lattice 300x300x300"),
                 SQ_ERR_TOO_LARGE, "lattice 300x300x300 needs 10485760 bytes");
    SQ_CHECK(log_calls == 1);
    SQ_CHECK(strstr(log_last, "memory: ") == log_last);
    sq_context_destroy(ctx);
}

SQ_TEST(aligned_allocation)
{
    sq_context *ctx = NULL;
    SQ_CHECK_OK(sq_context_create(NULL, &ctx));
    for (size_t n = 1; n < 5000; n = n * 3 + 1) {
        unsigned char *p = (unsigned char *)sq_alloc_zero(ctx, n);
        SQ_CHECK(p != NULL);
        SQ_CHECK(((uintptr_t)p % 64) == 0);
        for (size_t i = 0; i < n; i++) SQ_CHECK(p[i] == 0);
        SQ_CHECK(sq_context_bytes_in_use(ctx) == n);
        sq_free(ctx, p);
        SQ_CHECK(sq_context_bytes_in_use(ctx) == 0);
    }
    sq_free(ctx, NULL);
    sq_context_destroy(ctx);
}

SQ_TEST(allocation_beyond_limit_refused)
{
    sq_context *ctx = NULL;
    sq_context_desc d = {.memory_limit_bytes = 4096};
    SQ_CHECK_OK(sq_context_create(&d, &ctx));
    void *p = sq_alloc(ctx, 8192);
    SQ_CHECK(p == NULL);
    SQ_CHECK(strstr(sq_last_error(), "8192") != NULL);
    sq_context_destroy(ctx);
}

SQ_TEST(result_names)
{
    SQ_CHECK(strcmp(sq_result_name(SQ_OK), "SQ_OK") == 0);
    SQ_CHECK(strcmp(sq_result_name(SQ_ERR_UNSTABLE), "SQ_ERR_UNSTABLE") == 0);
    SQ_CHECK(strcmp(sq_result_name((sq_result)-99), "SQ_ERR_UNKNOWN") == 0);
}

/* Known-answer test from the Random123 distribution (kat_vectors): philox4x32-10 with
 * counter = key = 0 and with counter = key = all ones. */
SQ_TEST(philox_known_answers)
{
    uint32_t ctr0[4] = {0, 0, 0, 0}, key0[2] = {0, 0}, out[4];
    sq_philox4x32(ctr0, key0, out);
    SQ_CHECK(out[0] == 0x6627e8d5u && out[1] == 0xe169c58du && out[2] == 0xbc57ac4cu &&
             out[3] == 0x9b00dbd8u);
    uint32_t ctr1[4] = {0xffffffffu, 0xffffffffu, 0xffffffffu, 0xffffffffu};
    uint32_t key1[2] = {0xffffffffu, 0xffffffffu};
    sq_philox4x32(ctr1, key1, out);
    SQ_CHECK(out[0] == 0x408f276du && out[1] == 0x41c83b0eu && out[2] == 0xa20bc7c6u &&
             out[3] == 0x6d5451fdu);
}

SQ_TEST(rng_reproducible_and_uniform)
{
    const int n = 200000;
    double sum = 0.0, sum2 = 0.0;
    int hist[10] = {0};
    for (int i = 0; i < n; i++) {
        float u = sq_rng_uniform(42, 7, (uint64_t)i);
        SQ_CHECK(u >= 0.0f && u < 1.0f);
        SQ_CHECK(u == sq_rng_uniform(42, 7, (uint64_t)i));
        sum += u;
        sum2 += (double)u * u;
        hist[(int)(u * 10.0f)]++;
    }
    double mean = sum / n, var = sum2 / n - mean * mean;
    SQ_CHECK_NEAR(mean, 0.5, 0.005);
    SQ_CHECK_NEAR(var, 1.0 / 12.0, 0.002);
    for (int b = 0; b < 10; b++) SQ_CHECK_NEAR(hist[b], n / 10, 5 * sqrt(n / 10.0));
    SQ_CHECK(sq_rng_uniform(42, 7, 3) != sq_rng_uniform(43, 7, 3));
    SQ_CHECK(sq_rng_uniform(42, 7, 3) != sq_rng_uniform(42, 8, 3));
    double ns = 0.0, ns2 = 0.0;
    for (int i = 0; i < n; i++) {
        double z = sq_rng_normal(1, 2, (uint64_t)i);
        ns += z;
        ns2 += z * z;
    }
    SQ_CHECK_NEAR(ns / n, 0.0, 0.01);
    SQ_CHECK_NEAR(ns2 / n, 1.0, 0.02);
}

/* sq_noise3_many (eight points at a time with AVX2) gives sq_noise3's values bit for bit:
 * points on both sides of zero, far from it, on and just off the lattice, any count. */
SQ_TEST(noise_many_equals_scalar)
{
    sq_noise nz;
    sq_noise_init(&nz, 77);
    enum { N = 1003 };
    static float x[N], y[N], z[N], out[N];
    uint32_t s = 12345u;
    for (int i = 0; i < N; i++) {
        float v[3];
        for (int a = 0; a < 3; a++) {
            s = s * 1664525u + 1013904223u;
            const float u = (float)(s >> 8) / 16777216.0f; /* [0, 1) */
            switch (i % 4) {
            case 0: v[a] = 600.0f * u - 300.0f; break;            /* both signs */
            case 1: v[a] = 1.0e4f * u + 101.0f; break;            /* far from 0 (wraps at 256) */
            case 2: v[a] = (float)((int)(40.0f * u) - 20); break; /* on the lattice */
            default: v[a] = (float)((int)(40.0f * u) - 20) - 1.0e-6f * u; break; /* just below */
            }
        }
        x[i] = v[0];
        y[i] = v[1];
        z[i] = v[2];
    }
    const size_t counts[] = {0, 1, 7, 8, 9, 17, N};
    for (size_t c = 0; c < sizeof counts / sizeof counts[0]; c++) {
        for (int i = 0; i < N; i++) out[i] = 42.0f;
        sq_noise3_many(&nz, counts[c], x, y, z, out);
        int differ = 0;
        for (size_t i = 0; i < counts[c]; i++) {
            const float ref = sq_noise3(&nz, x[i], y[i], z[i]);
            differ += memcmp(&ref, &out[i], sizeof ref) != 0;
        }
        SQ_CHECK(differ == 0);
        for (size_t i = counts[c]; i < (size_t)N; i++) SQ_CHECK(out[i] == 42.0f); /* no overrun */
    }
}

SQ_TEST(noise_range_and_continuity)
{
    sq_noise nz;
    sq_noise_init(&nz, 1234);
    float mn = 1e9f, mx = -1e9f;
    double mean = 0.0;
    int cnt = 0;
    for (int i = 0; i < 40; i++)
        for (int j = 0; j < 40; j++)
            for (int k = 0; k < 10; k++) {
                float x = 0.37f * (float)i, y = 0.41f * (float)j, z = 0.53f * (float)k;
                float v = sq_noise3(&nz, x, y, z);
                mn = v < mn ? v : mn;
                mx = v > mx ? v : mx;
                mean += v;
                cnt++;
                /* Lipschitz: gradient noise changes little over a small step */
                float v2 = sq_noise3(&nz, x + 1e-3f, y, z);
                SQ_CHECK(fabsf(v2 - v) < 0.01f);
            }
    SQ_CHECK(mn >= -1.1f && mx <= 1.1f);
    SQ_CHECK(mx - mn > 1.0f); /* not constant */
    SQ_CHECK_NEAR(mean / cnt, 0.0, 0.05);
    /* zero at lattice points */
    SQ_CHECK_NEAR(sq_noise3(&nz, 3.0f, 5.0f, 7.0f), 0.0, 1e-6);
    sq_noise other;
    sq_noise_init(&other, 99);
    SQ_CHECK(sq_noise3(&nz, 0.5f, 0.5f, 0.5f) != sq_noise3(&other, 0.5f, 0.5f, 0.5f));
    float f = sq_noise_fbm3(&nz, 0.3f, 0.7f, 0.1f, 5, 2.0f, 0.5f);
    SQ_CHECK(f > -1.1f && f < 1.1f);
}

SQ_TEST(field_ghosts_and_views)
{
    sq_context *ctx = NULL;
    SQ_CHECK_OK(sq_context_create(NULL, &ctx));
    sq_field3 f;
    SQ_CHECK_OK(sq_field3_create(ctx, (sq_dims){4, 3, 2}, 1, &f));
    SQ_CHECK(f.count == 6 * 5 * 4);
    SQ_CHECK(((uintptr_t)f.base % 64) == 0);
    for (int k = 0; k < 2; k++)
        for (int j = 0; j < 3; j++)
            for (int i = 0; i < 4; i++) *sq_field3_at(&f, i, j, k) = (float)(i + 10 * j + 100 * k);
    int per[3] = {1, 0, 0};
    sq_field3_fill_ghosts(&f, per);
    SQ_CHECK(*sq_field3_at(&f, -1, 1, 1) == 3 + 10 + 100); /* periodic in x */
    SQ_CHECK(*sq_field3_at(&f, 4, 2, 0) == 0 + 20);
    SQ_CHECK(*sq_field3_at(&f, 2, -1, 0) == 2);           /* zero gradient in y */
    SQ_CHECK(*sq_field3_at(&f, 2, 1, 2) == 2 + 10 + 100); /* zero gradient in z */
    sq_field_view v = sq_field3_view(&f);
    SQ_CHECK(sq_view_get(&v, 3, 2, 1) == 123.0f);
    sq_field_view s = sq_field3_subview(&f, 1, 1, 1, (sq_dims){2, 2, 1});
    SQ_CHECK(sq_view_get(&s, 0, 0, 0) == 111.0f);
    SQ_CHECK(sq_view_get(&s, 1, 1, 0) == 122.0f);
    sq_field3_destroy(ctx, &f);
    SQ_CHECK_ERR(sq_field3_create(ctx, (sq_dims){2, 0, 4}, 1, &f), SQ_ERR_INVALID_ARG,
                 "2x0x4");
    SQ_CHECK(sq_context_bytes_in_use(ctx) == 0);
    sq_context_destroy(ctx);
}

SQ_TEST(field_too_large_refused_before_allocating)
{
    sq_context *ctx = NULL;
    sq_context_desc d = {.memory_limit_bytes = 1u << 20};
    SQ_CHECK_OK(sq_context_create(&d, &ctx));
    sq_field3 f;
    SQ_CHECK_ERR(sq_field3_create(ctx, (sq_dims){128, 128, 128}, 1, &f), SQ_ERR_TOO_LARGE,
                 "field 128x128x128 needs");
    SQ_CHECK(f.base == NULL);
    SQ_CHECK(sq_context_bytes_peak(ctx) == 0);
    sq_context_destroy(ctx);
}

SQ_TEST(math_matrices)
{
    sq_mat4 p = sq_m4_perspective(1.0f, 1.5f, 0.1f, 100.0f);
    sq_mat4 v = sq_m4_look_at(sq_v3(1, 2, 3), sq_v3(10, -4, 0), sq_v3(0, 0, 1));
    sq_mat4 pv = sq_m4_mul(p, v);
    sq_mat4 inv = sq_m4_inverse(pv);
    sq_mat4 id = sq_m4_mul(pv, inv);
    for (int i = 0; i < 16; i++) SQ_CHECK_NEAR(id.m[i], (i % 5 == 0) ? 1.0 : 0.0, 1e-4);
    /* the target projects to the screen centre */
    sq_vec4 c = sq_m4_mul_v4(pv, (sq_vec4){10, -4, 0, 1});
    SQ_CHECK_NEAR(c.x / c.w, 0.0, 1e-5);
    SQ_CHECK_NEAR(c.y / c.w, 0.0, 1e-5);
    SQ_CHECK(c.z / c.w > -1.0f && c.z / c.w < 1.0f);
    sq_vec3 a = sq_v3(1, 0, 0), b = sq_v3(0, 1, 0);
    sq_vec3 z = sq_v3_cross(a, b);
    SQ_CHECK(z.x == 0 && z.y == 0 && z.z == 1); /* right-handed */
}

SQ_TEST(features_listed)
{
    SQ_CHECK(sq_has_feature("yaml"));
    SQ_CHECK(sq_has_feature("png"));
    SQ_CHECK(!sq_has_feature("definitely-not-a-feature"));
    SQ_CHECK(!sq_has_feature(""));
    SQ_CHECK(strlen(sq_version()) > 0);
}
