"""scripts/calibration.py: its coverage with the reference's noise removed recovers the coverage
against the truth, its doc sections leave the hand-written text alone, and Session.error_terms
gives the bound the `error` pass shows."""
import importlib.util
import json
import pathlib

import numpy as np
import pytest

from gradphoton import _native

ROOT = pathlib.Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("calibration", ROOT / "scripts" / "calibration.py")
calibration = importlib.util.module_from_spec(spec)
spec.loader.exec_module(calibration)


def test_coverage_removes_the_reference_noise():
    rng = np.random.default_rng(11)
    shape = (128, 128)
    truth = rng.uniform(0.5, 2.0, shape)
    sd = 0.05 * truth
    bias = np.where(rng.uniform(size=shape) < 0.3, 2 * sd, 0.0)
    L = truth + bias + rng.normal(0, 1, shape) * sd
    c = 0.5
    # A calibrated bound: P(|bias + sd Z| <= bound) = c, from the script's own inverse.
    lo, hi = np.zeros(shape), 10 * sd + np.abs(bias)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        p = calibration.Phi((mid - bias) / sd) - calibration.Phi((-mid - bias) / sd)
        lo, hi = np.where(p < c, mid, lo), np.where(p < c, hi, mid)
    bound = 0.5 * (lo + hi)
    terms = {"bound": bound, "bias": bias}
    # References whose noise is as large as the image's: the observed coverage falls well below c.
    a = truth + rng.normal(0, 1, shape) * sd * np.sqrt(2)
    b = truth + rng.normal(0, 1, shape) * sd * np.sqrt(2)
    observed, predicted, corrected = calibration.coverage(L, terms, 0.5 * (a + b), 0.5 * (a - b), c)
    assert observed < c - 0.07
    assert abs(corrected - c) < 0.015, (observed, predicted, corrected)
    # Exact references: nothing to remove.
    o, p, corr = calibration.coverage(L, terms, truth, np.zeros(shape), c)
    assert abs(p - c) < 1e-6 and corr == pytest.approx(o)


def test_write_section_keeps_what_is_outside_its_markers(tmp_path):
    doc = tmp_path / "doc.md"
    doc.write_text("# Title\nhand-written\n<!-- calibration.py a: begin -->\nold\n<!-- calibration.py a: end -->\n"
                   "more hand-written text\n")
    calibration.write_section(doc, "new table\n", "a")
    assert doc.read_text() == ("# Title\nhand-written\n<!-- calibration.py a: begin -->\nnew table\n"
                               "<!-- calibration.py a: end -->\nmore hand-written text\n")
    calibration.write_section(doc, "b table\n", "b")  # a new section is appended
    assert doc.read_text().endswith("more hand-written text\n<!-- calibration.py b: begin -->\nb table\n"
                                    "<!-- calibration.py b: end -->\n")
    doc.write_text("x\n<!-- calibration.py a: begin -->\nkeep me\n")  # an end marker lost by hand
    with pytest.raises(SystemExit, match="not one begin/end pair"):
        calibration.write_section(doc, "t\n", "a")
    assert doc.read_text() == "x\n<!-- calibration.py a: begin -->\nkeep me\n"


def test_error_terms_give_the_error_pass():
    j = json.loads((ROOT / "scenes" / "cornell-box.json").read_text())
    j["camera"]["width"] = j["camera"]["height"] = 16
    scene = _native.load_scene_json(json.dumps(j), str(ROOT / "scenes"))
    s = _native.Session(scene, "sppm", {"photons": 2000, "seed": 1, "threads": 1})
    s.set_aux_passes(False)
    s.run(passes=8)
    terms = s.error_terms()
    assert set(terms) == {"radiance", "bias", "bias_sd", "noise_sd", "sigma", "bound", "mean_abs", "photon_passes",
                          "radius", "cut", "edge_bias", "edge_bias_sd"}
    error = s.develop()["error"][..., 0]
    lit = terms["radiance"] > 0
    assert lit.mean() > 0.9
    np.testing.assert_allclose(error[lit], (terms["bound"] / terms["radiance"])[lit], rtol=1e-5)
    # B' only widens the noise; a kept boundary bias replaces it by the corrected estimate's.
    plain = lit & (terms["edge_bias"] == 0)
    assert np.all(terms["sigma"][plain] >= terms["noise_sd"][plain])
    assert np.all((terms["cut"] >= 0) & (terms["cut"] <= 1))
    # --target-error's estimate: the pixels' estimated mean |e| / L, averaged (eq. 6.33).
    assert s.estimated_error == pytest.approx(np.mean((terms["mean_abs"] / terms["radiance"])[lit]), rel=1e-9)
    assert np.all(terms["photon_passes"] <= 8)
    with pytest.raises(ValueError, match="has no photon error estimate"):
        _native.Session(scene, "pt", {"threads": 1}).error_terms()
