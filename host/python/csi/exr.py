"""Float32 RGB EXR files from numpy (OpenEXR's Python binding), written whole or not at all."""

from __future__ import annotations

import os

import numpy as np

from . import atomic


def write(path, rgb) -> None:
    """Writes an (h, w, 3) image as float32 RGB EXR (ZIP) via a temporary file and a rename."""
    import OpenEXR

    path = os.fspath(path)
    img = np.ascontiguousarray(rgb, dtype=np.float32)
    if img.ndim != 3 or img.shape[2] != 3:
        raise ValueError(f"{path}: an EXR image must be (h, w, 3), got {img.shape}")
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with atomic.target(path, suffix=".exr") as tmp, OpenEXR.File(header, {"RGB": img}) as f:
        f.write(tmp)


def read(path) -> np.ndarray:
    """Reads an RGB EXR as an (h, w, 3) float32 array (R, G, B channels of any pixel type)."""
    import OpenEXR

    with OpenEXR.File(os.fspath(path), separate_channels=True) as f:
        ch = f.channels()
        return np.stack([np.asarray(ch[c].pixels, dtype=np.float32) for c in ("R", "G", "B")], axis=-1)
