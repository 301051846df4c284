"""csi-mitsuba end to end, as a user runs it: positions -> Mitsuba -> csi's library in-process
(the bits of csi-reconstruct on the dump), compared with Mitsuba's own box-filtered reference;
determinism; Mitsuba XML scenes (as users write them too: a film by <ref>, the sensor in an
<include>d file, a luminance film, a scene that renders black); positions requests; bad input
(exit 2, one line on stderr, nothing left behind: also no integrator, a crop window with --out,
--time-steps on a still scene, a plugin RGB cannot render, an XML error named at its file's line,
bad -D parameters, a --sensor the scene lacks); -D for an XML scene's $parameters; --sensor by id
and by index; NaN samples and references said in one warning line even with -q; the outputs' file
modes alike.

Scene: Mitsuba's Cornell box at 64x64, 4 samples per pixel of 16 paths each (csi's default grid
for 4 spp: 8x, 512x512 cells), reference 256 spp.
"""
import glob
import json
import os
import subprocess
import sys
import tempfile

import numpy as np
from PIL import Image

HERE = os.path.dirname(os.path.abspath(__file__))
PYDIR = os.path.join(HERE, "..", "..", "host", "python")
sys.path.insert(0, PYDIR)
sys.path.insert(0, HERE)
from checks import check, done  # noqa: E402
from csi import dump as csid  # noqa: E402
from csi import exr  # noqa: E402
from csi import programs  # noqa: E402


def cli(*args, **env_extra):
    env = dict(os.environ, PYTHONPATH=os.path.abspath(PYDIR), **env_extra)
    return subprocess.run([sys.executable, "-m", "csi.mitsuba_cli", *map(str, args)], stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE, text=True, env=env)


def ok(p, what):
    check(p.returncode == 0, f"{what}: exit {p.returncode}: {p.stderr.strip()}")
    return p.returncode == 0


XML = """<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="4"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="40"/><integer name="height" value="30"/>
      <rfilter type="gaussian"/></film>
  </sensor>
  <emitter type="constant"><rgb name="radiance" value="0.8, 0.9, 1.0"/></emitter>
  <shape type="sphere"><float name="radius" value="0.8"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.3, 0.2"/></bsdf></shape>
</scene>
"""


def main():
    with tempfile.TemporaryDirectory() as T:
        p = lambda name: os.path.join(T, name)  # noqa: E731
        # One pass (--no-refine): exactly 4 samples per pixel at csi's positions, the image csi-reconstruct's
        # on the dump; the default second pass is test_mitsuba_refine's.
        common = ["cornell", "--out", "64x64", "--spp", 4, "--paths", 16, "--seed", 2, "-q", "--no-refine"]
        ok(cli(*common, "--dump", p("a.csid"), "--aov", "-o", p("cs.exr"), "--stats", p("a.json")), "render + csi")
        ok(cli(*common, "--dump", p("b.csid"), "-o", p("mean.exr"), "--", "--estimator", "mean"), "render + mean")
        ok(cli(*common, "--dump", p("b.csid"), "--no-variance-peaks", "-o", p("csn.exr")),
           "render + csi without the variances")
        ok(cli("cornell", "--out", "64x64", "--reference", 256, "--npy", p("ref.npy"), "-o", p("ref.exr"),
               "--png", p("ref.png"), "-q"), "reference")
        modes = {f: os.stat(p(f)).st_mode & 0o777 for f in ("a.json", "cs.exr", "a.csid", "ref.npy", "ref.exr")
                 if os.path.exists(p(f))}
        check(len(set(modes.values())) == 1, f"the outputs' modes differ: {modes}")
        d = csid.read(p("a.csid"), want="samples")
        check(d.grid == (512, 512, 1) and d.out == (64, 64) and len(d.xyt) == 4 * 64 * 64 and d.channels == 3,
              f"dump header: grid {d.grid}, out {d.out}, {len(d.xyt)} samples, {d.channels} channels")
        with open(p("a.csid"), "rb") as f1, open(p("b.csid"), "rb") as f2:
            check(f1.read() == f2.read(), "the same seed gives different samples")
        alb, nrm = csid.read(p("a.albedo.csid")), csid.read(p("a.normal.csid"))
        check(np.array_equal(alb.xyt, d.xyt) and np.array_equal(nrm.xyt, d.xyt), "aov positions differ from the samples'")
        check(alb.values.min() >= 0 and alb.values.max() <= 1, "albedo outside [0, 1]")
        length = np.linalg.norm(nrm.values, axis=1)  # 0 where the ray leaves the box
        check((np.minimum(np.abs(length - 1), length) < 1e-3).all() and (length > 0.5).mean() > 0.9,
              f"normals neither unit length nor 0 (a miss): {np.unique(length.round(3))[:10]}")
        with open(p("a.json")) as f:
            st = json.load(f)
        check(st["samples"] == 16384 and st["mitsuba"]["paths"] == 16 * 16384 and st["mitsuba"]["per_path_us"] > 0
              and "reconstruction" in st, f"stats: {st}")

        ref = np.load(p("ref.npy"))
        check(np.allclose(exr.read(p("ref.exr")), ref, rtol=0, atol=0), "reference EXR differs from the .npy")
        # its preview: IEC 61966-2-1's sRGB encoding of the clamped linear values, to 8 bits (the
        # library's PNG writer's; one level of rounding apart)
        lin = np.clip(ref.astype(np.float64), 0, 1)
        srgb = np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * lin ** (1 / 2.4) - 0.055) * 255
        png = np.asarray(Image.open(p("ref.png")).convert("RGB"), dtype=np.float64)
        check(png.shape == ref.shape and np.abs(png - srgb).max() <= 0.5 + 1e-6,
              f"the reference's preview is not its sRGB encoding: {np.abs(png - srgb).max() if png.shape == ref.shape else png.shape}")
        mean_img = exr.read(p("mean.exr")).astype(np.float64)
        # csi-reconstruct's mean estimator is the per-pixel mean of the very samples in the dump
        # (float32 output: relative rounding 6e-8, summation order apart).
        m = d.pixel_means()
        check(np.abs(mean_img - m).max() <= 1e-6 * max(1.0, np.abs(m).max()), "csi's mean != numpy's mean of the dump")
        # Unbiased against Mitsuba's own box-filtered render: each pixel's mean of 4 samples has
        # variance s2/4 (s2: the 4 samples' unbiased variance); the reference averages 256
        # paths per pixel where the mean has 4 x 16 = 64, so its variance is about 64/256 of
        # that. The image-wide sum of differences over its standard error is then ~N(0, 1):
        # |z| < 5 unless the positions or pixel conventions disagree.
        v = d.values.astype(np.float64)
        bw = 512 // 64
        pix = (d.xyt[:, 1] // bw) * 64 + d.xyt[:, 0] // bw
        order = np.argsort(pix, kind="stable")
        s = v[order].reshape(64 * 64, 4, 3)
        var_pix = s.var(axis=1, ddof=1) / 4
        diff = (m.reshape(-1, 3) - ref.reshape(-1, 3).astype(np.float64))
        var_ref = var_pix * (4 * 16 / 256)
        z = diff.sum(axis=0) / np.sqrt((var_pix + var_ref).sum(axis=0))
        check((np.abs(z) < 5).all(), f"mean of the samples is biased against the reference: z = {z}")
        # and its MSE is at most what that variance predicts: s2 counts the signal's spread
        # within a pixel as noise, which well-spread positions (Poisson-disk) partly cancel, so
        # the ratio is below 1 (measured 0.55); misplaced samples would add the squared edge
        # differences of a shifted image on top.
        ratio = (diff ** 2).sum() / (var_pix + var_ref).sum()
        check(ratio < 1.2, f"MSE(mean, reference) / predicted variance = {ratio:.3f}")
        # csi-mitsuba reconstructs in its own process through the library: the bits of
        # csi-reconstruct on the dump it wrote (the same samples, options and seed; with 16 paths
        # per sample both use the variances beside the dump by default, and neither with
        # --no-variance-peaks / --variance none)
        subprocess.run([programs.find("csi-reconstruct"), p("a.csid"), "-o", p("cs_c.exr"), "-q"], check=True)
        check(np.array_equal(exr.read(p("cs.exr")), exr.read(p("cs_c.exr"))),
              "csi-mitsuba's image differs from csi-reconstruct's on its dump (and the variances beside it)")
        subprocess.run([programs.find("csi-reconstruct"), p("b.csid"), "-o", p("csn_c.exr"), "-q",
                        "--variance", "none"], check=True)
        check(np.array_equal(exr.read(p("csn.exr")), exr.read(p("csn_c.exr"))),
              "csi-mitsuba --no-variance-peaks differs from csi-reconstruct --variance none on its dump")
        check(not np.array_equal(exr.read(p("csn.exr")), exr.read(p("cs.exr"))),
              "the variances changed nothing (this seed's samples hold peaks their noise explains)")
        # Each sample's variance (its 16 paths' sample variance / 16): the dump's positions,
        # >= 0, and no larger on average than the within-pixel spread s2 above, whose
        # expectation is the paths' variance plus the signal's spread over the pixel (both
        # averages over 16384 samples: the check is far from their noise).
        va = csid.read(p("a.variance.csid"))
        check(np.array_equal(va.xyt, d.xyt) and va.values.shape == d.values.shape and (va.values >= 0).all(),
              "the variances' positions or values")
        check(va.values.astype(np.float64).mean() <= s.var(axis=1, ddof=1).mean() and va.values.mean() > 0,
              f"mean sample variance {va.values.mean():.4g} vs within-pixel {s.var(axis=1, ddof=1).mean():.4g}")
        # csi's own estimate resembles the scene: far below the error of a flat image at the
        # reference's mean (the reference's variance), which any image of the scene beats
        cs = exr.read(p("cs.exr")).astype(np.float64)
        mse_cs = ((cs - ref) ** 2).mean()
        check(mse_cs < 0.05 * ref.var(), f"csi: MSE {mse_cs:.4g} vs the reference's variance {ref.var():.4g}")

        # A Mitsuba XML scene: film size and filter overridden, a request evaluated as given.
        with open(p("s.xml"), "w") as f:
            f.write(XML)
        ok(cli(p("s.xml"), "--out", "16x12", "--reference", 16, "--npy", p("x.npy"), "-q"), "XML reference")
        check(os.path.exists(p("x.npy")) and np.load(p("x.npy")).shape == (12, 16, 3), "XML reference shape")
        subprocess.run([os.path.join(os.environ.get("CSI_BUILD_DIR", ""), "csi-positions"), "--out", "16x12",
                        "--spp", "2", "--method", "stratified", "--seed", "9", "-o", p("req.csid"), "-q"], check=True)
        ok(cli(p("s.xml"), "--request", p("req.csid"), "--dump", p("x.csid"), "-q"), "XML + request")
        req, x = csid.read(p("req.csid")), csid.read(p("x.csid"))
        check(x.grid == req.grid and x.out == (16, 12) and np.array_equal(x.xyt, req.xyt) and x.seed == 9,
              "the dump does not keep the request's grid, positions and seed")
        # a request in another order with a repeated position goes through the library's dump
        # reader (sorted, repeats averaged): the bits csi-reconstruct gives on the dump
        rev = csid.Dump(grid=req.grid, out=req.out, xyt=np.concatenate([req.xyt[::-1], req.xyt[:1]]), values=None,
                        seed=9)
        csid.write(p("rev.csid"), rev)
        ok(cli(p("s.xml"), "--request", p("rev.csid"), "--dump", p("r.csid"), "-o", p("r.exr"), "-q"),
           "XML + unordered request")
        subprocess.run([programs.find("csi-reconstruct"), p("r.csid"), "-o", p("r_c.exr"), "-q"], check=True)
        check(np.array_equal(exr.read(p("r.exr")), exr.read(p("r_c.exr"))),
              "an unordered request: csi-mitsuba's image differs from csi-reconstruct's on its dump")
        # the sphere (radius 0.8 at distance 4, fov 40 along x) fills the middle: lit reddish
        # diffuse there, the sky (0.8, 0.9, 1.0) at the corners
        u, vv, _ = x.cell_centres()
        corner = (np.abs(u - 0.5) > 0.4) & (np.abs(vv - 0.5) > 0.4)
        check(np.allclose(x.values[corner], [0.8, 0.9, 1.0], atol=1e-5), "sky radiance at the corners")
        centre = (np.abs(u - 0.5) < 0.1) & (np.abs(vv - 0.5) < 0.1)
        check(centre.any() and (x.values[centre][:, 0] > x.values[centre][:, 2]).all(), "the red sphere in the middle")

        # Scenes as users write them: the film given by <ref>, the sensor in an <include>d file
        # (the bridge edits the film through Mitsuba's own parser); a luminance film whose
        # reference is still RGB; a scene whose sensor sees nothing gives a black image at 1 spp.
        sensor = XML[XML.index("<sensor"):XML.index("</sensor>") + len("</sensor>")]
        with open(p("cam.xml"), "w") as f:
            f.write('<scene version="3.0.0">' + sensor + "</scene>")
        with open(p("inc.xml"), "w") as f:
            f.write(XML.replace(sensor, '<include filename="cam.xml"/>'))
        film = sensor[sensor.index("<film"):sensor.index("</film>") + len("</film>")]
        with open(p("ref.xml"), "w") as f:
            f.write(XML.replace(film, '<ref id="myfilm"/>').replace("<sensor", film.replace(
                '<film type="hdrfilm">', '<film type="hdrfilm" id="myfilm">') + "<sensor", 1))
        for name in ("inc", "ref"):
            if ok(cli(p(name + ".xml"), "--out", "16x12", "--spp", 1, "-o", p(name + ".exr"), "-q"), f"XML: {name}"):
                im = exr.read(p(name + ".exr"))
                check(im.shape == (12, 16, 3) and im[6, 8, 0] > im[6, 8, 2], f"XML {name}: {im.shape}, the red sphere")
        with open(p("lum.xml"), "w") as f:
            f.write(XML.replace('<film type="hdrfilm">', '<film type="hdrfilm"><string name="pixel_format" '
                                'value="luminance"/>'))
        ok(cli(p("lum.xml"), "--out", "16x12", "--reference", 16, "--npy", p("lum.npy"), "-q"), "luminance film reference")
        lum = np.load(p("lum.npy")) if os.path.exists(p("lum.npy")) else np.zeros((1, 1, 3))
        check(lum.shape == (12, 16, 3) and lum[6, 8, 0] > 1.5 * lum[6, 8, 2],
              f"a luminance film's reference is csi's RGB: {lum.shape}, centre {lum[6, 8] if lum.shape[0] > 6 else None}")
        with open(p("black.xml"), "w") as f:
            f.write(XML.replace('<emitter type="constant"><rgb name="radiance" value="0.8, 0.9, 1.0"/></emitter>', ""))
        if ok(cli(p("black.xml"), "--out", "16x12", "--spp", 1, "-o", p("black.exr"), "-q"), "a black scene at 1 spp"):
            check(not exr.read(p("black.exr")).any(), "a black scene at 1 spp: the image is 0")

        # -D gives an XML scene's $parameters (as mitsuba -D); what is wrong with the samples is
        # said even with -q, in one line, and Mitsuba's own warnings are not
        with open(p("param.xml"), "w") as f:
            f.write(XML.replace('<integer name="width" value="40"/>', '<integer name="width" value="$w"/>'))
        if ok(cli(p("param.xml"), "-D", "w=20", "--spp", 1, "-o", p("param.exr"), "-q"), "-D w=20"):
            check(exr.read(p("param.exr")).shape == (30, 20, 3), "-D w=20: the film 20 wide")
        with open(p("nan.xml"), "w") as f:
            f.write(XML.replace('value="0.8, 0.9, 1.0"', 'value="nan, 0.9, 1.0"'))
        for what, args, want in (("samples", ["--spp", 1, "-o", p("nan.exr")], "paths were NaN or Inf"),
                                 ("reference", ["--reference", 4, "-o", p("nanref.exr")], "reference's pixels are NaN")):
            r = cli(p("nan.xml"), "--out", "16x12", "-q", *args)
            check(r.returncode == 0 and len(r.stderr.strip().splitlines()) == 1 and want in r.stderr,
                  f"NaN {what} with -q: exit {r.returncode}, stderr {r.stderr.strip()!r}")

        # --sensor picks one of the scene's sensors, by id or by index in declaration order: a
        # second one (id "sky", a 12 x 10 film) looks away from the sphere, so that every
        # pixel it sees is the constant emitter's radiance
        sky = ('  <sensor type="perspective" id="sky">\n'
               '    <transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 8" up="0, 1, 0"/></transform>\n'
               '    <film type="hdrfilm"><integer name="width" value="12"/><integer name="height" value="10"/></film>\n'
               '  </sensor>\n')
        with open(p("two.xml"), "w") as f:
            f.write(XML.replace("  <emitter", sky + "  <emitter"))
        if (ok(cli(p("two.xml"), "--sensor", "sky", "--spp", 1, "-o", p("sky.exr"), "-q"), "--sensor sky")
                and ok(cli(p("two.xml"), "--sensor", 1, "--spp", 1, "-o", p("sky1.exr"), "-q"), "--sensor 1")
                and ok(cli(p("two.xml"), "--out", "16x12", "--spp", 1, "-o", p("first.exr"), "-q"), "no --sensor")):
            a = exr.read(p("sky.exr"))
            check(a.shape == (10, 12, 3) and np.allclose(a, [0.8, 0.9, 1.0], rtol=1e-5, atol=0),
                  f"--sensor sky: {a.shape}, values {a.reshape(-1, 3).min(axis=0)} .. {a.reshape(-1, 3).max(axis=0)}")
            check(np.array_equal(a, exr.read(p("sky1.exr"))), "--sensor 1 and --sensor sky: the same image")
            first = exr.read(p("first.exr"))
            check(first.shape == (12, 16, 3) and first[6, 8, 0] > 1.5 * first[6, 8, 2],
                  f"without --sensor, the first sensor (the sphere at the centre): {first[6, 8]}")

        # Bad input: exit 2, one line, nothing written.
        with open(p("noint.xml"), "w") as f:
            f.write(XML.replace('<integrator type="path"><integer name="max_depth" value="4"/></integrator>', ""))
        with open(p("crop.xml"), "w") as f:
            f.write(XML.replace('<rfilter type="gaussian"/>', '<integer name="crop_width" value="20"/>'))
        with open(p("bb.xml"), "w") as f:
            f.write(XML.replace('<rgb name="radiance" value="0.8, 0.9, 1.0"/>',
                                '<spectrum type="blackbody" name="radiance"><float name="temperature" value="3000"/></spectrum>'))
        with open(p("line.xml"), "w") as f:  # the declaration and comments kept: the error's line is the file's
            f.write('<?xml version="1.0"?>\n<!-- a comment -->\n' + XML.replace('value="0.7, 0.3, 0.2"', 'value="0.7, 0.3"'))
        bad_line = 2 + XML.split("\n").index(next(l for l in XML.split("\n") if "0.7, 0.3, 0.2" in l)) + 1
        with open(p("bad.xml"), "w") as f:
            f.write('<scene version="3.0.0"><sensor type="perspective">')
        with open(p("bad2.xml"), "w") as f:
            f.write('<scene version="3.0.0"><sensor type="perspective"/><shape type="no_such_plugin"/></scene>')
        before = set(os.listdir(T))
        cases = [
            ("missing scene", "nothere.xml", [p("nothere.xml"), "-o", p("o.exr")]),
            ("a device as the scene", "not a regular file", ["/dev/null", "-o", p("o.exr")]),
            ("malformed XML", "bad.xml", [p("bad.xml"), "-o", p("o.exr")]),
            ("Mitsuba refuses the XML", "no_such_plugin", [p("bad2.xml"), "-o", p("o.exr")]),
            ("bad size", "--out", ["cornell", "--out", "64x0", "-o", p("o.exr")]),
            ("zero paths", "--paths", ["cornell", "--paths", "0", "-o", p("o.exr")]),
            ("no output", "no output", ["cornell"]),
            ("aov without dump", "--aov", ["cornell", "--aov", "-o", p("o.exr")]),
            ("variance peaks of one path", "--variance-peaks", ["cornell", "--variance-peaks", "-o", p("o.exr")]),
            ("unwritable", "no-such-dir", ["cornell", "--out", "8x8", "-o", p("no-such-dir/o.exr")]),
            ("request size", "differs", [p("s.xml"), "--request", p("req.csid"), "--out", "8x8", "--dump", p("o.csid")]),
            ("samples as request", "not a positions request", [p("s.xml"), "--request", p("x.csid"), "--dump", p("o.csid")]),
            ("bad csi-reconstruct option", "--lambda", ["cornell", "--out", "8x8", "-o", p("o.exr"), "--dump", p("o.csid"),
                                                        "--", "--lambda", "abc"]),
            ("an unknown option alone", "--bogus", ["--bogus"]),
            ("-D without a value", "NAME=VALUE", [p("s.xml"), "-D", "w", "-o", p("o.exr")]),
            ("-D on the Cornell box", "has none", ["cornell", "-D", "w=1", "-o", p("o.exr")]),
            ("an undefined $parameter", "undefined parameter", [p("param.xml"), "--out", "8x8", "-o", p("o.exr")]),
            ("an unused -D", "unused parameters", [p("s.xml"), "-D", "bogus=1", "--out", "8x8", "-o", p("o.exr")]),
            ("no integrator", "no integrator", [p("noint.xml"), "--out", "8x8", "-o", p("o.exr")]),
            ("a crop window and --out", "crop window", [p("crop.xml"), "--out", "8x8", "-o", p("o.exr")]),
            ("--time-steps on a still scene", "is still", [p("s.xml"), "--out", "8x8", "--time-steps", "4", "-o",
                                                          p("o.exr")]),
            ("a plugin RGB cannot render", "cannot render", [p("bb.xml"), "--out", "8x8", "--spp", "1", "-o", p("o.exr")]),
            ("an error named at its line", f"line.xml (line {bad_line},", [p("line.xml"), "--out", "8x8", "-o", p("o.exr")]),
            ("a sensor index beyond the scene's", "has 2 sensors: 0, 1 (sky)", [p("two.xml"), "--sensor", "2", "-o",
                                                                             p("o.exr")]),
            ("a sensor id the scene lacks", "no sensor has that id", [p("two.xml"), "--sensor", "top", "-o", p("o.exr")]),
            ("frames after --", "csi-mitsuba's own --frames DIR", ["cornell", "--out", "8x8", "-o", p("o.exr"), "--", "--frames", "d"]),
            ("settle with the second pass", "--settle", ["cornell", "--out", "8x8", "-o", p("o.exr"), "--", "--settle",
                                                         "on"]),
            ("the step's coverage with the second pass", "--step-coverage",
             ["cornell", "--out", "8x8", "-o", p("o.exr"), "--", "--step-coverage", "on"]),
        ]
        # an LLVM Mitsuba cannot use: named before Dr.Jit starts (it would print several lines,
        # or abort inside code generation on LLVM < 16)
        old_llvm = sorted(glob.glob("/usr/lib/*-linux-gnu/libLLVM-1[0-5].so*"))
        envs = [("missing LLVM library", "no such file", {"DRJIT_LIBLLVM_PATH": p("nothere/libLLVM-19.so")}),
                ("missing csi library", "CSI_LIBRARY=", {"CSI_LIBRARY": p("nothere/libcsi.so")})]
        if old_llvm:
            envs.append(("LLVM too old", "needs LLVM >= 16", {"DRJIT_LIBLLVM_PATH": old_llvm[0]}))
        cases += [(name, want, ["cornell", "--out", "8x8", "-o", p("o.exr")], env) for name, want, env in envs]
        for name, want, args, *env in cases:
            r = cli(*args, **(env[0] if env else {}))
            lines = r.stderr.strip().splitlines()
            check(r.returncode == 2 and len(lines) == 1 and want in r.stderr,
                  f"{name}: exit {r.returncode}, stderr: {r.stderr.strip()!r}")
        left = set(os.listdir(T)) - before
        check(not left, f"failures left files behind: {sorted(left)}")
    return done()


if __name__ == "__main__":
    sys.exit(main())
