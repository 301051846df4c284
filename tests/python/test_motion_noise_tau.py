"""Alg. 2's tau given the samples' variances (csi/reconstruct.h, CSI_MOTION_TAU_NOISE; motion.c),
checked against its closed form and for the properties the library promises around it:

- the rule: per channel, tau with the variances is tau without them times
  max(1, min(3 (sqrt(mean variance) / mean |value|), 1) / (sqrt(n) tau_rel)), the noise ratio
  computed here in numpy (double; the first channel's noise, a half of its level, meets the cap);
  a channel whose noise is below the floor keeps the image and frames it has without the
  variances, bit for bit (channels are solved one at a time), with the frames' own step for noisy
  samples off (and with it the image's average with the frames);
- on a noisy volume (a still pattern and a moving disc, 25% of the cells, Gaussian noise of a
  half and a third of the level: Mitsuba's samples of 16 paths are at 0.27-0.29) the frames and
  the image with the variances are closer to the noise-free truth than without them, the point of
  the rule (on this volume the frames gain 0.57-0.77x; with noise of a fifth of the level they are
  within 1.3% either way, and of a tenth 4% worse, the image within 1.5%: docs/bench/animation.md,
  session 31);
- it is a ratio: values and variances scaled by powers of two (2^-20, 2^-40) give the image
  scaled by 2^-20, bit for bit;
- tiles: time windows, and x/y tiles, made one at a time (csi.reconstruct_tile with the whole's
  samples and variances) and merged give the in-process tiled image bit for bit, and that image
  is not the one without the variances;
- csi-reconstruct takes the variances beside a volume's dump (X.variance.csid) and writes the
  image csi.reconstruct(variance=...) gives (the stats' FNV-1a hash)."""
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

SOURCE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BUILD = os.environ.get("CSI_BUILD_DIR") or os.path.join(SOURCE, "build")
sys.path.insert(0, os.path.join(SOURCE, "host", "python"))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import csi  # noqa: E402
from csi import dump as csid  # noqa: E402
from checks import check, done  # noqa: E402

W, H, T = 48, 48, 32
GRID = (W, H, T, W, H)
NOISE = (0.5, 0.33, 0.002)  # each channel's noise relative to its level; the last below the floor


def truth():
    y, x = np.mgrid[0:H, 0:W] + 0.5
    still = 0.4 + 0.25 * np.sin(2 * np.pi * x / 17) * np.cos(2 * np.pi * y / 13)
    f = np.empty((T, H, W))
    for t in range(T):
        cx, cy = 10 + 0.8 * t, 24
        f[t] = np.where((x - cx) ** 2 + (y - cy) ** 2 < 36, 1.5, still)
    return np.stack([f, 0.5 * f, 2 * f], axis=-1)  # (T, H, W, 3)


F = truth()
pos = csi.positions(GRID, method="random", seed=4, fraction=0.25)
rng = np.random.default_rng(7)
clean = F[pos[:, 2], pos[:, 1], pos[:, 0]]
sd = np.array(NOISE) * np.abs(clean).mean(axis=0)
val = (clean + sd * rng.standard_normal(clean.shape)).astype(np.float32)
var = np.broadcast_to((sd ** 2).astype(np.float32), val.shape).copy()
n = len(pos)

plain = csi.reconstruct(pos, val, GRID, frames="on")
noisy = csi.reconstruct(pos, val, GRID, frames="on", variance=var)
tau_rel = float(plain.options["tau"])
for c in range(3):
    v, y = var[:, c].astype(np.float64), val[:, c].astype(np.float64)
    ratio = np.sqrt(v.mean()) / np.abs(y).mean()
    want = max(1.0, min(3.0 * ratio, 1.0) / (np.sqrt(n) * tau_rel))
    got = noisy.reports[c]["tau"] / plain.reports[c]["tau"]
    check(abs(got - want) <= 1e-9 * want, f"channel {c}: tau with / without the variances {got}, want {want}")
check(3.0 * 0.002 / np.sqrt(n) < tau_rel, "the third channel's noise is below the floor (the test's premise)")
# the frames' own step for noisy samples (csi/frames_denoise.h, test_frames_denoise.py) off, and
# with it the image's average with its frames: the rule alone
noisy_tau = csi.reconstruct(pos, val, GRID, frames="on", variance=var, frames_denoise="off")
check(np.array_equal(noisy_tau.image[..., 2], plain.image[..., 2]) and np.array_equal(noisy_tau.frames[..., 2], plain.frames[..., 2]),
      "a channel below the floor keeps its image and frames bit for bit")

for c in range(2):
    for what, a, b, ref in (("frames", plain.frames, noisy.frames, F), ("image", plain.image, noisy.image, F.mean(0))):
        e0 = float(np.mean((a[..., c] - ref[..., c]) ** 2))
        e1 = float(np.mean((b[..., c] - ref[..., c]) ** 2))
        check(e1 < e0, f"channel {c}: {what} MSE with the variances {e1:.4e}, without {e0:.4e}")

s = csi.reconstruct(pos, np.ldexp(val, -20), GRID, frames="on", variance=np.ldexp(var, -40))
check(np.array_equal(s.image, np.ldexp(noisy.image, -20)), "values and variances scaled by powers of two: the image scaled")

with tempfile.TemporaryDirectory() as d:
    for topts, count in ((dict(tiles_t=2), 2), (dict(tiles=4, tiles_t=1, tile_margin=8), 4)):
        tiled = csi.reconstruct(pos, val, GRID, variance=var, **topts)
        tiled_novar = csi.reconstruct(pos, val, GRID, **topts)
        check(tiled.info["tiles"] == count, f"{topts}: {tiled.info['tiles']} tiles")
        check(not np.array_equal(tiled.image, tiled_novar.image), f"{topts}: the tiled image follows the variances")
        parts = []
        for i in reversed(range(count)):
            t = csi.reconstruct_tile(pos, val, GRID, i, variance=var, **topts)
            parts.append(os.path.join(d, f"t{i}.csip"))
            t.write_partial(parts[-1], "s.csid")
        m = csi.merge_partials(parts)
        check(m.stats["image_fnv1a64"] == tiled.stats["image_fnv1a64"],
              f"{topts}: tiles made one at a time {m.stats['image_fnv1a64']} vs in process {tiled.stats['image_fnv1a64']}")

    req = csid.Dump(grid=GRID[:3], out=GRID[3:], xyt=pos, values=None, seed=4)
    csid.write(os.path.join(d, "v.csid"), req.with_values(val))
    csid.write(os.path.join(d, "v.variance.csid"), req.with_values(var))
    r = subprocess.run([os.path.join(BUILD, "csi-reconstruct"), os.path.join(d, "v.csid"), "-o", os.path.join(d, "v.exr"),
                        "--stats", os.path.join(d, "v.json"), "-q"], capture_output=True, text=True)
    h = json.load(open(os.path.join(d, "v.json"))).get("image_fnv1a64") if r.returncode == 0 else None
    check(h == noisy.stats["image_fnv1a64"], f"csi-reconstruct with v.variance.csid: exit {r.returncode} {r.stderr!r}, "
          f"hash {h} vs {noisy.stats['image_fnv1a64']}")

sys.exit(done())
