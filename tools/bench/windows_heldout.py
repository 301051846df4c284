#!/usr/bin/env python3
"""Time windows on held-out volumes (issue 11): the blurred image of 2, 4 and 8 time windows, the
windows' own (the default) and the binned shutter's (tile_image_binned on, csi/tiles.h), against
the whole, on procedural volumes written after the binned image was built and measured on the
repository's volumes (docs/bench/scale.md, "The binned shutter's image"): 64x64 x 192 frames,
6% random cells, position seeds 1-2, error against the exact mean over t.

  bounce   a ball bouncing over a still texture (its velocity changes sign and size)
  bar      a bar turning about the centre over it
  mixed    both
  flicker  the still texture under a light that changes over the shutter

    .venv/bin/python tools/bench/windows_heldout.py bounce,bar,mixed,flicker

One line per volume and seed: the whole's MSE, then each window count's ratios to it.
"""
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                                "host", "python"))
import csi  # noqa: E402


def mse(im, truth):
    return float(((im.astype(np.float64) - truth) ** 2).mean())


def volume(kind, W=64, T=192):
    """The (T, W, W) volume `kind` (the list above), float32."""
    t, y, x = np.mgrid[0:T, 0:W, 0:W].astype(np.float64)
    u, v, s = (x + 0.5) / W, (y + 0.5) / W, (t + 0.5) / T
    bg = 0.35 + 0.1 * np.sin(2 * np.pi * (4 * u + 1 * v)) + 0.08 * (np.floor(8 * u) % 2)
    f = bg.copy()
    if kind in ("bounce", "mixed"):   # a ball bouncing (velocity changes sign, accelerates)
        by = 0.2 + 0.6 * np.abs(np.sin(3 * np.pi * s))
        bx = 0.15 + 0.7 * s
        f = np.where(np.hypot(u - bx, v - by) < 0.08, 0.9, f)
    if kind in ("bar", "mixed"):      # a bar turning about the centre
        a = 2 * np.pi * 0.75 * s
        d = np.abs((u - 0.5) * np.sin(a) - (v - 0.5) * np.cos(a))
        along = np.abs((u - 0.5) * np.cos(a) + (v - 0.5) * np.sin(a))
        f = np.where((d < 0.03) & (along < 0.35), 0.1, f)
    if kind == "flicker":             # a still scene whose light changes over the shutter
        f = bg * (0.7 + 0.3 * np.cos(2 * np.pi * 2 * s))
    return f.astype(np.float32)

RATE = 0.06


def case(kind, seed):
    """The volume `kind` at RATE of its cells (position seed `seed`): grid, positions, values and
    the exact mean over t."""
    f = volume(kind)
    T, H, W = f.shape
    grid = (W, H, T, W, H)
    pos = csi.positions(grid, method="random", fraction=RATE, seed=seed)
    vals = f[pos[:, 2], pos[:, 1], pos[:, 0]][:, None]
    return grid, pos, vals, f.astype(np.float64).mean(axis=0)[..., None]


def main():
    for kind in (sys.argv[1] if len(sys.argv) > 1 else "bounce,bar,mixed,flicker").split(","):
        for seed in (1, 2):
            grid, pos, vals, truth = case(kind, seed)
            W, H, T = grid[:3]
            t0 = time.time()
            w = csi.reconstruct(pos, vals, grid, seed=1)
            ew = mse(w.image, truth)
            out = [f"{kind} s{seed} ({W}x{H}x{T}, {len(pos)} samples, v {float(w.options['motion_vx']):.2f}): "
                   f"whole {ew:.4e} ({time.time()-t0:.0f}s)"]
            for N in (2, 4, 8):
                e = mse(csi.reconstruct(pos, vals, grid, seed=1, tiles_t=N).image, truth)
                t1 = time.time()
                eb = mse(csi.reconstruct(pos, vals, grid, seed=1, tiles_t=N, tile_image_binned="on").image, truth)
                out.append(f"{N}w windows {e/ew:.4f}x, binned {eb/ew:.4f}x ({time.time()-t1:.0f}s)")
            print("; ".join(out), flush=True)


if __name__ == "__main__":
    main()
