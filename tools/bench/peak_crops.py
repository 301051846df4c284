#!/usr/bin/env python3
"""Crops around single pixels of the Mitsuba benchmark's dumps, side by side: the reference, the
per-pixel mean, csi, and csi given the samples' variances (`--variance`, docs/bench/mitsuba.md's
section on isolated peaks). One column per crop, one row per image; each crop is tone-mapped on
its own (x / (x + a), a the median of its reference), so a firefly over a dark floor and a
highlight on a bright sphere both show.

    .venv/bin/python tools/bench/peak_crops.py --data DATA --out peaks.png \\
        --crop envmap/s1_p64:91:52 --crop glossy_sun/s1_p64:92:114 --crop glints/s1_p64:64:90

--base BUILD adds a row: csi with the variances from another build (a change's before).
"""
import argparse
import os
import subprocess
import sys
import tempfile

import numpy as np
from PIL import Image, ImageDraw

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from bench_common import binaries, default_env, read_exr  # noqa: E402

HALF, ZOOM = 7, 8  # a crop is 15 x 15 pixels, each shown as 8 x 8


def images(exe, dump, tmp, base=None):
    """The mean, csi, (base's csi with the variances,) and csi with the variances, of one dump:
    (h, w, 3) float64 each."""
    out = []
    with_var = ["--variance", dump[: -len(".csid")] + ".variance.csid"]
    runs = [(exe, ["--estimator", "mean"]), (exe, [])] + ([(base, with_var)] if base else []) + [(exe, with_var)]
    for prog, args in runs:
        path = os.path.join(tmp, "x.exr")
        p = subprocess.run([prog, dump, "-o", path, "-q"] + args, capture_output=True, env=default_env())
        if p.returncode:
            sys.exit(f"peak_crops: {dump}: {p.stderr.decode(errors='replace').strip()}")
        out.append(read_exr(path).astype(np.float64))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", required=True, help="the Mitsuba dump cache (tools/bench/mitsuba_data.py)")
    ap.add_argument("--crop", action="append", required=True, metavar="SCENE/DUMP:X:Y",
                    help="a dump (without .csid) and the pixel at the crop's centre; repeatable")
    ap.add_argument("--out", required=True, help="the PNG")
    ap.add_argument("--build", help="build directory (default: the source tree's build/)")
    ap.add_argument("--base", help="another build: its csi with the variances as a row before this build's")
    ap.add_argument("--reference-spp", type=int, default=4096)
    a = ap.parse_args()
    exe = binaries(a.build)["csi-reconstruct"]
    base = binaries(a.base)["csi-reconstruct"] if a.base else None
    rows = ["reference", "mean", "csi"] + (["--variance, base"] if base else []) + ["csi --variance"]
    side = (2 * HALF + 1) * ZOOM
    pad, label_w, head = 4, 110, 16
    sheet = Image.new("RGB", (label_w + len(a.crop) * (side + pad), head + len(rows) * (side + pad)), "white")
    draw = ImageDraw.Draw(sheet)
    for r, name in enumerate(rows):
        draw.text((4, head + r * (side + pad) + side // 2), name, fill="black")
    with tempfile.TemporaryDirectory() as tmp:
        for col, spec in enumerate(a.crop):
            stem, x, y = spec.rsplit(":", 2)
            x, y = int(x), int(y)
            scene = stem.split("/")[0]
            ref = np.load(os.path.join(a.data, scene, f"reference_{a.reference_spp}.npy")).astype(np.float64)
            imgs = [ref] + images(exe, os.path.join(a.data, stem + ".csid"), tmp, base)
            h, w, _ = ref.shape
            y0, x0 = min(max(y - HALF, 0), h - 2 * HALF - 1), min(max(x - HALF, 0), w - 2 * HALF - 1)
            crops = [im[y0:y0 + 2 * HALF + 1, x0:x0 + 2 * HALF + 1] for im in imgs]
            scale = max(float(np.median(crops[0])), 1e-6)
            cx = label_w + col * (side + pad)
            draw.text((cx, 2), f"{scene} ({x}, {y})", fill="black")
            for r, c in enumerate(crops):
                v = np.clip(c, 0, None) / (np.clip(c, 0, None) + scale)  # tone map, 0..1
                tile = Image.fromarray((255 * v ** (1 / 2.2)).astype(np.uint8)).resize((side, side), Image.NEAREST)
                sheet.paste(tile, (cx, head + r * (side + pad)))
    sheet.save(a.out)


if __name__ == "__main__":
    main()
