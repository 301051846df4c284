"""csi-farm's refusals: bad usage, inputs and outputs get one line on stderr and exit 2, with
nothing written and no input changed; those the farm can check itself (option values, a scheduler
that does not answer, a missing input, an output that is an input or cannot be written) before it
starts a cluster, and those only a csi program can judge (a damaged dump, a bad reconstruction
option, a scene with an error) from the first task, neither retried nor logged by the worker.

Inputs: a dump csi-render writes of a bundled scene at 32x32 (a second), a LocalCluster of one
worker where a task runs at all.
"""
import hashlib
import os
import subprocess
import sys
import tempfile
import time

SOURCE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BUILD = os.environ.get("CSI_BUILD_DIR") or os.path.join(SOURCE, "build")
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from checks import check, done  # noqa: E402


def farm(*args, timeout=120):
    env = dict(os.environ, PYTHONPATH=os.path.join(SOURCE, "host", "python"))
    try:
        return subprocess.run([sys.executable, "-m", "csi.farm", "--bin", BUILD, *map(str, args)],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, timeout=timeout)
    except subprocess.TimeoutExpired:
        return subprocess.CompletedProcess(args, "timeout", "", f"no answer in {timeout} s")


def digest(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def options_either_side():
    """The farm's own options before or after the command, as docs/tiles.md writes them (parsed
    only: the run is replaced by a recorder)."""
    sys.path.insert(0, os.path.join(SOURCE, "host", "python"))
    from csi import farm as csi_farm
    seen = {}
    run, csi_farm.reconstruct = csi_farm.reconstruct, lambda *a, **k: seen.update(k)
    try:
        for argv, workers, retries in ((["--workers", "3", "reconstruct", "d.csid", "-o", "o.exr"], 3, 2),
                                       (["reconstruct", "d.csid", "-o", "o.exr", "--workers", "2"], 2, 2),
                                       (["--retries", "5", "reconstruct", "d.csid", "-o", "o.exr", "-q"], None, 5)):
            seen.clear()
            rc = csi_farm.main(argv)
            check(rc == 0 and seen.get("workers") == workers and seen.get("retries") == retries,
                  f"csi-farm {' '.join(argv)}: exit {rc}, parsed {seen}")
    finally:
        csi_farm.reconstruct = run


def main():
    options_either_side()
    with tempfile.TemporaryDirectory() as T:
        p = lambda name: os.path.join(T, name)  # noqa: E731
        with open(os.path.join(SOURCE, "data", "scenes", "triangle.scene")) as f:
            scene = f.read().replace("size 256 256", "size 32 32")
        with open(p("tri.scene"), "w") as f:
            f.write(scene)
        with open(p("bad.scene"), "w") as f:
            f.write("camera {")
        subprocess.run([os.path.join(BUILD, "csi-render"), p("tri.scene"), "--spp", "2", "--dump", p("tri.csid"),
                        "-o", p("tri.exr"), "-q"], check=True)
        with open(p("tri.csid"), "rb") as f, open(p("cut.csid"), "wb") as g:
            g.write(f.read()[:1000])
        os.mkdir(p("sub"))
        before = {name: digest(p(name)) for name in os.listdir(T) if os.path.isfile(p(name))}
        cases = [
            # checked by the farm before any cluster
            ("no command", "required", []),
            ("unknown option", "unrecognized", ["reconstruct", p("tri.csid"), "-o", p("o.exr"), "--bogus"]),
            ("an unknown option alone", "--bogus", ["--bogus"]),
            ("no worker", "--workers", ["--workers", "0", "reconstruct", p("tri.csid"), "-o", p("o.exr")]),
            ("no worker, after the command", "--workers",
             ["reconstruct", p("tri.csid"), "-o", p("o.exr"), "--workers", "0"]),
            ("no tile", "--tiles", ["--tiles", "0", "reconstruct", p("tri.csid"), "-o", p("o.exr")]),
            ("negative retries", "--retries", ["--retries", "-1", "reconstruct", p("tri.csid"), "-o", p("o.exr")]),
            ("zero spp", "--spp", ["render", p("tri.scene"), "-o", p("o_%d.exr"), "--spp", "0"]),
            ("a scheduler that does not answer", "no Dask scheduler answered",
             ["--scheduler", "tcp://127.0.0.1:1", "--connect-timeout", "1", "reconstruct", p("tri.csid"), "-o",
              p("o.exr")]),
            ("not a scheduler address", "not a scheduler address",
             ["--scheduler", "banana", "reconstruct", p("tri.csid"), "-o", p("o.exr")]),
            ("--bin without the programs", "--bin holds no", ["--bin", T, "reconstruct", p("tri.csid"), "-o", p("o.exr")]),
            ("missing dump", "No such file", ["reconstruct", p("none.csid"), "-o", p("o.exr")]),
            ("a directory as the dump", "a directory", ["reconstruct", p("sub"), "-o", p("o.exr")]),
            ("the image over the dump", "would overwrite the input", ["reconstruct", p("tri.csid"), "-o", p("tri.csid")]),
            ("the preview over the dump", "would overwrite the input",
             ["reconstruct", p("tri.csid"), "-o", p("o.exr"), "--png", p("tri.csid")]),
            ("an image in a missing directory", "does not exist", ["reconstruct", p("tri.csid"), "-o", p("no/o.exr")]),
            ("a directory as the image", "is a directory", ["reconstruct", p("tri.csid"), "-o", p("sub")]),
            ("missing scene", "No such file", ["render", p("none.scene"), "-o", p("o_%d.exr")]),
            ("a pattern of two numbers", "not a pattern", ["render", p("tri.scene"), "-o", p("o_%d_%d.exr")]),
            ("the image over the scene", "would overwrite the input", ["render", p("tri.scene"), "-o", p("tri.scene")]),
            ("a file as --work-dir", "--work-dir", ["render", p("tri.scene"), "-o", p("o_%d.exr"), "--work-dir",
                                                   p("tri.csid")]),
            # judged by a csi program in the first task
            ("a damaged dump", "truncated", ["reconstruct", p("cut.csid"), "-o", p("o.exr")]),
            ("a bad reconstruction option", "--lambda",
             ["reconstruct", p("tri.csid"), "-o", p("o.exr"), "--", "--lambda", "abc"]),
            ("a scene with an error", "bad.scene", ["render", p("bad.scene"), "-o", p("o_%d.exr")]),
        ]
        for what, want, args in cases:
            t0 = time.perf_counter()
            r = farm("--workers", "1", *args)  # (the case of --workers 0 gives its own after this)
            lines = r.stderr.strip().splitlines()
            check(r.returncode == 2 and len(lines) == 1 and want in r.stderr,
                  f"{what}: exit {r.returncode} after {time.perf_counter() - t0:.1f} s, stderr {r.stderr.strip()!r}")
        after = {name: digest(p(name)) for name in os.listdir(T) if os.path.isfile(p(name))}
        check(after == before, f"the refused runs changed or left files: {sorted(set(after.items()) ^ set(before.items()))}")
    return done()


if __name__ == "__main__":
    sys.exit(main())
