"""Screened Poisson reconstruction from Python (_native.reconstruct) and the CLI (`gradphoton reconstruct`)."""
import pathlib
import re
import subprocess

import numpy as np
import pytest

from gradphoton import _native

ROOT = pathlib.Path(__file__).resolve().parents[2]
CLI = ROOT / "build" / "gradphoton"


def image(h=24, w=31, c=3, seed=0):
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:h, 0:w]
    base = 1 + 0.5 * np.sin(0.3 * x)[..., None] * np.cos(0.2 * y)[..., None] + (x > w // 2)[..., None]
    return (base + 0.1 * rng.random((h, w, c))).astype(np.float32)


def gradients(img):
    gx = np.zeros_like(img)
    gy = np.zeros_like(img)
    gx[:, :-1] = img[:, 1:] - img[:, :-1]
    gy[:-1, :] = img[1:, :] - img[:-1, :]
    return gx, gy


@pytest.mark.parametrize("method", ["l2", "l1"])
def test_exact_gradients_give_back_the_image(method):
    img = image()
    gx, gy = gradients(img)
    out = _native.reconstruct(img, gx, gy, lam=0.2, method=method)
    assert out.shape == img.shape and out.dtype == np.float32
    np.testing.assert_allclose(out, img, atol=1e-4)


def test_l1_resists_an_outlier_gradient_that_l2_spreads():
    img = image(c=1)
    gx, gy = gradients(img)
    gx[12, 15, 0] += 20
    err2 = np.abs(_native.reconstruct(img, gx, gy, method="l2") - img).max()
    err1 = np.abs(_native.reconstruct(img, gx, gy, method="l1") - img).max()
    assert err2 > 1 and err1 < 0.05 * err2


def test_bad_arguments_are_clear_errors():
    img = image()
    gx, gy = gradients(img)
    with pytest.raises(TypeError, match="float32"):
        _native.reconstruct(img.astype(np.float64), gx, gy)
    with pytest.raises(ValueError, match="same shape"):
        _native.reconstruct(img, gx[:, :-1], gy)
    with pytest.raises(ValueError, match="l1"):
        _native.reconstruct(img, gx, gy, method="l3")


def test_gradient_passes_are_registered():
    names = [p[0] for p in _native.passes()]
    assert {"combined", "primal", "gradient_x", "gradient_y"} <= set(names)


def test_cli_reconstruct_from_one_or_two_exrs(tmp_path):
    img = image(h=20, w=27)
    gx, gy = gradients(img)
    noisy = img + np.float32(0.3)  # a primal off by a constant: exact gradients keep the offset
    _native.write_exr(str(tmp_path / "primal.exr"), {"primal": noisy})
    _native.write_exr(str(tmp_path / "grad.exr"), {"gradient_x": gx, "gradient_y": gy})
    _native.write_exr(str(tmp_path / "all.exr"), {"primal": noisy, "gradient_x": gx, "gradient_y": gy})
    ref = _native.reconstruct(noisy, gx, gy, lam=0.5, method="l2")
    for files in [["primal.exr", "grad.exr"], ["all.exr"]]:
        for flag in ["--l2", "--l1"]:
            out = tmp_path / "out.exr"
            p = subprocess.run([str(CLI), "reconstruct", *[str(tmp_path / f) for f in files], flag,
                                "--lambda", "0.5", "-o", str(out)], capture_output=True, text=True)
            assert p.returncode == 0, p.stderr
            assert re.search(r"reconstruction L[12] lambda 0.5", p.stdout)
            got = _native.read_exr(str(out))
            assert set(got) >= {"combined", "primal", "gradient_x", "gradient_y"}
            if flag == "--l2":
                np.testing.assert_allclose(got["combined"], ref, rtol=1e-5, atol=1e-5)
            # Consistent data: both norms return the offset primal.
            np.testing.assert_allclose(got["combined"], noisy, atol=1e-4)
    p = subprocess.run([str(CLI), "reconstruct", str(tmp_path / "primal.exr"), "-o", str(tmp_path / "x.exr")],
                       capture_output=True, text=True)
    assert p.returncode != 0 and "gradient_x" in p.stderr


def test_gpt_session_and_cli_flags(tmp_path):
    scene = _native.load_scene(str(ROOT / "scenes" / "cornell-box.json"))
    scene.width, scene.height = 24, 20
    session = _native.Session(scene, "gpt", {"seed": 2, "recon": "l1", "lambda": 0.3})
    session.run(passes=2)
    passes = session.develop()
    # The method's passes and the auxiliary ones every session adds (integrators/aov.h).
    assert set(passes) == {"combined", "primal", "gradient_x", "gradient_y", "albedo", "normal", "depth"}
    assert all(np.isfinite(a).all() and a.shape == (20, 24, 1 if k == "depth" else 3) for k, a in passes.items())
    assert passes["depth"].min() > 0  # run() made auxiliary passes too
    assert any(k.startswith("shift failed: ") for k in session.stats)
    out = tmp_path / "gpt.exr"
    p = subprocess.run([str(CLI), "render", str(ROOT / "scenes" / "cornell-box.json"), "--method", "gpt",
                        "--recon", "l1", "--lambda", "0.5", "--passes", "2", "--width", "16", "--height", "16",
                        "-o", str(out)], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    assert "warning" not in p.stderr  # recon and lambda are read by gpt
    # The CLI runs the same render session: the auxiliary passes too.
    assert set(_native.read_exr(str(out))) == set(passes)
    p = subprocess.run([str(CLI), "render", str(ROOT / "scenes" / "cornell-box.json"), "--method", "gpt",
                        "--recon", "l3", "-o", str(out)], capture_output=True, text=True)
    assert p.returncode != 0
