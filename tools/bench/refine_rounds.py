#!/usr/bin/env python3
"""The second pass's pick, once or in rounds (docs/bench/mitsuba.md, sessions 21-22; "two" is
csi-mitsuba --refine-passes 2, an option). For each cached Mitsuba dump: csi's first pass
(csi-reconstruct), then the rules' picks of the pixels to sample in every cell, each rendered
through the bridge as csi-mitsuba --refine renders them and patched with csi.refine_apply; errors
against the reference for that image and for the per-pixel mean of the same samples, the first
pass's and the pick's (csi-reconstruct --estimator mean, which fills a pixel without a sample):

  once    csi_refine_positions, csi-mitsuba's default (checked equal to the library's pick here):
          a pixel is picked when its disagreement (image - its samples' mean)^2, summed over the
          channels, is at least `share` of the image's total;
  two     that pick, then once more against the disagreement it left (what a third pass after
          the patch would pick: the picked pixels then agree with their means, the rest are as
          before);
  twosig  two, its second round only where the disagreement is beyond 9 times the variance of
          the pixel's mean (from its samples' spread; none for a pixel of one sample);
  rounds  by decreasing disagreement, a pixel is picked while it holds `share` of the
          disagreement not yet picked; at most 1 / share pixels;
  nbr     once, then two's second round only among the 8-neighbours of once's pixels (the idea:
          an HDR pixel's leak into the fit lands beside it, where csi would more likely be worse
          than the mean; measured, csi was as often the better estimate there);
  nbr1    once, and every 8-neighbour of once's pixels holding share / 10 of the image's total;
  domP    once, then a second round only for a pixel holding P% (5, 10, 25) of what once left;
  vnbr    once, rendered; then two's second round only beside once's pixels where csi was the
          worse estimate, judged by once's new samples (see verified());
  vall    once, rendered; then two's second round only if over once's pixels csi was the worse
          estimate in sum, judged the same way.

    .venv/bin/python tools/bench/refine_rounds.py --data DIR[,DIR...] --spp 4 --json out.json
    .venv/bin/python tools/bench/refine_rounds.py --summary out.json[,more.json]

DIR is a directory of tools/bench/mitsuba_data.py; --scenes-dir adds scene files of your own
(SCENE.py, registered by name, as held-out scenes are). --rules measures some of the rules (the
summary judges each against once's rows); a cell's rules already in --json are not measured
again, so a later run with other rules adds them. --summary merges the rows of several files, the
first file's first, and says how far a later file's once rows are from the first's.
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(HERE)), "host", "python"))
from bench_common import binaries, default_env, read_exr  # noqa: E402
import mitsuba_data as md  # noqa: E402
import csi  # noqa: E402
from csi import dump as csid  # noqa: E402
from csi import mitsuba_bridge as mb  # noqa: E402
from csi.mitsuba_cli import refine_seed  # noqa: E402

RULES = ("once", "two", "twosig", "rounds", "nbr", "nbr1", "dom5", "dom10", "dom25", "vnbr", "vall")


def errors(img, ref):
    d = (img.astype(np.float64) - ref) ** 2
    return float(d.mean()), float((d / (ref.astype(np.float64) ** 2 + 0.01)).mean())


def disagreement(D, img):
    """Per pixel: (samples, disagreement), as csi_refine_positions computes them."""
    w, h, _ = D.grid
    ow, oh = D.out
    p = (D.xyt[:, 1] // (h // oh)).astype(np.int64) * ow + D.xyt[:, 0] // (w // ow)
    cnt = np.bincount(p, minlength=ow * oh)
    s = np.stack([np.bincount(p, weights=D.values[:, c].astype(np.float64), minlength=ow * oh)
                  for c in range(D.values.shape[1])], 1)
    x = img.reshape(-1, img.shape[2]).astype(np.float64)
    m = s / np.maximum(cnt, 1)[:, None]
    e = x - m
    e[np.abs(e) <= 1e-5 * (np.abs(x) + np.abs(m))] = 0  # float rounding is no disagreement
    d = (e ** 2).sum(1)
    d[cnt == 0] = 0
    return cnt, d


def pick(D, img, rule, share):
    cnt, d = disagreement(D, img)
    w, h, _ = D.grid
    ow, oh = D.out
    bw, bh = w // ow, h // oh
    cand = (cnt > 0) & (cnt < bw * bh) & (d > 0)
    total = d.sum()
    sel = cand & (d >= share * total)
    if rule == "two":
        sel |= cand & (d >= share * (total - d[sel].sum()))
    elif rule == "twosig":
        # two, its second round only where the disagreement is beyond the mean's own noise: 9 times
        # the variance of the pixel's mean from its samples' spread (a pixel of one sample has none)
        p = (D.xyt[:, 1] // bh).astype(np.int64) * ow + D.xyt[:, 0] // bw
        v = D.values.astype(np.float64)
        s1 = np.stack([np.bincount(p, weights=v[:, c], minlength=ow * oh) for c in range(v.shape[1])], 1)
        s2 = np.stack([np.bincount(p, weights=v[:, c] ** 2, minlength=ow * oh) for c in range(v.shape[1])], 1)
        n = np.maximum(cnt, 1)[:, None]
        noise = np.where(cnt > 1, (np.maximum(s2 - s1 ** 2 / n, 0) / np.maximum(n - 1, 1) / n).sum(1), np.inf)
        sel |= cand & (d >= share * (total - d[sel].sum())) & (d >= 9.0 * noise)
    elif rule == "rounds":
        idx = np.flatnonzero(cand)
        left, sel = total, np.zeros_like(sel)
        for q in idx[np.lexsort((idx, -d[idx]))]:
            if sel.sum() >= int(1 / share) or d[q] < share * left:
                break
            sel[q], left = True, left - d[q]
    elif rule.startswith("dom"):
        # a second round only for a pixel that holds a large part (5, 10, 25%) of what once left
        sel |= cand & (d >= float(rule[3:]) / 100 * (total - d[sel].sum()))
    elif rule in ("nbr", "nbr1"):
        # the 8-neighbours of once's pixels, not themselves picked
        m = sel.reshape(oh, ow)
        near = np.zeros((oh + 2, ow + 2), bool)
        for dy in (0, 1, 2):
            for dx in (0, 1, 2):
                near[dy:dy + oh, dx:dx + ow] |= m
        near = near[1:-1, 1:-1].reshape(-1) & ~sel
        bar = share * (total - d[sel].sum()) if rule == "nbr" else share / 10 * total
        sel = sel | (cand & near & (d >= bar))
    return cells_of(D, sel), int(sel.sum())


def cells_of(D, sel):
    """The cells without a sample of the pixels sel (a mask over the output's pixels)."""
    w, h, _ = D.grid
    ow, oh = D.out
    bw, bh = w // ow, h // oh
    taken = set(zip(D.xyt[:, 0].tolist(), D.xyt[:, 1].tolist()))
    cells = [(x, y, 0) for q in np.flatnonzero(sel) for y in range((q // ow) * bh, (q // ow + 1) * bh)
             for x in range((q % ow) * bw, (q % ow + 1) * bw) if (x, y) not in taken]
    return np.array(cells, np.uint32).reshape(-1, 3)


def mean_image(bins, env, tmp, D, cells, values):
    """csi's mean estimator on the first pass's samples and the pick's (as bench_refine.py gives
    it): each pixel's mean, and pixels without a sample filled as csi-reconstruct fills them."""
    xyt = np.concatenate([D.xyt, cells])
    w, h, _ = D.grid
    order = np.argsort((xyt[:, 2].astype(np.int64) * h + xyt[:, 1]) * w + xyt[:, 0], kind="stable")
    path = os.path.join(tmp, "all.csid")
    csid.write(path, csid.Dump(grid=D.grid, out=D.out, xyt=xyt[order], values=np.concatenate([D.values, values])[order],
                               seed=D.seed))
    subprocess.run([bins["csi-reconstruct"], path, "-o", os.path.join(tmp, "m1.exr"), "-q", "--estimator", "mean",
                    "--variance", "none"], check=True, env=env)
    return read_exr(os.path.join(tmp, "m1.exr"))


def cell(bins, env, tmp, d, scene, stem, share, scenes, rules):
    dump = os.path.join(d, scene, stem + ".csid")
    info = json.load(open(os.path.join(d, scene, stem + ".json")))
    ref = np.load(os.path.join(d, scene, "reference_4096.npy"))
    subprocess.run([bins["csi-reconstruct"], dump, "-o", os.path.join(tmp, "c0.exr"), "-q"], check=True, env=env)
    c0 = read_exr(os.path.join(tmp, "c0.exr"))
    subprocess.run([bins["csi-reconstruct"], dump, "-o", os.path.join(tmp, "m0.exr"), "-q", "--estimator", "mean",
                    "--variance", "none"], check=True, env=env)
    m0 = read_exr(os.path.join(tmp, "m0.exr"))
    D = csid.read(dump)
    grid = (*D.grid, *D.out)
    lib, _ = csi.refine_positions(D.xyt, D.values, grid, c0, share)
    if (scene, D.out) not in scenes:
        scenes.clear()
        scenes[(scene, D.out)] = mb.load_scene(md.SCENES[scene], size=D.out)
    row = {}
    for rule in rules:
        if rule in ("vnbr", "vall"):
            row[rule] = verified(bins, env, tmp, D, c0, scenes[(scene, D.out)], info, ref, share, rule)
            continue
        cells, pixels = pick(D, c0, rule, share)
        if rule == "once" and sorted(map(tuple, cells.tolist())) != sorted(map(tuple, np.asarray(lib).tolist())):
            raise SystemExit(f"{dump}: this script's pick is not csi_refine_positions'")
        img, mean = c0, m0
        if len(cells):
            s2 = mb.render_request(scenes[(scene, D.out)], csid.Dump(grid=D.grid, out=D.out, xyt=cells, values=None,
                                                                     seed=D.seed),
                                   paths=info["paths"], seed=refine_seed(D.seed))
            img, _ = csi.refine_apply(D.xyt, D.values, cells, s2.values, grid, c0)
            mean = mean_image(bins, env, tmp, D, cells, s2.values)
        ce, me = errors(img, ref), errors(mean, ref)
        row[rule] = {"pixels": pixels, "extra": len(cells) / len(D.xyt), "csi": ce, "mean": me,
                     "ratio": [ce[0] / me[0], ce[1] / me[1]]}
    return row


def verified(bins, env, tmp, D, c0, scene, info, ref, share, rule):
    """once, rendered; then a second round judged by once's new samples. At each of once's pixels
    the new samples' mean m2 is independent of the first pass, so |c0 - m2|^2 against |m0 - m2|^2
    compares csi's error with the first mean's without bias (m2's own variance is in both):
      vnbr  two's second round only among the 8-neighbours of once's pixels where csi was the
            worse estimate by that test;
      vall  two's second round, only when over once's pixels csi was the worse estimate in sum."""
    w, h, _ = D.grid
    ow, oh = D.out
    bw, bh = w // ow, h // oh
    grid = (*D.grid, *D.out)
    cnt, d = disagreement(D, c0)
    cand = (cnt > 0) & (cnt < bw * bh) & (d > 0)
    total = d.sum()
    sel = cand & (d >= share * total)
    cells1 = cells_of(D, sel)
    if not len(cells1):
        mean = mean_image(bins, env, tmp, D, cells1, np.zeros((0, D.values.shape[1]), np.float32))
        ce, me = errors(c0, ref), errors(mean, ref)
        return {"pixels": 0, "extra": 0.0, "csi": ce, "mean": me, "ratio": [ce[0] / me[0], ce[1] / me[1]], "second": 0}
    req = lambda cells: csid.Dump(grid=D.grid, out=D.out, xyt=cells, values=None, seed=D.seed)  # noqa: E731
    v1 = mb.render_request(scene, req(cells1), paths=info["paths"], seed=refine_seed(D.seed)).values
    C = D.values.shape[1]
    pix = lambda xyt: (xyt[:, 1] // bh).astype(np.int64) * ow + xyt[:, 0] // bw  # noqa: E731
    sums = lambda xyt, v: np.stack([np.bincount(pix(xyt), weights=v[:, c].astype(np.float64), minlength=ow * oh)  # noqa: E731
                                    for c in range(C)], 1)
    n1 = np.bincount(pix(cells1), minlength=ow * oh)
    m2 = sums(cells1, v1) / np.maximum(n1, 1)[:, None]
    m0 = sums(D.xyt, D.values) / np.maximum(cnt, 1)[:, None]
    x = c0.reshape(-1, C).astype(np.float64)
    excess = ((x - m2) ** 2).sum(1) - ((m0 - m2) ** 2).sum(1)  # > 0: csi the worse estimate
    excess[~sel] = 0
    rest = cand & ~sel & (d >= share * (total - d[sel].sum()))
    if rule == "vnbr":
        m = (sel & (excess > 0)).reshape(oh, ow)
        near = np.zeros((oh + 2, ow + 2), bool)
        for dy in (0, 1, 2):
            for dx in (0, 1, 2):
                near[dy:dy + oh, dx:dx + ow] |= m
        sel2 = rest & near[1:-1, 1:-1].reshape(-1)
    else:
        sel2 = rest if excess.sum() > 0 else np.zeros_like(rest)
    cells2 = cells_of(D, sel2)
    cells, values = cells1, v1
    if len(cells2):
        v2 = mb.render_request(scene, req(cells2), paths=info["paths"], seed=refine_seed(D.seed, 1)).values
        cells, values = np.concatenate([cells1, cells2]), np.concatenate([v1, v2])
    img, _ = csi.refine_apply(D.xyt, D.values, cells, values, grid, c0)
    mean = mean_image(bins, env, tmp, D, cells, values)
    ce, me = errors(img, ref), errors(mean, ref)
    return {"pixels": int(sel.sum() + sel2.sum()), "extra": len(cells) / len(D.xyt), "csi": ce, "mean": me,
            "ratio": [ce[0] / me[0], ce[1] / me[1]], "second": int(sel2.sum())}


def summary(paths):
    r, apart = {}, {}
    for path in paths.split(","):
        for key, v in json.load(open(path)).items():
            if "once" in v and "once" in r.get(key, {}):  # a later file's once against the first's
                apart.setdefault(path, []).append(max(abs(x / y - 1) for x, y in zip(v["once"]["ratio"],
                                                                                     r[key]["once"]["ratio"])))
            r.setdefault(key, {}).update({k: x for k, x in v.items() if k not in r[key]})
    above = lambda v, k, by=1: v[k]["ratio"][0] > by or v[k]["ratio"][1] > by  # noqa: E731
    print(f"{paths}: {len(r)} cells")
    for path, rel in apart.items():
        print(f"  {path}: once's ratios within {max(rel):.2g} (relative) of the first file's in {len(rel)} cells")
    for k in (k for k in RULES if all(k in v for v in r.values())):
        ex = [v[k]["extra"] for v in r.values()]
        gm = lambda f: math.exp(sum(math.log(f(v)) for v in r.values()) / len(r))  # noqa: E731
        worst = max(max(v[k]["ratio"]) for v in r.values())
        n_above = sum(above(v, k) for v in r.values())
        newly = sum(above(v, k) and not above(v, "once") for v in r.values())
        print(f"  {k:6s} above the mean {n_above:3d} (newly {newly}), by over 0.1% {sum(above(v, k, 1.001) for v in r.values())},"
              f" worst {worst:.4f}; extra samples {100 * np.mean(ex):.2f}% (max {100 * max(ex):.1f}%); csi / mean (MSE, geometric "
              f"mean) {gm(lambda v: v[k]['ratio'][0]):.4f}; csi's MSE over once's {gm(lambda v: v[k]['csi'][0] / v['once']['csi'][0]):.4f}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", help="mitsuba_data.py directories, comma-separated")
    ap.add_argument("--spp", default="4")
    ap.add_argument("--share", type=float, default=0.005)
    ap.add_argument("--scenes-dir", help="more scenes: DIR/NAME.py each")
    ap.add_argument("--build", default=None)
    ap.add_argument("--json", help="the rows (resumed if it exists: the rules a cell lacks are measured)")
    ap.add_argument("--rules", default=",".join(RULES), help="the rules to measure, comma-separated")
    ap.add_argument("--summary", metavar="JSON", help="print the summary of finished --json files (comma-separated) and stop")
    a = ap.parse_args(argv)
    if a.summary:
        summary(a.summary)
        return 0
    if not a.data or not a.json:
        ap.error("--data and --json are needed")
    if a.scenes_dir:
        for f in sorted(os.listdir(a.scenes_dir)):
            if f.endswith(".py"):
                md.SCENES[f[:-3]] = os.path.join(a.scenes_dir, f)
    rules = a.rules.split(",")
    if set(rules) - set(RULES):
        ap.error(f"--rules: one of {', '.join(RULES)}")
    bins, env = binaries(a.build), default_env()
    rows = json.load(open(a.json)) if os.path.exists(a.json) else {}
    scenes = {}
    with tempfile.TemporaryDirectory() as tmp:
        for d in a.data.split(","):
            for scene in sorted(s for s in os.listdir(d) if s in md.SCENES):
                for spp in a.spp.split(","):
                    for stem in (f"s{spp}_p{p}{m}" for p in (1, 64) for m in ("", "_poisson")):
                        key = f"{os.path.basename(d.rstrip('/'))} {scene} {stem}"
                        todo = [k for k in rules if k not in rows.get(key, {})]
                        if not todo or not os.path.exists(os.path.join(d, scene, stem + ".csid")):
                            continue
                        rows.setdefault(key, {}).update(cell(bins, env, tmp, d, scene, stem, a.share, scenes, todo))
                        print(key, {k: (v["pixels"], f"{100 * v['extra']:.2f}%", [round(x, 4) for x in v["ratio"]])
                                    for k, v in rows[key].items()}, flush=True)
                        with open(a.json, "w") as f:
                            json.dump(rows, f, indent=0)
    summary(a.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
