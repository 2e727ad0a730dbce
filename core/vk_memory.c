/* core/vk_memory.c: memory types, buffers, images, staging copies and one-shot command buffers.
 *
 * One allocation per resource: Tandem creates a few dozen resources per run, far below
 * maxMemoryAllocationCount, and dedicated allocations keep lifetimes obvious.
 * Entry points: tnd_buffer_create/destroy/upload/download, tnd_image_create/destroy,
 * tnd_image_upload, tnd_cmd_begin, tnd_cmd_submit_wait, tnd_cmd_barrier, and the two seams every
 * allocation and every wait for the device pass through: tnd_vk_allocate, tnd_vk_wait. */
#include "core/core.h"

#include <pthread.h>
#include <stdio.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

uint32_t tnd_vk_memory_type(const tnd_vk *vk, uint32_t bits, VkMemoryPropertyFlags props)
{
    for (uint32_t i = 0; i < vk->mem.memoryTypeCount; i++)
        if ((bits & (1u << i)) && (vk->mem.memoryTypes[i].propertyFlags & props) == props)
            return i;
    return UINT32_MAX;
}

static tnd_result allocate(tnd_vk *vk, VkMemoryRequirements req, tnd_mem_kind kind,
                           bool device_address, const char *name, VkDeviceMemory *out)
{
    tnd_result res = TND_OK;
    uint32_t type = UINT32_MAX;
    switch (kind) {
    case TND_MEM_DEVICE:
        type = tnd_vk_memory_type(vk, req.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
        break;
    case TND_MEM_UPLOAD:
        type = tnd_vk_memory_type(vk, req.memoryTypeBits,
                                  VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT |
                                      VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
        break;
    case TND_MEM_READBACK:
        type = tnd_vk_memory_type(vk, req.memoryTypeBits,
                                  VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT |
                                      VK_MEMORY_PROPERTY_HOST_COHERENT_BIT |
                                      VK_MEMORY_PROPERTY_HOST_CACHED_BIT);
        if (type == UINT32_MAX)
            type = tnd_vk_memory_type(vk, req.memoryTypeBits,
                                      VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT |
                                          VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
        break;
    }
    if (type == UINT32_MAX)
        return tnd_fail(TND_ERR_UNSUPPORTED, "vulkan: %s: no suitable memory type", name);
    VkMemoryAllocateFlagsInfo flags = {.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_FLAGS_INFO,
                                       .flags = VK_MEMORY_ALLOCATE_DEVICE_ADDRESS_BIT};
    VkMemoryAllocateInfo ai = {.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO,
                               .pNext = device_address ? &flags : NULL,
                               .allocationSize = req.size,
                               .memoryTypeIndex = type};
    VkResult vr = tnd_vk_allocate(vk, &ai, out);
    if (vr == VK_ERROR_OUT_OF_DEVICE_MEMORY || vr == VK_ERROR_OUT_OF_HOST_MEMORY) {
        uint64_t used = 0;
        bool known = tnd_vk_memory_in_use(vk, &used);
        char in_use[64] = "";
        if (known)
            snprintf(in_use, sizeof in_use, ", %.0f MB in use", used / 1048576.0);
        return tnd_fail(TND_ERR_OUT_OF_MEMORY,
                        "vulkan: out of %s memory for '%s' (%.1f MB%s on %s): a smaller --size "
                        "or scene",
                        vr == VK_ERROR_OUT_OF_DEVICE_MEMORY ? "device" : "host", name,
                        req.size / 1048576.0, in_use, vk->info.name);
    }
    TND_VK_TRY(vr);
    TND_VK_NAME(vk, VK_OBJECT_TYPE_DEVICE_MEMORY, *out, "%s.memory", name);
fail:
    return res;
}

tnd_result tnd_buffer_create(tnd_vk *vk, const tnd_buffer_desc *desc, tnd_buffer *buf)
{
    tnd_result res = TND_OK;
    memset(buf, 0, sizeof *buf);
    const char *name = desc->name ? desc->name : "buffer";
    if (desc->size == 0)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "vulkan: buffer '%s' of size 0", name);
    VkBufferUsageFlags usage =
        desc->usage | VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    if (desc->device_address)
        usage |= VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT;
    VkBufferCreateInfo bci = {.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO,
                              .size = desc->size,
                              .usage = usage,
                              .sharingMode = VK_SHARING_MODE_EXCLUSIVE};
    TND_VK_TRY(vkCreateBuffer(vk->device, &bci, NULL, &buf->buffer));
    TND_VK_NAME(vk, VK_OBJECT_TYPE_BUFFER, buf->buffer, "%s", name);
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(vk->device, buf->buffer, &req);
    TND_TRY(allocate(vk, req, desc->mem, desc->device_address, name, &buf->memory));
    TND_VK_TRY(vkBindBufferMemory(vk->device, buf->buffer, buf->memory, 0));
    buf->size = desc->size;
    if (desc->mem != TND_MEM_DEVICE)
        TND_VK_TRY(vkMapMemory(vk->device, buf->memory, 0, VK_WHOLE_SIZE, 0, &buf->mapped));
    if (desc->device_address) {
        VkBufferDeviceAddressInfo ai = {.sType = VK_STRUCTURE_TYPE_BUFFER_DEVICE_ADDRESS_INFO,
                                        .buffer = buf->buffer};
        buf->address = vkGetBufferDeviceAddress(vk->device, &ai);
    }
    return TND_OK;
fail:
    tnd_buffer_destroy(vk, buf);
    return res;
}

void tnd_buffer_destroy(tnd_vk *vk, tnd_buffer *buf)
{
    if (buf->buffer)
        vkDestroyBuffer(vk->device, buf->buffer, NULL);
    if (buf->memory)
        tnd_vk_free(vk, buf->memory); /* unmaps implicitly */
    memset(buf, 0, sizeof *buf);
}

static tnd_result check_range(const tnd_buffer *b, VkDeviceSize off, VkDeviceSize size)
{
    if (off > b->size || size > b->size - off)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                        "vulkan: copy of %llu bytes at %llu exceeds buffer of %llu bytes",
                        (unsigned long long)size, (unsigned long long)off,
                        (unsigned long long)b->size);
    return TND_OK;
}

tnd_result tnd_buffer_upload(tnd_vk *vk, tnd_buffer *dst, VkDeviceSize offset, const void *data,
                             VkDeviceSize size)
{
    tnd_result res = check_range(dst, offset, size);
    if (res != TND_OK || size == 0)
        return res;
    if (dst->mapped) {
        memcpy((char *)dst->mapped + offset, data, size);
        return TND_OK;
    }
    tnd_buffer staging = {0};
    VkCommandBuffer cmd = VK_NULL_HANDLE;
    TND_TRY(tnd_buffer_create(
        vk, &(tnd_buffer_desc){.size = size, .mem = TND_MEM_UPLOAD, .name = "staging.upload"},
        &staging));
    memcpy(staging.mapped, data, size);
    TND_TRY(tnd_cmd_begin(vk, &cmd));
    vkCmdCopyBuffer(cmd, staging.buffer, dst->buffer, 1,
                    &(VkBufferCopy){.srcOffset = 0, .dstOffset = offset, .size = size});
    tnd_cmd_barrier(cmd);
    res = tnd_cmd_submit_wait(vk, cmd);
fail:
    tnd_buffer_destroy(vk, &staging);
    return res;
}

tnd_result tnd_buffer_download(tnd_vk *vk, const tnd_buffer *src, VkDeviceSize offset, void *data,
                               VkDeviceSize size)
{
    tnd_result res = check_range(src, offset, size);
    if (res != TND_OK || size == 0)
        return res;
    if (src->mapped) {
        memcpy(data, (const char *)src->mapped + offset, size);
        return TND_OK;
    }
    tnd_buffer staging = {0};
    VkCommandBuffer cmd = VK_NULL_HANDLE;
    TND_TRY(tnd_buffer_create(
        vk, &(tnd_buffer_desc){.size = size, .mem = TND_MEM_READBACK, .name = "staging.download"},
        &staging));
    TND_TRY(tnd_cmd_begin(vk, &cmd));
    tnd_cmd_barrier(cmd);
    vkCmdCopyBuffer(cmd, src->buffer, staging.buffer, 1,
                    &(VkBufferCopy){.srcOffset = offset, .dstOffset = 0, .size = size});
    tnd_cmd_barrier(cmd);
    TND_TRY(tnd_cmd_submit_wait(vk, cmd));
    memcpy(data, staging.mapped, size);
fail:
    tnd_buffer_destroy(vk, &staging);
    return res;
}

tnd_result tnd_image_create(tnd_vk *vk, const tnd_image_desc *desc, tnd_image *img)
{
    tnd_result res = TND_OK;
    memset(img, 0, sizeof *img);
    const char *name = desc->name ? desc->name : "image";
    if (desc->width == 0 || desc->height == 0 || desc->width > vk->info.max_image_dimension_2d ||
        desc->height > vk->info.max_image_dimension_2d)
        return tnd_fail(TND_ERR_LIMIT,
                        "vulkan: image '%s' of %ux%u: beyond the device limit, %s's largest 2D "
                        "image, %u a side (a smaller --size)",
                        name, desc->width, desc->height, vk->info.name,
                        vk->info.max_image_dimension_2d);
    VkImageUsageFlags usage =
        desc->usage ? desc->usage
                    : VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_SAMPLED_BIT |
                          VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    VkImageCreateInfo ici = {.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO,
                             .imageType = VK_IMAGE_TYPE_2D,
                             .format = desc->format,
                             .extent = {desc->width, desc->height, 1},
                             .mipLevels = 1,
                             .arrayLayers = 1,
                             .samples = VK_SAMPLE_COUNT_1_BIT,
                             .tiling = VK_IMAGE_TILING_OPTIMAL,
                             .usage = usage,
                             .sharingMode = VK_SHARING_MODE_EXCLUSIVE,
                             .initialLayout = VK_IMAGE_LAYOUT_UNDEFINED};
    TND_VK_TRY(vkCreateImage(vk->device, &ici, NULL, &img->image));
    TND_VK_NAME(vk, VK_OBJECT_TYPE_IMAGE, img->image, "%s", name);
    VkMemoryRequirements req;
    vkGetImageMemoryRequirements(vk->device, img->image, &req);
    TND_TRY(allocate(vk, req, TND_MEM_DEVICE, false, name, &img->memory));
    TND_VK_TRY(vkBindImageMemory(vk->device, img->image, img->memory, 0));
    VkImageViewCreateInfo vci = {
        .sType = VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO,
        .image = img->image,
        .viewType = VK_IMAGE_VIEW_TYPE_2D,
        .format = desc->format,
        .subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1},
    };
    TND_VK_TRY(vkCreateImageView(vk->device, &vci, NULL, &img->view));
    TND_VK_NAME(vk, VK_OBJECT_TYPE_IMAGE_VIEW, img->view, "%s.view", name);
    img->format = desc->format;
    img->width = desc->width;
    img->height = desc->height;

    VkCommandBuffer cmd;
    TND_TRY(tnd_cmd_begin(vk, &cmd));
    VkImageMemoryBarrier b = {.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER,
                              .srcAccessMask = 0,
                              .dstAccessMask =
                                  VK_ACCESS_MEMORY_READ_BIT | VK_ACCESS_MEMORY_WRITE_BIT,
                              .oldLayout = VK_IMAGE_LAYOUT_UNDEFINED,
                              .newLayout = VK_IMAGE_LAYOUT_GENERAL,
                              .srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
                              .dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
                              .image = img->image,
                              .subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1}};
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT,
                         0, 0, NULL, 0, NULL, 1, &b);
    TND_TRY(tnd_cmd_submit_wait(vk, cmd));
    return TND_OK;
fail:
    tnd_image_destroy(vk, img);
    return res;
}

void tnd_image_destroy(tnd_vk *vk, tnd_image *img)
{
    if (img->view)
        vkDestroyImageView(vk->device, img->view, NULL);
    if (img->image)
        vkDestroyImage(vk->device, img->image, NULL);
    if (img->memory)
        tnd_vk_free(vk, img->memory);
    memset(img, 0, sizeof *img);
}

tnd_result tnd_image_download(tnd_vk *vk, const tnd_image *img, void *data, size_t bytes)
{
    tnd_result res = TND_OK;
    tnd_buffer rb = {0};
    VkCommandBuffer cmd;
    TND_TRY(tnd_buffer_create(vk, &(tnd_buffer_desc){.size = bytes, .mem = TND_MEM_READBACK,
                                                     .name = "image.readback"},
                              &rb));
    TND_TRY(tnd_cmd_begin(vk, &cmd));
    tnd_cmd_barrier(cmd);
    VkBufferImageCopy r = {.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1},
                           .imageExtent = {img->width, img->height, 1}};
    vkCmdCopyImageToBuffer(cmd, img->image, VK_IMAGE_LAYOUT_GENERAL, rb.buffer, 1, &r);
    tnd_cmd_barrier(cmd);
    TND_TRY(tnd_cmd_submit_wait(vk, cmd));
    memcpy(data, rb.mapped, bytes);
fail:
    tnd_buffer_destroy(vk, &rb);
    return res;
}

tnd_result tnd_image_upload(tnd_vk *vk, const tnd_image *img, const void *data, size_t bytes)
{
    tnd_result res = TND_OK;
    tnd_buffer up = {0};
    VkCommandBuffer cmd;
    TND_TRY(tnd_buffer_create(vk, &(tnd_buffer_desc){.size = bytes, .mem = TND_MEM_UPLOAD,
                                                     .name = "image.upload"},
                              &up));
    memcpy(up.mapped, data, bytes);
    TND_TRY(tnd_cmd_begin(vk, &cmd));
    tnd_cmd_barrier(cmd);
    VkBufferImageCopy r = {.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1},
                           .imageExtent = {img->width, img->height, 1}};
    vkCmdCopyBufferToImage(cmd, up.buffer, img->image, VK_IMAGE_LAYOUT_GENERAL, 1, &r);
    tnd_cmd_barrier(cmd);
    TND_TRY(tnd_cmd_submit_wait(vk, cmd));
fail:
    tnd_buffer_destroy(vk, &up);
    return res;
}

tnd_result tnd_cmd_begin(tnd_vk *vk, VkCommandBuffer *cmd)
{
    tnd_result res = TND_OK;
    *cmd = VK_NULL_HANDLE;
    VkCommandBufferAllocateInfo ai = {.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO,
                                      .commandPool = vk->cmd_pool,
                                      .level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
                                      .commandBufferCount = 1};
    TND_VK_TRY(vkAllocateCommandBuffers(vk->device, &ai, cmd));
    VkCommandBufferBeginInfo bi = {.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO,
                                   .flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT};
    TND_VK_TRY(vkBeginCommandBuffer(*cmd, &bi));
    return TND_OK;
fail:
    if (*cmd)
        vkFreeCommandBuffers(vk->device, vk->cmd_pool, 1, cmd);
    *cmd = VK_NULL_HANDLE;
    return res;
}

tnd_result tnd_cmd_submit_wait(tnd_vk *vk, VkCommandBuffer cmd)
{
    tnd_result res = TND_OK;
    TND_VK_TRY(vkEndCommandBuffer(cmd));
    VkSubmitInfo si = {
        .sType = VK_STRUCTURE_TYPE_SUBMIT_INFO, .commandBufferCount = 1, .pCommandBuffers = &cmd};
    TND_VK_TRY(vkResetFences(vk->device, 1, &vk->fence));
    TND_VK_TRY(vkQueueSubmit(vk->queue, 1, &si, vk->fence));
    TND_VK_TRY(tnd_vk_wait(vk, vk->fence));
fail:
    vkFreeCommandBuffers(vk->device, vk->cmd_pool, 1, &cmd);
    return res;
}

tnd_result tnd_pending_create(tnd_vk *vk, tnd_pending *p)
{
    tnd_result res = TND_OK;
    *p = (tnd_pending){0};
    VkFenceCreateInfo fci = {.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    TND_VK_TRY(vkCreateFence(vk->device, &fci, NULL, &p->fence));
fail:
    return res;
}

void tnd_pending_destroy(tnd_vk *vk, tnd_pending *p)
{
    if (!p->fence)
        return;
    (void)tnd_pending_wait(vk, p);
    vkDestroyFence(vk->device, p->fence, NULL);
    *p = (tnd_pending){0};
}

tnd_result tnd_cmd_submit_pending(tnd_vk *vk, VkCommandBuffer cmd, tnd_pending *p)
{
    tnd_result res = TND_OK;
    if (p->cmd) {
        res = tnd_fail(TND_ERR_INVALID_ARGUMENT, "vulkan: a submission is still in flight");
        goto fail;
    }
    TND_VK_TRY(vkEndCommandBuffer(cmd));
    VkSubmitInfo si = {
        .sType = VK_STRUCTURE_TYPE_SUBMIT_INFO, .commandBufferCount = 1, .pCommandBuffers = &cmd};
    TND_VK_TRY(vkResetFences(vk->device, 1, &p->fence));
    TND_VK_TRY(vkQueueSubmit(vk->queue, 1, &si, p->fence));
    p->cmd = cmd;
    return TND_OK;
fail:
    vkFreeCommandBuffers(vk->device, vk->cmd_pool, 1, &cmd);
    return res;
}

tnd_result tnd_pending_wait(tnd_vk *vk, tnd_pending *p)
{
    tnd_result res = TND_OK;
    if (!p->cmd)
        return TND_OK;
    TND_VK_TRY(tnd_vk_wait(vk, p->fence));
fail: /* (a lost device: the command buffer goes all the same) */
    vkFreeCommandBuffers(vk->device, vk->cmd_pool, 1, &p->cmd);
    p->cmd = VK_NULL_HANDLE;
    return res;
}

/* A global memory barrier: `write` accesses in `stage` before `read` and `write` ones there. */
static void memory_barrier(VkCommandBuffer cmd, VkPipelineStageFlags stage, VkAccessFlags write,
                           VkAccessFlags read)
{
    VkMemoryBarrier mb = {.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER,
                          .srcAccessMask = write,
                          .dstAccessMask = read | write};
    vkCmdPipelineBarrier(cmd, stage, stage, 0, 1, &mb, 0, NULL, 0, NULL);
}

void tnd_cmd_compute_barrier(VkCommandBuffer cmd)
{
    memory_barrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT,
                   VK_ACCESS_SHADER_READ_BIT);
}

void tnd_cmd_barrier(VkCommandBuffer cmd)
{
    memory_barrier(cmd, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, VK_ACCESS_MEMORY_WRITE_BIT,
                   VK_ACCESS_MEMORY_READ_BIT);
}

bool tnd_vk_memory_in_use(const tnd_vk *vk, uint64_t *bytes)
{
    *bytes = 0;
    if (!vk->memory_budget)
        return false;
    VkPhysicalDeviceMemoryBudgetPropertiesEXT budget = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MEMORY_BUDGET_PROPERTIES_EXT};
    VkPhysicalDeviceMemoryProperties2 props = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MEMORY_PROPERTIES_2, .pNext = &budget};
    vkGetPhysicalDeviceMemoryProperties2(vk->phys, &props);
    for (uint32_t h = 0; h < props.memoryProperties.memoryHeapCount; h++)
        *bytes += budget.heapUsage[h];
    return true;
}

/* Tandem's device allocations alive in the process (soak runs: a leak of device memory shows as
 * a count that grows). */
static _Atomic uint64_t live_allocations;

/* ---- faults as a driver would report them ($TANDEM_FAULT, docs/reliability.md) ---------------
 * What a run does when the device runs out of memory or is lost cannot be provoked on demand on
 * real devices (lavapipe allocates from host memory; a lost device needs a driver reset), so the
 * two places every allocation and every wait for the device's work pass through can be told to
 * fail as the driver would:
 *   device-memory=MB  an allocation that takes the process's device allocations (all made since
 *                     it started, freed ones included) past MB fails, VK_ERROR_OUT_OF_DEVICE_MEMORY;
 *   device-lost=N     the Nth wait for the device's work (counted in the process) and every one
 *                     after it return VK_ERROR_DEVICE_LOST (the work itself finishes first, so
 *                     what is destroyed afterwards is idle, as after a real loss).
 * Comma-separated; a malformed value is reported once and ignored. */
static struct {
    uint64_t memory_limit; /* bytes; 0: none */
    uint64_t lost_at;      /* waits; 0: none */
    _Atomic uint64_t allocated, waits;
} fault;
static pthread_once_t fault_once = PTHREAD_ONCE_INIT;

static void fault_init(void)
{
    const char *v = getenv("TANDEM_FAULT");
    if (!v || !*v)
        return;
    char buf[256];
    snprintf(buf, sizeof buf, "%s", v);
    for (char *save = NULL, *t = strtok_r(buf, ",", &save); t; t = strtok_r(NULL, ",", &save)) {
        char *eq = strchr(t, '='), *end = NULL;
        unsigned long long n = eq ? strtoull(eq + 1, &end, 10) : 0;
        bool num = eq && end != eq + 1 && !*end && n > 0 && eq[1] != '-';
        if (num && !strncmp(t, "device-memory=", 14) && n < (1ull << 44)) {
            fault.memory_limit = n << 20;
            tnd_warn("vulkan", "TANDEM_FAULT: device allocations fail past %llu MB (simulated)", n);
        } else if (num && !strncmp(t, "device-lost=", 12)) {
            fault.lost_at = n;
            tnd_warn("vulkan", "TANDEM_FAULT: the device is lost at wait %llu (simulated)", n);
        } else {
            tnd_warn("vulkan",
                     "TANDEM_FAULT: '%s' ignored (device-memory=MB or device-lost=N expected)", t);
        }
    }
}

VkResult tnd_vk_allocate(const tnd_vk *vk, const VkMemoryAllocateInfo *ai, VkDeviceMemory *out)
{
    pthread_once(&fault_once, fault_init);
    if (fault.memory_limit || fault.lost_at) {
        uint64_t total = atomic_fetch_add(&fault.allocated, ai->allocationSize) + ai->allocationSize;
        if (fault.memory_limit && total > fault.memory_limit) {
            atomic_fetch_sub(&fault.allocated, ai->allocationSize); /* (not made) */
            *out = VK_NULL_HANDLE;
            return VK_ERROR_OUT_OF_DEVICE_MEMORY;
        }
    }
    VkResult r = vkAllocateMemory(vk->device, ai, NULL, out);
    if (r == VK_SUCCESS)
        live_allocations++;
    return r;
}

void tnd_vk_fault_report(void)
{
    if (fault.lost_at || fault.memory_limit) /* (so that a test can place a loss within a run) */
        tnd_warn("vulkan", "TANDEM_FAULT: %llu waits for the device, %.1f MB allocated so far",
                 (unsigned long long)fault.waits, fault.allocated / 1048576.0);
}

VkResult tnd_vk_wait(const tnd_vk *vk, VkFence fence)
{
    pthread_once(&fault_once, fault_init);
    VkResult r = vkWaitForFences(vk->device, 1, &fence, VK_TRUE, UINT64_MAX);
    if (r == VK_SUCCESS && (fault.lost_at || fault.memory_limit)) {
        uint64_t n = ++fault.waits;
        if (fault.lost_at && n >= fault.lost_at)
            r = VK_ERROR_DEVICE_LOST;
    }
    return r;
}

void tnd_vk_free(const tnd_vk *vk, VkDeviceMemory m)
{
    if (m) {
        vkFreeMemory(vk->device, m, NULL);
        live_allocations--;
    }
}

uint64_t tnd_vk_live_allocations(void)
{
    return live_allocations;
}
