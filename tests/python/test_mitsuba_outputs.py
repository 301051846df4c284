"""csi-mitsuba's outputs, as csi's programs treat theirs: each stated before any rendering and
refused then with one line (a directory, a missing directory, an input, another output); written
all or nothing (a write that fails after others leaves none of them); and a reconstruction that
cannot fit the device or the host refused before Mitsuba renders a sample.

Scene: Mitsuba's Cornell box at 8x8 (a fraction of a second per run).
"""
import contextlib
import io
import os
import re
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from checks import check, done  # noqa: E402
from test_mitsuba_e2e import cli  # noqa: E402  (csi-mitsuba as a user runs it; puts host/python on the path)


def refused(r, want, what):
    lines = r.stderr.strip().splitlines()
    check(r.returncode == 2 and len(lines) == 1 and want in r.stderr,
          f"{what}: exit {r.returncode}, stderr {r.stderr!r}")


def main():
    with tempfile.TemporaryDirectory() as T:
        p = lambda name: os.path.join(T, name)  # noqa: E731
        os.mkdir(p("sub"))
        base = ["cornell", "--out", "8x8", "--spp", 2, "-q"]
        before = set(os.listdir(T))
        # a directory as an output: the image's, the dump's, the statistics' (the last two were a
        # traceback after the rendering, the image already written)
        refused(cli(*base, "-o", T), "is a directory", "-o a directory")
        refused(cli(*base, "-o", p("o.exr"), "--dump", p("sub")), "is a directory", "--dump a directory")
        refused(cli(*base, "-o", p("o.exr"), "--stats", p("sub")), "is a directory", "--stats a directory")
        refused(cli(T, "--out", "8x8", "-o", p("o.exr")), "a directory, not a scene file", "a directory as the scene")
        # -o writes OpenEXR and --png a PNG: a name asking for another format is refused
        refused(cli(*base, "-o", p("o.png")), "o.png: the image (-o) is written as OpenEXR, not png", "-o named .png")
        refused(cli(*base, "-o", p("o.exr"), "--png", p("o.EXR")), "the preview (--png) is written as an 8-bit PNG",
                "--png named .EXR")
        # a write that fails after the others (the library's writers and the renames of the
        # commit, in turn): nothing of the run is left
        outs = ["-o", p("o.exr"), "--png", p("o.png"), "--dump", p("o.csid"), "--stats", p("o.json")]
        for n in range(1, 7):
            refused(cli(*base, *outs, CSI_FAIL_OUTPUT=str(n)), "o.", f"output event {n} failing")
        check(set(os.listdir(T)) == before, f"failed runs left files behind: {sorted(set(os.listdir(T)) - before)}")
        r = cli(*base, *outs)
        check(r.returncode == 0 and all(os.path.isfile(p(f"o.{e}")) for e in ("exr", "png", "csid", "json")),
              f"the same run without a failure: exit {r.returncode} {r.stderr!r}")

    # A reconstruction that cannot fit is refused before rendering: here with Mitsuba's
    # renderer replaced by one that fails the test when called.
    from csi import mitsuba_bridge, mitsuba_cli

    def render_request(*_a, **_k):
        raise AssertionError("Mitsuba rendered the samples of a run that cannot fit")

    mitsuba_bridge.render_request = render_request
    with tempfile.TemporaryDirectory() as T:
        for what, env, args, want in (
                ("device budget", {}, ["--", "--mem-budget", "1M"], "budget"),
                ("host memory", {"CSI_HOST_MEMORY_LIMIT": str(1 << 20)}, [], "host memory")):
            saved = dict(os.environ)
            os.environ.update(env)
            try:
                err = io.StringIO()
                with contextlib.redirect_stderr(err):
                    code = mitsuba_cli.main(["cornell", "--out", "64x64", "--spp", "4", "-o", os.path.join(T, "o.exr"),
                                             *args])
            except AssertionError as e:
                code, err = None, io.StringIO(str(e))
            finally:
                os.environ.clear()
                os.environ.update(saved)
            check(code == 2 and want in err.getvalue() and err.getvalue().startswith("csi-mitsuba: error: cornell:"),
                  f"{what}: exit {code}, stderr {err.getvalue()!r}")
        check(os.listdir(T) == [], f"refused runs left {os.listdir(T)}")

    # On a terminal the progress line follows the reconstruction too (the library's phases and
    # steps), not only Mitsuba's renders: a 1920x1080 run reconstructs for tens of seconds.
    with tempfile.TemporaryDirectory() as T:
        shown = on_terminal(["cornell", "--out", "64x64", "--spp", "4", "--no-refine", "-o", os.path.join(T, "o.exr")])
        check("csi-mitsuba: samples" in shown and "csi-mitsuba: reconstruction: solve 1/3  step 1" in shown,
              f"the progress on a terminal: {shown[-400:]!r}")
        check(re.search(r"reconstruction: solve 3/3  step \d+  eta \d+s", shown) is not None,
              f"no time left on the last channel's solve: {shown[-400:]!r}")

    # The time left, by hand: 2 tiles x 3 channels; the folds' "solve 1/1" is not a solve of its own
    clock = mitsuba_cli._SolveClock()
    seen = [clock.update(phase, now) for phase, now in (
        ("setup", 0.0), ("tile 1/2 solve 1/3", 1.0), ("tile 1/2 solve 2/3", 3.0), ("tile 1/2 solve 3/3", 5.0),
        ("tile 1/2 solve 1/1", 7.0), ("tile 2/2 solve 1/3", 9.0), ("tile 2/2 solve 3/3", 20.0))]
    want = [None, None, 2.0 * 5, 2.0 * 4, 2.0 * 4 - 2.0, 8.0 / 3 * 3, 19.0 / 5 * 1]
    check(all((a is None and b is None) or (a is not None and b is not None and abs(a - b) < 1e-9)
              for a, b in zip(seen, want)), f"the time left: {seen}, want {want}")
    return done()


def on_terminal(args):
    """csi-mitsuba ARGS with stderr on a pseudo-terminal: what it wrote there."""
    import pty
    import subprocess

    from test_mitsuba_e2e import PYDIR

    leader, follower = pty.openpty()
    env = dict(os.environ, PYTHONPATH=os.path.abspath(PYDIR))
    proc = subprocess.Popen([sys.executable, "-m", "csi.mitsuba_cli", *args], stdout=subprocess.DEVNULL,
                            stderr=follower, env=env)
    os.close(follower)
    out = b""
    while True:
        try:
            chunk = os.read(leader, 65536)
        except OSError:  # the child closed the terminal
            break
        if not chunk:
            break
        out += chunk
    proc.wait()
    os.close(leader)
    return out.decode(errors="replace")


if __name__ == "__main__":
    sys.exit(main())
