#!/usr/bin/env python3
"""Where csi's error exceeds the per-pixel mean's on one cached Mitsuba dump (docs/bench/mitsuba.md,
"The two cells still above the mean in MSE").

Reconstructs DATA/<scene>/<dump>.csid with `--estimator mean` and with csi (its defaults, or the
csi-reconstruct arguments after --), and prints both MSEs against Mitsuba's reference
(DATA/<scene>/reference_4096.npy), the excess (each pixel's squared error averaged over its
channels, csi's minus the mean's, summed over the pixels where it is positive and where it is
negative), how much of the positive part the largest pixels carry, and those pixels' values.

    .venv/bin/python tools/bench/excess_pixels.py --data /work/data/mitsuba --scene cornell --dump s4_p64
    .venv/bin/python tools/bench/excess_pixels.py --data DATA --scene horizon --dump s1_p64 -- --correct cv
"""
import argparse
import os
import subprocess
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from bench_common import binaries, default_env, read_exr  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", required=True, help="the Mitsuba dump cache (tools/bench/mitsuba_data.py)")
    ap.add_argument("--scene", required=True)
    ap.add_argument("--dump", required=True, help="the dump's name without .csid, e.g. s4_p64 or s1_p1_poisson")
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--top", type=int, default=8, help="pixels to print")
    ap.add_argument("--build", help="build directory (default: the source tree's build/)")
    ap.add_argument("args", nargs="*", help="csi-reconstruct arguments for csi (after --)")
    a = ap.parse_args()
    exe = binaries(a.build)["csi-reconstruct"]
    d = os.path.join(a.data, a.scene)
    ref = np.load(os.path.join(d, f"reference_{a.reference_spp}.npy")).astype(np.float64)
    err, img = {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, args in (("mean", ["--estimator", "mean"]), ("csi", a.args)):
            out = os.path.join(tmp, name + ".exr")
            p = subprocess.run([exe, os.path.join(d, a.dump + ".csid"), "-o", out, "-q"] + args,
                               capture_output=True, env=default_env())
            if p.returncode:
                sys.exit(f"excess_pixels: csi-reconstruct {' '.join(args)}: {p.stderr.decode(errors='replace').strip()}")
            img[name] = read_exr(out).astype(np.float64).reshape(ref.shape)
            err[name] = ((img[name] - ref) ** 2).mean(axis=2)
    diff = err["csi"] - err["mean"]
    pos = diff[diff > 0].sum()
    print(f"{a.scene} {a.dump}: MSE mean {err['mean'].mean():.4g}, csi {err['csi'].mean():.4g} "
          f"({err['csi'].mean() / err['mean'].mean():.3f}x)")
    print(f"excess: {pos:.4g} where csi is worse, {diff[diff < 0].sum():.4g} where it is better")
    order = np.argsort(diff.ravel())[::-1]
    for k in (10, 50, 200, 1000):
        print(f"  the {k} largest pixels carry {diff.ravel()[order[:k]].clip(0).sum():.4g}")
    for i in order[:a.top]:
        y, x = divmod(int(i), ref.shape[1])
        print(f"  pixel ({x}, {y}): reference {np.round(ref[y, x], 3)}, mean {np.round(img['mean'][y, x], 3)}, "
              f"csi {np.round(img['csi'][y, x], 3)}")


if __name__ == "__main__":
    main()
