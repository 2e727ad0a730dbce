/* eval/metrics_gpu.c: eval's per-frame metrics on the device (shaders/ev_metrics.comp): the two
 * images uploaded, four passes over planes in one storage buffer, the per-workgroup sums read
 * back and added in double. Entry points: ev_gpu_create, ev_gpu_destroy, ev_gpu_frame. */
#include "eval/eval.h"
#include "shaders/shader_list.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

enum { PLANES = 49, RESULTS = 6, GROUP = 256, MAX_GROUPS = 1024, KERNEL_CAP = 1024,
       BINDINGS = 5 };

typedef struct push {
    uint32_t pass, w, h, groups;
    float exposure, cmax;
    int32_t rc, rf;
} push;

struct ev_gpu {
    tnd_vk *vk;
    uint32_t w, h, groups;
    int rc, rf;
    float cmax;
    tnd_buffer in[2], planes, kern, partial;
    VkDescriptorSetLayout set_layout;
    VkPipelineLayout layout;
    VkDescriptorPool pool;
    VkDescriptorSet set;
    VkPipeline pipe;
    tnd_timer timer;
};

void ev_gpu_destroy(ev_gpu *g)
{
    if (!g)
        return;
    VkDevice d = g->vk->device;
    vkDeviceWaitIdle(d);
    tnd_timer_destroy(g->vk, &g->timer);
    if (g->pipe)
        vkDestroyPipeline(d, g->pipe, NULL);
    if (g->layout)
        vkDestroyPipelineLayout(d, g->layout, NULL);
    if (g->pool)
        vkDestroyDescriptorPool(d, g->pool, NULL);
    if (g->set_layout)
        vkDestroyDescriptorSetLayout(d, g->set_layout, NULL);
    for (int i = 0; i < 2; i++)
        tnd_buffer_destroy(g->vk, &g->in[i]);
    tnd_buffer_destroy(g->vk, &g->planes);
    tnd_buffer_destroy(g->vk, &g->kern);
    tnd_buffer_destroy(g->vk, &g->partial);
    free(g);
}

tnd_result ev_gpu_create(tnd_vk *vk, uint32_t w, uint32_t h, double ppd, ev_gpu **out)
{
    tnd_result res = TND_OK;
    *out = NULL;
    if (w < 11 || h < 11)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "eval: SSIM needs at least 11x11 pixels (got "
                        "%ux%u)", w, h);
    ev_gpu *g = calloc(1, sizeof *g);
    float *table = calloc(KERNEL_CAP, sizeof(float));
    if (!g || !table) {
        free(g);
        free(table);
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "eval: out of memory");
    }
    g->vk = vk, g->w = w, g->h = h;
    size_t n = (size_t)w * h;
    g->groups = (uint32_t)((n + GROUP - 1) / GROUP < MAX_GROUPS ? (n + GROUP - 1) / GROUP
                                                                 : MAX_GROUPS);
    double cmax;
    TND_TRY(ev_flip_kernels(ppd, table, KERNEL_CAP, &g->rc, &g->rf, &cmax));
    g->cmax = (float)cmax;
    const VkBufferUsageFlags ssbo = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
    for (int i = 0; i < 2; i++)
        TND_TRY(tnd_buffer_create(vk, &(tnd_buffer_desc){.size = 3 * n * sizeof(float), .usage = ssbo,
                                                         .mem = TND_MEM_UPLOAD,
                                                         .name = "eval.metrics_in"},
                                  &g->in[i]));
    TND_TRY(tnd_buffer_create(vk, &(tnd_buffer_desc){.size = (VkDeviceSize)PLANES * n * sizeof(float),
                                                     .usage = ssbo, .mem = TND_MEM_DEVICE,
                                                     .name = "eval.metrics_planes"},
                              &g->planes));
    TND_TRY(tnd_buffer_create(vk, &(tnd_buffer_desc){.size = KERNEL_CAP * sizeof(float),
                                                     .usage = ssbo, .mem = TND_MEM_UPLOAD,
                                                     .name = "eval.metrics_kernels"},
                              &g->kern));
    memcpy(g->kern.mapped, table, KERNEL_CAP * sizeof(float));
    TND_TRY(tnd_buffer_create(vk, &(tnd_buffer_desc){.size = (VkDeviceSize)MAX_GROUPS * RESULTS *
                                                             sizeof(float),
                                                     .usage = ssbo, .mem = TND_MEM_READBACK,
                                                     .name = "eval.metrics_sums"},
                              &g->partial));
    VkDescriptorSetLayoutBinding b[BINDINGS];
    for (uint32_t i = 0; i < BINDINGS; i++)
        b[i] = (VkDescriptorSetLayoutBinding){i, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1,
                                              VK_SHADER_STAGE_COMPUTE_BIT, NULL};
    TND_VK_TRY(vkCreateDescriptorSetLayout(
        vk->device,
        &(VkDescriptorSetLayoutCreateInfo){.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO,
                                           .bindingCount = BINDINGS,
                                           .pBindings = b},
        NULL, &g->set_layout));
    VkPushConstantRange pcr = {VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push)};
    TND_VK_TRY(vkCreatePipelineLayout(
        vk->device,
        &(VkPipelineLayoutCreateInfo){.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
                                      .setLayoutCount = 1,
                                      .pSetLayouts = &g->set_layout,
                                      .pushConstantRangeCount = 1,
                                      .pPushConstantRanges = &pcr},
        NULL, &g->layout));
    VkDescriptorPoolSize ps = {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, BINDINGS};
    TND_VK_TRY(vkCreateDescriptorPool(
        vk->device,
        &(VkDescriptorPoolCreateInfo){.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO,
                                      .maxSets = 1,
                                      .poolSizeCount = 1,
                                      .pPoolSizes = &ps},
        NULL, &g->pool));
    TND_VK_TRY(vkAllocateDescriptorSets(
        vk->device,
        &(VkDescriptorSetAllocateInfo){.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO,
                                       .descriptorPool = g->pool,
                                       .descriptorSetCount = 1,
                                       .pSetLayouts = &g->set_layout},
        &g->set));
    const tnd_buffer *bufs[BINDINGS] = {&g->in[0], &g->in[1], &g->planes, &g->kern, &g->partial};
    VkDescriptorBufferInfo bi[BINDINGS];
    VkWriteDescriptorSet wr[BINDINGS];
    for (uint32_t i = 0; i < BINDINGS; i++) {
        bi[i] = (VkDescriptorBufferInfo){bufs[i]->buffer, 0, VK_WHOLE_SIZE};
        wr[i] = (VkWriteDescriptorSet){.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
                                       .dstSet = g->set,
                                       .dstBinding = i,
                                       .descriptorCount = 1,
                                       .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                                       .pBufferInfo = &bi[i]};
    }
    vkUpdateDescriptorSets(vk->device, BINDINGS, wr, 0, NULL);
    size_t bytes;
    const uint32_t *code = tnd_spirv_code(TND_SHADER_ev_metrics, &bytes, NULL);
    TND_TRY(tnd_compute_pipeline_create(vk,
                                        &(tnd_compute_desc){.code = code, .bytes = bytes,
                                                            .layout = g->layout,
                                                            .name = "eval.metrics"},
                                        &g->pipe));
    TND_TRY(tnd_timer_create(vk, &g->timer));
    free(table);
    *out = g;
    return TND_OK;
fail:
    free(table);
    ev_gpu_destroy(g);
    return res;
}

tnd_result ev_gpu_frame(ev_gpu *g, const ev_image *out, const ev_image *ref, double exposure,
                        ev_gpu_metrics *m, float *flip_map)
{
    tnd_result res = TND_OK;
    if (out->width != g->w || out->height != g->h || ref->width != g->w || ref->height != g->h)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "eval: device metrics for %ux%u given %ux%u "
                        "against %ux%u", g->w, g->h, out->width, out->height, ref->width,
                        ref->height);
    size_t n = (size_t)g->w * g->h;
    memcpy(g->in[0].mapped, out->rgb, 3 * n * sizeof(float));
    memcpy(g->in[1].mapped, ref->rgb, 3 * n * sizeof(float));
    VkCommandBuffer cmd;
    TND_TRY(tnd_cmd_begin(g->vk, &cmd));
    tnd_timer_reset(cmd, &g->timer);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, g->pipe);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, g->layout, 0, 1, &g->set, 0,
                            NULL);
    static const char *const names[4] = {"eval.metrics_prep", "eval.metrics_rows",
                                         "eval.metrics_cols", "eval.metrics_reduce"};
    for (uint32_t pass = 0; pass < 4; pass++) {
        int slot = tnd_timer_begin(cmd, &g->timer, names[pass]);
        push p = {pass, g->w, g->h, g->groups, (float)exposure, g->cmax, g->rc, g->rf};
        vkCmdPushConstants(cmd, g->layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof p, &p);
        vkCmdDispatch(cmd, pass == 3 ? g->groups : (uint32_t)((n + GROUP - 1) / GROUP), 1, 1);
        tnd_timer_end(cmd, &g->timer, slot);
        tnd_cmd_barrier(cmd);
    }
    TND_TRY(tnd_cmd_submit_wait(g->vk, cmd));
    double ms[4] = {0};
    TND_TRY(tnd_timer_read(g->vk, &g->timer, ms));

    double sum[RESULTS] = {0};
    const float *part = g->partial.mapped;
    for (uint32_t i = 0; i < g->groups; i++)
        for (int k = 0; k < RESULTS; k++)
            sum[k] += part[(size_t)i * RESULTS + k];
    double v = 3.0 * (double)n;
    *m = (ev_gpu_metrics){.flip = sum[0] / (double)n,
                          .ssim = sum[1] / (3.0 * (g->w - 10.0) * (g->h - 10.0)),
                          .relmse = sum[2] / v,
                          .smape = sum[3] / v,
                          .rmse = sqrt(sum[4] / v),
                          .psnr = ev_psnr(sum[5] / v),
                          .gpu_ms = ms[0] + ms[1] + ms[2] + ms[3],
                          .pass_ms = {ms[0], ms[1], ms[2], ms[3]}};
    if (flip_map) /* (plane 43: shaders/ev_metrics.comp's P_RES) */
        TND_TRY(tnd_buffer_download(g->vk, &g->planes, (VkDeviceSize)43 * n * sizeof(float),
                                    flip_map, n * sizeof(float)));
fail:
    return res;
}
