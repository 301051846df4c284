#!/usr/bin/env python3
"""Samples at their cells' centres or jittered in their cells (csi-render --cell-point), against a
true stratified Monte Carlo and the pixel's integral (docs/bench/animation.md, session 46).

For each scene (a .scene path, or a bundled name: data/scenes/NAME.scene) at --size (the camera's
`size` rewritten in a copy, relative files made absolute), each spp and seed:
  reference  the mean of --ref-seeds runs of `csi-render --reference R` (every cell of a
             sqrt(R / T) x sqrt(R / T) lattice a pixel once a frame, jittered: its default)
  mc         `csi-render --method stratified` (jittered, one sample in each of the pixel's cells)
  centre     `csi-render` (the compressive method at its cells' centres: the default)
  jittered   `csi-render --cell-point jittered`
and prints one markdown row per scene and spp: the mean over seeds of Monte Carlo's image MSE,
and csi's at the centres and jittered over it (ratios of the means). --sheet FILE.png also
writes the images side by side (a row per scene: the reference, Monte Carlo, csi at the centres
and jittered, at the last spp and the first seed, 3x enlarged, linear radiance clipped at 1).

    .venv/bin/python tools/bench/cell_point.py tools/bench/scenes/kiosk.scene train --out OUT
    .venv/bin/python tools/bench/cell_point.py S --spp 4,9,16 --seeds 1,2,3,4 --time-steps 32

Renders are kept in OUT (a rerun reuses them); the table is also written to OUT/cell_point.md.
"""
import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bench_common as bc  # noqa: E402

sys.path.insert(0, os.path.join(bc.ROOT, "host", "python"))
from csi import atomic  # noqa: E402
from csi.preview import to_srgb8  # noqa: E402


def render(bins, scene, exr_path, args, env, log):
    if not os.path.exists(exr_path):
        bc.run([bins["csi-render"], scene, "-q", "-o", exr_path] + args, env=env, log=log)
    return bc.read_exr(exr_path).astype(np.float64)


def write_sheet(path, sheet, scale=3, pad=2):
    """One row per scene: its label, then the reference, Monte Carlo, csi at the centres and
    jittered, each enlarged `scale` times (nearest) and labelled."""
    from PIL import Image, ImageDraw, ImageFont

    font = ImageFont.load_default()
    box = font.getbbox("Ag")
    lh = box[3] - box[1] + 6
    cols = [("reference", "reference"), ("mc", "Monte Carlo"), ("centre", "csi, centres"),
            ("jittered", "csi, jittered")]
    h, w = sheet[0][1]["reference"].shape[:2]
    W = len(cols) * (w * scale + pad) + pad
    H = len(sheet) * (h * scale + 2 * lh + pad) + pad
    img = Image.new("RGB", (W, H), (24, 24, 24))
    d = ImageDraw.Draw(img)
    for r, (label, shown) in enumerate(sheet):
        y0 = pad + r * (h * scale + 2 * lh + pad)
        d.text((pad + 2, y0 + 1), label, fill=(230, 230, 230), font=font)
        for c, (key, text) in enumerate(cols):
            x0 = pad + c * (w * scale + pad)
            d.text((x0 + 2, y0 + lh + 1), text, fill=(230, 230, 230), font=font)
            tile = Image.fromarray(to_srgb8(shown[key])).resize((w * scale, h * scale), Image.NEAREST)
            img.paste(tile, (x0, y0 + 2 * lh))
    with atomic.target(path, suffix=".png") as tmp:
        img.save(tmp, format="PNG")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scenes", nargs="+", help="scene files or bundled scene names")
    ap.add_argument("--out", default="out/cell_point", help="folder for the renders [out/cell_point]")
    ap.add_argument("--size", default="64x64", help="image size W x H [64x64]")
    ap.add_argument("--spp", default="4,9,16", help="samples per pixel [4,9,16]")
    ap.add_argument("--seeds", default="1,2,3,4", help="seeds of each spp [1,2,3,4]")
    ap.add_argument("--time-steps", type=int, default=32, help="frames of a moving scene [32]")
    ap.add_argument("--ref-spp", type=int, default=0,
                    help="the reference's samples per pixel [0: 64 T for a volume, 1024 for a still image]")
    ap.add_argument("--ref-seeds", type=int, default=4, help="reference runs averaged [4]")
    ap.add_argument("--build", default=None, help="build folder [build, or $CSI_BUILD]")
    ap.add_argument("--sheet", default=None, help="also write the images side by side to this PNG")
    a = ap.parse_args()
    try:
        size = tuple(int(v) for v in a.size.lower().split("x"))
        spps = [int(v) for v in a.spp.split(",")]
        seeds = [int(v) for v in a.seeds.split(",")]
        if len(size) != 2:
            raise ValueError(a.size)
    except ValueError as e:
        sys.exit(f"cell_point.py: bad number in {e}")
    try:
        bins = bc.binaries(a.build)
        env = bc.default_env()
        os.makedirs(a.out, exist_ok=True)
        sheet = []
        rows = ["| scene | spp | seeds | MC MSE | csi (centres) / MC | csi jittered / MC |",
                "| --- | ---: | ---: | ---: | ---: | ---: |"]
        with open(os.path.join(a.out, "cell_point.log"), "a") as log:
            for sc in a.scenes:
                if not sc.endswith(".scene") and not os.path.exists(os.path.join(bc.SCENE_DIR, sc + ".scene")):
                    raise bc.BenchError(f"{sc}: neither a .scene file nor a bundled scene")
                if sc.endswith(".scene") and not os.path.exists(sc):
                    raise bc.BenchError(f"{sc}: no such file")
                scene, shash = bc.scene_variant(sc, size, a.out)
                name = os.path.splitext(os.path.basename(sc))[0]
                still = not bc.plan(bins, scene, env)["motion"]
                moving = [] if still else ["--time-steps", str(a.time_steps)]
                R = a.ref_spp or (1024 if still else 64 * a.time_steps)
                pre = os.path.join(a.out, f"{name}_{shash}")
                ref = np.mean([render(bins, scene, f"{pre}_ref{R}_{k}.exr",
                                      moving + ["--reference", str(R), "--seed", str(100 + k)], env, log)
                               for k in range(1, a.ref_seeds + 1)], axis=0)
                shown = {"reference": ref}
                for spp in spps:
                    e = {"mc": [], "centre": [], "jittered": []}
                    for s in seeds:
                        common = moving + ["--spp", str(spp), "--seed", str(s)]
                        runs = {"mc": ["--method", "stratified"], "centre": [], "jittered": ["--cell-point", "jittered"]}
                        for v, extra in runs.items():
                            img = render(bins, scene, f"{pre}_{v}_s{spp}_r{s}.exr", common + extra, env, log)
                            e[v].append(float(((img - ref) ** 2).mean()))
                            if spp == spps[-1] and s == seeds[0]:
                                shown[v] = img
                    m = {v: float(np.mean(x)) for v, x in e.items()}
                    row = (f"| {name} | {spp} | {len(seeds)} | {m['mc']:.2e} | {m['centre'] / m['mc']:.3f} | "
                           f"{m['jittered'] / m['mc']:.3f} |")
                    print(row, flush=True)
                    rows.append(row)
                sheet.append((f"{name}, {spps[-1]} spp, seed {seeds[0]}", shown))
        with open(os.path.join(a.out, "cell_point.md"), "w") as f:
            f.write("\n".join(rows) + "\n")
        if a.sheet:
            write_sheet(a.sheet, sheet)
    except bc.BenchError as e:
        sys.exit(f"cell_point.py: {e}")


if __name__ == "__main__":
    main()
