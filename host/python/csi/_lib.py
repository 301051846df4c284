"""The C library (libcsi.so, csi/csi.h) from Python: numpy arrays in and out, options by name,
errors as exceptions carrying the library's message.

The shared library is found, in order, at:
  1. $CSI_LIBRARY (a path to libcsi.so);
  2. $CSI_BUILD_DIR/sdk/libcsi.so (a build directory);
  3. the build/ directory of the source tree this package sits in (host/python/csi ->
     ../../../build/sdk/libcsi.so), which is what tools/setup and the tests use;
  4. an installed SDK: the libdir pkg-config gives for csi (set PKG_CONFIG_PATH to
     PREFIX/lib/pkgconfig after `cmake --install build --prefix PREFIX`), then the system's
     loader path (the soname of this package's ABI, libcsi.so.0.MINOR while the major is 0).
A library of another ABI (csi_version's major, and minor while the major is 0, differ from this
package's) is refused: the structures passed to it would be read wrongly.
It is loaded on first use, so `import csi` needs only numpy.
"""

from __future__ import annotations

import contextlib
import ctypes
import json
import os
import signal
import subprocess
import threading
from typing import Callable, Optional

import numpy as np

u32 = ctypes.c_uint32
c_size = ctypes.c_size_t


class Grid(ctypes.Structure):
    _fields_ = [("w", u32), ("h", u32), ("t", u32), ("out_w", u32), ("out_h", u32)]


#: csi_samples.flags / csi_dump.flags: every value is a noise-free point value (CSI_SAMPLES_EXACT).
SAMPLES_EXACT = 1


class _Samples(ctypes.Structure):
    _fields_ = [("grid", Grid), ("channels", u32), ("count", c_size),
                ("pos", ctypes.POINTER(u32)), ("values", ctypes.POINTER(ctypes.c_float)), ("flags", u32),
                ("variance", ctypes.POINTER(ctypes.c_float))]


class _Dump(ctypes.Structure):
    _fields_ = [("grid", Grid), ("channels", u32), ("seed", ctypes.c_uint64), ("count", c_size),
                ("pos", ctypes.POINTER(u32)), ("values", ctypes.POINTER(ctypes.c_float)), ("flags", u32)]


class _PosOpts(ctypes.Structure):
    _fields_ = [("method", ctypes.c_int), ("spp", u32), ("fraction", ctypes.c_double), ("seed", ctypes.c_uint64)]


class _Image(ctypes.Structure):
    _fields_ = [("w", u32), ("h", u32), ("channels", u32), ("data", ctypes.POINTER(ctypes.c_float))]


class _Progress(ctypes.Structure):
    _fields_ = [("phase", ctypes.c_char_p), ("iteration", ctypes.c_int), ("residual", ctypes.c_double)]


class _OptionInfo(ctypes.Structure):
    _fields_ = [("name", ctypes.c_char_p), ("kind", ctypes.c_int), ("metavar", ctypes.c_char_p),
                ("help", ctypes.c_char_p), ("default", ctypes.c_char_p), ("auto_rule", ctypes.c_char_p),
                ("program", ctypes.c_bool)]


class _Report(ctypes.Structure):
    _fields_ = [("converged", ctypes.c_bool), ("outcome", ctypes.c_int), ("reason", ctypes.c_char_p),
                ("message", ctypes.c_char_p), ("iterations", ctypes.c_int), ("inner_iterations", ctypes.c_int),
                ("rel_residual", ctypes.c_double), ("objective", ctypes.c_double), ("tau", ctypes.c_double),
                ("support", c_size), ("seconds", ctypes.c_double)]


class _Info(ctypes.Structure):  # csi_result_info, every field (the library writes all of them)
    _fields_ = [("method", ctypes.c_char_p), ("solver", ctypes.c_char_p), ("k", c_size), ("n", c_size),
                ("t_setup", ctypes.c_double), ("t_solve", ctypes.c_double), ("t_integrate", ctypes.c_double),
                ("tiles", u32), ("tile", ctypes.c_bool), ("tile_index", u32), ("tile_origin", u32 * 3)]


class _PartialInfo(ctypes.Structure):  # csi_partial_info
    _fields_ = [("software", ctypes.c_char * 32), ("method", ctypes.c_char * 96), ("input", ctypes.c_char * 128),
                ("input_id", ctypes.c_uint64), ("tile_index", u32), ("tile_count", u32), ("grid", Grid),
                ("channels", u32), ("frames", u32), ("samples", ctypes.c_uint64)]


_PROGRESS_FN = ctypes.CFUNCTYPE(ctypes.c_bool, ctypes.c_void_p, ctypes.POINTER(_Progress))
_OPTION_KINDS = ("choice", "number", "integer", "flag")


class CsiError(RuntimeError):
    """A failure of the C library: `status` is its name ("CSI_ERR_ARG"), the message the
    library's one line."""

    def __init__(self, status: str, message: str):
        super().__init__(message)
        self.status = status


def _candidates():
    out = []
    if os.environ.get("CSI_LIBRARY"):
        out.append(os.environ["CSI_LIBRARY"])
    if os.environ.get("CSI_BUILD_DIR"):
        out.append(os.path.join(os.environ["CSI_BUILD_DIR"], "sdk", "libcsi.so"))
    here = os.path.dirname(os.path.abspath(__file__))
    out.append(os.path.normpath(os.path.join(here, "..", "..", "..", "build", "sdk", "libcsi.so")))
    try:
        libdir = subprocess.run(["pkg-config", "--variable=libdir", "csi"], capture_output=True, text=True,
                                check=True).stdout.strip()
        if libdir:
            out.append(os.path.join(libdir, "libcsi.so"))
    except (OSError, subprocess.CalledProcessError):
        pass
    return out


_lib = None


def _abi(version: str) -> str:
    """The part of a version that names the ABI (csi/csi.h): "0.2" for 0.2.x, "1" for 1.x.y."""
    major, minor = version.split(".")[:2]
    return f"{major}.{minor}" if major == "0" else major


def _load(path):
    from . import __version__

    # Kernels built at run time (clFFT's generated ones, a cold program cache) would print the
    # OpenCL compiler's warnings on stderr: PoCL builds them with -w, as csi's programs ask
    # (host/cli/common.h), unless the caller set its own flags.
    os.environ.setdefault("POCL_EXTRA_BUILD_FLAGS", "-w")
    L = _bind(ctypes.CDLL(path))
    have = L.csi_version().decode()
    if _abi(have) != _abi(__version__):
        raise CsiError("CSI_ERR_ARG", f"{path}: libcsi {have} has another ABI than this package's "
                       f"{__version__}: load a libcsi {_abi(__version__)}.x (CSI_LIBRARY)")
    return L


def lib():
    """The loaded libcsi (loaded on the first call); CsiError naming where it looked if none."""
    global _lib
    if _lib is not None:
        return _lib
    given = os.environ.get("CSI_LIBRARY")
    if given and not os.path.isfile(given):  # asked for: that one, not some other build's
        raise CsiError("CSI_ERR_IO", f"CSI_LIBRARY={given}: no such file (unset it to let csi find libcsi.so)")
    tried = []
    for path in _candidates():
        tried.append(path)
        if os.path.isfile(path):
            _lib = _load(path)
            return _lib
    from . import __version__

    name = "libcsi.so." + _abi(__version__)
    tried.append(name)
    try:
        _lib = _load(name)
        return _lib
    except OSError:
        raise CsiError("CSI_ERR_IO", "libcsi.so not found (looked at " + ", ".join(tried) + "): build csi "
                       "(cmake --build build) or install its SDK and set CSI_LIBRARY or PKG_CONFIG_PATH") from None


def _bind(L):
    P = ctypes.c_void_p
    sig = {
        "csi_version": (ctypes.c_char_p, []),
        "csi_status_name": (ctypes.c_char_p, [ctypes.c_int]),
        "csi_last_error": (ctypes.c_char_p, []),
        "csi_free": (None, [P]),
        "csi_device_new": (ctypes.c_int, [ctypes.c_char_p, ctypes.POINTER(P)]),
        "csi_device_release": (None, [P]),
        "csi_device_name": (ctypes.c_char_p, [P]),
        "csi_device_cache_programs": (ctypes.c_int, [P, ctypes.POINTER(ctypes.c_int)]),
        "csi_cached_programs_dir": (ctypes.c_int, [ctypes.c_char_p, c_size]),
        "csi_default_grid_factor": (u32, [u32, u32, u32, ctypes.c_uint64]),
        "csi_camera_grid_factor": (u32, [u32, u32, u32, ctypes.c_uint64, ctypes.c_int]),
        "csi_pos_method_parse": (ctypes.c_int, [ctypes.c_char_p, ctypes.POINTER(ctypes.c_int)]),
        "csi_refine_positions": (ctypes.c_int, [ctypes.POINTER(_Samples), ctypes.POINTER(_Image), ctypes.c_double,
                                                ctypes.POINTER(ctypes.POINTER(u32)), ctypes.POINTER(c_size),
                                                ctypes.POINTER(c_size)]),
        "csi_refine_share_default": (ctypes.c_double, []),
        "csi_refine_apply": (ctypes.c_int, [ctypes.POINTER(_Samples), ctypes.POINTER(_Samples), ctypes.POINTER(_Image),
                                            ctypes.POINTER(c_size)]),
        "csi_refine_settle": (ctypes.c_int, [ctypes.POINTER(_Samples), ctypes.POINTER(_Samples),
                                             ctypes.POINTER(_Image), ctypes.POINTER(c_size)]),
        "csi_refine_step_coverage": (ctypes.c_int, [ctypes.POINTER(_Samples), ctypes.POINTER(_Samples),
                                                    ctypes.POINTER(_Image), ctypes.POINTER(c_size)]),
        "csi_positions": (ctypes.c_int, [ctypes.POINTER(Grid), ctypes.POINTER(_PosOpts),
                                         ctypes.POINTER(ctypes.POINTER(u32)), ctypes.POINTER(c_size), P]),
        "csi_dump_read": (ctypes.c_int, [ctypes.c_char_p, P, ctypes.POINTER(_Dump), P]),
        "csi_dump_free": (None, [ctypes.POINTER(_Dump)]),
        "csi_options_new": (ctypes.c_int, [ctypes.POINTER(P)]),
        "csi_options_free": (None, [P]),
        "csi_options_set": (ctypes.c_int, [P, ctypes.c_char_p, ctypes.c_char_p]),
        "csi_options_get": (ctypes.c_int, [P, ctypes.c_char_p, ctypes.c_char_p, c_size]),
        "csi_option_count": (c_size, []),
        "csi_option_describe": (ctypes.c_int, [c_size, ctypes.POINTER(_OptionInfo)]),
        "csi_reconstruct": (ctypes.c_int, [P, ctypes.POINTER(_Samples), P, _PROGRESS_FN, P, ctypes.POINTER(P)]),
        "csi_result_free": (None, [P]),
        "csi_result_image": (ctypes.c_int, [P, ctypes.POINTER(_Image)]),
        "csi_result_frame_count": (u32, [P]),
        "csi_result_frame": (ctypes.c_int, [P, u32, ctypes.POINTER(_Image)]),
        "csi_result_options": (P, [P]),
        "csi_result_info_get": (None, [P, ctypes.POINTER(_Info)]),
        "csi_result_report": (ctypes.c_int, [P, u32, ctypes.POINTER(_Report)]),
        "csi_json_new": (ctypes.c_int, [ctypes.POINTER(P)]),
        "csi_json_free": (None, [P]),
        "csi_json_text": (ctypes.c_int, [P, ctypes.POINTER(ctypes.c_char_p)]),
        "csi_result_stats": (None, [P, P]),
        "csi_result_stats_phases": (None, [P, P, ctypes.c_double, ctypes.c_double, ctypes.c_double]),
        "csi_result_attributes": (c_size, [P, ctypes.POINTER(P)]),
        "csi_exr_write": (ctypes.c_int, [ctypes.c_char_p, ctypes.POINTER(_Image), P, c_size]),
        "csi_png_write": (ctypes.c_int, [ctypes.c_char_p, ctypes.POINTER(_Image)]),
        "csi_reconstruct_tile": (ctypes.c_int, [P, ctypes.POINTER(_Samples), P, u32, ctypes.POINTER(ctypes.c_double),
                                                _PROGRESS_FN, P, ctypes.POINTER(P)]),
        "csi_samples_id": (ctypes.c_uint64, [ctypes.POINTER(_Samples)]),
        "csi_partial_write": (ctypes.c_int, [ctypes.c_char_p, P, ctypes.c_char_p, ctypes.c_uint64, ctypes.c_char_p]),
        "csi_partials_merge": (ctypes.c_int, [ctypes.POINTER(ctypes.c_char_p), c_size, ctypes.c_bool, _PROGRESS_FN,
                                              P, ctypes.POINTER(P), ctypes.POINTER(_PartialInfo)]),
        "csi_reconstruct_check": (ctypes.c_int, [P, ctypes.POINTER(Grid), u32, c_size, P, ctypes.c_uint64,
                                                 ctypes.c_char_p]),
        "csi_outset_create": (ctypes.c_int, [ctypes.POINTER(P)]),
        "csi_outset_free": (None, [P]),
        "csi_outset_input": (ctypes.c_int, [P, ctypes.c_char_p]),
        "csi_outset_file": (ctypes.c_int, [P, ctypes.c_char_p, ctypes.c_char_p]),
        "csi_outset_dir": (ctypes.c_int, [P, ctypes.c_char_p, ctypes.c_char_p]),
        "csi_outset_dir_file": (ctypes.c_int, [P, ctypes.c_char_p, ctypes.c_char_p, ctypes.c_char_p]),
        "csi_outset_tmp": (ctypes.c_int, [P, ctypes.c_char_p, ctypes.POINTER(ctypes.c_char_p)]),
        "csi_outset_commit": (ctypes.c_int, [P]),
        "csi_outset_abort": (None, [P]),
    }
    for name, (res, args) in sig.items():
        f = getattr(L, name)
        f.restype, f.argtypes = res, args
    return L


def _check(st: int):
    if st != 0:
        L = lib()
        raise CsiError(L.csi_status_name(st).decode(), L.csi_last_error().decode(errors="replace"))


def cached_programs_dir() -> str:
    """The folder of csi's program cache (Device.cache_programs); CsiError CSI_ERR_IO when the
    cache is off (CSI_PROGRAM_CACHE=0)."""
    buf = ctypes.create_string_buffer(4096)
    _check(lib().csi_cached_programs_dir(buf, len(buf)))
    return os.fsdecode(buf.value)


def version() -> str:
    """The version of the C library that is loaded."""
    return lib().csi_version().decode()


def options() -> list:
    """Every reconstruction option: name, kind, default, what auto resolves to, help."""
    L = lib()
    out = []
    for i in range(L.csi_option_count()):
        info = _OptionInfo()
        _check(L.csi_option_describe(i, ctypes.byref(info)))
        dec = lambda b: b.decode() if b else None  # noqa: E731
        out.append({"name": dec(info.name), "keyword": dec(info.name).replace("-", "_"),
                    "kind": _OPTION_KINDS[info.kind], "default": dec(info.default),
                    "auto": dec(info.auto_rule), "help": dec(info.help)})
    return out


def _text(value) -> str:
    if isinstance(value, (bool, np.bool_)):
        return "on" if value else "off"
    if isinstance(value, (float, np.floating)):
        return repr(float(value))  # the shortest text that reads back as the same double
    return str(value)


class Options:
    """Reconstruction options by name (csi/csi.h): Options(tau=1e-3, solver="romp", lambda_=0.2).
    Keywords are the programs' --names with '_' for '-' (a trailing '_' is dropped: lambda_)."""

    def __init__(self, **kwargs):
        L = lib()
        h = ctypes.c_void_p()
        _check(L.csi_options_new(ctypes.byref(h)))
        self._h = h
        for k, v in kwargs.items():
            self.set(k, v)

    def set(self, name: str, value):
        name = name.rstrip("_").replace("_", "-")
        _check(lib().csi_options_set(self._h, name.encode(), _text(value).encode()))

    def __del__(self):
        if getattr(self, "_h", None) and _lib is not None:
            _lib.csi_options_free(self._h)
            self._h = None


class Device:
    """An OpenCL device by name (None: $CSI_DEVICE, else PoCL's CPU device)."""

    def __init__(self, name: Optional[str] = None):
        L = lib()
        h = ctypes.c_void_p()
        _check(L.csi_device_new(name.encode() if name else None, ctypes.byref(h)))
        self._h = h
        self.name = L.csi_device_name(h).decode()

    def cache_programs(self) -> int:
        """Builds csi's OpenCL programs on this device and keeps their binaries for later
        processes, which then load them instead of building them (csi-reconstruct
        --cache-programs; slow the first time, quick when cached). Returns how many programs it
        stored now; CsiError CSI_ERR_IO when the cache is off or cannot be written."""
        n = ctypes.c_int(0)
        _check(lib().csi_device_cache_programs(self._h, ctypes.byref(n)))
        return n.value

    def close(self):
        if getattr(self, "_h", None) and _lib is not None:
            _lib.csi_device_release(self._h)
            self._h = None

    __del__ = close


_default_device = None


class Result:
    """A reconstruction: image (H, W, C) float32, frames (T, H, W, C) or None, the options as
    used (every auto that applied resolved), per-channel reports and the statistics (as
    csi-reconstruct --stats writes them, where the time went included: "phases", whose read_s,
    device_s and write_s are 0, the caller's own).
    write_exr / write_png write the image as csi-reconstruct does (the same bytes)."""

    def __init__(self, image, frames, options, reports, info, stats, handle=None):
        self.image, self.frames, self.options = image, frames, options
        self.reports, self.info, self.stats = reports, info, stats
        self._h = handle  # the library's result, for its writers; freed with this object

    def _write(self, path, exr: bool, frame=None):
        if not getattr(self, "_h", None):
            raise CsiError("CSI_ERR_ARG", "this result was closed")
        L = lib()
        img = _Image()
        _check(L.csi_result_image(self._h, ctypes.byref(img)) if frame is None
               else L.csi_result_frame(self._h, _whole("frame", frame, 0, _U32), ctypes.byref(img)))
        if exr:
            attrs = ctypes.c_void_p()
            n = L.csi_result_attributes(self._h, ctypes.byref(attrs))
            _check(L.csi_exr_write(os.fsencode(path), ctypes.byref(img), attrs, n))
        else:
            _check(L.csi_png_write(os.fsencode(path), ctypes.byref(img)))

    def set_image(self, image):
        """Replaces the image (H, W, C, the result's shape) in this result and in the library's
        buffer its writers read, for a caller that amends the reconstruction before writing it
        (csi-mitsuba --refine sets the pixels it sampled whole to their samples' mean)."""
        if not getattr(self, "_h", None):
            raise CsiError("CSI_ERR_ARG", "this result was closed")
        img = np.asarray(image, dtype=np.float32)
        if img.shape != self.image.shape:
            raise CsiError("CSI_ERR_ARG", f"set_image: shape {img.shape}, the result's is {self.image.shape}")
        view = _Image()
        _check(lib().csi_result_image(self._h, ctypes.byref(view)))
        planar = np.ascontiguousarray(np.moveaxis(img, 2, 0))
        ctypes.memmove(view.data, planar.ctypes.data, planar.nbytes)
        self.image = img.copy()

    def write_exr(self, path, frame: Optional[int] = None):
        """A float32 EXR with the run's figures and every option as used in its header (frame t
        of the frames when frame is given); written to a temporary file and renamed."""
        self._write(path, True, frame)

    def write_png(self, path, frame: Optional[int] = None):
        """An 8-bit sRGB preview (values clamped to [0, 1])."""
        self._write(path, False, frame)

    def write_partial(self, path, input: str = ""):
        """A tile's result (reconstruct_tile) as a partial (docs/partial-format.md), for
        merge_partials or csi-merge; `input` names the samples in messages."""
        if not getattr(self, "_h", None) or getattr(self, "_input_id", None) is None:
            raise CsiError("CSI_ERR_ARG", "write_partial: not the open result of reconstruct_tile")
        _check(lib().csi_partial_write(os.fsencode(path), self._h, os.fsencode(input), self._input_id, None))

    def close(self):
        if getattr(self, "_h", None) and _lib is not None:
            _lib.csi_result_free(self._h)
        self._h = None

    __del__ = close


def _hwc(img: _Image) -> np.ndarray:
    planar = np.ctypeslib.as_array(img.data, shape=(img.channels, img.h, img.w))
    # a copy always: for one channel the transpose is already contiguous, and ascontiguousarray
    # would return a view of the library's buffer, freed with the result
    return planar.transpose(1, 2, 0).copy()


def _result(L, r) -> Result:
    img = _Image()
    _check(L.csi_result_image(r, ctypes.byref(img)))
    image = _hwc(img)
    frames = None
    nf = L.csi_result_frame_count(r)
    if nf:
        frames = np.empty((nf,) + image.shape, dtype=np.float32)
        for t in range(nf):
            _check(L.csi_result_frame(r, t, ctypes.byref(img)))
            frames[t] = _hwc(img)
    used = {}
    buf = ctypes.create_string_buffer(64)
    ro = L.csi_result_options(r)
    for o in options():
        _check(L.csi_options_get(ro, o["name"].encode(), buf, 64))
        used[o["keyword"]] = buf.value.decode()
    reports = []
    for c in range(image.shape[2]):
        rep = _Report()
        _check(L.csi_result_report(r, c, ctypes.byref(rep)))
        reports.append({"converged": rep.converged, "reason": rep.reason.decode(), "message": rep.message.decode(),
                        "iterations": rep.iterations, "rel_residual": rep.rel_residual, "tau": rep.tau,
                        "support": rep.support, "seconds": rep.seconds})
    inf = _Info()
    L.csi_result_info_get(r, ctypes.byref(inf))
    info = {"method": inf.method.decode(), "solver": inf.solver.decode(), "k": inf.k, "n": inf.n,
            "t_setup": inf.t_setup, "t_solve": inf.t_solve, "t_integrate": inf.t_integrate, "tiles": inf.tiles}
    if inf.tile:
        info.update(tile=inf.tile_index, tile_origin=tuple(inf.tile_origin))
    j = ctypes.c_void_p()
    _check(L.csi_json_new(ctypes.byref(j)))
    try:
        L.csi_result_stats(r, j)
        L.csi_result_stats_phases(r, j, 0.0, 0.0, 0.0)  # no input read, device made or output written here
        text = ctypes.c_char_p()
        _check(L.csi_json_text(j, ctypes.byref(text)))
        stats = json.loads(text.value.decode())
    finally:
        L.csi_json_free(j)
    return Result(image, frames, used, reports, info, stats, r)


def _whole(name: str, value, lo: int, hi: int) -> int:
    """value as an int from lo to hi, else CsiError naming it: ctypes would pass a negative or
    too large number on silently, wrapped around (a seed of -1 as 2^64 - 1, 2^32 + 64 as 64)."""
    if isinstance(value, (bool, np.bool_)):
        v = None
    elif isinstance(value, (int, np.integer)):
        v = int(value)
    elif isinstance(value, (float, np.floating)) and np.isfinite(value) and float(value).is_integer():
        v = int(value)
    else:
        v = None
    if v is None or not lo <= v <= hi:
        raise CsiError("CSI_ERR_ARG", f"{name}: {value!r} is not a whole number from {lo} to {hi}")
    return v


_U32, _U64 = (1 << 32) - 1, (1 << 64) - 1


def _grid(grid) -> Grid:
    """(w, h, t, out_w, out_h) as the library's grid, each a whole number that fits its field."""
    try:
        sides = None if isinstance(grid, (str, bytes)) else list(grid)
    except TypeError:
        sides = None
    if sides is None or len(sides) != 5:
        raise CsiError("CSI_ERR_ARG", f"grid {grid!r}: expected (w, h, t, out_w, out_h)")
    return Grid(*[_whole(f"grid {n}", v, 0, _U32) for n, v in zip(("w", "h", "t", "out_w", "out_h"), sides)])


def _float32(a, what):
    """a as float32, refusing finite numbers float32 cannot hold (they would become infinities and
    be refused later as if the caller had given one): names the first such entry."""
    with np.errstate(over="ignore"):
        out = a.astype(np.float32, copy=False)
    if a.dtype.kind == "f" and a.dtype.itemsize > 4:
        lost = np.isfinite(a) & ~np.isfinite(out)
        if lost.any():
            at = np.unravel_index(int(np.argmax(lost)), a.shape)
            raise CsiError("CSI_ERR_ARG", f"{what} {tuple(int(i) for i in at)}: {float(a[at]):g} is beyond "
                           "float32's range (about 3.4e38)")
    return out


def _samples_arrays(positions, values):
    """(N, 3) uint32 cells and (N, C) float32 values, contiguous, from what the caller gave:
    positions of an integer type, or floats that are whole numbers, inside the uint32 range (a
    negative, fractional or NaN cell would otherwise be cast to another cell); real values of
    shape (N, C) or (N,)."""
    pos = np.asarray(positions)
    if pos.dtype.kind == "f":
        if pos.size and not (np.isfinite(pos).all() and (pos == np.floor(pos)).all()):
            raise CsiError("CSI_ERR_ARG", "positions: not whole numbers (cells are integer x, y, t)")
    elif pos.dtype.kind not in "iu":
        raise CsiError("CSI_ERR_ARG", f"positions: {pos.dtype} values, not integer cells")
    if pos.size and (pos.min() < 0 or pos.max() > _U32):
        raise CsiError("CSI_ERR_ARG", f"positions: cells from {pos.min()} to {pos.max()}, outside 0 to {_U32}")
    pos = np.ascontiguousarray(pos, dtype=np.uint32)
    val = np.asarray(values)
    if val.dtype.kind not in "biuf":
        raise CsiError("CSI_ERR_ARG", f"values: {val.dtype} values, not real numbers")
    val = _float32(val, "values at")
    val = np.ascontiguousarray(val[:, None] if val.ndim == 1 else val)
    if pos.ndim != 2 or pos.shape[1] != 3 or val.ndim != 2 or val.shape[0] != pos.shape[0]:
        raise CsiError("CSI_ERR_ARG", f"positions {pos.shape} and values {val.shape}: expected (N, 3) and (N, C)")
    return pos, val


def _variance_array(variance, val):
    """None, or each value's variance as contiguous float32 of val's (N, C) shape."""
    if variance is None:
        return None
    var = np.asarray(variance)
    if var.dtype.kind not in "iuf" or var.size != val.size or var.shape[:1] != val.shape[:1]:
        raise CsiError("CSI_ERR_ARG", f"variance {var.shape} of {var.dtype}: expected real numbers in the "
                       f"values' shape {val.shape}")
    return np.ascontiguousarray(_float32(var, "variance at").reshape(val.shape))


def _options_and_device(options, kwargs, device):
    """The options of a call (an Options with the keywords set on it, or new ones of the
    keywords) and its device (a Device, a device's name, or None: the process's default device,
    made on first use)."""
    global _default_device
    if isinstance(device, str):
        device = Device(device)
    elif device is not None and not isinstance(device, Device):
        raise CsiError("CSI_ERR_ARG", f"device {device!r}: expected a csi.Device, a device's name or None")
    if options is None:
        options = Options(**kwargs)
    else:
        for k, v in kwargs.items():
            options.set(k, v)
    if device is None:
        if _default_device is None:
            _default_device = Device()
        device = _default_device
    return options, device


class _Call:
    """The arguments of a reconstruction call: samples from numpy arrays (kept alive with it),
    options, device, and the progress relay that passes on what the callback raised."""

    def __init__(self, positions, values, grid, device, progress, options, kwargs, exact, variance=None):
        pos, val = _samples_arrays(positions, values)
        grid = _grid(grid)
        var = _variance_array(variance, val)
        options, device = _options_and_device(options, kwargs, device)
        self.arrays, self.options, self.device, self.raised = (pos, val, var), options, device, []
        self.samples = _Samples(grid, val.shape[1], pos.shape[0],
                                pos.ctypes.data_as(ctypes.POINTER(u32)),
                                val.ctypes.data_as(ctypes.POINTER(ctypes.c_float)), SAMPLES_EXACT if exact else 0,
                                var.ctypes.data_as(ctypes.POINTER(ctypes.c_float)) if var is not None else None)

        def relay(_user, p):
            if self.raised:  # a Ctrl-C (see interruptible)
                return False
            try:
                if progress is None:
                    return True
                go = progress(p.contents.phase.decode(), p.contents.iteration, p.contents.residual)
                return go is None or bool(go)
            except BaseException as e:  # noqa: BLE001 - passed on after the library has cleaned up
                self.raised.append(e)
                return False

        self.fn = _PROGRESS_FN(relay)

    @contextlib.contextmanager
    def interruptible(self):
        """Around the library's call: a Ctrl-C cancels it at its next progress report and is
        raised when it has returned. Python runs its signal handlers only between its own
        bytecodes (here: when the relay is entered, where a KeyboardInterrupt could not be
        caught), so SIGINT is recorded by a handler of ours meanwhile, in the main thread where
        Python's default handler is in place."""
        if (threading.current_thread() is not threading.main_thread()
                or signal.getsignal(signal.SIGINT) is not signal.default_int_handler):
            yield
            return
        old = signal.signal(signal.SIGINT, lambda *_: self.raised.append(KeyboardInterrupt()))
        try:
            yield
        finally:
            signal.signal(signal.SIGINT, old)

    def result(self, L, st, r) -> Result:
        if self.raised:
            raise self.raised[0]
        _check(st)
        try:
            return _result(L, r)  # which then owns r
        except BaseException:
            L.csi_result_free(r)
            raise


def reconstruct(positions, values, grid, device: Optional[Device] = None,
                progress: Optional[Callable[[str, int, float], Optional[bool]]] = None,
                options: Optional[Options] = None, exact: bool = False, variance=None, **kwargs) -> Result:
    """Reconstructs samples: positions (N, 3) integers (x, y, t cells of the fine grid), values
    (N, C) or (N,) float32, grid (w, h, t, out_w, out_h). Options as keywords (or an Options).
    exact: every value is the noise-free signal at its cell's centre (a deterministic point
    evaluation, not a Monte Carlo estimate; CSI_SAMPLES_EXACT), which makes correct="auto" take
    the control-variate correction instead of the blend. variance: None, or each value's
    variance, the values' shape (csi_samples.variance: an isolated bright sample its own noise
    explains is then shrunk by how much of it that noise explains).
    progress(phase, iteration, residual) may return False to cancel (CsiError CSI_ERR_CANCELLED);
    an exception it raises cancels and is raised again."""
    L = lib()
    c = _Call(positions, values, grid, device, progress, options, kwargs, exact, variance)
    r = ctypes.c_void_p()
    with c.interruptible():
        st = L.csi_reconstruct(c.device._h, ctypes.byref(c.samples), c.options._h, c.fn, None, ctypes.byref(r))
    return c.result(L, st, r)


def reconstruct_check(grid, channels: int, count: int, device: Optional[Device] = None,
                      options: Optional[Options] = None, extra_host: int = 0, input: str = "", **kwargs):
    """Sizes before work (csi_reconstruct_check): returns when reconstructing `count` samples of
    `channels` on grid (w, h, t, out_w, out_h) with these options fits the device and the host's
    available memory (with extra_host more bytes the caller holds meanwhile); else raises
    CsiError CSI_ERR_TOO_LARGE (CSI_ERR_ARG: a grid no plan can hold), its message starting with
    `input`. Arithmetic on the sizes only, in milliseconds: for a caller that refuses a run before
    rendering its samples."""
    L = lib()
    options, device = _options_and_device(options, kwargs, device)
    g = _grid(grid)
    _check(L.csi_reconstruct_check(device._h, ctypes.byref(g), _whole("channels", channels, 0, _U32),
                                   _whole("count", count, 0, _U64), options._h, _whole("extra_host", extra_host, 0, _U64),
                                   os.fsencode(input)))


def reconstruct_tile(positions, values, grid, index: int, scale=None, device: Optional[Device] = None,
                     progress: Optional[Callable[[str, int, float], Optional[bool]]] = None,
                     options: Optional[Options] = None, exact: bool = False, variance=None,
                     **kwargs) -> Result:
    """Tile `index` of the layout the options give (tiles=N asks for N; docs/tiles.md) from all
    the samples, as reconstruct takes them (exact and variance too): a Result holding the tile's
    window (info["tile"], info["tile_origin"]), which write_partial writes for merge_partials or
    csi-merge on another machine. scale: the whole problem's tau scale per channel (None:
    computed here)."""
    L = lib()
    c = _Call(positions, values, grid, device, progress, options, kwargs, exact, variance)
    sc = (ctypes.c_double * 4)(*[float(x) for x in list(scale)[:4]]) if scale is not None else None
    r = ctypes.c_void_p()
    with c.interruptible():
        st = L.csi_reconstruct_tile(c.device._h, ctypes.byref(c.samples), c.options._h, _whole("index", index, 0, _U32), sc, c.fn, None,
                                    ctypes.byref(r))
    res = c.result(L, st, r)
    res._input_id = L.csi_samples_id(ctypes.byref(c.samples))
    return res


def merge_partials(paths, frames: bool = False) -> Result:
    """The image of one run's partials (written by write_partial, or csi-reconstruct / csi-render
    --tile I/N), given in any order: the bits csi-merge gives. A missing, repeated, foreign,
    damaged or other-version partial raises CsiError naming the file. frames: keep the frames
    (the partials must hold them). The run's description is the result's .partial_info."""
    L = lib()
    names = [os.fsencode(p) for p in paths]
    arr = (ctypes.c_char_p * max(len(names), 1))(*names)
    r, inf = ctypes.c_void_p(), _PartialInfo()
    _check(L.csi_partials_merge(arr, len(names), bool(frames), _PROGRESS_FN(), None, ctypes.byref(r),
                                ctypes.byref(inf)))
    try:
        res = _result(L, r)
    except BaseException:
        L.csi_result_free(r)
        raise
    res.partial_info = {"software": inf.software.decode(), "method": inf.method.decode(),
                        "input": inf.input.decode(), "input_id": f"{inf.input_id:016x}",
                        "tiles": inf.tile_count, "samples": inf.samples}
    return res


_CAMERAS = ("still", "pans", "moves")


def default_grid_factor(out_w: int, out_h: int, t: int = 1, spp: int = 4, camera: str = "still") -> int:
    """csi's fine-grid factor F for spp samples per output pixel (csi_camera_grid_factor, the
    rule of csi-render and csi-positions): the grid is F out_w x F out_h cells, t frames. camera:
    how a volume's camera moves, "still" (or not known), "pans" (translates across its view
    alone) or "moves"."""
    if camera not in _CAMERAS:
        raise CsiError("CSI_ERR_ARG", f"camera: {camera!r} is not one of {', '.join(_CAMERAS)}")
    return int(lib().csi_camera_grid_factor(_whole("out_w", out_w, 1, _U32), _whole("out_h", out_h, 1, _U32),
                                            _whole("t", t, 1, _U32), _whole("spp", spp, 1, _U64),
                                            _CAMERAS.index(camera)))


def positions(grid, spp: int = 4, method: str = "poisson", seed: int = 1, fraction: Optional[float] = None):
    """The sample positions csi takes on grid (w, h, t, out_w, out_h): (N, 3) uint32 cells
    (x, y, t), sorted by cell, each once; csi-render's and csi-positions' for the same grid and
    seed. method: poisson, stratified or random; fraction: N = round(fraction * cells) instead
    of spp samples per output pixel."""
    L = lib()
    g = _grid(grid)
    m = ctypes.c_int()
    _check(L.csi_pos_method_parse(str(method).encode(), ctypes.byref(m)))
    o = _PosOpts(m.value, _whole("spp", spp, 0, _U32), float(fraction or 0), _whole("seed", seed, 0, _U64))
    p, n = ctypes.POINTER(u32)(), c_size()
    _check(L.csi_positions(ctypes.byref(g), ctypes.byref(o), ctypes.byref(p), ctypes.byref(n), None))
    try:
        return np.ctypeslib.as_array(p, shape=(n.value, 3)).copy()
    finally:
        L.csi_free(p)


def _image_samples(positions, values, grid, keep, variance=None):
    """csi_samples over (N, 3) positions and (N, C) or (N,) values (and their variances, or
    None), the arrays appended to keep (alive while the library reads them)."""
    pos, val = _samples_arrays(positions, values)
    var = _variance_array(variance, val)
    keep.extend((pos, val, var))
    return _Samples(_grid(grid), val.shape[1], pos.shape[0], pos.ctypes.data_as(ctypes.POINTER(u32)),
                    val.ctypes.data_as(ctypes.POINTER(ctypes.c_float)), 0,
                    var.ctypes.data_as(ctypes.POINTER(ctypes.c_float)) if var is not None else None)


def _planar_view(image, keep):
    """An (H, W, C) or (H, W) image as a planar csi_image over a copy (appended to keep)."""
    img = np.asarray(image, dtype=np.float32)
    img = img[:, :, None] if img.ndim == 2 else img
    if img.ndim != 3:
        raise CsiError("CSI_ERR_ARG", f"image {img.shape}: expected (H, W, C)")
    planar = np.ascontiguousarray(np.moveaxis(img, 2, 0))
    keep.append(planar)
    return _Image(img.shape[1], img.shape[0], img.shape[2], planar.ctypes.data_as(ctypes.POINTER(ctypes.c_float)))


def refine_positions(positions, values, grid, image, share: Optional[float] = None):
    """Where to sample next (csi_refine_positions): the cells without a sample of the pixels where
    image, the (H, W, C) reconstruction of these samples, and the mean of the pixel's own samples
    disagree by at least `share` (default 0.005) of their disagreement, (image - mean)^2 summed
    over the channels, over the whole image. Returns ((M, 3) uint32 cells, pixels picked); M = 0
    when none is. Images only (grid t = 1)."""
    L, keep = lib(), []
    samples, view = _image_samples(positions, values, grid, keep), _planar_view(image, keep)
    out, n, px = ctypes.POINTER(u32)(), c_size(), c_size()
    _check(L.csi_refine_positions(ctypes.byref(samples), ctypes.byref(view),
                                  float(L.csi_refine_share_default() if share is None else share),
                                  ctypes.byref(out), ctypes.byref(n), ctypes.byref(px)))
    try:
        cells = np.ctypeslib.as_array(out, shape=(n.value, 3)).copy() if n.value else np.zeros((0, 3), np.uint32)
    finally:
        L.csi_free(out)
    return cells, int(px.value)


def _refine_image(fn, positions, values, grid, image, variance, more_positions, more_values, more_variance):
    """One of csi_refine_apply / _settle / _step_coverage on image (H, W, C) and the samples (the more
    ones None where absent): (a copy of the image it gives, the pixels it changed)."""
    keep = []
    first = _image_samples(positions, values, grid, keep, variance)
    more = _image_samples(more_positions, more_values, grid, keep, more_variance) \
        if more_positions is not None else None
    view = _planar_view(image, keep)
    px = c_size()
    _check(fn(ctypes.byref(first), ctypes.byref(more) if more is not None else None, ctypes.byref(view),
              ctypes.byref(px)))
    planar = keep[-1]
    return np.moveaxis(planar, 0, 2).copy(), int(px.value)


def refine_apply(positions, values, more_positions, more_values, grid, image):
    """The image after the second pass (csi_refine_apply): image, the (H, W, C) reconstruction of
    the first samples, with every pixel that holds one of the more samples (the request,
    evaluated) set to the mean of all its samples. Returns (image, pixels set); image is a copy."""
    return _refine_image(lib().csi_refine_apply, positions, values, grid, image, None, more_positions, more_values,
                         None)


def refine_settle(positions, values, grid, image, variance=None, more_positions=None, more_values=None):
    """The image after the last pass, settled (csi_refine_settle): with each sample's variance
    given (several paths per sample), the pixels where image, the (H, W, C) image after the
    passes, and the mean of all their samples (these, then the more ones if given) still disagree
    by a large share of their disagreement over the whole image take that mean; without variances
    nothing moves. Returns (image, pixels moved); image is a copy."""
    return _refine_image(lib().csi_refine_settle, positions, values, grid, image, variance, more_positions,
                         more_values, None)


def refine_step_coverage(positions, values, grid, image, variance=None, more_positions=None, more_values=None,
                         more_variance=None):
    """The image after the settling, its HDR steps' pixels given the coverage their window's samples
    allow (csi_refine_step_coverage, as csi_reconstruct's last step on a fixed dump), from all the
    samples (these, then the more ones if given, taken in csi's cell order): with each sample's
    variance given (several paths per sample); without them nothing moves. Returns (image, pixels
    moved); image is a copy."""
    return _refine_image(lib().csi_refine_step_coverage, positions, values, grid, image, variance, more_positions,
                         more_values, more_variance)


class OutputSet:
    """A run's output files written all or nothing (csi_outset, csi/csi.h), as csi's programs
    write theirs: every output is stated before any work and refused then (one line naming the
    path) when its directory is missing or unwritable, when it is a directory, another output, or
    one of the stated inputs; after the work each is written to tmp(path) and commit() renames
    them all into place. Leaving a `with` block by an exception (KeyboardInterrupt included), or
    close() before commit(), removes every temporary file: a failed run leaves nothing.

        with csi.OutputSet(inputs=[scene]) as outs:
            outs.file("out.exr", "the image (-o)")
            ...                                    # the work
            result.write_exr(outs.tmp("out.exr"))
            outs.commit()
    """

    def __init__(self, inputs=()):
        L = lib()
        h = ctypes.c_void_p()
        _check(L.csi_outset_create(ctypes.byref(h)))
        self._h = h
        self._names = []  # the library keeps pointers to these
        for path in inputs:
            self.input(path)

    def _keep(self, text) -> bytes:
        b = os.fsencode(text)
        self._names.append(b)
        return b

    def input(self, path):
        """An input of the run: no output may be the same file (a missing one is not checked)."""
        if path:
            _check(lib().csi_outset_input(self._h, self._keep(path)))

    def file(self, path, what: str):
        """An output file, checked now (CsiError CSI_ERR_IO / CSI_ERR_ARG naming it)."""
        _check(lib().csi_outset_file(self._h, self._keep(path if path is not None else ""), self._keep(what)))

    def dir(self, path, what: str):
        """An output folder (made by the writer of its files; checked now)."""
        _check(lib().csi_outset_dir(self._h, self._keep(path if path is not None else ""), self._keep(what)))

    def dir_file(self, path, name: str, what: str):
        """A file of a stated output folder (its temporary path: tmp(os.path.join(path, name)))."""
        _check(lib().csi_outset_dir_file(self._h, self._keep(path), self._keep(name), self._keep(what)))

    def tmp(self, path) -> str:
        """The temporary path to write the stated output `path` to."""
        t = ctypes.c_char_p()
        _check(lib().csi_outset_tmp(self._h, self._keep(path), ctypes.byref(t)))
        return os.fsdecode(t.value)

    def commit(self):
        """Renames every output written into place, all or none."""
        _check(lib().csi_outset_commit(self._h))

    def close(self):
        """Removes what was not committed, and frees the set."""
        if getattr(self, "_h", None) and _lib is not None:
            _lib.csi_outset_free(self._h)
        self._h = None

    __del__ = close

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False


class Dump:
    """A sample dump read by the library (docs/dump-format.md): grid, positions (N, 3) uint32,
    values (N, C) float32, seed, exact (the header's flag: noise-free point values)."""

    def __init__(self, grid, positions, values, seed, exact=False):
        self.grid, self.positions, self.values, self.seed = grid, positions, values, seed
        self.exact = bool(exact)


def read_dump(path: str) -> Dump:
    L = lib()
    d = _Dump()
    _check(L.csi_dump_read(os.fsencode(path), None, ctypes.byref(d), None))
    try:
        g = d.grid
        grid = (g.w, g.h, g.t, g.out_w, g.out_h)
        pos = np.ctypeslib.as_array(d.pos, shape=(d.count, 3)).copy()
        val = np.ctypeslib.as_array(d.values, shape=(d.count, d.channels)).copy()
        return Dump(grid, pos, val, d.seed, bool(d.flags & SAMPLES_EXACT))
    finally:
        L.csi_dump_free(ctypes.byref(d))


def reconstruct_dump(path: str, variance_path: Optional[str] = None, **kwargs) -> Result:
    """Reconstructs a dump as csi-reconstruct does (its seed is the solver's unless given, its
    exact flag the samples'); variance_path: csi-reconstruct's --variance, a dump of the same
    positions whose values are the samples' variances (not read unless named: csi-reconstruct
    takes DUMP's stem .variance.csid by default where it exists)."""
    d = read_dump(path)
    if variance_path is not None:
        v = read_dump(variance_path)
        if v.grid != d.grid or not np.array_equal(v.positions, d.positions) or v.values.shape != d.values.shape:
            raise CsiError("CSI_ERR_FORMAT", f"{variance_path}: not the variances of {path}'s samples "
                           "(grid, positions or channels differ)")
        kwargs["variance"] = v.values
    if d.seed and "seed" not in kwargs:
        kwargs["seed"] = d.seed
    kwargs.setdefault("exact", d.exact)
    return reconstruct(d.positions, d.values, d.grid, **kwargs)
