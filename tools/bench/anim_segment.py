#!/usr/bin/env python3
"""A still/moving segmentation of an x, y, t volume with a velocity per part (issue 12; a numpy
prototype around csi's library, measured in docs/bench/animation.md, rounds 8 and 9).

csi's motion solve (Alg. 2) shears its basis by one velocity for the whole volume, or by none
(motion_velocity.c: a velocity must improve the samples' leave-one-out error on the mean and on
the median, so a mover over a still background keeps v = 0, and the mover is blurred). Here:

 1. layers: per-sample squared leave-one-out errors E[v, i] of the Gaussian normalized
    convolution along each candidate velocity v (sigma 1 cell in x, y and t in the frame moving
    at v: the search's own predictor, motion_velocity.c), on a grid of velocities (step 1 cell per
    frame, |v| <= 8) and the default's velocity (layer 0). Layers are added greedily, at most
    two: every candidate is scored by the segmentation's error with it added (step 2's labels,
    each sample scored by its own error in the layer it was given); the best is added when that
    error, cross-validated over --folds random folds of the samples (each fold scored with the
    candidate that is best on the others), is --gain (3%) below the current one; then it is
    refined on a 0.25-cell grid around it. (Accepting by the in-sample error, --folds 0, added
    layers on noise: the minimum over a few hundred candidates is optimistic; so did ranking by
    the sum of each sample's smallest error.)
 2. labels: each sample takes the layer with the smallest sum of its neighbours' errors
    (Gaussian weights of width 3 cells in x, y and 2 frames in t, itself left out; their
    errors did use it, so the score is not a clean cross-validation).
 3. a solve per layer: the default (layer 0) and csi with each further layer's velocity given
    (--motion-velocity given; Alg. 1's filter at the default's width when the default has one);
    a layer at v = 0 beside a sheared default by csi's still solve (--motion-velocity none, with
    its filter and per-pixel correction).
 4. composite: each cell's membership of a layer is the normalized convolution of the layer's
    labels (width 3 cells, 1.5 frames); frames = sum of memberships x the layers' frames; image =
    the default's image (with its per-pixel correction) + the mean over t of frames - its frames.

    .venv/bin/python tools/bench/anim_segment.py --volumes static+disc,pan+disc --rates 0.01,0.03,0.1 \\
        --seeds 0,1 --size 64x64x16 --out OUT
    DRJIT_LIBLLVM_PATH=... .venv/bin/python tools/bench/anim_segment.py --scenes anim_ball,anim_pan \\
        --mitsuba-size 64x64x16 --ref-spp 64 --paths 16 --rates 0.01,0.03,0.1 --seeds 0 --out OUT

Writes OUT/results.csv: per case the default's and the composite's image MSE over the
oracle-tuned 3-D Gaussian's (bench_animation.py's oracle), mean frame PSNR, temporal error (MSE
of frame differences), the layers' velocities, the segmentation's in-sample error after each
layer (cv_scores), the acceptance test's error for each candidate considered (tests: the
cross-validated one, or the in-sample one with --folds 0) and the seconds of the layer search.
"""
import argparse
import csv
import os
import sys
import time

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(HERE)), "host", "python"))

import bench_animation as ba  # noqa: E402

import csi  # noqa: E402


def loo_errors(pos, vals, T, vs, sig=1.0, sig_t=1.0):
    """E[a, i]: sample i's squared leave-one-out error (summed over channels) of the Gaussian
    normalized convolution in the frame moving at vs[a] (x - vx (t - tc), y - vy (t - tc), t),
    truncated at 3.5 widths; a sample with no neighbour is predicted by the mean."""
    p = pos.astype(np.float64)
    y = vals.astype(np.float64)
    tc = 0.5 * (T - 1)
    E = np.empty((len(vs), len(p)))
    for a, (vx, vy) in enumerate(vs):
        q = np.stack([(p[:, 0] - vx * (p[:, 2] - tc)) / sig, (p[:, 1] - vy * (p[:, 2] - tc)) / sig,
                      p[:, 2] / sig_t], 1)
        pairs = cKDTree(q).query_pairs(3.5, output_type="ndarray")
        w = np.exp(-0.5 * np.sum((q[pairs[:, 0]] - q[pairs[:, 1]]) ** 2, 1))
        num = np.zeros_like(y)
        den = np.zeros(len(p))
        for i, j in ((0, 1), (1, 0)):
            np.add.at(num, pairs[:, i], w[:, None] * y[pairs[:, j]])
            np.add.at(den, pairs[:, i], w)
        pred = np.where(den[:, None] > 1e-3, num / np.maximum(den, 1e-3)[:, None], y.mean(0))
        E[a] = np.sum((pred - y) ** 2, 1)
    return E


def neighbour_weights(pos, sig_s=3.0, sig_t=2.0):
    """The sparse symmetric matrix of Gaussian weights between samples (still frame, widths sig_s
    cells and sig_t frames, truncated at 3 widths), zero on the diagonal: W @ e is each sample's
    neighbours' sum of e, its own left out (their leave-one-out errors did use it: the score is
    not a clean cross-validation, see docs/bench/animation.md, round 8)."""
    from scipy import sparse
    p = pos.astype(np.float64)
    q = np.stack([p[:, 0] / sig_s, p[:, 1] / sig_s, p[:, 2] / sig_t], 1)
    pairs = cKDTree(q).query_pairs(3.0, output_type="ndarray")
    w = np.exp(-0.5 * np.sum((q[pairs[:, 0]] - q[pairs[:, 1]]) ** 2, 1))
    n = len(p)
    Wm = sparse.coo_matrix((np.concatenate([w, w]), (np.concatenate([pairs[:, 0], pairs[:, 1]]),
                                                      np.concatenate([pairs[:, 1], pairs[:, 0]]))), shape=(n, n))
    return Wm.tocsr()


def candidate_errors(S, E, lab_s, lab_e):
    """(n, candidates): each sample's error with that candidate added to the layers so far: the
    candidate's own error where its neighbours' sum S is below the current label's, else the
    current one."""
    return np.where(S < lab_s[:, None], E.T, lab_e[:, None])


def heldout_error(per, chosen, folds):
    """The cross-validated error of "add the best candidate": for each fold, the candidate that is
    best on the other folds' samples, scored on this fold's samples only. The in-sample minimum
    over a few hundred candidates is optimistic (it picks velocities on noise); this is not."""
    total = 0.0
    for k in range(int(folds.max()) + 1):
        held = folds == k
        fit = per[~held].sum(0)
        fit[chosen] = np.inf
        total += float(per[held, int(np.argmin(fit))].sum())
    return total


def choose_layers(Wm, E, gain, maxl=2, folds=None):
    """Greedy from layer 0 (the default's velocity): each candidate v is scored by the
    segmentation's error with it added: sample i takes the layer whose neighbours' errors
    (W @ E, its own left out) are smallest and is scored by its own error there. The best
    candidate is added when it lowers that error by the fraction gain; with folds (a fold index
    per sample), when heldout_error does (the candidate is then still the best on all samples)."""
    S = np.asarray(Wm @ E.T)  # (n, candidates)
    chosen, scores, tests = [0], [float(E[0].sum())], []
    lab_s, lab_e = S[:, 0].copy(), E[0].copy()
    cur = scores[0]
    for _ in range(maxl):
        per = candidate_errors(S, E, lab_s, lab_e)
        cv = per.sum(0)
        cv[chosen] = np.inf
        b = int(np.argmin(cv))
        test = float(cv[b]) if folds is None else heldout_error(per, chosen, folds)
        tests.append(test)
        if test > (1 - gain) * cur:
            break
        chosen.append(b)
        take = S[:, b] < lab_s
        lab_e = np.where(take, E[b], lab_e)
        lab_s = np.where(take, S[:, b], lab_s)
        cur = float(cv[b])
        scores.append(cur)
    choose_layers.scores = scores  # the error after each layer, for the report
    choose_layers.tests = tests  # the acceptance test's error for each candidate considered
    return chosen


def sample_folds(n, k, seed=0):
    """k folds of n samples, each sample's fold random (fixed seed: the same samples give the
    same folds) with the fold sizes as equal as they can be."""
    return np.random.default_rng(seed).permutation(np.arange(n) % k)


def find_layers(pos, vals, T, v0, gain=0.03, maxl=2, step=1.0, vmax=8.0, folds=5, refine="insample"):
    """The layers' velocities (v0, the default's, first) and their per-sample errors: a grid of
    velocities, then each added layer refined on a 0.25-cell grid around it (the others kept).
    folds > 1: a layer is accepted by its cross-validated error over that many folds (choose_layers);
    0: by the in-sample error (round 8's rule). refine "cv" (with folds > 1): a refined velocity
    replaces the grid's only when refine_layer's cross-validation says so; "still": a layer at
    the grid's v = 0 is not refined (both candidates: measured, not the default); "insample": the
    refinement best on all samples."""
    grid = np.arange(-vmax, vmax + 1e-9, step)
    vs = [tuple(v0)] + [(float(a), float(b)) for a in grid for b in grid]
    E = loo_errors(pos, vals, T, vs)
    Wm = neighbour_weights(pos)
    fold = sample_folds(len(pos), folds) if folds > 1 else None
    chosen = choose_layers(Wm, E, gain, maxl, fold)
    find_layers.scores = choose_layers.scores
    find_layers.tests = choose_layers.tests
    fine_steps = np.arange(-0.75, 0.76, 0.25)
    for l in range(1, len(chosen)):
        bx, by = vs[chosen[l]]
        if refine == "still" and bx == 0 and by == 0:
            continue  # a still layer stays still (csi's still solve, layer_solves)
        fine = [(bx + a, by + b) for a in fine_steps for b in fine_steps]
        Ef = loo_errors(pos, vals, T, fine)
        others = [k for m, k in enumerate(chosen) if m != l]
        if refine != "cv" or fold is None:
            sub = np.vstack([E[others], Ef])
            pick = choose_layers(Wm, sub, -np.inf, maxl=1)  # the best refinement, whatever its gain
            best = pick[1] - len(others) if len(pick) > 1 and pick[1] >= len(others) else None
        else:
            best = refine_layer(Wm, E[others], Ef, fine_steps.size ** 2 // 2, fold)
        if best is not None:
            vs.append(fine[best])
            E = np.vstack([E, Ef[best][None]])
            chosen[l] = len(vs) - 1
    return [vs[k] for k in chosen], E[chosen], Wm


def refine_layer(Wm, E_others, Ef, coarse, folds):
    """Which of the fine candidates Ef replaces a layer (E_others: the other layers' errors;
    Ef[coarse]: the layer's own grid velocity): the one best on all samples, when the
    cross-validated error of that choice is below the grid velocity's own error; else None (the
    grid velocity stays: the best of 49 neighbours is optimistic, as the grid's best is)."""
    n, no = Ef.shape[1], len(E_others)
    sub = np.vstack([E_others, Ef])
    S = np.asarray(Wm @ sub.T)
    lab = np.argmin(S[:, :no], 1)  # each sample's layer among the others (ties: the earlier)
    rows = np.arange(n)
    per = candidate_errors(S, sub, S[rows, lab], sub[lab, rows])
    fit = per.sum(0)
    fit[:no] = np.inf
    best = int(np.argmin(fit))
    if best == no + coarse or heldout_error(per, list(range(no)), folds) >= fit[no + coarse]:
        return None
    return best - no


def layer_solves(pos, vals, grid, r0, layers, still_weight=1.0):
    """The default's result and csi's for each further layer's velocity (still_weight: round 7's
    l1 weight of the layer's time-constant plane, what moves at its velocity)."""
    width = r0.options.get("motion_filter")
    try:
        width = float(width)
    except (TypeError, ValueError):
        width = -1.0
    out = [r0]
    for vx, vy in layers[1:]:
        if vx == 0 and vy == 0:  # a still layer beside a sheared default: csi's still solve
            kw = {"motion_still_weight": still_weight} if still_weight != 1.0 else {}
            out.append(csi.reconstruct(pos, vals, grid, frames="on", motion_velocity="none", **kw))
            continue
        kw = {"motion_filter": width} if width > 0 else {}
        if still_weight != 1.0:
            kw["motion_still_weight"] = still_weight
        out.append(csi.reconstruct(pos, vals, grid, frames="on", motion_velocity="given",
                                   motion_vx=vx, motion_vy=vy, **kw))
    return out


def membership(pos, lab, nl, shape, sig_s=3.0, sig_t=1.5):
    """(nl, T, H, W): each cell's share of each layer, the normalized convolution of the labels."""
    d = np.zeros(shape)
    d[pos[:, 2], pos[:, 1], pos[:, 0]] = 1
    s = (sig_t, sig_s, sig_s)
    d = ndimage.gaussian_filter(d, s, mode="nearest")
    m = np.empty((nl,) + tuple(shape))
    for l in range(nl):
        a = np.zeros(shape)
        a[pos[:, 2], pos[:, 1], pos[:, 0]] = lab == l
        m[l] = ndimage.gaussian_filter(a, s, mode="nearest") / np.maximum(d, 1e-12)
    return m / np.maximum(m.sum(0, keepdims=True), 1e-12)


def composite(pos, El, Wm, results, shape, hard=False, **kw):
    """Step 4; hard: the added layers' shares pushed to 0 or 1 away from the labels' boundary,
    clip((share - 0.25) / 0.5), layer 0 taking the rest."""
    if len(results) == 1:
        return results[0].image, results[0].frames
    m = membership(pos, np.argmin(np.asarray(Wm @ El.T), 1), len(results), shape, **kw)
    if hard:
        m = np.clip((m - 0.25) / 0.5, 0, 1)
        m[0] = 1 - m[1:].sum(0).clip(0, 1)
        m /= m.sum(0, keepdims=True)
    frames = sum(m[l][..., None] * r.frames for l, r in enumerate(results))
    return results[0].image + (frames - results[0].frames).mean(0), frames


def segmented(pos, vals, grid, gain=0.03, r0=None, still_weight=1.0, hard=False, folds=5, refine="insample"):
    """The whole method: (image, frames, layers) for samples at cells pos of grid (w, h, t, w, h)."""
    if r0 is None:
        r0 = csi.reconstruct(pos, vals, grid, frames="on")
    v0 = (float(r0.options.get("motion_vx") or 0), float(r0.options.get("motion_vy") or 0))
    layers, El, Wm = find_layers(pos, vals, grid[2], v0, gain, folds=folds, refine=refine)
    img, frames = composite(pos, El, Wm, layer_solves(pos, vals, grid, r0, layers, still_weight),
                            (grid[2], grid[1], grid[0]), hard)
    return img, frames, layers


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ba.add_small_case_args(ap)
    ap.add_argument("--gain", type=float, default=0.03)
    ap.add_argument("--layer-still-weight", type=float, default=1.0,
                    help="the added layers' solves with this --motion-still-weight (candidate)")
    ap.add_argument("--shares", choices=("soft", "hard"), default="soft", help="step 4's shares (candidate: hard)")
    ap.add_argument("--folds", type=int, default=5,
                    help="accept a layer by its error cross-validated over this many folds (0: in-sample, round 8)")
    ap.add_argument("--refine", choices=("insample", "cv", "still"), default="insample",
                    help="an added layer's 0.25-cell refinement: the best on all samples, only when "
                         "cross-validated over --folds, or the best on all samples but none for a layer "
                         "at the grid's v = 0 (candidates: cv, still)")
    a = ap.parse_args()
    cases = [("procedural", v) for v in a.volumes.split(",") if v] + [("mitsuba", s) for s in a.scenes.split(",") if s]
    for src, name in cases:
        known = ba.av.NAMES if src == "procedural" else tuple(ba.MITSUBA_SCENES)
        if name not in known:
            ap.error(f"unknown {'volume' if src == 'procedural' else 'scene'} {name!r} (one of {', '.join(known)})")
    if not cases:
        ap.error("nothing to run: give --volumes and/or --scenes")
    try:
        size = tuple(int(x) for x in a.size.split("x"))
        msize = tuple(int(x) for x in a.mitsuba_size.split("x"))
        rates = [float(x) for x in a.rates.split(",")]
        seeds = [int(x) for x in a.seeds.split(",")]
    except ValueError as e:
        ap.error(f"bad --size, --mitsuba-size, --rates or --seeds: {e}")
    if len(size) != 3 or len(msize) != 3 or min(size + msize) < 2 or not all(0 < r <= 1 for r in rates):
        ap.error("sizes are WxHxT (each at least 2) and rates fractions in (0, 1]")
    if a.folds == 1 or a.folds < 0:
        ap.error(f"--folds {a.folds}: 0 (in-sample) or at least 2")
    if a.refine == "cv" and a.folds < 2:
        ap.error("--refine cv needs --folds of at least 2")
    if not a.layer_still_weight > 0:
        ap.error(f"--layer-still-weight {a.layer_still_weight}: must be > 0")
    os.makedirs(a.out, exist_ok=True)
    path = os.path.join(a.out, "results.csv")
    new = not os.path.exists(path)
    with open(path, "a", newline="") as fh:
        wr = csv.writer(fh)
        if new:
            wr.writerow(["source", "volume", "rate", "seed", "gauss_img_mse", "csi_img", "seg_img", "seg_over_csi",
                         "csi_psnr", "seg_psnr", "csi_temporal", "seg_temporal", "layers", "cv_scores", "tests",
                         "t_layers_s"])
        for src, name in cases:
            for rate in rates:
                for seed in seeds:
                    if src == "procedural":
                        c = ba.procedural_case(name, seed, rate, size, os.path.join(a.data, "procedural"))
                    else:
                        c = ba.mitsuba_case(name, seed, rate, msize, a.data, a.ref_spp, a.paths)
                    ref = c.truth.mean(axis=0)
                    g = min(float(np.mean((ba.gauss_nc(c.shape, c.pos, c.vals, s).mean(0) - ref) ** 2))
                            for s in ba.GAUSS_SIGMAS)
                    r0 = csi.reconstruct(c.pos, c.vals, c.grid, frames="on")
                    m0 = ba.metrics(c, r0.image, r0.frames)
                    t0 = time.perf_counter()
                    img, frames, layers = segmented(c.pos, c.vals, c.grid, a.gain, r0, a.layer_still_weight,
                                                    a.shares == "hard", a.folds, a.refine)
                    sec = time.perf_counter() - t0
                    m1 = ba.metrics(c, img, frames)
                    row = [src, name, rate, seed, f"{g:.6e}", f"{m0['img_mse'] / g:.4f}", f"{m1['img_mse'] / g:.4f}",
                           f"{m1['img_mse'] / m0['img_mse']:.4f}", f"{m0['frames_psnr']:.3f}",
                           f"{m1['frames_psnr']:.3f}", f"{m0['temporal_mse']:.4e}", f"{m1['temporal_mse']:.4e}",
                           " ".join(f"{vx:.2f},{vy:.2f}" for vx, vy in layers),
                           " ".join(f"{x:.4g}" for x in find_layers.scores),
                           " ".join(f"{x:.4g}" for x in find_layers.tests), f"{sec:.1f}"]
                    wr.writerow(row)
                    fh.flush()
                    print(" ".join(str(x) for x in row), flush=True)


if __name__ == "__main__":
    main()
