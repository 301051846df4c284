#!/usr/bin/env python3
"""Reference inputs for the io tests (tests/data/io/), written without libpng.

- img_rgb.png: 16x12 8-bit RGB, codes from numpy's default_rng(seed 1).
- img_rgb.txt: one line per pixel "x y R G B", the linear values after the sRGB decode of
  IEC 61966-2-1 (s <= 0.04045: s/12.92, else ((s+0.055)/1.055)^2.4), %.9g.
- frame_000.png .. frame_003.png: 8x8 8-bit gray frames (seed 2), and frames.txt "t x y V".

The PNG encoder here is a minimal independent one (zlib + CRC from Python's standard library),
so the csi reader is checked against a different implementation than the one it uses.
Run: /work/main/.venv/bin/python tests/data/io/gen_refs.py
"""
import os
import struct
import zlib

import numpy as np

OUT = os.path.dirname(os.path.abspath(__file__))


def png_bytes(codes):
    """codes: uint8 array (h, w) gray or (h, w, 3) RGB."""
    h, w = codes.shape[:2]
    ctype = 0 if codes.ndim == 2 else 2

    def chunk(tag, data):
        c = struct.pack(">I", len(data)) + tag + data
        return c + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    raw = b"".join(b"\x00" + codes[y].tobytes() for y in range(h))  # filter type 0 per row
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, ctype, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


def srgb_decode(code):
    s = code / 255.0
    return s / 12.92 if s <= 0.04045 else ((s + 0.055) / 1.055) ** 2.4


def main():
    os.makedirs(OUT, exist_ok=True)
    rng = np.random.default_rng(1)
    rgb = rng.integers(0, 256, size=(12, 16, 3), dtype=np.uint8)
    with open(os.path.join(OUT, "img_rgb.png"), "wb") as f:
        f.write(png_bytes(rgb))
    with open(os.path.join(OUT, "img_rgb.txt"), "w") as f:
        for y in range(12):
            for x in range(16):
                f.write("%d %d %s\n" % (x, y, " ".join("%.9g" % srgb_decode(int(c)) for c in rgb[y, x])))
    rng = np.random.default_rng(2)
    with open(os.path.join(OUT, "frames.txt"), "w") as f:
        for t in range(4):
            g = rng.integers(0, 256, size=(8, 8), dtype=np.uint8)
            with open(os.path.join(OUT, "frame_%03d.png" % t), "wb") as p:
                p.write(png_bytes(g))
            for y in range(8):
                for x in range(8):
                    f.write("%d %d %d %.9g\n" % (t, x, y, srgb_decode(int(g[y, x]))))


if __name__ == "__main__":
    main()
