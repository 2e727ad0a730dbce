/* app/cmd_info.c: `tandem info`: devices, the chosen one, ray-tracing support and limits; with
 * --scene a scene, --capture a capture (capture_info.c), --pipeline the registries (front-ends,
 * denoisers with their capabilities, parameters and passes, metrics). */
#include "app/app.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static const app_cmd info_cmd = {
    "info",
    "Show the Vulkan devices, the one Tandem picks, and its ray-tracing support; with --scene,\n"
    "what a scene contains and which pipeline features it requires.",
    "[--json] [--device INDEX|NAME] [--scene PATH]", NULL};

static int scene_info(const char *path, const rn_env *env, bool json)
{
    tnd_scene *s = NULL;
    tnd_result r = rn_scene_load(path, env, &s);
    if (r != TND_OK)
        return app_report("info", r);
    rn_scene_counts c = rn_scene_count(s);
    const uint32_t *kinds = c.kinds, *lights = c.lights;
    uint64_t unique = c.unique;
    double geo_mb = c.geo_mb, tex_mb = c.tex_mb, mip_mb = c.mip_mb;
    if (json) {
        char *txt = rn_scene_info_json(path, s);
        if (!txt) {
            tnd_scene_destroy(s);
            return app_report("info", tnd_fail(TND_ERR_OUT_OF_MEMORY, "out of memory"));
        }
        printf("%s\n", txt);
        free(txt);
    } else {
        printf("scene %s\n", path);
        printf("  triangles   %llu traced (%llu in %u meshes), %u vertices\n",
               (unsigned long long)tnd_scene_triangles(s), (unsigned long long)unique,
               s->mesh_count, s->vertex_count);
        printf("  instances   %u (%u nodes)\n", s->instance_count, s->node_count);
        printf("  memory      %.1f MB geometry, %.1f MB textures (8-bit) + %.1f MB their mips\n",
               geo_mb, tex_mb, mip_mb);
        printf("  materials  ");
        for (int k = 0; k < TND_MAT_KIND_COUNT; k++)
            printf(" %u %s%s", kinds[k], tnd_material_kind_name((tnd_material_kind)k),
                   k + 1 < TND_MAT_KIND_COUNT ? "," : "");
        printf("; %u textures\n  lights     ", s->texture_count);
        for (int k = 0; k < TND_LIGHT_TYPE_COUNT; k++)
            printf(" %u %s%s", lights[k], tnd_light_type_name((tnd_light_type)k),
                   k == TND_LIGHT_AREA ? " (emissive triangles)" : ",");
        printf("\n  light pick  %s (--lights auto: the light tree from %d emitters, point and spot "
               "lights, reservoirs from %d; docs/lights.md)",
               tnd_light_sampling_name(tnd_light_sampling_for(s, TND_LIGHTS_AUTO)),
               TND_LIGHTS_TREE_FROM, TND_LIGHTS_RESTIR_FROM);
        printf("\n  cameras     %u\n  animation   %.3f s (%u frames at 30 fps)\n", s->camera_count,
               (double)s->duration, (unsigned)floor(s->duration * 30.0 + 1e-6) + 1);
        if (s->features & TND_FEATURE(SKY))
            printf("  sky         %g %g %g nits\n", (double)s->sky[0], (double)s->sky[1],
                   (double)s->sky[2]);
        if (s->env.width)
            printf("  environment %s: %ux%u, intensity %g, rotation %g degrees, mean luminance "
                   "%.4g nits%s\n",
                   s->env.path, s->env.width, s->env.height, (double)s->env.intensity,
                   (double)s->env.rotation, s->env.mean_luminance,
                   s->env.bad_texels ? " (bad texels set to 0)" : "");
        if (s->default_camera[0])
            printf("  default     %s\n", s->default_camera);
        if (s->default_light[0])
            printf("  default     %s\n", s->default_light);
        if (s->camera_path[0])
            printf("  camera 0    %s\n", s->camera_path);
        if (s->missing_image_count)
            printf("  missing     %u images (left out: their materials' factors alone):\n",
                   s->missing_image_count);
        for (uint32_t i = 0; i < s->missing_image_count; i++)
            printf("    - %s (material '%s'%s): %s\n", s->missing_images[i].name,
                   s->missing_images[i].material, s->missing_images[i].uses > 1 ? " and others" : "",
                   s->missing_images[i].reason);
        printf("  requires:\n");
        for (uint32_t b = 0; b < TND_FEATURE_COUNT; b++)
            if (s->features & (1u << b))
                printf("    - %s\n", tnd_feature_name(b));
    }
    tnd_scene_destroy(s);
    return APP_EXIT_OK;
}

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
    cJSON_AddStringToObject(o, "uuid", d->uuid);
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
    printf("%s device %u: %s (%s, %s, Vulkan %u.%u.%u)%s\n", chosen ? "*" : " ", d->index, d->name,
           type_name(d->type), d->driver_name, VK_API_VERSION_MAJOR(d->api_version),
           VK_API_VERSION_MINOR(d->api_version), VK_API_VERSION_PATCH(d->api_version),
           chosen ? "  <- chosen" : "");
    if (d->uuid[0])
        printf("    UUID %s (as nvidia-smi -L names NVIDIA GPUs)\n", d->uuid);
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

/* tandem info --pipeline: the registries (front-ends, denoisers with their capabilities,
 * parameters and passes, metrics), as text or JSON: what the pipeline is, as data. */
/* the capability bits set, by name (names: the registry's) */
static void caps_text(uint32_t caps, const char *(*name)(uint32_t))
{
    for (uint32_t b = 0, k = 0; name(b); b++)
        if (caps & (1u << b))
            printf("%s%s", k++ ? ", " : "", name(b));
}

/* The registries (front-ends, denoisers with their parameters and passes, metrics) as text (the
 * JSON: rn_pipeline_json). */
static void pipeline_text(void)
{
    printf("front-ends (--frontend; plugin:PATH.so loads one):\n");
    for (uint32_t i = 0; pl_frontend_name_at(i); i++) {
        const char *n = pl_frontend_name_at(i);
        printf("  %-8s ", n);
        caps_text(pl_frontend_caps_of(n), pl_frontend_cap_name);
        printf("\n");
    }
    printf("denoisers (--denoiser; the first is the default; plugin:PATH.so or "
           "python:MODULE:CALLABLE loads one):\n");
    for (uint32_t i = 0; i < pl_denoiser_count(); i++) {
        const pl_denoiser_info *d = pl_denoiser_at(i);
        printf("  %-8s %s\n           capabilities: ", d->name, d->summary);
        caps_text(d->caps, pl_denoiser_cap_name);
        printf("%s%s\n", d->fallback ? "; without gradient samples: " : "",
               d->fallback ? d->fallback : "");
        for (uint32_t k = 0; k < d->nparams; k++) {
            const pl_param *p = d->params[k];
            printf("           --%s %s: %c%g, %g]: %s\n", p->name, p->arg,
                   p->min_open ? '(' : '[', p->min, p->max, p->help);
        }
        printf("           passes:");
        for (uint32_t k = 0; k < d->npasses; k++)
            printf(" %s", d->passes[k].name);
        printf("\n");
    }
    printf("metrics (tandem eval; docs/metrics.md):");
    for (uint32_t k = 0; k < ev_metric_count(); k++)
        printf(" %s", ev_metric_at(k)->name);
    printf("\n");
}

static int pipeline_info(bool json)
{
    if (!json) {
        pipeline_text();
        return APP_EXIT_OK;
    }
    char *t = rn_pipeline_json();
    if (!t)
        return app_report("info", tnd_fail(TND_ERR_OUT_OF_MEMORY, "out of memory"));
    printf("%s\n", t);
    free(t);
    return APP_EXIT_OK;
}

int cmd_info(int argc, char **argv)
{
    bool json = false, pipeline = false;
    const char *scene = NULL, *capture = NULL, *map = NULL;
    rn_env env = RN_ENV_INIT;
    const app_opt opts[] = {
        {"json", APP_OPT_FLAG, &json, NULL, "print the same information as JSON on stdout"},
        {"scene", APP_OPT_STRING, &scene, "PATH",
         "describe a scene (.gltf/.glb, or stress:N) instead of the devices"},
        APP_ENV_OPTS(&env),
        {"capture", APP_OPT_STRING, &capture, "DIR",
         "describe a capture (frame_NNNN.exr) instead: entries, ranges, a motion check"},
        {"map", APP_OPT_STRING, &map, "JSON", "--capture: read it through this mapping"},
        {"pipeline", APP_OPT_FLAG, &pipeline, NULL,
         "what the pipeline is: the registered front-ends, denoisers (capabilities, parameters, "
         "passes) and metrics"},
        {0},
    };
    const char *pos[1];
    int npos;
    int rc = app_parse(&info_cmd, opts, argc, argv, pos, 0, &npos);
    if (rc >= 0)
        return rc;
    if (scene)
        return scene_info(scene, &env, json);
    if (capture)
        return app_capture_info(capture, map, json);
    if (pipeline)
        return pipeline_info(json);

    tnd_vk_device_info devs[16];
    uint32_t n = 0;
    tnd_result r = tnd_vk_list_devices(devs, 16, &n);
    if (r != TND_OK)
        return app_report("info", r);
    if (n > 16)
        n = 16;
    const char *want = getenv("TANDEM_DEVICE"); /* (--device sets it) */
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
