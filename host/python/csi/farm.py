"""csi-farm: the tiles of a reconstruction, and the frames of an animation, on a Dask cluster.

A dump's reconstruction is split into the tiles of csi's own layout (docs/tiles.md) and each tile
runs as one Dask task (``csi-reconstruct DUMP --tile I/N``); the partials come back through Dask
and ``csi-merge`` blends them here into the image, which is the same bits as one process tiling by
itself, for any number of workers and any completion order. ``render`` does the same for scenes
(the frames of an animation, or one moving scene's volume): ``csi-render --dump`` per scene as a
task, then its tiles, each scene merged as soon as its tiles are in.

Dask distributed is the engine: a LocalCluster on this machine by default (worker processes
bound to 127.0.0.1), or the scheduler at ``--scheduler ADDRESS`` of a cluster a site already
runs. Tasks that fail, or whose worker dies, are run again by Dask (up to ``--retries`` times for
a failure; a lost worker's tasks go to another worker). Inputs and the csi programs must be
reachable under the same paths from every worker (a shared file system on a real cluster);
partials travel through Dask, and nothing is written next to the outputs until the merge.

    csi-farm reconstruct scene.csid -o scene.exr --workers 2
    csi-farm render frame_*.scene -o out/frame_%04d.exr --spp 4 --scheduler tcp://head:8786
"""

import argparse
import functools
import json
import os
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import time

from ._argv import unknown_option


class FarmError(RuntimeError):
    """A csi program failed (its one-line message), or the farm was misused."""


class Refused:
    """What a task returns when its csi program refused its input (exit status 2: a bad dump,
    scene or option): the same on any worker, so it is handed back as a value, neither run
    again (--retries) nor logged by the worker as a failed task; the client raises it."""

    def __init__(self, message):
        self.message = message


def _value(res):
    """A task's result, or FarmError with the program's line when it refused its input."""
    if isinstance(res, Refused):
        raise FarmError(res.message)
    return res


# ---- what runs on a worker --------------------------------------------------------------------

def _die_with_parent():
    """The child is killed when the worker that started it dies (Linux PR_SET_PDEATHSIG), so a
    killed worker leaves no csi process running on behind it."""
    try:
        import ctypes
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGKILL)
    except OSError:
        pass


class _BadInput(FarmError):
    """The program exited with status 2: its input or options are bad."""


def _run(cmd):
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, preexec_fn=_die_with_parent)
    if p.returncode != 0:
        msg = p.stderr.decode(errors="replace").strip().splitlines()
        msg = msg[-1] if msg else f"{shlex.join(cmd)} exited with {p.returncode}"
        raise _BadInput(msg) if p.returncode == 2 else FarmError(msg)
    return p.stdout


def _refusable(task):
    """A task whose program's refusal (exit 2) is returned as Refused instead of raised."""
    @functools.wraps(task)
    def run(*args):
        try:
            return task(*args)
        except _BadInput as e:
            return Refused(str(e))
    return run


@_refusable
def task_info(program, source, args):
    """The layout and the whole problem's scale of one dump: csi-reconstruct --tile-info."""
    return json.loads(_run([program, source, "--tile-info", "-q"] + list(args)))


@_refusable
def task_tile(program, source, index, count, scale, args, scratch=None):
    """One tile's partial, as bytes (written in a private directory under `scratch`, which is
    then removed; a worker killed meanwhile leaves it to whoever removes `scratch`)."""
    if scratch:
        os.makedirs(scratch, exist_ok=True)
    d = tempfile.mkdtemp(prefix="csi-farm-tile-", dir=scratch)
    try:
        out = os.path.join(d, "tile.csip")
        cmd = [program, source, "--tile", f"{index}/{count}", "-o", out, "-q"] + list(args)
        if scale:
            cmd += ["--tile-scale", scale]
        _run(cmd)
        with open(out, "rb") as f:
            return f.read()
    finally:
        shutil.rmtree(d, ignore_errors=True)


@_refusable
def task_render(program, scene, dump, args):
    """Traces a scene into a dump (csi-render --dump; the per-pixel mean it also writes is
    discarded): the input of that scene's tiles."""
    d = tempfile.mkdtemp(prefix="csi-farm-render-")
    try:
        _run([program, scene, "--dump", dump, "--estimator", "mean", "-o", os.path.join(d, "mean.exr"), "-q"]
             + list(args))
        return dump
    finally:
        shutil.rmtree(d, ignore_errors=True)


# ---- the client side --------------------------------------------------------------------------

def find_programs(bin_dir=None):
    """Paths of csi-reconstruct, csi-render and csi-merge: bin_dir, $CSI_BIN, the build directory
    of this checkout, then $PATH."""
    here = os.path.dirname(os.path.abspath(__file__))
    if bin_dir:  # given: the programs there, or an error (not some other build's)
        missing = [n for n in ("csi-reconstruct", "csi-render", "csi-merge")
                   if not os.access(os.path.join(bin_dir, n), os.X_OK)]
        if missing:
            raise FarmError(f"{bin_dir}: --bin holds no {', '.join(missing)}")
    dirs = [bin_dir, os.environ.get("CSI_BIN"), os.path.join(here, "..", "..", "..", "build")]
    out = {}
    for name in ("csi-reconstruct", "csi-render", "csi-merge"):
        for d in dirs:
            if d and os.access(os.path.join(d, name), os.X_OK):
                out[name] = os.path.abspath(os.path.join(d, name))
                break
        else:
            found = shutil.which(name)
            if not found:
                raise FarmError(f"{name} not found: give --bin DIR (or set CSI_BIN) to the directory of the csi programs")
            out[name] = found
    return out


class Progress:
    """One line on stderr per finished task: count, what, where, seconds, and the time left at
    the rate the tasks have finished so far (the workers' parallel throughput, every task counted
    alike)."""

    def __init__(self, total, quiet=False, stream=None):
        self.total, self.done, self.quiet = total, 0, quiet
        self.stream = stream or sys.stderr
        self.t0 = time.perf_counter()

    def add(self, n):
        self.total += n

    def left(self, now):
        """Seconds left at the rate so far; None before a task has finished."""
        if self.done == 0:
            return None
        return max((now - self.t0) / self.done * (self.total - self.done), 0.0)

    def step(self, what):
        self.done += 1
        if not self.quiet:
            now = time.perf_counter()
            left = self.left(now)
            eta = f", about {left:.0f} s left" if left is not None and self.done < self.total else ""
            self.stream.write(f"csi-farm: [{self.done}/{self.total}] {what} ({now - self.t0:.1f} s{eta})\n")
            self.stream.flush()


#: Seconds to wait for a --scheduler to answer before giving up.
CONNECT_TIMEOUT = 10


def _client(scheduler=None, workers=None, timeout=CONNECT_TIMEOUT):
    """A client of the scheduler at `scheduler` (FarmError when it does not answer within
    `timeout` seconds), or of a new LocalCluster with `workers` worker processes (one thread
    each: a tile already uses every core through PoCL) on 127.0.0.1."""
    from distributed import Client, LocalCluster
    if scheduler:
        try:
            return Client(scheduler, timeout=timeout), None
        except (OSError, TimeoutError, ValueError, TypeError) as e:
            reason = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
            if isinstance(e, (ValueError, TypeError)):
                raise FarmError(f"--scheduler {scheduler}: not a scheduler address ({reason})") from None
            raise FarmError(f"--scheduler {scheduler}: no Dask scheduler answered within {timeout:g} s "
                            f"({reason})") from None
    n = workers or max(1, (os.cpu_count() or 2) // 2)
    # The scheduler's HTTP server on a free port: without an address it takes 8787, and a second
    # local cluster (another run, a test beside it) then warns on stderr and moves.
    cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                           dashboard_address="127.0.0.1:0")
    return Client(cluster), cluster


def _merge(progs, partials, output, png, frames_dir, stats, quiet):
    d = tempfile.mkdtemp(prefix="csi-farm-merge-")
    try:
        paths = []
        for i, data in enumerate(partials):
            p = os.path.join(d, f"tile_{i:06d}.csip")
            with open(p, "wb") as f:
                f.write(data)
            paths.append(p)
        cmd = [progs["csi-merge"]] + paths + ["-q"]
        for flag, val in (("-o", output), ("--png", png), ("--frames", frames_dir), ("--stats", stats)):
            if val:
                cmd += [flag, val]
        _run(cmd)
    finally:
        shutil.rmtree(d, ignore_errors=True)


def _check_input(path, what):
    """An input the workers will read, checked here first (the same path on a shared file system)."""
    if os.path.isdir(path):
        raise FarmError(f"{path}: cannot open the {what}: a directory")
    if not os.path.isfile(path):
        raise FarmError(f"{path}: cannot open the {what}: " + ("not a regular file" if os.path.exists(path)
                                                               else "No such file or directory"))


def _check_outputs(inputs, files, dirs=()):
    """The outputs csi-merge will write, checked before any task by the rule of csi's programs
    (csi.OutputSet: a directory that exists and is writable, not a directory itself, not one of
    the inputs, not another output), so that a run that cannot write them fails at once."""
    import csi

    try:
        with csi.OutputSet(inputs=inputs) as outs:
            for path, what in files:
                if path:
                    outs.file(path, what)
            for path, what in dirs:
                if path:
                    outs.dir(path, what)
    except csi.CsiError as e:
        raise FarmError(str(e)) from None


def _submit_tiles(client, progs, source, info, args, retries, scratch):
    n = int(info["tiles"])
    scale = info.get("tile_scale") or ""
    futs = []
    for i in range(n):
        futs.append(client.submit(task_tile, progs["csi-reconstruct"], source, i, n, scale, args, scratch,
                                  retries=retries, pure=False))
    return futs


def _scratch(client):
    """Where tasks keep their files: a directory of ours, removed at the end, when every worker
    runs on this machine (127.0.0.1); else each worker's own temporary directory."""
    workers = client.scheduler_info().get("workers", {})
    local = workers and all(w.split("://")[-1].startswith(("127.0.0.1:", "localhost:")) for w in workers)
    return tempfile.mkdtemp(prefix="csi-farm-scratch-") if local else None


def reconstruct(dump, output=None, *, png=None, frames_dir=None, stats=None, tiles=None, options=(),
                client=None, scheduler=None, workers=None, bin_dir=None, retries=2, quiet=False,
                connect_timeout=CONNECT_TIMEOUT):
    """Reconstructs one dump in tiles on a Dask cluster and writes the outputs with csi-merge.
    `options` are csi-reconstruct's reconstruction options (a list of arguments). Returns the
    layout (the --tile-info JSON as a dict)."""
    progs = find_programs(bin_dir)
    dump = os.path.abspath(dump)
    _check_input(dump, "sample dump")
    _check_outputs([dump], [(output, "the image (-o)"), (png, "the preview (--png)"),
                            (stats, "the statistics (--stats)")], [(frames_dir, "the frames (--frames)")])
    args = list(options) + (["--tiles", str(tiles)] if tiles else []) + (["--partial-frames"] if frames_dir else [])
    own = None
    if client is None:
        client, own = _client(scheduler, workers, connect_timeout)
    scratch = _scratch(client)
    try:
        from distributed import as_completed
        info = _value(client.submit(task_info, progs["csi-reconstruct"], dump, args, pure=False,
                                    retries=retries).result())
        futs = _submit_tiles(client, progs, dump, info, args, retries, scratch)
        prog = Progress(len(futs), quiet)
        index = {f.key: i for i, f in enumerate(futs)}
        parts = [None] * len(futs)
        for f in as_completed(futs):
            parts[index[f.key]] = _value(f.result())
            prog.step(f"{os.path.basename(dump)} tile {index[f.key]}")
        _merge(progs, parts, output, png, frames_dir, stats, quiet)
        return info
    finally:
        if own is not None:
            client.close()
            own.close()
        if scratch:
            shutil.rmtree(scratch, ignore_errors=True)


def render(scenes, output_pattern, *, render_options=(), options=(), png_pattern=None, frames_pattern=None,
           tiles=None, work_dir=None, client=None, scheduler=None, workers=None, bin_dir=None, retries=2,
           quiet=False, connect_timeout=CONNECT_TIMEOUT):
    """Renders and reconstructs every scene (the frames of an animation): one csi-render --dump
    task per scene, then the tiles of its dump, each scene merged when its tiles are in. Output
    patterns take the frame number (the scene's position in `scenes`) as %d. The dumps go to
    `work_dir` (default: a temporary directory, which only a cluster on this machine can share)
    and are removed at the end. Returns the output paths."""
    progs = find_programs(bin_dir)
    own_dir = work_dir is None
    args = list(options) + (["--tiles", str(tiles)] if tiles else []) + (["--partial-frames"] if frames_pattern else [])
    def fill(pat, i):
        try:
            return (pat % i) if pat and "%" in pat else pat
        except (TypeError, ValueError) as e:
            raise FarmError(f"{pat}: not a pattern with one frame number (%d, %04d ...): {e}") from None

    outputs = [fill(output_pattern, i) for i in range(len(scenes))]
    if len(set(outputs)) != len(outputs):
        raise FarmError(f"{output_pattern}: several scenes would write one output: put %d (the frame number) in it")
    for sc in scenes:
        _check_input(sc, "scene")
    _check_outputs(scenes, [(path, what) for i in range(len(scenes)) for path, what in
                            ((outputs[i], "the image (-o)"), (fill(png_pattern, i), "the preview (--png)"))],
                   [(fill(frames_pattern, i), "the frames (--frames)") for i in range(len(scenes))])
    if work_dir is not None and os.path.exists(work_dir) and not os.path.isdir(work_dir):
        raise FarmError(f"{work_dir}: --work-dir is not a directory")
    own = None
    if client is None:
        client, own = _client(scheduler, workers, connect_timeout)
    scratch = _scratch(client)
    work = tempfile.mkdtemp(prefix="csi-farm-") if own_dir else os.path.abspath(work_dir)
    os.makedirs(work, exist_ok=True)
    try:
        from distributed import as_completed
        prog = Progress(2 * len(scenes), quiet)
        pending = as_completed()
        what = {}
        for i, sc in enumerate(scenes):
            dump = os.path.join(work, f"frame_{i:06d}.csid")
            f = client.submit(task_render, progs["csi-render"], os.path.abspath(sc), dump, list(render_options),
                              pure=False, retries=retries)
            what[f.key] = ("render", i, None)
            pending.add(f)
        parts, infos = {}, {}
        for f in pending:
            kind, i, extra = what.pop(f.key)
            res = _value(f.result())
            if kind == "render":
                prog.step(f"{os.path.basename(scenes[i])} rendered")
                g = client.submit(task_info, progs["csi-reconstruct"], res, args, pure=False, retries=retries)
                what[g.key] = ("info", i, res)
                pending.add(g)
            elif kind == "info":
                infos[i] = res
                futs = _submit_tiles(client, progs, extra, res, args, retries, scratch)
                prog.add(len(futs))
                parts[i] = [None] * len(futs)
                for t, g in enumerate(futs):
                    what[g.key] = ("tile", i, t)
                    pending.add(g)
            else:
                parts[i][extra] = res
                prog.step(f"{os.path.basename(scenes[i])} tile {extra}")
                if all(p is not None for p in parts[i]):
                    _merge(progs, parts[i], outputs[i], fill(png_pattern, i), fill(frames_pattern, i), None, quiet)
                    parts[i] = None
                    os.remove(os.path.join(work, f"frame_{i:06d}.csid"))
                    prog.step(f"{outputs[i]} written")
        return outputs
    finally:
        if own is not None:
            client.close()
            own.close()
        if own_dir:
            shutil.rmtree(work, ignore_errors=True)
        if scratch:
            shutil.rmtree(scratch, ignore_errors=True)


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit 2 (argparse prints the usage too otherwise)
        raise FarmError(message)


def _count(lo):
    def parse(text):
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"'{text}' is not a whole number") from None
        if v < lo:
            raise argparse.ArgumentTypeError(f"'{text}' is not a whole number >= {lo}")
        return v
    return parse


def _seconds(text):
    try:
        v = float(text)
    except ValueError:
        v = -1
    if not 0 < v <= 3600:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number of seconds from 0 to 3600")
    return v


def _farm_options(ap, after=False):
    """The farm's own options, before the command or (after=True) after it: there they take
    effect only when given (SUPPRESS), so one given before the command is not reset."""
    d = (lambda v: argparse.SUPPRESS) if after else (lambda v: v)
    ap.add_argument("--scheduler", default=d(None),
                    help="address of a Dask scheduler (default: start a LocalCluster on 127.0.0.1)")
    ap.add_argument("--connect-timeout", type=_seconds, default=d(CONNECT_TIMEOUT), metavar="S",
                    help=f"seconds to wait for --scheduler to answer (default {CONNECT_TIMEOUT})")
    ap.add_argument("--workers", type=_count(1), default=d(None),
                    help="worker processes of the LocalCluster (default: half the cores, at least 1)")
    ap.add_argument("--tiles", type=_count(1), default=d(None),
                    help="tiles per image (default: as few as fit the memory budget)")
    ap.add_argument("--retries", type=_count(0), default=d(2), help="times a failed task is run again (default 2)")
    ap.add_argument("--bin", default=d(None),
                    help="directory of csi-reconstruct, csi-render, csi-merge (default: $CSI_BIN, the build, $PATH)")
    ap.add_argument("-q", "--quiet", action="store_true", default=d(False), help="no progress lines")


def main(argv=None):
    ap = _Parser(
        prog="csi-farm",
        description="Tiles of a csi reconstruction, and frames of an animation, on a Dask cluster "
                    "(a LocalCluster on this machine by default). The farm's options may come before or after "
                    "the command; options after -- go to the csi programs. "
                    "Exit status: 0 success, 2 bad input or usage, 1 other failure.")
    _farm_options(ap)
    sub = ap.add_subparsers(dest="cmd", metavar="COMMAND", required=True, parser_class=_Parser,
                            help="reconstruct or render")
    r = sub.add_parser("reconstruct", help="one dump, in tiles")
    _farm_options(r, after=True)
    r.add_argument("dump")
    r.add_argument("-o", "--output", required=True)
    r.add_argument("--png")
    r.add_argument("--frames", help="directory for every frame of a volume")
    r.add_argument("--stats")
    s = sub.add_parser("render", help="scenes (the frames of an animation): render, then tiles")
    _farm_options(s, after=True)
    s.add_argument("scenes", nargs="+")
    s.add_argument("-o", "--output", required=True, help="output path; %%d (or %%04d ...) is the frame number: the scene's place in the list, from 0")
    s.add_argument("--png", help="preview path pattern")
    s.add_argument("--frames", help="directory pattern for every frame of a moving scene's volume")
    s.add_argument("--spp", type=_count(1), help="samples per pixel (csi-render --spp)")
    s.add_argument("--seed", type=_count(0), help="csi-render --seed")
    s.add_argument("--work-dir", help="directory for the dumps, reachable by every worker (default: a temporary one)")
    argv = sys.argv[1:] if argv is None else list(argv)
    extra = []
    if "--" in argv:
        k = argv.index("--")
        argv, extra = argv[:k], argv[k + 1:]
    try:
        bad = unknown_option([ap, r, s], argv)
        if bad:
            raise FarmError(f"unrecognized argument: {bad} (see --help)")
        a = ap.parse_args(argv)
        if a.cmd == "reconstruct":
            reconstruct(a.dump, a.output, png=a.png, frames_dir=a.frames, stats=a.stats, tiles=a.tiles,
                        options=extra, scheduler=a.scheduler, workers=a.workers, bin_dir=a.bin,
                        retries=a.retries, quiet=a.quiet, connect_timeout=a.connect_timeout)
        else:
            ropts = (["--spp", str(a.spp)] if a.spp else []) + (["--seed", str(a.seed)] if a.seed is not None else [])
            render(a.scenes, a.output, render_options=ropts, options=extra, png_pattern=a.png,
                   frames_pattern=a.frames, tiles=a.tiles, work_dir=a.work_dir, scheduler=a.scheduler,
                   workers=a.workers, bin_dir=a.bin, retries=a.retries, quiet=a.quiet,
                   connect_timeout=a.connect_timeout)
    except FarmError as e:
        sys.stderr.write(f"csi-farm: error: {e}\n")
        return 2
    except OSError as e:
        sys.stderr.write(f"csi-farm: error: {e.filename + ': ' if e.filename else ''}{e.strerror or e}\n")
        return 1
    except KeyboardInterrupt:
        sys.stderr.write("csi-farm: interrupted\n")
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main())
