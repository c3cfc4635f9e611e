"""scripts/convergence.py's split reference: relMSE less the reference's own noise estimates the
error against the truth, which a noisy reference hides."""
import importlib.util
import pathlib

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("convergence", ROOT / "scripts" / "convergence.py")
convergence = importlib.util.module_from_spec(spec)
spec.loader.exec_module(convergence)


def test_split_reference_removes_the_reference_noise():
    rng = np.random.default_rng(7)
    shape = (64, 64, 3)
    truth = rng.uniform(0.05, 2.0, shape)
    # Reference halves noisier than the image: the raw relMSE is mostly the reference's.
    a = truth + rng.normal(0, 0.08, shape) * truth
    b = truth + rng.normal(0, 0.08, shape) * truth
    x = truth + rng.normal(0, 0.03, shape) * truth
    split = convergence.SplitReference(a, b)
    raw, excess = split.errors(x)
    true = float(((x - truth) ** 2 / (split.ref ** 2 + 0.001)).mean())
    assert raw > 2.5 * true  # the noisy reference would hide the method's error
    assert abs(excess - true) < 0.1 * true, (raw, excess, true)
    # Identical halves: no noise to remove, both numbers equal.
    same = convergence.SplitReference(truth, truth)
    assert same.errors(x)[0] == same.errors(x)[1]


def test_trimmed_leaves_out_the_few_worst_pixels_only():
    # A caustic's focus: one pixel 10x off holds most of the error; trimming one pixel's share
    # drops exactly its term and keeps every other pixel's, averaged over all pixels.
    rng = np.random.default_rng(11)
    h, w = 40, 50
    truth = rng.uniform(0.05, 2.0, (h, w, 3))
    x = truth + rng.normal(0, 0.03, (h, w, 3)) * truth
    same = convergence.SplitReference(truth, truth)
    x[17, 23] = 10.0 * truth[17, 23]
    full = same.errors(x)[1]
    focus = float(((x[17, 23] - truth[17, 23]) ** 2 / (truth[17, 23] ** 2 + 0.001)).mean()) / (h * w)
    assert focus > 0.9 * full  # the one pixel is nearly all of the error
    assert abs(same.trimmed(x, share=0.5 / (h * w)) - (full - focus)) < 1e-12
    assert same.trimmed(x, share=0.0) == full
