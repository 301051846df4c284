"""Animations (issue 12): the Mitsuba bridge re-posing a scene per time step (a .py scene's
animate(params, time)), its reference frames, csi-reconstruct's frames as an EXR sequence, and the
previews (csi.preview: contact sheet, animated image; csi-preview's bad input).

Scene: an orthographic camera looking down -z at a sphere that emits radiance 1 (max_depth 1: only
what a ray sees first, no noise) in front of a constant sky of 0.25, the sphere's centre moving
from x = -0.5 to 0.5 over the shutter at y = 0.3. The camera's film spans x, y in [-1, 1], image
point (u, v) (v = 0 on the top row) at x = 2u - 1, y = 1 - 2v. Every value is then known in closed
form: 1 where the ray through a cell's centre hits the sphere posed at the cell's time
(t + 0.5) / T, 0.25 elsewhere.
"""
import os
import subprocess
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
PYDIR = os.path.join(HERE, "..", "..", "host", "python")
sys.path.insert(0, PYDIR)
sys.path.insert(0, HERE)
from checks import check, done  # noqa: E402
from csi import dump as csid  # noqa: E402
from csi import mitsuba_bridge as mb  # noqa: E402
from csi import preview  # noqa: E402

RADIUS = 0.35
SCENE = f"""
import mitsuba as mi
T = mi.ScalarTransform4f
def centre(time):
    return [-0.5 + time, 0.3, 0.0]
def scene():
    return {{"type": "scene", "integrator": {{"type": "path", "max_depth": 1}},
            "sensor": {{"type": "orthographic",
                       "to_world": T().look_at(origin=[0, 0, 5], target=[0, 0, 0], up=[0, 1, 0]),
                       "film": {{"type": "hdrfilm", "width": 16, "height": 16}}}},
            "sky": {{"type": "constant", "radiance": {{"type": "rgb", "value": 0.25}}}},
            "ball": {{"type": "sphere", "to_world": T().translate(centre(0.5)).scale({RADIUS}),
                     "emitter": {{"type": "area", "radiance": {{"type": "rgb", "value": 1.0}}}}}}}}
def animate(params, time):
    params["ball.to_world"] = T().translate(centre(time)).scale({RADIUS})
"""


def inside(u, v, time):
    """Signed distance (in scene units) of the ray at image point (u, v) from the sphere's
    outline at shutter time `time`: < 0 inside."""
    x, y = 2 * u - 1, 1 - 2 * v
    return np.hypot(x - (-0.5 + time), y - 0.3) - RADIUS


def main():
    build = os.environ.get("CSI_BUILD_DIR", os.path.join(HERE, "..", "..", "build"))
    with tempfile.TemporaryDirectory() as tmp:
        p = lambda name: os.path.join(tmp, name)  # noqa: E731
        with open(p("ball.py"), "w") as f:
            f.write(SCENE)
        T = 4
        scene = mb.load_scene(p("ball.py"))
        check(scene.animate is not None and scene.size == (16, 16), "the animated scene loads")

        # The grid csi-mitsuba takes (csi_camera_grid_factor): from one sample per 8 frames a
        # volume has 2 x 2 cells a pixel, with a still camera or one that translates across its
        # view; any other moving camera keeps the pixel grid (as csi-render's plan decides for
        # its own cameras).
        for name, origin, target in (("pan.py", "[0.3 * time, 0, 5]", "[0.3 * time, 0, 0]"),
                                     ("dolly.py", "[0, 0, 5 - time]", "[0, 0, -time]"),
                                     ("turn.py", "[0, 0, 5]", "[0.4 * time, 0, 0]")):
            with open(p(name), "w") as f:
                f.write(SCENE + f"\n    params['sensor.to_world'] = T().look_at(origin={origin}, target={target}, "
                        "up=[0, 1, 0])\n")
        for name, want in (("ball.py", "still"), ("pan.py", "pans"), ("dolly.py", "moves"), ("turn.py", "moves")):
            got = mb.camera_motion(mb.load_scene(p(name)))
            check(got == want, f"{name}: the camera {got}, want {want}")
        for name, spp, want in (("ball.py", 1, (32, 32, T)), ("pan.py", 1, (32, 32, T)), ("turn.py", 2, (16, 16, T)),
                                ("dolly.py", 1, (16, 16, T))):
            r = subprocess.run([sys.executable, "-m", "csi.mitsuba_cli", p(name), "--time-steps", str(T), "--spp", str(spp),
                                "--dump", p("g.csid"), "-o", p("g.exr"), "-q"], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True, env=dict(os.environ, PYTHONPATH=os.path.abspath(PYDIR)))
            got = csid.read(p("g.csid")).grid if r.returncode == 0 else r.stderr.strip()
            check(got == want, f"csi-mitsuba {name} at {spp} spp, {T} frames: grid {got}, want {want}")

        # Samples: each the closed form at its cell's pose. Cells whose centre ray passes within
        # 1e-3 of the outline are skipped (a float32 ray may fall either side; the grid's
        # spacing is 2 / 32 = 0.06 scene units, so they are rare).
        req = mb.positions_request((16, 16), grid=16, method="random", seed=3, time_steps=T, fraction=0.5)
        s = mb.render_request(scene, req, paths=1, seed=3)
        u, v, _ = req.cell_centres()
        t = req.xyt[:, 2].astype(np.float64)
        d = inside(u, v, (t + 0.5) / T)
        want = np.where(d < 0, 1.0, 0.25)
        clear = np.abs(d) > 1e-3
        check(req.grid[2] == T and clear.sum() > 0.9 * len(d), f"grid {req.grid}, {clear.sum()} of {len(d)} clear")
        err = np.abs(s.values[clear] - want[clear, None]).max()
        check(err < 1e-6, f"samples differ from the closed form at their poses by {err:.3g}")
        # the same cells at the middle pose (what a still request of this scene sees) would differ
        moved = clear & ((d < 0) != (inside(u, v, 0.5) < 0))
        check(moved.sum() > 20, f"only {moved.sum()} samples see the motion")
        check(s.nonfinite == 0 and s.timing["samples"] == len(d), f"timing {s.timing}")
        # deterministic: the same request and seed give the same bits
        s2 = mb.render_request(scene, req, paths=1, seed=3)
        check(np.array_equal(s.values, s2.values), "the same request gives different samples")

        # Reference frames (box filter): every frame is its own pose; pixels the sphere never
        # reaches are the sky, bit for bit the same in every frame (same seeds per frame).
        sref = mb.load_scene(p("ball.py"), box_filter=True)
        ref = mb.render_reference_frames(sref, T, spp=16)
        check(ref.shape == (T, 16, 16, 3), f"reference frames {ref.shape}")
        yy, xx = np.mgrid[0:16, 0:16]
        # a pixel is 0.125 wide: its whole box is outside when its centre is 0.09 (half a
        # diagonal) beyond the outline at every pose
        far = np.all([inside((xx + 0.5) / 16, (yy + 0.5) / 16, (k + 0.5) / T) > 0.09 for k in range(T)], axis=0)
        check(far.sum() > 100 and np.all(ref[:, far] == 0.25), "static sky pixels are 0.25 in every frame")
        for k in range(T):
            core = inside((xx + 0.5) / 16, (yy + 0.5) / 16, (k + 0.5) / T) < -0.09
            check(core.any() and np.all(np.abs(ref[k][core] - 1.0) < 1e-6), f"frame {k}: the sphere's pixels are 1")
        check(not np.array_equal(ref[0], ref[-1]), "the first and last reference frames are the same")

        # csi-mitsuba --reference of the animation: its motion blur over the T poses, against the
        # closed form (each pixel's box covered by the sphere at each pose, from 32 x 32 points a
        # pixel, averaged over the poses). 1024 spp in all, 256 a frame: a pixel's binomial noise
        # is at most 0.75 * 0.5 / 16 = 0.023 (frames share seeds, so it need not average down),
        # the 32 x 32 points' coverage within about 0.02 at an edge pixel: 0.1 is 4 standard
        # deviations and the points' error. A reference of one pose (the middle of the shutter,
        # as csi-mitsuba rendered before) fails this by far where the sphere passes.
        sub = (np.arange(32) + 0.5) / 32
        su, sv = np.meshgrid(sub, sub)
        uu = (xx[..., None, None] + su) / 16  # each pixel's 32 x 32 points
        vv = (yy[..., None, None] + sv) / 16
        r = subprocess.run([sys.executable, "-m", "csi.mitsuba_cli", p("ball.py"), "--time-steps", str(T),
                            "--reference", "1024", "-o", p("blur.exr"), "--stats", p("blur.json"), "-q"],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                           env=dict(os.environ, PYTHONPATH=os.path.abspath(PYDIR)))
        check(r.returncode == 0, f"csi-mitsuba --reference of an animation: {r.stderr.strip()}")
        if r.returncode == 0:
            from csi import exr
            import json

            blur = exr.read(p("blur.exr"))
            cover = np.mean([(inside(uu, vv, (k + 0.5) / T) < 0).mean(axis=(-2, -1)) for k in range(T)], axis=0)
            want = 0.25 + 0.75 * cover
            err = np.abs(blur[..., 0] - want)
            check(blur.shape == (16, 16, 3) and err.max() < 0.1 and err.mean() < 0.01,
                  f"the animation's reference against its closed-form motion blur: max {err.max():.3f}, "
                  f"mean {err.mean():.4f}")
            st = json.load(open(p("blur.json")))
            check(st["frames"] == T and st["reference_spp_per_frame"] == 1024 // T, f"reference stats {st}")

        # csi-mitsuba --frames: the reference's frames, each against its pose's closed form (the
        # same bound: 256 spp a frame), and the reconstruction's frames, the bits csi-reconstruct
        # --frames gives on the dump and its variances, the image the bits of a run without them
        env = dict(os.environ, PYTHONPATH=os.path.abspath(PYDIR))
        mcli = lambda *args: subprocess.run([sys.executable, "-m", "csi.mitsuba_cli", p("ball.py"), "-q", *args],  # noqa: E731
                                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
        from csi import exr

        r = mcli("--time-steps", str(T), "--reference", "1024", "--frames", p("rf"))
        check(r.returncode == 0 and sorted(os.listdir(p("rf"))) == sorted(f"frame_{k:04d}.{e}" for k in range(T)
                                                                        for e in ("exr", "png")),
              f"csi-mitsuba --reference --frames: {r.stderr.strip()} {os.listdir(p('rf')) if os.path.isdir(p('rf')) else ''}")
        if r.returncode == 0:
            for k in range(T):
                cover = (inside(uu, vv, (k + 0.5) / T) < 0).mean(axis=(-2, -1))
                err = np.abs(exr.read(p(f"rf/frame_{k:04d}.exr"))[..., 0] - (0.25 + 0.75 * cover))
                check(err.max() < 0.1, f"reference frame {k} against its pose's closed form: max {err.max():.3f}")
        r = mcli("--time-steps", str(T), "--spp", "2", "--seed", "3", "-o", p("mf.exr"), "--frames", p("mf"),
                 "--dump", p("mf.csid"))
        r0 = mcli("--time-steps", str(T), "--spp", "2", "--seed", "3", "-o", p("m0.exr"))
        check(r.returncode == 0 and r0.returncode == 0, f"csi-mitsuba --frames: {r.stderr.strip()} {r0.stderr.strip()}")
        if r.returncode == 0 and r0.returncode == 0:
            rr = subprocess.run([os.path.join(build, "csi-reconstruct"), p("mf.csid"), "--variance",
                                 p("mf.variance.csid"), "-o", p("rf.exr"), "--frames", p("rcf"), "-q"],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            check(rr.returncode == 0, f"csi-reconstruct --frames on csi-mitsuba's dump: {rr.stderr.strip()}")
            same = rr.returncode == 0 and all(np.array_equal(exr.read(p(f"mf/frame_{k:04d}.exr")),
                                                             exr.read(p(f"rcf/frame_{k:04d}.exr"))) for k in range(T))
            check(same, "csi-mitsuba's frames differ from csi-reconstruct --frames on its dump")
            check(np.array_equal(exr.read(p("mf.exr")), exr.read(p("m0.exr"))), "--frames changed the image")
        # refused before any rendering, one line, nothing written
        before = set(os.listdir(tmp))
        for args, want in [(["--spp", "2", "--frames", p("nf")], "give --time-steps above 1"),
                           (["--time-steps", str(T), "--spp", "2", "--frames", p("nf"), "--", "--estimator", "mean"],
                            "makes no frames"),
                           (["--time-steps", str(T), "--spp", "2", "--frames", p("no/nf")], "does not exist")]:
            r = mcli(*args)
            check(r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1 and want in r.stderr,
                  f"csi-mitsuba {args}: {r.stderr!r}")
        check(set(os.listdir(tmp)) == before, f"refused runs left {set(os.listdir(tmp)) - before}")

        # csi-reconstruct's frames of the dump: an EXR sequence the previews read back.
        csid.write(p("s.csid"), req.with_values(s.values))
        r = subprocess.run([os.path.join(build, "csi-reconstruct"), p("s.csid"), "-o", p("img.exr"), "--frames",
                            p("frames"), "-q"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        check(r.returncode == 0, f"csi-reconstruct --frames: {r.stderr.strip()}")
        fr = preview.read_frames(p("frames"))
        check(fr.shape == (T, 16, 16, 3), f"frames read back {fr.shape}")
        # the frames follow the motion: the sphere's centre of mass moves right by about one
        # pose step (0.25 of the shutter = 2 pixels) per frame
        cx = [float(((fr[k, ..., 0] - 0.25).clip(0) * xx).sum() / (fr[k, ..., 0] - 0.25).clip(0).sum()) for k in range(T)]
        steps = np.diff(cx)
        check(np.all(steps > 1.0) and np.all(steps < 3.0), f"frame centroids {np.round(cx, 2)}")
        preview.contact_sheet(p("sheet.png"), [("reference", ref), ("csi", fr)], picks=T, scale=2)
        preview.animation(p("anim.webp"), [("reference", ref), ("csi", fr)], fps=4, scale=2)
        from PIL import Image

        with Image.open(p("sheet.png")) as im:
            # two rows of T frames and the mean, 32 pixels each plus 2 of padding, a label row each
            check(im.size[0] == (T + 1) * 34 + 2 and im.size[1] > 2 * 34, f"sheet size {im.size}")
        with Image.open(p("anim.webp")) as im:
            check(getattr(im, "n_frames", 1) == T, f"animation frames {getattr(im, 'n_frames', 1)}")

        # Bad input: one line, exit 2, nothing written.
        before = set(os.listdir(tmp))
        for args, want in [([p("nothere")], "not a directory"), ([tmp], "no frame_NNNN.exr"),
                           ([p("frames")], "no output given")]:
            out = [] if want == "no output given" else ["-o", p("x.png")]
            r = subprocess.run([sys.executable, "-m", "csi.preview", *args, *out], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True, env=dict(os.environ, PYTHONPATH=os.path.abspath(PYDIR)))
            lines = r.stderr.strip().splitlines()
            check(r.returncode == 2 and len(lines) == 1 and want in r.stderr, f"csi-preview {args}: {r.stderr!r}")
        # outputs as csi's programs state theirs (before: a frame overwritten by the sheet, one
        # output over the other, the sheet left when the animation failed, all exit 0 or after
        # the drawing); a canvas too large refused (before: minutes to a MemoryError)
        frame0 = open(p("frames/frame_0000.exr"), "rb").read()
        for args, want in [(["-o", p("frames/frame_0000.exr")], "would overwrite the input"),
                           (["-o", p("x.gif"), "--animation", p("x.gif")], "are the same file"),
                           (["-o", p("x.png"), "--animation", p("no/x.webp")], "does not exist"),
                           (["--animation", p("x.mp4")], "name it .webp or .gif"),
                           (["-o", p("frames")], "is a directory"),
                           (["-o", p("x.png"), "--scale", "100000"], "more than the"),
                           (["-o", p("x.png"), "--exposure", "inf"], "--exposure"),
                           (["-o", p("x.png"), "--scale", "abc"], "--scale")]:
            try:
                r = subprocess.run([sys.executable, "-m", "csi.preview", p("frames"), *args], stdout=subprocess.PIPE,
                                   stderr=subprocess.PIPE, text=True, timeout=60,
                                   env=dict(os.environ, PYTHONPATH=os.path.abspath(PYDIR)))
            except subprocess.TimeoutExpired:
                r = subprocess.CompletedProcess(args, "timeout", "", "no answer in 60 s")
            lines = r.stderr.strip().splitlines()
            check(r.returncode == 2 and len(lines) == 1 and want in r.stderr, f"csi-preview {args}: {r.stderr!r}")
        check(open(p("frames/frame_0000.exr"), "rb").read() == frame0, "csi-preview wrote over a frame")
        check(set(os.listdir(tmp)) == before, "csi-preview's failures left files")
        with open(p("bad.py"), "w") as f:
            f.write(SCENE.replace('params["ball.to_world"]', 'params["no_such_key"]'))
        try:
            mb.load_scene(p("bad.py"))
            check(False, "a failing animate() is not reported")
        except mb.BridgeError as e:
            check("bad.py" in str(e) and "animate" in str(e) and "\n" not in str(e), f"animate failure: {e}")
    return done()


if __name__ == "__main__":
    sys.exit(main())
