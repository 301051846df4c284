#!/usr/bin/env python3
"""How far a per-pixel blend of csi's fit and the pixel's mean could go, with the truth choosing
(issue 9, docs/bench/mitsuba.md, session 13).

For each cached Mitsuba dump of DATA at the given spp and paths (tools/bench/mitsuba_data.py),
reconstructs the fit's box integral b (`--correct none`: nothing after the fit), the per-pixel
mean m (`--estimator mean`) and csi (the defaults, or --csi-args), and prints per cell the
ratios to the mean's MSE / relMSE of csi, of b, and of two oracles that use the reference:
the better of b and m for each pixel (one choice for its channels, made on the figure it is
reported in) and the best convex weight w in b + w (m - b) for each pixel, w in [0, 1]; no rule
that blends b and m pixel by pixel can beat the second. Also the share of the mean's error in
"HDR" pixels (the reference's 3 x 3 window holds a luminance above max(1, 8x the image median)).

    .venv/bin/python tools/bench/blend_oracle.py --data /work/data/mitsuba --spp 4 --paths 64
"""
import os
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from bench_real_samples import cells, parse_cells, reconstruct  # noqa: E402


def hdr_pixels(ref):
    """Pixels whose 3 x 3 window of the reference holds a luminance above max(1, 8x the median)."""
    lum = ref.mean(-1)
    h, w = lum.shape
    pad = np.pad(lum, 1, mode="edge")
    top = np.max([pad[i:i + h, j:j + w] for i in range(3) for j in range(3)], axis=0)
    return top > max(1.0, 8 * np.median(lum))


def oracles(b, m, ref, wt):
    """Per-pixel squared errors (H, W, C) of the two oracles, each chosen on MSE (wt = 1) or on
    relMSE (wt = 1 / (ref^2 + 0.01))."""
    eb, em = (b - ref) ** 2, (m - ref) ** 2
    pick = ((em * wt).sum(-1) <= (eb * wt).sum(-1))[..., None]
    d = m - b
    w = np.clip(((ref - b) * d * wt).sum(-1, keepdims=True)
                / np.maximum((d * d * wt).sum(-1, keepdims=True), 1e-300), 0, 1)
    return np.where(pick, em, eb), (b + w * d - ref) ** 2


def main():
    a, exe = parse_cells(__doc__, "4", "64", "csi-reconstruct arguments for the csi column")
    print("| scene | spp | paths | positions | csi | b alone | oracle: b or m per pixel | "
          "oracle: best convex weight per pixel | mean's MSE / relMSE in HDR pixels | HDR pixels |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for scene, spp, paths, pos, dump, ref in cells(a.data, a.scenes, a.spp, a.paths, a.positions,
                                                         a.reference_spp, "blend_oracle"):
            m = reconstruct(exe, dump, ["--estimator", "mean"], tmp)
            b = reconstruct(exe, dump, ["--correct", "none"], tmp)
            c = reconstruct(exe, dump, a.csi_args.split(), tmp)
            rel = 1 / (ref ** 2 + 0.01)
            em = (m - ref) ** 2
            m0, r0 = em.mean(), (em * rel).mean()
            pick_m, convex_m = oracles(b, m, ref, np.ones_like(ref))
            pick_r, convex_r = oracles(b, m, ref, rel)

            def ratio(e_mse, e_rel=None):
                e_rel = e_mse if e_rel is None else e_rel
                return f"{e_mse.mean() / m0:.3f} / {(e_rel * rel).mean() / r0:.3f}"

            h = hdr_pixels(ref)
            print(f"| {scene} | {spp} | {paths} | {pos} | {ratio((c - ref) ** 2)} | {ratio((b - ref) ** 2)} | "
                  f"{ratio(pick_m, pick_r)} | {ratio(convex_m, convex_r)} | "
                  f"{em[h].sum() / em.sum():.2f} / {(em * rel)[h].sum() / (em * rel).sum():.2f} | "
                  f"{100 * h.mean():.0f}% |", flush=True)


if __name__ == "__main__":
    main()
