/* core/scene_internal.h: what scene.c and scene_gltf.c share. */
#ifndef TND_SCENE_INTERNAL_H
#define TND_SCENE_INTERNAL_H
#include "core/core.h"

/* Validate a filled scene (indices, finite vertices, degenerate emitters), build the emitter
 * list, propagate animation flags, apply the user's options (o may be NULL), give what is
 * missing its default, compute the duration and the features. */
tnd_result scene_finish(tnd_scene *s, const tnd_scene_options *o);
/* Where the default camera frames the bounds lo..hi from: their centre c, bounding radius and the
 * distance at which that sphere fills the default field of view less the margin. */
void scene_default_view(const double lo[3], const double hi[3], double c[3], double *rad,
                        double *dist);
/* The camera path o->camera_path over the bounds lo..hi as camera 0 (core/camera_path.c). */
tnd_result scene_camera_path(tnd_scene *s, const tnd_scene_options *o, const double lo[3],
                             const double hi[3]);
tnd_material_kind scene_classify(const tnd_material *m);
tnd_result scene_load_gltf(const char *path, const tnd_scene_options *o, tnd_scene **scene);
/* OBJ + MTL, FBX, Collada, PLY, STL, 3DS through assimp alone (materials by the MTL rule). */
tnd_result scene_load_assimp(const char *path, const tnd_scene_options *o, tnd_scene **scene);

#endif
