"""csi-mitsuba: renders a Mitsuba 3 scene at csi's sample positions and reconstructs it (see --help)."""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
import tempfile
import time

from . import dump as csid
from . import exr
from . import mitsuba_bridge as mb
from . import programs
from ._argv import unknown_option
from ._lib import CsiError

PROG = "csi-mitsuba"

DESCRIPTION = """\
Renders SCENE with Mitsuba 3 (llvm_ad_rgb, the scene's own sensor and integrator) at exactly
the fine-grid cell centres csi asks for (the grid and positions csi-positions and csi-render
would use for the same size, spp and seed), N paths per sample averaged, and reconstructs the
image with csi's library in the same process (the bits of csi-reconstruct on the dump). An
image then gets a second pass (--refine, the default): every cell of the few pixels csi cannot
decide is rendered too, and those pixels take the mean of all their samples. With
--reference it renders Mitsuba's own box-filtered image instead (the film's reconstruction
filter set to a box: pixel (px, py) is the mean over [px, px+1) x [py, py+1), csi's output
pixel), the ground truth to compare with.

SCENE is 'cornell' (Mitsuba's built-in Cornell box), a Mitsuba XML scene file, or a Python file
defining scene() that returns a Mitsuba scene dictionary (such as data/mitsuba/*.py).
Arguments after '--' are csi-reconstruct's reconstruction options (e.g. -- --estimator mean;
also --seed and --device)."""

EPILOG = """\
examples:
  csi-mitsuba cornell --out 128x128 --spp 4 -o cornell.exr --dump cornell.csid
  csi-mitsuba scene.xml --spp 4 --paths 64 --no-refine -o out.exr --dump exact_spp.csid
  csi-mitsuba scene.xml --spp 4 --paths 64 -o out.exr -- --estimator mean
  csi-mitsuba cornell --out 128x128 --reference 4096 -o ref.exr
  csi-positions --out 128x128 --spp 4 -o req.csid && csi-mitsuba cornell --request req.csid --dump s.csid
exit status: 0 success, 2 bad input or usage, 1 other failure"""


class UsageError(Exception):
    pass


class Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit 2 (argparse prints usage + error otherwise)
        raise UsageError(message)


def _size(s):
    try:
        w, h = (int(v) for v in s.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{s}' is not a size WxH") from None
    if not (1 <= w <= csid.MAX_SIDE and 1 <= h <= csid.MAX_SIDE):
        raise argparse.ArgumentTypeError(f"'{s}' is not a size from 1x1 to {csid.MAX_SIDE}x{csid.MAX_SIDE}")
    return (w, h)


def _int_range(lo, hi):
    def parse(s):
        try:
            v = int(s)
        except ValueError:
            raise argparse.ArgumentTypeError(f"'{s}' is not a whole number") from None
        if not lo <= v <= hi:
            raise argparse.ArgumentTypeError(f"'{s}' is not from {lo} to {hi}")
        return v
    return parse


def parser():
    p = Parser(prog=PROG, description=DESCRIPTION, epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("scene", metavar="SCENE")
    o = p.add_argument_group("outputs")
    o.add_argument("-o", "--output", metavar="OUT.exr", help="the reconstructed image (float32 EXR; with --reference: Mitsuba's reference)")
    o.add_argument("--png", metavar="OUT.png", help="8-bit sRGB preview of the reconstruction (with --reference: of the "
                   "reference)")
    o.add_argument("--frames", metavar="DIR", help="an animation's frames (--time-steps above 1): DIR/frame_NNNN.exr "
                   "and .png, as csi-reconstruct --frames writes them; with --reference, the reference's frames")
    o.add_argument("--dump", metavar="FILE.csid", help="the samples as a csi dump (docs/dump-format.md); with --paths above 1 "
                   "also their variances, FILE.variance.csid (csi-reconstruct --variance)")
    o.add_argument("--aov", action="store_true", help="with --dump: also per-sample albedo and normal at the first hit, "
                   "FILE.albedo.csid and FILE.normal.csid (OIDN's guides)")
    o.add_argument("--npy", metavar="FILE.npy", help="with --reference: the reference as an (h, w, 3) float32 numpy array too")
    o.add_argument("--stats", metavar="FILE.json", help="grid, Mitsuba's times (JIT apart, per sample, per path) and "
                   "the reconstruction's statistics")
    s = p.add_argument_group("sampling")
    s.add_argument("--out", type=_size, metavar="WxH", help="output image size (default: the scene film's)")
    s.add_argument("--spp", type=_int_range(1, 65536), default=4, help="samples per pixel (default 4)")
    s.add_argument("--paths", type=_int_range(1, 1 << 20), default=1, help="Mitsuba paths per sample, averaged (default 1)")
    s.add_argument("--variance-peaks", action=argparse.BooleanOptionalAction, default=None,
                   help="reconstruct with each sample's variance (csi-reconstruct --variance, which takes the "
                        "X.variance.csid beside a dump by default): an isolated bright sample its own noise explains "
                        "is shrunk by how much of it that noise explains, and an animation's solve regularises "
                        "as much as the samples' noise asks (with one path per sample, one path's variance is "
                        "estimated from a second path through one cell in 16, at most 1024). Default: on with "
                        "--paths above 1 or --time-steps above 1 (docs/bench/mitsuba.md, docs/bench/animation.md)")
    s.add_argument("--grid", type=_int_range(1, csid.MAX_SIDE), metavar="K",
                   help="fine-grid width in cells (default: csi's rule, see csi-positions --help; an "
                        "animation whose camera moves keeps the image's width, as csi-render does, "
                        "except a camera translating across its view, which takes a still camera's)")
    s.add_argument("--method", choices=("poisson", "stratified", "random"), default="poisson",
                   help="positions (default poisson, the compressive method's)")
    s.add_argument("--time-steps", type=_int_range(1, 4096), default=1, metavar="T",
                   help="frames across the shutter (default 1: a static image)")
    s.add_argument("--seed", type=_int_range(0, (1 << 64) - 1), default=1, help="seed of the positions and of Mitsuba's sampler (default 1)")
    s.add_argument("--request", metavar="REQ.csid", help="evaluate this positions request (csi-positions) instead; "
                   "the size, grid and positions are its own")
    s.add_argument("--refine", action=argparse.BooleanOptionalAction, default=None,
                   help="a second pass: every cell of the pixels csi cannot decide (where its image and the "
                        "pixel's mean disagree by a large share of their disagreement over the image: an HDR "
                        "highlight one of a pixel's few samples hit; about 2%% more samples) is rendered too, "
                        "and those pixels take the mean of all their samples; with --paths above 1 the pixels "
                        "that still decide the image then settle on their samples' mean ('-- --settle off': "
                        "not) and an HDR step's pixels take the coverage their window's samples allow "
                        "('-- --step-coverage off': not) (csi-reconstruct --refine-request, --refine-with; --dump writes all the samples; "
                        "docs/bench/mitsuba.md). Default: on "
                        "for an image reconstructed by csi; off with --request, --time-steps above 1 or "
                        "-- --estimator mean|gauss; --no-refine samples exactly --spp per pixel")
    s.add_argument("--refine-share", type=float, metavar="S",
                   help="with --refine: the share, 0 < S <= 1 (default 0.005)")
    s.add_argument("--refine-passes", type=_int_range(1, 16), metavar="N",
                   help="with --refine: passes after the first (default 1). Each picks again on all the samples "
                        "so far and the patched image, which settles a pixel that an earlier pick left just under "
                        "the share: a few %% more samples for a lower error, but more images a hair above the mean "
                        "of the same samples (docs/bench/mitsuba.md, session 21)")
    s.add_argument("--reference", type=_int_range(1, 1 << 20), metavar="SPP", help="render Mitsuba's box-filtered reference "
                   "with SPP samples per pixel instead of samples; of an animation with --time-steps T, its motion "
                   "blur: the mean of T frames posed at (t + 0.5) / T, ceil(SPP / T) samples a pixel each")
    s.add_argument("--sensor", metavar="ID|N", help="which of the scene's sensors renders: its id, or its index in "
                   "declaration order from 0 (as mi.render counts; digits alone are an index); default: the first")
    s.add_argument("-D", "--define", action="append", default=[], metavar="NAME=VALUE",
                   help="the value of an XML scene's $NAME parameter (as mitsuba -D; repeatable)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress or summary on stderr, and none of "
                   "Mitsuba's own warnings (csi-mitsuba's warnings about the samples are still said)")
    return p


class _Progress:
    def __init__(self, quiet):
        self.on = not quiet and sys.stderr.isatty()
        self.solves = _SolveClock()

    def __call__(self, phase, done, total):
        if self.on:
            sys.stderr.write(f"\r{PROG}: {phase} {done}/{total}   ")
            sys.stderr.flush()

    def reconstruction(self, phase, iteration, residual):
        """csi.reconstruct's progress callback: the library's phase, the solver's step and, once a
        channel's solve is done, the time left."""
        if self.on:
            left = self.solves.update(phase, time.perf_counter())
            step = f"  step {iteration}" if iteration > 0 else ""
            eta = f"  eta {left:.0f}s" if left is not None else ""
            sys.stderr.write(f"\r\033[K{PROG}: reconstruction: {phase}{step}{eta}")
            sys.stderr.flush()

    def end(self):
        if self.on:
            sys.stderr.write("\r\033[K")


class _SolveClock:
    """The time left in a reconstruction, as csi-reconstruct's progress line estimates it
    (host/cli/common_eta.c): the library's phases "solve c/C", each after "tile t/T " in a tiled
    run, are T x C solves one after another, the solve of channel c in tile t the ((t - 1) C + c)-th;
    the cross-validated choice's folds ("solve 1/1" after a tile's channels) are never past the
    current one and are not counted. The time left: the mean time of the solves done so far, what
    happens between them included, times those left, less what the current one has taken."""

    def __init__(self):
        self.unit = self.units = 0
        self.t_first = self.t_current = 0.0

    def update(self, phase, now):
        """Seconds left after `phase` began or went on at `now`; None before a solve is done."""
        m = re.match(r"(?:tile (\d+)/(\d+) )?solve (\d+)/(\d+)", phase)
        if m:
            t, nt = (int(m[1]), int(m[2])) if m[1] else (1, 1)
            c, nc = int(m[3]), int(m[4])
            u = (t - 1) * nc + c
            if 1 <= c <= nc and 1 <= t <= nt and u > self.unit:
                if self.unit == 0:
                    self.t_first = now
                self.unit, self.units, self.t_current = u, nt * nc, now
        done = self.unit - 1
        if done < 1:
            return None
        per = (self.t_current - self.t_first) / done
        return max(per * (self.units - done) - (now - self.t_current), 0.0)


def reconstruction_options(args):
    """csi-reconstruct's reconstruction arguments (the words after '--': --name VALUE, a flag
    alone, --name=VALUE; --seed S and --device NAME too) as csi.reconstruct keywords and a
    device name (None: the default device)."""
    import csi

    kinds = {o["name"]: o["kind"] for o in csi.options()}
    probe = csi.Options()  # each value checked as the library reads it
    kw, device, i = {}, None, 0
    while i < len(args):
        word = args[i]
        name, eq, value = word[2:].partition("=") if word.startswith("--") else ("", "", "")
        if name not in kinds and name != "device":
            raise UsageError(f"'{word}' after '--' is not one of csi-reconstruct's reconstruction options "
                             f"(see csi-reconstruct --help)")
        if name == "frames":  # an output, not a reconstruction option: the table holds it for the library's callers
            raise UsageError(f"'{word}' after '--': the frames are an output, csi-mitsuba's own --frames DIR")
        if kinds.get(name) == "flag" and not eq:
            value = "on"
        elif not eq:
            if i + 1 >= len(args):
                raise UsageError(f"'{word}' after '--' needs a value")
            i += 1
            value = args[i]
        if name == "device":
            device = value
        else:
            try:
                probe.set(name, value)
            except csi.CsiError as e:
                raise UsageError(f"--{e}") from None  # "--lambda: 'abc' is not ...", as csi-reconstruct says
            kw[name.replace("-", "_")] = value
        i += 1
    return kw, device


def reconstruct(d: csid.Dump, output, png=None, extra=(), variance=None, progress=None, frame_paths=None):
    """reconstruct_result, then its image written to output (EXR) and png, and with frame_paths
    (one (EXR, PNG) pair of paths per frame) the volume's frames; returns the statistics."""
    import csi

    t0 = time.perf_counter()
    res = reconstruct_result(d, extra, variance, progress, frames=bool(frame_paths))
    try:
        if output:
            res.write_exr(output)
        if png:
            res.write_png(png)
        for t, (exr_path, png_path) in enumerate(frame_paths or ()):
            res.write_exr(exr_path, frame=t)
            res.write_png(png_path, frame=t)
    except csi.CsiError as e:
        raise ReconstructError(e) from None
    stats = dict(res.stats)
    stats["t_wall_s"] = time.perf_counter() - t0
    return stats


def reconstruct_result(d: csid.Dump, extra=(), variance=None, progress=None, frames=False):
    """Reconstructs the samples d with csi's library in this process (the same bits as
    csi-reconstruct on their dump, with --variance when `variance`, the samples' variances, is
    given); returns csi's Result. progress: csi.reconstruct's callback, or None. Positions in
    csi's order (sorted by cell, each once: csi-positions' requests) go straight in; any others
    through the library's dump reader, which sorts them and averages repeats as csi-reconstruct
    does, without the variances (the variance of an averaged repeat is not their mean). frames:
    keep the volume's frames (Result.frames), as csi-reconstruct --frames does."""
    import numpy as np

    import csi

    kw, device = reconstruction_options(extra)
    if frames:
        kw["frames"] = "on"
    w, h, t = d.grid
    xyt = np.asarray(d.xyt, dtype=np.int64)
    idx = (xyt[:, 2] * h + xyt[:, 1]) * w + xyt[:, 0]
    try:
        dev = csi.Device(device) if device else None
        if len(idx) > 0 and (np.diff(idx) > 0).all():
            if d.seed and "seed" not in kw:
                kw["seed"] = d.seed  # csi-reconstruct's rule: the dump's seed unless given
            res = csi.reconstruct(d.xyt, d.values, (w, h, t, *d.out), device=dev, exact=d.exact,
                                  variance=variance, progress=progress, **kw)
        else:
            with tempfile.TemporaryDirectory(prefix="csi-mitsuba-") as tmp:
                path = os.path.join(tmp, "samples.csid")
                csid.write(path, d)
                res = csi.reconstruct_dump(path, device=dev, progress=progress, **kw)
    except csi.CsiError as e:
        raise ReconstructError(e) from None
    return res


def check_fits(req: csid.Dump, a, extra):
    """Refuses (exit 2) before any rendering a reconstruction that cannot fit the device or the
    host's memory, as csi-render does: the request's samples (RGB), with the positions, values
    and variances held meanwhile."""
    import csi

    kw, device = reconstruction_options(extra)
    if a.frames:
        kw["frames"] = "on"
    n = len(req.xyt)
    held = n * (12 + 12 + (12 if a.paths > 1 or (a.time_steps > 1 and a.variance_peaks) else 0))
    try:
        csi.reconstruct_check((*req.grid, *req.out), 3, n, device=csi.Device(device) if device else None,
                              extra_host=held, input=a.request or a.scene, **kw)
    except csi.CsiError as e:
        raise ReconstructError(e) from None


def refine_seed(seed: int, k: int = 0) -> int:
    """The paths' seed of refinement pass k (0: the second pass): one of their own, mixed with the
    run's, so that they are not an earlier pass's paths again in the same batches."""
    return ((int(seed) ^ 0x72656669_6E650000) + k) % (1 << 64)


def noise_seed(seed: int) -> int:
    """The seed of the paths that estimate one path's variance (mb.path_noise): their own, as
    refine_seed's are."""
    return ((int(seed) ^ 0x6E6F6973_65000000) + 1) % (1 << 64)


def refine(scene, req: csid.Dump, s: mb.Samples, a, extra, prog):
    """The passes after the first (--refine, --refine-passes): the cells csi_refine_positions
    picks, rendered as the first ones were and merged with them in csi's cell order; each further
    pass picks again on all the samples so far and the patched image. Returns (request, samples,
    statistics, image) of all the samples: the first pass's reconstruction (csi's Result) with
    each refined pixel set to the mean of all its samples, which a pixel sampled in every cell is
    given by the blend; then, with several paths per sample (their variances given to csi), the
    pixels that still decide the image settled on all their samples' mean (csi_refine_settle;
    not with '-- --settle off') and an HDR step's pixels given the coverage their window's samples
    allow (csi_refine_step_coverage; not with '-- --step-coverage off'); where no pixel is
    picked the two still run, which gives csi-reconstruct's default image, to the bit. A second
    reconstruction of all the samples differs from the patch only in the fit around the refined
    pixels: it measured the same error on average and above the mean of the same samples more
    often (docs/bench/mitsuba.md, sessions 20 and 48), for twice csi's time."""
    import numpy as np

    import csi

    t0 = time.perf_counter()
    # prog: csi-mitsuba's _Progress, or any callable for the renders alone (as the benchmarks pass)
    # the first pass as the fit left the pixels that decide it: the passes sample those pixels
    # instead of settling them on their few samples (csi-reconstruct --refine-request: the same)
    first = reconstruct_result(req.with_values(s.values), [*extra, "--settle", "off", "--step-coverage", "off"],
                               s.variance if a.variance_peaks else None, getattr(prog, "reconstruction", None))
    t_first = time.perf_counter() - t0
    info = {"pixels": 0, "cells": 0, "passes": [], "t_first_reconstruction_s": t_first, "settled": 0, "step_moved": 0,
            "image": "the first pass's reconstruction, each refined pixel its samples' mean, then (several "
                     "paths per sample) the pixels that still decide it settled on their samples' mean and "
                     "an HDR step's pixels given the coverage their window's samples allow"}
    grid = (*req.grid, *req.out)
    w, h, _ = req.grid
    image = first.image
    for k in range(a.refine_passes):
        try:
            cells, pixels = csi.refine_positions(req.xyt, s.values, grid, image, a.refine_share)
        except csi.CsiError as e:
            raise ReconstructError(e) from None
        if not len(cells):
            break
        more = csid.Dump(grid=req.grid, out=req.out, xyt=cells, values=None, seed=req.seed)
        s2 = mb.render_request(scene, more, paths=a.paths, seed=refine_seed(req.seed, k), aov=a.aov,
                               progress=lambda d, n: prog("refinement samples", d, n))
        try:  # csi-reconstruct FIRST --refine-with MORE's image, to the bit (the second pass)
            image, _ = csi.refine_apply(req.xyt, s.values, cells, s2.values, grid, image)
        except csi.CsiError as e:
            raise ReconstructError(e) from None
        xyt = np.concatenate([req.xyt, cells])
        order = np.argsort((xyt[:, 2].astype(np.int64) * h + xyt[:, 1]) * w + xyt[:, 0], kind="stable")
        join = lambda u, v: None if u is None or v is None else np.concatenate([u, v])[order]  # noqa: E731
        s = mb.Samples(values=join(s.values, s2.values), variance=join(s.variance, s2.variance),
                       albedo=join(s.albedo, s2.albedo), normal=join(s.normal, s2.normal), paths=s.paths,
                       nonfinite=s.nonfinite + s2.nonfinite, timing=s.timing)
        req = csid.Dump(grid=req.grid, out=req.out, xyt=xyt[order], values=None, seed=req.seed)
        info["pixels"] += pixels
        info["cells"] += int(len(cells))
        info["passes"].append({"pixels": pixels, "cells": int(len(cells)), "mitsuba": s2.timing})
    # with several paths per sample, the settling and the step follow the passes; where no pixel was
    # picked they make csi-reconstruct's default image of the first pass, to the bit
    if s.variance is not None and a.variance_peaks and reconstruction_options(extra)[0].get("settle") != "off":
        try:
            image, info["settled"] = csi.refine_settle(req.xyt, s.values, grid, image, variance=s.variance)
        except csi.CsiError as e:
            raise ReconstructError(e) from None
    if s.variance is not None and a.variance_peaks and reconstruction_options(extra)[0].get("step_coverage") != "off":
        try:  # the rims the passes did not take (csi_refine_step_coverage; the first pass went without it)
            image, info["step_moved"] = csi.refine_step_coverage(req.xyt, s.values, grid, image, variance=s.variance)
        except csi.CsiError as e:
            raise ReconstructError(e) from None
    if info["cells"] or info["settled"] or info["step_moved"]:
        first.set_image(image)
    return req, s, info, first


class ReconstructError(Exception):
    """csi's library refused the samples or failed (the status names which); exit 2 for bad input."""

    def __init__(self, e):
        super().__init__(str(e))
        self.code = 2 if e.status in ("CSI_ERR_ARG", "CSI_ERR_IO", "CSI_ERR_FORMAT", "CSI_ERR_SCENE", "CSI_ERR_DEVICE",
                                      "CSI_ERR_TOO_LARGE") else 1  # as csi-reconstruct exits


def _write_json(path, obj):
    with open(path, "w") as f:
        json.dump(obj, f, indent=1)


def _estimator(extra):
    """The estimator the reconstruction options after '--' ask for (the last --estimator), else cs."""
    value = "cs"
    for i, w in enumerate(extra):
        name, eq, v = w.partition("=")
        if name == "--estimator":
            value = v if eq else extra[i + 1] if i + 1 < len(extra) else value
    return value


def run(a, extra):
    prog = _Progress(a.quiet)
    if a.reference:
        for flag, v in (("--dump", a.dump), ("--aov", a.aov), ("--request", a.request)):
            if v:
                raise UsageError(f"{flag} does not apply to --reference (it writes -o/--png/--npy/--frames/--stats)")
        if extra:
            raise UsageError("csi-reconstruct arguments after '--' do not apply to --reference")
    else:
        if a.npy:
            raise UsageError("--npy is only for --reference (the samples go to --dump)")
        if a.aov and not a.dump:
            raise UsageError("--aov needs --dump FILE.csid (the albedo and normal go beside it)")
        reconstruction_options(extra)  # bad options refused before any rendering
    if a.variance_peaks is None:
        a.variance_peaks = a.paths > 1 or a.time_steps > 1
    if a.variance_peaks and a.paths < 2 and a.time_steps < 2:
        raise UsageError("--variance-peaks needs --paths above 1 (one path has no sample variance) or, for an "
                         "animation, --time-steps above 1")
    estimator = _estimator(extra)
    if a.refine is None:  # the default: on where csi reconstructs an image from its own positions
        a.refine = not (a.reference or a.request or a.time_steps > 1 or estimator in ("mean", "gauss"))
    if a.refine_share is not None and not a.refine:
        raise UsageError("--refine-share needs --refine")
    if a.refine_passes is not None and not a.refine:
        raise UsageError("--refine-passes needs --refine")
    if a.refine_passes is None:
        a.refine_passes = 1
    if a.refine_share is not None and not 0 < a.refine_share <= 1:
        raise UsageError(f"--refine-share: {a.refine_share:g} is not a share with 0 < S <= 1")
    if a.refine and estimator == "mean":
        raise UsageError("--refine picks the pixels where csi's image and the pixel's mean disagree: not with "
                         "--estimator mean")
    if a.refine and (a.reference or a.time_steps > 1):
        raise UsageError("--refine picks pixels of an image: not with " + ("--reference" if a.reference else
                                                                           "--time-steps above 1"))
    if not (a.output or a.png or a.dump or a.npy or a.frames):
        raise UsageError("no output given: use -o OUT.exr, --png, --frames, --dump or --npy")
    a.n_frames = 0
    if a.frames:
        a.n_frames = csid.read(a.request, want="request").grid[2] if a.request else a.time_steps
        if a.n_frames < 2:
            raise UsageError("--frames: an animation's frames; give --time-steps above 1" if not a.request else
                             f"--frames: {a.request} is an image (grid_t = 1), it has no frames")
        if estimator == "mean":
            raise UsageError("--frames: the per-pixel mean (--estimator mean) makes no frames")
    a.params = {}
    for d in a.define:
        name, eq, value = d.partition("=")
        if not eq or not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name):
            raise UsageError(f"-D {d}: not NAME=VALUE (the value of an XML scene's $NAME parameter)")
        if name in a.params:
            raise UsageError(f"-D {name}: given twice")
        a.params[name] = value
    aov_paths = var_path = None
    if a.dump:
        stem = a.dump[:-5] if a.dump.endswith(".csid") else a.dump
        if a.paths > 1 or (a.time_steps > 1 and a.variance_peaks):  # beside the values (csi-reconstruct --variance)
            var_path = stem + ".variance.csid"
        if a.aov:
            aov_paths = (stem + ".albedo.csid", stem + ".normal.csid")
    outs = [(a.output, "the image (-o)"), (a.png, "the preview (--png)"), (a.dump, "the dump (--dump)"),
            (a.npy, "the array (--npy)"), (a.stats, "the statistics (--stats)"),
            (var_path, "the variances (beside --dump)")]
    outs += list(zip(aov_paths, ("the albedo (--aov)", "the normals (--aov)"))) if aov_paths else []
    # Every output stated before any rendering (its directory, not a directory itself, not an
    # input, not another output), and written all or nothing after it: csi's programs' rule.
    import csi

    with csi.OutputSet(inputs=[a.scene, a.request]) as files:
        try:
            for path, what in outs:
                if path:
                    files.file(path, what)
            if a.frames:  # every frame's files stated now, as csi-reconstruct states them
                files.dir(a.frames, "the frames folder (--frames)")
                for t in range(a.n_frames):
                    files.dir_file(a.frames, f"frame_{t:04d}.exr", "a frame (--frames)")
                    files.dir_file(a.frames, f"frame_{t:04d}.png", "a frame's preview (--frames)")
        except csi.CsiError as e:
            raise UsageError(str(e)) from None
        _check_image_kinds(a.output, a.png)
        summary, warnings = _run(a, extra, prog, files, var_path, aov_paths)
        try:
            files.commit()
        except csi.CsiError as e:
            raise ReconstructError(e) from None
    if not a.quiet:
        print(summary, file=sys.stderr)
    for w in warnings:  # what is wrong with the samples is said even with -q
        print(f"{PROG}: warning: {w}", file=sys.stderr)
    return 0


_IMAGE_EXTS = ("exr", "png", "jpg", "jpeg", "hdr", "pfm", "tif", "tiff", "bmp", "ppm", "tga", "webp")


def _check_image_kinds(exr_path, png_path):
    """-o writes OpenEXR and --png a PNG whatever the name says: a name that asks for another
    image format is refused before any rendering, as csi's C programs refuse it (a name without
    an image extension is taken as given)."""
    for path, want, what, hint in ((exr_path, "exr", "the image (-o)", "name it .exr (--png FILE.png writes an "
                                                                        "8-bit preview)"),
                                   (png_path, "png", "the preview (--png)", "name it .png (-o FILE.exr writes the "
                                                                             "HDR image)")):
        ext = os.path.splitext(path)[1][1:].lower() if path else ""
        if ext in _IMAGE_EXTS and ext != want:
            raise UsageError(f"{path}: {what} is written as {'OpenEXR' if want == 'exr' else 'an 8-bit PNG'}, "
                             f"not {ext}; {hint}")


def frame_paths(a, files):
    """The temporary (EXR, PNG) paths of --frames' files, one pair per frame; None without it."""
    if not a.frames:
        return None
    name = lambda t, ext: os.path.join(a.frames, f"frame_{t:04d}.{ext}")  # noqa: E731
    return [(files.tmp(name(t, "exr")), files.tmp(name(t, "png"))) for t in range(a.n_frames)]


def write_png(path, rgb):
    """An 8-bit sRGB preview of an (h, w, 3) array (the reference and its frames; csi's own
    images go through the library's writer, with the same encoding)."""
    from PIL import Image

    from . import preview

    Image.fromarray(preview.to_srgb8(rgb)).save(path, format="PNG")


def _run(a, extra, prog, files, var_path, aov_paths):
    """The work of run(), every output written to its temporary name in `files`; returns the
    summary line and the warnings."""
    tmp = lambda path: files.tmp(path) if path else None  # noqa: E731
    req = None
    if a.request:
        req = csid.read(a.request, want="request")
        size = req.out
        if a.out and a.out != size:
            raise UsageError(f"--out {a.out[0]}x{a.out[1]} differs from the request's {size[0]}x{size[1]}")
        if a.refine and req.grid[2] > 1:
            raise UsageError(f"--refine picks pixels of an image: {a.request} is a volume (grid_t = {req.grid[2]})")
    t_load = time.perf_counter()
    if a.quiet:
        mb.quiet()
    scene = mb.load_scene(a.scene, size=a.out, box_filter=bool(a.reference), params=a.params, sensor=a.sensor)
    if req is not None and scene.size != req.out:
        scene = mb.load_scene(a.scene, size=req.out, params=a.params, sensor=a.sensor)
    t_load = time.perf_counter() - t_load
    size = scene.size
    if a.time_steps > 1 and scene.animate is None and not a.reference:
        raise UsageError(f"--time-steps {a.time_steps}: {scene.name} is still (a Mitsuba XML scene, or a .py without "
                         f"animate(params, time)): its frames would all be alike, on a grid of fewer cells per pixel "
                         f"than a still image's; give a .py scene with animate(), or leave out --time-steps")

    if a.reference:
        import numpy as np

        t0 = time.perf_counter()
        # An animation's reference is its motion blur over the discrete shutter csi's samples see:
        # the mean of its T frames, each posed at (t + 0.5) / T, SPP samples a pixel in all (as
        # csi-render's --reference counts them). One pose would be a still frame of the middle.
        frames = a.time_steps if scene.animate is not None else 1
        per_frame = -(-a.reference // frames)
        if a.frames and frames != a.n_frames:
            raise UsageError(f"--frames: {scene.name} is still (no animate(params, time)); its reference has no frames")
        if frames > 1:
            ref_frames = mb.render_reference_frames(scene, frames, per_frame, seed=a.seed,
                                                    progress=lambda d, n: prog("reference frames", d, n))
            ref = ref_frames.astype(np.float64).mean(axis=0).astype(np.float32)
            for t, (exr_path, png_path) in enumerate(frame_paths(a, files) or ()):
                exr.write(exr_path, ref_frames[t])
                write_png(png_path, ref_frames[t])
        else:
            ref = mb.render_reference(scene, a.reference, seed=a.seed, progress=lambda d, n: prog("reference pass", d, n))
        t_ref = time.perf_counter() - t0
        prog.end()
        if a.output:
            exr.write(tmp(a.output), ref)
        if a.png:
            write_png(tmp(a.png), ref)
        if a.npy:
            with open(tmp(a.npy), "wb") as f:
                np.save(f, ref)
        if a.stats:
            _write_json(tmp(a.stats), {"tool": PROG, "scene": a.scene, "reference_spp": a.reference, "out": list(size),
                                  "frames": frames, "reference_spp_per_frame": per_frame,
                                  "seed": a.seed, "t_load_s": t_load, "t_render_s": t_ref,
                                  "per_path_us": 1e6 * t_ref / (per_frame * frames * size[0] * size[1])})
        bad = int((~np.isfinite(ref)).any(axis=-1).sum())
        spp_said = f"{frames} frames x {per_frame} spp" if frames > 1 else f"{a.reference} spp"
        return (f"{PROG}: {scene.name} {size[0]}x{size[1]} reference, {spp_said}, box filter: {t_ref:.2f} s "
                f"-> {a.output or a.png or a.npy or a.frames}",
                [f"{bad} of the reference's pixels are NaN or Inf (the scene's paths give them): written as "
                 f"Mitsuba renders them"] if bad else [])

    if req is None:
        grid = a.grid
        if grid is None and a.time_steps > 1:  # the grid for the scene's camera, as csi-render's
            import csi

            grid = size[0] * csi.default_grid_factor(*size, a.time_steps, a.spp, camera=mb.camera_motion(scene))
        req = mb.positions_request(size, spp=a.spp, grid=grid, method=a.method, seed=a.seed, time_steps=a.time_steps)
    seed = a.seed if not a.request else req.seed
    if a.refine and reconstruction_options(extra)[0].get("settle") == "on":
        raise UsageError("--refine and '-- --settle on': the second pass samples the pixels that --settle would give "
                         "their means; give one (--no-refine for --settle)")
    if a.refine and reconstruction_options(extra)[0].get("step_coverage") == "on":
        raise UsageError("--refine and '-- --step-coverage on': the first pass goes without the step, and with "
                         "--paths above 1 it follows the passes by itself ('-- --step-coverage off': not)")
    if a.refine or a.output or a.png or a.frames:
        check_fits(req, a, extra)
    s = mb.render_request(scene, req, paths=a.paths, seed=seed, aov=a.aov,
                          progress=lambda d, n: prog("samples", d, n))
    prog.end()
    noise = None
    if s.variance is None and a.time_steps > 1 and a.variance_peaks:
        # one path per sample: one path's variance from a second path through some of the
        # cells, every sample's variance for csi (an animation's solve needs only their mean)
        import dataclasses

        import numpy as np

        v, t_noise = mb.path_noise(scene, req, s.values, seed=noise_seed(seed))
        s = dataclasses.replace(s, variance=np.broadcast_to(v.astype(np.float32), s.values.shape).copy())
        noise = {"cells": t_noise.get("samples", 0), "variance": v.tolist(), "mitsuba": t_noise}
    refined = refined_result = None
    if a.refine:
        req, s, refined, refined_result = refine(scene, req, s, a, extra, prog)
        prog.end()
    dump = req.with_values(s.values)
    stats = {"tool": PROG, "scene": a.scene, "out": list(req.out), "grid": list(req.grid), "seed": seed,
             "samples": len(req.xyt), "paths_per_sample": a.paths, "nonfinite_paths": s.nonfinite,
             "t_load_s": t_load, "mitsuba": s.timing}
    if refined is not None:
        stats["refine"] = refined
    if noise is not None:
        stats["path_noise"] = noise
    t_recon = None
    if refined_result is not None:
        import csi

        t_recon = refined["t_first_reconstruction_s"]
        stats["reconstruction"] = dict(refined_result.stats)
        try:
            if a.output:
                refined_result.write_exr(tmp(a.output))
            if a.png:
                refined_result.write_png(tmp(a.png))
        except csi.CsiError as e:
            raise ReconstructError(e) from None
    elif a.output or a.png or a.frames:
        t0 = time.perf_counter()
        stats["reconstruction"] = reconstruct(dump, tmp(a.output), tmp(a.png), extra=extra,
                                                variance=s.variance if a.variance_peaks else None,
                                                progress=prog.reconstruction, frame_paths=frame_paths(a, files))
        prog.end()
        t_recon = time.perf_counter() - t0
    if a.dump:
        csid.write(tmp(a.dump), dump)
        if aov_paths:
            csid.write(tmp(aov_paths[0]), req.with_values(s.albedo))
            csid.write(tmp(aov_paths[1]), req.with_values(s.normal))
        if var_path and s.variance is not None:
            csid.write(tmp(var_path), req.with_values(s.variance))
    if a.stats:
        _write_json(tmp(a.stats), stats)
    t = s.timing
    msg = (f"{PROG}: {scene.name} {req.out[0]}x{req.out[1]}: {len(req.xyt)} samples x {a.paths} path"
           f"{'s' if a.paths > 1 else ''} on a {req.grid[0]}x{req.grid[1]}x{req.grid[2]} grid; Mitsuba "
           f"{t['render_s']:.2f} s ({t['per_sample_us']:.2f} us/sample, {t['per_path_us']:.3f} us/path; "
           f"first call {t['jit_s']:.2f} s apart)")
    if refined is not None:
        passes = refined["passes"]
        msg += (f"; refine: {refined['cells']} more samples at {refined['pixels']} pixels"
                + (f" in {len(passes)} passes" if len(passes) > 1 else "")
                + (f" (Mitsuba {sum(q['mitsuba']['render_s'] for q in passes):.2f} s)" if passes else "")
                + (f", {refined['settled']} more settled on their samples' mean" if refined["settled"] else "")
                + (f", {refined['step_moved']} across an HDR step given their window's coverage"
                   if refined.get("step_moved") else ""))
    if t_recon is not None:
        msg += f", csi {t_recon:.2f} s"
    warnings = [f"{s.nonfinite} of Mitsuba's paths were NaN or Inf and are counted as 0"] if s.nonfinite else []
    return msg, warnings


def main(argv=None):
    argv = list(sys.argv[1:] if argv is None else argv)
    extra = []
    if "--" in argv:
        i = argv.index("--")
        argv, extra = argv[:i], argv[i + 1:]
    try:
        p = parser()
        bad = unknown_option([p], argv)
        if bad:
            raise UsageError(f"unrecognized argument: {bad} (see --help)")
        a = p.parse_args(argv)
        return run(a, extra)
    except UsageError as e:
        print(f"{PROG}: error: {e}", file=sys.stderr)
        return 2
    except (mb.BridgeError, csid.DumpError) as e:
        print(f"{PROG}: error: {e}", file=sys.stderr)
        return 2
    except (programs.ProgramError, ReconstructError) as e:
        print(f"{PROG}: error: {e}", file=sys.stderr)
        return e.code
    except CsiError as e:  # the library itself (not found, another ABI) or a call outside reconstruct
        print(f"{PROG}: error: {e}", file=sys.stderr)
        return ReconstructError(e).code
    except OSError as e:  # a write that failed after the checks (a full disk): the outputs were removed
        print(f"{PROG}: error: {e.filename + ': ' if e.filename else ''}{e.strerror or e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
