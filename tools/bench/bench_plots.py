#!/usr/bin/env python3
"""Plots of tools/bench/bench_accuracy.py's CSVs (matplotlib, Agg). Run on its own to redraw from an
output directory (the insets from the insets_<scene>.npz the run saved):

  .venv/bin/python tools/bench/bench_plots.py OUT_DIR
"""
import csv
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bench_common as bc  # noqa: E402

STYLE = {  # colour, marker: one per method, stable across figures
    "random": ("#999999", "x"), "stratified": ("#1f77b4", "o"), "oidn": ("#17becf", "D"),
    "cs-romp-db4": ("#d62728", "s"), "cs-romp-db8": ("#ff9896", "s"),
    "cs-sparsa-db4": ("#2ca02c", "^"), "cs-sparsa-db8": ("#98df8a", "^"),
    "gauss": ("#9467bd", "v"), "cs3d-sparsa": ("#2ca02c", "^"), "cs3d-romp": ("#d62728", "s"),
    "cs3d-paper": ("#bcbd22", "^"),
}
DPI = 80


def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import warnings
    warnings.filterwarnings("ignore", "Mean of empty slice")
    return plt


def _spp_axis(ax, spps):
    """Ticks at the measured spp values, printed plainly (log axes otherwise print 4x10^0)."""
    from matplotlib.ticker import FixedLocator, NullLocator, ScalarFormatter
    ax.xaxis.set_major_locator(FixedLocator(sorted(spps)))
    ax.xaxis.set_minor_locator(NullLocator())
    ax.xaxis.set_major_formatter(ScalarFormatter())


def read_csv(path):
    if not os.path.exists(path):
        return []
    with open(path) as f:
        rows = list(csv.DictReader(f))
    for r in rows:
        for k, v in r.items():
            try:
                r[k] = float(v)
            except (TypeError, ValueError):
                pass
    return rows


def seed_means(rows, keys, fields):
    g = {}
    for r in rows:
        g.setdefault(tuple(r[k] for k in keys), []).append(r)
    def num(v):
        try:
            return float(v)
        except (TypeError, ValueError):
            return float("nan")
    return {k: {f: float(np.nanmean([num(x.get(f)) for x in v])) for f in fields} for k, v in g.items()}


def _loglog_capped(ax, series, cap_from=("random", "stratified")):
    """Log-log lines per method; values above 30x the largest Monte Carlo value, infinite or NaN
    (a failed reconstruction) are drawn at that cap as an X, so one blow-up does not flatten the
    figure, and are named in the legend."""
    mc = [y for m, pts in series.items() if m in cap_from for _, y in pts if np.isfinite(y) and y > 0]
    cap = 30 * max(mc) if mc else float("inf")
    off = False
    for m, pts in series.items():
        c, mk = _style(m)
        good = [(x, y) for x, y in pts if np.isfinite(y) and 0 < y <= cap]
        bad = [x for x, y in pts if not (np.isfinite(y) and y <= cap)]
        if good:
            ax.loglog(*zip(*good), marker=mk, color=c, label=m)
        if bad:
            ax.loglog(bad, [cap] * len(bad), "X", color=c, ms=9, mec="k",
                      label=None if good else m)
            off = True
    if off:
        ax.axhline(cap, color="k", lw=0.5, ls=":")
        ax.text(0.02, 0.98, "X: off scale or NaN (see CSV)", transform=ax.transAxes, fontsize=6, va="top")


def _style(m):
    if m.endswith("-sharp"):  # --integrate sharp variants: the base method's colour, star marker
        return STYLE.get(m[:-6], ("k", "."))[0], "*"
    return STYLE.get(m, ("k", "."))


def plot_scene(out, scene, res, var, eff, frames):
    plt = _plt()
    rows = [r for r in res if r["scene"] == scene]
    if not rows:
        return []
    motion = rows[0]["kind"] == "motion"
    methods = list(dict.fromkeys(r["method"] for r in rows))
    M = seed_means(rows, ("method", "spp"), ("mse", "mse_edge", "frames_mse", "t_total_s", "t_recon_s"))
    made = []
    # 1. MSE vs spp (log-log), all pixels / edges (/ frames)
    panels = [("mse", "MSE, all pixels"), ("mse_edge", "MSE, edge pixels")]
    if motion:
        panels.append(("frames_mse", "mean per-frame MSE"))
    fig, axs = plt.subplots(1, len(panels), figsize=(4.2 * len(panels), 3.4), dpi=DPI)
    for ax, (f, title) in zip(axs, panels):
        series = {m: sorted((k[1], v[f]) for k, v in M.items() if k[0] == m and not (v[f] == 0))
                  for m in methods}
        _loglog_capped(ax, {m: p for m, p in series.items() if p and not all(np.isnan(y) for _, y in p)})
        ax.set_xlabel("samples per pixel")
        _spp_axis(ax, {k[1] for k in M})
        ax.set_title(title, fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
    axs[0].set_ylabel("MSE vs reference")
    axs[-1].legend(fontsize=7)
    fig.suptitle(f"{scene}: error vs spp ({rows[0]['width']:.0f}x{rows[0]['height']:.0f})", fontsize=10)
    fig.tight_layout()
    made.append(_save(fig, out, f"mse_spp_{scene}.png"))
    # 2. MSE vs total time (the trade-off)
    fig, ax = plt.subplots(figsize=(5, 3.6), dpi=DPI)
    # points joined in spp order (not time order: at small sizes times are noisy)
    _loglog_capped(ax, {m: [(v["t_total_s"], v["mse"]) for k, v in sorted(M.items(), key=lambda kv: kv[0][1])
                            if k[0] == m and v["mse"] > 0] for m in methods})
    ax.set_xlabel("render + reconstruction time (s)")
    ax.set_ylabel("MSE")
    ax.set_title(f"{scene}: error vs time (points: spp, joined in spp order)", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    made.append(_save(fig, out, f"mse_time_{scene}.png"))
    # 3. variance at edge pixels vs spp (Fig. 5)
    vr = [r for r in var if r["scene"] == scene and np.isfinite(r["var_edge"])]
    if vr:
        fig, ax = plt.subplots(figsize=(5, 3.6), dpi=DPI)
        for m in methods:
            pts = sorted((r["spp"], r["var_edge"]) for r in vr if r["method"] == m and r["var_edge"] > 0)
            if pts:
                c, mk = _style(m)
                ax.loglog(*zip(*pts), marker=mk, color=c, label=m)
        ax.set_xlabel("samples per pixel")
        _spp_axis(ax, {r["spp"] for r in vr})
        ax.set_ylabel("per-pixel variance (luminance)")
        ax.set_title(f"{scene}: variance at edge pixels over {int(vr[0]['seeds'])} seeds", fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
        fig.tight_layout()
        made.append(_save(fig, out, f"variance_{scene}.png"))
    # 4. solver effort and problem size
    er = [r for r in eff if r["scene"] == scene and r.get("error", "") in ("", None) and "mse" in r
          and isinstance(r["mse"], float)]
    if er:
        fig, axs = plt.subplots(1, 2, figsize=(9, 3.4), dpi=DPI)
        for m in dict.fromkeys(r["method"] for r in er):
            c, mk = _style(m)
            for axis, ls in (("max_iter", "-"), ("tol", ":")):
                pts = sorted((r["t_recon_s"], r["mse"]) for r in er if r["method"] == m and r["axis"] == axis)
                if pts:
                    axs[0].loglog(*zip(*pts), marker=mk, color=c, ls=ls, label=f"{m} ({axis} sweep)")
            pts = sorted((r["k"], r["t_recon_s"], r["mse"]) for r in er if r["method"] == m and r["axis"] == "k")
            if pts:
                ks, ts, ms = zip(*pts)
                axs[1].loglog(ks, ts, marker=mk, color=c, label=f"{m}: time")
                ax2 = axs[1].twinx() if not hasattr(axs[1], "_twin") else axs[1]._twin
                axs[1]._twin = ax2
                ax2.loglog(ks, ms, marker=mk, color=c, ls="--", label=f"{m}: MSE")
                ax2.set_ylabel("MSE (dashed)")
        axs[0].set_xlabel("reconstruction time (s)")
        axs[0].set_ylabel("MSE")
        axs[0].set_title("solver effort: iteration cap / tolerance", fontsize=10)
        axs[0].legend(fontsize=6)
        axs[0].grid(True, which="both", alpha=0.3)
        axs[1].set_xlabel("problem size k (fine-grid cells)")
        axs[1].set_ylabel("reconstruction time (s, solid)")
        axs[1].set_title(f"problem size at {int(er[0]['spp'])} spp", fontsize=10)
        axs[1].grid(True, which="both", alpha=0.3)
        axs[1].legend(fontsize=6, loc="upper left")
        fig.tight_layout()
        made.append(_save(fig, out, f"effort_{scene}.png"))
    # 5. per-frame PSNR (motion)
    fr = [r for r in frames if r["scene"] == scene]
    if fr:
        spps = sorted({r["spp"] for r in fr})
        spp = 4 if 4 in spps else spps[len(spps) // 2]
        fig, ax = plt.subplots(figsize=(5, 3.4), dpi=DPI)
        for m in methods:
            pts = sorted((r["frame"], r["psnr"]) for r in fr if r["method"] == m and r["spp"] == spp)
            if pts:
                c, mk = _style(m)
                ax.plot(*zip(*pts), color=c, label=m)
        ax.set_xlabel("frame")
        ax.set_ylabel("PSNR (dB, peak 1)")
        ax.set_title(f"{scene}: per-frame PSNR at {spp:g} spp, seed 1", fontsize=10)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
        fig.tight_layout()
        made.append(_save(fig, out, f"frames_{scene}.png"))
    return made


def plot_insets(out, scene, ref, images, edges, spp):
    """Reference with the inset box, then the inset of every method (nearest-neighbour zoom)."""
    plt = _plt()
    H, W = ref.shape[:2]
    s = max(8, min(H, W) // 4)
    # the window with the most edge pixels (a summed-area table over the edge mask)
    sat = np.pad(edges.astype(np.int64).cumsum(0).cumsum(1), ((1, 0), (1, 0)))
    cnt = sat[s:, s:] - sat[:-s, s:] - sat[s:, :-s] + sat[:-s, :-s]
    y0, x0 = np.unravel_index(np.argmax(cnt), cnt.shape)
    names = ["reference"] + list(images)
    fig, axs = plt.subplots(1, len(names) + 1, figsize=(1.9 * (len(names) + 1), 2.3), dpi=DPI)
    axs[0].imshow(bc.to_srgb8(ref), interpolation="nearest")
    axs[0].add_patch(__import__("matplotlib.patches", fromlist=["Rectangle"]).Rectangle(
        (x0 - 0.5, y0 - 0.5), s, s, fill=False, ec="red", lw=1))
    axs[0].set_title("reference (full)", fontsize=7)
    for ax, n in zip(axs[1:], names):
        img, m = (ref, 0.0) if n == "reference" else images[n]
        ax.imshow(bc.to_srgb8(img[y0:y0 + s, x0:x0 + s]), interpolation="nearest")
        ax.set_title(n if n == "reference" else f"{n}\nMSE {m:.2e}", fontsize=7)
    for ax in axs:
        ax.set_xticks([])
        ax.set_yticks([])
    fig.suptitle(f"{scene}: insets at {spp} spp, seed 1", fontsize=8)
    fig.tight_layout()
    return _save(fig, out, f"insets_{scene}.png")


def _save(fig, out, name):
    import matplotlib.pyplot as plt
    path = os.path.join(out, name)
    fig.savefig(path)
    plt.close(fig)
    return path


def plot_all(out, bench=None):
    res = read_csv(os.path.join(out, "results.csv"))
    var = read_csv(os.path.join(out, "variance.csv"))
    eff = read_csv(os.path.join(out, "effort.csv"))
    frames = read_csv(os.path.join(out, "frames.csv"))
    made = []
    for scene in dict.fromkeys(r["scene"] for r in res):
        made += plot_scene(out, scene, res, var, eff, frames)
        if bench is not None and scene in bench.insets:
            made.append(plot_insets(out, scene, bench.refimg[scene], bench.insets[scene], bench.edges[scene],
                                    bench.a.inset_spp))
        elif os.path.exists(os.path.join(out, f"insets_{scene}.npz")):  # saved by the run
            z = np.load(os.path.join(out, f"insets_{scene}.npz"))
            ims = {str(n): (img, float(m)) for n, img, m in zip(z["names"], z["images"], z["mse"])}
            spp = int(next((r["spp"] for r in res if r["scene"] == scene and r["spp"] == 4), 4))
            made.append(plot_insets(out, scene, z["ref"], ims, z["edges"], spp))
    return made


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    for p in plot_all(sys.argv[1]):
        print(p)
