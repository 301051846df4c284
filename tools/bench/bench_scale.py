#!/usr/bin/env python3
"""Tiles (issue 11): seams and error against the untiled reconstruction, time and peak memory
against image size and against Dask worker count, and single large targets.

  .venv/bin/python tools/bench/bench_scale.py seams   --out bench-scale   # tiled vs untiled, 256^2 (+ motion)
  .venv/bin/python tools/bench/bench_scale.py margins --out bench-scale   # tiled error against the margin
  .venv/bin/python tools/bench/bench_scale.py windows --out bench-scale   # volumes in time windows vs whole
  .venv/bin/python tools/bench/bench_scale.py seams_t --out bench-scale   # seams of 2 time windows (frames)
  .venv/bin/python tools/bench/bench_scale.py sizes   --out bench-scale   # 256^2 .. 3840x2160 at 4 spp
  .venv/bin/python tools/bench/bench_scale.py workers --out bench-scale   # csi-farm, 1 and 2 workers
  .venv/bin/python tools/bench/bench_scale.py target  --out bench-scale --size 3840x2160 --spp 16
  .venv/bin/python tools/bench/bench_scale.py long    --out bench-scale --spp 16 --variant "--mem-budget 16M --tiles-t 8"
  .venv/bin/python tools/bench/bench_scale.py plot    --out bench-scale   # the figures of docs/bench/scale.md
  .venv/bin/python tools/bench/bench_scale.py mitsuba --out bench-scale --data DIR[,DIR] [--base BUILD]

mitsuba: a real renderer's noisy samples (tools/bench/mitsuba_data.py's dumps, of any size; by
default 4 and 16 spp, 1 and 64 paths, stratified and Poisson-disk) untiled and in 2 and 4 tiles (a layout that
cannot be made is skipped), against the reference and the per-pixel mean of the same samples;
with --base, another build's csi-reconstruct on the same dumps beside this one's.
Every other input is rendered here by csi-render from a bundled scene (`bench_common.scene_variant` sets
the camera size) and dumped; reconstructions run csi-reconstruct on the dump as a user would.
- Error: MSE over pixels and channels against a stratified reference (csi-render --reference
  256), the same samples tiled and untiled (`--tiles 1` with the device's whole memory as budget).
- Seams: RMS of (tiled - untiled) over the pixels within `band` of an interior core boundary
  (the blend bands, from --tile-info) and over all other pixels; a seam would show as a larger
  difference in the bands.
- Time: wall clock of the process. Peak memory: the process's ru_maxrss (os.wait4), which on
  PoCL's CPU device includes the device buffers (they live in host memory), and csi_buffer's
  peak of device bytes (device_peak_bytes in the statistics). For csi-farm, the peak of the
  summed resident memory of the whole process tree (client, Dask workers, their csi processes),
  sampled every 0.1 s.
The machine is shared: times are comparable within one run only (record `uptime` with them).
"""
import argparse
import csv
import json
import os
import subprocess
import sys
import threading
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bench_common as bc  # noqa: E402

ROOT = bc.ROOT


def binaries():
    b = bc.binaries()
    d = os.path.dirname(b["csi-reconstruct"])
    b["csi-merge"] = os.path.join(d, "csi-merge")
    return b


def measured(cmd, env, capture=False):
    """Runs cmd; returns (wall s, peak RSS bytes of that process, stdout). Raises on failure."""
    t0 = time.perf_counter()
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE if capture else subprocess.DEVNULL, stderr=subprocess.PIPE,
                         env=env)
    out = p.stdout.read() if capture else b""
    err = p.stderr.read().decode(errors="replace")
    _, status, ru = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t0
    if os.waitstatus_to_exitcode(status) != 0:
        raise bc.BenchError(f"{' '.join(cmd)} failed:\n{err[-2000:]}")
    return wall, ru.ru_maxrss * 1024, out


class TreeRSS:
    """Peak of the summed RSS of this process and all its descendants, sampled every 0.1 s."""

    def __init__(self):
        import psutil
        self.psutil, self.peak, self._stop = psutil, 0, threading.Event()
        self._t = threading.Thread(target=self._run, daemon=True)

    def _run(self):
        me = self.psutil.Process()
        while not self._stop.is_set():
            total = 0
            for p in [me] + me.children(recursive=True):
                try:
                    total += p.memory_info().rss
                except self.psutil.Error:
                    pass
            self.peak = max(self.peak, total)
            time.sleep(0.1)

    def __enter__(self):
        self._t.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._t.join()


def load_avg():
    return " ".join(f"{x:.1f}" for x in os.getloadavg())


def device_memory(bins, env, dump, work):
    """The device's global memory as csi sees it (the budget that lets anything fit whole)."""
    info = json.loads(subprocess.run([bins["csi-reconstruct"], dump, "--tile-info", "--mem-budget", "1T", "-q"],
                                     capture_output=True, env=env, check=True).stdout)
    return info["budget"]


def make_dump(bins, env, scene, size, spp, work, log, extra=()):
    path, _ = bc.scene_variant(scene, size, work)
    dump = os.path.join(work, f"{scene}_{size[0]}x{size[1]}_s{spp}.csid")
    if not os.path.exists(dump):
        t = bc.run([bins["csi-render"], path, "--spp", str(spp), "--estimator", "mean", "--dump", dump, "-o",
                    os.path.join(work, "mean.exr"), "--seed", "1", "-q"] + list(extra), env, log=log)
        bc.log(f"  rendered {os.path.basename(dump)} in {t:.1f} s")
    return path, dump


def reference(bins, env, scene_path, work, log, spp=256):
    ref = os.path.join(work, os.path.basename(scene_path).replace(".scene", f"_ref{spp}.exr"))
    if not os.path.exists(ref):
        bc.run([bins["csi-render"], scene_path, "--reference", str(spp), "-o", ref, "-q"], env, log=log)
    return bc.read_exr(ref)


def recon(bins, env, dump, out, extra, work):
    st = os.path.join(work, "r.json")
    wall, rss, _ = measured([bins["csi-reconstruct"], dump, "-o", out, "--stats", st, "-q"] + list(extra), env)
    with open(st) as f:
        return wall, rss, json.load(f)


def band_mask(info, shape):
    h, w = shape[:2]
    m = np.zeros((h, w), bool)
    for key, axis, band in (("cores_x", 1, info["band"]), ("cores_y", 0, info["band_y"])):
        for b in [int(v) for v in info[key].split(",")][1:-1]:
            sl = slice(max(0, b - band), b + band)
            if axis == 1:
                m[:, sl] = True
            else:
                m[sl, :] = True
    return m


def mse(a, b, m=None):
    d = (a.astype(np.float64) - b) ** 2
    return float(d[m].mean() if m is not None else d.mean())


def seams(a, bins, env, work, logf):
    rows = []
    cases = [("garden", (256, 256), spp) for spp in (1, 4, 16)] + [("checkerboard", (256, 256), spp) for spp in (1, 4, 16)]
    cases += [("train", (128, 128), 4)]
    tiles = (4, 9)
    for scene, size, spp in cases:
        path, dump = make_dump(bins, env, scene, size, spp, work, logf)
        ref = reference(bins, env, path, work, logf)
        whole_budget = device_memory(bins, env, dump, work)
        u_exr = os.path.join(work, f"{scene}_{spp}_untiled.exr")
        wall_u, rss_u, st_u = recon(bins, env, dump, u_exr, ["--tiles", "1", "--mem-budget", str(whole_budget)], work)
        u = bc.read_exr(u_exr)
        e_u = mse(u, ref)
        for n in (tiles if scene != "train" else (2, 4)):
            info = json.loads(subprocess.run([bins["csi-reconstruct"], dump, "--tiles", str(n), "--tile-info", "-q"],
                                             capture_output=True, env=env, check=True).stdout)
            t_exr = os.path.join(work, f"{scene}_{spp}_t{n}.exr")
            wall_t, rss_t, st_t = recon(bins, env, dump, t_exr, ["--tiles", str(n)], work)
            t = bc.read_exr(t_exr)
            m = band_mask(info, t.shape)
            e_t = mse(t, ref)
            d_band = np.sqrt(mse(t, u, m)) if m.any() else 0.0
            d_rest = np.sqrt(mse(t, u, ~m))
            row = dict(scene=scene, size=f"{size[0]}x{size[1]}", spp=spp, tiles=n,
                       layout=f"{info['tiles_x']}x{info['tiles_y']}x{info['tiles_t']}",
                       mse_untiled=e_u, mse_tiled=e_t, ratio=e_t / e_u, rms_diff_band=d_band, rms_diff_rest=d_rest,
                       mse_band_untiled=mse(u, ref, m) if m.any() else 0.0, mse_band_tiled=mse(t, ref, m) if m.any() else 0.0,
                       wall_untiled=wall_u, wall_tiled=wall_t, rss_untiled=rss_u, rss_tiled=rss_t,
                       dev_untiled=st_u.get("device_peak_bytes", 0), dev_tiled=st_t.get("device_peak_bytes", 0))
            rows.append(row)
            bc.log(f"  {scene} {size} spp {spp} tiles {n} ({row['layout']}): MSE ratio {row['ratio']:.4f}, "
                   f"diff band {d_band:.2e} rest {d_rest:.2e}")
            if scene == "garden" and spp == 4 and n == 9:
                np.save(os.path.join(work, "seam_tiled.npy"), t)
                np.save(os.path.join(work, "seam_untiled.npy"), u)
                np.save(os.path.join(work, "seam_ref.npy"), ref)
                with open(os.path.join(work, "seam_info.json"), "w") as f:
                    json.dump(info, f)
                # each tile with its own scale (what csi-render --tile does without --tile-scale)
                parts = []
                for i in range(n):
                    p = os.path.join(work, f"local_{i}.csip")
                    bc.run([bins["csi-render"], path, "--spp", str(spp), "--seed", "1", "--tile", f"{i}/{n}", "-o", p, "-q"],
                           env, log=logf)
                    parts.append(p)
                l_exr = os.path.join(work, "local.exr")
                bc.run([bins["csi-merge"]] + parts + ["-o", l_exr, "-q"], env, log=logf)
                loc = bc.read_exr(l_exr)
                rows.append(dict(row, tiles=f"{n} own scale", mse_tiled=mse(loc, ref), ratio=mse(loc, ref) / e_u,
                                 rms_diff_band=np.sqrt(mse(loc, u, m)), rms_diff_rest=np.sqrt(mse(loc, u, ~m)),
                                 mse_band_tiled=mse(loc, ref, m)))
        write_csv(os.path.join(a.out, "seams.csv"), rows)
    return rows


def margins(a, bins, env, work, logf):
    """The tiled error against the tile margin: checkerboard (unbounded frequencies, the hardest
    case for a margin) at 16 spp on its 16x grid, and the moving train (a volume) at 4 spp."""
    rows = []
    cases = (("checkerboard", (256, 256), 16, (8, 16, 24)), ("train", (128, 128), 4, (4, 8, 16, 32)))
    for scene, size, spp, margins_px in cases:
        path, dump = make_dump(bins, env, scene, size, spp, work, logf)
        ref = reference(bins, env, path, work, logf)
        u_exr = os.path.join(work, f"{scene}_{spp}_untiled.exr")
        if not os.path.exists(u_exr):
            recon(bins, env, dump, u_exr, ["--tiles", "1", "--mem-budget", str(device_memory(bins, env, dump, work))],
                  work)
        e_u = mse(bc.read_exr(u_exr), ref)
        for m in margins_px:
            args = ["--tiles", "4", "--tile-margin", str(m)]
            info = json.loads(subprocess.run([bins["csi-reconstruct"], dump, "--tile-info", "-q"] + args,
                                             capture_output=True, env=env, check=True).stdout)
            out = os.path.join(work, f"{scene}_{spp}_t4_m{m}.exr")
            wall, _, st = recon(bins, env, dump, out, args, work)
            e_t = mse(bc.read_exr(out), ref)
            rows.append(dict(scene=scene, size=f"{size[0]}x{size[1]}", spp=spp, tiles=4,
                             layout=f"{info['tiles_x']}x{info['tiles_y']}x{info['tiles_t']}", margin_px=m,
                             margin_cells=m * info["grid_w"] // info["out_w"], mse_untiled=e_u, mse_tiled=e_t,
                             ratio=e_t / e_u, wall_tiled=wall, tile_bytes=info["tile_bytes"]))
            bc.log(f"  {scene} spp {spp} margin {m} px: MSE ratio {e_t / e_u:.4f}")
    write_csv(os.path.join(a.out, "margins.csv"), rows)
    return rows


def disc_volume(seed):
    """tests/e2e/test_tiles_recon.c's volume: a disc sliding over a still sinusoid, 32 x 32 x 48,
    10% random cells (position seed `seed`); the truth is the exact mean over t of the cells."""
    import csi
    W, T = 32, 48
    t, y, x = np.mgrid[0:T, 0:W, 0:W]
    u, v, s = (x + 0.5) / W, (y + 0.5) / W, (t + 0.5) / T
    f = np.where(np.hypot(u - (0.2 + 0.6 * s), v - 0.4) < 0.15, 0.85,
                 0.4 + 0.15 * np.sin(2 * np.pi * (3 * u + 2 * v))).astype(np.float32)
    grid = (W, W, T, W, W)
    pos = csi.positions(grid, method="random", fraction=0.1, seed=seed)
    vals = f[pos[:, 2], pos[:, 1], pos[:, 0]][:, None]
    return grid, pos, vals, f.astype(np.float64).mean(axis=0)[..., None]


def pan_volume(name, seed, size=(64, 64, 32), rate=0.1):
    """bench_animation's procedural volume `name` (anim_volumes.py) at `rate` of its cells."""
    import anim_volumes as av
    import bench_animation as ba
    W, H, T = size
    f, _ = av.volume(name, W, H, T, seed)
    pos, idx = ba.random_cells((T, H, W), rate, seed)
    vals = f.reshape(-1)[idx][:, None].astype(np.float32)
    return (W, H, T, W, H), pos, vals, f.astype(np.float64).mean(axis=0)[..., None]


def windows(a, bins, env, work, logf):
    """Volumes split in t against the whole, through the library (csi.reconstruct): 2 windows
    (--tiles-t 2) with the default margin (a third of a window's core) and with the former 4
    frames, 2 windows given the whole's velocity (each window searches its own by default), 4
    windows; and the paper's basis (no shear, DFT in t) whole and in 2 windows. Error: MSE of the blurred image against the exact mean over t (procedural) or the
    256-spp reference (rendered)."""
    import csi
    cases = [(f"disc s{s}", lambda s=s: disc_volume(s)) for s in range(5)]
    cases += [(f"{n} s{s}", lambda n=n, s=s: pan_volume(n, s)) for n in ("pan", "pan+disc") for s in range(2)]
    for scene in ("train", "billiards"):
        def rendered(scene=scene):
            path, dump = make_dump(bins, env, scene, (128, 128), 4, work, logf)
            d = csi.read_dump(dump)
            return d.grid, d.positions, d.values, reference(bins, env, path, work, logf).astype(np.float64)
        cases.append((f"{scene} 4 spp", rendered))
    paper = dict(motion_time="dft", motion_velocity="none")
    rows = []
    for label, make in cases:
        grid, pos, vals, truth = make()
        def run(**kw):
            r = csi.reconstruct(pos, vals, grid, seed=1, **kw)
            return r, float(((r.image.astype(np.float64) - truth) ** 2).mean())
        whole, e_w = run()
        v = (float(whole.options["motion_vx"]), float(whole.options["motion_vy"]))
        row = dict(case=label, frames=grid[2], samples=len(pos), v_whole=f"{v[0]:.2f},{v[1]:.2f}", mse_whole=e_w)
        variants = dict(t2=dict(tiles_t=2), t2_m4=dict(tiles_t=2, tile_margin_t=4),
                        t2_shared_v=dict(tiles_t=2, motion_velocity="given", motion_vx=v[0], motion_vy=v[1]),
                        t4=dict(tiles_t=4), t2_binned=dict(tiles_t=2, tile_image_binned="on"),
                        t4_binned=dict(tiles_t=4, tile_image_binned="on"))
        for name, kw in variants.items():
            r, e = run(**kw)
            row[f"ratio_{name}"] = e / e_w
            row[f"margin_{name}"] = r.options["tile_margin_t"]
        _, e_pw = run(**paper)
        _, e_pt = run(tiles_t=2, **paper)
        row.update(mse_paper_whole=e_pw, ratio_paper_t2=e_pt / e_pw)
        rows.append(row)
        bc.log("  " + ", ".join(f"{k} {val:.4g}" if isinstance(val, float) else f"{k} {val}" for k, val in row.items()))
        write_csv(os.path.join(a.out, "windows.csv"), rows)
    return rows


def frames_of(d):
    return np.stack([bc.read_exr(os.path.join(d, f)) for f in sorted(os.listdir(d)) if f.endswith(".exr")])


def seams_t(a, bins, env, work, logf):
    """The seam table's rows for volumes split in t: the bundled moving scenes at 128^2, 4 spp,
    untiled and in 2 time windows (--tiles-t 2) by csi-reconstruct with --frames, with the windows'
    image and with the binned shutter's (--tile-image-binned on); the band is the frames within
    band_t of the interior core boundary, the difference is over the frames."""
    rows = []
    for scene in ("train", "billiards"):
        path, dump = make_dump(bins, env, scene, (128, 128), 4, work, logf)
        ref = reference(bins, env, path, work, logf)
        whole_budget = device_memory(bins, env, dump, work)
        fu, ft = os.path.join(work, f"{scene}_fu"), os.path.join(work, f"{scene}_ft")
        u_exr = os.path.join(work, f"{scene}_u.exr")
        _, _, st_u = recon(bins, env, dump, u_exr, ["--tiles", "1", "--mem-budget", str(whole_budget), "--frames", fu], work)
        u, Fu = bc.read_exr(u_exr), frames_of(fu)
        # the windows' own image (the default), and the image of the binned shutter (csi/tiles.h)
        for label, extra in (("1x1x2", []), ("1x1x2 binned", ["--tile-image-binned", "on"])):
            ft = os.path.join(work, f"{scene}_ft" + ("_b" if extra else ""))
            t_exr = ft + ".exr"
            _, _, st_t = recon(bins, env, dump, t_exr, ["--tiles-t", "2", "--frames", ft] + extra, work)
            info = json.loads(subprocess.run([bins["csi-reconstruct"], dump, "--tiles-t", "2", "--tile-info", "-q"],
                                             capture_output=True, env=env, check=True).stdout)
            t, Ft = bc.read_exr(t_exr), frames_of(ft)
            T, band = Fu.shape[0], int(info["band_t"])
            m = np.zeros(T, bool)
            for b in [int(v) for v in info["cores_t"].split(",")][1:-1]:
                m[max(0, b - band):b + band] = True
            d2 = ((Ft.astype(np.float64) - Fu) ** 2).mean(axis=(1, 2, 3))
            row = dict(scene=scene, size="128x128", spp=4, tiles=2, layout=label, frames=T, window_t=info["window_t"],
                       margin_t=info["margin_t"], mse_untiled=mse(u, ref), mse_tiled=mse(t, ref),
                       ratio=mse(t, ref) / mse(u, ref), rms_diff_band=float(np.sqrt(d2[m].mean())),
                       rms_diff_rest=float(np.sqrt(d2[~m].mean())), dev_untiled=st_u.get("device_peak_bytes", 0),
                       dev_tiled=st_t.get("device_peak_bytes", 0))
            rows.append(row)
            bc.log("  " + ", ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}" for k, v in row.items()))
            write_csv(os.path.join(a.out, "seams_t.csv"), rows)
    return rows


def sizes(a, bins, env, work, logf):
    rows = []
    for w, h in a.sizes:
        _, dump = make_dump(bins, env, a.scene, (w, h), a.spp, work, logf)
        for label, extra in (("default", []),):
            out = os.path.join(work, f"size_{w}x{h}.exr")
            up = load_avg()
            wall, rss, st = recon(bins, env, dump, out, extra, work)
            rows.append(dict(width=w, height=h, spp=a.spp, cells=st["k"], samples=st["n"], run=label, tiles=st["tiles"],
                             wall_s=wall, peak_rss=rss, device_peak=st.get("device_peak_bytes", 0),
                             t_solve=st["t_solve_s"], cpu_work=st.get("cpu_work_s", 0), load=up))
            bc.log(f"  {w}x{h}: {st['tiles']} tiles, {wall:.1f} s, peak RSS {rss / 2**20:.0f} MiB, "
                   f"device peak {st.get('device_peak_bytes', 0) / 2**20:.0f} MiB (load {up})")
        if not a.keep:
            os.remove(dump)
        # after each size: the large ones take long, and the rows so far stay usable if stopped
        write_csv(os.path.join(a.out, "sizes.csv"), rows)
    return rows


def workers(a, bins, env, work, logf):
    rows = []
    w, h = a.sizes[0]
    _, dump = make_dump(bins, env, a.scene, (w, h), a.spp, work, logf)
    ref_exr = os.path.join(work, "w_single.exr")
    extra = ["--tiles", str(a.tiles)] if a.tiles else []
    wall1, rss1, st1 = recon(bins, env, dump, ref_exr, extra, work)
    rows.append(dict(runner="csi-reconstruct (one process)", workers=1, tiles=st1["tiles"], wall_s=wall1,
                     peak_rss=rss1, identical=True, load=load_avg()))
    sys.path.insert(0, os.path.join(ROOT, "host", "python"))
    from csi import farm
    for nw in a.workers:
        st = os.path.join(work, f"farm{nw}.json")
        up = load_avg()
        t0 = time.perf_counter()
        with TreeRSS() as tr:
            farm.reconstruct(dump, os.path.join(work, f"farm{nw}.exr"), stats=st, tiles=a.tiles or st1["tiles"],
                             workers=nw, bin_dir=os.path.dirname(bins["csi-reconstruct"]), quiet=True)
        wall = time.perf_counter() - t0
        with open(st) as f:
            same = json.load(f)["image_fnv1a64"] == st1["image_fnv1a64"]
        rows.append(dict(runner="csi-farm (LocalCluster)", workers=nw, tiles=st1["tiles"], wall_s=wall, peak_rss=tr.peak,
                         identical=same, load=up))
        bc.log(f"  farm {nw} workers: {wall:.1f} s, tree peak RSS {tr.peak / 2**20:.0f} MiB, identical {same} (load {up})")
    write_csv(os.path.join(a.out, "workers.csv"), rows)
    return rows


def target(a, bins, env, work, logf):
    w, h = a.sizes[0]
    t0 = time.perf_counter()
    _, dump = make_dump(bins, env, a.scene, (w, h), a.spp, work, logf)
    t_render = time.perf_counter() - t0
    up = load_avg()
    out = os.path.join(a.out, f"target_{w}x{h}_s{a.spp}.exr")
    wall, rss, st = recon(bins, env, dump, out, [], work)
    row = dict(width=w, height=h, spp=a.spp, cells=st["k"], samples=st["n"], tiles=st["tiles"], wall_s=wall,
               peak_rss=rss, device_peak=st.get("device_peak_bytes", 0), t_solve=st["t_solve_s"],
               cpu_work=st.get("cpu_work_s", 0), render_s=t_render, load_before=up, load_after=load_avg(),
               dump_bytes=os.path.getsize(dump))
    bc.log(f"  {w}x{h} {a.spp} spp: {st['tiles']} tiles, {wall:.0f} s, peak RSS {rss / 2**30:.2f} GiB, "
           f"device peak {row['device_peak'] / 2**30:.2f} GiB (load {up} -> {row['load_after']})")
    with open(os.path.join(a.out, f"target_{w}x{h}_s{a.spp}.json"), "w") as f:
        json.dump(row, f, indent=1)
    if not a.keep:
        os.remove(dump)
    return [row]


def long(a, bins, env, work, logf):
    """A long volume (--time-steps, default 256 frames) against the whole: the whole on the
    device's memory; each --variant (csi-reconstruct arguments, e.g. "--mem-budget 16M --tiles-t 8")
    in one process, and the first variant again through csi-farm on a LocalCluster of --workers
    processes. Time, peak RSS (csi-farm: the process tree's), device peak, MSE against the 256-spp
    reference, frames written, and whether the farm's image is the one process's bits. The
    planner's own layout at each variant's budget is logged from --tile-info."""
    w, h = a.sizes[0]
    path, dump = make_dump(bins, env, a.scene, (w, h), a.spp, work, logf, extra=["--time-steps", str(a.time_steps)])
    ref = reference(bins, env, path, work, logf)
    rows = []

    def info_of(args):
        return json.loads(subprocess.run([bins["csi-reconstruct"], dump, "--tile-info", "-q"] + args,
                                         capture_output=True, env=env, check=True).stdout)

    def row_of(label, args, wall, rss, st, exr, frames_dir, up):
        img = bc.read_exr(exr)
        frames = len([f for f in os.listdir(frames_dir) if f.endswith(".exr")])
        inf = info_of(args)
        r = dict(run=label, args=" ".join(args), tiles=st["tiles"],
                 layout=f"{inf['tiles_x']}x{inf['tiles_y']}x{inf['tiles_t']}", window_t=inf["window_t"],
                 margin_t=inf["margin_t"], wall_s=wall, peak_rss=rss, device_peak=st.get("device_peak_bytes", 0),
                 cpu_work=st.get("cpu_work_s", 0), mse=mse(img, ref), frames_written=frames,
                 image_hash=st["image_fnv1a64"], load=up)
        bc.log(f"  {label}: {r['tiles']} tiles ({r['layout']}, windows of {r['window_t']} frames), {wall:.0f} s, "
               f"peak RSS {rss / 2**20:.0f} MiB, device peak {r['device_peak'] / 2**20:.0f} MiB, MSE {r['mse']:.4e}, "
               f"{frames} frames (load {up})")
        return r

    def one(label, args):
        fd = os.path.join(work, f"frames_{len(rows)}")
        os.makedirs(fd, exist_ok=True)
        exr = os.path.join(work, f"long_{len(rows)}.exr")
        up = load_avg()
        wall, rss, st = recon(bins, env, dump, exr, args + ["--frames", fd], work)
        rows.append(row_of(label, args, wall, rss, st, exr, fd, up))
        write_csv(os.path.join(a.out, "long.csv"), rows)

    whole = device_memory(bins, env, dump, work)
    one("whole", ["--tiles", "1", "--mem-budget", str(whole)])
    for v in a.variant:
        args = v.split()
        budget = args[args.index("--mem-budget") + 1] if "--mem-budget" in args else None
        if budget:
            pl = info_of(["--mem-budget", budget])
            bc.log(f"  the planner at --mem-budget {budget}: {pl['tiles']} tiles ({pl['tiles_x']}x{pl['tiles_y']}x"
                   f"{pl['tiles_t']}), windows {pl['window_x']}x{pl['window_y']}x{pl['window_t']}, "
                   f"{pl['tile_bytes'] / 2**20:.1f} MiB each; the whole {pl['whole_bytes'] / 2**20:.1f} MiB")
        one(v, args)
    sys.path.insert(0, os.path.join(ROOT, "host", "python"))
    from csi import farm
    args = a.variant[0].split()
    fd = os.path.join(work, "frames_farm")
    os.makedirs(fd, exist_ok=True)
    st = os.path.join(work, "farm.json")
    exr = os.path.join(work, "long_farm.exr")
    up = load_avg()
    t0 = time.perf_counter()
    with TreeRSS() as tr:
        farm.reconstruct(dump, exr, stats=st, frames_dir=fd, tiles=rows[1]["tiles"], options=args, workers=a.workers[-1],
                         bin_dir=os.path.dirname(bins["csi-reconstruct"]), quiet=True)
    wall = time.perf_counter() - t0
    with open(st) as f:
        r = row_of(f"csi-farm, {a.workers[-1]} workers: " + a.variant[0], args, wall, tr.peak, json.load(f), exr, fd, up)
    r["identical"] = r["image_hash"] == rows[1]["image_hash"]
    bc.log(f"  csi-farm image bit-identical to the one process's: {r['identical']}")
    rows.append(r)
    write_csv(os.path.join(a.out, "long.csv"), rows)
    return rows


def write_csv(path, rows):
    keys = []
    for r in rows:
        keys += [k for k in r if k not in keys]
    with open(path, "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=keys)
        wr.writeheader()
        wr.writerows(rows)


def plot(a):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    figdir = a.figures
    os.makedirs(figdir, exist_ok=True)
    sz = os.path.join(a.out, "sizes.csv")
    if os.path.exists(sz):
        rows = list(csv.DictReader(open(sz)))
        px = [int(r["width"]) * int(r["height"]) / 1e6 for r in rows]
        fig, ax = plt.subplots(1, 2, figsize=(10, 3.8))
        ax[0].loglog(px, [float(r["wall_s"]) for r in rows], "o-", label="wall")
        ax[0].loglog(px, [float(r["cpu_work"]) for r in rows], "s--", label="CPU (solve + integrate)")
        ax[0].set_xlabel("output megapixels (4 spp, 8x grid)")
        ax[0].set_ylabel("seconds")
        ax[0].legend()
        ax[0].grid(True, which="both", alpha=0.3)
        ax[1].semilogx(px, [float(r["peak_rss"]) / 2**30 for r in rows], "o-", label="peak RSS (process)")
        ax[1].semilogx(px, [float(r["device_peak"]) / 2**30 for r in rows], "s--", label="device buffers (peak)")
        for r, x in zip(rows, px):
            ax[1].annotate(f"{r['tiles']} tiles", (x, float(r["peak_rss"]) / 2**30), fontsize=7,
                           textcoords="offset points", xytext=(0, 5))
        ax[1].axhline(1.0, color="gray", lw=0.8, ls=":")
        ax[1].set_xlabel("output megapixels")
        ax[1].set_ylabel("GiB")
        ax[1].legend()
        ax[1].grid(True, which="both", alpha=0.3)
        fig.tight_layout()
        fig.savefig(os.path.join(figdir, "sizes.png"), dpi=80)
    if os.path.exists(os.path.join(a.out, "seam_tiled.npy")):
        t = np.load(os.path.join(a.out, "seam_tiled.npy"))
        u = np.load(os.path.join(a.out, "seam_untiled.npy"))
        info = json.load(open(os.path.join(a.out, "seam_info.json")))
        fig, ax = plt.subplots(1, 4, figsize=(15, 4.0))
        srgb = lambda x: np.clip(np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.clip(x, 0, None) ** (1 / 2.4) - 0.055), 0, 1)
        ax[0].imshow(srgb(u))
        ax[0].set_title("untiled")
        ax[1].imshow(srgb(t))
        ax[1].set_title(f"{info['tiles']} tiles ({info['tiles_x']}x{info['tiles_y']})")
        d = np.abs(t - u).mean(axis=2)
        im = ax[2].imshow(d, cmap="magma", vmin=0, vmax=max(1e-6, np.percentile(d, 99.5)))
        ax[2].set_title("|tiled - untiled|, boundaries dotted")
        bx = [int(v) for v in info["cores_x"].split(",")][1:-1]
        by = [int(v) for v in info["cores_y"].split(",")][1:-1]
        for b in bx:
            ax[2].axvline(b - 0.5, color="c", lw=0.6, ls=":")
        for b in by:
            ax[2].axhline(b - 0.5, color="c", lw=0.6, ls=":")
        fig.colorbar(im, ax=ax[2], fraction=0.046)
        # a 64-pixel crop of the tiled image centred on a core boundary, pixels shown as blocks
        c = bx[len(bx) // 2] if bx else t.shape[1] // 2
        y0 = t.shape[0] // 2
        ax[3].imshow(srgb(t[y0 - 32:y0 + 32, c - 32:c + 32]), interpolation="nearest")
        ax[3].axvline(31.5, color="c", lw=0.6, ls=":")
        ax[3].set_title(f"tiled, crop at boundary x = {c}")
        for x in ax:
            x.set_xticks([])
            x.set_yticks([])
        fig.tight_layout()
        fig.savefig(os.path.join(figdir, "seams_garden.png"), dpi=72)


def mitsuba(a, bins, env, work, logf):
    """Tiled against untiled on Mitsuba's dumps (module doc): per dump and build, the MSE and relMSE
    of the untiled and tiled images over the mean's of the same samples."""
    builds = {"this": bins["csi-reconstruct"]}
    if a.base:
        builds["base"] = os.path.join(a.base, "csi-reconstruct")
    exr = os.path.join(work, "mitsuba.exr")

    def errors(ref):
        img = bc.read_exr(exr).astype(np.float64)
        d = (img - ref) ** 2
        return [float(d.mean()), float((d / (ref ** 2 + 0.01)).mean())]

    rows = []
    for d in a.data.split(","):
        for scene in sorted(os.listdir(d)):
            sd = os.path.join(d, scene)
            refs = sorted(f for f in os.listdir(sd) if f.startswith("reference_") and f.endswith(".npy")) \
                if os.path.isdir(sd) else []
            if not refs:
                continue
            ref = np.load(os.path.join(sd, refs[-1])).astype(np.float64)
            for stem in (f"s{spp}_p{p}{m}" for spp in a.mitsuba_spp.split(",") for p in a.mitsuba_paths.split(",")
                         for m in ("", "_poisson")):
                dump = os.path.join(sd, stem + ".csid")
                if not os.path.exists(dump):
                    continue
                subprocess.run([builds["this"], dump, "-o", exr, "-q", "--estimator", "mean", "--variance", "none"],
                               check=True, env=env)
                row = dict(data=os.path.basename(d.rstrip("/")), scene=scene, dump=stem, mean=errors(ref))
                for name, b in builds.items():
                    for n in [1] + a.mitsuba_tiles:
                        r = subprocess.run([b, dump, "-o", exr, "-q", "--tiles", str(n)], env=env,
                                           capture_output=True, text=True)
                        row[f"{name} {n}"] = errors(ref) if r.returncode == 0 else None
                rows.append(row)
                bc.log("  " + " ".join(f"{k}: {v[0] / row['mean'][0]:.4f}/{v[1] / row['mean'][1]:.4f}"
                                       for k, v in row.items() if isinstance(v, list) and k != "mean" and v)
                       + f"  ({row['data']} {scene} {stem}; over the mean, MSE/relMSE)")
    summary = mitsuba_summary(rows, builds, a.mitsuba_tiles)
    for line in summary:
        bc.log(line)
        print(line, file=logf)
    with open(os.path.join(a.out, "mitsuba.json"), "w") as f:
        json.dump(rows, f, indent=0)
    return summary


def mitsuba_summary(rows, builds, tiles):
    """Per build and tile count: the tiled/untiled ratios' range and the cells above the mean."""
    out = []
    for name in builds:
        u = [r for r in rows if r.get(f"{name} 1")]
        above_u = sum(max(r[f"{name} 1"][k] / r["mean"][k] for k in (0, 1)) > 1 for r in u)
        out.append(f"{name}, untiled: {len(u)} dumps, {above_u} above the mean (MSE or relMSE)")
        for n in tiles:
            t = [r for r in u if r.get(f"{name} {n}")]
            if not t:
                continue
            q = np.array([[r[f"{name} {n}"][k] / r[f"{name} 1"][k] for k in (0, 1)] for r in t])
            above = sum(max(r[f"{name} {n}"][k] / r["mean"][k] for k in (0, 1)) > 1 for r in t)
            newly = sum(max(r[f"{name} {n}"][k] / r["mean"][k] for k in (0, 1)) > 1 and
                        max(r[f"{name} 1"][k] / r["mean"][k] for k in (0, 1)) <= 1 for r in t)
            worse = sum(q.max(1) > 1.02)
            out.append(f"{name}, {n} tiles: {len(t)} dumps; tiled/untiled MSE {q[:, 0].min():.3f}-{q[:, 0].max():.3f} "
                       f"(geometric mean {np.exp(np.log(q[:, 0]).mean()):.4f}), relMSE {q[:, 1].min():.3f}-"
                       f"{q[:, 1].max():.3f} ({np.exp(np.log(q[:, 1]).mean()):.4f}); above untiled by > 2% in "
                       f"{worse}; above the mean {above} ({newly} where untiled is not)")
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("what", choices=["seams", "seams_t", "margins", "windows", "sizes", "workers", "target", "long",
                                     "plot", "mitsuba"])
    ap.add_argument("--out", default="bench-scale")
    ap.add_argument("--figures", default=os.path.join(ROOT, "docs", "bench", "scale"))
    ap.add_argument("--scene", default="garden")
    ap.add_argument("--spp", type=int, default=4)
    ap.add_argument("--size", action="append", help="WxH (repeatable); sizes: 256x256 .. 3840x2160")
    ap.add_argument("--tiles", type=int, default=0, help="workers: tiles (default: the budget's)")
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--keep", action="store_true", help="keep the dumps")
    ap.add_argument("--time-steps", type=int, default=256, help="long: frames of the volume")
    ap.add_argument("--variant", action="append", default=[],
                    help="long: csi-reconstruct arguments of a tiled run (repeatable; the first also runs on csi-farm)")
    ap.add_argument("--data", help="mitsuba: tools/bench/mitsuba_data.py directories, comma-separated")
    ap.add_argument("--mitsuba-spp", default="4,16", help="mitsuba: the dumps' spp")
    ap.add_argument("--mitsuba-paths", default="1,64", help="mitsuba: the dumps' paths per sample")
    ap.add_argument("--mitsuba-tiles", type=int, nargs="+", default=[2, 4], help="mitsuba: tile counts")
    ap.add_argument("--base", help="mitsuba: another build directory to run beside this one")
    a = ap.parse_args()
    if a.what == "mitsuba" and not a.data:
        ap.error("mitsuba needs --data")
    os.makedirs(a.out, exist_ok=True)
    if a.what == "plot":
        return plot(a)
    default_sizes = {"sizes": ["256x256", "512x512", "1024x1024", "1920x1080", "3840x2160"],
                     "workers": ["1920x1080"], "target": ["1920x1080"], "long": ["64x64"]}.get(a.what, [])
    a.sizes = [tuple(int(v) for v in s.split("x")) for s in (a.size or default_sizes)]
    bins = binaries()
    env = bc.default_env()
    work = os.path.join(a.out, "work")
    os.makedirs(work, exist_ok=True)
    with open(os.path.join(a.out, f"{a.what}.log"), "a") as logf:
        bc.log(f"{a.what}: load {load_avg()}")
        rows = globals()[a.what](a, bins, env, work if a.what not in ("seams", "seams_t", "margins", "windows") else a.out, logf)
    print(json.dumps(rows, indent=1, default=float))


if __name__ == "__main__":
    main()
