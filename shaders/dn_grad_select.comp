/* dn_grad_select.comp: A-SVGF's gradient samples (Schied et al. 2018; Q2RTX's choice rules): one
 * per 3x3 stratum, among the stratum's pixels whose surface was visible in the previous frame at
 * the motion's target (same instance, depth within 10%, geometric normal within 25 degrees), that
 * were not last frame's gradient sample (reusing a random sequence twice biases), picking the
 * brightest previous hf + spec (a random pick in a moving penumbra often misses the change; ties:
 * the first in row order). Writes the sample (pixel, the previous frame's rng key and surface) for
 * the front-end to re-shade (the composite looks its pixels up there too: no per-pixel mask), the
 * sample's previous luminances (grad[0].zw), and the stratum's sum of the accumulated lf L0 history
 * at the reprojected pixels (grad[0].y) for dn_gradients.comp (here, where the pixels are visited
 * anyway; the sum of the raw L0 now is dn_gradients.comp's, after the re-shading). It reads only
 * the primary pass's G-buffer of this frame: the Vulkan front-end runs it between its primary and
 * its shading pass, which re-shades the samples in place (docs/denoise.md). A non-finite motion
 * counts as none.
 * One thread per pixel tests its pixel; one thread per stratum then picks among the nine through
 * shared memory (a thread per stratum doing the nine tests itself is latency-bound: nine chains of
 * dependent loads). */
#version 460
#extension GL_GOOGLE_include_directive : require
#define DN_STRATUM_TILES 1
#include "dn_common.glsl"

shared float s_score[DN_TILE_N];  /* previous hf + spec luminance of a candidate, else 0 */
shared uint s_target[DN_TILE_N];  /* its reprojected pixel, x | y << 16 */
shared float s_hist[DN_TILE_N];   /* the accumulated lf L0 at the reprojection */

void main()
{
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    uint li = gl_LocalInvocationIndex;
    float score = 0.0;
    ivec2 pp = ivec2(0);
    float hist = 0.0;
    if (inside(p) && P.size.z != 0u) {
        uvec2 vis = imageLoad(img_vis_id, p).xy;
        vec3 m = imageLoad(img_motion, p).xyz;
        if (tnd_nonfinite(m.x) || tnd_nonfinite(m.y))
            m = vec3(0.0);
        /* the previous frame's sample nearest this frame's sample point (the jitters apart),
         * whose surface and random numbers a gradient re-shades */
        pp = ivec2(floor(vec2(p) + P.jitter.xy + m.xy - P.jitter.zw + 0.5));
        if (vis.x != TND_VIS_NONE) {
            /* a history is its pixel's mean: the pixel's own footprint moved (no jitter, as the
             * temporal pass reads it), or a still image would compare with a neighbour's */
            ivec2 pf = ivec2(floor(vec2(p) + m.xy + 0.5));
            float l0 = inside(pf) ? hist_lf_l0(imageLoad(hist_lf[1u - pc.slot], pf)) : 0.0;
            hist = tnd_nonfinite(l0) ? 0.0 : l0;
        }
        uvec4 g = inside(pp) ? imageLoad(prev_geo, pp) : uvec4(TND_VIS_NONE, 0u, 0u, 0u);
        if (vis.x != TND_VIS_NONE && g.x == vis.x) {
            float depth = imageLoad(img_depth, p).x;
            uint field = imageLoad(img_path, p).x & (TND_PATH_SPLIT | TND_PATH_REFRACT);
            /* g.z: bits 24-25 the field, bit 26 was last frame's sample */
            if (((g.z >> 24u) & 7u) == field &&
                abs(uintBitsToFloat(g.y) - (depth + m.z)) <= 0.1 * depth &&
                dot(oct_unpack12(g.z), imageLoad(img_geo_normal, p).xyz) >= 0.9) {
                vec2 pl = prev_lum_unpack(imageLoad(prev_lum, pp).x);
                float l = pl.x + pl.y;
                score = l > 0.0 ? l : 0.0; /* NaN: not a candidate */
            }
        }
    }
    s_score[li] = score;
    s_hist[li] = hist;
    s_target[li] = score > 0.0 ? uint(pp.x) | uint(pp.y) << 16u : 0u;
    barrier();
    if (li < DN_TILE_STRATA) {
        ivec2 s = tile_stratum(li);
        ivec2 gs = grad_size();
        uint best_k = ~0u;
        if (s.x < gs.x && s.y < gs.y) {
            float best = 0.0;
            for (int j = 0; j < DN_STRATUM; j++)
                for (int i = 0; i < DN_STRATUM; i++) {
                    uint k = tile_pixel_index(li, i, j);
                    if (s_score[k] > best) {
                        best = s_score[k];
                        best_k = k;
                    }
                }
            tnd_gpu_gradient smp;
            smp.a = uvec4(TND_GRADIENT_NONE, 0u, 0u, 0u);
            smp.b = uvec4(0u);
            smp.c = vec4(0.0); /* (the front-end's re-shading writes c and d) */
            smp.d = vec4(0.0);
            vec4 gout = vec4(0.0);
            if (best_k != ~0u) {
                ivec2 best_p = tile_pixel(best_k);
                ivec2 best_pp = ivec2(s_target[best_k] & 0xffffu, s_target[best_k] >> 16u);
                vec2 pl = prev_lum_unpack(imageLoad(prev_lum, best_pp).x);
                uvec2 key = imageLoad(prev_key, best_pp).xy;
                uint inst = imageLoad(prev_geo, best_pp).x;
                uvec4 ps = imageLoad(prev_surf, best_pp); /* primitive, barycentrics */
                smp.a = uvec4(uint(best_p.y) * P.size.x + uint(best_p.x), key, inst);
                smp.b = uvec4(ps.x, ps.y, ps.z, 1u);
                gout = vec4(0.0, 0.0, pl.x, pl.y);
            }
            samples[uint(s.y * gs.x + s.x)] = smp;
            float sum = 0.0;
            for (int j = 0; j < DN_STRATUM; j++)
                for (int i = 0; i < DN_STRATUM; i++)
                    sum += s_hist[tile_pixel_index(li, i, j)];
            imageStore(grad[0], s, vec4(0.0, sum, gout.zw));
        }
    }
}
