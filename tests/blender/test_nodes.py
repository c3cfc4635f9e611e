"""Export of shader node graphs (export/nodes.py, export/material.py): node trees built here with
bpy, the exporter's description checked against what Cycles 3.4 reads from the same tree
(intern/cycles/blender/shader.cpp): groups flattened, reroutes and muted nodes resolved, links
from unavailable sockets ignored, only what reaches the Cycles output written, unsupported nodes
one warning naming material and node."""
import os

import bpy
import pytest

import scenes
from gradphoton import export, native
from gradphoton.export import nodes as export_nodes


def node_material(name):
    m, nt, out = scenes._node_material(name)
    return m, nt, out


def export_material(mat):
    """(the material's scene-format dict, the whole table, warning lines)."""
    w = export.Warnings()
    table = {}
    exporter = export.material.MaterialExporter(table, w)
    exporter.name_for(mat)
    return table[mat.name], table, w.lines(), exporter


def ident(sockets, identifier):
    """A socket by identifier (Blender's [] looks names up: a Mix node has three "A")."""
    return next(s for s in sockets if s.identifier == identifier)


def link(node_id, output):
    return {"link": node_id, "output": output}


def diffuse_from(nt, out, socket):
    d = nt.nodes.new("ShaderNodeBsdfDiffuse")
    nt.links.new(socket, d.inputs["Color"])
    nt.links.new(d.outputs[0], out.inputs["Surface"])
    return d


def test_checker_into_a_diffuse_is_a_link_into_the_table(empty_scene):
    m, nt, out = node_material("Ground")
    ch = nt.nodes.new("ShaderNodeTexChecker")
    ch.inputs["Scale"].default_value = 5.0
    ch.inputs["Color1"].default_value = (0.8, 0.8, 0.8, 1)
    ch.inputs["Color2"].default_value = (0.2, 0.2, 0.2, 1)
    mapping = nt.nodes.new("ShaderNodeMapping")
    mapping.inputs["Rotation"].default_value = (0, 0, 0.3)
    mapping.inputs["Scale"].default_value = (2, 2, 2)
    tc = nt.nodes.new("ShaderNodeTexCoord")
    nt.links.new(tc.outputs["UV"], mapping.inputs["Vector"])
    nt.links.new(mapping.outputs["Vector"], ch.inputs["Vector"])
    diffuse_from(nt, out, ch.outputs["Color"])
    nt.nodes.new("ShaderNodeTexNoise")  # not connected: not written
    d, _, warnings, exporter = export_material(m)
    assert d["type"] == "diffuse" and d["color"] == link("Checker Texture", "Color")
    assert set(d["nodes"]) == {"Checker Texture", "Mapping", "Texture Coordinate"}
    checker = d["nodes"]["Checker Texture"]
    assert checker["type"] == "ShaderNodeTexChecker"
    assert checker["inputs"] == {"Vector": link("Mapping", "Vector"), "Color1": pytest.approx([0.8] * 3),
                                 "Color2": pytest.approx([0.2] * 3), "Scale": 5.0}
    mp = d["nodes"]["Mapping"]
    assert mp["props"] == {"vector_type": "POINT"}
    assert mp["inputs"]["Vector"] == link("Texture Coordinate", "UV")
    assert mp["inputs"]["Rotation"] == pytest.approx([0, 0, 0.3]) and mp["inputs"]["Scale"] == [2, 2, 2]
    assert "Location" in mp["inputs"]
    assert d["nodes"]["Texture Coordinate"] == {"type": "ShaderNodeTexCoord", "props": {"from_instancer": False}}
    assert not warnings
    assert exporter.needs_uvs(m)  # the Texture Coordinate node reads UVs


def test_procedural_texture_without_coordinates_needs_no_uvs(empty_scene):
    m, nt, out = node_material("Plain checker")
    ch = nt.nodes.new("ShaderNodeTexChecker")
    diffuse_from(nt, out, ch.outputs["Fac"])
    d, _, warnings, exporter = export_material(m)
    # The Vector input has no value of its own (Generated coordinates): left out.
    assert "Vector" not in d["nodes"]["Checker Texture"]["inputs"]
    assert d["color"] == link("Checker Texture", "Fac")  # float -> colour: the core converts
    assert not exporter.needs_uvs(m) and not warnings


def make_group(name, inputs, outputs):
    tree = bpy.data.node_groups.new(name, "ShaderNodeTree")
    for kind, sname in inputs:
        tree.inputs.new(kind, sname)
    for kind, sname in outputs:
        tree.outputs.new(kind, sname)
    gin = tree.nodes.new("NodeGroupInput")
    gout = tree.nodes.new("NodeGroupOutput")
    return tree, gin, gout


def test_group_inside_group_is_flattened(empty_scene):
    # Inner: Noise(Scale = input "Scale") -> Fac, Math MULTIPLY by 2 -> output "Out".
    inner, iin, iout = make_group("InnerGroup", [("NodeSocketFloat", "Scale")], [("NodeSocketFloat", "Out")])
    noise = inner.nodes.new("ShaderNodeTexNoise")
    mul = inner.nodes.new("ShaderNodeMath")
    mul.operation = 'MULTIPLY'
    mul.inputs[1].default_value = 2.0
    inner.links.new(iin.outputs["Scale"], noise.inputs["Scale"])
    inner.links.new(noise.outputs["Fac"], mul.inputs[0])
    inner.links.new(mul.outputs[0], iout.inputs["Out"])
    # Outer: passes its input "S" to the inner group; its output is the inner's.
    outer, oin, oout = make_group("OuterGroup", [("NodeSocketFloat", "S")], [("NodeSocketFloat", "Result")])
    g_inner = outer.nodes.new("ShaderNodeGroup")
    g_inner.node_tree = inner
    g_inner.name = "Inner"
    outer.links.new(oin.outputs["S"], g_inner.inputs["Scale"])
    outer.links.new(g_inner.outputs["Out"], oout.inputs["Result"])

    m, nt, out = node_material("Grouped")
    g = nt.nodes.new("ShaderNodeGroup")
    g.node_tree = outer
    g.name = "Group"
    g.inputs["S"].default_value = 7.5
    diffuse_from(nt, out, g.outputs["Result"])
    d, _, warnings, _ = export_material(m)
    assert d["color"] == link("Group/Inner/Math", "Value")
    assert set(d["nodes"]) == {"Group/Inner/Math", "Group/Inner/Noise Texture"}
    assert d["nodes"]["Group/Inner/Math"]["inputs"] == {"Value": link("Group/Inner/Noise Texture", "Fac"),
                                                        "Value_001": 2.0}
    # The outer group node's own input value reached the innermost node through two Group Inputs.
    assert d["nodes"]["Group/Inner/Noise Texture"]["inputs"]["Scale"] == 7.5
    assert not warnings

    # A linked group input: the link goes to the node outside.
    val = nt.nodes.new("ShaderNodeTexChecker")
    nt.links.new(val.outputs["Fac"], g.inputs["S"])
    d, _, _, _ = export_material(m)
    assert d["nodes"]["Group/Inner/Noise Texture"]["inputs"]["Scale"] == link("Checker Texture", "Fac")


def test_group_socket_converts_a_colour_to_a_float(empty_scene):
    """Cycles puts a conversion to the group socket's type at a group's boundary: a colour into a
    float socket is its luminance inside, also where the inside reads it as a colour again."""
    grp, gin, gout = make_group("Passthrough", [("NodeSocketFloat", "F")], [("NodeSocketColor", "C")])
    grp.links.new(gin.outputs["F"], gout.inputs["C"])
    m, nt, out = node_material("Converted")
    g = nt.nodes.new("ShaderNodeGroup")
    g.node_tree = grp
    ch = nt.nodes.new("ShaderNodeTexChecker")
    nt.links.new(ch.outputs["Color"], g.inputs["F"])
    diffuse_from(nt, out, g.outputs["C"])
    d, _, _, _ = export_material(m)
    conv = d["color"]["link"]
    assert conv.startswith("~") and d["color"]["output"] == "Value"
    assert d["nodes"][conv] == {"type": "ShaderNodeMath", "props": {"operation": "ADD", "use_clamp": False},
                                "inputs": {"Value": link("Checker Texture", "Color"), "Value_001": 0.0}}
    # A constant colour into that socket is folded: the luminance, Rec.709 weights.
    nt.links.remove(g.inputs["F"].links[0])
    rgb = nt.nodes.new("ShaderNodeRGB")
    rgb.outputs[0].default_value = (1.0, 0.5, 0.25, 1)
    nt.links.new(rgb.outputs[0], g.inputs["F"])
    d, _, _, _ = export_material(m)
    lum = 0.2126 + 0.7152 * 0.5 + 0.0722 * 0.25
    assert d["color"] == pytest.approx([lum] * 3) and "nodes" not in d


def test_reroute_and_muted_node_are_resolved(empty_scene):
    m, nt, out = node_material("Rerouted")
    ch = nt.nodes.new("ShaderNodeTexChecker")
    r1 = nt.nodes.new("NodeReroute")
    inv = nt.nodes.new("ShaderNodeInvert")
    inv.mute = True
    r2 = nt.nodes.new("NodeReroute")
    nt.links.new(ch.outputs["Color"], r1.inputs[0])
    nt.links.new(r1.outputs[0], inv.inputs["Color"])
    nt.links.new(inv.outputs["Color"], r2.inputs[0])
    diffuse_from(nt, out, r2.outputs[0])
    d, _, warnings, _ = export_material(m)
    assert d["color"] == link("Checker Texture", "Color")
    assert set(d["nodes"]) == {"Checker Texture"}
    # Unmuted, the Invert is written, fed through the reroute.
    inv.mute = False
    d, _, _, _ = export_material(m)
    assert d["color"] == link("Invert", "Color")
    assert d["nodes"]["Invert"]["inputs"] == {"Fac": 1.0, "Color": link("Checker Texture", "Color")}
    assert not warnings


def test_muted_output_without_internal_link_keeps_the_inputs_own_value(empty_scene):
    m, nt, out = node_material("Muted noise")
    noise = nt.nodes.new("ShaderNodeTexNoise")
    noise.mute = True  # no input of a Noise Texture maps to its Color output
    d = diffuse_from(nt, out, noise.outputs["Color"])
    d.inputs["Color"].default_value = (0.1, 0.2, 0.3, 1)
    mat, _, warnings, _ = export_material(m)
    assert mat["color"] == pytest.approx([0.1, 0.2, 0.3]) and "nodes" not in mat and not warnings


def test_math_with_clamp_and_links_from_unavailable_sockets(empty_scene):
    m, nt, out = node_material("Math")
    math = nt.nodes.new("ShaderNodeMath")
    math.operation = 'SUBTRACT'
    math.use_clamp = True
    math.inputs[0].default_value = 0.25
    ch = nt.nodes.new("ShaderNodeTexChecker")
    nt.links.new(ch.outputs["Fac"], math.inputs[1])
    nt.links.new(ch.outputs["Fac"], math.inputs[2])  # Value_002: unused by SUBTRACT (unavailable)
    diffuse_from(nt, out, math.outputs[0])
    d, _, _, _ = export_material(m)
    assert d["nodes"]["Math"] == {"type": "ShaderNodeMath", "props": {"operation": "SUBTRACT", "use_clamp": True},
                                  "inputs": {"Value": 0.25, "Value_001": link("Checker Texture", "Fac")}}
    # A link from an unavailable output (the float Mix's colour result) is no link: Blender and
    # Cycles ignore it, the input keeps its own value.
    mix = nt.nodes.new("ShaderNodeMix")
    assert mix.data_type == 'FLOAT' and not ident(mix.outputs, "Result_Color").enabled
    dnode = out.inputs["Surface"].links[0].from_node
    nt.links.new(ident(mix.outputs, "Result_Color"), dnode.inputs["Color"])
    dnode.inputs["Color"].default_value = (0.3, 0.3, 0.3, 1)
    d, _, _, _ = export_material(m)
    assert d["color"] == pytest.approx([0.3, 0.3, 0.3]) and "nodes" not in d


def test_color_ramp_and_mix_lighten_of_an_image_and_a_colour(empty_scene, out_dir):
    """The issue's case: a Mix node (Lighten) of an image and a colour into a Principled Base
    Color, the image's value through a Color Ramp."""
    img = scenes.save_image("Ramp source", scenes.pattern_pixels(8), os.path.join(str(out_dir), "src.png"))
    m, nt, out = node_material("Lighten")
    tex = scenes.image_node(nt, img)
    ramp = nt.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.interpolation = 'EASE'
    ramp.color_ramp.elements[0].color = (0.1, 0.0, 0.0, 1.0)
    ramp.color_ramp.elements.new(0.4).color = (0.0, 0.5, 0.0, 1.0)
    nt.links.new(tex.outputs["Color"], ramp.inputs["Fac"])
    mix = nt.nodes.new("ShaderNodeMix")
    mix.data_type = 'RGBA'
    mix.blend_type = 'LIGHTEN'
    ident(mix.inputs, "Factor_Float").default_value = 0.75
    ident(mix.inputs, "B_Color").default_value = (0.2, 0.3, 0.4, 1)
    nt.links.new(ramp.outputs["Color"], ident(mix.inputs, "A_Color"))
    p = nt.nodes.new("ShaderNodeBsdfPrincipled")
    nt.links.new(ident(mix.outputs, "Result_Color"), p.inputs["Base Color"])
    nt.links.new(p.outputs[0], out.inputs["Surface"])
    d, _, warnings, exporter = export_material(m)
    assert not warnings, warnings
    assert d["type"] == "principled" and d["color"] == link("Mix", "Result_Color")
    mixn = d["nodes"]["Mix"]
    assert mixn["props"] == {"data_type": "RGBA", "factor_mode": "UNIFORM", "blend_type": "LIGHTEN",
                             "clamp_factor": True, "clamp_result": False}
    assert mixn["inputs"] == {"Factor_Float": 0.75, "A_Color": link("ColorRamp", "Color"),
                              "B_Color": pytest.approx([0.2, 0.3, 0.4])}
    cr = d["nodes"]["ColorRamp"]["props"]["color_ramp"]
    assert cr["interpolation"] == "EASE" and cr["color_mode"] == "RGB"
    assert [e["position"] for e in cr["elements"]] == pytest.approx([0.0, 0.4, 1.0])
    assert cr["elements"][1]["color"] == pytest.approx([0.0, 0.5, 0.0, 1.0])
    assert d["nodes"]["ColorRamp"]["inputs"] == {"Fac": link("Image Texture", "Color")}
    it = d["nodes"]["Image Texture"]
    assert it["props"]["image"] == os.path.join(str(out_dir), "src.png")
    assert {k: it["props"][k] for k in ("colorspace", "interpolation", "extension", "projection", "alpha_mode")} == \
        {"colorspace": "sRGB", "interpolation": "Linear", "extension": "REPEAT", "projection": "FLAT",
         "alpha_mode": "STRAIGHT"}
    assert it["props"]["projection_blend"] == 0.0 and "inputs" not in it
    assert exporter.needs_uvs(m)


def test_noise_through_map_range_into_principled_roughness(empty_scene):
    m, nt, out = node_material("Rough")
    noise = nt.nodes.new("ShaderNodeTexNoise")
    noise.noise_dimensions = '4D'
    mr = nt.nodes.new("ShaderNodeMapRange")
    mr.inputs["To Min"].default_value = 0.2
    mr.inputs["To Max"].default_value = 0.6
    nt.links.new(noise.outputs["Fac"], mr.inputs["Value"])
    p = nt.nodes.new("ShaderNodeBsdfPrincipled")
    p.inputs["Metallic"].default_value = 0.5
    nt.links.new(mr.outputs["Result"], p.inputs["Roughness"])
    nt.links.new(p.outputs[0], out.inputs["Surface"])
    d, table, warnings, _ = export_material(m)
    assert not warnings, warnings
    assert d["type"] == "mix" and d["factor"] == 0.5
    plastic = table[d["a"]]
    # GGX alpha = r^2 of the clamped roughness: Math ADD(r, 0) clamped, then MULTIPLY by itself.
    sq = plastic["roughness"]["link"]
    nodes = plastic["nodes"]
    assert nodes[sq]["props"] == {"operation": "MULTIPLY", "use_clamp": False}
    clamp = nodes[sq]["inputs"]["Value"]["link"]
    assert nodes[sq]["inputs"]["Value_001"] == nodes[sq]["inputs"]["Value"]
    assert nodes[clamp] == {"type": "ShaderNodeMath", "props": {"operation": "ADD", "use_clamp": True},
                            "inputs": {"Value": link("Map Range", "Result"), "Value_001": 0.0}}
    assert nodes["Map Range"]["props"] == {"clamp": True, "interpolation_type": "LINEAR", "data_type": "FLOAT"}
    assert nodes["Map Range"]["inputs"] == {"Value": link("Noise Texture", "Fac"), "From Min": 0.0, "From Max": 1.0,
                                            "To Min": pytest.approx(0.2), "To Max": pytest.approx(0.6)}
    assert nodes["Noise Texture"]["props"] == {"noise_dimensions": "4D"}
    assert set(nodes["Noise Texture"]["inputs"]) == {"W", "Scale", "Detail", "Roughness", "Distortion"}
    # The metal layer reads the same roughness: its own table holds the same nodes.
    metal = table[d["b"]]
    assert metal["roughness"] == plastic["roughness"] and set(metal["nodes"]) == set(nodes)
    assert plastic["ior"] == pytest.approx(1.5)  # Specular 0.5: F0 0.04


def test_normal_map_and_bump_are_normal_links(empty_scene, out_dir):
    img = scenes.save_image("Bumps", scenes.normal_map_pixels(8), os.path.join(str(out_dir), "n.png"), 'Non-Color')
    m, nt, out = node_material("Bumpy")
    nm = nt.nodes.new("ShaderNodeNormalMap")
    nm.inputs["Strength"].default_value = 0.7
    nt.links.new(scenes.image_node(nt, img).outputs["Color"], nm.inputs["Color"])
    bump = nt.nodes.new("ShaderNodeBump")
    bump.invert = True
    noise = nt.nodes.new("ShaderNodeTexNoise")
    nt.links.new(noise.outputs["Fac"], bump.inputs["Height"])
    nt.links.new(nm.outputs["Normal"], bump.inputs["Normal"])
    g = nt.nodes.new("ShaderNodeBsdfGlossy")
    nt.links.new(bump.outputs["Normal"], g.inputs["Normal"])
    nt.links.new(g.outputs[0], out.inputs["Surface"])
    d, _, warnings, exporter = export_material(m)
    assert not warnings, warnings
    assert d["normal"] == link("Bump", "Normal")
    assert d["nodes"]["Bump"] == {"type": "ShaderNodeBump", "props": {"invert": True},
                                  "inputs": {"Strength": 1.0, "Distance": 1.0, "Height": link("Noise Texture", "Fac"),
                                             "Normal": link("Normal Map", "Normal")}}
    assert d["nodes"]["Normal Map"] == {"type": "ShaderNodeNormalMap", "props": {"space": "TANGENT", "uv_map": ""},
                                        "inputs": {"Strength": pytest.approx(0.7),
                                                   "Color": link("Image Texture", "Color")}}
    assert d["nodes"]["Image Texture"]["props"]["colorspace"] == "Non-Color"
    assert "normal_map" not in d and "bump" not in d  # the old material-level keys are gone
    assert exporter.needs_uvs(m)
    # A closure's Normal left unlinked is no key.
    nt.links.remove(g.inputs["Normal"].links[0])
    d, _, _, _ = export_material(m)
    assert "normal" not in d and "nodes" not in d


def test_unsupported_node_is_one_warning_naming_material_and_node(empty_scene):
    m, nt, out = node_material("Ground")
    attr = nt.nodes.new("ShaderNodeWireframe")  # not in the core
    assert attr.bl_idname not in export_nodes.SUPPORTED
    diffuse_from(nt, out, attr.outputs["Fac"])
    d, _, warnings, _ = export_material(m)
    assert d["color"] == pytest.approx([0.8, 0.8, 0.8]) and "nodes" not in d
    assert warnings == ["node not supported (the input it feeds keeps its own value): "
                        "'Ground': Wireframe (Diffuse BSDF Color uses 0.8 grey)"], warnings
    toon = nt.nodes.new("ShaderNodeBsdfToon")
    nt.links.new(toon.outputs[0], out.inputs["Surface"])
    d, _, warnings, _ = export_material(m)
    assert d == {"type": "diffuse", "color": 0.8}
    assert warnings == ["closure not supported (rendered as 0.8 grey diffuse): 'Ground': Toon BSDF"]


def test_the_active_cycles_output_is_exported(empty_scene):
    m, nt, out = node_material("Outputs")
    out.target = 'ALL'
    e = nt.nodes.new("ShaderNodeEmission")
    nt.links.new(e.outputs[0], out.inputs["Surface"])
    eevee = nt.nodes.new("ShaderNodeOutputMaterial")
    eevee.target = 'EEVEE'
    g = nt.nodes.new("ShaderNodeBsdfGlossy")
    nt.links.new(g.outputs[0], eevee.inputs["Surface"])
    assert export_material(m)[0]["type"] == "emission"
    cyc = nt.nodes.new("ShaderNodeOutputMaterial")
    cyc.target = 'CYCLES'
    d = nt.nodes.new("ShaderNodeBsdfDiffuse")
    nt.links.new(d.outputs[0], cyc.inputs["Surface"])
    assert export_material(m)[0]["type"] == "diffuse"  # a Cycles output wins over an All one


def test_mix_shader_with_a_linked_factor_weights_emission_by_nodes(empty_scene):
    m, nt, out = node_material("Glow")
    ch = nt.nodes.new("ShaderNodeTexChecker")
    e = nt.nodes.new("ShaderNodeEmission")
    e.inputs["Strength"].default_value = 3.0
    dif = nt.nodes.new("ShaderNodeBsdfDiffuse")
    mix = nt.nodes.new("ShaderNodeMixShader")
    nt.links.new(ch.outputs["Fac"], mix.inputs["Fac"])
    nt.links.new(dif.outputs[0], mix.inputs[1])
    nt.links.new(e.outputs[0], mix.inputs[2])
    nt.links.new(mix.outputs[0], out.inputs["Surface"])
    d, table, warnings, _ = export_material(m)
    assert not warnings, warnings
    nodes = d["nodes"]
    fac = d["factor"]["link"]
    assert nodes[fac]["props"] == {"operation": "ADD", "use_clamp": True}  # Cycles clamps the factor
    assert nodes[fac]["inputs"]["Value"] == link("Checker Texture", "Fac")
    # emission = (colour x strength) x factor, the factor being the emission's weight (part b)
    em = nodes[d["emission"]["link"]]
    assert em["type"] == "ShaderNodeVectorMath" and em["props"] == {"operation": "SCALE"}
    assert em["inputs"]["Vector"] == [3.0, 3.0, 3.0] and em["inputs"]["Scale"] == d["factor"]
    assert d["strength"] == 1.0 and d["two_sided"] is True
    assert "emission" not in table[d["b"]] and "strength" not in table[d["b"]]


def test_white_transparent_in_a_mix_is_the_transparent_closure_not_a_cut_out(empty_scene):
    """Cycles 3.4 keeps a Mix's Transparent BSDF as a closure of the mix's weight: paths pick it
    by that weight, next-event estimation lights the other closure at every hit, shadow rays pass
    filtered by it. The exporter writes the same mix (once a coverage cut-out: issue 30)."""
    m, nt, out = node_material("Leaf")
    ch = nt.nodes.new("ShaderNodeTexChecker")
    t = nt.nodes.new("ShaderNodeBsdfTransparent")
    dif = nt.nodes.new("ShaderNodeBsdfDiffuse")
    mix = nt.nodes.new("ShaderNodeMixShader")
    nt.links.new(ch.outputs["Fac"], mix.inputs["Fac"])
    nt.links.new(dif.outputs[0], mix.inputs[1])
    nt.links.new(t.outputs[0], mix.inputs[2])
    nt.links.new(mix.outputs[0], out.inputs["Surface"])
    d, table, warnings, _ = export_material(m)
    assert not warnings and d["type"] == "mix" and "alpha" not in d
    assert table[d["a"]]["type"] == "diffuse"
    assert table[d["b"]]["type"] == "transparent" and table[d["b"]]["color"] == [1.0, 1.0, 1.0]
    fac = d["nodes"][d["factor"]["link"]]
    assert fac["inputs"]["Value"] == link("Checker Texture", "Fac")


def test_the_addons_node_list_is_the_cores(empty_scene):
    """One list of node types in the addon (export/nodes.py SUPPORTED) and the core's own."""
    mod = native.get()
    if not hasattr(mod, "shader_node_types"):
        pytest.skip("this core does not list its node types (_native.shader_node_types)")
    assert export_nodes.SUPPORTED == set(mod.shader_node_types()) - export_nodes.CONSTANT_NODES


def test_a_long_chain_exports(empty_scene):
    """1100 Math nodes in a row (deeper than Python's default recursion allows) export."""
    m, nt, out = node_material("Chain")
    prev = nt.nodes.new("ShaderNodeTexChecker").outputs["Fac"]
    for _ in range(1100):
        a = nt.nodes.new("ShaderNodeMath")
        nt.links.new(prev, a.inputs[0])
        prev = a.outputs[0]
    diffuse_from(nt, out, prev)
    d, _, warnings, _ = export_material(m)
    assert len(d["nodes"]) == 1101 and not warnings


def test_every_supported_node_exports_and_the_core_accepts_it(empty_scene):
    """Each node type of SUPPORTED, with Blender's defaults, its first output into a Diffuse
    colour: written with its type, properties and every available input that has a value; the
    core then loads the material (once it lists its node types: it refuses unknown ones)."""
    scenes.add_camera(empty_scene)
    for kind in sorted(export_nodes.SUPPORTED):
        m, nt, out = node_material(kind)
        n = nt.nodes.new(kind)
        if kind in ("ShaderNodeTexImage", "ShaderNodeTexEnvironment"):
            n.image = bpy.data.images.new("generated", 4, 4)
        diffuse_from(nt, out, next(s for s in n.outputs if s.enabled))
        scenes.add_plane(empty_scene, kind, 1.0, m)
        mat, _, warnings, _ = export_material(m)
        assert not warnings, (kind, warnings)
        entry = mat["nodes"][n.name]
        assert entry["type"] == kind and mat["color"]["link"] == n.name
        valued = {s.identifier for s in n.inputs if s.enabled and hasattr(s, "default_value") and not s.hide_value}
        assert set(entry.get("inputs", {})) == valued, kind
    mod = native.get()
    if hasattr(mod, "shader_node_types"):
        scene = export.export_scene(bpy.context.evaluated_depsgraph_get()).build(mod)
        assert len(scene.material_names) >= len(export_nodes.SUPPORTED)


def test_a_scene_with_linked_emission_exports(empty_scene):
    """Whole-scene export with node-driven emission (the visibility checks read emission
    colours and strengths that may now be links)."""
    m, nt, out = node_material("Glowing checker")
    ch = nt.nodes.new("ShaderNodeTexChecker")
    e = nt.nodes.new("ShaderNodeEmission")
    nt.links.new(ch.outputs["Color"], e.inputs["Color"])
    nt.links.new(ch.outputs["Fac"], e.inputs["Strength"])
    nt.links.new(e.outputs[0], out.inputs["Surface"])
    scenes.add_plane(empty_scene, "Panel", 1.0, m)
    scenes.add_camera(empty_scene)
    d = export.export_scene(bpy.context.evaluated_depsgraph_get()).description["materials"]["Glowing checker"]
    assert d["emission"] == link("Checker Texture", "Color")
    assert d["nodes"][d["strength"]["link"]]["props"] == {"operation": "MAXIMUM", "use_clamp": False}
