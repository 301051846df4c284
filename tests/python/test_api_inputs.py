"""The Python binding's checks of what it hands the C library: positions, values, grids and the
whole numbers that ctypes would pass on wrapped around or truncated. Each bad input raises
csi.CsiError CSI_ERR_ARG naming it (before: a fractional or NaN position was cast to another
cell, a grid side of 2^32 + 64 became 64, a seed of -1 became 2^64 - 1, complex values lost their
imaginary part, all silently; a float64 value or variance beyond float32's range became an infinity
refused as if given); each good form of the same input is still taken, with the result
of its canonical form, bit for bit.
"""
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "host", "python"))
sys.path.insert(0, HERE)
import numpy as np  # noqa: E402

import csi  # noqa: E402
from checks import check, done  # noqa: E402

GRID = (64, 64, 1, 16, 16)


def refused(what, want, call):
    try:
        call()
    except csi.CsiError as e:
        check(e.status == "CSI_ERR_ARG" and want in str(e), f"{what}: {e.status} {e}")
        return
    except Exception as e:  # noqa: BLE001 - any other exception is the failure under test
        check(False, f"{what}: {type(e).__name__}: {e}")
        return
    check(False, f"{what}: taken")


def main():
    pos = csi.positions(GRID, spp=4, seed=1)
    val = np.random.default_rng(1).random((len(pos), 3)).astype(np.float32)
    rec = lambda p=pos, v=val, g=GRID, **kw: csi.reconstruct(p, v, g, max_iter=5, **kw)  # noqa: E731
    refused("fractional positions", "not whole numbers", lambda: rec(p=pos + 0.5))
    refused("NaN positions", "not whole numbers", lambda: rec(p=np.where(pos == 0, np.nan, pos.astype(float))))
    refused("negative positions", "outside 0 to", lambda: rec(p=pos.astype(np.int64) - 1))
    refused("positions past 2^32", "outside 0 to", lambda: rec(p=pos.astype(np.int64) + (1 << 32)))
    refused("text positions", "not integer cells", lambda: rec(p=pos.astype(str)))
    refused("complex values", "not real numbers", lambda: rec(v=val + 1j))
    refused("text values", "not real numbers", lambda: rec(v=val.astype(str)))
    refused("values (N, C, 1)", "expected (N, 3) and (N, C)", lambda: rec(v=val[:, :, None]))
    refused("variance of other rows", "values' shape", lambda: rec(variance=val[:10]))
    big = val.astype(np.float64)
    big[5, 1] = 1e300  # finite in float64, an infinity in float32: named, not refused as "inf"
    refused("a float64 value beyond float32", "values at (5, 1): 1e+300 is beyond float32", lambda: rec(v=big))
    refused("a float64 variance beyond float32", "variance at (5, 1): 1e+300 is beyond float32",
            lambda: rec(variance=np.where(big > 1, big, 0.0)))
    refused("a grid of 4 sides", "expected (w, h, t, out_w, out_h)", lambda: rec(g=GRID[:4]))
    refused("a grid of 6 sides", "expected (w, h, t, out_w, out_h)", lambda: rec(g=GRID + (1,)))
    refused("a grid as text", "expected (w, h, t, out_w, out_h)", lambda: rec(g="64x64x1"))
    refused("a grid side past 2^32", "grid w", lambda: rec(g=(64 + (1 << 32),) + GRID[1:]))
    refused("a negative grid side", "grid w", lambda: rec(g=(-64,) + GRID[1:]))
    refused("a NaN grid side", "grid w", lambda: rec(g=(float("nan"),) + GRID[1:]))
    refused("seed -1", "seed", lambda: csi.positions(GRID, seed=-1))
    refused("seed 2^64", "seed", lambda: csi.positions(GRID, seed=1 << 64))
    refused("spp -1", "spp", lambda: csi.positions(GRID, spp=-1))
    refused("spp 2^32", "spp", lambda: csi.positions(GRID, spp=1 << 32))
    refused("spp 2.5", "spp", lambda: csi.positions(GRID, spp=2.5))
    refused("grid factor of a zero width", "out_w", lambda: csi.default_grid_factor(0, 16))
    refused("grid factor of a negative width", "out_w", lambda: csi.default_grid_factor(-1, 16))
    refused("grid factor of spp 0", "spp", lambda: csi.default_grid_factor(16, 16, 1, 0))
    refused("grid factor of an unknown camera", "camera", lambda: csi.default_grid_factor(16, 16, 8, 4, camera="zoom"))
    refused("a negative frame", "frame", lambda: rec().write_exr(os.devnull, frame=-1))
    refused("a negative tile", "index", lambda: csi.reconstruct_tile(pos, val, GRID, -1, tiles=2))
    refused("a check of -1 samples", "count", lambda: csi.reconstruct_check(GRID, 3, -1))
    refused("a number as the device", "expected a csi.Device", lambda: rec(device=3))
    try:  # a device's name is taken for the device (it was an AttributeError)
        rec(device="no-such-device")
        check(False, "a device name that matches nothing was taken")
    except csi.CsiError as e:
        check(e.status == "CSI_ERR_DEVICE" and "no-such-device" in str(e), f"device by name: {e.status} {e}")
    # CSI_LIBRARY naming no file: refused (it fell through to the build's library, silently)
    r = subprocess.run([sys.executable, "-c", "import csi; print(csi.version())"], capture_output=True, text=True,
                       env=dict(os.environ, CSI_LIBRARY="/nonexistent/libcsi.so",
                                PYTHONPATH=os.path.join(HERE, "..", "..", "host", "python")))
    check(r.returncode != 0 and "CSI_LIBRARY=/nonexistent/libcsi.so: no such file" in r.stderr,
          f"CSI_LIBRARY naming no file: exit {r.returncode}, {r.stdout.strip()!r} {r.stderr.strip()[-200:]!r}")
    # the same inputs in other good forms: the canonical form's image, bit for bit
    ref = rec().image
    for what, p, v, g in (("int64 positions", pos.astype(np.int64), val, GRID),
                          ("whole float positions", pos.astype(np.float64), val, GRID),
                          ("float64 values", pos, val.astype(np.float64), GRID),
                          ("numpy grid sides", pos, val, np.array(GRID)),
                          ("whole float grid sides", pos, val, tuple(float(x) for x in GRID))):
        check(np.array_equal(rec(p=p, v=v, g=g).image, ref), f"{what}: another image")
    one = rec(v=val[:, 0]).image
    check(np.array_equal(rec(v=val[:, :1]).image, one), "values (N,) and (N, 1) differ")
    check(csi.positions(GRID, spp=4.0, seed=1).tolist() == pos.tolist(), "spp 4.0 is not spp 4")
    check(np.array_equal(rec(device=csi.Device().name).image, ref), "the default device by its name: another image")
    return done()


if __name__ == "__main__":
    sys.exit(main())
