/* tests/test_core.c: unit tests of core/ that need no GPU: results and messages, device choice,
 * SBT layout arithmetic, files. */
#include "core/core.h"
#include "shaders/sampling.h"
#include "tests/tnd_test.h"

#include <unistd.h>

static void test_result_catalogue(void)
{
    CHECK(TND_OK == 0, "TND_OK must be 0");
    CHECK(strcmp(tnd_result_name(TND_ERR_IO), "TND_ERR_IO") == 0, "name");
    CHECK(strcmp(tnd_result_message(TND_ERR_BAD_INPUT), "malformed input") == 0, "message");
    CHECK(strcmp(tnd_result_name((tnd_result)999), "TND_ERR_UNKNOWN") == 0, "out of range");
    tnd_result r = tnd_fail(TND_ERR_BAD_INPUT, "scene: %s: mesh %d", "x.gltf", 3);
    CHECK(r == TND_ERR_BAD_INPUT, "returns its code");
    CHECK(strcmp(tnd_error_detail(), "scene: x.gltf: mesh 3") == 0, "detail '%s'",
          tnd_error_detail());
    tnd_error_clear();
    CHECK(tnd_error_detail()[0] == '\0', "cleared");
}

static void test_vk_error_format(void)
{
    tnd_result r = tnd_fail_vk("/a/b/core/vk.c", 42, "vkCreateDevice(phys, &ci, NULL, &dev)",
                               VK_ERROR_INITIALIZATION_FAILED);
    CHECK(r == TND_ERR_VULKAN, "code");
    CHECK(strcmp(tnd_error_detail(), "vk.c:42: vkCreateDevice -> VK_ERROR_INITIALIZATION_FAILED") ==
              0,
          "got '%s'", tnd_error_detail());
    /* a lost device says so in words (it is not the user's input) and still names the call */
    r = tnd_fail_vk("/a/b/core/vk.c", 42, "vkWaitForFences(d, 1, &f, VK_TRUE, ~0ull)",
                    VK_ERROR_DEVICE_LOST);
    CHECK(r == TND_ERR_VULKAN && strstr(tnd_error_detail(), "the device was lost") &&
              strstr(tnd_error_detail(), "vk.c:42: vkWaitForFences -> VK_ERROR_DEVICE_LOST"),
          "got '%s'", tnd_error_detail());
    CHECK(strcmp(tnd_vk_result_name(VK_ERROR_OUT_OF_DEVICE_MEMORY),
                 "VK_ERROR_OUT_OF_DEVICE_MEMORY") == 0,
          "name");
}

static tnd_vk_device_info fake(const char *name, VkPhysicalDeviceType type, bool rt)
{
    tnd_vk_device_info d = {0};
    snprintf(d.name, sizeof d.name, "%s", name);
    d.type = type;
    d.compute_ok = true;
    d.suitable = rt;
    if (!rt)
        snprintf(d.why_not, sizeof d.why_not, "no VK_KHR_ray_tracing_pipeline");
    return d;
}

static void test_choose_device(void)
{
    tnd_vk_device_info devs[3] = {
        fake("llvmpipe (LLVM 19.1.7, 256 bits)", VK_PHYSICAL_DEVICE_TYPE_CPU, true),
        fake("Old iGPU", VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU, false),
        fake("NVIDIA H100 80GB HBM3", VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU, true),
    };
    uint32_t c = 99;
    CHECK_OK(tnd_vk_choose_device(devs, 3, NULL, true, &c));
    CHECK(c == 2, "a discrete GPU wins by default, got %u", c);
    CHECK_OK(tnd_vk_choose_device(devs, 2, "", true, &c));
    CHECK(c == 0, "lavapipe when no GPU has ray tracing, got %u", c);
    CHECK_OK(tnd_vk_choose_device(devs, 3, "LLVMPIPE", true, &c));
    CHECK(c == 0, "substring match is case-insensitive, got %u", c);
    CHECK_OK(tnd_vk_choose_device(devs, 3, NULL, false, &c));
    CHECK(c == 2, "compute-only still prefers discrete, got %u", c);
    CHECK_OK(tnd_vk_choose_device(devs + 1, 1, NULL, false, &c));
    CHECK(c == 0, "compute-only accepts a device without RT");

    tnd_result r = tnd_vk_choose_device(devs, 3, "nonexistent", true, &c);
    CHECK(r == TND_ERR_NO_DEVICE, "no match must fail");
    CHECK(strstr(tnd_error_detail(), "nonexistent") && strstr(tnd_error_detail(), "H100"),
          "message names the request and the devices: '%s'", tnd_error_detail());
    r = tnd_vk_choose_device(devs, 3, "iGPU", true, &c);
    CHECK(r == TND_ERR_NO_DEVICE, "an unsuitable match must fail");
    CHECK(strstr(tnd_error_detail(), "ray_tracing_pipeline") != NULL, "says why: '%s'",
          tnd_error_detail());
    r = tnd_vk_choose_device(devs, 0, NULL, true, &c);
    CHECK(r == TND_ERR_NO_DEVICE, "no devices at all");
    /* by index (an array task's GPU): digits are an index, never part of a name */
    CHECK_OK(tnd_vk_choose_device(devs, 3, "0", true, &c));
    CHECK(c == 0, "index 0 picks the first device even where a GPU would win, got %u", c);
    CHECK_OK(tnd_vk_choose_device(devs, 3, "2", true, &c));
    CHECK(c == 2, "index 2, got %u", c);
    r = tnd_vk_choose_device(devs, 3, "1", true, &c);
    CHECK(r == TND_ERR_NO_DEVICE && strstr(tnd_error_detail(), "ray_tracing_pipeline"),
          "an unsuitable index fails and says why: '%s'", tnd_error_detail());
    r = tnd_vk_choose_device(devs, 3, "80", true, &c); /* ("80GB" in the H100's name) */
    CHECK(r == TND_ERR_NO_DEVICE && strstr(tnd_error_detail(), "from 0 to 2"),
          "an index past the devices fails with their range: '%s'", tnd_error_detail());
    CHECK_OK(tnd_vk_choose_device(devs, 3, "H100 80", true, &c));
    CHECK(c == 2, "a name with digits still matches, got %u", c);
}

/* The SBT rules of VK_KHR_ray_tracing_pipeline, checked on the numbers of both machines we run
 * on (platform.md) and one more exotic set. */
static void test_sbt_layout(void)
{
    const uint32_t cases[][3] = {{32, 16, 32}, {32, 32, 64}, {16, 8, 256}};
    for (int k = 0; k < 3; k++) {
        uint32_t hs = cases[k][0], ha = cases[k][1], ba = cases[k][2];
        tnd_sbt_layout l;
        CHECK_OK(tnd_sbt_compute_layout(hs, ha, ba, 3, 2, 5, &l));
        CHECK(l.handle_stride >= hs && l.handle_stride % ha == 0, "stride %u", l.handle_stride);
        for (int i = 0; i < 3; i++)
            CHECK(l.raygen_offset[i] % ba == 0, "raygen %d offset %llu", i,
                  (unsigned long long)l.raygen_offset[i]);
        CHECK(l.raygen_size == l.handle_stride, "raygen size must equal its stride");
        CHECK(l.raygen_offset[1] >= l.raygen_offset[0] + l.raygen_size, "no overlap");
        CHECK(l.miss_offset % ba == 0 && l.hit_offset % ba == 0, "region bases aligned");
        CHECK(l.miss_offset >= l.raygen_offset[2] + l.raygen_size, "miss after raygen");
        CHECK(l.miss_size >= 2ull * l.handle_stride, "miss region holds 2 handles");
        CHECK(l.hit_offset >= l.miss_offset + l.miss_size, "hit after miss");
        CHECK(l.hit_size >= 5ull * l.handle_stride, "hit region holds 5 handles");
        CHECK(l.total >= l.hit_offset + 5ull * l.handle_stride, "total covers everything");
    }
    tnd_sbt_layout l;
    CHECK(tnd_sbt_compute_layout(32, 24, 64, 1, 1, 1, &l) == TND_ERR_INVALID_ARGUMENT,
          "non-power-of-two alignment rejected");
    CHECK(tnd_sbt_compute_layout(32, 16, 32, 0, 1, 1, &l) == TND_ERR_INVALID_ARGUMENT,
          "at least one raygen");
}

static void test_files(void)
{
    char dir[] = "/tmp/tandem_test_XXXXXX";
    REQUIRE(mkdtemp(dir) != NULL, "mkdtemp");
    char path[256], sub[256];
    snprintf(path, sizeof path, "%s/a.bin", dir);
    snprintf(sub, sizeof sub, "%s/x/y/z", dir);
    const char msg[] = "hello\0world";
    CHECK_OK(tnd_file_write_atomic(path, msg, sizeof msg));
    void *data = NULL;
    size_t size = 0;
    CHECK_OK(tnd_file_read(path, &data, &size));
    CHECK(size == sizeof msg && data && memcmp(data, msg, size) == 0, "round trip");
    CHECK(data && ((char *)data)[size] == '\0', "NUL-terminated");
    free(data);
    char tmp[300];
    snprintf(tmp, sizeof tmp, "%s.tmp.%ld", path, (long)getpid());
    CHECK(access(tmp, F_OK) != 0, "no temporary file left behind");

    snprintf(tmp, sizeof tmp, "%s/missing.gltf", dir);
    tnd_result r = tnd_file_read(tmp, &data, &size);
    CHECK(r == TND_ERR_IO && data == NULL, "missing file is TND_ERR_IO");
    CHECK(strstr(tnd_error_detail(), "missing.gltf") != NULL, "message names the file: %s",
          tnd_error_detail());
    snprintf(tmp, sizeof tmp, "%s/nodir/out.bin", dir);
    CHECK(tnd_file_write_atomic(tmp, msg, 3) == TND_ERR_IO, "write into a missing directory");
    CHECK(access(tmp, F_OK) != 0, "and no partial output");

    CHECK_OK(tnd_mkdirs(sub));
    CHECK_OK(tnd_mkdirs(sub)); /* idempotent */
    CHECK(tnd_mkdirs(path) == TND_ERR_IO, "a file is not a directory");
    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    CHECK(system(cmd) == 0, "cleanup");
}

/* OpenEXRCore 3.1 stores a ZIP chunk whose zlib output is exactly the raw size as zlib, and reads
 * it back as raw: garbage. The writer must notice and write the file uncompressed. Chunks of one
 * line (ZIPS) whose first k floats are random and the rest zero have every compressed size near
 * the raw one; some k hits it exactly. Every file must read back bit for bit, and the fallback
 * must have happened (else the test proves nothing). */
static void test_exr_zip_equal_size(void)
{
    char dir[] = "/tmp/tandem_exr_XXXXXX";
    REQUIRE(mkdtemp(dir), "mkdtemp");
    char path[256];
    snprintf(path, sizeof path, "%s/t.exr", dir);
    uint32_t before = tnd_exr_uncompressed_fallbacks(), files = 0, bad = 0;
    uint32_t state = 12345u;
    static float px[256];
    for (uint32_t w = 16; w <= 128 && tnd_exr_uncompressed_fallbacks() == before; w += 8)
        for (uint32_t k = 0; k <= w; k++) {
            for (uint32_t i = 0; i < w; i++) {
                state = state * 1664525u + 1013904223u;
                uint32_t bits = state;
                float v;
                memcpy(&v, &bits, 4);
                px[i] = i < k && isfinite(v) ? v : 0.0f;
            }
            const tnd_exr_channel_desc ch = {"Y", TND_EXR_FLOAT, px, 1};
            CHECK_OK(tnd_exr_write(path, w, 1, &ch, 1, NULL, 0, TND_EXR_ZIPS));
            tnd_exr_file f;
            if (tnd_exr_read(path, &f) != TND_OK) {
                bad++;
                tnd_error_clear();
                continue;
            }
            bad += memcmp(f.channels[0].data, px, (size_t)w * 4) != 0;
            tnd_exr_close(&f);
            files++;
        }
    uint32_t fallbacks = tnd_exr_uncompressed_fallbacks() - before;
    printf("     %u files: %u written uncompressed (equal-size zlib chunk), %u read back wrong\n",
           files, fallbacks, bad);
    CHECK(fallbacks > 0, "no chunk hit the equal-size case: the test saw nothing");
    CHECK(bad == 0, "%u files read back wrong", bad);
    remove(path);
    rmdir(dir);
}

/* The reference's sample sequence (shaders/sampling.h): the Sobol' second dimension's five-shift
 * form equals its direction numbers; every pair of dimensions of a pixel's first 2^m samples is a
 * (0, m, 2)-net (each of the 2^m cells of every shape 2^-a x 2^-(m-a) holds exactly one point),
 * the two coordinates are each a stratified 1D sequence, different pixels, frames and pairs draw
 * different points, and the real-time word keeps the hash. */
static void test_reference_samples_stratify(void)
{
    uint32_t state = 7u, bad_sobol = 0;
    for (int t = 0; t < 4096; t++) {
        state = state * 1664525u + 1013904223u;
        uint32_t x = 0u, v = 0x80000000u;
        for (uint32_t k = 0; k < 32; k++, v ^= v >> 1)
            if (state >> k & 1u)
                x ^= v;
        bad_sobol += tnd_reverse_bits(tnd_sobol1_rev(state)) != x;
    }
    CHECK(bad_sobol == 0, "%u of 4096 Sobol' points differ from the direction numbers", bad_sobol);
    enum { M = 8, N = 1 << M };
    static const uint32_t dims[][2] = {
        {TND_DIM_JITTER_X, TND_DIM_JITTER_Y}, {2 + TND_DIM_LIGHT_U, 2 + TND_DIM_LIGHT_V},
        {2 + 8 * 3 + TND_DIM_BRDF_U, 2 + 8 * 3 + TND_DIM_BRDF_V},
        {2 + 8 * 9 + TND_DIM_LIGHT_PICK, 2 + 8 * 9 + TND_DIM_LOBE},
        {2 + TND_DIM_RR, 2 + TND_DIM_SPLIT}};
    uint32_t bad_net = 0, nets = 0, same = 0;
    for (uint32_t px = 0; px < 3; px++)
        for (uint32_t d = 0; d < sizeof dims / sizeof dims[0]; d++) {
            float u[N], w[N];
            for (uint32_t s = 0; s < N; s++) {
                u[s] = tnd_rand(px * 7919u, 5u + px, tnd_reference_sample(s), dims[d][0]);
                w[s] = tnd_rand(px * 7919u, 5u + px, tnd_reference_sample(s), dims[d][1]);
                same += u[s] == w[s];
            }
            for (uint32_t m = 1; m <= M; m++)
                for (uint32_t a = 0; a <= m; a++) { /* cells 2^-a wide, 2^-(m-a) high */
                    uint8_t seen[N] = {0};
                    for (uint32_t s = 0; s < (1u << m); s++) {
                        uint32_t cx = (uint32_t)(u[s] * (float)(1u << a));
                        uint32_t cy = (uint32_t)(w[s] * (float)(1u << (m - a)));
                        seen[cx * (1u << (m - a)) + cy]++;
                    }
                    for (uint32_t c = 0; c < (1u << m); c++)
                        bad_net += seen[c] != 1;
                    nets++;
                }
        }
    CHECK(bad_net == 0, "%u cells of %u nets hold other than one point", bad_net, nets);
    CHECK(same < 4, "the two coordinates of a pair agree %u times", same);
    /* independence between pixels, frames and vertices: the first sample differs */
    float a = tnd_rand(1, 2, tnd_reference_sample(0), 2 + TND_DIM_BRDF_U);
    CHECK(a != tnd_rand(2, 2, tnd_reference_sample(0), 2 + TND_DIM_BRDF_U), "pixels share a point");
    CHECK(a != tnd_rand(1, 3, tnd_reference_sample(0), 2 + TND_DIM_BRDF_U), "frames share a point");
    CHECK(a != tnd_rand(1, 2, tnd_reference_sample(0), 10 + TND_DIM_BRDF_U), "vertices share");
    uint32_t h[4] = {1, 2, TND_SAMPLE_REALTIME, 2 + TND_DIM_BRDF_U};
    tnd_pcg4d(h);
    float rt = tnd_rand(1, 2, TND_SAMPLE_REALTIME, 2 + TND_DIM_BRDF_U);
    CHECK(rt == (float)(h[0] >> 8) / 16777216.0f, "the real-time word no longer draws the hash");
}

TND_TEST_MAIN(T(test_reference_samples_stratify), T(test_exr_zip_equal_size), T(test_result_catalogue), T(test_vk_error_format), T(test_choose_device),
              T(test_sbt_layout), T(test_files))
