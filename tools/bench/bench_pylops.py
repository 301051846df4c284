#!/usr/bin/env python3
"""csi's SpaRSA against PyLops FISTA on the same antialiasing problem (issues 3 and 6).

  .venv/bin/python tools/bench/bench_pylops.py --out bench-pylops               # 512^2 and 1024^2
  .venv/bin/python tools/bench/bench_pylops.py --quick --out bench-pylops-quick # 256^2, short

The problem (one channel, G): a scene rendered at Poisson-disk positions on a fine grid of k =
n x n cells (4x the output width), y = those samples. Both solvers see the same operator
  A = S . Phi^-1 . Psi
with S the restriction to the sample positions (pylops.Restriction), Phi^-1 the Wiener inverse of
the paper's Gaussian, (1 + lambda) G / (G^2 + lambda) on the spectrum (pylops FFT2D(real=True,
norm='ortho') . Diagonal . FFT2D^H is complex-valued, so the timed operator is the same filter as
a real PyLops operator on scipy.fft, both checked against numpy's irfft2(rfft2(x) * g)), and Psi the
periodized db4 synthesis (pylops DWT2D^H, PyWavelets underneath), with the same wavelet level
count (--levels, passed to csi too), lambda and Gaussian width (csi's spectral.h rule).

The objective: csi's SpaRSA minimises 0.5 ||y - A x||^2 + tau ||x||_1 with tau = tau_rel *
||A^H y||_inf (continuation down to it, then debiasing); PyLops FISTA minimises
||y - A x||^2 + eps ||x||_1 (threshold eps * alpha / 2), so eps = 2 tau makes them the same
problem. PyLops gets its step from its own power iteration (alpha = None), which is timed as part
of its solve (the CSV also gives the time of its first iteration, i.e. of that power iteration);
--pylops-step bound gives it 1 / (max Wiener gain)^2 instead, a valid bound on ||A||^2.

What is measured, in one run: csi-reconstruct's reconstruction time (setup + solve + integrate,
from its stats; after a warm-up run so kernel and FFT caches are warm) and wall time; its final
relative residual ||y - A x|| / ||y|| and image MSE against the reference. PyLops FISTA then runs
with a callback that records, per iteration, the elapsed solver time (the callback's own
evaluation time subtracted), the relative residual and the image MSE; reported: the time PyLops
needs to reach csi's residual, the time to reach csi's MSE, and its MSE at each. Speed-up =
PyLops time / csi time; where PyLops does not get there within --pylops-iter iterations, the
speed-up is a lower bound (marked '>').
"""
import argparse
import csv
import json
import os
import shutil
import sys
import time

import warnings

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bench_common as bc  # noqa: E402


def wiener_gain(n_h, n_w, out_h, out_w, lam, sigma_scale=1.0):
    """(1 + lambda) G / (G^2 + lambda) on the rfft2 half spectrum, G the paper's Gaussian with csi's
    per-axis rule (host/include/csi/spectral.h): sigma_phi = 1.1/4 * grid/out cells,
    sigma_G = n / (2 pi sigma_phi) in DFT-index units."""
    def g1(n, out):
        sphi = 1.1 * 0.25 * (n / out) * sigma_scale
        u = np.fft.fftfreq(n) * n
        sg = n / (2 * np.pi * sphi)
        return np.exp(-u ** 2 / (2 * sg ** 2))
    G = np.outer(g1(n_h, out_h), g1(n_w, out_w))
    g = (1 + lam) * G / (G ** 2 + lam)
    return g[:, : n_w // 2 + 1]


class _Wiener:
    """The Wiener inverse as a real, self-adjoint PyLops operator: irfft2(rfft2(x) * g) (scipy.fft,
    all cores). A real operator keeps FISTA's iterates real float32, as csi's are; the literal
    FFT2D . Diagonal . FFT2D^H composition is complex-valued and is used only to check this one."""

    @staticmethod
    def make(h, w, gh):
        import pylops
        import scipy.fft as sf

        class Wiener(pylops.LinearOperator):
            def __init__(self):
                super().__init__(dtype=np.dtype(np.float32), shape=(h * w, h * w))

            def _matvec(self, x):
                X = sf.rfft2(np.asarray(x, np.float32).reshape(h, w), workers=-1)
                return sf.irfft2(X * gh, s=(h, w), workers=-1).astype(np.float32).ravel()

            _rmatvec = _matvec

        return Wiener()


def build_operator(hdr, pos, levels, lam):
    import pylops
    from pylops.signalprocessing import DWT2D, FFT2D
    h, w = hdr["grid_h"], hdr["grid_w"]
    gh = wiener_gain(h, w, hdr["out_h"], hdr["out_w"], lam)
    Winv = _Wiener.make(h, w, gh)
    # check both constructions against numpy before trusting them with the timing
    F = FFT2D(dims=(h, w), norm="ortho", real=True, dtype=np.float32)
    Wlit = F.H @ pylops.Diagonal(gh.ravel().astype(np.complex64)) @ F
    x = np.random.default_rng(0).standard_normal(h * w).astype(np.float32)
    ref = np.fft.irfft2(np.fft.rfft2(x.reshape(h, w)) * gh, s=(h, w)).ravel()
    for name, op in (("FFT2D . Diagonal . FFT2D^H", Wlit), ("real Wiener", Winv)):
        for what, v in (("apply", op @ x), ("adjoint", op.H @ x)):
            err = np.abs(np.real(v) - ref).max() / np.abs(ref).max()
            if err > 1e-4:
                raise bc.BenchError(f"PyLops {name} {what} disagrees with numpy: {err:.2e}")
    Psi = DWT2D(dims=(h, w), wavelet="db4", level=levels, dtype=np.float32)
    idx = (pos[:, 1].astype(np.int64) * w + pos[:, 0]).astype(np.int64)
    order = np.argsort(idx)
    S = pylops.Restriction(h * w, idx[order], dtype=np.float32)
    return S @ Winv @ Psi.H, Psi, order


def box(f, hdr):
    h, w, oh, ow = hdr["grid_h"], hdr["grid_w"], hdr["out_h"], hdr["out_w"]
    return f.reshape(oh, h // oh, ow, w // ow).mean(axis=(1, 3))


def one_size(a, bins, env, out_w, work, logf):
    grid = out_w * 4
    bc.log(f"size {out_w}x{out_w}, grid {grid}^2")
    scene, _ = bc.scene_variant(a.scene, (out_w, out_w), work)
    # reference: every fine-grid cell traced once (16 spp on the 4x grid): the box image
    ref_exr = os.path.join(work, f"ref{out_w}.exr")
    bc.run([bins["csi-render"], scene, "-o", ref_exr, "--reference", "16", "-q"], env, log=logf)
    ref = bc.read_exr(ref_exr)[..., a.channel]
    # the samples: Poisson-disk positions on the 4x grid, a.spp per pixel
    d3 = os.path.join(work, f"s{out_w}.csid")
    bc.run([bins["csi-render"], scene, "-o", os.path.join(work, "mean.exr"), "--spp", str(a.spp), "--estimator",
            "mean", "--dump", d3, "--seed", "1", "-q"], env, log=logf)
    hdr, pos, vals = bc.read_dump(d3)
    y = np.ascontiguousarray(vals[:, a.channel], np.float32)
    d1 = os.path.join(work, f"s{out_w}_1ch.csid")
    bc.write_dump1(d1, hdr, pos, y)
    k = hdr["grid_w"] * hdr["grid_h"]

    # ours: a warm-up (kernel and FFT caches), then the timed run
    ours_exr, ours_js = os.path.join(work, "ours.exr"), os.path.join(work, "ours.json")
    cmd = [bins["csi-reconstruct"], d1, "-o", ours_exr, "--stats", ours_js, "-q", "--solver", "sparsa",
           "--wavelet", "db4", "--levels", str(a.levels), "--lambda", str(a.lam),
           # the operator and estimate PyLops is given: the paper's filter width, f_b integrated,
           # no per-pixel correction (csi's defaults change all three)
           "--sigma-spacing", "0", "--integrate", "filtered", "--correct", "none"]
    if a.tau_rel:
        cmd += ["--tau", str(a.tau_rel)]
    if a.max_iter:
        cmd += ["--max-iter", str(a.max_iter)]
    if a.tol:
        cmd += ["--tol", str(a.tol)]
    bc.run(cmd + ["--max-iter", "2"], env, log=logf)
    wall = bc.run(cmd, env, log=logf)
    with open(ours_js) as f:
        st = json.load(f)
    ch = st["channels"]["0"]
    img_ours = bc.read_exr(ours_exr)[..., 0]
    mse_ours = bc.mse(img_ours, ref)
    r_ours = float(ch["rel_residual"])
    t_ours = bc.recon_time(st)
    bc.log(f"  csi: {ch['iterations']} iterations, rel. residual {r_ours:.3e}, MSE {mse_ours:.3e}, "
           f"recon {t_ours:.2f} s (solve {st['t_solve_s']:.2f} s, wall {wall:.2f} s); {ch['message']}")

    # PyLops
    import pylops
    A, Psi, order = build_operator(hdr, pos, a.levels, a.lam)
    yo = y[order]
    ny = float(np.linalg.norm(yo))
    atb = float(np.abs(A.H @ yo).max())
    if a.tau_rel:
        tau_rel = a.tau_rel
        tau = tau_rel * atb
    elif ch.get("tau"):
        tau = float(ch["tau"])  # the tau csi's run ended with (its default rule), same objective
        tau_rel = tau / atb
    else:
        tau_rel = a.default_tau_rel
        tau = tau_rel * atb
    eps = 2 * tau
    trace = []
    state = {"t0": None, "excluded": 0.0}

    def callback(x):
        c0 = time.perf_counter()
        r = float(np.linalg.norm(yo - A @ x)) / ny
        img = box(np.asarray(Psi.H @ x).reshape(hdr["grid_h"], hdr["grid_w"]), hdr)
        m = bc.mse(img, ref)
        c1 = time.perf_counter()
        trace.append(dict(iteration=len(trace) + 1, t_s=c0 - state["t0"] - state["excluded"], rel_residual=r, mse=m))
        state["excluded"] += c1 - c0

    bc.log(f"  pylops FISTA: eps {eps:.3e} (tau_rel {tau_rel:g}), up to {a.pylops_iter} iterations")
    state["t0"] = time.perf_counter()
    alpha = None  # PyLops' default: 1 / (largest eigenvalue of A^H A) by its power iteration, timed
    if a.pylops_step == "bound":
        # ||S|| <= 1 and Psi is orthonormal, so ||A||^2 <= max Wiener gain^2: a valid step, no eigs
        alpha = 1.0 / float(wiener_gain(hdr["grid_h"], hdr["grid_w"], hdr["out_h"], hdr["out_w"], a.lam).max() ** 2)
    xinv, nit, _ = pylops.optimization.sparsity.fista(A, yo, niter=a.pylops_iter, eps=eps, alpha=alpha, tol=0,
                                                      callback=callback)
    t_pl_total = time.perf_counter() - state["t0"] - state["excluded"]

    def first(pred):
        for t in trace:
            if pred(t):
                return t
        return None

    hit_r = first(lambda t: t["rel_residual"] <= r_ours)
    hit_m = first(lambda t: t["mse"] <= mse_ours)
    last = trace[-1]
    row = dict(k=k, n=len(y), grid=grid, out=out_w, levels=a.levels, tau_rel=tau_rel,
               ours_iterations=ch["iterations"], ours_rel_residual=r_ours, ours_mse=mse_ours, ours_t_recon_s=t_ours,
               ours_t_solve_s=st["t_solve_s"], ours_t_wall_s=wall,
               pylops_iterations=nit, pylops_t_total_s=t_pl_total, pylops_final_rel_residual=last["rel_residual"],
               pylops_final_mse=last["mse"],
               # cost of one iteration: csi counts outer steps and inner (debiasing CG) steps, each
               # one A and one A^H; PyLops' from the trace, after its step-size power iteration
               ours_ms_per_iter=1e3 * st["t_solve_s"] / max(ch["iterations"] + ch.get("inner_iterations", 0), 1),
               pylops_ms_per_iter=1e3 * (last["t_s"] - trace[0]["t_s"]) / max(len(trace) - 1, 1),
               pylops_t_first_iter_s=trace[0]["t_s"])
    for name, hit in (("residual", hit_r), ("mse", hit_m)):
        if hit:
            row[f"pylops_t_to_{name}_s"] = hit["t_s"]
            row[f"pylops_iter_to_{name}"] = hit["iteration"]
            row[f"pylops_mse_at_{name}"] = hit["mse"]
            row[f"speedup_{name}"] = f"{hit['t_s'] / t_ours:.3g}"
        else:
            row[f"pylops_t_to_{name}_s"] = f">{t_pl_total:.4g}"
            row[f"pylops_iter_to_{name}"] = f">{nit}"
            row[f"pylops_mse_at_{name}"] = last["mse"]
            row[f"speedup_{name}"] = f">{t_pl_total / t_ours:.3g}"
    bc.log(f"  pylops: {nit} iterations in {t_pl_total:.2f} s, final rel. residual {last['rel_residual']:.3e}, "
           f"MSE {last['mse']:.3e}; speed-up to csi's residual {row['speedup_residual']}, to csi's MSE "
           f"{row['speedup_mse']}")
    for t in trace:
        t.update(k=k)
    for p in (d1, d3):
        os.remove(p)
    return row, trace


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="bench-pylops")
    ap.add_argument("--scene", default="checkerboard")
    ap.add_argument("--sizes", default="128,256", help="output widths; the grid is 4x (128 -> k = 512^2)")
    ap.add_argument("--spp", type=int, default=4)
    ap.add_argument("--channel", type=int, default=1, help="0 R, 1 G, 2 B")
    ap.add_argument("--levels", type=int, default=5)
    ap.add_argument("--lam", type=float, default=0.3, help="Wiener lambda (csi's default 0.3)")
    ap.add_argument("--tau-rel", type=float, default=0, help="tau / ||A^H y||_inf for both (default: csi's)")
    ap.add_argument("--default-tau-rel", type=float, default=1e-4,
                    help="csi's default tau_rel (host/include/csi/solve.h), used for PyLops when --tau-rel is not given")
    ap.add_argument("--max-iter", type=int, default=0, help="csi's iteration cap (default: the binary's)")
    ap.add_argument("--tol", type=float, default=0)
    ap.add_argument("--pylops-iter", type=int, default=500)
    ap.add_argument("--pylops-step", choices=("eigs", "bound"), default="eigs",
                    help="FISTA step: eigs = PyLops' power iteration (default, timed); bound = 1 / max "
                    "Wiener gain^2, a known bound on ||A||^2 (no eigs)")
    ap.add_argument("--build", default=None)
    ap.add_argument("--quick", action="store_true", help="one size, 64 (k = 256^2), 100 PyLops iterations")
    a = ap.parse_args()
    warnings.filterwarnings("ignore", "numpy backend always returns complex128")
    if a.quick:
        a.sizes = "64"
        a.pylops_iter = min(a.pylops_iter, 100)
        a.max_iter = a.max_iter or 100
        a.levels = min(a.levels, 5)
    bins = bc.binaries(a.build)
    env = bc.default_env()
    out = os.path.abspath(a.out)
    work = os.path.join(out, "work")
    os.makedirs(work, exist_ok=True)
    rows, traces = [], []
    with open(os.path.join(out, "commands.log"), "w") as logf:
        for s in (int(v) for v in a.sizes.split(",")):
            r, t = one_size(a, bins, env, s, work, logf)
            rows.append(r)
            traces += t
    fields = list(dict.fromkeys(k for r in rows for k in r))
    for name, rs, fs in (("pylops.csv", rows, fields), ("pylops_trace.csv", traces, list(traces[0]))):
        with open(os.path.join(out, name), "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=fs)
            w.writeheader()
            for r in rs:
                w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})
    plot(out, rows, traces)
    shutil.rmtree(work, ignore_errors=True)
    for r in rows:
        print(f"k = {r['grid']}^2: csi {r['ours_t_recon_s']:.2f} s (MSE {r['ours_mse']:.3e}, rel. res. "
              f"{r['ours_rel_residual']:.2e}); PyLops FISTA to that residual {r['pylops_t_to_residual_s']} s, to "
              f"that MSE {r['pylops_t_to_mse_s']} s; speed-up {r['speedup_residual']} / {r['speedup_mse']}")


def plot(out, rows, traces):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axs = plt.subplots(1, 2, figsize=(9, 3.4), dpi=80)
    for r, c in zip(rows, ("#1f77b4", "#d62728", "#2ca02c", "#9467bd")):
        tr = [t for t in traces if t["k"] == r["k"]]
        lab = f"{r['grid']}^2"
        axs[0].loglog([t["t_s"] for t in tr], [t["rel_residual"] for t in tr], color=c, label=f"PyLops FISTA {lab}")
        axs[0].plot([r["ours_t_recon_s"]], [r["ours_rel_residual"]], "*", ms=12, color=c, label=f"csi SpaRSA {lab}")
        axs[1].loglog([t["t_s"] for t in tr], [t["mse"] for t in tr], color=c, label=f"PyLops FISTA {lab}")
        axs[1].plot([r["ours_t_recon_s"]], [r["ours_mse"]], "*", ms=12, color=c, label=f"csi SpaRSA {lab}")
    axs[0].set_ylabel("relative residual")
    axs[1].set_ylabel("image MSE vs reference")
    for ax in axs:
        ax.set_xlabel("solver time (s)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle("csi SpaRSA (stars: its final point) vs PyLops FISTA, same operator and data", fontsize=9)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "pylops.png"))
    plt.close(fig)


if __name__ == "__main__":
    try:
        main()
    except bc.BenchError as e:
        sys.exit(f"bench_pylops: {e}")
