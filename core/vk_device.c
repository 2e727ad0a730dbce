/* core/vk_device.c: headless Vulkan instance, device listing and choice, context creation.
 *
 * Tandem needs Vulkan 1.2 (buffer device address, SPIR-V 1.5), and for the ray-traced front-end
 * VK_KHR_ray_tracing_pipeline + VK_KHR_acceleration_structure. Ray query is optional: the NVIDIA
 * datacenter driver has none. No window system extensions are ever enabled.
 * Entry points: tnd_vk_list_devices, tnd_vk_choose_device, tnd_vk_create, tnd_vk_destroy. */
#include "core/core.h"

#include <ctype.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct tnd_vk_messages {
    atomic_uint errors;
    atomic_uint warnings;
};

static VKAPI_ATTR VkBool32 VKAPI_CALL on_debug_message(
    VkDebugUtilsMessageSeverityFlagBitsEXT severity, VkDebugUtilsMessageTypeFlagsEXT types,
    const VkDebugUtilsMessengerCallbackDataEXT *data, void *user)
{
    (void)types;
    tnd_vk_messages *m = user;
    if (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT) {
        atomic_fetch_add(&m->errors, 1);
        fprintf(stderr, "tandem: vulkan: validation error: %s\n", data->pMessage);
    } else if (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT) {
        atomic_fetch_add(&m->warnings, 1);
        fprintf(stderr, "tandem: vulkan: validation warning: %s\n", data->pMessage);
    }
    return VK_FALSE;
}

static bool has_extension(const VkExtensionProperties *exts, uint32_t n, const char *name)
{
    for (uint32_t i = 0; i < n; i++)
        if (strcmp(exts[i].extensionName, name) == 0)
            return true;
    return false;
}

static bool env_true(const char *name)
{
    const char *v = getenv(name);
    return v && *v && strcmp(v, "0") != 0;
}

/* Instance with VK_EXT_debug_utils when available and the validation layer when asked for. */
static tnd_result create_instance(bool validation, const tnd_vk_desc *desc, VkInstance *inst,
                                  bool *debug_utils)
{
    tnd_result res = TND_OK;
    VkExtensionProperties *exts = NULL;
    uint32_t n = 0;
    *debug_utils = false;
    TND_VK_TRY(vkEnumerateInstanceExtensionProperties(NULL, &n, NULL));
    exts = calloc(n ? n : 1, sizeof *exts);
    if (!exts)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "vulkan: out of memory");
    TND_VK_TRY(vkEnumerateInstanceExtensionProperties(NULL, &n, exts));
    *debug_utils = has_extension(exts, n, VK_EXT_DEBUG_UTILS_EXTENSION_NAME);

    const char *layer = "VK_LAYER_KHRONOS_validation";
    if (validation) {
        uint32_t nl = 0;
        TND_VK_TRY(vkEnumerateInstanceLayerProperties(&nl, NULL));
        VkLayerProperties *layers = calloc(nl ? nl : 1, sizeof *layers);
        if (!layers) {
            res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "vulkan: out of memory");
            goto fail;
        }
        VkResult vr = vkEnumerateInstanceLayerProperties(&nl, layers);
        bool found = false;
        for (uint32_t i = 0; vr >= 0 && i < nl; i++)
            found |= strcmp(layers[i].layerName, layer) == 0;
        free(layers);
        if (!found) {
            res = tnd_fail(TND_ERR_UNSUPPORTED,
                           "vulkan: validation requested but %s is not installed "
                           "(Debian: vulkan-validationlayers)",
                           layer);
            goto fail;
        }
        if (!*debug_utils) {
            /* The layer itself provides the extension. */
            *debug_utils = true;
        }
    }
    uint32_t loader_version = VK_API_VERSION_1_0;
    TND_VK_TRY(vkEnumerateInstanceVersion(&loader_version));
    VkApplicationInfo app = {
        .sType = VK_STRUCTURE_TYPE_APPLICATION_INFO,
        .pApplicationName = "tandem",
        .applicationVersion = VK_MAKE_API_VERSION(0, 0, 1, 0),
        .pEngineName = "tandem",
        .apiVersion =
            loader_version >= VK_API_VERSION_1_3 ? VK_API_VERSION_1_3 : VK_API_VERSION_1_2,
    };
    /* debug utils, then what the caller needs (a window system's surfaces) */
    const char *ext_names[2 + TND_VK_MAX_INSTANCE_EXTENSIONS];
    uint32_t next = 0;
    if (*debug_utils)
        ext_names[next++] = VK_EXT_DEBUG_UTILS_EXTENSION_NAME;
    /* the layer's synchronization checks with its core ones: a missing barrier between queued
     * passes shows even on an in-order queue such as lavapipe's (the layer provides the
     * extension that turns them on) */
    VkValidationFeatureEnableEXT sync = VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT;
    VkValidationFeaturesEXT features = {.sType = VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT,
                                        .enabledValidationFeatureCount = 1,
                                        .pEnabledValidationFeatures = &sync};
#ifndef TND_SANITIZE_BUILD
    bool sync_checks = validation;
#else
    /* (not in the sanitizer build: the layer's synchronization checks leak inside the layer,
     * 1.3.239, which LeakSanitizer reports once the layer is unloaded; the release build's
     * tests run them) */
    bool sync_checks = false;
#endif
    if (sync_checks)
        ext_names[next++] = VK_EXT_VALIDATION_FEATURES_EXTENSION_NAME;
    uint32_t extra = desc ? desc->instance_extension_count : 0;
    if (extra > TND_VK_MAX_INSTANCE_EXTENSIONS) {
        res = tnd_fail(TND_ERR_LIMIT, "vulkan: %u instance extensions asked for (at most %d)",
                       extra, TND_VK_MAX_INSTANCE_EXTENSIONS);
        goto fail;
    }
    for (uint32_t i = 0; i < extra; i++) {
        if (!has_extension(exts, n, desc->instance_extensions[i])) {
            res = tnd_fail(TND_ERR_UNSUPPORTED, "vulkan: the instance lacks %s",
                           desc->instance_extensions[i]);
            goto fail;
        }
        ext_names[next++] = desc->instance_extensions[i];
    }
    VkInstanceCreateInfo ci = {
        .sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO,
        .pNext = sync_checks ? &features : NULL,
        .pApplicationInfo = &app,
        .enabledLayerCount = validation ? 1 : 0,
        .ppEnabledLayerNames = validation ? &layer : NULL,
        .enabledExtensionCount = next,
        .ppEnabledExtensionNames = ext_names,
    };
    TND_VK_TRY(vkCreateInstance(&ci, NULL, inst));
fail:
    free(exts);
    return res;
}

/* Everything Tandem wants to know about one physical device. */
static tnd_result query_device(VkPhysicalDevice pd, uint32_t index, tnd_vk_device_info *d)
{
    tnd_result res = TND_OK;
    VkExtensionProperties *exts = NULL;
    memset(d, 0, sizeof *d);
    d->index = index;

    uint32_t n = 0;
    TND_VK_TRY(vkEnumerateDeviceExtensionProperties(pd, NULL, &n, NULL));
    exts = calloc(n ? n : 1, sizeof *exts);
    if (!exts)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "vulkan: out of memory");
    TND_VK_TRY(vkEnumerateDeviceExtensionProperties(pd, NULL, &n, exts));
    bool has_rt = has_extension(exts, n, VK_KHR_RAY_TRACING_PIPELINE_EXTENSION_NAME);
    bool has_as = has_extension(exts, n, VK_KHR_ACCELERATION_STRUCTURE_EXTENSION_NAME) &&
                  has_extension(exts, n, VK_KHR_DEFERRED_HOST_OPERATIONS_EXTENSION_NAME);
    bool has_rq = has_extension(exts, n, VK_KHR_RAY_QUERY_EXTENSION_NAME);
    d->pipeline_executable_info =
        has_extension(exts, n, VK_KHR_PIPELINE_EXECUTABLE_PROPERTIES_EXTENSION_NAME);
    d->swapchain = has_extension(exts, n, VK_KHR_SWAPCHAIN_EXTENSION_NAME);
    d->memory_budget = has_extension(exts, n, VK_EXT_MEMORY_BUDGET_EXTENSION_NAME);

    VkPhysicalDeviceProperties base;
    vkGetPhysicalDeviceProperties(pd, &base);
    d->api_version = base.apiVersion;
    d->type = base.deviceType;
    d->vendor_id = base.vendorID;
    d->device_id = base.deviceID;
    snprintf(d->name, sizeof d->name, "%s", base.deviceName);
    d->max_image_dimension_2d = base.limits.maxImageDimension2D;
    d->max_compute_workgroup_invocations = base.limits.maxComputeWorkGroupInvocations;
    d->timestamp_period_ns = base.limits.timestampPeriod;
    bool v12 = base.apiVersion >= VK_API_VERSION_1_2;

    if (v12) {
        VkPhysicalDeviceAccelerationStructurePropertiesKHR asp = {
            .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_PROPERTIES_KHR};
        VkPhysicalDeviceRayTracingPipelinePropertiesKHR rtp = {
            .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_PROPERTIES_KHR};
        VkPhysicalDeviceDriverProperties drv = {
            .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES};
        VkPhysicalDeviceIDProperties idp = {.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ID_PROPERTIES,
                                            .pNext = &drv};
        VkPhysicalDeviceProperties2 p2 = {.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2,
                                          .pNext = &idp};
        if (has_rt) {
            rtp.pNext = p2.pNext;
            p2.pNext = &rtp;
        }
        if (has_as) {
            asp.pNext = p2.pNext;
            p2.pNext = &asp;
        }
        vkGetPhysicalDeviceProperties2(pd, &p2);
        const uint8_t *u = idp.deviceUUID;
        snprintf(d->uuid, sizeof d->uuid,
                 "GPU-%02x%02x%02x%02x-%02x%02x-%02x%02x-%02x%02x-%02x%02x%02x%02x%02x%02x", u[0],
                 u[1], u[2], u[3], u[4], u[5], u[6], u[7], u[8], u[9], u[10], u[11], u[12], u[13],
                 u[14], u[15]);
        snprintf(d->driver_name, sizeof d->driver_name, "%s", drv.driverName);
        snprintf(d->driver_info, sizeof d->driver_info, "%s", drv.driverInfo);
        d->shader_group_handle_size = rtp.shaderGroupHandleSize;
        d->shader_group_handle_alignment = rtp.shaderGroupHandleAlignment;
        d->shader_group_base_alignment = rtp.shaderGroupBaseAlignment;
        d->max_ray_recursion_depth = rtp.maxRayRecursionDepth;
        d->min_scratch_offset_alignment = asp.minAccelerationStructureScratchOffsetAlignment;
        d->max_primitive_count = asp.maxPrimitiveCount;
        d->max_instance_count = asp.maxInstanceCount;
        d->max_geometry_count = asp.maxGeometryCount;

        VkPhysicalDeviceAccelerationStructureFeaturesKHR asf = {
            .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_FEATURES_KHR};
        VkPhysicalDeviceRayTracingPipelineFeaturesKHR rtf = {
            .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_FEATURES_KHR};
        VkPhysicalDeviceRayQueryFeaturesKHR rqf = {
            .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_QUERY_FEATURES_KHR};
        VkPhysicalDeviceVulkan12Features f12 = {
            .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
        VkPhysicalDeviceFeatures2 f2 = {.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2,
                                        .pNext = &f12};
        if (has_rt) {
            rtf.pNext = f2.pNext;
            f2.pNext = &rtf;
        }
        if (has_as) {
            asf.pNext = f2.pNext;
            f2.pNext = &asf;
        }
        if (has_rq) {
            rqf.pNext = f2.pNext;
            f2.pNext = &rqf;
        }
        vkGetPhysicalDeviceFeatures2(pd, &f2);
        d->buffer_address = f12.bufferDeviceAddress;
        d->rt_pipeline = has_rt && rtf.rayTracingPipeline;
        d->accel_struct = has_as && asf.accelerationStructure;
        d->ray_query = has_rq && rqf.rayQuery;
    }

    uint32_t nq = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(pd, &nq, NULL);
    VkQueueFamilyProperties qf[32];
    if (nq > 32)
        nq = 32;
    vkGetPhysicalDeviceQueueFamilyProperties(pd, &nq, qf);
    bool compute_queue = false;
    for (uint32_t i = 0; i < nq; i++) {
        if (qf[i].queueFlags & VK_QUEUE_COMPUTE_BIT) {
            compute_queue = true;
            d->timestamps = qf[i].timestampValidBits > 0 && d->timestamp_period_ns > 0;
            break;
        }
    }
    VkPhysicalDeviceMemoryProperties mp;
    vkGetPhysicalDeviceMemoryProperties(pd, &mp);
    for (uint32_t i = 0; i < mp.memoryHeapCount; i++)
        if (mp.memoryHeaps[i].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT)
            d->device_local_bytes += mp.memoryHeaps[i].size;

    d->compute_ok = v12 && d->buffer_address && compute_queue;
    d->suitable = d->compute_ok && d->rt_pipeline && d->accel_struct;
    if (!v12)
        snprintf(d->why_not, sizeof d->why_not, "Vulkan %u.%u < 1.2",
                 VK_API_VERSION_MAJOR(d->api_version), VK_API_VERSION_MINOR(d->api_version));
    else if (!d->buffer_address)
        snprintf(d->why_not, sizeof d->why_not, "no bufferDeviceAddress");
    else if (!compute_queue)
        snprintf(d->why_not, sizeof d->why_not, "no compute queue");
    else if (!d->rt_pipeline)
        snprintf(d->why_not, sizeof d->why_not, "no VK_KHR_ray_tracing_pipeline");
    else if (!d->accel_struct)
        snprintf(d->why_not, sizeof d->why_not, "no VK_KHR_acceleration_structure");
fail:
    free(exts);
    return res;
}

tnd_result tnd_vk_list_devices(tnd_vk_device_info *out, uint32_t cap, uint32_t *count)
{
    tnd_result res = TND_OK;
    VkInstance inst = VK_NULL_HANDLE;
    VkPhysicalDevice pds[16];
    bool debug_utils;
    *count = 0;
    TND_TRY(create_instance(false, NULL, &inst, &debug_utils));
    uint32_t n = 16;
    TND_VK_TRY(vkEnumeratePhysicalDevices(inst, &n, pds));
    *count = n;
    for (uint32_t i = 0; i < n && i < cap; i++)
        TND_TRY(query_device(pds[i], i, &out[i]));
fail:
    if (inst)
        vkDestroyInstance(inst, NULL);
    return res;
}

static bool contains_nocase(const char *hay, const char *needle)
{
    size_t nl = strlen(needle);
    for (const char *h = hay; *h; h++) {
        size_t i = 0;
        while (i < nl && h[i] && tolower((unsigned char)h[i]) == tolower((unsigned char)needle[i]))
            i++;
        if (i == nl)
            return true;
    }
    return nl == 0;
}

static int type_rank(VkPhysicalDeviceType t)
{
    switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
        return 0;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
        return 1;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
        return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU:
        return 3;
    default:
        return 4;
    }
}

tnd_result tnd_vk_choose_device(const tnd_vk_device_info *devs, uint32_t count, const char *want,
                                bool need_rt, uint32_t *chosen)
{
    char names[1024] = "";
    for (uint32_t i = 0; i < count; i++) {
        size_t l = strlen(names);
        snprintf(names + l, sizeof names - l, "%s%u '%s'", i ? ", " : "", i, devs[i].name);
    }
    if (count == 0)
        return tnd_fail(TND_ERR_NO_DEVICE,
                        "vulkan: no Vulkan device found (Debian: install mesa-vulkan-drivers "
                        "for lavapipe)");
    if (want && *want) {
        /* digits: an index in the order `tandem info` lists the devices; else part of a name */
        bool digits = strspn(want, "0123456789") == strlen(want);
        unsigned long index = strlen(want) < 6 ? strtoul(want, NULL, 10) : ~0ul;
        if (digits && index >= count)
            return tnd_fail(TND_ERR_NO_DEVICE,
                            "vulkan: no device %s (TANDEM_DEVICE or --device: an index from 0 to "
                            "%u, or part of a name; devices: %s)", want, count - 1, names);
        for (uint32_t i = 0; i < count; i++) {
            if (digits ? i != index : !contains_nocase(devs[i].name, want))
                continue;
            bool ok = need_rt ? devs[i].suitable : devs[i].compute_ok;
            if (!ok)
                return tnd_fail(TND_ERR_NO_DEVICE, "vulkan: device '%s' (TANDEM_DEVICE=%s): %s",
                                devs[i].name, want, devs[i].why_not);
            *chosen = i;
            return TND_OK;
        }
        return tnd_fail(TND_ERR_NO_DEVICE,
                        "vulkan: no device matches TANDEM_DEVICE='%s' (devices: %s)", want,
                        names);
    }
    int best = -1;
    for (uint32_t i = 0; i < count; i++) {
        bool ok = need_rt ? devs[i].suitable : devs[i].compute_ok;
        if (ok && (best < 0 || type_rank(devs[i].type) < type_rank(devs[best].type)))
            best = (int)i;
    }
    if (best < 0)
        return tnd_fail(TND_ERR_NO_DEVICE,
                        "vulkan: no device has %s (devices: %s; for lavapipe with ray tracing "
                        "install mesa-vulkan-drivers >= 24.1, on Debian 12 from "
                        "bookworm-backports)",
                        need_rt ? "ray-tracing pipelines" : "Vulkan 1.2 compute", names);
    *chosen = (uint32_t)best;
    return TND_OK;
}

tnd_result tnd_vk_create(const tnd_vk_desc *desc, tnd_vk *vk)
{
    tnd_result res = TND_OK;
    tnd_vk_desc dd = {0};
    if (!desc)
        desc = &dd;
    memset(vk, 0, sizeof *vk);
    vk->validation = desc->validation || env_true("TANDEM_VALIDATION");
    bool need_rt = !desc->no_ray_tracing;

    vk->messages = calloc(1, sizeof *vk->messages);
    if (!vk->messages)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "vulkan: out of memory");

    bool debug_utils = false;
    TND_TRY(create_instance(vk->validation, desc, &vk->instance, &debug_utils));
    if (debug_utils) {
        PFN_vkCreateDebugUtilsMessengerEXT create_messenger =
            (PFN_vkCreateDebugUtilsMessengerEXT)vkGetInstanceProcAddr(
                vk->instance, "vkCreateDebugUtilsMessengerEXT");
        VkDebugUtilsMessengerCreateInfoEXT mci = {
            .sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT,
            .messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT |
                               VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT,
            .messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT |
                           VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT,
            .pfnUserCallback = on_debug_message,
            .pUserData = vk->messages,
        };
        if (create_messenger && vk->validation)
            TND_VK_TRY(create_messenger(vk->instance, &mci, NULL, &vk->messenger));
        vk->fn.vkSetDebugUtilsObjectNameEXT =
            (PFN_vkSetDebugUtilsObjectNameEXT)vkGetInstanceProcAddr(vk->instance,
                                                                    "vkSetDebugUtilsObjectNameEXT");
    }

    VkPhysicalDevice pds[16];
    tnd_vk_device_info infos[16];
    uint32_t n = 16;
    TND_VK_TRY(vkEnumeratePhysicalDevices(vk->instance, &n, pds));
    for (uint32_t i = 0; i < n; i++)
        TND_TRY(query_device(pds[i], i, &infos[i]));
    const char *want = desc->device ? desc->device : getenv("TANDEM_DEVICE");
    uint32_t pick = 0;
    TND_TRY(tnd_vk_choose_device(infos, n, want, need_rt, &pick));
    vk->phys = pds[pick];
    vk->info = infos[pick];
    vk->ray_tracing = vk->info.rt_pipeline && vk->info.accel_struct;
    vk->ray_query = vk->ray_tracing && vk->info.ray_query;
    vkGetPhysicalDeviceMemoryProperties(vk->phys, &vk->mem);

    /* One queue family with compute (graphics + compute preferred). */
    uint32_t nq = 32;
    VkQueueFamilyProperties qf[32];
    vkGetPhysicalDeviceQueueFamilyProperties(vk->phys, &nq, qf);
    int family = -1;
    for (uint32_t i = 0; i < nq; i++) {
        VkQueueFlags f = qf[i].queueFlags;
        if ((f & VK_QUEUE_COMPUTE_BIT) && (family < 0 || (f & VK_QUEUE_GRAPHICS_BIT)))
            family = (int)i;
        if ((f & VK_QUEUE_COMPUTE_BIT) && (f & VK_QUEUE_GRAPHICS_BIT))
            break;
    }
    vk->queue_family = (uint32_t)family;

    /* Features: what the passes need, enabled only where supported. */
    VkPhysicalDeviceVulkan12Features have12 = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
    VkPhysicalDeviceFeatures2 have = {.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2,
                                      .pNext = &have12};
    vkGetPhysicalDeviceFeatures2(vk->phys, &have);

    VkPhysicalDeviceRayQueryFeaturesKHR rq = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_QUERY_FEATURES_KHR, .rayQuery = VK_TRUE};
    VkPhysicalDeviceRayTracingPipelineFeaturesKHR rt = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_FEATURES_KHR,
        .rayTracingPipeline = VK_TRUE};
    VkPhysicalDeviceAccelerationStructureFeaturesKHR as = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_FEATURES_KHR,
        .accelerationStructure = VK_TRUE};
    VkPhysicalDeviceVulkan12Features f12 = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES,
        .bufferDeviceAddress = VK_TRUE,
        .hostQueryReset = have12.hostQueryReset,
        .scalarBlockLayout = have12.scalarBlockLayout,
        .shaderFloat16 = have12.shaderFloat16,
        .runtimeDescriptorArray = have12.runtimeDescriptorArray,
        .descriptorBindingPartiallyBound = have12.descriptorBindingPartiallyBound,
        .descriptorBindingVariableDescriptorCount = have12.descriptorBindingVariableDescriptorCount,
        .shaderSampledImageArrayNonUniformIndexing =
            have12.shaderSampledImageArrayNonUniformIndexing,
        .descriptorIndexing = have12.descriptorIndexing,
    };
    VkPhysicalDeviceFeatures2 f2 = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2,
        .pNext = &f12,
        .features =
            {
                .shaderInt64 = have.features.shaderInt64,
                .shaderStorageImageReadWithoutFormat =
                    have.features.shaderStorageImageReadWithoutFormat,
                .shaderStorageImageWriteWithoutFormat =
                    have.features.shaderStorageImageWriteWithoutFormat,
                .samplerAnisotropy = have.features.samplerAnisotropy,
            },
    };
    const char *exts[7];
    uint32_t next = 0;
    if (vk->info.memory_budget) { /* (what soak runs read: device memory in use) */
        exts[next++] = VK_EXT_MEMORY_BUDGET_EXTENSION_NAME;
        vk->memory_budget = true;
    }
    if (desc->swapchain) {
        if (!vk->info.swapchain) {
            res = tnd_fail(TND_ERR_UNSUPPORTED, "vulkan: %s has no VK_KHR_swapchain",
                           vk->info.name);
            goto fail;
        }
        exts[next++] = VK_KHR_SWAPCHAIN_EXTENSION_NAME;
    }
    void **chain = &f12.pNext;
    VkPhysicalDevicePipelineExecutablePropertiesFeaturesKHR pe = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PIPELINE_EXECUTABLE_PROPERTIES_FEATURES_KHR,
        .pipelineExecutableInfo = VK_TRUE};
    if (env_true("TANDEM_PIPELINE_STATS")) {
        if (vk->info.pipeline_executable_info) {
            exts[next++] = VK_KHR_PIPELINE_EXECUTABLE_PROPERTIES_EXTENSION_NAME;
            *chain = &pe;
            chain = &pe.pNext;
            vk->pipeline_stats = true;
        } else {
            tnd_warn("vulkan",
                     "TANDEM_PIPELINE_STATS: %s has no VK_KHR_pipeline_executable_properties",
                     vk->info.name);
        }
    }
    if (vk->ray_tracing) {
        exts[next++] = VK_KHR_ACCELERATION_STRUCTURE_EXTENSION_NAME;
        exts[next++] = VK_KHR_DEFERRED_HOST_OPERATIONS_EXTENSION_NAME;
        exts[next++] = VK_KHR_RAY_TRACING_PIPELINE_EXTENSION_NAME;
        *chain = &as;
        as.pNext = &rt;
        chain = &rt.pNext;
        if (vk->ray_query) {
            exts[next++] = VK_KHR_RAY_QUERY_EXTENSION_NAME;
            *chain = &rq;
        }
    }
    float prio = 1.0f;
    VkDeviceQueueCreateInfo qci = {.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO,
                                   .queueFamilyIndex = vk->queue_family,
                                   .queueCount = 1,
                                   .pQueuePriorities = &prio};
    VkDeviceCreateInfo dci = {.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO,
                              .pNext = &f2,
                              .queueCreateInfoCount = 1,
                              .pQueueCreateInfos = &qci,
                              .enabledExtensionCount = next,
                              .ppEnabledExtensionNames = exts};
    TND_VK_TRY(vkCreateDevice(vk->phys, &dci, NULL, &vk->device));
    vkGetDeviceQueue(vk->device, vk->queue_family, 0, &vk->queue);

    if (vk->ray_tracing) {
#define TND_X(F)                                                                                   \
    vk->fn.F = (PFN_##F)vkGetDeviceProcAddr(vk->device, #F);                                       \
    if (!vk->fn.F) {                                                                               \
        res = tnd_fail(TND_ERR_UNSUPPORTED, "vulkan: %s: %s not found", vk->info.name, #F);        \
        goto fail;                                                                                 \
    }
        TND_VK_DEVICE_FNS(TND_X)
#undef TND_X
    }

    VkCommandPoolCreateInfo pci = {.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO,
                                   .flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT,
                                   .queueFamilyIndex = vk->queue_family};
    TND_VK_TRY(vkCreateCommandPool(vk->device, &pci, NULL, &vk->cmd_pool));
    VkFenceCreateInfo fci = {.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    TND_VK_TRY(vkCreateFence(vk->device, &fci, NULL, &vk->fence));
    TND_VK_NAME(vk, VK_OBJECT_TYPE_COMMAND_POOL, vk->cmd_pool, "tandem.cmd_pool");
    TND_VK_NAME(vk, VK_OBJECT_TYPE_FENCE, vk->fence, "tandem.fence");
    tnd_debug("vulkan", "device '%s' (%s), ray tracing %s, ray query %s%s", vk->info.name,
              vk->info.driver_name, vk->ray_tracing ? "yes" : "no", vk->ray_query ? "yes" : "no",
              vk->validation ? ", validation on" : "");
    return TND_OK;
fail:
    tnd_vk_destroy(vk);
    return res;
}

void tnd_vk_destroy(tnd_vk *vk)
{
    if (vk->device) {
        tnd_vk_fault_report();
        vkDeviceWaitIdle(vk->device);
        if (vk->fence)
            vkDestroyFence(vk->device, vk->fence, NULL);
        if (vk->cmd_pool)
            vkDestroyCommandPool(vk->device, vk->cmd_pool, NULL);
        vkDestroyDevice(vk->device, NULL);
    }
    if (vk->messenger) {
        PFN_vkDestroyDebugUtilsMessengerEXT destroy_messenger =
            (PFN_vkDestroyDebugUtilsMessengerEXT)vkGetInstanceProcAddr(
                vk->instance, "vkDestroyDebugUtilsMessengerEXT");
        if (destroy_messenger)
            destroy_messenger(vk->instance, vk->messenger, NULL);
    }
    if (vk->instance)
        vkDestroyInstance(vk->instance, NULL);
    tnd_vk_messages *m = vk->messages;
    memset(vk, 0, sizeof *vk);
    free(m);
}

uint32_t tnd_vk_validation_errors(const tnd_vk *vk)
{
    return vk->messages ? atomic_load(&vk->messages->errors) : 0;
}

uint32_t tnd_vk_validation_warnings(const tnd_vk *vk)
{
    return vk->messages ? atomic_load(&vk->messages->warnings) : 0;
}

void tnd_vk_name(const tnd_vk *vk, VkObjectType type, uint64_t handle, const char *fmt, ...)
{
    if (!vk->fn.vkSetDebugUtilsObjectNameEXT || !handle || !vk->device)
        return;
    char name[256];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(name, sizeof name, fmt, ap);
    va_end(ap);
    VkDebugUtilsObjectNameInfoEXT ni = {.sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_OBJECT_NAME_INFO_EXT,
                                        .objectType = type,
                                        .objectHandle = handle,
                                        .pObjectName = name};
    vk->fn.vkSetDebugUtilsObjectNameEXT(vk->device, &ni);
}
