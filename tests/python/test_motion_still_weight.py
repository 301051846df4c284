"""The time-constant layer's own l1 weight in Alg. 2 (csi_recon_options.motion_still_weight,
csi_half_fourier_set_still_gain; issues 11 and 12), against an independent numpy solve.

Problem: min_x 0.5 ||y - S F^H x||^2 + tau sum_i w_i |x_i| over the complex 3-D spectrum x of an
8 x 8 x 8 volume (F the unitary 3-D DFT, numpy's fftn with norm="ortho"; S the sampled cells),
w_i = W on the plane u_t = 0 (the coefficients constant along t) and 1 elsewhere, and tau =
tau_rel ||F S^T y||_inf: the unweighted problem's reference, which the library keeps under the
weight. The library solves it on the half spectrum (the same minimiser, motion.c); its frames
with the paper's basis and every step after the solve switched off (no residual correction, no
range projection, no filter, no debiasing) are Re(F^H x). The reference is FISTA (Beck &
Teboulle 2009) in float64 with the weighted complex soft threshold, step 1 (||S F^H|| <= 1),
run to a change below 1e-13: an independent solver of the same convex problem.

The volume: a still texture (a few low modes and a 2-cell checker) with a bright square crossing
it, half of the cells sampled. Checks, for W = 0.25 and W = 4:
1. the library's frames against the reference's: max |difference| <= 1e-4 of the volume's peak.
   SpaRSA stops on the duality gap at tol 1e-7 (or its float32 floor, 32 u ||y||^2): the float32
   minimiser, measured 3e-7 to 3e-6 of the peak from float64's here; 1e-4 leaves a factor of 30
   for other float32 orderings (devices, FFT plans) and stays far below check 2's distances.
2. the weight matters at that tolerance: the reference's weighted and unweighted (W = 1)
   minimisers differ by more than 5x the tolerance, and the library is nearer the weighted one.
3. W = 1 given is the unweighted operator (not a gain of 1): the float64 unweighted minimiser.
4. auto (the default): on these exact samples of a mostly still volume, the share of the pixels
   holding two samples or more whose samples are all equal (counted here in numpy) is above one
   half, so auto is W = 0.5, the same bits as 0.5 given; the same samples with 1% multiplicative
   noise (no two equal) give W = 1, the bits of 1 given. A time window reports the weight given.
5. bad input: W < 0 or above the range is refused with a message naming the option.
"""
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "host", "python"))
sys.path.insert(0, HERE)
import csi  # noqa: E402
from checks import check, done  # noqa: E402
from weighted_l1_problem import GRID, N, PAPER, TAU_REL, check_minimiser, fista, sampled, samples, volume  # noqa: E402

TOL = 1e-4


def reference(shape, idx, y, weight):
    """The frames Re(F^H x) of the weighted minimiser (weight W on the plane u_t = 0)."""
    m, ys, tau = sampled(shape, idx, y)
    w = np.ones(shape)
    w[0] = weight  # axis 0 is t: the plane u_t = 0
    return np.real(np.fft.ifftn(fista(m, ys, tau * w), norm="ortho"))


def equal_share(pos, vals, grid):
    """The share of the output pixels holding two samples or more whose samples are all equal."""
    w, h, _, ow, oh = grid
    pix = (pos[:, 1] // (h // oh)).astype(np.int64) * ow + pos[:, 0] // (w // ow)
    held, equal = 0, 0
    for p in np.unique(pix):
        v = vals[pix == p]
        if len(v) >= 2:
            held += 1
            equal += bool(np.all(v == v[0]))
    return equal / held if held else 0.0


def main():
    f = volume()
    idx, pos, vals = samples(f)
    peak = f.max()
    ref1 = reference(f.shape, idx, vals[:, 0].astype(np.float64), 1.0)
    base = csi.reconstruct(pos, vals, GRID, tau=TAU_REL, **PAPER)  # W = 1 given
    for W in (0.25, 4.0):
        want = reference(f.shape, idx, vals[:, 0].astype(np.float64), W)
        res = csi.reconstruct(pos, vals, GRID, tau=TAU_REL, **dict(PAPER, motion_still_weight=W))
        check_minimiser(res.frames[..., 0].astype(np.float64), want, ref1, peak, TOL, f"W = {W}", "weighted",
                        "unweighted")
    e0 = np.abs(base.frames[..., 0] - ref1).max() / peak
    check(e0 <= TOL, f"W = 1 given: {e0:.2e} from the float64 unweighted minimiser")
    # auto: decided by whether most pixels' samples agree exactly over t
    auto = {k: v for k, v in PAPER.items() if k != "motion_still_weight"}
    share = equal_share(pos, vals, GRID)
    check(share > 0.5, f"the test volume's pixels with equal samples: {share:.3f} of those holding two")
    half = csi.reconstruct(pos, vals, GRID, tau=TAU_REL, **dict(PAPER, motion_still_weight=0.5))
    got = csi.reconstruct(pos, vals, GRID, tau=TAU_REL, **auto)
    check(float(got.options["motion_still_weight"]) == 0.5 and np.array_equal(got.frames, half.frames)
          and np.array_equal(got.image, half.image),
          f"auto on exact still samples: weight {got.options['motion_still_weight']}, the bits of 0.5 given")
    rng = np.random.default_rng(7)
    noisy = (vals * (1 + 0.01 * rng.standard_normal(vals.shape))).astype(np.float32)
    check(equal_share(pos, noisy, GRID) == 0, "the noisy samples: no pixel's samples all equal")
    one = csi.reconstruct(pos, noisy, GRID, tau=TAU_REL, **PAPER)
    got = csi.reconstruct(pos, noisy, GRID, tau=TAU_REL, **auto)
    check(float(got.options["motion_still_weight"]) == 1 and np.array_equal(got.frames, one.frames),
          f"auto on noisy samples: weight {got.options['motion_still_weight']}, the bits of 1 given")
    # a time window takes the weight given (its tau from the whole's scale, as before)
    big = (N, N, 48, N, N)
    bpos = csi.positions(big, method="random", fraction=0.3, seed=2)
    bvals = np.ones((len(bpos), 1), np.float32)
    tile = csi.reconstruct_tile(bpos, bvals, big, 0, tiles=2, tiles_t=2, motion_still_weight=0.5, max_iter=5)
    check(float(tile.options["motion_still_weight"]) == 0.5,
          f"time window 0 of 2: weight {tile.options['motion_still_weight']} (0.5 given)")
    for bad in (-1, 2e6):
        try:
            csi.reconstruct(pos, vals, GRID, motion_still_weight=bad)
            check(False, f"W = {bad} refused")
        except csi.CsiError as ex:
            check("motion-still-weight" in str(ex), f"W = {bad} refused: {ex}")
    return done()


if __name__ == "__main__":
    sys.exit(main())
