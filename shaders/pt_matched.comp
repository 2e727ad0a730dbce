/* pt_matched.comp: one sample of a matched reference, accumulated on the device (the Vulkan
 * front-end's fvk_matched_add): the contract the primary and shading passes just wrote for this
 * sample's key and pixel offset, composited and interleaved exactly as the host does it
 * (core/contract.c: tnd_frame_composite, then tnd_frame_interleave), summed into `accum` (RGB,
 * luminance^2) from the batch's first sample on; the host adds each batch's float sums into its
 * double ones. Interleave: a pixel of a split field is half its own composite and half the mean
 * of its 4-neighbours of the other field, so each such pixel composites its neighbours too. */
#version 460
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 8, local_size_y = 8) in;
#include "brdf.h"
#include "encoding.h"
#define TND_CONTRACT_SET 1
#include "contract.h"
TND_CONTRACT(TND_CT_DECLARE)

layout(set = 0, binding = 13, rgba32f) uniform image2D accum;
layout(push_constant) uniform Push { uint sample_index, batch_first; } pc;

const float SH_C0 = 0.282094791773878;
const float SH_C1 = 0.488602511902920;

#if TND_PACKED
#define LOAD_RGBE(img, p) tnd_rgbe_decode(imageLoad(img, p).x)
#else
#define LOAD_RGBE(img, p) imageLoad(img, p).rgb
#endif

/* the composite of pixel p (tnd_frame_composite, term for term) */
vec3 composite(ivec2 p)
{
    vec3 alb = imageLoad(img_albedo, p).rgb, nrm = imageLoad(img_normal, p).xyz;
    vec3 hf = LOAD_RGBE(img_hf, p), sp = LOAD_RGBE(img_spec, p);
    vec4 sh = imageLoad(img_lf_sh, p);
    vec2 cc = imageLoad(img_lf_cocg, p).xy;
    vec3 thr = imageLoad(img_throughput, p).rgb, em = imageLoad(img_emission, p).rgb;
    float m = imageLoad(img_metallic, p).x;
    float Y = SH_C0 * sh.w + (2.0 / 3.0) * SH_C1 * (nrm.x * sh.x + nrm.y * sh.y + nrm.z * sh.z);
    Y = max(Y, 0.0);
    float s = sh.w / SH_C0;
    float r = s > 0.0 ? Y / s : 0.0;
    float co = cc.x * r, cg = cc.y * r;
    float t = Y - 0.5 * cg, g = cg + t, b = t - 0.5 * co, rr = b + co;
    vec3 lf = vec3(max(rr, 0.0), max(g, 0.0), max(b, 0.0));
    vec3 demod = max(vec3(0.01), 0.04 * (1.0 - m) + alb * m);
    return ((hf + lf) * alb * (1.0 - m) + sp * demod) * thr + em;
}

void main()
{
    ivec2 p = ivec2(gl_GlobalInvocationID.xy), size = imageSize(accum);
    if (p.x >= size.x || p.y >= size.y)
        return;
    vec3 c = composite(p);
    uint path = imageLoad(img_path, p).x;
    if ((path & TND_PATH_SPLIT) != 0u) { /* (tnd_frame_interleave) */
        uint field = path & TND_PATH_REFRACT;
        const ivec2 d[4] = ivec2[4](ivec2(1, 0), ivec2(-1, 0), ivec2(0, 1), ivec2(0, -1));
        vec3 sum = vec3(0.0);
        float n = 0.0;
        for (int k = 0; k < 4; k++) {
            ivec2 q = p + d[k];
            if (q.x < 0 || q.y < 0 || q.x >= size.x || q.y >= size.y)
                continue;
            uint pq = imageLoad(img_path, q).x;
            if ((pq & TND_PATH_SPLIT) != 0u && (pq & TND_PATH_REFRACT) != field) {
                sum += composite(q);
                n += 1.0;
            }
        }
        if (n > 0.0)
            c = 0.5 * c + 0.5 * (sum / n);
    }
    float lum = tnd_luminance(c.r, c.g, c.b);
    vec4 a = pc.sample_index == pc.batch_first ? vec4(0.0) : imageLoad(accum, p);
    imageStore(accum, p, a + vec4(c, lum * lum));
}
