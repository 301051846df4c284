#!/usr/bin/env python3
"""Reference vectors for the spectral operators (tests/unit/test_spectral.c, test_fourier.c).

Gaussian filter Phi = F^H G F and Wiener inverse (1 + lambda) G / (G^2 + lambda) (Sen & Darabi
2010, Sec. 4, Alg. 1; the (1 + lambda) factor gives DC gain 1), computed with numpy's full
complex FFT in float64 (independent of the R2C/C2R path under test), and the orthonormal Fourier
basis as np.fft.fftn / ifftn with norm="ortho". Arrays have numpy shape (n2, n1, n0) = the C
layout of csi's dims[0] x dims[1] x dims[2] (x fastest). Fixed seeds; run from the repository
root:  .venv/bin/python tests/data/spectral/gen_refs.py
"""
import os

import numpy as np

OUT = os.path.dirname(os.path.abspath(__file__))


def gauss_1d(n, sigma_phi):
    """exp(-u^2 / (2 sigma_G^2)), u the signed DFT index, sigma_G = n / (2 pi sigma_phi)."""
    if sigma_phi == 0:
        return np.ones(n)
    u = np.fft.fftfreq(n) * n  # signed integer frequencies in numpy's order
    sigma_g = n / (2 * np.pi * sigma_phi)
    return np.exp(-u * u / (2 * sigma_g * sigma_g))


def gain(shape, sigmas):
    """Separable G over a numpy array of shape (n2, n1, n0); sigmas given as (x, y, z)."""
    g = np.ones(shape)
    nd = len(shape)
    for axis_xyz, s in enumerate(sigmas[:nd]):
        ax = nd - 1 - axis_xyz
        n = shape[ax]
        view = [1] * nd
        view[ax] = n
        g = g * gauss_1d(n, s).reshape(view)
    return g


def filt(x, g):
    return np.real(np.fft.ifftn(np.fft.fftn(x) * g))


FILTER_CASES = [
    # name, numpy shape, sigma (x, y, z), lambda, seed
    ("f64x64", (64, 64), (1.1, 2.2, 0.0), 0.3, 101),
    ("f96x64", (64, 96), (1.65, 0.55, 0.0), 0.3, 102),   # x = 96 = 3 * 2^5
    ("f45x30", (30, 45), (1.0, 1.5, 0.0), 0.1, 103),     # odd x length: R2C's other path
    ("f24x16x8", (8, 16, 24), (1.1, 0.8, 0.5), 0.3, 104),
    ("f32x32x8", (8, 32, 32), (1.1, 1.1, 2.0), 0.05, 105),
    ("f60", (60,), (2.0, 0.0, 0.0), 0.3, 106),           # 1-D
    ("f28x14x6", (6, 14, 28), (0.9, 1.3, 0.7), 0.2, 107),  # radices 7, 3 and 2 in csi's FFT
    # x = 320: rows of M = 160 = 8 x 4 x 5 complex values, so the 16-wide first pass (T = 20) and
    # pass at p = 8 (T = 40) both run, each with a last group that overlaps the one before it
    ("f320x24", (24, 320), (1.2, 0.9, 0.0), 0.3, 108),
    # radix 9 runs only on 16-wide vectors: rows of M = 81 = 3^4 complex values keep four
    # radix-3 passes (a radix-9 pass would come at p = 1 or 9, not a multiple of 16), columns of
    # 18 = 2 x 9 run a radix-9 pass; rows of M = 144 = 4 x 4 x 9 run it at p = 16
    ("f162x18", (18, 162), (1.3, 1.1, 0.0), 0.3, 109),
    ("f288x18", (18, 288), (0.9, 1.4, 0.0), 0.3, 110),
]

FOURIER_CASES = [
    ("c64x64", (64, 64), 201),
    ("c96x64", (64, 96), 202),
    ("c30x18", (18, 30), 203),
    ("c24x16x8", (8, 16, 24), 204),
    ("c32x32x8", (8, 32, 32), 205),
    ("c60", (60,), 206),
]


def main():
    os.makedirs(OUT, exist_ok=True)
    for name, shape, sig, lam, seed in FILTER_CASES:
        rng = np.random.default_rng(seed)
        x = rng.standard_normal(shape)
        g = gain(shape, sig)
        gx = filt(x, g)
        wx = filt(x, (1 + lam) * g / (g * g + lam))
        np.save(os.path.join(OUT, name + "_x.npy"), x.astype(np.float32))
        np.save(os.path.join(OUT, name + "_gauss.npy"), gx.astype(np.float32))
        np.save(os.path.join(OUT, name + "_wiener.npy"), wx.astype(np.float32))
    for name, shape, seed in FOURIER_CASES:
        rng = np.random.default_rng(seed)
        x = (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)).astype(np.complex64)
        xd = x.astype(np.complex128)
        np.save(os.path.join(OUT, name + "_x.npy"), x)
        np.save(os.path.join(OUT, name + "_fwd.npy"),
                np.fft.fftn(xd, norm="ortho").astype(np.complex64))
        np.save(os.path.join(OUT, name + "_inv.npy"),
                np.fft.ifftn(xd, norm="ortho").astype(np.complex64))


if __name__ == "__main__":
    main()
