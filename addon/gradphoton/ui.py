"""Panels, registered as Cycles registers its own: every gradphoton panel shares
GradphotonPanel, which polls the engine; Blender's shared panels opt in by adding the engine to
their COMPAT_ENGINES (those Blender's own renderer draws, less the ones gradphoton draws itself or
cannot honour, plus the few generic ones Blender lists only for EEVEE: material slots, surface
nodes, world, depth of field). The Light tab has one Light panel: gradphoton's own, with the
settings the core uses."""
import math
import textwrap

import bpy

from . import native, session
from .properties import (FILM_TRANSPARENT, NOT_A_PASS_TOGGLE, auto_toggle, declared, holder,
                         prop_name, read_when)

ENGINE = "GRADPHOTON"


class GradphotonPanel:
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'
    COMPAT_ENGINES = {ENGINE}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES


def _split(layout):
    layout.use_property_split = True
    layout.use_property_decorate = False
    return layout


def reads(method, name):
    """Whether `method` declares parameter `name` (its declarations in the core)."""
    return any(d["name"] == name for d in declared(method))


def draw_param(layout, settings, method, decl):
    """One parameter of `method`: its property, with its "Auto" toggle where 0 means automatic,
    greyed out while the settings leave it unread (its declaration's read_when)."""
    group = holder(settings, method, decl)
    prop = prop_name(decl)
    col = layout.column()
    col.active = read_when(settings, method, decl)
    toggle = auto_toggle(decl)
    if toggle:
        row = col.row(heading=decl["label"], align=True)
        row.prop(group, toggle, text="Auto")
        sub = row.row(align=True)
        sub.active = not getattr(group, toggle)
        sub.prop(group, prop, text="")
    else:
        col.prop(group, prop)


def group_params(method, group):
    """The method's declarations drawn in panel `group`, Blender-held ones aside."""
    return [d for d in declared(method) if d["group"] == group and d["name"] != FILM_TRANSPARENT]


class MethodParamsPanel(GradphotonPanel):
    """A Render tab panel of one group of parameters (their declarations' `group`): drawn for a
    method that declares any, with only the method's own."""
    group = ""

    @classmethod
    def poll(cls, context):
        return super().poll(context) and bool(group_params(context.scene.gradphoton.method, cls.group))

    def draw(self, context):
        layout = _split(self.layout)
        s = context.scene.gradphoton
        for d in group_params(s.method, self.group):
            draw_param(layout, s, s.method, d)


def method_label(method):
    return native.method_label(method)


class GRADPHOTON_PT_render(GradphotonPanel, bpy.types.Panel):
    bl_label = "Rendering"
    bl_context = "render"

    def draw(self, context):
        layout = _split(self.layout)
        if native.error():
            layout.label(text="Native module not loaded: run scripts/setup.sh", icon='ERROR')
        s = context.scene.gradphoton
        layout.prop(s, "method")
        layout.prop(s, "stop_rule")
        rule = s.stop_rule or 'TIME'
        layout.prop(s, {"TIME": "time_limit", "PASSES": "passes", "ERROR": "target_error"}[rule])
        if rule == 'ERROR':  # Cycles' Time Limit beside its Noise Threshold: whichever comes first
            layout.prop(s, "error_time_limit")
        for d in group_params(s.method, "Rendering"):
            if d["name"] not in SPECTRAL_PANEL:
                draw_param(layout, s, s.method, d)


class GRADPHOTON_PT_viewport(GradphotonPanel, bpy.types.Panel):
    bl_label = "Viewport"
    bl_context = "render"
    bl_parent_id = "GRADPHOTON_PT_render"

    def draw(self, context):
        layout = _split(self.layout)
        s = context.scene.gradphoton
        layout.prop(s, "viewport_method")
        layout.prop(s, "viewport_passes")


# Spectral rendering is set in one place, the Spectral sub-panel: the mode (declared in the
# Rendering group) and the method's spectral parameters.
SPECTRAL_PANEL = {"spectral"}
# Methods that always render by wavelength (they refuse spectral mode 'rgb').
SPECTRAL_METHODS = {"spt", "spt-hero", "sgpt"}


def spectral_matters(scene, method):
    """Whether the Spectral sub-panel is worth showing: a spectral method, a material that
    disperses (what spectral mode Auto switches on), or a mode the user set away from Auto."""
    if method in SPECTRAL_METHODS:
        return True
    if not any(d["name"] in SPECTRAL_PANEL or d["group"] == "Spectral" for d in declared(method)):
        return False
    if getattr(scene.gradphoton, "spectral_mode", "auto") != "auto":
        return True
    return any(m.users and getattr(m, "gradphoton", None) is not None and m.gradphoton.dispersion != 'NONE'
               for m in bpy.data.materials)


class GRADPHOTON_PT_spectral(GradphotonPanel, bpy.types.Panel):
    """Spectral mode and the method's spectral parameters, shown once, where spectral rendering
    matters (spectral_matters)."""
    bl_label = "Spectral"
    bl_context = "render"
    bl_parent_id = "GRADPHOTON_PT_render"

    @classmethod
    def poll(cls, context):
        return super().poll(context) and spectral_matters(context.scene, context.scene.gradphoton.method)

    def draw(self, context):
        layout = _split(self.layout)
        s = context.scene.gradphoton
        for d in declared(s.method):
            if d["name"] in SPECTRAL_PANEL or d["group"] == "Spectral":
                draw_param(layout, s, s.method, d)


def _params_panel(ident, group, label, parent="GRADPHOTON_PT_render", options=None):
    attrs = {"bl_label": label, "bl_context": "render", "group": group}
    if parent:
        attrs["bl_parent_id"] = parent
    if options:
        attrs["bl_options"] = options
    return type(ident, (MethodParamsPanel, bpy.types.Panel), attrs)


# One panel per group of the declarations (methods.cpp `group`), in Cycles' order.
GRADPHOTON_PT_photons = _params_panel("GRADPHOTON_PT_photons", "Photons", "Photons")
GRADPHOTON_PT_metropolis = _params_panel("GRADPHOTON_PT_metropolis", "Metropolis", "Metropolis")
GRADPHOTON_PT_reconstruction = _params_panel("GRADPHOTON_PT_reconstruction", "Reconstruction", "Reconstruction")
GRADPHOTON_PT_light_paths = _params_panel("GRADPHOTON_PT_light_paths", "Light Paths", "Light Paths", parent=None)
GRADPHOTON_PT_clamping = _params_panel("GRADPHOTON_PT_clamping", "Clamping", "Clamping",
                                       parent="GRADPHOTON_PT_light_paths")


class GRADPHOTON_PT_light_paths_caustics(GradphotonPanel, bpy.types.Panel):
    """Light Paths > Caustics as Cycles draws it (its own panel hangs under Cycles' Light Paths,
    which gradphoton replaces): Cycles' settings, which pt, spt and spt-hero honour."""
    bl_label = "Caustics"
    bl_context = "render"
    bl_parent_id = "GRADPHOTON_PT_light_paths"
    bl_options = {'DEFAULT_CLOSED'}

    def draw(self, context):
        layout = _split(self.layout)
        c = cycles_settings_or_note(context.scene, layout, "Caustics are")
        if c is None:
            return
        d = native.method_description(context.scene.gradphoton.method)  # Method::supports.caustics
        layout.active = d is None or d.get("supports", {}).get("caustics", False)
        layout.column().prop(c, "blur_glossy")
        col = layout.column(heading="Caustics", align=True)
        col.prop(c, "caustics_reflective", text="Reflective")
        col.prop(c, "caustics_refractive", text="Refractive")


PARAM_PANELS = (GRADPHOTON_PT_photons, GRADPHOTON_PT_metropolis, GRADPHOTON_PT_reconstruction, GRADPHOTON_PT_spectral,
                GRADPHOTON_PT_light_paths, GRADPHOTON_PT_clamping)


def cycles_settings(scene):
    """Cycles' scene settings (scene.cycles), which hold Film > Exposure and Pixel Filter; None
    when the Cycles add-on is disabled."""
    return getattr(scene, "cycles", None)


def cycles_settings_or_note(scene, layout, what):
    """cycles_settings(scene), or None with a line in `layout` saying that `what` (e.g. "Caustics
    are") Cycles' settings, which need the Cycles add-on."""
    c = cycles_settings(scene)
    if c is None:
        layout.label(text=f"{what} Cycles' settings: enable the Cycles add-on", icon='ERROR')
    return c


class GRADPHOTON_PT_film(GradphotonPanel, bpy.types.Panel):
    """Cycles' Film panel: Exposure (every method: the image is scaled when it reaches Blender),
    with Pixel Filter and Transparent below. The settings are Cycles' own, so a scene renders
    alike in both engines."""
    bl_label = "Film"
    bl_context = "render"
    bl_options = {'DEFAULT_CLOSED'}

    def draw(self, context):
        layout = _split(self.layout)
        c = cycles_settings_or_note(context.scene, layout, "Exposure and Pixel Filter are")
        if c is None:
            return
        layout.prop(c, "film_exposure")


class GRADPHOTON_PT_film_pixel_filter(GradphotonPanel, bpy.types.Panel):
    bl_label = "Pixel Filter"
    bl_context = "render"
    bl_parent_id = "GRADPHOTON_PT_film"

    @classmethod
    def poll(cls, context):
        return super().poll(context) and cycles_settings(context.scene) is not None

    def draw(self, context):
        layout = _split(self.layout)
        c = cycles_settings(context.scene)
        col = layout.column()
        col.prop(c, "pixel_filter_type", text="Type")
        if c.pixel_filter_type != 'BOX':
            col.prop(c, "filter_width", text="Width")


class GRADPHOTON_PT_film_transparency(GradphotonPanel, bpy.types.Panel):
    """Blender's Film > Transparent, for the methods that declare film_transparent."""
    bl_label = "Transparent"
    bl_context = "render"
    bl_parent_id = "GRADPHOTON_PT_film"

    @classmethod
    def poll(cls, context):
        return super().poll(context) and reads(context.scene.gradphoton.method, FILM_TRANSPARENT)

    def draw_header(self, context):
        self.layout.prop(context.scene.render, "film_transparent", text="")

    def draw(self, context):
        layout = _split(self.layout)
        layout.active = context.scene.render.film_transparent
        layout.label(text="Alpha 0 where the world is seen")


def motion_blur_note(method):
    """A line for the Motion Blur panels when `method` does not render motion blur (its
    declaration in the core, Method::supports), else None."""
    d = native.method_description(method)
    if d is None or d.get("supports", {}).get("motion_blur", False):
        return None
    return f"{method_label(method)} renders the frame without blur"


def _note(layout, text, icon='INFO', width=44):
    for i, line in enumerate(textwrap.wrap(text, width)):
        layout.label(text=line, icon=icon if i == 0 else 'BLANK1')


class GRADPHOTON_RENDER_PT_motion_blur(GradphotonPanel, bpy.types.Panel):
    """Render > Motion Blur, as Cycles' panel and with its settings (Blender's render settings and
    scene.cycles): Position, Shutter; Rolling Shutter is drawn but not rendered (a note here, a
    warning when rendering). Final renders blur; the viewport does not, as Cycles'
    (export/motion.py)."""
    bl_label = "Motion Blur"
    bl_context = "render"
    bl_options = {'DEFAULT_CLOSED'}

    def draw_header(self, context):
        self.layout.prop(context.scene.render, "use_motion_blur", text="")

    def draw(self, context):
        layout = _split(self.layout)
        rd = context.scene.render
        layout.active = rd.use_motion_blur
        c = cycles_settings(context.scene)
        col = layout.column()
        if c is not None:
            col.prop(c, "motion_blur_position", text="Position")
        col.prop(rd, "motion_blur_shutter")
        col.prop(context.scene.gradphoton, "motion_blur_lights")
        if c is not None:
            col.separator()
            col.prop(c, "rolling_shutter_type", text="Rolling Shutter")
            sub = col.column()
            sub.active = c.rolling_shutter_type != 'NONE'
            sub.prop(c, "rolling_shutter_duration")
            if c.rolling_shutter_type != 'NONE':
                _note(layout, "Rolling Shutter is not rendered: every row sees the whole shutter")
        else:
            _note(layout, "Position is Cycles' setting: enable the Cycles add-on (Center is used)", 'ERROR')
        note = motion_blur_note(context.scene.gradphoton.method)
        if note:
            _note(layout, note)


class GRADPHOTON_RENDER_PT_motion_blur_curve(GradphotonPanel, bpy.types.Panel):
    """Motion Blur > Shutter Curve, as Cycles'. Not rendered: a curve that is not flat is named in
    the render's warnings and here."""
    bl_label = "Shutter Curve"
    bl_context = "render"
    bl_parent_id = "GRADPHOTON_RENDER_PT_motion_blur"
    bl_options = {'DEFAULT_CLOSED'}

    def draw(self, context):
        from .export import motion
        layout = _split(self.layout)
        rd = context.scene.render
        layout.active = rd.use_motion_blur
        layout.column().template_curve_mapping(rd, "motion_blur_shutter_curve")
        row = layout.column(align=True).row(align=True)
        for shape, icon in (('SMOOTH', 'SMOOTHCURVE'), ('ROUND', 'SPHERECURVE'), ('ROOT', 'ROOTCURVE'),
                            ('SHARP', 'SHARPCURVE'), ('LINE', 'LINCURVE'), ('MAX', 'NOCURVE')):
            row.operator("render.shutter_curve_preset", icon=icon, text="").shape = shape
        if not motion.shutter_curve_is_flat(rd.motion_blur_shutter_curve):
            _note(layout, "The curve is not rendered: the shutter is open fully for its whole time (a flat curve)")


# Object types with Cycles' Object > Motion Blur panel (its CYCLES_OBJECT_PT_motion_blur.poll).
MOTION_BLUR_TYPES = {'MESH', 'CURVE', 'SURFACE', 'FONT', 'META', 'CAMERA', 'CURVES', 'POINTCLOUD', 'VOLUME'}


class GRADPHOTON_OBJECT_PT_motion_blur(GradphotonPanel, bpy.types.Panel):
    """Object > Motion Blur, as Cycles' (ob.cycles): the switch, Steps (2^Steps + 1 samples over
    the shutter) and Deformation (not for cameras). An instancer's switch and Steps apply to its
    instances too."""
    bl_label = "Motion Blur"
    bl_context = "object"
    bl_options = {'DEFAULT_CLOSED'}

    @classmethod
    def poll(cls, context):
        ob = context.object
        if not super().poll(context) or ob is None or getattr(ob, "cycles", None) is None:
            return False
        return ob.type in MOTION_BLUR_TYPES or (ob.instance_type == 'COLLECTION' and ob.instance_collection is not None)

    def draw_header(self, context):
        self.layout.active = context.scene.render.use_motion_blur
        self.layout.prop(context.object.cycles, "use_motion_blur", text="")

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        ob = context.object
        cob = ob.cycles
        layout.active = context.scene.render.use_motion_blur and cob.use_motion_blur
        col = layout.column()
        col.prop(cob, "motion_steps", text="Steps")
        if ob.type != 'CAMERA':
            col.prop(cob, "use_deform_motion", text="Deformation")


# Blender's icon for each report level (the status bar's and the Info editor's): a warning is the
# triangle, an error the cross.
REPORT_ICONS = {'ERROR': 'CANCEL', 'WARNING': 'ERROR', 'INFO': 'INFO'}


class GRADPHOTON_PT_report(GradphotonPanel, bpy.types.Panel):
    bl_label = "Last Render"
    bl_context = "render"

    @classmethod
    def poll(cls, context):
        return super().poll(context) and bool(session.REPORTS)

    def draw(self, context):
        col = self.layout.column(align=True)
        region = getattr(context, "region", None)  # wrap to the panel's width
        chars = max(20, int(region.width / (7 * context.preferences.system.ui_scale))) if region else 60
        for level, message in session.REPORTS:
            icon = REPORT_ICONS.get(level, 'INFO')
            for part in message.replace("gradphoton approximated: ", "approximated: ").split("; "):
                for i, line in enumerate(textwrap.wrap(part, chars) or [""]):
                    col.label(text=line, icon=icon if i == 0 else 'BLANK1')


class GRADPHOTON_PT_performance(GradphotonPanel, bpy.types.Panel):
    bl_label = "Performance"
    bl_context = "render"
    bl_options = {'DEFAULT_CLOSED'}

    def draw(self, context):
        layout = _split(self.layout)
        s = context.scene.gradphoton
        for d in group_params(s.method, "Performance"):
            if d["name"] == "seed":  # Cycles' seed row: the clock toggles Use Animated Seed
                row = layout.row(align=True)
                draw_param(row, s, s.method, d)
                row.prop(s, "use_animated_seed", text="", icon='TIME')
            else:
                draw_param(layout, s, s.method, d)
        layout.prop(context.scene.render, "use_persistent_data", text="Persistent Data")
        layout.prop(s, "export_uvs")
        layout.operator("gradphoton.export_scene", icon='EXPORT')


class GRADPHOTON_PT_passes(GradphotonPanel, bpy.types.Panel):
    bl_label = "Passes"
    bl_context = "view_layer"

    def draw(self, context):
        layout = _split(self.layout)
        method = context.scene.gradphoton.method
        produced = session.method_passes(method) or set()
        col = layout.column(heading="Include", align=True)
        col.label(text="Combined is always rendered")
        s = context.view_layer.gradphoton
        for name, channels, label in native.passes():
            if name in produced and name not in NOT_A_PASS_TOGGLE:
                col.prop(s, "use_pass_" + name)
        if len(produced - NOT_A_PASS_TOGGLE) == 0:
            col.label(text=f"{method_label(method)} writes no other pass", icon='INFO')


class GRADPHOTON_PT_material(GradphotonPanel, bpy.types.Panel):
    bl_label = "Settings"
    bl_context = "material"

    @classmethod
    def poll(cls, context):
        return super().poll(context) and context.material is not None

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        m = context.material.gradphoton
        layout.prop(m, "dispersion")
        if m.dispersion == 'ABBE':
            layout.prop(m, "abbe")
        elif m.dispersion == 'CAUCHY':
            layout.prop(m, "cauchy_b")
        layout.prop(m, "emission_one_sided")


class GRADPHOTON_LIGHT_PT_light(GradphotonPanel, bpy.types.Panel):
    """The one Light panel: the light types the core renders, with Cycles' settings for them.
    Point/spot radius and sun angle are rendered as Cycles renders them (export/light.py); area
    spread is not modelled, so it is not drawn: a non-default value is named below and reported
    as a warning when rendering."""
    bl_label = "Light"
    bl_context = "data"

    @classmethod
    def poll(cls, context):
        return super().poll(context) and context.light is not None

    def draw(self, context):
        layout = self.layout
        light = context.light
        layout.row().prop(light, "type", expand=True)
        _split(layout)
        col = layout.column()
        col.prop(light, "color")
        col.prop(light, "energy", text="Strength" if light.type == 'SUN' else "Power")
        if light.type in {'POINT', 'SPOT'}:
            col.prop(light, "shadow_soft_size", text="Radius")
        elif light.type == 'SUN':
            col.prop(light, "angle")
        ignored = None
        ob = context.object
        if (light.type != 'AREA' and ob is not None and ob.visible_camera
                and (light.type == 'SUN' or light.shadow_soft_size > 0)):
            ignored = "Lights the scene but is not shown to the camera"
        if light.type == 'SPOT':
            col.separator()
            col.prop(light, "spot_size", text="Spot Size")
            col.prop(light, "spot_blend", text="Blend")
            col.prop(light, "show_cone")
        elif light.type == 'AREA':
            col.separator()
            col.prop(light, "shape")
            sub = col.column(align=True)
            if light.shape in {'SQUARE', 'DISK'}:
                sub.prop(light, "size")
            else:
                sub.prop(light, "size", text="Size X")
                sub.prop(light, "size_y", text="Y")
            if abs(light.spread - math.pi) > 1e-4:
                ignored = (f"Spread {math.degrees(light.spread):.0f}\u00b0 renders as 180\u00b0: "
                           "the light spreads over its whole front side")
        if ignored:
            for i, line in enumerate(textwrap.wrap(ignored, 44)):
                layout.label(text=line, icon='INFO' if i == 0 else 'BLANK1')


# Object types whose Visibility panel has Cycles' Ray Visibility (its has_geometry_visibility).
RAY_VISIBILITY_TYPES = {'MESH', 'CURVE', 'SURFACE', 'FONT', 'META', 'LIGHT'}


def object_has_ray_visibility(ob):
    return ob is not None and (ob.type in RAY_VISIBILITY_TYPES or
                               (ob.instance_type == 'COLLECTION' and ob.instance_collection is not None))


def holdout_note(method, ob):
    """A line for an object set to Mask > Holdout that `method` does not hold out, else None."""
    if ob is None or not getattr(ob, "is_holdout", False) or ob.type == 'LIGHT':
        return None
    if (native.method_info(method) or {}).get("holdout", True):
        return None
    return f"Holdout: {method_label(method)} renders this object as a plain surface"


class GRADPHOTON_OBJECT_PT_visibility_ray_visibility(GradphotonPanel, bpy.types.Panel):
    """Object > Visibility > Ray Visibility, as Cycles': the switches the core honours (every
    method: Camera, Shadow; Diffuse, Glossy, Transmission as each method declares). Blender's
    Visibility panel above it holds Mask > Holdout. Volume Scatter is not drawn: the core does not
    honour it yet (media render in path tracing, but without that switch). A point, spot or sun light is never seen by camera rays (export/visibility.py),
    so its Camera switch is greyed out."""
    bl_label = "Ray Visibility"
    bl_context = "object"
    bl_parent_id = "OBJECT_PT_visibility"

    @classmethod
    def poll(cls, context):
        return super().poll(context) and object_has_ray_visibility(context.object)

    def draw(self, context):
        layout = _split(self.layout)
        ob = context.object
        col = layout.column()
        cam = col.column()
        cam.active = not (ob.type == 'LIGHT' and ob.data is not None and ob.data.type != 'AREA')
        cam.prop(ob, "visible_camera", text="Camera")
        col.prop(ob, "visible_diffuse", text="Diffuse")
        col.prop(ob, "visible_glossy", text="Glossy")
        col.prop(ob, "visible_transmission", text="Transmission")
        if ob.type != 'LIGHT':
            col.prop(ob, "visible_shadow", text="Shadow")
        note = holdout_note(context.scene.gradphoton.method, ob)
        if note:
            layout.label(text=note, icon='ERROR')


class GRADPHOTON_WORLD_PT_ray_visibility(GradphotonPanel, bpy.types.Panel):
    """World > Ray Visibility, as Cycles' (its world.cycles_visibility): Camera, Diffuse, Glossy,
    Transmission (export/visibility.py: the World by Cycles' own rule for it)."""
    bl_label = "Ray Visibility"
    bl_context = "world"
    bl_options = {'DEFAULT_CLOSED'}

    @classmethod
    def poll(cls, context):
        return super().poll(context) and context.world is not None

    def draw(self, context):
        layout = _split(self.layout)
        vis = getattr(context.world, "cycles_visibility", None)
        if vis is None:
            layout.label(text="Ray Visibility is Cycles' setting: enable the Cycles add-on", icon='ERROR')
            return
        col = layout.column()
        for name in ("camera", "diffuse", "glossy", "transmission"):
            col.prop(vis, name)


_classes = (GRADPHOTON_PT_render, GRADPHOTON_PT_spectral, GRADPHOTON_PT_viewport, GRADPHOTON_PT_photons,
            GRADPHOTON_PT_metropolis, GRADPHOTON_PT_reconstruction, GRADPHOTON_PT_light_paths, GRADPHOTON_PT_clamping,
            GRADPHOTON_PT_light_paths_caustics, GRADPHOTON_PT_film, GRADPHOTON_PT_film_pixel_filter, GRADPHOTON_PT_film_transparency,
            GRADPHOTON_RENDER_PT_motion_blur, GRADPHOTON_RENDER_PT_motion_blur_curve, GRADPHOTON_OBJECT_PT_motion_blur,
            GRADPHOTON_PT_performance, GRADPHOTON_PT_report, GRADPHOTON_PT_passes, GRADPHOTON_PT_material,
            GRADPHOTON_LIGHT_PT_light, GRADPHOTON_OBJECT_PT_visibility_ray_visibility, GRADPHOTON_WORLD_PT_ray_visibility)

# Blender's panels for its own renderer that gradphoton draws itself (the Light panel and its
# area and spot settings, as Cycles does) or cannot honour: a preview (no preview renders),
# falloff curves, simplify, freestyle.
_EXCLUDE = {"DATA_PT_light", "NODE_DATA_PT_light", "DATA_PT_area", "DATA_PT_spot", "DATA_PT_preview",
            "DATA_PT_falloff_curve", "RENDER_PT_simplify", "RENDER_PT_freestyle", "RENDER_PT_eevee_performance"}
# Generic panels Blender lists for EEVEE only: material slots, surface nodes, world, depth of field.
_EEVEE_KEEP = {"EEVEE_MATERIAL_PT_context_material", "EEVEE_MATERIAL_PT_surface", "EEVEE_WORLD_PT_surface",
               "DATA_PT_camera_dof", "DATA_PT_camera_dof_aperture"}


def _blender_panels():
    for p in bpy.types.Panel.__subclasses__():
        engines = getattr(p, "COMPAT_ENGINES", None)
        if engines is None or p.__name__ in _EXCLUDE:
            continue
        if "BLENDER_RENDER" in engines or p.__name__ in _EEVEE_KEEP:
            yield p


def register():
    for c in _classes:
        bpy.utils.register_class(c)
    for p in _blender_panels():
        p.COMPAT_ENGINES.add(ENGINE)


def unregister():
    for p in _blender_panels():
        p.COMPAT_ENGINES.discard(ENGINE)
    for c in reversed(_classes):
        bpy.utils.unregister_class(c)
