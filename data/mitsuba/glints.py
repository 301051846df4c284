"""Many sub-pixel glints: 400 small polished metal beads (GGX roughness 0.06, a third of a pixel to
two pixels across) scattered over a dark diffuse floor under a low sun and a dim sky. Each bead
shows a sun highlight far smaller than a pixel and hundreds of times brighter than the floor, so
a sample that lands on one over-reads its pixel and one that misses under-reads it: a field of
isolated peaks that are the image, not noise (precise with many paths per sample), the case
against which a rule that keeps such peaks has to be measured."""
import mitsuba as mi
import numpy as np

T = mi.ScalarTransform4f


def scene():
    rng = np.random.default_rng(7)  # fixed: the scene is data
    beads = {}
    for i in range(400):
        x, z = rng.uniform(-2.0, 2.0, 2)
        r = float(rng.uniform(0.006, 0.035))
        beads[f"bead{i}"] = {
            "type": "sphere", "center": [float(x), r, float(z)], "radius": r,
            "bsdf": {"type": "roughconductor", "material": "Au" if i % 3 == 0 else "Ag", "distribution": "ggx",
                     "alpha": 0.06},
        }
    return {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 6},
        "sensor": {"type": "perspective", "fov": 45,
                   "to_world": T().look_at(origin=[0, 3.2, 3.2], target=[0, 0, 0], up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": 128, "height": 128, "rfilter": {"type": "box"}}},
        "sun": {"type": "directional", "direction": [0.3, -0.45, -0.85],
                "irradiance": {"type": "rgb", "value": [10.0, 9.4, 8.6]}},
        "sky": {"type": "constant", "radiance": {"type": "rgb", "value": [0.08, 0.1, 0.15]}},
        "floor": {"type": "rectangle", "to_world": T().rotate([1, 0, 0], -90).scale(4),
                  "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.08, 0.07, 0.06]}}},
        **beads,
    }
