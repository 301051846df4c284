"""A street at night: sub-pixel street lamps (radiance 300-600, each smaller than a pixel, so
its light lives inside one or two pixels) on poles along both sides of a wet road (a glossy dark
plastic that reflects them in streaks), dim building fronts and a dark sky (about 0.05). A lamp
is a step of thousands to one inside a single pixel with dark pixels all around it, so a pixel
next to it that gets no sample of its own (csi's Poisson-disk positions at 1 spp) is where any
blur of the lamp's light is a large relative error: the case of a user's report in issue 9,
where an extended emitter's edge (the Cornell box's) is not."""
import mitsuba as mi

T = mi.ScalarTransform4f


def scene():
    # eye height, looking down the street
    eye = T().look_at(origin=[0.6, 1.7, 6.0], target=[0, 1.2, -30.0], up=[0, 1, 0])
    film = {"type": "hdrfilm", "width": 128, "height": 128, "rfilter": {"type": "box"}}
    d = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 4},
        "sensor": {"type": "perspective", "fov": 50, "to_world": eye, "film": film},
        "sky": {"type": "constant", "radiance": {"type": "rgb", "value": [0.04, 0.05, 0.07]}},
        # the wet road: a dark glossy plastic, low roughness, that mirrors the lamps in streaks
        "road": {"type": "rectangle", "to_world": T().translate([0, 0, -40]).rotate([1, 0, 0], -90).scale([7, 50, 1]),
                 "bsdf": {"type": "roughplastic", "distribution": "ggx", "alpha": 0.02,
                          "diffuse_reflectance": {"type": "rgb", "value": [0.05, 0.05, 0.05]}}},
    }
    wall = {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.35, 0.3, 0.25]}}
    for side, x in (("left", -7.0), ("right", 7.0)):
        rot = 90 if x < 0 else -90
        d[f"front_{side}"] = {"type": "rectangle", "bsdf": wall,
                              "to_world": T().translate([x, 8, -40]).rotate([0, 1, 0], rot).scale([50, 8, 1])}
    # Lamps on 5 m poles every 9 m down both sides; warm, radiance 300-600 by lamp. A pixel spans
    # about 0.0068 rad, so a sphere of radius r at distance t covers pi r^2 / (0.0068 t)^2 of one:
    # the radius is set from the distance to the camera for a lamp of 10-60% of a pixel's area.
    poles = {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.08, 0.08, 0.08]}}
    for i in range(7):
        z = -3.0 - 9.0 * i
        for j, x in enumerate((-5.5, 5.5)):
            k = 2 * i + j
            rad = 300.0 + 300.0 * ((k * 5) % 7) / 6.0
            t = ((x - 0.6) ** 2 + (5.0 - 1.7) ** 2 + (z - 6.0) ** 2) ** 0.5
            cover = 0.1 + 0.5 * ((k * 3) % 5) / 4.0
            d[f"lamp{k}"] = {"type": "sphere", "center": [x, 5.0, z], "radius": 0.0068 * t * (cover / 3.14159) ** 0.5,
                             "emitter": {"type": "area", "radiance": {"type": "rgb", "value": [rad, 0.8 * rad, 0.5 * rad]}}}
            d[f"pole{k}"] = {"type": "cylinder", "p0": [x, 0, z], "p1": [x, 4.9, z], "radius": 0.04, "bsdf": poles}
    return d
