"""The RenderEngine: one-line delegations to session.py (Cycles' engine.py habit)."""
import bpy

from . import session


class GradphotonRenderEngine(bpy.types.RenderEngine):
    bl_idname = "GRADPHOTON"
    bl_label = "gradphoton"
    bl_use_preview = False
    bl_use_postprocess = True
    bl_use_shading_nodes_custom = False  # edit materials with Blender's shader nodes
    bl_use_eevee_viewport = True         # material preview and viewport through EEVEE

    def __init__(self):
        self.session = None

    def render(self, depsgraph):
        self.session = session.RenderSession(self)
        self.session.render(depsgraph)

    def update_render_passes(self, scene=None, renderlayer=None):
        session.register_passes(self, scene, renderlayer)


def register():
    bpy.utils.register_class(GradphotonRenderEngine)


def unregister():
    bpy.utils.unregister_class(GradphotonRenderEngine)
