/* tests/gpu_common.h: one Vulkan context per GPU test executable, always with the validation
 * layer; each test asserts that it produced no validation error. */
#ifndef TND_GPU_COMMON_H
#define TND_GPU_COMMON_H

#include "core/core.h"
#include "tests/tnd_test.h"

static tnd_vk gpu_vk;
static bool gpu_ready;
static uint32_t gpu_errors_before;

/* Create the context on first use (validation on; the layer must be installed). */
static tnd_vk *gpu_begin(void)
{
    if (!gpu_ready) {
        tnd_result r = tnd_vk_create(&(tnd_vk_desc){.validation = true}, &gpu_vk);
        CHECK(r == TND_OK, "context: %s", tnd_error_detail());
        if (r != TND_OK)
            return NULL;
        gpu_ready = true;
        printf("     device: %s (%s)\n", gpu_vk.info.name, gpu_vk.info.driver_name);
    }
    gpu_errors_before = tnd_vk_validation_errors(&gpu_vk);
    return &gpu_vk;
}

/* Every GPU test ends with this: any validation error fails it. */
static void gpu_end(void)
{
    if (!gpu_ready)
        return;
    vkDeviceWaitIdle(gpu_vk.device);
    uint32_t now = tnd_vk_validation_errors(&gpu_vk);
    CHECK(now == gpu_errors_before, "%u validation error(s) during this test",
          now - gpu_errors_before);
}

static void gpu_shutdown(void)
{
    if (gpu_ready)
        tnd_vk_destroy(&gpu_vk);
    gpu_ready = false;
}

#endif
