"""Export a .blend to gradphoton's JSON scene format, so the command line renders what Blender shows:

    blender -b scene.blend --python scripts/export_blend.py -- out.json [--uvs]
    build/gradphoton render out.json -o out.exr

Uses the addon's exporter (the same code the render engine uses), from this checkout."""
import os
import sys

import bpy

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "addon"))
import addon_utils  # noqa: E402

args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
if not args:
    sys.exit("usage: blender -b scene.blend --python scripts/export_blend.py -- out.json [--uvs]")
addon_utils.enable("gradphoton", default_set=False)
from gradphoton import operators  # noqa: E402

scene = bpy.context.scene
depsgraph = bpy.context.evaluated_depsgraph_get()
exported = operators.write_scene_json(depsgraph, args[0], export_uvs="--uvs" in args)
for line in exported.warnings.lines():
    print("warning:", line)
print(f"exported {exported.triangle_count:,} triangles, {len(exported.description['lights'])} lights "
      f"to {args[0]} in {exported.seconds:.3f} s")
