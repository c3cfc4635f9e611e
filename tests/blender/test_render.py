"""Rendering: batch renders of a saved .blend in a subprocess (`blender -b file -E GRADPHOTON
-f 1`), every registered pass in the multilayer EXR and on the compositor's Render Layers node,
one warning for unsupported nodes, cancellation latency, and pass names taken from the core."""
import os
import subprocess
import sys
import time

import bpy
import numpy as np
import pytest

import scenes
from gradphoton import native, session
from gradphoton.engine import GradphotonRenderEngine

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
ENABLE = ("import sys, addon_utils; sys.path.insert(0, %r); "
          "addon_utils.enable('gradphoton', default_set=True)" % os.path.join(ROOT, "addon"))


def small_scene(scene):
    scenes.add_plane(scene, "Floor", 20.0, scenes.diffuse_material("Floor"))
    bpy.ops.mesh.primitive_monkey_add(location=(0, 0, 1))
    la = bpy.data.lights.new("Sun", 'SUN')
    la.energy = 3.0
    ob = bpy.data.objects.new("Sun", la)
    scene.collection.objects.link(ob)
    ob.rotation_euler = (0.5, 0.3, 0)
    scenes.add_camera(scene, (0, -6, 3), (0, 0, 0.8))
    for name, _, _, _, _ in session.blender_passes():
        if name != "combined":
            setattr(scene.view_layers[0].gradphoton, "use_pass_" + name, True)


def batch_render(blend, out_prefix, *extra):
    cmd = ["blender", "-b", "--factory-startup", blend, "--python-expr", ENABLE, "-E", "GRADPHOTON",
           "-o", out_prefix + "####", "-F", "OPEN_EXR_MULTILAYER", *extra]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=300)


def test_batch_render_writes_every_registered_pass(empty_scene, out_dir):
    small_scene(empty_scene)
    blend = str(out_dir / "small.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend, copy=True)
    r = batch_render(blend, str(out_dir / "frame_"), "-f", "1")
    assert r.returncode == 0, r.stdout + r.stderr
    exr = native.get().read_exr(str(out_dir / "frame_0001.exr"))
    vl, method = empty_scene.view_layers[0], empty_scene.gradphoton.method
    expected = {f"ViewLayer.{bl}" for _, bl, _, _, _ in session.enabled_passes(vl, method)}
    got = {k for k in exr if not k.endswith(".A")}
    assert got == expected, (got, expected)
    # Every toggle is on, but only the passes the method writes are registered.
    assert len(expected) < len(session.enabled_passes(vl)) and "ViewLayer.Gradient X" not in got
    combined = exr["ViewLayer.Combined"]
    assert combined.shape == (24, 32, 3) and combined.mean() > 0.01
    # Blender's rows run bottom to top: the floor (bright) fills the bottom, sky (black) the top
    assert combined[-1].mean() > combined[0].mean()


def test_sppm_batch_render_fills_its_own_passes(empty_scene, out_dir):
    """A photon method writes its error, radius and photon-count passes into the EXR."""
    small_scene(empty_scene)
    settings = empty_scene.gradphoton
    settings.method, settings.sppm.photons, settings.passes = "sppm", 20000, 4
    blend = str(out_dir / "sppm.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend, copy=True)
    r = batch_render(blend, str(out_dir / "sppm_"), "-f", "1")
    assert r.returncode == 0, r.stdout + r.stderr
    exr = native.get().read_exr(str(out_dir / "sppm_0001.exr"))
    labels = {n: label for n, _, label in native.get().passes()}
    for name in ("error", "radius", "photon_count"):
        img = exr[f"ViewLayer.{labels[name]}"]
        assert np.isfinite(img).all() and img.max() > 0, name
    assert exr["ViewLayer.Combined"].mean() > 0.01


def test_animation_frames(empty_scene, out_dir):
    small_scene(empty_scene)
    empty_scene.frame_start, empty_scene.frame_end = 1, 2
    blend = str(out_dir / "anim.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend, copy=True)
    r = batch_render(blend, str(out_dir / "anim_"), "-a")
    assert r.returncode == 0, r.stderr
    assert os.path.exists(out_dir / "anim_0001.exr") and os.path.exists(out_dir / "anim_0002.exr")


def test_compositor_render_layers_node_shows_the_passes(empty_scene):
    small_scene(empty_scene)
    empty_scene.use_nodes = True
    node = empty_scene.node_tree.nodes.new("CompositorNodeRLayers")
    vl = empty_scene.view_layers[0]
    for method in ("pt", "gpt"):  # every toggle is on: each method shows the passes it writes
        empty_scene.gradphoton.method = method
        vl.update_render_passes()
        outputs = {o.name for o in node.outputs if o.enabled}
        produced = {("Image" if bl == "Combined" else bl) for _, bl, _, _, _ in session.enabled_passes(vl, method)}
        assert produced <= outputs, outputs
        assert ("Gradient X" in outputs) == (method == "gpt"), outputs


def test_pass_names_are_the_cores():
    """The addon registers exactly the core's passes (film.h pass::kAll), and its view-layer
    toggles are those passes but Combined."""
    core = native.get().passes()
    assert [(n, c) for n, _, c, _, _ in session.blender_passes()] == [(n, 4 if n == "combined" else c)
                                                                       for n, c, _ in core if n != "alpha"]
    toggles = {p for p in bpy.types.ViewLayer.bl_rna.properties["gradphoton"].fixed_type.properties.keys()
               if p.startswith("use_pass_")}
    assert toggles == {"use_pass_" + n for n, _, _ in core if n not in ("combined", "alpha")}
    from gradphoton import properties
    assert [i[0] for i in properties.method_items(None, None)] == list(native.get().methods())


def test_unsupported_node_one_warning_and_still_renders(empty_scene, out_dir):
    small_scene(empty_scene)
    m = bpy.data.materials["Floor"]
    nt = m.node_tree
    wire = nt.nodes.new("ShaderNodeWireframe")  # not evaluated by the core
    nt.links.new(wire.outputs["Fac"], nt.nodes["Diffuse BSDF"].inputs["Color"])
    toon = bpy.data.materials.new("Toon")
    toon.use_nodes = True
    tn = toon.node_tree
    t = tn.nodes.new("ShaderNodeBsdfToon")
    tn.links.new(t.outputs[0], tn.nodes["Material Output"].inputs["Surface"])
    bpy.data.objects["Suzanne"].data.materials.append(toon)
    blend = str(out_dir / "warn.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend, copy=True)
    r = batch_render(blend, str(out_dir / "warn_"), "-f", "1")
    assert r.returncode == 0, r.stderr
    lines = [l for l in (r.stdout + r.stderr).splitlines() if "gradphoton approximated" in l]
    assert len(lines) == 1, lines
    assert "Wireframe" in lines[0]
    assert "Toon" in lines[0]
    assert native.get().read_exr(str(out_dir / "warn_0001.exr"))["ViewLayer.Combined"].mean() > 0.01


class _CancelAfter(bpy.types.RenderEngine):
    """The engine with test_break() firing after a delay (Esc pressed mid-render). Not a
    subclass of GradphotonRenderEngine: unregistering a subclass of a registered engine leaves
    Blender without the Python class of GRADPHOTON ("unable to get Python class for RNA struct
    'GRADPHOTON'"), and every later render in the session fails."""
    bl_idname = "GRADPHOTON_CANCEL_TEST"
    bl_label = "gradphoton (cancel test)"
    bl_use_postprocess = True
    update_render_passes = GradphotonRenderEngine.update_render_passes
    delay = 0.6
    record = {}

    def render(self, depsgraph):
        start, fired = time.perf_counter(), []

        def test_break():
            if time.perf_counter() - start >= self.delay:
                fired.append(time.perf_counter())
                return True
            return self.test_break()

        self.session = session.RenderSession(self, test_break=test_break)
        self.session.render(depsgraph)
        type(self).record.update(latency=time.perf_counter() - fired[0] if fired else None,
                                 passes=self.session.session.stats["passes"])


def test_cancel_returns_fast_and_keeps_the_image(empty_scene, out_dir):
    bpy.utils.register_class(_CancelAfter)
    try:
        small_scene(empty_scene)
        empty_scene.render.engine = _CancelAfter.bl_idname
        empty_scene.render.resolution_x, empty_scene.render.resolution_y = 1920, 1080
        empty_scene.gradphoton.stop_rule = 'TIME'
        empty_scene.gradphoton.time_limit = 60.0
        t0 = time.perf_counter()
        bpy.ops.render.render()
        total = time.perf_counter() - t0
        latency = _CancelAfter.record["latency"]
        print(f"CANCEL latency {latency:.3f} s after Esc, render returned after {total:.2f} s, "
              f"{_CancelAfter.record['passes']} passes")
        assert latency is not None and latency < 0.5
        path = str(out_dir / "cancelled.exr")
        empty_scene.render.image_settings.file_format = 'OPEN_EXR'
        bpy.data.images["Render Result"].save_render(path)
        img = native.get().read_exr(path)["combined"]
        assert img.mean() > 0.01  # the image so far is kept
    finally:
        bpy.utils.unregister_class(_CancelAfter)


def test_every_core_method_has_a_label():
    """The method menu reads the core's list and each method's own label and tooltip."""
    from gradphoton import properties
    items = properties.method_items(None, bpy.context)
    assert [i[0] for i in items] == list(native.get().methods())
    for name, label, tooltip, _ in items:
        assert label and label != name and tooltip and tooltip != name, (name, label, tooltip)


def test_render_border_crops_the_same_pixels(empty_scene, out_dir):
    """A border render (crop on) returns exactly the border's pixels of the full render: same
    seed, and every pixel owns its random stream, so the values match bit for bit."""
    small_scene(empty_scene)
    r = empty_scene.render
    r.resolution_x, r.resolution_y = 40, 30
    empty_scene.render.image_settings.file_format = 'OPEN_EXR'

    def render_to(path):
        bpy.ops.render.render()
        bpy.data.images["Render Result"].save_render(path)
        return native.get().read_exr(path)["combined"][..., :3]

    full = render_to(str(out_dir / "full.exr"))
    r.use_border, r.use_crop_to_border = True, True
    r.border_min_x, r.border_max_x, r.border_min_y, r.border_max_y = 0.25, 0.75, 0.2, 0.6
    crop = render_to(str(out_dir / "crop.exr"))
    x0, x1 = int(0.25 * 40), int(0.75 * 40)
    y0, y1 = int(0.2 * 30), int(0.6 * 30)  # from the bottom in Blender; EXR rows run from the top
    assert crop.shape == (y1 - y0, x1 - x0, 3)
    np.testing.assert_array_equal(crop, full[30 - y1:30 - y0, x0:x1])


def test_spectral_mode_reaches_the_core(empty_scene):
    """The render panel's spectral mode is the core's `spectral` parameter: forcing it turns
    path tracing spectral (the session then runs spt-hero, which the core says by its name)."""
    from gradphoton import session as sess
    small_scene(empty_scene)
    empty_scene.gradphoton.spectral_mode = 'spectral'
    params = sess.params_of(empty_scene.gradphoton)
    assert params["spectral"] == "spectral"
    N = native.get()
    scene = N.load_scene(os.path.join(ROOT, "scenes", "cornell-box.json"))
    scene.width = scene.height = 8
    forced = N.Session(scene, "pt", params)
    assert "spectral" not in forced.unused_params and forced.method == "spt-hero"
    assert N.Session(scene, "pt", dict(params, spectral="auto")).method == "pt"  # no dispersion
    with pytest.raises(ValueError, match="spectral"):
        N.Session(scene, "spt", dict(params, spectral="rgb"))


def test_saved_exr_carries_the_run_record_and_merges(empty_scene, out_dir):
    """Blender's saved EXR holds the gradphoton.* run record (RenderResult stamp fields), so
    still renders of two seeds merge with `gradphoton merge` (scripts/slurm/submit_blender.sh)."""
    small_scene(empty_scene)
    blend = str(out_dir / "seeds.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend, copy=True)
    for seed in (1, 2):
        r = batch_render(blend, str(out_dir / f"seed{seed}_"), "--python-expr",
                         f"import bpy; bpy.context.scene.gradphoton.seed = {seed}", "-f", "1")
        assert r.returncode == 0, r.stdout + r.stderr
    meta = native.get().read_exr_metadata(str(out_dir / "seed2_0001.exr"))
    assert meta["gradphoton.method"] == "pt" and meta["gradphoton.seed"] == "2", meta
    assert meta["gradphoton.size"] == "32x24" and meta["gradphoton.passes"] == "2"
    merged = str(out_dir / "merged.exr")
    m = subprocess.run([os.path.join(ROOT, "build", "gradphoton"), "merge", str(out_dir / "seed1_0001.exr"),
                        str(out_dir / "seed2_0001.exr"), "-o", merged], capture_output=True, text=True, timeout=120)
    assert m.returncode == 0, m.stderr
    images = [native.get().read_exr(str(out_dir / f"seed{s}_0001.exr"))["ViewLayer.Combined"] for s in (1, 2)]
    np.testing.assert_allclose(native.get().read_exr(merged)["ViewLayer.Combined"], (images[0] + images[1]) / 2,
                               rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("method", ["pt", "sppm", "gpt"])
def test_albedo_normal_and_depth_passes_for_every_method(empty_scene, out_dir, method):
    """Cycles' Denoising Albedo, Normal and Depth passes, whatever the method: at the image
    centre the Cornell room's back wall (y = 1, seen from y = -3.9: depth 4.9, normal -y, albedo
    0.73); the hidden area light above adds nothing to them."""
    import scenes
    scenes.cornell_lit(empty_scene, "area")
    empty_scene.render.resolution_x = empty_scene.render.resolution_y = 24
    g = empty_scene.gradphoton
    g.method, g.stop_rule, g.passes = method, 'PASSES', 2
    layer = empty_scene.view_layers[0]
    for name in ("albedo", "normal", "depth"):
        setattr(layer.gradphoton, "use_pass_" + name, True)
    empty_scene.render.image_settings.file_format = 'OPEN_EXR_MULTILAYER'
    empty_scene.render.filepath = str(out_dir / f"aov_{method}.exr")
    bpy.ops.render.render(write_still=True)
    d = native.get().read_exr(empty_scene.render.filepath)
    c = slice(10, 14)  # the central 4 x 4 pixels
    assert d["ViewLayer.Depth"][c, c].mean() == pytest.approx(4.9, abs=0.02)
    assert d["ViewLayer.Normal"][c, c].reshape(-1, 3).mean(0) == pytest.approx([0, -1, 0], abs=1e-3)
    assert d["ViewLayer.Denoising Albedo"][c, c].reshape(-1, 3).mean(0) == pytest.approx([0.73] * 3, abs=1e-3)
