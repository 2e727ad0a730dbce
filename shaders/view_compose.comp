#version 460
// shaders/view_compose.comp: what `tandem view` shows (viewer/vw_compose.c): image a left of
// the divider and b right of it (split < 0: a alone), both display-encoded RGBA32F, a divider
// line, and the overlay (RGBA8, alpha-blended) at the top-left, into an RGBA8 image.
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0, rgba32f) uniform readonly image2D img_a;
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D img_b;
layout(set = 0, binding = 2, rgba8) uniform readonly image2D overlay;
layout(set = 0, binding = 3, rgba8) uniform writeonly image2D result;
layout(push_constant) uniform Push {
    ivec2 size;
    int split;
    int pad;
    ivec2 overlay_size;
} pc;

void main()
{
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, pc.size)))
        return;
    vec3 c = pc.split < 0 || p.x < pc.split ? imageLoad(img_a, p).rgb : imageLoad(img_b, p).rgb;
    if (pc.split >= 0 && p.x == pc.split)
        c = vec3(1.0, 0.8, 0.2);
    if (all(lessThan(p, pc.overlay_size))) {
        vec4 o = imageLoad(overlay, p);
        c = mix(c, o.rgb, o.a);
    }
    imageStore(result, p, vec4(clamp(c, 0.0, 1.0), 1.0));
}
