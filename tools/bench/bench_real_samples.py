#!/usr/bin/env python3
"""csi's per-pixel estimate against the per-pixel mean of the very same samples, on a path
tracer's dumps (issue 9, section 2; docs/bench/mitsuba.md).

For every cached Mitsuba dump in DATA (tools/bench/mitsuba_data.py writes them: <scene>/
s<spp>_p<paths>.csid on stratified positions, s<spp>_p<paths>_poisson.csid on csi's Poisson-disk
positions, and reference_<SPP>.npy, Mitsuba's box-filtered render), reconstructs with each
configuration and with `--estimator mean`, and reports per (scene, spp, paths, positions) the
ratio of each configuration's MSE and relMSE to the mean's (relMSE = mean over pixels and
channels of (x - ref)^2 / (ref^2 + 0.01)) and its count of negative values. No renderer runs:
only csi-reconstruct on the cached dumps.

    .venv/bin/python tools/bench/bench_real_samples.py --data /work/data/mitsuba \\
        --configs "csi=;cv=--correct cv" --json out.json --md out.md

Configurations: NAME=csi-reconstruct arguments, separated by ';' (NAME= alone: the defaults).
csi-reconstruct takes `<dump>.variance.csid` (each sample's path variance, mitsuba_data.py
writes it for several paths per sample) by default where it exists; the row says where it does
(`variance`). `--variance none` measures without it; `--variance=auto` (the same as the default
since csi-reconstruct reads the file itself) becomes `--variance <dump>.variance.csid` where that
file exists and is dropped where it does not.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from bench_common import binaries, default_env, read_dump, read_exr  # noqa: E402

SCENES = ["cornell", "envmap", "glossy_sun", "horizon", "thin_geometry", "glints", "neon_tubes", "street_lamps"]


def errors(img, ref):
    d = (img.astype(np.float64) - ref) ** 2
    return float(d.mean()), float((d / (ref ** 2 + 0.01)).mean())


def cells(data, scenes, spps, paths_list, positions, reference_spp, who):
    """The cached dumps of DATA: (scene, spp, paths, positions, dump path, reference image) for
    each scene with a reference (the others are named on stderr) and each dump present."""
    for scene in scenes.split(","):
        refp = os.path.join(data, scene, f"reference_{reference_spp}.npy")
        if not os.path.exists(refp):
            print(f"{who}: {refp} is missing: {scene} skipped", file=sys.stderr)
            continue
        ref = np.load(refp).astype(np.float64)
        for spp in spps.split(","):
            for paths in paths_list.split(","):
                for pos in positions.split(","):
                    dump = os.path.join(data, scene, f"s{spp}_p{paths}{'_poisson' if pos == 'poisson' else ''}.csid")
                    if os.path.exists(dump):
                        yield scene, spp, paths, pos, dump, ref


def reconstruct(exe, dump, args, tmp):
    out = os.path.join(tmp, "r.exr")
    p = subprocess.run([exe, dump, "-o", out, "--quiet"] + args, capture_output=True, env=default_env())
    if p.returncode:
        sys.exit(f"bench_real_samples: {dump}: csi-reconstruct {' '.join(args)} failed: "
                 f"{p.stderr.decode(errors='replace').strip()}")
    return read_exr(out).astype(np.float64)


def cell_arguments(ap, spp, paths):
    """The arguments that pick the cells of DATA (cells() above) and the build, on `ap`."""
    ap.add_argument("--data", required=True, help="the Mitsuba dump cache (tools/bench/mitsuba_data.py)")
    ap.add_argument("--scenes", default=",".join(SCENES))
    ap.add_argument("--spp", default=spp)
    ap.add_argument("--paths", default=paths)
    ap.add_argument("--positions", default="stratified,poisson")
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--build", help="build directory (default: the source tree's build/)")


def parse_cells(doc, spp, paths, csi_args_help):
    """The command line of a script over DATA's cells with one more set of csi-reconstruct
    arguments (--csi-args): (the parsed arguments, csi-reconstruct's path)."""
    ap = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    cell_arguments(ap, spp, paths)
    ap.add_argument("--csi-args", default="", help=csi_args_help)
    a = ap.parse_args()
    return a, binaries(a.build)["csi-reconstruct"]


def with_variance(args, dump):
    """csi-reconstruct arguments with `--variance=auto` made `--variance <dump>.variance.csid`
    where that file exists, and dropped where it does not; and whether it exists."""
    side = dump[: -len(".csid")] + ".variance.csid"
    have = os.path.exists(side)
    return [x for v in args for x in ((["--variance", side] if have else []) if v == "--variance=auto" else [v])], have


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    cell_arguments(ap, "1,2,4,8,16", "1,64")  # the spp mitsuba_data.py renders; absent ones are skipped
    ap.add_argument("--configs", default="csi=", help="NAME=args;... (default: the defaults)")
    ap.add_argument("--json", help="write every figure here")
    ap.add_argument("--md", help="write the tables here (Markdown)")
    a = ap.parse_args()
    exe = binaries(a.build)["csi-reconstruct"]
    cfgs = []
    for c in a.configs.split(";"):
        name, _, args = c.partition("=")
        cfgs.append((name.strip(), args.split()))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for scene, spp, paths, pos, dump, ref in cells(a.data, a.scenes, a.spp, a.paths, a.positions,
                                                         a.reference_spp, "bench_real_samples"):
            hdr, _, _ = read_dump(dump)
            m0, r0 = errors(reconstruct(exe, dump, ["--estimator", "mean"], tmp), ref)
            row = dict(scene=scene, spp=int(spp), paths=int(paths), positions=pos,
                       grid=f"{hdr['grid_w']}x{hdr['grid_h']}", mean_mse=m0, mean_relmse=r0)
            row["variance"] = with_variance([], dump)[1]
            for name, args in cfgs:
                args = with_variance(args, dump)[0]
                img = reconstruct(exe, dump, args, tmp)
                m, r = errors(img, ref)
                row[name] = dict(mse=m / m0, relmse=r / r0, negative=int((img < 0).sum()),
                                 min=float(img.min()))
            rows.append(row)
            print(f"{scene:14s} {spp:>2s} spp {paths:>2s} paths {pos:10s} mean {m0:.3e} {r0:.3e} | "
                  + " | ".join(f"{n} {row[n]['mse']:.3f} {row[n]['relmse']:.3f} neg {row[n]['negative']}"
                               for n, _ in cfgs), flush=True)
            if a.json:
                with open(a.json, "w") as f:
                    json.dump(dict(configs=a.configs, rows=rows), f, indent=1)
    if a.md:
        names = [n for n, _ in cfgs]
        lines = ["| scene | spp | paths | positions | mean MSE | mean relMSE | "
                 + " | ".join(f"{n} MSE / relMSE (neg)" for n in names) + " |",
                 "|---|---|---|---|---|---|" + "---|" * len(names)]
        for r in rows:
            lines.append(f"| {r['scene']} | {r['spp']} | {r['paths']} | {r['positions']} | {r['mean_mse']:.3g} | "
                         f"{r['mean_relmse']:.3g} | "
                         + " | ".join(f"{r[n]['mse']:.3f} / {r[n]['relmse']:.3f} ({r[n]['negative']})" for n in names)
                         + " |")
        for n in names:
            worst_m = max(r[n]["mse"] for r in rows)
            worst_r = max(r[n]["relmse"] for r in rows)
            lines.append(f"\n{n}: worst ratio to the mean: MSE {worst_m:.3f}, relMSE {worst_r:.3f}; "
                         f"negative values in {sum(r[n]['negative'] > 0 for r in rows)} of {len(rows)} images")
        with open(a.md, "w") as f:
            f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
