#!/usr/bin/env python3
"""Quality sweep of csi's antialiasing estimators, run through the real binaries.

For each analytic test image (a slanted triangle, a procedural texture) this script
  1. renders the fine grid: each cell takes the image's value at the cell centre (what a ray
     tracer returns for a ray through that point), written as a 1-channel float EXR;
  2. computes the ground truth: the box average of the continuous image over each output pixel,
     supersampled in double (SS x SS points per fine cell, midpoint rule);
  3. makes sample dumps with build/csi-mkdump (stratified and/or Poisson-disk positions, given
     spp and seeds) and reconstructs them with build/csi-reconstruct under each configuration;
  4. prints (and with --md writes) MSE over all pixels and over edge pixels (pixels whose truth
     is strictly between the pixel's min and max cell value, i.e. pixels an edge crosses), plus
     solve time and iterations from --stats.

Usage (from the worktree root, after building):
  /work/main/.venv/bin/python tools/bench/quality_sweep.py --grid 256 --out 64 --spp 1,2,4,9,16 \
      --seeds 1,2 --configs mean,gauss,cs [--images triangle,texture] [--md docs/bench/quality.md]
Configurations are NAME or NAME=csi-reconstruct-args, e.g.
  'fast=--max-iter 100 --tau 1e-3'. Built-in names: mean (stratified positions, per-pixel
  sample mean), gauss (Gaussian normalized convolution), cs (csi-reconstruct defaults).
  A configuration whose name starts with 'p:' uses Poisson-disk positions instead of stratified.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
import OpenEXR

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


# ---- analytic images, coordinates in [0,1]^2 (x right, y down) -------------------------------
def triangle(x, y):
    """A slanted triangle (value 1) on a 0.1 background; no edge is axis-aligned."""
    a, b, c = (0.13, 0.21), (0.87, 0.36), (0.38, 0.91)

    def side(p, q):
        return (q[0] - p[0]) * (y - p[1]) - (q[1] - p[1]) * (x - p[0])

    s1, s2, s3 = side(a, b), side(b, c), side(c, a)
    inside = ((s1 >= 0) & (s2 >= 0) & (s3 >= 0)) | ((s1 <= 0) & (s2 <= 0) & (s3 <= 0))
    return np.where(inside, 1.0, 0.1)


def texture(x, y):
    """Smooth sinusoids plus a rotated checker (edges in two directions) and a soft disc."""
    u = 0.8 * x + 0.6 * y
    v = -0.6 * x + 0.8 * y
    sines = 0.15 * np.sin(2 * np.pi * 5.0 * x) * np.cos(2 * np.pi * 3.0 * y) + 0.1 * np.sin(2 * np.pi * 11.0 * u)
    checker = ((np.floor(u * 6.0) + np.floor(v * 6.0)) % 2.0) * 0.4
    disc = 0.2 * ((x - 0.6) ** 2 + (y - 0.4) ** 2 < 0.04)
    return 0.2 + sines + checker + disc


IMAGES = {"triangle": triangle, "texture": texture}


def fine_grid(fn, n):
    c = (np.arange(n) + 0.5) / n
    x, y = np.meshgrid(c, c)
    return fn(x, y).astype(np.float32)


def box_truth(fn, n, out, ss):
    """Box average of fn over each of out x out pixels, ss x ss midpoints per fine cell."""
    m = n * ss  # supersampled resolution
    res = np.zeros((out, out))
    rows = m // out
    c = (np.arange(m) + 0.5) / m
    for oy in range(out):
        y = c[oy * rows:(oy + 1) * rows]
        x, yy = np.meshgrid(c, y)
        v = fn(x, yy)
        res[oy] = v.reshape(rows, out, m // out).mean(axis=(0, 2))
    return res


def edge_mask(fine, out):
    n = fine.shape[0]
    b = n // out
    blk = fine.reshape(out, b, out, b)
    lo, hi = blk.min(axis=(1, 3)), blk.max(axis=(1, 3))
    return hi - lo > 0.15  # a step edge (triangle 0.9, checker 0.4, disc 0.2), not the sinusoids


def write_exr(path, a):
    hdr = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(hdr, {"Y": a.astype(np.float32)}) as f:
        f.write(path)


def read_exr(path):
    with OpenEXR.File(path) as f:
        ch = f.channels()
        name = "Y" if "Y" in ch else sorted(ch)[0]
        return np.array(ch[name].pixels, dtype=np.float64)


def run(cmd):
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit("failed: %s\n%s" % (" ".join(cmd), p.stderr))
    return p


BUILTIN = {"mean": "--estimator mean", "gauss": "--estimator gauss", "cs": ""}


def parse_configs(s):
    out = []
    for item in s.split(";") if ";" in s else s.split(","):
        item = item.strip()
        if not item:
            continue
        if "=" in item:
            name, args = item.split("=", 1)
        else:
            name, args = item, BUILTIN.get(item.split(":")[-1], "")
        out.append((name, args.split()))
    return out


def write_md(results, path, caption):
    """Appends one table per image: rows spp, columns configurations, cells MSE (edge MSE) and,
    for solvers, mean solve + integrate time."""
    with open(path, "a") as f:
        images = list(dict.fromkeys(r["image"] for r in results))
        names = list(dict.fromkeys(r["config"] for r in results))
        spps = sorted(set(r["spp"] for r in results))
        for img in images:
            f.write("\n**%s**, %s. MSE (edge-pixel MSE) [seconds]:\n\n" % (img, caption))
            f.write("| spp | " + " | ".join(names) + " |\n|---|" + "---|" * len(names) + "\n")
            for spp in spps:
                cells = []
                for n in names:
                    r = [x for x in results if x["image"] == img and x["spp"] == spp and x["config"] == n]
                    cells.append("%.2e (%.2e) [%.2f]" % (r[0]["mse"], r[0]["edge_mse"], r[0]["t"]) if r else "")
                f.write("| %d | %s |\n" % (spp, " | ".join(cells)))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--grid", type=int, default=256)
    ap.add_argument("--out", type=int, default=64)
    ap.add_argument("--spp", default="1,2,4,9,16")
    ap.add_argument("--seeds", default="1,2")
    ap.add_argument("--images", default="triangle,texture")
    ap.add_argument("--configs", default="mean,gauss,cs",
                    help="';'-separated (or ',' when no config has args) NAME[=ARGS]")
    ap.add_argument("--ss", type=int, default=8, help="supersampling per fine cell for the truth")
    ap.add_argument("--no-exact", dest="exact", action="store_false",
                    help="dumps without the exact-values flag (csi-mkdump before it, or to see --correct "
                         "auto on unflagged samples)")
    ap.add_argument("--md", help="append the table in Markdown to this file")
    ap.add_argument("--json", help="write all results as JSON")
    ap.add_argument("--from-json", help="only format a saved --json file as Markdown (to --md or stdout)")
    ap.add_argument("--caption", default="", help="with --from-json: the tables' caption")
    a = ap.parse_args()
    if a.from_json:
        with open(a.from_json) as f:
            write_md(json.load(f), a.md or "/dev/stdout", a.caption)
        return 0
    os.environ.setdefault("CSI_CACHE_DIR", os.path.expanduser("~/.cache/csi"))
    mkdump = os.path.join(a.build, "csi-mkdump")
    recon = os.path.join(a.build, "csi-reconstruct")
    spps = [int(s) for s in a.spp.split(",")]
    seeds = [int(s) for s in a.seeds.split(",")]
    configs = parse_configs(a.configs)
    results = []
    tmp = tempfile.mkdtemp(prefix="csi-quality-")
    for img in a.images.split(","):
        fn = IMAGES[img]
        fine = fine_grid(fn, a.grid)
        truth = box_truth(fn, a.grid, a.out, a.ss)
        edges = edge_mask(fine, a.out)
        gridmean = fine.astype(np.float64).reshape(a.out, a.grid // a.out, a.out, a.grid // a.out).mean(axis=(1, 3))
        floor = float(np.mean((gridmean - truth) ** 2))
        src = os.path.join(tmp, img + ".exr")
        write_exr(src, fine)
        print("# %s: %dx%d -> %dx%d, %d edge pixels, grid-mean floor MSE %.3g"
              % (img, a.grid, a.grid, a.out, a.out, int(edges.sum()), floor), flush=True)
        for spp in spps:
            for name, args in configs:
                mse, emse, tsol, iters = [], [], [], []
                for seed in seeds:
                    method = "poisson" if name.startswith("p:") else "stratified"
                    dump = os.path.join(tmp, "%s_%s_%d_%d.csid" % (img, method, spp, seed))
                    if not os.path.exists(dump):
                        # --exact: each cell holds the image's value at its centre (step 1), a
                        # noise-free point value, so --correct auto takes cv (docs/dump-format.md)
                        run([mkdump, src, "-o", dump, "--out", "%dx%d" % (a.out, a.out), "--spp", str(spp),
                             "--method", method, "--seed", str(seed), "-q"] + (["--exact"] if a.exact else []))
                    out = os.path.join(tmp, "o.exr")
                    st = os.path.join(tmp, "o.json")
                    t0 = time.time()
                    run([recon, dump, "-o", out, "--stats", st, "-q"] + args)
                    wall = time.time() - t0
                    est = read_exr(out)
                    with open(st) as f:
                        js = json.load(f)
                    err = (est - truth) ** 2
                    mse.append(err.mean())
                    emse.append(err[edges].mean())
                    tsol.append(js.get("t_solve_s", 0) + js.get("t_integrate_s", 0))
                    ch = js.get("channels", {})
                    iters.append(sum(v.get("iterations", 0) for v in ch.values()) if isinstance(ch, dict) else 0)
                r = dict(image=img, spp=spp, config=name, args=" ".join(args), mse=float(np.mean(mse)),
                         edge_mse=float(np.mean(emse)), t=float(np.mean(tsol)), iters=float(np.mean(iters)))
                results.append(r)
                print("%-9s spp %2d  %-24s MSE %.3e  edge %.3e  t %.2fs  it %.0f"
                      % (img, spp, name, r["mse"], r["edge_mse"], r["t"], r["iters"]), flush=True)
    if a.json:
        with open(a.json, "w") as f:
            json.dump(results, f, indent=1)
    if a.md:
        write_md(results, a.md, "%dx%d grid -> %dx%d, seeds %s" % (a.grid, a.grid, a.out, a.out, a.seeds))
    return 0


if __name__ == "__main__":
    sys.exit(main())
