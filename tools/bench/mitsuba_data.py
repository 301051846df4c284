"""The Mitsuba benchmark's data: sample dumps and references, rendered once and cached in a
directory so that re-runs (and other people) reuse them. Run alone it renders what is missing:
    .venv/bin/python tools/bench/mitsuba_data.py --data DIR [--scenes a,b] [--methods stratified,poisson]

Layout of DIR (README.txt, written here, says the same to a reader of the directory):
    DIR/<scene>/reference_<SPP>.exr / .npy     Mitsuba's box-filtered render, (h, w, 3) float32
    DIR/<scene>/s<spp>_p<paths>.csid           the samples: csi-positions' stratified positions
                                               for spp samples per pixel on csi's default grid,
                                               each the mean of <paths> paths
    DIR/<scene>/s<spp>_p<paths>_poisson.*      the same with csi's Poisson-disk positions
    DIR/<scene>/s<spp>_p<paths>.albedo.csid    albedo and shading normal at the first hit of each
    DIR/<scene>/s<spp>_p<paths>.normal.csid    sample (Mitsuba's aov integrator; OIDN's guides)
    DIR/<scene>/s<spp>_p<paths>.variance.csid  paths > 1: each sample's variance (its paths'
                                               sample variance / paths; csi-reconstruct --variance)
    DIR/<scene>/s<spp>_p<paths>.json           how the dump was made: grid, seed, Mitsuba times
A file is written only when missing (all writes go through a temporary name and a rename), so
an interrupted run leaves nothing partial and a rerun continues where it stopped.
"""
import glob
import json
import os
import sys
import textwrap
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "host", "python"))

from csi import atomic  # noqa: E402
from csi import dump as csid  # noqa: E402
from csi import exr  # noqa: E402
from csi import mitsuba_bridge as mb  # noqa: E402

#: Scene name -> what load_scene takes: Mitsuba's Cornell box, or a generator in data/mitsuba/.
SCENES = {
    "cornell": "cornell",
    "glossy_sun": os.path.join(ROOT, "data", "mitsuba", "glossy_sun.py"),
    "thin_geometry": os.path.join(ROOT, "data", "mitsuba", "thin_geometry.py"),
    "horizon": os.path.join(ROOT, "data", "mitsuba", "horizon.py"),
    "envmap": os.path.join(ROOT, "data", "mitsuba", "envmap.py"),
    "glints": os.path.join(ROOT, "data", "mitsuba", "glints.py"),
    "neon_tubes": os.path.join(ROOT, "data", "mitsuba", "neon_tubes.py"),
    "street_lamps": os.path.join(ROOT, "data", "mitsuba", "street_lamps.py"),
}


def scene_names(arg):
    """The scene names of a comma-separated --scenes: each a name above, or a scene file of one's own
    (a Mitsuba XML file, or a Python file defining scene() as data/mitsuba/*.py do), which is added
    to SCENES under its file name without the extension (its dumps go in DATA/NAME)."""
    names = []
    for s in arg.split(","):
        if s in SCENES:
            names.append(s)
        elif os.path.isfile(s):
            name = os.path.splitext(os.path.basename(s))[0]
            if name in SCENES and SCENES[name] != os.path.abspath(s):
                raise SystemExit(f"--scenes: {s}: the name {name!r} is taken by another scene")
            SCENES[name] = os.path.abspath(s)
            names.append(name)
        else:
            raise SystemExit(f"--scenes: {s}: neither a scene name ({', '.join(SCENES)}) nor a scene file")
    return names

README = """Mitsuba 3 sample dumps and references for csi (issue 9), made by
tools/bench/mitsuba_data.py of the csi repository, e.g.
    .venv/bin/python tools/bench/mitsuba_data.py --data DIR --methods stratified,poisson
(rerun it to add what is missing: files are only ever added, each whole).

Per scene directory (<scene>/):
  reference_<SPP>.exr, reference_<SPP>.npy
      Mitsuba's own render, SPP samples per pixel, film reconstruction filter = box: pixel
      (px, py) is the mean radiance over [px, px+1) x [py, py+1) of the image (row 0 on top),
      csi's output pixel. float32, linear RGB, (h, w, 3) in the .npy.
  s<spp>_p<paths>.csid
      csi sample dump (docs/dump-format.md), 3 channels (linear RGB), on csi's default grid for
      <spp> (4x the output size up to 3 spp, 8x for 4-15, 16x from 16), at the positions
      `csi-positions --method stratified` gives (each pixel's block split into <spp> strata,
      one random cell in each: exactly <spp> samples in every pixel, so the per-pixel mean is
      the standard Monte Carlo estimate; seed in the header); each record is the mean of
      <paths> Mitsuba paths through its cell's centre (Mitsuba's sensor and path integrator,
      llvm_ad_rgb).
  s<spp>_p<paths>_poisson.csid (and its .albedo/.normal/.json)
      the same scene, spp and paths at csi's default positions (Poisson-disk over the whole
      grid, what csi-render uses): some pixels get no sample at 1 spp (the mean leaves them 0).
  s<spp>_p<paths>.albedo.csid, s<spp>_p<paths>.normal.csid
      the same positions: albedo and shading normal at the first hit (Mitsuba's aov integrator,
      one evaluation per sample; normal 0 where the ray leaves the scene). Per-pixel means of
      them are OIDN's albedo and normal guides.
  s<spp>_p<paths>.variance.csid (64 paths; also _poisson)
      the same positions: the variance of each record's value as an estimate of the radiance at
      its point (the sample variance of its <paths> paths / <paths>), for csi-reconstruct
      --variance. Added to an existing directory without touching its other files.
  s<spp>_p<paths>.json
      grid, seed, paths, Mitsuba's time (JIT apart, per sample and per path), non-finite paths.

Scenes (generators in data/mitsuba/ of the csi repository; 'cornell' is Mitsuba's built-in
mi.cornell_box(), path tracer, max depth 8):
{scenes}
Caveats: the references are Monte Carlo estimates too (4096 paths per pixel: at 16 spp x 64
paths = 1024 paths per pixel their own error is about a quarter of the per-pixel mean's, which
inflates every method's measured MSE a little); glossy_sun has rare very bright paths (the sun's
glossy reflection reached through a diffuse bounce: single samples of several hundred where the
reference is below 1) that dominate its relMSE at low spp and vary from seed to seed.

Reconstruct one:  build/csi-reconstruct DIR/cornell/s4_p1.csid -o out.exr
The per-pixel mean of the very same samples:  ... --estimator mean
relMSE as in issue 9: mean over pixels and channels of (x - ref)^2 / (ref^2 + 0.01).
"""


def scene_dir(data, scene):
    d = os.path.join(data, scene)
    os.makedirs(d, exist_ok=True)
    return d


def reference_path(data, scene):
    """The reference of DATA's scene with the most samples per pixel (reference_<SPP>.npy)."""
    found = glob.glob(os.path.join(data, scene, "reference_*.npy"))
    spp = lambda p: int(os.path.basename(p)[len("reference_"):-len(".npy")])  # noqa: E731
    found = [p for p in found if os.path.basename(p)[len("reference_"):-len(".npy")].isdigit()]
    if not found:
        raise SystemExit(f"{os.path.join(data, scene)}: no reference_<SPP>.npy (mitsuba_data.py renders it)")
    return max(found, key=spp)


def _write_json(path, obj):
    with atomic.target(path) as tmp, open(tmp, "w") as f:
        json.dump(obj, f, indent=1, sort_keys=True)


def _write_npy(path, arr):
    with atomic.target(path, suffix=".npy") as tmp:
        np.save(tmp, arr)


def write_readme(data):
    """DIR/README.txt, describing every scene that has a directory in DIR."""
    lines = []
    for s in (s for s in SCENES if os.path.isdir(os.path.join(data, s))):
        src = SCENES[s]
        doc = "Mitsuba's built-in Cornell box" if src == "cornell" else (_docstring(src) or s)
        lines.append(textwrap.fill(f"{s}: {doc}", width=96, initial_indent="  ", subsequent_indent="      "))
    with atomic.target(os.path.join(data, "README.txt")) as tmp, open(tmp, "w") as f:
        f.write(README.replace("{scenes}", "\n".join(lines) + "\n"))


def _docstring(path):
    import ast

    with open(path) as f:
        doc = ast.get_docstring(ast.parse(f.read())) or ""
    return " ".join(doc.split())


def reference(data, scene, size, spp, log=print):
    """(h, w, 3) float32 reference, rendered if not cached; also returns Mitsuba's seconds (0 if cached)."""
    d = scene_dir(data, scene)
    npy = os.path.join(d, f"reference_{spp}.npy")
    if os.path.exists(npy):
        ref = np.load(npy)
        if ref.shape[:2] == (size[1], size[0]):
            return ref, 0.0
    log(f"  {scene}: reference at {spp} spp ...")
    t0 = time.perf_counter()
    ref = mb.render_reference(mb.load_scene(SCENES[scene], size=size, box_filter=True), spp=spp, seed=0)
    t = time.perf_counter() - t0
    exr.write(os.path.join(d, f"reference_{spp}.exr"), ref)
    _write_npy(npy, ref)
    return ref, t


def dump_paths(data, scene, spp, paths, method="stratified"):
    stem = os.path.join(scene_dir(data, scene), f"s{spp}_p{paths}" + ("" if method == "stratified" else f"_{method}"))
    p = {"dump": stem + ".csid", "albedo": stem + ".albedo.csid", "normal": stem + ".normal.csid",
         "info": stem + ".json"}
    if paths > 1:  # one path has no sample variance
        p["variance"] = stem + ".variance.csid"
    return p


def samples(data, scene, size, spp, paths, seed=1, method="stratified", log=print):
    """Renders (if not cached) the dump of `scene` at spp x paths; returns its file paths and info."""
    p = dump_paths(data, scene, spp, paths, method)
    if all(os.path.exists(f) for f in p.values()):
        with open(p["info"]) as f:
            return p, json.load(f)
    # Only the missing files are written (a directory made before the variances were kept gets
    # them added): the render is deterministic, so the others would be the same bytes.
    new = lambda k: not os.path.exists(p[k])
    log(f"  {scene}: {spp} spp x {paths} paths, {method} positions ...")
    req = mb.positions_request(size, spp=spp, seed=seed, method=method)
    sc = mb.load_scene(SCENES[scene], size=size)
    s = mb.render_request(sc, req, paths=paths, seed=seed, aov=new("albedo") or new("normal"))
    for k, v in (("albedo", s.albedo), ("normal", s.normal), ("variance", s.variance), ("dump", s.values)):
        if k in p and new(k):
            csid.write(p[k], req.with_values(v))
    if not new("info"):
        with open(p["info"]) as f:
            return p, json.load(f)
    info = {"scene": scene, "spp": spp, "paths": paths, "seed": seed, "grid": list(req.grid), "out": list(req.out),
            "samples": len(req.xyt), "nonfinite_paths": s.nonfinite, "mitsuba": s.timing,
            "positions": f"csi-positions --method {method}, default grid"}
    _write_json(p["info"], info)
    return p, info


def main(argv=None):
    import argparse

    ap = argparse.ArgumentParser(description="Renders the Mitsuba benchmark's dumps and references into DIR.")
    ap.add_argument("--data", required=True)
    ap.add_argument("--scenes", default=",".join(SCENES),
                    help="comma-separated scene names, or scene files of your own (XML, or Python defining scene())")
    # 2 and 8 spp besides the 1, 4 and 16: 2 is the 4x grid with most pixels holding two
    # samples or more and some one, 8 the 8x grid with twice 4's samples, regimes of their own
    # (docs/bench/mitsuba.md, session 37)
    ap.add_argument("--spp", default="1,2,4,8,16")
    ap.add_argument("--paths", default="1,64")
    ap.add_argument("--size", default="128x128")
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--methods", default="stratified", help="positions: stratified and/or poisson")
    ap.add_argument("--seed", type=int, default=1,
                    help="the positions' and paths' seed; another seed goes in another DIR (the reference, seed 0, is the same render)")
    a = ap.parse_args(argv)
    size = tuple(int(v) for v in a.size.split("x"))
    scenes = scene_names(a.scenes)
    os.makedirs(a.data, exist_ok=True)
    for scene in scenes:
        for spp in (int(v) for v in a.spp.split(",")):
            for paths in (int(v) for v in a.paths.split(",")):
                for method in a.methods.split(","):
                    samples(a.data, scene, size, spp, paths, seed=a.seed, method=method)
        reference(a.data, scene, size, a.reference_spp)
        write_readme(a.data)


if __name__ == "__main__":
    main()
