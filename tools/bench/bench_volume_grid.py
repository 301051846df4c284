#!/usr/bin/env python3
"""A volume's spatial grid: the pixel grid (1x) against F x F cells a pixel, against references of
the pixel's area (docs/bench/animation.md, sessions 42-43; csi_default_grid_factor).

  render   csi-render scenes (bundled names or .scene paths) at 64 x 64 x T: csi on each grid of
           --grids, and stratified on the pixel grid and on 8 x 8 cells a pixel (nearly
           continuous positions, a renderer's Monte Carlo), seeds 1..S, against `csi-render
           --reference 64T` (8 x 8 points a pixel a frame; the mean of --ref-seeds seeds for a
           path-traced scene). Table: image MSE over stratified's on 8 x 8 cells, the default
           grid's choice marked.
  mitsuba  Mitsuba animations (bundled names or .py files with animate()) at 64 x 64 x 16: the
           same number of random cells on each grid (a fraction of the pixel grid's cells, its
           quarter on the 2x grid), N paths a sample, csi's image against the box-filtered
           reference frames' mean (cached in --data, as bench_animation's).

  .venv/bin/python tools/bench/bench_volume_grid.py render --scenes billiards,train --out OUT
  .venv/bin/python tools/bench/bench_volume_grid.py mitsuba --scenes anim_ball,anim_pan --paths 16 --out OUT
"""
import argparse
import json
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "..", "host", "python"))
import bench_common as bc  # noqa: E402
import csi  # noqa: E402

SIZE = 64
MC_GRID = 8  # stratified's comparison grid, cells a pixel side: nearly continuous positions
REF_SIDE = 8  # the reference's points a pixel side a frame


def render_table(a):
    bins = bc.binaries(a.build)
    env = bc.default_env()
    grids = [int(f) for f in a.grids.split(",")]
    rows = []
    for scene in a.scenes.split(","):
        path, _ = bc.scene_variant(scene, (SIZE, SIZE), os.path.join(a.out, "scenes"))
        name = os.path.splitext(os.path.basename(scene))[0]
        plan = bc.plan(bins, path, env)
        if not plan["motion"]:
            raise bc.BenchError(f"{scene}: nothing moves (a still image has no time axis)")
        d = os.path.join(a.out, name)
        os.makedirs(d, exist_ok=True)
        T = a.time_steps
        refs = []
        for s in range(1, a.ref_seeds + 1):
            ref = os.path.join(d, f"ref{s}.exr")
            if not os.path.exists(ref):
                bc.run([bins["csi-render"], path, "--reference", str(REF_SIDE * REF_SIDE * T), "--time-steps", str(T),
                        "--seed", str(s), "-o", ref, "-q"], env)
            refs.append(bc.read_exr(ref))
        ref = np.mean(refs, axis=0)
        camera = "pans" if plan["camera_pans"] else "moves" if plan["camera_moves"] else "still"
        for spp in map(int, a.spp.split(",")):
            dflt = csi.default_grid_factor(SIZE, SIZE, T, spp, camera=camera)
            runs = [("cs", F) for F in sorted(set(grids + [dflt]))] + [("stratified", 1), ("stratified", MC_GRID)]
            err = {}
            for seed in range(1, a.seeds + 1):
                for method, F in runs:
                    out = os.path.join(d, f"s{spp}_r{seed}_g{F}_{method}.exr")
                    st = out[:-4] + ".json"
                    if not os.path.exists(out):
                        bc.run([bins["csi-render"], path, "--spp", str(spp), "--seed", str(seed), "--time-steps",
                                str(T), "--grid", str(SIZE * F), "--method", method, "-o", out, "--stats", st,
                                "-q"], env)
                    err.setdefault((method, F), []).append(bc.mse(bc.read_exr(out), ref))
                    if method == "cs":
                        err.setdefault(("t", F), []).append(json.load(open(st))["t_reconstruct_s"])
            m = {k: float(np.mean(v)) for k, v in err.items()}
            mc = m["stratified", MC_GRID]
            cells = " | ".join(f"{m['cs', F] / mc:.3f}" + (" *" if F == dflt else "") for F in grids)
            rows.append(f"| {name} | {camera} | {spp} | {mc:.3e} | {m['stratified', 1] / mc:.3f} | {cells} | {dflt}x "
                        f"| {m['cs', dflt] / mc:.3f} | " + ", ".join(f"{m['t', F]:.1f}" for F in grids) + " |")
            bc.log(rows[-1])
    head = ["| scene | camera | spp | stratified %dx MSE | stratified 1x | " % MC_GRID
            + " | ".join(f"csi {F}x" for F in grids) + " | default | csi default | csi s (" + ", ".join(f"{F}x" for F in grids) + ") |",
            "| --- | --- | ---: | ---: | ---: | " + " ---: |" * len(grids) + " --- | ---: | --- |"]
    return ["Image MSE over stratified's on %d x %d cells a pixel (positions nearly continuous, as a renderer's "
            "jitter), seeds 1-%d, against %d seed(s) of --reference %d (%d x %d points a pixel a frame); * the "
            "default grid:" % (MC_GRID, MC_GRID, a.seeds, a.ref_seeds, REF_SIDE * REF_SIDE * a.time_steps, REF_SIDE,
                                REF_SIDE), ""] + head + rows


def mitsuba_table(a):
    from csi import mitsuba_bridge as mb

    import bench_animation as ba

    T = 16
    rows = []
    for entry in a.scenes.split(","):
        path = ba.MITSUBA_SCENES.get(entry, entry)
        name = os.path.splitext(os.path.basename(path))[0]
        d = os.path.join(a.data, name)
        os.makedirs(d, exist_ok=True)
        ref_path = os.path.join(d, f"reference_{SIZE}x{SIZE}x{T}_{a.ref_spp}.npy")
        if not os.path.exists(ref_path):
            sref = mb.load_scene(path, size=(SIZE, SIZE), box_filter=True)
            np.save(ref_path, mb.render_reference_frames(sref, T, a.ref_spp, seed=1))
        ref = np.load(ref_path).astype(np.float64).mean(axis=0)
        scene = mb.load_scene(path, size=(SIZE, SIZE))
        camera = mb.camera_motion(scene)
        cells = []
        for rate in map(float, a.rates.split(",")):
            e = {}
            for seed in range(a.seeds):
                for F in (1, 2):
                    req = mb.positions_request((SIZE, SIZE), grid=SIZE * F, time_steps=T, method="random",
                                               seed=seed + 1, fraction=rate / (F * F))
                    s = mb.render_request(scene, req, paths=a.paths, seed=seed + 1)
                    g = (*req.grid, *req.out)
                    r = csi.reconstruct(req.xyt, s.values, g, variance=s.variance)
                    e.setdefault(F, []).append(bc.mse(np.asarray(r.image), ref))
            m = {F: float(np.mean(v)) for F, v in e.items()}
            cells.append(f"{m[1]:.2e} -> {m[2]:.2e}")
            bc.log(f"{name} {100 * rate:g}% {a.paths} paths: 1x {m[1]:.3e}, 2x {m[2]:.3e}")
        rows.append(f"| {name} | {camera} | {a.paths} | " + " | ".join(cells) + " |")
    rates = " | ".join(f"{100 * float(r):g}%" for r in a.rates.split(","))
    return (["Image MSE on the pixel grid -> on 2 x 2 cells a pixel, the same number of samples, seeds 0-%d, "
             "against %d-spp box-filtered references:" % (a.seeds - 1, a.ref_spp), "",
             f"| scene | camera | paths | {rates} |", "| --- | --- | ---: |" + " --- |" * len(a.rates.split(","))] + rows)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("part", choices=("render", "mitsuba"))
    ap.add_argument("--out", required=True)
    ap.add_argument("--scenes", default=None, help="render: billiards,train; mitsuba: anim_ball,anim_pan")
    ap.add_argument("--spp", default="4,9,16", help="render: samples per pixel")
    ap.add_argument("--time-steps", type=int, default=32, help="render: frames")
    ap.add_argument("--grids", default="1,2,3,4", help="render: csi's grids, cells a pixel side")
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--ref-seeds", type=int, default=1, help="render: reference seeds (4 for path-traced scenes)")
    ap.add_argument("--rates", default="0.1,0.2,0.3,0.5", help="mitsuba: fractions of the pixel grid's cells")
    ap.add_argument("--paths", type=int, default=16, help="mitsuba: paths per sample")
    ap.add_argument("--ref-spp", type=int, default=1024, help="mitsuba: reference samples per pixel per frame")
    ap.add_argument("--data", default=os.path.join(os.path.expanduser("~"), ".cache", "csi", "bench-animation"),
                    help="mitsuba: the references' cache (bench_animation's layout)")
    ap.add_argument("--build", default=None)
    a = ap.parse_args()
    a.scenes = a.scenes or ("billiards,train" if a.part == "render" else "anim_ball,anim_pan")
    os.makedirs(a.out, exist_ok=True)
    lines = render_table(a) if a.part == "render" else mitsuba_table(a)
    with open(os.path.join(a.out, f"{a.part}.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    try:
        main()
    except bc.BenchError as e:
        sys.exit(f"bench_volume_grid: {e}")
