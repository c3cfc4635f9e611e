"""Settings: Scene.gradphoton (render), ViewLayer.gradphoton (passes), Material.gradphoton.

Method names and pass names come from the native module (`_native.methods()`,
`_native.passes()`); which passes a method writes, whether it estimates its error and which
parameters it reads come from the method itself (`native.method_info`). Method parameters are
the union of what the methods read; parameters a method does not read are dropped silently by
the session. Labels and tooltips speak to artists first; the paper reference comes after.
"""
import bpy
from bpy.props import (BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty, StringProperty)

from . import native

# Readable labels for the core's method names (_native.methods()); an unknown name shows as itself.
METHOD_LABELS = {
    "pt": ("Path Tracing", "Unbiased reference, as Cycles renders: good for most scenes, noisy caustics "
                           "(next-event estimation and MIS, Veach 1997)"),
    "ppm": ("Photon Mapping", "Caustics and light through glass, sharpening as it renders; camera paths "
                              "traced once (progressive photon mapping, Hachisuka et al. 2008; thesis ch. 5)"),
    "sppm": ("Stochastic PPM", "Caustics and light through glass, with depth of field and glossy "
                               "surfaces; stops at a target error (thesis ch. 7)"),
    "sppm-adaptive": ("SPPM Adaptive", "Stochastic PPM that sends photons where the camera sees them: "
                                       "for light hidden behind openings (adaptive MCMC photons, thesis ch. 8)"),
    "msppm": ("Multisampled PPM", "Path tracing and photons combined per pixel, each where it is better "
                                  "(MIS of path tracing and SPPM, thesis ch. 9)"),
    "gpt": ("Gradient PT", "Path tracing of image gradients, then a smooth reconstruction: less noise "
                           "on flat areas (gradient-domain path tracing, Kettunen et al. 2015)"),
    "gpm": ("Gradient Photons", "Photon mapping of image gradients: smooth caustics in fewer passes "
                                "(gradient-domain photon density estimation, Hua et al. 2017)"),
    "spt": ("Spectral PT", "Path tracing by wavelength, for rainbows through dispersive glass "
                           "(one wavelength per path, Cauchy dispersion)"),
    "spt-hero": ("Spectral PT Hero", "Spectral path tracing with four wavelengths per path: less colour "
                                     "noise (hero wavelengths, Wilkie et al. 2014)"),
    "sgpt": ("Spectral Gradient", "Spectral path tracing with a smooth reconstruction across wavelengths "
                                  "(spectral gradient sampling, Petitjean et al. 2018)"),
    "gdmlt": ("Gradient MLT", "Explores bright, hard-to-find light paths by mutating them (gradient-domain "
                              "Metropolis light transport, Lehtinen et al. 2013)"),
}

_method_items = []  # Blender needs dynamic enum strings kept alive


def method_info(method):
    """What `method` declares (native.method_info): its passes, error estimate, unread parameters."""
    return native.method_info(method, PROBE_PARAMS)


def method_items(self, context):
    _method_items.clear()
    for i, name in enumerate(native.methods() or ["pt"]):
        label, desc = METHOD_LABELS.get(name, (name, name))
        _method_items.append((name, label, desc, i))
    return _method_items


# Native parameter name -> property name on GradphotonRenderSettings. The session sends every
# one of these; each method reads its own (Session.unused_params lists the others).
METHOD_PARAMS = {
    "max_depth": "max_bounces",
    "seed": "seed",
    "threads": "threads",
    "photons": "photons_per_pass",
    "alpha": "alpha",
    "radius": "initial_radius",
    "confidence": "confidence",
    "hash": "photon_hash",
    "lambda": "poisson_lambda",
    "recon": "reconstruction",
    "spectral": "spectral_mode",
    "clamp_direct": "clamp_direct",
    "clamp_indirect": "clamp_indirect",
}
# Parameters that Blender itself holds (scene.render), as Cycles reads them.
FILM_TRANSPARENT = "film_transparent"
# Parameters the panels grey out for a method that leaves them unread (method_info's "unused").
PROBE_PARAMS = {"clamp_direct": 0.0, "clamp_indirect": 0.0, FILM_TRANSPARENT: True}

# Parameters of one method only: native name -> property name, added to (or replacing)
# METHOD_PARAMS for that method. A method whose paper default differs from the shared
# property's gets its own property with the core's default (msppm's alpha 0.6 and one photon
# per pixel, gpm's and gdmlt's L1 reconstruction), and a choice that would override a method alias's
# default (photon_sampler: sppm-adaptive is sppm with "adaptive") is sent only where it is one.
_ADAPTIVE_PHOTONS = {"photon_sampler": "photon_sampler", "chains": "photon_chains"}
METHOD_SPECIFIC_PARAMS = {
    "sppm": _ADAPTIVE_PHOTONS,
    "ppm": _ADAPTIVE_PHOTONS,
    "sppm-adaptive": {"chains": "photon_chains"},
    "gpm": {"recon": "gpm_reconstruction", "manifold_iterations": "manifold_iterations"},
    "msppm": {"alpha": "msppm_alpha", "photons": "msppm_photons", "max_depth": "msppm_max_bounces",
              "path_samples": "msppm_path_samples"},
    "gdmlt": {"mutations": "mlt_mutations", "chains": "mlt_chains", "large_step": "mlt_large_step",
              "sigma": "mlt_sigma", "primal_share": "mlt_primal_share", "bootstrap": "mlt_bootstrap",
              "recon": "mlt_reconstruction"},
}
# Every native name the addon may send (the session warns only about others left unused).
KNOWN_PARAMS = set(METHOD_PARAMS).union(*METHOD_SPECIFIC_PARAMS.values()) | {FILM_TRANSPARENT}

# A property whose value 0 means "automatic" in the core is shown with an "Auto" toggle
# instead: property -> its toggle. The core receives 0 while the toggle is on.
AUTO_TOGGLES = {
    "initial_radius": "use_auto_radius",
    "msppm_photons": "use_auto_msppm_photons",
    "msppm_path_samples": "use_auto_msppm_path_samples",
}
# Cycles counts bounces (0 = direct light only); the core counts path segments, the camera
# ray and the segment to the light included, so max_depth = bounces + 2 (path_tracer.h).
BOUNCES_TO_SEGMENTS = 2


def native_value(settings, name, prop):
    """The value the core receives for native parameter `name` held by property `prop`."""
    if prop in AUTO_TOGGLES and getattr(settings, AUTO_TOGGLES[prop]):
        return 0
    value = getattr(settings, prop)
    return value + BOUNCES_TO_SEGMENTS if name == "max_depth" else value


def method_params(method):
    """Native parameter name -> property name for one method."""
    return {**METHOD_PARAMS, **METHOD_SPECIFIC_PARAMS.get(method, {})}


def param_prop(method, name):
    """The property that holds native parameter `name` for `method` (for the panel)."""
    return method_params(method).get(name, name)


# Which parameter groups the panel shows for a method (the core reads only its own).
PHOTON_METHODS = {"ppm", "sppm", "sppm-adaptive", "gpm", "msppm"}
GRADIENT_METHODS = {"gpt", "gpm", "gdmlt"}
ADAPTIVE_PHOTON_METHODS = {"ppm", "sppm", "sppm-adaptive"}  # read photon_sampler / chains
ERROR_ESTIMATE_METHODS = {"ppm", "sppm", "sppm-adaptive", "gpm"}  # read confidence (and hash)
MLT_METHODS = {"gdmlt"}


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


class GradphotonRenderSettings(bpy.types.PropertyGroup):
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
                                description="Relative error of the image to stop at, as the method "
                                            "estimates it (0.05 = 5 %; thesis eq. 6.33)")
    max_bounces: IntProperty(name="Max Bounces", default=30, min=0, max=1022,
                             description="Scatterings a path may have, as Cycles counts them "
                                         "(0 = direct light only); photon methods limit camera and "
                                         "photon paths each. Core: max_depth = bounces + 2")
    clamp_direct: FloatProperty(name="Direct Light", default=0.0, min=0.0, soft_max=100.0,
                                description="Largest value a sample of direct light may add, as in Cycles "
                                            "(0 = off): removes fireflies, darkens bright light. "
                                            "Greyed out where the method does not clamp")
    clamp_indirect: FloatProperty(name="Indirect Light", default=0.0, min=0.0, soft_max=100.0,
                                  description="Largest value a sample of indirect light may add, as in "
                                              "Cycles (0 = off): removes fireflies, darkens bright bounces. "
                                              "Greyed out where the method does not clamp")
    seed: IntProperty(name="Seed", default=0, min=0, description="Random seed: another seed gives other noise")
    use_animated_seed: BoolProperty(name="Use Animated Seed", default=False,
                                    description="Another seed every frame (a hash of the frame and the seed), "
                                                "as Cycles: the noise changes over an animation")
    viewport_method: EnumProperty(name="Method", items=viewport_method_items, default=0,
                                  description="How light is transported in the rendered viewport "
                                              "(Path Tracing shows a first image soonest)")
    viewport_passes: IntProperty(name="Passes", default=1024, min=0,
                                 description="Passes the rendered viewport refines to (0 = no limit)")
    threads: IntProperty(name="Threads", default=0, min=0, max=1024, description="Worker threads (0 = all cores)")
    photons_per_pass: IntProperty(name="Photons", default=100000, min=1000,
                                  description="Photons traced per pass: more gives smoother caustics per pass, "
                                              "longer passes")
    alpha: FloatProperty(name="Alpha", default=0.7, min=0.01, max=1.0,
                         description="How fast the photon radius shrinks: lower sharpens sooner, "
                                     "higher stays smoother (0.7; thesis eq. 5.9)")
    use_auto_radius: BoolProperty(name="Auto", default=True,
                                  description="Start the photon radius from each pixel's footprint")
    initial_radius: FloatProperty(name="Initial Radius", default=0.01, min=1e-6, unit='LENGTH', subtype='DISTANCE',
                                  description="Photon gathering radius of the first pass: larger is smoother "
                                              "and blurrier at first")
    confidence: FloatProperty(name="Confidence", default=0.5, min=0.01, max=0.999,
                              description="How sure the error estimate is: higher stops later with "
                                          "Target Error (thesis eq. 6.10)")
    photon_hash: EnumProperty(name="Lookup", default="exact",
                              items=[("exact", "Exact", "Find every photon near each point"),
                                     ("stochastic", "Stochastic", "Keep one photon per grid cell: faster "
                                                                  "with many photons (thesis ch. 10)")],
                              description="How photons near a point are found")
    poisson_lambda: FloatProperty(name="Lambda", default=0.2, min=0.0,
                                  description="Weight of the noisy image against its smooth gradients in the "
                                              "reconstruction: higher keeps more noise and detail "
                                              "(screened Poisson)")
    reconstruction: EnumProperty(name="Reconstruction", default="l2",
                                 items=[("l2", "L2", "Screened Poisson, least squares"),
                                        ("l1", "L1", "Screened Poisson, L1 by iteratively reweighted least squares")])
    spectral_mode: EnumProperty(
        name="Spectral", default="auto",
        items=[("auto", "Auto", "Spectral rendering only when a material disperses (Abbe number or Cauchy B)"),
               ("rgb", "RGB", "Always RGB (dispersion ignored)"),
               ("spectral", "Spectral", "Always spectral (path tracing runs with hero wavelengths)")],
        description="Spectral mode of the core (--spectral)")
    # Adaptive photon tracing (thesis ch. 8, adaptive_photons.h): ppm, sppm, sppm-adaptive
    photon_sampler: EnumProperty(
        name="Photon Sampler", default="uniform",
        items=[("uniform", "Uniform", "Photon paths from independent uniform random numbers"),
               ("adaptive", "Adaptive", "Send photons where the camera sees them: for light behind "
                                        "openings (MCMC on path visibility, thesis ch. 8)")],
        description="How photons are sent from the lights")
    photon_chains: IntProperty(name="Chains", default=64, min=1, max=65536,
                               description="Independent explorers of the adaptive sampler (Markov chains)")
    # MSPPM (thesis ch. 9, msppm.h): its own defaults
    msppm_alpha: FloatProperty(name="Alpha", default=0.6, min=0.01, max=0.99,
                               description="How fast the photon radius shrinks; below 2/3 "
                                           "(0.6; thesis eq. 9.23)")
    use_auto_msppm_photons: BoolProperty(name="Auto", default=True,
                                         description="One photon per pixel and pass (thesis §9.5)")
    msppm_photons: IntProperty(name="Photons", default=100000, min=1,
                               description="Photons traced per pass")
    msppm_max_bounces: IntProperty(name="Max Bounces", default=14, min=0, max=1022,
                                   description="Scatterings a camera or photon path may have, as Cycles "
                                               "counts them (14; core max_depth 16)")
    use_auto_msppm_path_samples: BoolProperty(
        name="Auto", default=True,
        description="As many path-tracing samples as the pixel expects photons (thesis §9.5)")
    msppm_path_samples: IntProperty(
        name="Path Samples", default=1, min=1, max=1024,
        description="Path-tracing samples per pixel and pass (1 often converges faster in short renders)")
    gpm_reconstruction: EnumProperty(name="Reconstruction", default="l1",
                                     items=[("l2", "L2", "Screened Poisson, least squares (unbiased)"),
                                            ("l1", "L1", "Screened Poisson, L1: robust to stray caustic "
                                                         "gradients (wins at equal time)")])
    manifold_iterations: IntProperty(
        name="Manifold Steps", default=20, min=0, max=100,
        description="Effort to move caustic photons between neighbouring pixels: 0 leaves caustics "
                    "out of the gradients; fewer than 20 darkens or brightens caustic edges "
                    "(manifold walk projections; the paper uses 5)")
    # Gradient-domain MLT (gdmlt.h)
    mlt_mutations: IntProperty(name="Mutations", default=1, min=1, max=1024,
                               description="Mutations per pixel and pass (a pass costs about one gradient PT pass)")
    mlt_chains: IntProperty(name="Chains", default=64, min=1, max=65536,
                            description="Independent explorers (Markov chains)")
    mlt_large_step: FloatProperty(name="Large Step", default=0.3, min=0.0, max=1.0,
                                  description="How often a path is replaced by a fresh one instead of "
                                              "a small change (Kelemen's p_large)")
    mlt_sigma: FloatProperty(name="Step Size", default=0.01, min=1e-5, max=0.99, precision=4,
                             description="Size of a small change to a path (sigma in primary sample space)")
    mlt_primal_share: FloatProperty(name="Image Share", default=0.05, min=1e-4, max=100.0, precision=3,
                                    description="How much the image itself, not only its gradients, guides "
                                                "the exploration (primal share of the target function)")
    mlt_bootstrap: IntProperty(name="Bootstrap", default=1, min=1, max=1024,
                               description="Plain samples per pixel to start the chains and set the brightness")
    mlt_reconstruction: EnumProperty(name="Reconstruction", default="l1",
                                     items=[("l2", "L2", "Screened Poisson, least squares (unbiased)"),
                                            ("l1", "L1", "Screened Poisson, L1 (robust; GD-MLT's default)")])
    export_uvs: BoolProperty(name="Export UVs", default=False,
                             description="Export UV maps (splits vertices at UV seams; no material uses UVs yet)")


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


def register():
    global _classes
    _classes = [GradphotonRenderSettings, _pass_toggles_class(), GradphotonMaterialSettings]
    for c in _classes:
        bpy.utils.register_class(c)
    bpy.types.Scene.gradphoton = PointerProperty(type=_classes[0])
    bpy.types.ViewLayer.gradphoton = PointerProperty(type=_classes[1])
    bpy.types.Material.gradphoton = PointerProperty(type=_classes[2])


def unregister():
    del bpy.types.Material.gradphoton
    del bpy.types.ViewLayer.gradphoton
    del bpy.types.Scene.gradphoton
    for c in reversed(_classes):
        bpy.utils.unregister_class(c)
