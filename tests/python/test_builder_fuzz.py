"""Property test of the Python entry point that takes user arrays (SceneBuilder.add_mesh and
finalize, what the Blender addon calls): random shapes, dtypes, layouts, NaN/Inf, out-of-range
indices and material slots, bad matrices. Every input either builds a scene that renders a finite
image, or fails with TypeError/ValueError whose message names the object or the argument at
fault (as "object '<name>': ..."); never a crash, another exception or a silent NaN (docs/reliability.md).

Seeded (hypothesis' derandomize) so CI sees the same examples every run; GRADPHOTON_FUZZ_EXAMPLES
raises the count for a longer search."""
import json
import os

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from gradphoton import _native  # noqa: E402

DESCRIPTION = json.dumps({
    "camera": {"position": [0, -4, 1], "look_at": [0, 0, 0], "fov": 40, "width": 8, "height": 6},
    "materials": {"white": {"type": "diffuse", "color": 0.8},
                  "lamp": {"type": "emission", "emission": 1, "strength": 5}},
    "lights": [{"type": "point", "position": [0, 0, 3], "power": 50}],
})
SPECIAL = [np.nan, np.inf, -np.inf, 0.0, -0.0, 1e30, -1e30, 1e-30, 1.0, -1.0, 0.5, 3e38]
EXAMPLES = int(os.environ.get("GRADPHOTON_FUZZ_EXAMPLES", "150"))


def floats(draw, shape, lo=-2.0, hi=2.0):
    size = int(np.prod(shape))
    return np.array(draw(st.lists(st.floats(lo, hi, width=32), min_size=size, max_size=size)),
                    np.float32).reshape(shape)


@st.composite
def valid_meshes(draw):
    """A mesh add_mesh accepts: float32 positions (N, 3), uint32 indices (M, 3) and, some of the
    time, material ids, normals, uvs and instance matrices."""
    nv, nt = draw(st.integers(3, 8)), draw(st.integers(1, 6))
    mesh = {
        "name": draw(st.sampled_from(["quad", "Würfel ✓", "obj.001", ""])),
        "positions": floats(draw, (nv, 3)),
        "indices": np.array(draw(st.lists(st.integers(0, nv - 1), min_size=3 * nt, max_size=3 * nt)),
                            np.uint32).reshape(nt, 3),
        "materials": draw(st.sampled_from([["white"], ["white", "lamp"]])),
    }
    if draw(st.booleans()):
        mesh["material_ids"] = np.array(draw(st.lists(st.integers(0, len(mesh["materials"]) - 1),
                                                      min_size=nt, max_size=nt)), np.uint32)
    if draw(st.booleans()):
        mesh["normals"] = floats(draw, (nv, 3), -1, 1)
    if draw(st.booleans()):
        mesh["uvs"] = floats(draw, (nv, 2), 0, 1)
    if draw(st.booleans()):
        k = draw(st.integers(1, 3))
        m = np.tile(np.eye(4, dtype=np.float32), (k, 1, 1))
        m[:, :3, 3] = floats(draw, (k, 3))
        mesh["matrices"] = m
        if draw(st.booleans()):
            mesh["instance_names"] = [f"inst{i}" for i in range(k)]
    return mesh


# ---- Mutations: each breaks one thing about a valid mesh ----
ARRAY_KEYS = ["positions", "indices", "material_ids", "normals", "uvs", "matrices"]


def mutate(draw, mesh):
    kind = draw(st.sampled_from(["dtype", "shape", "layout", "special", "index", "slot", "materials", "matrix",
                                 "names", "empty"]))
    present = [k for k in ARRAY_KEYS if k in mesh]
    key = draw(st.sampled_from(present))
    a = mesh[key]
    if kind == "dtype":
        mesh[key] = a.astype(draw(st.sampled_from([np.float64, np.float16, np.int32, np.int64, np.uint32,
                                                   np.float32, np.uint64, np.bool_])))
    elif kind == "shape":
        shape = draw(st.sampled_from([(-1,), (1, -1), (-1, 1), (-1, 2), (-1, 4), ()]))
        if shape == ():
            mesh[key] = a.reshape(-1)[:1].reshape(()) if a.size else np.float32(0)
        elif a.size % int(abs(np.prod(shape)) or 1) == 0 and (shape[-1] == -1 or a.size % shape[-1] == 0):
            mesh[key] = a.reshape(shape)
    elif kind == "layout" and a.ndim >= 1 and len(a) > 1:
        mesh[key] = a[::-1]
    elif kind == "special" and a.dtype == np.float32 and a.size:
        flat = a.reshape(-1).copy()
        flat[draw(st.integers(0, flat.size - 1))] = draw(st.sampled_from(SPECIAL))
        mesh[key] = flat.reshape(a.shape)
    elif kind == "index" and mesh["indices"].dtype == np.uint32 and mesh["indices"].size:
        idx = mesh["indices"].reshape(-1).copy()
        idx[draw(st.integers(0, idx.size - 1))] = draw(st.sampled_from([mesh["positions"].size // 3, 2**31, 2**32 - 1]))
        mesh["indices"] = idx.reshape(mesh["indices"].shape)
    elif kind == "slot" and "material_ids" in mesh and mesh["material_ids"].dtype == np.uint32 \
            and mesh["material_ids"].size:
        ids = mesh["material_ids"].copy()
        ids[draw(st.integers(0, ids.size - 1))] = draw(st.sampled_from([len(mesh["materials"]), 2**32 - 1]))
        mesh["material_ids"] = ids
    elif kind == "materials":
        mesh["materials"] = draw(st.sampled_from([[], ["missing"], ["white", "missing"], [""]]))
    elif kind == "matrix" and "matrices" in mesh and mesh["matrices"].dtype == np.float32 \
            and mesh["matrices"].ndim == 3 and len(mesh["matrices"]):
        m = mesh["matrices"].copy()
        m[draw(st.integers(0, len(m) - 1)), draw(st.integers(0, 3)), draw(st.integers(0, 3))] = draw(st.sampled_from(SPECIAL))
        mesh["matrices"] = m if draw(st.booleans()) else m[:0]
    elif kind == "names":
        mesh["instance_names"] = ["x"] * draw(st.integers(0, 4))
    elif kind == "empty":
        mesh[key] = a[:0]


@st.composite
def meshes(draw):
    """A valid mesh with zero, one or two things broken."""
    mesh = draw(valid_meshes())
    for _ in range(draw(st.sampled_from([0, 1, 1, 2]))):
        mutate(draw, mesh)
    return mesh


@settings(max_examples=EXAMPLES, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(meshes())
def test_add_mesh_builds_a_finite_scene_or_names_what_is_wrong(mesh):
    b = _native.SceneBuilder("fuzz")
    b.set_description(DESCRIPTION)
    name = mesh["name"]
    try:
        b.add_mesh(**mesh)
        scene = b.finalize()
    except (TypeError, ValueError) as e:
        message = str(e)
        names = [name] + list(mesh.get("instance_names", []))
        assert any(f"object '{n}'" in message for n in names), f"error does not name the object: {message!r}"
        return
    # Accepted: the scene must render a finite image.
    session = _native.Session(scene, "pt", {"seed": 1, "threads": 1})
    session.iterate()
    image = session.develop()["combined"]
    assert image.shape == (6, 8, 3)
    assert np.isfinite(image).all(), f"non-finite pixels from accepted mesh {name!r}"
