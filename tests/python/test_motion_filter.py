"""Alg. 1's filter in Alg. 2's solve (csi_half_fourier_set_filter, csi_recon_options.motion_filter;
issue 12): the volume is solved for blurred by a Gaussian of width sigma along x and y and seen by
the samples through its Wiener inverse, where a still basis is fitted to fewer than 2 samples per
pixel over the shutter.

Scene (closed form at the cells' centres): a still texture (two gratings, a checker of 3-cell
blocks and sharp-edged discs: not sparse in the Fourier basis) and one small disc crossing it,
32 x 32 x 16 cells, the image at the grid's size; uniformly random distinct cells.

1. The rule, against its closed form: at 1/T of the cells (one sample per pixel over t) the result
   reports the width max(0.275, 0.8 sqrt(w h / N)) (Alg. 1's paper width for a pixel of one
   cell, csi's sigma-spacing 0.8); at half the cells (8 samples per pixel), and with a sheared
   basis (a given velocity), none (-1), and the image is the same bits as with the filter off.
   A width given is used as given.
2. Against the truth (the volume's mean over t), summed over 3 seeds at 1/T of the cells: the
   filtered image's MSE is below the unfiltered one's (the point of the filter: at these rates a
   still texture seen through one sample per pixel is better modelled blurred, as in Alg. 1).
   No tolerance: the measured ratio is printed.
"""
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "host", "python"))
sys.path.insert(0, HERE)
import csi  # noqa: E402
from checks import check, done  # noqa: E402

W = H = 32
T = 16
GRID = (W, H, T, W, H)


def truth_volume():
    t, y, x = np.meshgrid(np.arange(T), np.arange(H), np.arange(W), indexing="ij")
    u, v, s = (x + 0.5) / W, (y + 0.5) / H, (t + 0.5) / T
    f = 0.45 + 0.12 * np.sin(2 * np.pi * (4 * u + 3 * v)) + 0.08 * np.cos(2 * np.pi * 7 * v)
    f += 0.1 * (((x // 3) + (y // 3)) % 2)
    for (cx, cy, r, val) in ((0.3, 0.35, 0.16, 0.9), (0.7, 0.7, 0.2, 0.15), (0.75, 0.25, 0.1, 0.7)):
        f = np.where(np.hypot(u - cx, v - cy) < r, val, f)
    f = np.where(np.hypot(u - (0.1 + 0.8 * s), v - 0.55) < 0.07, 1.2, f)
    return f.astype(np.float32)


def samples(f, seed, count):
    rng = np.random.default_rng(seed)
    idx = np.sort(rng.choice(f.size, count, replace=False))
    t, r = np.divmod(idx, H * W)
    y, x = np.divmod(r, W)
    return np.stack([x, y, t], axis=1).astype(np.uint32), f.reshape(-1)[idx][:, None].astype(np.float32)


def width(res):
    """The width the result reports; -1 for none (reported as "off")."""
    w = res.options["motion_filter"]
    return -1.0 if w == "off" else float(w)


f = truth_volume()
ref = f.mean(axis=0)
k = f.size

# 1. the rule
n = k // T
pos, vals = samples(f, 1, n)
res = csi.reconstruct(pos, vals, GRID)
want = max(0.275, 0.8 * math.sqrt(W * H / n))
check(abs(width(res) - want) < 1e-9, f"one sample per pixel: width {width(res)} (closed form {want})")
res = csi.reconstruct(pos, vals, GRID, motion_filter=1.7)
check(abs(width(res) - 1.7) < 1e-12, f"a given width is used: {width(res)}")
given = dict(motion_velocity="given", motion_vx=0.8, motion_vy=0.0)
res = csi.reconstruct(pos, vals, GRID, **given)
off = csi.reconstruct(pos, vals, GRID, motion_filter=-1, **given)
check(width(res) == -1 and np.array_equal(res.image, off.image),
      f"sheared basis: no filter ({width(res)}), the same image as with the filter off")
pos2, vals2 = samples(f, 1, k // 2)
res = csi.reconstruct(pos2, vals2, GRID)
off = csi.reconstruct(pos2, vals2, GRID, motion_filter=-1)
check(width(res) == -1 and np.array_equal(res.image, off.image),
      f"8 samples per pixel: no filter ({width(res)}), the same image as with the filter off")

# 2. the filter's gain on a still texture at one sample per pixel
e_on = e_off = 0.0
for seed in (1, 2, 3):
    pos, vals = samples(f, seed, n)
    on = csi.reconstruct(pos, vals, GRID)
    off = csi.reconstruct(pos, vals, GRID, motion_filter=-1)
    check(width(on) > 0 and width(off) == -1, f"seed {seed}: filter on by default, off when asked")
    e_on += float(np.mean((on.image[..., 0] - ref) ** 2))
    e_off += float(np.mean((off.image[..., 0] - ref) ** 2))
print(f"image MSE over 3 seeds: filtered {e_on:.4e}, unfiltered {e_off:.4e} ({e_on / e_off:.3f}x)")
check(e_on < e_off, f"the filtered image beats the unfiltered one: {e_on:.4e} vs {e_off:.4e}")
sys.exit(done())
