"""Shared helpers of the csi benchmarks (tools/bench/bench_accuracy.py, bench_pylops.py, bench_scaling.py).

Everything here drives the real binaries (csi-render, csi-reconstruct) as a user would and reads
what they write (EXR images, stats JSON, sample dumps); nothing re-implements the method.

Conventions used by every benchmark (documented in docs/BENCHMARKS-accuracy.md):
- MSE is the mean over pixels and the three channels of (image - reference)^2 in linear radiance.
- PSNR = 10 log10(peak^2 / MSE) with peak = 1 (linear radiance 1 is display white; the bundled
  scenes are lit so that most of the image is below 1), so PSNR values are comparable across
  methods and spp of one scene.
- Edge pixels: pixels of the reference whose luminance gradient magnitude (central differences,
  numpy.gradient, per pixel) is at least EDGE_REL times the 99th percentile of the reference's
  luminance (a scale-free threshold: 0.1 means a 10% step of the bright level across a pixel).
"""
import hashlib
import json
import os
import re
import shlex
import subprocess
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCENE_DIR = os.path.join(ROOT, "data", "scenes")
EDGE_REL = 0.1
PSNR_PEAK = 1.0
LUMA = np.array([0.2126, 0.7152, 0.0722], np.float32)  # Rec. 709 luminance weights


class BenchError(RuntimeError):
    pass


def default_env():
    """Environment for the binaries: warm PoCL / clFFT caches across runs (HELPERS-COMMON)."""
    env = dict(os.environ)
    env.setdefault("CSI_CACHE_DIR", os.path.join(os.path.expanduser("~"), ".cache", "csi"))
    return env


def binaries(build_dir=None):
    build_dir = build_dir or os.environ.get("CSI_BUILD") or os.path.join(ROOT, "build")
    out = {}
    for name in ("csi-render", "csi-reconstruct", "csi-mkdump"):
        p = os.path.join(build_dir, name)
        if not os.access(p, os.X_OK):
            raise BenchError(f"{p} not found: build first (cmake -S . -B build && cmake --build build -j2)")
        out[name] = p
    return out


def run(cmd, env=None, timeout=None, log=None):
    """Runs cmd (a list) and returns its wall time in seconds. Raises BenchError with the end of
    the command's stderr on a non-zero exit; `log` gets the command line and its stderr."""
    t0 = time.perf_counter()
    if log:
        log.write("$ " + " ".join(shlex.quote(c) for c in cmd) + "\n")
        log.flush()
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env or default_env())
    try:
        out, err = p.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        p.kill()
        p.communicate()
        raise BenchError(f"timed out after {timeout} s: {' '.join(cmd)}")
    # (peak memory of a child needs os.wait4 before it is reaped: see bench_scaling.py)
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        raise BenchError(f"exit {p.returncode}: {' '.join(cmd)}\n{err.decode(errors='replace')[-2000:]}")
    if log and err:
        log.write(err.decode(errors="replace"))
    return wall


def sha256_file(path, h=None):
    h = h or hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h


def tracer_fingerprint(bins, env=None):
    """What the reference depends on: the tracer and the position generator (not the solvers, so
    tuning a solver does not invalidate cached references). From the sources when this is a source
    tree, else the csi-render binary itself; plus csi-render --version."""
    h = hashlib.sha256()
    ver = subprocess.run([bins["csi-render"], "--version"], capture_output=True, env=env or default_env())
    h.update(ver.stdout)
    srcs = []
    for d in ("tracer", os.path.join("host", "io")):
        full = os.path.join(ROOT, d)
        if os.path.isdir(full):
            srcs += [os.path.join(full, f) for f in sorted(os.listdir(full)) if f.endswith((".c", ".h"))]
    for f in ("host/cli/csi_render.c", "host/include/csi/positions.h", "host/include/csi/samples.h"):
        if os.path.exists(os.path.join(ROOT, f)):
            srcs.append(os.path.join(ROOT, f))
    pos_src = [os.path.join(dp, f) for dp, _, fs in os.walk(os.path.join(ROOT, "host")) for f in fs
               if f.startswith("positions") and f.endswith(".c")]
    srcs += sorted(pos_src)
    if srcs:
        for s in srcs:
            sha256_file(s, h)
    else:
        sha256_file(bins["csi-render"], h)
    return h.hexdigest()[:16]


_QUOTED = re.compile(r'"([^"]+)"')
_SIZE = re.compile(r"\bsize\s+\d+\s+\d+")


def scene_variant(scene, size, workdir):
    """Writes a copy of data/scenes/<scene>.scene with the camera's `size W H` replaced (size =
    (W, H) or None for the scene's own) and every quoted relative path made absolute, so the copy
    works from any directory. Returns (path, content hash including referenced files)."""
    src = os.path.join(SCENE_DIR, scene + ".scene") if not scene.endswith(".scene") else scene
    with open(src) as f:
        text = f.read()
    base = os.path.dirname(os.path.abspath(src))
    h = hashlib.sha256()

    def absolutise(m):
        p = m.group(1)
        full = p if os.path.isabs(p) else os.path.normpath(os.path.join(base, p))
        if os.path.exists(full):
            sha256_file(full, h)
        return '"' + full + '"'

    text = _QUOTED.sub(absolutise, text)
    if size:
        if not _SIZE.search(text):
            text = re.sub(r"camera\s*\{", f"camera {{ size {size[0]} {size[1]} ", text, count=1)
        else:
            text = _SIZE.sub(f"size {size[0]} {size[1]}", text, count=1)
    h.update(text.encode())
    name = os.path.splitext(os.path.basename(src))[0]
    tag = f"{size[0]}x{size[1]}" if size else "native"
    os.makedirs(workdir, exist_ok=True)
    out = os.path.join(workdir, f"{name}_{tag}.scene")
    with open(out, "w") as f:
        f.write(text)
    return out, h.hexdigest()[:16]


def plan(bins, scene_path, env=None):
    p = subprocess.run([bins["csi-render"], "--plan", scene_path], capture_output=True, env=env or default_env())
    if p.returncode != 0:
        raise BenchError(p.stderr.decode(errors="replace"))
    return json.loads(p.stdout)


def read_exr(path):
    """Float32 (H, W, c) linear image of an EXR written by csi: RGB, or its single channel (Y)."""
    import OpenEXR
    with OpenEXR.File(path) as f:
        ch = f.channels()
        if "RGB" in ch:
            return np.asarray(ch["RGB"].pixels, np.float32)
        if all(c in ch for c in "RGB"):
            return np.stack([np.asarray(ch[c].pixels, np.float32) for c in "RGB"], axis=-1)
        if len(ch) == 1:
            return np.asarray(next(iter(ch.values())).pixels, np.float32)[..., None]
        raise BenchError(f"{path}: unexpected channels {sorted(ch)}")


def read_dump(path):
    """Reads a .csid (docs/dump-format.md): returns (header dict, xyt uint32 (n,3), values float32 (n,c))."""
    with open(path, "rb") as f:
        hdr = np.frombuffer(f.read(64), "<u4")
        if hdr[0] != int.from_bytes(b"CSID", "little") or hdr[1] != 1:
            raise BenchError(f"{path}: not a version-1 csi dump")
        gw, gh, gt, ow, oh, c = (int(v) for v in hdr[2:8])
        n = int(hdr[8]) | (int(hdr[9]) << 32)
        rec = np.frombuffer(f.read(), dtype=[("p", "<u4", 3), ("v", "<f4", c)], count=n)
    return dict(grid_w=gw, grid_h=gh, grid_t=gt, out_w=ow, out_h=oh, channels=c, count=n), rec["p"], rec["v"]


def write_dump1(path, hdr, pos, vals):
    """Writes a one-channel dump (docs/dump-format.md) with the grid of `hdr` and positions `pos`."""
    n = len(vals)
    h = np.zeros(16, "<u4")
    h[:8] = [int.from_bytes(b"CSID", "little"), 1, hdr["grid_w"], hdr["grid_h"], hdr["grid_t"], hdr["out_w"], hdr["out_h"], 1]
    h[8:10] = [n & 0xFFFFFFFF, n >> 32]
    rec = np.zeros(n, dtype=[("p", "<u4", 3), ("v", "<f4", 1)])
    rec["p"], rec["v"][:, 0] = pos, vals
    with open(path + ".tmp", "wb") as f:
        f.write(h.tobytes())
        f.write(rec.tobytes())
    os.replace(path + ".tmp", path)


def dump_frames(path, fill=None):
    """Per-pixel Monte Carlo frames from a dump: frame t of pixel p is the mean of p's samples with
    time index t. (T, H, W, c). Pixels with no sample in frame t take `fill` (H, W, c) at that
    pixel (the caller passes the per-pixel mean over all t, i.e. the blurred MC estimate), or NaN."""
    hdr, p, v = read_dump(path)
    T, W, H = hdr["grid_t"], hdr["out_w"], hdr["out_h"]
    bw, bh = hdr["grid_w"] // W, hdr["grid_h"] // H
    px = p[:, 0] // bw
    py = p[:, 1] // bh
    idx = (p[:, 2].astype(np.int64) * H + py) * W + px
    c = hdr["channels"]
    acc = np.zeros((T * H * W, c), np.float64)
    cnt = np.bincount(idx, minlength=T * H * W).astype(np.float64)
    for ch in range(c):
        acc[:, ch] = np.bincount(idx, weights=v[:, ch], minlength=T * H * W)
    with np.errstate(invalid="ignore", divide="ignore"):
        fr = (acc / cnt[:, None]).reshape(T, H, W, c)
    empty = cnt.reshape(T, H, W) == 0
    if fill is not None:
        fr = np.where(empty[..., None], np.broadcast_to(fill[None], fr.shape), fr)
    return fr.astype(np.float32), float(empty.mean())


def dump_grid_mean(paths):
    """Mean of several full-grid dumps (every cell sampled once per dump) as a (T, Hg, Wg, c) volume."""
    vol = None
    for path in paths:
        hdr, p, v = read_dump(path)
        T, Hg, Wg, c = hdr["grid_t"], hdr["grid_h"], hdr["grid_w"], hdr["channels"]
        if hdr["count"] != T * Hg * Wg:
            raise BenchError(f"{path}: {hdr['count']} records, expected the full grid {T * Hg * Wg}")
        idx = (p[:, 2].astype(np.int64) * Hg + p[:, 1]) * Wg + p[:, 0]
        cur = np.zeros((T * Hg * Wg, c), np.float64)
        cur[idx] = v
        vol = cur if vol is None else vol + cur
    return (vol / len(paths)).reshape(T, Hg, Wg, c).astype(np.float32)


def luminance(img):
    return img[..., :3] @ LUMA


def edge_mask(ref):
    """Edge pixels of a reference image (see the module docstring)."""
    y = luminance(ref).astype(np.float64)
    gy, gx = np.gradient(y)
    g = np.hypot(gx, gy)
    scale = max(np.percentile(y, 99), 1e-6)
    return g >= EDGE_REL * scale


def mse(img, ref, mask=None):
    d = (img.astype(np.float64) - ref.astype(np.float64)) ** 2
    if mask is not None:
        if not mask.any():
            return float("nan")
        d = d[mask]
    return float(d.mean())


def psnr(m):
    return float(10 * np.log10(PSNR_PEAK ** 2 / m)) if m > 0 else float("inf")


def to_srgb8(img):
    x = np.clip(img, 0, 1)
    x = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    return (x * 255 + 0.5).astype(np.uint8)


def stats_iterations(st):
    """(max over channels of the solver iterations, max relative residual, all converged) from a
    stats JSON (csi-render keeps them under 'reconstruction')."""
    rec = st.get("reconstruction", st)
    chans = rec.get("channels", {})
    return int(max([c.get("iterations", 0) for c in chans.values()] or [0])), \
        float(max([c.get("rel_residual", 0) for c in chans.values()] or [0])), \
        all(c.get("converged", True) for c in chans.values())


def stats_inner(st):
    """Max over channels of the solver's inner (least-squares / debiasing CG) iterations."""
    rec = st.get("reconstruction", st)
    return int(max([c.get("inner_iterations", 0) for c in rec.get("channels", {}).values()] or [0]))


def recon_time(st):
    """Reconstruction time: setup + solve + integrate (as csi-render's t_reconstruct_s; excludes
    reading the dump and creating the OpenCL context)."""
    if "t_reconstruct_s" in st:
        return float(st["t_reconstruct_s"])
    return float(st.get("t_setup_s", 0) + st.get("t_solve_s", 0) + st.get("t_integrate_s", 0))


def log(msg):
    print(time.strftime("%H:%M:%S"), msg, file=sys.stderr, flush=True)
