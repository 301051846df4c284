"""Mitsuba 3 as csi's renderer: radiance at exactly csi's cell centres, and box-filtered references.

    from csi import mitsuba_bridge as mb
    dump, s = mb.render("cornell", size=(128, 128), spp=4, paths=64)   # all in one call, or:
    scene = mb.load_scene("cornell", size=(128, 128))      # or an XML file, or a .py with scene()
    req = mb.positions_request(out=(128, 128), spp=4, seed=1)   # csi's grid and positions (csi-positions')
    s = mb.render_request(scene, req, paths=64, seed=1)     # numpy: s.values (n, 3), s.timing
    csi.dump.write("s.csid", req.with_values(s.values))     # the dump for csi-reconstruct
    ref = mb.render_reference(mb.load_scene("cornell", size=(128, 128), box_filter=True), spp=4096)

Animation (Mitsuba has no motion blur of its own): a .py scene may also define
animate(params, time), which poses the scene at shutter time `time` in [0, 1] by setting entries
of params = mi.traverse(scene) (a camera's or a shape's to_world, ...). A request with T > 1
time steps is then evaluated frame by frame, the scene re-posed at each cell's time
(t + 0.5) / T; render_reference_frames renders the reference of every such frame.

Each sample is evaluated with Mitsuba's own sensor and integrator: the sensor's ray through image
point ((x + 0.5) / grid_w, (y + 0.5) / grid_h) (v = 0 on the top row, the same convention as
csi's dumps), at shutter time (t + 0.5) / grid_t of the sensor's shutter interval, then the
scene's integrator along it; several paths per sample are averaged. The reference is
`mi.render` with the film's reconstruction filter set to a box: Mitsuba's pixel (px, py) is
then the mean over [px, px+1) x [py, py+1) of the film, which is csi's output pixel.

The llvm_ad_rgb variant needs an LLVM >= 16 shared library; DRJIT_LIBLLVM_PATH is set to one
found on the system when it is unset (see ../shared/TOOLCHAIN.md for the Debian 12 package).
"""

from __future__ import annotations

import dataclasses
import glob
import os
import re
import runpy
import time
import xml.etree.ElementTree as ET

import numpy as np

from . import dump as csid

VARIANT = "llvm_ad_rgb"
LLVM_MIN = 16
#: Lanes per Mitsuba launch: bounds memory (a few hundred bytes a lane) while keeping the
#: per-launch overhead small. Part of the seeding, so fixed: changing it changes the noise.
BATCH_LANES = 1 << 21


class BridgeError(RuntimeError):
    """Bad input or a missing dependency; the message is one line naming the problem."""


# ---- Mitsuba and its LLVM ---------------------------------------------------------------------

def _llvm_version(path):
    """The LLVM major version a library's path names (libLLVM-19.so, libLLVM.so.19.1,
    /usr/lib/llvm-19/...), or None."""
    m = re.search(r"libLLVM[-.](?:so\.)?(\d+)", os.path.basename(path)) or re.search(r"llvm-(\d+)", path)
    return int(m.group(1)) if m else None


def find_libllvm():
    """Path of an LLVM >= 16 shared library (newest first), or None."""
    found = []
    pats = ["/usr/lib/*-linux-gnu/libLLVM-*.so*", "/usr/lib/*-linux-gnu/libLLVM.so.*", "/usr/lib/llvm-*/lib/libLLVM*.so*",
            "/usr/lib64/libLLVM*.so*", "/usr/local/lib/libLLVM*.so*", "/opt/homebrew/opt/llvm/lib/libLLVM.dylib"]
    for pat in pats:
        for p in glob.glob(pat):
            v = _llvm_version(p)
            if v is not None and v >= LLVM_MIN and os.path.isfile(p):
                found.append((v, p))
    if not found:
        return None
    found.sort(key=lambda vp: (-vp[0], len(vp[1])))
    return found[0][1]


_mi = None


def mitsuba():
    """Imports Mitsuba with the llvm_ad_rgb variant (once), setting DRJIT_LIBLLVM_PATH if unset."""
    global _mi
    if _mi is not None:
        return _mi
    given = os.environ.get("DRJIT_LIBLLVM_PATH")
    if not given:
        lib = find_libllvm()
        if lib is None:
            raise BridgeError(f"no LLVM >= {LLVM_MIN} shared library found for Mitsuba's {VARIANT} variant: install one "
                              f"(Debian 12: apt-get install libllvm19) or set DRJIT_LIBLLVM_PATH to it")
        os.environ["DRJIT_LIBLLVM_PATH"] = lib
    else:
        # Checked here because Dr.Jit reports a missing library on several lines, and an older
        # LLVM aborts the process inside code generation ("Cannot select ... fminimum").
        if not os.path.isfile(given):
            raise BridgeError(f"DRJIT_LIBLLVM_PATH={given}: no such file (unset it to let csi find LLVM >= {LLVM_MIN})")
        v = _llvm_version(os.path.realpath(given)) or _llvm_version(given)
        if v is not None and v < LLVM_MIN:
            raise BridgeError(f"DRJIT_LIBLLVM_PATH={given} is LLVM {v}; Mitsuba's {VARIANT} variant needs LLVM >= "
                              f"{LLVM_MIN} (Debian 12: apt-get install libllvm19)")
    try:
        import mitsuba as mi
    except ImportError as e:
        raise BridgeError(f"Mitsuba 3 is not installed in this Python ({e}): pip install -r tools/requirements.txt "
                          f"(tools/setup does it)") from None
    try:
        mi.set_variant(VARIANT)
    except Exception as e:  # Dr.Jit reports a missing or too old LLVM here
        raise BridgeError(f"Mitsuba's {VARIANT} variant does not start (DRJIT_LIBLLVM_PATH="
                          f"{os.environ.get('DRJIT_LIBLLVM_PATH')}): {_one_line(e)}") from None
    _mi = mi
    return mi


def quiet():
    """Mitsuba's own log (its warnings while loading or rendering a scene) down to errors."""
    mi = mitsuba()
    mi.set_log_level(mi.LogLevel.Error)


def _one_line(e) -> str:
    msg = " ".join(str(e).split())
    return re.sub(r"\[[\w./-]+\.cpp:\d+\]\s*", "", msg)


def _root_cause(e) -> str:
    """The innermost exception's message on one line (Dr.Jit wraps a plugin's error raised
    inside mi.render in "error while performing a custom differentiable operation")."""
    while e.__cause__ is not None or e.__context__ is not None:
        e = e.__cause__ or e.__context__
    return _one_line(e)


# ---- scenes -----------------------------------------------------------------------------------

@dataclasses.dataclass
class Scene:
    mi_scene: object
    size: tuple  # (w, h) of the film = the output image
    name: str
    animate: object = None  # a .py scene's animate(params, time), or None (still)
    params: object = None  # mi.traverse(mi_scene) when animated


def pose(scene: Scene, time: float):
    """Poses an animated scene at shutter time `time` in [0, 1]; a still scene is left as it is."""
    if scene.animate is None:
        return
    try:
        scene.animate(scene.params, float(time))
        scene.params.update()
    except Exception as e:  # the scene's own code: name it
        raise BridgeError(f"{scene.name}: animate(params, {float(time):.4g}) failed: {_one_line(e)}") from None


def camera_motion(scene: Scene) -> str:
    """How the scene's animate() moves its sensor over the shutter, from its poses at times 0, 1/2
    and 1: "still"; "pans" when it only translates, across its view (the rotation and field of
    view the same, each translation at most a quarter along the view direction); else "moves"
    (csi-render's plan says the same of its cameras: camera_moves, camera_pans). Leaves the scene
    posed at time 0."""
    if scene.animate is None:
        return "still"
    import numpy as np

    sensor = scene.mi_scene.sensors()[0]
    fov = [k for k in scene.params.keys() if k.endswith("x_fov")]
    poses = []
    for t in (0.0, 0.5, 1.0):
        pose(scene, t)
        m = np.array(sensor.world_transform().matrix, dtype=np.float64).reshape(4, 4)
        poses.append((m, np.concatenate([np.array(scene.params[k], dtype=np.float64).reshape(-1) for k in fov]
                                        or [np.zeros(0)])))
    pose(scene, 0.0)
    (m0, f0), eps = poses[0], 1e-6 * max(1.0, float(np.abs(poses[0][0]).max()))
    if all(float(np.abs(m - m0).max()) <= eps and np.array_equal(f, f0) for m, f in poses[1:]):
        return "still"
    forward = m0[:3, 2] / np.linalg.norm(m0[:3, 2])  # the sensor looks along its local +z
    for m, f in poses[1:]:
        d = m[:3, 3] - m0[:3, 3]
        if (float(np.abs(m[:3, :3] - m0[:3, :3]).max()) > eps or not np.array_equal(f, f0)
                or abs(float(d @ forward)) > 0.25 * float(np.linalg.norm(d))):
            return "moves"
    return "pans"


#: Mitsuba's sensor plugins: how a scene dictionary's sensor entry is recognised.
SENSOR_TYPES = ("perspective", "thinlens", "orthographic", "telecentric", "radiancemeter", "irradiancemeter",
                "distant", "batch")


def _pick_sensor(names, which):
    """The index of the sensor `which` names among the scene's, in declaration order: None (the
    first), an index (as mi.render's sensor argument counts) or an id (a string)."""
    if not names:
        raise BridgeError("the scene has no sensor")
    if which is None:
        return 0
    listed = ", ".join(f"{i}" + (f" ({n})" if n else "") for i, n in enumerate(names))
    if isinstance(which, int) or str(which).isdigit():
        i = int(which)
        if i >= len(names):
            raise BridgeError(f"--sensor {i}: the scene has {len(names)} sensor{'s' if len(names) > 1 else ''}: {listed}")
        return i
    if which not in names:
        raise BridgeError(f"--sensor {which}: no sensor has that id; the scene's sensors: {listed}")
    return names.index(which)


def _film_dict_override(d, size, box_filter, which=None):
    keys = [k for k, v in d.items() if isinstance(v, dict) and v.get("type") in SENSOR_TYPES]
    chosen = keys[_pick_sensor(keys, which)]
    for k in keys:  # the scene keeps the chosen sensor only: it is then the scene's first
        if k != chosen:
            del d[k]
    sensor = d[chosen]
    film = sensor.setdefault("film", {"type": "hdrfilm"})
    if size:
        _no_crop(film.keys(), size)
        film["width"], film["height"] = int(size[0]), int(size[1])
    if box_filter:
        film["rfilter"] = {"type": "box"}
        film["pixel_format"] = "rgb"  # the samples are RGB: a luminance or XYZ film would not be
    return d


#: A film's crop window: csi's image is the film's crop, so a new size cannot keep it.
CROP_KEYS = ("crop_offset_x", "crop_offset_y", "crop_width", "crop_height")


def _no_crop(keys, size):
    crop = sorted(k for k in keys if k in CROP_KEYS)
    if crop:
        raise BridgeError(f"the film has a crop window ({', '.join(crop)}): its size cannot be set to "
                          f"{int(size[0])}x{int(size[1])}; render the crop at its own size (no --out) or remove "
                          f"the crop window from the scene")


def _xml_check(path):
    """What can be said about an XML file without Mitsuba: well-formed, a <scene> root."""
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as e:
        raise BridgeError(f"{path}: not well-formed XML: {e}") from None
    except OSError as e:
        raise BridgeError(f"{path}: cannot read: {e.strerror}") from None
    if root.tag != "scene":
        raise BridgeError(f"{path}: the root element is <{root.tag}>, not a Mitsuba <scene>")


def _xml_load(mi, path, size, box_filter, params=None, which=None):
    """The XML scene through Mitsuba's own parser (mi.parser, Mitsuba >= 3.7), the chosen sensor
    (`which`, _pick_sensor's; the others removed from the parsed state) with its film overridden:
    includes, <ref>'d films and sensors in included files are Mitsuba's, and an error names the
    user's file and line (not a rewritten copy's)."""
    P = mi.parser
    cfg = P.ParserConfig(VARIANT)
    state = P.parse_file(cfg, os.path.abspath(path), **(params or {}))  # $name parameters, as mitsuba -D
    P.transform_all(cfg, state)
    nodes = state.nodes
    RR = mi.Properties.Type.ResolvedReference

    def children(node, kind):
        return [nodes[node.props[k].index()] for k in node.props.keys()
                if node.props.type(k) == RR and nodes[node.props[k].index()].type == kind]

    sensors = [i for i, n in enumerate(nodes) if n.type == mi.ObjectType.Sensor]
    if not sensors:
        raise BridgeError(f"{path}: the scene has no <sensor>")
    chosen = sensors[_pick_sensor([nodes[i].props.id() for i in sensors], which)]
    others = set(sensors) - {chosen}
    for n in nodes:  # every reference to another sensor: the scene keeps the chosen one only
        for k in list(n.props.keys()):
            if n.props.type(k) == RR and n.props[k].index() in others:
                n.props.remove_property(k)
    if size or box_filter:
        sensor = nodes[chosen]
        films = children(sensor, mi.ObjectType.Film)
        if films:
            film = films[0].props
            if size:
                _no_crop(film.keys(), size)
                film["width"], film["height"] = int(size[0]), int(size[1])
            if box_filter:
                for k in list(film.keys()):
                    if film.type(k) == RR and nodes[film[k].index()].type == mi.ObjectType.ReconstructionFilter:
                        film.remove_property(k)
                film["rfilter"] = mi.load_dict({"type": "box"})
                film["pixel_format"] = "rgb"  # the samples are RGB: a luminance or XYZ film would not be
        else:
            d = {"type": "hdrfilm", **({"width": int(size[0]), "height": int(size[1])} if size else {}),
                 **({"rfilter": {"type": "box"}} if box_filter else {})}
            sensor.props["film"] = mi.load_dict(d)
    scene = P.instantiate(cfg, state)
    if size and scene.sensors() and tuple(int(v) for v in scene.sensors()[0].film().crop_size()) != tuple(size):
        raise BridgeError(f"{path}: cannot set the sensor's film to {size[0]}x{size[1]}")
    return scene


def _check_integrator(mi, scene, spec):
    """The scene's integrator is one csi-mitsuba can evaluate along a sensor ray."""
    integ = scene.integrator()
    if integ is None:
        raise BridgeError(f"{spec}: the scene has no integrator (add one, e.g. <integrator type=\"path\"/>)")
    name = integ.class_name() if hasattr(integ, "class_name") else type(integ).__name__
    if not isinstance(integ, mi.SamplingIntegrator):
        raise BridgeError(f"{spec}: the scene's integrator ({name}) does not trace paths from the sensor (csi-mitsuba "
                          f"evaluates radiance along the sensor's rays: path, volpath, direct, prb, ...)")
    if name == "AOVIntegrator" and not any(a.endswith(".R") for a in integ.aov_names()):
        raise BridgeError(f"{spec}: the scene's aov integrator has no nested integrator: it renders no radiance "
                          f"(nest one, e.g. <integrator type=\"path\"/>, or use the path integrator)")


def load_scene(spec, size=None, box_filter=False, params=None, sensor=None) -> Scene:
    """spec: "cornell" (Mitsuba's built-in Cornell box), a Mitsuba XML file, or a Python file
    defining scene() that returns a scene dictionary. size (w, h) overrides the film's; with
    box_filter the film's reconstruction filter becomes a box (for references). params: values of
    an XML scene's $name parameters ({name: text}, Mitsuba's -D name=value). sensor: which of
    the scene's sensors renders, an index in declaration order (as mi.render counts) or an id;
    None, the first. The scene is loaded with that sensor alone."""
    spec = os.fspath(spec)
    if params and (spec == "cornell" or spec.endswith(".py")):
        raise BridgeError(f"{spec}: parameters ({', '.join(sorted(params))}) are an XML scene's $name values; "
                          f"{'the Cornell box' if spec == 'cornell' else 'a Python scene'} has none")
    if size is not None and (size[0] < 1 or size[1] < 1 or size[0] > csid.MAX_SIDE or size[1] > csid.MAX_SIDE):
        raise BridgeError(f"image size {size[0]}x{size[1]} is not from 1x1 to {csid.MAX_SIDE}x{csid.MAX_SIDE}")
    # What can be checked without Mitsuba first: a bad path fails fast and without the import.
    if spec != "cornell" and os.path.isdir(spec):
        raise BridgeError(f"{spec}: a directory, not a scene file (give a Mitsuba XML file, a .py with scene(), or "
                          "'cornell')")
    if spec != "cornell" and os.path.exists(spec) and not os.path.isfile(spec):
        raise BridgeError(f"{spec}: not a regular file, not a scene file")
    if spec != "cornell" and not os.path.isfile(spec):
        raise BridgeError(f"{spec}: no such scene file (give a Mitsuba XML file, a .py with scene(), or 'cornell')")
    if spec != "cornell" and not spec.endswith(".py"):
        _xml_check(spec)
    mi = mitsuba()
    animate = None
    try:
        if spec == "cornell":
            scene = mi.load_dict(_film_dict_override(mi.cornell_box(), size, box_filter, sensor))
        elif spec.endswith(".py"):
            ns = runpy.run_path(spec)
            if not callable(ns.get("scene")):
                raise BridgeError(f"{spec}: defines no scene() function returning a Mitsuba scene dictionary")
            scene = mi.load_dict(_film_dict_override(ns["scene"](), size, box_filter, sensor))
            animate = ns.get("animate")
            if animate is not None and not callable(animate):
                raise BridgeError(f"{spec}: animate is not a function animate(params, time)")
        else:
            resolver = mi.Thread.thread().file_resolver()
            resolver.prepend(os.path.dirname(os.path.abspath(spec)))
            scene = _xml_load(mi, spec, size, box_filter, params, sensor)
    except BridgeError as e:
        raise BridgeError(str(e) if str(e).startswith(spec) else f"{spec}: {e}") from None
    except Exception as e:  # Mitsuba's parser and plugins raise RuntimeError with the reason
        raise BridgeError(f"{spec}: Mitsuba cannot load the scene: {_one_line(e)}") from None
    if not scene.sensors():
        raise BridgeError(f"{spec}: the scene has no sensor")
    _check_integrator(mi, scene, spec)
    film = scene.sensors()[0].film()
    w, h = (int(v) for v in film.crop_size())
    out = Scene(mi_scene=scene, size=(w, h), name=os.path.basename(spec), animate=animate,
                params=mi.traverse(scene) if animate else None)
    pose(out, 0.5)  # a still request of an animated scene sees the middle of the shutter
    return out


# ---- positions --------------------------------------------------------------------------------

def positions_request(out, spp=4, grid=None, method="poisson", seed=1, time_steps=1, fraction=None) -> csid.Dump:
    """The grid and positions csi wants, from csi's library (csi.positions on csi's grid rule:
    the request csi-positions writes, and csi-render's positions, for the same size, spp and
    seed)."""
    import csi

    w, h = int(out[0]), int(out[1])
    if grid:
        if grid % w:
            raise BridgeError(f"--grid {grid} is not a multiple of the image width {w}")
        factor = grid // w
    else:
        factor = None
    try:
        if factor is None:
            factor = csi.default_grid_factor(w, h, time_steps, spp)
        if max(w, h) * factor > csid.MAX_SIDE:
            raise BridgeError(f"fine grid {w * factor}x{h * factor} is larger than the limit {csid.MAX_SIDE} per side")
        g = (w * factor, h * factor, int(time_steps), w, h)
        xyt = csi.positions(g, spp=spp, method=method, seed=seed, fraction=fraction)
    except csi.CsiError as e:
        raise BridgeError(str(e)) from None
    return csid.Dump(grid=g[:3], out=(w, h), xyt=xyt, values=None, seed=int(seed))


# ---- rendering --------------------------------------------------------------------------------

@dataclasses.dataclass
class Samples:
    values: np.ndarray  # (n, 3) float32: mean radiance over the paths of each sample
    variance: np.ndarray | None  # (n, 3) float32: the variance of each value as an estimate of the
    #   radiance at its point (the paths' sample variance / paths), or None with one path per sample
    albedo: np.ndarray | None  # (n, 3) float32 at the first hit (aov), or None
    normal: np.ndarray | None  # (n, 3) float32 shading normal at the first hit (0 on a miss), or None
    paths: int
    nonfinite: int  # paths whose radiance was NaN/Inf, counted as 0 (Mitsuba's film would keep them)
    timing: dict


def _batch_seed(seed: int, batch: int) -> int:
    """A 32-bit seed per launch (splitmix64 of the user's seed and the batch number)."""
    z = (seed * 0x9E3779B97F4A7C15 + batch + 1) & 0xFFFFFFFFFFFFFFFF
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & 0xFFFFFFFFFFFFFFFF
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & 0xFFFFFFFFFFFFFFFF
    return (z ^ (z >> 31)) & 0xFFFFFFFF


#: Launch sizes are rounded up to a ladder: Dr.Jit compiles a kernel per launch size (the size
#: is part of the kernel's hash; for a path tracer the build costs far more than tracing a few
#: thousand paths) and caches it on disk. Rounded, a request of any size finds the kernel of an
#: earlier run: 8 sizes per octave, so the padding lanes cost at most 1/8 of a launch, and
#: below 8 steps of LADDER_MIN_STEP lanes at most one step.
LADDER_MIN_STEP = 1 << 14


def launch_size(n: int) -> int:
    """The lanes a launch of n points runs: n rounded up to the ladder."""
    step = max(1 << max(int(n).bit_length() - 4, 0), LADDER_MIN_STEP)
    return -(-int(n) // step) * step


def _aligned_lanes(a, m):
    """a as float32 in m lanes (the last value repeated), at a 64-byte boundary: Dr.Jit reads
    numpy's memory in place and compiles the load's alignment into the kernel, so an unaligned
    array would give the same kernel another hash and miss the cache."""
    buf = np.empty(m + 16, np.float32)
    off = (-buf.ctypes.data % 64) // 4
    out = buf[off:off + m]
    out[:len(a)] = a
    out[len(a):] = a[-1] if len(a) else 0.0
    return out


def _launch(scene, integrator, u, v, time_, seed, aov=False):
    """One Mitsuba launch over len(u) points: radiance (or the aov channels) at image points u, v.
    The launch runs launch_size(len(u)) lanes; lane i's random numbers depend on the seed and i
    only, so the padding lanes do not change the others'."""
    mi = mitsuba()
    import drjit as dr

    n = len(u)
    m = launch_size(n)
    sensor = scene.sensors()[0]
    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(dr.opaque(mi.UInt32, seed), m)  # opaque: the seed is a kernel input, not a constant baked into (and recompiling) the kernel
    pos = mi.Point2f(mi.Float(_aligned_lanes(u, m)), mi.Float(_aligned_lanes(v, m)))
    t = mi.Float(_aligned_lanes(time_, m))
    try:
        ray, weight = sensor.sample_ray(t, sampler.next_1d(), pos, sampler.next_2d())
        # The sensor's medium, as mi.render passes it: a camera inside fog sees through it.
        L, _, aovs = integrator.sample(scene, sampler, ray, medium=sensor.get_medium())
        if aov:
            out = np.stack([np.asarray(a)[:n] for a in aovs], axis=1)
        else:
            out = np.asarray(L * weight)
            if out.ndim != 2 or out.shape[1] != m:  # a constant: the integrator computes no radiance per ray
                raise BridgeError("the scene's integrator returns no radiance along the sensor's rays")
            out = out[:, :n].T
        dr.sync_thread()
    except BridgeError:
        raise
    except Exception as e:  # a plugin that cannot run in this variant (blackbody in RGB, ...)
        raise BridgeError(f"Mitsuba cannot render the scene: {_root_cause(e)}") from None
    return out.astype(np.float32, copy=False)


def render_request(scene: Scene, req: csid.Dump, paths=1, seed=None, aov=False, progress=None) -> Samples:
    """Evaluates a positions request with the scene's sensor and integrator: `paths` paths per
    sample, averaged. seed defaults to the request's. aov adds per-sample albedo and normal.
    progress(done, total) is called after each launch."""
    if req.out != scene.size:
        raise BridgeError(f"the request is for a {req.out[0]}x{req.out[1]} image but the scene's film is "
                          f"{scene.size[0]}x{scene.size[1]}: load the scene with size={req.out}")
    if paths < 1:
        raise BridgeError(f"paths per sample must be >= 1 (got {paths})")
    mi = mitsuba()
    seed = req.seed if seed is None else int(seed)
    if scene.animate is not None and req.grid[2] > 1:
        if aov:
            raise BridgeError(f"{scene.name}: albedo and normal (aov) are not available for an animated scene")
        return _render_frames(scene, req, paths, seed, progress)
    s = scene.mi_scene
    sensor = s.sensors()[0]
    u, v, tt = req.cell_centres()
    time_ = sensor.shutter_open() + tt * sensor.shutter_open_time()
    n = len(u)
    integrator = s.integrator()

    # The first launch traces Mitsuba's kernels (seconds the first time on a machine): time it
    # apart on a few lanes. (Dr.Jit still builds a kernel per launch size, on launch_size's
    # ladder, and caches it on disk: render_s below is the warm cost once a run has used that
    # rung.)
    t0 = time.perf_counter()
    k = min(n, 256)
    _launch(s, integrator, u[:k], v[:k], time_[:k], _batch_seed(seed, 1 << 40))
    jit_s = time.perf_counter() - t0

    per = max(1, BATCH_LANES // paths)  # samples per launch
    values = np.empty((n, 3), np.float32)
    variance = np.empty((n, 3), np.float32) if paths > 1 else None
    nonfinite = 0
    t0 = time.perf_counter()
    for b, i0 in enumerate(range(0, n, per)):
        i1 = min(n, i0 + per)
        rep = lambda a: np.repeat(a[i0:i1], paths)  # sample-major: a sample's paths are adjacent
        L = _launch(s, integrator, rep(u), rep(v), rep(time_), _batch_seed(seed, b)).astype(np.float64)
        bad = ~np.isfinite(L).all(axis=1)
        if bad.any():
            nonfinite += int(bad.sum())
            L[bad] = 0.0
        values[i0:i1] = L.reshape(i1 - i0, paths, 3).mean(axis=1)
        if variance is not None:
            variance[i0:i1] = L.reshape(i1 - i0, paths, 3).var(axis=1, ddof=1) / paths
        if progress:
            progress(i1, n)
    render_s = time.perf_counter() - t0

    albedo = normal = None
    aov_s = 0.0
    if aov:
        aov_int = mi.load_dict({"type": "aov", "aovs": "a:albedo,n:sh_normal"})
        _launch(s, aov_int, u[:k], v[:k], time_[:k], 0, aov=True)  # compile apart, as above
        t0 = time.perf_counter()
        a = np.empty((n, 6), np.float32)
        for b, i0 in enumerate(range(0, n, BATCH_LANES)):
            i1 = min(n, i0 + BATCH_LANES)
            a[i0:i1] = _launch(s, aov_int, u[i0:i1], v[i0:i1], time_[i0:i1], _batch_seed(seed, (1 << 41) + b), aov=True)
        aov_s = time.perf_counter() - t0
        a[~np.isfinite(a)] = 0.0
        albedo, normal = a[:, :3].copy(), a[:, 3:].copy()
    timing = {"jit_s": jit_s, "render_s": render_s, "samples": n, "paths": n * paths,
              "per_sample_us": 1e6 * render_s / n, "per_path_us": 1e6 * render_s / (n * paths), "aov_s": aov_s}
    return Samples(values=values, variance=variance, albedo=albedo, normal=normal, paths=paths,
                   nonfinite=nonfinite, timing=timing)


def _render_frames(scene: Scene, req: csid.Dump, paths, seed, progress) -> Samples:
    """render_request of an animated scene: the samples of each time step t evaluated with the
    scene posed at (t + 0.5) / T. Every launch has the same number of lanes (the last one of a
    frame padded by repeating its first sample), so Dr.Jit compiles one kernel for all frames
    and poses."""
    s = scene.mi_scene
    sensor = s.sensors()[0]
    integrator = s.integrator()
    u, v, tt = req.cell_centres()
    time_ = sensor.shutter_open() + tt * sensor.shutter_open_time()
    n, T = len(u), req.grid[2]
    ts = req.xyt[:, 2].astype(np.int64)
    order = np.argsort(ts, kind="stable")
    counts = np.bincount(ts, minlength=T)
    starts = np.concatenate([[0], np.cumsum(counts)])
    per = max(1, min(BATCH_LANES // paths, int(counts.max())))  # samples per launch
    lanes = lambda a, sel: np.repeat(a[sel], paths)

    t0 = time.perf_counter()
    first = order[np.zeros(per, np.int64)]
    _launch(s, integrator, lanes(u, first), lanes(v, first), lanes(time_, first), _batch_seed(seed, 1 << 40))
    jit_s = time.perf_counter() - t0

    values = np.empty((n, 3), np.float32)
    variance = np.empty((n, 3), np.float32) if paths > 1 else None
    nonfinite = 0
    t0 = time.perf_counter()
    for t in range(T):
        if counts[t] == 0:
            continue
        pose(scene, (t + 0.5) / T)
        mine = order[starts[t]:starts[t + 1]]
        for c, i0 in enumerate(range(0, len(mine), per)):
            chunk = mine[i0:i0 + per]
            sel = np.concatenate([chunk, np.full(per - len(chunk), chunk[0])])
            L = _launch(s, integrator, lanes(u, sel), lanes(v, sel), lanes(time_, sel),
                        _batch_seed(seed, (1 << 42) + (t << 20) + c)).astype(np.float64)
            L = L[: len(chunk) * paths]
            bad = ~np.isfinite(L).all(axis=1)
            if bad.any():
                nonfinite += int(bad.sum())
                L[bad] = 0.0
            values[chunk] = L.reshape(len(chunk), paths, 3).mean(axis=1)
            if variance is not None:
                variance[chunk] = L.reshape(len(chunk), paths, 3).var(axis=1, ddof=1) / paths
        if progress:
            progress(int(starts[t + 1]), n)
    render_s = time.perf_counter() - t0
    pose(scene, 0.5)
    timing = {"jit_s": jit_s, "render_s": render_s, "samples": n, "paths": n * paths,
              "per_sample_us": 1e6 * render_s / n, "per_path_us": 1e6 * render_s / (n * paths), "aov_s": 0.0}
    return Samples(values=values, variance=variance, albedo=None, normal=None, paths=paths,
                   nonfinite=nonfinite, timing=timing)


def render(spec, size=None, spp=4, paths=1, seed=1, method="poisson", grid=None, aov=False):
    """Everything in one call: the scene (see load_scene) at csi's positions for `spp` samples
    per pixel, `paths` paths each. Returns (dump, samples): dump a csi.dump.Dump with the values
    (write it with csi.dump.write), samples the Samples (values, albedo, normal, timing)."""
    scene = load_scene(spec, size=size)
    req = positions_request(scene.size, spp=spp, grid=grid, method=method, seed=seed)
    s = render_request(scene, req, paths=paths, seed=seed, aov=aov)
    return req.with_values(s.values, exact=False), s  # path-traced: Monte Carlo estimates, never exact


def render_reference(scene: Scene, spp: int, seed=0, progress=None) -> np.ndarray:
    """Mitsuba's own render of the scene (load it with box_filter=True for csi's box pixels):
    (h, w, 3) float32, the mean of passes of mi.render with different seeds, each pass at most
    BATCH_LANES samples, so memory stays bounded at any spp."""
    mi = mitsuba()
    w, h = scene.size
    limit = max(1, BATCH_LANES // (w * h))
    per = max(d for d in range(1, min(spp, limit) + 1) if spp % d == 0)
    acc = np.zeros((h, w, 3))
    passes = spp // per
    for i in range(passes):
        try:
            img = np.asarray(mi.render(scene.mi_scene, spp=per, seed=_batch_seed(seed, i)), dtype=np.float64)
        except Exception as e:
            raise BridgeError(f"{scene.name}: Mitsuba cannot render the scene: {_root_cause(e)}") from None
        if img.ndim != 3 or img.shape[2] < 3:
            raise BridgeError(f"{scene.name}: Mitsuba's image has {img.shape[-1]} channel(s), not RGB")
        acc += img[..., :3]
        if progress:
            progress(i + 1, passes)
    return (acc / passes).astype(np.float32)


PATH_NOISE_CELLS = 1024


def path_noise(scene: Scene, req: csid.Dump, values, seed, cells=None):
    """The variance of one path's radiance per channel, averaged over a request's cells, for
    samples of one path (`values`, which carry no variance of their own): one more path through
    `cells` of the samples (default one in 16, at least 64 and at most PATH_NOISE_CELLS), spread
    evenly over the request's order (every frame of an animation); each pair, the sample's own
    path and the new one, independent estimates of the same cell, gives (a - b)^2 / 2, and these
    are averaged. An animation's solve needs only this mean (csi_samples.variance;
    CSI_MOTION_TAU_NOISE in csi/reconstruct.h), so csi-mitsuba hands it to csi as every sample's
    variance. Returns ((3,) float64, Mitsuba's timing of the extra paths)."""
    n = len(req.xyt)
    if n == 0:
        return np.zeros(3), {}
    m = min(n, int(cells) if cells else max(64, min(PATH_NOISE_CELLS, n // 16)))
    idx = np.unique(np.linspace(0, n - 1, m).round().astype(np.int64))
    sub = csid.Dump(grid=req.grid, out=req.out, xyt=req.xyt[idx], values=None, seed=req.seed)
    s = render_request(scene, sub, paths=1, seed=seed)
    d = np.asarray(values, np.float64)[idx] - s.values.astype(np.float64)
    return 0.5 * (d * d).mean(axis=0), s.timing


def render_reference_frames(scene: Scene, frames: int, spp: int, seed=0, progress=None) -> np.ndarray:
    """The reference of an animation: render_reference of each of `frames` time steps with the
    scene posed at (t + 0.5) / frames, (frames, h, w, 3) float32. Every frame is rendered with
    the same seeds, so what does not change between two poses has the same bits in both (a
    still scene gives the same image for every t): the reference's own noise does not flicker,
    and a frame-to-frame difference measures the motion only. The motion-blurred reference of
    the paper's discrete model is their mean over t."""
    out = []
    for t in range(frames):
        pose(scene, (t + 0.5) / frames)
        out.append(render_reference(scene, spp, seed=seed))
        if progress:
            progress(t + 1, frames)
    pose(scene, 0.5)
    return np.stack(out)
