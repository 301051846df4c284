#!/usr/bin/env python3
"""The planner's layout of a volume under a budget, before and after a change (issue 11): each
volume reconstructed whole and at budgets of a fraction of the whole's planned device bytes by
two builds (--before and --after: build directories, their sdk/libcsi.so through the Python
binding and their csi-reconstruct --tile-info for the layout), the image's MSE over the whole's
and the CPU of each run.

Volumes (`--volumes`, comma-separated):
  billiards, train            the bundled scenes at 64x64 x 256 frames, 16 spp (bench_scale.py's
                              long volumes), against the 256-spp stratified reference
  billiards128, train128      the same at 128x128 and 4 spp (their own frames: 64 and 32)
  pan:S, pan+disc:S, disc:S   bench_scale.py's procedural windows set, position seed S, against
                              the exact mean over t
  bounce:S, bar:S, mixed:S, flicker:S   windows_heldout.py's held-out volumes

    git worktree add /tmp/before PARENT && cmake -S /tmp/before -B /tmp/before/build && cmake --build /tmp/before/build
    .venv/bin/python tools/bench/windows_planner.py --out OUT --before /tmp/before/build --after build \\
        --volumes billiards,train --fractions 0.95,0.85,0.7,0.55

Writes OUT/windows_planner.csv (one row per volume, budget and build: the layout, MSE / the
whole's, CPU seconds of the run: the process's, which holds PoCL's threads) and logs each row.
Each build runs in its own process (a process loads one libcsi.so).
"""
import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(ROOT, "host", "python"))

import bench_common as bc  # noqa: E402
import bench_scale as bs  # noqa: E402


def load(name, work):
    """grid, positions, values, reference, seed, exact of the volume `name` (the list above)."""
    import csi
    kind, _, sd = name.partition(":")
    if kind in ("pan", "pan+disc", "disc"):
        grid, pos, vals, truth = bs.disc_volume(int(sd)) if kind == "disc" else bs.pan_volume(kind, int(sd))
        return grid, pos, vals, truth, 1, False
    if kind in ("bounce", "bar", "mixed", "flicker"):
        import windows_heldout as wh
        grid, pos, vals, truth = wh.case(kind, int(sd))
        return grid, pos, vals, truth, 1, False
    scene, size, spp, extra = {"billiards": ("billiards", 64, 16, ["--time-steps", "256"]),
                               "train": ("train", 64, 16, ["--time-steps", "256"]),
                               "billiards128": ("billiards", 128, 4, []),
                               "train128": ("train", 128, 4, [])}[kind]
    d = os.path.join(work, kind)
    os.makedirs(d, exist_ok=True)
    bins, env = bs.binaries(), bc.default_env()
    with open(os.path.join(d, "render.log"), "a") as logf:
        path, dump = bs.make_dump(bins, env, scene, (size, size), spp, d, logf, extra=extra)
        ref = bs.reference(bins, env, path, d, logf).astype(np.float64)
    r = csi.read_dump(dump)
    return r.grid, r.positions, r.values, ref, r.seed, r.exact


def worker(a):
    """One build (CSI_LIBRARY): the whole, then every budget; rows as JSON lines on stdout."""
    import csi
    for name in a.volumes.split(","):
        grid, pos, vals, ref, seed, exact = load(name, a.work)
        t0 = time.process_time()
        whole = csi.reconstruct(pos, vals, grid, seed=seed, exact=exact, tiles=1)
        e_w = bs.mse(whole.image, ref)
        print(json.dumps(dict(volume=name, fraction=1.0, layout="1x1x1", mse=e_w, ratio=1.0,
                              cpu=time.process_time() - t0)), flush=True)
        for f in [float(v) for v in a.fractions.split(",")]:
            budget = int(f * a.whole_bytes[name])
            info = subprocess.run([os.path.join(a.build, "csi-reconstruct"), dump_path(a, name), "--tile-info",
                                   "--mem-budget", str(budget), "-q"], capture_output=True, text=True)
            if info.returncode:
                print(json.dumps(dict(volume=name, fraction=f, error=info.stderr.strip())), flush=True)
                continue
            t = json.loads(info.stdout)
            t0 = time.process_time()
            r = csi.reconstruct(pos, vals, grid, seed=seed, exact=exact, mem_budget=budget)
            e = bs.mse(r.image, ref)
            print(json.dumps(dict(volume=name, fraction=f, layout=f"{t['tiles_x']}x{t['tiles_y']}x{t['tiles_t']}",
                                  mse=e, ratio=e / e_w, cpu=time.process_time() - t0)), flush=True)


def dump_path(a, name):
    return os.path.join(a.work, name.replace(":", "_") + ".csid")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--before", required=True, help="the build directory before the change")
    ap.add_argument("--after", required=True, help="the build directory after it")
    ap.add_argument("--volumes", default="billiards,train,billiards128,train128,pan:0,pan:1,pan+disc:0,pan+disc:1")
    ap.add_argument("--fractions", default="0.95,0.85,0.7,0.55")
    ap.add_argument("--worker", default=None, help=argparse.SUPPRESS)
    ap.add_argument("--whole-bytes", default="{}", help=argparse.SUPPRESS)
    a = ap.parse_args()
    a.work = os.path.join(a.out, "work")
    if a.worker:
        a.whole_bytes, a.build = json.loads(a.whole_bytes), a.worker
        worker(a)
        return
    os.makedirs(a.work, exist_ok=True)
    # the whole's device bytes per volume, from the after build's plan (the same for both builds)
    whole = {}
    for name in a.volumes.split(","):
        whole[name] = planned_whole(a, name)
    rows = []
    for tag, build in (("before", a.before), ("after", a.after)):
        build = os.path.abspath(build)
        env = dict(bc.default_env(), CSI_LIBRARY=os.path.join(build, "sdk", "libcsi.so"))
        cmd = [sys.executable, os.path.abspath(__file__), "--worker", build, "--out", a.out, "--before", a.before,
               "--after", a.after, "--volumes", a.volumes, "--fractions", a.fractions,
               "--whole-bytes", json.dumps(whole)]
        p = subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True, env=env)
        for line in p.stdout:
            row = dict(json.loads(line), build=tag, load=os.getloadavg()[0])
            rows.append(row)
            bs.write_csv(os.path.join(a.out, "windows_planner.csv"), rows)
            bc.log(f"{tag} {row['volume']} {row['fraction']:.2f}: " +
                   (row["error"] if "error" in row else
                    f"{row['layout']} MSE {row['mse']:.4e} = {row['ratio']:.3f}x the whole ({row['cpu']:.0f} s CPU)"))
        if p.wait():
            sys.exit(f"windows_planner: the {tag} build's run failed")


def planned_whole(a, name):
    """The whole problem's planned device bytes (csi-reconstruct --tile-info of the after build on
    a dump of the volume's samples, written here): the budget that just holds it."""
    from csi import dump as cd
    grid, pos, vals, _, seed, exact = load(name, a.work)
    path = dump_path(a, name)
    if not os.path.exists(path):
        cd.write(path, cd.Dump(grid=tuple(grid[:3]), out=tuple(grid[3:]), xyt=np.asarray(pos, np.uint32),
                               values=np.asarray(vals, np.float32), seed=seed, exact=exact))
    info = subprocess.run([os.path.join(a.after, "csi-reconstruct"), path, "--tile-info", "--mem-budget", "1T", "-q"],
                          capture_output=True, text=True, env=bc.default_env(), check=True)
    return json.loads(info.stdout)["whole_bytes"]


if __name__ == "__main__":
    main()
