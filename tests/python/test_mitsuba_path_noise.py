"""One path's variance for an animation rendered with one path per sample (mb.path_noise; csi-mitsuba
hands it to csi as every sample's variance, which a volume's solve uses for its tau):

- against an independent estimate of the same quantity: Mitsuba's 32 paths through each of the
  cells path_noise took (one in 16 of the request's), their sample variance times 32 (one path's
  variance), averaged. Both estimates are unbiased; they must agree within 4 standard errors of
  their difference (each from the spread of its own per-cell figures), per channel;
- on a scene without noise (an emitter and a sky seen directly, max_depth 1: every path through a
  cell returns the same radiance) it is exactly 0;
- csi-mitsuba --time-steps 4 --paths 1 --dump X.csid writes X.variance.csid holding that figure
  (its --stats' path_noise) for every sample, and csi-reconstruct X.csid, which reads it beside the
  dump, writes the image csi-mitsuba did (the stats' FNV-1a hash); --no-variance-peaks writes none.

Scene: a diffuse sphere under a constant sky, max_depth 3 (path-traced noise), sliding across an
orthographic view, 32 x 32 pixels, 8 frames."""
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
PYDIR = os.path.join(HERE, "..", "..", "host", "python")
sys.path.insert(0, PYDIR)
sys.path.insert(0, HERE)
from checks import check, done  # noqa: E402
from csi import dump as csid  # noqa: E402
from csi import mitsuba_bridge as mb  # noqa: E402

SCENE = """
import mitsuba as mi
T = mi.ScalarTransform4f
def scene():
    return {"type": "scene", "integrator": {"type": "path", "max_depth": DEPTH},
            "sensor": {"type": "orthographic",
                       "to_world": T().look_at(origin=[0, 0, 5], target=[0, 0, 0], up=[0, 1, 0]),
                       "film": {"type": "hdrfilm", "width": 32, "height": 32}},
            "sky": {"type": "constant", "radiance": {"type": "rgb", "value": [0.8, 0.9, 1.0]}},
            "floor": {"type": "rectangle", "to_world": T().translate([0, 0, -1]).scale(3),
                      "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.5, 0.4, 0.3]}}},
            "ball": {"type": "sphere", "to_world": T().translate([-0.4, 0.1, 0]).scale(0.45),
                     BALL}}
def animate(params, time):
    params["ball.to_world"] = T().translate([-0.4 + 0.8 * time, 0.1, 0]).scale(0.45)
"""
NOISY = SCENE.replace("DEPTH", "3").replace(
    "BALL", '"bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.7, 0.3, 0.2]}}')
EXACT = SCENE.replace("DEPTH", "1").replace("BALL", '"emitter": {"type": "area", "radiance": {"type": "rgb", "value": 1.0}}')


def cli(*args):
    env = dict(os.environ, PYTHONPATH=os.path.abspath(PYDIR))
    return subprocess.run([sys.executable, "-m", "csi.mitsuba_cli", *map(str, args)], stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE, text=True, env=env)


def main():
    build = os.environ.get("CSI_BUILD_DIR", os.path.join(HERE, "..", "..", "build"))
    with tempfile.TemporaryDirectory() as tmp:
        p = lambda name: os.path.join(tmp, name)  # noqa: E731
        for name, text in (("noisy.py", NOISY), ("exact.py", EXACT)):
            with open(p(name), "w") as f:
                f.write(text)
        scene = mb.load_scene(p("noisy.py"))
        req = mb.positions_request((32, 32), grid=32, method="random", seed=5, time_steps=8, fraction=0.5)
        one = mb.render_request(scene, req, paths=1, seed=5)
        v, t = mb.path_noise(scene, req, one.values, seed=11)
        # the cells path_noise took: one in 16 of the request's, evenly over its order
        n = len(req.xyt)
        idx = np.unique(np.linspace(0, n - 1, n // 16).round().astype(np.int64))
        check(t["samples"] == len(idx) == n // 16, f"{t['samples']} cells of {n}")
        sub = csid.Dump(grid=req.grid, out=req.out, xyt=req.xyt[idx], values=None, seed=req.seed)
        second = mb.render_request(scene, sub, paths=1, seed=11)
        many = mb.render_request(scene, sub, paths=32, seed=12)
        d = one.values[idx].astype(np.float64) - second.values
        q2 = 0.5 * d * d  # per cell: one path's variance from the pair
        q32 = 32.0 * many.variance.astype(np.float64)  # ... from 32 paths
        check(np.allclose(v, q2.mean(axis=0), rtol=1e-12, atol=0), f"path_noise {v} is the pairs' mean {q2.mean(axis=0)}")
        se = np.sqrt(q2.var(axis=0, ddof=1) / len(idx) + q32.var(axis=0, ddof=1) / len(idx))
        ref = q32.mean(axis=0)
        check(np.all(ref > 1e-4), f"the scene is noisy: one path's variance {ref}")
        check(np.all(np.abs(v - ref) < 4 * se), f"one path's variance {v} against 32 paths' {ref} (4 standard errors {4 * se})")

        exact = mb.load_scene(p("exact.py"))
        z, _ = mb.path_noise(exact, req, mb.render_request(exact, req, paths=1, seed=5).values, seed=11)
        check(np.all(z == 0), f"a scene without noise: {z}")

        args = [p("noisy.py"), "--out", "32x32", "--time-steps", 4, "--spp", 2, "--seed", 3, "-q"]
        r = cli(*args, "--dump", p("x.csid"), "-o", p("x.exr"), "--stats", p("x.json"))
        check(r.returncode == 0, f"csi-mitsuba: {r.stderr.strip()}")
        if r.returncode == 0:
            st = json.load(open(p("x.json")))
            var = csid.read(p("x.variance.csid")).values
            want = np.float32(st["path_noise"]["variance"])
            check(var.shape == (st["samples"], 3) and np.all(var == want), f"X.variance.csid holds {want} for every sample")
            r2 = subprocess.run([os.path.join(build, "csi-reconstruct"), p("x.csid"), "-o", p("y.exr"), "--stats",
                                 p("y.json"), "-q"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            h = json.load(open(p("y.json")))["image_fnv1a64"] if r2.returncode == 0 else None
            check(h == st["reconstruction"]["image_fnv1a64"], f"csi-reconstruct on the dump: {h} vs csi-mitsuba's "
                  f"{st['reconstruction']['image_fnv1a64']} ({r2.stderr.strip()})")
        r = cli(*args, "--dump", p("n.csid"), "--no-variance-peaks")
        check(r.returncode == 0 and not os.path.exists(p("n.variance.csid")), f"--no-variance-peaks: {r.stderr.strip()}")
    return done()


if __name__ == "__main__":
    sys.exit(main())
