#!/usr/bin/python3
"""Image means and errors of one method over many seeds: the bias study of docs/gradient.md
("Bias and stuck chains"). A method is unbiased when the mean over seeds of its image mean
agrees with the reference's within the standard error; one seed's mean is mostly noise.

  scripts/seed_study.py --scene cornell-glass --size 48 36 --method gdmlt --passes 64 256 \\
      --seeds 0 32 --params '{"recon": "l2"}' --ref build/references/ref.exr

Prints one line per seed and checkpoint (seed, passes, mean of combined and of primal, relMSE
against --ref, the brightness b and acceptance rate of Metropolis methods), then per checkpoint
the mean over seeds of the combined mean with its standard error.
"""
import argparse
import json
import pathlib
import sys

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "build" / "python"))
from gradphoton import _native as native  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="cornell-glass")
    ap.add_argument("--size", type=int, nargs=2, default=[48, 36], metavar=("W", "H"))
    ap.add_argument("--method", default="gdmlt")
    ap.add_argument("--passes", type=int, nargs="+", default=[64], help="checkpoints, in passes")
    ap.add_argument("--seeds", type=int, nargs=2, default=[0, 8], metavar=("FIRST", "END"))
    ap.add_argument("--params", default="{}", help="method parameters as JSON")
    ap.add_argument("--ref", help="reference EXR of the same size (relMSE of combined against it)")
    opts = ap.parse_args()

    text = json.loads((ROOT / "scenes" / f"{opts.scene}.json").read_text())
    text["camera"]["width"], text["camera"]["height"] = opts.size
    scene = native.load_scene_json(json.dumps(text), str(ROOT / "scenes"))
    ref = native.read_exr(opts.ref)["combined"].astype(np.float64) if opts.ref else None
    means = {c: [] for c in opts.passes}
    for seed in range(*opts.seeds):
        session = native.Session(scene, opts.method, dict(json.loads(opts.params), seed=seed))
        for c in sorted(opts.passes):
            session.run(passes=c)
            film = session.develop()
            img = film["combined"].astype(np.float64)
            primal = film["primal"].mean() if "primal" in film else float("nan")
            rel = float(np.mean((img - ref) ** 2 / (ref ** 2 + 1e-2))) if ref is not None else float("nan")
            st = session.stats
            print(f"{seed} {c} {img.mean():.6g} {primal:.6g} {rel:.6g} {st.get('brightness b', 0):.6g} "
                  f"{st.get('acceptance rate', 0):.4f}", flush=True)
            means[c].append(img.mean())
    for c, m in means.items():
        m = np.array(m)
        print(f"passes {c}: mean of image means {m.mean():.6g} +- {m.std(ddof=1) / np.sqrt(len(m)):.2g} "
              f"(standard error, {len(m)} seeds)" if len(m) > 1 else f"passes {c}: {m.mean():.6g}")


if __name__ == "__main__":
    main()
