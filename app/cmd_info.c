/* app/cmd_info.c: `tandem info`: devices, the chosen one, ray-tracing support and limits. */
#include "app/app.h"

#include <cjson/cJSON.h>
#include <stdlib.h>
#include <string.h>

static const app_cmd info_cmd = {
    "info", "Show the Vulkan devices, the one Tandem picks, and its ray-tracing support.",
    "[--json] [--device NAME]", NULL};

static const char *type_name(VkPhysicalDeviceType t)
{
    switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
        return "discrete GPU";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
        return "integrated GPU";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
        return "virtual GPU";
    case VK_PHYSICAL_DEVICE_TYPE_CPU:
        return "CPU";
    default:
        return "other";
    }
}

static cJSON *device_json(const tnd_vk_device_info *d, bool chosen)
{
    cJSON *o = cJSON_CreateObject();
    char api[32];
    snprintf(api, sizeof api, "%u.%u.%u", VK_API_VERSION_MAJOR(d->api_version),
             VK_API_VERSION_MINOR(d->api_version), VK_API_VERSION_PATCH(d->api_version));
    cJSON_AddNumberToObject(o, "index", d->index);
    cJSON_AddStringToObject(o, "name", d->name);
    cJSON_AddStringToObject(o, "type", type_name(d->type));
    cJSON_AddStringToObject(o, "driver", d->driver_name);
    cJSON_AddStringToObject(o, "driver_info", d->driver_info);
    cJSON_AddStringToObject(o, "api_version", api);
    cJSON_AddBoolToObject(o, "chosen", chosen);
    cJSON_AddBoolToObject(o, "suitable", d->suitable);
    if (!d->suitable)
        cJSON_AddStringToObject(o, "why_not", d->why_not);
    cJSON_AddBoolToObject(o, "ray_tracing_pipeline", d->rt_pipeline);
    cJSON_AddBoolToObject(o, "acceleration_structure", d->accel_struct);
    cJSON_AddBoolToObject(o, "ray_query", d->ray_query);
    cJSON_AddBoolToObject(o, "timestamps", d->timestamps);
    cJSON_AddNumberToObject(o, "device_local_mib", (double)(d->device_local_bytes >> 20));
    cJSON *l = cJSON_AddObjectToObject(o, "limits");
    cJSON_AddNumberToObject(l, "shader_group_handle_size", d->shader_group_handle_size);
    cJSON_AddNumberToObject(l, "shader_group_handle_alignment", d->shader_group_handle_alignment);
    cJSON_AddNumberToObject(l, "shader_group_base_alignment", d->shader_group_base_alignment);
    cJSON_AddNumberToObject(l, "max_ray_recursion_depth", d->max_ray_recursion_depth);
    cJSON_AddNumberToObject(l, "min_scratch_offset_alignment", d->min_scratch_offset_alignment);
    cJSON_AddNumberToObject(l, "max_primitive_count", (double)d->max_primitive_count);
    cJSON_AddNumberToObject(l, "max_instance_count", (double)d->max_instance_count);
    cJSON_AddNumberToObject(l, "max_image_dimension_2d", d->max_image_dimension_2d);
    cJSON_AddNumberToObject(l, "timestamp_period_ns", d->timestamp_period_ns);
    return o;
}

static void device_text(const tnd_vk_device_info *d, bool chosen)
{
    printf("%s device %u: %s (%s, %s, Vulkan %u.%u.%u)%s\n", chosen ? "*" : " ", d->index,
           d->name, type_name(d->type), d->driver_name, VK_API_VERSION_MAJOR(d->api_version),
           VK_API_VERSION_MINOR(d->api_version), VK_API_VERSION_PATCH(d->api_version),
           chosen ? "  <- chosen" : "");
    printf("    ray tracing pipeline: %s   acceleration structure: %s   ray query: %s\n",
           d->rt_pipeline ? "yes" : "no", d->accel_struct ? "yes" : "no",
           d->ray_query ? "yes" : "no");
    if (!d->suitable)
        printf("    not usable for the ray-traced front-end: %s\n", d->why_not);
    if (d->rt_pipeline)
        printf("    SBT: handle size %u, handle alignment %u, base alignment %u; "
               "max recursion %u; AS scratch alignment %u\n",
               d->shader_group_handle_size, d->shader_group_handle_alignment,
               d->shader_group_base_alignment, d->max_ray_recursion_depth,
               d->min_scratch_offset_alignment);
    printf("    max image %u, timestamps %s (%.3g ns/tick), device-local memory %llu MiB\n",
           d->max_image_dimension_2d, d->timestamps ? "yes" : "no", d->timestamp_period_ns,
           (unsigned long long)(d->device_local_bytes >> 20));
}

int cmd_info(int argc, char **argv)
{
    bool json = false;
    const char *device = NULL;
    const app_opt opts[] = {
        {"json", APP_OPT_FLAG, &json, NULL, "print the same information as JSON on stdout"},
        {"device", APP_OPT_STRING, &device, "NAME",
         "pick the device whose name contains NAME (default: $TANDEM_DEVICE, then a GPU, "
         "then lavapipe)"},
        {0},
    };
    const char *pos[1];
    int npos;
    int rc = app_parse(&info_cmd, opts, argc, argv, pos, 0, &npos);
    if (rc >= 0)
        return rc;

    tnd_vk_device_info devs[16];
    uint32_t n = 0;
    tnd_result r = tnd_vk_list_devices(devs, 16, &n);
    if (r != TND_OK)
        return app_report("info", r);
    if (n > 16)
        n = 16;
    const char *want = device ? device : getenv("TANDEM_DEVICE");
    uint32_t chosen = 0;
    tnd_result cr = tnd_vk_choose_device(devs, n, want, true, &chosen);
    if (cr != TND_OK)
        return app_report("info", cr);

    if (json) {
        cJSON *root = cJSON_CreateObject();
        cJSON_AddStringToObject(root, "tandem_version", TND_VERSION_STRING);
        cJSON_AddNumberToObject(root, "chosen", chosen);
        cJSON *arr = cJSON_AddArrayToObject(root, "devices");
        for (uint32_t i = 0; i < n; i++)
            cJSON_AddItemToArray(arr, device_json(&devs[i], i == chosen));
        char *s = cJSON_Print(root);
        printf("%s\n", s);
        free(s);
        cJSON_Delete(root);
    } else {
        printf("tandem %s\n%u Vulkan device%s:\n", TND_VERSION_STRING, n, n == 1 ? "" : "s");
        for (uint32_t i = 0; i < n; i++)
            device_text(&devs[i], i == chosen);
        const tnd_vk_device_info *c = &devs[chosen];
        printf("chosen: %s; ray-tracing API: pipeline%s\n", c->name,
               c->ray_query ? " (ray query also available)" : " (no ray query)");
    }
    return APP_EXIT_OK;
}
