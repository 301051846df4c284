"""Reweighted l1 in Alg. 2 (csi_recon_options.motion_reweight, host/integrate/motion_reweight.c;
Candes, Wakin & Boyd 2008; issue 12), against an independent numpy solve.

Problem, R re-solves: x_0 = argmin 0.5 ||y - S F^H x||^2 + tau ||x||_1 over the complex 3-D
spectrum x of an 8 x 8 x 8 volume (F the unitary 3-D DFT, numpy's fftn with norm="ortho"; S the
sampled cells, tau = tau_rel ||F S^T y||_inf), then x_r = the same with tau sum_u w_u |x_u|, the
weights from x_(r-1). The library solves on the half spectrum z (numpy's rfftn layout along x:
z = X on the planes u_x = 0 and u_x = n/2, z = 2 X between, so ||z||_1 = ||X||_1) with the
weight c / (|z_i| + eps) per half-spectrum coefficient, eps = eps_rel times the mean |z_i| over
its non-zero coefficients and c such that sum_i w_i |z_i| = sum_i |z_i|. In full-spectrum terms
the weight of X_u is c / (c_u |X_u| + eps), c_u = 2 between the two planes and 1 on them (so a
conjugate pair shares its weight, and the minimiser stays Hermitian), with the sums over the
coefficients the half spectrum stores. The library's frames with the paper's basis and every
step after the solve switched off are Re(F^H x_R). The reference is weighted_l1_problem.py's
float64 FISTA, its weights from its own previous minimiser: an independent solver of the same
chain of convex problems.

Checks, for R = 1 and R = 2 (eps_rel 1) and R = 1 with eps_rel 0.25:
1. the library's frames against the reference's: max |difference| <= 1e-4 of the volume's peak.
   SpaRSA stops on the duality gap at tol 1e-7 (the re-solves at a third of it), so each
   float32 minimiser is within a few 1e-6 of float64's, and the weights carry that into the next
   problem: measured 5e-7 to 3e-6 of the peak here (test_motion_still_weight.py: 3e-7 to 3e-6
   for one weighted solve); 1e-4 leaves a factor of 30 for other float32 orderings (devices,
   FFT plans) and stays far below check 2's distances.
2. the reweighting matters at that tolerance: the reference's reweighted and plain minimisers
   differ by more than 5x the tolerance, and the library is nearer the reweighted one.
3. R = 0 given is the default's bits; the result's options report R and eps.
4. bad input: R < 0 or above 16, eps <= 0 are refused with a message naming the option.
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


def weights(x, eps_rel):
    """The half spectrum's weights c / (|z| + eps) on the full spectrum x (axis 2 is x)."""
    cu = np.full(x.shape, 2.0)
    cu[..., 0] = cu[..., N // 2] = 1.0
    a = cu * np.abs(x)  # |z| of the stored coefficient, or of the one a mirror coefficient pairs with
    half = np.zeros(x.shape, bool)
    half[..., : N // 2 + 1] = True  # u_x = 0 .. n/2: the coefficients the half spectrum stores
    l1 = np.abs(x).sum()  # = ||z||_1
    eps = eps_rel * l1 / np.count_nonzero((a > 1e-12 * a.max()) & half)
    c = l1 / np.sum((a / (a + eps))[half])
    return c / (a + eps)


def reference(shape, idx, y, resolves, eps_rel):
    """The frames Re(F^H x) of the plain minimiser (resolves 0) or of the last re-solve's."""
    m, ys, tau = sampled(shape, idx, y)
    x = fista(m, ys, tau)
    for _ in range(resolves):
        x = fista(m, ys, tau * weights(x, eps_rel))
    return np.real(np.fft.ifftn(x, norm="ortho"))


def main():
    f = volume()
    idx, pos, vals = samples(f)
    y64 = vals[:, 0].astype(np.float64)
    peak = f.max()
    plain = reference(f.shape, idx, y64, 0, 1.0)
    base = csi.reconstruct(pos, vals, GRID, tau=TAU_REL, **PAPER)
    for R, eps_rel in ((1, 1.0), (2, 1.0), (1, 0.25)):
        want = reference(f.shape, idx, y64, R, eps_rel)
        res = csi.reconstruct(pos, vals, GRID, tau=TAU_REL, motion_reweight=R, motion_reweight_eps=eps_rel, **PAPER)
        check_minimiser(res.frames[..., 0].astype(np.float64), want, plain, peak, TOL, f"R = {R}, eps {eps_rel}",
                        "reweighted", "plain")
        check(int(res.options["motion_reweight"]) == R and float(res.options["motion_reweight_eps"]) == eps_rel,
              f"options report {res.options['motion_reweight']} re-solves, eps {res.options['motion_reweight_eps']}")
    e0 = np.abs(base.frames[..., 0] - plain).max() / peak
    check(e0 <= TOL, f"R = 0 (the default): {e0:.2e} from the float64 plain minimiser")
    same = csi.reconstruct(pos, vals, GRID, tau=TAU_REL, motion_reweight=0, **PAPER)
    check(np.array_equal(same.frames, base.frames) and np.array_equal(same.image, base.image),
          "R = 0 given: the default's bits")
    for name, bad in (("motion_reweight", -1), ("motion_reweight", 17), ("motion_reweight_eps", 0),
                      ("motion_reweight_eps", -1)):
        try:
            csi.reconstruct(pos, vals, GRID, **{name: bad})
            check(False, f"{name} = {bad} refused")
        except csi.CsiError as ex:
            check(name.replace("_", "-") in str(ex), f"{name} = {bad} refused: {ex}")
    return done()


if __name__ == "__main__":
    sys.exit(main())
