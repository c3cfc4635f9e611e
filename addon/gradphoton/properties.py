"""Settings: Scene.gradphoton (render), ViewLayer.gradphoton (passes), Material.gradphoton.

Method names and pass names come from the native module (`_native.methods()`,
`_native.passes()`); which passes a method writes and whether it estimates its error come from
the method itself (`native.method_info`). Each method's parameters are properties made from its
declarations in the core (`_native.method_params`, integrators/methods.cpp): its own names,
defaults, ranges and descriptions, one group per method (Scene.gradphoton.sppm.alpha), so a
parameter added or renamed there appears here with no edit.
"""
import bpy
import math
import re

from bpy.app.handlers import persistent
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty

from . import native

_method_items = []  # Blender needs dynamic enum strings kept alive


def method_info(method):
    """What `method` produces (native.method_info): its passes and whether it estimates its error."""
    return native.method_info(method)


def method_items(self, context):
    _method_items.clear()
    for i, name in enumerate(native.methods() or ["pt"]):
        d = native.method_description(name) or {}
        label, desc = d.get("label", name), d.get("tooltip", name)
        _method_items.append((name, label, desc, i))
    return _method_items


# ---- Method parameters: made from the core's declarations (_native.method_params) ----
# Each method has its own property group, Scene.gradphoton.<method, '-' as '_'>, with a property
# per parameter it declares, named as the parameter, with its default, range and description.
# A parameter declared `shared` (seed, threads, tile size, spectral mode) is one property of the
# render settings for every method; film_transparent is Blender's own (Film > Transparent).
FILM_TRANSPARENT = "film_transparent"
SHARED_PROPS = {"spectral": "spectral_mode"}  # shared parameter -> property name, where they differ
BLENDER_HELD = {FILM_TRANSPARENT}             # held by Blender itself (scene.render)
# Cycles counts bounces (0 = direct light only); the core counts path segments, the camera
# ray and the segment to the light included, so max_depth = bounces + 2 (path_tracer.h).
BOUNCES_TO_SEGMENTS = 2
BOUNCES = {"max_depth": "max_bounces"}  # parameter in segments -> property in bounces


def method_group(method):
    """Attribute of Scene.gradphoton holding `method`'s parameters."""
    return method.replace("-", "_")


def declared(method):
    """The method's parameter declarations, [] without the module or for an unknown method."""
    return native.method_params(method)


def prop_name(decl):
    """The property that holds a parameter: its name, or max_bounces for max_depth (in bounces)."""
    if decl["shared"]:
        return SHARED_PROPS.get(decl["name"], decl["name"])
    return BOUNCES.get(decl["name"], decl["name"])


def auto_toggle(decl):
    """The "Auto" toggle's property for a parameter whose 0 means automatic, else None."""
    return "use_auto_" + decl["name"] if decl["zero_means"] else None


def holder(settings, method, decl):
    """The property group that holds `decl` for `method`: the render settings for a shared one."""
    return settings if decl["shared"] else getattr(settings, method_group(method))


def native_value(settings, method, decl):
    """The value the core receives for one of `method`'s parameters."""
    group = holder(settings, method, decl)
    toggle = auto_toggle(decl)
    if toggle and getattr(group, toggle):
        return 0
    value = getattr(group, prop_name(decl))
    return value + BOUNCES_TO_SEGMENTS if decl["name"] in BOUNCES else value


def params_of(settings, method=None):
    """The native parameters of `method` (default: the chosen one) from the render settings:
    each parameter it declares but the ones Blender holds itself (film_transparent)."""
    method = method or settings.method
    return {d["name"]: native_value(settings, method, d) for d in declared(method) if d["name"] not in BLENDER_HELD}


def read_when(settings, method, decl):
    """False when the declaration says the parameter is read only with another one's value
    ("photon_sampler=adaptive") and that is not the value now: the panel greys it out."""
    cond = decl["read_when"]
    if not cond or " " in cond or cond.count("=") != 1:
        return True
    name, value = cond.split("=")
    other = next((d for d in declared(method) if d["name"] == name), None)
    if other is None:
        return True
    return str(native_value(settings, method, other)) == value


# "thesis" in a declaration's reference is Hachisuka's (DESIGN.md): a tooltip says whose.
THESIS = "Hachisuka 2011,"


def _cited(text):
    return re.sub(r"\bthesis\b", THESIS, text)


def choice_descriptions(decl):
    """{choice: what it does} from a description written "what it sets; a: ...; b: ...", each
    choice's item in the menu then says what it does instead of repeating its name."""
    out = {}
    for part in decl["description"].split("; ")[1:]:
        name, sep, text = part.partition(": ")
        if sep and name in decl["choices"]:
            out[name] = text[0].upper() + text[1:]
    return out


def _tooltip(decl):
    text = decl["description"]
    if decl["type"] == "string" and choice_descriptions(decl):
        text = text.split("; ")[0]  # the choices say the rest, each in its own item
    text = text[0].upper() + text[1:]
    if decl["zero_means"]:
        text += f"; Auto: {_cited(decl['zero_means'])}"
    ref = ", ".join(_cited(x) for x in (decl["symbol"], decl["reference"]) if x)
    if ref:  # the paper last, short
        text += f" ({ref})"
    if decl["name"] in BOUNCES:
        text += f". Core: {decl['name']} = bounces + {BOUNCES_TO_SEGMENTS}"
    return text


def _choice_label(c):
    return c.upper() if len(c) <= 2 else c.capitalize()


def _bound(decl, which):
    """A Blender min/max: open ends nudged inside (Blender's are closed), None when unbounded."""
    v = decl[which]
    if v is None:
        return None
    if decl[which + "_open"]:
        eps = 1e-4 * max(1.0, abs(v))
        v = v + eps if which == "min" else v - eps
    return v


def make_property(decl):
    """{property name: bpy property} for one declaration (with its Auto toggle)."""
    name, kind = decl["name"], decl["type"]
    label, tip = decl["label"], _tooltip(decl)
    default = decl["manual_value"] if decl["zero_means"] else decl["default"]
    kw = {}
    out = {}
    if kind == "bool":
        prop = BoolProperty(name=label, default=bool(default), description=tip)
    elif kind == "string":
        said = choice_descriptions(decl)
        items = [(c, _choice_label(c), said.get(c, c)) for c in decl["choices"]]
        prop = EnumProperty(name=label, default=default, items=items, description=tip)
    else:
        lo, hi = _bound(decl, "min"), _bound(decl, "max")
        if name in BOUNCES:
            default -= BOUNCES_TO_SEGMENTS
            label = "Max Bounces"
            lo = 0
            hi = None if hi is None else hi - BOUNCES_TO_SEGMENTS
        if lo is not None:
            kw["min"] = int(math.ceil(lo)) if kind == "int" else lo
        if hi is not None:
            kw["max"] = int(math.floor(hi)) if kind == "int" else hi
        if kind == "int":
            prop = IntProperty(name=label, default=int(default), description=tip, **kw)
        else:
            prop = FloatProperty(name=label, default=float(default), description=tip,
                                 precision=max(3, -int(math.floor(math.log10(abs(default))))) if default else 3,
                                 **kw)
    if decl["zero_means"]:
        out[auto_toggle(decl)] = BoolProperty(name="Auto", default=True,
                                              description=f"Automatic: {decl['zero_means']}")
    out[prop_name(decl)] = prop
    return out


def _method_settings_class(method):
    annotations = {}
    for d in declared(method):
        if not d["shared"]:
            annotations.update(make_property(d))
    return type(f"GradphotonParams_{method_group(method)}", (bpy.types.PropertyGroup,),
                {"__annotations__": annotations, "__doc__": f"Parameters of {method}"})


def _shared_annotations():
    """The shared parameters' properties (first declaration of each), Blender-held ones aside."""
    out = {}
    for method in native.methods():
        for d in declared(method):
            if d["shared"] and d["name"] not in BLENDER_HELD and prop_name(d) not in out:
                prop = make_property(d)
                if d["name"] == "spectral":  # Blender's capitals for the items, the core's words
                    said = choice_descriptions(d)
                    labels = {"auto": "Auto", "rgb": "RGB", "spectral": "Spectral"}
                    prop[prop_name(d)] = EnumProperty(
                        name="Spectral", default="auto", description=_tooltip(d),
                        items=[(c, labels.get(c, _choice_label(c)), said.get(c, c)) for c in d["choices"]])
                out.update(prop)
    return out


# ---- Settings saved before the parameters were per method (one shared property each) ----
# old property -> (methods, parameter). Values a .blend file holds under the old names are moved
# into each method's group when the file loads (migrate_settings), enums by their identifiers.
_PHOTON = ("ppm", "sppm", "sppm-adaptive", "gpm")
_OLD_ENUMS = {"reconstruction": ("l2", "l1"), "gpm_reconstruction": ("l2", "l1"), "mlt_reconstruction": ("l2", "l1"),
              "photon_hash": ("exact", "stochastic"), "photon_sampler": ("uniform", "adaptive")}
OLD_PROPERTIES = {
    "max_bounces": (("pt", "ppm", "sppm", "sppm-adaptive", "gpt", "gpm", "gdmlt", "spt", "spt-hero", "sgpt"),
                    "max_bounces"),
    "msppm_max_bounces": (("msppm",), "max_bounces"),
    "clamp_direct": (("pt",), "clamp_direct"),
    "clamp_indirect": (("pt",), "clamp_indirect"),
    "photons_per_pass": (_PHOTON, "photons"),
    "alpha": (_PHOTON, "alpha"),
    "use_auto_radius": (_PHOTON + ("msppm",), "use_auto_radius"),
    "initial_radius": (_PHOTON + ("msppm",), "radius"),
    "confidence": (_PHOTON, "confidence"),
    "photon_hash": (_PHOTON, "hash"),
    "poisson_lambda": (("gpt", "gpm", "gdmlt", "sgpt"), "lambda"),
    "reconstruction": (("gpt",), "recon"),
    "photon_sampler": (("ppm", "sppm"), "photon_sampler"),
    "photon_chains": (("ppm", "sppm", "sppm-adaptive"), "chains"),
    "msppm_alpha": (("msppm",), "alpha"),
    "use_auto_msppm_photons": (("msppm",), "use_auto_photons"),
    "msppm_photons": (("msppm",), "photons"),
    "use_auto_msppm_path_samples": (("msppm",), "use_auto_path_samples"),
    "msppm_path_samples": (("msppm",), "path_samples"),
    "gpm_reconstruction": (("gpm",), "recon"),
    "manifold_iterations": (("gpm",), "manifold_iterations"),
    "mlt_mutations": (("gdmlt",), "mutations"),
    "mlt_chains": (("gdmlt",), "chains"),
    "mlt_large_step": (("gdmlt",), "large_step"),
    "mlt_sigma": (("gdmlt",), "sigma"),
    "mlt_primal_share": (("gdmlt",), "primal_share"),
    "mlt_bootstrap": (("gdmlt",), "bootstrap"),
    "mlt_reconstruction": (("gdmlt",), "recon"),
}


# Parameters that became automatic (0) after files were saved with explicit values: a value a
# file holds without its Auto toggle was set before the toggle existed, and stays in force.
NEWLY_AUTO = {"sppm": ("photons",), "gpm": ("photons",)}


def migrate_settings(scene):
    """Moves values saved under the old shared property names into the methods' groups; returns
    the old names it moved. A value the new property refuses is left as it was (and reported)."""
    s = scene.gradphoton
    moved = []
    for old, (methods, new) in OLD_PROPERTIES.items():
        if old not in s.keys():
            continue
        value = s[old]
        if old in _OLD_ENUMS:
            value = _OLD_ENUMS[old][int(value)]
        for method in methods:
            group = getattr(s, method_group(method), None)
            if group is not None and hasattr(group, new):
                setattr(group, new, value)
        del s[old]
        moved.append(old)
    for method, names in NEWLY_AUTO.items():
        group = getattr(s, method_group(method), None)
        for name in names:
            toggle = "use_auto_" + name
            if group is not None and name in group.keys() and toggle not in group.keys():
                setattr(group, toggle, False)
                moved.append(f"{method}.{name}")
    return moved


@persistent
def _migrate_on_load(_):
    for scene in bpy.data.scenes:
        if getattr(scene, "gradphoton", None) is not None:
            migrate_settings(scene)


STOP_RULES = [("TIME", "Time", "Render for a time budget: every method finishes in the same time", 0),
              ("PASSES", "Passes", "Render a number of passes (samples per pixel for path tracing; "
                                   "a photon pass costs much more)", 1),
              ("ERROR", "Target Error", "Render until the estimated relative error falls to a target "
                                        "(methods that estimate their error)", 2)]
_stop_items = []


_viewport_method_items = []


def viewport_method_items(self, context):
    """The render method (default) or any method, for the rendered viewport."""
    _viewport_method_items.clear()
    _viewport_method_items.append(('RENDER', "As Render", "The method chosen for final renders", 0))
    for i, (name, label, desc, _) in enumerate(method_items(self, context)):
        _viewport_method_items.append((name, label, desc, i + 1))
    return _viewport_method_items


def stop_rule_items(self, context):
    """The stop rules the chosen method can use: Target Error only where it estimates its error."""
    _stop_items.clear()
    info = method_info(self.method)
    _stop_items.extend(r for r in STOP_RULES if r[0] != "ERROR" or (info and info["error_estimate"]))
    return _stop_items


def _method_changed(self, context):
    # A Target Error rule left from a method with an estimate becomes the time budget.
    if self.get("stop_rule", 0) == 2 and not (method_info(self.method) or {}).get("error_estimate"):
        self["stop_rule"] = 0
    # The compositor's Render Layers node shows the passes of the new method.
    view_layer = getattr(context, "view_layer", None)
    if view_layer is not None:
        view_layer.update_render_passes()


class _RenderSettings:
    """Scene.gradphoton: method, stop rule, export options; the method parameters are added from
    the core's declarations (_render_settings_class)."""
    method: EnumProperty(name="Method", items=method_items, update=_method_changed,
                         description="How light is transported: each method suits different light")
    stop_rule: EnumProperty(name="Stop", items=stop_rule_items, default=0,
                            description="When the render stops (Esc stops it any time and keeps the image)")
    time_limit: FloatProperty(name="Time Limit", default=30.0, min=0.01, unit='TIME_ABSOLUTE', subtype='TIME_ABSOLUTE',
                              description="Seconds of rendering, the same for every method "
                                          "(the last pass finishes, so a render may run over by one pass)")
    passes: IntProperty(name="Passes", default=64, min=1,
                        description="Passes to render: samples per pixel for path tracing, photon passes "
                                    "for photon methods (one costs as much as many samples)")
    target_error: FloatProperty(name="Target Error", default=0.05, min=1e-4, max=1.0,
                                description="Stop when the method estimates the image's mean error has fallen to "
                                            "this (0.05 = 5 % of the pixels' brightness; Hachisuka 2011, eq. 6.33)")
    error_time_limit: FloatProperty(name="Time Limit", default=0.0, min=0.0, unit='TIME_ABSOLUTE',
                                    subtype='TIME_ABSOLUTE',
                                    description="Stop after this time even if Target Error is not reached yet, "
                                                "whichever comes first (0 = no limit), as Cycles' Time Limit")
    use_animated_seed: BoolProperty(name="Use Animated Seed", default=False,
                                    description="Another seed every frame (a hash of the frame and the seed), "
                                                "as Cycles: the noise changes over an animation")
    viewport_method: EnumProperty(name="Method", items=viewport_method_items, default=0,
                                  description="How light is transported in the rendered viewport "
                                              "(Path Tracing shows a first image soonest)")
    viewport_passes: IntProperty(name="Passes", default=1024, min=0,
                                 description="Passes the rendered viewport refines to (0 = no limit)")
    motion_blur_lights: BoolProperty(name="Blur Moving Lights", default=False,
                                     description="Lights that move during the shutter blur (light samples and "
                                                 "photons follow them). Off: each light stays where it is at the "
                                                 "frame, as in Cycles 3.4, which does not blur lights")
    export_uvs: BoolProperty(name="Export UVs", default=False,
                             description="Export every mesh's UV map, also where no material reads one (for Export "
                                         "Scene): materials with image textures get theirs anyway. Splits "
                                         "vertices at UV seams")


# Blender registers no pass toggle for these: alpha is Combined's Alpha (film_transparent).
NOT_A_PASS_TOGGLE = {"combined", "alpha"}


def _pass_toggles_class():
    """ViewLayer.gradphoton: one use_pass_<name> per pass of the core's table but Combined."""
    annotations = {}
    for name, channels, label in native.passes():
        if name in NOT_A_PASS_TOGGLE:
            continue
        annotations["use_pass_" + name] = BoolProperty(
            name=label, default=False, description=f"Render the {label} pass ({channels} channel(s))",
            update=lambda self, context: context.view_layer.update_render_passes())
    return type("GradphotonViewLayerSettings", (bpy.types.PropertyGroup,), {"__annotations__": annotations})


class GradphotonMaterialSettings(bpy.types.PropertyGroup):
    dispersion: EnumProperty(
        name="Dispersion", default="NONE",
        items=[("NONE", "None", "No dispersion"),
               ("ABBE", "Abbe Number", "Dispersion from the Abbe number V (with the IOR as n_d)"),
               ("CAUCHY", "Cauchy B", "Cauchy's law n = A + B / lambda^2, B in um^2")],
        description="Dispersion of glass (spectral methods)")
    abbe: FloatProperty(name="Abbe Number", default=64.0, min=1.0, max=200.0, description="Abbe number V (BK7: 64)")
    cauchy_b: FloatProperty(name="Cauchy B", default=0.0042, min=0.0, max=1.0, precision=5,
                            description="Cauchy B in um^2 (BK7: 0.0042)")
    emission_one_sided: BoolProperty(
        name="One-Sided Emission", default=False,
        description="Emit from the front face only (Cycles always emits from both faces of a mesh)")


_classes = []


def _render_settings_class():
    """Scene.gradphoton: the settings above, the shared parameters, and one group per method."""
    groups = {}
    for method in native.methods():
        cls = _method_settings_class(method)
        bpy.utils.register_class(cls)
        _classes.append(cls)
        groups[method_group(method)] = PointerProperty(type=cls, name=method)
    annotations = {**_RenderSettings.__annotations__, **_shared_annotations(), **groups}
    return type("GradphotonRenderSettings", (bpy.types.PropertyGroup,),
                {"__annotations__": annotations, "__doc__": _RenderSettings.__doc__})


def register():
    global _classes
    _classes = []
    settings = _render_settings_class()  # registers the method groups first
    _classes += [settings, _pass_toggles_class(), GradphotonMaterialSettings]
    for c in _classes[-3:]:
        bpy.utils.register_class(c)
    bpy.types.Scene.gradphoton = PointerProperty(type=settings)
    bpy.types.ViewLayer.gradphoton = PointerProperty(type=_classes[-2])
    bpy.types.Material.gradphoton = PointerProperty(type=_classes[-1])
    bpy.app.handlers.load_post.append(_migrate_on_load)


def unregister():
    if _migrate_on_load in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.remove(_migrate_on_load)
    del bpy.types.Material.gradphoton
    del bpy.types.ViewLayer.gradphoton
    del bpy.types.Scene.gradphoton
    for c in reversed(_classes):
        bpy.utils.unregister_class(c)
