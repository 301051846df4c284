"""Glossy highlights under a sun: spheres of decreasing roughness on a diffuse checkered ground,
lit by a directional sun (irradiance 10, from behind the spheres on the left) and a dim blue sky. The sun's reflection in the
glossiest sphere is a small highlight hundreds of times brighter than the ground around it:
the HDR step side by side with smooth shading that csi's samples have to carry."""
import mitsuba as mi

T = mi.ScalarTransform4f


def scene():
    spheres = {}
    for i, (alpha, colour) in enumerate([(0.02, [0.8, 0.2, 0.15]), (0.06, [0.15, 0.5, 0.8]), (0.15, [0.85, 0.75, 0.3])]):
        spheres[f"sphere{i}"] = {
            "type": "sphere", "center": [-1.3 + 1.3 * i, 0.5, 0.3 * (i % 2)], "radius": 0.5,
            "bsdf": {"type": "roughplastic", "distribution": "ggx", "alpha": alpha,
                     "diffuse_reflectance": {"type": "rgb", "value": colour}},
        }
    spheres["chrome"] = {"type": "sphere", "center": [0.65, 0.25, 1.2], "radius": 0.25,
                         "bsdf": {"type": "roughconductor", "material": "Al", "alpha": 0.03}}
    return {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 6},
        "sensor": {"type": "perspective", "fov": 40,
                   "to_world": T().look_at(origin=[0.3, 1.6, 5.0], target=[0, 0.45, 0], up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": 128, "height": 128, "rfilter": {"type": "box"}}},
        "sun": {"type": "directional", "direction": [0.55, -0.5, 0.65],
                "irradiance": {"type": "rgb", "value": [10.0, 9.3, 8.3]}},
        "sky": {"type": "constant", "radiance": {"type": "rgb", "value": [0.15, 0.2, 0.3]}},
        "ground": {"type": "rectangle", "to_world": T().rotate([1, 0, 0], -90).scale(8),
                   "bsdf": {"type": "diffuse", "reflectance": {
                       "type": "checkerboard", "color0": {"type": "rgb", "value": [0.6, 0.6, 0.6]},
                       "color1": {"type": "rgb", "value": [0.2, 0.2, 0.22]}, "to_uv": T().scale([16, 16, 1])}}},
        **spheres,
    }
