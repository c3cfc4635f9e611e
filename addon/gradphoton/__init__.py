# gradphoton: a Blender render engine for caustics, light through glass and dispersion.
# Cycles' layout: the engine (native core) knows nothing of Blender; export/ is the one layer
# that converts Blender data; engine.py's RenderEngine methods delegate to session.py.
bl_info = {
    "name": "gradphoton",
    "author": "gradphoton developers",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "Render Properties > Render Engine > gradphoton",
    "description": "Physically based renderer: path tracing, photon mapping, gradient-domain methods",
    "category": "Render",
}

if "bpy" in locals():
    import importlib
    for _m in ("native", "properties", "export", "sync", "session", "viewport", "engine", "ui", "operators"):
        if _m in locals():
            importlib.reload(locals()[_m])

import bpy

from . import native, properties, engine, ui, operators

_modules = (properties, engine, ui, operators)


def register():
    native.load()  # never raises: a missing module is reported once when rendering
    for m in _modules:
        m.register()


def unregister():
    for m in reversed(_modules):
        m.unregister()
