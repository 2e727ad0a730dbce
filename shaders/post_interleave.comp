/* post_interleave.comp: the checkerboard interleave (Q2RTX section 6.1, in Tandem's flat layout).
 * Where the primary path split at a surface that both reflects and refracts (path flag
 * TND_PATH_SPLIT: even x + y took the reflection with weight 2F, odd the refraction with
 * 2(1 - F)), each pixel holds one field; the merged value is 0.5 x its own + 0.5 x the mean of
 * its cross neighbours of the other field (F x reflection + (1 - F) x refraction on average).
 * Other pixels pass through. Writes the flat image the later passes read. */
#version 460
#extension GL_GOOGLE_include_directive : require
#define CP_NEEDS_CONTRACT
#include "post_common.glsl"

layout(set = 0, binding = CP_B_FLAT, rgba32f) uniform image2D flat_img;

void main()
{
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (!inside(p))
        return;
    vec4 c = imageLoad(in_hdr, p);
    uint path = imageLoad(img_path, p).x;
    if ((path & TND_PATH_SPLIT) != 0u) {
        uint field = path & TND_PATH_REFRACT;
        vec3 sum = vec3(0.0);
        float n = 0.0;
        const ivec2 cross4[4] = ivec2[4](ivec2(1, 0), ivec2(-1, 0), ivec2(0, 1), ivec2(0, -1));
        for (int k = 0; k < 4; k++) {
            ivec2 q = p + cross4[k];
            if (!inside(q))
                continue;
            uint pq = imageLoad(img_path, q).x;
            if ((pq & TND_PATH_SPLIT) != 0u && (pq & TND_PATH_REFRACT) != field) {
                sum += finite_or_zero(imageLoad(in_hdr, q).rgb);
                n += 1.0;
            }
        }
        if (n > 0.0)
            c.rgb = 0.5 * finite_or_zero(c.rgb) + 0.5 * (sum / n);
    }
    imageStore(flat_img, p, c);
}
