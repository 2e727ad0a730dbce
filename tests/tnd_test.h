/* tests/tnd_test.h: the test harness shared by every test executable.
 *
 * A test is a function; CHECK* macros record failures with file:line and continue. main() comes
 * from TND_TEST_MAIN(list): it runs each test (or those named on the command line), prints one
 * line per test and closes with the line "N passed, N failed" that CI reads. Exit status is 0
 * only when nothing failed. */
#ifndef TND_TEST_H
#define TND_TEST_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct tnd_test_case {
    const char *name;
    void (*fn)(void);
} tnd_test_case;

extern int tnd_test_failures; /* failures in the current test */

#define CHECK(cond, ...)                                                                           \
    do {                                                                                           \
        if (!(cond)) {                                                                             \
            tnd_test_failures++;                                                                   \
            fprintf(stderr, "  FAIL %s:%d: %s: ", __FILE__, __LINE__, #cond);                      \
            fprintf(stderr, __VA_ARGS__);                                                          \
            fputc('\n', stderr);                                                                   \
        }                                                                                          \
    } while (0)

/* |a - b| <= tol, and neither is NaN. */
#define CHECK_NEAR(a, b, tol, what)                                                                \
    do {                                                                                           \
        double ta_ = (double)(a), tb_ = (double)(b), tt_ = (double)(tol);                          \
        CHECK(fabs(ta_ - tb_) <= tt_, "%s: %.9g vs %.9g (tolerance %.3g)", what, ta_, tb_, tt_);   \
    } while (0)

#define CHECK_OK(expr)                                                                             \
    do {                                                                                           \
        tnd_result r_ = (expr);                                                                    \
        CHECK(r_ == TND_OK, "%s: %s", tnd_result_name(r_), tnd_error_detail());                    \
    } while (0)

/* Stop the current test when a precondition fails (use before dereferencing results). */
#define REQUIRE(cond, ...)                                                                         \
    do {                                                                                           \
        int before_ = tnd_test_failures;                                                           \
        CHECK(cond, __VA_ARGS__);                                                                  \
        if (tnd_test_failures != before_)                                                          \
            return;                                                                                \
    } while (0)

#define REQUIRE_OK(expr)                                                                           \
    do {                                                                                           \
        int before_ = tnd_test_failures;                                                           \
        CHECK_OK(expr);                                                                            \
        if (tnd_test_failures != before_)                                                          \
            goto cleanup;                                                                          \
    } while (0)

/* Sample-count scale of statistical tests: 1, or 1/4 in the sanitizer build (TND_SANITIZED),
 * where the same checks run 5 to 10 times slower. */
#ifdef TND_SANITIZED
#define TND_TEST_SAMPLES_DIV 4
#else
#define TND_TEST_SAMPLES_DIV 1
#endif

int tnd_test_run(const tnd_test_case *tests, int count, int argc, char **argv);

#define TND_TEST_MAIN(...)                                                                         \
    int main(int argc, char **argv)                                                                \
    {                                                                                              \
        static const tnd_test_case tests_[] = {__VA_ARGS__};                                       \
        return tnd_test_run(tests_, (int)(sizeof tests_ / sizeof tests_[0]), argc, argv);          \
    }
#define T(fn)                                                                                      \
    {                                                                                              \
#fn, fn                                                                                    \
    }

#endif
