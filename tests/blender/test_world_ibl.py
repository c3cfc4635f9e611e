"""Image-based lighting from the World's node tree (export/world.py, lights/environment_map):
the export of Environment Texture -> Background with Texture Coordinate and Mapping, and, in
real Blender, gradphoton against Cycles on one of Blender's own HDRIs: the background seen by
the camera turned by a Mapping rotation (orientation, filtering), and a diffuse floor lit only
by the HDRI (importance sampling, brightness). Small images, seeded: the bounds are about
twice what was measured (docs/blender.md)."""
import math
import os

import bpy
import numpy as np
import pytest

import scenes
from gradphoton import export, native

HDRI_DIR = "/usr/share/blender/datafiles/studiolights/world"
HDRI = os.path.join(HDRI_DIR, "forest.exr")
needs_hdri = pytest.mark.skipif(not os.path.isfile(HDRI), reason="Debian's blender-data HDRIs not installed")


def hdri_world(scene, path=HDRI, rotation_z_deg=0.0, strength=1.0, interpolation='Linear'):
    """World: Texture Coordinate (Generated) -> Mapping (rotation) -> Environment Texture -> Background."""
    w = scene.world
    w.use_nodes = True
    nt = w.node_tree
    bg = nt.nodes.get("Background")
    bg.inputs["Strength"].default_value = strength
    env = nt.nodes.new("ShaderNodeTexEnvironment")
    if os.path.isfile(path):
        env.image = bpy.data.images.load(path, check_existing=True)
    else:  # a file that is gone: an image datablock pointing at it, as a moved .blend has
        env.image = bpy.data.images.new("gone", 4, 4, float_buffer=True)
        env.image.source = 'FILE'
        env.image.filepath = path
    env.interpolation = interpolation
    mapping = nt.nodes.new("ShaderNodeMapping")
    mapping.inputs["Rotation"].default_value = (0.0, 0.0, math.radians(rotation_z_deg))
    coord = nt.nodes.new("ShaderNodeTexCoord")
    nt.links.new(coord.outputs["Generated"], mapping.inputs["Vector"])
    nt.links.new(mapping.outputs["Vector"], env.inputs["Vector"])
    nt.links.new(env.outputs["Color"], bg.inputs["Color"])
    return env, mapping


def export_env():
    return export.export_scene(bpy.context.evaluated_depsgraph_get()).description["environment"]


@needs_hdri
def test_export_reads_environment_texture_and_mapping(empty_scene):
    hdri_world(empty_scene, rotation_z_deg=90.0, strength=2.5, interpolation='Cubic')
    empty_scene.world.cycles.sampling_method = 'MANUAL'
    empty_scene.world.cycles.sample_map_resolution = 512
    env = export_env()
    assert env["type"] == "map" and os.path.samefile(env["image"], HDRI)
    assert env["strength"] == pytest.approx(2.5)
    assert env["interpolation"] == "cubic" and env["projection"] == "equirectangular"
    assert env["sampling_resolution"] == 512
    # Mapping (Point) rotation Z 90: the texture vector is Rz(90) d.
    assert np.allclose(env["transform"], [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-6)


def test_export_is_camera_ray_and_unsupported_nodes(empty_scene):
    """Light Path "Is Camera Ray" into a Mix Shader: camera rays see the second background;
    any other node is one warning naming it."""
    w = empty_scene.world
    w.use_nodes = True
    nt = w.node_tree
    bg = nt.nodes.get("Background")
    bg.inputs["Color"].default_value = (0.2, 0.3, 0.4, 1)
    cam_bg = nt.nodes.new("ShaderNodeBackground")
    cam_bg.inputs["Color"].default_value = (1, 1, 1, 1)
    cam_bg.inputs["Strength"].default_value = 0.5
    mix = nt.nodes.new("ShaderNodeMixShader")
    lp = nt.nodes.new("ShaderNodeLightPath")
    nt.links.new(lp.outputs["Is Camera Ray"], mix.inputs["Fac"])
    nt.links.new(bg.outputs[0], mix.inputs[1])
    nt.links.new(cam_bg.outputs[0], mix.inputs[2])
    out = nt.nodes.get("World Output")
    nt.links.new(mix.outputs[0], out.inputs["Surface"])
    # A node the core does not evaluate (a supported one makes the World a graph: test_world_graph).
    noise = nt.nodes.new("ShaderNodeTexPointDensity")
    nt.links.new(noise.outputs["Color"], cam_bg.inputs["Color"])
    ex = export.export_scene(bpy.context.evaluated_depsgraph_get())
    env = ex.description["environment"]
    assert env["color"] == pytest.approx([0.2, 0.3, 0.4])
    assert env["camera"]["strength"] == pytest.approx(0.5)
    assert any(noise.name in m for m in ex.warnings.lines()), ex.warnings.lines()


def _background_scene(scene, rotation_z_deg):
    hdri_world(scene, rotation_z_deg=rotation_z_deg)
    scenes.add_camera(scene, (0, 0, 0), (1, 0.3, 0.15), lens=20.0)
    scene.render.resolution_x, scene.render.resolution_y = 48, 24


@needs_hdri
@pytest.mark.parametrize("rotation", [0.0, 75.0])
def test_background_turned_by_mapping_matches_cycles(empty_scene, out_dir, rotation):
    """The camera sees only the HDRI: per pixel, gradphoton shows what Cycles shows (same
    orientation, Mapping rotation and bilinear filtering). A wrong sign or axis moves the image
    by many pixels and fails by far."""
    _background_scene(empty_scene, rotation)
    scenes.configure_cycles(empty_scene, 256, 1)
    cycles = native.get().read_exr(scenes.render_to_exr(empty_scene, os.path.join(str(out_dir), "bg_cycles.exr")))["combined"][..., :3]
    empty_scene.render.engine = 'GRADPHOTON'
    g = empty_scene.gradphoton
    g.method, g.stop_rule, g.passes = "pt", "PASSES", 256
    ours = native.get().read_exr(scenes.render_to_exr(empty_scene, os.path.join(str(out_dir), "bg_ours.exr")))["combined"][..., :3]
    ratio = ours.sum() / cycles.sum()
    rel = float(np.mean((ours - cycles) ** 2 / (cycles ** 2 + 0.01)))
    print(f"IBL background rotation {rotation}: gradphoton/cycles = {ratio:.4f}, relMSE {rel:.5f}")
    assert abs(ratio - 1) < 0.01
    assert rel < 0.002


@needs_hdri
def test_floor_lit_by_hdri_matches_cycles(empty_scene, out_dir):
    """A diffuse floor lit only by the HDRI (the sky out of view): importance-sampled map against
    Cycles' background light, image means within 1 %."""
    scenes.brightness_scene(empty_scene, "world")
    empty_scene.world.node_tree.nodes.get("Background").inputs["Color"].default_value = (1, 1, 1, 1)
    hdri_world(empty_scene, rotation_z_deg=30.0)
    empty_scene.render.resolution_x, empty_scene.render.resolution_y = 48, 36
    scenes.configure_cycles(empty_scene, 64, 4)
    cycles = native.get().read_exr(scenes.render_to_exr(empty_scene, os.path.join(str(out_dir), "floor_cycles.exr")))["combined"][..., :3]
    empty_scene.render.engine = 'GRADPHOTON'
    g = empty_scene.gradphoton
    g.method, g.stop_rule, g.passes, g.pt.max_bounces = 'pt', 'PASSES', 64, 4
    ours = native.get().read_exr(scenes.render_to_exr(empty_scene, os.path.join(str(out_dir), "floor_ours.exr")))["combined"][..., :3]
    ratio = ours.sum() / cycles.sum()
    print(f"IBL floor: gradphoton/cycles = {ratio:.4f}")
    assert abs(ratio - 1) < 0.01


def test_missing_hdri_renders_magenta(empty_scene, out_dir):
    """A missing HDRI: the core reads the path, warns once and renders magenta, as Cycles."""
    hdri_world(empty_scene, path=os.path.join(str(out_dir), "gone.exr"))
    assert export_env()["type"] == "map"
    scenes.add_camera(empty_scene, (0, 0, 0), (1, 0, 0), lens=50.0)
    empty_scene.render.resolution_x, empty_scene.render.resolution_y = 8, 8
    g = empty_scene.gradphoton
    g.method, g.stop_rule, g.passes = 'pt', 'PASSES', 1
    img = native.get().read_exr(scenes.render_to_exr(empty_scene, os.path.join(str(out_dir), "magenta.exr")))["combined"]
    assert np.allclose(img[..., :3].reshape(-1, 3).mean(0), [1, 0, 1], atol=1e-4)
