#!/usr/bin/env python3
"""Held-out-like test volumes for the animation benchmark (bench_animation.py): procedural
photographs moved by a camera pan, with discs crossing or small fast movers, at the cell centres
of a W x H x T grid (the paper's discrete model: what a renderer returns for that cell's ray).

The "photograph" is a dead-leaves image (discs of sizes r^-3 distributed between 1.5 cells and
0.3 of the frame, occluding each other: the scale-invariant edge statistics of natural images,
Lee, Mumford & Huang 2001), each leaf shaded by a gradient and a quarter of them textured by a
grating, over a smooth illumination, plus 1/f noise; rendered at 4x, blurred (optics) and box
averaged to the frame's resolution like a downsampled photo. A pan samples it bilinearly at
moving positions, as a renderer samples a texture. Values lie in [0, 1].

Volumes (name: what moves), each seed a different photo, direction and movers:
  pan            the camera pans by 0.3 of the width over the shutter (about 1.2 cells per frame
                 at 128 x 32), mostly along x
  panfast        the same by 0.6 of the width
  pan+disc       the pan, and a bright disc (radius 0.12 W) crossing 0.7 of the frame in another
                 direction (the issue's held-out volume)
  pan+movers     the pan and four small fast discs (radius 0.025-0.05 W) moving independently
  static+disc    a still photograph and the crossing disc
  static+movers  a still photograph and the four small movers
`volume(name, W, H, T, seed)` returns (f, info): f as float32 (T, H, W); info the velocities
(cells per frame) of the pan (first, when there is one) and of the disc.
"""
import numpy as np
from scipy import ndimage


def photo(rng, W, H, ss=4, density=0.4):
    """A W x H procedural photograph in [0, 1]."""
    Ws, Hs = int(W * ss), int(H * ss)
    yy0, xx0 = np.mgrid[0:Hs, 0:Ws] / (ss * max(W, H))
    img = 0.45 + 0.2 * np.cos(2 * np.pi * (rng.random() + 0.6 * xx0 * rng.normal() + 0.6 * yy0 * rng.normal()))
    n = int(density * W * H / 12)
    rmin, rmax = 1.5 * ss, 0.3 * max(W, H) * ss
    a, b = rmin ** -2, rmax ** -2
    r = (a - rng.random(n) * (a - b)) ** -0.5
    cx, cy = rng.uniform(0, Ws, n), rng.uniform(0, Hs, n)
    base = np.clip(rng.normal(0.45, 0.2, n), 0.03, 0.97)
    for i in rng.permutation(n):
        x0, x1 = int(max(cx[i] - r[i], 0)), int(min(cx[i] + r[i] + 1, Ws))
        y0, y1 = int(max(cy[i] - r[i], 0)), int(min(cy[i] + r[i] + 1, Hs))
        if x0 >= x1 or y0 >= y1:
            continue
        yy, xx = np.mgrid[y0:y1, x0:x1]
        dx, dy = xx + 0.5 - cx[i], yy + 0.5 - cy[i]
        m = dx * dx + dy * dy < r[i] * r[i]
        g = rng.normal(0, 0.25, 2) / r[i]
        v = base[i] + g[0] * dx + g[1] * dy
        if rng.random() < 0.25:  # a grating of 3-10 cells period
            th, per = rng.uniform(0, np.pi), rng.uniform(3, 10) * ss
            v = v + rng.uniform(0.04, 0.12) * np.sin(2 * np.pi * (np.cos(th) * dx + np.sin(th) * dy) / per)
        img[y0:y1, x0:x1][m] = v[m]
    nz = rng.normal(size=(Hs, Ws))
    fr = np.hypot(np.fft.fftfreq(Ws)[None, :], np.fft.fftfreq(Hs)[:, None])
    fr[0, 0] = 1
    nz = np.real(np.fft.ifft2(np.fft.fft2(nz) / fr))
    img = img + nz * (0.04 / nz.std())
    img = ndimage.gaussian_filter(img, 0.5 * ss)
    return np.clip(img.reshape(H, ss, W, ss).mean(axis=(1, 3)), 0, 1)


PAN = {"pan": 0.3, "panfast": 0.6}
NAMES = ("pan", "panfast", "pan+disc", "pan+movers", "static+disc", "static+movers")


def volume(name, W=128, H=128, T=32, seed=0):
    if name not in NAMES:
        raise ValueError(f"unknown volume {name!r} (one of {', '.join(NAMES)})")
    rng = np.random.default_rng(1000 + seed)
    y, x = np.mgrid[0:H, 0:W]
    X, Y = x + 0.5, y + 0.5
    tt = (np.arange(T) + 0.5) / T
    f = np.empty((T, H, W))
    info = []
    base = name.split("+")[0]
    if base in PAN:
        ang = rng.uniform(-0.4, 0.4) + (np.pi if seed % 2 else 0)
        s = PAN[base] * W
        sx, sy = s * np.cos(ang), s * np.sin(ang)
        P = photo(rng, int(W + abs(sx) + 8), int(H + abs(sy) + 8))
        ox, oy = 4 + max(-sx, 0), 4 + max(-sy, 0)
        for t in range(T):
            f[t] = ndimage.map_coordinates(P, [Y + oy + sy * tt[t] - 0.5, X + ox + sx * tt[t] - 0.5],
                                           order=1, mode="nearest")
        info.append((-sx / T, -sy / T))
    else:
        P = photo(rng, W, H)
        f[:] = P
    if name.endswith("+disc"):
        a0 = rng.uniform(0, 2 * np.pi)
        for t in range(T):
            cx = W * (0.5 + 0.35 * np.cos(a0) * (2 * tt[t] - 1))
            cy = H * (0.5 + 0.35 * np.sin(a0) * (2 * tt[t] - 1))
            f[t][(X - cx) ** 2 + (Y - cy) ** 2 < (0.12 * W) ** 2] = 0.95
        info.append((0.7 * W * np.cos(a0) / T, 0.7 * H * np.sin(a0) / T))
    if name.endswith("+movers"):
        for _ in range(4):
            p0, vel = rng.uniform(0.2, 0.8, 2), rng.uniform(-0.6, 0.6, 2)
            r, val = rng.uniform(0.025, 0.05) * W, rng.uniform(0.7, 1.0)
            for t in range(T):
                c = (p0 + vel * (tt[t] - 0.5)) * [W, H]
                f[t][(X - c[0]) ** 2 + (Y - c[1]) ** 2 < r * r] = val
    return f.astype(np.float32), info
