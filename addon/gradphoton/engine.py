"""The RenderEngine: one-line delegations to session.py (F12 renders) and viewport.py (the
rendered viewport), Cycles' engine.py habit."""
import bpy

from . import session, viewport


class GradphotonRenderEngine(bpy.types.RenderEngine):
    bl_idname = "GRADPHOTON"
    bl_label = "gradphoton"
    bl_use_preview = False
    bl_use_postprocess = True
    bl_use_shading_nodes_custom = False  # edit materials with Blender's shader nodes
    bl_use_eevee_viewport = True         # Material Preview through EEVEE; Rendered shading is ours

    def __init__(self):
        self.session = None
        self.viewport = None
        self.persistent = session.PersistentScene()  # kept between frames with Persistent Data

    def __del__(self):
        viewport.free(self)

    def render(self, depsgraph):
        self.session = session.RenderSession(self)
        self.session.render(depsgraph)

    def view_update(self, context, depsgraph):
        viewport.view_update(self, context, depsgraph)

    def view_draw(self, context, depsgraph):
        viewport.view_draw(self, context, depsgraph)

    def update_render_passes(self, scene=None, renderlayer=None):
        session.register_passes(self, scene, renderlayer)


def register():
    bpy.utils.register_class(GradphotonRenderEngine)


def unregister():
    bpy.utils.unregister_class(GradphotonRenderEngine)
