"""The methods' own parameters (adaptive photon tracing, MSPPM, GD-MLT) reach the core with the
core's defaults, their key statistics reach the status line, and every pass they produce
reaches the compositor."""
import os

import bpy
import numpy as np
import pytest

from gradphoton import native, properties, session
from test_render import ROOT, small_scene

SPECIFIC = properties.METHOD_SPECIFIC_PARAMS


def core_scene(w=16, h=12):
    scene = native.get().load_scene(os.path.join(ROOT, "scenes", "cornell-glass.json"))
    scene.width, scene.height = w, h
    return scene


def test_every_parameter_has_its_property(empty_scene):
    """Each (method, native name) maps to a property of the render settings."""
    s = empty_scene.gradphoton
    for method in native.get().methods():
        for name, prop in properties.method_params(method).items():
            assert hasattr(s, prop), (method, name, prop)
    assert properties.KNOWN_PARAMS >= set(properties.METHOD_PARAMS)


@pytest.mark.parametrize("method", sorted(SPECIFIC))
def test_method_parameters_are_read_by_the_core(empty_scene, method):
    """What the session sends for a method: its own parameters are all read (none in
    unused_params), and whatever it leaves unused is a shared one the session knows."""
    s = empty_scene.gradphoton
    s.photon_sampler = "adaptive"  # the chains of the adaptive sampler are read only then
    params = session.params_of(s, method)
    params.update(photons=2000, threads=1) if method != "msppm" else params.update(threads=1)
    N = native.get()
    ses = N.Session(core_scene(), method, params)
    assert ses.method == method
    unused = set(ses.unused_params)
    assert not unused & set(SPECIFIC[method]), unused
    assert unused <= properties.KNOWN_PARAMS, unused


@pytest.mark.parametrize("method", ["sppm", "sppm-adaptive", "msppm", "gpm", "gdmlt"])
def test_method_defaults_are_the_cores(empty_scene, method):
    """The properties' defaults are the core's (the papers') defaults: sending them renders the
    same image as leaving them to the core (to float32 rounding: Blender's FloatProperty holds
    0.6 as 0.6000000238)."""
    s = empty_scene.gradphoton
    sent = {name: properties.native_value(s, name, prop) for name, prop in SPECIFIC[method].items()}
    base = {"threads": 1, "photons": 2000} if method in ("sppm", "sppm-adaptive") else {"threads": 1}
    N = native.get()
    scene = core_scene(12, 9)
    images = []
    for params in (base, dict(base, **sent)):
        ses = N.Session(scene, method, params)
        ses.iterate()
        ses.iterate()
        images.append(ses.develop()["combined"])
    np.testing.assert_allclose(images[0], images[1], rtol=1e-5, atol=1e-7)


def render(scene, method, passes=2, **settings):
    small_scene(scene)
    s = scene.gradphoton
    s.method, s.passes = method, passes
    for k, v in settings.items():
        setattr(s, k, v)
    bpy.ops.render.render()
    return session.LAST


def test_gdmlt_chains_reach_the_core_and_the_status_line(empty_scene):
    last = render(empty_scene, "gdmlt", mlt_chains=5, mlt_large_step=0.5)
    stats = last.session.stats
    assert stats["chains"] == 5
    assert "chains 5" in last.status_line and "accept " in last.status_line, last.status_line
    assert "large " in last.status_line and "unshifted paths" in last.status_line
    assert 0.3 < stats["large-step share"] < 0.7  # large_step 0.5 reached the chains


def test_photon_sampler_choice_for_sppm(empty_scene):
    """sppm with the adaptive photon sampler reports the sampler's statistics (acceptance rate,
    mutation size, V_c) on the status line; uniform has none; sppm-adaptive stays adaptive
    whatever the choice (the choice is sppm's and ppm's)."""
    last = render(empty_scene, "sppm", photon_sampler="adaptive", photons_per_pass=5000, photon_chains=8)
    stats = last.session.stats
    assert last.session.method == "sppm"
    assert {"acceptance rate", "mutation size", "V_c"} <= set(stats), stats
    assert 0 < stats["V_c"] <= 1
    for label in ("accept ", "theta ", "V_c "):
        assert label in last.status_line, last.status_line
    last = render(empty_scene, "sppm", photon_sampler="uniform", photons_per_pass=5000)
    assert "acceptance rate" not in last.session.stats and "accept " not in last.status_line
    last = render(empty_scene, "sppm-adaptive", photon_sampler="uniform", photons_per_pass=5000)
    assert last.session.method == "sppm-adaptive" and "acceptance rate" in last.session.stats
    assert "V_c " in last.status_line


def test_msppm_status_line_and_defaults(empty_scene):
    last = render(empty_scene, "msppm")
    assert "PT share " in last.status_line and "points/px " in last.status_line, last.status_line
    # one photon per pixel by default (Photons: Auto, the core's 0), 2 passes
    assert last.session.stats["photons traced"] == 2 * 32 * 24
    # Path Samples reaches the core: a fixed count per pixel and pass instead of §9.5's
    last = render(empty_scene, "msppm", use_auto_msppm_path_samples=False, msppm_path_samples=3)
    assert last.session.stats["path tracing samples per pixel and pass"] == pytest.approx(3.0)


def test_status_line_never_fails_on_missing_or_odd_statistics():
    assert session.method_stats("gdmlt", {}) == []
    assert session.method_stats("no-such-method", {"chains": 3}) == []
    assert session.method_stats("gdmlt", {"chains": "x", "acceptance rate": 0.25}) == ["accept 0.250"]
    assert session.method_stats("gpt", {"shift failed: a": 2, "sensor shift failed: b": 3}) == ["unshifted paths 5"]


def _compositor_file_output(scene, out_dir, names):
    """Render Layers -> one File Output node (multilayer EXR) with a slot per pass."""
    scene.use_nodes = True
    scene.render.use_compositing = True
    tree = scene.node_tree
    for n in list(tree.nodes):
        tree.nodes.remove(n)
    rl = tree.nodes.new("CompositorNodeRLayers")
    comp = tree.nodes.new("CompositorNodeComposite")
    tree.links.new(rl.outputs["Image"], comp.inputs["Image"])
    fo = tree.nodes.new("CompositorNodeOutputFile")
    fo.base_path = str(out_dir / "comp_")
    fo.format.file_format = 'OPEN_EXR_MULTILAYER'
    fo.format.color_depth = '32'
    fo.layer_slots.clear()
    for name, bl_name in names:
        fo.layer_slots.new(name)
        out = rl.outputs["Image" if bl_name == "Combined" else bl_name]
        assert out.enabled, bl_name
        tree.links.new(out, fo.inputs[name])
    return str(out_dir / f"comp_{scene.frame_current:04d}.exr")


@pytest.mark.parametrize("method", ["sppm-adaptive", "msppm", "gdmlt"])
def test_every_pass_of_the_method_reaches_the_compositor(empty_scene, out_dir, method):
    """Every pass the core develops for the method (gdmlt: primal, gradients, sample density;
    photon methods: error, radius, photon count) is an output of the compositor's Render Layers
    node, and what a File Output node writes from it is the method's (non-zero) image."""
    small_scene(empty_scene)  # enables every pass toggle
    N = native.get()
    probe = N.Session(core_scene(8, 6), method, {"threads": 1, "photons": 2000})
    probe.iterate()
    produced = sorted(probe.develop())
    labels = {n: label for n, _, label in N.passes()}
    s = empty_scene.gradphoton
    s.method, s.passes, s.photons_per_pass = method, 3, 5000  # the Render Layers node shows its passes
    empty_scene.view_layers[0].update_render_passes()
    try:
        path = _compositor_file_output(empty_scene, out_dir, [(n, labels[n]) for n in produced])
        bpy.ops.render.render()
        exr = N.read_exr(path)
    finally:  # the scene outlives the test: leave no compositor behind
        empty_scene.node_tree.nodes.clear()
        empty_scene.use_nodes = False
    for name in produced:  # File Output layers are named by slot; RGB slots get an alpha (".A")
        assert name in exr, (name, sorted(exr))
        img = exr[name]
        assert img.shape[:2] == (24, 32) and np.isfinite(img).all() and np.abs(img).max() > 0, name
    if method == "gdmlt":  # chain states per pixel sum to the mutations: one per pixel per pass
        assert exr["sample_density"].sum() == pytest.approx(3 * 32 * 24, rel=1e-3)


class _Layout:
    """Records the properties a panel draws (panels cannot be drawn without a window)."""

    def __init__(self, drawn=None):
        self.drawn = [] if drawn is None else drawn
        self.use_property_split = self.use_property_decorate = self.active = False

    def column(self, **kwargs):
        return _Layout(self.drawn)

    row = column

    def separator(self):
        pass

    def operator(self, *args, **kwargs):
        pass

    def prop(self, data, name, **kwargs):
        assert hasattr(data, name), name
        self.drawn.append(name)

    def label(self, **kwargs):
        pass


@pytest.mark.parametrize("method,shown,hidden", [
    ("gdmlt", {"mlt_chains", "mlt_mutations", "mlt_large_step", "mlt_sigma", "mlt_primal_share", "mlt_bootstrap",
               "mlt_reconstruction", "poisson_lambda"}, {"photon_chains", "photon_sampler", "reconstruction"}),
    ("sppm", {"photon_sampler", "photon_chains", "photons_per_pass", "alpha", "confidence"}, {"mlt_chains"}),
    ("sppm-adaptive", {"photon_chains"}, {"photon_sampler", "mlt_chains"}),
    ("msppm", {"msppm_alpha", "msppm_photons", "use_auto_msppm_photons", "msppm_max_bounces", "msppm_path_samples"},
     {"alpha", "photons_per_pass", "max_bounces", "confidence", "photon_hash", "photon_chains"}),
    ("gpm", {"alpha", "photons_per_pass", "gpm_reconstruction", "manifold_iterations"},
     {"reconstruction", "photon_sampler", "mlt_chains"}),
    ("pt", {"max_bounces", "clamp_direct", "film_transparent"},
     {"photon_chains", "mlt_chains", "photon_sampler", "msppm_alpha", "manifold_iterations"}),
])
def test_method_panels_show_the_methods_own_parameters(empty_scene, method, shown, hidden):
    """What the Render tab's panels that poll true for the method draw (subpanels by group)."""
    from types import SimpleNamespace
    from gradphoton import ui
    empty_scene.gradphoton.method = method
    context = SimpleNamespace(scene=empty_scene, engine="GRADPHOTON")
    drawn = set()
    for cls in ui._classes:
        if getattr(cls, "bl_context", "") == "render" and cls.poll(context):
            panel = SimpleNamespace(layout=_Layout())
            cls.draw(panel, context)
            drawn |= set(panel.layout.drawn)
    assert shown <= drawn and not hidden & drawn, drawn
