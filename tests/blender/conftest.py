"""Blender test set-up: the addon from this checkout, enabled through addon_utils."""
import os
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "addon"))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import addon_utils  # noqa: E402
import bpy  # noqa: E402


def pytest_configure(config):
    addon_utils.enable("gradphoton", default_set=True, handle_error=lambda e: (_ for _ in ()).throw(e))


@pytest.fixture
def empty_scene():
    """The current scene emptied of objects and data, gradphoton selected, tiny resolution."""
    for coll in (bpy.data.objects, bpy.data.meshes, bpy.data.materials, bpy.data.lights, bpy.data.cameras,
                 bpy.data.collections, bpy.data.worlds):
        for item in list(coll):
            coll.remove(item)
    scene = bpy.context.scene
    scene.world = bpy.data.worlds.new("World")
    scene.render.engine = "GRADPHOTON"
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 32, 24, 100
    scene.render.use_border = False
    scene.render.use_motion_blur = False  # the motion blur tests turn it on
    scene.render.film_transparent = False  # the Film > Transparent tests turn it on
    # Settings persist in the scene across tests: start each from the addon's defaults.
    for prop in scene.gradphoton.bl_rna.properties:
        if prop.identifier != "rna_type":
            scene.gradphoton.property_unset(prop.identifier)
    scene.gradphoton.stop_rule = 'PASSES'
    scene.gradphoton.passes = 2
    scene.gradphoton.threads = 2
    scene.view_layers[0].name = "ViewLayer"
    return scene


@pytest.fixture
def out_dir(tmp_path):
    return tmp_path
