#!/usr/bin/env python3
"""csi-reconstruct alone on fixed path-traced dumps against the mean of the same samples, and the
rule that would bound it: the mean at the pixels that decide the image (issue 9, section 2;
docs/bench/mitsuba.md, sessions 20 and 25).

Without csi-mitsuba's second pass the samples are fixed, and a cell can be above the mean of the
same samples when one pixel decides it (a sun, a lamp, an emitter's edge). The rule measured
here moves each pixel from csi's value c towards its own mean m by

    w = clamp((share - lo) / (hi - lo), 0, 1),   share = d / sum over pixels of d,
    d = sum over channels of (c - m)^2,

i.e. where csi and the mean disagree by a large share of the image's disagreement (the share
csi-reconstruct --refine-request picks at, 0.5%), fully from `hi` on; a rule of the samples alone.
"bright" rules move only a pixel both see bright (the lower of csi's and the mean's channel means
at least 0.3 times the higher), which leaves a firefly (a mean far above csi) to csi, as session
20's rule did, and (as csi/settle.h's rule, `--settle`) only a pixel one of them sees beyond 4
times the image's mean pixel. csi's image is csi-reconstruct's with `--settle off`: the rules
are measured on the fit as it was before that step.
For every dump of each DATA directory (tools/bench/mitsuba_data.py's layout: SCENE/sSPP_pPATHS
[_poisson].csid and SCENE/reference_SPP.npy), csi-reconstruct's default and `--estimator mean`,
then per rule the MSE and relMSE over the mean's, grouped by spp x paths and in all.

    .venv/bin/python tools/bench/decided_mean.py --data /work/mdata,/work/mdata_s2 --json out.json
    .venv/bin/python tools/bench/decided_mean.py --figure settle.png --figure-cells DIR/SCENE/STEM,...

--figure: per cell a column of crops around its most disagreeing pixel (the reference, the mean,
csi without settling and csi-reconstruct's default), each tone-mapped on its own as
bench_refine.py's figure, with the MSE of the whole image over the mean's under it.
"""
import argparse
import glob
import json
import math
import os
import re
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from bench_common import binaries  # noqa: E402
from bench_real_samples import errors, reconstruct  # noqa: E402

# (name, lo, hi): the share at which the move to the mean starts and where it is whole
RULES = [("csi", None, None, False), ("ramp 0.5-2%", 0.005, 0.02, False),
         ("bright ramp 0.5-2%", 0.005, 0.02, True), ("bright ramp 0.5-5%", 0.005, 0.05, True),
         ("bright ramp 0.5-10%", 0.005, 0.1, True), ("bright ramp 2-20%", 0.02, 0.2, True)]


def dumps(data):
    """(dump path, reference path, spp, paths) for every dump of DATA whose scene has a reference."""
    for scene_dir in sorted(glob.glob(os.path.join(data, "*", ""))):
        refs = sorted(glob.glob(os.path.join(scene_dir, "reference_*.npy")))
        if not refs:
            continue
        for dump in sorted(glob.glob(os.path.join(scene_dir, "s*_p*.csid"))):
            m = re.fullmatch(r"s(\d+)_p(\d+)(_poisson)?\.csid", os.path.basename(dump))
            if m:
                yield dump, refs[-1], int(m.group(1)), int(m.group(2))


def moved(c, m, lo, hi, bright):
    if lo is None:
        return c
    d = ((c - m) ** 2).sum(-1)
    share = d / d.sum() if d.sum() > 0 else d
    w = np.clip((share - lo) / (hi - lo), 0.0, 1.0)
    if bright:
        cm, mm = c.mean(-1), m.mean(-1)
        w = np.where((np.minimum(cm, mm) >= 0.3 * np.maximum(cm, mm)) & (np.maximum(cm, mm) >= 4 * mm.mean()), w, 0.0)
    return c + w[..., None] * (m - c)


CROP, ZOOM = 7, 8  # a crop is 15 x 15 pixels, each shown as 8 x 8


def figure(exe, cells, out):
    from PIL import Image, ImageDraw

    names = ["reference", "mean", "csi, --settle off", "csi (default)"]
    side, pad, label_w, head, foot = (2 * CROP + 1) * ZOOM, 4, 110, 16, 14
    sheet = Image.new("RGB", (label_w + len(cells) * (side + pad), head + len(names) * (side + foot + pad)), "white")
    draw = ImageDraw.Draw(sheet)
    for r, name in enumerate(names):
        draw.text((4, head + r * (side + foot + pad) + side // 2), name, fill="black")
    with tempfile.TemporaryDirectory() as tmp:
        for col, spec in enumerate(cells):
            base, stem = os.path.split(spec)
            dump = os.path.join(base, stem + ".csid")
            refs = sorted(glob.glob(os.path.join(base, "reference_*.npy")))
            ref = np.load(refs[-1]).astype(np.float64)[..., :3]
            m = reconstruct(exe, dump, ["--estimator", "mean"], tmp)[..., :3]
            off = reconstruct(exe, dump, ["--settle", "off"], tmp)[..., :3]
            on = reconstruct(exe, dump, [], tmp)[..., :3]
            h, w, _ = ref.shape
            y, x = np.unravel_index(np.argmax(((off - m) ** 2).sum(-1)), (h, w))
            y0, x0 = min(max(y - CROP, 0), h - 2 * CROP - 1), min(max(x - CROP, 0), w - 2 * CROP - 1)
            m0 = errors(m, ref)[0]
            imgs = [ref, m, off, on]
            crops = [im[y0:y0 + 2 * CROP + 1, x0:x0 + 2 * CROP + 1] for im in imgs]
            scale = max(float(np.median(crops[0])), 1e-6)
            top = np.log1p(max(float(crops[0].max()), scale) / scale)
            cx = label_w + col * (side + pad)
            draw.text((cx, 2), f"{os.path.basename(base)} {stem}", fill="black")
            for r, (im, c) in enumerate(zip(imgs, crops)):
                v = np.clip(np.log1p(np.clip(c, 0, None) / scale) / top, 0, 1)
                tile = Image.fromarray((255 * v ** (1 / 2.2)).astype(np.uint8)).resize((side, side), Image.NEAREST)
                ty = head + r * (side + foot + pad)
                sheet.paste(tile, (cx, ty))
                if r:
                    draw.text((cx, ty + side + 1), f"MSE {errors(im, ref)[0] / m0:.3f}x the mean's", fill="black")
    sheet.save(out)


def geo(v):
    return math.exp(sum(math.log(x) for x in v) / len(v))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", help="mitsuba_data.py directories, separated by ','")
    ap.add_argument("--figure", metavar="OUT.png", help="crops of --figure-cells instead of the tables")
    ap.add_argument("--figure-cells", default="", help="DIR/SCENE/STEM of dumps, separated by ','")
    ap.add_argument("--build", help="build directory (default: the source tree's build/)")
    ap.add_argument("--json", help="write every cell's figures here")
    a = ap.parse_args()
    exe = binaries(a.build)["csi-reconstruct"]
    if a.figure:
        figure(exe, [c for c in a.figure_cells.split(",") if c], a.figure)
        return
    if not a.data:
        ap.error("--data is needed (or --figure)")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for data in a.data.split(","):
            for dump, refp, spp, paths in dumps(data):
                ref = np.load(refp).astype(np.float64)[..., :3]
                c = reconstruct(exe, dump, ["--settle", "off"], tmp)[..., :3]
                m = reconstruct(exe, dump, ["--estimator", "mean"], tmp)[..., :3]
                m0, r0 = errors(m, ref)
                row = dict(dump=dump, spp=spp, paths=paths, negative=int((c < 0).sum()))
                for name, lo, hi, bright in RULES:
                    e, r = errors(moved(c, m, lo, hi, bright), ref)
                    row[name] = (e / m0, r / r0)
                rows.append(row)
                print(f"{dump}: " + "  ".join(f"{n} {row[n][0]:.4f} / {row[n][1]:.4f}" for n, *_ in RULES),
                      flush=True)
    if a.json:
        with open(a.json, "w") as f:
            json.dump(rows, f, indent=1)
    groups = sorted({(r["spp"], r["paths"]) for r in rows})
    print("\n| cells | " + " | ".join(f"{n}: MSE / relMSE (geometric mean)" for n, *_ in RULES) + " |")
    print("|---|" + "---|" * len(RULES))
    for g in groups + [None]:
        sel = [r for r in rows if g is None or (r["spp"], r["paths"]) == g]
        label = "all" if g is None else f"{g[0]} spp x {g[1]}"
        print(f"| {label} ({len(sel)}) | " + " | ".join(
            f"{geo([r[n][0] for r in sel]):.3f} / {geo([r[n][1] for r in sel]):.3f}" for n, *_ in RULES) + " |")
    print("\n| rule | MSE above the mean (by > 1%) | worst MSE | relMSE above (by > 1%) | worst relMSE |")
    print("|---|---|---|---|---|")
    for n, *_ in RULES:
        e = [r[n][0] for r in rows]
        q = [r[n][1] for r in rows]
        print(f"| {n} | {sum(x > 1 for x in e)} ({sum(x > 1.01 for x in e)}) | {max(e):.4f} | "
              f"{sum(x > 1 for x in q)} ({sum(x > 1.01 for x in q)}) | {max(q):.4f} |")
    print(f"\nnegative values in csi's images: {sum(r['negative'] for r in rows)}")


if __name__ == "__main__":
    main()
