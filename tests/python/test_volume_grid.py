"""A volume's spatial grid (csi_default_grid_factor for t > 1; issue 12, docs/bench/animation.md
sessions 42-44): 2 x 2 cells a pixel from one sample per 8 frames, 3 x 3 from 9 spp and 4 x 4 from 16,
because a pixel of one cell is seen at its centre only, and one of 2 x 2 cells at four points.

Scene: a still sinusoidal texture 0.5 + 0.4 sin(2 pi (fx x + fy y)) (x, y in pixels), exact point
values at the cells' centres, 32 x 32 pixels, 8 frames, stratified positions. The truth is each
pixel's area mean, in closed form: the box integral of a sinusoid over a unit square scales it by
sinc(fx) sinc(fy) (numpy's normalised sinc) and centres it on the pixel's centre. Two textures, at
0.31 and 0.42 cycles a pixel along x.

1. The rule: at 8 frames the default is 2 from 1 spp, 3 from 9 and 4 from 16; at 32 frames 1 below
   4 spp and 2 from 4.
2. On the pixel grid (1x) every sample of a pixel is its centre's value, so the image cannot do
   better than the centre values themselves (the aliasing floor, here 2.9e-3 and 8.6e-3): at 2, 4
   and 6 spp its MSE against the truth is that floor to 1% (the still pixels take their samples'
   value), more samples do not lower it.
3. On the default grid (2x) the image's MSE falls from 2 to 4 spp and from 4 spp is below 0.2x the
   1x floor (measured 0.046x and 0.038x at 4 spp: the margin is over 4x).
4. 2 x 2 cells have a floor of their own: the mean of the four cells' centres, (+-1/4, +-1/4)
   pixels from the pixel's, scales the sinusoid by cos(pi fx / 2) cos(pi fy / 2) instead of the
   area's sinc(fx) sinc(fy) (here 1.5e-4 and 3.6e-4). Stratified positions deal a pixel's four
   cells one sample each, so from 4 spp the 2x image is at that floor: at 4, 6, 9 and 16 spp over
   8 frames within 10% of it (measured 0.91-1.08x); the default grid at 9 spp (3x) is below 0.5x
   of it (measured 0.31x and 0.38x) and at 16 spp (4x) below 0.25x (measured 0.14x).
5. Neither texture takes a velocity, on any grid at any spp: a sinusoid is constant along its wavefronts, so the velocity
   search's leave-one-out predicts it as well along them as any mover; the mirror test
   (motion_velocity.c) refuses such a shear, which cost 5x the image MSE at 2 and 4 spp.
"""
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "host", "python"))
sys.path.insert(0, HERE)
import csi  # noqa: E402
from checks import check, done  # noqa: E402

W = H = 32
T = 8


def texture(x, y, fx, fy):
    return 0.5 + 0.4 * np.sin(2 * np.pi * (fx * x + fy * y))


def image_mse(F, spp, fx, fy, truth):
    g = (W * F, H * F, T, W, H)
    pos = csi.positions(g, spp=spp, method="stratified", seed=3)
    v = texture((pos[:, 0] + 0.5) / F, (pos[:, 1] + 0.5) / F, fx, fy).astype(np.float32)[:, None]
    r = csi.reconstruct(pos, v, g, exact=True)
    o = r.stats["options"]
    check(o["motion_vx"] == 0 and o["motion_vy"] == 0,
          f"({fx}, {fy}) {F}x at {spp} spp: a still texture sheared by ({o['motion_vx']}, {o['motion_vy']})")
    img = np.asarray(r.image, np.float64).reshape(H, W)
    return float(((img - truth) ** 2).mean())


def main():
    for t, spp, f in ((8, 1, 2), (32, 3, 1), (32, 4, 2), (8, 8, 2), (8, 9, 3), (8, 15, 3), (8, 16, 4)):
        got = csi.default_grid_factor(W, H, t, spp)
        check(got == f, f"default grid at {t} frames, {spp} spp: {got}, want {f}")
    i, j = np.meshgrid(np.arange(W) + 0.5, np.arange(H) + 0.5)
    for fx, fy in ((0.31, 0.17), (0.42, 0.23)):
        truth = 0.5 + 0.4 * np.sinc(fx) * np.sinc(fy) * np.sin(2 * np.pi * (fx * i + fy * j))
        floor = float(((texture(i, j, fx, fy) - truth) ** 2).mean())
        one = [image_mse(1, s, fx, fy, truth) for s in (2, 4, 6)]
        two = [image_mse(2, s, fx, fy, truth) for s in (2, 4, 6)]
        print(f"texture ({fx}, {fy}): floor {floor:.3e}; 1x {', '.join(f'{e:.3e}' for e in one)}; "
              f"2x {', '.join(f'{e:.3e}' for e in two)} (2, 4, 6 spp)")
        check(all(abs(e / floor - 1) < 0.01 for e in one), f"({fx}, {fy}) 1x: {one} is not the floor {floor:.3e}")
        check(two[0] > two[1], f"({fx}, {fy}) 2x: the error does not fall from 2 to 4 spp: {two}")
        check(two[1] < 0.2 * floor and two[2] < 0.2 * floor,
              f"({fx}, {fy}) 2x at 4 and 6 spp: {two[1:]} not below 0.2x the floor {floor:.3e}")
        quad = 0.5 + 0.4 * np.cos(np.pi * fx / 2) * np.cos(np.pi * fy / 2) * np.sin(2 * np.pi * (fx * i + fy * j))
        floor2 = float(((quad - truth) ** 2).mean())
        high2 = [image_mse(2, s, fx, fy, truth) for s in (9, 16)]
        dflt = image_mse(csi.default_grid_factor(W, H, T, 16), 16, fx, fy, truth)
        dflt9 = image_mse(csi.default_grid_factor(W, H, T, 9), 9, fx, fy, truth)
        print(f"  2 x 2 cells' floor {floor2:.3e}; 2x {', '.join(f'{e:.3e}' for e in high2)} (9, 16 spp); "
              f"default at 9 spp {dflt9:.3e}, at 16 spp {dflt:.3e}")
        check(all(abs(e / floor2 - 1) < 0.1 for e in two[1:] + high2),
              f"({fx}, {fy}) 2x at 4, 6, 9 and 16 spp: {two[1:] + high2} not at its floor {floor2:.3e}")
        check(dflt9 < 0.5 * floor2, f"({fx}, {fy}) default grid at 9 spp: {dflt9:.3e} not below 0.5x of 2x's floor "
              f"{floor2:.3e}")
        check(dflt < 0.25 * floor2, f"({fx}, {fy}) default grid at 16 spp: {dflt:.3e} not below 0.25x of 2x's floor "
              f"{floor2:.3e}")
    return done()


if __name__ == "__main__":
    sys.exit(main())
