"""The range that bounds Alg. 2's volume and image with a still basis, grown where the pixels'
values change over t (host/integrate/sample_range.c; issue 12, docs/bench/animation.md session 30),
end to end through the library.

Scene (closed form at the cells' centres): a dim still background (0.3 with a faint grating) and a
bright disc (1.5, radius 8 cells) crossing it in 16 frames, 64 x 64 x 16 cells, the image at the
grid's size; each sample carries a 5% multiplicative Gaussian noise (a renderer's: no two samples
equal). 3% of the cells sampled (distinct, uniformly random): about half a sample per pixel over
the shutter, so a pixel's 3 x 3 window holds about four samples.

The failure this guards against: bounding every cell of a pixel by its 3 x 3 window's samples
when those few samples all caught the disc pins the pixel to the disc's value at every t, though
the disc covers it for a few frames only: the image overshoots the truth (the volume's mean over
t) by about the whole step there. Measured before the rule (a build of 728ae3e, whose Alg. 2 is
3217a5e's): 8-15 pixels of the image above the truth by more than half the step (0.6) on each of
4 seeds; with it, none.

Check, on 3 seeds: no pixel of the image exceeds the truth by half the step. Half the step is the
scale of a pinned pixel's error (a pixel the disc covers for k of 16 frames has truth 0.3 + 1.2 k /
16; pinned, it reads 1.5); the noise (5%) and an estimate between the two values stay below it.
"""
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "host", "python"))
sys.path.insert(0, HERE)
import csi  # noqa: E402
from checks import check, done  # noqa: E402

W = H = 64
T = 16
LOW, HIGH = 0.3, 1.5


def volume():
    y, x = np.mgrid[0:H, 0:W] + 0.5
    bg = LOW + 0.05 * np.sin(2 * np.pi * x / 23) * np.cos(2 * np.pi * y / 17)
    f = np.repeat(bg[None], T, 0)
    for t in range(T):
        cx = 4 + (W - 8) * t / (T - 1)
        f[t][(x - cx) ** 2 + (y - 32) ** 2 < 8 ** 2] = HIGH
    return f


def main():
    f = volume()
    truth = f.mean(axis=0)
    for seed in (0, 1, 2):
        rng = np.random.default_rng(100 + seed)
        noise = 1 + 0.05 * np.random.default_rng(seed).standard_normal(f.shape)
        idx = np.sort(rng.choice(W * H * T, int(0.03 * W * H * T), replace=False))
        t, yy, xx = np.unravel_index(idx, (T, H, W))
        pos = np.stack([xx, yy, t], 1).astype(np.uint32)
        vals = (f * noise).reshape(-1)[idx][:, None].astype(np.float32)
        r = csi.reconstruct(pos, vals, (W, H, T, W, H))
        over = r.image[..., 0] - truth
        n_over = int((over > 0.5 * (HIGH - LOW)).sum())
        check(n_over == 0, f"seed {seed}: {n_over} pixels above the truth by half the step (largest "
              f"{over.max():.3f}; basis velocity {r.options.get('motion_vx')}, {r.options.get('motion_vy')})")
        print(f"seed {seed}: largest overshoot {over.max():.3f} (half the step {0.5 * (HIGH - LOW):.2f}), "
              f"image MSE {float(np.mean(over ** 2)):.3g}")
    return done()


if __name__ == "__main__":
    sys.exit(main())
