#!/usr/bin/env python3
"""Reference vectors for the interpolation operator and Alg. 1's model grid
(tests/unit/test_interp.c, tests/unit/test_model_grid.c).

Interpolation (csi/interp.h): y_i = sum_j c[j] phi(p_i / D - j) on a periodic model grid, with
phi the "exponential of semicircle" kernel, evaluated directly in float64 (all taps, explicit
wrap), and its adjoint (the spread); phi^ by adaptive quadrature (scipy.integrate.quad), not the
Gauss-Legendre rule csi uses.

Model grid (csi/model_grid.h): the exact fine-grid image model f = Phi^-1 U^d g, where g is an
image on the model grid, U one level of PyWavelets' periodized synthesis with zero details
(pywt.waverec2) and Phi^-1 the Wiener inverse of the Gaussian on the fine grid by numpy's full
complex FFT, read at random fine cells (what the model grid's filter + interpolation must
reproduce) and box-averaged over output pixels. The error of csi's model grid against these is
the approximation error csi/model_grid.h documents; the main block also prints it for the
kernel's shape parameter (the measurement behind interp.c's BETA).

Arrays have numpy shape (h, w) = the C layout (x fastest). Fixed seeds; run from the repository
root:  .venv/bin/python tests/data/interp/gen_refs.py
"""
import os
import sys

import numpy as np
import pywt
from scipy.integrate import quad

OUT = os.path.dirname(os.path.abspath(__file__))
TAPS = 6
IH = TAPS // 2 - 1
BETA = 2.1 * TAPS


def phi(z, beta=BETA):
    u = 2.0 * np.asarray(z, float) / TAPS
    out = np.zeros_like(u)
    m = np.abs(u) < 1
    out[m] = np.exp(beta * (np.sqrt(1 - u[m] ** 2) - 1))
    return out


def phi_ft(xi, beta=BETA):
    f = lambda z: float(phi(z, beta)) * np.cos(2 * np.pi * xi * z)
    return 2 * quad(f, 0, TAPS / 2, epsabs=1e-14, epsrel=1e-13, limit=200)[0]


def gather(c, D, px, py, beta=BETA):
    mh, mw = c.shape
    y = np.zeros(len(px))
    for i, (x, yy) in enumerate(zip(px, py)):
        tx, ty = x / D, yy / D
        mx, my = x // D, yy // D
        for a in range(-IH, TAPS - IH):
            for b in range(-IH, TAPS - IH):
                w = phi(ty - (my + a), beta) * phi(tx - (mx + b), beta)
                y[i] += w * c[(my + a) % mh, (mx + b) % mw]
    return y


def spread(r, shape, D, px, py):
    mh, mw = shape
    c = np.zeros(shape)
    for i, (x, yy) in enumerate(zip(px, py)):
        tx, ty = x / D, yy / D
        mx, my = x // D, yy // D
        for a in range(-IH, TAPS - IH):
            for b in range(-IH, TAPS - IH):
                c[(my + a) % mh, (mx + b) % mw] += r[i] * phi(ty - (my + a)) * phi(tx - (mx + b))
    return c


def wiener_fine(h, w, sig, lam):
    fy, fx = np.fft.fftfreq(h), np.fft.fftfreq(w)
    G = np.outer(np.exp(-2 * np.pi ** 2 * sig[1] ** 2 * fy ** 2), np.exp(-2 * np.pi ** 2 * sig[0] ** 2 * fx ** 2))
    return (1 + lam) * G / (G * G + lam)


def fine_model(g, D, sig, lam, wavelet):
    """f = Phi^-1 U^d g on the fine grid (float64)."""
    f = g
    while f.shape[0] < g.shape[0] * D:
        z = np.zeros_like(f)
        f = pywt.waverec2([f, (z, z, z)], wavelet, mode="periodization")
    H, W = f.shape
    return np.real(np.fft.ifft2(np.fft.fft2(f) * wiener_fine(H, W, sig, lam)))


def test_image(mh, mw, kind, rng):
    if kind == "noise":
        return rng.standard_normal((mh, mw))
    yy, xx = np.mgrid[0:mh, 0:mw]
    disc = ((xx - 0.45 * mw) ** 2 + (yy - 0.4 * mh) ** 2) < (0.3 * min(mw, mh)) ** 2
    return disc * 1.0 + 0.3 * np.sin(xx / 3.0 + yy / 5.0) + (xx * mh > yy * mw) * 0.5


def model_approx(g, D, sig, lam, wavelet, px, py, beta=BETA, box=(1, 1)):
    """What csi computes, in float64: the model grid filter, then interpolation."""
    mh, mw = g.shape
    lo = np.array(pywt.Wavelet(wavelet).dec_lo)
    F = len(lo)

    def axis(m, B):
        v = np.fft.fftfreq(m) * m
        N = m * D
        h = np.ones(m, complex)
        n = N
        while n > m:
            h *= np.array([np.sum(lo * np.exp(-2j * np.pi * vv * (F // 2 - np.arange(F)) / n)) for vv in v])
            n //= 2
        q = np.arange(B)
        dr = np.array([np.mean(np.exp(2j * np.pi * vv * q / N)) for vv in v])
        ph = np.array([phi_ft(vv / m, beta) for vv in v])
        fac = h * dr / (D * ph)
        if m % 2 == 0:
            fac[m // 2] = 0
        return fac

    W = wiener_fine(mh, mw, (sig[0] / D, sig[1] / D), lam)
    gain = W * np.outer(axis(mh, box[1]), axis(mw, box[0]))
    c = np.real(np.fft.ifft2(np.fft.fft2(g) * gain))
    return gather(c, D, px, py, beta)


def save(name, **arrays):
    for k, v in arrays.items():
        np.save(os.path.join(OUT, f"{name}_{k}.npy"), v)


INTERP_CASES = [
    # name, model (w, h), D, samples, seed
    ("i20x12_D2", (20, 12), 2, 80, 11),
    ("i4x4_D4", (4, 4), 4, 30, 12),       # model grid smaller than the kernel: taps wrap onto themselves
    ("i200x40_D2", (200, 40), 2, 2000, 13),  # interior tiles (3 x 5 tiles, odd counts: 9 colours)
]

MODEL_CASES = [
    # name, fine (w, h), D, sigma (x, y) in fine cells, lambda, wavelet, image, seed
    ("m64x48_D2", (64, 48), 2, (3.2, 3.2), 0.3, "db4", "image", 21),
    ("m64x48_D2n", (64, 48), 2, (3.2, 3.2), 0.3, "db4", "noise", 22),
    ("m128x64_D4", (128, 64), 4, (6.4, 6.4), 0.3, "db4", "image", 23),
    ("m64x64_D2db8", (64, 64), 2, (3.0, 4.0), 0.3, "db8", "image", 24),
]

# box means: name, model case, box (bx, by)
BOX_CASES = [("b64x48_D2", "m64x48_D2", (8, 8)), ("b128x64_D4", "m128x64_D4", (8, 16))]


def main():
    zs = np.linspace(-3.2, 3.2, 33)
    xis = np.linspace(0, 0.75, 31)
    save("kernel", z=zs, phi=phi(zs), xi=xis, ft=np.array([phi_ft(x) for x in xis]))
    for name, (mw, mh), D, n, seed in INTERP_CASES:
        rng = np.random.default_rng(seed)
        fw, fh = mw * D, mh * D
        idx = rng.choice(fw * fh, n, replace=n > fw * fh)
        idx[:4] = [0, fw - 1, fw * fh - 1, fw * (fh - 1)]  # the corners wrap on both axes
        px, py = idx % fw, idx // fw
        c = rng.standard_normal((mh, mw))
        r = rng.standard_normal(n)
        save(name, idx=idx.astype(np.uint32), c=c.astype(np.float32), r=r.astype(np.float32),
             y=gather(c.astype(np.float32).astype(float), D, px, py),
             s=spread(r.astype(np.float32).astype(float), (mh, mw), D, px, py))
    for name, (fw, fh), D, sig, lam, wav, kind, seed in MODEL_CASES:
        rng = np.random.default_rng(seed)
        mw, mh = fw // D, fh // D
        g = test_image(mh, mw, kind, rng).astype(np.float32)
        n = fw * fh // 16
        idx = np.sort(rng.choice(fw * fh, n, replace=False))
        f = fine_model(g.astype(float), D, sig, lam, wav)
        y = f.reshape(-1)[idx]
        save(name, idx=idx.astype(np.uint32), g=g, y=y)
        if "--measure" in sys.argv:
            px, py = idx % fw, idx // fw
            for bf in (1.8, 2.0, 2.1, 2.2, 2.4):
                ya = model_approx(g.astype(float), D, sig, lam, wav, px, py, beta=bf * TAPS)
                print(f"{name}: beta {bf} w: rel L2 error {np.linalg.norm(ya - y) / np.linalg.norm(y):.2e}")
    for name, mcase, (bx, by) in BOX_CASES:
        m = [c for c in MODEL_CASES if c[0] == mcase][0]
        _, (fw, fh), D, sig, lam, wav, kind, seed = m
        g = np.load(os.path.join(OUT, f"{mcase}_g.npy")).astype(float)
        f = fine_model(g, D, sig, lam, wav)
        out = f.reshape(fh // by, by, fw // bx, bx).mean(axis=(1, 3))
        save(name, out=out)


if __name__ == "__main__":
    main()
