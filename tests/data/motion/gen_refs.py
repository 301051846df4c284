#!/usr/bin/env python3
"""Reference vectors for Alg. 2's motion basis (csi_fourier_half_set_motion; tests/unit/
test_motion_basis.c) and the Gaussian along the motion (csi_motion_filter_create; tests/unit/
test_motion_filter.c).

Computed independently of csi's R2C / Stockham / Makhoul path: each frame's spatial half spectrum
with numpy's rfftn (norm="ortho"), the shear as the phase exp(+2 pi i <u, v> (t - tc)) on it,
then along t numpy's FFT (norm="ortho") or scipy.fft.dct(type=2, norm="ortho") on the real and
imaginary parts; the synthesis (the real adjoint) with the inverse transforms and a full complex
ifftn of the zero-extended half spectrum (not irfft, which would enforce Hermitian symmetry).
The shear's signed frequencies are numpy's fftfreq except 0 at the Nyquist bins (csi's
convention: those components are not moved, so the shear stays unitary and real volumes real).
Arrays are float64 results rounded to float32 / complex64; numpy shape (T, H, W) = the C layout
of csi's dims (W, H, T), x fastest; spectra (T, [n1,] M + 1) over the squeezed spatial axes (the
last one halved). Fixed seeds; run from the repository root:
    .venv/bin/python tests/data/motion/gen_refs.py
"""
import os

import numpy as np
import scipy.fft as sf

OUT = os.path.dirname(os.path.abspath(__file__))

# name, dims (W, H, T), time transform, velocity (vx, vy) in cells per frame, seed
CASES = [
    ("m16x12x8_dct", (16, 12, 8), "dct", (0.7, -0.3), 301),
    ("m16x12x8_dft", (16, 12, 8), "dft", (0.7, -0.3), 302),
    ("m16x12x8_none", (16, 12, 8), "none", (-1.3, 0.45), 303),
    ("m24x16x6_dct", (24, 16, 6), "dct", (2.5, 1.25), 304),    # radices 3 and 2 along t
    ("m20x10x5_dct", (20, 10, 5), "dct", (-0.35, 0.8), 305),   # odd T (radix 5), M = 10
    ("m28x14x7_dct", (28, 14, 7), "dct", (0.0, 0.0), 306),     # radix 7, no shear: DCT alone
    ("m32x1x8_dct", (32, 1, 8), "dct", (1.1, 0.0), 307),       # H = 1: x and t only
    ("m1x16x8_dft", (1, 16, 8), "dft", (0.0, -0.9), 308),      # W = 1: the half axis is y
]


def freqs(n):
    f = np.fft.fftfreq(n)
    if n % 2 == 0:
        f[n // 2] = 0.0
    return f


def setup(dims, v):
    W, H, T = dims
    sp = [(n, vel) for n, vel in ((H, v[1]), (W, v[0])) if n > 1]  # squeezed spatial, slow first
    shape = (T,) + tuple(n for n, _ in sp)
    tc = (T - 1) / 2
    t = (np.arange(T) - tc).reshape((T,) + (1,) * len(sp))
    ph = np.zeros((T,) + tuple(1 for _ in sp))
    for i, (n, vel) in enumerate(sp):
        f = freqs(n)
        if i == len(sp) - 1:
            f = f[: n // 2 + 1]  # the half axis (rfft's u0 = 0 .. M)
        view = [1] * (len(sp) + 1)
        view[i + 1] = len(f)
        ph = ph + f.reshape(view) * vel
    return shape, sp, np.exp(2j * np.pi * ph * t)  # the forward (unshearing) phase


def t_fwd(a, kind):
    if kind == "dft":
        return np.fft.fft(a, axis=0, norm="ortho")
    if kind == "dct":
        return sf.dct(a.real, type=2, axis=0, norm="ortho") + 1j * sf.dct(a.imag, type=2, axis=0, norm="ortho")
    return a


def t_inv(a, kind):
    if kind == "dft":
        return np.fft.ifft(a, axis=0, norm="ortho")
    if kind == "dct":
        return sf.idct(a.real, type=2, axis=0, norm="ortho") + 1j * sf.idct(a.imag, type=2, axis=0, norm="ortho")
    return a


def forward(f, dims, kind, v):
    shape, sp, P = setup(dims, v)
    g = f.reshape(shape)
    axes = tuple(range(1, len(shape)))
    X = np.fft.rfftn(g, axes=axes, norm="ortho")
    return t_fwd(X * P, kind)


def inverse(z, dims, kind, v):
    shape, sp, P = setup(dims, v)
    G = t_inv(z, kind) * np.conj(P)
    full = np.zeros(shape, complex)
    full[..., : G.shape[-1]] = G
    axes = tuple(range(1, len(shape)))
    nsp = int(np.prod(shape[1:]))
    f = np.real(np.fft.ifftn(full, axes=axes, norm="ortho"))
    # ifftn "ortho" of the half spectrum alone: Re sum_{u0 <= M} z e^{...} / sqrt(n) (csi's synthesis)
    return f.reshape(dims[2], dims[1], dims[0]), nsp


# name, dims, time transform, velocity, sigma_xy, sigma_t, seed
FILTER_CASES = [
    ("g16x12x8_dct", (16, 12, 8), "dct", (0.7, -0.3), 1.1, 2.0, 401),
    ("g24x16x6_dft", (24, 16, 6), "dft", (1.5, 0.5), 0.8, 1.5, 402),
    ("g32x1x8_dct", (32, 1, 8), "dct", (-1.2, 0.0), 1.3, 3.0, 403),
]


def gauss(s, f):
    return np.exp(-2 * np.pi ** 2 * s * s * f * f)


def motion_filter(x, dims, kind, v, sxy, st):
    """B^-1 (g B x): the spectrum of the aligned volume times the Gaussian, built from numpy's
    full complex FFT of each aligned frame (not the half spectrum)."""
    W, H, T = dims
    shape, sp, P = setup(dims, v)
    g = x.reshape(shape)
    axes = tuple(range(1, len(shape)))
    Xf = np.fft.fftn(g, axes=axes, norm="ortho")
    # the unshearing phase on the full spectrum: exp(+2 pi i <u, v> (t - tc)), fftfreq with +1/2
    tc = (T - 1) / 2
    t = (np.arange(T) - tc).reshape((T,) + (1,) * len(sp))
    ph = np.zeros((T,) + (1,) * len(sp))
    gs = np.ones((1,) + tuple(n for n, _ in sp))
    for i, (n, vel) in enumerate(sp):
        view = [1] * (len(sp) + 1)
        view[i + 1] = n
        ph = ph + freqs(n).reshape(view) * vel
        gs = gs * gauss(sxy, np.fft.fftfreq(n)).reshape(view)
    Pf = np.exp(2j * np.pi * ph * t)
    A = t_fwd(Xf * Pf, kind)
    nu = np.arange(T) / (2 * T) if kind == "dct" else np.fft.fftfreq(T)
    A = A * gs * gauss(st, nu).reshape((T,) + (1,) * len(sp))
    G = t_inv(A, kind) * np.conj(Pf)
    return np.real(np.fft.ifftn(G, axes=axes, norm="ortho")).reshape(T, H, W)


def main():
    for name, dims, kind, v, seed in CASES:
        rng = np.random.default_rng(seed)
        W, H, T = dims
        f = rng.standard_normal((T, H, W)).astype(np.float32)
        z = forward(f.astype(np.float64), dims, kind, v)
        c = (rng.standard_normal(z.shape) + 1j * rng.standard_normal(z.shape)).astype(np.complex64)
        g, _ = inverse(c.astype(np.complex128), dims, kind, v)
        np.save(os.path.join(OUT, name + "_f.npy"), f)
        np.save(os.path.join(OUT, name + "_fwd.npy"), z.astype(np.complex64))
        np.save(os.path.join(OUT, name + "_c.npy"), c)
        np.save(os.path.join(OUT, name + "_inv.npy"), g.astype(np.float32))
    for name, dims, kind, v, sxy, st, seed in FILTER_CASES:
        rng = np.random.default_rng(seed)
        W, H, T = dims
        x = rng.standard_normal((T, H, W)).astype(np.float32)
        np.save(os.path.join(OUT, name + "_x.npy"), x)
        y = motion_filter(x.astype(np.float64), dims, kind, v, sxy, st)
        np.save(os.path.join(OUT, name + "_y.npy"), y.astype(np.float32))


if __name__ == "__main__":
    main()
