"""The frames of a volume of noisy samples (csi/frames_denoise.h), checked against the rule written
again here in numpy (double) and for what the library promises around it:

- the rule: csi's frames with the step are the fit's frames (the step off) taken through the
  documented rule in numpy: each sampled cell D + k (ybar - D) with D its unsampled 8
  neighbours' mean and k = v / (v + s^2 / m), then the Gaussian (along t on the path of the
  basis's velocity, bilinear, then along x and y, cut at the volume's sides) of the width whose
  smoothing of two folds' frames (the samples split by a hash of their cell, each half's
  channels' mean solved here by csi.reconstruct as one channel, to at most twice the whole
  solve's steps, and taken through the same D + k step) predicts the other half's channels'
  means best (and the folds solve one channel: their progress says so); to float32 rounding, and the same width chosen (the stats' frames_sigma_xy /
  _t), on a volume with one path's noise (the level's size: a smoothing is chosen), with a third
  of it, and on a pan (the basis's velocity found: the smoothing along t follows it); below a
  fifth of the level the step is off;
- the blurred image with the step is the average of the image without it and the mean over t of
  the step's frames (image_frames, csi/frames_denoise.h), to float32 rounding, the same bits
  whether the frames are asked for or not; with image_frames off, the same bits as without the
  step; image_frames on is refused with the step off, and below the step's floor turns it on and
  averages the same way;
- the point of it: on that volume the frames are closer to the noise-free truth with it than
  without it, by 30% or more in MSE (about half measured; on Mitsuba's animations:
  docs/bench/animation.md, session 32);
- non-negative samples (one path's exponential noise) give non-negative frames;
- auto: without variances the step is off (the options say so) and the frames are those of
  "off"; on a grid of 2 x 2 cells per pixel nothing changes either;
- tiles: time windows and x/y tiles made one at a time (csi.reconstruct_tile) and merged give
  the in-process tiled frames and image bit for bit (the image also from tiles made without
  their frames asked for), and there too the step brings the frames closer to the truth (by 30%
  or more); the tiled image is the average of the step-off tiled image and the tiled frames'
  mean, to float32 rounding (x/y tiles average each window's image, and the blend is linear;
  time windows give the blend their share of the frames' mean, averaged with after the whole
  shutter's correction), and with image_frames off it is the step-off image's bits;
- csi-reconstruct names both options in --help."""
import os
import subprocess
import sys
import tempfile

import numpy as np

SOURCE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BUILD = os.environ.get("CSI_BUILD_DIR") or os.path.join(SOURCE, "build")
sys.path.insert(0, os.path.join(SOURCE, "host", "python"))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import csi  # noqa: E402
from checks import check, done  # noqa: E402

W, H, T = 40, 40, 32
GRID = (W, H, T, W, H)
# The widths the rule chooses from (sigma_xy, sigma_t), in the library's order.
WIDTHS = [(0.0, 0.0)] + [(s, t) for s in (0.5, 0.75, 1.0, 1.5) for t in (0.0, 0.5, 1.0, 1.5)]


def truth():
    y, x = np.mgrid[0:H, 0:W] + 0.5
    still = 0.4 + 0.25 * np.sin(2 * np.pi * x / 17) * np.cos(2 * np.pi * y / 13)
    f = np.empty((T, H, W))
    for t in range(T):
        f[t] = np.where((x - (8 + 0.75 * t)) ** 2 + (y - 20) ** 2 < 30, 1.5, still)
    return np.stack([f, 0.5 * f, 2 * f], axis=-1)  # (T, H, W, 3)


def gauss_taps(sigma):
    if sigma == 0:
        return np.ones(1)
    r = int(np.ceil(3 * sigma))
    d = np.arange(-r, r + 1)
    return np.exp(-d * d / (2 * sigma * sigma))


def bilinear(img, yf, xf):
    """img (H, W) at the points (yf, xf), and the weight of the taps inside it (taps of weight 0
    left out)."""
    y0, x0 = np.floor(yf).astype(np.int64), np.floor(xf).astype(np.int64)
    fy, fx = yf - y0, xf - x0
    val, cover = 0.0, 0.0
    for dy, wy in ((0, 1 - fy), (1, fy)):
        for dx, wx in ((0, 1 - fx), (1, fx)):
            yy, xx = y0 + dy, x0 + dx
            w = np.where((wy * wx > 0) & (yy >= 0) & (yy < img.shape[0]) & (xx >= 0) & (xx < img.shape[1]), wy * wx, 0.0)
            val = val + w * img[np.clip(yy, 0, img.shape[0] - 1), np.clip(xx, 0, img.shape[1] - 1)]
            cover = cover + w
    return val, cover


def smooth_t(v, st, vel):
    """v (T, H, W) through a Gaussian along t on the path of velocity vel (cells per frame),
    bilinear between cells, cut at the ends and renormalised by the taps' weight inside."""
    if st == 0:
        return v
    k = gauss_taps(st)
    r = len(k) // 2
    yy, xx = np.mgrid[0:H, 0:W].astype(np.float64)
    out = np.empty_like(v)
    for t in range(T):
        num, den = np.zeros((H, W)), np.zeros((H, W))
        for j, g in enumerate(k):
            d = j - r
            if 0 <= t + d < T:
                val, cover = bilinear(v[t + d], yy + vel[1] * d, xx + vel[0] * d)
                num += g * val
                den += g * cover
        out[t] = num / den
    return out


def smooth(v, sxy, st, vel):
    """v (T, H, W) along t on the velocity's path, then along y and x, each cut at the ends and
    renormalised."""
    out = smooth_t(v, st, vel)
    for ax, sigma in ((1, sxy), (2, sxy)):
        if sigma == 0:
            continue
        k = gauss_taps(sigma)
        r = len(k) // 2
        n = v.shape[ax]
        num, den = np.zeros_like(out), np.zeros(n)
        for j, w in enumerate(k):
            d = j - r
            lo, hi = max(0, -d), min(n, n - d)
            dst, src = [slice(None)] * 3, [slice(None)] * 3
            dst[ax], src[ax] = slice(lo, hi), slice(lo + d, hi + d)
            num[tuple(dst)] += w * out[tuple(src)]
            den[lo:hi] += w
        shape = [1, 1, 1]
        shape[ax] = n
        out = num / den.reshape(shape)
    return out


def cells_step(frames, pos, val, noise):
    """Step 1 on frames (T, H, W, C) with the samples (pos, val): each sampled cell D + k (ybar - D)."""
    t, y, x = (pos[:, i].astype(np.int64) for i in (2, 1, 0))
    cnt = np.zeros((T, H, W))
    np.add.at(cnt, (t, y, x), 1)
    sampled = cnt > 0
    free = np.pad((~sampled).astype(np.float64), ((0, 0), (1, 1), (1, 1)))
    ring = [(dy, dx) for dy in (-1, 0, 1) for dx in (-1, 0, 1) if dy or dx]
    nfree = sum(free[:, 1 + dy:1 + dy + H, 1 + dx:1 + dx + W] for dy, dx in ring)
    P = frames.astype(np.float64).copy()
    for c in range(frames.shape[-1]):
        f = frames[..., c].astype(np.float64)
        fp = np.pad(f, ((0, 0), (1, 1), (1, 1))) * free
        acc = sum(fp[:, 1 + dy:1 + dy + H, 1 + dx:1 + dx + W] for dy, dx in ring)
        D = np.where(nfree > 0, acc / np.maximum(nfree, 1), f)[sampled]
        ysum = np.zeros((T, H, W))
        np.add.at(ysum, (t, y, x), val[:, c].astype(np.float64))
        m = cnt[sampled]
        ybar = ysum[sampled] / m
        s2 = (noise[c] * np.abs(val[:, c].astype(np.float64)).mean()) ** 2
        v = max(float(np.mean((ybar - D) ** 2 - s2 / m)), 0.0)
        k = v / (v + s2 / m)
        P[..., c][sampled] = D + k * (ybar - D)
    return P


def fold_of(pos):
    """The fold of each sample: splitmix64's finaliser of its cell's index (+ the golden ratio), low bit."""
    cell = ((pos[:, 2].astype(np.uint64) * np.uint64(H) + pos[:, 1]) * np.uint64(W) + pos[:, 0]).astype(np.uint64)
    with np.errstate(over="ignore"):
        z = cell + np.uint64(0x9E3779B97F4A7C15)
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        z = z ^ (z >> np.uint64(31))
    return (z & np.uint64(1)).astype(np.int64), cell


def rule(frames, pos, val, var, vel, steps):
    """The documented step on the fit's frames (T, H, W, C), its two folds solved here through
    csi.reconstruct as one channel, the samples' channels' mean (its variance the square of the
    channels' mean standard deviation), each to at most `steps` steps: (frames, (sigma_xy, sigma_t))."""
    noise = [np.sqrt(var[:, c].astype(np.float64).mean()) / np.abs(val[:, c].astype(np.float64)).mean()
             for c in range(val.shape[1])]
    v64 = val.astype(np.float64)
    mean = (v64.sum(axis=1) / val.shape[1]).astype(np.float32)[:, None]
    sd = np.sqrt(var.astype(np.float64)).sum(axis=1) / val.shape[1]
    mean_var = (sd * sd).astype(np.float32)[:, None]
    # the mean's noise relative to its level: the channels' absolute noise averaged, over mean |mean|
    mean_noise = sum(noise[c] * np.abs(v64[:, c]).mean() for c in range(val.shape[1])) / val.shape[1] / \
        np.abs(v64.sum(axis=1) / val.shape[1]).mean()
    fold, cell = fold_of(pos)
    errs = np.zeros(len(WIDTHS))
    for f in (0, 1):
        mine = np.nonzero(fold == f)[0]
        mine = mine[np.lexsort((mine, cell[mine]))]  # by cell, then index: the library's order
        other = np.nonzero(fold != f)[0]
        r = csi.reconstruct(pos[mine], mean[mine], GRID, frames="on", variance=mean_var[mine], frames_denoise="off",
                            motion_image_cv="off", max_iter=steps)
        fv = (float(r.options["motion_vx"]), float(r.options["motion_vy"]))
        P = cells_step(r.frames, pos[mine], mean[mine], [mean_noise])
        t, y, x = (pos[other][:, i].astype(np.int64) for i in (2, 1, 0))
        for j, w in enumerate(WIDTHS):
            errs[j] += float(np.sum((smooth(P[..., 0], *w, fv)[t, y, x] - mean[other][:, 0]) ** 2))
    best = WIDTHS[int(np.argmin(errs))]
    P = cells_step(frames, pos, val, noise)
    return np.stack([smooth(P[..., c], *best, vel) for c in range(frames.shape[-1])], axis=-1), best


def pan():
    """A texture sliding 0.8 cells per frame to the right (a camera pan): csi's basis follows it."""
    y, x = np.mgrid[0:H, 0:W] + 0.5
    f = np.stack([0.5 + 0.3 * np.sin(2 * np.pi * (x - 0.8 * t) / 11) * np.cos(2 * np.pi * y / 9) for t in range(T)])
    return np.stack([f, 0.7 * f, 1.3 * f], axis=-1)


F = truth()
pos = csi.positions(GRID, method="random", seed=5, fraction=0.2)
for label, vol, rel, want_smoothing in (("one path's noise", F, (1.0, 0.9, 1.1), True),
                                        ("a third of the level", F, (0.33,) * 3, None),
                                        ("a pan, a third of the level", pan(), (0.33,) * 3, None),
                                        ("a tenth of the level (below the step's floor)", F, (0.1,) * 3, None)):
    clean = vol[pos[:, 2], pos[:, 1], pos[:, 0]]
    rng = np.random.default_rng(11)
    sd = np.array(rel) * np.abs(clean).mean(axis=0)
    val = (clean + sd * rng.standard_normal(clean.shape)).astype(np.float32)
    var = np.broadcast_to((sd ** 2).astype(np.float32), val.shape).copy()
    off = csi.reconstruct(pos, val, GRID, frames="on", variance=var, frames_denoise="off")
    on = csi.reconstruct(pos, val, GRID, frames="on", variance=var)
    if rel[0] < 0.2:
        check(on.options["frames_denoise"] == "off" and np.array_equal(on.frames, off.frames),
              f"{label}: auto is off ({on.options['frames_denoise']}), the frames those of off")
        continue
    check(on.options["frames_denoise"] == "on" and on.options["image_frames"] == "on",
          f"{label}: auto is on with variances ({on.options['frames_denoise']}, {on.options['image_frames']})")
    noimg = csi.reconstruct(pos, val, GRID, frames="on", variance=var, image_frames="off")
    alone = csi.reconstruct(pos, val, GRID, variance=var)
    vel = (float(off.options["motion_vx"]), float(off.options["motion_vy"]))
    if vol is not F:
        check(abs(vel[0] - 0.8) < 0.1 and abs(vel[1]) < 0.1, f"{label}: the basis follows the pan ({vel})")
    # the folds' step cap: twice the whole solve's steps (its largest channel's), 20 to its own cap
    steps = min(max(2 * max(rep["iterations"] for rep in off.reports), 20), int(off.options["max_iter"]))
    want, width = rule(off.frames, pos, val, var, vel, steps)
    if vol is F and rel[0] == 1.0:  # the folds solve one channel: their progress says "solve 1/1"
        phases = set()
        csi.reconstruct(pos, val, GRID, variance=var, frames="on", progress=lambda p, i, r: phases.add(p))
        folds = sorted(p for p in phases if p.startswith("frames fold") and " solve" in p)
        check(folds == ["frames fold 1 solve 1/1", "frames fold 2 solve 1/1"] and "solve 3/3" in phases,
              f"{label}: the folds solve one channel, the whole three ({folds})")
    got = (on.stats.get("frames_sigma_xy"), on.stats.get("frames_sigma_t"))
    check(got == width, f"{label}: the width chosen {got}, the rule's {width}")
    err = float(np.abs(on.frames - want).max())
    check(err <= 1e-5 * float(np.abs(want).max()), f"{label}: frames against the rule in numpy, max difference {err:.3g}")
    check(np.array_equal(noimg.image, off.image), f"{label}: image_frames off: the image is the same bits with the step")
    avg = 0.5 * (off.image.astype(np.float64) + on.frames.astype(np.float64).mean(axis=0))
    err = float(np.abs(on.image - avg).max())
    check(err <= 1e-6 * float(np.abs(avg).max()), f"{label}: the image against the average with the frames' mean, {err:.3g}")
    check(np.array_equal(on.image, alone.image) and alone.frames is None,
          f"{label}: the image is the same bits without the frames asked for")
    if want_smoothing:
        check(width != (0.0, 0.0), f"{label}: a smoothing is chosen ({width})")
        for c in range(3):
            e0 = float(np.mean((off.frames[..., c] - F[..., c]) ** 2))
            e1 = float(np.mean((on.frames[..., c] - F[..., c]) ** 2))
            check(e1 < 0.7 * e0, f"{label}, channel {c}: frames MSE with the step {e1:.4e}, without {e0:.4e}")

# Non-negative samples (each a unit-mean exponential times the truth: a path tracer's one-path
# noise, about the level's size) give non-negative frames: step 1 is a convex combination of
# the neighbours' and the samples' values, step 2 a mean with positive weights.
clean = F[pos[:, 2], pos[:, 1], pos[:, 0]]
val = (clean * np.random.default_rng(13).exponential(1.0, clean.shape)).astype(np.float32)
var = np.broadcast_to((clean ** 2).mean(axis=0).astype(np.float32), val.shape).copy()
on = csi.reconstruct(pos, val, GRID, frames="on", variance=var)
check(on.options["frames_denoise"] == "on" and on.frames.min() >= 0,
      f"non-negative samples: the frames' least value {on.frames.min():.4g} ({on.options['frames_denoise']})")

plain = csi.reconstruct(pos, val, GRID, frames="on")
plain_off = csi.reconstruct(pos, val, GRID, frames="on", frames_denoise="off")
check(plain.options["frames_denoise"] == "off" and np.array_equal(plain.frames, plain_off.frames),
      f"without variances auto is off ({plain.options['frames_denoise']}) and the frames are those of off")

GRID2 = (2 * W, 2 * H, T, W, H)
pos2 = csi.positions(GRID2, method="random", seed=6, fraction=0.05)
val2 = (np.repeat(np.repeat(F, 2, axis=1), 2, axis=2)[pos2[:, 2], pos2[:, 1], pos2[:, 0]] +
        0.3 * np.random.default_rng(3).standard_normal((len(pos2), 3))).astype(np.float32)
var2 = np.full(val2.shape, 0.09, np.float32)
a = csi.reconstruct(pos2, val2, GRID2, frames="on", variance=var2)
b = csi.reconstruct(pos2, val2, GRID2, frames="on", variance=var2, frames_denoise="off")
check(np.array_equal(a.frames, b.frames), "2 x 2 cells per pixel: the frames as the fit gave them")

# tiles, on the volume with one path's noise
clean = F[pos[:, 2], pos[:, 1], pos[:, 0]]
rng = np.random.default_rng(11)
sd = np.array((1.0, 0.9, 1.1)) * np.abs(clean).mean(axis=0)
val = (clean + sd * rng.standard_normal(clean.shape)).astype(np.float32)
var = np.broadcast_to((sd ** 2).astype(np.float32), val.shape).copy()
with tempfile.TemporaryDirectory() as d:
    for topts, count in ((dict(tiles_t=2), 2), (dict(tiles=4, tiles_t=1, tile_margin=8), 4)):
        tiled = csi.reconstruct(pos, val, GRID, frames="on", variance=var, **topts)
        tiled_off = csi.reconstruct(pos, val, GRID, frames="on", variance=var, frames_denoise="off", **topts)
        check(tiled.info["tiles"] == count, f"{topts}: {tiled.info['tiles']} tiles")
        parts = []
        for i in reversed(range(count)):
            t = csi.reconstruct_tile(pos, val, GRID, i, variance=var, frames="on", **topts)
            parts.append(os.path.join(d, f"t{i}.csip"))
            t.write_partial(parts[-1], "s.csid")
        m = csi.merge_partials(parts, frames=True)
        check(np.array_equal(m.frames, tiled.frames), f"{topts}: frames of tiles made one at a time = in process")
        check(np.array_equal(m.image, tiled.image), f"{topts}: the image of tiles made one at a time = in process")
        # tiles made without their frames asked for: the same image (each makes its frames for it)
        bare = []
        for i in range(count):
            t = csi.reconstruct_tile(pos, val, GRID, i, variance=var, **topts)
            bare.append(os.path.join(d, f"b{i}.csip"))
            t.write_partial(bare[-1], "s.csid")
        check(np.array_equal(csi.merge_partials(bare).image, tiled.image),
              f"{topts}: tiles made without frames give the same image")
        check(tiled.options["image_frames"] == "on", f"{topts}: image_frames {tiled.options['image_frames']}")
        # the blended frames' mean differs from the mean of the blended frames by float32 rounding
        avg = 0.5 * (tiled_off.image.astype(np.float64) + tiled.frames.astype(np.float64).mean(axis=0))
        err = float(np.abs(tiled.image - avg).max())
        check(err <= 1e-5 * float(np.abs(avg).max()),
              f"{topts}: the tiled image against the average with the frames' mean, {err:.3g}")
        if_off = csi.reconstruct(pos, val, GRID, variance=var, image_frames="off", **topts)
        check(np.array_equal(if_off.image, tiled_off.image), f"{topts}: image_frames off, the step-off image's bits")
        e0 = float(np.mean((tiled_off.frames - F) ** 2))
        e1 = float(np.mean((tiled.frames - F) ** 2))
        check(e1 < 0.7 * e0, f"{topts}: tiled frames MSE with the step {e1:.4e}, without {e0:.4e}")

# image_frames on averages with the denoised frames: refused with the step off, and on its own it
# turns the step on (auto) even where the samples' noise is below its floor
try:
    csi.reconstruct(pos, val, GRID, variance=var, image_frames="on", frames_denoise="off")
    check(False, "image_frames on with frames_denoise off: accepted")
except csi.CsiError as e:
    check("frames-denoise off" in str(e), f"image_frames on with frames_denoise off: {e}")
quiet = (clean + 0.05 * np.abs(clean).mean(axis=0) * np.random.default_rng(3).standard_normal(clean.shape)).astype(np.float32)
qvar = np.broadcast_to((0.05 * np.abs(clean).mean(axis=0)) ** 2, quiet.shape).astype(np.float32).copy()
q_auto = csi.reconstruct(pos, quiet, GRID, variance=qvar)
q_on = csi.reconstruct(pos, quiet, GRID, variance=qvar, image_frames="on", frames="on")
check(q_auto.options["image_frames"] == "off" and q_on.options["frames_denoise"] == "on",
      f"below the floor: auto {q_auto.options['image_frames']}; on turns the step {q_on.options['frames_denoise']}")
q_off = csi.reconstruct(pos, quiet, GRID, variance=qvar, frames="on", frames_denoise="on")
avg = 0.5 * (q_auto.image.astype(np.float64) + q_off.frames.astype(np.float64).mean(axis=0))
check(float(np.abs(q_on.image - avg).max()) <= 1e-6 * float(np.abs(avg).max()),
      "image_frames on below the floor: the average with the step's frames")

h = subprocess.run([os.path.join(BUILD, "csi-reconstruct"), "--help"], capture_output=True, text=True)
check("--frames-denoise" in h.stdout and "--image-frames" in h.stdout,
      "csi-reconstruct --help names --frames-denoise and --image-frames")

sys.exit(done())
