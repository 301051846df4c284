#!/usr/bin/env python3
"""Issue 12's "2-D wavelet x 1-D transform in t" basis for Alg. 2, measured in numpy before building
it in C (docs/bench/animation.md, round 5): the same l1 problem solved with the 3-D DFT (the
paper's basis) and with PyWavelets' periodized 2-D Daubechies wavelet per frame (Alg. 1's db4,
4 levels) times the orthonormal DCT-II along t, each with and without Alg. 1's filter (the
samples see the model through the Wiener inverse of a Gaussian of width S along x and y; the
output is the sharp estimate). The same samples as tools/bench/bench_animation.py (its
random_cells), the same absolute tau for every basis (csi's rule, 0.25 / sqrt(N) times the DC
coefficient n mean / sqrt(k): every basis is orthonormal, so the aliasing floor it has to cut is
the same), FISTA for ITERS steps, then csi's residual correction (the Gaussian normalized
convolution of the residuals, width 0.5 (k / N)^(1/3)). No range projection and no per-pixel
image correction (csi's later stages, the same for any basis): the figures compare bases, not
csi's images.

    anim_wavelet_basis.py static+disc 0.03 0 --filters 0,1.0 --bases dft,db4
"""
import argparse
import os
import sys

import numpy as np
import pywt
import scipy.fft as sf

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import anim_volumes as av  # noqa: E402
import bench_animation as ba  # noqa: E402

ITERS = 300
LEVELS = 4


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("volume", choices=av.NAMES)
    ap.add_argument("rate", type=float)
    ap.add_argument("seed", type=int)
    ap.add_argument("--size", default="128x128x32")
    ap.add_argument("--filters", default="0,1.0", help="widths S of the filter (0: none)")
    ap.add_argument("--bases", default="dft,db4")
    a = ap.parse_args()
    W, H, T = (int(v) for v in a.size.split("x"))
    f, _ = av.volume(a.volume, W, H, T, a.seed)
    pos, idx = ba.random_cells((T, H, W), a.rate, a.seed)
    y = f.reshape(-1)[idx]
    n, k = len(y), f.size
    ref = f.mean(axis=0)
    tau = 0.25 / np.sqrt(n) * n * abs(y.mean()) / np.sqrt(k)
    _, slices = pywt.coeffs_to_array(pywt.wavedec2(np.zeros((H, W)), "db4", mode="periodization", level=LEVELS))

    def wav_syn(c):
        c = sf.idct(c, axis=0, norm="ortho")
        return np.stack([pywt.waverec2(pywt.array_to_coeffs(c[t], slices, output_format="wavedec2"), "db4",
                                       mode="periodization") for t in range(T)])

    def wav_ana(v):
        c = np.stack([pywt.coeffs_to_array(pywt.wavedec2(v[t], "db4", mode="periodization", level=LEVELS))[0]
                      for t in range(T)])
        return sf.dct(c, axis=0, norm="ortho")

    bases = {"dft": (lambda c: np.fft.ifftn(c, norm="ortho"), lambda v: np.fft.fftn(v, norm="ortho"), True),
             "db4": (wav_syn, wav_ana, False)}
    fy = np.fft.fftfreq(H)[:, None]
    fx = np.fft.fftfreq(W)[None, :]
    sig = 0.5 * (k / n) ** (1 / 3)
    gauss = min((float(np.mean((ba.gauss_nc((T, H, W), pos, y[:, None], s)[..., 0].mean(0) - ref) ** 2)), s)
                for s in ba.GAUSS_SIGMAS)
    print(f"{a.volume} {a.rate:g} seed {a.seed}: tuned Gaussian image MSE {gauss[0]:.4e} (width {gauss[1]:.2f})")
    for width in (float(s) for s in a.filters.split(",")):
        step = 1.0  # 1 / L, L = ||A||^2 <= the largest gain squared (an orthonormal basis)
        if width > 0:
            g = np.exp(-2 * np.pi ** 2 * width ** 2 * (fx ** 2 + fy ** 2))
            gain = 1.3 * g / (g * g + 0.3)  # csi's lambda 0.3
            step = 1.0 / float(gain.max()) ** 2
        for name in a.bases.split(","):
            syn0, ana0, cplx = bases[name]
            if width > 0:
                filt = (lambda v: np.fft.ifft2(np.fft.fft2(v, axes=(1, 2)) * gain, axes=(1, 2)))
                syn = (lambda c, s0=syn0: filt(s0(c))) if cplx else (lambda c, s0=syn0: np.real(filt(s0(c))))
                ana = (lambda v, a0=ana0: a0(filt(v))) if cplx else (lambda v, a0=ana0: a0(np.real(filt(v))))
            else:
                syn, ana = syn0, ana0
            dt = complex if cplx else float
            x = np.zeros((T, H, W), dt)
            z = x.copy()
            tk = 1.0
            for _ in range(ITERS):  # FISTA
                r = np.zeros(k, dt)
                r[idx] = syn(z).reshape(-1)[idx] - y
                u = z - step * ana(r.reshape(T, H, W))
                xn = u * np.maximum(1 - step * tau / np.maximum(np.abs(u), 1e-30), 0)
                tn = (1 + np.sqrt(1 + 4 * tk * tk)) / 2
                z = xn + (tk - 1) / tn * (xn - x)
                x, tk = xn, tn
            fr = np.real(syn(x))
            fc = fr + ba.gauss_nc((T, H, W), pos, (y - fr.reshape(-1)[idx])[:, None], sig)[..., 0]
            e = float(np.mean((fc.mean(0) - ref) ** 2))
            print(f"  {name:4s} filter {width:4.2f}: image MSE {e:.4e} ({e / gauss[0]:.3f}x the tuned Gaussian), "
                  f"frames MSE {float(np.mean((fc - f) ** 2)):.4e}", flush=True)


if __name__ == "__main__":
    main()
