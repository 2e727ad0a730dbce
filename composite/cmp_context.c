/* composite/cmp_context.c: the post chain's images (TAA history in two slots, bloom ping-pong at
 * 1/4 resolution, the display image), the histogram buffer, the pipelines, and the per-frame
 * recording with a timestamp around each pass. Passes not asked for are not dispatched (TAA off,
 * bloom off, fixed exposure: no histogram).
 * Entry points: cmp_create, cmp_destroy, cmp_run, cmp_download_hdr, cmp_download_display,
 * cmp_exposure, cmp_settings, cmp_passes, cmp_curve_parse, cmp_curve_name. */
#include "composite/composite.h"
#include "shaders/post_shared.h"
#include "shaders/shader_list.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { P_TAA, P_HIST, P_EXPOSURE, P_BLOOM, P_TONEMAP, P_INTERLEAVE, P_TAAU, P_COUNT };

struct cmp_context {
    tnd_vk *vk;
    cmp_desc desc;
    uint32_t width, height, frame;
    uint32_t in_width, in_height; /* the input's size (smaller: the TAA pass upscales) */
    tnd_image taa[2], bloom[2], display, flat; /* flat: the interleave's output (input size) */
    tnd_image depth[2]; /* the input's depth, this frame's and the last's (upscaling only) */
    tnd_buffer params, hist, hist_host; /* hist: device-local (atomics); _host: its read-back */
    VkDescriptorSetLayout layouts[2];
    VkPipelineLayout layout;
    VkDescriptorPool pool;
    VkDescriptorSet sets[3]; /* [0] set 0 reading the input, [1] the contract, [2] set 0
                                reading the interleaved image */
    VkPipeline pipes[P_COUNT];
    tnd_timer timer;
    const tnd_image *last_in; /* the input of the last frame (the HDR output with TAA off) */
    bool have_history;
    char passes[128];
    tnd_pending pending; /* the frame in flight (cmp_submit) */
    int rec[5];          /* its timestamp slots: taa, bloom, exposure, tonemap, interleave */
    bool due;            /* its timestamps not read yet */
    cmp_timings last;
};

/* The index of s in names[0..n), or -1. */
static int name_index(const char *const *names, int n, const char *s)
{
    for (int i = 0; i < n; i++)
        if (strcmp(s, names[i]) == 0)
            return i;
    return -1;
}

static const char *const curve_names[] = {"aces", "agx", "reinhard", "linear"};

tnd_result cmp_curve_parse(const char *s, cmp_curve *c)
{
    int i = name_index(curve_names, 4, s);
    if (i < 0)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                        "composite: tone curve '%s' (expected aces, agx, reinhard or linear)", s);
    *c = (cmp_curve)i;
    return TND_OK;
}

const char *cmp_curve_name(cmp_curve c)
{
    return (unsigned)c < 4 ? curve_names[c] : "?";
}

static const char *const upscaler_names[CMP_UPSCALE_COUNT] = {"temporal", "bilinear", "bicubic",
                                                               "lanczos"};

tnd_result cmp_upscaler_parse(const char *s, cmp_upscaler *u)
{
    int i = name_index(upscaler_names, CMP_UPSCALE_COUNT, s);
    if (i < 0)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                        "composite: upscaler '%s' (expected " CMP_UPSCALER_NAMES ")", s);
    *u = (cmp_upscaler)i;
    return TND_OK;
}

cmp_upscaler cmp_upscaler_used(cmp_upscaler u, bool taa)
{
    return u == CMP_UPSCALE_TEMPORAL && !taa ? CMP_UPSCALE_BILINEAR : u;
}

const char *cmp_upscaler_name(cmp_upscaler u)
{
    return (unsigned)u < CMP_UPSCALE_COUNT ? upscaler_names[u] : "?";
}

/* Whether the TAA pass upscales, and whether from this frame alone. */
static bool upscales(const cmp_context *c)
{
    return c->in_width != c->width || c->in_height != c->height;
}
static bool spatial(const cmp_context *c)
{
    return upscales(c) && (c->desc.upscaler != CMP_UPSCALE_TEMPORAL || !c->desc.taa);
}

void cmp_destroy(cmp_context *c)
{
    if (!c)
        return;
    tnd_vk *vk = c->vk;
    if (vk->device)
        vkDeviceWaitIdle(vk->device);
    tnd_pending_destroy(vk, &c->pending);
    tnd_timer_destroy(vk, &c->timer);
    for (int i = 0; i < P_COUNT; i++)
        if (c->pipes[i])
            vkDestroyPipeline(vk->device, c->pipes[i], NULL);
    if (c->pool)
        vkDestroyDescriptorPool(vk->device, c->pool, NULL);
    if (c->layout)
        vkDestroyPipelineLayout(vk->device, c->layout, NULL);
    for (int i = 0; i < 2; i++) {
        if (c->layouts[i])
            vkDestroyDescriptorSetLayout(vk->device, c->layouts[i], NULL);
        tnd_image_destroy(vk, &c->taa[i]);
        tnd_image_destroy(vk, &c->bloom[i]);
        tnd_image_destroy(vk, &c->depth[i]);
    }
    tnd_image_destroy(vk, &c->display);
    tnd_image_destroy(vk, &c->flat);
    tnd_buffer_destroy(vk, &c->params);
    tnd_buffer_destroy(vk, &c->hist);
    tnd_buffer_destroy(vk, &c->hist_host);
    free(c);
}

static tnd_result create_pipelines(cmp_context *c, tnd_precision prec)
{
    tnd_result res = TND_OK;
    tnd_vk *vk = c->vk;
    VkDescriptorSetLayoutBinding b0[CP_BINDINGS];
    for (uint32_t i = 0; i < CP_BINDINGS; i++)
        b0[i] = (VkDescriptorSetLayoutBinding){i, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1,
                                               VK_SHADER_STAGE_COMPUTE_BIT, NULL};
    b0[CP_B_PARAMS].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
    b0[CP_B_HIST].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    b0[CP_B_TAA].descriptorCount = 2;
    b0[CP_B_BLOOM].descriptorCount = 2;
    b0[CP_B_DEPTH].descriptorCount = 2;
    TND_VK_TRY(vkCreateDescriptorSetLayout(
        vk->device,
        &(VkDescriptorSetLayoutCreateInfo){.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO,
                                           .bindingCount = CP_BINDINGS,
                                           .pBindings = b0},
        NULL, &c->layouts[0]));
    TND_TRY(tnd_contract_set_layout(vk, VK_SHADER_STAGE_COMPUTE_BIT, &c->layouts[1]));
    VkPushConstantRange pcr = {VK_SHADER_STAGE_COMPUTE_BIT, 0, 8};
    TND_VK_TRY(vkCreatePipelineLayout(
        vk->device,
        &(VkPipelineLayoutCreateInfo){.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
                                      .setLayoutCount = 2,
                                      .pSetLayouts = c->layouts,
                                      .pushConstantRangeCount = 1,
                                      .pPushConstantRanges = &pcr},
        NULL, &c->layout));
    VkDescriptorPoolSize ps[3] = {{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 2},
                                  {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 2},
                                  {VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 2 * 10 + TND_CT_COUNT}};
    TND_VK_TRY(vkCreateDescriptorPool(
        vk->device,
        &(VkDescriptorPoolCreateInfo){.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO,
                                      .maxSets = 3,
                                      .poolSizeCount = 3,
                                      .pPoolSizes = ps},
        NULL, &c->pool));
    const VkDescriptorSetLayout three[3] = {c->layouts[0], c->layouts[1], c->layouts[0]};
    TND_VK_TRY(vkAllocateDescriptorSets(
        vk->device,
        &(VkDescriptorSetAllocateInfo){.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO,
                                       .descriptorPool = c->pool,
                                       .descriptorSetCount = 3,
                                       .pSetLayouts = three},
        c->sets));
    const tnd_shader ids[P_COUNT] = {
        prec == TND_PRECISION_PACKED ? TND_SHADER_post_taa_packed : TND_SHADER_post_taa_f32,
        TND_SHADER_post_histogram, TND_SHADER_post_exposure, TND_SHADER_post_bloom,
        TND_SHADER_post_tonemap,
        prec == TND_PRECISION_PACKED ? TND_SHADER_post_interleave_packed
                                     : TND_SHADER_post_interleave_f32,
        prec == TND_PRECISION_PACKED ? TND_SHADER_post_taau_packed : TND_SHADER_post_taau_f32};
    const char *names[P_COUNT] = {"composite.taa",      "composite.histogram",
                                  "composite.exposure", "composite.bloom",
                                  "composite.tonemap",  "composite.interleave",
                                  "composite.taau"};
    for (int i = 0; i < P_COUNT; i++) {
        if (i == P_TAAU && !upscales(c))
            continue; /* (only where the input is smaller) */
        size_t bytes;
        const uint32_t *code = tnd_spirv_code(ids[i], &bytes, NULL);
        TND_TRY(tnd_compute_pipeline_create(vk,
                                            &(tnd_compute_desc){.code = code, .bytes = bytes,
                                                                .layout = c->layout,
                                                                .name = names[i]},
                                            &c->pipes[i]));
    }
fail:
    return res;
}

/* The sets' own images and buffers (once): both set-0s; the second reads the interleaved image. */
static void write_own_set(cmp_context *c)
{
    for (int set = 0; set < 2; set++) {
        VkDescriptorSet ds = c->sets[set ? 2 : 0];
        VkDescriptorImageInfo ii[8];
#define IMG(i, img) (ii[i] = (VkDescriptorImageInfo){VK_NULL_HANDLE, (img)->view, VK_IMAGE_LAYOUT_GENERAL})
        IMG(0, &c->taa[0]);
        IMG(1, &c->taa[1]);
        IMG(2, &c->bloom[0]);
        IMG(3, &c->bloom[1]);
        IMG(4, &c->display);
        IMG(5, &c->flat); /* the interleave's output, and the second set's input */
        if (upscales(c)) { /* (the only pass that reads them is made only then) */
            IMG(6, &c->depth[0]);
            IMG(7, &c->depth[1]);
        }
#undef IMG
        VkWriteDescriptorSet w[8];
        const uint32_t bind[5] = {CP_B_TAA, CP_B_BLOOM, CP_B_DISPLAY, CP_B_FLAT, CP_B_IN};
        const uint32_t first[5] = {0, 2, 4, 5, 5}, count[5] = {2, 2, 1, 1, 1};
        uint32_t nw = 0;
        for (int k = 0; k < (set ? 5 : 4); k++)
            w[nw++] = (VkWriteDescriptorSet){.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
                                             .dstSet = ds, .dstBinding = bind[k],
                                             .descriptorCount = count[k],
                                             .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE,
                                             .pImageInfo = &ii[first[k]]};
        VkDescriptorBufferInfo bp = {c->params.buffer, 0, VK_WHOLE_SIZE};
        VkDescriptorBufferInfo bh = {c->hist.buffer, 0, VK_WHOLE_SIZE};
        w[nw++] = (VkWriteDescriptorSet){.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
                                         .dstSet = ds, .dstBinding = CP_B_PARAMS,
                                         .descriptorCount = 1,
                                         .descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER,
                                         .pBufferInfo = &bp};
        w[nw++] = (VkWriteDescriptorSet){.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
                                         .dstSet = ds, .dstBinding = CP_B_HIST,
                                         .descriptorCount = 1,
                                         .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                                         .pBufferInfo = &bh};
        if (upscales(c))
            w[nw++] = (VkWriteDescriptorSet){.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
                                             .dstSet = ds, .dstBinding = CP_B_DEPTH,
                                             .descriptorCount = 2,
                                             .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE,
                                             .pImageInfo = &ii[6]};
        vkUpdateDescriptorSets(c->vk->device, nw, w, 0, NULL);
    }
}

/* This frame's inputs: the back-end's image and the contract (motion). */
static void write_inputs(cmp_context *c, const tnd_image *in, const tnd_contract_gpu *ct)
{
    VkDescriptorImageInfo ii = {VK_NULL_HANDLE, in->view, VK_IMAGE_LAYOUT_GENERAL};
    VkWriteDescriptorSet w = {.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
                              .dstSet = c->sets[0], .dstBinding = CP_B_IN,
                              .descriptorCount = 1,
                              .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE,
                              .pImageInfo = &ii};
    vkUpdateDescriptorSets(c->vk->device, 1, &w, 0, NULL);
    tnd_contract_write_set(c->vk, c->sets[1], ct);
    c->last_in = in;
}

/* The passes the settings dispatch, for run.json. */
static void describe_passes(cmp_context *c)
{
    const cmp_desc *d = &c->desc;
    char taa[32];
    if (!upscales(c))
        snprintf(taa, sizeof taa, "%s", d->taa ? "taa," : "");
    else if (spatial(c))
        snprintf(taa, sizeof taa, "upscale-%s,",
                 cmp_upscaler_name(cmp_upscaler_used(d->upscaler, d->taa)));
    else
        snprintf(taa, sizeof taa, "taau,");
    snprintf(c->passes, sizeof c->passes, "%s%s%s%sexposure,tonemap",
             d->interleave ? "interleave," : "", taa, d->bloom > 0 ? "bloom," : "",
             d->fixed_exposure ? "" : "histogram,");
}

tnd_result cmp_create(tnd_vk *vk, uint32_t width, uint32_t height, tnd_precision prec,
                      const cmp_desc *desc, cmp_context **out)
{
    return cmp_create_scaled(vk, width, height, width, height, prec, desc, out);
}

tnd_result cmp_create_scaled(tnd_vk *vk, uint32_t in_width, uint32_t in_height, uint32_t width,
                             uint32_t height, tnd_precision prec, const cmp_desc *desc,
                             cmp_context **out)
{
    tnd_result res = TND_OK;
    *out = NULL;
    if (!in_width || !in_height || in_width > width || in_height > height)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                        "composite: input %ux%u for an output of %ux%u (at most the output's)",
                        in_width, in_height, width, height);
    cmp_context *c = calloc(1, sizeof *c);
    if (!c)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "composite: out of memory");
    c->vk = vk;
    c->width = width;
    c->height = height;
    c->in_width = in_width;
    c->in_height = in_height;
    if (desc)
        c->desc = *desc;
    cmp_desc *d = &c->desc;
    /* (the temporal upscaler takes 0.2: each output pixel's samples come sparser, and on
     * cornell at half the size 0.2 beat 0.1 still and in motion; docs/upscaling.md) */
    d->taa_weight = d->taa_weight > 0 ? d->taa_weight
                    : in_width != width || in_height != height ? 0.2f
                                                                : 0.1f;
    d->taa_clip = d->taa_clip > 0 ? d->taa_clip : 1.0f;
    d->taa_sparkle = d->taa_sparkle > 0 ? d->taa_sparkle : 4.0f;
    d->bloom_sigma = d->bloom_sigma > 0 ? d->bloom_sigma : 0.037f;
    if (!(d->low > 0 || d->high > 0))
        d->low = 0.5f, d->high = 0.95f;
    d->speed_up = d->speed_up > 0 ? d->speed_up : 3.0f;
    d->speed_down = d->speed_down > 0 ? d->speed_down : 1.0f;
    uint32_t qw = (width + 3) / 4, qh = (height + 3) / 4;
    for (int i = 0; i < 2; i++) {
        TND_TRY(tnd_image_create(vk, &(tnd_image_desc){.width = width, .height = height,
                                                       .format = VK_FORMAT_R32G32B32A32_SFLOAT,
                                                       .name = i ? "composite.taa[1]" : "composite.taa[0]"},
                                 &c->taa[i]));
        TND_TRY(tnd_image_create(vk, &(tnd_image_desc){.width = qw, .height = qh,
                                                       .format = VK_FORMAT_R32G32B32A32_SFLOAT,
                                                       .name = i ? "composite.bloom[1]" : "composite.bloom[0]"},
                                 &c->bloom[i]));
    }
    TND_TRY(tnd_image_create(vk, &(tnd_image_desc){.width = width, .height = height,
                                                   .format = VK_FORMAT_R32G32B32A32_SFLOAT,
                                                   .name = "composite.display"},
                             &c->display));
    TND_TRY(tnd_image_create(vk, &(tnd_image_desc){.width = in_width, .height = in_height,
                                                   .format = VK_FORMAT_R32G32B32A32_SFLOAT,
                                                   .name = "composite.flat"},
                             &c->flat));
    for (int i = 0; i < 2 && upscales(c); i++)
        TND_TRY(tnd_image_create(vk, &(tnd_image_desc){.width = in_width, .height = in_height,
                                                       .format = VK_FORMAT_R32_SFLOAT,
                                                       .name = i ? "composite.depth[1]"
                                                                 : "composite.depth[0]"},
                                 &c->depth[i]));
    TND_TRY(tnd_buffer_create(vk, &(tnd_buffer_desc){.size = sizeof(cp_params),
                                                     .usage = VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT,
                                                     .mem = TND_MEM_UPLOAD, .name = "composite.params"},
                              &c->params));
    TND_TRY(tnd_buffer_create(vk, &(tnd_buffer_desc){.size = sizeof(cp_histogram),
                                                     .usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                                     .name = "composite.histogram"},
                              &c->hist));
    TND_TRY(tnd_buffer_create(vk, &(tnd_buffer_desc){.size = sizeof(cp_histogram),
                                                     .mem = TND_MEM_READBACK,
                                                     .name = "composite.histogram_host"},
                              &c->hist_host));
    VkCommandBuffer cmd;
    TND_TRY(tnd_cmd_begin(vk, &cmd));
    vkCmdFillBuffer(cmd, c->hist.buffer, 0, VK_WHOLE_SIZE, 0);
    tnd_cmd_barrier(cmd);
    TND_TRY(tnd_cmd_submit_wait(vk, cmd));
    TND_TRY(create_pipelines(c, prec));
    write_own_set(c);
    describe_passes(c);
    TND_TRY(tnd_timer_create(vk, &c->timer));
    TND_TRY(tnd_pending_create(vk, &c->pending));
    *out = c;
    return TND_OK;
fail:
    cmp_destroy(c);
    return res;
}

static void dispatch(cmp_context *c, VkCommandBuffer cmd, int pass, uint32_t w, uint32_t h,
                     uint32_t index)
{
    uint32_t pc[2] = {c->frame & 1u, index};
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, c->pipes[pass]);
    vkCmdPushConstants(cmd, c->layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof pc, pc);
    vkCmdDispatch(cmd, (w + 7) / 8, (h + 7) / 8, 1);
    tnd_cmd_barrier(cmd);
}

/* Wait for the frame in flight and read its timestamps (c->last). */
static tnd_result settle(cmp_context *c)
{
    tnd_result res = TND_OK;
    TND_TRY(tnd_pending_wait(c->vk, &c->pending));
    if (!c->due)
        return TND_OK;
    c->due = false;
    double ms[5] = {0, 0, 0, 0, 0};
    TND_TRY(tnd_timer_read(c->vk, &c->timer, ms));
    cmp_timings *t = &c->last;
    *t = (cmp_timings){0};
    int k = 0;
    if (c->rec[4] >= 0)
        t->interleave_ms = ms[k++];
    if (c->rec[0] >= 0)
        t->taa_ms = ms[k++];
    if (c->rec[1] >= 0)
        t->bloom_ms = ms[k++];
    t->exposure_ms = ms[k++];
    t->tonemap_ms = ms[k];
fail:
    return res;
}

tnd_result cmp_run(cmp_context *c, const tnd_image *hdr, const tnd_contract_gpu *ct,
                   const cmp_frame *f, cmp_timings *t)
{
    tnd_result res = cmp_submit(c, hdr, ct, f);
    return res == TND_OK ? cmp_wait(c, t) : res;
}

tnd_result cmp_wait(cmp_context *c, cmp_timings *t)
{
    tnd_result res = settle(c);
    if (res == TND_OK && t)
        *t = c->last;
    return res;
}

tnd_result cmp_submit(cmp_context *c, const tnd_image *hdr, const tnd_contract_gpu *ct,
                      const cmp_frame *f)
{
    tnd_result res = TND_OK;
    TND_TRY(settle(c));
    if (hdr->width != c->in_width || hdr->height != c->in_height || ct->width != c->in_width ||
        ct->height != c->in_height)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "composite: input %ux%u, expected %ux%u",
                        hdr->width, hdr->height, c->in_width, c->in_height);
    write_inputs(c, hdr, ct);
    const cmp_desc *d = &c->desc;
    bool history = c->have_history && !f->reset;
    bool bloom = d->bloom > 0;
    float sigma = fminf(100.0f, fmaxf(1.0f, 0.25f * d->bloom_sigma * (float)c->height));
    /* (upscaling: the TAA pass writes the output size, whichever upscaler; the later passes
     * read it as TAA's) */
    bool up = upscales(c);
    uint32_t flags = (d->taa || up ? CP_F_TAA : 0u) | (history ? CP_F_HISTORY : 0u) |
                     (up ? CP_F_UPSCALE : 0u) | (spatial(c) ? CP_F_SPATIAL : 0u) |
                     (bloom ? CP_F_BLOOM : 0u) | (d->fixed_exposure ? 0u : CP_F_AUTO) |
                     (d->no_dither ? 0u : CP_F_DITHER);
    *(cp_params *)c->params.mapped = (cp_params){
        .size = {c->width, c->height, c->frame, flags},
        .taa = {d->taa_weight, d->taa_clip, d->taa_sparkle,
                spatial(c) ? (float)(cmp_upscaler_used(d->upscaler, d->taa) - CMP_UPSCALE_BILINEAR)
                           : 0.0f},
        .bloom = {d->bloom, sigma, ceilf(3.0f * sigma), 0},
        .tm = {(float)d->curve, d->ev100, d->low, d->high},
        .adapt = {f->dt > 0 ? f->dt : 1.0f / 30.0f, d->speed_up, d->speed_down, d->bias},
        .up = {(float)c->in_width, (float)c->in_height, f->jitter[0], f->jitter[1]},
    };
    VkCommandBuffer cmd;
    TND_TRY(tnd_cmd_begin(c->vk, &cmd));
    tnd_timer_reset(cmd, &c->timer);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, c->layout, 0, 2, c->sets, 0, NULL);
    tnd_cmd_barrier(cmd);
    int s[5] = {-1, -1, -1, -1, -1};
    if (d->interleave) {
        s[4] = tnd_timer_begin(cmd, &c->timer, "composite.interleave");
        dispatch(c, cmd, P_INTERLEAVE, c->in_width, c->in_height, 0);
        tnd_timer_end(cmd, &c->timer, s[4]);
        /* the later passes read the interleaved image */
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, c->layout, 0, 1, &c->sets[2],
                                0, NULL);
    }
    if (d->taa || up) {
        s[0] = tnd_timer_begin(cmd, &c->timer, "composite.taa");
        dispatch(c, cmd, up ? P_TAAU : P_TAA, c->width, c->height, 0);
        tnd_timer_end(cmd, &c->timer, s[0]);
    }
    if (bloom) {
        uint32_t qw = (c->width + 3) / 4, qh = (c->height + 3) / 4;
        s[1] = tnd_timer_begin(cmd, &c->timer, "composite.bloom");
        for (uint32_t i = 0; i < 3; i++)
            dispatch(c, cmd, P_BLOOM, qw, qh, i);
        tnd_timer_end(cmd, &c->timer, s[1]);
    }
    s[2] = tnd_timer_begin(cmd, &c->timer, "composite.exposure");
    if (!d->fixed_exposure) /* (a group per CP_HIST_TILE^2 pixels: 8x8 of width / 4 x height / 4) */
        dispatch(c, cmd, P_HIST, (c->width + CP_HIST_TILE / 8 - 1) / (CP_HIST_TILE / 8),
                 (c->height + CP_HIST_TILE / 8 - 1) / (CP_HIST_TILE / 8), 0);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, c->pipes[P_EXPOSURE]);
    vkCmdDispatch(cmd, 1, 1, 1);
    tnd_cmd_barrier(cmd);
    tnd_timer_end(cmd, &c->timer, s[2]);
    s[3] = tnd_timer_begin(cmd, &c->timer, "composite.tonemap");
    dispatch(c, cmd, P_TONEMAP, c->width, c->height, 0);
    tnd_timer_end(cmd, &c->timer, s[3]);
    vkCmdCopyBuffer(cmd, c->hist.buffer, c->hist_host.buffer, 1,
                    &(VkBufferCopy){0, 0, sizeof(cp_histogram)});
    VkMemoryBarrier hb = {.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER,
                          .srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT,
                          .dstAccessMask = VK_ACCESS_HOST_READ_BIT};
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1,
                         &hb, 0, NULL, 0, NULL);
    memcpy(c->rec, s, sizeof c->rec);
    TND_TRY(tnd_cmd_submit_pending(c->vk, cmd, &c->pending));
    c->due = true;
    c->have_history = true;
    c->frame++;
fail:
    return res;
}

static tnd_result download_rgb(cmp_context *c, const tnd_image *img, float *rgb, uint8_t *rgb8)
{
    size_t n = (size_t)c->width * c->height;
    float *px = malloc(n * 16);
    if (!px)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "composite: out of memory");
    tnd_result res = tnd_image_download(c->vk, img, px, n * 16);
    for (size_t q = 0; res == TND_OK && q < n; q++)
        for (int k = 0; k < 3; k++) {
            float v = px[4 * q + k];
            if (rgb)
                rgb[3 * q + k] = v;
            else
                rgb8[3 * q + k] = (uint8_t)fminf(255.0f, floorf(fmaxf(v, 0.0f) * 255.0f + 0.5f));
        }
    free(px);
    return res;
}

tnd_result cmp_download_hdr(cmp_context *c, float *rgb)
{
    if (c->frame == 0)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "composite: no frame yet");
    if (!c->desc.taa && !upscales(c)) /* the input itself (interleaved when the fields were merged) */
        return download_rgb(c, c->desc.interleave ? &c->flat : c->last_in, rgb, NULL);
    return download_rgb(c, &c->taa[(c->frame - 1) & 1u], rgb, NULL);
}

tnd_result cmp_download_display(cmp_context *c, uint8_t *rgb8)
{
    if (c->frame == 0)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "composite: no frame yet");
    return download_rgb(c, &c->display, NULL, rgb8);
}

const tnd_image *cmp_display_image(const cmp_context *c)
{
    return &c->display;
}

tnd_result cmp_exposure(cmp_context *c, float *exposure, float *log2_luminance)
{
    tnd_result res = settle(c); /* (the read-back buffer is the host's once waited for) */
    if (res != TND_OK)
        return res;
    const cp_histogram *h = c->hist_host.mapped;
    *exposure = h->exposure;
    *log2_luminance = h->adapted_log_lum;
    return TND_OK;
}

const cmp_desc *cmp_settings(const cmp_context *c)
{
    return &c->desc;
}

const char *cmp_passes(const cmp_context *c)
{
    return c->passes;
}
