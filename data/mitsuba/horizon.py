"""A textured plane to the horizon: a checkerboard ground (procedural, so its squares stay sharp
however small they get) running from the camera's feet to the horizon under a sky (a vertical
gradient from pale blue at the horizon to deep blue overhead, an environment map made here) and
a low sun (irradiance 6) that puts a highlight on a glossy sphere near the camera. Towards the
horizon the squares fall below a pixel: detail no sampling rate resolves, which the box filter
averages to grey."""
import mitsuba as mi
import numpy as np

T = mi.ScalarTransform4f


def sky(width=256, height=128):
    """Equirectangular sky, rows from the zenith (row 0) to the nadir: blue overhead, pale at the
    horizon, dark below it (the ground hides that half)."""
    theta = (np.arange(height) + 0.5) / height * np.pi  # polar angle from +y
    up = np.cos(theta)[:, None]
    zenith, horizon = np.array([0.15, 0.3, 0.8]), np.array([0.8, 0.85, 0.9])
    t = np.clip(up, 0, 1) ** 0.5
    rgb = np.where(up[..., None] >= 0, (1 - t[..., None]) * horizon + t[..., None] * zenith, 0.1 * horizon)
    return np.ascontiguousarray(np.broadcast_to(rgb, (height, width, 3)), dtype=np.float32)


def scene():
    return {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 5},
        "sensor": {"type": "perspective", "fov": 50,
                   "to_world": T().look_at(origin=[0, 1.0, 0], target=[0.0, 0.55, -4.0], up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": 128, "height": 128, "rfilter": {"type": "box"}}},
        "sky": {"type": "envmap", "bitmap": mi.Bitmap(sky()), "scale": 1.0},
        "sun": {"type": "directional", "direction": [-0.4, -0.3, 0.87],
                "irradiance": {"type": "rgb", "value": [6.0, 5.4, 4.5]}},
        "ground": {"type": "rectangle", "to_world": T().rotate([1, 0, 0], -90).scale(500),
                   "bsdf": {"type": "diffuse", "reflectance": {
                       "type": "checkerboard", "color0": {"type": "rgb", "value": [0.75, 0.75, 0.72]},
                       "color1": {"type": "rgb", "value": [0.08, 0.08, 0.1]}, "to_uv": T().scale([1000, 1000, 1])}}},
        "ball": {"type": "sphere", "center": [0.9, 0.45, -3.0], "radius": 0.45,
                 "bsdf": {"type": "roughplastic", "distribution": "ggx", "alpha": 0.04,
                          "diffuse_reflectance": {"type": "rgb", "value": [0.1, 0.3, 0.12]}}},
    }
