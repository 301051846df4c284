"""csi on a real renderer's samples: the Mitsuba 3 benchmark (issue 9, section 3). One command:

    .venv/bin/python tools/bench/bench_mitsuba.py --data DATA --out docs/bench/mitsuba
    .venv/bin/python tools/bench/bench_mitsuba.py --quick --data /tmp/mq --out /tmp/mq-out   # minutes

Scenes: Mitsuba's Cornell box and the generators in data/mitsuba/ (procedural, no downloads).
Per scene, spp and paths per sample (default 1, 4, 16 spp x 1, 64 paths at 128x128), the very
same samples (csi's default grid for the spp, stratified positions: exactly spp samples in
every pixel; --positions poisson for csi's own) go to every method:
  mean          csi's estimator mean (the per-pixel Monte Carlo mean)
  csi           csi with its defaults (csi's library in this process, csi.reconstruct_dump with
                the variances beside the dump: the bits of csi-reconstruct on the dump; times
                without a process start)
  oidn          Intel Open Image Denoise (pyoidn, HDR, quality high) on the mean, colour only
  oidn+aux      the same with albedo and normal guides: per-pixel means (csi's estimator
                mean) of Mitsuba's first-hit albedo and shading normal per sample
  csi>oidn      OIDN on csi's image (negative values clipped to 0: OIDN wants HDR >= 0), colour
  csi>oidn+aux  the same with the guides
  avg           (oidn+aux + csi>oidn+aux) / 2, the mean of the two denoised images
  mix>oidn+aux  OIDN with the guides on (mean + csi) / 2
and csi-mitsuba's default, its second pass (two passes: more samples, so apart from the rest):
  csi-mitsuba   csi as csi-mitsuba runs it (each sample's variance used with more than one path),
                then the cells of the pixels it cannot decide rendered through the bridge and
                those pixels set to the mean of all their samples (csi.refine_positions,
                csi.refine_apply), then with more than one path the pixels that still decide
                the image settled on their samples' mean (csi.refine_settle) and an HDR step's
                pixels given their window's coverage (csi.refine_step_coverage), against
  mean+pass     the per-pixel mean of the same samples, the first pass's and the second's;
  oidn+pass, oidn+aux+pass
                OIDN on mean+pass, colour only and with the guides (the first pass's: the
                second renders no albedo or normal), what a user of OIDN gets from those samples;
  csi-mitsuba>oidn, csi-mitsuba>oidn+aux
                OIDN on csi-mitsuba's image, colour only and with the same guides.
Figures against Mitsuba's reference (its own render with a box pixel filter at --reference-spp):
MSE, relMSE = mean over pixels and channels of (x - ref)^2 / (ref^2 + 0.01), the count of
negative values, and each method's time. Mitsuba's cost per sample and per path is measured in
the same run (fresh renders at 4 spp, not the cached dumps), and so is mi.render's cost per
path; the equal-time comparison puts csi at 4 spp (render + reconstruction wall time) against
Mitsuba's own box-filtered render at the spp it reaches in that total time.

Dumps and references are cached in DATA (tools/bench/mitsuba_data.py; reusable by anyone);
reconstructions are redone every run. Writes OUT/results.json, OUT/report.md (the tables) and
OUT/<scene>.png (contact sheets: one row per spp x paths, the reference first).
"""
import argparse
import json
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import mitsuba_data as md  # noqa: E402
import csi  # noqa: E402
from csi import dump as csid  # noqa: E402
from csi import mitsuba_bridge as mb  # noqa: E402

ALL_SCENES = ["cornell", "thin_geometry", "glossy_sun", "horizon", "envmap"]
COMPOSITIONS = ["csi>oidn", "csi>oidn+aux", "avg", "mix>oidn+aux"]
METHODS = ["mean", "csi", "oidn", "oidn+aux", *COMPOSITIONS]


def mse(x, ref):
    return float(np.mean((x.astype(np.float64) - ref) ** 2))


def relmse(x, ref):
    r = ref.astype(np.float64)
    return float(np.mean((x.astype(np.float64) - r) ** 2 / (r ** 2 + 0.01)))


def reconstruct(dump_path, **options):
    """A dump through csi's library in this process (csi.reconstruct_dump: what csi-reconstruct
    computes, the same bits): (image, wall seconds, csi's own seconds: setup + solve + integrate).
    The process's first call also makes the OpenCL device (kept for the run)."""
    t0 = time.perf_counter()
    res = csi.reconstruct_dump(dump_path, **options)
    wall = time.perf_counter() - t0
    i = res.info
    return res.image, wall, i["t_setup"] + i["t_solve"] + i["t_integrate"]


def oidn(color, albedo=None, normal=None):
    import pyoidn

    t0 = time.perf_counter()
    c = np.ascontiguousarray(np.maximum(color, 0), np.float32)
    kw = {}
    if albedo is not None:
        kw = {"albedo": np.ascontiguousarray(np.clip(albedo, 0, 1), np.float32),
              "normal": np.ascontiguousarray(np.clip(normal, -1, 1), np.float32)}
    out = pyoidn.denoise(c, hdr=True, quality="high", **kw)
    return np.asarray(out, np.float32), time.perf_counter() - t0


def run_cell(files, ref):
    """Every method on one dump. Returns {method: metrics} and {method: image}, the images with the
    guides OIDN took ("albedo", "normal": the per-pixel means of Mitsuba's first-hit AOVs)."""
    imgs, times = {}, {}
    imgs["mean"], w, inner = reconstruct(files["dump"], estimator="mean")
    times["mean"] = (w, inner)
    # the variances beside the dump (several paths per sample), as csi-reconstruct takes them
    var = files.get("variance")
    imgs["csi"], w, inner = reconstruct(files["dump"], variance_path=var if var and os.path.exists(var) else None)
    times["csi"] = (w, inner)
    albedo, _, _ = reconstruct(files["albedo"], estimator="mean")
    normal, _, _ = reconstruct(files["normal"], estimator="mean")
    imgs["oidn"], t = oidn(imgs["mean"])
    times["oidn"] = (times["mean"][0] + t, t)
    imgs["oidn+aux"], t = oidn(imgs["mean"], albedo, normal)
    times["oidn+aux"] = (times["mean"][0] + t, t)
    imgs["csi>oidn"], t = oidn(imgs["csi"])
    times["csi>oidn"] = (times["csi"][0] + t, t)
    imgs["csi>oidn+aux"], t = oidn(imgs["csi"], albedo, normal)
    times["csi>oidn+aux"] = (times["csi"][0] + t, t)
    imgs["avg"] = 0.5 * (imgs["oidn+aux"] + imgs["csi>oidn+aux"])
    times["avg"] = (times["csi>oidn+aux"][0] + times["oidn+aux"][1], 0.0)
    imgs["mix>oidn+aux"], t = oidn(0.5 * (imgs["mean"] + imgs["csi"]), albedo, normal)
    imgs["albedo"], imgs["normal"] = albedo, normal
    times["mix>oidn+aux"] = (times["csi"][0] + times["mean"][0] + t, t)
    res = {}
    for m in METHODS:
        res[m] = {"mse": mse(imgs[m], ref), "relmse": relmse(imgs[m], ref), "negatives": int((imgs[m] < 0).sum()),
                  "min": float(imgs[m].min()), "t_wall_s": times[m][0], "t_method_s": times[m][1]}
    return res, imgs


def two_passes(files, scene_obj, paths, passes=1):
    """csi-mitsuba's image on a cached dump, by csi-mitsuba's own code (mitsuba_cli.refine, with
    its defaults: each sample's variance used with more than one path, the default share):
    the first reconstruction, the cells of the pixels it cannot decide rendered through the
    bridge with the refinement's seed, the patch; `passes` passes after the first. Returns
    ({"csi-mitsuba": image, "mean+pass": image}, extra samples, Mitsuba's wall seconds for them,
    csi's wall seconds (first reconstruction, picks, patches))."""
    import types

    from csi import mitsuba_cli

    d = csid.read(files["dump"])
    req = csid.Dump(grid=d.grid, out=d.out, xyt=d.xyt, values=None, seed=d.seed)
    s = mb.Samples(values=d.values, variance=csid.read(files["variance"]).values if paths > 1 else None,
                   albedo=None, normal=None, paths=paths, nonfinite=0, timing={})
    a = types.SimpleNamespace(refine_share=None, refine_passes=passes, paths=paths, aov=False,
                              variance_peaks=paths > 1)
    t0 = time.perf_counter()
    req2, s2, info, result = mitsuba_cli.refine(scene_obj, req, s, a, [], lambda *_: None)
    wall = time.perf_counter() - t0
    t_render = sum(q["mitsuba"]["render_s"] + q["mitsuba"]["jit_s"] for q in info["passes"])
    merged = csid.Dump(grid=d.grid, out=d.out, xyt=req2.xyt, values=s2.values, seed=d.seed)
    # a pixel without a sample (Poisson-disk positions at 1 spp) is 0 in the mean, as csi's estimator
    # mean leaves it, not NaN
    mean_pass = np.nan_to_num(merged.pixel_means(), nan=0.0).astype(np.float32)
    return ({"csi-mitsuba": result.image, "mean+pass": mean_pass}, info["cells"],
            t_render, wall - t_render)


def measure_mitsuba(scene, size, seed, paths_list, log):
    """Mitsuba's cost in this run: render_request (csi's positions through the bridge) at 4 spp
    for each paths count, and mi.render's own cost per path (box filter) on a 64-spp render.
    Fresh renders (nothing cached), each timed on its second run."""
    sc = mb.load_scene(md.SCENES[scene], size=size)
    req = mb.positions_request(size, spp=4, seed=seed + 1000, method="stratified")
    out = {}
    for paths in paths_list:
        # Dr.Jit builds a kernel per launch size the first time (then caches it on disk): the
        # second of two identical renders is the warm cost.
        mb.render_request(sc, req, paths=paths, seed=seed + 1000)
        s = mb.render_request(sc, req, paths=paths, seed=seed + 1001)
        out[f"p{paths}"] = s.timing
        log(f"    Mitsuba at 4 spp x {paths} paths: {s.timing['per_sample_us']:.2f} us/sample, "
            f"{s.timing['per_path_us']:.3f} us/path")
    ref_sc = mb.load_scene(md.SCENES[scene], size=size, box_filter=True)
    mb.render_reference(ref_sc, 64, seed=7)  # the same launches once, to build their kernels
    t0 = time.perf_counter()
    mb.render_reference(ref_sc, 64, seed=8)
    t = time.perf_counter() - t0
    out["mi_render_per_path_us"] = 1e6 * t / (64 * size[0] * size[1])
    log(f"    mi.render: {out['mi_render_per_path_us']:.3f} us/path")
    return out


def render_in_time(scene, size, paths, budget, per_spp, seed):
    """mi.render (box filter) at the spp that fits `budget` seconds at per_spp seconds per spp of
    `paths` paths: (spp, image, measured seconds). The cost per path moves with the launch size
    and the machine's load: when the render misses the budget by more than 25%, the spp is
    rescaled by the measured time and rendered again (once); the time reported is the last
    render's, measured."""
    spp = max(1, int(budget / per_spp))
    sc = mb.load_scene(md.SCENES[scene], size=size, box_filter=True)
    for attempt in range(2):
        t0 = time.perf_counter()
        img = mb.render_reference(sc, spp * paths, seed=seed + attempt)
        t_mc = time.perf_counter() - t0
        if abs(t_mc - budget) <= 0.25 * budget or attempt == 1:
            break
        spp = max(1, int(spp * budget / t_mc))
    return spp, img, t_mc


def equal_time(scene, size, ref, cell4, timing, paths, seed, log):
    """csi at 4 spp (render + reconstruction wall time) against mi.render at the spp it reaches
    in that time (box filter; the same paths per pixel sample as csi's samples). Both renders
    are charged mi.render's measured cost per path: a renderer evaluating csi's positions
    traces the same paths (the bridge's own per-launch overhead is reported apart)."""
    pix = size[0] * size[1]
    per_spp = timing["mi_render_per_path_us"] * paths * pix * 1e-6  # one sample of `paths` paths per pixel
    t_render = 4 * per_spp
    t_csi = t_render + cell4["csi"]["t_wall_s"]
    spp, img, t_mc = render_in_time(scene, size, paths, t_csi, per_spp, seed + 2000)
    log(f"    equal time ({paths} paths): csi 4 spp {t_csi:.2f} s vs Mitsuba {spp} spp ({t_mc:.2f} s measured)")
    return {"paths": paths, "csi_spp": 4, "csi_total_s": t_csi, "csi_render_s": t_render,
            "csi_reconstruct_s": cell4["csi"]["t_wall_s"], "csi_mse": cell4["csi"]["mse"], "csi_relmse": cell4["csi"]["relmse"],
            "mc_spp": spp, "mc_render_s": t_mc, "mc_mse": mse(img, ref), "mc_relmse": relmse(img, ref)}


def equal_time_two_passes(scene, size, ref, cell, timing, paths, seed, log):
    """csi-mitsuba at 4 spp with its second pass against mi.render in the same total time: the
    first pass's and the second's samples charged mi.render's cost per path (as above), csi's
    reconstruction, pick and patch at their measured wall time."""
    pix = size[0] * size[1]
    per_path = timing["mi_render_per_path_us"] * 1e-6
    t_render = (4 * pix + cell["extra_samples"]) * paths * per_path
    t_total = t_render + cell["t_csi_s"]
    per_spp = per_path * paths * pix
    spp, img, t_mc = render_in_time(scene, size, paths, t_total, per_spp, seed + 3000)
    c = cell["methods"]["csi-mitsuba"]
    log(f"    equal time, two passes ({paths} paths): csi-mitsuba {t_total:.2f} s vs Mitsuba {spp} spp ({t_mc:.2f} s)")
    return {"paths": paths, "total_s": t_total, "render_s": t_render, "csi_s": cell["t_csi_s"],
            "bridge_second_render_s": cell["t_second_render_s"], "csi_mse": c["mse"], "csi_relmse": c["relmse"],
            "mc_spp": spp, "mc_render_s": t_mc, "mc_mse": mse(img, ref), "mc_relmse": relmse(img, ref)}


def tonemap(img, exposure):
    x = np.maximum(img * exposure, 0)
    x = x / (1 + x)  # Reinhard per channel: HDR highlights stay distinguishable
    return (np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055) * 255 + 0.5).astype(np.uint8)


def contact_sheet(path, ref, rows, cols):
    """rows: [(label, {method: image})]; one tile per method, the reference first."""
    from PIL import Image, ImageDraw

    exposure = 1.0 / max(1e-6, float(np.percentile(ref, 90)))
    h, w = ref.shape[:2]
    lab_w, lab_h = 70, 14
    sheet = Image.new("RGB", (lab_w + w * (len(cols) + 1), lab_h + h * len(rows)), (255, 255, 255))
    d = ImageDraw.Draw(sheet)
    for j, name in enumerate(["reference", *cols]):
        d.text((lab_w + j * w + 2, 1), name[:22], fill=(0, 0, 0))
    for i, (label, imgs) in enumerate(rows):
        d.text((2, lab_h + i * h + h // 2 - 5), label, fill=(0, 0, 0))
        for j, img in enumerate([ref, *[imgs[c] for c in cols]]):
            sheet.paste(Image.fromarray(tonemap(img, exposure)), (lab_w + j * w, lab_h + i * h))
    # 256 colours (median cut, no dither) keep a sheet near 0.3 MB instead of 0.8 MB of noise
    sheet.quantize(colors=256, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE).save(path, optimize=True)


def fmt(v):
    return f"{v:.3g}" if isinstance(v, float) else str(v)


def report(results, args):
    L = []
    L.append(f"Size {args.size}, reference {args.reference_spp} spp (Mitsuba, box filter), {args.positions} positions on csi's "
             f"default grid. Method columns: MSE / relMSE as ratios to the mean of the same samples (< 1: better "
             f"than the mean). avg = (oidn+aux + csi>oidn+aux) / 2; mix>oidn+aux = OIDN with guides on (mean + csi) / 2.\n")
    for scene, r in results["scenes"].items():
        L.append(f"### {scene}\n")
        L.append("| spp | paths | grid | mean: MSE | relMSE | " + " | ".join(f"{m}" for m in METHODS[1:])
                 + " | csi: negatives | time (s) |")
        L.append("|" + " --- |" * (7 + len(METHODS) - 1))
        for key, c in r["cells"].items():
            m0 = c["methods"]["mean"]
            row = [str(c["spp"]), str(c["paths"]), "x".join(map(str, c["grid"][:2])), fmt(m0["mse"]), fmt(m0["relmse"])]
            for m in METHODS[1:]:
                x = c["methods"][m]
                row.append(f"{x['mse'] / m0['mse']:.2f} / {x['relmse'] / m0['relmse']:.2f}")
            row += [str(c["methods"]["csi"]["negatives"]), f"{c['methods']['csi']['t_wall_s']:.2f}"]
            L.append("| " + " | ".join(row) + " |")
        t = r["mitsuba"]
        L.append("")
        L.append("Mitsuba in this run: " + ", ".join(
            f"{k[1:]} path(s) per sample {v['per_sample_us']:.2f} us/sample, {v['per_path_us']:.3f} us/path"
            for k, v in t.items() if k.startswith("p")) + f" (csi-mitsuba's bridge, 4 spp); mi.render "
            f"{t['mi_render_per_path_us']:.3f} us/path (64 spp).")
        if any("two_passes" in c for c in r["cells"].values()):
            L.append("")
            L.append("csi-mitsuba's default, two passes (the second pass's samples added to both; ratios to mean+pass, "
                     "the mean of all the samples; the last two columns: OIDN on csi-mitsuba's image, colour only and "
                     "with the guides, over the better of OIDN on mean+pass with and without them, per figure):")
            L.append("")
            L.append("| spp | paths | extra samples | mean+pass: MSE | relMSE | csi-mitsuba: MSE / relMSE ratio | "
                     "first pass alone (csi / mean) | negatives | csi-mitsuba>oidn | csi-mitsuba>oidn+aux |")
            L.append("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
            for c in r["cells"].values():
                q = c.get("two_passes")
                if not q:
                    continue
                m0, x = q["methods"]["mean+pass"], q["methods"]["csi-mitsuba"]
                f0, f1 = c["methods"]["mean"], c["methods"]["csi"]
                qm = q["methods"]
                best = {k: min(qm[m][k] for m in ("oidn+pass", "oidn+aux+pass")) for k in ("mse", "relmse")}
                L.append(f"| {c['spp']} | {c['paths']} | {100 * q['extra_samples'] / q['samples']:.2f}% | {fmt(m0['mse'])} | "
                         f"{fmt(m0['relmse'])} | **{x['mse'] / m0['mse']:.3f} / {x['relmse'] / m0['relmse']:.3f}** | "
                         f"{f1['mse'] / f0['mse']:.3f} / {f1['relmse'] / f0['relmse']:.3f} | {x['negatives']} | "
                         + " | ".join(f"{qm[m]['mse'] / best['mse']:.3f} / {qm[m]['relmse'] / best['relmse']:.3f}"
                                      for m in ("csi-mitsuba>oidn", "csi-mitsuba>oidn+aux")) + " |")
            L.append("")
        for e in r.get("equal_time_two_passes", []):
            L.append(f"Equal time, two passes, {e['paths']} path(s) per sample: csi-mitsuba at 4 spp takes "
                     f"{e['total_s']:.2f} s (render {e['render_s']:.2f} at mi.render's cost per path + csi "
                     f"{e['csi_s']:.2f}; the bridge rendered the second pass in {e['bridge_second_render_s']:.3f} s): "
                     f"MSE {fmt(e['csi_mse'])}, relMSE {fmt(e['csi_relmse'])}; Mitsuba renders {e['mc_spp']} spp in that "
                     f"time ({e['mc_render_s']:.2f} s measured): MSE {fmt(e['mc_mse'])}, relMSE {fmt(e['mc_relmse'])} "
                     f"(csi-mitsuba / Mitsuba: {e['csi_mse'] / e['mc_mse']:.2f} / {e['csi_relmse'] / e['mc_relmse']:.2f}).")
        for e in r["equal_time"]:
            L.append(f"Equal time, {e['paths']} path(s) per sample: csi at 4 spp takes {e['csi_total_s']:.2f} s "
                     f"(render {e['csi_render_s']:.2f} + reconstruct {e['csi_reconstruct_s']:.2f}): MSE {fmt(e['csi_mse'])}, "
                     f"relMSE {fmt(e['csi_relmse'])}; Mitsuba renders {e['mc_spp']} spp in that time "
                     f"({e['mc_render_s']:.2f} s measured): MSE {fmt(e['mc_mse'])}, relMSE {fmt(e['mc_relmse'])} "
                     f"(csi / Mitsuba: {e['csi_mse'] / e['mc_mse']:.2f} / {e['csi_relmse'] / e['mc_relmse']:.2f}).")
        L.append("")
    return "\n".join(L) + "\n"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", required=True, help="cache of dumps and references (created; reused across runs)")
    ap.add_argument("--out", required=True, help="results.json, report.md, contact sheets")
    ap.add_argument("--quick", action="store_true", help="cornell and glossy_sun at 64x64, 1 and 4 spp, 1 and 16 paths")
    ap.add_argument("--scenes", help=f"comma-separated names or scene files of your own (XML, or Python defining "
                                     f"scene()), default all: {','.join(ALL_SCENES)}")
    ap.add_argument("--spp", default="1,4,16")
    ap.add_argument("--paths", default="1,64")
    ap.add_argument("--size", default="128x128")
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--positions", choices=("stratified", "poisson"), default="stratified",
                    help="the samples' positions: stratified (every pixel gets spp samples, default) or poisson "
                         "(csi's own default; at 1 spp some pixels get none and the mean leaves them 0)")
    ap.add_argument("--two-passes", action=argparse.BooleanOptionalAction, default=True,
                    help="also csi-mitsuba's default with its second pass (renders the cells it asks for) [on]")
    ap.add_argument("--refine-passes", type=int, default=1,
                    help="with --two-passes: csi-mitsuba --refine-passes (passes after the first) [1]")
    a = ap.parse_args(argv)
    if a.quick:
        a.scenes = a.scenes or "cornell,glossy_sun"
        a.spp, a.paths, a.size, a.reference_spp = "1,4", "1,16", "64x64", 1024
    scenes = md.scene_names(a.scenes or ",".join(ALL_SCENES))
    size = tuple(int(v) for v in a.size.split("x"))
    spps = [int(v) for v in a.spp.split(",")]
    paths_list = [int(v) for v in a.paths.split(",")]
    os.makedirs(a.out, exist_ok=True)
    os.makedirs(a.data, exist_ok=True)
    log = lambda s: print(s, flush=True)  # noqa: E731
    results = {"args": vars(a), "scenes": {}}
    t_start = time.perf_counter()
    for scene in scenes:
        log(f"{scene}:")
        ref, _ = md.reference(a.data, scene, size, a.reference_spp, log=log)
        ref = ref.astype(np.float64)
        scene_obj = mb.load_scene(md.SCENES[scene], size=size) if a.two_passes else None
        cells, rows = {}, []
        for spp in spps:
            for paths in paths_list:
                files, info = md.samples(a.data, scene, size, spp, paths, seed=a.seed, method=a.positions, log=log)
                res, imgs = run_cell(files, ref)
                cells[f"s{spp}_p{paths}"] = {"spp": spp, "paths": paths, "grid": info["grid"], "methods": res,
                                              "mitsuba_when_cached": info["mitsuba"]}
                if a.two_passes:
                    two, extra, t_render, t_csi = two_passes(files, scene_obj, paths, a.refine_passes)
                    albedo, normal = imgs["albedo"], imgs["normal"]
                    mp, cm = (np.asarray(two[k], np.float32).reshape(ref.shape) for k in ("mean+pass", "csi-mitsuba"))
                    two.update({"oidn+pass": oidn(mp)[0], "oidn+aux+pass": oidn(mp, albedo, normal)[0],
                                "csi-mitsuba>oidn": oidn(cm)[0], "csi-mitsuba>oidn+aux": oidn(cm, albedo, normal)[0]})
                    cells[f"s{spp}_p{paths}"]["two_passes"] = {
                        "samples": info["samples"], "extra_samples": extra, "t_second_render_s": t_render, "t_csi_s": t_csi,
                        "methods": {m: {"mse": mse(im, ref), "relmse": relmse(im, ref), "negatives": int((im < 0).sum()),
                                        "min": float(im.min())} for m, im in two.items()}}
                    imgs = dict(imgs, **two)
                    q = cells[f"s{spp}_p{paths}"]["two_passes"]["methods"]
                    log(f"    {spp:>2} spp x {paths:>2} paths, two passes (+{extra} samples): csi-mitsuba / mean+pass "
                        f"{q['csi-mitsuba']['mse'] / q['mean+pass']['mse']:.3f} / "
                        f"{q['csi-mitsuba']['relmse'] / q['mean+pass']['relmse']:.3f}")
                rows.append((f"{spp} spp\n{paths} path{'s' if paths > 1 else ''}", imgs))
                best = min(COMPOSITIONS, key=lambda m: res[m]["relmse"])
                log(f"    {spp:>2} spp x {paths:>2} paths: relMSE mean {res['mean']['relmse']:.4g}, csi "
                    f"{res['csi']['relmse'] / res['mean']['relmse']:.2f}x, oidn+aux "
                    f"{res['oidn+aux']['relmse'] / res['mean']['relmse']:.2f}x, {best} "
                    f"{res[best]['relmse'] / res['mean']['relmse']:.2f}x; csi {res['csi']['t_wall_s']:.1f} s")
        contact_sheet(os.path.join(a.out, f"{scene}.png"), ref, rows, ["mean", "csi", "oidn", "oidn+aux",
                                                                       "csi>oidn+aux"]
                      + (["csi-mitsuba"] if a.two_passes else []))
        timing = measure_mitsuba(scene, size, a.seed, paths_list, log)
        eq = []
        if 4 in spps:
            for paths in paths_list:
                eq.append(equal_time(scene, size, ref, cells[f"s4_p{paths}"]["methods"], timing, paths, a.seed, log))
        results["scenes"][scene] = {"cells": cells, "mitsuba": timing, "equal_time": eq}
        if a.two_passes and 4 in spps:
            results["scenes"][scene]["equal_time_two_passes"] = [
                equal_time_two_passes(scene, size, ref, dict(cells[f"s4_p{paths}"]["two_passes"]), timing, paths,
                                      a.seed, log) for paths in paths_list]
        md.write_readme(a.data)
        with open(os.path.join(a.out, "results.json"), "w") as f:
            json.dump(results, f, indent=1)
    results["t_total_s"] = time.perf_counter() - t_start
    with open(os.path.join(a.out, "results.json"), "w") as f:
        json.dump(results, f, indent=1)
    with open(os.path.join(a.out, "report.md"), "w") as f:
        f.write(report(results, a))
    log(f"done in {results['t_total_s']:.0f} s: {a.out}/report.md")


if __name__ == "__main__":
    main()
