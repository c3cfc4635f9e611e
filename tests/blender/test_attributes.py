"""Colour attributes and generic mesh attributes (Color Attribute and Attribute nodes) rendered
by gradphoton against Cycles 3.4 in this Blender.

An 8 x 8 grid of quads fills a 64 x 64 orthographic frame (faces on pixel boundaries), emission
strength 1, its colour read from the mesh's attributes: point and corner domains, byte and
float colours, a float, a vector on faces, the render colour by an empty name, a missing name.
Cycles renders one sample at each pixel's centre (the exact value); gradphoton averages
jittered samples over the pixel. Values are linear over each triangle, so the pixel average is
the centre's value except where a pixel crosses a quad's diagonal (the slope changes there):
every pixel must agree within TOL, the image means within MEAN_TOL (measured: docs/blender.md).
"""
import os

import bpy
import numpy as np
import pytest

import scenes
from test_nodes_render import render_plane

N = 8          # quads per side
SIZE = 64      # pixels per side
TOL = 2e-3     # per pixel: measured at most 5.0e-4 (the diagonal's kink); a wrong domain or
               # colour space moves pixels by > 0.1
MEAN_TOL = 2e-4  # measured at most 1e-5


def grid_plane(scene, material):
    """An N x N grid of quads over [-1, 1]^2 with attributes from a fixed seed."""
    verts = [(-1 + 2 * i / N, -1 + 2 * j / N, 0) for j in range(N + 1) for i in range(N + 1)]
    faces = [(j * (N + 1) + i, j * (N + 1) + i + 1, (j + 1) * (N + 1) + i + 1, (j + 1) * (N + 1) + i)
             for j in range(N) for i in range(N)]
    ob = scenes.add_mesh_object(scene, "Grid", verts, faces, material)
    me = ob.data
    rng = np.random.default_rng(5)
    corner_byte = me.color_attributes.new("CornerByte", 'BYTE_COLOR', 'CORNER')
    corner_byte.data.foreach_set("color", rng.random(len(me.loops) * 4).astype(np.float32))
    point_float = me.color_attributes.new("PointFloat", 'FLOAT_COLOR', 'POINT')
    point_float.data.foreach_set("color", (rng.random(len(me.vertices) * 4) * 1.5).astype(np.float32))
    point_byte = me.color_attributes.new("PointByte", 'BYTE_COLOR', 'POINT')
    point_byte.data.foreach_set("color", rng.random(len(me.vertices) * 4).astype(np.float32))
    height = me.attributes.new("height", 'FLOAT', 'POINT')
    height.data.foreach_set("value", rng.random(len(me.vertices)).astype(np.float32))
    tint = me.attributes.new("tint", 'FLOAT_VECTOR', 'FACE')
    tint.data.foreach_set("vector", rng.random(len(me.polygons) * 3).astype(np.float32))
    me.attributes.default_color_name = "CornerByte"  # the render colour (camera icon)
    me.update()
    return ob


def attribute_plane(scene, case, build):
    scenes.set_world(scene)
    m, nt, out = scenes._node_material(case)
    e = nt.nodes.new("ShaderNodeEmission")
    nt.links.new(build(nt), e.inputs["Color"])
    nt.links.new(e.outputs[0], out.inputs["Surface"])
    grid_plane(scene, m)
    cam = scenes.add_camera(scene, (0, 0, 5), (0, 0, 0))
    cam.data.type = 'ORTHO'
    cam.data.ortho_scale = 2.0
    cam.rotation_euler = (0.0, 0.0, 0.0)
    scene.render.resolution_x = scene.render.resolution_y = SIZE
    scene.render.resolution_percentage = 100


def color_attribute(name, output="Color"):
    def build(nt):
        n = nt.nodes.new("ShaderNodeVertexColor")
        n.layer_name = name
        return n.outputs[output]
    return build


def attribute(name, output):
    def build(nt):
        n = nt.nodes.new("ShaderNodeAttribute")
        n.attribute_name = name
        return n.outputs[output]
    return build


def alpha_and_fac(nt):
    """(Color Attribute PointFloat's Alpha, Attribute height's Fac, Attribute missing's Alpha)."""
    comb = nt.nodes.new("ShaderNodeCombineColor")
    nt.links.new(color_attribute("PointFloat", "Alpha")(nt), comb.inputs[0])
    nt.links.new(attribute("height", "Fac")(nt), comb.inputs[1])
    nt.links.new(attribute("missing", "Alpha")(nt), comb.inputs[2])
    return comb.outputs[0]


CASES = {
    "render_colour_corner_byte": color_attribute(""),
    "point_float_colour": color_attribute("PointFloat"),
    "point_byte_colour": attribute("PointByte", "Color"),
    "face_vector": attribute("tint", "Vector"),
    "alpha_fac_missing": alpha_and_fac,
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_attributes_against_cycles(empty_scene, out_dir, case):
    attribute_plane(empty_scene, case, CASES[case])
    ours, cycles = render_plane(empty_scene, str(out_dir), f"attr_{case}")
    diff = np.abs(ours - cycles)
    worst = np.unravel_index(np.argmax(diff), diff.shape)
    print(f"ATTRIBUTES {case}: max |gradphoton - Cycles| = {diff.max():.2e} at {worst}, "
          f"mean |diff| {diff.mean():.2e}, means {ours.mean():.5f} / {cycles.mean():.5f}")
    assert cycles.std() > 0.05, f"{case}: Cycles' image is nearly flat"
    assert abs(ours.mean() - cycles.mean()) < MEAN_TOL
    assert diff.max() < TOL, f"{case}: max difference {diff.max():.2e} at {worst}"
