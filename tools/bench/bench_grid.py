#!/usr/bin/env python3
"""Fine-grid multiplier sweep of csi-render's compressive method on the static scenes (issue 6,
docs/bench/grid.md): MSE against a 256-spp stratified reference (csi-render --reference 256, on
the 16x grid) and reconstruction time, for every (scene, spp, multiplier), next to stratified
Monte Carlo at the same spp on the reference's 16x grid (as tools/bench/bench_accuracy.py does).
The metric code is tools/bench/bench_common.py's (mse over all pixels and RGB channels).

  .venv/bin/python tools/bench/bench_grid.py --size 64x64 --grids 4,8,16 --spp 1,4,9,16 --seeds 4
  .venv/bin/python tools/bench/bench_grid.py --grids auto ...   # csi-render's default (no --grid)
"""
import argparse
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bench_common as bc  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", default="triangle,checkerboard,garden")
    ap.add_argument("--size", default="64x64")
    ap.add_argument("--spp", default="1,4,9,16")
    ap.add_argument("--grids", default="4,8,16", help="multipliers; 'auto' = no --grid (the default rule)")
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--ref-spp", type=int, default=256)
    ap.add_argument("--work", default="/tmp/csi-bench-grid")
    ap.add_argument("--build", default=None)
    ap.add_argument("--csv", default=None, help="append rows to this CSV")
    a = ap.parse_args()
    W, H = (int(v) for v in a.size.split("x"))
    bins = bc.binaries(a.build)
    env = bc.default_env()
    os.makedirs(a.work, exist_ok=True)
    out = open(a.csv, "a") if a.csv else None

    def render(scene, args):
        exr, js = os.path.join(a.work, "o.exr"), os.path.join(a.work, "o.json")
        bc.run([bins["csi-render"], scene, "-o", exr, "--stats", js, "-q"] + args, env)
        with open(js) as f:
            st = json.load(f)
        return bc.read_exr(exr), st

    mc = int(round(a.ref_spp ** 0.5))
    for name in a.scenes.split(","):
        scene, shash = bc.scene_variant(name, (W, H), a.work)
        refp = os.path.join(a.work, f"ref_{name}_{W}x{H}_r{a.ref_spp}_{shash}.npy")
        if os.path.exists(refp):
            ref = np.load(refp)
        else:
            ref, _ = render(scene, ["--reference", str(a.ref_spp)])
            np.save(refp, ref)
        for spp in (int(s) for s in a.spp.split(",")):
            strat = [bc.mse(render(scene, ["--spp", str(spp), "--seed", str(s), "--grid", str(mc * W),
                                           "--method", "stratified"])[0], ref) for s in range(1, a.seeds + 1)]
            ms = float(np.mean(strat))
            row = f"{name},{W}x{H},{spp},stratified,{mc},{ms:.4g},1,0"
            print(row, flush=True)
            if out:
                out.write(row + "\n")
            for g in a.grids.split(","):
                errs, times, used = [], [], None
                for s in range(1, a.seeds + 1):
                    args = ["--spp", str(spp), "--seed", str(s)] + ([] if g == "auto" else ["--grid", str(int(g) * W)])
                    img, st = render(scene, args)
                    errs.append(bc.mse(img, ref))
                    times.append(bc.recon_time(st))
                    used = st.get("grid_w")
                m = float(np.mean(errs))
                tag = g if g != "auto" else f"auto({used // W if used else '?'})"
                row = f"{name},{W}x{H},{spp},cs,{tag},{m:.4g},{m / ms:.3g},{np.median(times):.3g}"
                print(row, flush=True)
                if out:
                    out.write(row + "\n")
    if out:
        out.close()


if __name__ == "__main__":
    main()
