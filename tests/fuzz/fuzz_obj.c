/* tests/fuzz/fuzz_obj.c: the OBJ + MTL reader (core/scene_gltf.c's assimp path: the material
 * rule, texture merging, the flattening). The input is the OBJ, then a line "#MTL", then the
 * MTL it names as in.mtl (seeds: tests/fuzz/seeds.sh rewrites their mtllib lines). */
#include "tests/fuzz/fuzz_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const char sep[] = "\n#MTL\n";
    size_t cut = size;
    for (size_t i = 0; i + sizeof sep - 1 <= size; i++)
        if (memcmp(data + i, sep, sizeof sep - 1) == 0) {
            cut = i;
            break;
        }
    const char *mtl = cut < size ? fuzz_write("in.mtl", data + cut + sizeof sep - 1,
                                              size - cut - (sizeof sep - 1))
                                 : fuzz_write("in.mtl", (const uint8_t *)"", 0);
    const char *path = fuzz_write("in.obj", data, cut);
    tnd_scene *s = NULL;
    if (mtl && path && tnd_scene_load(path, &s) == TND_OK) {
        tnd_scene_state st = {0};
        (void)tnd_scene_evaluate(s, 0.0, 0, 1.5f, &st);
        tnd_scene_state_free(&st);
        tnd_scene_destroy(s);
    }
    tnd_error_clear();
    return 0;
}
