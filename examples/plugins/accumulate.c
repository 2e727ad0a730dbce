/* examples/plugins/accumulate.c: a Tandem denoiser plugin (include/tandem/tandem_plugin.h):
 * plain reprojected temporal accumulation of the noisy radiance (accumulate.comp), on the
 * Vulkan device Tandem hands it. It owns its history (two ping-ponged colour and depth images)
 * and records one dispatch per frame into Tandem's command buffer. It needs nothing of Tandem
 * but the header.
 *
 *     tandem render --scene data/scenes/cornell.gltf --frontend vk \
 *         --denoiser plugin:build/plugins/accumulate.so --out out/accumulate
 *
 * $TANDEM_ACCUMULATE_FRAMES sets the window (default 32 frames). */
#include <vulkan/vulkan.h>

#include <tandem/tandem_plugin.h>

#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "accumulate_spv.h" /* accumulate_spv: the shader, compiled at build time */

enum { B_RADIANCE, B_MOTION, B_DEPTH, B_RESULT, B_HIST_PREV, B_DEPTH_PREV, B_HIST_CUR,
       B_DEPTH_CUR, B_COUNT };

typedef struct image {
    VkImage image;
    VkDeviceMemory memory;
    VkImageView view;
} image;

typedef struct state {
    tandem_vulkan vk;
    uint32_t width, height, frame;
    float max_frames;
    image hist[2], depth[2];
    VkDescriptorSetLayout set_layout;
    VkPipelineLayout layout;
    VkDescriptorPool pool;
    VkDescriptorSet set;
    VkPipeline pipe;
    VkCommandPool cmd_pool;
} state;

typedef struct push {
    uint32_t size[2];
    uint32_t reset;
    float max_frames;
} push;

#define CHECK(call, what)                                                                          \
    do {                                                                                           \
        VkResult r_ = (call);                                                                      \
        if (r_ != VK_SUCCESS) {                                                                    \
            snprintf(err, cap, "%s failed (VkResult %d)", what, (int)r_);                          \
            return 1;                                                                              \
        }                                                                                          \
    } while (0)

static void image_destroy(const state *s, image *i)
{
    if (i->view)
        vkDestroyImageView(s->vk.device, i->view, NULL);
    if (i->image)
        vkDestroyImage(s->vk.device, i->image, NULL);
    if (i->memory)
        vkFreeMemory(s->vk.device, i->memory, NULL);
    memset(i, 0, sizeof *i);
}

static int image_create(state *s, VkFormat format, image *out, char *err, uint32_t cap)
{
    VkImageCreateInfo ci = {.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO,
                            .imageType = VK_IMAGE_TYPE_2D,
                            .format = format,
                            .extent = {s->width, s->height, 1},
                            .mipLevels = 1,
                            .arrayLayers = 1,
                            .samples = VK_SAMPLE_COUNT_1_BIT,
                            .tiling = VK_IMAGE_TILING_OPTIMAL,
                            .usage = VK_IMAGE_USAGE_STORAGE_BIT,
                            .initialLayout = VK_IMAGE_LAYOUT_UNDEFINED};
    CHECK(vkCreateImage(s->vk.device, &ci, NULL, &out->image), "vkCreateImage");
    VkMemoryRequirements req;
    vkGetImageMemoryRequirements(s->vk.device, out->image, &req);
    VkPhysicalDeviceMemoryProperties mp;
    vkGetPhysicalDeviceMemoryProperties(s->vk.physical_device, &mp);
    uint32_t type = UINT32_MAX;
    for (uint32_t t = 0; t < mp.memoryTypeCount && type == UINT32_MAX; t++)
        if ((req.memoryTypeBits & (1u << t)) &&
            (mp.memoryTypes[t].propertyFlags & VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT))
            type = t;
    if (type == UINT32_MAX) {
        snprintf(err, cap, "no device-local memory for the history");
        return 1;
    }
    VkMemoryAllocateInfo ai = {.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO,
                               .allocationSize = req.size,
                               .memoryTypeIndex = type};
    CHECK(vkAllocateMemory(s->vk.device, &ai, NULL, &out->memory), "vkAllocateMemory");
    CHECK(vkBindImageMemory(s->vk.device, out->image, out->memory, 0), "vkBindImageMemory");
    VkImageViewCreateInfo vi = {.sType = VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO,
                                .image = out->image,
                                .viewType = VK_IMAGE_VIEW_TYPE_2D,
                                .format = format,
                                .subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1}};
    CHECK(vkCreateImageView(s->vk.device, &vi, NULL, &out->view), "vkCreateImageView");
    return 0;
}

static void acc_destroy(void *ctx)
{
    state *s = ctx;
    if (!s)
        return;
    VkDevice dev = s->vk.device;
    for (int k = 0; k < 2; k++) {
        image_destroy(s, &s->hist[k]);
        image_destroy(s, &s->depth[k]);
    }
    if (s->pipe)
        vkDestroyPipeline(dev, s->pipe, NULL);
    if (s->layout)
        vkDestroyPipelineLayout(dev, s->layout, NULL);
    if (s->pool)
        vkDestroyDescriptorPool(dev, s->pool, NULL);
    if (s->set_layout)
        vkDestroyDescriptorSetLayout(dev, s->set_layout, NULL);
    if (s->cmd_pool)
        vkDestroyCommandPool(dev, s->cmd_pool, NULL);
    free(s);
}

/* The history images to layout GENERAL, once (the only submission: in create). */
static int to_general(state *s, char *err, uint32_t cap)
{
    VkCommandPoolCreateInfo pi = {.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO,
                                  .queueFamilyIndex = s->vk.queue_family};
    CHECK(vkCreateCommandPool(s->vk.device, &pi, NULL, &s->cmd_pool), "vkCreateCommandPool");
    VkCommandBufferAllocateInfo ai = {.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO,
                                      .commandPool = s->cmd_pool,
                                      .level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
                                      .commandBufferCount = 1};
    VkCommandBuffer cmd;
    CHECK(vkAllocateCommandBuffers(s->vk.device, &ai, &cmd), "vkAllocateCommandBuffers");
    VkCommandBufferBeginInfo bi = {.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO,
                                   .flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT};
    CHECK(vkBeginCommandBuffer(cmd, &bi), "vkBeginCommandBuffer");
    VkImageMemoryBarrier b[4];
    for (int k = 0; k < 4; k++)
        b[k] = (VkImageMemoryBarrier){
            .sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER,
            .dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT,
            .oldLayout = VK_IMAGE_LAYOUT_UNDEFINED,
            .newLayout = VK_IMAGE_LAYOUT_GENERAL,
            .srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
            .dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
            .image = k < 2 ? s->hist[k].image : s->depth[k - 2].image,
            .subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1}};
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT,
                         VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, 0, 0, NULL, 0, NULL, 4, b);
    CHECK(vkEndCommandBuffer(cmd), "vkEndCommandBuffer");
    VkSubmitInfo si = {.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO,
                       .commandBufferCount = 1,
                       .pCommandBuffers = &cmd};
    CHECK(vkQueueSubmit(s->vk.queue, 1, &si, VK_NULL_HANDLE), "vkQueueSubmit");
    CHECK(vkQueueWaitIdle(s->vk.queue), "vkQueueWaitIdle");
    vkFreeCommandBuffers(s->vk.device, s->cmd_pool, 1, &cmd);
    return 0;
}

static int setup(state *s, char *err, uint32_t cap)
{
    VkDevice dev = s->vk.device;
    for (int k = 0; k < 2; k++)
        if (image_create(s, VK_FORMAT_R32G32B32A32_SFLOAT, &s->hist[k], err, cap) ||
            image_create(s, VK_FORMAT_R32_SFLOAT, &s->depth[k], err, cap))
            return 1;
    if (to_general(s, err, cap))
        return 1;
    VkDescriptorSetLayoutBinding b[B_COUNT];
    for (uint32_t i = 0; i < B_COUNT; i++)
        b[i] = (VkDescriptorSetLayoutBinding){
            .binding = i,
            .descriptorType = i <= B_DEPTH ? VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE
                                           : VK_DESCRIPTOR_TYPE_STORAGE_IMAGE,
            .descriptorCount = 1,
            .stageFlags = VK_SHADER_STAGE_COMPUTE_BIT};
    VkDescriptorSetLayoutCreateInfo li = {.sType =
                                              VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO,
                                          .bindingCount = B_COUNT,
                                          .pBindings = b};
    CHECK(vkCreateDescriptorSetLayout(dev, &li, NULL, &s->set_layout),
          "vkCreateDescriptorSetLayout");
    VkPushConstantRange pr = {VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push)};
    VkPipelineLayoutCreateInfo pli = {.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
                                      .setLayoutCount = 1,
                                      .pSetLayouts = &s->set_layout,
                                      .pushConstantRangeCount = 1,
                                      .pPushConstantRanges = &pr};
    CHECK(vkCreatePipelineLayout(dev, &pli, NULL, &s->layout), "vkCreatePipelineLayout");
    VkDescriptorPoolSize ps[2] = {{VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE, 3},
                                  {VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, B_COUNT - 3}};
    VkDescriptorPoolCreateInfo dpi = {.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO,
                                      .maxSets = 1,
                                      .poolSizeCount = 2,
                                      .pPoolSizes = ps};
    CHECK(vkCreateDescriptorPool(dev, &dpi, NULL, &s->pool), "vkCreateDescriptorPool");
    VkDescriptorSetAllocateInfo sai = {.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO,
                                       .descriptorPool = s->pool,
                                       .descriptorSetCount = 1,
                                       .pSetLayouts = &s->set_layout};
    CHECK(vkAllocateDescriptorSets(dev, &sai, &s->set), "vkAllocateDescriptorSets");
    VkShaderModuleCreateInfo mi = {.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO,
                                   .codeSize = sizeof accumulate_spv,
                                   .pCode = accumulate_spv};
    VkShaderModule mod;
    CHECK(vkCreateShaderModule(dev, &mi, NULL, &mod), "vkCreateShaderModule");
    VkComputePipelineCreateInfo ci = {
        .sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO,
        .stage = {.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO,
                  .stage = VK_SHADER_STAGE_COMPUTE_BIT,
                  .module = mod,
                  .pName = "main"},
        .layout = s->layout};
    VkResult r = vkCreateComputePipelines(dev, VK_NULL_HANDLE, 1, &ci, NULL, &s->pipe);
    vkDestroyShaderModule(dev, mod, NULL);
    CHECK(r, "vkCreateComputePipelines");
    return 0;
}

static int acc_create(const tandem_denoiser_create_info *info, void **out, char *err,
                      uint32_t cap)
{
    state *s = calloc(1, sizeof *s);
    if (!s) {
        snprintf(err, cap, "out of memory");
        return 1;
    }
    s->vk = *info->vulkan;
    s->width = info->width;
    s->height = info->height;
    const char *w = getenv("TANDEM_ACCUMULATE_FRAMES");
    s->max_frames = w && atof(w) >= 1.0 ? (float)atof(w) : 32.0f;
    if (setup(s, err, cap)) {
        acc_destroy(s);
        return 1;
    }
    *out = s;
    return 0;
}

static int acc_record(void *ctx, VkCommandBuffer cmd, const tandem_frame_settings *fs,
                      const tandem_denoiser_io *io, char *err, uint32_t cap)
{
    state *s = ctx;
    if (fs->width != s->width || fs->height != s->height) {
        snprintf(err, cap, "frame %ux%u, created for %ux%u", fs->width, fs->height, s->width,
                 s->height);
        return 1;
    }
    /* (Tandem calls record once the previous frame is done: the set can be rewritten) */
    uint32_t cur = s->frame & 1u, prev = cur ^ 1u;
    VkImageView views[B_COUNT] = {io->radiance.view,      io->entries[TANDEM_ENTRY_MOTION].view,
                                  io->entries[TANDEM_ENTRY_DEPTH].view, io->output.view,
                                  s->hist[prev].view,     s->depth[prev].view,
                                  s->hist[cur].view,      s->depth[cur].view};
    VkDescriptorImageInfo ii[B_COUNT];
    VkWriteDescriptorSet w[B_COUNT];
    for (uint32_t i = 0; i < B_COUNT; i++) {
        ii[i] = (VkDescriptorImageInfo){VK_NULL_HANDLE, views[i], VK_IMAGE_LAYOUT_GENERAL};
        w[i] = (VkWriteDescriptorSet){.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
                                      .dstSet = s->set,
                                      .dstBinding = i,
                                      .descriptorCount = 1,
                                      .descriptorType = i <= B_DEPTH
                                                            ? VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE
                                                            : VK_DESCRIPTOR_TYPE_STORAGE_IMAGE,
                                      .pImageInfo = &ii[i]};
    }
    vkUpdateDescriptorSets(s->vk.device, B_COUNT, w, 0, NULL);
    push pc = {{s->width, s->height}, fs->reset || s->frame == 0, s->max_frames};
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, s->pipe);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, s->layout, 0, 1, &s->set, 0,
                            NULL);
    vkCmdPushConstants(cmd, s->layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof pc, &pc);
    vkCmdDispatch(cmd, (s->width + 7) / 8, (s->height + 7) / 8, 1);
    s->frame++;
    return 0;
}

static const tandem_denoiser_plugin denoiser = {
    .struct_size = sizeof denoiser,
    .reads = TANDEM_INPUT_RADIANCE | TANDEM_ENTRY_BIT(TANDEM_ENTRY_MOTION) |
             TANDEM_ENTRY_BIT(TANDEM_ENTRY_DEPTH),
    .precisions = TANDEM_PRECISION_BIT(TANDEM_PRECISION_FLOAT32) |
                  TANDEM_PRECISION_BIT(TANDEM_PRECISION_PACKED),
    .create = acc_create,
    .destroy = acc_destroy,
    .record = acc_record,
};

static const tandem_plugin plugin = {
    .struct_size = sizeof plugin,
    .abi_version = TANDEM_PLUGIN_ABI_VERSION,
    .kind = TANDEM_PLUGIN_DENOISER,
    .name = "accumulate",
    .description = "reprojected temporal accumulation of the noisy radiance",
    .denoiser = &denoiser,
};

__attribute__((visibility("default"))) const tandem_plugin *tandem_plugin_entry(uint32_t abi)
{
    return abi == TANDEM_PLUGIN_ABI_VERSION ? &plugin : NULL;
}
