/* tests/fuzz/fuzz_env.c: the environment map reader (core/env.c: a latitude-longitude EXR, its
 * checks, the importance-sampling tables built from it). */
#include "tests/fuzz/fuzz_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = fuzz_write("env.exr", data, size);
    tnd_env e = {0};
    if (path && tnd_env_load(path, 1.0f, 30.0f, &e) == TND_OK)
        tnd_env_free(&e);
    tnd_error_clear();
    return 0;
}
