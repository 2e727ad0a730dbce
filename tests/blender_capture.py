"""tests/blender_capture.py: a real Blender Cycles capture for tests/test_blender_capture.py.
Run as
    blender -b --factory-startup -P tests/blender_capture.py -- SCENE.gltf OUTDIR FRAMES SIZE SPP REF_SPP

Imports SCENE.gltf (a Tandem scene, with its camera), makes its camera dolly towards the scene by
2% of its distance per frame, and renders FRAMES frames at SIZE x SIZE:
- OUTDIR/capture/frame_NNNN.exr: multilayer EXR of view layer "ViewLayer" with the passes
  data/mappings/blender_cycles.json reads: Combined, Z, Vector, Normal, Emission and Cycles'
  denoising data (Denoising Albedo, Normal, Depth), at SPP samples, no denoiser,
  no motion blur (the Vector pass needs it off);
- OUTDIR/capture_default/frame_NNNN.exr: the same with Blender's default passes (Combined, Z)
  plus Denoising Data and Vector only: no Emission, no Normal pass;
- OUTDIR/converged/frame_NNNN.exr: the same frames' Combined at REF_SPP samples.
Materials are as the importer makes them (Principled BSDF). Frames are numbered from 0 in the
files (Blender's frame 1 is frame_0000)."""
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from blender_common import cycles, import_gltf  # noqa: E402

argv = sys.argv[sys.argv.index("--") + 1:]
scene_path, out_dir = argv[0], argv[1]
frames, size, spp, ref_spp = int(argv[2]), int(argv[3]), int(argv[4]), int(argv[5])

scene = import_gltf(scene_path)
cams = [o for o in scene.objects if o.type == "CAMERA"]
if not cams:
    sys.exit("blender_capture: %s: no camera" % scene_path)
cam = cams[0]
scene.camera = cam
# the camera where the scene has it at its start, free of parents and animation
scene.frame_set(1)
mw = cam.matrix_world.copy()
for o in [cam] + ([cam.parent] if cam.parent else []):
    o.animation_data_clear()
cam.parent = None
cam.matrix_world = mw
# the dolly: along the camera's view direction, 2% of its distance to the origin per frame
forward = -(mw.to_3x3().col[2]).normalized()
start = mw.translation.copy()
dist = start.length
for f in range(frames):
    cam.location = start + forward * (0.02 * dist * f)
    cam.keyframe_insert("location", frame=f + 1)
scene.frame_start, scene.frame_end = 1, frames

world = bpy.data.worlds.new("black")
world.use_nodes = True
world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
scene.world = world

cy = cycles(scene, size, 3, True, 8)
scene.render.use_motion_blur = False

vl = scene.view_layers[0]
vl.name = "ViewLayer"


def render(sub, samples, passes, emit=True):
    cy.samples = samples
    vl.use_pass_z = vl.use_pass_vector = vl.use_pass_normal = vl.use_pass_emit = passes
    vl.cycles.denoising_store_passes = passes
    if not emit:  # Blender's default passes (Combined, Z) + Denoising Data + Vector
        vl.use_pass_normal = vl.use_pass_emit = False
    img = scene.render.image_settings
    img.file_format = "OPEN_EXR_MULTILAYER" if passes else "OPEN_EXR"
    img.color_depth = "32"
    img.exr_codec = "ZIP"
    if not passes:
        img.color_mode = "RGB"
    d = os.path.join(out_dir, sub)
    os.makedirs(d, exist_ok=True)
    for f in range(frames):
        scene.frame_set(f + 1)
        scene.render.filepath = os.path.join(d, "frame_%04d.exr" % f)
        bpy.ops.render.render(write_still=True)


render("capture", spp, True)
render("capture_default", spp, True, emit=False)
render("converged", ref_spp, False)
