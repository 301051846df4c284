"""csi-mitsuba evaluates exactly csi's cell centres, and Mitsuba's box-filtered reference uses
csi's pixels (pixel (px, py) covers [px, px+1) x [py, py+1), row 0 on top): checked on a scene
whose radiance is a known function of the image position.

The scene: an orthographic sensor at z = 5 looking down -z (up +y) at an emissive square
[-2, 2]^2 in the plane z = 0, whose radiance is a bitmap texture holding ramps. A viewer looking
down -z with +y up has +x on the right, so image point (u, v) (v down) sees world
x = 2u - 1, y = (1 - 2v) / aspect (Mitsuba's orthographic sensor spans [-1, 1] along x and
[-1/aspect, 1/aspect] along y, aspect = width / height). The square's uv is
((x/2 + 1) / 2, (y/2 + 1) / 2), and texel (row j, column i) of an N x N bitmap lies at uv
((i + 0.5) / N, (j + 0.5) / N). Texel values R = (i + 0.5) / N, G = (j + 0.5) / N make the
bilinearly filtered radiance exactly R = uv.u, G = uv.v inside the outer half-texel (the view
sees uv in [0.25, 0.75]), so

    R(u, v) = u / 2 + 1/4,    G(u, v) = (1 - 2v) / (4 aspect) + 1/2,    B = 1.

A width != height film makes a swapped x/y or aspect error visible; a sample taken half a cell
off the centre is off by 1 / (4 grid_w) in R, far above the float32 tolerance used here.
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "host", "python"))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from checks import check, done  # noqa: E402
from csi import mitsuba_bridge as mb  # noqa: E402

W, H = 24, 16
ASPECT = W / H
N = 64


def ramp_scene(path):
    """Writes the scene as a Python scene file (what csi-mitsuba and load_scene take)."""
    with open(path, "w") as f:
        f.write(f'''
import mitsuba as mi
import numpy as np
def scene():
    N = {N}
    tex = np.ones((N, N, 3), np.float32)
    tex[..., 0] = ((np.arange(N) + 0.5) / N)[None, :]
    tex[..., 1] = ((np.arange(N) + 0.5) / N)[:, None]
    T = mi.ScalarTransform4f
    return {{"type": "scene", "integrator": {{"type": "direct"}},
        "sensor": {{"type": "orthographic", "to_world": T().look_at(origin=[0, 0, 5], target=[0, 0, 0], up=[0, 1, 0]),
                   "film": {{"type": "hdrfilm", "width": 8, "height": 8}}}},
        "square": {{"type": "rectangle", "to_world": T().scale(2),
                   "emitter": {{"type": "area", "radiance": {{"type": "bitmap", "bitmap": mi.Bitmap(tex), "raw": True,
                                                            "filter_type": "bilinear", "wrap_mode": "clamp"}}}}}}}}
''')


def expected(u, v):
    return np.stack([u / 2 + 0.25, (1 - 2 * v) / (4 * ASPECT) + 0.5, np.ones_like(u)], axis=-1)


def main():
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "ramp.py")
        ramp_scene(path)
        scene = mb.load_scene(path, size=(W, H))
        check(scene.size == (W, H), f"film size {scene.size}")
        # Samples: every default grid (4x at 1 spp, 8x at 4, 16x at 16) and a moving grid (1x).
        for spp, t in ((1, 1), (4, 1), (16, 1), (2, 4)):
            req = mb.positions_request((W, H), spp=spp, seed=spp, time_steps=t)
            s = mb.render_request(scene, req, paths=2)
            x, y = req.xyt[:, 0].astype(np.float64), req.xyt[:, 1].astype(np.float64)
            want = expected((x + 0.5) / req.grid[0], (y + 0.5) / req.grid[1])
            # float32 positions and bilinear weights: errors of a few 1e-7; 2e-5 is 20x below the
            # smallest half-cell offset checked here (1 / (4 * 384) = 6.5e-4 in R at 16x).
            err = np.abs(s.values - want).max(axis=0)
            check((err < 2e-5).all(), f"{spp} spp, T = {t}, grid {req.grid}: |sample - closed form| max {err}")
            # and not at the cell's corner: a half-cell shift is detected by this same check
            shifted = expected((x + 1.0) / req.grid[0], (y + 1.0) / req.grid[1])
            check(np.abs(s.values - shifted).max() > 1e-4, f"{spp} spp: a half-cell shift would go unnoticed")
        # Mitsuba's reference with the box filter: R and G are linear in (u, v), so each pixel's
        # box mean is the value at its centre ((px + 0.5) / W, (py + 0.5) / H). The Monte Carlo
        # error of R over a pixel at 256 spp is 1/(2W) / sqrt(12 * 256) = 3.3e-4 (G: 1/(2H aspect)
        # likewise, 3.3e-4); 3e-3 is 9 sigma, while a half-pixel shift errs by 1/(4W) = 0.010.
        ref_scene = mb.load_scene(path, size=(W, H), box_filter=True)
        ref = mb.render_reference(ref_scene, spp=256, seed=3)
        py, px = np.mgrid[0:H, 0:W]
        want = expected((px + 0.5) / W, (py + 0.5) / H)
        err = np.abs(ref - want).max(axis=(0, 1))
        check(ref.shape == (H, W, 3) and (err < 3e-3).all(), f"reference vs pixel-centre closed form: max {err}")
        check(np.abs(ref[0, :, 1] - want[0, :, 1]).max() < 3e-3 and ref[0, 0, 1] > ref[-1, 0, 1],
              "reference row 0 is the top of the image")
    return done()


if __name__ == "__main__":
    sys.exit(main())
