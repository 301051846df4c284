"""Previews of an animation a person would rather look at than read: a contact sheet (PNG) of
frames side by side, and an animated image (WebP, or GIF) that plays them.

    from csi import preview
    frames = preview.read_frames("out-frames/")                # (T, h, w, c) float32 from frame_NNNN.exr
    preview.contact_sheet("sheet.png", [("csi", frames)], picks=8)
    preview.animation("anim.webp", [("reference", ref), ("csi", frames)], fps=12)

Frames are linear radiance; they are shown as 8-bit sRGB of the linear values times `exposure`,
clipped to [0, 1] (as csi-reconstruct's --png). Several sequences are laid out one per row on the
sheet (each frame a column), side by side in the animation; a label is drawn above each. Needs
Pillow (and OpenEXR's Python module to read EXR frames). `csi-preview` is the command line.
"""

from __future__ import annotations

import argparse
import glob
import os
import re
import sys

import numpy as np

from . import atomic

PROG = "csi-preview"


class PreviewError(ValueError):
    """Bad input; the message is one line naming the file or the problem."""


def read_frames(directory) -> np.ndarray:
    """The frames csi-reconstruct --frames (or csi-render --frames) wrote to `directory`, in
    order: frame_NNNN.exr, as (T, h, w, c) float32 (c = 3 for RGB, 1 for a single channel)."""
    import OpenEXR

    directory = os.fspath(directory)
    if not os.path.isdir(directory):
        raise PreviewError(f"{directory}: not a directory of frames")
    files = sorted(f for f in glob.glob(os.path.join(directory, "frame_*.exr"))
                   if re.fullmatch(r"frame_\d+\.exr", os.path.basename(f)))
    if not files:
        raise PreviewError(f"{directory}: no frame_NNNN.exr files")
    out = []
    for f in files:
        try:
            with OpenEXR.File(f, separate_channels=True) as e:
                ch = e.channels()
                names = [c for c in ("R", "G", "B") if c in ch] or sorted(ch)[:1]
                out.append(np.stack([np.asarray(ch[c].pixels, dtype=np.float32) for c in names], axis=-1))
        except Exception as e:  # OpenEXR raises RuntimeError with its reason
            raise PreviewError(f"{f}: cannot read the EXR frame: {e}") from None
    if any(o.shape != out[0].shape for o in out):
        raise PreviewError(f"{directory}: frames of different sizes")
    return np.stack(out)


def to_srgb8(img, exposure=1.0) -> np.ndarray:
    """(h, w, c) linear -> (h, w, 3) uint8 sRGB (a single channel is shown grey)."""
    x = np.clip(np.nan_to_num(np.asarray(img, dtype=np.float64) * exposure), 0.0, 1.0)
    if x.ndim == 2:
        x = x[..., None]
    if x.shape[-1] == 1:
        x = np.repeat(x, 3, axis=-1)
    x = x[..., :3]
    s = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    return (s * 255 + 0.5).astype(np.uint8)


def _label_height(font):
    box = font.getbbox("Ag")
    return box[3] - box[1] + 6


def _canvas(rows, cols, h, w, scale, labels, font, pad=2):
    from PIL import Image

    lh = _label_height(font) if labels else 0
    W = cols * (w * scale + pad) + pad
    H = rows * (h * scale + lh + pad) + pad
    return Image.new("RGB", (W, H), (24, 24, 24)), lh


def _check(seqs):
    if not seqs:
        raise PreviewError("nothing to show")
    shape = None
    for label, fr in seqs:
        fr = np.asarray(fr)
        if fr.ndim == 3:
            fr = fr[..., None]
        if fr.ndim != 4:
            raise PreviewError(f"{label}: frames must be (T, h, w[, c]), got {fr.shape}")
        if shape is not None and fr.shape[:3] != shape:
            raise PreviewError(f"{label}: {fr.shape[0]} frames of {fr.shape[2]}x{fr.shape[1]}, the first "
                               f"sequence has {shape[0]} of {shape[2]}x{shape[1]}")
        shape = fr.shape[:3]
    return [(label, np.asarray(fr) if np.asarray(fr).ndim == 4 else np.asarray(fr)[..., None]) for label, fr in seqs]


def _pick(T, picks):
    if isinstance(picks, int):
        picks = min(picks, T)
        return sorted({int(round(i * (T - 1) / max(picks - 1, 1))) for i in range(picks)})
    return [int(p) for p in picks]


def contact_sheet(path, seqs, picks=8, scale=2, exposure=1.0, mean=True):
    """Writes a PNG: one row per (label, frames) in seqs, the frames `picks` (a count spread over
    T, or a list of indices) as columns, and with `mean` a last column with the mean over all
    frames (the motion-blurred image). Each frame is enlarged `scale` times (nearest)."""
    from PIL import Image, ImageDraw, ImageFont

    seqs = _check(seqs)
    T, h, w = seqs[0][1].shape[:3]
    idx = _pick(T, picks)
    font = ImageFont.load_default()
    cols = len(idx) + (1 if mean else 0)
    img, lh = _canvas(len(seqs), cols, h, w, scale, True, font)
    d = ImageDraw.Draw(img)
    pad = 2
    for r, (label, fr) in enumerate(seqs):
        y0 = pad + r * (h * scale + lh + pad)
        tiles = [(f"{label}  t={t}" if c == 0 else f"t={t}", fr[t]) for c, t in enumerate(idx)]
        if mean:
            tiles.append(("mean over t", fr.mean(axis=0)))
        for c, (text, tile) in enumerate(tiles):
            x0 = pad + c * (w * scale + pad)
            d.text((x0 + 2, y0 + 1), text, fill=(230, 230, 230), font=font)
            im = Image.fromarray(to_srgb8(tile, exposure)).resize((w * scale, h * scale), Image.NEAREST)
            img.paste(im, (x0, y0 + lh))
    with atomic.target(path, suffix=".png") as tmp:
        img.save(tmp, format="PNG")


def animation(path, seqs, fps=12, scale=2, exposure=1.0):
    """Writes an animated image playing the frames of every sequence side by side (labelled),
    looping: WebP when `path` ends in .webp (lossless), else GIF (256 colours per frame)."""
    from PIL import Image, ImageDraw, ImageFont

    seqs = _check(seqs)
    T, h, w = seqs[0][1].shape[:3]
    font = ImageFont.load_default()
    pad = 2
    out = []
    for t in range(T):
        img, lh = _canvas(1, len(seqs), h, w, scale, True, font)
        d = ImageDraw.Draw(img)
        for c, (label, fr) in enumerate(seqs):
            x0 = pad + c * (w * scale + pad)
            d.text((x0 + 2, pad + 1), f"{label}  t={t}", fill=(230, 230, 230), font=font)
            im = Image.fromarray(to_srgb8(fr[t], exposure)).resize((w * scale, h * scale), Image.NEAREST)
            img.paste(im, (x0, pad + lh))
        out.append(img)
    webp = os.fspath(path).lower().endswith(".webp")
    with atomic.target(path, suffix=".webp" if webp else ".gif") as tmp:
        kw = dict(save_all=True, append_images=out[1:], duration=int(round(1000 / fps)), loop=0)
        if webp:
            out[0].save(tmp, format="WEBP", lossless=True, **kw)
        else:
            out[0].save(tmp, format="GIF", **kw)


def main(argv=None):
    p = argparse.ArgumentParser(prog=PROG, description="A contact sheet (PNG) and an animated preview (WebP or GIF) "
                                "of the frames csi-reconstruct / csi-render --frames DIR wrote.")
    p.add_argument("frames", metavar="DIR", nargs="+", help="frame directories (frame_NNNN.exr), one row each")
    p.add_argument("-o", "--sheet", metavar="SHEET.png", help="the contact sheet")
    p.add_argument("--animation", metavar="ANIM.webp|.gif", help="the animated preview")
    p.add_argument("--picks", type=int, default=8, help="frames on the sheet (spread over T), default 8")
    p.add_argument("--scale", type=int, default=2, help="enlargement (nearest), default 2")
    p.add_argument("--exposure", type=float, default=1.0, help="linear values are multiplied by this, default 1")
    p.add_argument("--fps", type=float, default=12, help="frames per second of the animation, default 12")
    a = p.parse_args(argv)
    try:
        if not (a.sheet or a.animation):
            raise PreviewError("no output given: use -o SHEET.png and/or --animation ANIM.webp")
        if a.picks < 1 or a.scale < 1 or not (a.fps > 0) or not (a.exposure > 0):
            raise PreviewError("--picks and --scale must be >= 1, --fps and --exposure > 0")
        seqs = [(os.path.basename(os.path.normpath(d)), read_frames(d)) for d in a.frames]
        if a.sheet:
            contact_sheet(a.sheet, seqs, picks=a.picks, scale=a.scale, exposure=a.exposure)
        if a.animation:
            animation(a.animation, seqs, fps=a.fps, scale=a.scale, exposure=a.exposure)
    except (PreviewError, OSError) as e:
        print(f"{PROG}: error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
