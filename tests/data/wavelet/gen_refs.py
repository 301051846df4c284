#!/usr/bin/env python3
"""Reference vectors for the 2-D periodized Daubechies wavelet (tests/unit/test_wavelet.c).

For each case (family, W, H, levels) writes into tests/data/wavelet/:
  <tag>_img.npy   float32 (H, W) image, normal(0, 1) from a fixed seed
  <tag>_fwd.npy   float32 (H, W) coeffs_to_array(wavedec2(img, family, 'periodization', levels))
                  computed in float64 from the float32 image, then rounded to float32
  <tag>_coef.npy  float32 (H, W) coefficient array, normal(0, 1) from a fixed seed
  <tag>_inv.npy   float32 (H, W) waverec2 of that array (split with array_to_coeffs), float64
<tag> = <family>_<W>x<H>_L<levels>; and filters_<family>.npy, float64 (2, F): dec_lo, dec_hi. Also checks the filter tables in kernels/wavelet.cl against
pywt.Wavelet(...).dec_lo / dec_hi, so the kernel's data cannot drift from PyWavelets.

Run: /work/main/.venv/bin/python tests/data/wavelet/gen_refs.py   (numpy, PyWavelets: tools/bench/requirements.txt)
"""
import os
import re
import sys
import warnings

import numpy as np
import pywt

OUT = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(OUT)))
SEED = 20261122

# (family, W, H, levels). Covers: square and non-square, sides 3*2^n, several level counts,
# the smallest sides a level count allows (2^L, and 3*2^L with a 3-wide coarsest band), and bands
# shorter than the filter (taps wrapping around the band several times, e.g. db8 at 8x8 L=3).
CASES = [
    ("db4", 64, 64, 1),
    ("db4", 64, 64, 3),
    ("db8", 64, 64, 2),
    ("db8", 64, 64, 4),
    ("db4", 96, 64, 3),
    ("db8", 128, 48, 4),
    ("db4", 48, 48, 4),
    ("db8", 48, 96, 4),
    ("db8", 160, 96, 5),
    ("db4", 2, 2, 1),
    ("db8", 4, 2, 1),
    ("db4", 12, 6, 1),
    ("db8", 8, 8, 3),
    ("db4", 24, 48, 3),
]


def check_kernel_tables():
    src = open(os.path.join(ROOT, "kernels", "wavelet.cl")).read()
    for fam in ("db4", "db8"):
        w = pywt.Wavelet(fam)
        for kind, want in (("lo", w.dec_lo), ("hi", w.dec_hi)):
            m = re.search(r"csi_%s_%s\[\d+\]\s*=\s*\{([^}]*)\}" % (fam, kind), src)
            if not m:
                sys.exit("kernels/wavelet.cl: table csi_%s_%s not found" % (fam, kind))
            got = [float(v.strip().rstrip("f")) for v in m.group(1).split(",") if v.strip()]
            if len(got) != len(want) or max(abs(a - b) for a, b in zip(got, want)) > 1e-16:
                sys.exit("kernels/wavelet.cl: csi_%s_%s differs from pywt.Wavelet('%s').dec_%s"
                         % (fam, kind, fam, kind))
        # dec_hi is the quadrature mirror of dec_lo, as the kernel comments state.
        F = len(w.dec_lo)
        qmf = [(-1) ** (j + 1) * w.dec_lo[F - 1 - j] for j in range(F)]
        assert np.allclose(qmf, w.dec_hi, rtol=0, atol=0)
    print("kernels/wavelet.cl filter tables match PyWavelets", pywt.__version__)


def main():
    check_kernel_tables()
    os.makedirs(OUT, exist_ok=True)
    rng = np.random.default_rng(SEED)
    total = 0
    # The filters as float64 (dec_lo then dec_hi) for the test's own plain-C reference at sizes
    # too large to commit.
    for fam in ("db4", "db8"):
        w = pywt.Wavelet(fam)
        path = os.path.join(OUT, "filters_%s.npy" % fam)
        np.save(path, np.array([w.dec_lo, w.dec_hi], dtype=np.float64))
        total += os.path.getsize(path)
    for fam, W, H, L in CASES:
        tag = "%s_%dx%d_L%d" % (fam, W, H, L)
        img = rng.standard_normal((H, W)).astype(np.float32)
        coef = rng.standard_normal((H, W)).astype(np.float32)
        with warnings.catch_warnings():
            # pywt warns when the coarsest band is shorter than the filter; those cases are
            # deliberate (periodic wrap-around).
            warnings.simplefilter("ignore", UserWarning)
            c = pywt.wavedec2(img.astype(np.float64), fam, mode="periodization", level=L)
            fwd, slices = pywt.coeffs_to_array(c)
            split = pywt.array_to_coeffs(coef.astype(np.float64), slices, output_format="wavedec2")
            inv = pywt.waverec2(split, fam, mode="periodization")
        assert fwd.shape == (H, W) and inv.shape == (H, W)
        # Orthonormality sanity checks on the references themselves.
        assert abs(np.sum(fwd ** 2) - np.sum(img.astype(np.float64) ** 2)) < 1e-9 * np.sum(img ** 2)
        for name, arr in (("img", img), ("fwd", fwd), ("coef", coef), ("inv", inv)):
            path = os.path.join(OUT, "%s_%s.npy" % (tag, name))
            np.save(path, arr.astype(np.float32))
            total += os.path.getsize(path)
    print("wrote %d cases, %d bytes, to %s (seed %d)" % (len(CASES), total, OUT, SEED))


if __name__ == "__main__":
    main()
