"""An animated object (csi's animation benchmark, issue 12): a still camera looks at a textured
wall and a checkered floor; a large striped ball rolls across the frame (translation and the
matching rotation) and a small bright ball flies over it the other way, fast: a large mover
and a small fast one on a static background (the paper's BILLIARDS situation). Sun and sky,
path traced (3 bounces). animate(params, time) poses both objects at shutter time in [0, 1]
(Mitsuba has no motion blur of its own: the bridge re-poses the scene for each time step)."""
import math
import os

import mitsuba as mi

T = mi.ScalarTransform4f
TEXTURES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "textures")
R = 0.5  # the ball's radius


def ball(time):
    x = -1.6 + 3.2 * time  # rolls without slipping: angle = distance / radius
    return T().translate([x, R, 0.3]).rotate([0, 0, 1], -math.degrees(3.2 * time / R)).scale(R)


def flyer(time):
    x = 2.0 - 4.0 * time
    return T().translate([x, 1.55 + 0.3 * math.sin(math.pi * time), 1.2]).scale(0.12)


def scene():
    return {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 4},
        "sensor": {"type": "perspective", "fov": 45,
                   "to_world": T().look_at(origin=[0, 1.3, 4.5], target=[0, 0.7, 0], up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": 128, "height": 128, "rfilter": {"type": "box"}}},
        "sun": {"type": "directional", "direction": [-0.3, -0.8, -0.5],
                "irradiance": {"type": "rgb", "value": [3.0, 2.85, 2.6]}},
        "sky": {"type": "constant", "radiance": {"type": "rgb", "value": [0.25, 0.3, 0.4]}},
        "floor": {"type": "rectangle", "to_world": T().rotate([1, 0, 0], -90).scale(8),
                  "bsdf": {"type": "diffuse", "reflectance": {
                      "type": "checkerboard", "color0": {"type": "rgb", "value": [0.65, 0.65, 0.62]},
                      "color1": {"type": "rgb", "value": [0.25, 0.25, 0.27]}, "to_uv": T().scale([12, 12, 1])}}},
        "wall": {"type": "rectangle", "to_world": T().translate([0, 2.0, -1.5]).scale([6, 2.0, 1]),
                 "bsdf": {"type": "diffuse", "reflectance": {
                     "type": "bitmap", "filename": os.path.join(TEXTURES, "wood.png"),
                     "to_uv": T().scale([3, 1, 1])}}},
        "ball": {"type": "sphere", "to_world": ball(0.5),
                 "bsdf": {"type": "diffuse", "reflectance": {
                     "type": "bitmap", "filename": os.path.join(TEXTURES, "ball.png")}}},
        "flyer": {"type": "sphere", "to_world": flyer(0.5),
                 "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.95, 0.9, 0.4]}}},
    }


def animate(params, time):
    params["ball.to_world"] = ball(time)
    params["flyer.to_world"] = flyer(time)
