"""The bridge's Mitsuba launches run a ladder of sizes so that a request of any size reuses a kernel
Dr.Jit has compiled before, and the padding lanes change nothing:

- launch_size(n) against exact integer arithmetic: at least n, less than n + its step, at most
  8 sizes per octave from 2^17 up, non-decreasing;
- a launch's values are bit for bit those of Mitsuba evaluated directly on exactly those points
  (the same sampler, seed and calls, no padding), and a point's value does not depend on how
  many points share its launch;
- two launches whose sizes round to the same rung run the same kernel: Dr.Jit's kernel history
  shows one hash and a cache hit for the second, even when the caller's arrays sit at different
  alignments (Dr.Jit compiles a load's alignment into the kernel).
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "host", "python"))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from checks import check, done  # noqa: E402
from csi import mitsuba_bridge as mb  # noqa: E402


def check_ladder():
    ns = np.concatenate([np.arange(1, 300000), np.random.default_rng(5).integers(300000, 1 << 26, 20000)])
    sizes = np.array([mb.launch_size(int(n)) for n in ns], dtype=np.int64)
    step = np.maximum(2 ** np.maximum(np.floor(np.log2(ns)).astype(np.int64) - 3, 0), mb.LADDER_MIN_STEP)
    check((sizes >= ns).all() and (sizes - ns < step).all(), "launch_size: n <= size < n + step")
    check((sizes % step == 0).all(), "launch_size: a multiple of the step")
    big = ns >= 1 << 17
    check((sizes[big] * 8 <= ns[big] * 9 + 8 * step[big]).all() and (sizes[big] - ns[big] < ns[big] / 8).all(),
          "launch_size: at most 1/8 of padding from 2^17 up")
    order = np.argsort(ns, kind="stable")
    check((np.diff(sizes[order]) >= 0).all(), "launch_size is non-decreasing")
    for k in range(17, 26):
        rungs = {mb.launch_size(n) for n in range(1 << k, 1 << (k + 1), 997)} | {mb.launch_size((1 << (k + 1)) - 1)}
        check(len(rungs) <= 8 + 1, f"octave 2^{k}: {len(rungs)} launch sizes")  # + 1: its top rung is the next octave's first


def direct(scene, integrator, u, v, seed):
    """Mitsuba on exactly these points: the bridge's calls without its ladder."""
    mi = mb.mitsuba()
    import drjit as dr

    n = len(u)
    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(dr.opaque(mi.UInt32, seed), n)
    pos = mi.Point2f(mi.Float(u.astype(np.float32)), mi.Float(v.astype(np.float32)))
    ray, weight = scene.sensors()[0].sample_ray(mi.Float(np.zeros(n, np.float32)), sampler.next_1d(), pos,
                                                sampler.next_2d())
    L, _, _ = integrator.sample(scene, sampler, ray)
    return np.asarray(L * weight).T.astype(np.float32)


def main():
    check_ladder()
    mi = mb.mitsuba()
    import drjit as dr

    sc = mb.load_scene("cornell", size=(16, 16))
    s, integrator = sc.mi_scene, sc.mi_scene.integrator()
    rng = np.random.default_rng(3)
    u, v = rng.random(20000), rng.random(20000)
    t = np.zeros(20000)
    small = mb._launch(s, integrator, u[:1000], v[:1000], t[:1000], 11)        # 16384 lanes
    large = mb._launch(s, integrator, u, v, t, 11)                               # 32768 lanes
    ref = direct(s, integrator, u[:1000], v[:1000], 11)
    check(small.shape == (1000, 3) and large.shape == (20000, 3), f"shapes {small.shape} {large.shape}")
    check(np.array_equal(small, ref), f"padded launch vs Mitsuba on the points alone: max |diff| {np.abs(small - ref).max()}")
    check(np.array_equal(large[:1000], small), "a point's value depends on its launch's size")
    check(np.isfinite(small).all() and (small > 0).any() and np.unique(small).size > 100,
          "the Cornell box's samples look like radiance")

    # one rung, two sizes, the caller's arrays at other alignments: one kernel
    dr.set_flag(dr.JitFlag.KernelHistory, True)
    dr.kernel_history()  # clears it
    for n, off in ((17000, 1), (19999, 3)):  # both on the rung of 32768 lanes
        buf = np.empty(n + off, np.float32)[off:]
        buf[:] = u[:n]
        mb._launch(s, integrator, buf, v[:n], t[:n], 11)
    jit = [k for k in dr.kernel_history() if k["type"] == dr.KernelType.JIT]
    dr.set_flag(dr.JitFlag.KernelHistory, False)
    hashes = [k["hash"] for k in jit]
    check(len(jit) >= 2 and len(set(hashes)) == len(hashes) // 2 and jit[-1]["cache_hit"],
          f"two launches on one rung compiled {len(set(hashes))} kernels: {[(k['hash'][:8], k['size'], k['cache_hit']) for k in jit]}")
    return done()


if __name__ == "__main__":
    sys.exit(main())
