"""A volume's blurred image at a pixel that holds no sample (motion_correct.c): each channel lies
within the range of that pixel's 8 neighbours' values in the image (computed here in numpy from the
image csi returns), untiled and when the image is assembled from time windows (the same step on the
windows' sums), on path-traced-like samples (a bright disc crossing a textured background, 3% of
the cells, noise of a fifth of the level) and on exact ones; the pixels that hold samples are not
bound by it, and at 3% of 32 frames about a third of the pixels hold none (883 of 2304 here).
Before the rule, 108-118 of these 883 pixels left their neighbours' range in each run."""
import os
import sys

import numpy as np

SOURCE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(SOURCE, "host", "python"))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import csi  # noqa: E402
from checks import check, done  # noqa: E402

W, H, T = 48, 48, 32
GRID = (W, H, T, W, H)


def volume():
    y, x = np.mgrid[0:H, 0:W] + 0.5
    still = 0.3 + 0.2 * (((x // 4) + (y // 4)) % 2) + 0.1 * np.sin(x / 3.0)
    f = np.empty((T, H, W, 3))
    for t in range(T):
        disc = (x - (6 + 1.1 * t)) ** 2 + (y - 24) ** 2 < 30
        for c, level in enumerate((4.0, 2.5, 1.0)):
            f[t, ..., c] = np.where(disc, level, still * (1 + 0.3 * c))
    return f


def outside(img, pos):
    """Pixels without a sample whose value leaves its 8 neighbours' range, in any channel."""
    has = np.zeros((H, W), bool)
    has[pos[:, 1], pos[:, 0]] = True
    bad = 0
    for py in range(H):
        for px in range(W):
            if has[py, px]:
                continue
            ys, xs = slice(max(py - 1, 0), py + 2), slice(max(px - 1, 0), px + 2)
            nb = img[ys, xs].reshape(-1, img.shape[-1]).astype(np.float64)
            keep = np.ones(len(nb), bool)
            keep[(py - ys.start) * (xs.stop - xs.start) + (px - xs.start)] = False
            v = img[py, px].astype(np.float64)
            bad += bool(np.any(v < nb[keep].min(axis=0)) or np.any(v > nb[keep].max(axis=0)))
    return bad, int((~has).sum())


F = volume()
pos = csi.positions(GRID, method="random", seed=2, fraction=0.03)
clean = F[pos[:, 2], pos[:, 1], pos[:, 0]].astype(np.float32)
rng = np.random.default_rng(5)
noisy = (clean * (1 + 0.2 * rng.standard_normal(clean.shape))).clip(0).astype(np.float32)
for name, vals in (("noisy", noisy), ("exact", clean)):
    for opts in ({}, {"tiles_t": 2}):
        r = csi.reconstruct(pos, vals, GRID, **opts)
        check(r.options["motion_vx"] in ("0", 0) and r.options["motion_vy"] in ("0", 0),
              f"{name} {opts}: a still basis (the rule's scope), velocity {r.options['motion_vx']}, {r.options['motion_vy']}")
        bad, empty = outside(r.image, pos)
        check(empty > 500, f"{name} {opts}: {empty} pixels without a sample")
        check(bad == 0, f"{name} {opts}: {bad} of {empty} pixels without a sample outside their neighbours' range")

sys.exit(done())
