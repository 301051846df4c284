"""The bridge's samples see the participating medium the sensor sits in, as Mitsuba's own render
does (mi.render hands the integrator the sensor's medium; a camera in fog sees through fog):
checked against a closed form.

The scene: a perspective sensor at z = D looking down -z inside a purely absorbing homogeneous
medium (albedo 0, extinction SIGMA), facing an emissive plane z = 0 of radiance L that fills
the view; the volumetric path tracer. A path either crosses the medium to the plane, with
probability exp(-SIGMA * l), and carries L, or scatters first and carries 0 (albedo 0). l is the
ray's length in the medium from the near clip plane to z = 0. Mitsuba's perspective sensor with
its field of view on x sends image point (u, v) (v down) along camera-space direction
(x, y, 1), x = (2u - 1) tan(fov / 2), y = (1 - 2v) tan(fov / 2) / aspect, from the point
where it crosses the near clip plane z = NEAR, so l = (D - NEAR) sqrt(1 + x^2 + y^2) (the sign
conventions of x and y do not matter to the length). A sample of P paths has expectation
L exp(-SIGMA l) and binomial variance L^2 p (1 - p) / P.

Without the medium the samples are L everywhere: 2.7-4x the closed form here.
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "host", "python"))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from checks import check, done  # noqa: E402
from csi import mitsuba_bridge as mb  # noqa: E402

W, H = 24, 16
D, NEAR, SIGMA, L, FOV = 2.0, 1e-3, 0.5, 3.0, 60.0
PATHS = 16


def fog_scene(path):
    """Writes the scene as a Python scene file (what csi-mitsuba and load_scene take)."""
    with open(path, "w") as f:
        f.write(f'''
import mitsuba as mi
def scene():
    T = mi.ScalarTransform4f
    return {{"type": "scene", "integrator": {{"type": "volpath", "max_depth": 4}},
        "fog": {{"type": "homogeneous", "albedo": {{"type": "rgb", "value": [0, 0, 0]}}, "sigma_t": {SIGMA}}},
        "sensor": {{"type": "perspective", "fov": {FOV}, "fov_axis": "x", "near_clip": {NEAR},
                   "to_world": T().look_at(origin=[0, 0, {D}], target=[0, 0, 0], up=[0, 1, 0]),
                   "film": {{"type": "hdrfilm", "width": 8, "height": 8}},
                   "medium": {{"type": "ref", "id": "fog"}}}},
        "wall": {{"type": "rectangle", "to_world": T().scale(50),
                 "emitter": {{"type": "area", "radiance": {{"type": "rgb", "value": [{L}, {L}, {L}]}}}}}}}}
''')


def transmittance(u, v):
    t = np.tan(np.radians(FOV) / 2)
    x, y = (2 * u - 1) * t, (1 - 2 * v) * t / (W / H)
    return np.exp(-SIGMA * (D - NEAR) * np.sqrt(1 + x * x + y * y))


def main():
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "fog.py")
        fog_scene(path)
        scene = mb.load_scene(path, size=(W, H))
        req = mb.positions_request((W, H), spp=4, seed=5)
        s = mb.render_request(scene, req, paths=PATHS)
        u, v, _ = req.cell_centres()
        p = transmittance(u, v)
        got = s.values.astype(np.float64).mean(axis=1)  # the three channels carry the same paths
        # The mean over all samples against its expectation: the binomial standard error of a
        # mean of independent samples; 5 sigma (a false failure 1 run in 1.7 million).
        n = len(p)
        se = L * np.sqrt((p * (1 - p)).sum() / PATHS) / n
        err = got.mean() - L * p.mean()
        check(abs(err) < 5 * se, f"mean of {n} samples {got.mean():.5f}, closed form {L * p.mean():.5f} "
                                 f"(standard error {se:.2e})")
        # The longest paths (the corners) and the shortest (the centre) each, the same bound: the
        # path length follows the image position, not one constant.
        for name, sel in (("centre", p >= np.quantile(p, 0.75)), ("corners", p <= np.quantile(p, 0.25))):
            q = p[sel]
            se = L * np.sqrt((q * (1 - q)).sum() / PATHS) / len(q)
            err = got[sel].mean() - L * q.mean()
            check(abs(err) < 5 * se, f"{name}: mean {got[sel].mean():.5f}, closed form {L * q.mean():.5f} "
                                     f"(standard error {se:.2e})")
        check(p[p <= np.quantile(p, 0.25)].mean() < 0.9 * p[p >= np.quantile(p, 0.75)].mean(),
              "the corners' paths are not longer than the centre's: the test would not see a shape error")
    return done()


if __name__ == "__main__":
    sys.exit(main())
