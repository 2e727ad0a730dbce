/* tests/fuzz/fuzz_mapping.c: the channel-mapping reader (core/capture_map.c: roles, patterns,
 * cameras, conventions, conversions) and the listing of a directory through it. */
#include "tests/fuzz/fuzz_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = fuzz_write("map.json", data, size);
    tnd_capture_map *m = NULL;
    if (path && tnd_capture_map_load(path, &m) == TND_OK) {
        char **names = NULL;
        size_t n = 0;
        if (tnd_capture_map_list(m, fuzz_dir(), &names, &n) == TND_OK)
            tnd_capture_list_free(names, n);
        tnd_capture_map_destroy(m);
    }
    tnd_error_clear();
    return 0;
}

#ifdef TND_FUZZ_MUTATOR
/* JSON-aware mutations beside libFuzzer's (tests/fuzz/fuzz_common.h) */
size_t LLVMFuzzerCustomMutator(uint8_t *data, size_t size, size_t max_size, unsigned int seed);
size_t LLVMFuzzerCustomMutator(uint8_t *data, size_t size, size_t max_size, unsigned int seed)
{
    return fuzz_json_mutate(data, size, max_size, seed);
}
#endif
