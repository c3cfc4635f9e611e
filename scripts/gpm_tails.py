#!/usr/bin/python3
"""Are a method's worst pixels biased, or only noisy? (issue 34, docs/gradient.md "GPM's worst pixels")

  scripts/gpm_tails.py REF_A REF_B LABEL=PASS:GLOB [LABEL=PASS:GLOB ...] [--classify GLOB]

REF_A, REF_B: the split reference's halves (/work/refs, convergence.SplitReference). Each
LABEL=PASS:GLOB is one configuration rendered at several seeds (the files GLOB matches), PASS the
pass read (`combined`, or gpm's `primal`: SPPM's estimator on the same photons). For each:

- relMSE and trimmed relMSE (the worst 0.1 % of pixels left out) per run, less the reference's
  noise, as scripts/bench_gpm.py error prints them;
- the worst pixels without selection bias: W = the 0.1 % of pixels of largest mean error over the
  first half of the seeds, measured over the other half (and the halves swapped): W's share of
  relMSE split into bias^2 ((mean - reference)^2 less var/K and the reference's noise: unbiased)
  and variance, and the signed relative bias sum(mean - ref) / sum(ref) over W. Pixels chosen by
  the same runs they are measured on would show their noise as bias.

--classify GLOB (gpm runs): each run's own worst 0.1 % pixels, by what put the error there,
comparing `combined` with the run's primal and with `gradphoton reconstruct --l1` of its primal
and gradients (written next to the run as RUN.l1.exr once; that image has the gather paths'
light seen in place of the further camera paths'):
  emission: combined - RUN.l1 carries over half the error (light seen along the further camera
            paths: emitters and their images in mirrors and glass, primal domain, no gradients);
  shared:   the primal is as far off on the same side (SPPM's estimator on the same photons and
            paths has the error too: a caustic focus's photon lottery, a light seen on a rare path);
  gradient: the rest (the reconstruction put it there).
"""
import glob
import pathlib
import subprocess
import sys

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))
sys.path.insert(0, str(ROOT / "build" / "python"))
from convergence import SplitReference  # noqa: E402
from gradphoton import _native as native  # noqa: E402


def read(path, name="combined"):
    return native.read_exr(str(path))[name].astype(np.float64)


def tails(R, label, xs):
    N = R.ref.shape[0] * R.ref.shape[1]
    e = [R.errors(x)[1] for x in xs]
    t = [R.trimmed(x) for x in xs]
    print(f"{label}: {len(xs)} runs, relMSE mean {np.mean(e):.5f} ({' '.join('%.5f' % v for v in e)}), "
          f"trim mean {np.mean(t):.5f}")
    h = len(xs) // 2
    for sel, ev in ((xs[:h], xs[h:]), (xs[h:], xs[:h])):
        err = np.mean([((x - R.ref) ** 2 / R.norm).mean(2) for x in sel], axis=0)
        W = np.zeros(err.shape, bool)
        W.flat[np.argsort(err.ravel())[-max(1, N // 1000):]] = True
        X = np.stack(ev)
        k, m, v = len(ev), X.mean(0), X.var(0, ddof=1)
        b2 = ((m - R.ref) ** 2 - v / k - R.noise)[W] / R.norm[W]
        print(f"  W of {len(sel)} seeds on the other {k}: bias^2 {b2.sum() / N / 3:.5f} + var "
              f"{(v[W] / R.norm[W]).sum() / N / 3:.5f}; signed relative bias "
              f"{(m[W] - R.ref[W]).sum() / R.ref[W].sum():+.3f}")


def classify(R, path):
    rl_path = pathlib.Path(str(path)[:-4] + ".l1.exr")
    if not rl_path.exists():
        subprocess.run([str(ROOT / "build" / "gradphoton"), "reconstruct", "--l1", "--threads", "1", str(path),
                        "-o", str(rl_path)], check=True, stdout=subprocess.DEVNULL)
    c, p, rl = read(path), read(path, "primal"), read(rl_path)
    N = c.shape[0] * c.shape[1]
    e = (((c - R.ref) ** 2 - R.noise) / R.norm).mean(2)
    out = {"emission": 0.0, "shared": 0.0, "gradient": 0.0}
    for i in np.argsort(e.ravel())[-max(1, N // 1000):]:
        y, x = divmod(int(i), c.shape[1])
        dc, dl, dp = ((img[y, x] - R.ref[y, x]).mean() for img in (c, rl, p))
        if abs(dl) < 0.5 * abs(dc):
            k = "emission"
        elif np.sign(dp) == np.sign(dl) and abs(dp) >= 0.7 * abs(dl):
            k = "shared"
        else:
            k = "gradient"
        out[k] += e[y, x] / N
    print(f"{path}: relMSE {e.sum() / N:.5f}, worst 0.1 % {sum(out.values()):.5f} = "
          + ", ".join(f"{k} {v:.5f}" for k, v in out.items()))


def main(argv):
    if len(argv) < 3:
        print(__doc__)
        return 2
    R = SplitReference(read(argv[0]), read(argv[1]))
    rest = argv[2:]
    cls = None
    if "--classify" in rest:
        i = rest.index("--classify")
        cls = rest[i + 1]
        rest = rest[:i] + rest[i + 2:]
    for spec in rest:
        label, _, pass_glob = spec.partition("=")
        name, _, pattern = pass_glob.partition(":")
        files = sorted(f for f in glob.glob(pattern) if not f.endswith(".l1.exr"))
        tails(R, label, [read(f, name) for f in files])
    if cls:
        for f in sorted(f for f in glob.glob(cls) if not f.endswith(".l1.exr")):
            classify(R, f)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
