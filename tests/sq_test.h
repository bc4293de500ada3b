/* sq_test.h — a tiny test harness. Each SQ_TEST(name) in a file becomes one CTest entry
 * (tests/CMakeLists.txt scans the file for them); the executable runs the case named by its
 * first argument. A file may set its label with a line `SQ_LABEL(physics)` (default: unit).
 * Checks print file:line and the values, count failures and keep going within the case. */
#ifndef SQ_TEST_H
#define SQ_TEST_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "squall/core.h"

typedef void (*sq_test_fn)(void);
typedef struct sq_test_entry {
    const char *name;
    sq_test_fn fn;
} sq_test_entry;

#define SQ_TEST_MAX 256
static sq_test_entry sq_test_table[SQ_TEST_MAX];
static int sq_test_count;
static int sq_test_failures;

static inline void sq_test_register(const char *name, sq_test_fn fn)
{
    if (sq_test_count < SQ_TEST_MAX) {
        sq_test_table[sq_test_count].name = name;
        sq_test_table[sq_test_count].fn = fn;
        sq_test_count++;
    }
}

#define SQ_LABEL(x)
#define SQ_REQUIRES(x) /* read by tests/CMakeLists.txt: features the file needs ("gl mp4") */
#define SQ_TEST(name)                                                                          \
    static void sq_test_##name(void);                                                          \
    __attribute__((constructor)) static void sq_test_reg_##name(void)                          \
    {                                                                                          \
        sq_test_register(#name, sq_test_##name);                                               \
    }                                                                                          \
    static void sq_test_##name(void)

#define SQ_FAIL_AT(...)                                                                        \
    do {                                                                                       \
        fprintf(stderr, "%s:%d: FAIL: ", __FILE__, __LINE__);                                  \
        fprintf(stderr, __VA_ARGS__);                                                          \
        fprintf(stderr, "\n");                                                                 \
        sq_test_failures++;                                                                    \
    } while (0)

#define SQ_CHECK(cond)                                                                         \
    do {                                                                                       \
        if (!(cond)) SQ_FAIL_AT("%s", #cond);                                                  \
    } while (0)

#define SQ_CHECK_MSG(cond, ...)                                                                \
    do {                                                                                       \
        if (!(cond)) SQ_FAIL_AT(__VA_ARGS__);                                                  \
    } while (0)

/* |a - b| <= tol */
#define SQ_CHECK_NEAR(a, b, tol)                                                               \
    do {                                                                                       \
        double sq_a_ = (double)(a), sq_b_ = (double)(b), sq_t_ = (double)(tol);                \
        if (!(fabs(sq_a_ - sq_b_) <= sq_t_))                                                   \
            SQ_FAIL_AT("%s = %.9g, %s = %.9g, |diff| = %.3g > %.3g", #a, sq_a_, #b, sq_b_,     \
                       fabs(sq_a_ - sq_b_), sq_t_);                                            \
    } while (0)

/* |a - b| <= rel * |b| */
#define SQ_CHECK_REL(a, b, rel)                                                                \
    do {                                                                                       \
        double sq_a_ = (double)(a), sq_b_ = (double)(b), sq_r_ = (double)(rel);                \
        if (!(fabs(sq_a_ - sq_b_) <= sq_r_ * fabs(sq_b_)))                                     \
            SQ_FAIL_AT("%s = %.9g, %s = %.9g, rel diff = %.3g > %.3g", #a, sq_a_, #b, sq_b_,   \
                       sq_b_ != 0.0 ? fabs(sq_a_ - sq_b_) / fabs(sq_b_) : INFINITY, sq_r_);    \
    } while (0)

#define SQ_CHECK_OK(expr)                                                                      \
    do {                                                                                       \
        sq_result sq_r_ = (expr);                                                              \
        if (sq_r_ != SQ_OK)                                                                    \
            SQ_FAIL_AT("%s returned %s: %s", #expr, sq_result_name(sq_r_), sq_last_error());   \
    } while (0)

/* expr must fail with code; the error text must contain needle (may be NULL). */
#define SQ_CHECK_ERR(expr, code, needle)                                                       \
    do {                                                                                       \
        sq_result sq_r_ = (expr);                                                              \
        const char *sq_n_ = (needle);                                                          \
        if (sq_r_ != (code))                                                                   \
            SQ_FAIL_AT("%s returned %s, expected %s (%s)", #expr, sq_result_name(sq_r_),       \
                       sq_result_name(code), sq_last_error());                                 \
        else if (sq_n_ && !strstr(sq_last_error(), sq_n_))                                     \
            SQ_FAIL_AT("%s: error text \"%s\" does not contain \"%s\"", #expr,                 \
                       sq_last_error(), sq_n_);                                                \
    } while (0)

/* Source directory of the project (tests read ../shared and scenes/ through it). */
#ifndef SQ_TEST_SOURCE_DIR
#define SQ_TEST_SOURCE_DIR "."
#endif

int main(int argc, char **argv)
{
    if (argc < 2) {
        for (int i = 0; i < sq_test_count; i++) printf("%s\n", sq_test_table[i].name);
        return 0;
    }
    for (int i = 0; i < sq_test_count; i++) {
        if (strcmp(sq_test_table[i].name, argv[1]) == 0) {
            sq_test_table[i].fn();
            if (sq_test_failures) {
                fprintf(stderr, "%s: %d check(s) failed\n", argv[1], sq_test_failures);
                return 1;
            }
            printf("%s: ok\n", argv[1]);
            return 0;
        }
    }
    fprintf(stderr, "no test case named '%s'\n", argv[1]);
    return 2;
}

#endif
