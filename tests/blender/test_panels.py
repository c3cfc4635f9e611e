"""Blender's panels fit the engine as Cycles' do: one Light panel, no EEVEE-only panels, the
stop rules and passes each method declares, Film > Transparent with a real alpha, Light Paths >
Clamping, Max Bounces as Cycles counts them, warnings of the last render in the Render tab."""
import os

import bpy
import numpy as np
import pytest

from gradphoton import native, properties, session, ui
from test_render import small_scene
import scenes


def gradphoton_panels(context=None):
    """Every registered panel drawn for GRADPHOTON (its COMPAT_ENGINES), optionally of one tab."""
    return [p for p in bpy.types.Panel.__subclasses__()
            if ui.ENGINE in getattr(p, "COMPAT_ENGINES", ()) and (context is None or getattr(p, "bl_context", "") == context)]


def test_one_light_panel_and_no_eevee_only_panels():
    data = gradphoton_panels("data")
    lights = [p for p in data if p.bl_label == "Light" and not getattr(p, "bl_parent_id", "")]
    assert [p.__name__ for p in lights] == ["GRADPHOTON_LIGHT_PT_light"], lights
    names = {p.__name__ for p in gradphoton_panels()}
    # EEVEE's own settings (Blend/Shadow Mode, SSR, light factors, custom distance, shadows)
    # and previews gradphoton cannot render are not drawn for it.
    for eevee_only in ("EEVEE_MATERIAL_PT_settings", "DATA_PT_EEVEE_light", "DATA_PT_EEVEE_light_distance",
                       "DATA_PT_EEVEE_shadow", "DATA_PT_preview", "MATERIAL_PT_preview", "DATA_PT_light",
                       "DATA_PT_area", "DATA_PT_spot", "EEVEE_MATERIAL_PT_volume", "RENDER_PT_eevee_film"):
        assert eevee_only not in names, eevee_only
    # An EEVEE panel drawn for gradphoton is a generic one: kept on purpose, or Cycles draws it too.
    eevee = {p.__name__ for p in gradphoton_panels() if "EEVEE" in p.__name__ and "CYCLES" not in p.COMPAT_ENGINES}
    assert eevee <= ui._EEVEE_KEEP, sorted(eevee - ui._EEVEE_KEEP)
    # What a material, world and camera need is there: slots, surface nodes, depth of field.
    assert {"EEVEE_MATERIAL_PT_context_material", "EEVEE_MATERIAL_PT_surface", "EEVEE_WORLD_PT_surface",
            "DATA_PT_camera_dof", "GRADPHOTON_PT_material", "DATA_PT_context_light"} <= names
    assert not any(p.bl_label == "Preview" for p in gradphoton_panels("data") + gradphoton_panels("material"))


def test_photon_surface_setting_is_gone():
    """Nothing in the core read it: it is not offered."""
    assert "classification" not in bpy.types.Material.bl_rna.properties["gradphoton"].fixed_type.properties


@pytest.mark.parametrize("method", native.methods())
def test_method_info_is_what_the_method_renders(method):
    """The passes and error estimate the panels offer are what a real session of the method
    develops and estimates (on a scene with glass, caustics and an environment)."""
    info = properties.method_info(method)
    scene = native.get().load_scene(os.path.join(os.path.dirname(__file__), "..", "..", "scenes", "cornell-glass.json"))
    scene.width, scene.height = 8, 6
    params = {"threads": 1, "photons": 2000} if method in ("ppm", "sppm", "sppm-adaptive", "gpm") else {"threads": 1}
    s = native.get().Session(scene, method, params)
    s.iterate()
    assert sorted(s.develop()) == sorted(info["passes"])
    assert (s.estimated_error >= 0) == info["error_estimate"]


def test_stop_rules_follow_the_method(empty_scene):
    s = empty_scene.gradphoton
    rules = lambda: [i[0] for i in properties.stop_rule_items(s, bpy.context)]  # noqa: E731
    s.method = "sppm"
    assert rules() == ["TIME", "PASSES", "ERROR"]
    s.stop_rule = "ERROR"
    s.method = "pt"  # no error estimate: Target Error is not offered, the rule falls back to Time
    assert rules() == ["TIME", "PASSES"]
    assert s.stop_rule == "TIME"


def test_default_stop_is_a_time_budget(empty_scene):
    for prop in ("stop_rule", "time_limit"):
        empty_scene.gradphoton.property_unset(prop)
    assert empty_scene.gradphoton.stop_rule == "TIME" and empty_scene.gradphoton.time_limit == 30.0


def test_passes_panel_offers_the_methods_passes(empty_scene):
    from types import SimpleNamespace
    from test_method_params import _Layout
    small_scene(empty_scene)
    drawn = {}
    for method in ("pt", "gpt", "sppm"):
        empty_scene.gradphoton.method = method
        panel = SimpleNamespace(layout=_Layout())
        ui.GRADPHOTON_PT_passes.draw(panel, SimpleNamespace(scene=empty_scene, view_layer=empty_scene.view_layers[0]))
        drawn[method] = set(panel.layout.drawn)
    aux = {"use_pass_albedo", "use_pass_normal", "use_pass_depth"}  # every method's (aov.h)
    assert drawn["pt"] == aux
    assert drawn["gpt"] == {"use_pass_primal", "use_pass_gradient_x", "use_pass_gradient_y"} | aux
    assert drawn["sppm"] == {"use_pass_error", "use_pass_radius", "use_pass_photon_count"} | aux


def test_max_bounces_as_cycles_counts_them(empty_scene):
    s = empty_scene.gradphoton
    s.pt.max_bounces = 0  # direct light only: camera ray plus the segment to the light
    assert session.params_of(s, "pt")["max_depth"] == 2
    assert s.msppm.max_bounces == 14  # its own default: core max_depth 16
    assert session.params_of(s, "msppm")["max_depth"] == 16
    s.sppm.use_auto_radius = True
    assert session.params_of(s, "sppm")["radius"] == 0
    s.sppm.use_auto_radius, s.sppm.radius = False, 0.05
    assert session.params_of(s, "sppm")["radius"] == pytest.approx(0.05)


def _alpha_scene(scene, method):
    """A floor filling the lower part of the frame under a blue sky: the top rows see the world."""
    small_scene(scene)
    scenes.set_world(scene, (0.2, 0.4, 1.0), 1.0)
    s = scene.gradphoton
    s.method, s.passes = method, 2
    if method == "sppm":
        s.sppm.photons = 5000


@pytest.mark.parametrize("method", ["pt", "sppm"])
def test_film_transparent_gives_alpha_zero_where_the_world_is_seen(empty_scene, out_dir, method):
    _alpha_scene(empty_scene, method)
    N = native.get()
    try:
        empty_scene.render.film_transparent = True
        rgba = N.read_exr(scenes.render_to_exr(empty_scene, str(out_dir / f"{method}_transparent.exr")))
    finally:
        empty_scene.render.film_transparent = False
    opaque = N.read_exr(scenes.render_to_exr(empty_scene, str(out_dir / f"{method}_opaque.exr")))
    print(sorted(rgba))
    a = rgba["A"][..., 0] if "A" in rgba else rgba["combined.A"][..., 0]
    rgb = np.dstack([rgba[c][..., 0] for c in ("R", "G", "B")]) if "R" in rgba else None
    # Rows run top to bottom in read_exr: the top row is sky, the bottom row is floor.
    assert a[0].max() == 0.0 and a[-1].min() == 1.0, (a[0], a[-1])
    assert 0 < a.mean() < 1
    if rgb is not None:
        assert np.abs(rgb[0]).max() == 0.0  # no background in Combined (premultiplied)
    a_opaque = opaque["A"][..., 0] if "A" in opaque else opaque["combined.A"][..., 0]
    assert (a_opaque == 1.0).all()
    assert not any("no transparent film" in m for _, m in session.REPORTS)


def test_film_transparent_on_a_method_without_it_is_reported(empty_scene, out_dir):
    _alpha_scene(empty_scene, "gpt")
    try:
        empty_scene.render.film_transparent = True
        bpy.ops.render.render()
    finally:
        empty_scene.render.film_transparent = False
    assert any("gpt has no transparent film" in m for _, m in session.REPORTS), session.REPORTS


def _mean_combined(scene, out_dir, name):
    exr = native.get().read_exr(scenes.render_to_exr(scene, str(out_dir / f"{name}.exr")))
    return np.dstack([exr[c][..., 0] for c in ("R", "G", "B")]) if "R" in exr else exr["combined"]


def test_clamping_reaches_path_tracing(empty_scene, out_dir):
    _alpha_scene(empty_scene, "pt")
    s = empty_scene.gradphoton
    s.passes = 4
    free = _mean_combined(empty_scene, out_dir, "free")
    s.pt.clamp_direct = s.pt.clamp_indirect = 1e6  # a limit above every sample: the same image
    assert np.array_equal(_mean_combined(empty_scene, out_dir, "high"), free)
    s.pt.clamp_direct, s.pt.clamp_indirect = 0.05, 0.0
    direct = _mean_combined(empty_scene, out_dir, "direct")
    s.pt.clamp_direct, s.pt.clamp_indirect = 0.0, 0.001
    indirect = _mean_combined(empty_scene, out_dir, "indirect")
    s.pt.clamp_direct = s.pt.clamp_indirect = 0.0
    assert direct.sum() < 0.8 * free.sum()  # the sunlit floor is direct light
    assert indirect.sum() < free.sum() and indirect.sum() > direct.sum()


def test_clamping_and_transparency_only_for_methods_that_declare_them():
    assert ui.reads("pt", "clamp_direct") and ui.reads("pt", "film_transparent")
    assert not ui.reads("sppm", "clamp_direct") and ui.reads("sppm", "film_transparent")
    assert not ui.reads("gdmlt", "clamp_direct") and not ui.reads("gdmlt", "film_transparent")


def test_warnings_of_the_last_render_are_kept_for_the_panel(empty_scene):
    small_scene(empty_scene)
    bpy.data.lights["Sun"].use_shadow = False
    empty_scene.gradphoton.passes = 1
    bpy.ops.render.render()
    assert any("renders with shadows" in m for _, m in session.REPORTS), session.REPORTS
    assert ui.GRADPHOTON_PT_report.poll(type("C", (), {"engine": "GRADPHOTON"})())


def test_time_budget_stops_at_the_pass_boundary_nearest_the_budget():
    """Long passes (GPM at 1080p: about 25 s each here) end the render near the budget, not one
    whole pass past it; short passes run to the budget."""
    import time
    from types import SimpleNamespace
    p = session.Progress(SimpleNamespace(stop_rule='TIME', time_limit=10.0, passes=64, target_error=0.05))
    p.start = time.perf_counter() - 9.0
    assert p.done(1, None)          # one 9 s pass: a second would end at 18 s
    assert not p.done(9, None)      # 1 s passes: one more ends at 10 s
    p.start = time.perf_counter() - 10.0
    assert p.done(100, None)


def test_light_panel_draws_the_settings_the_core_renders(empty_scene):
    """Point/spot radius and sun angle reach the core (export/light.py), so the Light panel offers
    them as Cycles does; the area light's spread, which it does not model, is not drawn."""
    from types import SimpleNamespace
    from test_method_params import _Layout
    drawn = {}
    for kind in ("POINT", "SPOT", "SUN", "AREA"):
        light = bpy.data.lights.new(kind, kind)
        ob = bpy.data.objects.new(kind, light)
        panel = SimpleNamespace(layout=_Layout())
        ui.GRADPHOTON_LIGHT_PT_light.draw(panel, SimpleNamespace(scene=empty_scene, light=light, object=ob))
        drawn[kind] = set(panel.layout.drawn)
    assert "shadow_soft_size" in drawn["POINT"] and "shadow_soft_size" in drawn["SPOT"]
    assert "angle" in drawn["SUN"] and "shadow_soft_size" not in drawn["SUN"]
    assert "spread" not in drawn["AREA"] and "angle" not in drawn["AREA"]
