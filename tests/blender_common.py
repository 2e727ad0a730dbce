"""tests/blender_common.py: what the scripts Blender runs for the tests share
(tests/cycles_render.py, tests/blender_capture.py): importing a Tandem glTF, and Cycles set up
as an unbiased path tracer (no adaptive sampling, no denoiser, no clamping)."""
import bpy


def import_gltf(path):
    """An empty scene with the glTF imported; its scene."""
    # Debian's Blender 3.4 glTF importer calls numpy.bool, an alias that Debian 12's numpy 1.24
    # has removed ("module 'numpy' has no attribute 'bool'"): give it back the builtin it stood
    # for.
    import numpy

    if "bool" not in numpy.__dict__:
        numpy.bool = bool
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=path)
    return bpy.context.scene


def cycles(scene, size, seed, animated_seed, bounces):
    """Cycles on the CPU at size x size, unbiased, `bounces` of every kind; its settings."""
    scene.render.engine = "CYCLES"
    cy = scene.cycles
    cy.device = "CPU"
    cy.use_adaptive_sampling = False
    cy.use_denoising = False
    cy.seed = seed
    cy.use_animated_seed = animated_seed
    cy.max_bounces = cy.diffuse_bounces = cy.glossy_bounces = cy.transmission_bounces = bounces
    cy.transparent_max_bounces = cy.volume_bounces = bounces
    cy.sample_clamp_direct = cy.sample_clamp_indirect = 0.0
    cy.light_sampling_threshold = 0.0
    scene.render.resolution_x = scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.exposure = 0.0
    return cy
