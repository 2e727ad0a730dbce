/* tests/fuzz/fuzz_gltf.c: the glTF reader (core/scene_gltf.c: the JSON pre-pass, buffers and
 * data URIs, accessor and index checks, materials, cameras, lights, animation; through assimp)
 * and the scene's evaluation at one moment. A .glb (JSON and binary chunks) when the input
 * starts with the binary container's magic, else a .gltf. */
#include "tests/fuzz/fuzz_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    bool glb = size >= 4 && memcmp(data, "glTF", 4) == 0;
    const char *path = fuzz_write(glb ? "in.glb" : "in.gltf", data, size);
    tnd_scene *s = NULL;
    if (path && tnd_scene_load(path, &s) == TND_OK) {
        tnd_scene_state st = {0};
        (void)tnd_scene_evaluate(s, 0.5, 0, 1.5f, &st);
        tnd_scene_state_free(&st);
        tnd_scene_destroy(s);
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
