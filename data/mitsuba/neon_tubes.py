"""Thin saturated emitters on a dim wall: tubes of coloured light (radiance about 30 / 90 / 160 in
R / G / B, and a red and a green one), a half to one pixel wide, in front of a dim orange wall
(about 2.2 / 0.45 / 0.06 under a weak ambient light). A tube is a step of up to 3000:1 in one
channel across a pixel edge, so a pixel next to a tube that gets no sample of its own (csi's
Poisson-disk positions at 1 spp) is where any blur of the tube's light into the wall is a large
relative error: the case of a user's report in issue 9."""
import mitsuba as mi

T = mi.ScalarTransform4f


def scene():
    wall = {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.7, 0.14, 0.02]}}
    d = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 4},
        "sensor": {"type": "perspective", "fov": 45,
                   "to_world": T().look_at(origin=[0, 0, 4.0], target=[0, 0, 0], up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": 128, "height": 128, "rfilter": {"type": "box"}}},
        # a dim warm ambient light: the wall reads about (2.2, 0.45, 0.06) away from the tubes
        "ambient": {"type": "constant", "radiance": {"type": "rgb", "value": [3.0, 3.0, 3.0]}},
        "wall": {"type": "rectangle", "to_world": T().scale(3.0), "bsdf": wall},
        "floor": {"type": "rectangle", "to_world": T().translate([0, -1.7, 2]).rotate([1, 0, 0], -90).scale(3),
                  "bsdf": wall},
    }
    # A pixel of the 128x128 image is about 26 mm on the wall: radii of 6-13 mm make tubes from
    # half a pixel to one pixel wide, a few cm in front of the wall (they light it).
    blue = [30.0, 90.0, 160.0]
    tubes = [  # (p0, p1, radius, radiance)
        ([-1.3, 0.9, 0.05], [1.3, 0.9, 0.05], 0.013, blue),
        ([-1.3, 0.3, 0.05], [0.6, 0.3, 0.05], 0.008, blue),
        ([-0.9, -1.3, 0.05], [-0.9, 1.3, 0.05], 0.011, blue),
        ([0.4, -1.2, 0.05], [1.2, 0.2, 0.05], 0.010, blue),
        ([-1.2, -0.5, 0.05], [0.9, -0.5, 0.05], 0.006, [160.0, 25.0, 8.0]),
        ([0.9, -1.3, 0.05], [0.9, 1.3, 0.05], 0.009, [15.0, 140.0, 30.0]),
    ]
    for i, (p0, p1, r, rad) in enumerate(tubes):
        d[f"tube{i}"] = {"type": "cylinder", "p0": p0, "p1": p1, "radius": r,
                         "emitter": {"type": "area", "radiance": {"type": "rgb", "value": rad}}}
    return d
