/* denoise/dn_context.c: the back-end's images (histories in two slots, the recurrent mode's fast
 * and clamped histories, a-trous ping-pong, the
 * previous frame's geometry, luminances and barycentrics, the 1/3-res gradients and lf filter,
 * the output), the gradient sample buffer, its pipelines and the per-frame recording with a
 * timestamp around each pass.
 * Entry points: dn_create, dn_destroy, dn_frame_for_camera, dn_run, dn_submit, dn_wait,
 * dn_select_gradients, dn_select_gradients_gpu, dn_gradient_capacity, dn_output, dn_download,
 * dn_dump_count, dn_dump_name, dn_dump_size, dn_dump, dn_traffic_of, dn_dispatch_times,
 * dn_mode_parse, dn_mode_name. */
#include "denoise/denoise.h"
#include "shaders/denoise_shared.h"
#include "shaders/encoding.h"
#include "shaders/sampling.h"
#include "shaders/scene_gpu.h"
#include "shaders/shader_list.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

_Static_assert(DN_STRATUM == TND_GRADIENT_STRATUM,
               "the sample list's strata, as the Vulkan front-end's shading pass reads them");

/* histories: hf (+ moments), lf (SH, CoCg, length), spec (+ length); a-trous ping-pong; lf
 * ping-pong (1/3 res: tangent plane and CoCg, SH) */
enum { N_PAIRED = 8, N_SINGLE = 8 };
static const uint32_t paired_binding[N_PAIRED] = {
    DN_B_HIST_HF, DN_B_HIST_LF,  DN_B_HIST_SPEC, DN_B_AT,
    DN_B_AT_LF,   DN_B_AT_LF_SH, DN_B_HIST_FAST, DN_B_HIST_RC};
static const char *const paired_name[N_PAIRED] = {"hist_hf",  "hist_lf",   "hist_spec",
                                                  "atrous",   "at_lf",     "at_lf_sh",
                                                  "hist_fast", "hist_rc"};
enum { PAIRED_HIST_HF, PAIRED_HIST_LF, PAIRED_HIST_SPEC, PAIRED_AT, PAIRED_AT_LF,
       PAIRED_AT_LF_SH, PAIRED_HIST_FAST, PAIRED_HIST_RC }; /* indices into paired_binding */

struct dn_context {
    tnd_vk *vk;
    dn_desc desc;
    uint32_t width, height, frame;
    tnd_image paired[N_PAIRED][2];
    tnd_image prev_geo, prev_surf, out, fgeo; /* fgeo: the a-trous filter geometry */
    tnd_image centre;  /* position (relative to the filter origin) and depth */
    tnd_image prev_lum, prev_key, grad[2]; /* A-SVGF */
    tnd_image lf_geo; /* 1/3-res lf anchors: position, depth */
    tnd_buffer params, samples, samples_host; /* samples: device-local; _host: its read-back */
    tnd_buffer samples_up;  /* the host's re-shaded values (dn_set_gradient_values), made once */
    bool samples_up_due;    /* copied into `samples` before the next frame's gradients */
    /* the parameters of the pass recorded next: each command buffer carries its copy
     * (record_params), so that the host never writes `params` under a queued pass */
    dn_params host_params;
    uint64_t ct_serial; /* the contract sets[1] points at (write_contract_set; 0: none) */
    uint32_t grad_w, grad_h;
    uint32_t selected_frame; /* c->frame + 1 when dn_select_gradients ran for this frame */
    VkDescriptorSetLayout layouts[2];
    VkPipelineLayout layout;
    VkDescriptorPool pool;
    VkDescriptorSet sets[2];
    VkPipeline temporal, history, atrous, composite, grad_select, gradients, lf, lf_down;
    tnd_timer timer, select_timer, fine; /* fine: per dispatch (desc.dispatch_timing) */
    double select_ms; /* GPU time of the last selection read */
    bool select_due;  /* a selection without a host copy is in flight in `select_pending` */
    uint32_t select_frame; /* the frame (c->frame) that selection is for */
    double fine_ms[TND_TIMER_MAX_PASSES]; /* the last dn_run's, fine.count of them */
    bool batching; /* dispatches recorded now are independent: no barrier after each */
    bool fine_on;  /* recording dn_run with desc.dispatch_timing: time each dispatch */
    bool have_history;
    bool last_gradients; /* the last frame ran with gradient samples */
    /* the frame in flight (dn_submit) and its timestamp slots, `last` its timings once read;
     * the selection (dn_select_gradients_gpu) has its own, so that the back-end's passes are
     * recorded and queued behind it without waiting for it */
    tnd_pending pending, select_pending;
    struct {
        int grad, temporal, history, lf, atrous, composite;
        uint32_t frame; /* c->frame of the frame in flight */
        bool due; /* timestamps not read yet */
    } rec;
    dn_timings last;
};

/* The back-end's images that are neither ping-ponged nor the gradient pair: where they live in
 * the context, their binding, resolution (third: 1/3) and format; created, bound and destroyed
 * from this table. */
static const struct {
    size_t offset;
    uint32_t binding;
    bool third;
    VkFormat format;
    const char *name;
} single_images[N_SINGLE] = {
    {offsetof(dn_context, prev_geo), DN_B_PREV_GEO, false, VK_FORMAT_R32G32B32A32_UINT,
     "denoise.prev_geo"},
    {offsetof(dn_context, prev_surf), DN_B_PREV_SURF, false, VK_FORMAT_R32G32B32A32_UINT,
     "denoise.prev_surf"},
    {offsetof(dn_context, out), DN_B_OUT, false, VK_FORMAT_R32G32B32A32_SFLOAT, "denoise.out"},
    {offsetof(dn_context, fgeo), DN_B_FGEO, false, VK_FORMAT_R32G32_UINT, "denoise.fgeo"},
    {offsetof(dn_context, centre), DN_B_CENTRE, false, VK_FORMAT_R32G32B32A32_SFLOAT,
     "denoise.centre"},
    {offsetof(dn_context, prev_lum), DN_B_PREV_LUM, false, VK_FORMAT_R32_UINT, "denoise.prev_lum"},
    {offsetof(dn_context, prev_key), DN_B_PREV_KEY, false, VK_FORMAT_R32G32_UINT,
     "denoise.prev_key"},
    {offsetof(dn_context, lf_geo), DN_B_LF_GEO, true, VK_FORMAT_R32G32B32A32_SFLOAT,
     "denoise.lf_geo"},
};

static tnd_image *single_image(dn_context *c, int i)
{
    return (tnd_image *)((char *)c + single_images[i].offset);
}

/* The compute pipelines: where each lives in the context, its shader (float32 and packed
 * contract) and its debug name; created and destroyed from this table. */
#define DN_PIPE(member, stem, name)                                                                \
    {offsetof(dn_context, member), TND_SHADER_##stem##_f32, TND_SHADER_##stem##_packed, name}
static const struct {
    size_t offset;
    tnd_shader f32, packed;
    const char *name;
} pipelines[] = {
    DN_PIPE(temporal, dn_temporal, "denoise.temporal"),
    DN_PIPE(history, dn_history, "denoise.history"),
    DN_PIPE(atrous, dn_atrous, "denoise.atrous"),
    DN_PIPE(composite, dn_composite, "denoise.composite"),
    DN_PIPE(grad_select, dn_grad_select, "denoise.grad_select"),
    DN_PIPE(gradients, dn_gradients, "denoise.gradients"),
    DN_PIPE(lf, dn_lf, "denoise.lf"),
    DN_PIPE(lf_down, dn_lf_down, "denoise.lf_down"),
};
#undef DN_PIPE
enum { N_PIPELINES = sizeof pipelines / sizeof pipelines[0] };

static VkPipeline *pipeline_of(dn_context *c, int i)
{
    return (VkPipeline *)((char *)c + pipelines[i].offset);
}

tnd_result dn_mode_parse(const char *s, dn_mode *mode)
{
    if (strcmp(s, "svgf") == 0)
        *mode = DN_MODE_SVGF;
    else if (strcmp(s, "off") == 0)
        *mode = DN_MODE_OFF;
    else if (strcmp(s, "asvgf") == 0)
        *mode = DN_MODE_ASVGF;
    else if (strcmp(s, "recurrent") == 0)
        *mode = DN_MODE_RECURRENT;
    else
        return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                        "denoise: mode '%s' (expected svgf, asvgf, recurrent or off)", s);
    return TND_OK;
}

const char *dn_mode_name(dn_mode mode)
{
    return mode == DN_MODE_OFF         ? "off"
           : mode == DN_MODE_ASVGF     ? "asvgf"
           : mode == DN_MODE_RECURRENT ? "recurrent"
                                       : "svgf";
}

void dn_destroy(dn_context *c)
{
    if (!c)
        return;
    tnd_vk *vk = c->vk;
    if (vk->device)
        vkDeviceWaitIdle(vk->device);
    tnd_pending_destroy(vk, &c->pending);
    tnd_pending_destroy(vk, &c->select_pending);
    tnd_timer_destroy(vk, &c->timer);
    tnd_timer_destroy(vk, &c->select_timer);
    tnd_timer_destroy(vk, &c->fine);
    for (int i = 0; i < N_PIPELINES; i++)
        if (*pipeline_of(c, i))
            vkDestroyPipeline(vk->device, *pipeline_of(c, i), NULL);
    if (c->pool)
        vkDestroyDescriptorPool(vk->device, c->pool, NULL);
    if (c->layout)
        vkDestroyPipelineLayout(vk->device, c->layout, NULL);
    for (int i = 0; i < 2; i++)
        if (c->layouts[i])
            vkDestroyDescriptorSetLayout(vk->device, c->layouts[i], NULL);
    for (int k = 0; k < N_PAIRED; k++)
        for (int s = 0; s < 2; s++)
            tnd_image_destroy(vk, &c->paired[k][s]);
    for (int i = 0; i < N_SINGLE; i++)
        tnd_image_destroy(vk, single_image(c, i));
    tnd_image_destroy(vk, &c->grad[0]);
    tnd_image_destroy(vk, &c->grad[1]);
    tnd_buffer_destroy(vk, &c->params);
    tnd_buffer_destroy(vk, &c->samples);
    tnd_buffer_destroy(vk, &c->samples_host);
    tnd_buffer_destroy(vk, &c->samples_up);
    free(c);
}

static tnd_result create_pipelines(dn_context *c)
{
    tnd_result res = TND_OK;
    tnd_vk *vk = c->vk;
    VkDescriptorSetLayoutBinding b0[DN_BINDINGS];
    for (uint32_t i = 0; i < DN_BINDINGS; i++)
        b0[i] = (VkDescriptorSetLayoutBinding){i, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1,
                                               VK_SHADER_STAGE_COMPUTE_BIT, NULL};
    b0[DN_B_PARAMS].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
    b0[DN_B_SAMPLES].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    for (int k = 0; k < N_PAIRED; k++)
        b0[paired_binding[k]].descriptorCount = 2;
    b0[DN_B_GRAD].descriptorCount = 2;
    VkDescriptorSetLayoutCreateInfo ci0 = {.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO,
                                           .bindingCount = DN_BINDINGS,
                                           .pBindings = b0};
    TND_VK_TRY(vkCreateDescriptorSetLayout(vk->device, &ci0, NULL, &c->layouts[0]));
    TND_TRY(tnd_contract_set_layout(vk, VK_SHADER_STAGE_COMPUTE_BIT, &c->layouts[1]));
    VkPushConstantRange pcr = {VK_SHADER_STAGE_COMPUTE_BIT, 0, 8};
    VkPipelineLayoutCreateInfo pci = {.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
                                      .setLayoutCount = 2,
                                      .pSetLayouts = c->layouts,
                                      .pushConstantRangeCount = 1,
                                      .pPushConstantRanges = &pcr};
    TND_VK_TRY(vkCreatePipelineLayout(vk->device, &pci, NULL, &c->layout));
    VkDescriptorPoolSize ps[3] = {{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1},
                                  {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1},
                                  {VK_DESCRIPTOR_TYPE_STORAGE_IMAGE,
                                   2 * N_PAIRED + N_SINGLE + 4 + TND_CT_COUNT}};
    VkDescriptorPoolCreateInfo dpci = {.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO,
                                       .maxSets = 2,
                                       .poolSizeCount = 3,
                                       .pPoolSizes = ps};
    TND_VK_TRY(vkCreateDescriptorPool(vk->device, &dpci, NULL, &c->pool));
    VkDescriptorSetAllocateInfo ai = {.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO,
                                      .descriptorPool = c->pool,
                                      .descriptorSetCount = 2,
                                      .pSetLayouts = c->layouts};
    TND_VK_TRY(vkAllocateDescriptorSets(vk->device, &ai, c->sets));
    bool packed = c->desc.precision == TND_PRECISION_PACKED;
    for (int i = 0; i < N_PIPELINES; i++) {
        size_t bytes;
        const uint32_t *code = tnd_spirv_code(packed ? pipelines[i].packed : pipelines[i].f32,
                                              &bytes, NULL);
        TND_TRY(tnd_compute_pipeline_create(vk,
                                            &(tnd_compute_desc){.code = code, .bytes = bytes,
                                                                .layout = c->layout,
                                                                .name = pipelines[i].name},
                                            pipeline_of(c, i)));
    }
fail:
    return res;
}

static void write_own_set(dn_context *c)
{
    VkDescriptorImageInfo ii[2 * N_PAIRED + N_SINGLE + 4];
    VkWriteDescriptorSet w[N_PAIRED + N_SINGLE + 4];
    uint32_t n = 0, k = 0;
    for (int p = 0; p < N_PAIRED; p++) {
        ii[k] = (VkDescriptorImageInfo){VK_NULL_HANDLE, c->paired[p][0].view, VK_IMAGE_LAYOUT_GENERAL};
        ii[k + 1] = (VkDescriptorImageInfo){VK_NULL_HANDLE, c->paired[p][1].view, VK_IMAGE_LAYOUT_GENERAL};
        w[n++] = (VkWriteDescriptorSet){.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
                                        .dstSet = c->sets[0], .dstBinding = paired_binding[p],
                                        .descriptorCount = 2,
                                        .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE,
                                        .pImageInfo = &ii[k]};
        k += 2;
    }
    ii[k] = (VkDescriptorImageInfo){VK_NULL_HANDLE, c->grad[0].view, VK_IMAGE_LAYOUT_GENERAL};
    ii[k + 1] = (VkDescriptorImageInfo){VK_NULL_HANDLE, c->grad[1].view, VK_IMAGE_LAYOUT_GENERAL};
    w[n++] = (VkWriteDescriptorSet){.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
                                    .dstSet = c->sets[0], .dstBinding = DN_B_GRAD,
                                    .descriptorCount = 2,
                                    .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE,
                                    .pImageInfo = &ii[k]};
    k += 2;
    for (int s = 0; s < N_SINGLE; s++) {
        ii[k] = (VkDescriptorImageInfo){VK_NULL_HANDLE, single_image(c, s)->view,
                                        VK_IMAGE_LAYOUT_GENERAL};
        w[n++] = (VkWriteDescriptorSet){.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
                                        .dstSet = c->sets[0],
                                        .dstBinding = single_images[s].binding,
                                        .descriptorCount = 1,
                                        .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE,
                                        .pImageInfo = &ii[k++]};
    }
    VkDescriptorBufferInfo bi = {c->params.buffer, 0, VK_WHOLE_SIZE};
    w[n++] = (VkWriteDescriptorSet){.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
                                    .dstSet = c->sets[0], .dstBinding = DN_B_PARAMS,
                                    .descriptorCount = 1,
                                    .descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER,
                                    .pBufferInfo = &bi};
    VkDescriptorBufferInfo si = {c->samples.buffer, 0, VK_WHOLE_SIZE};
    w[n++] = (VkWriteDescriptorSet){.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
                                    .dstSet = c->sets[0], .dstBinding = DN_B_SAMPLES,
                                    .descriptorCount = 1,
                                    .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                                    .pBufferInfo = &si};
    vkUpdateDescriptorSets(c->vk->device, n, w, 0, NULL);
}

tnd_result dn_create(tnd_vk *vk, uint32_t width, uint32_t height, const dn_desc *desc,
                     dn_context **out)
{
    tnd_result res = TND_OK;
    *out = NULL;
    dn_context *c = calloc(1, sizeof *c);
    if (!c)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "denoise: out of memory");
    c->vk = vk;
    c->width = width;
    c->height = height;
    if (desc)
        c->desc = *desc;
    dn_desc *d = &c->desc;
    d->iters_hf = d->iters_hf ? d->iters_hf : 4;
    d->iters_lf = d->iters_lf ? d->iters_lf : 3;
    d->iters_spec = d->iters_spec ? d->iters_spec : 3;
    d->min_alpha_hf = d->min_alpha_hf > 0 ? d->min_alpha_hf : 0.02f;
    d->min_alpha_lf = d->min_alpha_lf > 0 ? d->min_alpha_lf : 0.01f;
    d->min_alpha_spec = d->min_alpha_spec > 0 ? d->min_alpha_spec : 0.01f;
    d->min_alpha_moments = d->min_alpha_moments > 0 ? d->min_alpha_moments : 0.01f;
    d->antilag_hf = d->antilag_hf > 0 ? d->antilag_hf : 1.0f;
    d->antilag_spec = d->antilag_spec > 0 ? d->antilag_spec : 2.0f;
    d->antilag_motion = d->antilag_motion > 0 ? d->antilag_motion : 0.004f;
    d->antilag_lf = d->antilag_lf > 0 ? d->antilag_lf : 1.0f;
    d->lf_sigma = d->lf_sigma > 0 ? d->lf_sigma : 2.0f;
    d->hf_sigma = d->hf_sigma > 0 ? d->hf_sigma : 4.0f;
    d->lf_deflicker = d->lf_deflicker == 0 ? 2.0f : d->lf_deflicker < 0 ? 0.0f : d->lf_deflicker;
    d->fast_frames = d->fast_frames > 0 ? d->fast_frames : 6.0f;
    d->clamp_sigma = d->clamp_sigma > 0 ? d->clamp_sigma : 2.0f;
    d->history_fix = d->history_fix == 0 ? 3.0f : d->history_fix < 0 ? 0.0f : d->history_fix;
    d->fix_stride = d->fix_stride > 0 ? d->fix_stride : 14.0f;
    d->resample = d->resample == 0 ? DN_RESAMPLE_DEFAULT : d->resample;
    if (d->grad_segment == 0 || d->grad_segment > DN_GRAD_SEGMENT)
        d->grad_segment = DN_GRAD_SEGMENT;
    c->grad_w = (width + DN_STRATUM - 1) / DN_STRATUM;
    c->grad_h = (height + DN_STRATUM - 1) / DN_STRATUM;
    for (int k = 0; k < N_PAIRED; k++)
        for (int s = 0; s < 2; s++) {
            char name[64];
            snprintf(name, sizeof name, "denoise.%s[%d]", paired_name[k], s);
            bool third = k == PAIRED_AT_LF || k == PAIRED_AT_LF_SH;
            /* the recurrent denoiser's own histories: a texel elsewhere (bound, never read) */
            bool none = (k == PAIRED_HIST_FAST || k == PAIRED_HIST_RC) &&
                        d->mode != DN_MODE_RECURRENT;
            VkFormat f = k == PAIRED_AT_LF_SH     ? VK_FORMAT_R32G32B32A32_SFLOAT
                         : k == PAIRED_HIST_SPEC ? VK_FORMAT_R32G32_UINT
                                                 : VK_FORMAT_R32G32B32A32_UINT;
            uint32_t iw = none ? 1 : third ? c->grad_w : width;
            uint32_t ih = none ? 1 : third ? c->grad_h : height;
            TND_TRY(tnd_image_create(vk, &(tnd_image_desc){.width = iw,
                                                           .height = ih,
                                                           .format = f,
                                                           .name = name},
                                     &c->paired[k][s]));
        }
    for (int i = 0; i < N_SINGLE; i++)
        TND_TRY(tnd_image_create(vk,
                                 &(tnd_image_desc){
                                     .width = single_images[i].third ? c->grad_w : width,
                                     .height = single_images[i].third ? c->grad_h : height,
                                     .format = single_images[i].format,
                                     .name = single_images[i].name},
                                 single_image(c, i)));
    for (int i = 0; i < 2; i++)
        TND_TRY(tnd_image_create(vk, &(tnd_image_desc){.width = c->grad_w, .height = c->grad_h,
                                                       .format = VK_FORMAT_R32G32B32A32_SFLOAT,
                                                       .name = i ? "denoise.grad[1]"
                                                                 : "denoise.grad[0]"},
                                 &c->grad[i]));
    VkDeviceSize sample_bytes = (VkDeviceSize)c->grad_w * c->grad_h * sizeof(tnd_gpu_gradient);
    TND_TRY(tnd_buffer_create(vk, &(tnd_buffer_desc){.size = sample_bytes,
                                                     .usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                                     .name = "denoise.samples"},
                              &c->samples));
    TND_TRY(tnd_buffer_create(vk, &(tnd_buffer_desc){.size = sample_bytes,
                                                     .mem = TND_MEM_READBACK,
                                                     .name = "denoise.samples_host"},
                              &c->samples_host));
    /* (written only by the command buffers, record_params: device-local, as the front-end's
     * frame parameters) */
    TND_TRY(tnd_buffer_create(vk, &(tnd_buffer_desc){.size = sizeof(dn_params),
                                                     .usage = VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT,
                                                     .mem = TND_MEM_DEVICE, .name = "denoise.params"},
                              &c->params));
    TND_TRY(create_pipelines(c));
    write_own_set(c);
    TND_TRY(tnd_pending_create(vk, &c->pending));
    TND_TRY(tnd_pending_create(vk, &c->select_pending));
    TND_TRY(tnd_timer_create(vk, &c->timer));
    TND_TRY(tnd_timer_create(vk, &c->select_timer));
    if (c->desc.dispatch_timing)
        TND_TRY(tnd_timer_create(vk, &c->fine));
    *out = c;
    return TND_OK;
fail:
    dn_destroy(c);
    return res;
}

/* Names of the dispatches for dn_dispatch_times: the pass's, with the iteration for the
 * iterated ones (names that outlive the context). */
static const char *dispatch_name(const char *pass, uint32_t iteration)
{
    static const char *const names[][8] = {
        {"atrous.0", "atrous.1", "atrous.2", "atrous.3", "atrous.4", "atrous.5", "atrous.6", "atrous.7+"},
        {"lf.downsample", "lf.deflicker", "lf.atrous0", "lf.atrous1", "lf.atrous2", "lf.atrous3",
         "lf.atrous4", "lf.atrous5+"},
    };
    static const char *const passes[] = {"atrous", "lf"};
    for (int k = 0; k < 2; k++)
        if (strcmp(pass, passes[k]) == 0)
            return names[k][iteration < 7 ? iteration : 7];
    return pass;
}

static void dispatch_grid(dn_context *c, VkCommandBuffer cmd, VkPipeline pipe, const char *name,
                          const uint32_t pc[2], uint32_t groups_x, uint32_t groups_y)
{
    int slot = c->fine_on ? tnd_timer_begin(cmd, &c->fine, dispatch_name(name, pc[1])) : -1;
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipe);
    vkCmdPushConstants(cmd, c->layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, 2 * sizeof(uint32_t), pc);
    vkCmdDispatch(cmd, groups_x, groups_y, 1);
    if (!c->batching)
        tnd_cmd_compute_barrier(cmd);
    if (slot >= 0)
        tnd_timer_end(cmd, &c->fine, slot);
}

static void dispatch(dn_context *c, VkCommandBuffer cmd, VkPipeline pipe, const char *name,
                     uint32_t slot, uint32_t iteration)
{
    dispatch_grid(c, cmd, pipe, name, (uint32_t[2]){slot, iteration}, (c->width + 7) / 8,
                  (c->height + 7) / 8);
}

/* the modes that select gradient samples (A-SVGF; recurrent, as its confidence) */
static bool uses_gradients(const dn_desc *d)
{
    return d->mode == DN_MODE_ASVGF || d->mode == DN_MODE_RECURRENT;
}

/* full-res a-trous passes run: the most hf or spec asks for (the other is carried through) */
static uint32_t atrous_iters(const dn_desc *d)
{
    return d->iters_hf > d->iters_spec ? d->iters_hf : d->iters_spec;
}

dn_frame dn_frame_for_camera(const float proj[16], uint32_t height, uint32_t frame, bool reset)
{
    dn_frame f = {.pixel_spread = (float)(2.0 / fabs((double)proj[5]) / height), .reset = reset};
    tnd_jitter(frame, f.jitter);
    tnd_jitter(frame ? frame - 1 : 0, f.prev_jitter);
    return f;
}

/* the camera's position from a rigid view matrix (world to view): -R^T t */
static void view_position(const float v[16], float pos[3])
{
    for (int k = 0; k < 3; k++)
        pos[k] = -(v[4 * k] * v[12] + v[4 * k + 1] * v[13] + v[4 * k + 2] * v[14]);
}

void dn_frame_set_camera(dn_frame *f, const tnd_camera_state *c)
{
    /* a perspective projection: clip w = -z (m[2][3] = -1) */
    f->has_camera = c && c->proj[11] != 0.0f && c->prev_proj[11] != 0.0f;
    if (!f->has_camera)
        return;
    memcpy(f->view, c->view, sizeof f->view);
    memcpy(f->proj, c->proj, sizeof f->proj);
    memcpy(f->prev_view, c->prev_view, sizeof f->prev_view);
    memcpy(f->prev_proj, c->prev_proj, sizeof f->prev_proj);
}

/* proj * the view's rotation (camera-relative points in, clip out), as 4 columns */
static void rotation_clip(const float view[16], const float proj[16], dn_vec4 out[4])
{
    float r[16], m[16];
    memcpy(r, view, sizeof r);
    r[12] = r[13] = r[14] = 0.0f;
    tnd_mat4_mul(proj, r, m);
    for (int c = 0; c < 4; c++)
        out[c] = (dn_vec4){m[4 * c], m[4 * c + 1], m[4 * c + 2], m[4 * c + 3]};
}

static tnd_result check_contract(const dn_context *c, const tnd_contract_gpu *ct)
{
    if (ct->width != c->width || ct->height != c->height || ct->precision != c->desc.precision)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                        "denoise: contract %ux%u (%s) does not match the back-end's %ux%u (%s)",
                        ct->width, ct->height, tnd_precision_name(ct->precision), c->width,
                        c->height, tnd_precision_name(c->desc.precision));
    return TND_OK;
}

static void fill_params(dn_context *c, const dn_frame *f, bool gradients)
{
    bool history = c->have_history && !f->reset;
    const dn_desc *d = &c->desc;
    uint32_t mode = d->mode == DN_MODE_OFF         ? DN_RUN_OFF
                    : d->mode == DN_MODE_ASVGF     ? DN_RUN_ASVGF
                    : d->mode == DN_MODE_RECURRENT ? DN_RUN_RECURRENT
                                                   : DN_RUN_SVGF;
    c->host_params = (dn_params){
        .size = {c->width, c->height, history ? 1u : 0u, mode},
        .iters = {d->iters_hf, d->iters_lf, d->iters_spec, d->grad_segment},
        .alpha = {d->min_alpha_hf, d->min_alpha_lf, d->min_alpha_spec, d->min_alpha_moments},
        .jitter = {f->jitter[0], f->jitter[1], f->prev_jitter[0], f->prev_jitter[1]},
        .weights = {2.0f, 64.0f, d->hf_sigma, 8.0f},
        .misc = {f->pixel_spread, 256.0f, 1024.0f, gradients ? 1.0f : 0.0f},
        .antilag = {d->antilag_hf, d->antilag_spec, d->antilag_motion, d->antilag_lf},
        .lf = {d->lf_deflicker, d->no_leak_guard ? 0.0f : 1.0f, d->lf_sigma, 0.0f},
        .frame = {c->frame, d->resample == 1 ? 1u : 0u, 0, 0},
        .rc = {d->fast_frames, d->clamp_sigma, d->history_fix, d->fix_stride},
    };
    dn_params *P = &c->host_params;
    if (f->has_camera) {
        float cam[3], prev[3];
        view_position(f->view, cam);
        view_position(f->prev_view, prev);
        rotation_clip(f->view, f->proj, P->cur_vp);
        rotation_clip(f->prev_view, f->prev_proj, P->prev_vp);
        P->cam_pos = (dn_vec4){cam[0], cam[1], cam[2], 0.0f};
        P->cam_delta = (dn_vec4){cam[0] - prev[0], cam[1] - prev[1], cam[2] - prev[2], 1.0f};
    }
}

/* The parameters fill_params made, into the params buffer as the command buffer runs (after
 * its first barrier: the passes queued before it have read theirs): all but the filter
 * geometry's origin, which is copied from contract `ct`'s position and visibility at the centre
 * pixel (dn_submit) or stays as the frame before left it (`ct` NULL: the selection does not read
 * it). Then one barrier for the uniform reads. */
static void record_params(dn_context *c, VkCommandBuffer cmd, const tnd_contract_gpu *ct)
{
    const VkDeviceSize a = offsetof(dn_params, origin_position), b = offsetof(dn_params, frame);
    vkCmdUpdateBuffer(cmd, c->params.buffer, 0, a, &c->host_params);
    vkCmdUpdateBuffer(cmd, c->params.buffer, b, sizeof(dn_params) - b,
                      (const char *)&c->host_params + b);
    VkOffset3D centre = {(int32_t)(c->width / 2), (int32_t)(c->height / 2), 0};
    const struct {
        tnd_ct id;
        VkDeviceSize offset;
    } fields[2] = {{TND_CT_POSITION, offsetof(dn_params, origin_position)},
                   {TND_CT_VIS_ID, offsetof(dn_params, origin_vis)}};
    for (int i = 0; ct && i < 2; i++) {
        VkBufferImageCopy r = {.bufferOffset = fields[i].offset,
                               .imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1},
                               .imageOffset = centre,
                               .imageExtent = {1, 1, 1}};
        vkCmdCopyImageToBuffer(cmd, ct->images[fields[i].id].image, VK_IMAGE_LAYOUT_GENERAL,
                               c->params.buffer, 1, &r);
    }
    VkMemoryBarrier mb = {.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER,
                          .srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT,
                          .dstAccessMask = VK_ACCESS_UNIFORM_READ_BIT};
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                         0, 1, &mb, 0, NULL, 0, NULL);
}

/* a pass in stratum tiles (one thread per pixel, DN_TILE_W x DN_TILE_H per work group) */
static void dispatch_tiles(dn_context *c, VkCommandBuffer cmd, VkPipeline pipe, const char *name)
{
    dispatch_grid(c, cmd, pipe, name, (uint32_t[2]){c->frame & 1u, 0},
                  (c->width + DN_TILE_W - 1) / DN_TILE_W, (c->height + DN_TILE_H - 1) / DN_TILE_H);
}

/* a 1/3-resolution pass (one thread per 3x3 stratum, 8 x 8 per work group) */
static void dispatch_third(dn_context *c, VkCommandBuffer cmd, VkPipeline pipe, const char *name,
                           uint32_t iteration)
{
    dispatch_grid(c, cmd, pipe, name, (uint32_t[2]){c->frame & 1u, iteration},
                  (c->grad_w + 7) / 8, (c->grad_h + 7) / 8);
}

/* step k of the lf filter: the downsample (k = 0), the deflicker, the a-trous iterations */
static void dispatch_lf(dn_context *c, VkCommandBuffer cmd, uint32_t k)
{
    if (k == 0)
        dispatch_tiles(c, cmd, c->lf_down, "lf.downsample");
    else
        dispatch_third(c, cmd, c->lf, "lf", k);
}

/* Wait for the selection in flight and read its time (c->select_ms). */
static tnd_result settle_select(dn_context *c)
{
    tnd_result res = TND_OK;
    TND_TRY(tnd_pending_wait(c->vk, &c->select_pending));
    if (c->select_due) {
        c->select_due = false;
        TND_TRY(tnd_timer_read(c->vk, &c->select_timer, &c->select_ms));
    }
fail:
    return res;
}

/* Wait for the frame in flight and read its timestamps (c->last), with its selection's (done
 * before it in the queue); a selection for the next frame may stay in flight. Every entry point
 * that records the back-end's passes, or reads its images, settles first. */
static tnd_result settle(dn_context *c)
{
    tnd_result res = TND_OK;
    TND_TRY(tnd_pending_wait(c->vk, &c->pending));
    if (c->rec.due && c->select_due && c->select_frame == c->rec.frame)
        TND_TRY(settle_select(c));
    if (!c->rec.due)
        return TND_OK;
    c->rec.due = false;
    double ms[6] = {0, 0, 0, 0, 0, 0};
    TND_TRY(tnd_timer_read(c->vk, &c->timer, ms));
    dn_timings *t = &c->last;
    *t = (dn_timings){0};
    int k = 0;
    if (c->rec.grad >= 0) {
        t->select_ms = c->select_ms;
        t->gradient_ms = ms[k++];
    }
    if (c->rec.temporal >= 0)
        t->temporal_ms = ms[k++];
    if (c->rec.history >= 0)
        t->history_ms = ms[k++];
    if (c->rec.lf >= 0)
        t->lf_ms = ms[k++];
    if (c->rec.atrous >= 0)
        t->atrous_ms = ms[k++];
    t->lf_beside_atrous = c->rec.atrous >= 0 && c->rec.lf < 0;
    t->composite_ms = ms[k];
    if (c->desc.dispatch_timing)
        TND_TRY(tnd_timer_read(c->vk, &c->fine, c->fine_ms));
fail:
    return res;
}

/* Point sets[1] at the contract `ct`, where it is not already: a set a queued pass reads is
 * rewritten only once both passes in flight are done. */
static tnd_result write_contract_set(dn_context *c, const tnd_contract_gpu *ct)
{
    tnd_result res = TND_OK;
    if (ct->serial && ct->serial == c->ct_serial)
        return TND_OK;
    TND_TRY(settle_select(c));
    TND_TRY(settle(c));
    tnd_contract_write_set(c->vk, c->sets[1], ct);
    c->ct_serial = ct->serial;
fail:
    return res;
}

/* The selection pass; `host`: also copy the list to the read-back buffer. */
static tnd_result select_pass(dn_context *c, const tnd_contract_gpu *ct, const dn_frame *f,
                              bool host)
{
    tnd_result res = TND_OK;
    TND_TRY(check_contract(c, ct));
    TND_TRY(settle_select(c)); /* (the selection before: its timer and command buffer) */
    TND_TRY(write_contract_set(c, ct));
    fill_params(c, f, false);
    VkCommandBuffer cmd;
    TND_TRY(tnd_cmd_begin(c->vk, &cmd));
    tnd_timer_reset(cmd, &c->select_timer);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, c->layout, 0, 2, c->sets, 0, NULL);
    tnd_cmd_barrier(cmd);
    record_params(c, cmd, NULL);
    int s_s = tnd_timer_begin(cmd, &c->select_timer, "denoise.grad_select");
    dispatch_tiles(c, cmd, c->grad_select, "select");
    tnd_cmd_barrier(cmd); /* for the copy and the front-end's passes that read the samples */
    tnd_timer_end(cmd, &c->select_timer, s_s);
    if (host) {
        vkCmdCopyBuffer(cmd, c->samples.buffer, c->samples_host.buffer, 1,
                        &(VkBufferCopy){0, 0, c->samples.size});
        VkMemoryBarrier hb = {.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER,
                              .srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT,
                              .dstAccessMask = VK_ACCESS_HOST_READ_BIT};
        vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1,
                             &hb, 0, NULL, 0, NULL);
    }
    if (host) { /* the list is read at once */
        TND_TRY(tnd_cmd_submit_wait(c->vk, cmd));
        TND_TRY(tnd_timer_read(c->vk, &c->select_timer, &c->select_ms));
    } else { /* the front-end's launches and the back-end's passes come after it in the queue */
        TND_TRY(tnd_cmd_submit_pending(c->vk, cmd, &c->select_pending));
        c->select_due = true;
        c->select_frame = c->frame;
    }
    c->selected_frame = c->frame + 1;
fail:
    return res;
}

tnd_result dn_select_gradients_gpu(dn_context *c, const tnd_contract_gpu *ct, const dn_frame *f,
                                   VkBuffer *buffer, uint32_t *slots, uint32_t *row)
{
    *buffer = VK_NULL_HANDLE;
    *slots = 0;
    *row = c->grad_w;
    if (!uses_gradients(&c->desc))
        return TND_OK;
    tnd_result res = select_pass(c, ct, f, false);
    if (res == TND_OK) {
        *buffer = c->samples.buffer;
        *slots = c->grad_w * c->grad_h;
    }
    return res;
}

tnd_result dn_select_gradients(dn_context *c, const tnd_contract_gpu *ct, const dn_frame *f,
                               uint32_t *samples, uint32_t *count)
{
    tnd_result res = TND_OK;
    *count = 0;
    if (!uses_gradients(&c->desc))
        return TND_OK;
    TND_TRY(select_pass(c, ct, f, true));
    const tnd_gpu_gradient *g = c->samples_host.mapped;
    uint32_t n = 0, strata = c->grad_w * c->grad_h;
    for (uint32_t i = 0; i < strata; i++) {
        if (g[i].pixel == TND_GRADIENT_NONE)
            continue;
        const uint32_t v[DN_GRADIENT_WORDS] = {g[i].pixel,     g[i].rng_frame, g[i].rng_pixel,
                                               g[i].instance,  g[i].primitive, g[i].u_bits,
                                               g[i].v_bits};
        memcpy(samples + (size_t)n * DN_GRADIENT_WORDS, v, sizeof v);
        n++;
    }
    *count = n;
fail:
    return res;
}

tnd_result dn_set_gradient_values(dn_context *c, const uint32_t *samples, uint32_t count,
                                  const tnd_frame *reshaded)
{
    tnd_result res = TND_OK;
    if (count == 0)
        return TND_OK;
    if (!uses_gradients(&c->desc) || c->selected_frame != c->frame + 1)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                        "denoise: gradient values without this frame's selection");
    if (reshaded->width != c->width || reshaded->height != c->height ||
        !reshaded->present[TND_CT_HF] || !reshaded->present[TND_CT_SPEC] ||
        !reshaded->present[TND_CT_LF_SH])
        return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                        "denoise: gradient values from a %ux%u frame without hf, spec or lf "
                        "(the back-end is %ux%u)",
                        reshaded->width, reshaded->height, c->width, c->height);
    TND_TRY(settle(c)); /* (the frame before may still copy from samples_up) */
    if (!c->samples_up.buffer)
        TND_TRY(tnd_buffer_create(c->vk, &(tnd_buffer_desc){.size = c->samples.size,
                                                            .mem = TND_MEM_UPLOAD,
                                                            .name = "denoise.samples_up"},
                                  &c->samples_up));
    tnd_gpu_gradient *up = c->samples_up.mapped;
    memcpy(up, c->samples_host.mapped, c->samples.size); /* (the selection, as read back) */
    const float *hf = tnd_frame_f(reshaded, TND_CT_HF), *sp = tnd_frame_f(reshaded, TND_CT_SPEC);
    const float *sh = tnd_frame_f(reshaded, TND_CT_LF_SH);
    for (uint32_t k = 0; k < count; k++) {
        uint32_t q = samples[(size_t)k * DN_GRADIENT_WORDS], x = q % c->width, y = q / c->width;
        uint32_t i = y / DN_STRATUM * c->grad_w + x / DN_STRATUM;
        if (q >= c->width * c->height || up[i].pixel != q)
            return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                            "denoise: gradient value %u at pixel %u, which the selection did not "
                            "pick",
                            k, q);
        memcpy(up[i].hf, hf + 3 * (size_t)q, sizeof up[i].hf);
        memcpy(up[i].spec, sp + 3 * (size_t)q, sizeof up[i].spec);
        up[i].l0 = sh[4 * (size_t)q + 3];
        up[i].reshaded = 1.0f;
    }
    c->samples_up_due = true;
fail:
    return res;
}

uint32_t dn_gradient_capacity(const dn_context *c)
{
    return c->grad_w * c->grad_h;
}

tnd_result dn_run(dn_context *c, const tnd_contract_gpu *ct, const dn_frame *f, dn_timings *t)
{
    tnd_result res = dn_submit(c, ct, f);
    return res == TND_OK ? dn_wait(c, t) : res;
}

tnd_result dn_wait(dn_context *c, dn_timings *t)
{
    tnd_result res = settle(c);
    if (res == TND_OK && t)
        *t = c->last;
    return res;
}

tnd_result dn_submit(dn_context *c, const tnd_contract_gpu *ct, const dn_frame *f)
{
    tnd_result res = TND_OK;
    TND_TRY(check_contract(c, ct));
    TND_TRY(settle(c)); /* (the frame before; not this frame's selection, queued before it) */
    TND_TRY(write_contract_set(c, ct));
    const dn_desc *d = &c->desc;
    bool gradients = uses_gradients(d) && c->selected_frame == c->frame + 1 &&
                     c->have_history && !f->reset;
    fill_params(c, f, gradients);
    c->last_gradients = gradients;
    uint32_t slot = c->frame & 1u;
    uint32_t iters = atrous_iters(d);
    VkCommandBuffer cmd;
    TND_TRY(tnd_cmd_begin(c->vk, &cmd));
    tnd_timer_reset(cmd, &c->timer);
    if (d->dispatch_timing)
        tnd_timer_reset(cmd, &c->fine);
    c->fine_on = d->dispatch_timing;
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, c->layout, 0, 2, c->sets, 0, NULL);
    tnd_cmd_barrier(cmd);
    record_params(c, cmd, ct);
    int s_g = -1, s_t = -1, s_h = -1, s_l = -1, s_a = -1;
    if (c->samples_up_due) { /* the host's re-shaded values (dn_set_gradient_values) */
        if (gradients) {
            vkCmdCopyBuffer(cmd, c->samples_up.buffer, c->samples.buffer, 1,
                            &(VkBufferCopy){0, 0, c->samples.size});
            tnd_cmd_barrier(cmd);
        }
        c->samples_up_due = false;
    }
    if (gradients) {
        s_g = tnd_timer_begin(cmd, &c->timer, "denoise.gradients");
        /* the gradients and their blur along rows (grad[0] and the samples -> grad[1]), then
         * along columns (-> grad[0]), a segment of a row or column per work group */
        uint32_t seg = d->grad_segment;
        dispatch_grid(c, cmd, c->gradients, "gradient.rows", (uint32_t[2]){c->frame & 1u, 0},
                      (c->grad_w + seg - 1) / seg, c->grad_h);
        dispatch_grid(c, cmd, c->gradients, "gradient.columns", (uint32_t[2]){c->frame & 1u, 1},
                      (c->grad_h + seg - 1) / seg, c->grad_w);
        tnd_timer_end(cmd, &c->timer, s_g);
    }
    if (d->mode != DN_MODE_OFF) {
        s_t = tnd_timer_begin(cmd, &c->timer, "denoise.temporal");
        dispatch(c, cmd, c->temporal, "temporal", slot, 0);
        tnd_timer_end(cmd, &c->timer, s_t);
        if (d->mode == DN_MODE_RECURRENT) {
            s_h = tnd_timer_begin(cmd, &c->timer, "denoise.history");
            dispatch(c, cmd, c->history, "history", slot, 0);
            tnd_timer_end(cmd, &c->timer, s_h);
        }
        /* the lf filter (1/3 res, latency-bound, few threads) and the a-trous (full res) do not
         * depend on each other: their dispatches are paired without a barrier between them, so
         * the lf passes run beside the a-trous ones. Per-dispatch timing runs them in turn. */
        uint32_t n_lf = d->iters_lf + 2; /* downsample, deflicker, a-trous */
        if (d->dispatch_timing) {
            s_l = tnd_timer_begin(cmd, &c->timer, "denoise.lf");
            for (uint32_t k = 0; k < n_lf; k++)
                dispatch_lf(c, cmd, k);
            tnd_timer_end(cmd, &c->timer, s_l);
            s_a = tnd_timer_begin(cmd, &c->timer, "denoise.atrous");
            for (uint32_t i = 0; i < iters; i++)
                dispatch(c, cmd, c->atrous, "atrous", slot, i);
            tnd_timer_end(cmd, &c->timer, s_a);
        } else {
            s_a = tnd_timer_begin(cmd, &c->timer, "denoise.atrous+lf");
            /* with one lf step more than a-trous iterations (the defaults: 5 and 4), one runs
             * alone: the deflicker, the cheapest (H200, dynamic: back-end 1.061 -> 1.058 ms
             * against the last lf a-trous alone) */
            const uint32_t lone = 1;
            for (uint32_t k = 0; k < n_lf || k < iters; k++) {
                c->batching = true;
                uint32_t ka = k; /* the a-trous iteration beside lf step k (iters: none) */
                if (n_lf == iters + 1 && lone < n_lf && k >= lone)
                    ka = k == lone ? iters : k - 1;
                if (ka < iters)
                    dispatch(c, cmd, c->atrous, "atrous", slot, ka);
                if (k < n_lf) /* after: its few groups fill the a-trous's last wave (H200:
                                 a-trous + lf 0.500 -> 0.494 ms, dynamic) */
                    dispatch_lf(c, cmd, k);
                c->batching = false;
                tnd_cmd_compute_barrier(cmd);
            }
            tnd_timer_end(cmd, &c->timer, s_a);
        }
    }
    int s_c = tnd_timer_begin(cmd, &c->timer, "denoise.composite");
    dispatch(c, cmd, c->composite, "composite", slot, 0);
    tnd_cmd_barrier(cmd); /* the output is read by other passes (post chain, downloads) */
    tnd_timer_end(cmd, &c->timer, s_c);
    c->fine_on = false;
    c->rec.grad = s_g;
    c->rec.temporal = s_t;
    c->rec.history = s_h;
    c->rec.lf = s_l;
    c->rec.atrous = s_a;
    c->rec.composite = s_c;
    c->rec.frame = c->frame;
    TND_TRY(tnd_cmd_submit_pending(c->vk, cmd, &c->pending));
    c->rec.due = true;
    c->have_history = true;
    c->frame++;
fail:
    return res;
}

uint32_t dn_dispatch_times(const dn_context *c, const char **names, double *ms, uint32_t max)
{
    uint32_t n = c->fine.count < max ? c->fine.count : max;
    for (uint32_t i = 0; i < n; i++) {
        names[i] = c->fine.names[i];
        ms[i] = c->fine_ms[i];
    }
    return n;
}

void dn_traffic_of(const dn_context *c, dn_traffic *t)
{
    /* per pixel (full res) or per stratum (1/3 res) bytes, from the shaders' loads and stores
     * (each texel once; the back-end's own texels are 16 bytes but where noted) */
    tnd_precision p = c->desc.precision;
#define CT(id) ((double)tnd_ct_texel_bytes(TND_CT_##id, p))
    const dn_desc *d = &c->desc;
    double n = (double)c->width * c->height, n3 = (double)c->grad_w * c->grad_h;
    bool asvgf = uses_gradients(d), filter = d->mode != DN_MODE_OFF;
    bool recurrent = d->mode == DN_MODE_RECURRENT;
    *t = (dn_traffic){0};
    if (asvgf) {
        /* the stratum's 9 pixels: vis, motion, depth, geometric normal, path now; the previous
         * surface (16) and luminances (4) at the reprojection; the lf history at the
         * reprojection (16); per stratum the sample written (32), one gradient texel (lf
         * history sum, previous luminances), and at the chosen pixel the previous luminances,
         * rng key and surface (4 + 8 + 16 + 16) */
        t->select = n * (CT(VIS_ID) + CT(MOTION) + CT(DEPTH) + CT(GEO_NORMAL) + CT(PATH) + 16 +
                         4 + 16) +
                    n3 * (32 + 16 + 4 + 8 + 16 + 16);
        /* rows: the stratum's 9 pixels' vis and lf now; per stratum the lf history sum and
         * previous luminances, the sample, hf and spec at the sample pixel, the texel written;
         * columns: one texel read, one written */
        t->gradient = n * (CT(VIS_ID) + CT(LF_SH)) +
                      n3 * (16 + 32 + CT(HF) + CT(SPEC) + 16 + 16 + 16);
    }
    if (filter) {
        t->temporal = n * (CT(VIS_ID) + CT(HF) + CT(SPEC) + CT(LF_SH) + CT(LF_COCG) + CT(DEPTH) +
                           CT(GEO_NORMAL) + CT(MOTION) + CT(NORMAL) + CT(ROUGHNESS) +
                           CT(PATH) + CT(POSITION) +
                           56 /* previous surface, hf, lf and spec histories (16 16 16 8) */
                           + 16 + 16 + 8 /* written: hf, lf and spec histories */
                           + 16 + 8 + 16 /* the a-trous input, filter geometry, centre */
                           + (asvgf ? CT(RNG) + 4 + 8 : 0) /* the next frame's sample data */
                           + (recurrent ? 16 + 16 + 16 : 0) /* clamped and fast histories read,
                                                               the fast one written */) +
                      (asvgf ? n3 * (16 + 32) : 0); /* the gradient and the sample per stratum */
        /* downsample (full-res reads: vis, geometric normal, centre, lf history, this frame's
         * lf sample; 1/3-res writes: the anchor and the two lf texels), then deflicker and
         * a-trous at 1/3 res (per step the anchor (the a-trous's centre) and both texels read,
         * both written) */
        t->lf = n * (CT(VIS_ID) + CT(GEO_NORMAL) + 16 + 16 + CT(LF_SH)) +
                n3 * (3 * 16 + (double)(d->iters_lf + 1) * (3 * 16 + 2 * 16));
        /* per iteration: the ping-pong texel (16 bytes: both colours, variance) and the filter
         * geometry (8) of each tap, the centre texel; the texel written */
        t->atrous = n * ((double)atrous_iters(d) * (16 + 8 + 16 + 16));
        /* the history pass: filter geometry, the three histories, centre and a-trous input
         * read (the neighbours' are the same texels); the clamped history and the a-trous
         * input written */
        if (recurrent)
            t->history = n * (8 + 16 + 8 + 16 + 16 + 16 + 16 + 16);
    }
    t->composite = n * (CT(VIS_ID) + CT(GEO_NORMAL) + CT(VIS_BARY) + CT(EMISSION) +
                        CT(ALBEDO) + CT(METALLIC) + CT(THROUGHPUT) +
                        (filter ? 16 + 8 + 16 /* centre, filter geometry, the a-trous result */
                                : CT(DEPTH) + CT(NORMAL) + CT(PATH) + CT(HF) + CT(SPEC) +
                                      CT(LF_SH) + CT(LF_COCG)) +
                        16 + 16 + 16 /* previous surface (two texels); output */) +
                   (filter ? n3 * (16 + 16) : 0) + /* lf anchors and texels */
                   (asvgf ? n3 * 16 : 0);           /* the strata's samples */
#undef CT
}

/* Dumps: name, channel names, the image (slot: 0 this frame's history, 1 the final a-trous). */
enum { DUMP_HIST, DUMP_HIST_COCG, DUMP_HIST_MOM, DUMP_ATROUS, DUMP_LF, DUMP_GRAD, DUMP_OUT,
       DUMP_RC, DUMP_CONF };
static const struct {
    const char *name;
    const char *channels[4];
    int kind, index; /* index into paired[] */
} dumps[] = {
    {"temporal.hf", {"R", "G", "B", "history"}, DUMP_HIST, PAIRED_HIST_HF},
    {"temporal.moments", {"m1", "m2", "history_lf", "history_spec"}, DUMP_HIST_MOM, PAIRED_HIST_HF},
    {"temporal.lf_sh", {"L1x", "L1y", "L1z", "L0"}, DUMP_HIST, PAIRED_HIST_LF},
    {"temporal.lf_cocg", {"Co", "Cg", "unused0", "unused1"}, DUMP_HIST_COCG, PAIRED_HIST_LF},
    {"temporal.spec", {"R", "G", "B", "unused"}, DUMP_HIST, PAIRED_HIST_SPEC},
    {"atrous.hf", {"R", "G", "B", "variance"}, DUMP_ATROUS, 0}, /* index: hf 0, spec 1 */
    {"lf.sh", {"L1x", "L1y", "L1z", "L0"}, DUMP_LF, PAIRED_AT_LF_SH},
    {"lf.cocg", {"Co", "Cg", "variance", "unused"}, DUMP_LF, PAIRED_AT_LF},
    {"atrous.spec", {"R", "G", "B", "unused"}, DUMP_ATROUS, 1},
    {"gradients", {"hf", "spec", "lf", "unused"}, DUMP_GRAD, 0},
    /* recurrent (zeros in other modes): the fast histories (and the fast lf L0); the slow
     * histories after the clamp (and the reflection's distance) */
    {"recurrent.fast", {"R", "G", "B", "lf_L0"}, DUMP_RC, PAIRED_HIST_FAST},
    {"recurrent.fast_spec", {"R", "G", "B", "unused"}, DUMP_RC, PAIRED_HIST_FAST + 16},
    {"recurrent.clamped", {"R", "G", "B", "hit_distance"}, DUMP_RC, PAIRED_HIST_RC},
    {"recurrent.clamped_spec", {"R", "G", "B", "unused"}, DUMP_RC, PAIRED_HIST_RC + 16},
    /* the confidence the gradients give the histories, (1 - antilag)^10 (1/3 res; asvgf and
     * recurrent frames with gradient samples, 1 elsewhere) */
    {"confidence", {"hf", "spec", "lf", "unused"}, DUMP_CONF, 0},
    {"output", {"R", "G", "B", "A"}, DUMP_OUT, 0},
};

/* The histories decoded (dn_common.glsl's hist_hf_pack, hist_lf_pack, hist_rgb_pack): kind
 * DUMP_HIST gives hf's rgb and history length, lf's SH, or spec's rgb (w 0) by `index`;
 * DUMP_HIST_COCG the lf history's CoCg, DUMP_HIST_MOM the moments and the lf and spec history
 * lengths. */
static float rel_half(uint32_t h, float l0) /* rel_unpack */
{
    return tnd_half_to_float((uint16_t)(h & 0xffffu)) * l0;
}

static tnd_result dump_history(dn_context *c, int kind, int index, uint32_t slot, size_t n,
                               float *rgba)
{
    tnd_result res = TND_OK;
    uint32_t *hf = malloc(n * 16), *lf = malloc(n * 16), *spec = malloc(n * 8);
    if (!hf || !lf || !spec) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "denoise: out of memory");
        goto fail;
    }
    TND_TRY(tnd_image_download(c->vk, &c->paired[PAIRED_HIST_HF][slot], hf, n * 16));
    TND_TRY(tnd_image_download(c->vk, &c->paired[PAIRED_HIST_LF][slot], lf, n * 16));
    TND_TRY(tnd_image_download(c->vk, &c->paired[PAIRED_HIST_SPEC][slot], spec, n * 8));
    for (size_t q = 0; q < n; q++) {
        const uint32_t *h = hf + 4 * q, *l = lf + 4 * q, *s = spec + 2 * q;
        const uint32_t *rgb = index == PAIRED_HIST_HF ? h : s;
        float *o = rgba + 4 * q, l0;
        memcpy(&l0, &l[0], 4);
        if (kind == DUMP_HIST && index == PAIRED_HIST_LF) {
            o[0] = rel_half(l[1], l0);
            o[1] = rel_half(l[1] >> 16, l0);
            o[2] = rel_half(l[2], l0);
            o[3] = l0;
        } else if (kind == DUMP_HIST) {
            o[0] = tnd_uf16_decode(rgb[0] & 0xffffu);
            o[1] = tnd_uf16_decode(rgb[0] >> 16);
            o[2] = tnd_uf16_decode(rgb[1] & 0xffffu);
            o[3] = index == PAIRED_HIST_HF ? tnd_half_to_float((uint16_t)(rgb[1] >> 16)) : 0.0f;
        } else if (kind == DUMP_HIST_COCG) {
            o[0] = rel_half(l[3], l0);
            o[1] = rel_half(l[3] >> 16, l0);
            o[2] = o[3] = 0.0f;
        } else {
            memcpy(&o[0], &h[2], 4);
            memcpy(&o[1], &h[3], 4);
            o[2] = tnd_half_to_float((uint16_t)(l[2] >> 16));
            o[3] = tnd_half_to_float((uint16_t)(s[1] >> 16));
        }
    }
fail:
    free(hf);
    free(lf);
    free(spec);
    return res;
}

/* An image in at_pack's layout (dn_common.glsl: hf rgb, spec rgb, a 16-bit w, all tnd_uf16)
 * decoded: spec's rgb or hf's, and w (or 0). */
static tnd_result dump_at(dn_context *c, const tnd_image *img, int spec, bool with_w, size_t n,
                          float *rgba)
{
    tnd_result res = tnd_image_download(c->vk, img, rgba, n * 16);
    for (size_t q = 0; res == TND_OK && q < n; q++) {
        uint32_t t[4];
        memcpy(t, rgba + 4 * q, 16);
        uint16_t v[8];
        for (int k = 0; k < 8; k++)
            v[k] = (uint16_t)(t[k / 2] >> (16 * (k & 1)));
        for (int k = 0; k < 3; k++)
            rgba[4 * q + k] = tnd_uf16_decode(v[3 * spec + k]);
        rgba[4 * q + 3] = with_w ? tnd_uf16_decode(v[6]) : 0.0f;
    }
    return res;
}

uint32_t dn_dump_count(void)
{
    return (uint32_t)(sizeof dumps / sizeof dumps[0]);
}

const char *dn_dump_name(uint32_t i, const char **channels)
{
    if (i >= dn_dump_count())
        return NULL;
    if (channels)
        for (int k = 0; k < 4; k++)
            channels[k] = dumps[i].channels[k];
    return dumps[i].name;
}

tnd_result dn_dump_size(const dn_context *c, uint32_t i, uint32_t *w, uint32_t *h)
{
    if (i >= dn_dump_count())
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "denoise: dump %u does not exist", i);
    bool third = dumps[i].kind == DUMP_GRAD || dumps[i].kind == DUMP_LF ||
                 dumps[i].kind == DUMP_CONF;
    *w = third ? c->grad_w : c->width;
    *h = third ? c->grad_h : c->height;
    return TND_OK;
}

tnd_result dn_dump(dn_context *c, uint32_t i, float *rgba)
{
    uint32_t w = 0, h = 0;
    tnd_result res = dn_dump_size(c, i, &w, &h);
    if (res != TND_OK)
        return res;
    if (c->frame == 0)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "denoise: dump %s before the first frame",
                        dumps[i].name);
    uint32_t slot = (c->frame - 1) & 1u;
    /* what the mode does not write holds nothing of this run: zeros, not the memory's leftovers
     * (off composites the noisy signals alone; gradients only where they were taken) */
    if ((c->desc.mode == DN_MODE_OFF && dumps[i].kind != DUMP_OUT) ||
        (dumps[i].kind == DUMP_GRAD && !c->last_gradients)) {
        memset(rgba, 0, (size_t)w * h * 16);
        return TND_OK;
    }
    bool hist = dumps[i].kind == DUMP_HIST || dumps[i].kind == DUMP_HIST_COCG ||
                dumps[i].kind == DUMP_HIST_MOM;
    const tnd_image *img = hist                           ? &c->paired[dumps[i].index][slot]
                           : dumps[i].kind == DUMP_ATROUS
                               ? &c->paired[PAIRED_AT][atrous_iters(&c->desc) & 1u]
                           : dumps[i].kind == DUMP_LF
                               ? &c->paired[dumps[i].index][(c->desc.iters_lf + 1) & 1u]
                           : dumps[i].kind == DUMP_GRAD   ? &c->grad[0]
                                                          : &c->out;
    if (dumps[i].kind == DUMP_RC) { /* at_pack's layout: index + 16 for spec */
        int k = dumps[i].index & 15, spec = dumps[i].index >> 4;
        if (c->desc.mode != DN_MODE_RECURRENT) {
            memset(rgba, 0, (size_t)w * h * 16);
            return TND_OK;
        }
        return dump_at(c, &c->paired[k][slot], spec, !spec, (size_t)w * h, rgba);
    }
    if (dumps[i].kind == DUMP_CONF) { /* dn_temporal.comp's antilag from the filtered gradients */
        size_t n = (size_t)w * h;
        bool with = c->last_gradients;
        res = with ? tnd_image_download(c->vk, &c->grad[0], rgba, n * 16) : TND_OK;
        const float gain[3] = {c->desc.antilag_hf, c->desc.antilag_spec, c->desc.antilag_lf};
        for (size_t q = 0; res == TND_OK && q < n; q++)
            for (int k = 0; k < 4; k++) {
                /* (hf: the relative change, the square root of its gradient: dn_temporal.comp) */
                float r = k == 0 ? sqrtf(rgba[4 * q] > 0.0f ? rgba[4 * q] : 0.0f) : rgba[4 * q + k];
                float g = with && k < 3 ? gain[k] * r : 0.0f;
                g = g < 0.0f ? 0.0f : g > 1.0f ? 1.0f : g;
                rgba[4 * q + k] = k < 3 ? powf(1.0f - g, 10.0f) : 0.0f;
            }
        return res;
    }
    if (dumps[i].kind == DUMP_ATROUS) /* decode the packed texel: index 0 hf, 1 spec */
        return dump_at(c, img, dumps[i].index, dumps[i].index == 0, (size_t)w * h, rgba);
    if (hist) /* the packed histories */
        return dump_history(c, dumps[i].kind, dumps[i].index, slot, (size_t)w * h, rgba);
    if (dumps[i].kind == DUMP_LF && dumps[i].index == PAIRED_AT_LF) {
        /* z: CoCg relative to the SH texel's L0 (two half floats), w: the L0 variance (float);
         * dn_common.glsl's lf_pack */
        size_t n = (size_t)w * h;
        float *sh = malloc(n * 16);
        if (!sh)
            return tnd_fail(TND_ERR_OUT_OF_MEMORY, "denoise: out of memory");
        res = tnd_image_download(c->vk, img, rgba, n * 16);
        if (res == TND_OK)
            res = tnd_image_download(
                c->vk, &c->paired[PAIRED_AT_LF_SH][(c->desc.iters_lf + 1) & 1u], sh, n * 16);
        for (size_t q = 0; res == TND_OK && q < n; q++) {
            uint32_t t[4];
            memcpy(t, rgba + 4 * q, 16);
            float l0 = sh[4 * q + 3];
            rgba[4 * q] = rel_half(t[2], l0);
            rgba[4 * q + 1] = rel_half(t[2] >> 16, l0);
            memcpy(&rgba[4 * q + 2], &t[3], 4);
            rgba[4 * q + 3] = 0.0f;
        }
        free(sh);
        return res;
    }
    return tnd_image_download(c->vk, img, rgba, (size_t)w * h * 16);
}

const tnd_image *dn_output(const dn_context *c)
{
    return &c->out;
}

tnd_result dn_download(dn_context *c, float *rgb)
{
    size_t n = (size_t)c->width * c->height;
    float *px = malloc(n * 16);
    if (!px)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "denoise: out of memory");
    tnd_result res = tnd_image_download(c->vk, &c->out, px, n * 16);
    for (size_t q = 0; res == TND_OK && q < n; q++)
        for (int k = 0; k < 3; k++)
            rgb[3 * q + k] = px[4 * q + k];
    free(px);
    return res;
}
