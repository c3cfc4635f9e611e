"""Object ray visibility as Cycles 3.4 applies it (Object Properties > Visibility > Ray
Visibility), as scene-format keys (docs/scene-format.md) on a variant of a surface's materials
and on lights:

  Camera        `visible_to_camera`   camera rays pass through a surface hidden from them
  Shadow        `casts_shadow`        shadow rays pass through
  Diffuse       `visible_to_diffuse`  bounce rays of that kind (the kind of the BSDF lobe that
  Glossy        `visible_to_glossy`   sampled them) pass through; a light or emissive surface
  Transmission  `visible_to_transmission`  lights only the lobes of the kinds it is visible to

The core honours Camera and Shadow in every method, Diffuse/Glossy/Transmission in path
tracing only (native/integrators/path_tracer.cpp): another method renders them as visible, a
counted warning naming the method. Volume Scatter is a warning (volumes are not rendered).

Light objects: Blender 3.4 creates them with Camera off, so Cycles does not show a light to
the camera unless the user turns it on (area lights are pass-through surfaces: export/light.py).
"""

LOBE_SWITCHES = (("visible_diffuse", "visible_to_diffuse", "diffuse"),
                 ("visible_glossy", "visible_to_glossy", "glossy"),
                 ("visible_transmission", "visible_to_transmission", "transmission"))
LOBE_KEYS = tuple(key for _, key, _ in LOBE_SWITCHES)
# Methods whose core integrator honours the per-kind keys (the rest see every surface).
METHODS_WITH_LOBE_VISIBILITY = ("pt",)


def lobe_flags(ob, warnings):
    """The object's Diffuse / Glossy / Transmission switches that are off, as scene-format keys."""
    if not getattr(ob, "visible_volume_scatter", True):
        warnings.add("volume scatter visibility not honoured (volumes are not rendered)", ob.name)
    return {key: False for attr, key, _ in LOBE_SWITCHES if not getattr(ob, attr, True)}


def surface_flags(ob, warnings):
    """Material flags for a geometry object's surfaces: {} when Cycles' defaults apply."""
    flags = lobe_flags(ob, warnings)
    if not ob.visible_camera:
        flags["visible_to_camera"] = False
    if not ob.visible_shadow:
        flags["casts_shadow"] = False
    return flags


def check_light(ob, la, warnings):
    """Warnings for the light visibility the core cannot give (area lights are handled by
    export/light.py as pass-through surfaces)."""
    if la.type != 'AREA' and ob.visible_camera and (la.type == 'SUN' or la.shadow_soft_size > 0):
        warnings.add("point, spot and sun lights are not shown to the camera or in mirrors", ob.name)
    if not la.use_shadow:
        warnings.add("light without shadows renders with shadows", ob.name)


def check_method(description, method, warnings):
    """One warning per object whose Diffuse/Glossy/Transmission switches `method` ignores."""
    if method in METHODS_WITH_LOBE_VISIBILITY:
        return
    for name, d in list(description["materials"].items()) + [(d.get("name", "?"), d) for d in description["lights"]]:
        off = [key[len("visible_to_"):] for key in LOBE_KEYS if d.get(key) is False]
        if off:
            warnings.add(f"diffuse/glossy/transmission ray visibility honoured by path tracing only, not by {method} "
                         "(still visible to these rays)", f"{name}: {', '.join(off)}")
