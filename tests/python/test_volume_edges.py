"""Edge cases of volumes that an audit of the motion path found (session 35), each against a
closed form or the documented message:

- the Gaussian baseline (estimator gauss) is a normalized convolution, a mean of the samples with
  non-negative weights, so in exact arithmetic it lies within the samples' range; the FFT's
  rounding next to a bright sample, divided by a small density, carried it below (frames to -48
  from samples of 0.5 and 1e4): frames now within [min, max] of the samples (or 0 where no
  sample is within reach, as documented), the image within [0, max];
- the per-pixel mean (estimator mean) makes no frames: asking for them is refused in one line
  (it used to drop them silently), and its image still runs;
- time windows that cannot be laid out: the message says when the margin is the default and how
  to set another; on a frame count the FFT cannot take (13) with margins too wide, the message
  names the margins, not the padding of the frames; x/y tiles likewise name their margin;
- csi-reconstruct -q prints nothing on stderr, even when every kernel is built afresh (an empty
  program cache): the OpenCL compiler's warnings used to reach it."""
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


def refused(fn, words, what):
    try:
        fn()
    except csi.CsiError as e:
        msg = str(e)
        check(all(w in msg for w in words) and "\n" not in msg, f"{what}: {msg}")
        return msg
    check(False, f"{what}: not refused")


def main():
    rng = np.random.default_rng(0)
    g = (24, 24, 8, 24, 24)
    pos = csi.positions(g, method="random", seed=1, fraction=0.15)
    val = np.full((len(pos), 1), 0.5, np.float32)
    val[rng.random(len(pos)) < 0.02] = 1e4
    for sigma in (0.7, 1.5, 3.0):
        r = csi.reconstruct(pos, val, g, frames="on", estimator="gauss", gauss_sigma=sigma)
        lo, hi = float(val.min()), float(val.max())
        f = r.frames[r.frames != 0]  # 0: a cell no sample reaches (the documented fallback)
        check(r.image.min() >= 0 and r.image.max() <= hi and f.min() >= lo and f.max() <= hi,
              f"gauss sigma {sigma}: image [{r.image.min():.4g}, {r.image.max():.4g}] within [0, {hi}], frames "
              f"where a sample reaches [{f.min():.4g}, {f.max():.4g}] within the samples' [{lo}, {hi}]")

    ones = np.ones((len(pos), 1), np.float32)
    refused(lambda: csi.reconstruct(pos, ones, g, frames="on", estimator="mean"), ("estimator mean", "frames"),
            "frames of the per-pixel mean")
    m = csi.reconstruct(pos, ones, g, estimator="mean")
    check(m.frames is None and float(m.image.max()) == 1.0, "the per-pixel mean's image of ones")

    g16 = (32, 32, 16, 32, 32)
    p16 = csi.positions(g16, method="random", seed=1, fraction=0.2)
    v16 = rng.exponential(0.5, (len(p16), 1)).astype(np.float32)
    refused(lambda: csi.reconstruct(p16, v16, g16, tiles_t=2), ("margins of 4", "the default", "--tile-margin-t"),
            "2 windows of 16 frames at the default margin")
    check(csi.reconstruct(p16, v16, g16, tiles_t=2, tile_margin_t=2).info["tiles"] == 2,
          "2 windows of 16 frames at margin 2")
    g13 = (40, 24, 13, 40, 24)
    p13 = csi.positions(g13, method="random", seed=1, fraction=0.2)
    v13 = rng.exponential(0.5, (len(p13), 1)).astype(np.float32)
    msg = refused(lambda: csi.reconstruct(p13, v13, g13, tiles_t=2, tile_margin_t=3), ("margins of 3",),
                  "2 windows of 13 frames at margin 3")
    check(msg is not None and "padded" not in msg and "prime" not in msg, f"13 frames: the margins named ({msg})")
    check(csi.reconstruct(p13, v13, g13, tiles_t=2, tile_margin_t=2).info["tiles"] == 2,
          "2 windows of 13 frames at margin 2")
    # x/y tiles the default margins leave no room for: the message names the margin and its option
    g24 = (24, 24, 4, 24, 24)
    p24 = csi.positions(g24, method="random", seed=1, fraction=0.2)
    v24 = rng.exponential(0.5, (len(p24), 1)).astype(np.float32)
    refused(lambda: csi.reconstruct(p24, v24, g24, tiles=4), ("margins of 16 pixels", "--tile-margin"),
            "4 tiles of a 24 x 24 volume at the default margin")
    check(csi.reconstruct(p24, v24, g24, tiles=4, tile_margin=2).info["tiles"] == 4,
          "4 tiles of a 24 x 24 volume at margin 2")

    with tempfile.TemporaryDirectory() as d:
        src = os.path.join(d, "v.csid")
        csid.write(src, csid.Dump(grid=g[:3], out=g[3:], xyt=pos.astype(np.uint32), values=val))
        env = {k: v for k, v in os.environ.items() if k != "POCL_EXTRA_BUILD_FLAGS"}
        env["CSI_CACHE_DIR"] = os.path.join(d, "cache")  # empty: every kernel built here
        p = subprocess.run([os.path.join(BUILD, "csi-reconstruct"), src, "-o", os.path.join(d, "o.exr"), "-q"],
                           capture_output=True, text=True, env=env)
        check(p.returncode == 0 and p.stderr == "", f"csi-reconstruct -q, kernels built afresh: exit "
              f"{p.returncode}, stderr {p.stderr[:200]!r}")
    return done()


if __name__ == "__main__":
    sys.exit(main())
