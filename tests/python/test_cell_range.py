"""A still light does not glow into pixels whose own neighbourhood never saw it (issue 12,
docs/bench/animation.md session 45).

Where a still camera's samples say little moves (moving_share.c: for exact samples the rule of
the still layer's tenth, for noisy ones a stricter share of motion), each cell of the volume is
kept within the range of the samples in the 3 x 3 cells around it, over all t (sample_range.c),
not within those of the 3 x 3 pixels around its pixel: on 4 x 4 cells a pixel the pixels' window
spans 12 x 12 cells, and the fit, which sees each cell once over the shutter, can keep a light at
the frames no sample saw in cells a pixel away from it.

Scene: 24 x 24 pixels over 8 frames, 16 spp (4 x 4 cells a pixel, each cell sampled once),
exact point values at the cells' centres: a faint sinusoidal texture (0.05 +- 0.03) with three
still lights of 40, 25 and 60 (radius 0.55, 0.8 and 0.3 pixels, off the pixel lattice).

1. The still layer takes the tenth (the premise of the bound for exact samples).
2. Every frame of every pixel lies within the samples of the (4 + 2) x (4 + 2) cells around the
   pixel (the union of its cells' ranges; a frame is its cells' mean), to float rounding: the
   bound, checked against the samples themselves. Before it 241 pixels' frames left it, by up
   to 2.5 where those samples stay below 0.08. The same for the picture's samples each times
   1 + 0.1 N(0, 1) (noisy, not flagged exact: the weight stays one; with the bound for exact
   samples alone 297 pixels left it, by up to 3.0).
3. The image against the truth (each pixel's mean over its area and the shutter, 32 x 32
   points a pixel, 32 times): below the per-pixel mean of the same samples (stratified Monte
   Carlo) and below the image without the bound (the tenth given as an option, which keeps the
   pixels' ranges; measured 0.80x and 1.12x the mean's MSE: at one sample a cell the mean is
   hard to beat, and the glow had made csi worse than it).
"""
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "host", "python"))
sys.path.insert(0, HERE)
import csi  # noqa: E402
from checks import check, done  # noqa: E402

W = H = 24
T = 8
SPP = 16
LIGHTS = ((7.3, 9.6, 0.55, 40.0), (16.8, 15.2, 0.8, 25.0), (12.6, 4.4, 0.3, 60.0))  # x, y, radius (pixels), value


def picture(x, y):
    v = 0.05 + 0.03 * np.sin(2 * np.pi * (0.23 * x + 0.11 * y))
    for cx, cy, r, value in LIGHTS:
        v = np.where((x - cx) ** 2 + (y - cy) ** 2 < r * r, value, v)
    return v


def main():
    F = csi.default_grid_factor(W, H, T, SPP)
    check(F == 4, f"{SPP} spp over {T} frames: {F} x {F} cells a pixel, want 4 x 4")
    g = (W * F, H * F, T, W, H)
    pos = csi.positions(g, spp=SPP, method="stratified", seed=3)
    v = picture((pos[:, 0] + 0.5) / F, (pos[:, 1] + 0.5) / F).astype(np.float32)[:, None]
    r = csi.reconstruct(pos, v, g, exact=True, frames=True)
    weight = r.stats["options"]["motion_still_weight"]
    check(weight == 0.1, f"the still layer's weight {weight}, want 0.1")
    bounded(r, pos, v, F, "exact")
    # the same picture through a path tracer's noise (not exact: the weight stays one)
    noisy = (v * (1 + 0.1 * np.random.default_rng(11).standard_normal(v.shape))).astype(np.float32)
    rn = csi.reconstruct(pos, noisy, g, frames=True)
    weight = rn.stats["options"]["motion_still_weight"]
    check(weight == 1, f"noisy samples: the still layer's weight {weight}, want 1")
    bounded(rn, pos, noisy, F, "noisy")

    s = 32
    fx, fy = np.meshgrid((np.arange(W * s) + 0.5) / s, (np.arange(H * s) + 0.5) / s)
    truth = picture(fx, fy).reshape(H, s, W, s).mean(axis=(1, 3))
    pix = (pos[:, 1] // F) * W + pos[:, 0] // F
    mean = (np.bincount(pix, v[:, 0], W * H) / np.bincount(pix, minlength=W * H)).reshape(H, W)
    img = np.asarray(r.image, np.float64).reshape(H, W)
    # the tenth given as an option: the same weight, the pixels' ranges (csi's bound before)
    before = np.asarray(csi.reconstruct(pos, v, g, exact=True, motion_still_weight=0.1).image, np.float64)
    e_csi, e_mean, e_before = (float(((a.reshape(H, W) - truth) ** 2).mean()) for a in (img, mean, before))
    print(f"image MSE {e_csi:.3e}, the per-pixel mean's {e_mean:.3e} ({e_csi / e_mean:.2f}x), by the pixels' "
          f"ranges {e_before:.3e} ({e_before / e_mean:.2f}x)")
    check(e_csi < e_mean, f"image MSE {e_csi:.3e} not below the per-pixel mean's {e_mean:.3e}")
    check(e_csi < e_before, f"image MSE {e_csi:.3e} not below the pixels' ranges' {e_before:.3e}")
    return done()


def bounded(r, pos, v, F, what):
    """Every frame of every pixel within the samples of the (F + 2) x (F + 2) cells around it."""
    lo = np.full((H * F, W * F), np.inf)
    hi = np.full((H * F, W * F), -np.inf)
    np.minimum.at(lo, (pos[:, 1], pos[:, 0]), v[:, 0])
    np.maximum.at(hi, (pos[:, 1], pos[:, 0]), v[:, 0])
    plo = np.empty((H, W))
    phi = np.empty((H, W))
    for py in range(H):
        for px in range(W):
            ys = slice(max(py * F - 1, 0), min(py * F + F + 1, H * F))
            xs = slice(max(px * F - 1, 0), min(px * F + F + 1, W * F))
            plo[py, px], phi[py, px] = lo[ys, xs].min(), hi[ys, xs].max()
    frames = np.asarray(r.frames, np.float64)[..., 0]
    tol = 1e-5 * np.maximum(np.abs(plo), np.abs(phi))
    over = np.maximum(frames - (phi + tol), (plo - tol) - frames).max(axis=0)
    worst = tuple(int(i) for i in np.unravel_index(np.argmax(over), over.shape))
    print(f"{what}: frames beyond the samples of the cells around their pixel: {int((over > 0).sum())} pixels, "
          f"at most {over.max():.3g} (pixel {worst[::-1]}, its samples in [{plo[worst]:.3g}, {phi[worst]:.3g}])")
    check(over.max() <= 0, f"{what}: a frame of pixel {worst[::-1]} leaves its cells' samples' range "
          f"[{plo[worst]:.3g}, {phi[worst]:.3g}] by {over.max():.3g}")


if __name__ == "__main__":
    sys.exit(main())
