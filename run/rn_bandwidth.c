/* run/rn_bandwidth.c: the device's memory bandwidth for the floors of `tandem bench`
 * (rn_bandwidth): a timed vkCmdCopyBuffer (the transfer path) and a STREAM-style compute copy
 * (shaders/bandwidth_copy.comp, the path the back-end's passes take), both between two
 * device-local buffers, medians after a warm-up, counting the bytes read and written. */
#include "run/rn_internal.h"
#include "shaders/shader_list.h"

#include <stdlib.h>

tnd_result rn_bandwidth(tnd_vk *vk, VkDeviceSize bytes, unsigned repeats, double *transfer_gbs,
                         double *compute_gbs)
{
    tnd_result res = TND_OK;
    tnd_buffer buf[2] = {{0}};
    tnd_timer t = {0};
    VkDescriptorSetLayout dsl = VK_NULL_HANDLE;
    VkPipelineLayout layout = VK_NULL_HANDLE;
    VkPipeline pipe = VK_NULL_HANDLE;
    VkDescriptorPool pool = VK_NULL_HANDLE;
    VkDescriptorSet set = VK_NULL_HANDLE;
    double *ms = calloc(2 * (size_t)(repeats ? repeats : 1), sizeof *ms);
    *transfer_gbs = *compute_gbs = 0;
    if (!ms)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "bandwidth: out of memory");
    bytes &= ~(VkDeviceSize)15;
    for (int i = 0; i < 2; i++)
        TND_TRY(tnd_buffer_create(vk, &(tnd_buffer_desc){.size = bytes,
                                                         .usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                                         .name = i ? "bandwidth.b" : "bandwidth.a"},
                                  &buf[i]));
    VkDescriptorSetLayoutBinding b[2] = {
        {0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, NULL},
        {1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, NULL}};
    TND_VK_TRY(vkCreateDescriptorSetLayout(
        vk->device,
        &(VkDescriptorSetLayoutCreateInfo){.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO,
                                           .bindingCount = 2,
                                           .pBindings = b},
        NULL, &dsl));
    VkPushConstantRange pcr = {VK_SHADER_STAGE_COMPUTE_BIT, 0, 4};
    TND_VK_TRY(vkCreatePipelineLayout(
        vk->device,
        &(VkPipelineLayoutCreateInfo){.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
                                      .setLayoutCount = 1,
                                      .pSetLayouts = &dsl,
                                      .pushConstantRangeCount = 1,
                                      .pPushConstantRanges = &pcr},
        NULL, &layout));
    size_t code_bytes;
    const uint32_t *code = tnd_spirv_code(TND_SHADER_bandwidth_copy, &code_bytes, NULL);
    TND_TRY(tnd_compute_pipeline_create(vk,
                                        &(tnd_compute_desc){.code = code, .bytes = code_bytes,
                                                            .layout = layout,
                                                            .name = "bandwidth.copy"},
                                        &pipe));
    VkDescriptorPoolSize ps = {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 2};
    TND_VK_TRY(vkCreateDescriptorPool(
        vk->device,
        &(VkDescriptorPoolCreateInfo){.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO,
                                      .maxSets = 1,
                                      .poolSizeCount = 1,
                                      .pPoolSizes = &ps},
        NULL, &pool));
    TND_VK_TRY(vkAllocateDescriptorSets(
        vk->device,
        &(VkDescriptorSetAllocateInfo){.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO,
                                       .descriptorPool = pool,
                                       .descriptorSetCount = 1,
                                       .pSetLayouts = &dsl},
        &set));
    VkDescriptorBufferInfo bi[2] = {{buf[0].buffer, 0, VK_WHOLE_SIZE},
                                    {buf[1].buffer, 0, VK_WHOLE_SIZE}};
    VkWriteDescriptorSet w[2];
    for (uint32_t i = 0; i < 2; i++)
        w[i] = (VkWriteDescriptorSet){.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
                                      .dstSet = set,
                                      .dstBinding = i,
                                      .descriptorCount = 1,
                                      .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                                      .pBufferInfo = &bi[i]};
    vkUpdateDescriptorSets(vk->device, 2, w, 0, NULL);
    TND_TRY(tnd_timer_create(vk, &t));
    uint32_t count = (uint32_t)(bytes / 16);
    for (unsigned r = 0; r <= repeats; r++) { /* r = 0 warms up */
        VkCommandBuffer cmd;
        TND_TRY(tnd_cmd_begin(vk, &cmd));
        tnd_timer_reset(cmd, &t);
        int s0 = tnd_timer_begin(cmd, &t, "bandwidth.transfer");
        vkCmdCopyBuffer(cmd, buf[0].buffer, buf[1].buffer, 1, &(VkBufferCopy){0, 0, bytes});
        tnd_timer_end(cmd, &t, s0);
        tnd_cmd_barrier(cmd);
        int s1 = tnd_timer_begin(cmd, &t, "bandwidth.compute");
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipe);
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, &set, 0, NULL);
        vkCmdPushConstants(cmd, layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, 4, &count);
        uint32_t groups = (count + 255) / 256;
        vkCmdDispatch(cmd, groups < 65535 ? groups : 65535, 1, 1);
        tnd_timer_end(cmd, &t, s1);
        TND_TRY(tnd_cmd_submit_wait(vk, cmd));
        double m[2] = {0, 0};
        TND_TRY(tnd_timer_read(vk, &t, m));
        if (r > 0)
            ms[r - 1] = m[0], ms[repeats + r - 1] = m[1];
    }
    if (repeats) {
        double a = rn_median(ms, repeats), c = rn_median(ms + repeats, repeats);
        *transfer_gbs = a > 0 ? 2.0 * (double)bytes / (a * 1e-3) / 1e9 : 0;
        *compute_gbs = c > 0 ? 2.0 * (double)bytes / (c * 1e-3) / 1e9 : 0;
    }
fail:
    free(ms);
    tnd_timer_destroy(vk, &t);
    if (pool)
        vkDestroyDescriptorPool(vk->device, pool, NULL);
    if (pipe)
        vkDestroyPipeline(vk->device, pipe, NULL);
    if (layout)
        vkDestroyPipelineLayout(vk->device, layout, NULL);
    if (dsl)
        vkDestroyDescriptorSetLayout(vk->device, dsl, NULL);
    tnd_buffer_destroy(vk, &buf[0]);
    tnd_buffer_destroy(vk, &buf[1]);
    return res;
}
