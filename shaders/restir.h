/* ReSTIR DI (`--lights restir`; Bitterli et al. 2020, with the generalized balance heuristic of
 * Lin et al. 2022 for unbiased reuse): the constants both front-ends are to share. The Embree
 * front-end runs it today (frontend_embree/femb_restir.c, which describes the algorithm); the
 * Vulkan front-end refuses the mode until it has the same passes.
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

#endif
