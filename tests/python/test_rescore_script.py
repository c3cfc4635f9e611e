"""scripts/rescore.py: the same snapshots scored against two references can rank two methods
oppositely, when one reference shares one method's bias (docs/gradient.md, "A reference that
shares SPPM's bias")."""
import csv
import pathlib
import subprocess
import sys

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
native = pytest.importorskip("gradphoton._native")


def blur_rows(img):
    """A three-row box blur: what a radius rule wider than a pixel does to a horizontal edge."""
    out = img.copy()
    out[1:-1] = (img[:-2] + img[1:-1] + img[2:]) / 3
    return out


def test_a_reference_sharing_a_methods_blur_ranks_it_first(tmp_path):
    rng = np.random.default_rng(3)
    truth = np.full((32, 32, 3), 0.05, np.float32)
    truth[:, :, :] += (np.arange(32) % 8 < 4)[:, None, None] * 0.9  # horizontal bands: sharp edges

    def noisy(img, sd):
        return (img * (1 + rng.normal(0, sd, img.shape))).astype(np.float32)

    def write(name, img):
        native.write_exr(str(tmp_path / name), {"combined": img})

    # "blurry" has the blurred reference's bias and little noise, "sharp" no bias and more noise.
    for t in (1, 2):
        write(f"s-blurry.{t}s.exr", noisy(blur_rows(truth), 0.01 / t))
        write(f"s-sharp.{t}s.exr", noisy(truth, 0.1 / t))
    for seed in (3, 4):
        write(f"blurred-{seed}.exr", noisy(blur_rows(truth), 0.01))
        write(f"sharp-{seed}.exr", noisy(truth, 0.05))
    out = tmp_path / "scores.csv"
    subprocess.run([sys.executable, ROOT / "scripts" / "rescore.py", "--snapshots", tmp_path, "--scene", "s",
                    "--scale", "1", "--methods", "blurry", "sharp", "--checkpoints", "1,2",
                    "--reference", "blurred", str(tmp_path / "blurred-[34].exr"),
                    "--reference", "sharp", str(tmp_path / "sharp-[34].exr"), "--csv", out], check=True)
    rows = list(csv.DictReader(open(out)))
    score = {(r["reference"], r["method"], float(r["seconds"])): float(r["relmse_excess"]) for r in rows}
    for t in (1.0, 2.0):
        assert score["blurred", "blurry", t] < score["blurred", "sharp", t]  # the shared bias hides
        assert score["sharp", "sharp", t] < score["sharp", "blurry", t]      # and shows against truth
