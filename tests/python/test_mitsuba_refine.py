"""csi-mitsuba --refine end to end: the first pass's samples, the cells csi asks for next
(csi_refine_positions on the first pass's reconstruction), Mitsuba rendering them, and the image:
the first pass's reconstruction with each refined pixel its samples' mean, then, with several
paths per sample, the pixels that still decide it settled on their samples' mean and an HDR step's
pixels given the coverage their window's samples allow; bad arguments refused before any rendering.

Scene: data/mitsuba/horizon.py (a textured plane to the horizon, a sun glinting on a glossy
sphere: a few pixels hold most of the image's error) at 48x48, 4 samples per pixel of 4 paths
(csi's default grid for 4 spp: 8x, 384x384 cells).
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.join(HERE, "..", "..")
PYDIR = os.path.join(ROOT, "host", "python")
sys.path.insert(0, PYDIR)
sys.path.insert(0, HERE)
from checks import check, done  # noqa: E402
import csi  # noqa: E402
from csi import dump as csid  # noqa: E402
from csi import exr  # noqa: E402
from csi import programs  # noqa: E402

SCENE = os.path.join(ROOT, "data", "mitsuba", "horizon.py")


def cli(*args):
    env = dict(os.environ, PYTHONPATH=os.path.abspath(PYDIR))
    return subprocess.run([sys.executable, "-m", "csi.mitsuba_cli", *map(str, args)], stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE, text=True, env=env)


def second_pass(both, one, path, values=None):
    """Writes the samples of the dump `both` that the one-pass dump `one` lacks (the second pass's)
    to path, with `values` (both's own by default: e.g. their variances) in both's order."""
    key = lambda a: a[:, 1].astype(np.int64) * both.grid[0] + a[:, 0]  # noqa: E731
    new = ~np.isin(key(both.xyt), key(one.xyt))
    csid.write(path, csid.Dump(grid=both.grid, out=both.out, xyt=both.xyt[new],
                               values=(both.values if values is None else values)[new], seed=both.seed))


def main():
    with tempfile.TemporaryDirectory() as T:
        p = lambda name: os.path.join(T, name)  # noqa: E731
        common = [SCENE, "--out", "48x48", "--spp", 4, "--paths", 4, "--seed", 3, "-q"]
        # the default for an image is the second pass; --refine says it too
        r = cli(*common, "--dump", p("r.csid"), "-o", p("r.exr"), "--stats", p("r.json"))
        check(r.returncode == 0, f"the default (--refine): exit {r.returncode}: {r.stderr.strip()}")
        r1 = cli(*common, "--no-refine", "--dump", p("one.csid"), "-o", p("one.exr"))
        check(r1.returncode == 0, f"one pass: exit {r1.returncode}: {r1.stderr.strip()}")
        if r.returncode or r1.returncode:
            return
        st = json.load(open(p("r.json")))["refine"]
        d, d1 = csid.read(p("r.csid")), csid.read(p("one.csid"))
        v1 = csid.read(p("one.variance.csid")).values
        grid = (*d.grid, *d.out)
        # The first pass is the one-pass run's samples (same positions and seed); what the
        # refinement adds is exactly what csi asks for on that pass's reconstruction (the library
        # in this process, the run's reconstruction options: the variances beside the dump, and the
        # pixels that decide the image as the fit left them, csi/settle.h, csi/step_coverage.h).
        first = csi.reconstruct(d1.xyt, d1.values, grid, variance=v1, seed=d1.seed, settle="off",
                                step_coverage="off")
        cells, pixels = csi.refine_positions(d1.xyt, d1.values, grid, first.image)
        check(st["cells"] == len(cells) > 0 and st["pixels"] == pixels > 0,
              f"stats say {st['cells']} cells at {st['pixels']} pixels; the library {len(cells)} at {pixels}")
        both = np.concatenate([d1.xyt, cells])
        key = lambda a: (a[:, 1].astype(np.int64) * d.grid[0] + a[:, 0])  # noqa: E731
        check(len(d.xyt) == len(both) and np.array_equal(np.sort(key(d.xyt)), np.sort(key(both))),
              f"the dump holds {len(d.xyt)} samples, not the first pass's {len(d1.xyt)} and the {len(cells)} asked for")
        check((np.diff(key(d.xyt)) > 0).all(), "the dump's positions are not in csi's cell order")
        old = np.isin(key(d.xyt), key(d1.xyt))
        check(np.array_equal(d.values[old], d1.values), "the first pass's values changed in the refined dump")
        # Every picked pixel is now sampled in every cell, so its mean has no sampling error and
        # the blend returns it (the mean of its 64 samples, in float32: a relative 1e-6 covers
        # the summation's rounding).
        f = d.grid[0] // d.out[0]
        pix = (d.xyt[:, 1] // f) * d.out[0] + d.xyt[:, 0] // f
        cnt = np.bincount(pix, minlength=d.out[0] * d.out[1])
        picked = np.unique((cells[:, 1] // f) * d.out[0] + cells[:, 0] // f)
        check(len(picked) == pixels and (cnt[picked] == f * f).all(), f"picked pixels not sampled in every cell: "
              f"{cnt[picked]}")
        img = exr.read(p("r.exr")).reshape(-1, 3).astype(np.float64)
        m = d.pixel_means().reshape(-1, 3)
        err = np.abs(img[picked] - m[picked]).max() / max(1.0, np.abs(m[picked]).max())
        check(err <= 1e-6, f"a fully sampled pixel is not its samples' mean: relative {err:.3g}")
        # Every other pixel is the first pass's reconstruction: csi-reconstruct --settle off
        # --step-coverage off's on the one-pass dump (with the variances beside it), to the bit.
        subprocess.run([programs.find("csi-reconstruct"), p("one.csid"), "-o", p("c.exr"), "-q", "--settle", "off",
                        "--step-coverage", "off"], check=True)
        c1 = exr.read(p("c.exr")).reshape(-1, 3)
        rest = np.setdiff1d(np.arange(len(c1)), picked)
        check(np.array_equal(c1[rest], exr.read(p("r.exr")).reshape(-1, 3)[rest]),
              "csi-mitsuba --refine's other pixels != csi-reconstruct's on the first pass's dump")
        # The one-pass run is csi-reconstruct's default on its dump (the deciding pixels settled,
        # then an HDR step's pixels given their window's coverage), and settling moves only pixels
        # the second pass samples (csi/settle.h).
        subprocess.run([programs.find("csi-reconstruct"), p("one.csid"), "-o", p("cs.exr"), "-q"], check=True)
        cs1 = exr.read(p("cs.exr")).reshape(-1, 3)
        check(np.array_equal(cs1, exr.read(p("one.exr")).reshape(-1, 3)), "the one-pass run's image != csi-reconstruct's")
        subprocess.run([programs.find("csi-reconstruct"), p("one.csid"), "-o", p("cs.exr"), "-q", "--step-coverage",
                        "off"], check=True)
        moved = np.flatnonzero((exr.read(p("cs.exr")).reshape(-1, 3) != c1).any(axis=1))
        check(len(moved) > 0 and np.isin(moved, picked).all(),
              f"settling moved {len(moved)} pixels, {np.isin(moved, picked).sum()} of them picked by the second pass")
        # Another renderer's second pass: csi-reconstruct FIRST --refine-with MORE (the request's
        # cells evaluated) gives csi-mitsuba's image, to the bit; MORE missing a cell, or of
        # another grid, is refused with one line and no output.
        new = ~old
        csid.write(p("more.csid"), csid.Dump(grid=d.grid, out=d.out, xyt=d.xyt[new], values=d.values[new], seed=d.seed))
        rw = subprocess.run([programs.find("csi-reconstruct"), p("one.csid"), "--refine-with", p("more.csid"), "-o",
                             p("rw.exr")], capture_output=True, text=True)
        check(rw.returncode == 0 and np.array_equal(exr.read(p("rw.exr")), exr.read(p("r.exr"))),
              f"csi-reconstruct --refine-with != csi-mitsuba's image: exit {rw.returncode} {rw.stderr.strip()}")
        # The same without a second reconstruction (docs/dump-format.md): the first pass's EXR
        # (c.exr, csi-reconstruct on the one-pass dump) patched in Python, to the bit.
        a, b = csid.read(p("one.csid")), csid.read(p("more.csid"))
        patched, _ = csi.refine_apply(a.xyt, a.values, b.xyt, b.values, grid, exr.read(p("c.exr")))
        check(np.array_equal(patched, exr.read(p("r.exr"))), "the first pass's EXR patched in Python != csi-mitsuba's image")
        csid.write(p("less.csid"), csid.Dump(grid=d.grid, out=d.out, xyt=d.xyt[new][1:], values=d.values[new][1:],
                                             seed=d.seed))
        csid.write(p("other.csid"), csid.Dump(grid=(d.grid[0] * 2, d.grid[1] * 2, 1), out=d.out, xyt=d.xyt[new] * 2,
                                              values=d.values[new], seed=d.seed))
        for more, what in (("less.csid", "a cell missing"), ("other.csid", "another grid")):
            e = subprocess.run([programs.find("csi-reconstruct"), p("one.csid"), "--refine-with", p(more), "-o",
                                p("x.exr"), "-q"], capture_output=True, text=True)
            check(e.returncode == 2 and len(e.stderr.strip().splitlines()) == 1 and more in e.stderr
                  and not os.path.exists(p("x.exr")), f"--refine-with, {what}: exit {e.returncode}: {e.stderr!r}")
        # Off by default with the mean as the estimator (it has nothing to disagree with) and for
        # an explicit request of positions.
        m = cli(*common, "--dump", p("m.csid"), "--", "--estimator", "mean")
        check(m.returncode == 0 and open(p("m.csid"), "rb").read() == open(p("one.csid"), "rb").read(),
              f"-- --estimator mean refined by default: exit {m.returncode} {m.stderr.strip()}")
        # Deterministic: the same run twice, the same bytes.
        r2 = cli(*common, "--refine", "--dump", p("r2.csid"))
        check(r2.returncode == 0 and open(p("r2.csid"), "rb").read() == open(p("r.csid"), "rb").read(),
              "--refine twice gave different samples")

        # A further pass (--refine-passes 2) picks again on all the samples of the first two and
        # the patched image, exactly as csi_refine_positions does on them; the pixels it refines
        # take the mean of all their samples, every other pixel is the two-pass image.
        t = cli(*common, "--refine-passes", "2", "--dump", p("t.csid"), "-o", p("t.exr"), "--stats", p("t.json"))
        check(t.returncode == 0, f"--refine-passes 2: exit {t.returncode}: {t.stderr.strip()}")
        if t.returncode == 0:
            d3 = csid.read(p("t.csid"))
            third, tpix = csi.refine_positions(d.xyt, d.values, grid, exr.read(p("r.exr")))
            passes = json.load(open(p("t.json")))["refine"]["passes"]
            check(len(third) > 0 and [q["cells"] for q in passes] == [st["cells"], len(third)],
                  f"passes {[q['cells'] for q in passes]}: the second pass {st['cells']}, the library's next pick {len(third)}")
            check(len(d3.xyt) == len(d.xyt) + len(third) and np.array_equal(
                np.sort(key(d3.xyt)), np.sort(np.concatenate([key(d.xyt), key(third)]))),
                "--refine-passes 2's samples are not the two-pass samples and the next pick")
            tp = np.unique((third[:, 1] // f) * d.out[0] + third[:, 0] // f)
            timg = exr.read(p("t.exr")).reshape(-1, 3)
            tm = d3.pixel_means().reshape(-1, 3)
            check(np.abs(timg[tp] - tm[tp]).max() / max(1.0, np.abs(tm[tp]).max()) <= 1e-6,
                  "a pixel of the third pass is not its samples' mean")
            rest3 = np.setdiff1d(np.arange(len(timg)), tp)
            check(np.array_equal(timg[rest3], exr.read(p("r.exr")).reshape(-1, 3)[rest3]),
                  "--refine-passes 2 changed pixels the third pass did not refine")

        # After the passes, with several paths per sample, the pixels that still decide the image
        # settle on all their samples' mean (csi_refine_settle). The horizon's pick leaves none
        # (stats: settled 0); street lamps at the same size and sampling leave some. Against the
        # run with '-- --settle off' (the patch alone) the default differs at exactly the pixels
        # the stats count, each now the mean of all its samples in the dump; csi-reconstruct
        # --refine-with on the first pass's dump (and its variances) gives the same bits; with one
        # path per sample (no variances) nothing is settled.
        check(st["settled"] == 0, f"the horizon's stats say {st['settled']} pixels settled after the pass")
        lamps = [os.path.join(ROOT, "data", "mitsuba", "street_lamps.py"), "--out", "48x48", "--spp", 4, "--seed", 3,
                 "-q"]
        runs = {name: cli(*lamps, *args) for name, args in (
            ("ls", ["--paths", 4, "--dump", p("ls.csid"), "-o", p("ls.exr"), "--stats", p("ls.json")]),
            ("off", ["--paths", 4, "-o", p("off.exr"), "--", "--settle", "off"]),
            ("one", ["--paths", 4, "--no-refine", "--dump", p("lone.csid"), "-o", p("lone.exr")]),
            ("p1", ["--paths", 1, "-o", p("p1.exr"), "--stats", p("p1.json")]))}
        for name, rr in runs.items():
            check(rr.returncode == 0, f"street lamps, {name}: exit {rr.returncode}: {rr.stderr.strip()}")
        if not any(rr.returncode for rr in runs.values()):
            n_set = json.load(open(p("ls.json")))["refine"]["settled"]
            dl = csid.read(p("ls.csid"))
            ml = dl.pixel_means().reshape(-1, 3)
            a_img, b_img = exr.read(p("ls.exr")).reshape(-1, 3), exr.read(p("off.exr")).reshape(-1, 3)
            moved = np.flatnonzero((a_img != b_img).any(axis=1))
            # each moved towards its mean by one weight in (0, 1] for all channels (csi/settle.h: the
            # whole way from 2% of the disagreement, part of it from 0.5%)
            step, gap = (a_img[moved] - b_img[moved]).astype(np.float64), (ml[moved] - b_img[moved]).astype(np.float64)
            big = np.abs(gap) > 1e-3 * np.abs(ml[moved]).max(axis=1, keepdims=True)
            w = np.where(big, step / np.where(big, gap, 1), np.nan)
            wp = np.nanmean(w, axis=1) if len(moved) else np.zeros(0)
            spread = np.nanmax(np.abs(w - wp[:, None])) if len(moved) else 0.0
            check(n_set > 0 and len(moved) == n_set and (wp > 0).all() and (wp <= 1 + 1e-5).all() and spread <= 1e-4,
                  f"settled after the pass: stats {n_set}, pixels changed {len(moved)}, weights towards their means "
                  f"{np.round(wp, 4)} (spread over the channels {spread:.2g})")
            second_pass(dl, csid.read(p("lone.csid")), p("lmore.csid"))
            rw = subprocess.run([programs.find("csi-reconstruct"), p("lone.csid"), "--refine-with", p("lmore.csid"),
                                 "-o", p("lrw.exr")], capture_output=True, text=True)
            check(rw.returncode == 0 and np.array_equal(exr.read(p("lrw.exr")), exr.read(p("ls.exr")))
                  and f"{n_set} more settled" in rw.stderr,
                  f"csi-reconstruct --refine-with (settling) != csi-mitsuba's image: exit {rw.returncode} "
                  f"{rw.stderr.strip()}")
            check(json.load(open(p("p1.json")))["refine"]["settled"] == 0, "one path per sample: pixels settled")

        # Then, with several paths per sample, an HDR step's pixels the passes did not take move to
        # the coverage their window's samples allow (csi_refine_step_coverage): the Cornell box's
        # emitter rims. Against '-- --step-coverage off' the default differs at exactly the pixels
        # the stats count, each within the range of the samples of its 5 x 5 window (its own dark and
        # bright levels, or, where its own samples are of one class, the window's); csi-reconstruct
        # --refine-with on the first pass's dump gives the same bits with the second pass's
        # variances beside its dump, and without them warns and keeps the settled patch.
        cb = ["cornell", "--out", "48x48", "--spp", 4, "--paths", 4, "--seed", 3, "-q"]
        runs = {name: cli(*cb, *args) for name, args in (
            ("cb", ["--dump", p("cb.csid"), "-o", p("cb.exr"), "--stats", p("cb.json")]),
            ("off", ["-o", p("cboff.exr"), "--", "--step-coverage", "off"]),
            ("one", ["--no-refine", "--dump", p("cbone.csid")]))}
        for name, rr in runs.items():
            check(rr.returncode == 0, f"Cornell box, {name}: exit {rr.returncode}: {rr.stderr.strip()}")
        if not any(rr.returncode for rr in runs.values()):
            n_step = json.load(open(p("cb.json")))["refine"]["step_moved"]
            a_img, b_img = exr.read(p("cb.exr")).reshape(-1, 3), exr.read(p("cboff.exr")).reshape(-1, 3)
            moved = np.flatnonzero((a_img != b_img).any(axis=1))
            dc = csid.read(p("cb.csid"))
            f = dc.grid[0] // dc.out[0]
            px, py = (dc.xyt[:, 0] // f).astype(np.int64), (dc.xyt[:, 1] // f).astype(np.int64)

            def window(q):
                return dc.values[(abs(px - q % dc.out[0]) <= 2) & (abs(py - q // dc.out[0]) <= 2)]
            between = all((a_img[q] >= window(q).min(axis=0) * (1 - 1e-6)).all()
                          and (a_img[q] <= window(q).max(axis=0) * (1 + 1e-6)).all() for q in moved)
            check(n_step > 0 and len(moved) == n_step and between,
                  f"the step after the passes: stats {n_step}, pixels changed {len(moved)}, within their windows' "
                  f"samples {between}")
            c1 = csid.read(p("cbone.csid"))
            second_pass(dc, c1, p("cbmore.csid"))
            rw = subprocess.run([programs.find("csi-reconstruct"), p("cbone.csid"), "--refine-with", p("cbmore.csid"),
                                 "-o", p("cbrw0.exr")], capture_output=True, text=True)
            check(rw.returncode == 0 and np.array_equal(exr.read(p("cbrw0.exr")), exr.read(p("cboff.exr")))
                  and "no variances beside it" in rw.stderr,
                  f"--refine-with without the second pass's variances: exit {rw.returncode} {rw.stderr.strip()}")
            second_pass(dc, c1, p("cbmore.variance.csid"), csid.read(p("cb.variance.csid")).values)
            rw = subprocess.run([programs.find("csi-reconstruct"), p("cbone.csid"), "--refine-with", p("cbmore.csid"),
                                 "-o", p("cbrw.exr")], capture_output=True, text=True)
            check(rw.returncode == 0 and np.array_equal(exr.read(p("cbrw.exr")), exr.read(p("cb.exr")))
                  and f"{n_step} across an HDR step" in rw.stderr,
                  f"csi-reconstruct --refine-with (the step) != csi-mitsuba's image: exit {rw.returncode} "
                  f"{rw.stderr.strip()}")
        # Where the pick takes no pixel (--refine-share 1: no pixel holds all the disagreement or all
        # the means' sampling variance), the settling and the step still follow: csi-mitsuba's image
        # and csi-reconstruct --refine-request's are csi-reconstruct's default image of the same
        # samples, to the bit.
        z = cli(*cb, "--refine-share", 1, "--dump", p("z.csid"), "-o", p("z.exr"), "--stats", p("z.json"))
        check(z.returncode == 0, f"--refine-share 1: exit {z.returncode}: {z.stderr.strip()}")
        if z.returncode == 0:
            zst = json.load(open(p("z.json")))["refine"]
            subprocess.run([programs.find("csi-reconstruct"), p("z.csid"), "-o", p("zd.exr"), "-q"], check=True)
            zr = subprocess.run([programs.find("csi-reconstruct"), p("z.csid"), "--refine-request", p("zreq.csid"),
                                 "--refine-share", "1", "-o", p("zr.exr"), "-q"], capture_output=True, text=True)
            check(zst["cells"] == 0 and zst["settled"] + zst["step_moved"] > 0
                  and np.array_equal(exr.read(p("z.exr")), exr.read(p("zd.exr"))),
                  f"no pixel picked: stats {zst['cells']} cells, {zst['settled']} settled, {zst['step_moved']} "
                  "stepped; csi-mitsuba's image != csi-reconstruct's default")
            check(zr.returncode == 0 and not os.path.exists(p("zreq.csid"))
                  and np.array_equal(exr.read(p("zr.exr")), exr.read(p("zd.exr"))),
                  f"--refine-request picking nothing: exit {zr.returncode}, its image != the default {zr.stderr!r}")

        # Refused before any rendering: one line, exit 2, nothing written (the scene a copy: a
        # failure must not write over the repository's).
        shutil.copyfile(SCENE, p("scene.py"))
        for args, what in (((SCENE, "--no-refine", "--refine-share", "0.01", "-o", p("x.exr")),
                            "--refine-share with --no-refine"),
                           ((SCENE, "--refine", "--refine-share", "0", "-o", p("x.exr")), "share 0"),
                           ((SCENE, "--no-refine", "--refine-passes", "2", "-o", p("x.exr")),
                            "--refine-passes with --no-refine"),
                           ((SCENE, "--refine", "--refine-passes", "0", "-o", p("x.exr")), "0 passes"),
                           ((SCENE, "--dump", p("x.exr"), "-o", p("x.exr")), "the dump and the image on one path"),
                           ((SCENE, "--paths", "2", "--dump", p("x.csid"), "-o", p("x.variance.csid")),
                            "the image on the dump's variances"),
                           ((p("scene.py"), "-o", p("scene.py")), "the image over the scene"),
                           ((SCENE, "--refine", "--refine-share", "1.5", "-o", p("x.exr")), "share 1.5"),
                           ((SCENE, "--refine", "--reference", "16", "-o", p("x.exr")), "with --reference"),
                           ((SCENE, "--refine", "--time-steps", "4", "-o", p("x.exr")), "a volume"),
                           ((SCENE, "--refine", "-o", p("x.exr"), "--", "--estimator", "mean"), "the mean estimator")):
            e = cli(*args)
            check(e.returncode == 2 and len(e.stderr.strip().splitlines()) == 1 and not os.path.exists(p("x.exr")),
                  f"{what}: exit {e.returncode}, stderr {e.stderr!r}")


if __name__ == "__main__":
    main()
    sys.exit(done())
