"""Operator: export the current scene (as gradphoton would render it) to a JSON scene file for
the `gradphoton` command line."""
import json

import bpy
from bpy_extras.io_utils import ExportHelper

from . import export


def write_scene_json(depsgraph, path, export_uvs=False):
    # As a final render exports it, motion blur included (CLI parity).
    exported = export.export_scene(depsgraph, export_uvs=export_uvs, frame_set=export.scene_frame_set(depsgraph))
    data = exported.to_json()
    data["description"] = f"exported from Blender scene '{exported.name}'"
    with open(path, "w", encoding="utf-8") as f:
        json.dump(data, f)
    return exported


class GRADPHOTON_OT_export_scene(bpy.types.Operator, ExportHelper):
    """Export the scene to gradphoton's JSON scene format (for the command line renderer)"""
    bl_idname = "gradphoton.export_scene"
    bl_label = "Export gradphoton Scene"
    filename_ext = ".json"
    filter_glob: bpy.props.StringProperty(default="*.json", options={'HIDDEN'})

    def execute(self, context):
        depsgraph = context.evaluated_depsgraph_get()
        exported = write_scene_json(depsgraph, self.filepath, context.scene.gradphoton.export_uvs)
        if exported.warnings:
            self.report({'WARNING'}, exported.warnings.summary())
        self.report({'INFO'}, f"Exported {exported.triangle_count:,} triangles to {self.filepath}")
        return {'FINISHED'}


def menu_func(self, context):
    self.layout.operator(GRADPHOTON_OT_export_scene.bl_idname, text="gradphoton Scene (.json)")


def register():
    bpy.utils.register_class(GRADPHOTON_OT_export_scene)
    bpy.types.TOPBAR_MT_file_export.append(menu_func)


def unregister():
    bpy.types.TOPBAR_MT_file_export.remove(menu_func)
    bpy.utils.unregister_class(GRADPHOTON_OT_export_scene)
