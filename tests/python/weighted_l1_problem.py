"""The small weighted complex l1 problem the motion solve's weights are tested on
(test_motion_still_weight.py, test_motion_reweight.py): an 8 x 8 x 8 volume, half of its cells
sampled, the library's options that leave the solve alone, and a float64 reference solver.

min_x 0.5 ||y - S F^H x||^2 + sum_u thr_u |x_u| over the complex 3-D spectrum x (F the unitary
3-D DFT, numpy's fftn with norm="ortho"; S the sampled cells). The library's frames with the
paper's basis and every step after the solve switched off (no residual correction, no range
projection, no filter, no debiasing, one l1 weight unless a test gives another; PAPER) are Re(F^H x). The reference is FISTA (Beck &
Teboulle 2009) in float64 with the weighted complex soft threshold, step 1 (||S F^H|| <= 1), run
to a change below 1e-13: an independent solver of the same convex problem."""
import numpy as np
from checks import check

N = 8
T = 8
GRID = (N, N, T, N, N)
TAU_REL = 0.03
PAPER = dict(motion_velocity="none", motion_time="dft", motion_filter=-1, motion_resid_sigma=-1,
             correct="none", stop="gap", tol=1e-7, max_iter=20000, frames="on", motion_still_weight=1)


def volume():
    """A still texture (a few low modes and a 2-cell checker) with a bright square crossing it."""
    t, y, x = np.meshgrid(np.arange(T), np.arange(N), np.arange(N), indexing="ij")
    f = 0.5 + 0.2 * np.cos(2 * np.pi * x / N) + 0.1 * np.sin(2 * np.pi * 2 * y / N) + 0.08 * (((x // 2) + (y // 2)) % 2)
    sq = (np.abs(x - (1 + 0.75 * t)) < 1.5) & (np.abs(y - 4) < 1.5)
    return np.where(sq, 1.3, f)


def samples(f):
    """Half of the cells (seed 5): their flat indices, positions (x, y, t) and values."""
    rng = np.random.default_rng(5)
    idx = np.sort(rng.choice(f.size, f.size // 2, replace=False))
    t, r = np.divmod(idx, N * N)
    yy, xx = np.divmod(r, N)
    pos = np.stack([xx, yy, t], axis=1).astype(np.uint32)
    vals = f.reshape(-1)[idx].astype(np.float32)[:, None]
    return idx, pos, vals


def sampled(shape, idx, y):
    """The mask of sampled cells, the samples in place, and tau = TAU_REL ||F S^T y||_inf."""
    m = np.zeros(shape)
    m.flat[idx] = 1.0
    ys = np.zeros(shape)
    ys.flat[idx] = y
    return m, ys, TAU_REL * np.abs(np.fft.fftn(ys, norm="ortho")).max()


def fista(m, ys, thr):
    """The weighted minimiser x (float64) for the thresholds thr (a number or one per coefficient)."""
    x = np.zeros(m.shape, complex)
    z, tk = x.copy(), 1.0
    for _ in range(200000):
        r = m * np.fft.ifftn(z, norm="ortho") - ys  # S^T (S F^H z - y), complex (the imaginary part too)
        v = z - np.fft.fftn(r, norm="ortho")
        a = np.abs(v)
        xn = v * np.maximum(0.0, 1.0 - thr / np.maximum(a, 1e-300))
        tn = (1 + np.sqrt(1 + 4 * tk * tk)) / 2
        z = xn + (tk - 1) / tn * (xn - x)
        change = np.abs(xn - x).max()
        x, tk = xn, tn
        if change < 1e-13:
            break
    return x


def check_minimiser(got, want, other, peak, tol, label, name, other_name):
    """The library's frames `got` within tol of the peak from the reference minimiser's `want`,
    and that tolerance resolving the two problems: `want` and the other problem's minimiser
    `other` more than 5 tol apart, with the library nearer `want`."""
    e = np.abs(got - want).max() / peak
    apart = np.abs(want - other).max() / peak
    e1 = np.abs(got - other).max() / peak
    print(f"{label}: {e:.2e} from the {name}, {e1:.2e} from the {other_name} minimiser, they {apart:.2e} apart")
    check(e <= tol, f"{label}: the library's frames within {e:.2e} of the float64 {name} minimiser's "
          f"(tolerance {tol:g} of the peak)")
    check(apart > 5 * tol and e < e1, f"{label}: the {name} and {other_name} minimisers {apart:.2e} apart; "
          f"the library {e:.2e} from the {name}, {e1:.2e} from the {other_name}")
