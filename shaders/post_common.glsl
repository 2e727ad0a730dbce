/* post_common.glsl: declarations shared by the post passes (composite/). Push constant x = the
 * TAA slot written this frame, y = a pass-specific index. */
#extension GL_GOOGLE_include_directive : require
#include "post_shared.h"
#include "encoding.h"
#ifdef CP_NEEDS_CONTRACT /* only TAA reads the contract (motion): the others need no variants */
#define TND_CONTRACT_SET 1
#include "contract.h"
TND_CONTRACT(TND_CT_DECLARE)
#endif

layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = CP_B_PARAMS, std140) uniform Params { cp_params P; };
layout(set = 0, binding = CP_B_IN, rgba32f) uniform image2D in_hdr;
layout(set = 0, binding = CP_B_TAA, rgba32f) uniform image2D taa[2];
layout(set = 0, binding = CP_B_BLOOM, rgba32f) uniform image2D bloom[2];
layout(set = 0, binding = CP_B_DISPLAY, rgba32f) uniform image2D display;
layout(set = 0, binding = CP_B_HIST, std430) buffer Hist { cp_histogram H; };
layout(push_constant) uniform Push { uint slot; uint index; } pc;

ivec2 img_size() { return ivec2(P.size.xy); }
bool inside(ivec2 p) { return all(greaterThanEqual(p, ivec2(0))) && all(lessThan(p, img_size())); }
float luma(vec3 c) { return dot(c, vec3(0.2126, 0.7152, 0.0722)); }
vec3 finite_or_zero(vec3 v)
{
    return vec3(tnd_nonfinite(v.x) ? 0.0 : v.x, tnd_nonfinite(v.y) ? 0.0 : v.y,
                tnd_nonfinite(v.z) ? 0.0 : v.z);
}
/* the linear HDR image after TAA (or the back-end's output with TAA off) */
vec3 load_hdr(ivec2 p)
{
    vec3 c = (P.size.w & CP_F_TAA) != 0u ? imageLoad(taa[pc.slot], p).rgb : imageLoad(in_hdr, p).rgb;
    return max(finite_or_zero(c), vec3(0.0));
}
