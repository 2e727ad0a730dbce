/* viewer/vw_compose.c: the image `tandem view` shows, composed on the device (view_compose.comp):
 * one or two views split by a divider, the overlay on top.
 * Entry points: vw_compose_create, vw_compose_destroy, vw_compose_run. */
#include "shaders/shader_list.h"
#include "viewer/viewer.h"

#include <stdlib.h>

struct vw_compose {
    tnd_vk *vk;
    VkDescriptorSetLayout set_layout;
    VkPipelineLayout layout;
    VkDescriptorPool pool;
    VkDescriptorSet set;
    VkPipeline pipe;
};

typedef struct push {
    int32_t size[2];
    int32_t split, pad;
    int32_t overlay_size[2];
} push;

void vw_compose_destroy(vw_compose *c)
{
    if (!c)
        return;
    VkDevice d = c->vk->device;
    vkDeviceWaitIdle(d);
    if (c->pipe)
        vkDestroyPipeline(d, c->pipe, NULL);
    if (c->layout)
        vkDestroyPipelineLayout(d, c->layout, NULL);
    if (c->pool)
        vkDestroyDescriptorPool(d, c->pool, NULL);
    if (c->set_layout)
        vkDestroyDescriptorSetLayout(d, c->set_layout, NULL);
    free(c);
}

tnd_result vw_compose_create(tnd_vk *vk, vw_compose **out)
{
    tnd_result res = TND_OK;
    *out = NULL;
    vw_compose *c = calloc(1, sizeof *c);
    if (!c)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "window: out of memory");
    c->vk = vk;
    VkDescriptorSetLayoutBinding b[4];
    for (uint32_t i = 0; i < 4; i++)
        b[i] = (VkDescriptorSetLayoutBinding){i, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1,
                                              VK_SHADER_STAGE_COMPUTE_BIT, NULL};
    TND_VK_TRY(vkCreateDescriptorSetLayout(
        vk->device,
        &(VkDescriptorSetLayoutCreateInfo){
            .sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO,
            .bindingCount = 4,
            .pBindings = b},
        NULL, &c->set_layout));
    VkPushConstantRange pcr = {VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push)};
    TND_VK_TRY(vkCreatePipelineLayout(
        vk->device,
        &(VkPipelineLayoutCreateInfo){.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
                                      .setLayoutCount = 1,
                                      .pSetLayouts = &c->set_layout,
                                      .pushConstantRangeCount = 1,
                                      .pPushConstantRanges = &pcr},
        NULL, &c->layout));
    VkDescriptorPoolSize ps = {VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 4};
    TND_VK_TRY(vkCreateDescriptorPool(
        vk->device,
        &(VkDescriptorPoolCreateInfo){.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO,
                                      .maxSets = 1,
                                      .poolSizeCount = 1,
                                      .pPoolSizes = &ps},
        NULL, &c->pool));
    TND_VK_TRY(vkAllocateDescriptorSets(
        vk->device,
        &(VkDescriptorSetAllocateInfo){.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO,
                                       .descriptorPool = c->pool,
                                       .descriptorSetCount = 1,
                                       .pSetLayouts = &c->set_layout},
        &c->set));
    size_t bytes = 0;
    const uint32_t *code = tnd_spirv_code(TND_SHADER_view_compose, &bytes, NULL);
    TND_TRY(tnd_compute_pipeline_create(
        vk, &(tnd_compute_desc){.code = code, .bytes = bytes, .layout = c->layout,
                                .name = "view.compose"},
        &c->pipe));
    *out = c;
    return TND_OK;
fail:
    vw_compose_destroy(c);
    return res;
}

tnd_result vw_compose_run(vw_compose *c, const tnd_image *a, const tnd_image *b, int split,
                          const tnd_image *overlay, const tnd_image *out)
{
    tnd_result res = TND_OK;
    const tnd_image *imgs[4] = {a, b ? b : a, overlay, out};
    VkDescriptorImageInfo ii[4];
    VkWriteDescriptorSet w[4];
    for (uint32_t i = 0; i < 4; i++) {
        ii[i] = (VkDescriptorImageInfo){VK_NULL_HANDLE, imgs[i]->view, VK_IMAGE_LAYOUT_GENERAL};
        w[i] = (VkWriteDescriptorSet){.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
                                      .dstSet = c->set,
                                      .dstBinding = i,
                                      .descriptorCount = 1,
                                      .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE,
                                      .pImageInfo = &ii[i]};
    }
    /* (every submission here is waited for: the set is free to rewrite) */
    vkUpdateDescriptorSets(c->vk->device, 4, w, 0, NULL);
    push pc = {{(int32_t)out->width, (int32_t)out->height},
               b ? split : -1,
               0,
               {(int32_t)overlay->width, (int32_t)overlay->height}};
    VkCommandBuffer cmd;
    TND_TRY(tnd_cmd_begin(c->vk, &cmd));
    tnd_cmd_barrier(cmd);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, c->pipe);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, c->layout, 0, 1, &c->set, 0,
                            NULL);
    vkCmdPushConstants(cmd, c->layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof pc, &pc);
    vkCmdDispatch(cmd, (out->width + 7) / 8, (out->height + 7) / 8, 1);
    tnd_cmd_barrier(cmd);
    TND_TRY(tnd_cmd_submit_wait(c->vk, cmd));
fail:
    return res;
}
