"""Run records in EXR headers and `gradphoton merge` (docs/distributed.md): work weights,
gradient methods reconstructed once from merged primal and gradients, photon methods' note, and
clear errors naming the file for runs that cannot be merged."""
import pathlib
import re
import subprocess

import numpy as np
import pytest

from gradphoton import _native

ROOT = pathlib.Path(__file__).resolve().parents[2]
CLI = ROOT / "build" / "gradphoton"
CORNELL = ROOT / "scenes" / "cornell-box.json"
GLASS = ROOT / "scenes" / "cornell-glass.json"
SIZE = ["--width", "32", "--height", "32"]


def run(*args, ok=True):
    p = subprocess.run([str(CLI), *map(str, args)], capture_output=True, text=True, timeout=300)
    if ok:
        assert p.returncode == 0, p.stderr
    return p


def render(out, *args, scene=CORNELL):
    run("render", scene, *SIZE, "-o", out, *args)
    return out


def relmse(a, b):
    return float(re.search(r"relMSE\s+(\S+)", run("diff", a, b).stdout).group(1))


def test_every_render_records_its_run(tmp_path):
    exr = render(tmp_path / "a.exr", "--passes", 3, "--seed", 7, "--method", "sppm", "--photons", 5000,
                 "--checkpoints", "0")
    for path in (exr, tmp_path / "a.0s.exr"):
        meta = _native.read_exr_metadata(str(path))
        assert meta["gradphoton.method"] == "sppm" and meta["gradphoton.seed"] == "7", meta
        assert meta["gradphoton.size"] == "32x32" and meta["gradphoton.version"]
        assert int(meta["gradphoton.paths"]) > 0 and float(meta["gradphoton.seconds"]) >= 0
        assert '"photons":5000' in meta["gradphoton.params"] and "seed" not in meta["gradphoton.params"]
        assert len(meta["gradphoton.scene_hash"]) == 16
    assert _native.read_exr_metadata(str(exr))["gradphoton.passes"] == "3"
    # Python sessions record theirs too, with the same scene fingerprint as the CLI.
    s = _native.Session(_native.load_scene(str(CORNELL)), "pt", {"seed": 3})
    s.iterate()
    s.write_exr(str(tmp_path / "py.exr"))
    meta = _native.read_exr_metadata(str(tmp_path / "py.exr"))
    assert meta["gradphoton.seed"] == "3" and meta["gradphoton.passes"] == "1"
    cli = _native.read_exr_metadata(str(render(tmp_path / "c.exr", "--passes", 1)))
    assert meta["gradphoton.scene_hash"] == cli["gradphoton.scene_hash"]


def test_runs_are_weighted_by_their_work(tmp_path):
    """A 1-pass and a 15-pass run: the merge must be as good as 16 passes, i.e. a little better
    than the 15-pass run alone. Equal weights would make it about 4x worse than that run."""
    short = render(tmp_path / "short.exr", "--passes", 1, "--seed", 1)
    long = render(tmp_path / "long.exr", "--passes", 15, "--seed", 2)
    ref = render(tmp_path / "ref.exr", "--passes", 1024, "--seed", 99)
    merged = tmp_path / "merged.exr"
    out = run("merge", short, long, "-o", merged).stdout
    assert re.search(r"weight\s+0\.0625\s+\S*short\.exr", out), out
    a, b, m = (_native.read_exr(str(p))["combined"] for p in (short, long, merged))
    np.testing.assert_allclose(m, (a + 15 * b) / 16, rtol=1e-5, atol=1e-6)
    # Expected about 15/16 plus the reference's noise: measured 1.01; equal weights (the mean
    # of the two images) measured 5.7. The bound leaves 50 % headroom.
    ratio = relmse(merged, ref) / relmse(long, ref)
    assert ratio < 1.5, ratio
    meta = _native.read_exr_metadata(str(merged))
    assert meta["gradphoton.seed"] == "1,2" and meta["gradphoton.runs"] == "2" and meta["gradphoton.passes"] == "16"


def test_gradient_runs_are_reconstructed_once_from_merged_gradients(tmp_path):
    """L1 is not linear: the merged combined is the L1 reconstruction of the merged primal and
    gradients (plus what each run added after its own solve), not the mean of the runs'
    reconstructions."""
    runs = [render(tmp_path / f"g{s}.exr", "--method", "gpt", "--recon", "l1", "--lambda", 0.3, "--passes", 2,
                   "--seed", s) for s in (1, 2, 3)]
    merged = tmp_path / "merged.exr"
    run("merge", *runs, "-o", merged)
    m = _native.read_exr(str(merged))
    rec = _native.reconstruct(m["primal"], m["gradient_x"], m["gradient_y"], 0.3, "l1")
    after_solve = np.mean([f["combined"] - _native.reconstruct(f["primal"], f["gradient_x"], f["gradient_y"], 0.3, "l1")
                           for f in (_native.read_exr(str(r)) for r in runs)], axis=0)
    np.testing.assert_allclose(m["combined"], rec + after_solve, rtol=1e-3, atol=1e-4)
    mean_of_recs = np.mean([_native.read_exr(str(r))["combined"] for r in runs], axis=0)
    assert np.abs(m["combined"] - mean_of_recs).mean() > 10 * np.abs(m["combined"] - rec - after_solve).mean()


@pytest.mark.parametrize("method", [["gpt", "--recon", "l1"], ["gdmlt"], ["gpm", "--photons", 5000]])
def test_a_merge_of_one_gradient_run_is_that_run(tmp_path, method):
    """What the methods add after their solve (directly seen emission kept out of the gradients;
    GPM's emission from further camera paths, which its primal leaves out) survives the merge.
    Seen failing when the merge took the reconstruction of the merged passes alone: largest
    differences gpt (L1) 0.05, gdmlt 0.18, gpm 15 (the light's pixels)."""
    one = render(tmp_path / "one.exr", "--method", *method, "--passes", 2, "--seed", 4, scene=GLASS)
    merged = tmp_path / "merged.exr"
    run("merge", one, "-o", merged)
    a, b = _native.read_exr(str(merged))["combined"], _native.read_exr(str(one))["combined"]
    np.testing.assert_allclose(a, b, rtol=1e-4, atol=1e-5)


def test_photon_merge_keeps_one_runs_bias_and_says_so(tmp_path):
    runs = [render(tmp_path / f"p{s}.exr", "--method", "sppm", "--photons", 5000, "--passes", 3, "--seed", s,
                   scene=GLASS) for s in (1, 2)]
    out = run("merge", *runs, "-o", tmp_path / "m.exr").stdout
    assert "bias of one run" in out
    m = _native.read_exr(str(tmp_path / "m.exr"))
    assert np.isfinite(m["error"]).all() and m["error"].max() > 0
    assert "BIAS OF K PASSES" in run("merge", "--help").stdout


@pytest.mark.parametrize("case", ["method", "size", "params", "scene", "seed", "metadata", "unreadable"])
def test_runs_that_cannot_be_merged_are_refused_naming_the_file(tmp_path, case):
    good = render(tmp_path / "good.exr", "--passes", 1, "--seed", 1)
    bad = tmp_path / "bad.exr"
    if case == "method":
        render(bad, "--passes", 1, "--seed", 2, "--method", "gpt")
    elif case == "size":
        run("render", CORNELL, "--width", 16, "--height", 16, "--passes", 1, "--seed", 2, "-o", bad)
    elif case == "params":
        render(bad, "--passes", 1, "--seed", 2, "--max-depth", 3)
    elif case == "scene":
        render(bad, "--passes", 1, "--seed", 2, scene=GLASS)
    elif case == "seed":
        render(bad, "--passes", 2, "--seed", 1)
    elif case == "metadata":
        _native.write_exr(str(bad), _native.read_exr(str(good)))
    else:
        bad.write_text("not an EXR")
    p = run("merge", good, bad, "-o", tmp_path / "m.exr", ok=False)
    assert p.returncode == 1 and "Traceback" not in p.stderr and "terminate" not in p.stderr, p.stderr
    assert str(bad) in p.stderr, p.stderr
    expected = {"method": "method 'gpt'", "size": "16x16", "params": "max_depth", "scene": "another scene",
                "seed": "seed 1 was already used", "metadata": "no gradphoton run metadata",
                "unreadable": "cannot read EXR"}[case]
    assert expected in p.stderr, p.stderr
    assert not (tmp_path / "m.exr").exists()
