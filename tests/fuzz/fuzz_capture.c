/* tests/fuzz/fuzz_capture.c: the EXR capture reader (core/capture.c over OpenEXR Core: the
 * channel validation, the camera attributes, the derived entries) and the gradient samples'. */
#include "tests/fuzz/fuzz_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = fuzz_write("frame_0000.exr", data, size);
    tnd_frame f = {0};
    if (path && tnd_capture_read(path, &f) == TND_OK) {
        tnd_gradient_samples g = {0};
        /* the same bytes as a samples file beside a frame of the size read */
        if (tnd_capture_read_gradients(path, f.width, f.height, &g) == TND_OK)
            tnd_gradient_samples_free(&g);
        tnd_frame_destroy(&f);
    }
    tnd_error_clear();
    return 0;
}
