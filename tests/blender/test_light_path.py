"""Light Path fields as the integrators fill them (core/math.h RayState), against Cycles 3.4 in
this Blender, path tracing with the same samples and bounces:

  - camera_only_emitter: the common trick, a Mix Shader of a Diffuse and an Emission by Is
    Camera Ray: the camera sees the emitter glow, nothing else sees its light (a sun lights the
    floor so the image is not black elsewhere);
  - ray_depth_mirror: an emitter whose strength is Ray Depth + 1, seen directly (1) and in a
    smooth mirror floor (2);
  - diffuse_depth: a floor whose colour is a Color Ramp of Diffuse Depth, in a closed box lit by
    a sun through an opening (bounces read depths 0, 1, 2).

Means within MEAN_TOL, relMSE below a bound about twice what was measured (docs/blender.md)."""
import math

import numpy as np
import pytest

import scenes
from test_cycles_brightness import relmse, render_both

SIZE = (48, 36)
MEAN_TOL = 0.01
# Measured (2026-11-27): means 1.0007, 0.9990, 1.0012; relMSE 0.0034, 0.0007, 0.0192.
RELMSE = {"camera_only_emitter": 0.007, "ray_depth_mirror": 0.002, "diffuse_depth": 0.04}


def light_path(nt):
    return nt.nodes.new("ShaderNodeLightPath")


def camera_only_emitter(scene):
    m, nt, out = scenes._node_material("CameraOnly")
    lp = light_path(nt)
    mix = nt.nodes.new("ShaderNodeMixShader")
    d = nt.nodes.new("ShaderNodeBsdfDiffuse")
    e = nt.nodes.new("ShaderNodeEmission")
    e.inputs["Strength"].default_value = 8.0
    e.inputs["Color"].default_value = (1.0, 0.6, 0.2, 1)
    nt.links.new(lp.outputs["Is Camera Ray"], mix.inputs["Fac"])
    nt.links.new(d.outputs[0], mix.inputs[1])
    nt.links.new(e.outputs[0], mix.inputs[2])
    nt.links.new(mix.outputs[0], out.inputs["Surface"])
    scenes.add_plane(scene, "Floor", 8.0, scenes.diffuse_material("Floor"))
    scenes.add_plane(scene, "Emitter", 1.5, m, location=(0, 0, 1.0))
    sun = scenes.add_light(scene, "Sun", 'SUN', None, 2.0, {"angle": 0.0}, (3, 0, 3))
    sun.rotation_euler = (0.6, 0.0, 0.4)
    scenes.add_camera(scene, (0, -5, 4), (0, 0, 0.3), lens=35.0)


def ray_depth_mirror(scene):
    m, nt, out = scenes._node_material("DepthEmitter")
    lp = light_path(nt)
    add = nt.nodes.new("ShaderNodeMath")
    add.operation = 'ADD'
    add.inputs[1].default_value = 1.0
    e = nt.nodes.new("ShaderNodeEmission")
    nt.links.new(lp.outputs["Ray Depth"], add.inputs[0])
    nt.links.new(add.outputs[0], e.inputs["Strength"])
    nt.links.new(e.outputs[0], out.inputs["Surface"])
    mirror, mnt, mout = scenes._node_material("Mirror")
    g = mnt.nodes.new("ShaderNodeBsdfGlossy")
    g.inputs["Roughness"].default_value = 0.0
    g.inputs["Color"].default_value = (0.9, 0.9, 0.9, 1)
    mnt.links.new(g.outputs[0], mout.inputs["Surface"])
    scenes.add_plane(scene, "Floor", 8.0, mirror)
    wall = scenes.add_plane(scene, "Wall", 2.0, m, location=(0, 2.0, 1.0))
    wall.rotation_euler = (math.pi / 2, 0.0, 0.0)  # facing -y, towards the camera
    scenes.add_camera(scene, (0, -4, 1.5), (0, 1.5, 0.5), lens=35.0)


def diffuse_depth(scene):
    m, nt, out = scenes._node_material("DepthFloor")
    lp = light_path(nt)
    ramp = nt.nodes.new("ShaderNodeMapRange")
    ramp.inputs["From Max"].default_value = 3.0
    ramp.inputs["To Min"].default_value = 0.9
    ramp.inputs["To Max"].default_value = 0.1
    d = nt.nodes.new("ShaderNodeBsdfDiffuse")
    nt.links.new(lp.outputs["Diffuse Depth"], ramp.inputs["Value"])
    nt.links.new(ramp.outputs[0], d.inputs["Color"])
    nt.links.new(d.outputs[0], out.inputs["Surface"])
    scenes.add_plane(scene, "Floor", 4.0, m)
    for i, (loc, rot) in enumerate([((0, 2, 1), (math.pi / 2, 0, 0)), ((2, 0, 1), (0, math.pi / 2, 0)),
                                    ((-2, 0, 1), (0, math.pi / 2, 0))]):
        w = scenes.add_plane(scene, f"Wall{i}", 4.0, m, location=loc)
        w.rotation_euler = rot
    sun = scenes.add_light(scene, "Sun", 'SUN', None, 3.0, {"angle": 0.0}, (0, -3, 3))
    sun.rotation_euler = (-0.5, 0.0, 0.0)
    scenes.add_camera(scene, (0, -5, 2), (0, 0, 0.8), lens=30.0)


CASES = {"camera_only_emitter": camera_only_emitter, "ray_depth_mirror": ray_depth_mirror,
         "diffuse_depth": diffuse_depth}


@pytest.mark.parametrize("case", sorted(CASES))
def test_light_path_against_cycles(empty_scene, out_dir, case):
    scenes.set_world(empty_scene, (0.0, 0.0, 0.0), 0.0)
    CASES[case](empty_scene)
    empty_scene.render.resolution_x, empty_scene.render.resolution_y = SIZE
    ours, cycles = render_both(empty_scene, str(out_dir), f"lightpath_{case}", samples=64, bounces=4)
    ratio = ours.sum() / cycles.sum()
    err = relmse(ours, cycles)
    print(f"LIGHTPATH {case}: gradphoton/cycles = {ratio:.4f}, relMSE {err:.5f}")
    assert cycles.sum() > 1e-3
    assert abs(ratio - 1) < MEAN_TOL, f"{case}: gradphoton/Cycles = {ratio:.4f}"
    assert err < RELMSE[case], f"{case}: relMSE {err:.5f}"
