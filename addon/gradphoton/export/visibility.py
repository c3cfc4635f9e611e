"""Object ray visibility as Cycles 3.4 applies it (Object Properties > Visibility > Ray
Visibility). The core honours two of the switches per surface (material flags, see
docs/scene-format.md): Camera (`visible_to_camera`) and Shadow (`casts_shadow`). Diffuse,
Glossy, Transmission and Volume Scatter switched off are counted warnings: the object stays
visible to those rays.

Light objects: Blender 3.4 creates them with Camera off, so Cycles does not show a light to
the camera unless the user turns it on; their Diffuse/Glossy/Transmission switches decide which
bounces see the light, which the core does not separate (a warning when one is off).
"""

RAY_SWITCHES = (("visible_diffuse", "diffuse"), ("visible_glossy", "glossy"),
                ("visible_transmission", "transmission"), ("visible_volume_scatter", "volume scatter"))


def _warn_ray_switches(ob, warnings):
    off = [label for attr, label in RAY_SWITCHES if not getattr(ob, attr, True)]
    if off:
        warnings.add("ray visibility not honoured (still visible to these rays)", f"{ob.name}: {', '.join(off)}")


def surface_flags(ob, warnings):
    """Material flags for a geometry object's surfaces: {} when Cycles' defaults apply."""
    _warn_ray_switches(ob, warnings)
    flags = {}
    if not ob.visible_camera:
        flags["visible_to_camera"] = False
    if not ob.visible_shadow:
        flags["casts_shadow"] = False
    return flags


def check_light(ob, la, warnings):
    """Warnings for the light visibility the core cannot give (area lights are handled by
    export/light.py as pass-through surfaces)."""
    _warn_ray_switches(ob, warnings)
    if la.type != 'AREA' and ob.visible_camera and (la.type == 'SUN' or la.shadow_soft_size > 0):
        warnings.add("point, spot and sun lights are not shown to the camera or in mirrors", ob.name)
    if not la.use_shadow:
        warnings.add("light without shadows renders with shadows", ob.name)
