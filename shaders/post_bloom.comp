/* post_bloom.comp: bloom in linear HDR (after TAA, before tone mapping). index 0: 4x4 box
 * downsample into bloom[0] (1/4 resolution); 1: horizontal Gaussian bloom[0] -> bloom[1];
 * 2: vertical bloom[1] -> bloom[0]. sigma in quarter-res pixels, taps to 3 sigma; weights are
 * normalised over the taps inside the image (no darkening at borders). The tone-mapping pass
 * mixes it in. */
#version 460
#extension GL_GOOGLE_include_directive : require
#include "post_common.glsl"

void main()
{
    ivec2 s = ivec2(gl_GlobalInvocationID.xy);
    ivec2 qs = (img_size() + 3) / 4;
    if (s.x >= qs.x || s.y >= qs.y)
        return;
    if (pc.index == 0u) {
        vec3 sum = vec3(0.0);
        float n = 0.0;
        for (int j = 0; j < 4; j++)
            for (int i = 0; i < 4; i++) {
                ivec2 p = s * 4 + ivec2(i, j);
                if (inside(p))
                    sum += load_hdr(p), n += 1.0;
            }
        imageStore(bloom[0], s, vec4(sum / max(n, 1.0), 1.0));
        return;
    }
    uint src = pc.index == 1u ? 0u : 1u;
    ivec2 dir = pc.index == 1u ? ivec2(1, 0) : ivec2(0, 1);
    float sigma = P.bloom.y;
    int r = int(P.bloom.z);
    vec3 sum = vec3(0.0);
    float wsum = 0.0;
    for (int k = -r; k <= r; k++) {
        ivec2 q = s + k * dir;
        if (q.x < 0 || q.y < 0 || q.x >= qs.x || q.y >= qs.y)
            continue;
        float w = exp(-0.5 * float(k * k) / (sigma * sigma));
        sum += w * finite_or_zero(imageLoad(bloom[src], q).rgb);
        wsum += w;
    }
    imageStore(bloom[1u - src], s, vec4(sum / max(wsum, 1e-8), 1.0));
}
