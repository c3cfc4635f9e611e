"""The `gradphoton` command end to end: render with checkpoints, diff, info, clear errors."""
import pathlib
import re
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
CLI = ROOT / "build" / "gradphoton"
CORNELL = ROOT / "scenes" / "cornell-box.json"


def run(*args, ok=True):
    p = subprocess.run([str(CLI), *map(str, args)], capture_output=True, text=True, timeout=300)
    if ok:
        assert p.returncode == 0, p.stderr
    return p


def test_render_writes_exr_png_and_checkpoints(tmp_path):
    out = tmp_path / "sub" / "box.exr"
    p = run("render", CORNELL, "--passes", 6, "--width", 48, "--height", 40, "--checkpoints", "0,0.001",
            "-o", out, "--png", tmp_path / "box.png")
    assert out.exists() and (tmp_path / "box.png").exists()
    assert (tmp_path / "sub" / "box.0s.exr").exists() and (tmp_path / "sub" / "box.0.001s.exr").exists()
    assert re.search(r"passes\s+6", p.stdout)
    assert re.search(r"Mrays/s\s+[0-9.]+", p.stdout)


def test_diff_of_an_image_with_itself_is_zero_and_against_noise_is_not(tmp_path):
    a, b = tmp_path / "a.exr", tmp_path / "b.exr"
    run("render", CORNELL, "--passes", 2, "--width", 32, "--height", 32, "--seed", 1, "-o", a)
    run("render", CORNELL, "--passes", 2, "--width", 32, "--height", 32, "--seed", 2, "-o", b)
    same = run("diff", a, a).stdout
    assert float(re.search(r"relMSE\s+(\S+)", same).group(1)) == 0.0
    assert float(re.search(r"mean ratio\s+(\S+)", same).group(1)) == 1.0
    other = run("diff", a, b, "--png", tmp_path / "err.png").stdout
    assert float(re.search(r"relMSE\s+(\S+)", other).group(1)) > 0.0
    assert (tmp_path / "err.png").exists()


def test_info_summarises_the_scene():
    out = run("info", ROOT / "scenes" / "cornell-glass.json").stdout
    assert re.search(r"triangles\s+\d+", out)
    assert "dielectric" in out and "conductor" in out
    assert re.search(r"warnings\s+0", out)


@pytest.mark.parametrize("scene_text, expected", [
    ('{"materials": {"a": {"type": "diffuse"}}, "objects": [{"type": "sphere", "radius": 1, "material": "b"}]}',
     "/objects/0/material"),
    ('{"objects": [{"type": "sphere", "radius": "big", "material": "a"}]', "bad.json"),
])
def test_bad_scenes_give_one_clear_error(tmp_path, scene_text, expected):
    bad = tmp_path / "bad.json"
    bad.write_text(scene_text)
    p = run("render", bad, "-o", tmp_path / "x.exr", ok=False)
    assert p.returncode != 0
    assert p.stderr.startswith("error: ") and expected in p.stderr
    assert "Traceback" not in p.stderr and len(p.stderr.splitlines()) <= 3


def test_unknown_method_and_parameter_are_reported(tmp_path):
    p = run("render", CORNELL, "--method", "nope", "-o", tmp_path / "x.exr", ok=False)
    assert p.returncode != 0 and "unknown method 'nope'" in p.stderr
    p = run("render", CORNELL, "--passes", 1, "--width", 8, "--height", 8, "--param", "max_dpeth=3",
            "-o", tmp_path / "y.exr")
    assert "max_dpeth" in p.stderr


def test_spectral_mode_flag_and_summary(tmp_path):
    # auto: a scene without dispersion stays RGB; --spectral spectral forces spectral; a
    # dispersive scene (prism) turns pt into spt-hero and says so.
    out = tmp_path / "s.exr"
    plain = run("render", CORNELL, "--passes", 1, "--width", 16, "--height", 16, "-o", out).stdout
    assert re.search(r"method\s+pt\n", plain) and not re.search(r"^spectral ", plain, re.M)
    forced = run("render", CORNELL, "--passes", 1, "--width", 16, "--height", 16, "--spectral", "spectral",
                 "-o", out).stdout
    assert re.search(r"method\s+spt-hero", forced) and "forced by --spectral spectral" in forced
    prism = run("render", ROOT / "scenes" / "prism.json", "--passes", 1, "--width", 16, "--height", 12,
                "-o", out).stdout
    assert re.search(r"spectral\s+on: dispersive material", prism)
    rgb = run("render", ROOT / "scenes" / "prism.json", "--passes", 1, "--width", 16, "--height", 12,
              "--spectral", "rgb", "-o", out).stdout
    assert re.search(r"method\s+pt\n", rgb)
    bad = run("render", CORNELL, "--spectral", "maybe", "-o", out, ok=False)
    assert bad.returncode != 0 and "maybe" in bad.stderr


def test_photon_sampler_flag_reports_the_adaptive_statistics(tmp_path):
    door = ROOT / "scenes" / "door-ajar.json"
    p = run("render", door, "--method", "sppm", "--photon-sampler", "adaptive", "--photons", 20000, "--passes", 2,
            "--width", 24, "--height", 18, "-o", tmp_path / "a.exr")
    for name in ("acceptance rate", "mutation size", "V_c", "uniform count", "visible count"):
        assert re.search(name + r"\s+[0-9.e+-]+", p.stdout), name
    bad = run("render", door, "--method", "sppm", "--photon-sampler", "mcmc", "-o", tmp_path / "b.exr", ok=False)
    assert bad.returncode != 0 and "photon_sampler" in bad.stderr


def test_msppm_renders_and_reports_its_statistics(tmp_path):
    p = run("render", ROOT / "scenes" / "cornell-glass.json", "--method", "msppm", "--passes", 3,
            "--width", 24, "--height", 24, "-o", tmp_path / "m.exr")
    assert re.search(r"method\s+msppm", p.stdout)
    for name in ("path tracing share", "measurement points per pixel", "photons found per point"):
        assert re.search(name + r"\s+[0-9.e+-]+", p.stdout), name


@pytest.mark.parametrize("method", ["pt", "sppm", "gdmlt"])
def test_ctrl_c_stops_the_render_and_writes_the_image_so_far(tmp_path, method):
    """SIGINT (Ctrl-C) sets the cancel flag: the render returns, reports it and still writes the
    EXR. No timing assertion (scripts/cancel_latency.py measures that); the 60 s budget must
    not run out, so a method that ignores the flag fails by the timeout."""
    import signal
    import time
    out = tmp_path / "cancelled.exr"
    p = subprocess.Popen([str(CLI), "render", ROOT / "scenes" / "cornell-glass.json", "--method", method,
                          "--time", "60", "--width", "320", "--height", "240", "-o", out],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(1.5)
    p.send_signal(signal.SIGINT)
    stdout, stderr = p.communicate(timeout=30)
    assert p.returncode == 0, stderr
    assert "cancelled  yes" in stdout
    assert out.exists()


def test_pixel_renders_one_pixel_as_the_full_render(tmp_path):
    """--pixel X,Y renders that pixel alone, single-threaded, and prints it: the value of the
    full (multi-threaded) render of the same seed, to the last digit."""
    import numpy as np
    from gradphoton import _native as N
    full = tmp_path / "full.exr"
    args = ("render", CORNELL, "--passes", 3, "--width", 16, "--height", 12, "--seed", 4)
    run(*args, "--threads", 2, "-o", full)
    p = run(*args, "--pixel", "5,7", "-o", tmp_path / "one.exr")
    line = re.search(r"^pixel 5,7 combined (\S+) (\S+) (\S+)$", p.stdout, re.M)
    assert line, p.stdout
    expected = N.read_exr(str(full))["combined"][7, 5]
    np.testing.assert_array_equal(np.float32([float(v) for v in line.groups()]), expected)
    one = N.read_exr(str(tmp_path / "one.exr"))["combined"]
    assert np.count_nonzero(one.sum(axis=2)) == 1  # only that pixel was rendered
    bad = run(*args, "--pixel", "16,0", "-o", tmp_path / "x.exr", ok=False)
    assert bad.returncode == 1 and "--pixel 16,0 is outside the 16x12 image" in bad.stderr
    chains = run(*args, "--method", "gdmlt", "--pixel", "1,1", "-o", tmp_path / "x.exr", ok=False)
    assert chains.returncode == 1 and "does not trace its pixels independently" in chains.stderr
