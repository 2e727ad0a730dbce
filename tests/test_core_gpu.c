/* tests/test_core_gpu.c: the Vulkan context on a real driver (lavapipe in CI): device choice,
 * buffers, images, compute pipelines, push and specialisation constants, timestamps, and the
 * validation-message plumbing itself. Label: gpu. */
#include "eval/eval.h"
#include "shaders/encoding.h"
#include "shaders/sampling.h"
#include "shaders/shader_list.h"
#include "tests/gpu_common.h"

static void test_context(void)
{
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    CHECK(vk->ray_tracing, "the chosen device must have RT pipelines: %s", vk->info.name);
    CHECK(vk->info.suitable, "suitable");
    CHECK(vk->validation, "validation enabled");
    CHECK(vk->fn.vkCmdTraceRaysKHR && vk->fn.vkCreateAccelerationStructureKHR, "RT functions");
    CHECK(vk->info.shader_group_handle_size > 0 && vk->info.shader_group_base_alignment > 0,
          "SBT properties read from the device");
    gpu_end();
}

/* The validation plumbing must count errors, or every "no validation error" check is vacuous:
 * inject one through the debug-utils messenger and see the counter move. */
static void test_validation_counts_errors(void)
{
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    PFN_vkSubmitDebugUtilsMessageEXT submit =
        (PFN_vkSubmitDebugUtilsMessageEXT)vkGetInstanceProcAddr(vk->instance,
                                                                "vkSubmitDebugUtilsMessageEXT");
    REQUIRE(submit, "vkSubmitDebugUtilsMessageEXT");
    VkDebugUtilsMessengerCallbackDataEXT data = {
        .sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CALLBACK_DATA_EXT,
        .pMessage = "(injected by test_validation_counts_errors; expected)"};
    uint32_t before = tnd_vk_validation_errors(vk);
    submit(vk->instance, VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT,
           VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT, &data);
    CHECK(tnd_vk_validation_errors(vk) == before + 1, "error counted");
    gpu_errors_before = tnd_vk_validation_errors(vk); /* the injected one is expected */
    gpu_end();
}

static void test_device_override(void)
{
    tnd_vk other;
    tnd_result r = tnd_vk_create(&(tnd_vk_desc){.device = "no-such-device-xyz"}, &other);
    CHECK(r == TND_ERR_NO_DEVICE, "override to a missing device fails: %s", tnd_result_name(r));
    CHECK(strstr(tnd_error_detail(), "no-such-device-xyz") != NULL, "message: %s",
          tnd_error_detail());
    CHECK(other.device == VK_NULL_HANDLE && other.instance == VK_NULL_HANDLE,
          "nothing left half-built");
    tnd_vk_destroy(&other); /* safe on a destroyed object */
}

static void test_buffers(void)
{
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    enum { N = 1 << 18 };
    uint32_t *src = malloc(N * 4), *dst = malloc(N * 4);
    tnd_buffer b = {0};
    for (uint32_t i = 0; i < N; i++)
        src[i] = i * 2654435761u;
    REQUIRE_OK(tnd_buffer_create(vk,
                                 &(tnd_buffer_desc){.size = N * 4,
                                                    .usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                                    .device_address = true,
                                                    .name = "test.buffer"},
                                 &b));
    CHECK(b.address != 0, "device address");
    CHECK(b.mapped == NULL, "device-local buffers are not mapped");
    REQUIRE_OK(tnd_buffer_upload(vk, &b, 0, src, N * 4));
    REQUIRE_OK(tnd_buffer_upload(vk, &b, 400, src + 1000, 64));
    REQUIRE_OK(tnd_buffer_download(vk, &b, 0, dst, N * 4));
    memcpy(src + 100, src + 1000, 64);
    CHECK(memcmp(src, dst, N * 4) == 0, "round trip through device memory");
    CHECK(tnd_buffer_upload(vk, &b, N * 4 - 8, src, 16) == TND_ERR_INVALID_ARGUMENT, "range check");
    tnd_buffer z;
    CHECK(tnd_buffer_create(vk, &(tnd_buffer_desc){.size = 0, .name = "zero"}, &z) ==
              TND_ERR_INVALID_ARGUMENT,
          "size 0 rejected");
cleanup:
    tnd_buffer_destroy(vk, &b);
    tnd_buffer_destroy(vk, &b); /* twice is safe */
    free(src);
    free(dst);
    gpu_end();
}

static void test_images(void)
{
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    tnd_image img = {0}, bad = {0};
    REQUIRE_OK(tnd_image_create(vk,
                                &(tnd_image_desc){.width = 37,
                                                  .height = 19,
                                                  .format = VK_FORMAT_R16G16B16A16_SFLOAT,
                                                  .name = "test.image"},
                                &img));
    CHECK(img.view != VK_NULL_HANDLE && img.width == 37, "image and view");
    CHECK(tnd_image_create(
              vk, &(tnd_image_desc){.width = 0, .height = 4, .format = VK_FORMAT_R32_SFLOAT},
              &bad) == TND_ERR_LIMIT,
          "width 0");
    CHECK(tnd_image_create(vk,
                           &(tnd_image_desc){.width = vk->info.max_image_dimension_2d + 1,
                                             .height = 4,
                                             .format = VK_FORMAT_R32_SFLOAT},
                           &bad) == TND_ERR_LIMIT,
          "beyond the device limit");
    CHECK(strstr(tnd_error_detail(), "limit") != NULL, "message: %s", tnd_error_detail());
cleanup:
    tnd_image_destroy(vk, &img);
    gpu_end();
}

static void test_compute_and_timestamps(void)
{
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    enum { N = 1000 };
    float in[N], out[N];
    for (int i = 0; i < N; i++)
        in[i] = 0.25f * (float)(i - 500);
    tnd_buffer bin = {0}, bout = {0};
    VkDescriptorSetLayout dsl = VK_NULL_HANDLE;
    VkPipelineLayout pl = VK_NULL_HANDLE;
    VkPipeline pipe = VK_NULL_HANDLE;
    VkDescriptorPool pool = VK_NULL_HANDLE;
    tnd_timer timer = {0};
    REQUIRE_OK(tnd_buffer_create(vk,
                                 &(tnd_buffer_desc){.size = sizeof in,
                                                    .usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                                    .name = "in"},
                                 &bin));
    REQUIRE_OK(tnd_buffer_create(vk,
                                 &(tnd_buffer_desc){.size = sizeof out,
                                                    .usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                                    .name = "out"},
                                 &bout));
    REQUIRE_OK(tnd_buffer_upload(vk, &bin, 0, in, sizeof in));

    VkDescriptorSetLayoutBinding bind[2] = {
        {0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, NULL},
        {1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, NULL}};
    VkDescriptorSetLayoutCreateInfo dci = {.sType =
                                               VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO,
                                           .bindingCount = 2,
                                           .pBindings = bind};
    REQUIRE(vkCreateDescriptorSetLayout(vk->device, &dci, NULL, &dsl) == VK_SUCCESS, "dsl");
    VkPushConstantRange pcr = {VK_SHADER_STAGE_COMPUTE_BIT, 0, 12};
    VkPipelineLayoutCreateInfo pci = {.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
                                      .setLayoutCount = 1,
                                      .pSetLayouts = &dsl,
                                      .pushConstantRangeCount = 1,
                                      .pPushConstantRanges = &pcr};
    REQUIRE(vkCreatePipelineLayout(vk->device, &pci, NULL, &pl) == VK_SUCCESS, "layout");
    size_t bytes;
    const uint32_t *code = tnd_spirv_code(TND_SHADER_timestamp_test_comp, &bytes, NULL);
    uint32_t local = 64;
    VkSpecializationMapEntry me = {0, 0, 4};
    VkSpecializationInfo spec = {1, &me, 4, &local};
    REQUIRE_OK(tnd_compute_pipeline_create(
        vk,
        &(tnd_compute_desc){
            .code = code, .bytes = bytes, .layout = pl, .spec = &spec, .name = "timestamp_test"},
        &pipe));
    VkDescriptorPoolSize ps = {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 2};
    VkDescriptorPoolCreateInfo dpci = {.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO,
                                       .maxSets = 1,
                                       .poolSizeCount = 1,
                                       .pPoolSizes = &ps};
    REQUIRE(vkCreateDescriptorPool(vk->device, &dpci, NULL, &pool) == VK_SUCCESS, "pool");
    VkDescriptorSet set;
    VkDescriptorSetAllocateInfo dsai = {.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO,
                                        .descriptorPool = pool,
                                        .descriptorSetCount = 1,
                                        .pSetLayouts = &dsl};
    REQUIRE(vkAllocateDescriptorSets(vk->device, &dsai, &set) == VK_SUCCESS, "set");
    VkDescriptorBufferInfo bi[2] = {{bin.buffer, 0, VK_WHOLE_SIZE},
                                    {bout.buffer, 0, VK_WHOLE_SIZE}};
    VkWriteDescriptorSet w = {.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
                              .dstSet = set,
                              .dstBinding = 0,
                              .descriptorCount = 2,
                              .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                              .pBufferInfo = bi};
    vkUpdateDescriptorSets(vk->device, 1, &w, 0, NULL);
    REQUIRE_OK(tnd_timer_create(vk, &timer));

    VkCommandBuffer cmd;
    REQUIRE_OK(tnd_cmd_begin(vk, &cmd));
    tnd_timer_reset(cmd, &timer);
    int slot = tnd_timer_begin(cmd, &timer, "scale");
    struct {
        float scale, offset;
        uint32_t count;
    } push = {2.0f, 0.5f, N};
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipe);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pl, 0, 1, &set, 0, NULL);
    vkCmdPushConstants(cmd, pl, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof push, &push);
    vkCmdDispatch(cmd, (N + local - 1) / local, 1, 1);
    tnd_timer_end(cmd, &timer, slot);
    tnd_cmd_barrier(cmd);
    REQUIRE_OK(tnd_cmd_submit_wait(vk, cmd));
    REQUIRE_OK(tnd_buffer_download(vk, &bout, 0, out, sizeof out));
    int bad = 0;
    for (int i = 0; i < N; i++)
        bad += out[i] != in[i] * 2.0f + 0.5f; /* exact: quarters times 2 plus a half */
    CHECK(bad == 0, "%d of %d outputs wrong", bad, N);
    double ms[1] = {-1};
    CHECK_OK(tnd_timer_read(vk, &timer, ms));
    CHECK(timer.count == 1 && strcmp(timer.names[0], "scale") == 0, "one named pass");
    CHECK(ms[0] >= 0.0 && ms[0] < 10000.0, "pass time %.4f ms", ms[0]);
    printf("     compute pass: %.4f ms (timestamps %s)\n", ms[0],
           vk->info.timestamps ? "on" : "unavailable");
cleanup:
    tnd_timer_destroy(vk, &timer);
    if (pool)
        vkDestroyDescriptorPool(vk->device, pool, NULL);
    if (pipe)
        vkDestroyPipeline(vk->device, pipe, NULL);
    if (pl)
        vkDestroyPipelineLayout(vk->device, pl, NULL);
    if (dsl)
        vkDestroyDescriptorSetLayout(vk->device, dsl, NULL);
    tnd_buffer_destroy(vk, &bin);
    tnd_buffer_destroy(vk, &bout);
    gpu_end();
}

/* Run `shader` over n items with two storage buffers (in, out) and a 4-byte push constant n. */
static tnd_result run_two_buffer_shader(tnd_vk *vk, tnd_shader shader, const void *in,
                                        size_t in_bytes, void *out, size_t out_bytes, uint32_t n)
{
    tnd_result res = TND_OK;
    tnd_buffer bin = {0}, bout = {0};
    VkDescriptorSetLayout dsl = VK_NULL_HANDLE;
    VkPipelineLayout pl = VK_NULL_HANDLE;
    VkPipeline pipe = VK_NULL_HANDLE;
    VkDescriptorPool pool = VK_NULL_HANDLE;
    TND_TRY(tnd_buffer_create(vk,
                              &(tnd_buffer_desc){.size = in_bytes,
                                                 .usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                                 .name = "in"},
                              &bin));
    TND_TRY(tnd_buffer_create(vk,
                              &(tnd_buffer_desc){.size = out_bytes,
                                                 .usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                                 .mem = TND_MEM_READBACK,
                                                 .name = "out"},
                              &bout));
    TND_TRY(tnd_buffer_upload(vk, &bin, 0, in, in_bytes));
    VkDescriptorSetLayoutBinding bind[2] = {
        {0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, NULL},
        {1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, NULL}};
    VkDescriptorSetLayoutCreateInfo dci = {.sType =
                                               VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO,
                                           .bindingCount = 2,
                                           .pBindings = bind};
    TND_VK_TRY(vkCreateDescriptorSetLayout(vk->device, &dci, NULL, &dsl));
    VkPushConstantRange pcr = {VK_SHADER_STAGE_COMPUTE_BIT, 0, 4};
    VkPipelineLayoutCreateInfo pci = {.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
                                      .setLayoutCount = 1,
                                      .pSetLayouts = &dsl,
                                      .pushConstantRangeCount = 1,
                                      .pPushConstantRanges = &pcr};
    TND_VK_TRY(vkCreatePipelineLayout(vk->device, &pci, NULL, &pl));
    size_t bytes;
    const uint32_t *code = tnd_spirv_code(shader, &bytes, NULL);
    TND_TRY(tnd_compute_pipeline_create(
        vk, &(tnd_compute_desc){.code = code, .bytes = bytes, .layout = pl, .name = "test"},
        &pipe));
    VkDescriptorPoolSize ps = {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 2};
    VkDescriptorPoolCreateInfo dpci = {.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO,
                                       .maxSets = 1,
                                       .poolSizeCount = 1,
                                       .pPoolSizes = &ps};
    TND_VK_TRY(vkCreateDescriptorPool(vk->device, &dpci, NULL, &pool));
    VkDescriptorSet set;
    VkDescriptorSetAllocateInfo dsai = {.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO,
                                        .descriptorPool = pool,
                                        .descriptorSetCount = 1,
                                        .pSetLayouts = &dsl};
    TND_VK_TRY(vkAllocateDescriptorSets(vk->device, &dsai, &set));
    VkDescriptorBufferInfo bi[2] = {{bin.buffer, 0, VK_WHOLE_SIZE},
                                    {bout.buffer, 0, VK_WHOLE_SIZE}};
    VkWriteDescriptorSet w = {.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
                              .dstSet = set,
                              .dstBinding = 0,
                              .descriptorCount = 2,
                              .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                              .pBufferInfo = bi};
    vkUpdateDescriptorSets(vk->device, 1, &w, 0, NULL);
    VkCommandBuffer cmd;
    TND_TRY(tnd_cmd_begin(vk, &cmd));
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipe);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pl, 0, 1, &set, 0, NULL);
    vkCmdPushConstants(cmd, pl, VK_SHADER_STAGE_COMPUTE_BIT, 0, 4, &n);
    vkCmdDispatch(cmd, (n + 63) / 64, 1, 1);
    tnd_cmd_barrier(cmd);
    TND_TRY(tnd_cmd_submit_wait(vk, cmd));
    TND_TRY(tnd_buffer_download(vk, &bout, 0, out, out_bytes));
fail:
    if (pool)
        vkDestroyDescriptorPool(vk->device, pool, NULL);
    if (pipe)
        vkDestroyPipeline(vk->device, pipe, NULL);
    if (pl)
        vkDestroyPipelineLayout(vk->device, pl, NULL);
    if (dsl)
        vkDestroyDescriptorSetLayout(vk->device, dsl, NULL);
    tnd_buffer_destroy(vk, &bin);
    tnd_buffer_destroy(vk, &bout);
    return res;
}

/* shaders/encoding.h compiled as GLSL gives the same bits as compiled as C, over the extremes
 * (1e-8 .. 1e7, zero, denormals, negatives, NaN, Inf). Both contract precisions' declarations
 * compile (the two shader variants). */
static void test_rgbe_glsl_matches_c(void)
{
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    enum { N = 4096 };
    float(*in)[4] = calloc(N, sizeof *in);
    uint32_t(*out)[4] = calloc(3 * N, sizeof *out); /* rgbe, uf16, uf16 from scaled values */
    uint32_t s = 777;
    for (int i = 0; i < N; i++)
        for (int c = 0; c < 3; c++) {
            s = s * 1664525u + 1013904223u;
            in[i][c] = (float)pow(10.0, -8.0 + 15.0 * (double)(s >> 8) / 16777216.0);
        }
    const float special[] = {0.0f,         -0.0f,
                             1e-40f,       -1.0f,
                             NAN,          INFINITY,
                             -INFINITY,    (float)TND_RGBE_MAX,
                             130815.9f,    511.75f / 256.0f,
                             3.0517578e-5f};
    for (int i = 0; i < 11; i++)
        for (int c = 0; c < 3; c++)
            in[i * 3 + c][c] = special[i], in[i * 3 + c][3] = special[i];
    const tnd_shader variants[2] = {TND_SHADER_encoding_test_f32, TND_SHADER_encoding_test_packed};
    for (int v = 0; v < 2; v++) {
        REQUIRE_OK(run_two_buffer_shader(vk, variants[v], in, N * sizeof *in, out,
                                         3 * N * sizeof *out, N));
        int bad = 0, bad_dec = 0, bad_nf = 0, bad6 = 0, bad_scaled = 0;
        for (int i = 0; i < N; i++) {
            uint32_t p = tnd_rgbe_encode(in[i][0], in[i][1], in[i][2]);
            float r = tnd_rgbe_channel(p, 0), g = tnd_rgbe_channel(p, 1);
            uint32_t rb, gb;
            memcpy(&rb, &r, 4);
            memcpy(&gb, &g, 4);
            if (out[i][0] != p && bad++ < 3)
                printf("     item %d (%g %g %g): GLSL %08x, C %08x\n", i, in[i][0], in[i][1],
                       in[i][2], out[i][0], p);
            bad_dec += out[i][1] != rb || out[i][2] != gb;
            bad_nf += out[i][3] != (tnd_nonfinite(in[i][3]) ? 1u : 0u);
            uint32_t h[3], d6[3];
            for (int c = 0; c < 3; c++) {
                h[c] = tnd_uf16_encode(in[i][c]);
                float x = tnd_uf16_decode(h[c]);
                memcpy(&d6[c], &x, 4);
            }
            bad6 += out[N + i][0] != (h[0] | h[1] << 16) || out[N + i][1] != d6[0] ||
                    out[N + i][2] != d6[1] || out[N + i][3] != d6[2];
            for (int c = 0; c < 3; c++) /* defined for finite values >= 0 */
                if (in[i][c] >= 0.0f && in[i][c] < INFINITY && out[2 * N + i][c] != h[c] &&
                    bad_scaled++ < 3)
                    printf("     %g: scaled %04x, C %04x\n", in[i][c], out[2 * N + i][c], h[c]);
        }
        CHECK(bad6 == 0, "%d of %d tnd_uf16 encodings or decodings differ", bad6, N);
        CHECK(bad_scaled == 0, "%d tnd_uf16_encode_scaled codes differ from tnd_uf16_encode",
              bad_scaled);
        CHECK(bad == 0, "%d of %d RGBE encodings differ between GLSL and C", bad, N);
        CHECK(bad_dec == 0, "%d decodings differ", bad_dec);
        CHECK(bad_nf == 0, "%d non-finite tests differ", bad_nf);
    }
cleanup:
    free(in);
    free(out);
    gpu_end();
}

/* The shared counter-based generator draws the same bits in GLSL as in C. */
static void test_rng_glsl_matches_c(void)
{
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    enum { N = 8192 };
    uint32_t(*in)[4] = calloc(N, sizeof *in), (*out)[4] = calloc(N, sizeof *out);
    for (uint32_t i = 0; i < N; i++) {
        in[i][0] = i * 7919u % 2073600u; /* pixel keys of a 1080p frame */
        in[i][1] = i % 3 == 0 ? 0xffffffffu - i : i / 13u;
        in[i][2] = i % 5 == 0 ? TND_SAMPLE_REALTIME : tnd_reference_sample(i * 2654435761u);
        in[i][3] = tnd_dim(i % 6, i % TND_DIMS_PER_BOUNCE);
    }
    REQUIRE_OK(run_two_buffer_shader(vk, TND_SHADER_sampling_test, in, N * sizeof *in, out,
                                     N * sizeof *out, N));
    int bad = 0;
    double mean = 0;
    for (uint32_t i = 0; i < N; i++) {
        float r = tnd_rand(in[i][0], in[i][1], in[i][2], in[i][3]);
        uint32_t rb, v[4] = {in[i][0], in[i][1], in[i][2], in[i][3]};
        memcpy(&rb, &r, 4);
        tnd_pcg4d(v);
        bad += out[i][0] != rb || out[i][1] != v[1] || out[i][2] != v[2] || out[i][3] != v[3];
        mean += r;
    }
    mean /= N;
    CHECK(bad == 0, "%d of %d draws differ between GLSL and C", bad, N);
    /* uniform on [0,1): mean 1/2 with standard error 1/sqrt(12 N) = 0.0032; 5 sigma */
    CHECK(fabs(mean - 0.5) < 5 * 0.0032, "mean %.4f", mean);
cleanup:
    free(in);
    free(out);
    gpu_end();
}

/* A host frame survives upload to the contract images and download, bit for bit, at both
 * precisions (formats straight from the table). */
static void test_contract_images(void)
{
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    for (int p = 0; p < 2; p++) {
        tnd_frame f = {0}, g = {0};
        tnd_contract_gpu c = {0};
        REQUIRE_OK(tnd_frame_create(37, 23, &f));
        REQUIRE_OK(tnd_frame_create(37, 23, &g));
        uint32_t s = 99;
        for (int i = 0; i < TND_CT_COUNT; i++) {
            const tnd_ct_info *e = tnd_ct_get((tnd_ct)i);
            for (size_t k = 0; k < (size_t)37 * 23 * e->comps; k++) {
                s = s * 1664525u + 1013904223u;
                if (e->kind == TND_CT_UINT)
                    tnd_frame_u(&f, (tnd_ct)i)[k] = s;
                else
                    tnd_frame_f(&f, (tnd_ct)i)[k] =
                        (float)((double)(s >> 8) / 16777216.0 * 4.0 - 1.0) * (k % 7 ? 1.0f : 3e4f);
            }
            f.present[i] = true;
        }
        tnd_frame_quantize(&f, (tnd_precision)p);
        REQUIRE_OK(tnd_contract_gpu_create(vk, 37, 23, (tnd_precision)p, &c));
        CHECK(c.images[TND_CT_HF].format ==
                  (p ? VK_FORMAT_R32_UINT : VK_FORMAT_R32G32B32A32_SFLOAT),
              "hf format from the table");
        REQUIRE_OK(tnd_contract_upload(vk, &c, &f));
        REQUIRE_OK(tnd_contract_download(vk, &c, &g));
        for (int i = 0; i < TND_CT_COUNT; i++) {
            size_t bytes = (size_t)37 * 23 * tnd_ct_get((tnd_ct)i)->comps * 4;
            CHECK(memcmp(f.data[i], g.data[i], bytes) == 0, "%s: %s differs after the GPU",
                  tnd_precision_name((tnd_precision)p), tnd_ct_get((tnd_ct)i)->name);
        }
        tnd_contract_gpu_destroy(vk, &c);
        tnd_frame_destroy(&f);
        tnd_frame_destroy(&g);
    }
cleanup:
    gpu_end();
}

static void test_shutdown(void)
{
    gpu_shutdown();
}

/* eval's metrics on the device (eval/metrics_gpu.c) against the CPU's (eval/metrics.c) on a
 * smooth image with edges and texture and a noisy copy of it, at a size that is no multiple of a
 * workgroup: relMSE, SMAPE and RMSE within 1e-5 relative (float sums per workgroup), PSNR within
 * 1e-4 dB, SSIM within 1e-5 (float moments on the device, double on the CPU: 1e-7 of E[x^2]
 * against C2 = 9e-4 on flat windows), FLIP within 2e-4 relative and its map within 2e-3 a pixel
 * (float colour maths, the device's pow and cube root). */
static void test_eval_metrics_on_device(void)
{
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    enum { W = 157, H = 93, N = W * H };
    ev_image ref = {0}, out = {0};
    ev_gpu *g = NULL;
    float *tr = malloc(3 * N * sizeof(float)), *to = malloc(3 * N * sizeof(float));
    float *map_c = malloc(N * sizeof(float)), *map_g = malloc(N * sizeof(float));
    REQUIRE(tr && to && map_c && map_g, "out of memory");
    REQUIRE_OK(ev_image_alloc(W, H, &ref));
    REQUIRE_OK(ev_image_alloc(W, H, &out));
    uint32_t st = 5;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            for (int k = 0; k < 3; k++) {
                size_t i = 3 * ((size_t)y * W + x) + k;
                st = st * 1664525u + 1013904223u;
                float base = (0.05f + 0.9f * x / W) * ((x / 17 + y / 13) % 2 ? 1.0f : 0.25f) *
                             (k == 2 ? 0.7f : 1.0f);
                ref.rgb[i] = 1.5f * base;
                out.rgb[i] = ref.rgb[i] * (0.5f + (float)(st >> 8) / 16777216.0f);
            }
    const double exposure = 1.1;
    REQUIRE_OK(ev_gpu_create(vk, W, H, EV_FLIP_PPD, &g));
    ev_gpu_metrics m;
    REQUIRE_OK(ev_gpu_frame(g, &out, &ref, exposure, &m, map_g));
    ev_tonemap(&ref, exposure, tr);
    ev_tonemap(&out, exposure, to);
    double relmse = ev_relmse(out.rgb, ref.rgb, 3 * N), smape = ev_smape(out.rgb, ref.rgb, 3 * N);
    double rmse = sqrt(ev_mse(out.rgb, ref.rgb, 3 * N)), psnr = ev_psnr(ev_mse(to, tr, 3 * N));
    double ssim, flip;
    REQUIRE_OK(ev_ssim(to, tr, W, H, &ssim));
    REQUIRE_OK(ev_flip(tr, to, W, H, EV_FLIP_PPD, map_c, &flip));
    float worst = 0;
    for (int q = 0; q < N; q++)
        worst = fmaxf(worst, fabsf(map_c[q] - map_g[q]));
    printf("     device / CPU: relMSE %.6g / %.6g, SMAPE %.6g / %.6g, RMSE %.6g / %.6g, PSNR %.5f / "
           "%.5f, SSIM %.7f / %.7f, FLIP %.6f / %.6f (map: %.2g at worst), %.3f ms (%.3f, %.3f, "
           "%.3f, %.3f)\n",
           m.relmse, relmse, m.smape, smape, m.rmse, rmse, m.psnr, psnr, m.ssim, ssim, m.flip, flip,
           worst, m.gpu_ms, m.pass_ms[0], m.pass_ms[1], m.pass_ms[2], m.pass_ms[3]);
    CHECK_NEAR(m.relmse, relmse, 1e-5 * relmse, "relMSE");
    CHECK_NEAR(m.smape, smape, 1e-5 * smape, "SMAPE");
    CHECK_NEAR(m.rmse, rmse, 1e-5 * rmse, "RMSE");
    CHECK_NEAR(m.psnr, psnr, 1e-4, "PSNR");
    CHECK_NEAR(m.ssim, ssim, 1e-5, "SSIM");
    CHECK_NEAR(m.flip, flip, 2e-4 * flip, "FLIP");
    CHECK(worst < 2e-3f, "FLIP map differs by %g", worst);
    ev_image small = {0};
    REQUIRE_OK(ev_image_alloc(W - 1, H, &small));
    CHECK(ev_gpu_frame(g, &small, &ref, exposure, &m, NULL) != TND_OK, "a frame of another size");
    tnd_error_clear();
    ev_image_free(&small);
cleanup:
    ev_gpu_destroy(g);
    ev_image_free(&ref);
    ev_image_free(&out);
    free(tr);
    free(to);
    free(map_c);
    free(map_g);
    gpu_end();
}

TND_TEST_MAIN(T(test_context), T(test_validation_counts_errors), T(test_device_override),
              T(test_buffers), T(test_images), T(test_compute_and_timestamps),
              T(test_rgbe_glsl_matches_c), T(test_rng_glsl_matches_c), T(test_contract_images),
              T(test_eval_metrics_on_device), T(test_shutdown))
