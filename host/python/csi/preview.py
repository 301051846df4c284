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


def animation(path, seqs, fps=12, scale=2, exposure=1.0, webp=None):
    """Writes an animated image playing the frames of every sequence side by side (labelled),
    looping: WebP (lossless) when `webp`, else GIF (256 colours per frame); webp None: WebP when
    `path` ends in .webp."""
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
    if webp is None:
        webp = os.fspath(path).lower().endswith(".webp")
    with atomic.target(path, suffix=".webp" if webp else ".gif") as tmp:
        kw = dict(save_all=True, append_images=out[1:], duration=int(round(1000 / fps)), loop=0)
        if webp:
            out[0].save(tmp, format="WEBP", lossless=True, **kw)
        else:
            out[0].save(tmp, format="GIF", **kw)


#: The most pixels csi-preview draws (the sheet, or all the animation's frames together): about
#: 400 MB of RGB, so that a --scale or --picks far too large is refused, not left to exhaust memory.
MAX_PIXELS = 1 << 27


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line (argparse prints the usage too otherwise)
        raise PreviewError(message)


def _pixels(seqs, picks, scale, sheet, anim):
    """The pixels the sheet and the animation would hold (their canvases), from the sizes alone."""
    from PIL import ImageFont

    T, h, w = seqs[0][1].shape[:3]
    lh, pad = _label_height(ImageFont.load_default()), 2
    n = 0
    if sheet:
        cols = len(_pick(T, picks)) + 1
        n += (cols * (w * scale + pad) + pad) * (len(seqs) * (h * scale + lh + pad) + pad)
    if anim:
        n += T * (len(seqs) * (w * scale + pad) + pad) * (h * scale + lh + 2 * pad)
    return n


def main(argv=None):
    p = _Parser(prog=PROG, description="A contact sheet (PNG) and an animated preview (WebP or GIF) "
                "of the frames csi-reconstruct / csi-render --frames DIR wrote. Exit status: 0 success, 2 bad "
                "input or usage.")
    p.add_argument("frames", metavar="DIR", nargs="+", help="frame directories (frame_NNNN.exr), one row each")
    p.add_argument("-o", "--sheet", metavar="SHEET.png", help="the contact sheet")
    p.add_argument("--animation", metavar="ANIM.webp|.gif", help="the animated preview")
    p.add_argument("--picks", type=int, default=8, help="frames on the sheet (spread over T), default 8")
    p.add_argument("--scale", type=int, default=2, help="enlargement (nearest), default 2")
    p.add_argument("--exposure", type=float, default=1.0, help="linear values are multiplied by this, default 1")
    p.add_argument("--fps", type=float, default=12, help="frames per second of the animation, default 12")
    from ._lib import CsiError, OutputSet

    try:
        a = p.parse_args(argv)
        if not (a.sheet or a.animation):
            raise PreviewError("no output given: use -o SHEET.png and/or --animation ANIM.webp")
        if a.animation and not a.animation.lower().endswith((".webp", ".gif")):
            raise PreviewError(f"{a.animation}: the animation is written as WebP or GIF: name it .webp or .gif")
        if a.picks < 1 or a.scale < 1 or not 0 < a.fps < float("inf") or not 0 < a.exposure < float("inf"):
            raise PreviewError("--picks and --scale must be >= 1, --fps and --exposure finite and > 0")
        # The outputs as csi's programs state theirs: checked before any work (not a directory,
        # not a frame, not each other), written all or nothing.
        frames = [f for d in a.frames for f in sorted(glob.glob(os.path.join(d, "frame_*.exr")))]
        with OutputSet(inputs=frames) as outs:
            for path, what in ((a.sheet, "the contact sheet (-o)"), (a.animation, "the animation (--animation)")):
                if path:
                    outs.file(path, what)
            seqs = [(os.path.basename(os.path.normpath(d)), read_frames(d)) for d in a.frames]
            n = _pixels(_check(seqs), a.picks, a.scale, a.sheet, a.animation)
            if n > MAX_PIXELS:
                raise PreviewError(f"--scale {a.scale} would draw {n} pixels, more than the {MAX_PIXELS} csi-preview "
                                   "draws: give a smaller --scale or --picks")
            if a.sheet:
                contact_sheet(outs.tmp(a.sheet), seqs, picks=a.picks, scale=a.scale, exposure=a.exposure)
            if a.animation:
                animation(outs.tmp(a.animation), seqs, fps=a.fps, scale=a.scale, exposure=a.exposure,
                          webp=a.animation.lower().endswith(".webp"))
            outs.commit()
    except (PreviewError, CsiError) as e:
        print(f"{PROG}: error: {e}", file=sys.stderr)
        return 2
    except OSError as e:
        print(f"{PROG}: error: {e.filename + ': ' if e.filename else ''}{e.strerror or e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main())
