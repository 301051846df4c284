"""Sample dumps and positions requests (docs/dump-format.md) in pure numpy.

A dump holds point samples on a fine grid: a 64-byte header, then records (u32 x, u32 y, u32 t,
channels x f32). A positions request is the same format with channels = 0: the records are the
positions csi wants samples at (written by csi-positions), for a renderer to evaluate at the
cells' centres and write back as a dump with values.

    req = read("request.csid")            # Dump with values None
    u, v, t = req.cell_centres()           # image point in [0,1]^2 (v down), shutter time
    write("samples.csid", req.with_values(rgb))

The reader checks what csi's C reader checks (docs/dump-format.md, "What a reader refuses") and
raises DumpError with one line naming the file and the byte or record; unlike the C reader it
keeps records as they are (no sorting, no averaging of duplicates).
"""

from __future__ import annotations

import dataclasses
import os
import stat

import numpy as np

from . import atomic

MAGIC = b"CSID"
VERSION = 1
HEADER_BYTES = 64
MAX_SIDE = 65536
MAX_CELLS = 1 << 31
MAX_CHANNELS = 4
FLAG_EXACT = 1  # header bytes 48-51 (u32 flags), bit 0: the values are exact (csi/csi.h CSI_SAMPLES_EXACT)


class DumpError(ValueError):
    """A file that is not a valid dump or request; the message is one line naming the file."""


@dataclasses.dataclass
class Dump:
    grid: tuple  # (w, h, t) fine-grid cells
    out: tuple  # (out_w, out_h) final image
    xyt: np.ndarray  # (n, 3) uint32 cell indices
    values: np.ndarray | None  # (n, channels) float32, None for a positions request
    seed: int = 0
    exact: bool = False  # header flag (byte 48, bit 0): every value is a noise-free point value

    @property
    def channels(self) -> int:
        return 0 if self.values is None else int(self.values.shape[1])

    @property
    def is_request(self) -> bool:
        return self.values is None

    @property
    def factor(self) -> int:
        """Fine-grid cells per output pixel along x."""
        return self.grid[0] // self.out[0]

    def cell_centres(self):
        """(u, v, time) float64 arrays: the image point ((x+0.5)/w, (y+0.5)/h) in [0,1]^2 with
        v = 0 on the top row, and the shutter time (t+0.5)/T in [0,1]."""
        w, h, t = self.grid
        x, y, tt = (self.xyt[:, i].astype(np.float64) for i in range(3))
        return (x + 0.5) / w, (y + 0.5) / h, (tt + 0.5) / t

    def with_values(self, values, exact=False) -> "Dump":
        """This request's positions with values (n, c) or (n,): a dump to write back. exact: the
        values are noise-free point evaluations at the cell centres (a deterministic renderer),
        not Monte Carlo estimates (docs/dump-format.md)."""
        v = np.asarray(values, dtype=np.float32)
        if v.ndim == 1:
            v = v[:, None]
        if v.shape[0] != len(self.xyt):
            raise ValueError(f"{v.shape[0]} values for {len(self.xyt)} positions")
        return dataclasses.replace(self, values=v, exact=bool(exact))

    def pixel_means(self) -> np.ndarray:
        """Per-output-pixel mean of the values (out_h, out_w, channels), float64; NaN where a
        pixel has no sample. Duplicates count as separate samples here."""
        if self.values is None:
            raise ValueError("a positions request has no values")
        bw, bh = self.grid[0] // self.out[0], self.grid[1] // self.out[1]
        ow, oh = self.out
        pix = (self.xyt[:, 1] // bh).astype(np.int64) * ow + self.xyt[:, 0] // bw
        c = self.channels
        sums = np.zeros((ow * oh, c))
        for k in range(c):
            sums[:, k] = np.bincount(pix, weights=self.values[:, k].astype(np.float64), minlength=ow * oh)
        cnt = np.bincount(pix, minlength=ow * oh).astype(np.float64)
        with np.errstate(invalid="ignore", divide="ignore"):
            return (sums / cnt[:, None]).reshape(oh, ow, c)


def _check_grid(path, grid, out, channels, allow_request):
    w, h, t = grid
    ow, oh = out
    for name, off, v in (("grid_w", 8, w), ("grid_h", 12, h), ("grid_t", 16, t), ("out_w", 20, ow), ("out_h", 24, oh)):
        if v == 0:
            raise DumpError(f"{path}: byte {off}: {name} is zero")
        if v > MAX_SIDE:
            raise DumpError(f"{path}: byte {off}: {name} = {v} is larger than the limit {MAX_SIDE}")
    if w % ow:
        raise DumpError(f"{path}: byte 8: grid_w = {w} is not a multiple of out_w = {ow}")
    if h % oh:
        raise DumpError(f"{path}: byte 12: grid_h = {h} is not a multiple of out_h = {oh}")
    if w * h * t > MAX_CELLS:
        raise DumpError(f"{path}: byte 8: grid {w}x{h}x{t} has {w * h * t} cells, more than the limit {MAX_CELLS}")
    if not ((allow_request and channels == 0) or 1 <= channels <= MAX_CHANNELS):
        raise DumpError(f"{path}: byte 28: channels = {channels} (must be {'0 to' if allow_request else '1 to'} {MAX_CHANNELS})")


def _kind(mode) -> str:
    for test, name in ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return name
    return "not a regular file"


def _open_regular(path):
    """path opened for reading when it is a regular file (and its size), else DumpError saying
    what it is: opened without blocking (a FIFO would wait for a writer), so that a FIFO or
    /dev/zero is refused at once instead of read without end (the C reader's rule)."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    except OSError as e:
        raise DumpError(f"{path}: cannot open: {e.strerror}") from None
    st = os.fstat(fd)
    if not stat.S_ISREG(st.st_mode):
        os.close(fd)
        raise DumpError(f"{path}: cannot open: {_kind(st.st_mode)}, not a regular file")
    os.set_blocking(fd, True)
    return os.fdopen(fd, "rb"), st.st_size


def read(path, *, want=None) -> Dump:
    """Reads a dump or a positions request. want: None (either), "request" or "samples". The
    header is checked against the file's size before the records are read."""
    path = os.fspath(path)
    f, size = _open_regular(path)
    with f:
        return _read(f, size, path, want)


def _read(f, size, path, want) -> Dump:
    data = f.read(HEADER_BYTES)
    if len(data) >= 4 and data[:4] != MAGIC:
        raise DumpError(f"{path}: byte 0: wrong magic {data[:4]!r} (expected 'CSID'): not a csi sample dump")
    if len(data) < HEADER_BYTES:
        raise DumpError(f"{path}: byte {len(data)}: truncated header (file has {len(data)} bytes, a dump header has 64)")
    hdr = np.frombuffer(data[:HEADER_BYTES], "<u4")
    if hdr[1] != VERSION:
        raise DumpError(f"{path}: byte 4: unknown version {hdr[1]} (this reader knows version {VERSION})")
    grid = tuple(int(v) for v in hdr[2:5])
    out = tuple(int(v) for v in hdr[5:7])
    channels = int(hdr[7])
    count = int(hdr[8]) | int(hdr[9]) << 32
    seed = int(hdr[10]) | int(hdr[11]) << 32
    _check_grid(path, grid, out, channels, allow_request=True)
    if want == "samples" and channels == 0:
        raise DumpError(f"{path}: byte 28: channels = 0: a positions request, not samples")
    if want == "request" and channels != 0:
        raise DumpError(f"{path}: byte 28: channels = {channels}: a sample dump, not a positions request (channels = 0)")
    flags = int(hdr[12])
    if flags & ~FLAG_EXACT:
        raise DumpError(f"{path}: byte 48: flags 0x{flags:08x} has reserved bits 0x{flags & ~FLAG_EXACT:08x} set, "
                        f"must be zero (this reader knows 0x{FLAG_EXACT:08x}: exact values)")
    if channels == 0 and flags:
        raise DumpError(f"{path}: byte 48: flags 0x{flags:08x} on a positions request (it has no values to be exact)")
    for i in range(52, 64):
        if data[i]:
            raise DumpError(f"{path}: byte {i}: reserved byte is 0x{data[i]:02x}, must be zero")
    if count == 0:
        raise DumpError(f"{path}: byte 32: zero samples (count = 0)")
    rec = 12 + 4 * channels
    payload = size - HEADER_BYTES
    if count > payload // rec:
        raise DumpError(f"{path}: byte 32: count = {count} records of {rec} bytes but the file holds only "
                        f"{payload} bytes after the header (truncated at record {payload // rec})")
    if payload != count * rec:
        raise DumpError(f"{path}: byte {HEADER_BYTES + count * rec}: {payload - count * rec} trailing bytes "
                        f"after the last of {count} records")
    body = f.read(count * rec)
    if len(body) != count * rec:
        raise DumpError(f"{path}: byte {HEADER_BYTES + len(body)}: the file ended at record {len(body) // rec} of "
                        f"{count} while it was read")
    dt = np.dtype([("p", "<u4", 3), ("v", "<f4", channels)]) if channels else np.dtype([("p", "<u4", 3)])
    recs = np.frombuffer(body, dtype=dt, count=count)
    xyt = recs["p"].astype(np.uint32)
    outside = (xyt[:, 0] >= grid[0]) | (xyt[:, 1] >= grid[1]) | (xyt[:, 2] >= grid[2])
    if outside.any():
        r = int(np.argmax(outside))
        x, y, t = (int(v) for v in xyt[r])
        if grid[2] == 1 and t != 0:
            raise DumpError(f"{path}: record {r} (byte {HEADER_BYTES + r * rec}): t = {t} but the grid is static "
                            f"(grid_t = 1, so t must be 0)")
        raise DumpError(f"{path}: record {r} (byte {HEADER_BYTES + r * rec}): position ({x}, {y}, {t}) outside the "
                        f"{grid[0]}x{grid[1]}x{grid[2]} grid")
    values = None
    if channels:
        values = recs["v"].astype(np.float32).reshape(count, channels)
        bad = ~np.isfinite(values)
        if bad.any():
            r, c = (int(v) for v in np.argwhere(bad)[0])
            kind = "NaN" if np.isnan(values[r, c]) else "infinite"
            raise DumpError(f"{path}: record {r} (byte {HEADER_BYTES + r * rec + 12 + 4 * c}): channel {c} is {kind}")
    return Dump(grid=grid, out=out, xyt=xyt, values=values, seed=seed, exact=bool(flags & FLAG_EXACT))


def write(path, d: Dump) -> None:
    """Writes a dump (or a request when d.values is None): temporary file in the same directory,
    then rename, so nothing partial is ever seen and nothing is left on failure."""
    path = os.fspath(path)
    channels = d.channels
    _check_grid(path, d.grid, d.out, channels, allow_request=True)
    xyt = np.asarray(d.xyt)
    n = len(xyt)
    if n == 0:
        raise DumpError(f"{path}: cannot write a dump with zero samples")
    if xyt.shape != (n, 3):
        raise ValueError(f"{path}: positions must be an (n, 3) array, got {xyt.shape}")
    if (xyt < 0).any() or (xyt[:, 0] >= d.grid[0]).any() or (xyt[:, 1] >= d.grid[1]).any() or (xyt[:, 2] >= d.grid[2]).any():
        raise DumpError(f"{path}: cannot write dump: a position is outside the {d.grid[0]}x{d.grid[1]}x{d.grid[2]} grid")
    if channels and not np.isfinite(d.values).all():
        raise DumpError(f"{path}: cannot write dump: a value is not finite")
    if d.exact and not channels:
        raise DumpError(f"{path}: cannot write dump: a positions request has no values to be exact")
    hdr = np.zeros(16, "<u4")
    hdr[0] = int.from_bytes(MAGIC, "little")
    hdr[1] = VERSION
    hdr[2:5] = d.grid
    hdr[5:7] = d.out
    hdr[7] = channels
    hdr[8:10] = [n & 0xFFFFFFFF, n >> 32]
    hdr[10:12] = [d.seed & 0xFFFFFFFF, (d.seed >> 32) & 0xFFFFFFFF]
    hdr[12] = FLAG_EXACT if d.exact else 0
    dt = np.dtype([("p", "<u4", 3), ("v", "<f4", channels)]) if channels else np.dtype([("p", "<u4", 3)])
    rec = np.zeros(n, dtype=dt)
    rec["p"] = xyt
    if channels:
        rec["v"] = np.asarray(d.values, dtype=np.float32).reshape(n, channels)
    with atomic.target(path) as tmp, open(tmp, "wb") as f:
        f.write(hdr.tobytes())
        f.write(rec.tobytes())
