#!/usr/bin/env python3
"""Generates the bundled scenes' procedural assets: textures (PNG) under data/textures and the
garden's grass mesh (OBJ) and scene file under data/scenes. Deterministic (fixed seeds); no
downloaded assets. Run: /work/main/.venv/bin/python data/make_assets.py [ROOT]"""
import os
import struct
import sys
import zlib

import numpy as np

ROOT = sys.argv[1] if len(sys.argv) > 1 else os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TEX = os.path.join(ROOT, "data", "textures")
SCN = os.path.join(ROOT, "data", "scenes")


def write_png(path, img):
    """img: HxWx3 float in [0, 1] (sRGB-encoded values). Minimal PNG writer (RFC 2083)."""
    a = np.clip(np.round(img * 255), 0, 255).astype(np.uint8)
    h, w, _ = a.shape
    raw = b"".join(b"\x00" + a[y].tobytes() for y in range(h))

    def chunk(tag, data):
        c = struct.pack(">I", len(data)) + tag + data
        return c + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    with open(path, "wb") as f:
        f.write(png)


def value_noise(rng, h, w, cells):
    """Smooth noise: bilinear interpolation of a random lattice (tileable)."""
    g = rng.random((cells, cells))
    y = np.arange(h) * cells / h
    x = np.arange(w) * cells / w
    y0 = np.floor(y).astype(int)
    x0 = np.floor(x).astype(int)
    fy = (y - y0)[:, None]
    fx = (x - x0)[None, :]
    fy = fy * fy * (3 - 2 * fy)
    fx = fx * fx * (3 - 2 * fx)
    y1 = (y0 + 1) % cells
    x1 = (x0 + 1) % cells
    a = g[y0][:, x0]
    b = g[y0][:, x1]
    c = g[y1][:, x0]
    d = g[y1][:, x1]
    return (a * (1 - fx) + b * fx) * (1 - fy) + (c * (1 - fx) + d * fx) * fy


def ball_texture():
    """A striped billiard ball (u around, v from the top): white caps, a coloured band, and a
    white number disc on the band."""
    h, w = 128, 256
    v = (np.arange(h)[:, None] + 0.5) / h
    u = (np.arange(w)[None, :] + 0.5) / w
    img = np.ones((h, w, 3))
    band = np.abs(v - 0.5) < 0.2
    col = np.array([0.85, 0.55, 0.05])
    img[np.broadcast_to(band, (h, w))] = col
    for uc in (0.25, 0.75):
        du = (u - uc) * 2 * np.pi * np.sin(np.pi * v)
        dv = (v - 0.5) * np.pi
        disc = du * du + dv * dv < 0.28 ** 2
        img[disc] = 1.0
        ring = (du * du + dv * dv < 0.12 ** 2) & ((np.abs(du) < 0.03) | (np.abs(dv) < 0.03))
        img[ring] = 0.05
    return img


def wood_texture(rng):
    h, w = 128, 128
    n = value_noise(rng, h, w, 8)
    y = np.arange(h)[:, None] / h
    rings = 0.5 + 0.5 * np.sin(2 * np.pi * (12 * y + 3 * n))
    base = np.array([0.45, 0.28, 0.14])
    dark = np.array([0.28, 0.16, 0.07])
    t = rings[:, :, None]
    return base * (1 - t) + dark * t


def brick_texture(rng):
    h, w = 128, 128
    img = np.zeros((h, w, 3))
    n = value_noise(rng, h, w, 16)
    rows = 8
    bh = h // rows
    bw = w // 4
    for r in range(rows):
        off = (bw // 2) * (r % 2)
        for c in range(-1, 5):
            x0 = c * bw + off
            col = np.array([0.55, 0.22, 0.15]) * (0.8 + 0.4 * rng.random())
            ys = slice(r * bh + 1, (r + 1) * bh - 1)
            for x in range(x0 + 1, x0 + bw - 1):
                if 0 <= x < w:
                    img[ys, x] = col
    mortar = img.sum(2) == 0
    img[mortar] = 0.7
    return np.clip(img * (0.85 + 0.3 * n[:, :, None]), 0, 1)


def panel_texture(rng):
    """A train car's side: painted panel with a row of windows and a stripe."""
    h, w = 128, 256
    img = np.ones((h, w, 3)) * np.array([0.12, 0.3, 0.6])
    img[int(0.70 * h):int(0.76 * h)] = [0.9, 0.8, 0.1]
    for k in range(6):
        x0 = int((k + 0.2) * w / 6)
        x1 = int((k + 0.8) * w / 6)
        img[int(0.2 * h):int(0.55 * h), x0:x1] = [0.75, 0.85, 0.9]
        img[int(0.2 * h):int(0.55 * h), (x0 + x1) // 2] = [0.1, 0.1, 0.1]
    n = value_noise(rng, h, w, 16)[:, :, None]
    return np.clip(img * (0.9 + 0.2 * n), 0, 1)


def leaves_texture(rng):
    """Dense small leaves: random ellipses in greens over dark shadow."""
    h, w = 128, 128
    img = np.ones((h, w, 3)) * np.array([0.03, 0.08, 0.02])
    yy, xx = np.mgrid[0:h, 0:w]
    for _ in range(260):
        cy, cx = rng.random() * h, rng.random() * w
        a = rng.random() * np.pi
        ra, rb = 3 + 4 * rng.random(), 1.5 + 1.5 * rng.random()
        dy = (yy - cy + h / 2) % h - h / 2
        dx = (xx - cx + w / 2) % w - w / 2
        p = dx * np.cos(a) + dy * np.sin(a)
        q = -dx * np.sin(a) + dy * np.cos(a)
        m = (p / ra) ** 2 + (q / rb) ** 2 < 1
        g = 0.25 + 0.5 * rng.random()
        img[m] = [0.3 * g, g, 0.15 * g]
        vein = m & (np.abs(q) < 0.4)
        img[vein] = [0.5 * g, 1.2 * g if g < 0.8 else 0.95, 0.3 * g]
    return np.clip(img, 0, 1)


def grass_obj(rng, path):
    """Thin grass blades (one triangle each) on a 6 x 3 patch: dense sub-pixel geometry."""
    lines = ["# garden grass: generated by data/make_assets.py (seed 5)"]
    nb = 3000
    for i in range(nb):
        x = -2.0 + 4.0 * rng.random()
        z = -0.6 + 2.2 * rng.random()
        hgt = 0.15 + 0.25 * rng.random()
        wid = 0.008 + 0.01 * rng.random()
        a = rng.random() * np.pi
        lean = 0.08 * (rng.random() - 0.5)
        dx, dz = np.cos(a) * wid, np.sin(a) * wid
        lines.append(f"v {x - dx:.4f} 0 {z - dz:.4f}")
        lines.append(f"v {x + dx:.4f} 0 {z + dz:.4f}")
        lines.append(f"v {x + lean:.3f} {hgt:.3f} {z + lean * 0.5:.3f}")
    for i in range(nb):
        lines.append(f"f {3 * i + 1} {3 * i + 2} {3 * i + 3}")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def garden_scene(rng, path):
    out = []
    w = out.append
    w("# garden: dense thin geometry and textures (foliage, fences, grass): the paper's Fig. 3.")
    w("# Generated by data/make_assets.py (seed 5); static, so the plan picks T = 1.")
    w("camera { position 0 0.75 -1.3 target 0 0.45 2 up 0 1 0 fov 50 size 256 256 }")
    w("background 0.55 0.7 0.95")
    w("ambient_occlusion { samples 4 distance 0.6 color 0.35 0.4 0.5 }")
    w("light directional { direction -0.4 -1 0.6 irradiance 2.6 2.4 2.1 }")
    w('material soil { diffuse 0.25 0.18 0.1 }')
    w('material grass { diffuse 0.2 0.45 0.1 }')
    w('material wood { texture "../textures/wood.png" uv_scale 4 4 }')
    w('material leaves { texture "../textures/leaves.png" uv_scale 1.5 1.5 }')
    w('material wall { texture "../textures/bricks.png" uv_scale 1 1 }')
    w("plane { corner -20 0 -20 edge_u 40 0 0 edge_v 0 0 40 material soil }")
    w('mesh { file "garden_grass.obj" material grass }')
    w("# picket fence: 61 thin pickets and two rails")
    for i in range(61):
        x = -3.0 + i * 0.1
        w(f"box {{ min {x - 0.018:.3f} 0 1.6 max {x + 0.018:.3f} 0.9 1.62 material wood }}")
    w("box { min -3.1 0.25 1.62 max 3.1 0.29 1.64 material wood }")
    w("box { min -3.1 0.7 1.62 max 3.1 0.74 1.64 material wood }")
    w("# a brick wall behind the fence")
    w("plane { corner -8 0 4 edge_u 16 0 0 edge_v 0 2.2 0 material wall }")
    w("# bushes: clusters of small leaf cards at random orientations")
    for b in range(5):
        cx, cz = -2.0 + 1.0 * b + 0.3 * rng.random(), (1.2 if b % 2 else 2.3) + 0.2 * rng.random()
        for k in range(70):
            c = np.array([cx, 0.55, cz]) + rng.normal(size=3) * np.array([0.35, 0.25, 0.3])
            c[1] = abs(c[1]) + 0.05
            u = rng.normal(size=3)
            u /= np.linalg.norm(u)
            v = np.cross(u, rng.normal(size=3))
            v /= np.linalg.norm(v)
            s = 0.08 + 0.06 * rng.random()
            corner = c - 0.5 * s * (u + v)
            w("plane { corner %.4f %.4f %.4f edge_u %.4f %.4f %.4f edge_v %.4f %.4f %.4f material leaves }"
              % (*corner, *(s * u), *(s * v)))
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")


def main():
    os.makedirs(TEX, exist_ok=True)
    os.makedirs(SCN, exist_ok=True)
    rng = np.random.default_rng(5)
    write_png(os.path.join(TEX, "ball.png"), ball_texture())
    write_png(os.path.join(TEX, "wood.png"), wood_texture(rng))
    write_png(os.path.join(TEX, "bricks.png"), brick_texture(rng))
    write_png(os.path.join(TEX, "panel.png"), panel_texture(rng))
    write_png(os.path.join(TEX, "leaves.png"), leaves_texture(rng))
    grass_obj(np.random.default_rng(5), os.path.join(SCN, "garden_grass.obj"))
    garden_scene(np.random.default_rng(6), os.path.join(SCN, "garden.scene"))


if __name__ == "__main__":
    main()
