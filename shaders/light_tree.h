/* The light tree both front-ends sample for next-event estimation (`--lights tree`), shared by C
 * and GLSL: its node layout, a node's importance for a shading point, the pick by descent and
 * the probability of a given light (for MIS). core/lights.c builds it beside the light list
 * (shaders/lights.h), frontend_embree reads the array, frontend_vk uploads it as a storage
 * buffer. Written from the published method (Conty Estevez and Kulla, HPG 2018; the bounds as
 * pbrt-v4's book describes them), not from code.
 *
 * A binary tree over the list's lights. The root's two children are the local lights' subtree
 * (emissive triangles, point and spot lights) and the infinite lights' (directional lights, the
 * environment map), each weighed by its power alone (TND_LT_POWER_ONLY): the infinite lights
 * keep the plain list's probabilities (so the environment map's pick for MIS is the list's), and
 * the local ones share the local lights' total of them. Inside the local subtree a node is
 * weighed by its importance for the shading point p: power x cos(theta') / d^2, where d is the
 * distance from p to the centre of the node's bounding box (at least half its diagonal) and
 * theta' the smallest angle, over the box, between the emitters' normal cone (axis, theta_o)
 * and the direction to p, less theta_e (the spread of emission about a normal: pi/2 for a
 * Lambertian emitter); 0 where theta' >= theta_e (no emitter of the node faces p). The bound is
 * conservative: a node that can light p never weighs 0, so the estimator stays unbiased.
 * A node holds what the importance needs, made once on the host (in double, rounded once): the
 * box's centre and half-diagonal r (the box's angle from p: sin theta_b = r / d), and the
 * cone's cos and sin theta_o, so that theta' is found by the angle-difference identities
 * (cos(a - b) = cos a cos b + sin a sin b, sin(a - b) = sin a cos b - cos a sin b) with two
 * square roots beside the 1 / d the direction needs, and no other division: the descent's
 * arithmetic was half or more of the tree's cost on the GPU (docs/lights.md).
 * A descent picks a child in proportion to the two children's importances, remapping the one
 * uniform into the chosen interval, down to a leaf (one light each); the pick's probability is
 * the product of the choices'. A light's path from the root (one bit per level, 0 = link.x) is
 * kept in its list record (tnd_light_gpu.p2.w, the bits as a float), so that the probability of
 * a light a BRDF sample hits is the same product, recomputed (tnd_lt_pmf).
 * The receiver's normal is not used (a point behind a surface still counts its lights). */
#ifndef TND_LIGHT_TREE_H
#define TND_LIGHT_TREE_H

#define TND_LT_LEAF 1u
#define TND_LT_TWO_SIDED 2u  /* the node holds a two-sided emitter: either side of the cone */
#define TND_LT_POWER_ONLY 4u /* weighed by its power alone (the root's two groups, infinite) */
#define TND_LT_MAX_DEPTH 32u /* the builder splits at the median: depth <= ceil(log2 n) + 1 */

#ifndef TND_GLSL
#include <math.h>
#include <stdint.h>
typedef struct { float x, y, z, w; } tnd_ltvec4;
typedef struct { uint32_t x, y, z, w; } tnd_ltuvec4;
#define vec4 tnd_ltvec4
#define uvec4 tnd_ltuvec4
#endif

struct tnd_light_node {
    vec4 centre; /* the bounding box's centre; w: power (the list's flux, summed) */
    vec4 axis;   /* the normal cone's unit axis; w: cos theta_o (the normals within theta_o) */
    vec4 cone;   /* x: sin theta_o, y: cos theta_e, z: r^2 and w: r, r half the box's diagonal */
    uvec4 link;  /* x, y: the children (a leaf: x its light's index in the list); z: flags */
};

#if defined(TND_GLSL) && defined(TND_LT_BINDING) /* the shader's buffer of them */
layout(set = TND_LT_SET, binding = TND_LT_BINDING, std430) readonly buffer LightNodes {
    tnd_light_node light_nodes[];
};
#endif

#ifndef TND_GLSL
#undef vec4
#undef uvec4
typedef struct tnd_light_node tnd_light_node;
_Static_assert(sizeof(tnd_light_node) == 64, "tnd_light_node is 4 vec4");
#define TND_LT_FN static inline
#define TND_LT_U32 uint32_t
#define TND_LT_ARG const tnd_light_node *light_nodes,
#define TND_LT_PASS light_nodes,
#define TND_LT_SQRT sqrtf
#define TND_LT_MAX fmaxf
#define TND_LT_MIN fminf
#define TND_LT_ABS fabsf
#else
#define TND_LT_FN
#define TND_LT_U32 uint
#define TND_LT_ARG
#define TND_LT_PASS
#define TND_LT_SQRT sqrt
#define TND_LT_MAX max
#define TND_LT_MIN min
#define TND_LT_ABS abs
#endif

/* Node i's importance for shading point (px, py, pz). */
TND_LT_FN float tnd_lt_importance(TND_LT_ARG TND_LT_U32 i, float px, float py, float pz)
{
    float power = light_nodes[i].centre.w;
    if (!(power > 0.0f))
        return 0.0f;
    if ((light_nodes[i].link.z & TND_LT_POWER_ONLY) != 0u)
        return power;
    float dx = px - light_nodes[i].centre.x, dy = py - light_nodes[i].centre.y;
    float dz = pz - light_nodes[i].centre.z;
    float dd = dx * dx + dy * dy + dz * dz, r2 = light_nodes[i].cone.z;
    float d2 = TND_LT_MAX(dd, r2);
    /* the angle between the cone's axis and the direction from the box's centre to p */
    float inv = dd > 0.0f ? 1.0f / TND_LT_SQRT(dd) : 0.0f;
    float cos_w = (light_nodes[i].axis.x * dx + light_nodes[i].axis.y * dy +
                   light_nodes[i].axis.z * dz) * inv;
    if ((light_nodes[i].link.z & TND_LT_TWO_SIDED) != 0u)
        cos_w = TND_LT_ABS(cos_w);
    if (!(dd > 0.0f))
        cos_w = 1.0f; /* p at the centre: any direction */
    cos_w = TND_LT_MIN(TND_LT_MAX(cos_w, -1.0f), 1.0f);
    /* theta' = max(0, theta_w - theta_o - theta_b): 0 where the cone holds the direction (the
     * box's own angle need not be known then), and where p is inside the box's sphere */
    float cos_p = 1.0f, cos_o = light_nodes[i].axis.w;
    if (cos_w < cos_o && dd > r2) {
        float sin_o = light_nodes[i].cone.x;
        float sin_w = TND_LT_SQRT(TND_LT_MAX(0.0f, 1.0f - cos_w * cos_w));
        float cos_x = cos_w * cos_o + sin_w * sin_o; /* theta_x = theta_w - theta_o > 0 */
        float sin_x = TND_LT_MAX(0.0f, sin_w * cos_o - cos_w * sin_o);
        float sin_b = light_nodes[i].cone.w * inv; /* r / d < 1 */
        float cos_b = TND_LT_SQRT(TND_LT_MAX(0.0f, 1.0f - sin_b * sin_b));
        if (cos_x < cos_b)
            cos_p = cos_x * cos_b + sin_x * sin_b;
    }
    if (cos_p <= light_nodes[i].cone.y)
        return 0.0f;
    return power * cos_p / d2;
}

/* Descend from the root by u in [0, 1) for shading point p: the light's index in the list and
 * its probability (0 and TND_LT_NONE where no light can reach p). */
#define TND_LT_NONE 0xFFFFFFFFu
#ifdef TND_GLSL
uint tnd_lt_sample(float px, float py, float pz, float u, out float pmf)
#else
static inline uint32_t tnd_lt_sample(const tnd_light_node *light_nodes, float px, float py,
                                     float pz, float u, float *pmf_out)
#endif
{
    TND_LT_U32 node = 0u;
    float p = 1.0f;
    for (TND_LT_U32 depth = 0u; depth <= TND_LT_MAX_DEPTH; depth++) {
        if ((light_nodes[node].link.z & TND_LT_LEAF) != 0u) {
#ifdef TND_GLSL
            pmf = p;
#else
            *pmf_out = p;
#endif
            return light_nodes[node].link.x;
        }
        TND_LT_U32 a = light_nodes[node].link.x, b = light_nodes[node].link.y;
        float ia = tnd_lt_importance(TND_LT_PASS a, px, py, pz);
        float ib = tnd_lt_importance(TND_LT_PASS b, px, py, pz);
        float s = ia + ib;
        if (!(s > 0.0f))
            break;
        float pa = ia / s;
        if (u < pa) {
            node = a;
            p *= pa;
            u = TND_LT_MIN(u / pa, 0.99999994f);
        } else {
            node = b;
            p *= 1.0f - pa;
            u = TND_LT_MIN((u - pa) / (1.0f - pa), 0.99999994f);
        }
    }
#ifdef TND_GLSL
    pmf = 0.0f;
#else
    *pmf_out = 0.0f;
#endif
    return TND_LT_NONE;
}

/* The probability that tnd_lt_sample picks the light whose path from the root is `trail` (bit k:
 * the child at depth k, 1 = link.y), for shading point p. */
TND_LT_FN float tnd_lt_pmf(TND_LT_ARG TND_LT_U32 trail, float px, float py, float pz)
{
    TND_LT_U32 node = 0u;
    float p = 1.0f;
    for (TND_LT_U32 depth = 0u; depth < TND_LT_MAX_DEPTH; depth++) {
        if ((light_nodes[node].link.z & TND_LT_LEAF) != 0u)
            return p;
        TND_LT_U32 a = light_nodes[node].link.x, b = light_nodes[node].link.y;
        float ia = tnd_lt_importance(TND_LT_PASS a, px, py, pz);
        float ib = tnd_lt_importance(TND_LT_PASS b, px, py, pz);
        float s = ia + ib;
        if (!(s > 0.0f))
            return 0.0f;
        float pa = ia / s;
        bool right = ((trail >> depth) & 1u) != 0u;
        p *= right ? 1.0f - pa : pa;
        node = right ? b : a;
    }
    return (light_nodes[node].link.z & TND_LT_LEAF) != 0u ? p : 0.0f;
}

#endif
