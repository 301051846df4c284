#!/usr/bin/env python3
"""What csi's accuracy on an animation costs in time (issue 12, the user's "show what accuracy
costs in time"): the render cost per sample above which csi pays, on Mitsuba animations.

csi reconstructs a volume from a fraction r of its cells; a baseline (the renderer's own
per-pixel mean and per-frame Monte Carlo `mc`, OIDN on those, `oidn`, or the oracle-tuned 3-D
Gaussian `gauss`, whose width no user could choose: a bound for a linear filter) reaches csi's
error only from more samples. Both run on the very samples bench_animation.py uses (its
mitsuba_case: Mitsuba 3 re-posed per time step, csi's random cells, PATHS paths per sample, the
variances beside them; its methods and metrics). For each csi run this finds, on a ladder of
rates, the rate r_eq at which the baseline's error equals csi's (log-log interpolation between
the two ladder rates around it; seeds' errors averaged first), then

    csi pays when a sample costs more than  c* = (t_csi - t_base(r_eq)) / (N(r_eq) - N(r))

with N(r) the samples at rate r and t the reconstruction's (or the baseline's) wall time, both
measured here in one process, one after the other (csi's faster of its second and third runs of
the case, its kernels built; the Gaussian's one run at the width the oracle chose, the sweep not
counted). c* is set beside what a sample costs Mitsuba,
measured in the same run (mitsuba_cost: the render time of the ladder's top rate less its lowest's,
over the samples between, so the per-frame re-posing drops out), and in Mitsuba paths (its time
per path at the top rate). Where the baseline
does not reach csi's error at the top rate, r_eq is above it and c* is an upper bound ("<");
where csi's error is above the baseline's at csi's own rate, csi does not pay at any cost
("never"). Image (the motion-blurred mean over t) and frames (the mean frame MSE) separately.

    .venv/bin/python tools/bench/bench_animation_time.py --out OUT      # anim_ball, anim_pan
    .venv/bin/python tools/bench/bench_animation_time.py --scenes anim_ball --paths 1 --out OUT

Writes OUT/results.csv (one row per scene, rate, seed and method) and OUT/summary.md.
"""
import argparse
import csv
import json
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import bench_animation as ba  # noqa: E402

BASELINES = ("mc", "oidn", "gauss")


def mitsuba_cost(scene, size, lo, hi, paths):
    """What a sample costs Mitsuba, measured here: the bridge renders csi's positions at rates lo
    and hi (each four times, the first compiling; the fastest of the other three counts), and the
    marginal cost is the time between over the samples between (the per-frame re-posing, the same
    at both, drops out). Returns (us per sample, us per path at hi)."""
    from csi import mitsuba_bridge as mb

    W, H, T = size
    sc = mb.load_scene(ba.MITSUBA_SCENES[scene], size=(W, H))
    timing = {}
    for r in (lo, hi):
        req = mb.positions_request((W, H), grid=W, method="random", seed=1, time_steps=T, fraction=r)
        runs = [mb.render_request(sc, req, paths=paths, seed=1).timing for _ in range(4)][1:]
        best = min(runs, key=lambda t: t["render_s"])
        timing[r] = (best["render_s"], len(req.xyt), best["per_path_us"])
    (t0, n0, _), (t1, n1, path_us) = timing[lo], timing[hi]
    return 1e6 * (t1 - t0) / (n1 - n0), path_us


def crossing(rates, errs, target):
    """The rate at which errs (decreasing with rate, as a power law between ladder points) equals
    target: (rate, kind) with kind "" inside the ladder, "<" above its top (None returned), "never"
    below its bottom."""
    if target >= errs[0]:
        return rates[0], "never"
    for i in range(1, len(rates)):
        if errs[i] <= target:
            a, b = np.log(errs[i - 1]), np.log(errs[i])
            u = (np.log(target) - a) / (b - a) if b != a else 1.0
            return float(np.exp(np.log(rates[i - 1]) + u * (np.log(rates[i]) - np.log(rates[i - 1])))), ""
    return None, "<"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", required=True, help="directory for results.csv and summary.md")
    ap.add_argument("--scenes", default="anim_ball,anim_pan",
                    help="Mitsuba animations (bench_animation's names, or a .py scene file)")
    ap.add_argument("--size", default="64x64x16", help="WxHxT")
    ap.add_argument("--rates", default="0.03,0.1", help="csi's fractions of the cells")
    ap.add_argument("--ladder", default="0.03,0.1,0.2,0.3,0.5,1.0", help="the baselines' fractions")
    ap.add_argument("--seeds", default="0,1")
    ap.add_argument("--paths", type=int, default=16, help="Mitsuba paths per sample")
    ap.add_argument("--ref-spp", type=int, default=1024)
    ap.add_argument("--methods", default=",".join(BASELINES), help="baselines, of " + ", ".join(BASELINES))
    ap.add_argument("--data", default=os.path.join(os.path.expanduser("~"), ".cache", "csi", "bench-anim"),
                    help="where bench_animation caches Mitsuba's references and samples")
    a = ap.parse_args()
    W, H, T = (int(v) for v in a.size.split("x"))
    rates = sorted(float(v) for v in a.rates.split(","))
    ladder = sorted(float(v) for v in a.ladder.split(","))
    seeds = [int(v) for v in a.seeds.split(",")]
    methods = [m for m in a.methods.split(",") if m]
    for m in methods:
        if m not in BASELINES:
            sys.exit(f"bench_animation_time: unknown baseline {m!r} (one of {', '.join(BASELINES)})")
    scenes = []
    for s in (v for v in a.scenes.split(",") if v):
        if s.endswith(".py"):
            name = os.path.splitext(os.path.basename(s))[0]
            ba.MITSUBA_SCENES[name] = os.path.abspath(s)
            s = name
        if s not in ba.MITSUBA_SCENES:
            sys.exit(f"bench_animation_time: unknown scene {s!r} (one of {', '.join(ba.MITSUBA_SCENES)}, or a .py)")
        scenes.append(s)
    os.makedirs(a.out, exist_ok=True)
    cells = W * H * T
    rows = []
    for scene in scenes:
        for seed in seeds:
            for r in sorted(set(rates) | set(ladder)):
                case = ba.mitsuba_case(scene, seed, r, (W, H, T), a.data, a.ref_spp, a.paths)
                todo = (["csi"] if r in rates else []) + (methods if r in ladder else [])
                for m in todo:
                    if m == "csi":
                        ba.run_csi(case)  # the library's kernels built and cached: time the next two
                        sec0 = ba.run_csi(case)[2]
                    img, fr, sec, notes = ba.run_method(case, m)
                    if m == "csi":
                        sec = min(sec, sec0)
                    if m == "gauss":  # its time without the oracle's sweep: one run at the width it chose
                        t0 = time.perf_counter()
                        ba.csi.reconstruct(case.pos, case.vals, case.grid, frames="on", estimator="gauss",
                                           gauss_sigma=notes["sigma_image"])
                        sec = time.perf_counter() - t0
                    met = ba.metrics(case, img, fr)
                    rows.append({"scene": scene, "rate": r, "seed": seed, "method": m, "samples": len(case.pos),
                                 "seconds": sec,
                                 "img_mse": met["img_mse"], "frames_mse": met["frames_mse"]})
                    ba.log(f"{scene} {100 * r:g}% s{seed} {m}: image {met['img_mse']:.3e} frames "
                           f"{met['frames_mse']:.3e} {sec:.2f} s")
    cost = {s: mitsuba_cost(s, (W, H, T), ladder[0], ladder[-1], a.paths) for s in scenes}
    with open(os.path.join(a.out, "results.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    summarize(rows, scenes, rates, ladder, methods, cells, cost, a)


def summarize(rows, scenes, rates, ladder, methods, cells, cost, a):
    def mean(scene, rate, method, key):
        v = [r[key] for r in rows if r["scene"] == scene and r["rate"] == rate and r["method"] == method]
        return float(np.mean(v))

    lines = ["# What csi's accuracy costs in time on Mitsuba animations", "",
             f"{a.size}, {a.paths} path(s) per sample, seeds {a.seeds}, {a.ref_spp}-spp references; errors and "
             "times are seed means. c*: the render cost per sample above which csi at its rate beats the "
             "baseline in equal total time (render + reconstruction); Mitsuba: what a sample cost it here.", ""]
    hdr = ("| scene | csi rate | csi s | of | baseline | rate for csi's error | baseline s | c* (us/sample) "
           "| Mitsuba us/sample | c* in Mitsuba paths |")
    lines += [hdr, "|" + "---|" * (hdr.count("|") - 1)]
    for scene in scenes:
        hi = ladder[-1]
        sample_us, path_us = cost[scene]
        for r in rates:
            t_csi, n_csi = mean(scene, r, "csi", "seconds"), r * cells
            for key, what in (("img_mse", "image"), ("frames_mse", "frames")):
                target = mean(scene, r, "csi", key)
                for m in methods:
                    errs = [mean(scene, x, m, key) for x in ladder]
                    secs = [mean(scene, x, m, "seconds") for x in ladder]
                    r_eq, kind = crossing(ladder, errs, target)
                    if kind == "" and r_eq <= r:
                        kind = "never"  # the baseline reaches csi's error from no more samples
                    if kind == "never":
                        cstar = paths = "never"
                        eq, t_b = f"{100 * r_eq:.1f}%", float(np.interp(r_eq, ladder, secs))
                    else:
                        x = r_eq if r_eq is not None else hi
                        t_b = float(np.interp(x, ladder, secs))
                        c = max(1e6 * (t_csi - t_b) / (x * cells - n_csi), 0.0)
                        bound = "< " if kind == "<" else ""
                        cstar, paths = f"{bound}{c:.0f}", f"{bound}{c / path_us:.0f}"
                        eq = f"> {100 * hi:g}%" if kind == "<" else f"{100 * r_eq:.1f}%"
                    lines.append(f"| {scene} | {100 * r:g}% | {t_csi:.2f} | {what} | {m} | {eq} | {t_b:.2f} | {cstar} | "
                                 f"{sample_us:.2g} | {paths} |")
    with open(os.path.join(a.out, "summary.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    with open(os.path.join(a.out, "run.json"), "w") as f:
        json.dump({"argv": sys.argv, "load": os.getloadavg(), "date": time.strftime("%Y-%m-%d %H:%M:%S")}, f)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
