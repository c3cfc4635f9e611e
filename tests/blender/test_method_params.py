"""Blender's properties and panels are made from the core's parameter declarations
(_native.method_params): every method's own parameters with its own defaults, ranges and
descriptions, drawn in its panels and nothing else; they reach the core, their statistics reach
the status line, and every pass the method produces reaches the compositor. Settings saved under
the old shared property names are moved into the methods' groups."""
import os

import bpy
import numpy as np
import pytest

from gradphoton import native, properties, session
from test_render import ROOT, small_scene

METHODS = native.get().methods()


def core_scene(w=16, h=12):
    scene = native.get().load_scene(os.path.join(ROOT, "scenes", "cornell-glass.json"))
    scene.width, scene.height = w, h
    return scene


def prop_of(settings, method, decl):
    """(property group, property name, RNA property) that holds `decl` for `method`."""
    group = properties.holder(settings, method, decl)
    name = properties.prop_name(decl)
    return group, name, group.bl_rna.properties[name]


@pytest.mark.parametrize("method", METHODS)
def test_properties_are_the_declarations(empty_scene, method):
    """Each declared parameter has its property: its label, description, default (Max Bounces
    in Cycles' bounces), range and choices; the method's group holds nothing else."""
    s = empty_scene.gradphoton
    own = set()
    for d in native.get().method_params(method):
        if d["name"] in properties.BLENDER_HELD:
            continue
        group, name, rna = prop_of(s, method, d)
        if not d["shared"]:
            own.add(name)
        # A menu's tooltip says what it sets; each item what it does ("...; l1: ...; l2: ...").
        said = properties.choice_descriptions(d)
        summary = d["description"].split("; ")[0] if said else d["description"]
        assert summary[1:] in rna.description, (method, d["name"], rna.description)
        for item in (rna.enum_items if said else ()):
            if item.identifier in said:
                assert item.description == said[item.identifier], (method, d["name"], item.identifier)
        default = d["manual_value"] if d["zero_means"] else d["default"]
        if d["name"] == "max_depth":
            default -= properties.BOUNCES_TO_SEGMENTS
            assert rna.name == "Max Bounces"
        else:
            assert rna.name == d["label"], (method, d["name"])
        if d["type"] == "string":
            assert [i.identifier for i in rna.enum_items] == d["choices"], d["name"]
            assert rna.default == default
        elif d["type"] == "bool":
            assert rna.default == default
        else:
            assert rna.default == pytest.approx(default, rel=1e-6), (method, d["name"])
            if d["min"] is not None and d["name"] != "max_depth":
                assert rna.hard_min >= d["min"] - 1e-6 and (d["min_open"] or rna.hard_min <= d["min"] + 1e-6)
            if d["max"] is not None:
                assert rna.hard_max <= d["max"] + 1e-6
        if d["zero_means"]:
            toggle = properties.auto_toggle(d)
            own.add(toggle)
            assert getattr(group, toggle) is True, "automatic by default: the core's 0"
    group = getattr(s, properties.method_group(method))
    assert {p.identifier for p in group.bl_rna.properties if p.identifier not in ("rna_type", "name")} == own


@pytest.mark.parametrize("method", METHODS)
def test_defaults_render_the_cores_image(empty_scene, method):
    """What the session sends with every property at its default is what the core uses when
    given nothing: the same image (to float32 rounding: a FloatProperty holds 0.6 as
    0.6000000238)."""
    s = empty_scene.gradphoton
    sent = session.params_of(s, method)
    assert set(sent) == {d["name"] for d in native.get().method_params(method)} - properties.BLENDER_HELD
    base = {"threads": 1, "photons": 2000} if "photons" in sent and method != "msppm" else {"threads": 1}
    N = native.get()
    scene = core_scene(12, 9)
    images = []
    for params in (base, dict(sent, **base)):
        ses = N.Session(scene, method, params)
        assert not ses.unused_report or all("is not read with these settings" in u for u in ses.unused_report)
        ses.iterate()
        ses.iterate()
        images.append(ses.develop()["combined"])
    np.testing.assert_allclose(images[0], images[1], rtol=1e-5, atol=1e-7)


def test_old_settings_move_into_the_methods_groups(empty_scene):
    """A file saved with the shared properties (alpha, poisson_lambda, reconstruction as an
    enum index, ...) keeps its values: each goes to the methods that read it."""
    s = empty_scene.gradphoton
    s["alpha"], s["msppm_alpha"], s["poisson_lambda"], s["reconstruction"] = 0.5, 0.55, 0.3, 1
    s["photon_chains"], s["mlt_chains"], s["max_bounces"], s["use_auto_radius"] = 7, 9, 5, 0
    moved = properties.migrate_settings(empty_scene)
    assert set(moved) == {"alpha", "msppm_alpha", "poisson_lambda", "reconstruction", "photon_chains", "mlt_chains",
                          "max_bounces", "use_auto_radius"}
    assert "alpha" not in s.keys()
    assert s.sppm.alpha == pytest.approx(0.5) and s.gpm.alpha == pytest.approx(0.5)
    assert s.msppm.alpha == pytest.approx(0.55)
    assert all(getattr(s, m).__getattribute__("lambda") == pytest.approx(0.3) for m in ("gpt", "gpm", "gdmlt", "sgpt"))
    assert s.gpt.recon == "l1" and s.gpm.recon == "l1"  # gpm's own reconstruction was not saved: its default
    assert s.sppm.chains == 7 and s.gdmlt.chains == 9 and s.pt.max_bounces == 5 and s.msppm.max_bounces == 14
    assert s.sppm.use_auto_radius is False  # (the fixture resets the groups: property_unset)


def render(scene, method, passes=2, **params):
    """Renders `method` with properties of its group set (chains=5: Scene.gradphoton.gdmlt.chains)."""
    small_scene(scene)
    s = scene.gradphoton
    s.method, s.passes = method, passes
    group = getattr(s, properties.method_group(method))
    for k, v in params.items():
        setattr(group, k, v)
    bpy.ops.render.render()
    return session.LAST


def test_gdmlt_chains_reach_the_core_and_the_status_line(empty_scene):
    last = render(empty_scene, "gdmlt", chains=5, large_step=0.5)
    stats = last.session.stats
    assert stats["chains"] == 5
    assert "chains 5" in last.status_line and "accept " in last.status_line, last.status_line
    assert "large " in last.status_line and "unshifted paths" in last.status_line
    assert 0.3 < stats["large-step share"] < 0.7  # large_step 0.5 reached the chains


def test_photon_sampler_choice_for_sppm(empty_scene):
    """sppm with the adaptive photon sampler reports the sampler's statistics (acceptance rate,
    mutation size, V_c) on the status line; uniform has none; sppm-adaptive stays adaptive
    by default (its declaration's default)."""
    last = render(empty_scene, "sppm", photon_sampler="adaptive", photons=5000, chains=8)
    stats = last.session.stats
    assert last.session.method == "sppm"
    assert {"acceptance rate", "mutation size", "V_c"} <= set(stats), stats
    assert 0 < stats["V_c"] <= 1
    for label in ("accept ", "theta ", "V_c "):
        assert label in last.status_line, last.status_line
    last = render(empty_scene, "sppm", photon_sampler="uniform", photons=5000)
    assert "acceptance rate" not in last.session.stats and "accept " not in last.status_line
    last = render(empty_scene, "sppm-adaptive", photons=5000)  # its own default: adaptive
    assert last.session.method == "sppm-adaptive" and "acceptance rate" in last.session.stats
    assert "V_c " in last.status_line


def test_msppm_status_line_and_defaults(empty_scene):
    last = render(empty_scene, "msppm")
    assert "PT share " in last.status_line and "points/px " in last.status_line, last.status_line
    # one photon per pixel by default (Photons: Auto, the core's 0), 2 passes
    assert last.session.stats["photons traced"] == 2 * 32 * 24
    # Path Samples reaches the core: a fixed count per pixel and pass instead of §9.5's
    last = render(empty_scene, "msppm", use_auto_path_samples=False, path_samples=3)
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


def test_photon_counts_saved_before_the_auto_default_stay_in_force(empty_scene):
    """sppm's and gpm's photons per pass became automatic (0: a ramp to two per pixel); a file
    that saved an explicit count, in the group or under the old shared name, keeps rendering
    with it, while a scene that never set one sends 0."""
    s = empty_scene.gradphoton
    assert session.params_of(s, "sppm")["photons"] == 0 and session.params_of(s, "gpm")["photons"] == 0
    s.sppm["photons"] = 250000  # how a file from before the toggle holds it
    s["photons_per_pass"] = 30000
    try:
        moved = properties.migrate_settings(empty_scene)
        assert "photons_per_pass" in moved and "sppm.photons" in moved and "gpm.photons" in moved
        # The old shared name wins over the group's value, as for every moved setting.
        assert session.params_of(s, "sppm")["photons"] == 30000
        assert session.params_of(s, "gpm")["photons"] == 30000
        assert s.sppm.use_auto_photons is False and s.gpm.use_auto_photons is False
        s.sppm.use_auto_photons = True  # the toggle, once stored, is the user's again
        assert "sppm.photons" not in properties.migrate_settings(empty_scene)
        assert session.params_of(s, "sppm")["photons"] == 0
    finally:
        for g in (s.ppm, s.sppm, s.sppm_adaptive, s.gpm):
            for key in ("photons", "use_auto_photons"):
                if key in g.keys():
                    del g[key]


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
    s.method, s.passes = method, 3  # the Render Layers node shows its passes
    if hasattr(getattr(s, properties.method_group(method)), "photons"):
        getattr(s, properties.method_group(method)).photons = 5000
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

    def __init__(self, drawn=None, drawn_on=None):
        self.drawn = [] if drawn is None else drawn
        self.drawn_on = [] if drawn_on is None else drawn_on  # (data's RNA type, property)
        self.use_property_split = self.use_property_decorate = self.active = False

    def column(self, **kwargs):
        return _Layout(self.drawn, self.drawn_on)

    row = column

    def separator(self):
        pass

    def operator(self, *args, **kwargs):
        from types import SimpleNamespace
        return SimpleNamespace()  # its properties are set by the panel

    def template_curve_mapping(self, data, name, **kwargs):
        assert hasattr(data, name), name

    def prop(self, data, name, **kwargs):
        assert hasattr(data, name), name
        self.drawn.append(name)
        self.drawn_on.append((data.bl_rna.identifier, name))

    def label(self, **kwargs):
        pass


# Render settings the panels draw that are not method parameters.
# Render settings that are not method parameters: stop rule, export, the viewport's own settings,
# Cycles' animated seed and Persistent Data.
NOT_PARAMETERS = {"method", "stop_rule", "time_limit", "passes", "target_error", "error_time_limit", "export_uvs",
                  "viewport_method", "viewport_passes", "use_animated_seed", "motion_blur_lights"}
BLENDER_RENDER_SETTINGS = {"use_persistent_data", "use_motion_blur", "motion_blur_shutter"}
# Cycles' Film, Motion Blur and Light Paths > Caustics settings gradphoton reads (Film > Exposure,
# Pixel Filter; Motion Blur > Position, Rolling Shutter; Filter Glossy, Reflective and Refractive
# Caustics): not method parameters.
CYCLES_FILM_SETTINGS = {"film_exposure", "pixel_filter_type", "filter_width", "motion_blur_position",
                        "rolling_shutter_type", "rolling_shutter_duration", "blur_glossy", "caustics_reflective",
                        "caustics_refractive"}


def drawn_parameters(scene, method):
    """(property group, property) of everything the Render tab's panels polling true draw."""
    from types import SimpleNamespace
    from gradphoton import ui
    scene.gradphoton.method = method
    # A dispersive material: the Spectral sub-panel shows where spectral rendering matters.
    glass = bpy.data.materials.get("Dispersive") or bpy.data.materials.new("Dispersive")
    glass.gradphoton.dispersion = 'ABBE'
    glass.use_fake_user = True
    context = SimpleNamespace(scene=scene, engine="GRADPHOTON")
    drawn = []
    for cls in ui._classes:
        if getattr(cls, "bl_context", "") == "render" and cls.poll(context):
            panel = SimpleNamespace(layout=_Layout(), group=getattr(cls, "group", None))
            if hasattr(cls, "draw_header"):  # a checkbox in the header (Film > Transparent)
                cls.draw_header(panel, context)
            cls.draw(panel, context)
            drawn += panel.layout.drawn_on
    return {d for d in drawn if not (d[0] == "GradphotonRenderSettings" and d[1] in NOT_PARAMETERS)
            and not (d[0] == "RenderSettings" and d[1] in BLENDER_RENDER_SETTINGS)
            and not (d[0] == "CyclesRenderSettings" and d[1] in CYCLES_FILM_SETTINGS)}


@pytest.mark.parametrize("method", METHODS)
def test_panels_draw_exactly_the_methods_parameters(empty_scene, method):
    """The Render tab draws each parameter the method declares, once, where it is held (its
    group, the render settings for a shared one, Film > Transparent for film_transparent), with
    its Auto toggle; and no parameter of another method."""
    expected = set()
    for d in native.get().method_params(method):
        if d["name"] == properties.FILM_TRANSPARENT:
            expected.add(("RenderSettings", "film_transparent"))
            continue
        owner = "GradphotonRenderSettings" if d["shared"] else f"GradphotonParams_{properties.method_group(method)}"
        expected.add((owner, properties.prop_name(d)))
        if d["zero_means"]:
            expected.add((owner, properties.auto_toggle(d)))
    assert drawn_parameters(empty_scene, method) == expected


def test_chains_are_greyed_out_unless_the_adaptive_sampler_reads_them(empty_scene):
    s = empty_scene.gradphoton
    chains = next(d for d in native.get().method_params("sppm") if d["name"] == "chains")
    assert chains["read_when"] == "photon_sampler=adaptive"
    assert not properties.read_when(s, "sppm", chains)
    s.sppm.photon_sampler = "adaptive"
    assert properties.read_when(s, "sppm", chains)
    assert properties.read_when(s, "sppm-adaptive", chains)  # adaptive by default
