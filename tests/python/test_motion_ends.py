"""The still basis's transform along t chosen by how much the shutter's ends differ (motion.c's
auto, host/integrate/motion_ends.c; docs/bench/animation.md, session 34).

The rule, written again here in numpy: blocks of output pixels just large enough that each
quarter of the shutter's frames expects 8 samples; per block and channel the mean of the samples
in the first quarter (a), the last (z) and all (m), each squared term less its sampling variance
(s^2 / n); ratio = sum (a - z)^2 / sum m^2 over blocks with two samples or more in each quarter.
Above 1 the DCT-II, else the DFT (with a still basis; a sheared one always takes the DCT).

Two volumes of exact samples at 10% of the cells, 48 x 48 x 16, one cell per pixel, on a still
background (a smooth texture):
- a lamp (an HDR rectangle, 20 against a background of about 0.5) in the top rows for the
  first half of the shutter, then gone (a light leaving the view): numpy's ratio above 2, and the
  library takes the DCT (its options say so, and its image and frames are those of
  --motion-time dct, bit for bit); the point of it: its frames are closer to the truth than the
  DFT's by 20% or more in MSE (the DFT joins the last frames to the first, where the lamp is);
- a disc crossing the background (a still camera with a mover: ends alike in energy): numpy's
  ratio below 0.5, and the library keeps the DFT (the bits of --motion-time dft).
With the samples' variances (the frames' step, whose folds take the whole's transform) auto's
bits are still those of the transform it names. With a given velocity the basis is sheared and
takes the DCT whatever the ends."""
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "host", "python"))
sys.path.insert(0, HERE)
import csi  # noqa: E402
from checks import check, done  # noqa: E402

W = H = 48
T = 16
GRID = (W, H, T, W, H)


def background():
    y, x = np.mgrid[0:H, 0:W] + 0.5
    return 0.5 + 0.2 * np.sin(2 * np.pi * x / 19) * np.cos(2 * np.pi * y / 23)


def lamp_volume():
    f = np.repeat(background()[None], T, axis=0)
    f[: T // 2, 2:8, 14:34] = 20.0
    return f


def disc_volume():
    y, x = np.mgrid[0:H, 0:W] + 0.5
    f = np.repeat(background()[None], T, axis=0)
    for t in range(T):
        f[t][(x - (6 + 2.2 * t)) ** 2 + (y - 24) ** 2 < 20] = 1.5
    return f


def ends_ratio(pos, val):
    """The documented rule, in numpy (double)."""
    n = len(pos)
    q = max(1, T // 4)
    per_pixel = n / (W * H) * q / T
    B = int(min(max(np.ceil(np.sqrt(8.0 / per_pixel)), 1), min(W, H)))
    nbx, nby = -(-W // B), -(-H // B)
    blk = (pos[:, 1] // B) * nbx + pos[:, 0] // B

    def stats(mask):
        v = val[mask, 0].astype(np.float64)
        cnt = np.bincount(blk[mask], minlength=nbx * nby).astype(np.float64)
        mean = np.bincount(blk[mask], v, minlength=nbx * nby) / np.maximum(cnt, 1)
        ss = np.bincount(blk[mask], (v - mean[blk[mask]]) ** 2, minlength=nbx * nby)
        return cnt, mean, np.where(cnt > 1, ss / np.maximum(cnt - 1, 1) / np.maximum(cnt, 1), 0)

    t = pos[:, 2]
    ca, a, va = stats(t < q)
    cz, z, vz = stats(t >= T - q)
    cm, m, vm = stats(np.ones(n, bool))
    ok = (ca >= 2) & (cz >= 2)
    return float(np.sum(((a - z) ** 2 - va - vz)[ok]) / np.sum((m ** 2 - vm)[ok]))


pos = csi.positions(GRID, method="random", seed=4, fraction=0.1)
for name, f, want in (("lamp leaving", lamp_volume(), "dct"), ("disc crossing", disc_volume(), "dft")):
    val = f[pos[:, 2], pos[:, 1], pos[:, 0]][:, None].astype(np.float32)
    ratio = ends_ratio(pos, val)
    check(ratio > 2 if want == "dct" else ratio < 0.5, f"{name}: numpy's ratio {ratio:.3f}")
    auto = csi.reconstruct(pos, val, GRID, frames="on")
    check(auto.options["motion_vx"] == "0" and auto.options["motion_vy"] == "0",
          f"{name}: a still basis (velocity {auto.options['motion_vx']}, {auto.options['motion_vy']})")
    check(auto.options["motion_time"] == want, f"{name}: auto takes {auto.options['motion_time']}, the rule {want}")
    same = csi.reconstruct(pos, val, GRID, frames="on", motion_time=want)
    check(np.array_equal(auto.image, same.image) and np.array_equal(auto.frames, same.frames),
          f"{name}: auto's image and frames are those of motion_time {want}")
    if want == "dct":
        dft = csi.reconstruct(pos, val, GRID, frames="on", motion_time="dft")
        e_dct = float(np.mean((auto.frames[..., 0] - f) ** 2))
        e_dft = float(np.mean((dft.frames[..., 0] - f) ** 2))
        check(e_dct <= 0.8 * e_dft, f"{name}: frames MSE with the DCT {e_dct:.4e}, the DFT {e_dft:.4e}")

# with the samples' variances the frames' step solves two folds of half the samples: they take
# the whole's transform (csi_frames_fold_options), so auto's frames and image are still those
# of the transform it names
f = lamp_volume()
clean = f[pos[:, 2], pos[:, 1], pos[:, 0]]
noisy = (clean + 0.3 * np.random.default_rng(2).standard_normal(clean.shape))[:, None].astype(np.float32)
var = np.full_like(noisy, 0.09)
auto = csi.reconstruct(pos, noisy, GRID, frames="on", variance=var)
same = csi.reconstruct(pos, noisy, GRID, frames="on", variance=var, motion_time="dct")
check(auto.options["frames_denoise"] == "on" and auto.options["motion_time"] == "dct",
      f"noisy lamp: frames_denoise {auto.options['frames_denoise']}, motion_time {auto.options['motion_time']}")
check(np.array_equal(auto.image, same.image) and np.array_equal(auto.frames, same.frames),
      "noisy lamp: auto's image and frames are those of motion_time dct")

# a sheared basis takes the DCT whatever the ends
val = disc_volume()[pos[:, 2], pos[:, 1], pos[:, 0]][:, None].astype(np.float32)
given = csi.reconstruct(pos, val, GRID, motion_velocity="given", motion_vx=1.0, motion_vy=0.0)
check(given.options["motion_time"] == "dct", f"given velocity: {given.options['motion_time']}")

sys.exit(done())
