"""The nodes docs/blender.md listed as "not yet measured" against Cycles, on the emission planes of
test_nodes_render.py (the same check: every pixel and channel within TOL of Cycles' value at the
pixel's centre, each test printing its largest difference).

Inputs that a node reads per pixel cell come from the snapped UV (textures, curves, colour
conversions); nodes that read the surface itself (Geometry, UV Map, Bump, Normal Map, Fresnel,
Layer Weight, Vector Transform) see continuous inputs that are linear over the plane, so
gradphoton's jittered samples average to the pixel centre's value, and Bump's height is linear
so its finite differences are exact whatever step a renderer takes.
"""
import pytest

import scenes
from test_nodes_render import _texture, check_plane, gradient



def _colour_of_vector(nt, socket, scale=0.5, offset=0.5):
    """A vector in [-1, 1] shown as a colour in [0, 1] (v * scale + offset)."""
    ma = scenes.new_node(nt, "ShaderNodeVectorMath", operation='MULTIPLY_ADD')
    nt.links.new(socket, ma.inputs[0])
    ma.inputs[1].default_value = (scale,) * 3
    ma.inputs[2].default_value = (offset,) * 3
    return ma.outputs[0]


def rgb_curves(nt, vec):
    c = scenes.new_node(nt, "ShaderNodeRGBCurve")
    m = c.mapping
    m.curves[3].points.new(0.4, 0.7)   # C: every channel
    m.curves[0].points.new(0.3, 0.1)   # R
    m.curves[2].points[1].location = (1.0, 0.6)  # B's end
    m.update()
    c.inputs["Fac"].default_value = 0.9
    nt.links.new(gradient(nt, vec), c.inputs["Color"])
    return c.outputs[0]


def float_curve(nt, vec):
    sep = scenes.new_node(nt, "ShaderNodeSeparateXYZ")
    nt.links.new(vec, sep.inputs[0])
    c = scenes.new_node(nt, "ShaderNodeFloatCurve")
    c.mapping.curves[0].points.new(0.35, 0.8)
    c.mapping.curves[0].points[0].location = (0.0, 0.1)
    c.mapping.update()
    nt.links.new(sep.outputs[0], c.inputs["Value"])
    comb = scenes.new_node(nt, "ShaderNodeCombineXYZ")
    nt.links.new(c.outputs[0], comb.inputs[0])
    nt.links.new(sep.outputs[1], comb.inputs[1])
    return comb.outputs[0]


def vector_curves(nt, vec):
    c = scenes.new_node(nt, "ShaderNodeVectorCurve")
    c.mapping.curves[0].points.new(0.2, 0.6)    # X over Blender's -1..1 range
    c.mapping.curves[1].points.new(0.5, -0.3)   # Y
    c.mapping.update()
    nt.links.new(vec, c.inputs["Vector"])
    return _colour_of_vector(nt, c.outputs[0])


def legacy_rgb_hsv(nt, vec):
    """Blender's older Separate/Combine RGB and HSV (kept in 3.4 for old files)."""
    sep = scenes.new_node(nt, "ShaderNodeSeparateRGB")
    nt.links.new(gradient(nt, vec), sep.inputs[0])
    hsv = scenes.new_node(nt, "ShaderNodeCombineHSV")
    nt.links.new(sep.outputs["R"], hsv.inputs["H"])
    nt.links.new(sep.outputs["G"], hsv.inputs["S"])
    nt.links.new(sep.outputs["B"], hsv.inputs["V"])
    sep2 = scenes.new_node(nt, "ShaderNodeSeparateHSV")
    nt.links.new(hsv.outputs[0], sep2.inputs[0])
    rgb = scenes.new_node(nt, "ShaderNodeCombineRGB")
    nt.links.new(sep2.outputs["V"], rgb.inputs["R"])
    nt.links.new(sep2.outputs["H"], rgb.inputs["G"])
    nt.links.new(hsv.outputs[0], rgb.inputs["B"])  # a colour read as a float: its average
    return rgb.outputs[0]


def colour_family(nt, vec):
    """Invert, Gamma, Bright/Contrast and RGB to BW chained on the gradient."""
    inv = scenes.new_node(nt, "ShaderNodeInvert", Fac=0.7)
    nt.links.new(gradient(nt, vec), inv.inputs["Color"])
    gam = scenes.new_node(nt, "ShaderNodeGamma", Gamma=1.7)
    nt.links.new(inv.outputs[0], gam.inputs["Color"])
    bc = scenes.new_node(nt, "ShaderNodeBrightContrast", Bright=0.1, Contrast=0.4)
    nt.links.new(gam.outputs[0], bc.inputs["Color"])
    bw = scenes.new_node(nt, "ShaderNodeRGBToBW")
    nt.links.new(bc.outputs[0], bw.inputs[0])
    mix = scenes.new_node(nt, "ShaderNodeMixRGB", blend_type='MULTIPLY', use_clamp=True)
    mix.inputs["Fac"].default_value = 0.5
    nt.links.new(bw.outputs[0], mix.inputs["Color1"])
    nt.links.new(bc.outputs[0], mix.inputs["Color2"])
    return mix.outputs[0]


def geometry_position(nt, vec):
    g = scenes.new_node(nt, "ShaderNodeNewGeometry")
    return _colour_of_vector(nt, g.outputs["Position"], 0.4, 0.5)


def uv_map(nt, vec):
    u = scenes.new_node(nt, "ShaderNodeUVMap", uv_map="UVMap")
    return u.outputs[0]


def object_info(nt, vec):
    """Object Info's Location and Random (Cycles hashes the object's name)."""
    o = scenes.new_node(nt, "ShaderNodeObjectInfo")
    comb = scenes.new_node(nt, "ShaderNodeCombineXYZ")
    sep = scenes.new_node(nt, "ShaderNodeSeparateXYZ")
    nt.links.new(o.outputs["Location"], sep.inputs[0])
    add = scenes.new_node(nt, "ShaderNodeMath", operation='ADD')
    nt.links.new(sep.outputs[0], add.inputs[0])
    nt.links.new(o.outputs["Random"], add.inputs[1])
    nt.links.new(add.outputs[0], comb.inputs[0])
    nt.links.new(o.outputs["Random"], comb.inputs[1])
    u = scenes.new_node(nt, "ShaderNodeSeparateXYZ")
    nt.links.new(vec, u.inputs[0])
    nt.links.new(u.outputs[0], comb.inputs[2])  # so that the image varies
    return comb.outputs[0]


def vector_transform(nt, vec):
    g = scenes.new_node(nt, "ShaderNodeNewGeometry")
    t = scenes.new_node(nt, "ShaderNodeVectorTransform", vector_type='POINT', convert_from='WORLD', convert_to='CAMERA')
    nt.links.new(g.outputs["Position"], t.inputs[0])
    scale = scenes.new_node(nt, "ShaderNodeVectorMath", operation='MULTIPLY')
    scale.inputs[1].default_value = (0.4, 0.4, 0.1)
    nt.links.new(t.outputs[0], scale.inputs[0])
    return _colour_of_vector(nt, scale.outputs[0], 1.0, 0.5)


def _linear_height(nt):
    """h = 0.3 u + 0.2 v: linear, so every finite difference of it is exact."""
    tc = scenes.new_node(nt, "ShaderNodeTexCoord")
    dot = scenes.new_node(nt, "ShaderNodeVectorMath", operation='DOT_PRODUCT')
    dot.inputs[1].default_value = (0.3, 0.2, 0.0)
    nt.links.new(tc.outputs["UV"], dot.inputs[0])
    return dot.outputs["Value"]


def _bump(nt):
    b = scenes.new_node(nt, "ShaderNodeBump", Strength=0.8, Distance=0.7)
    nt.links.new(_linear_height(nt), b.inputs["Height"])
    return b


def bump(nt, vec):
    return _colour_of_vector(nt, _bump(nt).outputs[0])


def normal_map(nt, vec):
    """A tangent-space normal map of a colour linear in the UVs."""
    tc = scenes.new_node(nt, "ShaderNodeTexCoord")
    ma = scenes.new_node(nt, "ShaderNodeVectorMath", operation='MULTIPLY_ADD')
    ma.inputs[1].default_value = (0.4, -0.3, 0.0)
    ma.inputs[2].default_value = (0.3, 0.65, 0.9)
    nt.links.new(tc.outputs["UV"], ma.inputs[0])
    nm = scenes.new_node(nt, "ShaderNodeNormalMap", space='TANGENT', uv_map="UVMap", Strength=0.9)
    nt.links.new(ma.outputs[0], nm.inputs["Color"])
    return _colour_of_vector(nt, nm.outputs[0])


def fresnel_layer_weight(nt, vec):
    """Fresnel (IOR 1.45) and Layer Weight (Blend 0.3: Fresnel, Facing) of a bumped normal."""
    n = _bump(nt).outputs[0]
    fr = scenes.new_node(nt, "ShaderNodeFresnel", IOR=1.45)
    nt.links.new(n, fr.inputs["Normal"])
    lw = scenes.new_node(nt, "ShaderNodeLayerWeight", Blend=0.3)
    nt.links.new(n, lw.inputs["Normal"])
    comb = scenes.new_node(nt, "ShaderNodeCombineXYZ")
    nt.links.new(fr.outputs[0], comb.inputs[0])
    nt.links.new(lw.outputs["Fresnel"], comb.inputs[1])
    nt.links.new(lw.outputs["Facing"], comb.inputs[2])
    mul = scenes.new_node(nt, "ShaderNodeVectorMath", operation='MULTIPLY')  # a bigger range to compare
    mul.inputs[1].default_value = (4.0, 4.0, 4.0)
    nt.links.new(comb.outputs[0], mul.inputs[0])
    return mul.outputs[0]


CASES = {
    "gradient_linear": _texture("ShaderNodeTexGradient", "Color", gradient_type='LINEAR'),
    "gradient_spherical": _texture("ShaderNodeTexGradient", "Fac", gradient_type='SPHERICAL'),
    "magic": _texture("ShaderNodeTexMagic", "Color", turbulence_depth=3, Scale=3.0, Distortion=1.5),
    "brick": _texture("ShaderNodeTexBrick", "Color", Scale=3.0, offset=0.4, squash=1.5),
    "white_noise": _texture("ShaderNodeTexWhiteNoise", "Color", noise_dimensions='3D'),
    "rgb_curves": rgb_curves,
    "float_curve": float_curve,
    "vector_curves": vector_curves,
    "legacy_rgb_hsv": legacy_rgb_hsv,
    "colour_family": colour_family,
    "geometry_position": geometry_position,
    "uv_map": uv_map,
    "object_info": object_info,
    "vector_transform": vector_transform,
    "bump": bump,
    "normal_map": normal_map,
    "fresnel_layer_weight": fresnel_layer_weight,
}


@pytest.mark.parametrize("case", list(CASES))
def test_more_nodes_against_cycles(empty_scene, out_dir, case):
    check_plane(empty_scene, str(out_dir), case, CASES[case])


def test_object_info_random_of_instances_against_cycles(empty_scene, out_dir):
    """Object Info's Random on instanced copies: Cycles takes each copy's own random id from the
    depsgraph (not its name's hash, which an object of its own gets). Four collection instances
    of one emitting plane, and the plane itself, in one row; every tile's value as Cycles'."""
    import bpy
    import numpy as np
    from test_nodes_render import render_plane
    scene = empty_scene
    scenes.set_world(scene)
    m, nt, out = scenes._node_material("random")
    e = nt.nodes.new("ShaderNodeEmission")
    info = nt.nodes.new("ShaderNodeObjectInfo")
    nt.links.new(info.outputs["Random"], e.inputs["Color"])
    nt.links.new(e.outputs[0], out.inputs["Surface"])
    coll = bpy.data.collections.new("Tiles")
    tile = scenes.add_plane(scene, "Tile", 0.36, m, (-0.8, 0, 0))
    coll.objects.link(tile)  # also in the scene: the object itself, hashed by name
    for k in range(1, 5):
        inst = bpy.data.objects.new(f"Copy{k}", None)
        inst.instance_type = 'COLLECTION'
        inst.instance_collection = coll
        inst.location = (0.4 * k, 0, 0)
        scene.collection.objects.link(inst)
    cam = scenes.add_camera(scene, (0, 0, 5), (0, 0, 0))
    cam.data.type = 'ORTHO'
    cam.data.ortho_scale = 2.0
    cam.rotation_euler = (0.0, 0.0, 0.0)
    scene.render.resolution_x, scene.render.resolution_y = 50, 10
    scene.render.resolution_percentage = 100
    ours, cycles = render_plane(scene, str(out_dir), "object_info_instances")
    tiles = [(cycles[5, 5 + 10 * k, 0], ours[5, 5 + 10 * k, 0]) for k in range(5)]
    print("NODES object_info_instances (Cycles, gradphoton) per tile:", [(round(float(c), 4), round(float(o), 4)) for c, o in tiles])
    assert len({round(float(c), 3) for c, _ in tiles}) == 5, "Cycles' tiles should differ"
    for c, o in tiles:
        assert abs(c - o) < 1e-3
