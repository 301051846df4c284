#!/usr/bin/env python3
"""The blurred image of a volume split in time windows from one 2-D solve over all its samples
(issue 11, session 22).

The blurred image is the mean over t of the volume, and a sample f(x, y, t_i) at a time spread
over the shutter is a noisy sample of that image at (x, y). So the image can be estimated from
every sample at once by a 2-D problem (one frame's memory: it fits wherever the windows fit): Alg. 1 (what csi-reconstruct runs on a 2-D dump) on the samples with
t dropped, the samples sharing an (x, y) cell averaged as the dump reader merges duplicates, and
flagged as not exact (they differ over t). Measured here through the library, nothing built into
it, against the whole volume's image and the 2- and 4-window images of bench_scale.py's windows
rows (the same calls: seed 1, samples not flagged exact), windows_heldout.py's volumes, and the
long billiards and train (64x64 x 256 frames, 16 spp; windows_choice.py's cases).

Images, each cached in OUT/cache/<case>.npz:
  whole      csi.reconstruct on the volume (tiles 1)
  wN         the N windows' image (tiles_t N, the default image)
  2d         Alg. 1 on the merged samples (grid W x H x 1, the volume's x/y grid)
  2d_none    the same without the per-pixel correction (correct none: the fit alone)
  gauss      the Gaussian normalized convolution of the same 2-D samples (estimator gauss)
  pmean      the per-pixel mean over the samples themselves (each sample weighted 1), in numpy
             (a pixel without a sample takes the 2-D image's value)

and from them, in numpy, what the truth can make of the windows' image and the 2-D image: the
better per pixel (oracle_px), per 8x8 region (oracle_r8), and the best single weight of the 2-D
image over the image (best_weight, its MSE oracle_weight): bounds for any blend of the two (each
with Alg. 1's and with the Gaussian's 2-D image). And a
rule from the samples alone (still_rR_eE): the 2-D image in the R x R regions that hold a fine
cell sampled at two or more times and where no such cell changed by more than E between them
(--rules R:E,...), the windows' image elsewhere; whole_still_rR_eE the same rule on the whole's
image (what the rule gains without windows). And a weight per pixel from the samples (ivar): the
2-D image weighted c / (c + v), v the variance of the pixel's sample mean (at least its median
over the image), c the best of a scan by the truth (a bound for that form of rule; the better of
the two 2-D images in the table).

    .venv/bin/python tools/bench/windows_image2d.py --out OUT                   # the cases below, 2 and 4 windows
    .venv/bin/python tools/bench/windows_image2d.py --out OUT --cases billiards,train --windows 2,4,8

One line per case: each image's MSE over the whole's; at the end the table of docs/bench/scale.md
(the bounds at 4 windows, or at the last count when 4 is not asked; a row more for each larger
count) and OUT/windows_image2d.csv with every figure.
"""
import argparse
import csv
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(ROOT, "host", "python"))

import bench_common as bc  # noqa: E402
import windows_choice as wc  # noqa: E402

import csi  # noqa: E402

# bench_scale.py windows' rows, then windows_heldout.py's volumes
CASES = ["disc:0", "disc:1", "disc:2", "disc:3", "disc:4", "pan:0", "pan:1", "pan+disc:0", "pan+disc:1",
         "train128", "billiards128", "bounce:1", "bounce:2", "bar:1", "bar:2", "mixed:1", "mixed:2", "flicker:1",
         "flicker:2"]


def flatten(pos, vals, grid):
    """The samples with t dropped: one per occupied (x, y) cell, the mean of the cell's values (in
    double, as the dump reader merges duplicates), and how many were merged into each."""
    W, H = grid[0], grid[1]
    cell = pos[:, 1].astype(np.int64) * W + pos[:, 0]
    cnt = np.bincount(cell, minlength=W * H)
    occ = np.flatnonzero(cnt)
    sums = np.stack([np.bincount(cell, weights=vals[:, c].astype(np.float64), minlength=W * H)
                     for c in range(vals.shape[1])], 1)
    p2 = np.stack([occ % W, occ // W, np.zeros_like(occ)], 1).astype(np.uint32)
    v2 = (sums[occ] / cnt[occ, None]).astype(np.float32)
    return p2, v2, cnt[occ]


def pixel_of(pos, grid):
    """Each sample's output pixel (row-major)."""
    bw, bh = grid[0] // grid[3], grid[1] // grid[4]
    return (pos[:, 1] // bh).astype(np.int64) * grid[3] + pos[:, 0] // bw


def pixel_moments(pos, vals, grid):
    """Each pixel's mean of its samples (every sample weighted 1; NaN where it has none), their
    count, and the variance of that mean (the samples' variance over t / their count: the spread
    of the Monte Carlo estimate of the blur; inf where the pixel has fewer than 2)."""
    pix = pixel_of(pos, grid)
    n = np.bincount(pix, minlength=grid[3] * grid[4]).astype(np.float64)
    v = vals.astype(np.float64)
    s1 = np.stack([np.bincount(pix, weights=v[:, c], minlength=n.size) for c in range(v.shape[1])], 1)
    s2 = np.stack([np.bincount(pix, weights=v[:, c] ** 2, minlength=n.size) for c in range(v.shape[1])], 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = s1 / n[:, None]
        var = (s2 - s1 * mean) / np.maximum(n - 1, 1)[:, None] / n[:, None]
    var = np.where(n[:, None] >= 2, np.maximum(var, 0), np.inf)
    shape = (grid[4], grid[3], -1)
    return mean.reshape(shape), n.reshape(grid[4], grid[3]), var.reshape(shape)


def cell_spread(pos, vals, grid):
    """Per pixel, the largest change between two samples of one fine cell at different times (max
    over channels), -1 where no cell of the pixel was sampled twice: 0 means every repeated cell
    of the pixel gave the same value at every time it was sampled."""
    cell = pos[:, 1].astype(np.int64) * grid[0] + pos[:, 0]
    o = np.argsort(cell, kind="stable")
    c, v = cell[o], vals[o].astype(np.float64)
    same = c[1:] == c[:-1]
    dv = np.abs(v[1:] - v[:-1]).max(1)[same]
    px = pixel_of(pos[o][1:][same], grid)
    spread = np.full(grid[3] * grid[4], -1.0)
    np.maximum.at(spread, px, dv)
    return spread.reshape(grid[4], grid[3])


def still_regions(spread, r, eps):
    """The r x r regions holding a cell sampled at two or more times, no such cell changing by more
    than eps over t: True on their pixels."""
    H, W = spread.shape
    s = spread[:H // r * r, :W // r * r].reshape(H // r, r, W // r, r)
    top = s.max((1, 3))
    ok = (top <= eps) & (top >= 0)
    m = np.zeros((H, W), bool)
    m[:H // r * r, :W // r * r] = np.kron(ok, np.ones((r, r), int)).astype(bool)
    return m


def images(name, out, bins, env, windows):
    cache = os.path.join(out, "cache", name.replace(":", "_") + ".npz")
    have = dict(np.load(cache)) if os.path.exists(cache) else {}
    need = ["whole", "2d", "2d_none", "gauss", "spread", "pvar"] + [f"w{N}" for N in windows]
    if all(k in have for k in need):
        return have
    grid, pos, vals, _, _, truth = wc.load_case(name, out, bins, env)
    have["truth"] = truth
    have["pmean"], have["pcnt"], have["pvar"] = pixel_moments(pos, vals, grid)
    have["spread"] = cell_spread(pos, vals, grid)

    def rec(key, p, v, g, **kw):
        if key in have:
            return
        t0 = time.perf_counter()
        r = csi.reconstruct(p, v, g, seed=1, **kw)
        have[key] = r.image.astype(np.float64)
        have[key + "_s"] = time.perf_counter() - t0
        have[key + "_v"] = np.array([float(r.options.get("motion_vx", 0) or 0),
                                     float(r.options.get("motion_vy", 0) or 0)])
        os.makedirs(os.path.dirname(cache), exist_ok=True)
        np.savez(cache, **have)

    rec("whole", pos, vals, grid, tiles=1, tiles_t=1)
    for N in windows:
        rec(f"w{N}", pos, vals, grid, tiles=0, tiles_t=N)
    p2, v2, _ = flatten(pos, vals, grid)
    g2 = (grid[0], grid[1], 1, grid[3], grid[4])
    rec("2d", p2, v2, g2)
    rec("2d_none", p2, v2, g2, correct="none")
    rec("gauss", p2, v2, g2, estimator="gauss")
    np.savez(cache, **have)
    return have


def mse(a, b):
    return float(((a - b) ** 2).mean())


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--windows", default="2,4")
    ap.add_argument("--rules", default="8:0", help="still-region rules r:eps, comma-separated")
    a = ap.parse_args()
    rules = [(int(x.split(":")[0]), float(x.split(":")[1])) for x in a.rules.split(",")]
    os.makedirs(a.out, exist_ok=True)
    windows = [int(x) for x in a.windows.split(",")]
    bins, env = bc.binaries(), bc.default_env()
    rows = []
    for name in a.cases.split(","):
        h = images(name, a.out, bins, env, windows)
        t = h["truth"]
        e_w = mse(h["whole"], t)
        row = dict(case=name, mse_whole=e_w, v_whole="%.2f,%.2f" % tuple(h["whole_v"]))
        for N in windows:
            row[f"w{N}"] = mse(h[f"w{N}"], t) / e_w
        for k in ("2d", "2d_none", "gauss"):
            row[k] = mse(h[k], t) / e_w
        pm = np.where(np.isnan(h["pmean"]), h["2d"], h["pmean"])
        row["pmean"] = mse(pm, t) / e_w
        masks = {f"r{r}_e{eps:g}": still_regions(h["spread"], r, eps) for r, eps in rules}
        for tag, m in masks.items():
            row[f"still_share_{tag}"] = float(m.mean())
            row[f"whole_still_{tag}"] = mse(np.where(m[..., None], h["2d"], h["whole"]), t) / e_w
        pv = h["pvar"]
        floor = float(np.median(pv[np.isfinite(pv)]))
        for N in windows:
            w = h[f"w{N}"]
            for k in ("2d", "gauss"):
                d = h[k]
                # bounds: the truth picks per pixel or per 8x8 region, or sets one weight
                ew, ed = ((w - t) ** 2).sum(-1), ((d - t) ** 2).sum(-1)
                row[f"oracle_px_{k}_{N}"] = float(np.minimum(ew, ed).sum() / t.size) / e_w
                H, W = ew.shape
                rw = ew.reshape(H // 8, 8, W // 8, 8).sum((1, 3))
                rd = ed.reshape(H // 8, 8, W // 8, 8).sum((1, 3))
                row[f"oracle_r8_{k}_{N}"] = float(np.minimum(rw, rd).sum() / t.size) / e_w
                g = d - w
                alpha = float(((t - w) * g).sum() / max((g * g).sum(), 1e-30))
                row[f"best_weight_{k}_{N}"] = alpha
                row[f"oracle_weight_{k}_{N}"] = mse(w + alpha * g, t) / e_w
                # per pixel, c / (c + the pixel mean's variance, at least its median): the
                # 2-D image where its samples agree; c chosen by the truth (a bound for the form)
                best = min((mse(w + c / (c + np.maximum(pv, floor)) * g, t) / e_w, c)
                           for c in 10.0 ** np.arange(-8, -0.9, 0.25))
                row[f"ivar_{k}_{N}"], row[f"ivar_c_{k}_{N}"] = best
            for tag, m in masks.items():
                row[f"still_{tag}_{N}"] = mse(np.where(m[..., None], h["2d"], w), t) / e_w
        rows.append(row)
        bc.log("  " + ", ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}" for k, v in row.items()))
    with open(os.path.join(a.out, "windows_image2d.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print_table(rows, windows, "r%d_e%g" % rules[0])


def fmt(x):
    return f"{float(x):.3f}" if float(x) < 100 else f"{float(x):.0f}"


NAMES = {"train128": "train 128x128 x 32, 4 spp", "billiards128": "billiards 128x128 x 64, 4 spp",
         "billiards": "billiards 64x64 x 256, 16 spp", "train": "train 64x64 x 256, 16 spp"}


def print_table(rows, windows, tag):
    """docs/bench/scale.md's table: the bounds and rules at 4 windows (or the last count asked),
    a row more for each larger count."""
    N = 4 if 4 in windows else windows[-1]

    def bounds(r, N):
        iv = min(r[f"ivar_2d_{N}"], r[f"ivar_gauss_{N}"])
        return (f"{fmt(r[f'oracle_weight_gauss_{N}'])} ({r[f'best_weight_gauss_{N}']:.2f}) "
                f"| {fmt(r[f'oracle_r8_2d_{N}'])} | {fmt(iv)}")

    first = [n for n in windows if n <= N][-2:]
    print(f"| volume | MSE whole | " + " | ".join(f"{n} windows" for n in first) + " | 2-D: Alg. 1 | 2-D: Gaussian "
          f"| one weight of the Gaussian, truth's ({N} windows) | per 8x8 region, truth's ({N} windows) "
          f"| inverse variance, truth's c ({N} windows) | still rule: share | "
          + " | ".join(f"{n} windows + still rule" for n in first) + " | whole + still rule |")
    print("| --- |" + " ---: |" * (8 + 2 * len(first)))
    for r in rows:
        name = NAMES.get(r["case"], r["case"].replace(":", " s"))
        print(f"| {name} | {r['mse_whole']:.3e} | " + " | ".join(fmt(r[f"w{n}"]) for n in first)
              + f" | {fmt(r['2d'])} | {fmt(r['gauss'])} | {bounds(r, N)} | {r[f'still_share_{tag}']:.2f} | "
              + " | ".join(fmt(r[f"still_{tag}_{n}"]) for n in first) + f" | {fmt(r[f'whole_still_{tag}'])} |")
    for n in (n for n in windows if n > N):
        for r in rows:
            name = NAMES.get(r["case"], r["case"].replace(":", " s"))
            print(f"| {name}: {n} windows | | | {fmt(r[f'w{n}'])} | | | {bounds(r, n)} | | | "
                  f"{fmt(r[f'still_{tag}_{n}'])} | |")


if __name__ == "__main__":
    main()
