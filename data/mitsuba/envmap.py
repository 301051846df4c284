"""Objects lit by an environment map made here (no download): an equirectangular HDR sky with a
small sun (radiance 20000 over a disc of 1.5 degrees), bright window-like panels along the
horizon and a dim ground, reflected by a mirror sphere, a rough metal sphere and a diffuse one
on a grey floor. The sun makes a highlight far brighter than everything else in the mirror and a
hard shadow; the panels give sharp reflected edges."""
import mitsuba as mi
import numpy as np

T = mi.ScalarTransform4f


def environment(width=512, height=256):
    theta = (np.arange(height) + 0.5) / height * np.pi  # polar angle from +y (row 0: zenith)
    phi = (np.arange(width) + 0.5) / width * 2 * np.pi
    up = np.cos(theta)[:, None] * np.ones((1, width))
    t = np.clip(up, 0, 1)[..., None]
    img = (1 - t) * np.array([0.9, 0.8, 0.7]) + t * np.array([0.2, 0.35, 0.7])
    img = np.where(up[..., None] < 0, np.array([0.12, 0.1, 0.08]), img)
    # window-like panels on the horizon: four bright rectangles in (phi, theta)
    for k in range(4):
        p0 = 2 * np.pi * (k + 0.2) / 4
        inside = (np.abs(phi[None, :] - p0) < 0.25) & (np.abs(theta[:, None] - np.pi * 0.45) < 0.12)
        img = np.where(inside[..., None], np.array([8.0, 7.5, 6.0]), img)
    # the sun: a disc of angular radius 0.75 degrees at elevation 35 degrees
    d_sun = np.array([np.cos(np.radians(35)) * np.cos(1.0), np.sin(np.radians(35)), np.cos(np.radians(35)) * np.sin(1.0)])
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    dirs = np.stack([st * np.cos(phi)[None, :], ct * np.ones_like(phi)[None, :], st * np.sin(phi)[None, :]], axis=-1)
    ang = np.arccos(np.clip(dirs @ d_sun, -1, 1))
    img = np.where((ang < np.radians(0.75))[..., None], np.array([20000.0, 19000.0, 17000.0]), img)
    return np.ascontiguousarray(img, dtype=np.float32)


def scene():
    return {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 6},
        "sensor": {"type": "perspective", "fov": 45,
                   "to_world": T().look_at(origin=[0, 1.4, 4.5], target=[0, 0.5, 0], up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": 128, "height": 128, "rfilter": {"type": "box"}}},
        "env": {"type": "envmap", "bitmap": mi.Bitmap(environment()), "scale": 1.0},
        "floor": {"type": "rectangle", "to_world": T().rotate([1, 0, 0], -90).scale(6),
                  "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.45, 0.45, 0.45]}}},
        "mirror": {"type": "sphere", "center": [-1.2, 0.6, 0], "radius": 0.6, "bsdf": {"type": "conductor", "material": "Ag"}},
        "metal": {"type": "sphere", "center": [0.1, 0.5, 0.6], "radius": 0.5,
                  "bsdf": {"type": "roughconductor", "material": "Cu", "alpha": 0.15}},
        "matte": {"type": "sphere", "center": [1.3, 0.55, -0.2], "radius": 0.55,
                  "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.7, 0.7, 0.65]}}},
    }
