#!/usr/bin/env python3
"""Animation benchmark (issue 12): csi's frames and motion-blurred image from 1-10% of the cells
of an x, y, t volume, against the oracle-tuned 3-D Gaussian, per-frame Monte Carlo, per-frame
compressive antialiasing (Alg. 1 on each frame) and per-frame OIDN, with temporal stability.

    .venv/bin/python tools/bench/bench_animation.py --out docs/bench/animation-run   # the full run
    .venv/bin/python tools/bench/bench_animation.py --quick --out /tmp/anim-quick     # minutes
    .venv/bin/python tools/bench/bench_animation.py --sources mitsuba --data DATA ...  # Mitsuba only

Sources:
  procedural  held-out-like volumes (tools/bench/anim_volumes.py: procedural photographs panned,
              discs crossing, small fast movers), exact at the cell centres; the truth is the
              volume itself.
  mitsuba     Mitsuba 3 animations (data/mitsuba/anim_pan.py: an animated camera,
              anim_ball.py: animated objects; or a scene of your own, a .py file with
              animate(params, time) given to --scenes), re-posed per time step (the bridge's
              render_request / render_reference_frames; Mitsuba has no motion blur of its own),
              sampled at csi's positions (csi-positions --method random --fraction F
              --time-steps T), PATHS paths per sample, each sample's variance beside it as
              csi-mitsuba gives it (one path's from mb.path_noise with PATHS = 1); the truth is
              Mitsuba's box-filtered render of every frame at --ref-spp (same sampler seed in
              every frame, so static pixels are identical from frame to frame, and the blurred
              image carries one frame's noise), cached in --data.

Every method gets the very same samples (uniformly random distinct cells, the paper's Alg. 2
step 2, at each --rates fraction, per --seeds):
  csi          csi's defaults (csi.reconstruct in-process, the C library)
  csi-paper    the paper's basis: --motion-time dft --motion-velocity none (csi's default before
               issue 12, with its residual correction)
  csi-unfiltered  csi's default without Alg. 1's filter in the motion solve (--motion-filter off)
  csi-imgcv    csi's default with the image chosen per region against a 4-bin shutter's solve
               (--motion-image-cv on; --methods to add it)
  csi-dft-v    candidates: the sheared basis with the DFT along t; csi-dct the DCT without a
  csi-dct      velocity (--methods to add them)
  gauss        the 3-D Gaussian normalized convolution (csi --estimator gauss), its width tuned
               by an oracle: the best of 0.5 * 1.15^j <= 6 cells against the truth, separately for
               the image and for the frames (the frames' width also gives its temporal figures)
  mc           per-frame Monte Carlo: each frame from its own samples (N / T of them on average),
               a pixel its sample, or the nearest sample of its frame where it has none; the image
               is the per-pixel mean of all samples (nearest where a pixel has none)
  mc-pixel     bench_accuracy.py's Monte Carlo frames (not per frame): a pixel's sample at t, or
               its mean over all t where it has none (--methods to add it)
  cs2d         per-frame csi 2-D: Alg. 1 (csi's defaults) on each frame's own samples (a still
               W x H grid per frame, its output the same grid); the image is their mean
  oidn         each mc frame (and the mc image) denoised by OIDN (pyoidn, HDR, colour only)
Metrics against the truth (linear values, peak 1): image MSE (the mean over t), mean per-frame
PSNR, temporal error = MSE of the frame-to-frame differences f[t+1] - f[t] against the truth's,
and flicker = mean over the truth's static pixels (identical in every frame) of the variance over
t of the estimate (reported where at least 1% of the pixels are static).

Writes OUT/results.csv (a row per case, rate, seed and method), OUT/summary.md (seed means,
ratios to the tuned Gaussian, the issue's targets checked with their margins), OUT/sheet_*.png
(contact sheets: rows reference, csi, gauss, mc, cs2d, oidn; columns frames and the mean) and
OUT/anim_*.webp (the same playing), OUT/run.json (options, machine load, times).
"""
import argparse
import csv
import json
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(ROOT, "host", "python"))

import anim_volumes as av  # noqa: E402

import csi  # noqa: E402
from csi import preview  # noqa: E402

ALL_METHODS = ["csi", "csi-paper", "csi-unfiltered", "csi-imgcv", "csi-dft-v", "csi-dct", "gauss", "mc", "mc-pixel", "cs2d", "oidn"]
DEFAULT_METHODS = ["csi", "csi-paper", "gauss", "mc", "cs2d", "oidn"]
CSI_VARIANTS = {
    "csi": {},
    "csi-paper": {"motion_time": "dft", "motion_velocity": "none", "motion_filter": -1},
    "csi-unfiltered": {"motion_filter": -1},
    "csi-imgcv": {"motion_image_cv": "on"},
    "csi-dft-v": {"motion_time": "dft"},
    "csi-dct": {"motion_time": "dct", "motion_velocity": "none"},
}
GAUSS_SIGMAS = [0.5 * 1.15 ** j for j in range(20) if 0.5 * 1.15 ** j <= 6.0]
MITSUBA_SCENES = {"anim_pan": os.path.join(ROOT, "data", "mitsuba", "anim_pan.py"),
                  "anim_ball": os.path.join(ROOT, "data", "mitsuba", "anim_ball.py")}


def add_small_case_args(ap):
    """The case options of the numpy prototypes around this benchmark (anim_segment.py,
    anim_image.py): procedural volumes and Mitsuba scenes at 64 x 64 x 16 by default."""
    ap.add_argument("--out", required=True)
    ap.add_argument("--volumes", default="")
    ap.add_argument("--scenes", default="")
    ap.add_argument("--rates", default="0.01,0.03,0.1")
    ap.add_argument("--seeds", default="0")
    ap.add_argument("--size", default="64x64x16")
    ap.add_argument("--mitsuba-size", default="64x64x16")
    ap.add_argument("--data", default=os.path.join(os.path.expanduser("~"), ".cache", "csi", "bench-anim"))
    ap.add_argument("--ref-spp", type=int, default=64)
    ap.add_argument("--paths", type=int, default=16)


def log(msg):
    print(f"[{time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)


# ---- cases: a truth volume (T, H, W, C) and samples ------------------------------------------

class Case:
    def __init__(self, source, name, seed, rate, truth, pos, vals, info=None, extra=None, variance=None):
        self.source, self.name, self.seed, self.rate = source, name, seed, rate
        self.truth = truth  # (T, H, W, C) float32
        self.pos, self.vals = pos, vals  # (n, 3) uint32 x, y, t; (n, C) float32
        self.variance = variance  # (n, C) float32: each value's variance (a renderer's), or None
        self.info = info or []
        self.extra = extra or {}

    @property
    def shape(self):
        return self.truth.shape[:3]

    @property
    def grid(self):
        T, H, W = self.shape
        return (W, H, T, W, H)

    @property
    def label(self):
        return f"{self.name} {100 * self.rate:g}% s{self.seed}"


def random_cells(shape, rate, seed):
    """Uniformly random distinct cells (Alg. 2 step 2): (n, 3) x, y, t, sorted by linear index."""
    T, H, W = shape
    k = T * H * W
    n = max(1, int(round(rate * k)))
    idx = np.sort(np.random.default_rng(seed * 7919 + 17).choice(k, n, replace=False))
    t, r = np.divmod(idx, H * W)
    y, x = np.divmod(r, W)
    return np.stack([x, y, t], axis=1).astype(np.uint32), idx


def procedural_case(name, seed, rate, size, cache):
    W, H, T = size
    path = os.path.join(cache, f"{name}_{W}x{H}x{T}_s{seed}.npz")
    if os.path.exists(path):
        z = np.load(path)
        f, info = z["f"], [tuple(v) for v in z["info"]]
    else:
        f, info = av.volume(name, W, H, T, seed)
        os.makedirs(cache, exist_ok=True)
        np.savez(path + ".tmp.npz", f=f, info=np.array(info, dtype=np.float64).reshape(-1, 2))
        os.replace(path + ".tmp.npz", path)
    pos, idx = random_cells((T, H, W), rate, seed)
    vals = f.reshape(-1)[idx][:, None].astype(np.float32)
    return Case("procedural", name, seed, rate, f[..., None], pos, vals, info)


def mitsuba_case(name, seed, rate, size, data, ref_spp, paths):
    """A Mitsuba animation: the reference frames and the samples, cached in data/<name>/."""
    from csi import dump as csid
    from csi import mitsuba_bridge as mb

    W, H, T = size
    d = os.path.join(data, name)
    os.makedirs(d, exist_ok=True)
    ref_path = os.path.join(d, f"reference_{W}x{H}x{T}_{ref_spp}.npy")
    if not os.path.exists(ref_path):
        log(f"mitsuba: {name} reference, {T} frames at {ref_spp} spp")
        scene = mb.load_scene(MITSUBA_SCENES[name], size=(W, H), box_filter=True)
        ref = mb.render_reference_frames(scene, T, ref_spp, seed=1)
        np.save(ref_path + ".tmp.npy", ref)
        os.replace(ref_path + ".tmp.npy", ref_path)
    truth = np.load(ref_path)
    dump_path = os.path.join(d, f"r{rate:g}_{W}x{H}x{T}_p{paths}_s{seed}.csid")
    meta_path = dump_path[:-5] + ".json"
    if not os.path.exists(dump_path):
        log(f"mitsuba: {name} samples, {100 * rate:g}% of {W}x{H}x{T}, {paths} paths, seed {seed}")
        scene = mb.load_scene(MITSUBA_SCENES[name], size=(W, H))
        req = mb.positions_request((W, H), grid=W, method="random", seed=seed + 1, time_steps=T, fraction=rate)
        s = mb.render_request(scene, req, paths=paths, seed=seed + 1)
        csid.write(dump_path, req.with_values(s.values))
        if paths > 1:
            csid.write(dump_path[:-5] + ".variance.csid", req.with_values(s.variance))
        with open(meta_path + ".tmp", "w") as f:
            json.dump({"timing": s.timing, "nonfinite": s.nonfinite, "paths": paths, "grid": list(req.grid)}, f)
        os.replace(meta_path + ".tmp", meta_path)
    dump = csid.read(dump_path)
    # Each sample's variance beside it, as csi-mitsuba writes it (X.variance.csid), which csi
    # reads with the samples; with one path per sample, one path's variance from a second path
    # through some of the cells (mb.path_noise, csi-mitsuba's for an animation). A dump cached before the
    # variances were kept is rendered again for them: Mitsuba gives the same values for the same
    # seed (checked).
    var_path = dump_path[:-5] + ".variance.csid"
    if not os.path.exists(var_path):
        log(f"mitsuba: {name} variances of {os.path.basename(dump_path)}")
        scene = mb.load_scene(MITSUBA_SCENES[name], size=(W, H))
        if paths > 1:
            s = mb.render_request(scene, dump, paths=paths, seed=seed + 1)
            if not np.array_equal(np.asarray(s.values, np.float32), np.asarray(dump.values, np.float32)):
                raise SystemExit(f"bench_animation: {dump_path}: Mitsuba no longer renders these values; "
                                 "remove the dump to render it again")
            var = s.variance
        else:
            from csi.mitsuba_cli import noise_seed

            v, _ = mb.path_noise(scene, dump, dump.values, seed=noise_seed(seed + 1))
            var = np.broadcast_to(v.astype(np.float32), dump.values.shape)
        csid.write(var_path, dump.with_values(var))
    variance = csid.read(var_path).values.astype(np.float32)
    meta = json.load(open(meta_path)) if os.path.exists(meta_path) else {}
    return Case("mitsuba", name, seed, rate, truth, dump.xyt.astype(np.uint32), dump.values.astype(np.float32),
                extra={"mitsuba": meta.get("timing", {}), "paths": paths}, variance=variance)


# ---- methods: each returns (image (H, W, C), frames (T, H, W, C), seconds, notes) -----------

def run_csi(case, **opts):
    t0 = time.perf_counter()
    r = csi.reconstruct(case.pos, case.vals, case.grid, frames="on", variance=case.variance, **opts)
    sec = time.perf_counter() - t0
    notes = {"iterations": max(rep["iterations"] for rep in r.reports),
             "vx": r.options.get("motion_vx"), "vy": r.options.get("motion_vy"),
             "t_velocity": r.stats.get("t_velocity_s", 0.0)}
    return r.image, r.frames, sec, notes


def gauss_nc(shape, pos, vals, sigma):
    """csi's Gaussian baseline in float64 numpy (the same periodic filter and density threshold as
    --estimator gauss), for the oracle's sweep: (T, H, W, C)."""
    T, H, W = shape
    ft = np.fft.fftfreq(T)[:, None, None]
    fy = np.fft.fftfreq(H)[None, :, None]
    fx = np.fft.rfftfreq(W)[None, None, :]
    g = np.exp(-2 * np.pi ** 2 * sigma ** 2 * (ft ** 2 + fy ** 2 + fx ** 2))
    filt = lambda a: np.fft.irfftn(np.fft.rfftn(a) * g, s=a.shape, axes=(0, 1, 2))
    den = np.zeros(shape)
    den[pos[:, 2], pos[:, 1], pos[:, 0]] = 1
    den = filt(den)
    eps = 1e-6 / (np.sqrt(2 * np.pi) * sigma) ** 3
    out = np.empty(shape + (vals.shape[1],))
    for c in range(vals.shape[1]):
        a = np.zeros(shape)
        a[pos[:, 2], pos[:, 1], pos[:, 0]] = vals[:, c]
        out[..., c] = np.where(den > eps, filt(a) / np.maximum(den, eps), 0)
    return out


def run_gauss(case):
    """The oracle: the width with the lowest image MSE and the one with the lowest mean frame MSE
    (numpy sweep), each then run by csi (--estimator gauss) and measured on csi's output."""
    t0 = time.perf_counter()
    best_i = best_f = None
    ref_img = case.truth.mean(axis=0)
    for s in GAUSS_SIGMAS:
        e = gauss_nc(case.shape, case.pos, case.vals, s)
        mi = float(np.mean((e.mean(axis=0) - ref_img) ** 2))
        mf = float(np.mean((e - case.truth) ** 2))
        if best_i is None or mi < best_i[0]:
            best_i = (mi, s)
        if best_f is None or mf < best_f[0]:
            best_f = (mf, s)
    r_i = csi.reconstruct(case.pos, case.vals, case.grid, frames="on", estimator="gauss", gauss_sigma=best_i[1])
    r_f = r_i if best_f[1] == best_i[1] else csi.reconstruct(case.pos, case.vals, case.grid, frames="on",
                                                               estimator="gauss", gauss_sigma=best_f[1])
    sec = time.perf_counter() - t0
    return r_i.image, r_f.frames, sec, {"sigma_image": best_i[1], "sigma_frames": best_f[1]}


def mc_frames(case):
    """Per-frame Monte Carlo (see the module docstring): each frame from its own samples only, an
    empty pixel taking the value of the nearest sample of the same frame; the image is the
    per-pixel mean over all samples (empty pixels: the nearest pixel's)."""
    from scipy import ndimage

    T, H, W = case.shape
    C = case.vals.shape[1]
    x, y, t = (case.pos[:, i].astype(np.int64) for i in range(3))

    def fill(have, val):
        if not have.any():
            return np.zeros(val.shape)
        _, (iy, ix) = ndimage.distance_transform_edt(~have, return_indices=True)
        return val[iy, ix]
    frames = np.zeros((T, H, W, C))
    for tt in range(T):
        sel = t == tt
        have = np.zeros((H, W), bool)
        have[y[sel], x[sel]] = True
        v = np.zeros((H, W, C))
        v[y[sel], x[sel]] = case.vals[sel]
        frames[tt] = fill(have, v)
    img, _ = mc_pixel(case)
    return img, frames.astype(np.float32)


def mc_pixel(case):
    """bench_accuracy.py's Monte Carlo frames: a pixel's sample at t, else its mean over all t
    (which borrows the other frames' samples); the image is the per-pixel mean."""
    T, H, W = case.shape
    C = case.vals.shape[1]
    x, y, t = (case.pos[:, i].astype(np.int64) for i in range(3))
    pix = y * W + x
    cnt = np.bincount(pix, minlength=H * W).astype(np.float64)
    img = np.zeros((H * W, C))
    for c in range(C):
        img[:, c] = np.bincount(pix, weights=case.vals[:, c], minlength=H * W)
    with np.errstate(invalid="ignore", divide="ignore"):
        img = np.where(cnt[:, None] > 0, img / np.maximum(cnt, 1)[:, None], 0.0)
    fr = np.repeat(img[None], T, axis=0)  # (T, H*W, C): the blurred estimate where a frame has none
    fr[t, pix] = case.vals  # cells are distinct: one sample per (pixel, frame) at most
    img = img.reshape(H, W, C)
    empty = cnt.reshape(H, W) == 0
    if empty.any() and not empty.all():
        from scipy import ndimage
        _, (iy, ix) = ndimage.distance_transform_edt(empty, return_indices=True)
        img = img[iy, ix]
    return img.astype(np.float32), fr.reshape(T, H, W, C).astype(np.float32)


def run_mc_pixel(case):
    t0 = time.perf_counter()
    img, fr = mc_pixel(case)
    return img, fr, time.perf_counter() - t0, {}


def run_mc(case):
    t0 = time.perf_counter()
    img, fr = mc_frames(case)
    return img, fr, time.perf_counter() - t0, {}


def run_cs2d(case):
    """Alg. 1 on each frame's samples (csi's defaults), the frame's grid its output grid."""
    T, H, W = case.shape
    _, mc = mc_frames(case)
    t0 = time.perf_counter()
    frames = np.empty(case.truth.shape, np.float32)
    its = []
    for t in range(T):
        sel = case.pos[:, 2] == t
        if sel.sum() < 2:
            frames[t] = mc[t]
            continue
        p = case.pos[sel].copy()
        p[:, 2] = 0
        r = csi.reconstruct(p, case.vals[sel], (W, H, 1, W, H),
                            variance=None if case.variance is None else case.variance[sel])
        frames[t] = r.image
        its.append(max(rep["iterations"] for rep in r.reports))
    sec = time.perf_counter() - t0
    return frames.mean(axis=0), frames, sec, {"iterations": int(np.mean(its)) if its else 0}


_oidn_ready = False


def run_oidn(case):
    """OIDN (pyoidn.denoise: HDR, quality high, colour only) on the mc image and on each mc frame;
    a single channel is denoised as grey RGB. Device creation and weights once, outside the time."""
    global _oidn_ready
    import pyoidn

    if not _oidn_ready:
        pyoidn.denoise(np.zeros((16, 16, 3), np.float32), hdr=True)
        _oidn_ready = True
    img, fr = mc_frames(case)
    t0 = time.perf_counter()

    def den(a):
        rgb = np.repeat(a, 3, axis=-1) if a.shape[-1] == 1 else a[..., :3]
        out = np.asarray(pyoidn.denoise(np.ascontiguousarray(np.maximum(rgb, 0), dtype=np.float32), hdr=True,
                                        quality="high"), dtype=np.float32)
        return out.mean(axis=-1, keepdims=True) if a.shape[-1] == 1 else out
    res_img = den(img)
    res_fr = np.stack([den(fr[t]) for t in range(fr.shape[0])])
    return res_img, res_fr, time.perf_counter() - t0, {}


# ---- metrics -----------------------------------------------------------------------------------

def metrics(case, img, frames):
    f = case.truth.astype(np.float64)
    e = frames.astype(np.float64)
    img_mse = float(np.mean((img.astype(np.float64) - f.mean(axis=0)) ** 2))
    fm = np.mean((e - f) ** 2, axis=(1, 2, 3))
    frames_psnr = float(np.mean(10 * np.log10(1.0 / np.maximum(fm, 1e-20))))
    temporal = float(np.mean((np.diff(e, axis=0) - np.diff(f, axis=0)) ** 2))
    static = np.all(f == f[:1], axis=(0, 3))
    frac = float(static.mean())
    flicker = float(np.mean(np.var(e, axis=0)[static])) if frac >= 0.01 else float("nan")
    return {"img_mse": img_mse, "frames_mse": float(fm.mean()), "frames_psnr": frames_psnr,
            "temporal_mse": temporal, "flicker": flicker, "static_frac": frac}


METHOD_FN = {"gauss": run_gauss, "mc": run_mc, "mc-pixel": run_mc_pixel, "cs2d": run_cs2d, "oidn": run_oidn}


def run_method(case, m):
    if m in CSI_VARIANTS:
        return run_csi(case, **CSI_VARIANTS[m])
    return METHOD_FN[m](case)


# ---- report ------------------------------------------------------------------------------------

def mean_rows(rows, key):
    v = [r[key] for r in rows if r.get(key) is not None and np.isfinite(r[key])]
    return float(np.mean(v)) if v else float("nan")


def summarize(rows, methods, out):
    """summary.md: per (source, case, rate), seed means; ratios and differences to the tuned
    Gaussian; the issue's targets."""
    from collections import defaultdict

    groups = defaultdict(list)
    for r in rows:
        groups[(r["source"], r["case"], r["rate"])].append(r)
    lines = ["# Animation benchmark: seed means", "",
             "Image MSE ratio and frame PSNR difference against the oracle-tuned 3-D Gaussian; temporal",
             "error (MSE of frame differences) against per-frame Monte Carlo (mc) and per-frame csi 2-D (cs2d).", ""]
    hdr = "| source | case | rate | method | image MSE | / gauss | frame PSNR | - gauss | temporal | / mc | / cs2d | flicker | s |"
    lines += [hdr, "|" + "---|" * (hdr.count("|") - 1)]
    checks = []
    for key in sorted(groups):
        g = groups[key]
        by = defaultdict(list)
        for r in g:
            by[r["method"]].append(r)
        base = {m: {k: mean_rows(by[m], k) for k in ("img_mse", "frames_psnr", "temporal_mse", "flicker", "seconds")}
                for m in by}
        gi = base.get("gauss", {}).get("img_mse", float("nan"))
        gf = base.get("gauss", {}).get("frames_psnr", float("nan"))
        tm = base.get("mc", {}).get("temporal_mse", float("nan"))
        tc = base.get("cs2d", {}).get("temporal_mse", float("nan"))
        for m in methods:
            if m not in base:
                continue
            b = base[m]
            lines.append(f"| {key[0]} | {key[1]} | {100 * key[2]:g}% | {m} | {b['img_mse']:.3e} | {b['img_mse'] / gi:.2f} | "
                         f"{b['frames_psnr']:.2f} | {b['frames_psnr'] - gf:+.2f} | {b['temporal_mse']:.3e} | "
                         f"{b['temporal_mse'] / tm:.2f} | {b['temporal_mse'] / tc:.2f} | "
                         f"{b['flicker']:.2e} | {b['seconds']:.1f} |")
        if "csi" in base and "gauss" in base:
            b = base["csi"]
            lim = 0.7 if key[2] <= 0.035 else 0.5 if key[2] >= 0.095 else None
            if lim is not None and key[0] == "procedural":
                checks.append(f"- {key[1]} {100 * key[2]:g}%: image {b['img_mse'] / gi:.2f}x the tuned Gaussian (target <= {lim}): "
                              f"{'met' if b['img_mse'] / gi <= lim else 'MISSED'}; frame PSNR {b['frames_psnr'] - gf:+.2f} dB "
                              f"({'met' if b['frames_psnr'] > gf else 'MISSED'})")
            if "mc" in base and "cs2d" in base:
                checks.append(f"- {key[1]} {100 * key[2]:g}% ({key[0]}): temporal error {b['temporal_mse'] / tm:.2f}x per-frame MC, "
                              f"{b['temporal_mse'] / tc:.2f}x per-frame csi 2-D: "
                              f"{'met' if b['temporal_mse'] < min(tm, tc) else 'MISSED'}")
    lines += ["", "## Targets", ""] + checks
    with open(os.path.join(out, "summary.md"), "w") as f:
        f.write("\n".join(lines) + "\n")


def figures(case, results, out):
    """Contact sheet and animation of one case: the reference and each method's frames."""
    seqs = [("reference", case.truth)] + [(m, fr) for m, fr in results]
    stem = f"{case.name.replace('+', '_')}_{100 * case.rate:g}pct_s{case.seed}"
    # one cell per pixel: a page's figure, not a poster (the animation is the enlarged one)
    sheet = [s for s in seqs if s[0] in ("reference", "csi", "csi-paper", "gauss", "mc", "cs2d")]
    preview.contact_sheet(os.path.join(out, f"sheet_{stem}.png"), sheet, picks=6, scale=1)
    keep = [s for s in seqs if s[0] in ("reference", "csi", "gauss", "mc", "cs2d")]
    preview.animation(os.path.join(out, f"anim_{stem}.webp"), keep, fps=10, scale=2)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--quick", action="store_true", help="64x64x16, rates 3%% and 10%%, one seed, two volumes")
    ap.add_argument("--sources", default="procedural,mitsuba")
    ap.add_argument("--volumes", default=",".join(av.NAMES))
    ap.add_argument("--scenes", default=",".join(MITSUBA_SCENES),
                    help="Mitsuba animations: the bundled ones by name, or a Python scene file with "
                    "animate(params, time) (named by its file's stem; its data cached under that name)")
    ap.add_argument("--rates", default="0.01,0.03,0.1")
    ap.add_argument("--seeds", default="0,1,2")
    ap.add_argument("--size", default="128x128x32", help="WxHxT of the procedural volumes")
    ap.add_argument("--mitsuba-size", default="128x128x32")
    ap.add_argument("--methods", default=",".join(DEFAULT_METHODS))
    ap.add_argument("--data", default=os.path.join(os.path.expanduser("~"), ".cache", "csi", "bench-anim"),
                    help="cache of the volumes and of Mitsuba's references and samples")
    ap.add_argument("--ref-spp", type=int, default=1024,
                    help="Mitsuba reference samples per pixel per frame (at 64 the reference's own noise was a "
                    "quarter of the image error on anim_ball at 10%%: docs/bench/animation.md, session 31)")
    ap.add_argument("--paths", type=int, default=16, help="Mitsuba paths per sample")
    ap.add_argument("--figures", default="0.03", help="rates whose first seed gets figures")
    ap.add_argument("--variant", action="append", default=[], metavar="NAME=OPT:VALUE[,OPT:VALUE]",
                    help="another csi method: csi's defaults with these options (csi.reconstruct's names), "
                    "e.g. still4=motion_still_weight:0.25; then listed in --methods like any other")
    a = ap.parse_args()
    for v in a.variant:
        name, _, opts = v.partition("=")
        if not name or name in ALL_METHODS or not opts:
            sys.exit(f"bench_animation: --variant {v!r}: need a new NAME=OPT:VALUE[,OPT:VALUE]")
        CSI_VARIANTS[name] = {}
        for kv in opts.split(","):
            key, _, val = kv.partition(":")
            if not key or not val:
                sys.exit(f"bench_animation: --variant {v!r}: {kv!r} is not OPT:VALUE")
            CSI_VARIANTS[name][key] = val
        ALL_METHODS.append(name)
    if a.quick:
        a.size = a.mitsuba_size = "64x64x16"
        a.rates, a.seeds = "0.03,0.1", "0"
        a.volumes, a.scenes = "pan+disc,static+movers", "anim_ball"
        a.ref_spp = min(a.ref_spp, 64)
    scenes = []
    for entry in a.scenes.split(",") if "mitsuba" in a.sources.split(",") else []:
        if entry.endswith(".py"):
            if not os.path.isfile(entry):
                sys.exit(f"bench_animation: --scenes {entry}: no such file")
            name = os.path.splitext(os.path.basename(entry))[0]
            if name in MITSUBA_SCENES and os.path.abspath(MITSUBA_SCENES[name]) != os.path.abspath(entry):
                sys.exit(f"bench_animation: --scenes {entry}: its name {name!r} is a bundled scene's; rename the file")
            MITSUBA_SCENES[name] = os.path.abspath(entry)
            entry = name
        elif entry not in MITSUBA_SCENES:
            sys.exit(f"bench_animation: --scenes {entry!r}: not one of {', '.join(MITSUBA_SCENES)} "
                     "nor a .py scene file")
        scenes.append(entry)
    os.makedirs(a.out, exist_ok=True)
    methods = a.methods.split(",")
    for m in methods:
        if m not in ALL_METHODS:
            sys.exit(f"bench_animation: unknown method {m!r} (one of {', '.join(ALL_METHODS)})")
    size = tuple(int(v) for v in a.size.split("x"))
    msize = tuple(int(v) for v in a.mitsuba_size.split("x"))
    rates = [float(r) for r in a.rates.split(",")]
    seeds = [int(s) for s in a.seeds.split(",")]
    fig_rates = [float(r) for r in a.figures.split(",")] if a.figures else []
    cases = []
    for src in a.sources.split(","):
        names = a.volumes.split(",") if src == "procedural" else scenes
        for name in names:
            for seed in seeds:
                for rate in rates:
                    cases.append((src, name, seed, rate))
    rows = []
    t_run = time.perf_counter()
    load0 = os.getloadavg()
    with open(os.path.join(a.out, "results.csv"), "w", newline="") as fcsv:
        w = None
        for src, name, seed, rate in cases:
            case = (procedural_case(name, seed, rate, size, os.path.join(a.data, "volumes")) if src == "procedural"
                    else mitsuba_case(name, seed, rate, msize, a.data, a.ref_spp, a.paths))
            log(f"{src} {case.label}: {len(case.vals)} samples")
            results = []
            for m in methods:
                img, fr, sec, notes = run_method(case, m)
                met = metrics(case, img, fr)
                row = {"source": src, "case": name, "seed": seed, "rate": rate, "method": m, "n": len(case.vals),
                       "seconds": sec, **met, **{k: notes.get(k) for k in ("iterations", "vx", "vy", "t_velocity",
                                                                            "sigma_image", "sigma_frames")},
                       "true_v": ";".join(f"{vx:.3f},{vy:.3f}" for vx, vy in case.info)}
                rows.append(row)
                if w is None:
                    w = csv.DictWriter(fcsv, fieldnames=list(row))
                    w.writeheader()
                w.writerow(row)
                fcsv.flush()
                log(f"  {m:10s} image {met['img_mse']:.3e} frames {met['frames_psnr']:.2f} dB temporal "
                    f"{met['temporal_mse']:.3e} {sec:.1f}s")
                results.append((m, fr))
            if seed == seeds[0] and rate in fig_rates:
                figures(case, results, a.out)
    summarize(rows, methods, a.out)
    with open(os.path.join(a.out, "run.json"), "w") as f:
        json.dump({"args": vars(a), "seconds": time.perf_counter() - t_run, "loadavg_start": load0,
                   "loadavg_end": os.getloadavg(), "csi_version": csi.version()}, f, indent=1)
    log(f"done in {time.perf_counter() - t_run:.0f} s: {a.out}/summary.md")


if __name__ == "__main__":
    main()
