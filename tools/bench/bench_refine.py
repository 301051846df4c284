#!/usr/bin/env python3
"""csi's second pass on a path tracer's samples (csi-reconstruct --refine-request, csi-mitsuba
--refine; docs/bench/mitsuba.md): for each cached Mitsuba dump, the cells csi asks for next
rendered by Mitsuba as csi-mitsuba --refine renders them, appended, and the image reconstructed
again; errors against Mitsuba's reference before and after, for csi and for the mean of the
very same samples.

    .venv/bin/python tools/bench/bench_refine.py --data DIR[,DIR2...] --json out.json --md out.md
    .venv/bin/python tools/bench/bench_refine.py --data DIR --figure refine.png --figure-cells horizon/s4_p64_poisson

DIR is a directory of tools/bench/mitsuba_data.py (its seed is read from each dump's .json). Per
(scene, spp, paths, positions) cell: csi's MSE and relMSE over the mean's on the first pass's
samples ("before"), the same on all samples ("after": csi and the mean both given the extra
samples, csi re-solved as csi-reconstruct does on the merged dump), the patch ("patched": the
first pass's reconstruction with each refined pixel the mean of all its samples: csi-mitsuba
--refine's image before session 48, which settles after it with several paths per sample),
and how many cells and pixels the request held. Each renders only the requested cells (a few hundred paths'
batches): a cell costs seconds.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(ROOT, "host", "python"))
from bench_common import binaries, default_env, read_exr  # noqa: E402
import mitsuba_data as md  # noqa: E402
import csi  # noqa: E402
from csi import dump as csid  # noqa: E402
from csi import mitsuba_bridge as mb  # noqa: E402
from csi.mitsuba_cli import refine_seed  # noqa: E402


def errors(img, ref):
    d = (img.astype(np.float64) - ref) ** 2
    return float(d.mean()), float((d / (ref.astype(np.float64) ** 2 + 0.01)).mean())


def recon(bins, dump, out, args, env):
    subprocess.run([bins["csi-reconstruct"], dump, "-o", out, "-q"] + args, check=True, env=env)
    return read_exr(out)


def cell(bins, env, tmp, d, scene, stem, share, scenes_cache, images=None):
    dump = os.path.join(d, scene, stem + ".csid")
    info = json.load(open(os.path.join(d, scene, stem + ".json")))
    ref = np.load(md.reference_path(d, scene))
    req_path = os.path.join(tmp, "req.csid")
    if os.path.exists(req_path):
        os.remove(req_path)
    st_path = os.path.join(tmp, "st.json")
    c0 = recon(bins, dump, os.path.join(tmp, "c0.exr"), ["--refine-request", req_path, "--refine-share", str(share),
                                                         "--stats", st_path], env)
    st = json.load(open(st_path))
    m0 = recon(bins, dump, os.path.join(tmp, "m0.exr"), ["--estimator", "mean"], env)
    row = {"cells": st["refine_cells"], "pixels": st["refine_pixels"], "samples": st["records"],
           "csi_before": errors(c0, ref), "mean_before": errors(m0, ref)}
    if row["cells"]:
        D = csid.read(dump)
        req = csid.read(req_path, want="request")
        key = (scene, D.out)
        if key not in scenes_cache:
            scenes_cache.clear()
            scenes_cache[key] = mb.load_scene(md.SCENES[scene], size=D.out)
        s = mb.render_request(scenes_cache[key], req, paths=info["paths"], seed=refine_seed(D.seed))
        row["mitsuba_s"] = s.timing["render_s"]
        xyt = np.concatenate([D.xyt, req.xyt])
        w, h, _ = D.grid
        order = np.argsort((xyt[:, 2].astype(np.int64) * h + xyt[:, 1]) * w + xyt[:, 0], kind="stable")
        aug = os.path.join(tmp, "aug.csid")
        csid.write(aug, csid.Dump(grid=D.grid, out=D.out, xyt=xyt[order], values=np.concatenate([D.values, s.values])[order],
                                  seed=D.seed))
        vp = os.path.join(d, scene, stem + ".variance.csid")
        args = ["--variance", "none"]
        if os.path.exists(vp) and s.variance is not None:
            V = csid.read(vp)
            csid.write(os.path.join(tmp, "aug.variance.csid"),
                       csid.Dump(grid=D.grid, out=D.out, xyt=xyt[order],
                                 values=np.concatenate([V.values, s.variance])[order], seed=D.seed))
            args = ["--variance", os.path.join(tmp, "aug.variance.csid")]
        c1 = recon(bins, aug, os.path.join(tmp, "c1.exr"), args, env)
        m1 = recon(bins, aug, os.path.join(tmp, "m1.exr"), ["--estimator", "mean", "--variance", "none"], env)
        row["csi_after"], row["mean_after"] = errors(c1, ref), errors(m1, ref)
        # csi-mitsuba's image (csi-reconstruct DUMP --refine-with MORE): the first pass's, each
        # refined pixel the mean of all its samples
        cp, _ = csi.refine_apply(D.xyt, D.values, req.xyt, s.values, (*D.grid, *D.out), c0)
        row["csi_patch"] = errors(cp, ref)
    else:
        row["csi_after"], row["mean_after"], c1, m1 = row["csi_before"], row["mean_before"], c0, m0
        row["csi_patch"], cp = row["csi_before"], c0
    if images is not None:
        images.update(reference=ref, mean=m0, csi=c0, mean_after=m1, csi_after=cp,
                      picked=csid.read(req_path, want="request").xyt if row["cells"] else np.zeros((0, 3), np.uint32),
                      factor=D.grid[0] // D.out[0] if row["cells"] else 1)
    return row


HALF, ZOOM = 7, 8  # a crop is 15 x 15 pixels, each shown as 8 x 8


def figure(bins, env, tmp, d, specs, share, out):
    """One column per cell (SCENE/STEM), a crop around its brightest picked pixel: the reference, the
    mean and csi of the first pass, the mean and csi of all the samples; each crop tone-mapped
    on its own, log(1 + x / a) / log(1 + max / a), a the median and max the largest value of its
    reference, so that a sun and the ground beside it both show."""
    from PIL import Image, ImageDraw

    names = ["reference", "mean", "csi", "mean, refined", "csi, refined"]  # csi-mitsuba --refine's
    keys = ["reference", "mean", "csi", "mean_after", "csi_after"]
    side, pad, label_w, head = (2 * HALF + 1) * ZOOM, 4, 100, 16
    sheet = Image.new("RGB", (label_w + len(specs) * (side + pad), head + len(keys) * (side + pad)), "white")
    draw = ImageDraw.Draw(sheet)
    for r, name in enumerate(names):
        draw.text((4, head + r * (side + pad) + side // 2), name, fill="black")
    for col, spec in enumerate(specs):
        scene, stem = spec.split("/")
        im = {}
        cell(bins, env, tmp, d, scene, stem, share, {}, im)
        h, w, _ = im["reference"].shape
        if len(im["picked"]):  # the brightest picked pixel (by the reference)
            px = np.unique((im["picked"][:, 1] // im["factor"]) * w + im["picked"][:, 0] // im["factor"])
            y, x = divmod(int(px[np.argmax(im["reference"].mean(-1).ravel()[px])]), w)
        else:
            y, x = np.unravel_index(np.argmax(im["reference"].mean(-1)), (h, w))
        y0, x0 = min(max(y - HALF, 0), h - 2 * HALF - 1), min(max(x - HALF, 0), w - 2 * HALF - 1)
        crops = [np.asarray(im[k], np.float64)[y0:y0 + 2 * HALF + 1, x0:x0 + 2 * HALF + 1] for k in keys]
        scale = max(float(np.median(crops[0])), 1e-6)
        top = np.log1p(max(float(crops[0].max()), scale) / scale)
        cx = label_w + col * (side + pad)
        draw.text((cx, 2), f"{scene} {stem}", fill="black")
        for r, c in enumerate(crops):
            v = np.clip(np.log1p(np.clip(c, 0, None) / scale) / top, 0, 1)
            tile = Image.fromarray((255 * v ** (1 / 2.2)).astype(np.uint8)).resize((side, side), Image.NEAREST)
            sheet.paste(tile, (cx, head + r * (side + pad)))
    sheet.save(out)


def summary(rows):
    r = lambda k, a, b, i: np.array([v[a][i] / v[b][i] for v in rows.values()])
    above = lambda a, b: sum(1 for v in rows.values() if v[a][0] > v[b][0] or v[a][1] > v[b][1])
    gm = lambda x: float(np.exp(np.log(x).mean()))
    ex = np.array([v["cells"] / v["samples"] for v in rows.values()])
    return {"cells": len(rows), "above_before": above("csi_before", "mean_before"),
            "above_after": above("csi_after", "mean_after"), "above_patch": above("csi_patch", "mean_after"),
            "patch_over_before_gm": gm(r(0, "csi_patch", "csi_before", 0)),
            "patch_over_after_gm": gm(r(0, "csi_patch", "csi_after", 0)),
            "patch_over_mean_after_gm": gm(r(0, "csi_patch", "mean_after", 0)),
            "mse_before_gm": gm(r(0, "csi_before", "mean_before", 0)), "mse_after_gm": gm(r(0, "csi_after", "mean_after", 0)),
            "mse_after_over_mean_before_gm": gm(r(0, "csi_after", "mean_before", 0)),
            "rel_before_gm": gm(r(0, "csi_before", "mean_before", 1)), "rel_after_gm": gm(r(0, "csi_after", "mean_after", 1)),
            "mse_before_max": float(r(0, "csi_before", "mean_before", 0).max()),
            "mse_after_max": float(r(0, "csi_after", "mean_after", 0).max()),
            "extra_mean": float(ex.mean()), "extra_max": float(ex.max())}


def markdown(rows, s):
    out = ["| cell | picked pixels | extra samples | csi / mean before (MSE, relMSE) | csi re-solved / mean after | "
           "csi patched / mean after | csi patched / csi before (MSE) |",
           "| --- | ---: | ---: | --- | --- | --- | ---: |"]
    for k, v in rows.items():
        f = lambda a, b: f"{v[a][0] / v[b][0]:.3f}, {v[a][1] / v[b][1]:.3f}"
        out.append(f"| {k} | {v['pixels']} | {100 * v['cells'] / v['samples']:.2f}% | {f('csi_before', 'mean_before')} | "
                   f"{f('csi_after', 'mean_after')} | {f('csi_patch', 'mean_after')} | "
                   f"{v['csi_patch'][0] / v['csi_before'][0]:.3f} |")
    out.append("")
    out.append(f"{s['cells']} cells; above the mean in MSE or relMSE: {s['above_before']} before, {s['above_after']} after; "
               f"MSE over the mean's (geometric mean): {s['mse_before_gm']:.3f} before, {s['mse_after_gm']:.3f} after "
               f"(worst {s['mse_before_max']:.3f} -> {s['mse_after_max']:.3f}); csi after over the mean before "
               f"{s['mse_after_over_mean_before_gm']:.3f}; extra samples {100 * s['extra_mean']:.2f}% on average, "
               f"{100 * s['extra_max']:.2f}% at most. Patched (csi-mitsuba --refine's image): over csi before "
               f"{s['patch_over_before_gm']:.3f}, over re-solved {s['patch_over_after_gm']:.3f}, over the mean after "
               f"{s['patch_over_mean_after_gm']:.3f}, above the mean after in {s['above_patch']} cells")
    return "\n".join(out) + "\n"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", required=True, help="mitsuba_data.py directories, comma-separated")
    ap.add_argument("--build", default=None, help="csi build directory (default: ./build)")
    ap.add_argument("--scenes", default=",".join(md.SCENES),
                    help="scene names, or scene files of one's own (as mitsuba_data.py --scenes)")
    ap.add_argument("--spp", default="4", help="comma-separated, e.g. 4,16")
    ap.add_argument("--paths", default="1,64")
    ap.add_argument("--methods", default="stratified,poisson")
    ap.add_argument("--share", type=float, default=0.005, help="csi-reconstruct --refine-share")
    ap.add_argument("--json", help="rows and summary (resumed if it exists)")
    ap.add_argument("--md")
    ap.add_argument("--figure", metavar="OUT.png", help="crops of --figure-cells (of the first --data) instead")
    ap.add_argument("--figure-cells", default="horizon/s4_p64_poisson", help="SCENE/STEM, comma-separated")
    a = ap.parse_args(argv)
    a.scenes = ",".join(md.scene_names(a.scenes))
    bins, env = binaries(a.build), default_env()
    if a.figure:
        with tempfile.TemporaryDirectory(prefix="bench_refine-") as tmp:
            figure(bins, env, tmp, a.data.split(",")[0], a.figure_cells.split(","), a.share, a.figure)
        return 0
    rows = json.load(open(a.json))["rows"] if a.json and os.path.exists(a.json) else {}
    cache = {}
    with tempfile.TemporaryDirectory(prefix="bench_refine-") as tmp:
        for d in a.data.split(","):
            for scene in a.scenes.split(","):
                for spp in a.spp.split(","):
                    for paths in a.paths.split(","):
                        for meth in a.methods.split(","):
                            stem = f"s{spp}_p{paths}" + ("" if meth == "stratified" else f"_{meth}")
                            key = f"{os.path.basename(d.rstrip('/'))} {scene} {spp}x{paths} {meth}"
                            if key in rows or not os.path.exists(os.path.join(d, scene, stem + ".csid")):
                                continue
                            rows[key] = cell(bins, env, tmp, d, scene, stem, a.share, cache)
                            v = rows[key]
                            print(f"{key}: {v['pixels']} px, {v['cells']} cells; csi/mean MSE "
                                  f"{v['csi_before'][0] / v['mean_before'][0]:.3f} -> {v['csi_after'][0] / v['mean_after'][0]:.3f}",
                                  flush=True)
                            if a.json:
                                with open(a.json + ".tmp", "w") as f:
                                    json.dump({"rows": rows}, f)
                                os.replace(a.json + ".tmp", a.json)
    s = summary(rows)
    if a.json:
        with open(a.json + ".tmp", "w") as f:
            json.dump({"rows": rows, "summary": s}, f, indent=1)
        os.replace(a.json + ".tmp", a.json)
    text = markdown(rows, s)
    if a.md:
        with open(a.md, "w") as f:
            f.write(text)
    print(text.splitlines()[-1])
    return 0


if __name__ == "__main__":
    sys.exit(main())
