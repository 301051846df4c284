#!/usr/bin/env python3
"""Two time windows against the whole volume on short (16-frame) volumes (issue 11, docs/bench/scale.md
session 30): the image's and the frames' MSE of `tiles_t=2` over `tiles_t=1`, on tools/bench/
bench_animation.py's cases (its procedural volumes and Mitsuba animations, the same samples).

The planner refuses two windows of a 16-frame volume with its default margins; the measurement was made
with a scratch build that lays them out from a core and one margin, loaded through CSI_LIBRARY:

    CSI_LIBRARY=SCRATCH/build/sdk/libcsi.so .venv/bin/python tools/bench/windows_short.py --data DATA
"""
import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bench_animation as ba  # noqa: E402
import csi  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", required=True, help="bench_animation's cache of volumes and renders")
    ap.add_argument("--cases", default="anim_ball,anim_pan,static+disc,static+movers,pan+disc,pan")
    ap.add_argument("--rates", default="0.03,0.1")
    ap.add_argument("--seeds", default="0,1,2")
    ap.add_argument("--size", default="64x64x16")
    a = ap.parse_args()
    size = tuple(int(v) for v in a.size.split("x"))
    ratios = []
    for name in a.cases.split(","):
        for rate in (float(r) for r in a.rates.split(",")):
            for seed in (int(s) for s in a.seeds.split(",")):
                case = (ba.mitsuba_case(name, seed, rate, size, a.data, 64, 16) if name in ba.MITSUBA_SCENES
                        else ba.procedural_case(name, seed, rate, size, a.data))
                ref = case.truth.mean(axis=0)
                whole = csi.reconstruct(case.pos, case.vals, case.grid, seed=1, frames="on", tiles=1, tiles_t=1)
                win = csi.reconstruct(case.pos, case.vals, case.grid, seed=1, frames="on", tiles=0, tiles_t=2)
                img = float(np.mean((win.image - ref) ** 2) / np.mean((whole.image - ref) ** 2))
                frm = float(np.mean((win.frames - case.truth) ** 2) / np.mean((whole.frames - case.truth) ** 2))
                ratios.append((img, frm))
                print(f"{name} {rate:g} seed {seed}: 2 windows / whole: image {img:.3f} frames {frm:.3f}", flush=True)
    r = np.array(ratios)
    print(f"geometric mean: image {np.exp(np.log(r[:, 0]).mean()):.3f}, frames {np.exp(np.log(r[:, 1]).mean()):.3f}; "
          f"image beyond 2%: {(r[:, 0] > 1.02).sum()} of {len(r)}; worst {r[:, 0].max():.3f}")


if __name__ == "__main__":
    main()
