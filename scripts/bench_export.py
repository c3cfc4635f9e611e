"""Export timing: a 1 M-triangle mesh from Blender's depsgraph to the native scene.

    blender -b --factory-startup --python scripts/bench_export.py [-- --triangles N]

Prints the time of the export (depsgraph -> numpy arrays through foreach_get), of the native
build (SceneBuilder.add_mesh + finalize: world-space copy, Embree BVH) and the split between
the per-vertex path (all smooth / all flat) and the per-corner path (mixed smooth/flat)."""
import math
import os
import sys
import time

import bpy

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "addon"))
import addon_utils  # noqa: E402

args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
triangles = int(args[args.index("--triangles") + 1]) if "--triangles" in args else 1_000_000
addon_utils.enable("gradphoton", default_set=False)
from gradphoton import export, native  # noqa: E402

N = native.get()
for ob in list(bpy.data.objects):
    bpy.data.objects.remove(ob)
n = int(math.ceil(math.sqrt(triangles / 2))) + 1
bpy.ops.mesh.primitive_grid_add(x_subdivisions=n, y_subdivisions=n, size=10)
grid = bpy.context.active_object
bpy.ops.object.shade_smooth()
bpy.ops.object.camera_add(location=(0, 0, 20))
bpy.context.scene.camera = bpy.context.active_object


def run(label, repeats=3):
    dg = bpy.context.evaluated_depsgraph_get()
    best = None
    for _ in range(repeats):
        t0 = time.perf_counter()
        ex = export.export_scene(dg)
        t1 = time.perf_counter()
        scene = ex.build(N)
        t2 = time.perf_counter()
        if best is None or t1 - t0 < best[0]:
            best = (t1 - t0, t2 - t1)
    print(f"EXPORT {label}: {ex.triangle_count:,} triangles: export {best[0] * 1000:.0f} ms, "
          f"native build {best[1] * 1000:.0f} ms (SceneBuilder + finalize, Embree BVH)")
    assert scene.triangle_count == ex.triangle_count


run("smooth (per-vertex normals)")
grid.data.polygons.foreach_set("use_smooth", [False] * len(grid.data.polygons))
grid.data.update()
run("flat (no normals)")
grid.data.polygons[0].use_smooth = True
grid.data.update()
run("mixed smooth/flat (per-corner normals)")

# A textured material (image colour + normal map, export/texture.py): the UV map is exported,
# which takes the per-corner path; the image is read once by the native build.
import tempfile  # noqa: E402

import numpy as np  # noqa: E402

for p in grid.data.polygons:
    p.use_smooth = True
grid.data.update()
img = bpy.data.images.new("bench_pattern", 512, 512)
img.pixels.foreach_set(np.random.default_rng(1).random(512 * 512 * 4).astype(np.float32))
img.filepath_raw = os.path.join(tempfile.mkdtemp(), "bench_pattern.png")
img.file_format = 'PNG'
img.save()
mat = bpy.data.materials.new("Textured")
mat.use_nodes = True
nt = mat.node_tree
bsdf = nt.nodes["Principled BSDF"]
tex = nt.nodes.new("ShaderNodeTexImage")
tex.image = bpy.data.images.load(img.filepath_raw)
nt.links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
nmap = nt.nodes.new("ShaderNodeNormalMap")
ntex = nt.nodes.new("ShaderNodeTexImage")
ntex.image = tex.image
nt.links.new(ntex.outputs["Color"], nmap.inputs["Color"])
nt.links.new(nmap.outputs["Normal"], bsdf.inputs["Normal"])
grid.data.materials.append(mat)
run("textured (image + normal map: UVs, per-corner)")
