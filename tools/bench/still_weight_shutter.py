#!/usr/bin/env python3
"""The still layer's weight (--motion-still-weight) against the shutter's continuous-time
reference (docs/bench/animation.md, round 7).

A bundled moving scene at --size (bench_common.scene_variant) rendered by csi-render at --spp with
each --frames count of time steps (its own samples and seed, as bench_scale.py renders its
dumps), reconstructed by the library with each --weights value, and its image compared with
csi-render --reference 256 (the shutter's mean: continuous in t, not the mean of T time cells).

    .venv/bin/python tools/bench/still_weight_shutter.py --scene train --frames 32,64,128,256 --out OUT

Prints one line per frames count: the image MSE at each weight and their ratios to the first.
"""
import argparse
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(HERE)), "host", "python"))

import bench_common as bc  # noqa: E402
import bench_scale as bs  # noqa: E402
import windows_still as ws  # noqa: E402

import csi  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ws.scene_args(ap, "train")
    ap.add_argument("--frames", default="32,64,128")
    ap.add_argument("--weights", default="1,0.5")
    a = ap.parse_args()
    size = tuple(int(v) for v in a.size.split("x"))
    weights = [float(w) for w in a.weights.split(",")]
    bins, env = bs.binaries(), bc.default_env()
    for T in [int(t) for t in a.frames.split(",")]:
        work = os.path.join(a.out, f"{a.scene}_T{T}_s{a.spp}")
        os.makedirs(work, exist_ok=True)
        with open(os.path.join(work, "log"), "a") as logf:
            path, dump = bs.make_dump(bins, env, a.scene, size, a.spp, work, logf, extra=["--time-steps", str(T)])
            ref = bs.reference(bins, env, path, work, logf)
        d = csi.read_dump(dump)
        e = [bs.mse(csi.reconstruct(d.positions, d.values, d.grid, seed=d.seed, exact=d.exact,
                                    motion_still_weight=w).image, ref) for w in weights]
        print(f"{a.scene} {a.size} x {T}, {a.spp} spp: " +
              ", ".join(f"W = {w:g}: MSE {m:.4e} ({m / e[0]:.3f})" for w, m in zip(weights, e)), flush=True)


if __name__ == "__main__":
    main()
