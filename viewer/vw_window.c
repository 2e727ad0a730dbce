/* viewer/vw_window.c: the window (GLFW) and its Vulkan swapchain. Each frame shows one RGBA8
 * image: acquire, blit into the swapchain image (the blit converts to its format and scales to
 * its size), present. The swapchain is recreated when the window changed size or the surface
 * says it is out of date.
 * Entry points: vw_window_create, vw_window_destroy, vw_window_instance_extensions,
 * vw_window_attach, vw_window_size, vw_window_set_size, vw_window_poll, vw_window_present,
 * vw_key_code, vw_key_name. */
#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>

#include "viewer/viewer.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { MAX_IMAGES = 8 };

struct vw_window {
    GLFWwindow *win;
    vw_event_fn on_event;
    void *user;
    tnd_vk *vk;
    VkSurfaceKHR surface;
    VkSwapchainKHR swapchain;
    VkFormat format;
    VkExtent2D extent;
    uint32_t count;
    VkImage images[MAX_IMAGES];
    VkSemaphore acquired, done;
    VkFence fence;
    VkCommandBuffer cmd;
    bool stale; /* recreate the swapchain before the next frame */
    double mx, my;
    bool have_mouse;
};

static char glfw_error[512];

static void on_glfw_error(int code, const char *text)
{
    snprintf(glfw_error, sizeof glfw_error, "GLFW error %#x: %s", code, text);
}

static void on_key(GLFWwindow *gw, int key, int scancode, int action, int mods)
{
    (void)scancode;
    (void)mods;
    vw_window *w = glfwGetWindowUserPointer(gw);
    if (action == GLFW_REPEAT)
        return;
    w->on_event(&(vw_event){.kind = VW_KEY, .key = key, .down = action == GLFW_PRESS}, w->user);
}

static void on_cursor(GLFWwindow *gw, double x, double y)
{
    vw_window *w = glfwGetWindowUserPointer(gw);
    if (w->have_mouse)
        w->on_event(&(vw_event){.kind = VW_MOUSE,
                                .dx = x - w->mx,
                                .dy = y - w->my,
                                .drag = glfwGetMouseButton(gw, GLFW_MOUSE_BUTTON_LEFT) ==
                                        GLFW_PRESS},
                    w->user);
    w->mx = x;
    w->my = y;
    w->have_mouse = true;
}

static void on_resize(GLFWwindow *gw, int width, int height)
{
    vw_window *w = glfwGetWindowUserPointer(gw);
    w->stale = true;
    if (width > 0 && height > 0)
        w->on_event(&(vw_event){.kind = VW_RESIZE, .width = (uint32_t)width,
                                .height = (uint32_t)height},
                    w->user);
}

tnd_result vw_window_create(const char *title, uint32_t width, uint32_t height, vw_event_fn on_event,
                            void *user, vw_window **out)
{
    *out = NULL;
    glfwSetErrorCallback(on_glfw_error);
    glfw_error[0] = 0;
    if (!glfwInit())
        return tnd_fail(TND_ERR_UNSUPPORTED, "window: cannot open a window (no display?): %s",
                        glfw_error[0] ? glfw_error : "glfwInit failed");
    if (!glfwVulkanSupported()) {
        glfwTerminate();
        return tnd_fail(TND_ERR_UNSUPPORTED, "window: GLFW finds no Vulkan loader for windows");
    }
    vw_window *w = calloc(1, sizeof *w);
    if (!w) {
        glfwTerminate();
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "window: out of memory");
    }
    w->on_event = on_event;
    w->user = user;
    glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
    w->win = glfwCreateWindow((int)width, (int)height, title, NULL, NULL);
    if (!w->win) {
        tnd_result res = tnd_fail(TND_ERR_UNSUPPORTED, "window: cannot create a window: %s",
                                  glfw_error[0] ? glfw_error : "glfwCreateWindow failed");
        free(w);
        glfwTerminate();
        return res;
    }
    glfwSetWindowUserPointer(w->win, w);
    glfwSetKeyCallback(w->win, on_key);
    glfwSetCursorPosCallback(w->win, on_cursor);
    glfwSetFramebufferSizeCallback(w->win, on_resize);
    *out = w;
    return TND_OK;
}

const char *const *vw_window_instance_extensions(uint32_t *count)
{
    return glfwGetRequiredInstanceExtensions(count);
}

static void destroy_swapchain(vw_window *w)
{
    if (w->swapchain)
        vkDestroySwapchainKHR(w->vk->device, w->swapchain, NULL);
    w->swapchain = VK_NULL_HANDLE;
    w->count = 0;
}

static tnd_result create_swapchain(vw_window *w)
{
    tnd_result res = TND_OK;
    tnd_vk *vk = w->vk;
    vkDeviceWaitIdle(vk->device);
    VkSurfaceCapabilitiesKHR caps;
    TND_VK_TRY(vkGetPhysicalDeviceSurfaceCapabilitiesKHR(vk->phys, w->surface, &caps));
    int fw = 0, fh = 0;
    glfwGetFramebufferSize(w->win, &fw, &fh);
    VkExtent2D e = caps.currentExtent.width != UINT32_MAX
                       ? caps.currentExtent
                       : (VkExtent2D){(uint32_t)fw, (uint32_t)fh};
    if (e.width == 0 || e.height == 0) { /* minimised: nothing to show */
        destroy_swapchain(w);
        w->extent = e;
        return TND_OK;
    }
    if (!(caps.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_DST_BIT))
        return tnd_fail(TND_ERR_UNSUPPORTED, "window: the surface's images cannot be blitted to");
    uint32_t nf = 0;
    TND_VK_TRY(vkGetPhysicalDeviceSurfaceFormatsKHR(vk->phys, w->surface, &nf, NULL));
    VkSurfaceFormatKHR formats[64];
    nf = nf > 64 ? 64 : nf;
    TND_VK_TRY(vkGetPhysicalDeviceSurfaceFormatsKHR(vk->phys, w->surface, &nf, formats));
    /* a UNORM format: the image shown is already display-encoded (sRGB) */
    VkFormat fmt = VK_FORMAT_UNDEFINED;
    for (uint32_t i = 0; i < nf && fmt == VK_FORMAT_UNDEFINED; i++)
        if (formats[i].format == VK_FORMAT_B8G8R8A8_UNORM ||
            formats[i].format == VK_FORMAT_R8G8B8A8_UNORM)
            fmt = formats[i].format;
    if (fmt == VK_FORMAT_UNDEFINED)
        return tnd_fail(TND_ERR_UNSUPPORTED, "window: the surface offers no 8-bit UNORM format");
    uint32_t n = caps.minImageCount + 1;
    if (caps.maxImageCount && n > caps.maxImageCount)
        n = caps.maxImageCount;
    VkSwapchainKHR old = w->swapchain;
    VkSwapchainCreateInfoKHR ci = {
        .sType = VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR,
        .surface = w->surface,
        .minImageCount = n,
        .imageFormat = fmt,
        .imageColorSpace = VK_COLOR_SPACE_SRGB_NONLINEAR_KHR,
        .imageExtent = e,
        .imageArrayLayers = 1,
        .imageUsage = VK_IMAGE_USAGE_TRANSFER_DST_BIT,
        .imageSharingMode = VK_SHARING_MODE_EXCLUSIVE,
        .preTransform = caps.currentTransform,
        .compositeAlpha = VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR,
        .presentMode = VK_PRESENT_MODE_FIFO_KHR, /* (always supported) */
        .clipped = VK_TRUE,
        .oldSwapchain = old};
    TND_VK_TRY(vkCreateSwapchainKHR(vk->device, &ci, NULL, &w->swapchain));
    if (old)
        vkDestroySwapchainKHR(vk->device, old, NULL);
    w->count = MAX_IMAGES;
    TND_VK_TRY(vkGetSwapchainImagesKHR(vk->device, w->swapchain, &w->count, w->images));
    w->format = fmt;
    w->extent = e;
    w->stale = false;
fail:
    return res;
}

tnd_result vw_window_attach(vw_window *w, tnd_vk *vk)
{
    tnd_result res = TND_OK;
    w->vk = vk;
    TND_VK_TRY(glfwCreateWindowSurface(vk->instance, w->win, NULL, &w->surface));
    VkBool32 ok = VK_FALSE;
    TND_VK_TRY(vkGetPhysicalDeviceSurfaceSupportKHR(vk->phys, vk->queue_family, w->surface, &ok));
    if (!ok)
        return tnd_fail(TND_ERR_UNSUPPORTED, "window: %s's queue cannot present to this window",
                        vk->info.name);
    VkSemaphoreCreateInfo si = {.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
    TND_VK_TRY(vkCreateSemaphore(vk->device, &si, NULL, &w->acquired));
    TND_VK_TRY(vkCreateSemaphore(vk->device, &si, NULL, &w->done));
    VkFenceCreateInfo fci = {.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    TND_VK_TRY(vkCreateFence(vk->device, &fci, NULL, &w->fence));
    VkCommandBufferAllocateInfo ai = {.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO,
                                      .commandPool = vk->cmd_pool,
                                      .level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
                                      .commandBufferCount = 1};
    TND_VK_TRY(vkAllocateCommandBuffers(vk->device, &ai, &w->cmd));
    TND_TRY(create_swapchain(w));
fail:
    return res;
}

void vw_window_destroy(vw_window *w)
{
    if (!w)
        return;
    if (w->vk) {
        VkDevice d = w->vk->device;
        vkDeviceWaitIdle(d);
        destroy_swapchain(w);
        if (w->cmd)
            vkFreeCommandBuffers(d, w->vk->cmd_pool, 1, &w->cmd);
        if (w->fence)
            vkDestroyFence(d, w->fence, NULL);
        if (w->acquired)
            vkDestroySemaphore(d, w->acquired, NULL);
        if (w->done)
            vkDestroySemaphore(d, w->done, NULL);
        if (w->surface)
            vkDestroySurfaceKHR(w->vk->instance, w->surface, NULL);
    }
    glfwDestroyWindow(w->win);
    glfwTerminate();
    free(w);
}

void vw_window_size(const vw_window *w, uint32_t *width, uint32_t *height)
{
    int fw = 0, fh = 0;
    glfwGetFramebufferSize(w->win, &fw, &fh);
    *width = (uint32_t)(fw > 0 ? fw : 0);
    *height = (uint32_t)(fh > 0 ? fh : 0);
}

void vw_window_set_size(vw_window *w, uint32_t width, uint32_t height)
{
    glfwSetWindowSize(w->win, (int)width, (int)height);
}

bool vw_window_poll(vw_window *w)
{
    glfwPollEvents();
    return !glfwWindowShouldClose(w->win);
}

static void image_barrier(VkCommandBuffer cmd, VkImage img, VkImageLayout from, VkImageLayout to,
                          VkAccessFlags src, VkAccessFlags dst, VkPipelineStageFlags s0,
                          VkPipelineStageFlags s1)
{
    VkImageMemoryBarrier b = {.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER,
                              .srcAccessMask = src,
                              .dstAccessMask = dst,
                              .oldLayout = from,
                              .newLayout = to,
                              .srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
                              .dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
                              .image = img,
                              .subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1}};
    vkCmdPipelineBarrier(cmd, s0, s1, 0, 0, NULL, 0, NULL, 1, &b);
}

tnd_result vw_window_present(vw_window *w, const tnd_image *img)
{
    tnd_result res = TND_OK;
    tnd_vk *vk = w->vk;
    uint32_t fw, fh;
    vw_window_size(w, &fw, &fh);
    if (w->stale || fw != w->extent.width || fh != w->extent.height || !w->swapchain)
        TND_TRY(create_swapchain(w));
    if (!w->swapchain)
        return TND_OK;
    uint32_t idx = 0;
    VkResult r = vkAcquireNextImageKHR(vk->device, w->swapchain, UINT64_MAX, w->acquired,
                                       VK_NULL_HANDLE, &idx);
    if (r == VK_ERROR_OUT_OF_DATE_KHR) {
        w->stale = true;
        return TND_OK;
    }
    if (r != VK_SUCCESS && r != VK_SUBOPTIMAL_KHR)
        return tnd_fail(TND_ERR_VULKAN, "window: vkAcquireNextImageKHR: %s", tnd_vk_result_name(r));
    VkCommandBuffer cmd = w->cmd;
    TND_VK_TRY(vkResetCommandBuffer(cmd, 0));
    VkCommandBufferBeginInfo bi = {.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO,
                                   .flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT};
    TND_VK_TRY(vkBeginCommandBuffer(cmd, &bi));
    tnd_cmd_barrier(cmd); /* (the image shown was written by earlier submissions) */
    image_barrier(cmd, w->images[idx], VK_IMAGE_LAYOUT_UNDEFINED,
                  VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 0, VK_ACCESS_TRANSFER_WRITE_BIT,
                  VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT);
    VkImageBlit blit = {.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1},
                        .srcOffsets = {{0, 0, 0}, {(int32_t)img->width, (int32_t)img->height, 1}},
                        .dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1},
                        .dstOffsets = {{0, 0, 0},
                                       {(int32_t)w->extent.width, (int32_t)w->extent.height, 1}}};
    vkCmdBlitImage(cmd, img->image, VK_IMAGE_LAYOUT_GENERAL, w->images[idx],
                   VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &blit, VK_FILTER_NEAREST);
    image_barrier(cmd, w->images[idx], VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                  VK_IMAGE_LAYOUT_PRESENT_SRC_KHR, VK_ACCESS_TRANSFER_WRITE_BIT, 0,
                  VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT);
    TND_VK_TRY(vkEndCommandBuffer(cmd));
    VkPipelineStageFlags wait_stage = VK_PIPELINE_STAGE_TRANSFER_BIT;
    VkSubmitInfo si = {.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO,
                       .waitSemaphoreCount = 1,
                       .pWaitSemaphores = &w->acquired,
                       .pWaitDstStageMask = &wait_stage,
                       .commandBufferCount = 1,
                       .pCommandBuffers = &cmd,
                       .signalSemaphoreCount = 1,
                       .pSignalSemaphores = &w->done};
    TND_VK_TRY(vkResetFences(vk->device, 1, &w->fence));
    TND_VK_TRY(vkQueueSubmit(vk->queue, 1, &si, w->fence));
    VkPresentInfoKHR pi = {.sType = VK_STRUCTURE_TYPE_PRESENT_INFO_KHR,
                           .waitSemaphoreCount = 1,
                           .pWaitSemaphores = &w->done,
                           .swapchainCount = 1,
                           .pSwapchains = &w->swapchain,
                           .pImageIndices = &idx};
    r = vkQueuePresentKHR(vk->queue, &pi);
    if (r == VK_ERROR_OUT_OF_DATE_KHR || r == VK_SUBOPTIMAL_KHR)
        w->stale = true;
    else if (r != VK_SUCCESS)
        res = tnd_fail(TND_ERR_VULKAN, "window: vkQueuePresentKHR: %s", tnd_vk_result_name(r));
    /* one frame at a time: the command buffer and semaphores are reused next frame */
    TND_VK_TRY(tnd_vk_wait(vk, w->fence));
fail:
    return res;
}

/* ---- key names ----------------------------------------------------------------------------- */
static const struct {
    const char *name;
    int code;
} named_keys[] = {
    {"SPACE", GLFW_KEY_SPACE},         {"TAB", GLFW_KEY_TAB},
    {"ESCAPE", GLFW_KEY_ESCAPE},       {"ENTER", GLFW_KEY_ENTER},
    {"LEFT_SHIFT", GLFW_KEY_LEFT_SHIFT}, {"LEFT_CONTROL", GLFW_KEY_LEFT_CONTROL},
    {"LEFT_BRACKET", GLFW_KEY_LEFT_BRACKET}, {"RIGHT_BRACKET", GLFW_KEY_RIGHT_BRACKET},
    {"MINUS", GLFW_KEY_MINUS},         {"EQUAL", GLFW_KEY_EQUAL},
    {"COMMA", GLFW_KEY_COMMA},         {"PERIOD", GLFW_KEY_PERIOD},
    {"SLASH", GLFW_KEY_SLASH},         {"BACKSPACE", GLFW_KEY_BACKSPACE},
};

int vw_key_code(const char *name)
{
    if (!name || !*name)
        return -1;
    if (!name[1] && ((name[0] >= 'A' && name[0] <= 'Z') || (name[0] >= '0' && name[0] <= '9')))
        return name[0]; /* GLFW's codes for letters and digits are their ASCII */
    if (name[0] == 'F' && name[1] >= '1' && name[1] <= '9') {
        int n = atoi(name + 1);
        if (n >= 1 && n <= 12)
            return GLFW_KEY_F1 + n - 1;
    }
    for (size_t i = 0; i < sizeof named_keys / sizeof named_keys[0]; i++)
        if (strcmp(named_keys[i].name, name) == 0)
            return named_keys[i].code;
    return -1;
}

const char *vw_key_name(int code)
{
    static char one[4];
    if ((code >= 'A' && code <= 'Z') || (code >= '0' && code <= '9')) {
        one[0] = (char)code;
        one[1] = 0;
        return one;
    }
    if (code >= GLFW_KEY_F1 && code <= GLFW_KEY_F12) {
        snprintf(one, sizeof one, "F%d", code - GLFW_KEY_F1 + 1);
        return one;
    }
    for (size_t i = 0; i < sizeof named_keys / sizeof named_keys[0]; i++)
        if (named_keys[i].code == code)
            return named_keys[i].name;
    return "?";
}
