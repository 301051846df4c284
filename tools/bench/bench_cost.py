#!/usr/bin/env python3
"""What csi's reconstruction costs per sample, in Mitsuba paths (issue 13).

Measures, in one run so that the machine's load hits both alike:
  - Mitsuba 3's cost per path: the Cornell box (mi.cornell_box(), path tracer, max depth 8,
    llvm_ad_rgb), batches of --paths paths at random image positions (TOOLCHAIN.md's recipe),
    warm (a first batch compiles and is not counted); wall and CPU time (both threads) per
    path, in a child process;
  - csi-reconstruct on sample dumps (warm: PoCL's cache filled by an untimed first run), with
    its phases from --stats: fixed cost (reading the dump, the OpenCL context, setup including
    the kernel programs), solve and integration per channel, writing; and the child's CPU time.
  Cost per sample = (solve + integrate) / samples, and that in Mitsuba paths (wall over wall,
  and CPU over CPU). Path batches run before every case and between its runs; each case is
  compared with the batches closest to it.
Cases:
  demo     data/scenes/triangle at 256x256, 4 spp (what tools/demo renders), csi's default grid
  hd       data/scenes/garden at 1920x1080, 4 spp, csi's default grid (8x: 15360 x 8640)
  mitsuba  the Mitsuba dataset's 128x128 dumps at 4 spp, 64 paths per sample (--mitsuba-data)
With --base BUILD_DIR every case also runs the other build (the "before"), on the same dumps.
--quality compares the two builds' images on the same samples against references: the bundled
scenes at 128x128 (1, 4, 16 spp; reference: csi-render --reference 256), the analytic images of
tools/bench/quality_sweep.py (csi-mkdump dumps; exact box truth), and the Mitsuba dataset's
dumps (its references). --equal-time (needs the Mitsuba data): csi at 4 spp against the
per-pixel mean at the spp the same total time buys, and the break-even cost per sample
(docs/BENCHMARKS-accuracy.md's definition) against Mitsuba's measured cost per path.
With --refine as well, csi also with csi-mitsuba's second pass: the cells it asks for rendered
through the bridge (needs Mitsuba and the scenes), the render's wall time counted.

Usage (from a worktree root, after building):
  .venv/bin/python tools/bench/bench_cost.py --base /path/to/old/build --runs 3 --md docs/bench/cost.md
  .venv/bin/python tools/bench/bench_cost.py --cases demo --runs 5
Mitsuba needs DRJIT_LIBLLVM_PATH (set here to /usr/lib/x86_64-linux-gnu/libLLVM-19.so unless
given). The machine is shared: the report prints the load average before and after.
"""
import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bench_common as bc  # noqa: E402

LLVM = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so"
MITSUBA_SCENES = ("cornell", "glossy_sun", "thin_geometry", "horizon", "envmap")


# ---- Mitsuba's cost per path (child process) -----------------------------------------------------
def mitsuba_child(paths, batches, seed0):
    """Runs in a child: prints JSON {wall_us, cpu_us} per path for each warm batch."""
    os.environ.setdefault("DRJIT_LIBLLVM_PATH", LLVM)
    import drjit as dr
    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")
    d = mi.cornell_box()
    d["integrator"] = {"type": "path", "max_depth": 8}
    scene = mi.load_dict(d)
    sensor = scene.sensors()[0]
    rng = np.random.default_rng(seed0)

    def batch(seed):
        u = mi.Float(rng.random(paths).astype(np.float32))
        v = mi.Float(rng.random(paths).astype(np.float32))
        sampler = sensor.sampler().clone()
        sampler.seed(dr.opaque(mi.UInt32, seed), paths)
        ray, w = sensor.sample_ray(0.0, sampler.next_1d(), mi.Point2f(u, v), sampler.next_2d())
        L, _, _ = scene.integrator().sample(scene, sampler, ray)
        return np.array(L * w)  # forces the evaluation

    batch(seed0)  # compiles
    out = []
    for b in range(batches):
        c0, t0 = time.process_time(), time.perf_counter()
        img = batch(seed0 + 1 + b)
        t, c = time.perf_counter() - t0, time.process_time() - c0
        if not np.isfinite(img).all():
            raise SystemExit("mitsuba: non-finite radiance")
        out.append({"wall_us": 1e6 * t / paths, "cpu_us": 1e6 * c / paths})
    print(json.dumps(out))


def mitsuba_cost(args, seed):
    cmd = [sys.executable, os.path.abspath(__file__), "--mitsuba-child", str(args.paths), str(args.batches), str(seed)]
    env = bc.default_env()
    env.setdefault("DRJIT_LIBLLVM_PATH", LLVM)
    p = subprocess.run(cmd, capture_output=True, env=env, text=True)
    if p.returncode != 0:
        raise bc.BenchError("mitsuba path timing failed:\n" + p.stderr[-2000:])
    return json.loads(p.stdout.strip().splitlines()[-1])


# ---- csi runs -------------------------------------------------------------------------------------
def run_timed(cmd, env=None):
    """Runs cmd; returns (wall s, CPU s of the child: user + system, all threads, its peak resident
    bytes)."""
    t0 = time.perf_counter()
    p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env or bc.default_env())
    _, status, ru = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t0
    err = p.stderr.read().decode(errors="replace")
    p.stderr.close()
    if os.waitstatus_to_exitcode(status) != 0:
        raise bc.BenchError(f"exit {os.waitstatus_to_exitcode(status)}: {' '.join(cmd)}\n{err[-2000:]}")
    # ru_maxrss is in KiB on Linux (getrusage(2)); wait4's is this child's alone
    return wall, ru.ru_utime + ru.ru_stime, ru.ru_maxrss * 1024


def reconstruct(build, dump, out_exr, stats, extra=(), rss=None):
    """Runs csi-reconstruct; returns (wall s, CPU s, its stats). rss: a list that gets the peak
    resident bytes appended."""
    exe = os.path.join(build, "csi-reconstruct")
    wall, cpu, peak = run_timed([exe, dump, "-o", out_exr, "--stats", stats, "-q", *extra])
    if rss is not None:
        rss.append(peak)
    with open(stats) as f:
        st = json.load(f)
    return wall, cpu, st


def phases(st):
    """The stats' phase times (new builds) or what an old build's stats give."""
    ph = st.get("phases")
    # The run's totals, not the channels' own phases: with the cross-validated choice (noisy
    # samples) the two folds' solves and integrations count in t_solve_s and t_integrate_s only.
    solve, integrate = st["t_solve_s"], st["t_integrate_s"]
    if ph:
        return dict(read=ph["read_s"], device=ph["device_s"], programs=ph["programs_s"], setup=ph["setup_s"],
                    solve=solve, integrate=integrate, write=ph["write_s"], fixed=st["fixed_s"])
    return dict(read=None, device=None, programs=None, setup=st["t_setup_s"], solve=st["t_solve_s"],
                integrate=st["t_integrate_s"], write=None, fixed=None)


# ---- cases ------------------------------------------------------------------------------------------
def make_dump(bins, scene, size, spp, work, name):
    dump = os.path.join(work, name + ".csid")
    if os.path.exists(dump):
        return dump
    path, _ = bc.scene_variant(scene, size, work)
    bc.log(f"dump {name}: rendering {scene} at {size[0]}x{size[1]}, {spp} spp")
    # the dump is what counts: csi-render's own reconstruction is the cheap per-pixel mean here
    bc.run([bins["csi-render"], path, "--spp", str(spp), "--dump", dump, "--estimator", "mean",
            "-o", os.path.join(work, name + ".render.exr"), "-q"])
    return dump


def cases(args, bins):
    out = []
    want = args.cases.split(",")
    if "demo" in want:
        out.append(("demo: triangle 256x256, 4 spp", make_dump(bins, "triangle", (256, 256), 4, args.work, "demo")))
    if "hd" in want:
        out.append(("hd: garden 1920x1080, 4 spp", make_dump(bins, "garden", (1920, 1080), 4, args.work, "hd")))
    if "mitsuba" in want:
        for s in MITSUBA_SCENES:
            d = os.path.join(args.mitsuba_data, s, "s4_p64_poisson.csid")
            if os.path.exists(d):
                out.append((f"mitsuba {s} 128x128, 4 spp", d))
    return out


def cost_section(args, bins, report):
    builds = [("after", args.build)] + ([("before", args.base)] if args.base else [])
    extra = {"after": args.build_args.split(), "before": []}
    nruns = {"after": args.runs, "before": args.base_runs}
    for v in args.cost_variant:
        # the new build with other arguments, alternating with the builds like a third build
        name, _, vargs = v.partition(":")
        builds.append((name, args.build))
        extra[name] = vargs.split()
        nruns[name] = args.runs
    rows, paths = [], []
    for label, dump in cases(args, bins):
        hdr, _, _ = bc.read_dump(dump)
        for bname, build in builds if args.warmup else ():
            # warm-up: PoCL's and clFFT's caches, the dump in the page cache
            reconstruct(build, dump, os.path.join(args.work, "warm.exr"), os.path.join(args.work, "warm.json"),
                        extra[bname])
        best, cpus = {}, {b: [] for b, _ in builds}
        # the builds' runs alternate (after, before, before, after, ...) so that a change of the
        # machine's load hits both alike
        for r in range(max(nruns[b] for b, _ in builds)):
            for bname, build in (builds if r % 2 == 0 else builds[::-1]):
                if r >= nruns[bname]:
                    continue
                m = mitsuba_cost(args, 100 + len(paths))
                paths.append(m)
                rss = []
                wall, cpu, st = reconstruct(build, dump, os.path.join(args.work, "cost.exr"),
                                            os.path.join(args.work, "cost.json"), extra[bname], rss)
                ph = phases(st)
                n = st["n"] if "n" in st else hdr["count"]
                per = 1e6 * (ph["solve"] + ph["integrate"]) / n
                path_wall = min(b["wall_us"] for b in m)
                path_cpu = min(b["cpu_us"] for b in m)
                # CPU of the solves and integration (new builds' stats), else the whole process's
                cpu_per = st.get("cpu_per_sample_us", 1e6 * cpu / n)
                cpus[bname].append(cpu_per)
                rec = dict(case=label, build=bname, samples=n, grid=f"{hdr['grid_w']}x{hdr['grid_h']}",
                           D=st.get("model_grid_factor", 1), tiles=st.get("tiles", 1),
                           steps="/".join(str(c["iterations"]) for c in st["channels"].values()),
                           wall=wall, cpu=cpu, per_sample_us=per, cpu_per_sample_us=cpu_per,
                           cpu_is_work="cpu_per_sample_us" in st, path_wall_us=path_wall,
                           path_cpu_us=path_cpu, peak_rss=rss[0], args=" ".join(extra[bname]), **ph)
                bc.log(f"{label} [{bname}] run {r + 1}: wall {wall:.2f} s, {per:.2f} us/sample, "
                       f"path {path_wall:.3f} us -> {per / path_wall:.1f} paths/sample; CPU {cpu_per:.2f} us/sample; "
                       f"peak RSS {rss[0] / 1e9:.2f} GB")
                if bname not in best or wall < best[bname]["wall"]:
                    best[bname] = rec
        for bname, _ in builds:
            best[bname]["cpu_median_us"] = float(np.median(cpus[bname]))
            best[bname]["runs"] = len(cpus[bname])
            rows.append(best[bname])
    report["cost"] = rows
    report["paths"] = paths
    return rows, paths


def fmt(v, f="{:.3f}"):
    return "" if v is None else f.format(v)


def cost_markdown(rows, paths):
    allw = [b["wall_us"] for m in paths for b in m]
    allc = [b["cpu_us"] for m in paths for b in m]
    lines = [f"Mitsuba 3 Cornell box, depth 8, {len(allw)} warm batches: wall {min(allw):.3f}-{max(allw):.3f} us per "
             f"path (median {np.median(allw):.3f}); CPU {min(allc):.3f}-{max(allc):.3f} us per path.", "",
             "| case | build | samples | grid | D | tiles | steps per channel | fixed s | programs s | solve s | integrate s | write s | wall s | reconstruction us/sample | Mitsuba us/path (same run) | paths per sample | CPU us/sample | CPU paths per sample | CPU us/sample, median of runs | peak RSS GB |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    notes = ["", "Per sample: (solve + integrate) / samples, wall clock; CPU: process CPU time of the solves and "
             "integration (all threads; * = an old build's whole process, setup included, which its stats do not "
             "split). Paths per sample: that over Mitsuba's cost per path (wall over wall, CPU over CPU), the fastest "
             "batch measured just before the case's run. The builds' runs alternate; the row is each build's fastest run (wall), "
             "the median CPU cost over all its runs, and that run's peak resident memory (the process's ru_maxrss)."]
    for r in rows:
        build = r["build"] + (f" ({r['args']})" if r.get("args") else "")
        lines.append(f"| {r['case']} | {build} | {r['samples']} | {r['grid']} | {r['D']} | {r['tiles']} | {r['steps']} | "
                     f"{fmt(r['fixed'])} | {fmt(r['programs'])} | {fmt(r['solve'])} | {fmt(r['integrate'])} | {fmt(r['write'])} | "
                     f"{r['wall']:.2f} | {r['per_sample_us']:.2f} | {r['path_wall_us']:.3f} | "
                     f"{r['per_sample_us'] / r['path_wall_us']:.1f} | {r['cpu_per_sample_us']:.2f}{'' if r['cpu_is_work'] else '*'} | "
                     f"{r['cpu_per_sample_us'] / r['path_cpu_us']:.1f} | {r['cpu_median_us']:.2f} ({r['runs']}) | "
                     f"{r['peak_rss'] / 1e9:.2f} |")
    return "\n".join(lines + notes)


# ---- quality: the same samples through both builds ----------------------------------------------
def rel_mse(img, ref):
    return float(np.mean((img - ref) ** 2 / (ref ** 2 + 0.01)))


def scene_dumps(args, bins, size, spps, seeds):
    """The bundled scenes at size x size: (name, dump, reference) for each spp and seed."""
    out = []
    for scene in ("triangle", "garden", "checkerboard"):
        path, _ = bc.scene_variant(scene, (size, size), args.work)
        tag = "" if size == 128 else f"_{size}"
        ref_exr = os.path.join(args.work, f"q_{scene}{tag}_ref.exr")
        if not os.path.exists(ref_exr):
            bc.log(f"reference {scene} {size}x{size}")
            bc.run([bins["csi-render"], path, "--reference", "256", "-o", ref_exr, "-q"])
        ref = bc.read_exr(ref_exr)
        for spp in spps:
            for seed in seeds:
                name = f"q_{scene}{tag}_s{spp}_{seed}"
                dump = os.path.join(args.work, name + ".csid")
                if not os.path.exists(dump):
                    bc.run([bins["csi-render"], path, "--spp", str(spp), "--seed", str(seed), "--dump", dump,
                            "--estimator", "mean", "-o", os.path.join(args.work, name + ".r.exr"), "-q"])
                out.append((f"{scene} {size}x{size} {spp} spp seed {seed}", dump, ref))
    return out


def quality_dumps(args, bins):
    """(name, dump, reference image) triples of the sets in --quality-sets."""
    sets = args.quality_sets.split(",")
    out = []
    if "bundled" in sets:
        out += scene_dumps(args, bins, 128, args.quality_spp, (1, 2))
    if "bundled256" in sets:
        # 256x256 at 4 spp: the demo's size, where the model grid is coarser than the samples'
        # (D = 2); at 128x128 the default grid allows no coarser model (D = 1)
        out += scene_dumps(args, bins, 256, (4,), (1, 2))
    if "bundled288" in sets:
        # 288x288 at 4 spp: a model grid of 1152 x 1152 (rows of M = 576 = 8 x 8 x 9, columns
        # 8 x 4 x 4 x 9), so the radix-9 passes run along both axes, as in the 1920x1080 tiles
        out += scene_dumps(args, bins, 288, (4,), (1, 2))
    if "analytic" not in sets:
        return out + mitsuba_quality_dumps(args, sets)
    import quality_sweep as qs
    for img, fn in qs.IMAGES.items():
        for grid, o, spp in ((512, 64, 4), (256, 64, 1), (256, 64, 4), (256, 64, 16)):
            fine_exr = os.path.join(args.work, f"a_{img}_{grid}.exr")
            if not os.path.exists(fine_exr):
                qs.write_exr(fine_exr, qs.fine_grid(fn, grid))
            truth = qs.box_truth(fn, grid, o, 4)[..., None].astype(np.float32)
            for seed in (1, 2):
                name = f"a_{img}_{grid}_{o}_s{spp}_{seed}"
                dump = os.path.join(args.work, name + ".csid")
                if not os.path.exists(dump):
                    bc.run([bins["csi-mkdump"], fine_exr, "-o", dump, "--out", f"{o}x{o}", "--spp", str(spp),
                            "--seed", str(seed), "--method", "poisson", "-q"])
                out.append((f"analytic {img} {grid}->{o} {spp} spp seed {seed}", dump, truth))
    return out + mitsuba_quality_dumps(args, sets)


def mitsuba_quality_dumps(args, sets):
    out = []
    if "mitsuba" not in sets:
        return out
    for s in MITSUBA_SCENES:
        d = os.path.join(args.mitsuba_data, s)
        refs = sorted(f for f in os.listdir(d) if f.startswith("reference_") and f.endswith(".npy")) if os.path.isdir(d) else []
        if not refs:
            continue
        ref = np.load(os.path.join(d, refs[-1])).astype(np.float32)
        for spp in args.quality_spp:
            for paths in (1, 64):
                dump = os.path.join(d, f"s{spp}_p{paths}_poisson.csid")
                if os.path.exists(dump):
                    out.append((f"mitsuba {s} {spp} spp {paths} paths", dump, ref))
    return out


def quality_section(args, bins, report):
    """Every dump through the base build and each variant of the new one (--variant)."""
    variants = [("after", [])] + [(v.split(":", 1)[0], v.split(":", 1)[1].split()) for v in args.variant]
    rows = []
    for name, dump, ref in quality_dumps(args, bins):
        res = {}
        for vname, build, extra in [("before", args.base, [])] + [(v, args.build, e) for v, e in variants]:
            exr, js = os.path.join(args.work, "q_v.exr"), os.path.join(args.work, "q_v.json")
            _, _, st = reconstruct(build, dump, exr, js, extra)
            img = bc.read_exr(exr)
            steps = sum(c["iterations"] for c in st["channels"].values() if c.get("t_total_s", 1) > 0)
            res[vname] = dict(mse=bc.mse(img, ref), relmse=rel_mse(img, ref), D=st.get("model_grid_factor", 1),
                              solve=phases(st)["solve"], steps=steps)
        rows.append(dict(name=name, **{f"{v}_{k}": x for v, r in res.items() for k, x in r.items()}))
        bc.log(f"quality {name}: MSE before {res['before']['mse']:.4e}; " + ", ".join(
            f"{v} {res[v]['mse'] / res['before']['mse']:.4f} ({res[v]['steps']} steps)" for v, _ in variants))
    report["quality"] = rows
    report["variants"] = [v for v, _ in variants]
    return rows, [v for v, _ in variants]


def quality_markdown(rows, variants):
    lines = []
    for v in variants:
        r = np.array([q[f"{v}_mse"] / q["before_mse"] for q in rows])
        lines.append(f"- **{v}**: MSE / before over {len(rows)} dumps: min {r.min():.4f}, max {r.max():.4f}, "
                     f"geometric mean {np.exp(np.log(r).mean()):.4f}; within 2%: {int((np.abs(r - 1) <= 0.02).sum())} "
                     f"of {len(r)}.")
    head = "| samples | D | MSE before | " + " | ".join(f"{v} / before | steps {v}" for v in variants) + " | steps before |"
    lines += ["", head, "|" + "---|" * (4 + 2 * len(variants))]
    for q in rows:
        lines.append(f"| {q['name']} | {q[variants[0] + '_D']} | {q['before_mse']:.4e} | " +
                     " | ".join(f"{q[v + '_mse'] / q['before_mse']:.4f} | {q[v + '_steps']}" for v in variants) +
                     f" | {q['before_steps']} |")
    return "\n".join(lines)


# ---- equal time on the Mitsuba scenes -------------------------------------------------------------
def loglog_spp(mse_by_spp, target):
    """The spp at which the stratified mean's MSE equals target: log-log interpolation of the
    measured points, extrapolated with the slope of the last two past the largest spp."""
    s = np.array(sorted(mse_by_spp))
    m = np.array([mse_by_spp[k] for k in s])
    ls, lm = np.log(s), np.log(m)
    if target >= m[0]:
        i = 0
    else:
        i = min(np.searchsorted(-lm, -np.log(target)) - 1, len(s) - 2)
        i = max(i, 0)
    slope = (lm[i + 1] - lm[i]) / (ls[i + 1] - ls[i])
    return float(np.exp(ls[i] + (np.log(target) - lm[i]) / slope))


def equal_time_section(args, bins, report, path_us):
    rows = []
    for s in MITSUBA_SCENES:
        d = os.path.join(args.mitsuba_data, s)
        refs = sorted(f for f in os.listdir(d) if f.startswith("reference_") and f.endswith(".npy")) if os.path.isdir(d) else []
        need = [os.path.join(d, f) for f in ("s4_p64_poisson.csid", "s1_p64.csid", "s4_p64.csid", "s16_p64.csid")]
        if not refs or not all(os.path.exists(p) for p in need):
            continue
        ref = np.load(os.path.join(d, refs[-1])).astype(np.float32)
        mean = {}
        for spp in (1, 4, 16):
            exr = os.path.join(args.work, "et_mean.exr")
            reconstruct(args.build, os.path.join(d, f"s{spp}_p64.csid"), exr, os.path.join(args.work, "et.json"),
                        ["--estimator", "mean"])
            mean[spp] = bc.mse(bc.read_exr(exr), ref)
        exr = os.path.join(args.work, "et_cs.exr")
        more_path = os.path.join(args.work, "et_more.csid")
        if os.path.exists(more_path):
            os.remove(more_path)
        _, _, st = reconstruct(args.build, need[0], exr, os.path.join(args.work, "et.json"),
                               ["--refine-request", more_path] if args.refine else [])
        ph = phases(st)
        n = st["n"]
        c_rec = 1e6 * (ph["solve"] + ph["integrate"]) / n      # reconstruction us per sample
        cs_img = bc.read_exr(exr)
        cs = bc.mse(cs_img, ref)
        second = second_pass(args, s, need[0], more_path, cs_img, ref) if args.refine else None
        with open(need[0].replace(".csid", ".json")) as f:
            mts = json.load(f)["mitsuba"]
        # the sample's cost: 64 of this run's measured paths (the dataset's own timing ran under
        # whatever load it had)
        c_sample = 64 * path_us
        s_star = loglog_spp(mean, cs)                          # stratified spp as accurate as csi at 4
        spp_eq = 4 + 4 * c_rec / c_sample                      # what csi's total time buys the mean
        mse_eq = float(np.exp(np.interp(np.log(spp_eq), np.log([1, 4, 16]), np.log([mean[1], mean[4], mean[16]]))))
        be = 4 * c_rec / (s_star - 4) if s_star > 4 else float("inf")
        rows.append(dict(scene=s, mse_mean4=mean[4], mse_cs4=cs, s_star=s_star, c_rec_us=c_rec, c_sample_us=c_sample,
                         dataset_path_us=mts["per_path_us"], spp_eq=spp_eq, mse_mean_eq=mse_eq,
                         wins=cs < mse_eq, breakeven_us=be, breakeven_paths=be / path_us))
        bc.log(f"equal time {s}: csi {cs:.3e} vs mean at {spp_eq:.2f} spp {mse_eq:.3e}; break-even {be:.2f} us = "
               f"{be / path_us:.1f} paths")
        if second is not None:
            # csi-mitsuba's whole run per pixel: the first pass's 4 samples and their
            # reconstruction, then the second pass's render (its wall time through the bridge,
            # fixed costs included) and patch; the mean gets that time in samples of c_sample
            pix = n / 4
            for k in ("warm", "cold"):
                spp_k = spp_eq + 1e6 * (second[f"render_{k}_s"] + second["host_s"]) / (pix * c_sample)
                mse_k = float(np.exp(np.interp(np.log(spp_k), np.log([1, 4, 16]), np.log([mean[1], mean[4], mean[16]]))))
                second[f"spp_eq_{k}"], second[f"mse_mean_eq_{k}"] = spp_k, mse_k
                second[f"wins_{k}"] = second["mse"] < mse_k
            rows[-1]["refine"] = second
            bc.log(f"  with the second pass ({second['cells']} cells): csi {second['mse']:.3e} vs mean at "
                   f"{second['spp_eq_warm']:.2f} spp {second['mse_mean_eq_warm']:.3e} (warm), "
                   f"{second['spp_eq_cold']:.2f} spp {second['mse_mean_eq_cold']:.3e} (cold)")
    report["equal_time"] = rows
    return rows


def second_pass(args, scene, dump, more_path, first_img, ref):
    """csi-mitsuba's second pass on a dataset dump, as csi-mitsuba runs it: the cells
    csi-reconstruct --refine-request asked for rendered through the bridge with the first pass's
    paths per sample and the refinement's seed, and the first pass's image patched. The render
    runs twice: cold (the first launch of its size in this process; Dr.Jit may still find the
    kernel in its disk cache) and warm; the patch (csi.refine_apply) is timed too."""
    sys.path.insert(0, os.path.join(bc.ROOT, "host", "python"))
    os.environ.setdefault("CSI_BUILD_DIR", args.build)  # the library of the build under test
    import csi
    from csi import dump as csid
    from csi import mitsuba_bridge as mb
    from csi.mitsuba_cli import refine_seed
    import mitsuba_data as md

    D = csid.read(dump)
    if not os.path.exists(more_path):  # no pixel to refine: the first pass's image is the answer
        return dict(cells=0, render_cold_s=0.0, render_warm_s=0.0, host_s=0.0, mse=bc.mse(first_img, ref))
    more = csid.read(more_path, want="request")
    paths = json.load(open(dump.replace(".csid", ".json")))["paths"]
    sc = mb.load_scene(md.SCENES[scene], size=D.out)
    walls = []
    for _ in range(2):
        t0 = time.perf_counter()
        s2 = mb.render_request(sc, more, paths=paths, seed=refine_seed(D.seed))
        walls.append(time.perf_counter() - t0)
    t0 = time.perf_counter()
    img, _ = csi.refine_apply(D.xyt, D.values, more.xyt, s2.values, (*D.grid, *D.out), first_img)
    host_s = time.perf_counter() - t0
    return dict(cells=int(len(more.xyt)), render_cold_s=walls[0], render_warm_s=walls[1], host_s=host_s,
                mse=bc.mse(img, ref))


def equal_time_markdown(rows, path_us):
    lines = [f"Sample = 64 paths at this run's Mitsuba cost ({path_us:.3f} us per path): {64 * path_us:.1f} us.", "",
             "| scene | MSE mean 4 spp | MSE csi 4 spp | stratified spp as accurate as csi (s*) | csi reconstruction us/sample | spp the same time buys the mean | MSE mean at that spp | csi wins in equal time | break-even us/sample | in paths |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['scene']} | {r['mse_mean4']:.4e} | {r['mse_cs4']:.4e} | {r['s_star']:.2f} | {r['c_rec_us']:.2f} | "
                     f"{r['spp_eq']:.2f} | {r['mse_mean_eq']:.4e} | {'yes' if r['wins'] else 'no'} | "
                     f"{r['breakeven_us']:.2f} | {r['breakeven_paths']:.1f} |")
    second = [r for r in rows if "refine" in r]
    if second:
        lines += ["", "With csi-mitsuba's second pass (its render's wall time through the bridge, cold = the first "
                  "launch of its size in the process, warm = the second; the patch's time included):", "",
                  "| scene | cells | render s cold / warm | patch s | MSE csi, both passes | spp the time buys the mean (warm) | "
                  "MSE mean there | wins (warm) | spp (cold) | MSE mean there | wins (cold) |",
                  "|---|---|---|---|---|---|---|---|---|---|---|"]
        for r in second:
            q = r["refine"]
            lines.append(f"| {r['scene']} | {q['cells']} | {q['render_cold_s']:.3f} / {q['render_warm_s']:.3f} | "
                         f"{q['host_s']:.3f} | {q['mse']:.4e} | {q['spp_eq_warm']:.2f} | {q['mse_mean_eq_warm']:.4e} | "
                         f"{'yes' if q['wins_warm'] else 'no'} | {q['spp_eq_cold']:.2f} | {q['mse_mean_eq_cold']:.4e} | "
                         f"{'yes' if q['wins_cold'] else 'no'} |")
    return "\n".join(lines)


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if argv and argv[0] == "--mitsuba-child":
        mitsuba_child(int(argv[1]), int(argv[2]), int(argv[3]))
        return 0
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default=os.path.join(bc.ROOT, "build"))
    ap.add_argument("--base", help="another build directory to compare with (the 'before')")
    ap.add_argument("--work", default="/tmp/csi-bench-cost", help="dumps, references, scratch (kept)")
    ap.add_argument("--cases", default="demo,hd,mitsuba")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--base-runs", type=int, default=1)
    ap.add_argument("--build-args", default="", metavar="ARGS",
                    help="extra csi-reconstruct arguments for --build's cost runs (e.g. an option under test)")
    ap.add_argument("--cost-variant", action="append", default=[], metavar="NAME:ARGS",
                    help="the cost runs: also --build with these csi-reconstruct arguments, its runs "
                    "alternating with the builds' (repeatable), e.g. 'whole:--mem-budget 4G'")
    ap.add_argument("--warmup", type=int, default=1, choices=(0, 1),
                    help="one untimed run of each build per case first [1]; 0 when the caches are known warm")
    ap.add_argument("--paths", type=int, default=1 << 20, help="paths per Mitsuba batch [2^20]")
    ap.add_argument("--batches", type=int, default=3, help="warm Mitsuba batches per measurement [3]")
    ap.add_argument("--mitsuba-data", default="/work/data/mitsuba")
    ap.add_argument("--quality", action="store_true", help="compare --base and --build on the same samples")
    ap.add_argument("--quality-sets", default="bundled,analytic,mitsuba",
                    help="--quality: which dumps (bundled: the scenes at 128x128, 1/4/16 spp; bundled256: at "
                    "256x256, 4 spp; bundled288: at 288x288, 4 spp; analytic; mitsuba) [bundled,analytic,mitsuba]")
    ap.add_argument("--quality-spp", default="1,4,16", type=lambda v: tuple(int(x) for x in v.split(",")),
                    help="--quality: the spp of the bundled 128x128 and Mitsuba dumps [1,4,16]")
    ap.add_argument("--variant", action="append", default=[], metavar="NAME:ARGS",
                    help="--quality: also the new build with these csi-reconstruct arguments, e.g. "
                    "'warm:--warm-channels on' (repeatable)")
    ap.add_argument("--equal-time", action="store_true")
    ap.add_argument("--refine", action="store_true",
                    help="--equal-time: also csi with csi-mitsuba's second pass (renders its cells with Mitsuba)")
    ap.add_argument("--md", help="write the report as markdown")
    ap.add_argument("--json", help="write the raw figures")
    args = ap.parse_args(argv)
    if args.quality and not args.base:
        ap.error("--quality needs --base")
    os.makedirs(args.work, exist_ok=True)
    bins = bc.binaries(args.build)
    report = {"load_before": os.getloadavg(), "args": vars(args)}
    md = [f"Load average at the start: {' '.join(f'{v:.2f}' for v in os.getloadavg())}."]
    rows, paths = cost_section(args, bins, report) if args.cases else ([], [])
    if rows:
        md += ["", "## Cost per sample", "", cost_markdown(rows, paths)]
    path_us = min(b["wall_us"] for m in paths for b in m) if paths else min(b["wall_us"] for b in mitsuba_cost(args, 7))
    if args.equal_time:
        md += ["", "## Equal time (Mitsuba scenes, 64 paths per sample)", "",
               equal_time_markdown(equal_time_section(args, bins, report, path_us), path_us)]
    if args.quality:
        md += ["", "## Quality on the same samples (before -> after)", "", quality_markdown(*quality_section(args, bins, report))]
    report["load_after"] = os.getloadavg()
    md.append(f"\nLoad average at the end: {' '.join(f'{v:.2f}' for v in os.getloadavg())}.")
    text = "\n".join(md) + "\n"
    print(text)
    if args.md:
        with open(args.md, "w") as f:
            f.write(text)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(report, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
