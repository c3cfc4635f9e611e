"""What a Cycles user reaches for in Blender's panels works with gradphoton (issue 36): Object and
World Ray Visibility, Mask > Holdout, Film > Exposure and Pixel Filter, Target Error with a Time
Limit, Spectral in one place, tooltips that say what a control does, warnings that name the
node and the value used, and the image sent to Blender as often as Cycles sends it."""
import re
import time
from types import SimpleNamespace

import bpy
import numpy as np
import pytest

from gradphoton import native, properties, session, ui
from gradphoton.export import light as light_export
from gradphoton.export import world as world_export
from gradphoton.export import Warnings
from test_method_params import _Layout
from test_render import small_scene
import scenes


def draw(panel_cls, context):
    panel = SimpleNamespace(layout=_Layout())
    panel_cls.draw(panel, context)
    return panel.layout.drawn


# ---- Ray Visibility ----

def test_object_ray_visibility_sub_panel_draws_cycles_switches(empty_scene):
    assert ui.ENGINE in bpy.types.OBJECT_PT_visibility.COMPAT_ENGINES  # its parent, with Mask > Holdout
    assert ui.GRADPHOTON_OBJECT_PT_visibility_ray_visibility.bl_parent_id == "OBJECT_PT_visibility"
    cube = bpy.data.objects.new("Cube", bpy.data.meshes.new("Cube"))
    lamp = bpy.data.objects.new("Lamp", bpy.data.lights.new("Lamp", 'AREA'))
    empty = bpy.data.objects.new("Empty", None)
    ctx = lambda ob, engine="GRADPHOTON": SimpleNamespace(engine=engine, object=ob, scene=empty_scene)  # noqa: E731
    panel = ui.GRADPHOTON_OBJECT_PT_visibility_ray_visibility
    assert panel.poll(ctx(cube)) and panel.poll(ctx(lamp))
    assert not panel.poll(ctx(empty)) and not panel.poll(ctx(cube, "CYCLES"))
    assert draw(panel, ctx(cube)) == ["visible_camera", "visible_diffuse", "visible_glossy",
                                      "visible_transmission", "visible_shadow"]
    assert draw(panel, ctx(lamp)) == ["visible_camera", "visible_diffuse", "visible_glossy", "visible_transmission"]


def test_world_ray_visibility_panel(empty_scene):
    panel = ui.GRADPHOTON_WORLD_PT_ray_visibility
    ctx = SimpleNamespace(engine="GRADPHOTON", world=empty_scene.world, scene=empty_scene)
    assert panel.poll(ctx)
    assert draw(panel, ctx) == ["camera", "diffuse", "glossy", "transmission"]


# ---- Holdout ----

def _holdout_scene(scene, method):
    small_scene(scene)
    scenes.set_world(scene, (0.2, 0.4, 1.0), 1.0)
    s = scene.gradphoton
    s.method, s.passes = method, 2
    if method == "sppm":
        s.sppm.use_auto_photons, s.sppm.photons = False, 5000
    return bpy.data.objects["Suzanne"]


def _rgba(scene, out_dir, name):
    exr = native.get().read_exr(scenes.render_to_exr(scene, str(out_dir / f"{name}.exr")))
    if "R" in exr:  # a single-layer file
        return np.dstack([exr[c][..., 0] for c in ("R", "G", "B")]), exr["A"][..., 0]
    return exr["combined"], exr["A"][..., 0]  # multilayer: Combined's RGB, and its Alpha as "A"


@pytest.mark.parametrize("method", ["pt", "sppm"])
def test_holdout_is_black_with_alpha_zero_as_cycles(empty_scene, out_dir, method):
    """Mask > Holdout on the monkey: where the camera sees it, no colour and alpha 0, with Film >
    Transparent and without (Cycles' integrate_surface_holdout; alpha 0 with an opaque film too:
    test_holdout_alpha_without_film_transparent_is_cycles'); the floor it shadows is as without
    the holdout."""
    monkey = _holdout_scene(empty_scene, method)
    empty_scene.render.film_transparent = True
    try:
        plain_rgb, plain_a = _rgba(empty_scene, out_dir, "plain")
        monkey.is_holdout = True
        held_rgb, held_a = _rgba(empty_scene, out_dir, "held")
        empty_scene.render.film_transparent = False
        opaque_rgb, opaque_a = _rgba(empty_scene, out_dir, "opaque")
    finally:
        empty_scene.render.film_transparent = False
        monkey.is_holdout = False
    held = (held_a == 0) & (plain_a == 1)  # the monkey's pixels
    assert held.sum() > 20, held.sum()
    assert np.abs(held_rgb[held]).max() == 0.0
    assert plain_rgb[held].mean() > 0.05  # it was a lit monkey
    assert np.abs(opaque_rgb[held]).max() == 0.0
    # An opaque film: the monkey still alpha 0 (as Cycles), the world and the floor 1.
    assert (opaque_a[held] == 0).all() and (opaque_a[(held_a == 1) | (plain_a == 0)] == 1).all()
    assert not any("Holdout" in m for _, m in session.REPORTS), session.REPORTS


@pytest.mark.parametrize("method", ["pt", "sppm"])
def test_holdout_alpha_without_film_transparent_is_cycles(empty_scene, out_dir, method):
    """Film > Transparent off, Mask > Holdout on the monkey: Cycles 3.4 gives the monkey's pixels
    alpha 0 all the same, and the World and floor alpha 1 (measured here, in Blender: its Combined
    Alpha); gradphoton's Combined Alpha matches it pixel for pixel but at the monkey's edges
    (Cycles' 16 box-filtered samples against our 4 passes: a fraction there; measured: 2 of 3072
    pixels differ by more than 0.5, mean alpha 0.8140 both), and the scene without a holdout
    keeps alpha 1. Seen failing with alpha keyed on Film > Transparent alone (alpha 1
    everywhere)."""
    monkey = _holdout_scene(empty_scene, method)
    empty_scene.render.resolution_x, empty_scene.render.resolution_y = 64, 48
    monkey.is_holdout = True
    try:
        scenes.configure_cycles(empty_scene, 16)
        _, c_a = _rgba(empty_scene, out_dir, "holdout_opaque_cycles")
        empty_scene.render.engine = 'GRADPHOTON'
        empty_scene.gradphoton.passes = 4
        rgb, a = _rgba(empty_scene, out_dir, f"holdout_opaque_{method}")
        monkey.is_holdout = False
        _, plain_a = _rgba(empty_scene, out_dir, f"holdout_opaque_{method}_plain")
    finally:
        monkey.is_holdout = False
    held = c_a == 0  # the monkey's pixels in Cycles
    print(f"HOLDOUT ALPHA {method}: Cycles alpha 0 on {held.sum()} pixels, 1 on {(c_a == 1).sum()}; "
          f"gradphoton 0 on {(a == 0).sum()}, 1 on {(a == 1).sum()}; |difference| > 0.5 on "
          f"{(np.abs(a - c_a) > 0.5).sum()}, mean alpha {a.mean():.4f} (Cycles {c_a.mean():.4f})")
    assert held.sum() > 100 and (c_a == 1).sum() > 2000  # Cycles: the monkey out, the rest opaque
    assert (np.abs(a - c_a) > 0.5).sum() <= 0.1 * held.sum()  # a few edge pixels
    assert abs(a.mean() - c_a.mean()) < 0.01
    assert np.abs(rgb[(a == 0) & held]).max() == 0.0
    assert (plain_a == 1).all()


def test_collection_holdout_in_the_view_layer_holds_out_its_objects(empty_scene, out_dir):
    """A collection with Holdout ticked in the view layer (View Layer > Collections, the
    Outliner's Holdout toggle) holds out its objects as Mask > Holdout does (Cycles: the
    object's holdout_get in the view layer); the same collection without it does not."""
    monkey = _holdout_scene(empty_scene, "pt")
    coll = bpy.data.collections.new("HeldOut")
    empty_scene.collection.children.link(coll)
    for c in list(monkey.users_collection):
        c.objects.unlink(monkey)
    coll.objects.link(monkey)
    layer_coll = bpy.context.view_layer.layer_collection.children["HeldOut"]
    empty_scene.render.film_transparent = True
    try:
        plain_rgb, plain_a = _rgba(empty_scene, out_dir, "coll_plain")
        layer_coll.holdout = True
        held_rgb, held_a = _rgba(empty_scene, out_dir, "coll_held")
    finally:
        empty_scene.render.film_transparent = False
        layer_coll.holdout = False
        coll.objects.unlink(monkey)
        empty_scene.collection.objects.link(monkey)
        bpy.data.collections.remove(coll)
    assert (plain_a == 1).sum() > (held_a == 1).sum() + 20
    held = (held_a == 0) & (plain_a == 1)  # the monkey's pixels
    assert held.sum() > 20, held.sum()
    assert np.abs(held_rgb[held]).max() == 0.0
    assert plain_rgb[held].mean() > 0.05


def test_holdout_shader_is_cut_out_as_mask_holdout(empty_scene, out_dir):
    """A Holdout shader as the monkey's surface: alpha 0 and no colour where the camera sees it,
    as Mask > Holdout (Cycles' holdout closure)."""
    monkey = _holdout_scene(empty_scene, "pt")
    mat = bpy.data.materials.new("HoldoutShader")
    mat.use_nodes = True
    nt = mat.node_tree
    nt.links.new(nt.nodes.new("ShaderNodeHoldout").outputs[0], nt.nodes["Material Output"].inputs["Surface"])
    empty_scene.render.film_transparent = True
    try:
        _, plain_a = _rgba(empty_scene, out_dir, "shader_plain")
        monkey.data.materials.clear()
        monkey.data.materials.append(mat)
        rgb, a = _rgba(empty_scene, out_dir, "shader_held")
    finally:
        empty_scene.render.film_transparent = False
    held = (a == 0) & (plain_a == 1)  # the monkey's pixels
    assert held.sum() > 20, held.sum()
    assert np.abs(rgb[held]).max() == 0.0


def _mixed_holdout_scene(scene, fac):
    """A box whose surface is a Mix Shader (Fac `fac`) of a Holdout (first) and a Diffuse BSDF,
    on a floor, lit by a sun and a blue world; Film > Transparent."""
    scenes.add_plane(scene, "Floor", 20.0, scenes.diffuse_material("Floor"))
    m, nt, out = scenes._node_material("HalfHeld")
    mix = nt.nodes.new("ShaderNodeMixShader")
    mix.inputs["Fac"].default_value = fac
    d = nt.nodes.new("ShaderNodeBsdfDiffuse")
    d.inputs["Color"].default_value = (0.8, 0.5, 0.2, 1)
    nt.links.new(nt.nodes.new("ShaderNodeHoldout").outputs[0], mix.inputs[1])
    nt.links.new(d.outputs[0], mix.inputs[2])
    nt.links.new(mix.outputs[0], out.inputs["Surface"])
    s = 0.9
    v = [(x, y, z) for x in (-s, s) for y in (-s, s) for z in (0.1, 0.1 + 2 * s)]
    f = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    scenes.add_mesh_object(scene, "Box", v, f, m).rotation_euler = (0, 0, 0.5)
    la = bpy.data.lights.new("Sun", 'SUN')
    la.energy = 3.0
    sun = bpy.data.objects.new("Sun", la)
    scene.collection.objects.link(sun)
    sun.rotation_euler = (0.5, 0.3, 0)
    scenes.add_camera(scene, (0, -6, 3), (0, 0, 0.8))
    scenes.set_world(scene, (0.2, 0.4, 1.0), 1.0)
    scene.render.resolution_x, scene.render.resolution_y = 64, 48
    scene.render.film_transparent = True


@pytest.mark.parametrize("method", ["pt", "sppm"])
def test_holdout_in_a_mix_is_weighted_as_cycles(empty_scene, out_dir, method):
    """A Mix Shader (Fac 0.3) of a Holdout and a Diffuse BSDF on a box: Cycles gives the box alpha
    1 - 0.7 = 0.3 and 0.3 of the diffuse colour (svm_node_closure_holdout: the holdout closure
    weighted by the mix; integrate_surface_holdout: that weight becomes transparency). gradphoton
    matches its alpha and colour over the box within 2 % (seeded; measured: see the print).
    Seen failing with the weight ignored (alpha 0 or 1 over the box)."""
    _mixed_holdout_scene(empty_scene, 0.3)
    try:
        scenes.configure_cycles(empty_scene, 64, 4)
        c_rgb, c_a = _rgba(empty_scene, out_dir, "mixed_holdout_cycles")
        empty_scene.render.engine = 'GRADPHOTON'
        g = empty_scene.gradphoton
        g.method, g.stop_rule, g.passes = method, 'PASSES', 64
        if method == "sppm":
            g.sppm.use_auto_photons, g.sppm.photons = False, 20000
        else:
            g.pt.max_bounces = 4
        rgb, a = _rgba(empty_scene, out_dir, f"mixed_holdout_{method}")
    finally:
        empty_scene.render.film_transparent = False
    box = (c_a > 0.2) & (c_a < 0.4)  # the box's pixels in Cycles (its edges left out)
    assert box.sum() > 150, box.sum()
    alpha, c_alpha = a[box].mean(), c_a[box].mean()
    colour, c_colour = rgb[box].mean(axis=0), c_rgb[box].mean(axis=0)
    print(f"MIXED HOLDOUT {method}: alpha {alpha:.4f} (Cycles {c_alpha:.4f}), colour {colour.round(4)} "
          f"(Cycles {c_colour.round(4)}) over {box.sum()} pixels")
    assert abs(alpha - c_alpha) < 0.02 * c_alpha
    assert np.all(np.abs(colour - c_colour) < 0.02 * c_colour)
    assert not any("Holdout" in m for _, m in session.REPORTS), session.REPORTS


def test_holdout_in_a_method_without_it_is_a_warning_naming_method_and_material(empty_scene):
    monkey = _holdout_scene(empty_scene, "gpt")
    monkey.is_holdout = True
    try:
        bpy.ops.render.render()
    finally:
        monkey.is_holdout = False
    line = next((m for _, m in session.REPORTS if "Holdout not rendered by gpt" in m), None)
    assert line is not None, session.REPORTS
    assert "Path Tracing" in line and "material" in line, line
    assert "gpm" not in {m for m in native.methods() if native.method_info(m)["holdout"]}


# ---- Film ----

@pytest.mark.parametrize("method", native.methods())
def test_film_panel_offers_exposure_and_pixel_filter_to_every_method(empty_scene, method):
    empty_scene.gradphoton.method = method
    ctx = SimpleNamespace(engine="GRADPHOTON", scene=empty_scene)
    assert ui.GRADPHOTON_PT_film.poll(ctx) and ui.GRADPHOTON_PT_film_pixel_filter.poll(ctx)
    assert draw(ui.GRADPHOTON_PT_film, ctx) == ["film_exposure"]
    empty_scene.cycles.pixel_filter_type = 'GAUSSIAN'
    assert draw(ui.GRADPHOTON_PT_film_pixel_filter, ctx) == ["pixel_filter_type", "filter_width"]
    empty_scene.cycles.pixel_filter_type = 'BOX'
    assert draw(ui.GRADPHOTON_PT_film_pixel_filter, ctx) == ["pixel_filter_type"]
    empty_scene.cycles.property_unset("pixel_filter_type")
    assert ui.GRADPHOTON_PT_film_transparency.poll(ctx) == ui.reads(method, "film_transparent")


def test_exposure_scales_the_image_as_cycles(empty_scene, out_dir):
    _holdout_scene(empty_scene, "pt")
    one, _ = _rgba(empty_scene, out_dir, "exposure1")
    empty_scene.cycles.film_exposure = 2.5
    try:
        more, alpha = _rgba(empty_scene, out_dir, "exposure2")
    finally:
        empty_scene.cycles.property_unset("film_exposure")
    assert one.mean() > 0.05
    np.testing.assert_allclose(more, 2.5 * one, rtol=1e-6, atol=0)
    assert (alpha == 1).all()


# ---- Rendering: Target Error with a Time Limit, Spectral once ----

def test_target_error_stops_at_its_time_limit_whichever_comes_first():
    settings = SimpleNamespace(stop_rule='ERROR', time_limit=30.0, passes=64, target_error=0.01, error_time_limit=5.0)
    p = session.Progress(settings)
    assert not p.done(3, 0.5)
    p.start = time.perf_counter() - 5.0
    assert p.done(3, 0.5) and p.timed_out(0.5)
    assert p.fraction(3, 0.5) == 1.0
    settings.error_time_limit = 0.0  # no limit: the target alone
    p = session.Progress(settings)
    p.start = time.perf_counter() - 500.0
    assert not p.done(3, 0.5) and p.done(3, 0.009)


def test_time_limit_is_drawn_beside_target_error(empty_scene):
    s = empty_scene.gradphoton
    s.method, s.stop_rule = "sppm", "ERROR"
    drawn = draw(ui.GRADPHOTON_PT_render, SimpleNamespace(engine="GRADPHOTON", scene=empty_scene))
    assert drawn[:4] == ["method", "stop_rule", "target_error", "error_time_limit"], drawn


def test_target_error_time_limit_ends_a_real_render(empty_scene):
    from test_render import _CancelAfter
    bpy.utils.register_class(_CancelAfter)
    try:
        _holdout_scene(empty_scene, "sppm")
        empty_scene.render.engine = _CancelAfter.bl_idname
        _CancelAfter.delay = 20.0  # a guard: Esc after 20 s, should the Time Limit not stop it
        _CancelAfter.record.clear()
        s = empty_scene.gradphoton
        s.stop_rule, s.target_error, s.error_time_limit = "ERROR", 1e-4, 0.5
        bpy.ops.render.render()
        assert _CancelAfter.record["latency"] is None  # the guard never fired
        assert any("Time Limit reached" in m for _, m in session.REPORTS), session.REPORTS
    finally:
        _CancelAfter.delay = 0.6
        empty_scene.render.engine = "GRADPHOTON"
        bpy.utils.unregister_class(_CancelAfter)


def _spectral_drawn(scene):
    ctx = SimpleNamespace(engine="GRADPHOTON", scene=scene)
    out = []
    for cls in ui._classes:
        if getattr(cls, "bl_context", "") == "render" and cls.poll(ctx):
            panel = SimpleNamespace(layout=_Layout(), group=getattr(cls, "group", None))
            cls.draw(panel, ctx)
            out += [name for name in panel.layout.drawn if name in ("spectral_mode", "wavelengths")]
    return out


def test_spectral_is_shown_once_and_only_where_it_matters(empty_scene):
    s = empty_scene.gradphoton
    s.method = "pt"
    assert _spectral_drawn(empty_scene) == []  # nothing disperses
    glass = scenes.glass_material("Prism")
    glass.gradphoton.dispersion = 'ABBE'
    plane = scenes.add_plane(empty_scene, "Prism", 1.0, glass)
    assert _spectral_drawn(empty_scene) == ["spectral_mode", "wavelengths"]
    bpy.data.objects.remove(plane)
    bpy.data.materials.remove(glass)
    assert _spectral_drawn(empty_scene) == []
    s.spectral_mode = "spectral"  # the user asked for it: shown
    assert _spectral_drawn(empty_scene) == ["spectral_mode", "wavelengths"]
    s.spectral_mode = "auto"
    s.method = "spt"
    assert _spectral_drawn(empty_scene).count("spectral_mode") == 1


# ---- Words ----

def test_tooltips_say_what_a_control_does():
    """No parameter tooltip points at a docs file, ends in a bare '(radius 0)', leaves 'thesis'
    unnamed, or describes a menu item by its identifier."""
    for method in native.methods():
        for d in native.get().method_params(method):
            tip = properties._tooltip(d)
            assert "docs/" not in tip and "(radius 0)" not in tip, (method, tip)
            assert not re.search(r"\bthesis\b", tip), (method, tip)
            if d["type"] == "string" and d["name"] != "spectral":
                said = properties.choice_descriptions(d)
                assert set(said) == set(d["choices"]), (method, d["name"], d["description"])
    conf = next(d for d in native.get().method_params("sppm") if d["name"] == "confidence")
    assert properties._tooltip(conf).endswith("(1 - β, Hachisuka 2011, eq. 6.10)")
    assert "no material uses UVs" not in properties._RenderSettings.__annotations__["export_uvs"].keywords["description"]


def test_status_line_does_not_repeat_blenders_elapsed_time():
    p = session.Progress(SimpleNamespace(stop_rule='TIME', time_limit=30.0, passes=64, target_error=0.05))
    p.start = time.perf_counter() - 3.0
    line = p.status({"passes": 2, "paths": 1000}, None, "pt")
    assert line == "Pass 2 | 1,000 paths | 27.0 s left", line


def test_world_warning_names_the_node_and_the_value_used(empty_scene):
    world = empty_scene.world
    world.use_nodes = True
    bg = world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.05, 0.1, 0.2, 1)
    # A node the core does not evaluate (supported ones make the World a graph: test_world_graph).
    node = world.node_tree.nodes.new("ShaderNodeTexPointDensity")
    world.node_tree.links.new(node.outputs["Color"], bg.inputs["Color"])
    w = Warnings()
    world_export.export_world(world, w)
    assert any("node 'Point Density' into Background: Color (rendered as (0.05, 0.1, 0.2))" in line
               for line in w.lines()), w.lines()


def test_area_light_spread_is_said_plainly(empty_scene):
    la = bpy.data.lights.new("Panel", 'AREA')
    la.spread = 0.5
    ob = bpy.data.objects.new("Panel", la)
    drawn = []

    class Layout(_Layout):
        def label(self, text="", **kwargs):
            drawn.append(text)
    panel = SimpleNamespace(layout=Layout())
    ui.GRADPHOTON_LIGHT_PT_light.draw(panel, SimpleNamespace(scene=empty_scene, light=la, object=ob))
    assert "Spread 29° renders as 180°:" in " ".join(drawn), drawn
    w = Warnings()
    light_export._add_area(SimpleNamespace(description={"materials": {}}, meshes=[]), ob, la,
                           np.eye(4), "Panel", [1, 1, 1], w, {})
    assert any("Spread not modelled" in line and "Panel (Spread 29°)" in line for line in w.lines()), w.lines()


# ---- Reports and refresh ----

def test_last_render_panel_uses_blenders_icons_per_level():
    assert ui.REPORT_ICONS == {'ERROR': 'CANCEL', 'WARNING': 'ERROR', 'INFO': 'INFO'}


def test_export_warnings_reach_the_status_bar_when_the_render_ends(empty_scene):
    """Blender's banner shows a warning 5 s from its report: sent at the end, it is there when
    the image is; the Last Render panel has it from the start."""
    small_scene(empty_scene)
    bpy.data.lights["Sun"].use_shadow = False
    empty_scene.gradphoton.passes = 1
    events = []

    class Engine:
        persistent = None

        def test_break(self):
            return False

        def report(self, levels, message):
            events.append(("report", message))

        def update_stats(self, *a):
            pass

        def update_progress(self, *a):
            pass

        def begin_result(self, *a, **kw):
            return bpy.types.RenderResult  # never written: the pass list is empty below

        def update_result(self, r):
            events.append(("image", None))

        def end_result(self, r):
            events.append(("end", None))

        def get_result(self):
            raise AttributeError

    s = session.RenderSession(Engine())
    s._write = lambda result, passes, **kwargs: None
    s.render(bpy.context.evaluated_depsgraph_get())
    kinds = [k for k, m in events if k != "report" or "renders with shadows" in m]
    assert kinds.index("end") < kinds.index("report"), events
    assert any("renders with shadows" in m for _, m in session.REPORTS)


def test_images_reach_blender_as_often_as_cycles_sends_them():
    assert session.display_interval(0.0) == 0.25 and session.display_interval(3.0) == 0.5
    assert session.display_interval(9.9) == 1.0 and session.display_interval(10.0) == 2.0


def test_previews_for_the_methods_whose_pass_cost_follows_the_pixels():
    """Reduced-resolution first passes where a smaller image is quicker: camera paths or mutations
    per pixel; not the photon methods, which pause their first pass instead (Multisampled PPM
    too, whatever its photons)."""
    for method in ("pt", "spt", "gpt", "sgpt", "gdmlt"):
        assert session.previews_help(method, {}), method
    for method in ("ppm", "sppm", "sppm-adaptive", "gpm", "msppm"):
        assert not session.previews_help(method, {}), method
    assert not session.previews_help("msppm", {"photons": 0})


def test_first_images_at_reduced_resolution_leave_the_render_unchanged(empty_scene, out_dir):
    """A time-limited F12 render shows smaller first passes (progressive resolution) before its
    full-size passes; the image it ends with is the full-size passes' alone, bit for bit the
    render of as many passes without them."""
    _holdout_scene(empty_scene, "pt")
    empty_scene.render.resolution_x, empty_scene.render.resolution_y = 256, 192
    s = empty_scene.gradphoton
    s.stop_rule, s.time_limit = "TIME", 1.5
    timed, _ = _rgba(empty_scene, out_dir, "timed")
    updates = list(session.LAST.updates)
    passes = session.LAST.session.stats["passes"]
    assert updates[0][1] == 0 and any(p > 0 for _, p in updates), updates  # a preview first
    assert passes >= 1
    s.stop_rule, s.passes = "PASSES", passes
    counted, _ = _rgba(empty_scene, out_dir, "counted")
    assert session.LAST.updates[0][1] > 0  # no preview for a pass count
    np.testing.assert_array_equal(timed, counted)
