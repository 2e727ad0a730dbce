/* frontend_vk/fvk_internal.h: the context of the Vulkan path-tracing front-end. */
#ifndef FVK_INTERNAL_H
#define FVK_INTERNAL_H

#include "frontend_vk/frontend_vk.h"
#include "shaders/scene_gpu.h"

typedef struct fvk_texture {
    VkImage image;
    VkDeviceMemory memory;
    VkImageView view;
} fvk_texture;

struct fvk_context {
    tnd_vk *vk;
    const tnd_scene *scene;
    tnd_precision precision;
    /* scene */
    tnd_buffer positions, normals, uvs, tangents, indices, meshes, materials, instances, lights,
        frame_ubo, gradients, env, uvs1, texel_lut; /* texel_lut: shaders/texel_lut.h's table */
    /* the alpha test's data, what the any-hit reads in two steps (shaders/pt_scene.glsl
     * alpha_pass): per alpha-tested mesh a record and its triangles' UVs; alpha_at[mesh]: the
     * record's vec4 index + 1 (0: none), which each instance carries in info.z */
    tnd_buffer alpha;
    tnd_buffer light_nodes; /* the light tree (shaders/light_tree.h; binding 18) */
    /* ReSTIR DI (--lights restir; shaders/pt_restir.glsl): the reservoirs (binding 19: two
     * frames' final ones and this frame's after the temporal merge, W x H each) and the surfaces
     * (binding 20: two frames'), made at the frame's size (a record each without reservoirs);
     * the slot this frame writes (the previous frame's is the other), whether the previous
     * frame's are there, the frames they belong to */
    tnd_buffer rs_reservoirs, rs_surfaces;
    bool restir;
    uint32_t rs_width, rs_height, rs_slot, rs_frame, rs_prev_frame;
    bool rs_have_cur, rs_have_prev;
    uint32_t *alpha_at;
    uint32_t gradient_capacity;
    uint32_t shade_slot_rows; /* the next shading pass's launch rows for mode 2's slots */
    fvk_texture *textures;
    uint32_t texture_count;
    VkSampler sampler;
    fvk_blas *blas; /* per mesh, then the merged runs' (mesh_count + run) */
    fvk_tlas tlas;
    fvk_instance *inst; /* the TLAS's instances */
    /* Static instances merged (fvk_scene_frame, merge_static): each run of consecutive
     * instances that never move is one BLAS of their meshes as placed, one TLAS instance whose
     * custom index is the run's first instance; the shaders add gl_GeometryIndexEXT (one
     * geometry per instance, in order), so a hit names the scene's instance as before. */
    bool merge_tried, unmerged; /* unmerged: a merged instance moved after all */
    uint32_t run_count;
    uint32_t *run_of;  /* per instance: its run + 1 (0: an instance of its own) */
    uint32_t *run_first;
    float *last_xf;    /* per instance, the transform of the last TLAS build */
    tnd_light_list light_list;
    double tlas_ms;
    /* pipeline */
    VkDescriptorSetLayout set_layout[2];
    VkPipelineLayout layout;
    /* The passes, twice (fvk_pt.c need_passes): [0] the real-time frame's (the real-time sample
     * word only, built for the frame's bounce count and --bounces half or not), [1] every sample
     * word, bounce count and resolution (references, matched references; TND_USES_REFERENCE).
     * Each made when first needed. */
    struct fvk_passes {
        VkPipeline pipeline;  /* ray-tracing pipeline (FVK_RT_PIPELINE) */
        tnd_sbt sbt;
        VkPipeline compute[3]; /* primary, shade, reference (FVK_RT_QUERY) */
        uint32_t bounces_spec; /* the bounces they are built for + 1 (0: the frame's) */
        uint32_t half_spec;    /* built for the indirect paths of every pixel (1), of half (2),
                                  or as the frame says (0) */
    } passes[2];
    int bound;                /* the passes bind_all bound last (what launch launches) */
    bool references;          /* fvk_desc.references: every frame with the reference passes */
    bool specialise;          /* fvk_desc.specialise resolved: false, every frame with them too */
    VkPipeline matched;       /* pt_matched.comp: a matched reference's sample summed */
    tnd_image accum;          /* reference accumulation (rgb sum, luminance^2 sum) */
    fvk_rt_api api;
    uint32_t uses;            /* TND_USES_*: the specialization of every pass */
    uint32_t reflect_depth;   /* specular vertices of the primary chain (frame params.w) */
    float footprint_scale;    /* the ray cones' spread over the traced pixel's (fvk_desc) */
    uint32_t ref_bounces;     /* fvk_set_reference_bounces (0: full paths; frame params.x) */
    char variant[160];
    VkDescriptorPool pool;
    VkDescriptorSet sets[2];
    /* The scene set again, its gradient binding (11) at the back-end's per-stratum list
     * (fvk_shade_gradient_slots), so that pointing it there never touches the set a submitted
     * render uses. */
    VkDescriptorSet slot_set;
    VkBuffer slot_buffer; /* what slot_set's binding 11 points at (VK_NULL_HANDLE: ours) */
    bool slot_set_queued; /* a submission not yet waited for binds slot_set */
    /* The passes' submissions: render (primary + shading) and the gradient launches, each with its
     * own fence and timer. Neither is waited for when submitted; every entry point that writes
     * what a submitted pass reads (the scene buffers, descriptor sets, the frame parameters'
     * shadow is not among them: each command buffer carries its own copy) settles first. */
    tnd_pending run[2];
    /* A render in two submissions (fvk_render_primary, then fvk_render_shade as run[0]): the
     * primary pass's, its times in timer[0] with the shading pass's, read once run[0] is done
     * (a fence covers every earlier submission) */
    tnd_pending primary_run;
    bool primary_open; /* a primary pass was submitted without its shading pass yet */
    tnd_timer timer[2];
    bool due[2];            /* run[i]'s timestamps are still to be read */
    double due_tlas_ms;     /* tlas_ms of the render in flight */
    fvk_timings last;       /* the times read last (render, then its gradient launch) */
    tnd_gpu_frame ubo;      /* the frame parameters, copied into frame_ubo by each submission */
    /* frame */
    tnd_contract_gpu contract;
    uint32_t width, height, frame;
    bool have_frame;
};

tnd_result fvk_scene_upload(fvk_context *c);
void fvk_scene_free(fvk_context *c);
tnd_result fvk_scene_frame(fvk_context *c, const tnd_scene_state *cur, const tnd_scene_state *prev,
                           bool first);

#endif
