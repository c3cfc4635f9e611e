"""Texture Coordinate's Camera and Window outputs (the scene's camera in the shading context)
against Cycles 3.4 in this Blender: the emission plane of test_nodes_render seen by a
perspective camera with a shift (lens 100 mm, shift x 0.05: the 2 m plane still fills the
frame), its Emission colour the output mapped into [0, 1]. Both outputs are linear in the
frame's coordinates on a plane facing the camera, so a pixel's average is its centre's value:
every pixel within TOL of Cycles' (one sample at each pixel centre).

Window through an orthographic camera (svm/tex_coord.h): on a surface as for perspective; for
the World, a camera ray takes its origin's place in the frame (sd->ray_P: all of the camera's
rays share one direction, so the direction alone would give one colour), and any other ray
its direction taken as a point (Cycles adds the camera position only for perspective)."""
import os

import bpy
import numpy as np
import pytest

import scenes
from test_cycles_brightness import read_rgb

SIZE = 64
PASSES = 64
TOL = 2e-4  # measured 3.0e-5 (Window), 2.2e-5 (Camera)


def scaled(nt, socket, scale, offset):
    """socket * scale + offset (Vector Math Multiply Add)."""
    n = nt.nodes.new("ShaderNodeVectorMath")
    n.operation = 'MULTIPLY_ADD'
    n.inputs[1].default_value = scale
    n.inputs[2].default_value = offset
    nt.links.new(socket, n.inputs[0])
    return n.outputs[0]


def build_window(nt, vec):
    return nt.nodes.new("ShaderNodeTexCoord").outputs["Window"]


def build_camera(nt, vec):
    # Camera space: x, y within about +-1 on the plane, z = 5 (the distance): into [0, 1].
    tc = nt.nodes.new("ShaderNodeTexCoord")
    return scaled(nt, tc.outputs["Camera"], (0.4, 0.4, 0.1), (0.5, 0.5, 0.0))


@pytest.mark.parametrize("case", ["window", "camera"])
def test_camera_and_window_against_cycles(empty_scene, out_dir, case):
    build = build_window if case == "window" else build_camera
    scenes.emission_plane(empty_scene, f"texcoord_{case}", build, SIZE)
    cam = empty_scene.camera
    cam.data.type = 'PERSP'
    cam.data.lens = 100.0
    cam.data.sensor_width = 36.0
    cam.data.shift_x = 0.05
    scenes.configure_cycles_centres(empty_scene)
    cycles = read_rgb(scenes.render_to_exr(empty_scene, os.path.join(str(out_dir), f"texcoord_{case}_cycles.exr")))
    empty_scene.render.engine = 'GRADPHOTON'
    g = empty_scene.gradphoton
    g.method, g.stop_rule, g.passes, g.pt.max_bounces = 'pt', 'PASSES', PASSES, 0
    ours = read_rgb(scenes.render_to_exr(empty_scene, os.path.join(str(out_dir), f"texcoord_{case}_gradphoton.exr")))
    diff = np.abs(ours - cycles)
    worst = np.unravel_index(np.argmax(diff), diff.shape)
    print(f"TEXCOORD {case}: max |gradphoton - Cycles| = {diff.max():.2e} at {worst}, "
          f"Cycles range {cycles.min():.3f}..{cycles.max():.3f}")
    assert cycles.std() > 0.05
    assert diff.max() < TOL, f"{case}: max difference {diff.max():.2e} at {worst}"


def world_window(scene):
    """The World's Background colour = Window (strength 1), the plane removed."""
    bpy.data.objects.remove(bpy.data.objects["Plane"])
    nt = scene.world.node_tree
    bg = nt.nodes["Background"]
    bg.inputs["Strength"].default_value = 1.0
    nt.links.new(nt.nodes.new("ShaderNodeTexCoord").outputs["Window"], bg.inputs["Color"])


def world_mirror(scene):
    """A smooth mirror filling the frame (reflection rays are not camera rays) under the
    Window World."""
    world_window(scene)
    m = bpy.data.materials.new("texcoord_mirror")
    m.use_nodes = True
    nt = m.node_tree
    nt.nodes.remove(nt.nodes["Principled BSDF"])
    g = nt.nodes.new("ShaderNodeBsdfGlossy")
    g.distribution = 'SHARP'
    g.inputs["Color"].default_value = (1, 1, 1, 1)
    nt.links.new(g.outputs[0], nt.nodes["Material Output"].inputs["Surface"])
    scenes.uv_plane(scene, "Mirror", 4.0, m)


@pytest.mark.parametrize("case", ["surface-ortho", "world-ortho", "world-persp", "world-ortho-mirror"])
def test_window_of_orthographic_cameras_and_the_world_against_cycles(empty_scene, out_dir, case):
    scenes.emission_plane(empty_scene, f"texcoord_{case}", build_window, 16)
    cam = empty_scene.camera
    cam.data.type = 'PERSP' if case.endswith("persp") else 'ORTHO'
    cam.data.lens = 50.0
    cam.data.sensor_width = 36.0
    cam.data.ortho_scale = 1.0
    cam.data.shift_x = 0.05
    # Off the World's origin and turned: a direction taken as a point shows it.
    cam.location = (0.2, -0.1, 5)
    cam.rotation_euler = (0.05, 0.03, 0.1)
    if case.startswith("world"):
        (world_mirror if case.endswith("mirror") else world_window)(empty_scene)
    scenes.configure_cycles_centres(empty_scene)
    empty_scene.cycles.max_bounces = empty_scene.cycles.glossy_bounces = 1
    cycles = read_rgb(scenes.render_to_exr(empty_scene, os.path.join(str(out_dir), f"{case}_cycles.exr")))
    empty_scene.render.engine = 'GRADPHOTON'
    g = empty_scene.gradphoton
    g.method, g.stop_rule, g.passes, g.pt.max_bounces = 'pt', 'PASSES', 16, 1
    ours = read_rgb(scenes.render_to_exr(empty_scene, os.path.join(str(out_dir), f"{case}_gradphoton.exr")))
    diff = np.abs(ours - cycles)
    worst = np.unravel_index(np.argmax(diff), diff.shape)
    print(f"WINDOW {case}: max |gradphoton - Cycles| = {diff.max():.2e} at {worst}, "
          f"Cycles range {cycles.min():.3f}..{cycles.max():.3f}")
    assert cycles.max() > 0.05
    assert diff.max() < 1e-3, f"{case}: max difference {diff.max():.2e} at {worst}"
