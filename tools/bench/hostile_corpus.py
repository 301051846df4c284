#!/usr/bin/env python3
"""Hostile inputs against csi's programs (issue 14), counted: crashes, hangs, files left behind by
failed runs, inputs overwritten, multi-line or raw-control-character messages, and how long
oversized inputs take to be refused.

The corpus is rebuilt here (seeded), in classes:
  dump      truncations and byte mutations of small valid dumps, header fields set to edge values
            (zero, huge, non-divisible sizes, channels 0 and 5, counts off by one, reserved bytes,
            NaN/Inf/1e20/1e38/subnormal values, positions outside, t != 0 when static)
  oversized dumps and scenes whose sizes cannot fit (16384^2 with one sample, 65536^2, grid_t =
            65536, scenes of 8192^2 and 16384^2 pixels, frames 4096, --spp 65536); each must be
            refused (or run) within the 20 s limit; the time to a refusal is reported
  scene     truncations and token mutations of the bundled and test scenes, OBJ files with lines
            over 4095 bytes, missing or directory textures
  input     FIFOs, /dev/zero, directories, names with terminal escape sequences
  output    an output naming an input (-o, --png, --stats, --dump, hard and symbolic links), two
            outputs to one file, --png/--stats naming a directory after a good -o, --frames into a
            file or under bad input, missing directories, and a write failure injected after each
            output file (CSI_FAIL_OUTPUT, ignored by builds that do not know it)

Every case runs with a 20 s limit (then SIGTERM, and SIGKILL 2 s later) in a fresh directory
holding its inputs; afterwards the directory must hold only the inputs (unchanged) when the
program failed or was stopped. The programs run with CSI_PROGRESS=PROGRESS_EVERY (a progress line
on stderr at most every few seconds, as in a log). A run stopped at 20 s is "stopped"; it is a
hang when its last progress line came more than PROGRESS_QUIET seconds before the stop (or never),
i.e. it was not advancing: an input that fits may be legitimate work that takes longer, and the
report lists every stopped run with what it was doing. A run stopped after its summary line (the
work done and the outputs committed, the stop in its teardown) is "completed": its outputs are
not counted as left behind.

  python3 tools/bench/hostile_corpus.py BUILD_DIR [--out report.json] [--only CLASS] [--quick]

The programs come from BUILD_DIR (csi-render, csi-reconstruct, csi-mkdump); the bundled scenes
and test data from this source tree."""
import argparse
import hashlib
import json
import os
import random
import re
import shutil
import signal
import stat
import struct
import subprocess
import sys
import tempfile
import time

SRC = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
LIMIT = 20.0
PROGRESS_EVERY = 2.0
# a progress line is due every PROGRESS_EVERY seconds while a phase reports; allow a phase step
# (a kernel, a tracing batch) several times that long between reports before calling it stuck
PROGRESS_QUIET = 8.0
PROGRESS_LINE = re.compile(r"^[\w.-]+: progress: .*\[(\d+) s\]$")
# the summary line a program prints after it committed its outputs ("csi-reconstruct: 64x64 from
# 4096 samples ...", "csi-render: 64x64 from ... samples (...) : render ..."); a run stopped after
# it finished the work and committed (at the limit, in its teardown) left its outputs, not litter
DONE_LINE = re.compile(r"^csi-[\w-]+: \d+x\d+.* from \d+ (samples|tiles)\b", re.M)


def dump_bytes(grid, out, records, channels, seed=0, count=None):
    w, h, t = grid
    n = len(records) if count is None else count
    hdr = b"CSID" + struct.pack("<7I", 1, w, h, t, out[0], out[1], channels) + struct.pack("<QQ", n, seed)
    hdr += bytes(16)
    return hdr + b"".join(struct.pack("<3I", *p) + struct.pack("<%df" % channels, *v) for p, v in records)


def records(rng, grid, n, channels, values=None):
    w, h, t = grid
    cells = sorted(rng.sample(range(w * h * t), n))
    return [((c % w, (c // w) % h, c // (w * h)),
             [values(rng) if values else rng.uniform(0, 1) for _ in range(channels)]) for c in cells]


class Case:
    def __init__(self, cls, name, prog, args, files=None, env=None, fifo=(), oversized=False, link=None):
        self.cls, self.name, self.prog, self.args = cls, name, prog, args
        self.files = files or {}  # name -> bytes (inputs written into the case's directory)
        self.env = env or {}
        self.fifo = fifo          # names of FIFOs to make
        self.oversized = oversized
        self.link = link or []    # (kind, target, name): "hard" / "sym" links to make


def digest(d):
    out = {}
    for root, dirs, files in os.walk(d):
        for f in files + [x for x in dirs]:
            p = os.path.join(root, f)
            rel = os.path.relpath(p, d)
            st = os.lstat(p)
            if stat.S_ISREG(st.st_mode):
                with open(p, "rb") as fh:
                    out[rel] = hashlib.sha1(fh.read()).hexdigest()
            else:
                out[rel] = "dir" if stat.S_ISDIR(st.st_mode) else "special"
    return out


def run(build, case):
    d = tempfile.mkdtemp(prefix="hostile-")
    try:
        for name, data in case.files.items():
            p = os.path.join(d, name)
            os.makedirs(os.path.dirname(p), exist_ok=True)
            if data is None:
                os.makedirs(p, exist_ok=True)
            else:
                with open(p, "wb") as f:
                    f.write(data)
        for name in case.fifo:
            os.mkfifo(os.path.join(d, name))
        for kind, target, name in case.link:
            (os.link if kind == "hard" else os.symlink)(os.path.join(d, target), os.path.join(d, name))
        before = digest(d)
        args = [a.replace("@", d) for a in case.args]
        env = dict(os.environ, CSI_PROGRESS="%g" % PROGRESS_EVERY, **case.env)
        t0 = time.monotonic()
        p = subprocess.Popen([os.path.join(build, case.prog)] + args, cwd=d, env=env, stdout=subprocess.DEVNULL,
                             stderr=subprocess.PIPE, start_new_session=True)
        try:
            _, err = p.communicate(timeout=LIMIT)
            rc = p.returncode
        except subprocess.TimeoutExpired:
            # as timeout(1) does: SIGTERM first (a program may clean up), SIGKILL 2 s later
            os.killpg(p.pid, signal.SIGTERM)
            try:
                _, err = p.communicate(timeout=2)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
                _, err = p.communicate()
            rc = "stopped"
        dt = time.monotonic() - t0
        after = digest(d)
        res = {"class": case.cls, "name": case.name, "rc": rc, "seconds": round(dt, 3)}
        text = err.decode("utf-8", "replace")
        progress = [int(m.group(1)) for m in map(PROGRESS_LINE.match, text.splitlines()) if m]
        res["crash"] = rc != "stopped" and (rc < 0 or rc >= 128 or "AddressSanitizer" in text or
                                         "runtime error:" in text or "Assertion" in text)
        res["stopped"] = rc == "stopped"
        res["completed"] = rc == "stopped" and bool(DONE_LINE.search(text))
        res["last_progress_s"] = progress[-1] if progress else None
        res["hang"] = (rc == "stopped" and not res["completed"] and
                       (not progress or progress[-1] < LIMIT - PROGRESS_QUIET))
        changed = [k for k, v in before.items() if after.get(k) != v]
        res["inputs_changed"] = changed
        if rc != 0 and not res["completed"]:
            res["left_behind"] = sorted(k for k in after if k not in before)
            lines = [l for l in text.splitlines() if "warning" not in l and not PROGRESS_LINE.match(l)]
            res["error_lines"] = len(lines)
        else:
            res["left_behind"] = []
            res["error_lines"] = 0
        res["raw_control"] = any(c in text for c in "\x1b\x07\x08\x9b")
        res["stderr"] = text[-300:]
        return res
    finally:
        for root, dirs, files in os.walk(d):
            for x in dirs:
                os.chmod(os.path.join(root, x), 0o755)
        shutil.rmtree(d, ignore_errors=True)


def corpus(quick):
    rng = random.Random(14)
    cases = []
    static = open(os.path.join(SRC, "tests/cli/scenes/small_triangle.scene"), "rb").read()
    moving = open(os.path.join(SRC, "tests/cli/scenes/small_moving.scene"), "rb").read()
    png = open(os.path.join(SRC, "tests/data/io/img_rgb.png"), "rb").read()
    fast = ["--max-iter", "20", "-q"]

    # --- dumps ------------------------------------------------------------------------------------
    good = {
        "static": dump_bytes((16, 16, 1), (4, 4), records(rng, (16, 16, 1), 64, 3), 3),
        "moving": dump_bytes((16, 16, 8), (4, 4), records(rng, (16, 16, 8), 200, 1), 1),
    }
    for gname, data in good.items():
        step = max(1, len(data) // (10 if quick else 60))
        for cut in range(0, len(data), step):
            cases.append(Case("dump", "%s truncated at %d" % (gname, cut), "csi-reconstruct",
                              ["@/d.csid", "-o", "@/o.exr"] + fast, {"d.csid": data[:cut]}))
        for i in range(10 if quick else 150):
            b = bytearray(data)
            for _ in range(rng.randint(1, 4)):
                pos = rng.randrange(len(b)) if rng.random() < 0.5 else rng.randrange(64)
                b[pos] = rng.randrange(256)
            cases.append(Case("dump", "%s mutated %d" % (gname, i), "csi-reconstruct",
                              ["@/d.csid", "-o", "@/o.exr"] + fast, {"d.csid": bytes(b)}))
    edge_fields = [(8, 0), (8, 3), (8, 65537), (12, 0), (16, 0), (16, 1025), (20, 0), (20, 3), (24, 7),
                   (28, 0), (28, 5), (28, 0xFFFFFFFF), (32, 0), (32, 65), (32, 63), (32, 0xFFFFFFFF),
                   (56, 7), (4, 2)]
    base = bytearray(good["static"])
    for off, val in edge_fields:
        b = bytearray(base)
        b[off:off + 4] = struct.pack("<I", val)
        cases.append(Case("dump", "field %d = %d" % (off, val), "csi-reconstruct", ["@/d.csid", "-o", "@/o.exr"] + fast,
                          {"d.csid": bytes(b)}))
    for label, fn in [("1e20", lambda r: 1e20), ("3e38", lambda r: 3.0e38 * r.uniform(0.5, 1)),
                      ("-1e30", lambda r: -1e30 * r.uniform(0, 1)), ("subnormal", lambda r: 1e-44),
                      ("1e-30", lambda r: 1e-30 * r.uniform(0, 1)), ("mixed", lambda r: r.choice([1e30, 1e-30, -5, 0])),
                      ("nan", lambda r: float("nan")), ("inf", lambda r: float("inf"))]:
        for gname, grid, ch in [("static", (16, 16, 1), 3), ("moving", (16, 16, 8), 1)]:
            data = dump_bytes(grid, (4, 4), records(rng, grid, 60, ch, fn), ch)
            cases.append(Case("dump", "%s values %s" % (gname, label), "csi-reconstruct",
                              ["@/d.csid", "-o", "@/o.exr"] + fast, {"d.csid": data}))
            for est in ("mean", "gauss"):
                cases.append(Case("dump", "%s values %s, %s" % (gname, label, est), "csi-reconstruct",
                                  ["@/d.csid", "-o", "@/o.exr", "--estimator", est] + fast, {"d.csid": data}))
    outside = dump_bytes((8, 8, 1), (2, 2), [((9, 0, 0), [1.0]), ((0, 0, 1), [1.0])], 1)
    cases.append(Case("dump", "positions outside", "csi-reconstruct", ["@/d.csid", "-o", "@/o.exr"], {"d.csid": outside}))

    # --- oversized ----------------------------------------------------------------------------------
    one = lambda grid, out, ch=3: dump_bytes(grid, out, [((0, 0, 0), [0.5] * ch)], ch)
    for name, data in [("16384^2, one sample", one((16384, 16384, 1), (4096, 4096))),
                       ("16384^2 -> 8192^2, one sample", one((16384, 16384, 1), (8192, 8192))),
                       ("65536^2", one((65536, 65536, 1), (65536, 65536))),
                       ("65536 x 32768 full resolution", one((65536, 32768, 1), (65536, 32768))),
                       ("grid_t 65536, 48 samples", dump_bytes((4, 4, 65536), (1, 1),
                                                               records(rng, (4, 4, 65536), 48, 1), 1)),
                       ("grid_t 4096, 48 samples", dump_bytes((4, 4, 4096), (1, 1),
                                                              records(rng, (4, 4, 4096), 48, 1), 1))]:
        cases.append(Case("oversized", name, "csi-reconstruct", ["@/d.csid", "-o", "@/o.exr"], {"d.csid": data},
                          oversized=True))
        cases.append(Case("oversized", name + ", mean", "csi-reconstruct",
                          ["@/d.csid", "-o", "@/o.exr", "--estimator", "mean"], {"d.csid": data}, oversized=True))
    for size in (4096, 8192, 16384):
        sc = static.replace(b"size 32 32", b"size %d %d" % (size, size))
        cases.append(Case("oversized", "scene %d^2" % size, "csi-render", ["@/s.scene", "-o", "@/o.exr"],
                          {"s.scene": sc}, oversized=True))
    cases.append(Case("oversized", "frames 4096", "csi-render", ["@/s.scene", "-o", "@/o.exr"],
                      {"s.scene": moving.replace(b"frames 8", b"frames 4096")}, oversized=True))
    cases.append(Case("oversized", "frames 1024 at 256^2", "csi-render", ["@/s.scene", "-o", "@/o.exr"],
                      {"s.scene": moving.replace(b"frames 8", b"frames 1024").replace(b"size 32 32", b"size 256 256")},
                      oversized=True))
    cases.append(Case("oversized", "--spp 65536", "csi-render", ["@/s.scene", "-o", "@/o.exr", "--spp", "65536"],
                      {"s.scene": static}, oversized=True))
    cases.append(Case("oversized", "--time-steps 4096", "csi-render",
                      ["@/s.scene", "-o", "@/o.exr", "--time-steps", "4096"], {"s.scene": moving}, oversized=True))

    # --- scenes -------------------------------------------------------------------------------------
    scenes = {"static": static, "moving": moving}
    for s in ("triangle", "checkerboard", "train"):
        scenes[s] = open(os.path.join(SRC, "data/scenes/%s.scene" % s), "rb").read().replace(
            b"size 256 256", b"size 32 32")
    tokens = [b"{", b"}", b'"', b"#", b"nan", b"inf", b"1e999", b"-1", b"0", b"65536", b"camera", b"motion", b"key",
              b"frames", b"\x00", b"\x1b[31m", b"mesh", b"file", b"texture"]
    for sname, text in scenes.items():
        for i in range(4 if quick else 40):
            b = bytearray(text)
            for _ in range(rng.randint(1, 3)):
                pos = rng.randrange(len(b))
                if rng.random() < 0.5:
                    b[pos:pos + rng.randint(1, 8)] = rng.choice(tokens)
                else:
                    b[pos] = rng.randrange(256)
            cases.append(Case("scene", "%s mutated %d" % (sname, i), "csi-render", ["@/s.scene", "-o", "@/o.exr"] + fast,
                              {"s.scene": bytes(b)}))
        for cut in range(0, len(text), max(1, len(text) // (3 if quick else 15))):
            cases.append(Case("scene", "%s truncated at %d" % (sname, cut), "csi-render",
                              ["@/s.scene", "-o", "@/o.exr"] + fast, {"s.scene": text[:cut]}))
    cam = b"camera { position 0 0 -3 target 0 0 0 size 16 16 }\nmaterial m { diffuse 1 1 1 }\n"
    long_obj = b"v 0 0 0" + b" " * 5000 + b"\nv 1 0 0\nv 0 1 0\nf 1 2 3" + b" " * 5000 + b"\n"
    cases.append(Case("scene", "OBJ with 5000-byte lines", "csi-render", ["@/s.scene", "-o", "@/o.exr"] + fast,
                      {"s.scene": cam + b'mesh { file "m.obj" material m }\n', "m.obj": long_obj}))
    cases.append(Case("scene", "OBJ missing", "csi-render", ["@/s.scene", "-o", "@/o.exr"],
                      {"s.scene": cam + b'mesh { file "none.obj" material m }\n'}))
    cases.append(Case("scene", "OBJ is a directory", "csi-render", ["@/s.scene", "-o", "@/o.exr"],
                      {"s.scene": cam + b'mesh { file "dir" material m }\n', "dir": None}))
    cases.append(Case("scene", "texture is a directory", "csi-render", ["@/s.scene", "-o", "@/o.exr"],
                      {"s.scene": cam + b'material t { texture "dir" }\n', "dir": None}))
    cases.append(Case("scene", "texture is /dev/zero", "csi-render", ["@/s.scene", "-o", "@/o.exr"],
                      {"s.scene": cam + b'material t { texture "/dev/zero" }\n'}))
    cases.append(Case("scene", "OBJ is /dev/zero", "csi-render", ["@/s.scene", "-o", "@/o.exr"],
                      {"s.scene": cam + b'mesh { file "/dev/zero" material m }\n'}))

    # --- inputs -------------------------------------------------------------------------------------
    cases.append(Case("input", "FIFO dump", "csi-reconstruct", ["@/f.csid", "-o", "@/o.exr"], fifo=["f.csid"]))
    cases.append(Case("input", "FIFO scene", "csi-render", ["@/f.scene", "-o", "@/o.exr"], fifo=["f.scene"]))
    cases.append(Case("input", "FIFO image", "csi-mkdump", ["@/f.png", "-o", "@/o.csid", "--out", "4x3"], fifo=["f.png"]))
    cases.append(Case("input", "FIFO texture", "csi-render", ["@/s.scene", "-o", "@/o.exr"],
                      {"s.scene": cam + b'material t { texture "f.png" }\n'}, fifo=["f.png"]))
    cases.append(Case("input", "/dev/zero scene", "csi-render", ["/dev/zero", "-o", "@/o.exr"]))
    cases.append(Case("input", "/dev/zero dump", "csi-reconstruct", ["/dev/zero", "-o", "@/o.exr"]))
    cases.append(Case("input", "directory dump", "csi-reconstruct", ["@/dir", "-o", "@/o.exr"], {"dir": None}))
    cases.append(Case("input", "directory scene", "csi-render", ["@/dir", "-o", "@/o.exr"], {"dir": None}))
    cases.append(Case("input", "escape sequence in a name", "csi-reconstruct", ["@/\x1b[31mred\x07.csid", "-o", "@/o.exr"]))
    cases.append(Case("input", "escape sequence in a scene token", "csi-render", ["@/s.scene", "-o", "@/o.exr"],
                      {"s.scene": b"\x1b[2J\x1b[31mcamera\n"}))

    # --- outputs ------------------------------------------------------------------------------------
    d = good["static"]
    cases += [
        Case("output", "dump -o itself", "csi-reconstruct", ["@/d.csid", "-o", "@/d.csid"] + fast, {"d.csid": d}),
        Case("output", "dump --stats itself", "csi-reconstruct", ["@/d.csid", "-o", "@/o.exr", "--stats", "@/d.csid"] + fast,
             {"d.csid": d}),
        Case("output", "dump --png hard link", "csi-reconstruct", ["@/d.csid", "-o", "@/o.exr", "--png", "@/h.csid"] + fast,
             {"d.csid": d}, link=[("hard", "d.csid", "h.csid")]),
        Case("output", "dump -o symlink", "csi-reconstruct", ["@/d.csid", "-o", "@/l.csid"] + fast, {"d.csid": d},
             link=[("sym", "d.csid", "l.csid")]),
        Case("output", "scene -o itself", "csi-render", ["@/s.scene", "-o", "@/s.scene"] + fast, {"s.scene": static}),
        Case("output", "scene --dump itself", "csi-render", ["@/s.scene", "-o", "@/o.exr", "--dump", "@/s.scene"] + fast,
             {"s.scene": static}),
        Case("output", "texture as --png", "csi-render", ["@/s.scene", "-o", "@/o.exr", "--png", "@/t.png"] + fast,
             {"s.scene": cam + b'material t { texture "t.png" }\nsphere { center 0 0 0 radius 1 material t }\n',
              "t.png": png}),
        Case("output", "mkdump -o its image", "csi-mkdump", ["@/i.png", "-o", "@/i.png", "--out", "4x3"], {"i.png": png}),
        Case("output", "-o and --png one file", "csi-reconstruct", ["@/d.csid", "-o", "@/o.exr", "--png", "@/o.exr"] + fast,
             {"d.csid": d}),
        Case("output", "--png directory after -o", "csi-reconstruct", ["@/d.csid", "-o", "@/o.exr", "--png", "@/dir"] + fast,
             {"d.csid": d, "dir": None}),
        Case("output", "--stats directory after -o", "csi-render", ["@/s.scene", "-o", "@/o.exr", "--stats", "@/dir"] + fast,
             {"s.scene": static, "dir": None}),
        Case("output", "--dump directory", "csi-render", ["@/s.scene", "-o", "@/o.exr", "--dump", "@/dir"] + fast,
             {"s.scene": static, "dir": None}),
        Case("output", "--frames on bad input", "csi-reconstruct", ["@/d.csid", "-o", "@/o.exr", "--frames", "@/fr"],
             {"d.csid": b"XXXX"}),
        Case("output", "--frames into a file", "csi-render", ["@/s.scene", "-o", "@/o.exr", "--frames", "@/f"] + fast,
             {"s.scene": moving, "f": b"x"}),
        Case("output", "missing output directory", "csi-reconstruct", ["@/d.csid", "-o", "@/no/o.exr"] + fast, {"d.csid": d}),
        Case("output", "output /dev/null", "csi-reconstruct", ["@/d.csid", "-o", "/dev/null/x.exr"] + fast, {"d.csid": d}),
    ]
    for n in range(1, 30):
        cases.append(Case("output", "write failure at output event %d" % n, "csi-render",
                          ["@/s.scene", "-o", "@/o.exr", "--png", "@/o.png", "--stats", "@/o.json", "--dump", "@/o.csid",
                           "--frames", "@/fr", "--time-steps", "2", "--spp", "1"] + fast,
                          {"s.scene": moving}, env={"CSI_FAIL_OUTPUT": str(n)}))
    return cases


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("build")
    ap.add_argument("--out")
    ap.add_argument("--only")
    ap.add_argument("--quick", action="store_true")
    a = ap.parse_args()
    build = os.path.abspath(a.build)
    cases = [c for c in corpus(a.quick) if not a.only or c.cls == a.only]
    results = []
    t0 = time.monotonic()
    for i, c in enumerate(cases):
        results.append(run(build, c))
        if (i + 1) % 50 == 0:
            print("%d/%d cases, %.0f s" % (i + 1, len(cases), time.monotonic() - t0), file=sys.stderr)
    summary = {"build": build, "cases": len(results), "by_class": {}}
    keys = ("crash", "stopped", "completed", "hang", "left_behind", "inputs_changed", "multi_line", "raw_control", "oversized_over_1s")
    for r in results:
        s = summary["by_class"].setdefault(r["class"], {k: 0 for k in ("cases", "failed") + keys})
        s["cases"] += 1
        s["failed"] += r["rc"] != 0
        s["crash"] += bool(r["crash"])
        s["stopped"] += bool(r["stopped"])
        s["completed"] += bool(r["completed"])
        s["hang"] += bool(r["hang"])
        s["left_behind"] += bool(r["left_behind"])
        s["inputs_changed"] += bool(r["inputs_changed"])
        s["multi_line"] += r["error_lines"] > 1
        s["raw_control"] += bool(r["raw_control"])
        if r["class"] == "oversized" and r["rc"] not in (0, "stopped"):  # refusals only
            s["oversized_over_1s"] += r["seconds"] > 1.0
    total = {k: sum(s[k] for s in summary["by_class"].values()) for k in ("cases", "failed") + keys}
    summary["total"] = total
    summary["oversized"] = [{"name": r["name"], "rc": r["rc"], "seconds": r["seconds"],
                             "last_progress_s": r["last_progress_s"], "stderr": r["stderr"][-160:]}
                            for r in results if r["class"] == "oversized"]
    summary["problems"] = [r for r in results if r["crash"] or r["hang"] or r["left_behind"] or r["inputs_changed"]
                           or r["error_lines"] > 1 or r["raw_control"]]
    if a.out:
        with open(a.out, "w") as f:
            json.dump({"summary": summary, "results": results}, f, indent=1)
    print(json.dumps({k: summary[k] for k in ("cases", "total", "by_class", "oversized")}, indent=1))


if __name__ == "__main__":
    main()
