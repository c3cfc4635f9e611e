"""Panels: every gradphoton panel shares GradphotonPanel, which polls the engine; Blender's
own panels that fit (output, dimensions, camera, light, material slots, world) get the engine
added to their COMPAT_ENGINES, as other engines do."""
import bpy

from . import native
from .properties import (ADAPTIVE_PHOTON_METHODS, ERROR_ESTIMATE_METHODS, GRADIENT_METHODS, MLT_METHODS,
                         PHOTON_METHODS, param_prop)

ENGINE = "GRADPHOTON"


class GradphotonPanel:
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'
    COMPAT_ENGINES = {ENGINE}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES


class GRADPHOTON_PT_render(GradphotonPanel, bpy.types.Panel):
    bl_label = "Rendering"
    bl_context = "render"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        if native.error():
            layout.label(text="Native module not loaded: run scripts/setup.sh", icon='ERROR')
        s = context.scene.gradphoton
        layout.prop(s, "method")
        layout.prop(s, "stop_rule")
        col = layout.column()
        col.prop(s, {"TIME": "time_limit", "PASSES": "passes", "ERROR": "target_error"}[s.stop_rule])


class GRADPHOTON_PT_method(GradphotonPanel, bpy.types.Panel):
    bl_label = "Method"
    bl_context = "render"
    bl_parent_id = "GRADPHOTON_PT_render"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        s = context.scene.gradphoton
        m = s.method
        # A parameter's property can depend on the method (properties.METHOD_SPECIFIC_PARAMS).
        layout.prop(s, param_prop(m, "max_depth"))
        layout.prop(s, "spectral_mode")
        if m in PHOTON_METHODS:
            col = layout.column(heading="Photons")
            col.prop(s, param_prop(m, "photons"))
            col.prop(s, param_prop(m, "alpha"))
            col.prop(s, "initial_radius")
            if m in ERROR_ESTIMATE_METHODS:
                col.prop(s, "photon_hash")
                col.prop(s, "confidence")
            if m == "msppm":
                col.prop(s, "msppm_path_samples")
        if m in ADAPTIVE_PHOTON_METHODS:
            col = layout.column(heading="Photon Sampler")
            if m != "sppm-adaptive":
                col.prop(s, "photon_sampler")
            sub = col.column()
            sub.active = m == "sppm-adaptive" or s.photon_sampler == "adaptive"
            sub.prop(s, "photon_chains")
        if m in MLT_METHODS:
            col = layout.column(heading="Metropolis")
            for name in ("mutations", "chains", "large_step", "sigma", "primal_share", "bootstrap"):
                col.prop(s, param_prop(m, name))
        if m in GRADIENT_METHODS:
            col = layout.column(heading="Reconstruction")
            col.prop(s, param_prop(m, "recon"))
            col.prop(s, "poisson_lambda")
            if m == "gpm":
                col.prop(s, "manifold_iterations")


class GRADPHOTON_PT_performance(GradphotonPanel, bpy.types.Panel):
    bl_label = "Performance"
    bl_context = "render"
    bl_options = {'DEFAULT_CLOSED'}

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        s = context.scene.gradphoton
        layout.prop(s, "threads")
        layout.prop(s, "seed")
        layout.prop(s, "export_uvs")
        layout.operator("gradphoton.export_scene", icon='EXPORT')


class GRADPHOTON_PT_passes(GradphotonPanel, bpy.types.Panel):
    bl_label = "Passes"
    bl_context = "view_layer"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        col = layout.column(heading="Include", align=True)
        col.label(text="Combined is always rendered")
        s = context.view_layer.gradphoton
        for name, channels, label in native.passes():
            if name != "combined":
                col.prop(s, "use_pass_" + name)


class GRADPHOTON_PT_material(GradphotonPanel, bpy.types.Panel):
    bl_label = "gradphoton"
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
        layout.prop(m, "classification")


_classes = (GRADPHOTON_PT_render, GRADPHOTON_PT_method, GRADPHOTON_PT_performance, GRADPHOTON_PT_passes,
            GRADPHOTON_PT_material)

# Blender panels drawn for this engine too (as BlendLuxCore/appleseed do).
_EXCLUDE = {"RENDER_PT_eevee_performance", "VIEWLAYER_PT_eevee_layer_passes_data",
            "VIEWLAYER_PT_eevee_layer_passes_light", "VIEWLAYER_PT_eevee_layer_passes_effects"}
_EEVEE_KEEP = {"EEVEE_MATERIAL_PT_context_material", "EEVEE_MATERIAL_PT_surface", "EEVEE_MATERIAL_PT_settings",
               "EEVEE_WORLD_PT_surface", "DATA_PT_EEVEE_light", "DATA_PT_EEVEE_light_distance",
               "DATA_PT_spot", "DATA_PT_light", "DATA_PT_area"}


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
