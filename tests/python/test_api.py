"""The Python binding (host/python/csi/_lib.py over libcsi.so): `import csi` needs only numpy;
csi.reconstruct_dump gives the pixels csi-reconstruct and csi-render give on the same dump, bit
for bit (the stats' hash, and the same FNV-1a computed here over the returned array); options by
keyword come back resolved; csi.positions on csi's grid rule gives csi-positions' request
(mitsuba_bridge.positions_request); Result.write_exr / write_png write the very bytes csi-reconstruct
writes (its EXR header holds only what the inputs decide); errors are CsiError with the library's
message; a progress callback that returns False cancels; tiles made apart (csi.reconstruct_tile,
written as partials) merge to csi.reconstruct's tiled bits. Run by ctest with CSI_BUILD_DIR
(programs and sdk/libcsi.so)."""
import ctypes
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

SOURCE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BUILD = os.environ.get("CSI_BUILD_DIR") or os.path.join(SOURCE, "build")
sys.path.insert(0, os.path.join(SOURCE, "host", "python"))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import csi  # noqa: E402
from checks import check, done  # noqa: E402


def fnv1a64(a: np.ndarray) -> str:
    h = 1469598103934665603
    for b in a.tobytes():
        h = ((h ^ b) * 1099511628211) & 0xFFFFFFFFFFFFFFFF
    return f"{h:016x}"


check("csi._lib" not in sys.modules, "import csi loads the C library only when used")
check(csi.version() == csi.__version__, f"library {csi.version()} vs package {csi.__version__}")
names = {o["keyword"] for o in csi.options()}
check({"tau", "solver", "lambda", "mem_budget"} <= names, f"options: {sorted(names)[:5]}...")

h_of = {}
with tempfile.TemporaryDirectory() as T:
    for sc in ("small_triangle", "small_moving"):
        scene = os.path.join(SOURCE, "tests", "cli", "scenes", sc + ".scene")
        dump = os.path.join(T, sc + ".csid")
        subprocess.run([os.path.join(BUILD, "csi-render"), scene, "-o", os.path.join(T, sc + ".r.exr"), "--dump",
                        dump, "--stats", os.path.join(T, sc + ".r.json"), "-q"], check=True)
        subprocess.run([os.path.join(BUILD, "csi-reconstruct"), dump, "-o", os.path.join(T, sc + ".c.exr"),
                        "--stats", os.path.join(T, sc + ".c.json"), "-q"], check=True)
        want = [json.load(open(os.path.join(T, sc + x)))for x in (".r.json", ".c.json")]
        h_render = h_of[sc] = want[0]["reconstruction"]["image_fnv1a64"]
        h_recon = want[1]["image_fnv1a64"]
        res = csi.reconstruct_dump(dump)
        planar = np.ascontiguousarray(res.image.transpose(2, 0, 1))
        check(res.stats["image_fnv1a64"] == h_recon == h_render,
              f"{sc}: python {res.stats['image_fnv1a64']}, csi-reconstruct {h_recon}, csi-render {h_render}")
        check(fnv1a64(planar) == h_recon, f"{sc}: the returned array's own bits hash to {fnv1a64(planar)}")
        check(res.image.dtype == np.float32 and res.image.shape[2] == 3, f"{sc}: image {res.image.shape}")
        check(res.options["solver"] == "sparsa" and res.options["tau"] not in ("auto", ""),
              f"{sc}: resolved options {res.options['solver']} {res.options['tau']}")
        check(res.info["tiles"] == 1 and res.info["n"] == want[1]["n"], f"{sc}: info {res.info}")
        # where the time went, as csi-reconstruct's statistics say it: each channel's solve
        ph = res.stats.get("phases", {})
        check(sorted(ph.get("solve_s", {})) == sorted(want[1]["phases"]["solve_s"]) and res.stats.get("cpu_work_s", 0) > 0
              and ph.get("read_s") == 0, f"{sc}: the phases {ph}")
        subprocess.run([os.path.join(BUILD, "csi-reconstruct"), dump, "-o", os.path.join(T, sc + ".c2.exr"),
                        "--png", os.path.join(T, sc + ".c.png"), "-q"], check=True)
        res.write_exr(os.path.join(T, sc + ".py.exr"))
        res.write_png(os.path.join(T, sc + ".py.png"))
        for ext in ("exr", "png"):
            a, b = (open(os.path.join(T, f"{sc}.{x}.{ext}"), "rb").read() for x in ("c2" if ext == "exr" else "c", "py"))
            check(a == b, f"{sc}: Result.write_{ext} ({len(b)} bytes) differs from csi-reconstruct's ({len(a)} bytes)")

    # what the samples are: csi-render flags a scene without random effects exact (its plan's
    # "exact"), the dump carries it, and correct = auto then resolves to cv; exact= on the
    # reconstruction of the same arrays chooses between the two images
    plan = json.loads(subprocess.run([os.path.join(BUILD, "csi-render"), "--plan", os.path.join(
        SOURCE, "tests", "cli", "scenes", "small_triangle.scene")], check=True, capture_output=True).stdout)
    d = csi.read_dump(os.path.join(T, "small_triangle.csid"))
    check(plan["exact"] is True and d.exact, f"small_triangle: plan exact {plan['exact']}, dump exact {d.exact}")
    flagged = csi.reconstruct(d.positions, d.values, d.grid, seed=d.seed, exact=True)
    as_cv = csi.reconstruct(d.positions, d.values, d.grid, seed=d.seed, correct="cv")
    plain = csi.reconstruct(d.positions, d.values, d.grid, seed=d.seed)
    as_blend = csi.reconstruct(d.positions, d.values, d.grid, seed=d.seed, correct="blend")
    check(flagged.options["correct"] == "cv" and np.array_equal(flagged.image, as_cv.image)
          and fnv1a64(np.ascontiguousarray(flagged.image.transpose(2, 0, 1))) == h_of["small_triangle"],
          f"exact=True: correct {flagged.options['correct']}, not cv's image or csi-render's")
    check(plain.options["correct"] == "blend" and np.array_equal(plain.image, as_blend.image),
          f"exact=False (default): correct {plain.options['correct']}, not the blend's image")
    check(not np.array_equal(flagged.image, plain.image), "the flag changed nothing on noise-free samples")

    # the ctypes mirrors have csi/csi.h's layout (sizes and offsets from a C compiler)
    from csi import _lib  # noqa: E402
    mirrors = {"csi_samples": _lib._Samples, "csi_dump": _lib._Dump}
    lines = ["#include <stddef.h>", "#include <stdio.h>", '#include "csi/csi.h"', "int main(void) {"]
    for cname, py in mirrors.items():
        lines.append(f'printf("{cname} %zu\\n", sizeof({cname}));')
        for fname, _ in py._fields_:
            lines.append(f'printf("{cname}.{fname} %zu\\n", offsetof({cname}, {fname}));')
    src = os.path.join(T, "layout.c")
    with open(src, "w") as f:
        f.write("\n".join(lines + ["return 0; }"]) + "\n")
    exe = os.path.join(T, "layout")
    subprocess.run(["cc", "-std=c11", "-I", os.path.join(SOURCE, "host", "include"), src, "-o", exe], check=True)
    c_layout = dict(line.rsplit(" ", 1) for line in subprocess.run([exe], check=True, capture_output=True,
                                                                    text=True).stdout.splitlines())
    py_layout = {}
    for cname, py in mirrors.items():
        py_layout[cname] = str(ctypes.sizeof(py))
        for fname, _ in py._fields_:
            py_layout[f"{cname}.{fname}"] = str(getattr(py, fname).offset)
    check(c_layout == py_layout, f"ctypes layout {py_layout} differs from C's {c_layout}")

    # positions: the library's on csi's grid rule are csi-positions' request (mitsuba_bridge's)
    from csi import dump as csid  # noqa: E402
    from csi import mitsuba_bridge as mb  # noqa: E402
    for out, spp, method, t in (((40, 30), 4, "poisson", 1), ((24, 16), 9, "stratified", 1), ((16, 16), 4, "random", 8)):
        path = os.path.join(T, "req.csid")
        subprocess.run([os.path.join(BUILD, "csi-positions"), "--out", f"{out[0]}x{out[1]}", "--spp", str(spp),
                        "--method", method, "--seed", "7", "--time-steps", str(t), "-o", path, "-q"], check=True)
        want = csid.read(path, want="request")
        req = mb.positions_request(out, spp=spp, method=method, seed=7, time_steps=t)
        check(req.grid == want.grid and req.out == want.out and req.seed == want.seed
              and np.array_equal(req.xyt, want.xyt),
              f"positions {out} {spp} spp {method} t={t}: grid {req.grid} vs {want.grid}, {len(req.xyt)} vs "
              f"{len(want.xyt)} positions")

    d = csi.read_dump(os.path.join(T, "small_moving.csid"))
    res = csi.reconstruct(d.positions, d.values, d.grid, frames=True, seed=d.seed)
    check(res.frames is not None and res.frames.shape == (d.grid[2],) + res.image.shape,
          f"frames {None if res.frames is None else res.frames.shape}")
    check(abs(float(res.options["tau"]) - min(3e-2, max(1e-4, 0.25 / np.sqrt(len(d.positions))))) < 1e-15,
          f"the volume's tau {res.options['tau']}")

    try:
        csi.reconstruct(d.positions, d.values, d.grid, lambda_=-1)
        check(False, "a bad lambda raises")
    except csi.CsiError as e:
        check(e.status == "CSI_ERR_ARG" and str(e).startswith("lambda"), f"error: {e.status} {e}")
    calls = []

    def stop(phase, it, res_):
        calls.append(phase)
        return not phase.startswith("solve") or it < 2

    try:
        csi.reconstruct(d.positions, d.values, d.grid, progress=stop)
        check(False, "a progress callback returning False cancels")
    except csi.CsiError as e:
        check(e.status == "CSI_ERR_CANCELLED" and calls[0] == "setup", f"cancel: {e.status} {e} {calls[:3]}")

    # tiles as separate jobs: tiles made by csi.reconstruct_tile and written as partials, one of
    # them by csi-reconstruct --tile instead, merged by csi.merge_partials and by csi-merge, give
    # csi.reconstruct's own tiled image (the same options), bit for bit
    st = csi.read_dump(os.path.join(T, "small_triangle.csid"))
    topts = dict(tiles=4, tile_margin=4, max_iter=40, seed=st.seed, exact=st.exact)
    whole = csi.reconstruct(st.positions, st.values, st.grid, **topts)
    parts = []
    for i in (3, 0, 2):
        t = csi.reconstruct_tile(st.positions, st.values, st.grid, i, **topts)
        check(t.info.get("tile") == i and t.info["tiles"] == 4, f"tile {i}: info {t.info}")
        parts.append(os.path.join(T, f"py{i}.csip"))
        t.write_partial(parts[-1], "small_triangle.csid")
    parts.append(os.path.join(T, "cli1.csip"))
    subprocess.run([os.path.join(BUILD, "csi-reconstruct"), os.path.join(T, "small_triangle.csid"), "--tile", "1/4",
                    "--tile-margin", "4", "--max-iter", "40", "-o", parts[-1], "-q"], check=True)
    m = csi.merge_partials(parts)
    check(whole.info["tiles"] == 4 and np.array_equal(m.image, whole.image)
          and m.stats["image_fnv1a64"] == whole.stats["image_fnv1a64"],
          f"merged partials {m.stats['image_fnv1a64']} vs tiled {whole.stats['image_fnv1a64']}")
    check(m.partial_info["tiles"] == 4 and m.partial_info["input"] == "small_triangle.csid",
          f"the run's description {m.partial_info}")
    subprocess.run([os.path.join(BUILD, "csi-merge")] + parts + ["-o", os.path.join(T, "pm.exr"), "--stats",
                   os.path.join(T, "pm.json"), "-q"], check=True)
    check(json.load(open(os.path.join(T, "pm.json")))["image_fnv1a64"] == whole.stats["image_fnv1a64"],
          "csi-merge of the same partials")
    try:
        csi.merge_partials(parts[:3])
        check(False, "a missing tile raises")
    except csi.CsiError as e:
        check(e.status == "CSI_ERR_ARG" and "tile 1 of 4 is missing" in str(e), f"missing tile: {e.status} {e}")

# csi's program cache: its folder follows CSI_CACHE_DIR (or the XDG / home cache) as the C
# library documents; caching twice stores nothing the second time; off, both refuse.
cache_root = os.environ.get("CSI_CACHE_DIR") or (os.path.join(os.environ["XDG_CACHE_HOME"], "csi")
                                                 if os.environ.get("XDG_CACHE_HOME")
                                                 else os.path.join(os.path.expanduser("~"), ".cache", "csi"))
check(csi.cached_programs_dir() == os.path.join(cache_root, "programs"), f"cache folder {csi.cached_programs_dir()}")
dev = csi.Device()
dev.cache_programs()
check(dev.cache_programs() == 0, "a second cache_programs stored programs again")
os.environ["CSI_PROGRAM_CACHE"] = "0"
for call in (csi.cached_programs_dir, dev.cache_programs):
    try:
        call()
        check(False, f"{call.__name__} with the cache off raises")
    except csi.CsiError as e:
        check(e.status == "CSI_ERR_IO" and "off" in str(e), f"cache off: {e.status} {e}")
del os.environ["CSI_PROGRAM_CACHE"]
dev.close()

sys.exit(done())
