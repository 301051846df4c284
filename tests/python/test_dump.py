"""csi.dump (pure numpy) against csi's C programs: it reads csi-positions' requests and
csi-render's dumps record for record (raw bytes decoded independently here with struct), what it
writes csi-reconstruct reads (its mean estimator gives numpy's per-pixel mean), and it refuses
what docs/dump-format.md says a reader refuses, naming the byte or record."""
import dataclasses
import os
import struct
import subprocess
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "host", "python"))
sys.path.insert(0, HERE)
from checks import check, done  # noqa: E402
from csi import dump as csid  # noqa: E402
from csi import exr  # noqa: E402

B = os.environ.get("CSI_BUILD_DIR", os.path.join(HERE, "..", "..", "build"))
SRC = os.path.join(HERE, "..", "..")


def run(*args):
    env = dict(os.environ)
    env.setdefault("CSI_CACHE_DIR", os.path.join(os.path.expanduser("~"), ".cache", "csi"))
    subprocess.run([str(a) for a in args], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)


def records(path, channels):
    """(x, y, t) and values of every record, decoded with struct (independent of csi.dump)."""
    with open(path, "rb") as f:
        data = f.read()
    n = struct.unpack_from("<Q", data, 32)[0]
    size = 12 + 4 * channels
    fmt = "<3I" + "f" * channels
    recs = [struct.unpack_from(fmt, data, 64 + i * size) for i in range(n)]
    return [r[:3] for r in recs], [r[3:] for r in recs]


def expect_error(path, expected, **kw):
    try:
        csid.read(path, **kw)
    except csid.DumpError as e:
        msg = str(e)
        check(expected in msg and msg.startswith(path) and "\n" not in msg, f"{os.path.basename(path)}: message {msg!r}")
        return
    check(False, f"{os.path.basename(path)}: read without error (expected {expected!r})")


def main():
    with tempfile.TemporaryDirectory() as T:
        p = lambda name: os.path.join(T, name)  # noqa: E731
        # a request from csi-positions: header and records as struct decodes them
        run(os.path.join(B, "csi-positions"), "--out", "24x16", "--spp", 3, "--seed", 4, "-o", p("req.csid"), "-q")
        req = csid.read(p("req.csid"))
        pos, _ = records(p("req.csid"), 0)
        check(req.is_request and req.grid == (96, 64, 1) and req.out == (24, 16) and req.seed == 4,
              f"request header: {req.grid} {req.out} seed {req.seed}")
        check(req.xyt.tolist() == [list(r) for r in pos], "request positions differ from the file's records")
        u, v, t = req.cell_centres()
        check(np.allclose(u, (req.xyt[:, 0] + 0.5) / 96) and np.allclose(v, (req.xyt[:, 1] + 0.5) / 64)
              and np.allclose(t, 0.5), "cell centres")
        # a dump from csi-render
        run(os.path.join(B, "csi-render"), os.path.join(SRC, "tests", "cli", "scenes", "small_triangle.scene"), "--spp", 2,
            "--dump", p("r.csid"), "-o", p("r.exr"), "--max-iter", 5, "-q")
        d = csid.read(p("r.csid"), want="samples")
        pos, val = records(p("r.csid"), 3)
        check(d.xyt.tolist() == [list(r) for r in pos] and np.array_equal(d.values, np.array(val, np.float32)),
              "csi-render's dump decoded differently")
        # the flags at byte 48: csi-render's scene has no random effect, so its values are exact
        flags = struct.unpack_from("<I", open(p("r.csid"), "rb").read(), 48)[0]
        check(flags == 1 and d.exact, f"csi-render's dump of a noise-free scene: flags {flags}, exact {d.exact}")
        check(not req.exact and open(p("req.csid"), "rb").read()[48:64] == bytes(16), "a request is never exact")
        for exact in (True, False):
            csid.write(p("x.csid"), d.with_values(d.values, exact=exact))
            raw = open(p("x.csid"), "rb").read()
            back = csid.read(p("x.csid"))
            check(struct.unpack_from("<I", raw, 48)[0] == int(exact) and raw[52:64] == bytes(12)
                  and back.exact == exact, f"exact={exact}: flags written {raw[48:52].hex()}, read {back.exact}")
        try:
            csid.write(p("xreq.csid"), dataclasses.replace(req, exact=True))
            check(False, "wrote an exact positions request")
        except csid.DumpError:
            check(not os.path.exists(p("xreq.csid")), "a refused request left a file")
        # written here, read by csi-reconstruct: duplicates at one position are averaged
        rng = np.random.default_rng(1)
        vals = rng.random((len(req.xyt), 3), dtype=np.float32) * 10
        dup = req.with_values(vals)
        both = csid.Dump(grid=dup.grid, out=dup.out, xyt=np.concatenate([dup.xyt, dup.xyt]),
                         values=np.concatenate([vals, 3 * vals]), seed=dup.seed)
        csid.write(p("w.csid"), both)
        back = csid.read(p("w.csid"))
        check(np.array_equal(back.xyt, both.xyt) and np.array_equal(back.values, both.values), "write/read round trip")
        run(os.path.join(B, "csi-reconstruct"), p("w.csid"), "--estimator", "mean", "-o", p("w.exr"), "-q")
        img = exr.read(p("w.exr"))
        # each position's two records average to 2 * vals; every pixel holds 3 positions
        want = dup.with_values(2 * vals.astype(np.float64)).pixel_means()
        check(np.abs(img - want).max() <= 2e-6 * np.abs(want).max(), f"csi-reconstruct's mean: max error "
              f"{np.abs(img - want).max()}")
        csid.write(p("w_req.csid"), req)
        with open(p("w_req.csid"), "rb") as a, open(p("req.csid"), "rb") as b:
            check(a.read() == b.read(), "a request written here differs from csi-positions' bytes")

        # what a reader refuses (docs/dump-format.md), the byte or record named
        good = open(p("r.csid"), "rb").read()

        def bad(name, data):
            with open(p(name), "wb") as f:
                f.write(data)
            return p(name)

        patch = lambda off, b: good[:off] + b + good[off + len(b):]  # noqa: E731
        expect_error(bad("magic.csid", patch(0, b"\x89PNG")), "byte 0: wrong magic")
        expect_error(bad("version.csid", patch(4, struct.pack("<I", 2))), "byte 4: unknown version 2")
        expect_error(bad("header.csid", good[:40]), "byte 40: truncated header")
        expect_error(bad("div.csid", patch(8, struct.pack("<I", 130))), "byte 8: grid_w = 130 is not a multiple of out_w = 32")
        expect_error(bad("chan.csid", patch(28, struct.pack("<I", 5))), "byte 28: channels = 5")
        expect_error(bad("res.csid", patch(60, b"\x07")), "byte 60: reserved byte is 0x07")
        flag_msg = "byte 48: flags 0x00000003 has reserved bits 0x00000002 set, must be zero"
        expect_error(bad("flag.csid", patch(48, struct.pack("<I", 3))), flag_msg)
        expect_error(bad("flag31.csid", patch(48, struct.pack("<I", 1 << 31))), "reserved bits 0x80000000")
        expect_error(bad("reqflag.csid", open(p("req.csid"), "rb").read()[:48] + struct.pack("<I", 1)
                         + open(p("req.csid"), "rb").read()[52:]), "byte 48: flags 0x00000001 on a positions request")
        c = subprocess.run([os.path.join(B, "csi-reconstruct"), p("flag.csid"), "-o", p("flag.exr"), "-q"],
                           capture_output=True, text=True)
        check(c.returncode == 2 and flag_msg in c.stderr and not os.path.exists(p("flag.exr")),
              f"csi-reconstruct on an unknown flag: {c.returncode} {c.stderr.strip()!r}")
        expect_error(bad("zero.csid", patch(32, struct.pack("<Q", 0))), "byte 32: zero samples")
        expect_error(bad("trunc.csid", good[:-5]), "byte 32: count =")
        expect_error(bad("trail.csid", good + b"\0"), "1 trailing bytes")
        expect_error(bad("pos.csid", patch(64 + 24, struct.pack("<3I", 9999, 0, 0))), "record 1 (byte 88): position (9999, 0, 0)")
        expect_error(bad("t.csid", patch(64 + 24, struct.pack("<3I", 0, 0, 1))), "record 1 (byte 88): t = 1 but the grid is static")
        expect_error(bad("nan.csid", patch(64 + 24 + 16, struct.pack("<f", float("nan")))), "record 1 (byte 104): channel 1 is NaN")
        expect_error(p("req.csid"), "a positions request, not samples", want="samples")
        expect_error(p("r.csid"), "not a positions request", want="request")
        expect_error(p("missing.csid"), "cannot open")
        expect_error(T, "a directory, not a regular file")
        # what is not a regular file is refused without being read: /dev/zero was read without
        # end (24 GB and the OOM killer), a FIFO waited for a writer for ever. Each in a process
        # of its own with 2 GB of address space and a minute, so that the old behaviour fails here.
        os.mkfifo(p("fifo.csid"))
        probe = ("import resource, sys; resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30)); "
                 "from csi import dump\ntry:\n    dump.read(sys.argv[1])\nexcept dump.DumpError as e:\n    print(e)")
        for path, want in (("/dev/zero", "a character device"), (p("fifo.csid"), "a FIFO")):
            try:
                r = subprocess.run([sys.executable, "-c", probe, path], capture_output=True, text=True, timeout=60,
                                   env=dict(os.environ, PYTHONPATH=os.path.join(HERE, "..", "..", "host", "python")))
                out = r.stdout + r.stderr.strip()[-200:]
            except subprocess.TimeoutExpired:
                out = "no answer in 60 s"
            check(want in out, f"{path}: {out!r}")
        try:
            csid.write(p("nan_out.csid"), d.with_values(np.full_like(d.values, np.nan)))
            check(False, "wrote NaN values")
        except csid.DumpError:
            check(not any(n.startswith(".nan_out") or n == "nan_out.csid" for n in os.listdir(T)),
                  "a refused write left a file behind")
    return done()


if __name__ == "__main__":
    sys.exit(main())
