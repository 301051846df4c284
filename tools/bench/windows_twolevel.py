#!/usr/bin/env python3
"""Two levels in t for a volume split in time windows (issue 11): a sum, not a choice.

The windows' image loses a volume's low temporal frequencies (each window sees its stretch of the
shutter), the binned shutter's image (tile_image_binned on) the high ones (motion within a bin).
Measured here, in Python over the library (nothing of it is built into it):

  1. the coarse volume: the binned shutter's solve (the samples sharing a cell of the grid binned
     to ceil(T / b) frames averaged, b as csi_tiling_bin_t chooses it), its bins' frames;
  2. each sample's residual against the coarse volume at its pixel and time: the bin's value
     (variant const) or linear between bin centres, clamped at the ends (lin);
  3. the N windows fit the residuals (csi.reconstruct_tile of each window with the whole
     volume's tau scale, its mean sample, so that their penalty is that of the windows on the
     samples themselves; merged by csi.merge_partials, with the whole shutter's correction);
     constX / linX: that scale times X;
  4. the image: the coarse volume's mean over t plus the windows' residual image ("on the binned
     image": the binned solve's own image, with its per-pixel correction, in place of the mean).

The other order (rev, revX): the windows first (csi.reconstruct with tiles_t N and their
blended frames), then the binned shutter's solve of each sample's residual against the windows'
frame at its pixel (the whole volume's tau scale, times X), added to the windows' image.

The cases and truths are windows_choice.py's, and so are its cached images (--from: a
windows_choice.py --out directory; without it they are made here, folds included). --check also
runs the windows on the samples through this script's path (reconstruct_tile, merge_partials),
which must give the cached windows' image.

    .venv/bin/python tools/bench/windows_twolevel.py --out OUT --from WC --cases billiards,bounce:1 \
        --windows 8,4,2 --variants const,lin,rev

One line per case and window count (MSE over the whole's of: the windows' image, the binned
image, each two-level variant); the table in markdown at the end and OUT/windows_twolevel.csv.
"""
import argparse
import os
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(ROOT, "host", "python"))

import bench_common as bc  # noqa: E402
import bench_scale as bs  # noqa: E402
import windows_choice as wc  # noqa: E402

import csi  # noqa: E402


def smooth7(n):
    for p in (2, 3, 5, 7):
        while n % p == 0:
            n //= p
    return n == 1


def bin_frames(T, L):
    """csi_tiling_bin_t: the smallest b with ceil(T / b) <= L bins, a 7-smooth count."""
    b = 1
    while -(-T // b) > L or not smooth7(-(-T // b)):
        b += 1
    return b


def bin_samples(grid, pos, vals, b):
    """The samples on the grid binned b frames a bin, as binned.c makes them: those sharing a
    binned cell averaged, each cell's record named by its first sample in sample order. The
    binned grid, positions and values."""
    W, H, T, ow, oh = grid
    cell = (pos[:, 2] // b).astype(np.int64) * (W * H) + pos[:, 1].astype(np.int64) * W + pos[:, 0]
    uniq, first, inv = np.unique(cell, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    slot = rank[inv]
    cnt = np.bincount(slot, minlength=len(uniq)).astype(np.float64)
    sums = np.stack([np.bincount(slot, weights=vals[:, c].astype(np.float64), minlength=len(uniq))
                     for c in range(vals.shape[1])], 1)
    c = uniq[order]
    bp = np.stack([c % W, (c // W) % H, c // (W * H)], 1).astype(np.uint32)
    return (W, H, -(-T // b), ow, oh), bp, (sums / cnt[:, None]).astype(np.float32)


def binned_solve(grid, pos, vals, seed, exact, b, scale=None):
    """The binned shutter's solve of one x/y column (here the whole frame) over the whole shutter:
    its bins' frames (Tb, H, W, C) and image. scale: a given tau scale (the binned grid solved as
    one tile of itself), where the samples' own mean is none (residuals)."""
    bg, bp, bv = bin_samples(grid, pos, vals, b)
    if scale is None:
        r = csi.reconstruct(bp, bv, bg, seed=seed, exact=exact, frames=True)
    else:
        r = csi.reconstruct_tile(bp, bv, bg, 0, scale=scale, seed=seed, exact=exact, frames=True, tiles=1, tiles_t=1)
    return r.frames.astype(np.float64), r.image.astype(np.float64)


def coarse_at(frames, grid, pos, b, mode):
    """The coarse volume's value at each sample's pixel and time (n, C), and the coarse volume's
    mean over the T frames (H, W, C) under the same interpolation."""
    W, H, T, ow, oh = grid
    Tb = frames.shape[0]
    px, py = pos[:, 0] // (W // ow), pos[:, 1] // (H // oh)
    t = pos[:, 2].astype(np.int64)
    if mode == "const":
        j = t // b
        at = frames[j, py, px]
        w = np.bincount(np.arange(T) // b, minlength=Tb).astype(np.float64)
        return at, np.tensordot(w / T, frames, axes=(0, 0))
    # bin j's centre: the middle of its frames (the last bin may hold fewer)
    lo = np.arange(Tb) * b
    hi = np.minimum(lo + b, T)
    centre = (lo + hi - 1) / 2.0
    tt = np.arange(T, dtype=np.float64)
    k = np.clip(np.searchsorted(centre, tt, side="right") - 1, 0, Tb - 1)
    k1 = np.minimum(k + 1, Tb - 1)
    span = np.where(k1 > k, centre[k1] - centre[k], 1.0)
    f = np.clip((tt - centre[k]) / span, 0.0, 1.0)
    f = np.where(k1 > k, f, 0.0)
    at = (1 - f[t])[:, None] * frames[k[t], py, px] + f[t][:, None] * frames[k1[t], py, px]
    wt = np.zeros(Tb)
    np.add.at(wt, k, 1 - f)
    np.add.at(wt, k1, f)
    return at, np.tensordot(wt / T, frames, axes=(0, 0))


def windows_image(grid, pos, vals, seed, exact, N, scale):
    """The N windows' merged image of (pos, vals), each window with the given tau scale."""
    with tempfile.TemporaryDirectory() as tmp:
        paths, i, count = [], 0, None
        while count is None or i < count:
            r = csi.reconstruct_tile(pos, vals, grid, i, scale=scale, seed=seed, exact=exact, tiles=0, tiles_t=N)
            count = int(r.info["tiles"])
            p = os.path.join(tmp, f"t{i}.csip")
            r.write_partial(p)
            r.close()
            paths.append(p)
            i += 1
        m = csi.merge_partials(paths)
        return m.image.astype(np.float64), count


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--from", dest="src", default=None, help="a windows_choice.py --out directory to take images from")
    ap.add_argument("--cases", default="billiards")
    ap.add_argument("--windows", default="2,4,8")
    ap.add_argument("--variants", default="const,lin")
    ap.add_argument("--check", action="store_true", help="also the windows on the samples through this path "
                    "(must equal the cached windows' image) and the binned image against the cached one")
    a = ap.parse_args()
    os.makedirs(os.path.join(a.out, "cache"), exist_ok=True)
    bins, env = bs.binaries(), bc.default_env()
    windows = [int(v) for v in a.windows.split(",")]
    variants = a.variants.split(",")
    rows = []
    for name in a.cases.split(","):
        src = a.src or a.out
        h = wc.images(name, src, bins, env, windows) if a.src is None else dict(
            np.load(os.path.join(src, "cache", name.replace(":", "_") + ".npz")))
        cache = os.path.join(a.out, "cache", name.replace(":", "_") + ".npz")
        mine = dict(np.load(cache)) if os.path.exists(cache) else {}
        grid, pos, vals, seed, exact, truth = wc.load_case(name, src, bins, env)
        vals = np.asarray(vals, np.float32).reshape(len(pos), -1)
        t = h["truth"]
        e0 = wc.mse(h["whole"], t)
        scale = vals.astype(np.float64).mean(0)
        T = grid[2]
        for N in windows:
            row = {"case": name, "windows": N, "whole MSE": f"{e0:.3e}",
                   "windows' image": wc.mse(h[f"w{N}"], t) / e0, "binned": wc.mse(h[f"b{N}"], t) / e0}
            # the window's length as the layout makes it: read from one tile
            r0 = csi.reconstruct_tile(pos[:1], vals[:1], grid, 0, scale=scale, seed=seed, exact=exact, tiles=0,
                                      tiles_t=N) if f"L{N}" not in mine else None
            if r0 is not None:
                mine[f"L{N}"] = np.array(int(r0.info["k"]) // (grid[0] * grid[1]))  # one x/y tile: k = W H L
                r0.close()
            b = int(mine[f"b{N}"]) if f"b{N}" in mine else None
            t0 = time.perf_counter()
            if f"cf{N}" not in mine:
                L = int(mine[f"L{N}"])
                b = bin_frames(T, L)
                mine[f"b{N}"] = np.array(b)
                mine[f"cf{N}"], mine[f"ci{N}"] = binned_solve(grid, pos, vals, seed, exact, b)
                np.savez(cache, **mine)
            row["b"] = b
            row["binned (here)"] = wc.mse(mine[f"ci{N}"], t) / e0
            if a.check and f"wchk{N}" not in mine:
                mine[f"wchk{N}"], _ = windows_image(grid, pos, vals, seed, exact, N, scale)
                np.savez(cache, **mine)
            if a.check:
                row["check: windows here - cached (max)"] = float(np.abs(mine[f"wchk{N}"] - h[f"w{N}"]).max())
            if any(v.startswith("rev") for v in variants):
                # the other order: the windows first (their blended frames), then the binned
                # shutter's solve of the samples' residuals against those frames
                if f"wf{N}" not in mine:
                    r = csi.reconstruct(pos, vals, grid, seed=seed, exact=exact, tiles=0, tiles_t=N, frames=True)
                    mine[f"wf{N}"] = r.frames.astype(np.float64)
                    mine[f"wi{N}"] = r.image.astype(np.float64)
                    r.close()
                    np.savez(cache, **mine)
                wf = mine[f"wf{N}"]
                px, py = pos[:, 0] // (grid[0] // grid[3]), pos[:, 1] // (grid[1] // grid[4])
                for v in [v for v in variants if v.startswith("rev")]:
                    mult = float(v[3:]) if len(v) > 3 else 1.0
                    key = f"{v}{N}"
                    if key + "f" not in mine:
                        res = (vals.astype(np.float64) - wf[pos[:, 2], py, px]).astype(np.float32)
                        mine[key + "f"], mine[key + "i"] = binned_solve(grid, pos, res, seed, exact, b, scale * mult)
                        np.savez(cache, **mine)
                    _, bmean = coarse_at(mine[key + "f"], grid, pos[:1], b, "const")
                    wmean = wf.mean(0)
                    row[v + " (frames + res image)"] = wc.mse(wmean + mine[key + "i"], t) / e0
                    row[v + " (frames + res frames)"] = wc.mse(wmean + bmean, t) / e0
                    row[v + " (image + res frames)"] = wc.mse(mine[f"wi{N}"] + bmean, t) / e0
                row["windows' frames mean"] = wc.mse(wf.mean(0), t) / e0
            if any(v.startswith("x") for v in variants) and f"cf0_{N}" not in mine:
                # cross-fitted coarse volumes: each fold's samples take their residual against
                # the coarse volume of the other fold (the coarse's error where it has no sample)
                fold = wc.folds(pos, grid)[0] & 1
                for f in (0, 1):
                    m = fold == f
                    mine[f"cf{f}_{N}"], _ = binned_solve(grid, pos[m], vals[m], seed, exact, b)
                mine[f"fold{N}"] = fold
                np.savez(cache, **mine)
            for v in [v for v in variants if v.startswith("x")]:
                key = f"{v}{N}"
                mode = "lin" if v.startswith("xlin") else "const"
                fold = mine[f"fold{N}"]
                at = np.empty_like(vals, dtype=np.float64)
                cmean = 0
                for f in (0, 1):
                    m = fold == f
                    at[m], cm = coarse_at(mine[f"cf{1 - f}_{N}"], grid, pos[m], b, mode)
                    cmean = cmean + cm / 2
                if key not in mine:
                    res = (vals.astype(np.float64) - at).astype(np.float32)
                    mine[key], _ = windows_image(grid, pos, res, seed, exact, N, scale)
                    np.savez(cache, **mine)
                row[v] = wc.mse(cmean + mine[key], t) / e0
                row[v + " coarse alone"] = wc.mse(cmean, t) / e0
                _, cfull = coarse_at(mine[f"cf{N}"], grid, pos[:1], b, mode)
                row[v + " on the full coarse"] = wc.mse(cfull + mine[key], t) / e0
            for v in [v for v in variants if not v.startswith("rev") and not v.startswith("x")]:
                key = f"{v}{N}"
                mode = "lin" if v.startswith("lin") else "const"
                at, cmean = coarse_at(mine[f"cf{N}"], grid, pos, b, mode)
                if key not in mine:
                    res = (vals.astype(np.float64) - at).astype(np.float32)
                    tail = v[3:] if v.startswith("lin") else v[5:]
                    sc = scale * (float(tail) if tail else 1.0)
                    mine[key], _ = windows_image(grid, pos, res, seed, exact, N, sc)
                    np.savez(cache, **mine)
                row[v] = wc.mse(cmean + mine[key], t) / e0
                row[v + " coarse alone"] = wc.mse(cmean, t) / e0
                row[v + " on the binned image"] = wc.mse(mine[f"ci{N}"] + mine[key], t) / e0
            row["s"] = round(time.perf_counter() - t0, 1)
            rows.append(row)
            bc.log(f"{name} {N}w: " + "; ".join(f"{k} {v:.4f}" if isinstance(v, float) else f"{k} {v}"
                                               for k, v in row.items()))
            bs.write_csv(os.path.join(a.out, "windows_twolevel.csv"), rows)
    cols = list(rows[0])
    print("| " + " | ".join(cols) + " |")
    print("|" + "---|" * len(cols))
    for row in rows:
        print("| " + " | ".join(f"{row.get(k, ''):.3f}" if isinstance(row.get(k), float) else str(row.get(k, ''))
                                for k in cols) + " |")


if __name__ == "__main__":
    main()
