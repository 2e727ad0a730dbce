/* ReSTIR DI (`--lights restir`; Bitterli et al. 2020, with the generalized balance heuristic of
 * Lin et al. 2022 for unbiased reuse): the constants and records both front-ends share. The
 * Embree front-end's frontend_embree/femb_restir.c describes the algorithm; the Vulkan
 * front-end's shaders/pt_restir.glsl mirrors it on the same random numbers.
 *
 * A sample is (light index, u, v): the light of the list and the two numbers that place a point
 * on it (a triangle's uniform point, the environment map's direction), so that the same sample
 * means the same point on the emitter from any surface. Targets are measured on the emitter (area
 * for triangles, direction for the environment and directional lights, the point itself for point
 * and spot lights): moving a sample between pixels needs no Jacobian. */
#ifndef TND_RESTIR_H
#define TND_RESTIR_H

/* candidates per pixel and frame, drawn by the light tree (or the power table) */
#define TND_RESTIR_CANDIDATES 4u
/* the previous frame's reservoir counts at most this many times the candidates (its history
 * fades; Bitterli et al.'s 20) */
#define TND_RESTIR_HISTORY 1u
/* spatial neighbours merged per pixel */
#define TND_RESTIR_NEIGHBOURS 3u
/* a neighbour or a previous pixel is merged only where its surface is like the pixel's: normals
 * within acos(0.9), distances from the camera within 10% */
#define TND_RESTIR_NORMAL_DOT 0.9f
#define TND_RESTIR_DEPTH_REL 0.1f
/* surfaces under this perceptual roughness keep next-event estimation with MIS (light samples
 * cannot find a sharp highlight that a BRDF sample finds) */
#define TND_RESTIR_MIN_ROUGHNESS 0.2f

/* pdf_prev of a path whose previous vertex took the light list's whole share by a reservoir: an
 * emitter of the list, or the environment map, that its BRDF sample finds gets weight 0 */
#define TND_PDF_RESERVOIR (-1.0f)

/* The Vulkan front-end's reservoir and surface records (binding 19: the two frames' final
 * reservoirs, W x H each, then this frame's after the temporal merge; binding 20: the two frames'
 * surfaces). */
#ifdef TND_GLSL
struct tnd_gpu_reservoir {
    uvec4 a; /* light, u bits, v bits, W bits */
    vec4 b;  /* M, 0, 0, 0 */
};
struct tnd_gpu_rsurf {
    vec4 p;    /* xyz, w: distance from the camera */
    vec4 ns;   /* xyz, w: perceptual roughness */
    vec4 ng;   /* xyz, w: metallic */
    vec4 wo;   /* xyz, w: the material's specular factor */
    vec4 base; /* rgb */
};
#else
enum { TND_GPU_RESERVOIR_BYTES = 32, TND_GPU_RSURF_BYTES = 80 };
#endif

#endif
