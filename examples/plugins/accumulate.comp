#version 450
// examples/plugins/accumulate.comp: plain reprojected temporal accumulation (the accumulate
// plugin). Each pixel's history is fetched at its previous position (the motion vector), with
// bilinear weights over the taps whose stored depth matches the depth the motion predicts; the
// new frame enters with weight 1 / n up to a window of max_frames.
#extension GL_EXT_samplerless_texture_functions : require
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0) uniform texture2D radiance; // Tandem's noisy radiance
layout(set = 0, binding = 1) uniform texture2D motion;   // previous - current: xy pixels, z depth
layout(set = 0, binding = 2) uniform texture2D depth;    // along the primary ray; 1e30 on a miss
layout(set = 0, binding = 3, rgba32f) uniform writeonly image2D result;
layout(set = 0, binding = 4, rgba32f) uniform readonly image2D hist_prev; // rgb, frames
layout(set = 0, binding = 5, r32f) uniform readonly image2D depth_prev;
layout(set = 0, binding = 6, rgba32f) uniform writeonly image2D hist_cur;
layout(set = 0, binding = 7, r32f) uniform writeonly image2D depth_cur;

layout(push_constant) uniform Push {
    uvec2 size;
    uint reset;
    float max_frames;
} pc;

void main()
{
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(uvec2(p), pc.size)))
        return;
    vec3 c = texelFetch(radiance, p, 0).rgb;
    float d = texelFetch(depth, p, 0).r;
    vec3 m = texelFetch(motion, p, 0).xyz;
    bool hit = d < 1e29;
    vec3 h = vec3(0.0);
    float n = 0.0, wsum = 0.0;
    if (pc.reset == 0u && hit) {
        vec2 q = vec2(p) + 0.5 + m.xy - 0.5; // the previous position, in texel-corner units
        ivec2 q0 = ivec2(floor(q));
        vec2 f = q - vec2(q0);
        float expect = d + m.z;
        for (int k = 0; k < 4; k++) {
            ivec2 o = ivec2(k & 1, k >> 1), t = q0 + o;
            if (any(lessThan(t, ivec2(0))) || any(greaterThanEqual(uvec2(t), pc.size)))
                continue;
            float dp = imageLoad(depth_prev, t).r;
            if (abs(dp - expect) > 0.02 * expect)
                continue;
            float w = (o.x == 1 ? f.x : 1.0 - f.x) * (o.y == 1 ? f.y : 1.0 - f.y);
            vec4 hp = imageLoad(hist_prev, t);
            h += w * hp.rgb;
            n += w * hp.a;
            wsum += w;
        }
        if (wsum > 1e-3) {
            h /= wsum;
            n /= wsum;
        } else {
            n = 0.0;
        }
    }
    n = hit ? min(n + 1.0, pc.max_frames) : 0.0;
    vec3 r = hit ? mix(h, c, 1.0 / n) : c;
    imageStore(result, p, vec4(r, 1.0));
    imageStore(hist_cur, p, vec4(r, n));
    imageStore(depth_cur, p, vec4(hit ? d : 1e30));
}
