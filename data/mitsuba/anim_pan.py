"""An animated camera (csi's animation benchmark, issue 12): the camera slides sideways past
three spheres on a checkered floor in front of a brick wall, looking straight ahead, so the
image pans, and with parallax: the near spheres move across the frame faster than the wall
behind them (several velocities at once, like the paper's TRAIN scene). Lit by a sun and a dim
sky; path traced (3 bounces). animate(params, time) poses the camera at shutter time in [0, 1]
(Mitsuba has no motion blur of its own: the bridge re-poses the scene for each time step)."""
import os

import mitsuba as mi

T = mi.ScalarTransform4f
TEXTURES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "textures")
SLIDE = 1.2  # camera travel over the shutter (scene units; the wall is 6 units away)


def camera(time):
    x = -0.5 * SLIDE + SLIDE * time
    return T().look_at(origin=[x, 1.1, 4.0], target=[x, 0.8, -2.0], up=[0, 1, 0])


def scene():
    spheres = {}
    for i, (pos, colour) in enumerate([([-1.1, 0.45, 1.2], [0.8, 0.25, 0.15]), ([0.2, 0.45, 0.2], [0.2, 0.5, 0.8]),
                                       ([1.4, 0.45, 1.0], [0.85, 0.75, 0.3])]):
        spheres[f"sphere{i}"] = {"type": "sphere", "center": pos, "radius": 0.45,
                                 "bsdf": {"type": "plastic", "diffuse_reflectance": {"type": "rgb", "value": colour}}}
    return {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 4},
        "sensor": {"type": "perspective", "fov": 45, "to_world": camera(0.5),
                   "film": {"type": "hdrfilm", "width": 128, "height": 128, "rfilter": {"type": "box"}}},
        "sun": {"type": "directional", "direction": [-0.4, -0.7, -0.6],
                "irradiance": {"type": "rgb", "value": [3.0, 2.85, 2.6]}},
        "sky": {"type": "constant", "radiance": {"type": "rgb", "value": [0.25, 0.3, 0.4]}},
        "floor": {"type": "rectangle", "to_world": T().rotate([1, 0, 0], -90).scale(8),
                  "bsdf": {"type": "diffuse", "reflectance": {
                      "type": "checkerboard", "color0": {"type": "rgb", "value": [0.65, 0.65, 0.62]},
                      "color1": {"type": "rgb", "value": [0.25, 0.25, 0.27]}, "to_uv": T().scale([12, 12, 1])}}},
        "wall": {"type": "rectangle", "to_world": T().translate([0, 2.0, -2.0]).scale([6, 2.0, 1]),
                 "bsdf": {"type": "diffuse", "reflectance": {
                     "type": "bitmap", "filename": os.path.join(TEXTURES, "bricks.png"),
                     "to_uv": T().scale([4, 1.4, 1])}}},
        **spheres,
    }


def animate(params, time):
    params["sensor.to_world"] = camera(time)
