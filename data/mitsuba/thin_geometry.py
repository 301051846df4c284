"""An HDR emitter seen through thin geometry: a window (an area emitter of radiance 60) in the
back wall of a dim room, behind a lattice of thin bars (4-16 mm radius at about 3.6 m, where a
pixel of the 128x128 image is about 25 mm: a third of a pixel to more than one pixel wide). Every bar is a step between about 60 and about 0.1
across less than a pixel, and the room is lit only by the window, so most of the image is dark
indirect light, noisy at one path per sample."""
import mitsuba as mi

T = mi.ScalarTransform4f


def scene():
    grey = {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.4, 0.4, 0.4]}}
    dark = {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.1, 0.08, 0.06]}}
    d = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 6},
        "sensor": {"type": "perspective", "fov": 45,
                   "to_world": T().look_at(origin=[0.4, 0.1, 4.0], target=[0, 0, -1], up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": 128, "height": 128, "rfilter": {"type": "box"}}},
        "window": {"type": "rectangle", "to_world": T().translate([0, 0.2, -1.99]).scale([0.9, 0.7, 1]),
                   "emitter": {"type": "area", "radiance": {"type": "rgb", "value": [60.0, 57.0, 50.0]}}},
        "back": {"type": "rectangle", "to_world": T().translate([0, 0, -2.0]).scale(2.0), "bsdf": grey},
        "floor": {"type": "rectangle", "to_world": T().translate([0, -1.2, 0]).rotate([1, 0, 0], -90).scale(4), "bsdf": grey},
        "ceiling": {"type": "rectangle", "to_world": T().translate([0, 1.6, 0]).rotate([1, 0, 0], 90).scale(4), "bsdf": grey},
        "left": {"type": "rectangle", "to_world": T().translate([-2.0, 0, 0]).rotate([0, 1, 0], 90).scale(4), "bsdf": grey},
        "right": {"type": "rectangle", "to_world": T().translate([2.0, 0, 0]).rotate([0, 1, 0], -90).scale(4), "bsdf": grey},
    }
    # The lattice: vertical and horizontal bars in front of the window, radii varied so that
    # some bars are well under a pixel wide and some about one pixel.
    for i in range(9):
        x = -0.8 + 0.2 * i
        d[f"vbar{i}"] = {"type": "cylinder", "p0": [x, -0.6, -1.6], "p1": [x, 1.0, -1.6],
                         "radius": 0.004 * (1 + i % 4), "bsdf": dark}
    for j in range(6):
        y = -0.4 + 0.25 * j
        d[f"hbar{j}"] = {"type": "cylinder", "p0": [-1.0, y, -1.5], "p1": [1.0, y, -1.5],
                         "radius": 0.004 * (1 + j % 3), "bsdf": dark}
    # A rotated diagonal wire: no alignment with the pixel grid.
    d["diag"] = {"type": "cylinder", "p0": [-0.9, -0.5, -1.4], "p1": [0.9, 0.9, -1.4], "radius": 0.005, "bsdf": dark}
    return d
