#!/usr/bin/env python3
"""What the samples say about `--peak-range`'s peak pixels (docs/bench/mitsuba.md, session 11):
for every peak pixel of the cached dumps with several paths per sample at 4 and 16 spp (the
option's test: two samples or more, the brightest at least 4 times the pixel's others and 2 times
every neighbour's sample, by the channels' mean), whether the pixel's mean over-reads its truth
(the log fit, which only lowers, can help) or under-reads it (it can only hurt), tallied by the
brightest record's relative variance (its `.variance.csid`) and by its ratio to the neighbours'
brightest, each group weighted by the mean's squared error there.

    .venv/bin/python tools/bench/peak_features.py --data /work/data/mitsuba
"""
import argparse
import glob
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from bench_common import read_dump  # noqa: E402


def peaks(dump, ref):
    """(x, y, truth, mean, brightest, its relative variance, brightest / neighbours' brightest)."""
    h, p, v = read_dump(dump)
    _, _, var = read_dump(dump[: -len(".csid")] + ".variance.csid")
    bw, bh, W, H = h["grid_w"] // h["out_w"], h["grid_h"] // h["out_h"], h["out_w"], h["out_h"]
    lum = v.mean(1)
    rv = var.mean(1) / np.maximum(lum, 1e-12) ** 2
    pid = (p[:, 1] // bh) * W + p[:, 0] // bw
    order = np.argsort(pid, kind="stable")
    ps = pid[order]
    start = np.searchsorted(ps, np.arange(W * H))
    end = np.searchsorted(ps, np.arange(W * H), "right")
    pmax = np.zeros(W * H)
    for q in np.nonzero(end > start)[0]:
        pmax[q] = lum[order[start[q]:end[q]]].max()
    e = 0.01 * np.abs(v).mean()
    for q in np.nonzero(end - start >= 2)[0]:
        idx = order[start[q]:end[q]]
        l = lum[idx]
        k = int(np.argmax(l))
        if l[k] < 4 * np.delete(l, k).max() + e:
            continue
        x, y = q % W, q // W
        nm = max(pmax[(y + dy) * W + x + dx] for dy in (-1, 0, 1) for dx in (-1, 0, 1)
                 if (dx or dy) and 0 <= x + dx < W and 0 <= y + dy < H)
        if l[k] < 2 * nm:
            continue
        yield x, y, ref[y, x], l.mean(), l[k], rv[idx[k]], l[k] / max(nm, 1e-12)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", required=True, help="the Mitsuba dump cache (tools/bench/mitsuba_data.py)")
    a = ap.parse_args()
    rows = []
    for dump in sorted(glob.glob(os.path.join(a.data, "*", "s*_p*.csid"))):
        name = os.path.basename(dump)
        if name.count(".") > 1 or name.startswith("s1_") or not os.path.exists(dump[:-5] + ".variance.csid"):
            continue
        scene = os.path.basename(os.path.dirname(dump))
        ref = np.load(os.path.join(a.data, scene, "reference_4096.npy")).mean(-1)
        rows += [(f"{scene}/{name}",) + r for r in peaks(dump, ref)]
    print(f"{len(rows)} peak pixels")
    for label, group in (("over-reads", [r for r in rows if r[3] < r[4]]),
                         ("under-reads", [r for r in rows if r[3] >= r[4]])):
        w = np.array([(r[4] - r[3]) ** 2 for r in group])
        rv = np.array([r[6] for r in group])
        tn = np.array([r[7] for r in group])
        print(f"{label}: {len(group)} pixels, weight {w.sum():.4g}")
        for lo, hi in ((0, 0.05), (0.05, 0.2), (0.2, np.inf)):
            s = (rv >= lo) & (rv < hi)
            print(f"  relative variance [{lo}, {hi}): {s.sum()} pixels, weight {w[s].sum():.4g}")
        for lo, hi in ((0, 4), (4, 16), (16, 64), (64, np.inf)):
            s = (tn >= lo) & (tn < hi)
            print(f"  brightest / neighbours' [{lo}, {hi}): {s.sum()} pixels, weight {w[s].sum():.4g}")
    for r in sorted(rows, key=lambda r: -(r[4] - r[3]) ** 2)[:10]:
        print(f"{r[0]} ({r[1]}, {r[2]}): truth {r[3]:.4g} mean {r[4]:.4g} brightest {r[5]:.4g} "
              f"relative variance {r[6]:.3g} / neighbours' {r[7]:.3g}")


if __name__ == "__main__":
    main()
