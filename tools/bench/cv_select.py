#!/usr/bin/env python3
"""A per-region choice between csi and the per-pixel mean made by two-fold cross-validation
against held-out pixel means (issue 9, section 2; docs/bench/mitsuba.md, "Choosing csi or the
mean per region by cross-validation").

Why this estimate: the quantity to decide on is each estimator's error in the pixel's integral I,
not in point values. Split every pixel's samples into two folds A and B. The mean of B's samples,
m_B, is an unbiased estimate of I whose error is independent of everything computed from A. So
for any estimator e_A computed from A alone,

    E[(e_A - m_B)^2] = E[(e_A - I)^2] + Var(m_B)

(the cross term vanishes), and the difference D = (c_A - m_B)^2 - (m_A - m_B)^2 has expectation
E[(c_A - I)^2] - E[(m_A - I)^2] with no variance to estimate: the noise of the held-out mean
cancels. Summing D over both directions (A -> B, B -> A), the channels and the pixels of a
region gives an unbiased estimate of how much csi on half the samples loses (D > 0) or gains
(D < 0) against the mean of half the samples there. The variants measured: the sum of D ("mse"),
of D / (m^2 + 0.01) ("rel", m the pixel's mean), or both above their thresholds ("both"); square
regions of side R, or a pixel switched when either of its regions of sides R1+R2 loses; the
threshold 0, z standard errors of the sum (z > 0), or |z| times the root of the sum of the
pixels' squared D (z < 0, self-normalised). csi-reconstruct's --cv-select (host/integrate/
cv_select.c) is "both", 8+16, z = -1.5, without a pixel tier; this script runs csi with
--cv-select off and makes the choice itself, so every variant is measured on the same
reconstructions.

A pixel tier, measured and not in csi (--step RATIO:N[:G], "off" for none, N "any" for no limit;
docs/bench/mitsuba.md): on top of the regions' choice, a pixel where each fold's samples straddle
an HDR step (in some channel the largest above RATIO times the smallest, each lifted by 0.1, the
root of relMSE's floor), holding at most N samples, with both its sums of D positive, takes its
mean: a bet on the sign of one pixel's D where the region rule cannot see one or two pixels (a
small emitter's rim). RATIO written with a trailing 'a' (30a:4) asks the step of all the pixel's
samples together instead of each fold's; with G, a pixel within G pixels of such a step is a
candidate too.

The folds: in a pixel with n >= 2 samples, the pixel is cut into k x k sub-squares
(k = ceil(sqrt(n))) and a sample goes to fold A or B by the parity of its sub-square. On
csi-positions' stratified positions (2 x 2 strata at 4 spp, 4 x 4 at 16) this is the diagonal
(checkerboard) split of the strata: each fold's mean is then unbiased for every image that is a
sum of a function of x and a function of y over the pixel (edges along the axes included), which
a split into halves of rows or columns is not. Pixels with one sample (every pixel at 1 spp) give
no held-out pair and no term: a region without any keeps csi, so 1-spp dumps are csi's image.

The price: two more reconstructions (each with half the samples, on a coarser model grid).

    .venv/bin/python tools/bench/cv_select.py --data /work/data/mitsuba --cache /tmp/cvsel \\
        --regions 8,16,8+16 --z 0,-1.5 --step off,30:4 --json out.json
"""
import argparse
import json
import os
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from bench_common import binaries, default_env, read_dump, read_exr  # noqa: E402
from bench_real_samples import SCENES, cells, errors  # noqa: E402


FOLD_ARGS = ["--model-sigma-min", "0.75"]


def reconstruct(exe, dump, out, args=()):
    if os.path.exists(out):
        return read_exr(out).astype(np.float64)
    p = subprocess.run([exe, dump, "-o", out + ".tmp.exr", "--quiet", "--cv-select", "off"] + list(args),
                       capture_output=True, env=default_env())
    if p.returncode:
        sys.exit(f"cv_select: {dump}: csi-reconstruct failed: {p.stderr.decode(errors='replace').strip()}")
    os.replace(out + ".tmp.exr", out)
    return read_exr(out).astype(np.float64)


def folds(hdr, pos):
    """Fold (0 or 1) of every sample, pixel index of every sample, samples per pixel."""
    W, H = hdr["out_w"], hdr["out_h"]
    bw, bh = hdr["grid_w"] // W, hdr["grid_h"] // H
    px, py = pos[:, 0] // bw, pos[:, 1] // bh
    pix = py.astype(np.int64) * W + px
    n = np.bincount(pix, minlength=W * H)
    k = np.ceil(np.sqrt(np.maximum(n[pix], 1))).astype(np.int64)
    sx = ((pos[:, 0] % bw).astype(np.int64) * k) // bw
    sy = ((pos[:, 1] % bh).astype(np.int64) * k) // bh
    return ((sx + sy) % 2).astype(np.int64), pix, n


def write_subset(src, dst, keep):
    """The dump `src` with only the records where `keep` is true (same header otherwise)."""
    with open(src, "rb") as f:
        raw = f.read()
    head = bytearray(raw[:64])
    c = int.from_bytes(head[28:32], "little")
    rec = np.frombuffer(raw[64:], dtype=np.dtype([("r", "V%d" % (12 + 4 * c))]))
    sub = rec[keep]
    head[32:40] = int(len(sub)).to_bytes(8, "little")
    with open(dst + ".tmp", "wb") as f:
        f.write(bytes(head))
        f.write(sub.tobytes())
    os.replace(dst + ".tmp", dst)


def pixel_means(vals, pix, sel, npix):
    cnt = np.bincount(pix[sel], minlength=npix).astype(np.float64)
    c = vals.shape[1]
    m = np.zeros((npix, c))
    for ch in range(c):
        m[:, ch] = np.bincount(pix[sel], weights=vals[sel, ch].astype(np.float64), minlength=npix)
    with np.errstate(invalid="ignore", divide="ignore"):
        m /= cnt[:, None]
    return m, cnt


def tile_sum(a, R):
    H, W = a.shape
    ty, tx = (H + R - 1) // R, (W + R - 1) // R
    pad = np.zeros((ty * R, tx * R))
    pad[:H, :W] = a
    return pad.reshape(ty, R, tx, R).sum(axis=(1, 3))


def loses(d, pair, R, z):
    """Per R x R region: whether the per-pixel differences d (pixels with a held-out pair,
    `pair`) sum above z standard errors of that sum (from the pixels' spread)."""
    k = tile_sum(pair.astype(float), R)
    s1 = tile_sum(d, R)
    s2 = tile_sum(d * d, R)
    with np.errstate(invalid="ignore", divide="ignore"):
        var = np.where(k > 1, (s2 - s1 * s1 / np.maximum(k, 1)) * k / np.maximum(k - 1, 1), 0)
    if z < 0:  # self-normalised: the sum above |z| times the root of the sum of squares
        return s1 > -z * np.sqrt(s2)
    return s1 > z * np.sqrt(np.maximum(var, 0))


def select(c, m, D, R, weight=None, both=None, pair=None, z=0.0, has=True):
    """Per R x R region: the mean where the (weighted) cross-validated difference sums above
    z standard errors (and, with `both`, where the sum weighted by `both` does too), csi
    elsewhere; a pixel without a sample (`has` false) keeps csi. Returns the image, the fraction of
    pixels given the mean, and their mask."""
    H, W = D.shape[:2]
    use_m = np.zeros((H, W), bool)
    for r in (R if isinstance(R, tuple) else (R,)):
        d1 = D if weight is None else D * weight
        s = loses(d1.sum(axis=2), pair, r, z)
        if both is not None:
            s &= loses((D * both).sum(axis=2), pair, r, z)
        use_m |= np.kron(s, np.ones((r, r)))[:H, :W].astype(bool)
    use_m &= has
    out = np.where(use_m[..., None], m, c)
    return out, float(use_m.mean()), use_m


def pixel_range(vals, pix, sel, npix):
    """Per pixel and channel: the smallest and the largest of the samples `sel` (inf / -inf where
    none)."""
    c = vals.shape[1]
    lo = np.full((npix, c), np.inf)
    hi = np.full((npix, c), -np.inf)
    for ch in range(c):
        np.minimum.at(lo[:, ch], pix[sel], vals[sel, ch].astype(np.float64))
        np.maximum.at(hi[:, ch], pix[sel], vals[sel, ch].astype(np.float64))
    return lo, hi


def straddles(lo, hi, ratio):
    return ((hi + 0.1) > ratio * (np.maximum(lo, 0) + 0.1)).any(axis=2)


def step_tier(out, m, D, wrel, pair, n, ranges, ratio, nmax, grow=0, folds_each=True):
    """The pixel tier on top of a choice `out`: the mean where each fold's samples in the pixel
    straddle an HDR step (folds_each false: all its samples together do; with grow = g, a pixel
    within g pixels of such a step is a candidate too), the pixel holds at most nmax samples (None:
    any) and both its sums of D are positive. ranges: (lo, hi) of all samples, of fold A's, of B's."""
    if folds_each:
        step = straddles(*ranges[1], ratio) & straddles(*ranges[2], ratio)
    else:
        step = straddles(*ranges[0], ratio) & (n >= 2)
    for _ in range(grow):
        p = np.pad(step, 1)
        step = np.zeros_like(step)
        for dy in range(3):
            for dx in range(3):
                step |= p[dy:dy + step.shape[0], dx:dx + step.shape[1]]
    sel = step & pair & (D.sum(axis=2) > 0) & ((D * wrel).sum(axis=2) > 0)
    if nmax is not None:
        sel &= n <= nmax
    return np.where(sel[..., None], m, out), sel


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--cache", required=True, help="scratch directory for the fold dumps and images")
    ap.add_argument("--scenes", default=",".join(SCENES))
    ap.add_argument("--spp", default="4,16")
    ap.add_argument("--paths", default="1,64")
    ap.add_argument("--positions", default="stratified,poisson")
    ap.add_argument("--regions", default="8+16", help="region sides; 8+16: a pixel takes the mean when either of its regions says so")
    ap.add_argument("--z", default="-1.5", help="thresholds: 0; z > 0: z standard errors of the sum; z < 0: |z| times the root of the sum of squares")
    ap.add_argument("--step", default="off", help="pixel tiers RATIO:N[:G] (N 'any': no limit; G: grown by G pixels) or 'off', ',' between")
    ap.add_argument("--build")
    ap.add_argument("--json")
    a = ap.parse_args()
    exe = binaries(a.build)["csi-reconstruct"]
    os.makedirs(a.cache, exist_ok=True)
    regions = [tuple(int(x) for x in r.split("+")) if "+" in r else int(r) for r in a.regions.split(",")]
    rows = []
    for scene, spp, paths, posm, dump, ref in cells(a.data, a.scenes, a.spp, a.paths, a.positions, 4096,
                                                   "cv_select"):
        name = os.path.basename(dump)[:-len(".csid")]
        hdr, pos, vals = read_dump(dump)
        H, W, C = hdr["out_h"], hdr["out_w"], hdr["channels"]
        f, pix, n = folds(hdr, pos)
        base = os.path.join(a.cache, f"{scene}_{name}")
        dA, dB = base + ".A.csid", base + ".B.csid"
        if not os.path.exists(dA):
            write_subset(dump, dA, f == 0)
            write_subset(dump, dB, f == 1)
        c = reconstruct(exe, dump, base + ".csi.exr")
        m = reconstruct(exe, dump, base + ".mean.exr", ["--estimator", "mean"])
        # the folds on csi-reconstruct's own model grid for them (CSI_CV_FOLD_SIGMA_MIN, csi/cv_select.h)
        cA = reconstruct(exe, dA, base + ".A.exr", FOLD_ARGS)
        cB = reconstruct(exe, dB, base + ".B.exr", FOLD_ARGS)
        mA, nA = pixel_means(vals, pix, f == 0, W * H)
        mB, nB = pixel_means(vals, pix, f == 1, W * H)
        both = (nA > 0) & (nB > 0)
        mA = np.where(both[:, None], mA, 0).reshape(H, W, C)
        mB = np.where(both[:, None], mB, 0).reshape(H, W, C)
        b3 = both.reshape(H, W)[..., None]
        D = np.where(b3, (cA - mB) ** 2 - (mA - mB) ** 2 + (cB - mA) ** 2 - (mB - mA) ** 2, 0.0)
        ranges = [tuple(x.reshape(H, W, C) for x in pixel_range(vals, pix, sel, W * H))
                  for sel in (np.ones(len(f), bool), f == 0, f == 1)]
        e_m = errors(m, ref)
        e_c = errors(c, ref)
        row = dict(scene=scene, spp=int(spp), paths=int(paths), positions=posm,
                   mean=e_m, csi=[e_c[0] / e_m[0], e_c[1] / e_m[1]],
                   half_csi=[(errors(cA, ref)[0] + errors(cB, ref)[0]) / 2 / e_m[0]],
                   pairs=float(both.mean()), sel={})
        wrel = 1.0 / (m ** 2 + 0.01)
        for R in regions:
            for crit, w, w2 in (("mse", None, None), ("rel", wrel, None), ("both", None, wrel)):
                for z in [float(v) for v in a.z.split(",")]:
                    out, frac, mask = select(c, m, D, R, w, w2, both.reshape(H, W), z,
                                             (n > 0).reshape(H, W))
                    key = f"{crit}{R if isinstance(R, int) else '+'.join(map(str, R))}" + (f"z{z:g}" if z else "")
                    for st in a.step.split(","):
                        o2, k2, f2 = out, key, frac
                        if st != "off":
                            ratio, nmax, grow = (st.split(":") + ["0"])[:3]
                            o2, sel = step_tier(out, m, D, wrel, both.reshape(H, W), n.reshape(H, W), ranges,
                                                float(ratio.rstrip("a")), None if nmax == "any" else int(nmax),
                                                int(grow), not ratio.endswith("a"))
                            k2, f2 = f"{key}s{st}", float((mask | sel).mean())
                        e = errors(o2, ref)
                        row["sel"][k2] = [e[0] / e_m[0], e[1] / e_m[1], f2, int((o2 < 0).sum())]
        rows.append(row)
        s = " ".join(f"{k}={v[0]:.3f}/{v[1]:.3f}({v[2]:.2f})" for k, v in row["sel"].items())
        print(f"{scene} {name}: csi {row['csi'][0]:.3f}/{row['csi'][1]:.3f} {s}", flush=True)
    summary(rows)
    if a.json:
        with open(a.json, "w") as fo:
            json.dump(rows, fo, indent=1)


def summary(rows):
    """Per variant: the cells above the mean in either figure, and the worst change against the
    same choice without a pixel tier (its key before the 's' of --step)."""
    if not rows:
        return
    for key in rows[0]["sel"]:
        above = [f"{r['scene']} {r['spp']}x{r['paths']} {r['positions']}" for r in rows if max(r["sel"][key][:2]) > 1.0]
        base = key[:key.index("s", 4)] if "s" in key[4:] else key
        worse = [(max(r["sel"][key][0] / r["sel"][base][0], r["sel"][key][1] / r["sel"][base][1]),
                  f"{r['scene']} {r['spp']}x{r['paths']} {r['positions']}") for r in rows]
        w = max(worse)
        print(f"{key}: above the mean in {len(above)} of {len(rows)} cells {above}; worse than {base} by > 0.5% "
              f"in {sum(x > 1.005 for x, _ in worse)} (worst {w[0]:.4f}, {w[1]}); negative values in "
              f"{sum(r['sel'][key][3] > 0 for r in rows)}")


if __name__ == "__main__":
    main()
