#!/usr/bin/env python3
"""A per-region choice between the time windows' image and the binned shutter's image (issue 11).

For each volume and window count N: the whole's image, the N windows' image (the default), the
binned shutter's image (tile_image_binned on), and both again from each of two folds of the
samples (each pixel's samples in t order, alternately fold 0 and fold 1), all through the library
(csi.reconstruct), cached in OUT/cache/*.npz. Then, in numpy, rules that pick per region of r x r
pixels which of the two full-sample images to keep:

  oracle    the truth decides (the best any per-region choice of the two can do)
  oblend    the least-squares weight of the binned image per region, from the truth ("best
            blend": over the whole image); half: the two images' mean
  cv        two-fold cross-validation, as host/integrate/cv_select.c does for csi against the
            mean: in each pixel with samples in both folds, d_f = (W_f - m_g)^2 - (B_f - m_g)^2,
            W_f and B_f the windows' and binned images made from fold f, m_g the other fold's
            pixel mean (independent of fold f's images, so E[d_f] is the difference of their
            MSEs against the pixel's mean over t); the binned image where the sum of d over a
            region is positive (cv), or only where both folds' sums are above z times their
            spread (cvz, the cv_select rule with the windows as the fallback), or the windows only
            where both folds say so (cvzb, the binned as the fallback); cvblend: the
            least-squares weight per region against the other fold's pixel means
  cv4       (--quarters) four folds (each pixel's samples in t order dealt 0, 1, 2, 3, 0, ...):
            each image made from three of them and scored against the fourth's pixel means, the
            four d summed; the binned image where the region's sum is positive (cv4) or above z
            times the root of its sum of squares (cvz4)

Volumes: billiards and train 64x64 x 256 at 16 spp (the dumps and 256-spp references as
windows_still.py makes them), billiards128 / train128 (128x128 x 64 / 32, 4 spp), the disc
(seeds 0-4), pan and pan+disc (seeds 0-1) of bench_scale.py's windows set, and
windows_heldout.py's bounce, bar, mixed and flicker (seeds 1-2).

    .venv/bin/python tools/bench/windows_choice.py --out OUT --cases billiards,bounce:1 --windows 2,4,8

Logs one line per case and window count (each image's MSE over the whole's), prints the table
in markdown and writes it to OUT/windows_choice.csv with the share of pixels each rule gave the
binned image.
"""
import argparse
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
import windows_heldout as wh  # noqa: E402

import csi  # noqa: E402


def load_case(name, out, bins, env):
    """grid, positions, values, seed, exact, truth (H, W, C) of the case `name`."""
    kind, _, sd = name.partition(":")
    if kind == "disc":
        g, p, v, t = bs.disc_volume(int(sd))
        return g, p, v, 1, False, t
    if kind in ("pan", "pan+disc"):
        g, p, v, t = bs.pan_volume(kind, int(sd))
        return g, p, v, 1, False, t
    if kind in ("bounce", "bar", "mixed", "flicker"):
        g, p, v, t = wh.case(kind, int(sd))
        return g, p, v, 1, False, t
    scene, size, spp, extra = {
        "billiards": ("billiards", (64, 64), 16, ["--time-steps", "256"]),
        "train": ("train", (64, 64), 16, ["--time-steps", "256"]),
        "billiards128": ("billiards", (128, 128), 4, []),
        "train128": ("train", (128, 128), 4, []),
    }[kind]
    work = os.path.join(out, "work", kind)
    os.makedirs(work, exist_ok=True)
    with open(os.path.join(out, "windows_choice.log"), "a") as logf:
        path, dump = bs.make_dump(bins, env, scene, size, spp, work, logf, extra=extra)
        ref = bs.reference(bins, env, path, work, logf)
    d = csi.read_dump(dump)
    return d.grid, d.positions, d.values, d.seed, d.exact, ref.astype(np.float64)


def folds(pos, grid):
    """Each sample's rank within its pixel in (t, y, x) order, and its pixel: fold rank & 1 of two,
    rank & 3 of four."""
    bw, bh = grid[0] // grid[3], grid[1] // grid[4]
    pix = (pos[:, 1] // bh).astype(np.int64) * grid[3] + pos[:, 0] // bw
    order = np.lexsort((pos[:, 0], pos[:, 1], pos[:, 2], pix))
    sp = pix[order]
    start = np.r_[0, np.flatnonzero(np.diff(sp)) + 1]
    rank = np.arange(len(sp)) - np.repeat(start, np.diff(np.r_[start, len(sp)]))
    f = np.empty(len(pos), np.int64)
    f[order] = rank
    return f, pix


def images(name, out, bins, env, windows, quarters=False):
    """The cached images of `name`: truth, whole, and per N: windows, binned, and both per fold
    (quarters: also both from each three quarters of the samples, four folds)."""
    cache = os.path.join(out, "cache", name.replace(":", "_") + ".npz")
    have = dict(np.load(cache)) if os.path.exists(cache) else {}
    need = ["whole"] + [f"{k}{N}" for N in windows for k in ("w", "b", "w0_", "w1_", "b0_", "b1_")]
    if quarters:
        need += [f"{k}q{q}_{N}" for N in windows for k in "wb" for q in range(4)]
    if all(k in have for k in need):
        return have
    grid, pos, vals, seed, exact, truth = load_case(name, out, bins, env)
    rank, pix = folds(pos, grid)
    fold, quarter = rank & 1, rank & 3
    npx = grid[3] * grid[4]
    C = vals.shape[1]
    have["truth"] = truth
    for f in (0, 1):
        m = fold == f
        cnt = np.bincount(pix[m], minlength=npx).astype(np.float64)
        s = np.stack([np.bincount(pix[m], weights=vals[m, c].astype(np.float64), minlength=npx) for c in range(C)], 1)
        have[f"cnt{f}"] = cnt
        have[f"sum{f}"] = s
    for q in range(4):
        m = quarter == q
        have[f"qcnt{q}"] = np.bincount(pix[m], minlength=npx).astype(np.float64)
        have[f"qsum{q}"] = np.stack([np.bincount(pix[m], weights=vals[m, c].astype(np.float64), minlength=npx)
                                     for c in range(C)], 1)

    def rec(p, v, **kw):
        t0 = time.perf_counter()
        r = csi.reconstruct(p, v, grid, seed=seed, exact=exact, **kw)
        return r.image.astype(np.float64), time.perf_counter() - t0

    if "whole" not in have:
        have["whole"], have["whole_s"] = rec(pos, vals, tiles=1, tiles_t=1)
    for N in windows:
        for k, kw in (("w", {}), ("b", {"tile_image_binned": "on"})):
            if k + str(N) not in have:
                have[f"{k}{N}"], have[f"{k}{N}_s"] = rec(pos, vals, tiles=0, tiles_t=N, **kw)
            for f in (0, 1):
                key = f"{k}{f}_{N}"
                if key not in have:
                    m = fold == f
                    have[key], _ = rec(pos[m], vals[m], tiles=0, tiles_t=N, **kw)
            for q in range(4) if quarters else ():
                key = f"{k}q{q}_{N}"
                if key not in have:
                    m = quarter != q
                    have[key], _ = rec(pos[m], vals[m], tiles=0, tiles_t=N, **kw)
        os.makedirs(os.path.dirname(cache), exist_ok=True)
        np.savez(cache, **have)
    np.savez(cache, **have)
    return have


def mse(a, b):
    return float(((a - b) ** 2).mean())


def region_sum(x, r):
    """Sums of x (H, W) over r x r regions (r = 0: the whole image), broadcast back to every pixel."""
    H, W = x.shape
    r = r or max(H, W)
    rh, rw = -(-H // r), -(-W // r)
    pad = np.zeros((rh * r, rw * r))
    pad[:H, :W] = x
    s = pad.reshape(rh, r, rw, r).sum(axis=(1, 3))
    return np.repeat(np.repeat(s, r, 0), r, 1)[:H, :W]


def blends(h, N, r):
    """Per-pixel weights of the binned image: the least-squares weight per region against the
    truth (oblend) and against the other fold's pixel means (cvblend), clipped to [0, 1]."""
    t, W, B = h["truth"], h[f"w{N}"], h[f"b{N}"]
    H, Wd = t.shape[:2]
    num = region_sum(((W - t) * (W - B)).sum(-1), r)
    den = region_sum(((W - B) ** 2).sum(-1), r)
    out = {"oblend": np.clip(num / np.maximum(den, 1e-300), 0, 1)}
    num, den = 0, 0
    for f in (0, 1):
        g = 1 - f
        cnt, s = h[f"cnt{g}"].reshape(H, Wd), h[f"sum{g}"].reshape(H, Wd, -1)
        ok = (cnt > 0) & (h[f"cnt{f}"].reshape(H, Wd) > 0)
        m = s / np.maximum(cnt, 1)[..., None]
        Wf, Bf = h[f"w{f}_{N}"], h[f"b{f}_{N}"]
        num = num + region_sum(((Wf - m) * (Wf - Bf)).sum(-1) * ok, r)
        den = den + region_sum(((Wf - Bf) ** 2).sum(-1) * ok, r)
    out["cvblend"] = np.clip(num / np.maximum(den, 1e-300), 0, 1)
    return out


def choices(h, N, r, z):
    """Per-pixel masks (True: the binned image) of each rule at region side r."""
    t, W, B = h["truth"], h[f"w{N}"], h[f"b{N}"]
    H, Wd = t.shape[:2]
    out = {"oracle": region_sum(((W - t) ** 2 - (B - t) ** 2).sum(-1), r) > 0}
    d, ss = [], []
    for f in (0, 1):
        g = 1 - f
        cnt, s = h[f"cnt{g}"].reshape(H, Wd), h[f"sum{g}"].reshape(H, Wd, -1)
        ok = (cnt > 0) & (h[f"cnt{f}"].reshape(H, Wd) > 0)
        m = s / np.maximum(cnt, 1)[..., None]
        df = (((h[f"w{f}_{N}"] - m) ** 2 - (h[f"b{f}_{N}"] - m) ** 2).sum(-1)) * ok
        d.append(region_sum(df, r))
        ss.append(np.sqrt(region_sum(df ** 2, r)))
    out["cv"] = d[0] + d[1] > 0
    out["cvz"] = (d[0] > z * ss[0]) & (d[1] > z * ss[1])
    out["cvzb"] = ~((d[0] < -z * ss[0]) & (d[1] < -z * ss[1]))
    if "wq0_%d" % N in h:  # four folds: images of three quarters scored against the fourth's pixel means
        d4, s4 = 0, 0
        for q in range(4):
            cnt, s = h[f"qcnt{q}"].reshape(H, Wd), h[f"qsum{q}"].reshape(H, Wd, -1)
            ok = cnt > 0
            m = s / np.maximum(cnt, 1)[..., None]
            dq = (((h[f"wq{q}_{N}"] - m) ** 2 - (h[f"bq{q}_{N}"] - m) ** 2).sum(-1)) * ok
            d4 = d4 + region_sum(dq, r)
            s4 = s4 + region_sum(dq ** 2, r)
        out["cv4"] = d4 > 0
        out["cvz4"] = d4 > z * np.sqrt(s4)
    return out


COLUMNS = (  # (column, rule, region side, z)
    ("oracle r8", "oracle", 8, 0), ("oracle r16", "oracle", 16, 0), ("best blend", "oblend", 0, 0),
    ("cv r8", "cv", 8, 0), ("cvz r8 z1.5", "cvz", 8, 1.5), ("cvz r8 z1", "cvz", 8, 1.0),
    ("cvz r4 z1", "cvz", 4, 1.0), ("cvz r16 z1.5", "cvz", 16, 1.5), ("cvzb r8 z1.5", "cvzb", 8, 1.5),
    ("cvblend r8", "cvblend", 8, 0))
QUARTER_COLUMNS = (("cv4 r8", "cv4", 8, 0), ("cvz4 r8 z1", "cvz4", 8, 1.0), ("cvz4 r8 z1.5", "cvz4", 8, 1.5),
                   ("cv4 r16", "cv4", 16, 0))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--cases", default="billiards")
    ap.add_argument("--windows", default="2,4,8")
    ap.add_argument("--quarters", action="store_true", help="also the four-fold rules (8 more solves a count)")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    bins, env = bs.binaries(), bc.default_env()
    windows = [int(v) for v in a.windows.split(",")]
    rows = []
    for name in a.cases.split(","):
        h = images(name, a.out, bins, env, windows, a.quarters)
        t = h["truth"]
        e0 = mse(h["whole"], t)
        for N in windows:
            W, B = h[f"w{N}"], h[f"b{N}"]
            row = {"case": name, "windows": N, "whole MSE": f"{e0:.3e}", "windows' image": mse(W, t) / e0,
                   "binned": mse(B, t) / e0, "half": mse((W + B) / 2, t) / e0}
            for col, rule, r, z in COLUMNS + (QUARTER_COLUMNS if a.quarters else ()):
                if rule in ("oblend", "cvblend"):
                    wb = blends(h, N, r)[rule][..., None]
                else:
                    wb = choices(h, N, r, z)[rule][..., None].astype(np.float64)
                row[col] = mse(wb * B + (1 - wb) * W, t) / e0
                row[col + " binned share"] = float(wb.mean())
            rows.append(row)
            bc.log(f"{name} {N}w: " + "; ".join(f"{k} {v:.3f}" if isinstance(v, float) else f"{k} {v}"
                                               for k, v in row.items() if "share" not in k))
            bs.write_csv(os.path.join(a.out, "windows_choice.csv"), rows)
    cols = [k for k in rows[0] if "share" not in k]
    print("| " + " | ".join(cols) + " |")
    print("|" + "---|" * len(cols))
    for row in rows:
        print("| " + " | ".join(f"{row[k]:.3f}" if isinstance(row[k], float) else str(row[k]) for k in cols) + " |")


if __name__ == "__main__":
    main()
