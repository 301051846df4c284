#!/usr/bin/env python3
"""Time windows against the whole with the time-constant layer weighted apart (issue 11).

A long volume (--scene, --size, --spp, --time-steps; the dump and its 256-spp reference made as
bench_scale.py makes them; or --scene disc:S, pan:S, pan+disc:S, bench_scale.py's procedural
windows set with position seed S, against the exact mean over t) is reconstructed whole and in each --windows count of time windows,
through the library (csi.reconstruct on the dump's samples, the options below), and its blurred
image compared with the reference. Variants of the windows:

  default   the library's defaults (each window: the whole's absolute tau; the still plane's
            weight auto)
  one       one l1 weight (motion_still_weight 1: the default before round 7), against the whole
            with one weight too ("whole-one")
  rule      each window of L frames (the solved frames, margins included) of the whole's T:
            tau_rel given as the whole's x T / L (so the window's absolute tau is the whole's x
            sqrt(T / L)) and the still plane's weight L / T (its absolute weight the whole's x
            sqrt(L / T)): a still pattern's coefficient in a window is sqrt(L / T) of the whole's
            and a mover's l1 norm in its window sqrt(L / T) of the whole's, so the windows' sum of
            penalties matches the whole's for both (docs/bench/scale.md, "Why the windows lose")
  still     the still plane's weight L / T alone (the default tau)
  tau       the tau of rule alone (one weight; the rule measured in docs/bench/scale.md)
  rulesqrt  rule's tau with the still plane's weight sqrt(L / T) (its absolute weight the whole's)
  binned    the image from one solve of the whole shutter binned in t to at most a window's
            frames (tile_image_binned on: csi/tiles.h, host/integrate/binned.c)
  --extra NAME=OPT:VALUE[,...]   more variants, e.g. w05=motion_still_weight:0.5

    .venv/bin/python tools/bench/windows_still.py --scene billiards --out OUT

Writes OUT/windows_still.csv (one row per run: windows, variant, MSE, / the whole's, the
options the library resolved) and logs each row.
"""
import argparse
import json
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(ROOT, "host", "python"))

import bench_common as bc  # noqa: E402
import bench_scale as bs  # noqa: E402

import csi  # noqa: E402


def scene_args(ap, scene):
    """The arguments that name a rendered scene's dumps: --out, --scene, --size, --spp."""
    ap.add_argument("--out", required=True)
    ap.add_argument("--scene", default=scene)
    ap.add_argument("--size", default="64x64")
    ap.add_argument("--spp", type=int, default=16)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    scene_args(ap, "billiards")
    ap.add_argument("--time-steps", type=int, default=256)
    ap.add_argument("--windows", default="2,4,8")
    ap.add_argument("--variants", default="default,one")
    ap.add_argument("--extra", action="append", default=[], metavar="NAME=OPT:VALUE[,OPT:VALUE]")
    ap.add_argument("--data", default=None, help="where the dump and reference are kept (default OUT/work)")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    work = a.data or os.path.join(a.out, "work")
    os.makedirs(work, exist_ok=True)
    size = tuple(int(v) for v in a.size.split("x"))
    bins = bs.binaries()
    env = bc.default_env()
    extra = {}
    for v in a.extra:
        name, _, opts = v.partition("=")
        extra[name] = {kv.partition(":")[0]: kv.partition(":")[2] for kv in opts.split(",")}
    if ":" in a.scene:  # a procedural volume of bench_scale.py's windows set: disc:SEED, pan:SEED, pan+disc:SEED
        kind, _, sd = a.scene.partition(":")
        grid, pos, vals, truth = bs.disc_volume(int(sd)) if kind == "disc" else bs.pan_volume(kind, int(sd))
        ref, seed, exact = truth, 1, False
    else:
        with open(os.path.join(a.out, "windows_still.log"), "a") as logf:
            path, dump = bs.make_dump(bins, env, a.scene, size, a.spp, work, logf,
                                      extra=["--time-steps", str(a.time_steps)])
            ref = bs.reference(bins, env, path, work, logf)
        d = csi.read_dump(dump)
        grid, pos, vals, seed, exact = d.grid, d.positions, d.values, d.seed, d.exact
    T = grid[2]
    rows = []

    def run(windows, variant, L, **opts):
        t0 = time.perf_counter()
        r = csi.reconstruct(pos, vals, grid, seed=seed, exact=exact, tiles=1 if windows == 1 else 0,
                            tiles_t=windows, **opts)
        sec = time.perf_counter() - t0
        e = bs.mse(r.image, ref)
        # "one" against the whole with one weight too; the others against the whole's defaults
        base = [r for r in rows if r["variant"] == ("whole-one" if variant == "one" else "whole")]
        row = dict(scene=a.scene, size=a.size, spp=a.spp, frames=T, windows=windows, window_frames=L,
                   variant=variant, mse=e, ratio=e / base[0]["mse"] if base else 1.0, seconds=sec,
                   options=json.dumps({k: str(v) for k, v in opts.items()}), load=os.getloadavg()[0])
        rows.append(row)
        bs.write_csv(os.path.join(a.out, "windows_still.csv"), rows)
        bc.log(f"{a.scene} {windows} windows ({L} frames) {variant:8s} MSE {e:.4e} = {row['ratio']:.3f}x the whole "
               f"({sec:.0f} s)")
        return r

    whole = run(1, "whole", T)
    if "one" in a.variants.split(","):
        run(1, "whole-one", T, motion_still_weight=1)
    tau_whole = float(whole.options["tau"])
    for n in [int(v) for v in a.windows.split(",")]:
        # the windows' length: tile 0's frames (one solver step, no search: only its size counts)
        L = csi.reconstruct_tile(pos, vals, grid, 0, seed=seed, exact=exact, tiles_t=n, tiles=n, frames="on",
                                 max_iter=1, motion_velocity="none").frames.shape[0]
        for v in a.variants.split(","):
            if v == "default":
                run(n, v, L)
            elif v == "rule":
                run(n, v, L, tau=tau_whole * T / L, motion_still_weight=L / T)
            elif v == "still":
                run(n, v, L, motion_still_weight=L / T)
            elif v == "one":
                run(n, v, L, motion_still_weight=1)
            elif v == "tau":
                run(n, v, L, tau=tau_whole * T / L)
            elif v == "binned":
                run(n, v, L, tile_image_binned="on")
            elif v == "rulesqrt":
                run(n, v, L, tau=tau_whole * T / L, motion_still_weight=(L / T) ** 0.5)
            else:
                sys.exit(f"windows_still: unknown variant {v!r}")
        for name, opts in extra.items():
            run(n, name, L, **opts)


if __name__ == "__main__":
    main()
