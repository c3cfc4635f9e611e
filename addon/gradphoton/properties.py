"""Settings: Scene.gradphoton (render), ViewLayer.gradphoton (passes), Material.gradphoton.

Method names and pass names come from the native module (`_native.methods()`,
`_native.passes()`); nothing here lists them. Method parameters are the union of what the
methods read; parameters a method does not read are dropped silently by the session.
"""
import bpy
from bpy.props import (BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty, StringProperty)

from . import native

# Readable labels for the core's method names (_native.methods()); an unknown name shows as itself.
METHOD_LABELS = {
    "pt": ("Path Tracing", "Unidirectional path tracing with next-event estimation and MIS (reference)"),
    "ppm": ("Progressive Photon Mapping", "Hachisuka et al. 2008 (thesis ch. 5)"),
    "sppm": ("Stochastic PPM", "Stochastic progressive photon mapping (thesis ch. 7)"),
    "sppm-adaptive": ("SPPM, Adaptive Photons", "SPPM with adaptive MCMC photon tracing on path visibility (thesis ch. 8)"),
    "msppm": ("Multisampled PPM", "MIS of path tracing and SPPM (thesis ch. 9)"),
    "gpt": ("Gradient-Domain PT", "Gradient-domain path tracing (KMA15)"),
    "gpm": ("Gradient-Domain Photons", "Gradient-domain photon density estimation"),
    "spt": ("Spectral PT (1 wavelength)", "Spectral path tracing, one wavelength per path, Cauchy dispersion"),
    "spt-hero": ("Spectral PT (hero)", "Spectral path tracing with hero wavelengths (4 per path), Cauchy dispersion"),
    "sgpt": ("Spectral Gradient PT", "Spectral gradient sampling with 1D Poisson reconstruction (Petitjean et al. 2018)"),
    "gdmlt": ("Gradient-Domain MLT", "Gradient-domain Metropolis light transport"),
}

_method_items = []  # Blender needs dynamic enum strings kept alive


def method_items(self, context):
    _method_items.clear()
    for i, name in enumerate(native.methods() or ["pt"]):
        label, desc = METHOD_LABELS.get(name, (name, name))
        _method_items.append((name, label, desc, i))
    return _method_items


# Native parameter name -> property name on GradphotonRenderSettings. The session sends every
# one of these; each method reads its own (Session.unused_params lists the others).
METHOD_PARAMS = {
    "max_depth": "max_depth",
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
}

# Parameters of one method only: native name -> property name, added to (or replacing)
# METHOD_PARAMS for that method. A method whose paper default differs from the shared
# property's gets its own property with the core's default (msppm's alpha 0.6 and one photon
# per pixel, gpm's alpha 0.9, gdmlt's L1 reconstruction), and a choice that would override a method alias's
# default (photon_sampler: sppm-adaptive is sppm with "adaptive") is sent only where it is one.
_ADAPTIVE_PHOTONS = {"photon_sampler": "photon_sampler", "chains": "photon_chains"}
METHOD_SPECIFIC_PARAMS = {
    "sppm": _ADAPTIVE_PHOTONS,
    "ppm": _ADAPTIVE_PHOTONS,
    "sppm-adaptive": {"chains": "photon_chains"},
    "gpm": {"alpha": "gpm_alpha", "photons": "gpm_photons", "manifold_iterations": "manifold_iterations"},
    "msppm": {"alpha": "msppm_alpha", "photons": "msppm_photons", "max_depth": "msppm_max_depth",
              "path_samples": "msppm_path_samples"},
    "gdmlt": {"mutations": "mlt_mutations", "chains": "mlt_chains", "large_step": "mlt_large_step",
              "sigma": "mlt_sigma", "primal_share": "mlt_primal_share", "bootstrap": "mlt_bootstrap",
              "recon": "mlt_reconstruction"},
}
# Every native name the addon may send (the session warns only about others left unused).
KNOWN_PARAMS = set(METHOD_PARAMS).union(*METHOD_SPECIFIC_PARAMS.values())


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


class GradphotonRenderSettings(bpy.types.PropertyGroup):
    method: EnumProperty(name="Method", items=method_items, description="Light transport method")
    stop_rule: EnumProperty(
        name="Stop", default="PASSES",
        items=[("TIME", "Time", "Render for a wall-clock budget"),
               ("PASSES", "Passes", "Render a number of passes (samples per pixel for path tracing)"),
               ("ERROR", "Target Error", "Render until the estimated relative error is reached")])
    time_limit: FloatProperty(name="Time Limit", default=10.0, min=0.01, unit='TIME_ABSOLUTE', subtype='TIME_ABSOLUTE',
                              description="Seconds of rendering")
    passes: IntProperty(name="Passes", default=64, min=1, description="Number of passes")
    target_error: FloatProperty(name="Target Error", default=0.05, min=1e-4, max=1.0,
                                description="Estimated relative error to stop at (methods with an error estimate)")
    max_depth: IntProperty(name="Max Bounces", default=32, min=1, max=1024,
                           description="Longest path in segments (camera ray = 1)")
    seed: IntProperty(name="Seed", default=0, min=0, description="Random seed")
    threads: IntProperty(name="Threads", default=0, min=0, max=1024, description="Worker threads (0 = all cores)")
    photons_per_pass: IntProperty(name="Photons per Pass", default=100000, min=1000,
                                  description="Photon paths traced per pass (photon methods)")
    alpha: FloatProperty(name="Alpha", default=0.7, min=0.01, max=1.0,
                         description="Radius reduction of progressive photon mapping (thesis eq. 5.9; 0.7)")
    initial_radius: FloatProperty(name="Initial Radius", default=0.0, min=0.0, unit='LENGTH', subtype='DISTANCE',
                                  description="Initial photon gather radius (0 = automatic from the pixel footprint)")
    confidence: FloatProperty(name="Confidence", default=0.5, min=0.01, max=0.999,
                              description="Confidence of the estimated error bound (thesis eq. 6.10)")
    photon_hash: EnumProperty(name="Photon Lookup", default="exact",
                              items=[("exact", "Exact", "Spatial hash grid with every photon"),
                                     ("stochastic", "Stochastic", "One photon per cell, flux scaled (thesis ch. 10)")])
    poisson_lambda: FloatProperty(name="Poisson Lambda", default=0.2, min=0.0,
                                  description="Weight of the primal image in the screened Poisson reconstruction")
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
               ("adaptive", "Adaptive", "Adaptive MCMC on path visibility with replica exchange (thesis ch. 8)")],
        description="How photon paths are sampled (sppm-adaptive always uses the adaptive sampler)")
    photon_chains: IntProperty(name="Chains", default=64, min=1, max=65536,
                               description="Markov chains of the adaptive photon sampler (independent of threads)")
    # MSPPM (thesis ch. 9, hybrid_ppm.h): its own defaults
    msppm_alpha: FloatProperty(name="Alpha", default=0.6, min=0.01, max=0.99,
                               description="Radius reduction of MSPPM; below 2/3 (thesis eq. 9.23; 0.6)")
    msppm_photons: IntProperty(name="Photons per Pass", default=0, min=0,
                               description="Photon paths per pass (0 = one per pixel, thesis §9.5)")
    msppm_max_depth: IntProperty(name="Max Bounces", default=16, min=1, max=1024,
                                 description="Longest camera or photon path in segments (MSPPM: 16)")
    msppm_path_samples: IntProperty(
        name="Path Samples", default=0, min=0, max=1024,
        description="Path-tracing samples per pixel and pass (0 = as many as the pixel expects photons, "
                    "thesis §9.5; 1 often converges faster in short renders)")
    gpm_alpha: FloatProperty(name="Alpha", default=0.9, min=0.01, max=0.99,
                             description="Radius reduction of gradient-domain photon mapping (its paper's 0.9)")
    gpm_photons: IntProperty(name="Photons per Pass", default=1000000, min=1000,
                             description="Photon paths traced per pass (gradient-domain photons: the paper's 1 M)")
    manifold_iterations: IntProperty(
        name="Manifold Iterations", default=5, min=0, max=100,
        description="Steps a manifold walk may take to shift a caustic photon (the paper's 5; "
                    "0 keeps caustic photons out of the gradient domain)")
    # Gradient-domain MLT (gdmlt.h)
    mlt_mutations: IntProperty(name="Mutations per Pixel", default=1, min=1, max=1024,
                               description="Mutations per pixel per pass (a pass costs about one gpt pass)")
    mlt_chains: IntProperty(name="Chains", default=64, min=1, max=65536,
                            description="Independent Markov chains (independent of threads)")
    mlt_large_step: FloatProperty(name="Large Step", default=0.3, min=0.0, max=1.0,
                                  description="Probability of a large step (Kelemen's p_large)")
    mlt_sigma: FloatProperty(name="Sigma", default=0.01, min=1e-5, max=0.99, precision=4,
                             description="Deviation of a small step in primary sample space")
    mlt_primal_share: FloatProperty(name="Primal Share", default=0.05, min=1e-4, max=100.0, precision=3,
                                    description="Share of the primal throughput in the target function")
    mlt_bootstrap: IntProperty(name="Bootstrap", default=1, min=1, max=1024,
                               description="Uniform bootstrap samples per pixel (normalisation, chain starts)")
    mlt_reconstruction: EnumProperty(name="Reconstruction", default="l1",
                                     items=[("l2", "L2", "Screened Poisson, least squares (unbiased)"),
                                            ("l1", "L1", "Screened Poisson, L1 (robust; GD-MLT's default)")])
    export_uvs: BoolProperty(name="Export UVs", default=False,
                             description="Export UV maps (splits vertices at UV seams; no material uses UVs yet)")


def _pass_toggles_class():
    """ViewLayer.gradphoton: one use_pass_<name> per pass of the core's table but Combined."""
    annotations = {}
    for name, channels, label in native.passes():
        if name == "combined":
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
    classification: EnumProperty(
        name="Photon Surface", default="AUTO",
        items=[("AUTO", "Automatic", "Specular when the roughness is below the threshold"),
               ("DIFFUSE", "Diffuse", "Always store photons here"),
               ("SPECULAR", "Specular", "Never store photons here")],
        description="Diffuse/specular classification for photon methods (not yet read by the core)")


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
