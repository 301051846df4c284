#!/usr/bin/env python3
"""Writes the fuzzers' seed corpora (tests/fuzz/corpus/<target>/), committed beside this script.

dump and recon: small sample dumps (docs/dump-format.md) of every kind the reader and the
methods meet: static and moving grids, 1 to 4 channels, unsorted records with duplicates, an odd
width (clFFT's path), a NaN record, a positions request, extreme magnitudes; for recon the
header's seed field selects the estimator, solver and options (tests/fuzz/fuzz_recon.c), and a
few carry the exact-values flag (and one a reserved flag bit, refused).
scene: the bundled scenes (but the 44 KB garden) and the command-line tests' scenes, plus scenes
using the test data's OBJ and PNG. obj: the tracer tests' OBJ files and the head of the garden's
grass. partial: tile partials (docs/partial-format.md) that csi-reconstruct --tile writes from
some of the dumps (static and moving, 1 to 3 channels, with frames, ROMP and the Gaussian
baseline, a layout of one tile that a merge blends alone), made with the programs of the build
given as the argument (default: build), their timings set to 0 and the checksum recomputed here
so that the bytes do not depend on the run (they do on the library's pixels), and two whose
layout claims a huge image or tile count (regressions of the merge). Deterministic (seeded).
Inputs a fuzzer found (FOUND: regressions committed beside the seeds, not made here) are kept;
every other file of the corpus is written anew."""
import os
import random
import struct
import subprocess
import sys
import tempfile

here = os.path.dirname(os.path.abspath(__file__))
root = os.path.dirname(os.path.dirname(here))
out = os.path.join(here, "corpus")


def dump(grid, outsz, records, channels, seed=0, flags=0):
    w, h, t = grid
    hdr = b"CSID" + struct.pack("<7I", 1, w, h, t, outsz[0], outsz[1], channels)
    hdr += struct.pack("<QQI", len(records), seed, flags) + bytes(12)
    body = b"".join(struct.pack("<3I", *p) + struct.pack("<%df" % channels, *v) for p, v in records)
    return hdr + body


def random_records(rng, grid, n, channels, scale=1.0, sort=True, dup=0):
    w, h, t = grid
    cells = rng.sample(range(w * h * t), n)
    if sort:
        cells.sort()
    cells += cells[:dup]
    rec = []
    for c in cells:
        p = (c % w, (c // w) % h, c // (w * h))
        rec.append((p, [scale * rng.uniform(0, 1) for _ in range(channels)]))
    return rec


M64 = (1 << 64) - 1


def mix64(z):
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & M64
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & M64
    return z ^ (z >> 31)


def hash64(h, data):
    """csi_hash64 (docs/partial-format.md)."""
    n8 = len(data) // 8 * 8
    for i in range(0, n8, 8):
        h = mix64(h ^ struct.unpack_from("<Q", data, i)[0])
    h = mix64(h ^ int.from_bytes(data[n8:], "little"))
    return mix64(h ^ len(data))


def options_end(b):
    """Where a partial's layout starts: after its two option blocks, as given and as reported
    (docs/partial-format.md), each a count and that many 96-byte name-value pairs."""
    at = 272
    for _ in range(2):
        at += 8 + 96 * struct.unpack_from("<Q", b, at)[0]
    return at


def untimed_partial(b):
    """A partial with its seconds (the tile's 10, each channel report's 5) set to 0 and the
    checksum recomputed; the offsets follow docs/partial-format.md."""
    b = bytearray(b)
    at = options_end(b) + (5 * 8 + 3 * 8 + 3 * 48 + 8 + 8 + 3 * 8) + (2 * 8 + 3 * 8 + 8 + 4 * 8)
    channels = struct.unpack_from("<Q", b, at + 48)[0]
    at += 8 * 8 + 8 + 8 + 8 + 3 * 8  # the window, solver, model_factor, chroma_model_factor, k, n, unknowns
    b[at:at + 80] = bytes(80)
    at += 80
    for _ in range(channels):
        b[at + 96:at + 136] = bytes(40)
        at += 336
    struct.pack_into("<Q", b, len(b) - 8, hash64(0, bytes(b[:-8])))
    return bytes(b)


def relaid_partial(b, size, n, window):
    """A partial whose layout (docs/partial-format.md) claims a size x size image in n x n tiles
    of the given window, its checksum recomputed: layouts that a merge of that file alone once
    allocated for before it refused them (14 GB for the image, 34 GB for the tiles' paths)."""
    b = bytearray(b)
    at = options_end(b)
    struct.pack_into("<8Q", b, at, size, size, 1, size, size, size, size, 1)  # the grid, the image's size
    for a, (length, tiles, win) in enumerate(((size, n, window), (size, n, window), (1, 1, 1))):
        struct.pack_into("<6Q", b, at + 64 + 48 * a, length, tiles, win, 0, 1, 1)
    struct.pack_into("<Q", b, at + 208, n * n)
    struct.pack_into("<2Q", b, at + 264, size, size)  # the scope's out_w, out_h
    struct.pack_into("<Q", b, len(b) - 8, hash64(0, bytes(b[:-8])))
    return bytes(b)


# (target, name) of the inputs the fuzzers found, committed by hand: left in place
FOUND = {("recon", "velocity_walk")}


def clear_corpus():
    """Removes every file of the corpus but the FOUND ones."""
    for sub in os.listdir(out) if os.path.isdir(out) else []:
        d = os.path.join(out, sub)
        for name in os.listdir(d):
            if (sub, name) not in FOUND:
                os.remove(os.path.join(d, name))


def write(sub, name, data):
    d = os.path.join(out, sub)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), "wb") as f:
        f.write(data)


def main():
    build = sys.argv[1] if len(sys.argv) > 1 else os.path.join(root, "build")
    recon = os.path.join(build, "csi-reconstruct")
    if not os.access(recon, os.X_OK):
        sys.exit("make_seeds.py: %s is not a program: give the build directory" % recon)
    clear_corpus()
    dumps = {}
    rng = random.Random(14)
    cases = [
        ("static_y", (8, 8, 1), (2, 2), 16, 1, {}),
        ("static_rgb_dup", (16, 16, 1), (4, 4), 40, 3, {"sort": False, "dup": 5}),
        ("moving_ya", (8, 8, 4), (2, 2), 30, 2, {}),
        ("moving_rgb", (16, 16, 8), (4, 4), 120, 3, {"sort": False}),
        ("odd_width", (15, 15, 1), (5, 5), 40, 1, {}),
        ("odd_moving", (15, 16, 4), (5, 4), 60, 1, {}),
        ("rgba_big_values", (16, 8, 1), (4, 2), 30, 4, {"scale": 1e30}),
        ("tiny_values", (8, 8, 1), (4, 4), 20, 1, {"scale": 1e-30}),
    ]
    for i, (name, grid, osz, n, ch, kw) in enumerate(cases):
        rec = random_records(rng, grid, n, ch, **kw)
        dumps[name] = dump(grid, osz, rec, ch, seed=i)
        write("dump", name, dumps[name])
        # recon: the seed field picks the options: estimator (bits 0-1), ROMP (2), frames (3),
        # full spectrum (4), model grid off (5), two tiles (6), iterations (8-10), a volume's
        # velocity (11-12: estimate, none, given by bytes 4 and 5 in eighths of a cell per
        # frame) and time transform (13-14: auto, dft, dct)
        sels = (0, 1, 2, 4 | 32, 8 | 16, 64, 3 << 8)
        if grid[2] > 1:
            sels += (1 << 11, 2 << 11 | 12 << 32 | 0xF8 << 40, 1 << 11 | 2 << 13, 2 << 11 | 20 << 32 | 1 << 13)
        for sel in sels:
            if grid[0] % 2 == 0:  # odd widths run on clFFT, left out of fuzz_recon
                write("recon", "%s_%x" % (name, sel), dump(grid, osz, rec, ch, seed=sel))
        if name in ("static_y", "static_rgb_dup"):
            # the exact-values flag (byte 48): --correct auto takes cv instead of the blend
            write("dump", name + "_exact", dump(grid, osz, rec, ch, seed=i, flags=1))
            for sel in (0, 64):
                write("recon", "%s_exact_%x" % (name, sel), dump(grid, osz, rec, ch, seed=sel, flags=1))
            if name == "static_y":  # a flag bit no reader knows: refused
                write("dump", "flags_reserved_bit", dump(grid, osz, rec, ch, seed=i, flags=3))
    nan = random_records(rng, (8, 8, 1), 10, 1)
    nan[3] = (nan[3][0], [float("nan")])
    write("dump", "nan_record", dump((8, 8, 1), (2, 2), nan, 1))
    req = dump((8, 8, 1), (2, 2), [((i, i, 0), []) for i in range(8)], 0)
    write("dump", "positions_request", req)
    write("dump", "truncated", dump((8, 8, 1), (2, 2), random_records(rng, (8, 8, 1), 4, 1), 1)[:70])

    scenes = [os.path.join(root, "data", "scenes", s + ".scene")
              for s in ("triangle", "checkerboard", "billiards", "train")]
    scenes += [os.path.join(root, "tests", "cli", "scenes", s)
               for s in sorted(os.listdir(os.path.join(root, "tests", "cli", "scenes")))]
    for s in scenes:
        write("scene", os.path.basename(s), open(s, "rb").read())
    cam = b"camera { position 0 0 -3 target 0 0 0 size 16 16 }\n"
    write("scene", "obj_mesh", cam + b'material m { diffuse 0.5 0.5 0.5 }\nmesh { file "quad.obj" material m }\n')
    write("scene", "texture", cam + b'material t { texture "empty.png" }\nsphere { center 0 0 0 radius 1 material t }\n')
    write("scene", "motion_effects", cam + b"shutter 0 2\nframes 16\nambient_occlusion { samples 2 }\n"
          b"path_tracing { max_bounces 2 }\nmaterial m { checker 1 0 0 0 0 1 0.25 uv_scale 2 2 }\n"
          b"box { min -1 -1 -1 max 1 1 1 material m motion { key 0 { rotate 0 1 0 30 } key 2 { translate 1 0 0 "
          b"scale 2 } } }\nlight area { corner -1 3 -1 edge_u 2 0 0 edge_v 0 0 2 radiance 4 4 4 samples 2 }\n")
    # partials: (dump, seed name, csi-reconstruct's arguments)
    partials = [
        ("static_y", "static_y_whole", ["--tile", "0/1"]),
        ("static_rgb32", "static_rgb_tile2of4", ["--tile", "2/4", "--tile-margin", "2"]),
        ("static_rgb32", "static_rgb_romp_whole", ["--tile", "0/1", "--solver", "romp"]),
        ("moving_y32", "moving_y_frames", ["--tile", "1/2", "--partial-frames", "--tile-margin", "4", "--tile-margin-t", "2"]),
        ("moving_ya", "moving_ya_gauss_whole", ["--tile", "0/1", "--partial-frames", "--estimator", "gauss"]),
        # a side the FFT cannot take: tiles of the padded 40x24 grid, cut to 37x23 at the merge
        ("static_y37", "static_y_padded_tile1of2", ["--tile", "1/2", "--tile-margin", "4"]),
    ]
    prng = random.Random(1414)  # its own: the other corpora stay as they were
    dumps["static_rgb32"] = dump((32, 32, 1), (32, 32), random_records(prng, (32, 32, 1), 200, 3), 3)
    dumps["moving_y32"] = dump((32, 16, 4), (32, 16), random_records(prng, (32, 16, 4), 200, 1), 1)
    dumps["static_y37"] = dump((37, 23, 1), (37, 23), random_records(prng, (37, 23, 1), 200, 1), 1)
    with tempfile.TemporaryDirectory() as tmp:
        for src, name, args in partials:
            dpath, ppath = os.path.join(tmp, src + ".csid"), os.path.join(tmp, name + ".csip")
            with open(dpath, "wb") as f:
                f.write(dumps[src])
            subprocess.run([recon, dpath, "-o", ppath, "-q", "--max-iter", "4"] + args, check=True)
            write("partial", name, untimed_partial(open(ppath, "rb").read()))
    whole = open(os.path.join(out, "partial", "static_y_whole"), "rb").read()  # a 2x2 window
    write("partial", "huge_image_one_tile", relaid_partial(whole, 60000, 1, 2))
    write("partial", "huge_tile_count", relaid_partial(whole, 65536, 65535, 2))
    data = os.path.join(root, "tests", "tracer", "data")
    for f in sorted(os.listdir(data)):
        if f.endswith(".obj"):
            write("obj", f, open(os.path.join(data, f), "rb").read())
    grass = open(os.path.join(root, "data", "scenes", "garden_grass.obj"), "rb").read().split(b"\n")
    write("obj", "grass_head", b"\n".join(grass[:60]) + b"\n")


if __name__ == "__main__":
    main()
