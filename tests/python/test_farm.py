"""csi-farm on a Dask LocalCluster of 2 worker processes on 127.0.0.1 (host/python/csi/farm.py).

Claims:
  1. the farm's image is bit-identical to the single-process tiled run (csi-reconstruct --tiles N
     on the same dump): the image hashes in the statistics agree;
  2. a worker killed (SIGKILL) while it runs a tile costs nothing: Dask runs the tile again on a
     worker, the image is still bit-identical, the killed worker's csi-reconstruct does not
     outlive it, nothing but the requested outputs appears in the output directory, and the
     farm's scratch directory is gone at the end;
  3. the frames of an animation: two scenes rendered and reconstructed by csi-farm render give
     each the bits of csi-render --tiles N on that scene;
  4. a moving scene's volume in time windows (--tiles-t 2), each window a task whose partial
     carries its residual sums for the whole shutter's correction (csi/tiles.h): the bits of
     csi-reconstruct --tiles-t 2 in one process;
  5. an image whose sides the FFT cannot take (74 x 46 pixels: 37 and 23 are prime), which one
     process solves on a padded grid and crops: by default the padded whole (one task), with
     --tiles 2 tiles of the padded grid (its own has no layout of 2), with --tiles 4 tiles of its
     own grid; each the EXR of csi-reconstruct in one process with the same options, byte for
     byte; and a volume of 11 frames (a prime count), solved on 12, in 2 x/y tiles: the same.
The dumps are written here from an analytic image (no renderer involved): a 128 x 128 image on a
1024 x 1024 grid, 4 samples per pixel at distinct random cells, 8 tiles; and the same at 74 x 46.
Run by ctest with CSI_BUILD_DIR set (the programs) and this tree's host/python on PYTHONPATH.
"""
import filecmp
import json
import os
import signal
import sys
import tempfile
import threading
import time

import numpy as np

SOURCE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BUILD = os.environ.get("CSI_BUILD_DIR") or os.path.join(SOURCE, "build")
sys.path.insert(0, os.path.join(SOURCE, "host", "python"))
from csi import farm  # noqa: E402

failures = []


def check(cond, what):
    if not cond:
        failures.append(what)
        print("FAIL:", what, file=sys.stderr)


def write_dump(path, out=128, out_h=None, factor=8, spp=4, seed=5):
    """A one-channel dump (docs/dump-format.md) of a smooth image with edges, out x out_h pixels
    (out_h None: square), sampled at distinct random cells."""
    out_h = out_h or out
    gw, gh = out * factor, out_h * factor
    rng = np.random.default_rng(seed)
    lin = np.sort(rng.choice(gw * gh, size=out * out_h * spp, replace=False))
    x, y = lin % gw, lin // gw
    u, v = (x + 0.5) / gw, (y + 0.5) / gh
    val = 0.3 + 0.2 * np.sin(2 * np.pi * 3 * u) * np.cos(2 * np.pi * 2 * v) + 0.4 * ((u - 0.5) ** 2 + (v - 0.4) ** 2 < 0.06)
    hdr = np.zeros(16, "<u4")
    hdr[:8] = [int.from_bytes(b"CSID", "little"), 1, gw, gh, 1, out, out_h, 1]
    hdr[8] = len(lin)
    rec = np.zeros(len(lin), dtype=[("p", "<u4", 3), ("v", "<f4", 1)])
    rec["p"][:, 0], rec["p"][:, 1] = x, y
    rec["v"][:, 0] = val
    with open(path, "wb") as f:
        f.write(hdr.tobytes())
        f.write(rec.tobytes())


def image_hash(stats):
    with open(stats) as f:
        return json.load(f)["image_fnv1a64"]


def process_stat(pid):
    """The fields of /proc/PID/stat after the command name (state first), or None when gone."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()
    except OSError:
        return None


def user_time(pid):
    """PID's user CPU time in clock ticks, or None when it is gone or a zombie."""
    st = process_stat(pid)
    return int(st[11]) if st and st[0] not in ("Z", "X") else None


def csi_processes(marker):
    """PIDs of running processes whose command line mentions marker."""
    out = []
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                if marker.encode() in f.read() and int(pid) != os.getpid():
                    out.append(int(pid))
        except OSError:
            pass
    return out


def progress_lines():
    """The progress line's time left, by hand: 4 tasks, the first done 3 s after the start (9 s
    left at that rate), the third at 9 s (3 s left), none said after the last."""
    import io

    p = farm.Progress(4, stream=io.StringIO())
    p.t0 = 10.0
    check(p.left(12.0) is None, "a time left before any task finished")
    p.done = 1
    check(abs(p.left(13.0) - 9.0) < 1e-12, f"1 of 4 done after 3 s: {p.left(13.0)} s left, want 9")
    p.done = 3
    check(abs(p.left(19.0) - 3.0) < 1e-12, f"3 of 4 done after 9 s: {p.left(19.0)} s left, want 3")
    p.t0 = time.perf_counter()
    p.step("tile 4")
    line = p.stream.getvalue()
    check(line.startswith("csi-farm: [4/4] tile 4 (") and "left" not in line, f"the last task's line: {line!r}")


def main():
    from distributed import Client, LocalCluster
    import subprocess

    progress_lines()

    os.environ.setdefault("CSI_CACHE_DIR", os.path.join(os.path.expanduser("~"), ".cache", "csi"))
    tmp = tempfile.mkdtemp(prefix="csi-test-farm-")
    # A private temporary directory for this process and the workers it starts (they inherit
    # TMPDIR): the scratch check below must not see the farm directories of other runs on a
    # shared machine.
    private = os.path.join(tmp, "tmp")
    os.mkdir(private)
    os.environ["TMPDIR"] = tempfile.tempdir = private
    dump = os.path.join(tmp, "img.csid")
    write_dump(dump)
    recon = os.path.join(BUILD, "csi-reconstruct")
    opts = ["--tile-margin", "8", "--max-iter", "60"]
    ref_stats = os.path.join(tmp, "ref.json")
    subprocess.run([recon, dump, "-o", os.path.join(tmp, "ref.exr"), "--tiles", "8", "--stats", ref_stats, "-q"] + opts,
                   check=True)
    ref = image_hash(ref_stats)
    with open(ref_stats) as f:
        check(json.load(f)["tiles"] == 8, "the reference run has 8 tiles")

    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                           dashboard_address="127.0.0.1:0")
    client = Client(cluster)
    try:
        # 1. bit-identical to the single-process tiled run
        out1 = os.path.join(tmp, "out1")
        os.mkdir(out1)
        farm.reconstruct(dump, os.path.join(out1, "img.exr"), stats=os.path.join(out1, "img.json"), tiles=8,
                         options=opts, client=client, bin_dir=BUILD, quiet=True)
        check(image_hash(os.path.join(out1, "img.json")) == ref, "2 workers: the farm's image differs from --tiles 8")
        check(filecmp.cmp(os.path.join(out1, "img.exr"), os.path.join(tmp, "ref.exr"), shallow=False),
              "2 workers: the farm's EXR is not --tiles 8's, byte for byte")

        # 2. a worker killed mid-tile
        out2 = os.path.join(tmp, "out2")
        os.mkdir(out2)
        result = {}

        def run():
            try:
                farm.reconstruct(dump, os.path.join(out2, "img.exr"), stats=os.path.join(out2, "img.json"), tiles=8,
                                 options=opts, client=client, bin_dir=BUILD, quiet=True)
                result["ok"] = True
            except Exception as e:  # reported below
                result["error"] = repr(e)

        th = threading.Thread(target=run)
        th.start()
        killed, victim_children = None, []
        deadline = time.time() + 300
        while killed is None and th.is_alive() and time.time() < deadline:
            for addr, keys in client.processing().items():
                if any(str(k).startswith("task_tile") for k in keys):
                    # the tile's csi-reconstruct is running under this worker: kill the worker
                    pid = client.run(os.getpid, workers=[addr])[addr]
                    victims = [p for p in csi_processes(dump) if (process_stat(p) or [None, None])[1] == str(pid)]
                    if not victims:
                        continue
                    victim_children = victims
                    os.kill(pid, signal.SIGKILL)
                    killed = pid
                    print(f"killed worker {addr} (pid {pid}) while its csi-reconstruct {victims} ran a tile")
                    break
            time.sleep(0.02)
        # Whether the killed worker's csi-reconstruct outlived it: once the worker is gone, a child
        # killed with it (PR_SET_PDEATHSIG) runs no more user code, though it may show in /proc a
        # while longer (its memory torn down, then a zombie until something reaps it); one that
        # survived goes on computing its tile (a few tenths of a second here: measured at once).
        # So: its user time must not grow by more than the tick of its last moments.
        outlived = []
        if killed is not None:
            t0 = time.time()
            while user_time(killed) is not None and time.time() < t0 + 30:
                time.sleep(0.01)
            time.sleep(0.05)
            u0 = {p: user_time(p) for p in victim_children}
            time.sleep(0.25)
            outlived = [p for p in victim_children if u0[p] is not None and (user_time(p) or u0[p]) > u0[p] + 2]
        th.join(600)
        check(killed is not None, "a worker running a tile was found and killed")
        check(result.get("ok"), f"the farm finished after the kill ({result.get('error')})")
        if result.get("ok"):
            check(image_hash(os.path.join(out2, "img.json")) == ref, "after a killed worker the image differs")
        check(sorted(os.listdir(out2)) == ["img.exr", "img.json"], f"only the outputs in the output dir: {os.listdir(out2)}")
        check(not outlived, f"the killed worker's csi-reconstruct {outlived} outlived it (still computing)")
        leftovers = [d for d in os.listdir(private) if d.startswith("csi-farm-scratch-")]
        check(not leftovers, f"scratch directories left: {leftovers}")

        # 3. frames of an animation: two scenes
        scenes = [os.path.join(SOURCE, "tests", "cli", "scenes", s) for s in ("small_triangle.scene", "small_moving.scene")]
        out3 = os.path.join(tmp, "out3")
        os.mkdir(out3)
        sopts = ["--tile-margin", "4", "--tile-margin-t", "2", "--max-iter", "40"]
        farm.render(scenes, os.path.join(out3, "frame_%02d.exr"), render_options=["--spp", "4"], options=sopts,
                    tiles=2, client=client, bin_dir=BUILD, quiet=True)
        for i, sc in enumerate(scenes):
            st = os.path.join(tmp, f"scene{i}.json")
            subprocess.run([os.path.join(BUILD, "csi-render"), sc, "--spp", "4", "--tiles", "2", "-o",
                            os.path.join(tmp, f"scene{i}.exr"), "--stats", st, "-q"] + sopts, check=True)
            # the farm's frame, reconstructed again from its stats-free EXR: compare pixels
            a = read_exr(os.path.join(out3, f"frame_{i:02d}.exr"))
            b = read_exr(os.path.join(tmp, f"scene{i}.exr"))
            check(a is not None and b is not None and a.shape == b.shape and np.array_equal(a, b),
                  f"frame {i}: csi-farm render differs from csi-render --tiles 2")

        # 4. time windows as tasks
        mdump = os.path.join(tmp, "moving.csid")
        subprocess.run([os.path.join(BUILD, "csi-render"), scenes[1], "--spp", "4", "--time-steps", "16", "--dump", mdump, "-o",
                        os.path.join(tmp, "moving_render.exr"), "-q"], check=True)
        topts = ["--tiles-t", "2", "--tile-margin-t", "2", "--max-iter", "40"]
        tref = os.path.join(tmp, "moving_ref.json")
        subprocess.run([recon, mdump, "-o", os.path.join(tmp, "moving_ref.exr"), "--tiles", "2", "--stats", tref,
                        "-q"] + topts, check=True)
        with open(tref) as f:
            check(json.load(f)["tiles"] == 2, "the moving reference run has 2 time windows")
        out4 = os.path.join(tmp, "out4")
        os.mkdir(out4)
        farm.reconstruct(mdump, os.path.join(out4, "moving.exr"), stats=os.path.join(out4, "moving.json"), tiles=2,
                         options=topts, client=client, bin_dir=BUILD, quiet=True)
        check(image_hash(os.path.join(out4, "moving.json")) == image_hash(tref),
              "2 workers, 2 time windows: the farm's image differs from --tiles-t 2 in one process")

        # 4b. 11 frames, a count the FFT cannot take: solved on 12 in 2 x/y tiles
        pdump11 = os.path.join(tmp, "moving11.csid")
        subprocess.run([os.path.join(BUILD, "csi-render"), scenes[1], "--spp", "4", "--time-steps", "11", "--dump",
                        pdump11, "--estimator", "mean", "-o", os.path.join(tmp, "moving11_mean.exr"), "-q"], check=True)
        o11 = ["--tiles-t", "1", "--tile-margin", "4", "--max-iter", "40"]
        ref11 = os.path.join(tmp, "moving11_ref.json")
        subprocess.run([recon, pdump11, "-o", os.path.join(tmp, "moving11_ref.exr"), "--tiles", "2", "--stats", ref11,
                        "-q"] + o11, check=True)
        info11 = farm.reconstruct(pdump11, os.path.join(out4, "moving11.exr"), stats=os.path.join(out4, "moving11.json"),
                                  tiles=2, options=o11, client=client, bin_dir=BUILD, quiet=True)
        check(info11["solved_t"] == 12 and info11["tiles"] == 2 and
              image_hash(os.path.join(out4, "moving11.json")) == image_hash(ref11),
              f"11 frames in 2 tiles: the farm's image differs from one process's, or the layout is not over 12: {info11}")
        check(filecmp.cmp(os.path.join(out4, "moving11.exr"), os.path.join(tmp, "moving11_ref.exr"), shallow=False),
              "11 frames in 2 tiles: the farm's EXR is not one process's, byte for byte")

        # 5. sides the FFT cannot take: padded whole, tiles of the padded grid, tiles of its own
        pdump = os.path.join(tmp, "padded.csid")
        write_dump(pdump, out=74, out_h=46)
        popts = ["--tile-margin", "8", "--max-iter", "60"]
        out5 = os.path.join(tmp, "out5")
        os.mkdir(out5)
        for tiles, solved, count in ((None, 80, 1), (2, 80, 2), (4, 74, 4)):
            name = f"padded_{tiles or 'auto'}"
            targs = ["--tiles", str(tiles)] if tiles else []
            pref = os.path.join(tmp, name + ".json")
            subprocess.run([recon, pdump, "-o", os.path.join(tmp, name + ".exr"), "--stats", pref, "-q"] + targs + popts,
                           check=True)
            info = farm.reconstruct(pdump, os.path.join(out5, name + ".exr"), stats=os.path.join(out5, name + ".json"),
                                    tiles=tiles, options=popts, client=client, bin_dir=BUILD, quiet=True)
            check(info["tiles"] == count and info["solved_out_w"] == solved and info["solved_out_h"] == (48 if solved == 80 else 46),
                  f"{name}: the layout is not {count} tiles over {solved} pixels: {info}")
            a = read_exr(os.path.join(out5, name + ".exr"))
            b = read_exr(os.path.join(tmp, name + ".exr"))
            check(image_hash(os.path.join(out5, name + ".json")) == image_hash(pref) and a.shape == b.shape and a.shape[:2] == (46, 74)
                  and np.array_equal(a, b), f"{name}: the farm's image differs from one process's ({a.shape}, {b.shape})")
            check(filecmp.cmp(os.path.join(out5, name + ".exr"), os.path.join(tmp, name + ".exr"), shallow=False),
                  f"{name}: the farm's EXR is not one process's, byte for byte (attributes)")
    finally:
        client.close()
        cluster.close()
    import shutil
    shutil.rmtree(tmp, ignore_errors=True)
    print(f"{'FAILED' if failures else 'passed'}: {len(failures)} failure(s)")
    return 1 if failures else 0


def read_exr(path):
    import OpenEXR
    with OpenEXR.File(path) as f:
        ch = f.channels()
        return np.stack([np.asarray(ch[c].pixels, np.float32) for c in sorted(ch)], axis=-1) if "RGB" not in ch \
            else np.asarray(ch["RGB"].pixels, np.float32)


if __name__ == "__main__":
    sys.exit(main())
