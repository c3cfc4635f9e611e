"""Volumes (export/volume.py): a material's and the World's Volume output become media of the
core, with Cycles 3.4's coefficients (kernel/svm/closure.h); a Principled Volume cube renders at
Cycles' mean brightness; a method without media says so, naming itself."""
import math
import os

import bpy
import numpy as np
import pytest

import scenes
from gradphoton import native
from gradphoton.export import export_scene


def export_current():
    return export_scene(bpy.context.evaluated_depsgraph_get())


def volume_material(name, kind, **inputs):
    """A material whose Volume output is one `kind` node (no surface), its inputs set."""
    m, nt, out = scenes._node_material(name)
    v = nt.nodes.new(kind)
    for k, val in inputs.items():
        v.inputs[k].default_value = val
    nt.links.new(v.outputs[0], out.inputs["Volume"])
    return m

def add_cube(scene, name, size, material, location=(0, 0, 0)):
    s = size / 2
    verts = [(x, y, z) for x in (-s, s) for y in (-s, s) for z in (-s, s)]
    faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    ob = scenes.add_mesh_object(scene, name, verts, faces, material)
    ob.data.validate()
    ob.data.update()
    ob.location = location
    return ob


def test_volume_outputs_export_as_media_with_cycles_coefficients(empty_scene):
    scenes.add_camera(empty_scene)
    pv = volume_material("Smoke", "ShaderNodeVolumePrincipled", **{
        "Color": (0.8, 0.5, 0.2, 1), "Density": 2.0, "Anisotropy": 0.3, "Absorption Color": (0.25, 0.0, 1.0, 1),
        "Emission Strength": 1.5, "Emission Color": (1.0, 0.5, 0.0, 1)})
    add_cube(empty_scene, "SmokeCube", 2.0, pv)
    ab = volume_material("Ink", "ShaderNodeVolumeAbsorption", **{"Color": (0.2, 0.6, 1.0, 1), "Density": 0.5})
    add_cube(empty_scene, "InkCube", 1.0, ab, (4, 0, 0))
    # Glass with a scattering interior: the surface stays, the medium is its interior.
    glass = scenes.glass_material("Murky")
    nt = glass.node_tree
    sc = nt.nodes.new("ShaderNodeVolumeScatter")
    sc.inputs["Color"].default_value = (0.9, 0.9, 0.9, 1)
    sc.inputs["Density"].default_value = 3.0
    sc.inputs["Anisotropy"].default_value = -0.2
    nt.links.new(sc.outputs[0], nt.nodes["Material Output"].inputs["Volume"])
    add_cube(empty_scene, "Glass", 1.0, glass, (-4, 0, 0))
    # World fog.
    w = empty_scene.world
    w.use_nodes = True
    fog = w.node_tree.nodes.new("ShaderNodeVolumeScatter")
    fog.inputs["Density"].default_value = 0.01
    w.node_tree.links.new(fog.outputs[0], w.node_tree.nodes["World Output"].inputs["Volume"])

    ex = export_current()
    d = ex.description
    media, mats = d["media"], d["materials"]
    assert mats["Smoke"] == {"type": "volume", "interior": "Smoke"}
    smoke = media["Smoke"]
    c, a, dens = (0.8, 0.5, 0.2), (0.25, 0.0, 1.0), 2.0
    np.testing.assert_allclose(smoke["sigma_s"], [x * dens for x in c], rtol=1e-6)
    np.testing.assert_allclose(smoke["sigma_a"], [(1 - x) * (1 - math.sqrt(y)) * dens for x, y in zip(c, a)], rtol=1e-6)
    np.testing.assert_allclose(smoke["emission"], [1.5, 0.75, 0.0], rtol=1e-6)
    assert abs(smoke["g"] - 0.3) < 1e-6
    np.testing.assert_allclose(media["Ink"]["sigma_a"], [0.8 * 0.5, 0.4 * 0.5, 0.0], rtol=1e-6, atol=1e-7)
    assert media["Ink"]["sigma_s"] == [0.0, 0.0, 0.0]
    assert mats["Murky"]["type"] == "dielectric" and mats["Murky"]["interior"] == "Murky"
    np.testing.assert_allclose(media["Murky"]["sigma_s"], [2.7, 2.7, 2.7], rtol=1e-6)
    assert d["world_medium"] == "__world"
    np.testing.assert_allclose(media["__world"]["sigma_s"], [0.008, 0.008, 0.008], rtol=1e-5)  # Color 0.8 default
    assert not any("volume" in line for line in ex.warnings.lines()), ex.warnings.lines()
    nscene = ex.build(native.get())  # the keys are the core's
    assert nscene is not None


def test_volume_of_zero_density_without_surface_is_a_clear_boundary(empty_scene):
    """Cycles renders a material with a Volume output and no Surface as no surface at all, even
    when the volume adds nothing."""
    scenes.add_camera(empty_scene)
    add_cube(empty_scene, "Empty", 1.0, volume_material("Empty", "ShaderNodeVolumeScatter", Density=0.0))
    d = export_current().description
    assert d["materials"]["Empty"] == {"type": "volume", "interior": "Empty"}
    assert d["media"]["Empty"] == {"sigma_a": [0.0, 0.0, 0.0], "sigma_s": [0.0, 0.0, 0.0]}


def test_blackbody_and_linked_inputs_are_warnings(empty_scene):
    scenes.add_camera(empty_scene)
    pv = volume_material("Fire", "ShaderNodeVolumePrincipled", **{"Blackbody Intensity": 1.0})
    nt = pv.node_tree
    nt.links.new(nt.nodes.new("ShaderNodeValue").outputs[0], nt.nodes["Principled Volume"].inputs["Density"])
    add_cube(empty_scene, "FireCube", 1.0, pv)
    lines = export_current().warnings.lines()
    assert any(line.startswith("volume blackbody emission not rendered: material 'Fire'") for line in lines), lines
    assert any(line.startswith("linked volume input uses its own value: material 'Fire'") for line in lines), lines


def volume_cube_scene(scene):
    """A Principled Volume cube (no surface) on a diffuse floor, a sun and a grey World."""
    scenes.set_world(scene, (0.5, 0.55, 0.6), 0.6)
    scenes.add_plane(scene, "Floor", 20.0, scenes.diffuse_material("Floor", (0.6, 0.6, 0.6)))
    pv = volume_material("Cloud", "ShaderNodeVolumePrincipled", **{
        "Color": (0.9, 0.7, 0.5, 1), "Density": 0.8, "Anisotropy": 0.4, "Absorption Color": (0.3, 0.2, 0.1, 1)})
    # Lifted off the floor: a volume boundary coplanar with a surface is ambiguous (which is
    # crossed first), and renders differently from Cycles (docs/scene-format.md).
    add_cube(scene, "Cloud", 2.0, pv, (0, 0, 1.3))
    sun = scenes.add_light(scene, "Sun", 'SUN', None, 3.0, {"angle": 0.0}, (2, -1, 4))
    scenes.look_at(sun, (0, 0, 0))
    scenes.add_camera(scene, (0, -7, 3), (0, 0, 0.8), lens=40.0)


def test_principled_volume_cube_at_cycles_brightness(empty_scene, out_dir):
    volume_cube_scene(empty_scene)
    # Measured: 1.0000 over the image, 0.9986 over the cube (1024 samples); 1 % is the bound.
    scenes.volume_at_cycles_brightness(empty_scene, out_dir, "principled cube", "cube", (48, 36))  # the cube's own pixels


def test_camera_inside_a_volume_cube_at_cycles_brightness(empty_scene, out_dir):
    """The camera inside a Principled Volume cube (no surface), looking at an emissive panel and a
    floor inside it under a sun: Cycles starts such camera rays in the cube's volume
    (integrator_volume_stack_init at the ray's origin, on the near clip plane); gradphoton does
    too (CameraMedia, paths/medium_stack.h). The image mean within 1 % of Cycles': measured 0.9982,
    1.0019 over the panel's window (256 samples). With camera rays started in the World's medium
    alone (before) the image read 1.7596 of Cycles', 2.3244 over the panel."""
    camera_in_murk(empty_scene, out_dir, "a cube")


def test_camera_inside_a_cube_hidden_from_the_camera_at_cycles_brightness(empty_scene, out_dir):
    """The same cube with Object > Visibility > Camera off: Cycles finds the camera's volumes with
    a ray of camera visibility (integrator_volume_stack_init, PATH_RAY_CAMERA), so the cube is not
    around the camera and its camera rays pass the cube's faces without entering it: no murk on
    them (nor on the rays that leave the cube from inside). gradphoton's CameraMedia traces its
    probes as camera rays too: measured 1.0006 of Cycles, 1.0001 over the panel (256 samples);
    with the cube on the camera's stack (before) 0.5514, 0.4296 over the panel."""
    camera_in_murk(empty_scene, out_dir, "a cube hidden from the camera", hidden=True)


def camera_in_murk(scene, out_dir, what, hidden=False):
    """The camera inside a murk cube before a panel (above): gradphoton's whole image's mean and
    the panel window's within 1 % of Cycles'."""
    scenes.set_world(scene, (0.5, 0.55, 0.6), 0.4)
    scenes.add_plane(scene, "Floor", 20.0, scenes.diffuse_material("Floor", (0.6, 0.6, 0.6)))
    pv = volume_material("Murk", "ShaderNodeVolumePrincipled", **{
        "Color": (0.8, 0.7, 0.5, 1), "Density": 0.35, "Anisotropy": 0.2, "Absorption Color": (0.4, 0.3, 0.2, 1)})
    cube = add_cube(scene, "Murk", 6.0, pv, (0, 0, 2.7))  # z from -0.3 to 5.7: the floor inside, not on a face
    cube.visible_camera = not hidden
    panel = scenes.add_plane(scene, "Panel", 2.0, scenes.emission_material("Panel", 4.0, (1.0, 0.9, 0.7)), (0, 2.0, 1.2))
    panel.rotation_euler = (math.radians(90), 0, 0)  # facing -Y, toward the camera
    sun = scenes.add_light(scene, "Sun", 'SUN', None, 2.0, {"angle": 0.0}, (2, -1, 4))
    scenes.look_at(sun, (0, 0, 0))
    scenes.add_camera(scene, (0, -2.0, 1.4), (0, 2.0, 1.0), lens=30.0)
    # The window: the panel seen through the murk.
    scenes.volume_at_cycles_brightness(scene, out_dir, f"camera inside {what}", "panel", (40, 30))


def test_method_without_media_says_so(empty_scene):
    volume_cube_scene(empty_scene)
    ex = export_current()
    s = native.get().Session(ex.build(native.get()), "gpm", {"seed": 1})
    assert len(s.feature_report) == 1 and "method 'gpm' does not render participating media" in s.feature_report[0]
    assert native.get().Session(ex.build(native.get()), "pt", {"seed": 1}).feature_report == []



def test_media_error_warning_only_for_a_target_error(empty_scene):
    """SPPM renders media but estimates no error there (thesis ch. 6 models the surface disc):
    said to a render whose stop is a Target Error, which then runs to its Time Limit, and not to
    a Time or Samples render (it was one line on every render of such a scene)."""
    from gradphoton import session
    volume_cube_scene(empty_scene)
    empty_scene.render.resolution_x, empty_scene.render.resolution_y = 32, 24
    s = empty_scene.gradphoton
    s.method = "sppm"
    s.sppm.use_auto_photons, s.sppm.photons = False, 2000
    s.stop_rule, s.passes = "PASSES", 2
    bpy.ops.render.render()
    said = [m for _, m in session.REPORTS if "estimates no error" in m]
    assert said == [], session.REPORTS
    s.stop_rule, s.target_error, s.error_time_limit = "ERROR", 1e-4, 0.5
    bpy.ops.render.render()
    said = [m for _, m in session.REPORTS if "estimates no error" in m]
    assert len(said) == 1 and "method 'sppm'" in said[0], session.REPORTS
    assert any("Time Limit reached" in m for _, m in session.REPORTS), session.REPORTS  # ran on, no error break
    assert not any(level == 'ERROR' for level, _ in session.REPORTS), session.REPORTS

# ---- Volume objects: a .vdb file's grids (export/volume_object.py) ----

def write_blob_vdb(path, n=12):
    """A smooth blob of density (0 at the box's faces), its cells filling [-1, 1]^3, and a
    temperature grid, written with the core's companion writer (Blender 3.4 has no pyopenvdb)."""
    i = (np.arange(n) + 0.5) / n * 2 - 1
    z, y, x = np.meshgrid(i, i, i, indexing="ij")
    density = np.clip(1 - (x * x + y * y + z * z), 0, None).astype(np.float32) * 3.0
    m = np.eye(4, dtype=np.float32)
    m[:3, :3] *= 2.0 / n
    m[:3, 3] = -1  # voxel i fills the cell [i, i + 1] (as Cycles reads grids)
    native.get().write_vdb(path, [
        {"name": "density", "values": density, "index_to_object": m},
        {"name": "temperature", "values": (density > 0).astype(np.float32) * 2.0, "index_to_object": m}])
    return path


def add_volume_object(scene, name, path, material=None, location=(0, 0, 0), scale=1.0):
    vol = bpy.data.volumes.new(name)
    vol.filepath = path
    if material is not None:
        vol.materials.append(material)
    ob = bpy.data.objects.new(name, vol)
    scene.collection.objects.link(ob)
    ob.location = location
    ob.scale = (scale, scale, scale)
    return ob


def test_volume_object_exports_a_grid_medium_in_a_box(empty_scene, out_dir):
    scenes.add_camera(empty_scene)
    path = write_blob_vdb(os.path.join(str(out_dir), "blob.vdb"))
    pv = volume_material("Smoke", "ShaderNodeVolumePrincipled", **{
        "Color": (0.8, 0.6, 0.4, 1), "Density": 2.0, "Blackbody Intensity": 0.5, "Temperature": 900.0})
    add_volume_object(empty_scene, "Blob", path, pv, location=(1, 2, 3), scale=0.5)
    ex = export_current()
    d = ex.description
    name = "Blob [Smoke]"
    assert d["materials"][name] == {"type": "volume", "interior": name}
    g = d["media"][name]["grid"]
    assert g["file"] == path and g["density_grid"] == "density" and g["temperature_grid"] == "temperature"
    assert "color_grid" not in g  # the Color Attribute is empty by default
    assert g["density"] == 2.0 and abs(g["blackbody_intensity"] - 0.5) < 1e-6 and g["temperature"] == 900.0
    np.testing.assert_allclose(np.array(g["transform"]["matrix"]).reshape(4, 4)[:3, 3], [1, 2, 3])
    rec = [m for m in ex.meshes if m.name == name][0]
    np.testing.assert_allclose(rec.positions.min(0), [-1, -1, -1], atol=1e-6)
    np.testing.assert_allclose(rec.positions.max(0), [1, 1, 1], atol=1e-6)
    lines = ex.warnings.lines()
    assert not any("volume" in line for line in lines), lines
    assert ex.build(native.get()) is not None
    # A missing file: one warning naming the object and the file, nothing rendered, no traceback.
    add_volume_object(empty_scene, "Gone", os.path.join(str(out_dir), "gone.vdb"))
    lines = export_current().warnings.lines()
    assert any(line.startswith("volume file not found (volume not rendered): Gone") and "gone.vdb" in line
               for line in lines), lines


def test_vdb_volume_object_at_cycles_brightness(empty_scene, out_dir):
    """A VDB blob (Principled Volume over its density grid) on a floor under a sun and a grey
    World: the image mean within 1 % of Cycles'."""
    scene = empty_scene
    path = write_blob_vdb(os.path.join(str(out_dir), "blob.vdb"), 16)
    scenes.set_world(scene, (0.5, 0.55, 0.6), 0.6)
    scenes.add_plane(scene, "Floor", 20.0, scenes.diffuse_material("Floor", (0.6, 0.6, 0.6)))
    pv = volume_material("Cloud", "ShaderNodeVolumePrincipled", **{
        "Color": (0.9, 0.7, 0.5, 1), "Density": 1.5, "Anisotropy": 0.3})
    add_volume_object(scene, "Cloud", path, pv, location=(0, 0, 1.3))
    sun = scenes.add_light(scene, "Sun", 'SUN', None, 3.0, {"angle": 0.0}, (2, -1, 4))
    scenes.look_at(sun, (0, 0, 0))
    scenes.add_camera(scene, (0, -6, 2.5), (0, 0, 1.0), lens=40.0)
    scenes.volume_at_cycles_brightness(scene, out_dir, "vdb object", "blob", (40, 30), volume_step_rate=0.25)


def test_world_fog_under_a_spot_light_at_cycles_brightness(empty_scene, out_dir):
    """The World's Volume output (Volume Scatter fog) lit by a spot light over a floor: a light
    shaft; the image mean within 1 % of Cycles'. pt samples the shaft by equiangular distances
    toward the spot, MIS with free flights (paths/camera_path.h), as Cycles does. Both start the
    camera rays on the camera's near clip plane (Clip Start 0.1 m: Cycles' camera_sample_perspective,
    Camera::clip_start), so the fog in front of it is not there: before gradphoton clipped, Cycles
    was 2.6 % brighter (gradphoton/cycles 0.974 at 2048 spp, exp(0.24 x 0.1) = 1.024 of it).
    FOG_SPP=... sets the samples, FOG_VOLUME_BOUNCES / FOG_BOUNCES the bounces, FOG_LIGHT=POINT
    a point light, FOG_SAMPLING the World's Volume > Sampling for Cycles (EQUIANGULAR, Blender's
    default for a World; DISTANCE; MULTIPLE_IMPORTANCE)."""
    scene = empty_scene
    if os.environ.get("FOG_FLOOR", "1") != "0":
        scenes.add_plane(scene, "Floor", 12.0, scenes.diffuse_material("Floor", (0.6, 0.6, 0.6)))
    w = scene.world
    w.use_nodes = True
    fog = w.node_tree.nodes.new("ShaderNodeVolumeScatter")
    fog.inputs["Density"].default_value = float(os.environ.get("FOG_DENSITY", 0.3))
    fog.inputs["Anisotropy"].default_value = 0.3
    w.node_tree.links.new(fog.outputs[0], w.node_tree.nodes["World Output"].inputs["Volume"])
    w.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    kind = os.environ.get("FOG_LIGHT", "SPOT")
    extra = {"shadow_soft_size": 0.0}
    if kind == "SPOT":
        extra.update({"spot_size": math.radians(40), "spot_blend": 0.2})
    spot = scenes.add_light(scene, "Spot", kind, None, 800.0, extra, (1, 0, 4))
    scenes.look_at(spot, (0, 0, 0))
    scenes.add_camera(scene, (0, -7, 2), (0, 0, 1.2), lens=35.0)
    scene.render.resolution_x, scene.render.resolution_y = 40, 30
    samples, bounces = int(os.environ.get('FOG_SPP', 1024)), int(os.environ.get('FOG_BOUNCES', 8))
    scenes.configure_cycles(scene, samples, bounces)
    # Volume bounces 0 (Blender's default: single scattering in the fog, the floor's light through
    # it). Measured 0.9975 (512 spp), 1.0000 (2048 spp). With FOG_VOLUME_BOUNCES=8 gradphoton reads
    # 0.970-0.981 of Cycles' default (Equiangular), where Cycles' own estimators disagree by 3.3 %
    # at 4096 spp (Equiangular 0.02960, Multiple Importance 0.02935, Distance 0.02864; gradphoton
    # 0.0288): docs/blender.md, not resolved, so the test stays at Volume bounces 0.
    scene.cycles.volume_bounces = int(os.environ.get('FOG_VOLUME_BOUNCES', 0))
    w.cycles.volume_sampling = os.environ.get('FOG_SAMPLING', 'EQUIANGULAR')
    a, b = scenes.cycles_then_pt(scene, out_dir, samples, bounces)
    ratio = a.sum() / b.sum()
    print(f"VOLUME world fog, spot (volume bounces {scene.cycles.volume_bounces}, {samples} spp): gradphoton/cycles = {ratio:.4f}; "
          f"gradphoton {a.reshape(-1, 3).mean(0).round(4)}, cycles {b.reshape(-1, 3).mean(0).round(4)}")
    assert abs(ratio - 1) < 0.01, ratio


def test_volume_bounces_are_read_as_cycles_reads_them(empty_scene, out_dir):
    """Light Paths > Volume bounces 0 (Blender's default: single scattering) on the Principled
    Volume cube: exported as the scene's volume_bounces, and the image within 1 % of Cycles' at
    the same setting, which is darker than with 8 volume bounces."""
    volume_cube_scene(empty_scene)
    empty_scene.render.resolution_x, empty_scene.render.resolution_y = 48, 36
    samples, bounces = 256, 8
    scenes.configure_cycles(empty_scene, samples, bounces)
    empty_scene.cycles.volume_bounces = 0
    assert export_current().description["volume_bounces"] == 0
    a, b = scenes.cycles_then_pt(empty_scene, out_dir, samples, bounces)
    empty_scene.cycles.volume_bounces = 8
    assert export_current().description["volume_bounces"] == 8
    more = native.get().read_exr(scenes.render_to_exr(empty_scene, os.path.join(str(out_dir), "g8.exr")))["combined"]
    c = more[..., :3].astype(np.float64)
    ratio, ratio_mid = scenes.window_ratios(a, b)
    gain = scenes.window_ratios(c, a)[1]
    print(f"VOLUME bounces 0: gradphoton/cycles = {ratio:.4f} (cube window {ratio_mid:.4f}); "
          f"8 bounces / 0 over the cube {gain:.4f}")
    assert abs(ratio - 1) < 0.01, ratio
    assert abs(ratio_mid - 1) < 0.01, ratio_mid
    assert gain > 1.03, gain  # the setting is read: multiple scattering adds light


def _fog_single_scattering(cam, target, lens, light, power, sigma_s, g, w, h, clip=0.1, sub=2, n_theta=2000):
    """Image mean of single scattering in unbounded fog (no absorption) under a point light, the
    exact integral per pixel: along a ray o + t d, t = delta + D tan(theta) turns
    dt / r^2 into dtheta / D (the equiangular substitution), integrated by the midpoint rule; a
    Blender camera (sensor 36 mm, horizontal fit), sub x sub rays a pixel, each starting on the
    near clip plane `clip` metres ahead (Clip Start, as Cycles' camera rays: t0 = clip / cos of
    the ray's angle to the view axis; the fog before it is not seen, nor does it dim the rest)."""
    cam, target, light = (np.array(v, dtype=np.float64) for v in (cam, target, light))
    f = target - cam
    f /= np.linalg.norm(f)
    r = np.cross(f, [0.0, 0.0, 1.0])
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    i = (np.arange(w * sub) + 0.5) / (w * sub) - 0.5
    j = 0.5 - (np.arange(h * sub) + 0.5) / (h * sub)
    x, y = np.meshgrid(i * 36.0 / lens, j * 36.0 * h / w / lens)
    d = f + x[..., None] * r + y[..., None] * u
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    t0 = clip / (d @ f)
    oc = light - cam
    delta = d @ oc
    D = np.linalg.norm(oc - delta[..., None] * d, axis=-1)
    ta = np.arctan2(t0 - delta, D)
    k = (np.arange(n_theta) + 0.5) / n_theta
    th = ta[..., None] + k * (np.pi / 2 - ta)[..., None]
    t = delta[..., None] + D[..., None] * np.tan(th)
    rr = D[..., None] / np.cos(th)
    # cos between the ray's direction and the direction to the light: (delta - t) / r.
    c = (delta[..., None] - t) / rr
    den = 1 + g * g - 2 * g * c
    hg = (1 - g * g) / (4 * np.pi * den * np.sqrt(den))
    val = np.exp(-sigma_s * (t - t0[..., None] + rr)) * sigma_s * hg * (power / (4 * np.pi)) / D[..., None]
    return float((val.mean(-1) * (np.pi / 2 - ta)).mean())


def test_world_fog_point_light_shaft_is_the_exact_single_scattering(empty_scene, out_dir):
    """World fog (Volume Scatter) under a point light, nothing else, Volume bounces 0 (Blender's
    default): the image mean is the exact single-scattering integral (computed here per pixel,
    from the near clip plane as Cycles' camera rays start) within 1 %. Equiangular sampling
    (paths/camera_path.h) is what gets it there at 256 passes. FOG_CYCLES=1 prints Cycles beside
    it (1024 samples: 1.0196 of the integral from the camera itself, 1.0002 of this one)."""
    scene = empty_scene
    w = scene.world
    w.use_nodes = True
    fog = w.node_tree.nodes.new("ShaderNodeVolumeScatter")
    fog.inputs["Density"].default_value = 0.3
    fog.inputs["Anisotropy"].default_value = 0.3
    w.node_tree.links.new(fog.outputs[0], w.node_tree.nodes["World Output"].inputs["Volume"])
    w.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    scenes.add_light(scene, "Point", 'POINT', None, 800.0, {"shadow_soft_size": 0.0}, (1, 0, 4))
    scenes.add_camera(scene, (0, -7, 2), (0, 0, 1.2), lens=35.0)
    scene.render.resolution_x, scene.render.resolution_y = 40, 30
    samples = int(os.environ.get('FOG_SPP', 256))
    scenes.configure_cycles(scene, samples, 8)
    scene.cycles.volume_bounces = 0
    exact = _fog_single_scattering((0, -7, 2), (0, 0, 1.2), 35.0, (1, 0, 4), 800.0, 0.3 * 0.8, 0.3, 40, 30)
    scene.render.engine = 'GRADPHOTON'
    g = scene.gradphoton
    g.method, g.stop_rule, g.passes, g.pt.max_bounces = 'pt', 'PASSES', samples, 8
    ours = native.get().read_exr(scenes.render_to_exr(scene, os.path.join(str(out_dir), "g.exr")))["combined"]
    ratio = float(ours[..., :3].astype(np.float64).mean()) / exact
    line = f"VOLUME world fog, point light, single scattering: gradphoton/exact = {ratio:.4f}"
    if os.environ.get("FOG_CYCLES"):
        scene.render.engine = 'CYCLES'
        cycles = native.get().read_exr(scenes.render_to_exr(scene, os.path.join(str(out_dir), "c.exr")))["combined"]
        line += f", cycles/exact = {float(cycles[..., :3].astype(np.float64).mean()) / exact:.4f}"
    print(line)
    assert abs(ratio - 1) < 0.01, ratio


def test_vdb_colour_grid_at_cycles_brightness(empty_scene, out_dir):
    """A VDB blob with a colour grid (red at one side, blue at the other) read through Principled
    Volume's Color Attribute, on a floor under a sun and a grey World: the image mean and the
    blob's window within 1 % of Cycles' (the colour grid multiplies Color: svm_node_principled_volume)."""
    scene = empty_scene
    path = os.path.join(str(out_dir), "blob_colour.vdb")
    write_blob_vdb(path, 16)
    n = 16
    i = (np.arange(n) + 0.5) / n * 2 - 1
    z, y, x = np.meshgrid(i, i, i, indexing="ij")
    density = np.clip(1 - (x * x + y * y + z * z), 0, None).astype(np.float32) * 3.0
    colour = np.stack([0.5 + 0.5 * x, 0.4 + 0 * x, 0.5 - 0.5 * x], axis=-1).astype(np.float32)
    m = np.eye(4, dtype=np.float32)
    m[:3, :3] *= 2.0 / n
    m[:3, 3] = -1
    native.get().write_vdb(path, [{"name": "density", "values": density, "index_to_object": m},
                                  {"name": "color", "values": colour, "index_to_object": m}])
    scenes.set_world(scene, (0.5, 0.55, 0.6), 0.6)
    scenes.add_plane(scene, "Floor", 20.0, scenes.diffuse_material("Floor", (0.6, 0.6, 0.6)))
    pv = volume_material("Cloud", "ShaderNodeVolumePrincipled", **{
        "Color": (1.0, 1.0, 1.0, 1), "Color Attribute": "color", "Density": 1.5, "Anisotropy": 0.3})
    add_volume_object(scene, "Cloud", path, pv, location=(0, 0, 1.3))
    sun = scenes.add_light(scene, "Sun", 'SUN', None, 3.0, {"angle": 0.0}, (2, -1, 4))
    scenes.look_at(sun, (0, 0, 0))
    scenes.add_camera(scene, (0, -6, 2.5), (0, 0, 1.0), lens=40.0)
    scenes.volume_at_cycles_brightness(scene, out_dir, "vdb colour grid", "blob", (40, 30), volume_step_rate=0.25)
