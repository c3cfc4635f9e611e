"""SceneBuilder (scenes from numpy arrays, as the Blender addon exports them) and the tables the
module exposes (passes, methods)."""
import json
import pathlib

import numpy as np
import pytest

from gradphoton import _native

ROOT = pathlib.Path(__file__).resolve().parents[2]

DESCRIPTION = {
    "camera": {"position": [0, -4, 1], "look_at": [0, 0, 1], "fov": 40, "width": 32, "height": 24},
    "materials": {"white": {"type": "diffuse", "color": 0.8},
                  "lamp": {"type": "emission", "emission": 1, "strength": 5}},
    "lights": [{"type": "point", "position": [0, 0, 1.5], "power": 50}],
}


def quad(z=0.0, s=1.0):
    p = np.array([[-s, -s, z], [s, -s, z], [s, s, z], [-s, s, z]], np.float32)
    i = np.array([[0, 1, 2], [0, 2, 3]], np.uint32)
    return p, i


def builder():
    b = _native.SceneBuilder("test")
    b.set_description(json.dumps(DESCRIPTION))
    return b


def test_pass_table_comes_from_the_core():
    passes = _native.passes()
    names = [p[0] for p in passes]
    assert names[0] == "combined" == _native.PASS_COMBINED
    assert len(set(names)) == len(names)
    for name, channels, label in passes:
        assert channels in (1, 3) and label


def test_mesh_from_arrays_with_instances_and_materials():
    b = builder()
    p, i = quad()
    m = np.stack([np.eye(4, dtype=np.float32)] * 3)
    m[1, 0, 3] = 3.0           # translated copy
    m[2, 0, 0] = -1.0          # mirrored copy: winding reversed
    b.add_mesh("floor", p, i, ["white", "lamp"], material_ids=np.array([0, 1], np.uint32),
               normals=np.tile(np.array([0, 0, 1], np.float32), (4, 1)), uvs=np.zeros((4, 2), np.float32),
               matrices=m, instance_names=["a", "b", "c"])
    assert b.triangle_count == 6
    scene = b.finalize()
    assert scene.triangle_count == 6
    assert scene.material_names == ["white", "lamp"]
    # one point light + 3 emissive triangles (one per instance)
    assert scene.light_count == 4
    s = _native.Session(scene, "pt", {"seed": 1, "threads": 1})
    s.run(passes=2)
    img = s.develop()["combined"]
    assert img.shape == (24, 32, 3) and np.isfinite(img).all() and img.mean() > 0


def test_builder_matches_the_json_loader():
    """Same quad through JSON and through arrays gives the same image."""
    p, i = quad()
    text = dict(DESCRIPTION)
    text["objects"] = [{"type": "mesh", "name": "floor", "positions": p.tolist(), "indices": i.tolist(),
                        "material": "white", "transform": {"translate": [0, 0, 0.25]}}]
    a = _native.load_scene_json(json.dumps(text))
    b = builder()
    m = np.eye(4, dtype=np.float32)
    m[2, 3] = 0.25
    b.add_mesh("floor", p, i, ["white"], matrices=m)
    bs = b.finalize()
    imgs = []
    for scene in (a, bs):
        s = _native.Session(scene, "pt", {"seed": 5, "threads": 1})
        s.run(passes=2)
        imgs.append(s.develop()["combined"])
    np.testing.assert_allclose(imgs[0], imgs[1], rtol=1e-5, atol=1e-6)


def test_errors_name_the_object_and_dtypes_are_strict():
    b = builder()
    p, i = quad()
    with pytest.raises(TypeError, match="uint32"):
        b.add_mesh("x", p, i.astype(np.int32), ["white"])
    with pytest.raises(TypeError, match="float32"):
        b.add_mesh("x", p.astype(np.float64), i, ["white"])
    bad = i.copy()
    bad[1, 2] = 9
    with pytest.raises(ValueError, match="object 'Suzanne'.*vertex 9"):
        b.add_mesh("Suzanne", p, bad, ["white"])
    with pytest.raises(ValueError, match="object 'Cube'.*material slot 3"):
        b.add_mesh("Cube", p, i, ["white"], material_ids=np.array([0, 3], np.uint32))
    b.add_mesh("Plane", p, i, ["nope"])
    with pytest.raises(ValueError, match="object 'Plane'.*unknown material 'nope'"):
        b.finalize()
    with pytest.raises(ValueError, match="unknown light type"):
        b.set_description(json.dumps({"lights": [{"type": "laser"}]}))


def test_read_exr_round_trip(tmp_path):
    scene = _native.load_scene(str(ROOT / "scenes" / "cornell-box.json"))
    scene.width, scene.height = 8, 6
    s = _native.Session(scene, "pt", {"seed": 1})
    s.run(passes=1)
    path = str(tmp_path / "x.exr")
    s.write_exr(path)
    back = _native.read_exr(path)
    np.testing.assert_array_equal(back["combined"], s.develop()["combined"])


def test_mesh_attributes_from_arrays_and_their_errors():
    """add_mesh's attributes (Color Attribute / Attribute nodes): (name, domain, float32 array),
    the render colour named by default_color; sizes are checked when the scene is finalized,
    naming the object and the attribute."""
    p, i = quad()
    b = builder()
    b.add_mesh("floor", p, i, ["white"], attributes=[
        ("Col", "corner", np.ones((6, 4), np.float32)),
        ("height", "point", np.linspace(0, 1, 4, dtype=np.float32)),
        ("tint", "face", np.zeros((2, 3), np.float32))], default_color="Col")
    assert b.finalize().triangle_count == 2
    b = builder()
    b.add_mesh("floor", p, i, ["white"], attributes=[("Col", "corner", np.ones((5, 4), np.float32))])
    with pytest.raises(_native.SceneError, match="'floor'.*attribute 'Col': 20 values for 6 corner"):
        b.finalize()
    with pytest.raises(ValueError, match="unknown domain 'edge'"):
        builder().add_mesh("floor", p, i, ["white"], attributes=[("x", "edge", np.ones(4, np.float32))])
    with pytest.raises(TypeError, match="float32"):
        builder().add_mesh("floor", p, i, ["white"], attributes=[("x", "point", np.ones(4))])
