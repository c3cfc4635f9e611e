"""Time of a World edit in the rendered viewport's path (Scene.update_description, what
sync.py's plan applies after a World change), for a World graph lit by an HDRI: the graph
(Background <- MixRGB Multiply tint <- Environment Texture <- Mapping <- Texture Coordinate: a
colour from a node, which only the graph route says) edited by a Mapping rotation, a
Strength, sent unchanged (a material edit re-sends the World), and by a colour multiplier
(which changes the sampling: baked again); then that Background inside a Mix with a constant
one (a sum of Backgrounds: world_graph.h's terms) edited by its Strength, the constant one's
colour and the Mix factor. Best of --repeat per edit, seconds.

    /usr/bin/python3 scripts/bench_world_edit.py [--build build] [--hdri forest.exr] [--repeat 5]

--build: the build whose python module is timed (another checkout's build for a before/after).
"""
import argparse
import json
import os
import sys
import time

p = argparse.ArgumentParser()
p.add_argument("--build", default=os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "build"))
p.add_argument("--hdri", default="/usr/share/blender/datafiles/studiolights/world/forest.exr")
p.add_argument("--repeat", type=int, default=5)
a = p.parse_args()
sys.path.insert(0, os.path.join(os.path.abspath(a.build), "python"))
from gradphoton import _native as native  # noqa: E402

MATERIALS = {"grey": {"type": "diffuse", "color": 0.5}}


def world(rot_z=0.0, strength=1.0, tint=1.0):
    return {"type": "graph",
            "surface": {"type": "background", "strength": strength, "color": {"link": "tint", "output": "Color"}},
            "nodes": {"env": {"type": "ShaderNodeTexEnvironment", "props": {"image": a.hdri},
                              "inputs": {"Vector": {"link": "map", "output": "Vector"}}},
                      "tint": {"type": "ShaderNodeMixRGB", "props": {"blend_type": "MULTIPLY"},
                               "inputs": {"Fac": 1.0, "Color1": {"link": "env", "output": "Color"}, "Color2": [tint, tint, tint, 1]}},
                      "map": {"type": "ShaderNodeMapping",
                              "inputs": {"Vector": {"link": "tc", "output": "Generated"}, "Rotation": [0, 0, rot_z]}},
                      "tc": {"type": "ShaderNodeTexCoord"}}}


def mixed(strength=1.0, colour=0.4, factor=0.3):
    """The graph above inside a Mix Shader with a constant Background."""
    env = world(strength=strength)
    env["surface"] = {"type": "mix", "factor": factor, "a": env["surface"],
                      "b": {"type": "background", "color": [colour, colour * 0.8, colour * 0.5], "strength": 2.0}}
    return env


def description(env):
    return json.dumps({"materials": MATERIALS, "environment": env})


scene_json = {"camera": {"position": [0, -4, 1.5], "look_at": [0, 0, 0.4], "fov": 40, "width": 64, "height": 64},
              "materials": MATERIALS, "environment": world(),
              "objects": [{"type": "quad", "center": [0, 0, 0], "u": [3, 0, 0], "v": [0, 3, 0], "material": "grey"}]}
t0 = time.perf_counter()
scene = native.load_scene_json(json.dumps(scene_json))
print(f"module {native.__file__}")
print(f"first load (image read and baked): {time.perf_counter() - t0:.3f} s")
edits = {
    "rotation": lambda i: world(rot_z=0.1 * (i + 1)),
    "strength": lambda i: world(strength=1.0 + 0.1 * (i + 1)),
    "unchanged": lambda i: world(),
    "colour (bakes again)": lambda i: world(tint=1.0 + 0.1 * (i + 1)),
}
mixed_edits = {
    "strength inside a Mix": lambda i: mixed(strength=1.0 + 0.1 * (i + 1)),
    "constant colour inside a Mix": lambda i: mixed(colour=0.4 + 0.05 * (i + 1)),
    "Mix factor": lambda i: mixed(factor=0.3 + 0.05 * (i + 1)),
}
for name, make, first in [(n, m, world) for n, m in edits.items()] + [(n, m, mixed) for n, m in mixed_edits.items()]:
    best = 1e9
    for i in range(a.repeat):
        scene.update_description(description(first()))  # back to the first World
        d = description(make(i))
        t0 = time.perf_counter()
        scene.update_description(d)
        best = min(best, time.perf_counter() - t0)
    print(f"{name}: {best * 1e3:.3f} ms (best of {a.repeat})")
