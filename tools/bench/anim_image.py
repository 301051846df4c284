#!/usr/bin/env python3
"""The motion-blurred image estimated directly (issue 12, session 10; measured in
docs/bench/animation.md): a second estimator of the image beside csi's volume solve, and a
per-region choice between the two by two-fold cross-validation.

The image is the mean over t of the frames, a smoother signal than the frames. Every sample
(x, y, t) at a uniformly random cell is an unbiased point sample of the blurred image at pixel
(x, y), the randomness of t acting as noise. So the samples binned in t can be solved on their
own, with the volume solve kept for the frames:

  binK   the samples' shutter merged into K equal bins (samples sharing an (x, y, bin) cell
         averaged, as csi's binned shutter does: host/integrate/binned.c, whose sampling
         operator takes one value per cell), solved by csi's defaults on the W x H x K grid;
         its image. K = 1 is Alg. 1 (2-D csi, with its noise-aware blend) on the per-pixel means.
  gauss2d (--g2d) the oracle-tuned 2-D Gaussian normalized convolution of the samples projected
         to x, y (t treated as noise).
  cvK    per region, csi's default image or binK's (cvK+K': or the better of binK's and binK''s), whichever a two-fold cross-validation of the
         pixel integrals says is closer: each pixel's samples split in two folds (alternately in
         t order, the first fold by the pixel's parity), both estimators reconstructed from each
         fold and scored against the other fold's pixel means; D = (binK_A - m_B)^2 -
         (default_A - m_B)^2 summed over both directions (its expectation is the difference of
         the two estimators' errors in the pixel integral: m_B's noise cancels). A region of
         R x R pixels takes binK's image only when each direction's sum is below -z times the
         root of the sum of its pixels' squared D (z = 1.5, R = 8 or 2R lose: the rule and the
         thresholds of host/integrate/cv_select.c and csi/cv_select.h, there between the image
         and the per-pixel mean).

Cases are bench_animation.py's (the same samples, truth and oracle-tuned 3-D Gaussian):

    .venv/bin/python tools/bench/anim_image.py --volumes pan,pan+disc --rates 0.01,0.03,0.1 \\
        --seeds 0,1,2 --size 64x64x16 --out OUT
    .venv/bin/python tools/bench/anim_image.py --scenes anim_ball --mitsuba-size 64x64x16 \\
        --ref-spp 64 --paths 16 --rates 0.01,0.03,0.1 --seeds 0,1,2 --out OUT

The bundled moving scenes (bench_accuracy.py's billiards and train, traced by csi-render with
the dump and the cached reference of that benchmark: run it first with the same size, T and the
default --ref-spp 256, so the reference is in --ref-cache):

    .venv/bin/python tools/bench/anim_image.py --bundled billiards,train --spp 1,4,16 \
        --bundled-seeds 1,2,3 --motion-size 64x64 --time-steps 32 --out OUT

Writes OUT/results.csv: per case and method the image MSE, its ratio to the tuned Gaussian's and
to csi's default image, the share of pixels that took the alternative (cv methods) and seconds.
"""
import argparse
import csv
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(HERE)), "host", "python"))

import bench_animation as ba  # noqa: E402

import csi  # noqa: E402

CV_Z = 1.5       # csi/cv_select.h's CSI_CV_Z
CV_REGION = 8    # csi/cv_select.h's CSI_CV_REGION (and twice that side)


def binned(pos, vals, shape, bins):
    """The samples on a shutter of `bins` equal bins: (positions (m, 3), values (m, C)), samples
    sharing an (x, y, bin) cell averaged; cells in linear order (deterministic)."""
    T, H, W = shape
    x, y, t = (pos[:, i].astype(np.int64) for i in range(3))
    key = ((t * bins // T) * H + y) * W + x
    u, inv, cnt = np.unique(key, return_inverse=True, return_counts=True)
    v = np.stack([np.bincount(inv, weights=vals[:, c].astype(np.float64), minlength=len(u))
                  for c in range(vals.shape[1])], 1) / cnt[:, None]
    b, r = np.divmod(u, H * W)
    yy, xx = np.divmod(r, W)
    return np.stack([xx, yy, b], 1).astype(np.uint32), v.astype(np.float32)


def image_binned(pos, vals, shape, bins):
    """binK's image (H, W, C): csi's defaults on the binned shutter."""
    T, H, W = shape
    p, v = binned(pos, vals, shape, bins)
    return csi.reconstruct(p, v, (W, H, bins, W, H)).image.astype(np.float64)


def image_default(pos, vals, shape):
    T, H, W = shape
    return csi.reconstruct(pos, vals, (W, H, T, W, H)).image.astype(np.float64)


def folds(pos, shape, k=2):
    """Each pixel's samples in turn to folds 0, 1, ..., k - 1 in t order, the first by (x + y)
    mod k (k = 2: the pixel's parity): about 1/k of every pixel's samples in each, independent of
    the values."""
    T, H, W = shape
    x, y, t = (pos[:, i].astype(np.int64) for i in range(3))
    pix = y * W + x
    order = np.lexsort((t, pix))
    ps = pix[order]
    start = np.r_[0, np.flatnonzero(np.diff(ps)) + 1]
    rank = np.arange(len(ps)) - np.repeat(start, np.diff(np.r_[start, len(ps)]))
    f = np.empty(len(pos), np.int64)
    f[order] = (rank + (x[order] + y[order])) % k
    return f


def pixel_means(pos, vals, shape):
    """(H, W, C) per-pixel means and (H, W) counts."""
    T, H, W = shape
    pix = pos[:, 1].astype(np.int64) * W + pos[:, 0]
    cnt = np.bincount(pix, minlength=H * W).astype(np.float64)
    s = np.stack([np.bincount(pix, weights=vals[:, c].astype(np.float64), minlength=H * W)
                  for c in range(vals.shape[1])], 1)
    return (s / np.maximum(cnt, 1)[:, None]).reshape(H, W, -1), cnt.reshape(H, W)


def region_sums(a, r):
    H, W = a.shape
    hh, ww = -(-H // r) * r, -(-W // r) * r
    p = np.zeros((hh, ww))
    p[:H, :W] = a
    return p.reshape(hh // r, r, ww // r, r).sum(axis=(1, 3))


def gauss2d_oracle(pos, vals, shape, ref):
    """The 2-D Gaussian normalized convolution of the samples projected to x, y (t treated as
    noise; periodic, as bench_animation's 3-D one), its width the best of bench_animation's sweep
    against the truth."""
    T, H, W = shape
    fy, fx = np.fft.fftfreq(H)[:, None], np.fft.fftfreq(W)[None, :]
    den = np.zeros((H, W))
    np.add.at(den, (pos[:, 1], pos[:, 0]), 1.0)
    best = None
    for sg in ba.GAUSS_SIGMAS:
        g = np.exp(-2 * np.pi ** 2 * sg ** 2 * (fy ** 2 + fx ** 2))
        filt = lambda a: np.real(np.fft.ifft2(np.fft.fft2(a) * g))  # noqa: E731
        d = filt(den)
        out = np.empty((H, W, vals.shape[1]))
        for c in range(vals.shape[1]):
            num = np.zeros((H, W))
            np.add.at(num, (pos[:, 1], pos[:, 0]), vals[:, c].astype(np.float64))
            out[..., c] = filt(num) / np.maximum(d, 1e-12)
        e = float(np.mean((out - ref) ** 2))
        if best is None or e < best[0]:
            best = (e, out)
    return best[1]


def cv_choice(pos, vals, shape, bins, z=CV_Z, region=CV_REGION, nfolds=2):
    """(H, W) int: per pixel the index into `bins` of the binned estimator that wins against
    csi's default image by the folds, -1 where none does. Each fold's samples are held out in
    turn, both estimators made from the others. A region of side `region` (then, where none wins
    there, of twice the side) takes, among the estimators whose sums (one per fold) are all below
    -z times the root of the sum of its pixels' squared D, the one with the smallest total."""
    T, H, W = shape
    f = folds(pos, shape, nfolds)
    d = [[None] * nfolds for _ in bins]
    for a in range(nfolds):
        ia, ib = f != a, f == a
        m_b, n_b = pixel_means(pos[ib], vals[ib], shape)
        e_def = image_default(pos[ia], vals[ia], shape)
        for j, k in enumerate(bins):
            e_alt = image_binned(pos[ia], vals[ia], shape, k)
            d[j][a] = np.where(n_b > 0, np.sum((e_alt - m_b) ** 2 - (e_def - m_b) ** 2, axis=2), 0.0)
    choice = np.full((H, W), -1)
    for r in (region, 2 * region):
        best = np.full(region_sums(np.zeros((H, W)), r).shape, -1)
        best_s = np.zeros(best.shape)
        for j in range(len(bins)):
            sums = [region_sums(d[j][a], r) for a in range(nfolds)]
            q = region_sums(sum(d[j]) ** 2, r)
            lim = z * np.sqrt(q)
            tot = sum(sums)
            ok = np.logical_and.reduce([sa < -lim for sa in sums]) & (q > 0) & (tot < best_s)
            best = np.where(ok, j, best)
            best_s = np.where(ok, tot, best_s)
        up = np.kron(best, np.ones((r, r), int))[:H, :W]
        choice = np.where(choice < 0, up, choice)
    return choice


def bundled_case(name, spp, seed, size, T, work, ref_cache):
    """A bundled moving scene: csi-render's samples (bench_accuracy.py's cs3d dump: --estimator
    mean --spp S --seed s --time-steps T) and that benchmark's cached reference image."""
    import glob

    import bench_common as bc

    scene, shash = bc.scene_variant(name, size, work)
    refs = glob.glob(os.path.join(ref_cache, f"{name}_{size[0]}x{size[1]}_T{T}_r256_{shash}_*.npz"))
    if len(refs) != 1:
        sys.exit(f"anim_image: {ref_cache}: {len(refs)} references of {name} {size} T={T} (run bench_accuracy.py first)")
    ref = np.load(refs[0])["image"].astype(np.float64)
    dump = os.path.join(work, f"{name}_s{spp}_r{seed}.csid")
    bins = bc.binaries()
    bc.run([bins["csi-render"], scene, "-o", dump[:-5] + ".exr", "-q", "--spp", str(spp), "--seed", str(seed),
            "--time-steps", str(T), "--estimator", "mean", "--dump", dump, "--threads", "1"], bc.default_env())
    d = csi.read_dump(dump)
    os.remove(dump)
    os.remove(dump[:-5] + ".exr")
    W, H, t = d.grid[:3]
    return d.positions.astype(np.uint32), d.values.astype(np.float32), (t, H, W), ref


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ba.add_small_case_args(ap)
    ap.add_argument("--bins", default="1,2,4", help="binK estimators")
    ap.add_argument("--cv-bins", default="4", help="cv choices: comma list of K or K+K'+... (candidates)")
    ap.add_argument("--folds", type=int, default=2, help="folds of the cv choices (2: the engine's)")
    ap.add_argument("--g2d", action="store_true", help="also the oracle-tuned 2-D Gaussian of the projected samples")
    ap.add_argument("--bundled", default="", help="bundled moving scenes (csi-render), e.g. billiards,train")
    ap.add_argument("--spp", default="1,4,16")
    ap.add_argument("--bundled-seeds", default="1,2,3")
    ap.add_argument("--motion-size", default="64x64")
    ap.add_argument("--time-steps", type=int, default=32)
    ap.add_argument("--ref-cache", default=os.path.join(os.path.expanduser("~"), ".cache", "csi", "bench-ref"))
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    size = tuple(int(v) for v in a.size.split("x"))
    msize = tuple(int(v) for v in a.mitsuba_size.split("x"))
    bins = [int(k) for k in a.bins.split(",") if k]
    cvb = [[int(k) for k in c.split("+")] for c in a.cv_bins.split(",") if c]
    bsize = tuple(int(v) for v in a.motion_size.split("x"))
    cases = [("procedural", n) for n in a.volumes.split(",") if n] + [("mitsuba", n) for n in a.scenes.split(",") if n]
    jobs = [(src, n, int(s), float(r)) for src, n in cases for s in a.seeds.split(",") for r in a.rates.split(",")]
    jobs += [("bundled", n, int(s), int(spp)) for n in a.bundled.split(",") if n for spp in a.spp.split(",")
             for s in a.bundled_seeds.split(",")]
    work = os.path.join(a.out, "work")
    with open(os.path.join(a.out, "results.csv"), "w", newline="") as fcsv:
        w = csv.DictWriter(fcsv, fieldnames=["source", "case", "seed", "rate", "n", "method", "img_mse", "over_gauss",
                                             "over_default", "alt_share", "seconds"])
        w.writeheader()
        for src, name, seed, rate in jobs:
            res = {}
            if src == "bundled":
                os.makedirs(work, exist_ok=True)
                pos, vals, shape, ref = bundled_case(name, rate, seed, bsize, a.time_steps, work,
                                                     a.ref_cache)
                label = f"{name} {rate} spp s{seed}"
            else:
                case = (ba.procedural_case(name, seed, rate, size, os.path.join(a.data, "procedural"))
                        if src == "procedural" else
                        ba.mitsuba_case(name, seed, rate, msize, a.data, a.ref_spp, a.paths))
                pos, vals, shape, ref = case.pos, case.vals, case.shape, case.truth.astype(np.float64).mean(axis=0)
                label = case.label
                t0 = time.perf_counter()
                gi, _, _, _ = ba.run_gauss(case)
                res["gauss"] = (gi, None, time.perf_counter() - t0)
            if a.g2d:
                t0 = time.perf_counter()
                res["gauss2d"] = (gauss2d_oracle(pos, vals, shape, ref), None, time.perf_counter() - t0)
            t0 = time.perf_counter()
            dimg = image_default(pos, vals, shape)
            res["csi"] = (dimg, None, time.perf_counter() - t0)
            for k in bins:
                t0 = time.perf_counter()
                res[f"bin{k}"] = (image_binned(pos, vals, shape, k), None, time.perf_counter() - t0)
            for ks in cvb:
                t0 = time.perf_counter()
                alts = [res[f"bin{k}"][0] if k in bins else image_binned(pos, vals, shape, k) for k in ks]
                ch = cv_choice(pos, vals, shape, ks, nfolds=a.folds)
                img = dimg.copy()
                for j, alt in enumerate(alts):
                    img = np.where((ch == j)[..., None], alt, img)
                res["cv" + "+".join(map(str, ks)) + (f"f{a.folds}" if a.folds != 2 else "")] = (img, float((ch >= 0).mean()), time.perf_counter() - t0)
            err = {m: float(np.mean((r[0] - ref) ** 2)) for m, r in res.items()}
            g, d = err.get("gauss", float("nan")), err["csi"]
            for m, (_, share, sec) in res.items():
                w.writerow({"source": src, "case": name, "seed": seed, "rate": rate, "n": len(vals), "method": m,
                            "img_mse": err[m], "over_gauss": err[m] / g, "over_default": err[m] / d,
                            "alt_share": share if share is not None else "", "seconds": round(sec, 3)})
            fcsv.flush()
            ba.log(f"{label}: " + "  ".join(f"{m} {err[m] / d:.3f}" + (f" ({r[1]:.2f})" if r[1] is not None else "")
                                            for m, r in res.items()) + " (over csi's default)")


if __name__ == "__main__":
    main()
