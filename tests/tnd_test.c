/* tests/tnd_test.c: the harness runner (see tnd_test.h). */
#include "tests/tnd_test.h"

#include <time.h>

int tnd_test_failures;

int tnd_test_run(const tnd_test_case *tests, int count, int argc, char **argv)
{
    int passed = 0, failed = 0;
    /* arguments: the tests to run (all when none is named); -NAME leaves NAME out */
    int named = 0;
    for (int a = 1; a < argc; a++)
        named += argv[a][0] != '-';
    for (int i = 0; i < count; i++) {
        int wanted = !named;
        for (int a = 1; a < argc; a++) {
            if (argv[a][0] == '-' && strcmp(argv[a] + 1, tests[i].name) == 0)
                wanted = 0, a = argc;
            else if (argv[a][0] != '-' && strcmp(argv[a], tests[i].name) == 0)
                wanted = 1;
        }
        if (!wanted)
            continue;
        tnd_test_failures = 0;
        struct timespec t0, t1;
        clock_gettime(CLOCK_MONOTONIC, &t0);
        tests[i].fn();
        clock_gettime(CLOCK_MONOTONIC, &t1);
        double s = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
        if (tnd_test_failures) {
            failed++;
            printf("FAIL %s (%d checks failed, %.2fs)\n", tests[i].name, tnd_test_failures, s);
        } else {
            passed++;
            printf("ok   %s (%.2fs)\n", tests[i].name, s);
        }
        fflush(stdout);
    }
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}
