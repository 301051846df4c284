#!/usr/bin/env python3
"""csi composed with Intel Open Image Denoise, decided from the samples alone, against OIDN alone
(issue 9's "beyond" target; docs/bench/mitsuba.md, session 25: measured, not kept).

Step 1 (--cache DIR): for each cached Mitsuba dump of DATA (tools/bench/mitsuba_data.py), the
images every rule below is made from, in DIR/<tag>.npz: the per-pixel mean, csi (the library's
defaults, each sample's variance where the dump has it, as csi-reconstruct), the guides (per-pixel
means of the albedo and normal dumps), OIDN (pyoidn, HDR, quality high) on the mean and on csi's
image, each with and without the guides; and the same from each of two folds of the samples (csi/cv_select.h's split:
each pixel's block cut into k x k squares, k = ceil(sqrt(n)), a sample's fold the parity of its
square), with each fold's pixel means and sample counts; and each pixel's smallest and largest
sample, the spread of its samples and, with several paths per sample, its mean's path variance.

Step 2 (--eval DIR[,DIR...]): per cell, MSE / relMSE of each composition below as a ratio to the
better OIDN alone in that figure (the lower of OIDN on the mean with and without the guides);
below 1 in both, the composition beats OIDN alone. The composition (`csi+oidn`), decided from the
samples alone:
  1. four OIDN images: on the mean and on csi's image, each with and without the guides;
  2. S: their convex combination whose weights fit, by least squares over both folds, each fold's
     four images to the other fold's pixel means (two-fold cross-validation: the held-out means'
     noise is independent of the fitted images, so the fit's expected loss is the combination's
     squared error plus a constant; stacking, Breiman 1996). This is a fit of the MSE, which the
     bright pixels carry. E: the four images' plain mean (an ensemble: lower variance in the dark
     pixels that carry the relMSE, where the held-out means are too noisy to fit weights);
  3. the base: S in bright pixels, E in dark ones (a smooth step of E's luminance in log between
     0.3 and 3);
  4. csi's image instead of the base, with a smooth weight, where the samples contradict OIDN:
     (A) the pixel's smallest sample is 1.5-3x above the base (luminance, the smallest sample at
     least 1): OIDN dimmed a highlight or an emitter that every sample of the pixel sees; (B) the
     base is 1.5-3x above the pixel's largest sample (+ 1e-3) next to a pixel whose mean is 10x
     the base (5x5): OIDN spread a bright neighbour's light over a dark pixel.
`mean+oidn` is the same without csi (the two OIDN images on the mean, the mean for csi in A, B),
what the rule gives without csi; `csi>oidn` is OIDN on csi's image alone. --parts adds the
composition's steps (E, S, base), OIDN with guides on csi's image and the compositions measured
before this one (tried()). On 64 development cells the composition beats OIDN alone in both
figures in 28, on 36 held-out cells in 14 (the doc's section has the tables).

    .venv/bin/python tools/bench/oidn_cv.py --data /work/mdata --cache C1    # then
    .venv/bin/python tools/bench/oidn_cv.py --eval C1,C2 --parts
"""
import argparse
import os
import re
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import oidn_compose  # noqa: E402
from bench_real_samples import SCENES, cells, errors  # noqa: E402


def oidn(color, albedo=None, normal=None):
    return oidn_compose.oidn(color, albedo, normal).astype(np.float32)


def pixel_of(pos, grid):
    bw, bh = grid[0] // grid[3], grid[1] // grid[4]
    return (pos[:, 1] // bh).astype(np.int64) * grid[3] + pos[:, 0] // bw


def folds(pos, grid):
    """csi_cv_folds (host/integrate/cv_select.c): each sample's fold, 0 or 1."""
    bw, bh = grid[0] // grid[3], grid[1] // grid[4]
    pix = pixel_of(pos, grid)
    cnt = np.bincount(pix, minlength=grid[3] * grid[4])[pix]
    k = np.ceil(np.sqrt(cnt)).astype(np.int64)
    k = np.where((k - 1) ** 2 >= cnt, k - 1, k)
    k = np.where(k * k < cnt, k + 1, k)
    sx = (pos[:, 0] % bw).astype(np.int64) * k // bw
    sy = (pos[:, 1] % bh).astype(np.int64) * k // bh
    return ((sx + sy) & 1).astype(np.uint8)


def means(pos, values, grid):
    """(per-pixel mean (h, w, c) with 0 where a pixel has no sample, counts (h, w))."""
    ow, oh = grid[3], grid[4]
    pix = pixel_of(pos, grid)
    cnt = np.bincount(pix, minlength=ow * oh).astype(np.float64)
    s = np.stack([np.bincount(pix, weights=values[:, c].astype(np.float64), minlength=ow * oh)
                  for c in range(values.shape[1])], -1)
    m = np.where(cnt[:, None] > 0, s / np.maximum(cnt, 1)[:, None], 0.0)
    return m.reshape(oh, ow, -1), cnt.reshape(oh, ow)


def spread(pos, values, grid, var):
    """s2: each pixel's unbiased variance of its samples (0 with fewer than 2); pv: the variance of
    its mean from each sample's own (path) variance, sum(var) / n^2 (0 without variances); both
    (h, w, c); lo, hi: the pixel's smallest and largest sample (h, w, c)."""
    ow, oh = grid[3], grid[4]
    pix = pixel_of(pos, grid)
    n = np.bincount(pix, minlength=ow * oh).astype(np.float64)
    v = values.astype(np.float64)
    s1 = np.stack([np.bincount(pix, weights=v[:, c], minlength=ow * oh) for c in range(v.shape[1])], -1)
    s2 = np.stack([np.bincount(pix, weights=v[:, c] ** 2, minlength=ow * oh) for c in range(v.shape[1])], -1)
    m = s1 / np.maximum(n, 1)[:, None]
    s2 = np.where(n[:, None] > 1, np.maximum(s2 - n[:, None] * m * m, 0) / np.maximum(n - 1, 1)[:, None], 0)
    pv = np.zeros_like(s2)
    if var is not None:
        pv = np.stack([np.bincount(pix, weights=var[:, c].astype(np.float64), minlength=ow * oh)
                       for c in range(v.shape[1])], -1) / np.maximum(n, 1)[:, None] ** 2
    lo = np.full((ow * oh, v.shape[1]), np.inf)
    hi = np.full((ow * oh, v.shape[1]), -np.inf)
    for c in range(v.shape[1]):
        np.minimum.at(lo[:, c], pix, v[:, c])
        np.maximum.at(hi[:, c], pix, v[:, c])
    lo[n == 0], hi[n == 0] = 0, 0
    r = lambda a: a.reshape(oh, ow, -1).astype(np.float32)  # noqa: E731
    return {"s2": r(s2), "pv": r(pv), "lo": r(lo), "hi": r(hi)}


def build(dump, out):
    import csi

    base = dump[: -len(".csid")]
    d = csi.read_dump(dump)
    al, nr = csi.read_dump(base + ".albedo.csid"), csi.read_dump(base + ".normal.csid")
    for g in (al, nr):
        if not np.array_equal(g.positions, d.positions):
            sys.exit(f"oidn_cv: {dump}: the guides' positions differ")
    var = None
    if os.path.exists(base + ".variance.csid"):
        var = csi.read_dump(base + ".variance.csid").values
    grid, seed = d.grid, d.seed
    img = {}

    def make(sel, tag, fill=None):
        pos, val = d.positions[sel], d.values[sel]
        m, n = means(pos, val, grid)
        a, _ = means(pos, al.values[sel], grid)
        nn, _ = means(pos, nr.values[sel], grid)
        c = csi.reconstruct(pos, val, grid, variance=None if var is None else var[sel], seed=seed).image
        if fill is not None:  # a fold's pixel without a sample: its guides from all samples, its
            hole = (n == 0)[..., None]  # colour the fold's csi (OIDN's input only)
            a, nn = np.where(hole, fill[0], a), np.where(hole, fill[1], nn)
            mo = np.where(hole, c, m)
        else:
            mo = m
        img[f"mean{tag}"], img[f"n{tag}"], img[f"csi{tag}"] = m.astype(np.float32), n.astype(np.float32), c
        img[f"alb{tag}"], img[f"nrm{tag}"] = a.astype(np.float32), nn.astype(np.float32)
        img[f"oidn{tag}"] = oidn(mo)
        img[f"oidnaux{tag}"] = oidn(mo, a, nn)
        img[f"csioidnaux{tag}"] = oidn(c, a, nn)
        img[f"csioidn{tag}"] = oidn(c)
        return a, nn

    full = make(np.ones(len(d.values), bool), "")
    img.update(spread(d.positions, d.values, grid, var))
    f = folds(d.positions, grid)
    for k in (0, 1):
        make(f == k, "AB"[k], fill=full)
    np.savez_compressed(out, **img)


LUMA = np.array([0.2126, 0.7152, 0.0722])


def lum(x):
    return x @ LUMA


def smooth(t):
    t = np.clip(t, 0, 1)
    return t * t * (3 - 2 * t)


def stack_weights(z, names):
    """Convex weights of the images `names` fitted by two-fold cross-validation (step 2 above)."""
    from scipy.optimize import nnls

    xs, ys = [], []
    for a, b in (("A", "B"), ("B", "A")):
        ok = z["n" + b] > 0
        xs.append(np.stack([z[n + a][ok].astype(np.float64).ravel() for n in names], 1))
        ys.append(z["mean" + b][ok].astype(np.float64).ravel())
    x, y = np.concatenate(xs), np.concatenate(ys)
    # the sum-to-one constraint as a heavily weighted row of a non-negative least-squares fit
    lam = 1e3 * np.sqrt(len(y)) * max(1.0, float(np.abs(y).max()))
    c, _ = nnls(np.vstack([x, lam * np.ones((1, len(names)))]), np.concatenate([y, [lam]]))
    return c


def compose(z, names, alt, parts=None):
    """The composition (steps 2-4 above) of the OIDN images `names` and the image `alt`; parts
    (a dict, optional) receives its steps' images: E, S, base."""
    from scipy.ndimage import maximum_filter

    imgs = [z[n].astype(np.float64) for n in names]
    w = stack_weights(z, names)
    s_img = sum(c * x for c, x in zip(w, imgs))
    e_img = sum(imgs) / len(imgs)
    s = smooth((np.log(np.maximum(lum(e_img), 1e-6)) - np.log(0.3)) / (np.log(3) - np.log(0.3)))[..., None]
    base = s * s_img + (1 - s) * e_img
    if parts is not None:
        parts.update({"E": e_img, "S": s_img, "base": base})
    lb = np.maximum(lum(base), 1e-6)
    lo, hi = lum(z["lo"]), lum(z["hi"])
    wa = smooth((lo / lb - 1.5) / 1.5) * (lo >= 1)
    wb = smooth((lb / (hi + 1e-3) - 1.5) / 1.5) * (maximum_filter(lum(z["mean"]), size=5) > 10 * lb)
    wt = (np.maximum(wa, wb) * (z["n"] >= 2))[..., None]
    x = z[alt].astype(np.float64)
    return base + wt * (x - base), w


def region_sum(a, r):
    """Sums of a (h, w) array over r x r regions (the last ones cut at the sides), spread back to
    every pixel of each region."""
    h, w = a.shape
    hh, ww = -(-h // r) * r, -(-w // r) * r
    p = np.zeros((hh, ww))
    p[:h, :w] = a
    t = p.reshape(hh // r, r, ww // r, r).sum((1, 3))
    return np.repeat(np.repeat(t, r, 0), r, 1)[:h, :w]


def cv_loss(z, x, rel=False):
    """Each pixel's two-fold cross-validated squared error of the image named x (its folds' images
    against the other fold's pixel means, both directions, summed over the channels); rel: each
    term over (the fold's OIDN image^2 + 0.01), a weight independent of the held-out mean."""
    t = 0
    for a, b in (("A", "B"), ("B", "A")):
        ok = (z["n" + b] > 0)[..., None]
        wt = 1 / (z["oidn" + a].astype(np.float64) ** 2 + 0.01) if rel else 1.0
        t = t + np.where(ok, (z[x + a].astype(np.float64) - z["mean" + b]) ** 2 * wt, 0).sum(-1)
    return t


def tried(z):
    """The compositions measured before the one above (docs/bench/mitsuba.md, session 25)."""
    out = {}
    # per 8x8 region, the image of the five with the lowest cross-validated squared error
    five = ["oidnaux", "oidn", "csi", "csioidn", "csioidnaux"]
    k = np.stack([region_sum(cv_loss(z, x), 8) for x in five]).argmin(0)
    out["region-cv"] = np.choose(k[..., None], [z[x].astype(np.float64) for x in five])
    # csi instead of (oidn + csi>oidn+aux) / 2 where a region of 8 or 16 pixels' cross-validated
    # squared error is lower by 1.5 x the root of its pixels' squared differences, and its relative
    # one not higher by as much (csi/cv_select.h's test)
    base = (z["oidn"].astype(np.float64) + z["csioidnaux"]) / 2
    for f in ("A", "B"):
        z["base2" + f] = (z["oidn" + f].astype(np.float64) + z["csioidnaux" + f]) / 2
    pick = np.zeros(z["n"].shape, bool)
    d_m = cv_loss(z, "csi") - cv_loss(z, "base2")
    d_r = cv_loss(z, "csi", True) - cv_loss(z, "base2", True)
    for r in (8, 16):
        pick |= ((region_sum(d_m, r) < -1.5 * np.sqrt(region_sum(d_m ** 2, r)))
                 & (region_sum(d_r, r) < 1.5 * np.sqrt(region_sum(d_r ** 2, r))))
    out["region-cv-z"] = np.where(pick[..., None], z["csi"], base)
    # per pixel, csi where both csi and the mean are 1.5-3x above OIDN with guides (smooth)
    oa = z["oidnaux"].astype(np.float64)
    r = np.minimum(lum(z["csi"]), lum(z["mean"])) / (lum(oa) + 1e-6)
    out["ratio"] = oa + smooth((r - 1.5) / 1.5)[..., None] * (z["csi"] - oa)
    # per pixel, OIDN shrunk towards csi by the mean's own noise (James-Stein's positive part):
    # w = 1 - v / |mean - oidn|^2, v = max(spread^2 / n, path variance of the mean)
    o = z["oidn"].astype(np.float64)
    v = np.maximum(z["s2"] / np.maximum(z["n"], 1)[..., None], z["pv"]).sum(-1)
    w = np.clip(1 - v / np.maximum(((z["mean"] - o) ** 2).sum(-1), 1e-30), 0, 1) * (z["n"] > 0)
    out["shrink"] = o + w[..., None] * (z["csi"] - o)
    return out


def evaluate(dirs, parts=False):
    methods = ["csi>oidn", "csi+oidn", "mean+oidn"] + (["csi>oidn+aux", "E", "S", "base", "region-cv", "region-cv-z",
                                                       "ratio", "shrink"] if parts else [])
    print("| set | scene | paths | positions | oidn / oidn+aux (to the mean) | " + " | ".join(methods)
          + " | S's weights (oidn, oidn+aux, csi>oidn, csi>oidn+aux) |")
    print("|---|---|---|---|---|" + "---|" * len(methods) + "---|")
    ratios = {d: {m: [] for m in methods} for d in dirs}
    agree = np.zeros((2, 2), int)  # [figure][the folds' true errors, the cross-validated ones]
    for d in dirs:
        for f in sorted(os.listdir(d)):
            if not f.endswith(".npz"):
                continue
            z = dict(np.load(os.path.join(d, f)))
            ref = np.load(os.path.join(d, f[:-4] + ".ref.npy")).astype(np.float64)
            scene, _, paths, pos = re.match(r"(.+)_s(\d+)_p(\d+)_(\w+)$", f[:-4]).groups()
            e0, eo, ea = errors(z["mean"], ref), errors(z["oidn"], ref), errors(z["oidnaux"], ref)
            best = (min(eo[0], ea[0]), min(eo[1], ea[1]))
            four = ["oidn", "oidnaux", "csioidn", "csioidnaux"]
            steps = {}
            comp, w = compose(z, four, "csi", steps)
            img = {"csi>oidn": z["csioidn"], "csi+oidn": comp, "mean+oidn": compose(z, ["oidn", "oidnaux"], "mean")[0],
                   "csi>oidn+aux": z["csioidnaux"], **steps}
            if parts:
                img.update(tried(z))
                # which of oidn and oidn+aux is better, as the full images' true errors say, against
                # the folds' true errors and the cross-validated errors
                for f in (0, 1):
                    full = errors(z["oidn"], ref)[f] < errors(z["oidnaux"], ref)[f]
                    folds_ = sum(errors(z["oidn" + k], ref)[f] - errors(z["oidnaux" + k], ref)[f] for k in "AB") < 0
                    cv = (cv_loss(z, "oidn", f == 1) - cv_loss(z, "oidnaux", f == 1)).sum() < 0
                    agree[f] += [full == folds_, full == cv]
            cols = []
            for m in methods:
                e = errors(img[m], ref)
                r = (e[0] / best[0], e[1] / best[1])
                ratios[d][m].append(r)
                c = f"{r[0]:.3f} / {r[1]:.3f}"
                cols.append(f"**{c}**" if r[0] < 1 and r[1] < 1 else c)
            print(f"| {os.path.basename(d.rstrip('/'))} | {scene} | {paths} | {pos} | {eo[0] / e0[0]:.3f} / {eo[1] / e0[1]:.3f}, "
                  f"{ea[0] / e0[0]:.3f} / {ea[1] / e0[1]:.3f} | " + " | ".join(cols) + " | "
                  + ", ".join(f"{c:.2f}" for c in w) + " |", flush=True)
    print()
    for m in methods:
        r = np.array([x for d in dirs for x in ratios[d][m]])
        g = np.exp(np.log(r).mean(0))
        print(f"{m}: beats OIDN alone in both figures in {int(((r[:, 0] < 1) & (r[:, 1] < 1)).sum())} of {len(r)} "
              f"cells (MSE in {int((r[:, 0] < 1).sum())}, relMSE in {int((r[:, 1] < 1).sum())}); worst "
              f"{r[:, 0].max():.3f} / {r[:, 1].max():.3f}; geometric mean {g[0]:.3f} / {g[1]:.3f}")
    if parts:
        n = sum(len(ratios[d][methods[0]]) for d in dirs)
        for f, name in ((0, "MSE"), (1, "relMSE")):
            print(f"which of oidn and oidn+aux has the lower {name}: the folds' own images (against the reference) "
                  f"agree with the full images in {agree[f][0]} of {n} cells, the cross-validated errors in {agree[f][1]}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--eval", help="evaluate these cache directories (comma-separated) and stop")
    ap.add_argument("--parts", action="store_true",
                    help="with --eval, also OIDN with guides on csi's image, the composition's steps E, S, "
                    "base and the compositions tried before it (tried())")
    ap.add_argument("--data")
    ap.add_argument("--scenes", default=",".join(SCENES))
    ap.add_argument("--spp", default="4")
    ap.add_argument("--paths", default="1,64")
    ap.add_argument("--positions", default="stratified,poisson")
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--cache", help="directory of the per-cell images")
    a = ap.parse_args()
    if a.eval:
        evaluate(a.eval.split(","), a.parts)
        return
    if not a.data or not a.cache:
        ap.error("--data and --cache, or --eval")
    os.makedirs(a.cache, exist_ok=True)
    for scene, spp, paths, pos, dump, ref in cells(a.data, a.scenes, a.spp, a.paths, a.positions,
                                                     a.reference_spp, "oidn_cv"):
        out = os.path.join(a.cache, f"{scene}_s{spp}_p{paths}_{pos}.npz")
        if not os.path.exists(out):
            build(dump, out)
            np.save(out[:-4] + ".ref.npy", ref.astype(np.float32))
        print(out, flush=True)


if __name__ == "__main__":
    main()
