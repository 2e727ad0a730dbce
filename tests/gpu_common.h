/* tests/gpu_common.h: a Vulkan context per GPU test, always with the validation layer; each test
 * asserts that it produced no validation error. A test starts on a fresh device (gpu_begin after
 * gpu_end): lavapipe's pipeline keys (its shader cache on disk) depend on the pipelines created
 * on the device before, so on a shared device a test's pipelines missed the cache whenever the
 * tests before it differed (the sanitizer build skips some cases: its half of `make test`
 * recompiled what the release half had compiled, at ASan's 4-6x cost: test_frontend_vk 524 s).
 * gpu_fresh gives a loop of cases the same: a fresh device per case. */
#ifndef TND_GPU_COMMON_H
#define TND_GPU_COMMON_H

#include "core/core.h"
#include "tests/tnd_test.h"

static tnd_vk gpu_vk;
static bool gpu_ready;
static uint32_t gpu_errors_before;

/* Create the context where there is none (validation on; the layer must be installed). */
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

/* Every GPU test ends with this: any validation error fails it; the context goes. */
static void gpu_end(void)
{
    if (!gpu_ready)
        return;
    vkDeviceWaitIdle(gpu_vk.device);
    uint32_t now = tnd_vk_validation_errors(&gpu_vk);
    CHECK(now == gpu_errors_before, "%u validation error(s) during this test",
          now - gpu_errors_before);
    tnd_vk_destroy(&gpu_vk);
    gpu_ready = false;
}

/* A fresh device in the middle of a test (a loop's next case): what gpu_end checks, then
 * gpu_begin; every object of the old device must be gone. */
static inline tnd_vk *gpu_fresh(void)
{
    gpu_end();
    return gpu_begin();
}

static void gpu_shutdown(void)
{
    if (gpu_ready)
        tnd_vk_destroy(&gpu_vk);
    gpu_ready = false;
}

#endif
