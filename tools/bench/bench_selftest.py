#!/usr/bin/env python3
"""Self-test of the benchmark helpers' arithmetic (no binaries needed, a second to run):

  .venv/bin/python tools/bench/bench_selftest.py

Checks against closed forms: dump writing/reading round trip (docs/dump-format.md layout),
per-frame Monte Carlo means with the empty-cell fallback, full-grid dump averaging, the edge-pixel
rule on a step image, MSE / PSNR, the scene copy (size replaced, relative paths made absolute),
the break-even interpolation, and PyLops' Wiener operator against numpy. Exits 1 on a failure.
"""
import math
import os
import sys
import tempfile

import warnings

import numpy as np

warnings.filterwarnings("ignore")
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bench_common as bc  # noqa: E402

failures = 0


def check(cond, what):
    global failures
    if not cond:
        failures += 1
        print("FAIL:", what)
    else:
        print("ok:  ", what)


def main():
    tmp = tempfile.mkdtemp(prefix="csi-bench-selftest-")
    # dump round trip: header fields at the documented offsets
    hdr = dict(grid_w=4, grid_h=2, grid_t=3, out_w=2, out_h=1)
    pos = np.array([[0, 0, 0], [3, 1, 2], [1, 0, 1]], np.uint32)
    vals = np.array([1.5, -2.0, 7.25], np.float32)
    p = os.path.join(tmp, "a.csid")
    bc.write_dump1(p, hdr, pos, vals)
    raw = open(p, "rb").read()
    check(len(raw) == 64 + 3 * 16 and raw[:4] == b"CSID", "dump size and magic (64 + n * (12 + 4c) bytes)")
    h2, p2, v2 = bc.read_dump(p)
    check(h2["grid_w"] == 4 and h2["grid_t"] == 3 and h2["channels"] == 1 and h2["count"] == 3, "dump header read back")
    check(np.array_equal(p2, pos) and np.array_equal(v2[:, 0], vals), "dump records read back")

    # per-frame means: 2x1 pixels, blocks of 2x2 cells, T = 2
    hdr = dict(grid_w=4, grid_h=2, grid_t=2, out_w=2, out_h=1)
    pos = np.array([[0, 0, 0], [1, 1, 0], [2, 0, 1], [3, 1, 1], [3, 0, 1]], np.uint32)
    vals = np.array([1.0, 3.0, 10.0, 20.0, 30.0], np.float32)
    p = os.path.join(tmp, "f.csid")
    bc.write_dump1(p, hdr, pos, vals)
    fill = np.array([[[100.0], [200.0]]], np.float32)  # (H, W, c)
    fr, empty = bc.dump_frames(p, fill=fill)
    want = np.array([[[[2.0], [200.0]]], [[[100.0], [20.0]]]], np.float32)
    check(fr.shape == (2, 1, 2, 1) and np.allclose(fr, want), "per-frame means, empty cells take the fill")
    check(abs(empty - 0.5) < 1e-12, "fraction of empty (pixel, frame) cells")

    # full-grid average of two dumps
    hdr = dict(grid_w=2, grid_h=1, grid_t=2, out_w=2, out_h=1)
    cells = np.array([[0, 0, 0], [1, 0, 0], [0, 0, 1], [1, 0, 1]], np.uint32)
    pa, pb = os.path.join(tmp, "g1.csid"), os.path.join(tmp, "g2.csid")
    bc.write_dump1(pa, hdr, cells, np.array([1, 2, 3, 4], np.float32))
    bc.write_dump1(pb, hdr, cells[::-1], np.array([8, 6, 4, 2], np.float32))  # any record order
    vol = bc.dump_grid_mean([pa, pb])
    check(np.allclose(vol[..., 0], [[[1.5, 3.0]], [[4.5, 6.0]]]), "full-grid dumps averaged per cell")

    # edge rule on a step: luminance 0 | 1 between columns 3 and 4 of an 8-wide image
    img = np.zeros((6, 8, 3), np.float32)
    img[:, 4:] = 1.0
    e = bc.edge_mask(img)
    check(e[:, 3].all() and e[:, 4].all() and not e[:, :3].any() and not e[:, 5:].any(),
          "edge pixels: the two columns beside a unit step (central-difference gradient 0.5 >= 0.1)")

    # MSE / PSNR
    a = np.zeros((2, 2, 3), np.float32)
    b = np.full((2, 2, 3), 0.1, np.float32)
    check(abs(bc.mse(a, b) - 0.01) < 1e-9 and abs(bc.psnr(0.01) - 20.0) < 1e-9, "MSE 0.01 and PSNR 20 dB")
    check(math.isnan(bc.mse(a, b, np.zeros((2, 2), bool))), "MSE over an empty mask is NaN")

    # scene copy
    path, h = bc.scene_variant("garden", (48, 32), tmp)
    text = open(path).read()
    check("size 48 32" in text and "size 256 256" not in text, "scene copy: camera size replaced")
    quoted = [q for q in bc._QUOTED.findall(text)]
    check(quoted and all(os.path.isabs(q) and os.path.exists(q) for q in quoted), "scene copy: paths absolute and present")
    _, h2 = bc.scene_variant("garden", (48, 32), tmp)
    _, h3 = bc.scene_variant("garden", (64, 32), tmp)
    check(h == h2 and h != h3, "scene hash: stable, and changes with the size")

    # break-even: stratified MSE = 1/spp exactly; a method at 4 spp with MSE 1/8 equals stratified at 8
    import bench_accuracy as ba
    B = ba.Bench.__new__(ba.Bench)
    B.results = []
    for spp in (1, 2, 4, 9, 16):
        B.results.append(dict(scene="s", kind="static", width=10, height=10, spp=spp, seed=1, method="stratified",
                              mse=1.0 / spp, mse_edge=1.0, frames_mse=float("nan"), frames_psnr=float("nan"),
                              t_render_s=1e-6 * 100 * spp, t_recon_s=0.0, t_total_s=0.0, t_per_sample_us=1.0,
                              iterations=0, samples=100 * spp))
    B.results.append(dict(B.results[2], method="cs-x", mse=1.0 / 8, t_recon_s=0.5))
    B.results.append(dict(B.results[2], method="cs-y", mse=1.0 / 32, t_recon_s=0.5))
    be = {r["method"]: r for r in B.breakeven()}
    x, y = be["cs-x"], be["cs-y"]
    check(abs(x["equivalent_stratified_spp"] - 8) < 1e-9, "break-even: s* interpolated (log-log) = 8")
    check(abs(x["breakeven_cost_per_sample_us"] - 1e6 * 0.5 / (100 * 4)) < 1e-6,
          "break-even: c* = t_rec / (P (s* - 4)) = 1250 us")
    check(abs(y["equivalent_stratified_spp"] - 32) < 1e-6, "break-even: s* extrapolated past 16 with the last slope")

    # PyLops Wiener operator (skipped when pylops is absent)
    try:
        import bench_pylops as bp
        hdr = dict(grid_w=32, grid_h=16, out_w=8, out_h=4)
        rng = np.random.default_rng(1)
        pos = np.stack([rng.integers(0, 32, 100), rng.integers(0, 16, 100), np.zeros(100, int)], 1).astype(np.uint32)
        pos = np.unique(pos, axis=0)
        A, Psi, order = bp.build_operator(hdr, pos, 2, 0.3)
        x = rng.standard_normal(32 * 16).astype(np.float32)
        yv = rng.standard_normal(len(pos)).astype(np.float32)
        lhs, rhs = float(np.dot(np.ravel(A @ x), yv)), float(np.dot(x, np.ravel(A.H @ yv)))
        check(abs(lhs - rhs) <= 1e-4 * max(abs(lhs), 1), "PyLops A and A^H are adjoint (<Ax, y> = <x, A^H y>)")
        g = bp.wiener_gain(16, 32, 4, 8, 0.3)
        check(abs(g[0, 0] - 1.0) < 1e-12, "Wiener gain at DC is 1 ((1 + lambda) normalisation, spectral.h)")
    except ImportError as e:
        print("skip: PyLops check:", e)
    print("FAILED" if failures else "all passed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
