"""Time windows over a part of the shutter that holds no sample are refused (csi_tiling_check_samples,
csi/tiles.h), before any work, in one line naming the window, its frames and the remedy:

- why: such a window knows nothing, and its frames would be zero, so the tiled image (the mean
  over the shutter of the blended frames) came out short by the window's share: on the volume
  below, samples in frames 0-4 of 16 of a field of value 1, the untiled image's mean is about 1
  and two windows gave about 0.5 before this check;
- in-process (csi.reconstruct) with --tiles-t 2, and a tile run alone (csi.reconstruct_tile) of
  either window given every sample: CsiError naming "time window 2 of 2" (a window run from its
  own window's samples alone: tests/e2e/test_api_partials.c);
- the same samples untiled, or in x/y tiles only (not split in t), reconstruct as before, and a
  volume whose samples reach every window is not refused;
- csi-reconstruct on that dump with --tiles-t 2: exit status non-zero, one line on stderr naming
  the dump and the window, and no output file left behind."""
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

W = H = 24
T = 16
GRID = (W, H, T, W, H)
WINDOWS = dict(tiles_t=2, tile_margin_t=1)


def refused(fn, what):
    try:
        fn()
    except csi.CsiError as e:
        check("time window 2 of 2" in str(e) and "--tiles-t" in str(e), f"{what}: refused with {e}")
        return
    check(False, f"{what}: not refused")


def main():
    rng = np.random.default_rng(0)
    every = csi.positions(GRID, method="random", seed=1, fraction=0.2)
    pos = every[every[:, 2] < 5]  # frames 0-4 only
    val = (1 + 0.05 * rng.standard_normal((len(pos), 1))).astype(np.float32)

    untiled = csi.reconstruct(pos, val, GRID)
    check(abs(float(untiled.image.mean()) - 1) < 0.1, f"untiled image mean {untiled.image.mean():.3f}, about 1")
    refused(lambda: csi.reconstruct(pos, val, GRID, **WINDOWS), "in-process, 2 time windows")
    for i in (0, 1):
        refused(lambda: csi.reconstruct_tile(pos, val, GRID, i, **WINDOWS), f"tile {i} alone, every sample")

    # Not split in t: x/y tiles of the same samples run.
    big = (64, 64, 4, 64, 64)
    bpos = csi.positions(big, method="random", seed=2, fraction=0.2)
    bpos = bpos[bpos[:, 2] < 2]
    bval = np.ones((len(bpos), 1), np.float32)
    xy = csi.reconstruct(bpos, bval, big, tiles=2, tiles_t=1)
    check(xy.info["tiles"] == 2 and np.isfinite(xy.image).all(), f"x/y tiles: {xy.info['tiles']} tiles")
    # Samples in every window: not refused.
    fval = (1 + 0.05 * rng.standard_normal((len(every), 1))).astype(np.float32)
    full = csi.reconstruct(every, fval, GRID, **WINDOWS)
    check(full.info["tiles"] == 2 and abs(float(full.image.mean()) - 1) < 0.05,
          f"samples over the whole shutter in 2 windows: image mean {full.image.mean():.3f}")

    with tempfile.TemporaryDirectory() as d:
        src = os.path.join(d, "early.csid")
        out = os.path.join(d, "out.exr")
        csid.write(src, csid.Dump(grid=GRID[:3], out=GRID[3:], xyt=pos.astype(np.uint32), values=val))
        p = subprocess.run([os.path.join(BUILD, "csi-reconstruct"), src, "-o", out, "--tiles-t", "2",
                            "--tile-margin-t", "1", "-q"], capture_output=True, text=True)
        lines = p.stderr.strip().splitlines()
        check(p.returncode != 0 and len(lines) == 1 and src in lines[0] and "time window 2 of 2" in lines[0],
              f"csi-reconstruct --tiles-t 2: exit {p.returncode}, stderr {p.stderr!r}")
        check(sorted(os.listdir(d)) == ["early.csid"], f"files left: {sorted(os.listdir(d))}")
    return done()


if __name__ == "__main__":
    sys.exit(main())
