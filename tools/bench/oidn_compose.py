#!/usr/bin/env python3
"""csi composed with Intel Open Image Denoise against OIDN alone on the same samples (issue 9's
"beyond" target; docs/bench/mitsuba.md, session 13).

For each cached Mitsuba dump of DATA (tools/bench/mitsuba_data.py), with csi-reconstruct: the
per-pixel mean, csi (defaults; with --csi-args too) and the guides (per-pixel means of the
albedo and normal dumps); OIDN (pyoidn, HDR, quality high, negative values clipped) on the mean
with and without the guides, and on csi's image and on (mean + csi) / 2 with the guides. Prints
per cell each method's MSE / relMSE as a ratio to the better OIDN alone (the lower of oidn and
oidn+aux in that figure): below 1 in both, a pipeline with csi beats OIDN alone.

    .venv/bin/python tools/bench/oidn_compose.py --data /work/data/mitsuba --spp 4 \\
        --csi-args "--variance=auto --blend-spread on"
"""
import os
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from bench_real_samples import cells, errors, parse_cells, reconstruct, with_variance  # noqa: E402


def oidn(color, albedo=None, normal=None):
    import pyoidn

    c = np.ascontiguousarray(np.maximum(color, 0), np.float32)
    kw = {}
    if albedo is not None:
        kw = {"albedo": np.ascontiguousarray(np.clip(albedo, 0, 1), np.float32),
              "normal": np.ascontiguousarray(np.clip(normal, -1, 1), np.float32)}
    return np.asarray(pyoidn.denoise(c, hdr=True, quality="high", **kw), np.float64)


def main():
    a, exe = parse_cells(__doc__, "4", "1,64", "csi-reconstruct arguments of a second csi (csi2)")
    names = ["csi", "csi>oidn+aux", "mix>oidn+aux"] + (["csi2", "csi2>oidn+aux"] if a.csi_args else [])
    print("| scene | spp | paths | positions | oidn / oidn+aux (to the mean) | "
          + " | ".join(names) + " |")
    print("|---|---|---|---|---|" + "---|" * len(names))
    with tempfile.TemporaryDirectory() as tmp:
        for scene, spp, paths, pos, dump, ref in cells(a.data, a.scenes, a.spp, a.paths, a.positions,
                                                         a.reference_spp, "oidn_compose"):
            base = dump[: -len(".csid")]
            mean = reconstruct(exe, dump, ["--estimator", "mean"], tmp)
            alb = reconstruct(exe, base + ".albedo.csid", ["--estimator", "mean"], tmp)
            nrm = reconstruct(exe, base + ".normal.csid", ["--estimator", "mean"], tmp)
            img = {"csi": reconstruct(exe, dump, [], tmp)}
            if a.csi_args:
                img["csi2"] = reconstruct(exe, dump, with_variance(a.csi_args.split(), dump)[0], tmp)
                img["csi2>oidn+aux"] = oidn(img["csi2"], alb, nrm)
            img["csi>oidn+aux"] = oidn(img["csi"], alb, nrm)
            img["mix>oidn+aux"] = oidn(0.5 * (mean + img["csi"]), alb, nrm)
            e0 = errors(mean, ref)
            eo, ea = errors(oidn(mean), ref), errors(oidn(mean, alb, nrm), ref)
            best = (min(eo[0], ea[0]), min(eo[1], ea[1]))
            cols = []
            for n in names:
                e = errors(img[n], ref)
                cols.append(f"{e[0] / best[0]:.3f} / {e[1] / best[1]:.3f}")
            print(f"| {scene} | {spp} | {paths} | {pos} | {eo[0] / e0[0]:.3f} / {eo[1] / e0[1]:.3f}, "
                  f"{ea[0] / e0[0]:.3f} / {ea[1] / e0[1]:.3f} | " + " | ".join(cols) + " |", flush=True)


if __name__ == "__main__":
    main()
