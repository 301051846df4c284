#!/usr/bin/env python3
"""What accuracy costs in time (issue 6): error of every method against a high-spp reference,
render and reconstruction time measured separately in the same run, for every bundled scene.

  .venv/bin/python tools/bench/bench_accuracy.py --out bench-out            # the full run
  .venv/bin/python tools/bench/bench_accuracy.py --quick --out bench-quick  # a smoke run, minutes
  .venv/bin/python tools/bench/bench_accuracy.py --replot bench-out          # redo break-even + plots

Methods (names used in the CSVs and plots):
  static scenes (2-D antialiasing):
    random, stratified          Monte Carlo: per-pixel sample mean (csi-render --method ...), on
                                the reference's fine grid (--mc-grid, default sqrt(ref-spp) = 16x
                                the image: positions as fine as the reference's, so they behave
                                like continuous ones; on the cs grid of 4x, 16 spp would sample
                                every cell and be exact on that grid)
    oidn                        stratified followed by Intel Open Image Denoise (pyoidn, CPU, HDR
                                mode, colour only: no albedo/normal buffers)
    cs-<solver>-<wavelet>       compressive (Poisson-disk positions), solver romp|sparsa,
                                wavelet db4|db8
    cs-<solver>-<wavelet>-sharp the same with --integrate sharp (on request only: --methods)
  moving scenes (3-D motion blur), each on the blurred image and on every frame:
    random, stratified          per-pixel Monte Carlo over x, y, t on a grid of 8 x 8 cells a
                                pixel (positions nearly continuous, as a renderer's jitter; on
                                csi's grid of a volume, 1-4 cells a pixel side, they would see
                                the cells' centres only); a frame's pixel is the mean of the
                                pixel's samples in that frame (pixels with none: the pixel's mean
                                over all t)
    oidn                        OIDN on the stratified image and on each Monte Carlo frame
    gauss                       3-D Gaussian normalized convolution (csi --estimator gauss) on
                                the compressive method's samples, sigma swept and the best picked
                                against the reference (an oracle: separately for the blurred image
                                and for the frames)
    cs3d-<solver>               the compressive 3-D method (Alg. 2)
    cs3d-paper                  the same with the paper's basis (--motion-time dft
                                --motion-velocity none --motion-filter off: csi's default before
                                issue 12; on request)
    cs3d-unfiltered             csi's default without Alg. 1's filter in the motion solve
                                (--motion-filter off; on request)
The compressive runs trace once per (scene, spp, seed) with --dump and reconstruct the same
samples with csi-reconstruct for each variant: render time comes from the render, reconstruction
time from csi-reconstruct's stats (setup + solve + integrate), both per run.

See docs/BENCHMARKS-accuracy.md for the figures, the edge-pixel rule and the break-even analysis.
"""
import argparse
import csv
import json
import math
import os
import shutil
import sys
import time

import warnings

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bench_common as bc  # noqa: E402

ALL_SCENES = ["triangle", "checkerboard", "garden", "billiards", "train"]
STATIC_CS = ["cs-romp-db4", "cs-romp-db8", "cs-sparsa-db4", "cs-sparsa-db8"]
STATIC_METHODS = ["random", "stratified", "oidn"] + STATIC_CS
# on request (--methods): the same with --integrate sharp (integrate Phi^-1 f_b, not f_b)
STATIC_CS_SHARP = [m + "-sharp" for m in STATIC_CS]
MOTION_METHODS = ["random", "stratified", "oidn", "gauss", "cs3d-sparsa"]
MOTION_MC_GRID = 8  # cells a pixel side of the moving scenes' Monte Carlo positions
# Alg. 2 variants run only when --methods names them: their csi-reconstruct options
CS3D_ON_REQUEST = {"cs3d-romp": ["--solver", "romp"],
                   "cs3d-paper": ["--solver", "sparsa", "--motion-time", "dft", "--motion-velocity", "none",
                                  "--motion-filter", "off"],
                   "cs3d-unfiltered": ["--solver", "sparsa", "--motion-filter", "off"]}
GAUSS_FACTORS = [0.35, 0.5, 0.71, 1.0, 1.41, 2.0, 2.83]

RESULT_FIELDS = ["scene", "kind", "width", "height", "grid_w", "grid_h", "grid_t", "k", "spp", "seed",
                 "method", "param", "samples", "mse", "psnr", "mse_edge", "psnr_edge", "edge_pixels",
                 "frames_mse", "frames_psnr", "t_render_s", "t_recon_s", "t_total_s", "t_wall_s",
                 "t_per_sample_us", "iterations", "inner_iterations", "rel_residual", "converged", "finite", "error"]


def parse_args(argv):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="bench-accuracy", help="output directory (CSVs, plots, run.json)")
    ap.add_argument("--scenes", default=",".join(ALL_SCENES), help="comma list of bundled scenes (names) and .scene files (paths)")
    ap.add_argument("--spp", default=None, help="comma list of samples per pixel [1,2,4,9,16; --quick: 1,4,16]")
    ap.add_argument("--methods", default="all",
                    help="comma list of methods (see above; 'cs' = every cs variant); default all")
    ap.add_argument("--seeds", type=int, default=10, help="seeds per (scene, spp, method) [10]")
    ap.add_argument("--size", default=None, help="WxH override of static scenes' image size")
    ap.add_argument("--motion-size", default=None, help="WxH override of moving scenes' image size")
    ap.add_argument("--time-steps", type=int, default=0, help="T of moving scenes (default: the plan's)")
    ap.add_argument("--max-iter", type=int, default=0, help="solver iteration cap (default: the binary's)")
    ap.add_argument("--tol", type=float, default=0, help="solver tolerance (default: the binary's)")
    ap.add_argument("--ref-spp", type=int, default=256, help="reference samples per pixel [256]")
    ap.add_argument("--mc-grid", type=int, default=0,
                    help="fine-grid multiplier of the Monte Carlo baselines on static scenes (default: "
                    "sqrt(ref-spp), the reference's grid, so their positions are as fine as the reference's)")
    ap.add_argument("--ref-cache", default=os.path.join(os.path.expanduser("~"), ".cache", "csi", "bench-ref"))
    ap.add_argument("--effort-scenes", default=None,
                    help="scenes for the solver-effort and problem-size sweeps (default: the first static one)")
    ap.add_argument("--effort-spp", type=int, default=4)
    ap.add_argument("--iters", default="25,50,100,200,400,1000,2000", help="max-iter sweep")
    ap.add_argument("--tols", default="1e-2,3e-3,1e-3", help="tolerance sweep")
    ap.add_argument("--grids", default="2,4,8", help="fine-grid multipliers for the k axis (2,4,8 at "
                    "256x256 are k = 512^2, 1024^2, 2048^2)")
    ap.add_argument("--gauss-factors", default=",".join(map(str, GAUSS_FACTORS)),
                    help="gauss sigma sweep, multiples of 0.5 (T/spp)^(1/3) cells")
    ap.add_argument("--inset-spp", type=int, default=4)
    ap.add_argument("--build", default=None, help="build directory with the binaries [ROOT/build]")
    ap.add_argument("--threads", type=int, default=0, help="tracing threads (default: all cores)")
    ap.add_argument("--quick", action="store_true",
                    help="smoke run: 64x64 static, 32x32x16 motion, spp 1,4,16 (unless --spp is given), 2 seeds, "
                    "max-iter 100, small sweeps")
    ap.add_argument("--keep", action="store_true", help="keep the work directory (images, dumps)")
    ap.add_argument("--resume", action="store_true",
                    help="continue a run in --out: keep its finished (scene, spp) blocks and effort sweeps, "
                    "redo the rest (use the same options)")
    ap.add_argument("--no-plots", action="store_true")
    ap.add_argument("--cs3d-variant", action="append", default=[], metavar="NAME=ARGS",
                    help="another Alg. 2 method: csi-reconstruct --solver sparsa with these arguments, e.g. "
                    "'cs3d-w05=--motion-still-weight 0.5' (repeatable; run when --methods names it)")
    a = ap.parse_args(argv)
    if a.quick:
        a.size = a.size or "64x64"
        a.motion_size = a.motion_size or "32x32"
        a.time_steps = a.time_steps or 16
        a.max_iter = a.max_iter or 100
        a.seeds = min(a.seeds, 2)
        a.spp = a.spp or "1,4,16"
        a.iters = "10,30,100" if a.iters == ap.get_default("iters") else a.iters
        a.tols = "1e-2" if a.tols == ap.get_default("tols") else a.tols
        a.gauss_factors = "0.5,1.0,2.0" if a.gauss_factors == ap.get_default("gauss_factors") else a.gauss_factors
    for v in a.cs3d_variant:
        name, _, args = v.partition("=")
        if not name.startswith("cs3d-") or name in CS3D_ON_REQUEST or name in MOTION_METHODS or not args:
            ap.error(f"--cs3d-variant {v!r}: need a new cs3d-NAME=ARGS")
        CS3D_ON_REQUEST[name] = ["--solver", "sparsa"] + args.split()
    # a scene is a bundled scene's name or a .scene file's path, reported by its file's stem
    a.scene_files = {}
    for s in a.scenes.split(","):
        if s.endswith(".scene"):
            if not os.path.isfile(s):
                ap.error(f"--scenes: {s}: no such scene file")
            a.scene_files[os.path.splitext(os.path.basename(s))[0]] = os.path.abspath(s)
    a.scenes = [os.path.splitext(os.path.basename(s))[0] if s.endswith(".scene") else s
                for s in a.scenes.split(",") if s]
    a.spp = sorted({int(s) for s in (a.spp or "1,2,4,9,16").split(",") if s})
    a.iters = [int(x) for x in a.iters.split(",") if x]
    a.tols = [float(x) for x in a.tols.split(",") if x]
    a.grids = [int(x) for x in a.grids.split(",") if x]
    a.gauss_factors = [float(x) for x in a.gauss_factors.split(",") if x]
    a.size = tuple(int(v) for v in a.size.lower().split("x")) if a.size else None
    a.mc_grid = a.mc_grid or math.ceil(math.sqrt(a.ref_spp) - 1e-9)
    a.motion_size = tuple(int(v) for v in a.motion_size.lower().split("x")) if a.motion_size else None
    if a.methods == "all":
        a.methods = None
    else:
        ms = []
        for m in a.methods.split(","):
            ms += STATIC_CS + ["cs3d-sparsa"] if m == "cs" else [m]
        a.methods = ms
    return a


def _num(v):
    """A CSV or row value as a float (NaN when empty or not a number)."""
    try:
        return float(v)
    except (TypeError, ValueError):
        return float("nan")


class Bench:
    def __init__(self, a):
        self.a = a
        self.env = bc.default_env()
        self.bins = bc.binaries(a.build)
        self.out = os.path.abspath(a.out)
        self.work = os.path.join(self.out, "work")
        os.makedirs(self.work, exist_ok=True)
        self.logf = open(os.path.join(self.out, "commands.log"), "a" if a.resume else "w")
        self.fp = bc.tracer_fingerprint(self.bins, self.env)
        self.results = []
        self.variance = []
        self.sweeps = []
        self.effort = []
        self.frames_rows = []
        self.refs = []
        self.insets = {}
        self._oidn_ready = False
        self.done = set()
        self.effort_done = set()
        if a.resume:
            self.load_previous()

    def load_previous(self):
        """--resume: keep the (scene, spp) blocks that finished (their variance rows are written
        when a block ends) and the scenes whose effort sweeps finished; drop partial blocks."""
        import bench_plots
        rd = lambda n: bench_plots.read_csv(os.path.join(self.out, n))  # noqa: E731
        self.variance = rd("variance.csv")
        self.done = {(r["scene"], int(r["spp"])) for r in self.variance}
        keep = lambda rows: [r for r in rows if (r["scene"], int(r["spp"])) in self.done]  # noqa: E731
        self.results = keep(rd("results.csv"))
        self.sweeps = keep(rd("gauss_sweep.csv"))
        self.frames_rows = keep(rd("frames.csv"))
        self.effort = rd("effort.csv")
        self.effort_done = {r["scene"] for r in self.effort}
        self.refs = rd("references.csv")
        for f in os.listdir(self.out):
            if f.startswith("insets_") and f.endswith(".npz"):
                z = np.load(os.path.join(self.out, f))
                self.insets[f[7:-4]] = {str(n): (img, float(m)) for n, img, m in zip(z["names"], z["images"], z["mse"])}
        bc.log(f"resume: {len(self.done)} finished (scene, spp) blocks, {len(self.results)} rows kept")

    # ---- running the binaries ------------------------------------------------------------
    def solver_opts(self):
        o = []
        if self.a.max_iter:
            o += ["--max-iter", str(self.a.max_iter)]
        if self.a.tol:
            o += ["--tol", str(self.a.tol)]
        return o

    def render(self, scene, tag, args, frames=False):
        exr = os.path.join(self.work, tag + ".exr")
        js = os.path.join(self.work, tag + ".json")
        cmd = [self.bins["csi-render"], scene, "-o", exr, "--stats", js, "-q"] + args
        if self.a.threads:
            cmd += ["--threads", str(self.a.threads)]
        wall = bc.run(cmd, self.env, log=self.logf)
        with open(js) as f:
            st = json.load(f)
        st["t_wall_s"] = wall
        img = bc.read_exr(exr)
        self.tidy(exr, js)
        return img, st

    def tidy(self, *paths):
        """Outputs are read at once; a long run would otherwise fill the disk (--keep keeps them)."""
        if not self.a.keep:
            for p in paths:
                if os.path.exists(p):
                    os.remove(p)

    def reconstruct(self, dump, tag, args, frames_dir=None):
        exr = os.path.join(self.work, tag + ".exr")
        js = os.path.join(self.work, tag + ".json")
        cmd = [self.bins["csi-reconstruct"], dump, "-o", exr, "--stats", js, "-q"] + args
        if frames_dir:
            shutil.rmtree(frames_dir, ignore_errors=True)
            cmd += ["--frames", frames_dir]
        wall = bc.run(cmd, self.env, log=self.logf)
        with open(js) as f:
            st = json.load(f)
        st["t_wall_s"] = wall
        fr = None
        if frames_dir:
            names = sorted(n for n in os.listdir(frames_dir) if n.endswith(".exr"))
            fr = np.stack([bc.read_exr(os.path.join(frames_dir, n)) for n in names])
        img = bc.read_exr(exr)
        self.tidy(exr, js)
        return img, st, fr

    def oidn(self, img):
        import pyoidn
        if not self._oidn_ready:  # device creation and weight loading once, outside the timings
            pyoidn.denoise(np.zeros((16, 16, 3), np.float32), hdr=True)
            self._oidn_ready = True
        x = np.ascontiguousarray(np.maximum(np.nan_to_num(img), 0), np.float32)
        t0 = time.perf_counter()
        y = pyoidn.denoise(x, hdr=True, quality="high")
        return y, time.perf_counter() - t0

    # ---- references -----------------------------------------------------------------------
    def reference(self, name, scene, shash, plan):
        """Static: csi-render --reference R (stratified, R samples per pixel on a sqrt(R)x finer
        grid). Moving: a reference grid of 4 x 4 cells a pixel and T frames (--reference 16T),
        every cell traced once at a random point of it (csi-render's references jitter since
        session 46), the pixel the mean of its 4 x 4 points (finer than any default grid of a
        volume: at most 4 x 4 cells, csi_default_grid_factor), averaged over ceil(R / 16T) seeds
        (shading noise and the points)."""
        W, H, T = plan["width"], plan["height"], plan["frames"]
        R = self.a.ref_spp
        os.makedirs(self.a.ref_cache, exist_ok=True)
        key = f"{name}_{W}x{H}_T{T}_r{R}{'_c4' if T > 1 else ''}_{shash}_{self.fp}"
        path = os.path.join(self.a.ref_cache, key + ".npz")
        if os.path.exists(path):
            z = np.load(path)
            bc.log(f"reference {key}: cached")
            return z["image"], (z["frames"] if z["frames"].ndim == 4 else None), float(z["t_render"])
        bc.log(f"reference {key}: rendering")
        t0 = time.perf_counter()
        if T == 1:
            img, st = self.render(scene, f"ref_{name}", ["--reference", str(R)])
            frames = np.zeros(0)
            trender = st["t_render_s"]
        else:
            nseeds = max(1, math.ceil(R / (16 * T)))
            dumps = []
            trender = 0
            for s in range(nseeds):
                d = os.path.join(self.work, f"ref_{name}_{s}.csid")
                _, st = self.render(scene, f"ref_{name}_{s}",
                                    ["--reference", str(16 * T), "--time-steps", str(T), "--seed", str(s + 1), "--dump", d])
                trender += st["t_render_s"]
                dumps.append(d)
            fine = bc.dump_grid_mean(dumps)  # (T, 4H, 4W, 3)
            frames = fine.reshape(T, H, 4, W, 4, -1).mean(axis=(2, 4)).astype(np.float32)
            for d in dumps:
                os.remove(d)
            img = frames.mean(axis=0)
        np.savez_compressed(path + ".tmp.npz", image=img, frames=frames, t_render=trender)
        os.replace(path + ".tmp.npz", path)
        self.refs.append(dict(scene=name, key=key, t_render_s=trender, t_wall_s=time.perf_counter() - t0))
        return img, (frames if frames.ndim == 4 else None), trender

    # ---- bookkeeping -----------------------------------------------------------------------
    def want(self, m, motion):
        pool = MOTION_METHODS + list(CS3D_ON_REQUEST) if motion else STATIC_METHODS + STATIC_CS_SHARP
        if m not in pool:
            return False
        if self.a.methods is None:  # ROMP is real-valued (the 3-D problem is complex); sharp: on request
            return m not in CS3D_ON_REQUEST and not m.endswith("-sharp")
        return m in self.a.methods

    def row(self, ctx, method, img, ref, edges, st_render, t_recon, frames=None, ref_frames=None,
            param="", st_recon=None):
        finite = bool(np.isfinite(img).all())
        m = bc.mse(img, ref) if finite else float("inf")  # a NaN pixel is a failed image, not a skipped one
        me = bc.mse(img, ref, edges) if finite else float("inf")
        fm = fp = float("nan")
        if frames is not None and ref_frames is not None:
            per = [bc.mse(frames[t], ref_frames[t]) if np.isfinite(frames[t]).all() else float("inf")
                   for t in range(len(frames))]
            fm = float(np.mean(per))
            fp = float(np.mean([bc.psnr(x) for x in per]))
            if ctx["seed"] == 1:
                for t, x in enumerate(per):
                    self.frames_rows.append(dict(scene=ctx["scene"], spp=ctx["spp"], method=method, frame=t,
                                                 mse=x, psnr=bc.psnr(x)))
        its, res, conv = bc.stats_iterations(st_recon) if st_recon else (0, 0.0, True)
        t_render = float(st_render["t_render_s"])
        r = dict(ctx, method=method, param=param, samples=st_render["samples"], mse=m, psnr=bc.psnr(m),
                 mse_edge=me, psnr_edge=bc.psnr(me), edge_pixels=int(edges.sum()), frames_mse=fm,
                 frames_psnr=fp, t_render_s=t_render, t_recon_s=t_recon, t_total_s=t_render + t_recon,
                 t_wall_s=st_render.get("t_wall_s", 0) + (st_recon or {}).get("t_wall_s", 0),
                 t_per_sample_us=st_render.get("t_per_sample_us", 0), iterations=its,
                 inner_iterations=bc.stats_inner(st_recon) if st_recon else 0, rel_residual=res,
                 converged=int(conv), finite=int(finite))
        if st_recon and "k" in st_recon:
            r["k"] = st_recon["k"]
        self.results.append(r)
        acc = self.var_acc.setdefault(method, [0, 0.0, 0.0])
        y = bc.luminance(img).astype(np.float64)
        acc[0] += 1
        acc[1] = acc[1] + y
        acc[2] = acc[2] + y * y
        if ctx["spp"] == self.a.inset_spp and ctx["seed"] == 1:
            self.insets.setdefault(ctx["scene"], {})[method] = (img, m)
        bc.log(f"  {ctx['scene']} spp {ctx['spp']} seed {ctx['seed']} {method:14s} {param:18s} "
               f"MSE {m:.3e} edge {me:.3e} render {t_render:.2f}s recon {t_recon:.2f}s"
               + (f" frames PSNR {fp:.2f}" if frames is not None else ""))
        return r

    def failed(self, ctx, method, err, st_render=None, param=""):
        """A reconstruction that exited non-zero: recorded as a failed image (infinite error), the
        run goes on. The first line of the message is kept in the CSV."""
        msg = str(err).strip().splitlines()
        msg = (msg[-1] if msg else "failed")[:200]
        st_render = st_render or {}
        self.results.append(dict(ctx, method=method, param=param, samples=st_render.get("samples", 0),
                                 mse=float("inf"), psnr=float("-inf"), mse_edge=float("inf"),
                                 psnr_edge=float("-inf"), edge_pixels=0, frames_mse=float("inf"),
                                 frames_psnr=float("-inf"), t_render_s=st_render.get("t_render_s", 0),
                                 t_recon_s=float("nan"), t_total_s=float("nan"), t_wall_s=float("nan"),
                                 t_per_sample_us=st_render.get("t_per_sample_us", float("nan")), iterations=0,
                                 inner_iterations=0, rel_residual=float("nan"), converged=0, finite=0, error=msg))
        bc.log(f"  {ctx['scene']} spp {ctx['spp']} seed {ctx['seed']} {method}: FAILED: {msg}")

    def flush_variance(self, scene, spp, edges):
        for method, (n, s, s2) in self.var_acc.items():
            if n < 2:
                v = ve = float("nan")
            else:
                var = np.maximum((s2 - s * s / n) / (n - 1), 0)
                v, ve = float(var.mean()), float(var[edges].mean()) if edges.any() else float("nan")
            self.variance.append(dict(scene=scene, spp=spp, method=method, seeds=n, var_all=v, var_edge=ve))
        self.var_acc = {}
        if spp == self.a.inset_spp and scene in self.insets:  # kept for --resume and --replot
            ins = self.insets[scene]
            np.savez_compressed(os.path.join(self.out, f"insets_{scene}.npz"), ref=self.refimg[scene],
                                edges=self.edges[scene], names=np.array(list(ins)),
                                images=np.stack([v[0] for v in ins.values()]),
                                mse=np.array([v[1] for v in ins.values()]))

    # ---- the scene loops --------------------------------------------------------------------
    def static_scene(self, name):
        a = self.a
        scene, shash = bc.scene_variant(a.scene_files.get(name, name), a.size, self.work)
        plan = bc.plan(self.bins, scene, self.env)
        W, H = plan["width"], plan["height"]
        ref, _, _ = self.reference(name, scene, shash, plan)
        edges = bc.edge_mask(ref)
        self.edges[name] = edges
        self.refimg[name] = ref
        so = self.solver_opts()
        for spp in a.spp:
            self.var_acc = {}
            if (name, spp) in self.done:
                continue
            for seed in range(1, a.seeds + 1):
                ctx = dict(scene=name, kind="static", width=W, height=H, grid_w=0, grid_h=0, grid_t=1,
                           k=0, spp=spp, seed=seed)
                common = ["--spp", str(spp), "--seed", str(seed)]
                mc = common + ["--grid", str(a.mc_grid * W)]
                tag = f"{name}_s{spp}_r{seed}"
                if self.want("random", False):
                    img, st = self.render(scene, tag + "_random", mc + ["--method", "random"])
                    self.row(dict(ctx, grid_w=st["grid_w"], grid_h=st["grid_h"]), "random", img, ref, edges,
                             st, st["t_reconstruct_s"])
                if self.want("stratified", False) or self.want("oidn", False):
                    img, st = self.render(scene, tag + "_strat", mc + ["--method", "stratified"])
                    c2 = dict(ctx, grid_w=st["grid_w"], grid_h=st["grid_h"])
                    if self.want("stratified", False):
                        self.row(c2, "stratified", img, ref, edges, st, st["t_reconstruct_s"])
                    if self.want("oidn", False):
                        den, t = self.oidn(img)
                        self.row(c2, "oidn", den, ref, edges, st, st["t_reconstruct_s"] + t)
                cs = [m for m in STATIC_CS + STATIC_CS_SHARP if self.want(m, False)]
                if cs:
                    dump = os.path.join(self.work, tag + ".csid")
                    _, st = self.render(scene, tag + "_poisson", common + ["--estimator", "mean", "--dump", dump])
                    for m in cs:
                        solver, wav = m.split("-")[1:3]
                        integ = ["--integrate", "sharp"] if m.endswith("-sharp") else []
                        try:
                            img, sr, _ = self.reconstruct(dump, f"{tag}_{m}",
                                                          ["--solver", solver, "--wavelet", wav] + integ + so)
                        except bc.BenchError as e:
                            self.failed(ctx, m, e, st)
                            continue
                        c2 = dict(ctx, grid_w=sr["grid_w"], grid_h=sr["grid_h"], k=sr["k"])
                        self.row(c2, m, img, ref, edges, st, bc.recon_time(sr), st_recon=sr,
                                 param=f"max_iter={a.max_iter or 'default'}")
                    os.remove(dump)
            self.flush_variance(name, spp, edges)

    def motion_scene(self, name):
        a = self.a
        scene, shash = bc.scene_variant(a.scene_files.get(name, name), a.motion_size, self.work)
        plan = bc.plan(self.bins, scene, self.env)
        if a.time_steps:
            plan["frames"] = a.time_steps
        W, H, T = plan["width"], plan["height"], plan["frames"]
        if T < 2:
            bc.log(f"{name}: no motion in the plan; running it as a static scene")
            return self.static_scene(name)
        ref, ref_frames, _ = self.reference(name, scene, shash, plan)
        edges = bc.edge_mask(ref)
        self.edges[name] = edges
        self.refimg[name] = ref
        so = self.solver_opts()
        ts = ["--time-steps", str(T)]
        for spp in a.spp:
            self.var_acc = {}
            best_sigma = None
            if (name, spp) in self.done:
                continue
            for seed in range(1, a.seeds + 1):
                ctx = dict(scene=name, kind="motion", width=W, height=H, grid_w=W, grid_h=H, grid_t=T,
                           k=W * H * T, spp=spp, seed=seed)
                common = ["--spp", str(spp), "--seed", str(seed)] + ts
                tag = f"{name}_s{spp}_r{seed}"
                for meth in ("random", "stratified"):
                    if not (self.want(meth, True) or (meth == "stratified" and self.want("oidn", True))):
                        continue
                    dump = os.path.join(self.work, f"{tag}_{meth}.csid")
                    img, st = self.render(scene, f"{tag}_{meth}", common + ["--method", meth, "--dump", dump,
                                                                           "--grid", str(MOTION_MC_GRID * W)])
                    fr, _ = bc.dump_frames(dump, fill=img)
                    os.remove(dump)
                    if self.want(meth, True):
                        self.row(ctx, meth, img, ref, edges, st, st["t_reconstruct_s"], fr, ref_frames)
                    if meth == "stratified" and self.want("oidn", True):
                        den, t = self.oidn(img)
                        dfr = []
                        for f in fr:
                            y, tf = self.oidn(f)
                            dfr.append(y)
                            t += tf
                        self.row(ctx, "oidn", den, ref, edges, st, st["t_reconstruct_s"] + t, np.stack(dfr), ref_frames)
                want_cs = [m for m in ("cs3d-sparsa",) + tuple(CS3D_ON_REQUEST) if self.want(m, True)]
                if not (want_cs or self.want("gauss", True)):
                    continue
                dump = os.path.join(self.work, tag + ".csid")
                _, st = self.render(scene, tag + "_poisson", common + ["--estimator", "mean", "--dump", dump])
                fdir = os.path.join(self.work, tag + "_frames")
                if self.want("gauss", True):
                    s0 = 0.5 * (T / spp) ** (1 / 3)
                    if best_sigma is None:  # the oracle: sweep on the first seed against the reference
                        sweep = []
                        for f in a.gauss_factors:
                            sg = s0 * f
                            img, sr, fr = self.reconstruct(dump, f"{tag}_gauss{f}",
                                                           ["--estimator", "gauss", "--gauss-sigma", f"{sg:.4g}"], fdir)
                            m_img = bc.mse(img, ref)
                            m_fr = float(np.mean([bc.mse(fr[t], ref_frames[t]) for t in range(T)]))
                            sweep.append((f"{sg:.4g}", m_img, m_fr))
                            self.sweeps.append(dict(scene=name, spp=spp, seed=seed, sigma=sg, factor=f, mse=m_img,
                                                    frames_mse=m_fr, t_recon_s=bc.recon_time(sr)))
                        best_sigma = (min(sweep, key=lambda x: x[1])[0], min(sweep, key=lambda x: x[2])[0])
                    s_img, s_fr = best_sigma
                    img, sr, fr = self.reconstruct(dump, f"{tag}_gauss", ["--estimator", "gauss", "--gauss-sigma", s_img], fdir)
                    if s_fr != s_img:
                        _, _, fr = self.reconstruct(dump, f"{tag}_gaussf", ["--estimator", "gauss", "--gauss-sigma", s_fr], fdir)
                    self.row(ctx, "gauss", img, ref, edges, st, bc.recon_time(sr), fr, ref_frames,
                             param=f"sigma={s_img}/{s_fr}", st_recon=sr)
                for m in want_cs:
                    try:
                        args = CS3D_ON_REQUEST.get(m, ["--solver", m.split("-")[1]])
                        img, sr, fr = self.reconstruct(dump, f"{tag}_{m}", args + so, fdir)
                    except bc.BenchError as e:
                        self.failed(ctx, m, e, st)
                        continue
                    self.row(ctx, m, img, ref, edges, st, bc.recon_time(sr), fr, ref_frames, st_recon=sr,
                             param=f"max_iter={a.max_iter or 'default'}")
                shutil.rmtree(fdir, ignore_errors=True)
                os.remove(dump)
            self.flush_variance(name, spp, edges)

    def effort_scene(self, name):
        """Solver effort (iteration cap, tolerance) and problem size k for the cs variants (db4), one
        seed, spp = --effort-spp."""
        a = self.a
        scene, _ = bc.scene_variant(a.scene_files.get(name, name), a.size, self.work)
        plan = bc.plan(self.bins, scene, self.env)
        if plan["frames"] > 1:
            return
        W = plan["width"]
        ref, edges = self.refimg[name], self.edges[name]
        solvers = [m for m in ("cs-sparsa-db4", "cs-romp-db4") if self.want(m, False)]
        if not solvers:
            return
        spp = a.effort_spp
        for mult in a.grids:
            tag = f"effort_{name}_g{mult}"
            dump = os.path.join(self.work, tag + ".csid")
            _, st = self.render(scene, tag + "_poisson", ["--spp", str(spp), "--grid", str(mult * W), "--estimator",
                                                          "mean", "--dump", dump])
            sweeps = [("k", mult * W, self.solver_opts())]
            if mult == 4:  # the default grid: also sweep the iteration cap and the tolerance
                sweeps += [("max_iter", it, ["--max-iter", str(it)]) for it in a.iters]
                sweeps += [("tol", tol, ["--tol", str(tol)] + (["--max-iter", str(a.max_iter)] if a.max_iter else []))
                           for tol in a.tols]
            for m in solvers:
                _, solver, wav = m.split("-")
                for axis, val, opts in sweeps:
                    try:
                        img, sr, _ = self.reconstruct(dump, f"{tag}_{m}_{axis}{val}",
                                                      ["--solver", solver, "--wavelet", wav] + opts)
                    except bc.BenchError as e:  # e.g. a grid too large for the device: record, go on
                        bc.log(f"  effort {name} {m} {axis}={val}: {str(e).splitlines()[0]}")
                        self.effort.append(dict(scene=name, method=m, axis=axis, value=val, spp=spp, error=str(e)[:200]))
                        continue
                    its, res, conv = bc.stats_iterations(sr)
                    r = dict(scene=name, method=m, axis=axis, value=val, spp=spp, k=sr["k"], n=sr["n"],
                             iterations=its, inner_iterations=bc.stats_inner(sr), rel_residual=res,
                             converged=int(conv), t_render_s=st["t_render_s"],
                             t_recon_s=bc.recon_time(sr), t_solve_s=sr.get("t_solve_s", 0),
                             mse=bc.mse(img, ref), mse_edge=bc.mse(img, ref, edges), error="")
                    self.effort.append(r)
                    bc.log(f"  effort {name} {m} {axis}={val}: k={r['k']} its={its} recon {r['t_recon_s']:.2f}s "
                           f"MSE {r['mse']:.3e}")
            os.remove(dump)

    # ---- analysis -----------------------------------------------------------------------------
    def means(self):
        """Seed means per (scene, method, spp)."""
        g = {}
        for r in self.results:
            g.setdefault((r["scene"], r["method"], r["spp"]), []).append(r)
        out = {}
        for key, rs in g.items():  # an infinite MSE (a failed image) makes the mean infinite
            key = (key[0], key[1], int(_num(key[2])))
            out[key] = {f: float(np.nanmean([_num(x.get(f)) for x in rs])) for f in
                        ("mse", "mse_edge", "frames_mse", "frames_psnr", "t_render_s", "t_recon_s", "t_total_s",
                         "t_per_sample_us", "iterations", "samples")}
        return out

    def breakeven(self):
        """Per scene and cs variant: s* = the stratified spp whose MSE (log-log interpolation of the
        measured curve, extrapolated past the largest spp with the slope of its last two points)
        equals cs's MSE at 4 spp. With c the render cost per sample and P pixels, stratified at
        equal total time has 4 + t_rec / (P c) spp, so cs wins iff s* > 4 and
        c > c* = t_rec_cs / (P (s* - 4)). Reported with the measured c of the scene."""
        M = self.means()
        rows = []
        for scene in dict.fromkeys(r["scene"] for r in self.results):
            st = sorted((s, v) for (sc, m, s), v in M.items() if sc == scene and m == "stratified")
            if len(st) < 2:
                continue
            xs = np.log([s for s, _ in st])
            ys = np.log([v["mse"] for _, v in st])
            P = next(r["width"] * r["height"] for r in self.results if r["scene"] == scene)
            c_meas = float(np.mean([v["t_per_sample_us"] for _, v in st])) * 1e-6
            t_rec_strat = float(np.mean([v["t_recon_s"] for _, v in st]))
            for m in dict.fromkeys(r["method"] for r in self.results if r["scene"] == scene):
                if not m.startswith("cs") and m not in ("oidn", "gauss"):
                    continue
                v = M.get((scene, m, 4))
                if v is None:
                    continue
                y = math.log(v["mse"])
                if y >= ys[0] and ys[0] >= ys[-1]:  # worse than stratified at its smallest spp
                    s_eq = math.exp(xs[0])
                    if y > ys[0]:
                        s_eq = float("nan")
                elif y <= ys[-1]:
                    slope = (ys[-1] - ys[-2]) / (xs[-1] - xs[-2])
                    s_eq = math.exp(xs[-1] + (y - ys[-1]) / slope) if slope < 0 else float("inf")
                else:
                    # ys decreases with spp (Monte Carlo); find the bracketing segment
                    s_eq = float("nan")
                    for i in range(len(xs) - 1):
                        lo, hi = sorted((ys[i], ys[i + 1]))
                        if lo <= y <= hi and ys[i] != ys[i + 1]:
                            s_eq = math.exp(xs[i] + (y - ys[i]) * (xs[i + 1] - xs[i]) / (ys[i + 1] - ys[i]))
                            break
                t_extra = max(v["t_recon_s"] - t_rec_strat, 0.0)
                if not (s_eq > 4):
                    c_star = float("inf")
                    verdict = f"never ({m} at 4 spp is not more accurate than stratified at 4 spp)"
                else:
                    c_star = t_extra / (P * (s_eq - 4)) if math.isfinite(s_eq) else 0.0
                    verdict = "wins at this scene's cost" if c_meas > c_star else "loses at this scene's cost"
                rows.append(dict(scene=scene, method=m, mse_at_4spp=v["mse"], equivalent_stratified_spp=s_eq,
                                 t_recon_s=v["t_recon_s"], pixels=P, cost_per_sample_us_measured=c_meas * 1e6,
                                 breakeven_cost_per_sample_us=c_star * 1e6, verdict=verdict))
        return rows

    def write_csv(self, name, rows, fields=None):
        if not rows:
            return
        fields = fields or list(dict.fromkeys(k for r in rows for k in r))
        path = os.path.join(self.out, name)
        with open(path + ".tmp", "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=fields, extrasaction="ignore")
            w.writeheader()
            for r in rows:
                w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})
        os.replace(path + ".tmp", path)

    def save(self):
        self.write_csv("results.csv", self.results, RESULT_FIELDS)
        self.write_csv("variance.csv", self.variance)
        self.write_csv("gauss_sweep.csv", self.sweeps)
        self.write_csv("effort.csv", self.effort)
        self.write_csv("frames.csv", self.frames_rows)
        self.write_csv("references.csv", self.refs)
        self.be = self.breakeven()
        self.write_csv("breakeven.csv", self.be)
        self.write_summary()

    def write_summary(self):
        """summary.md: seed means per scene, method and spp, and the issue's quality targets checked
        against them (with the margin), for the lead's docs/BENCHMARKS.md."""
        M = self.means()
        be = {(r["scene"], r["method"]): r for r in self.be}
        L = ["# Accuracy benchmark summary", "",
             "Seed means of `results.csv`; MSE vs the reference, PSNR peak 1; times in seconds. "
             "Generated by tools/bench/bench_accuracy.py.", ""]
        scenes = list(dict.fromkeys(r["scene"] for r in self.results))
        spps = sorted({int(r["spp"]) for r in self.results})
        for sc in scenes:
            methods = list(dict.fromkeys(r["method"] for r in self.results if r["scene"] == sc))
            motion = any(r["kind"] == "motion" for r in self.results if r["scene"] == sc)
            L += [f"## {sc}", "", "| method | " + " | ".join(f"MSE {s} spp" for s in spps) +
                  " | edge MSE 4 spp | " + ("frames PSNR 4 spp | " if motion else "") +
                  "render s 4 spp | recon s 4 spp | eq. stratified spp of 4 spp | break-even us/sample |",
                  "|---" * (len(spps) + 6 + motion) + "|"]
            for m in methods:
                v4 = M.get((sc, m, 4), {})
                b = be.get((sc, m), {})
                cells = [f"{M[(sc, m, s)]['mse']:.3g}" if (sc, m, s) in M else "" for s in spps]
                cells.append(f"{v4.get('mse_edge', float('nan')):.3g}")
                if motion:
                    cells.append(f"{v4.get('frames_psnr', float('nan')):.2f}")
                cells += [f"{v4.get('t_render_s', float('nan')):.3g}", f"{v4.get('t_recon_s', float('nan')):.3g}",
                          f"{_num(b.get('equivalent_stratified_spp')):.3g}" if b else "",
                          f"{_num(b.get('breakeven_cost_per_sample_us')):.3g}" if b else ""]
                L.append(f"| {m} | " + " | ".join(cells) + " |")
            L.append("")
        # the quality targets of issue 6
        L += ["## Quality targets", "", "| target | scene | method | measured | met |", "|---|---|---|---|---|"]
        for sc in scenes:
            for m in dict.fromkeys(r["method"] for r in self.results if r["scene"] == sc):
                if not m.startswith("cs"):
                    continue
                b = be.get((sc, m))
                if b:
                    s_eq = _num(b["equivalent_stratified_spp"])
                    L.append(f"| 4 spp reaches stratified at 9 spp | {sc} | {m} | equivalent stratified spp "
                             f"{s_eq:.3g} | {'yes' if s_eq >= 9 else 'no'} |")
                worse = [(s, M[(sc, m, s)]["mse"] / M[(sc, 'stratified', s)]["mse"]) for s in spps
                         if (sc, m, s) in M and (sc, "stratified", s) in M and s <= 16
                         and not M[(sc, m, s)]["mse"] <= M[(sc, "stratified", s)]["mse"]]
                L.append(f"| never worse than stratified at equal spp (<= 16) | {sc} | {m} | "
                         + (", ".join(f"{s} spp: {x:.2f}x stratified's MSE" for s, x in worse) or "never worse")
                         + f" | {'no' if worse else 'yes'} |")
                if (sc, m, 4) in M and (sc, "oidn", 4) in M:
                    r = M[(sc, m, 4)]["mse"] / M[(sc, "oidn", 4)]["mse"]
                    L.append(f"| lower error than stratified + OIDN at 4 spp | {sc} | {m} | {r:.2f}x OIDN's MSE | "
                             f"{'yes' if r < 1 else 'no'} |")
                if m.startswith("cs3d") and (sc, m, 4) in M and (sc, "gauss", 4) in M:
                    v, g = M[(sc, m, 4)], M[(sc, "gauss", 4)]
                    L.append(f"| motion: lower blurred-image error than the tuned 3-D Gaussian (4 spp) | {sc} | {m} | "
                             f"{v['mse'] / g['mse']:.2f}x its MSE | {'yes' if v['mse'] < g['mse'] else 'no'} |")
                    L.append(f"| motion: higher mean per-frame PSNR than the tuned 3-D Gaussian (4 spp) | {sc} | {m} | "
                             f"{v['frames_psnr'] - g['frames_psnr']:+.2f} dB | "
                             f"{'yes' if v['frames_psnr'] > g['frames_psnr'] else 'no'} |")
        L += ["", "The motion targets are stated at 1% sampling; 4 spp over T frames is 4/T "
              "(6% at T = 64): run with the spp that gives 1% (T = 64: not an integer spp; use a larger T) "
              "to check them exactly.", ""]
        with open(os.path.join(self.out, "summary.md"), "w") as f:
            f.write("\n".join(L))

    def run(self):
        a = self.a
        t0 = time.time()
        self.edges, self.refimg = {}, {}
        static = []
        for name in a.scenes:
            scene, _ = bc.scene_variant(a.scene_files.get(name, name), a.size, self.work)
            motion = bc.plan(self.bins, scene, self.env)["frames"] > 1
            bc.log(f"scene {name} ({'motion' if motion else 'static'})")
            if motion:
                self.motion_scene(name)
            else:
                self.static_scene(name)
                static.append(name)
            self.save()
        eff = a.effort_scenes.split(",") if a.effort_scenes else static[:1]
        for name in eff:
            if name not in self.refimg or name in self.effort_done:
                continue
            bc.log(f"effort sweeps on {name}")
            self.effort_scene(name)
            self.save()
        info = dict(args={k: v for k, v in vars(a).items()}, tracer_fingerprint=self.fp,
                    version=os.popen(f"{self.bins['csi-render']} --version").read().strip(),
                    started=time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(t0)),
                    wall_s=time.time() - t0, runs=len(self.results))
        with open(os.path.join(self.out, "run.json"), "w") as f:
            json.dump(info, f, indent=1, default=str)
        if not a.no_plots:
            import bench_plots
            bench_plots.plot_all(self.out, self)
        if not a.keep:
            shutil.rmtree(self.work, ignore_errors=True)
        bc.log(f"done in {time.time() - t0:.0f} s: {self.out}")
        for r in self.be:
            bc.log(f"break-even {r['scene']:12s} {r['method']:14s} eq.spp {r['equivalent_stratified_spp']:.3g} "
                   f"c* {r['breakeven_cost_per_sample_us']:.3g} us/sample (measured "
                   f"{r['cost_per_sample_us_measured']:.3g}): {r['verdict']}")


def replot(out):
    """Recomputes breakeven.csv from results.csv and redraws the figures of an existing output
    directory (insets from the insets_<scene>.npz files the run saved)."""
    import bench_plots
    b = Bench.__new__(Bench)
    b.out = os.path.abspath(out)
    b.results = bench_plots.read_csv(os.path.join(b.out, "results.csv"))
    if not b.results:
        raise bc.BenchError(f"{out}: no results.csv")
    b.be = b.breakeven()
    b.write_csv("breakeven.csv", b.be)
    b.write_summary()
    for p in bench_plots.plot_all(b.out):
        print(p)


def main(argv=None):
    warnings.filterwarnings("ignore", "Mean of empty slice")
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["--replot"]:
        if len(argv) != 2:
            print("usage: bench_accuracy.py --replot OUT_DIR", file=sys.stderr)
            return 2
        try:
            replot(argv[1])
        except bc.BenchError as e:
            print(f"bench_accuracy: {e}", file=sys.stderr)
            return 1
        return 0
    a = parse_args(argv)
    try:
        Bench(a).run()
    except bc.BenchError as e:
        print(f"bench_accuracy: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
