/* core/scene_internal.h: what scene.c and scene_gltf.c share. */
#ifndef TND_SCENE_INTERNAL_H
#define TND_SCENE_INTERNAL_H
#include "core/core.h"

/* Validate a filled scene (indices, finite vertices, degenerate emitters), build the emitter
 * list, propagate animation flags, compute the duration and the features. */
tnd_result scene_finish(tnd_scene *s);
tnd_material_kind scene_classify(const tnd_material *m);
tnd_result scene_load_gltf(const char *path, tnd_scene **scene);

#endif
