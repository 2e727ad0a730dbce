"""tests/cycles_render.py: render a glTF scene with Blender Cycles the way Tandem's reference
models it, for tests/test_cycles.py. Run as
    blender -b --factory-startup -P tests/cycles_render.py -- SCENE.gltf OUT.exr SPP SIZE SEED

What makes the two model the same thing (docs/platform.md): every material becomes a Diffuse
BSDF of the glTF base colour with roughness 0 (Lambert; the scenes use KHR_materials_specular
specularFactor 0, so Tandem's material is Lambert too); an emissive material adds an Emission of
emissiveFactor x KHR_materials_emissive_strength (radiance, as Tandem's nits) on its front face
only, unless the material is doubleSided (Cycles' mesh emission is two-sided by itself); a black
world, or the scene's tandem_env as an Environment Texture (equirectangular, Closest: the nearest
texel, as Tandem reads it; strength = its intensity); a box pixel filter one pixel wide
(Tandem's reference jitters uniformly over the pixel);
128 bounces, no clamping, no light threshold, no adaptive sampling, no denoising; linear float
EXR."""
import json
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from blender_common import cycles, import_gltf  # noqa: E402

argv = sys.argv[sys.argv.index("--") + 1:]
scene_path, out_path, spp, size, seed = argv[0], argv[1], int(argv[2]), int(argv[3]), int(argv[4])

import_gltf(scene_path)
with open(scene_path) as f:
    doc = json.load(f)

for m in doc.get("materials", []):
    mat = bpy.data.materials.get(m["name"])
    if mat is None:
        sys.exit("cycles_render: %s: material '%s' was not imported" % (scene_path, m["name"]))
    mat.use_backface_culling = False
    mat.use_nodes = True
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    nodes.clear()
    out = nodes.new("ShaderNodeOutputMaterial")
    base = m.get("pbrMetallicRoughness", {}).get("baseColorFactor", [1, 1, 1, 1])
    diffuse = nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (base[0], base[1], base[2], 1.0)
    diffuse.inputs["Roughness"].default_value = 0.0
    shader = diffuse.outputs["BSDF"]
    e = m.get("emissiveFactor", [0, 0, 0])
    k = m.get("extensions", {}).get("KHR_materials_emissive_strength", {}).get(
        "emissiveStrength", 1.0)
    if max(e) > 0:
        emit = nodes.new("ShaderNodeEmission")
        emit.inputs["Color"].default_value = (e[0] * k, e[1] * k, e[2] * k, 1.0)
        emit.inputs["Strength"].default_value = 1.0
        add = nodes.new("ShaderNodeAddShader")
        links.new(emit.outputs["Emission"], add.inputs[0])
        links.new(diffuse.outputs["BSDF"], add.inputs[1])
        shader = add.outputs["Shader"]
        if not m.get("doubleSided", False):  # the back face: the diffuse part alone
            geo = nodes.new("ShaderNodeNewGeometry")
            mix = nodes.new("ShaderNodeMixShader")
            links.new(geo.outputs["Backfacing"], mix.inputs["Fac"])
            links.new(add.outputs["Shader"], mix.inputs[1])
            links.new(diffuse.outputs["BSDF"], mix.inputs[2])
            shader = mix.outputs["Shader"]
    links.new(shader, out.inputs["Surface"])

scene = bpy.context.scene
cams = [o for o in scene.objects if o.type == "CAMERA"]
if not cams:
    sys.exit("cycles_render: %s: no camera" % scene_path)
scene.camera = cams[0]
yfov = doc["cameras"][0]["perspective"]["yfov"]
cams[0].data.sensor_fit = "VERTICAL"
cams[0].data.angle_y = yfov

world = bpy.data.worlds.new("world")
world.use_nodes = True
bg = world.node_tree.nodes["Background"]
env = doc["scenes"][0].get("extras", {}).get("tandem_env")
if env is None:
    bg.inputs["Strength"].default_value = 0.0  # black
else:
    # the environment map as Tandem reads it: the nearest texel (Closest), equirectangular,
    # strength = intensity; unrotated (the scenes here use rotation 0)
    if env.get("rotation", 0) != 0:
        sys.exit("cycles_render: %s: tandem_env rotation is not modelled here" % scene_path)
    uri = env["uri"]
    if not uri.startswith("/"):
        uri = os.path.join(os.path.dirname(os.path.abspath(scene_path)), uri)
    tex = world.node_tree.nodes.new("ShaderNodeTexEnvironment")
    tex.image = bpy.data.images.load(uri)
    tex.image.colorspace_settings.name = "Linear"
    tex.interpolation = "Closest"
    tex.projection = "EQUIRECTANGULAR"
    world.node_tree.links.new(tex.outputs["Color"], bg.inputs["Color"])
    bg.inputs["Strength"].default_value = env.get("intensity", 1.0)
scene.world = world

cy = cycles(scene, size, seed, False, 128)
cy.samples = spp
cy.pixel_filter_type = "BOX"
cy.filter_width = 1.0
scene.render.film_transparent = False
scene.render.image_settings.file_format = "OPEN_EXR"
scene.render.image_settings.color_depth = "32"
scene.render.image_settings.exr_codec = "NONE"
scene.render.image_settings.color_mode = "RGB"
scene.render.filepath = out_path
bpy.ops.render.render(write_still=True)
