"""Object ray visibility as Cycles 3.4 applies it (Object Properties > Visibility > Ray
Visibility), as scene-format keys (docs/scene-format.md) on a variant of a surface's materials
and on lights:

  Camera        `visible_to_camera`   camera rays pass through a surface hidden from them
  Shadow        `casts_shadow`        shadow rays pass through
  Diffuse       `visible_to_diffuse`  bounce rays of that kind (the kind of the BSDF lobe that
  Glossy        `visible_to_glossy`   sampled them) pass through; a light or emissive surface
  Transmission  `visible_to_transmission`  lights only the lobes of the kinds it is visible to

World > Settings > Ray Visibility becomes the same keys on the environment (Camera, Diffuse,
Glossy, Transmission; the core applies Cycles' rule for the World, docs/blender.md).

The core honours Camera and Shadow in every method, the World's Camera too. Which methods honour
Diffuse/Glossy/Transmission the method itself declares (`_native.method_info`'s
'lobe_visibility': of surfaces, of lights and the World): another method renders them as
visible, a counted warning naming the method and the object. Volume Scatter is a warning
(not honoured: media scatter to every light).

Mask > Holdout (Object Properties > Visibility, Cycles' is_holdout), or a collection's Holdout in
the view layer, becomes the `holdout` key of the surface's materials: camera rays that meet it give no colour and alpha 0, as Cycles renders
a holdout (black without Film > Transparent). Which methods honour it each declares
(`_native.method_info`'s 'holdout'); another renders the object as a plain surface, a warning
naming the method and the object.

Light objects: Blender 3.4 creates them with Camera off, so Cycles does not show a light to
the camera unless the user turns it on (area lights are pass-through surfaces: export/light.py).
"""

LOBE_SWITCHES = (("visible_diffuse", "visible_to_diffuse", "diffuse"),
                 ("visible_glossy", "visible_to_glossy", "glossy"),
                 ("visible_transmission", "visible_to_transmission", "transmission"))
LOBE_KEYS = tuple(key for _, key, _ in LOBE_SWITCHES)
def lobe_flags(ob, warnings):
    """The object's Diffuse / Glossy / Transmission switches that are off, as scene-format keys."""
    if not getattr(ob, "visible_volume_scatter", True):
        warnings.add("volume scatter visibility not honoured", ob.name)
    return {key: False for attr, key, _ in LOBE_SWITCHES if not getattr(ob, attr, True)}


def surface_flags(ob, warnings, holdout=None):
    """Material flags for a geometry object's surfaces: {} when Cycles' defaults apply.
    `holdout`: whether the object is held out in the view layer (is_held_out), else its own
    Mask > Holdout alone."""
    flags = lobe_flags(ob, warnings)
    if not ob.visible_camera:
        flags["visible_to_camera"] = False
    if not ob.visible_shadow:
        flags["casts_shadow"] = False
    if holdout if holdout is not None else getattr(ob, "is_holdout", False):
        flags["holdout"] = True
    return flags


def is_held_out(inst, view_layer):
    """Cycles 3.4's rule (blender/object.cpp): an object is a holdout when its parent (the
    instancer for an instance, else itself) is held out in the view layer: its own Mask >
    Holdout, or a collection of it with Holdout ticked in the view layer (Outliner / View Layer
    > Collections, LayerCollection.holdout). Blender's Object.holdout_get answers both."""
    holder = inst.parent if inst.is_instance and inst.parent is not None else inst.object
    if view_layer is None:
        return getattr(holder, "is_holdout", False)
    return holder.holdout_get(view_layer=view_layer)


def check_light(ob, la, warnings):
    """Warnings for the light visibility the core cannot give (area lights are handled by
    export/light.py as pass-through surfaces)."""
    if la.type != 'AREA' and ob.visible_camera and (la.type == 'SUN' or la.shadow_soft_size > 0):
        warnings.add("point, spot and sun lights are not shown to the camera or in mirrors", ob.name)
    if not la.use_shadow:
        warnings.add("light without shadows renders with shadows", ob.name)


def world_flags(world, warnings):
    """World > Settings > Ray Visibility (Cycles' `world.cycles_visibility`) switches that are off,
    as scene-format keys of the environment."""
    vis = getattr(world, "cycles_visibility", None)
    if vis is None:  # Cycles' add-on not registered: its defaults, all visible
        return {}
    if not getattr(vis, "scatter", True):
        warnings.add("volume scatter visibility not honoured", f"world '{world.name}'")
    flags = {key: False for attr, key, _ in LOBE_SWITCHES if not getattr(vis, attr[len("visible_"):], True)}
    if not getattr(vis, "camera", True):
        flags["visible_to_camera"] = False
    return flags


def _roles(name, d):
    """What a description entry's per-kind switches act on: 'lights' for a light object (a light,
    an area light's pass-through surface, the World), 'surfaces' for a mesh's material, both for
    an emissive material (the surface lights the scene too)."""
    if name.startswith("__light") or d.get("type") in ("point", "spot", "sun", "world"):
        return ("lights",)
    emissive = _maybe_positive(d.get("strength", 0)) and any(_maybe_positive(c) for c in _colour(d.get("emission", 0)))
    return ("surfaces", "lights") if emissive else ("surfaces",)


def _colour(c):
    return c if isinstance(c, (list, tuple)) else (c,)


def _maybe_positive(v):
    """A constant above zero, or a link into the material's node graph (it may be)."""
    return isinstance(v, dict) or v > 0


def holdout_methods():
    """The labels of the methods that honour Holdout, as each declares (method_info)."""
    from .. import native
    return [native.method_label(m) for m in native.methods() if (native.method_info(m) or {}).get("holdout")]


def check_method(description, method, warnings, honoured=None):
    """One warning per object (material, light, the World) whose Diffuse/Glossy/Transmission
    switches `method` ignores. `honoured`: {'surfaces': bool, 'lights': bool} as the core's method
    declares it (native.method_info), looked up when not given."""
    info = None
    if honoured is None:
        from .. import native
        info = native.method_info(method) or {}
    # Held-out surfaces are material variants "<material> [holdout=True, ...]" (material.py's name_for).
    holdouts = sorted({name.split(" [")[0] for name, d in description["materials"].items() if d.get("holdout")})
    if holdouts and not (info.get("holdout", True) if info is not None else honoured.get("holdout", True)):
        warnings.add(f"Holdout not rendered by {method}: objects set to Mask > Holdout and Holdout shaders "
                     f"render as plain surfaces ({', '.join(holdout_methods())} hold them out)",
                     ", ".join(f"material '{m}'" for m in holdouts))
    if honoured is None:
        honoured = info.get("lobe_visibility") or {}
    entries = list(description["materials"].items()) + [(d.get("name", "?"), d) for d in description["lights"]]
    if description.get("environment"):
        entries.append(("World", dict(description["environment"], type="world")))
    for name, d in entries:
        off = [key[len("visible_to_"):] for key in LOBE_KEYS if d.get(key) is False]
        ignored = [role for role in _roles(name, d) if not honoured.get(role, False)]
        if off and ignored:
            warnings.add(f"diffuse/glossy/transmission ray visibility of {' and '.join(ignored)} not honoured by {method} "
                         "(still visible to these rays)", f"{name}: {', '.join(off)}")
