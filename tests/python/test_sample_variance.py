"""Each sample's variance (csi_samples.variance; csi-reconstruct --variance, a dump of the same
positions whose values are the variances; csi.reconstruct(variance=...)), end to end through the
library, the program and the binding, on samples whose outcome csi/peak_noise.h states exactly:

- 1 sample per pixel on csi's stratified positions (32 x 32 pixels, 4x grid), values 1 + 0.05 u
  (u uniform in [-1, 1]) with variance 1e-4, and two isolated peaks of 20: one with variance 1
  (excess 19 > 3 sd: the image's, so its pixel keeps the value it has without the variances) and
  one with variance 400 (one path carrying the whole value: noise, with v above its excess
  squared, so the shrink keeps none of it and the pixel is the median of its 8 neighbours'
  samples, computed here in double and rounded to float as the library does);
- without the variances that pixel differs from the median (the rule is what set it), and no
  other pixel moves;
- csi-reconstruct --variance writes the same image as csi.reconstruct(variance=...) (the stats'
  FNV-1a hash), and a variance dump of other positions is refused: exit 2, one line naming it;
- at 2 samples per pixel, a sample of 20 with variance 400 beside one near 1 is noise against its
  pixel's other sample: the pixel is that sample's value exactly, and no other pixel moves;
- in 4 tiles the rule acts in each tile's window: the noisy peak is the neighbours' median again
  (to float rounding: a pixel two tiles' windows share is their weighted blend of it), no other
  pixel than it moves against the tiles without the variances, and tiles made one at a time
  (csi-reconstruct --tile I/N --variance, csi.reconstruct_tile(variance=...)) and merged give the
  in-process tiled image bit for bit; csi-reconstruct takes the variances beside a dump by default,
  and a tile run without them does not merge with tiles run with them."""
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

SOURCE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BUILD = os.environ.get("CSI_BUILD_DIR") or os.path.join(SOURCE, "build")
sys.path.insert(0, os.path.join(SOURCE, "host", "python"))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import csi  # noqa: E402
from csi import dump as csid  # noqa: E402
from checks import check, done  # noqa: E402

OW, F = 32, 4
GRID = (OW * F, OW * F, 1, OW, OW)


def samples(spp, seed):
    pos = csi.positions(GRID, spp=spp, method="stratified", seed=seed)
    rng = np.random.default_rng(seed)
    val = (1 + 0.05 * rng.uniform(-1, 1, len(pos))).astype(np.float32)[:, None]
    var = np.full_like(val, 1e-4)
    return pos, val, var


pos, val, var = samples(1, 3)
pix = (pos[:, 1] // F) * OW + pos[:, 0] // F
keep, noise = 10 * OW + 8, 20 * OW + 22  # two pixels well apart, neither at the border
for p, v in ((keep, 1.0), (noise, 400.0)):
    i = int(np.flatnonzero(pix == p)[0])
    val[i], var[i] = 20.0, v
img_of = np.zeros(OW * OW)
img_of[pix] = val[:, 0]
ny, nx = divmod(noise, OW)
nbrs = [img_of[(ny + dy) * OW + nx + dx] for dy in (-1, 0, 1) for dx in (-1, 0, 1) if dy or dx]
want_noise = np.float32(np.median(np.array(nbrs, np.float64)))

with_v = csi.reconstruct(pos, val, GRID, variance=var).image[:, :, 0].ravel()
without = csi.reconstruct(pos, val, GRID).image[:, :, 0].ravel()
check(with_v[noise] == want_noise, f"the noisy peak: {with_v[noise]}, want the neighbours' median {want_noise}")
check(without[noise] != want_noise and without[noise] > 2 * want_noise,
      f"without the variances the noisy peak is the blend's, near its sample: {without[noise]}")
changed = np.flatnonzero(with_v != without)
check(changed.tolist() == [noise], f"pixels changed: {changed.tolist()}, want the noisy peak's only")

with tempfile.TemporaryDirectory() as T:
    req = csi.positions(GRID, spp=1, method="stratified", seed=3)
    d = csid.Dump(grid=GRID[:3], out=GRID[3:], xyt=req, values=val, seed=1)
    csid.write(os.path.join(T, "s.csid"), d)
    csid.write(os.path.join(T, "s.variance.csid"), csid.Dump(grid=GRID[:3], out=GRID[3:], xyt=req, values=var, seed=1))
    other = csi.positions(GRID, spp=1, method="stratified", seed=4)
    csid.write(os.path.join(T, "o.variance.csid"), csid.Dump(grid=GRID[:3], out=GRID[3:], xyt=other, values=var, seed=1))
    r = subprocess.run([os.path.join(BUILD, "csi-reconstruct"), os.path.join(T, "s.csid"), "-o", os.path.join(T, "c.exr"),
                        "--variance", os.path.join(T, "s.variance.csid"), "--stats", os.path.join(T, "c.json"), "-q"])
    py = csi.reconstruct_dump(os.path.join(T, "s.csid"), variance_path=os.path.join(T, "s.variance.csid"))
    check(r.returncode == 0 and json.load(open(os.path.join(T, "c.json")))["image_fnv1a64"] == py.stats["image_fnv1a64"],
          "csi-reconstruct --variance and csi.reconstruct_dump(variance_path=...): the same bits")
    check(json.load(open(os.path.join(T, "c.json"))).get("variance", "").endswith("s.variance.csid"),
          "the stats do not name the variances' file")
    check(py.image[noise // OW, noise % OW, 0] == want_noise, "the dump's noisy peak taken as noise as well")
    r = subprocess.run([os.path.join(BUILD, "csi-reconstruct"), os.path.join(T, "s.csid"), "-o", os.path.join(T, "x.exr"),
                        "--variance", os.path.join(T, "o.variance.csid")], capture_output=True, text=True)
    lines = r.stderr.strip().splitlines()
    check(r.returncode == 2 and len(lines) == 1 and "o.variance.csid" in lines[0] and "not its variances" in lines[0]
          and not os.path.exists(os.path.join(T, "x.exr")), f"other positions refused: {r.returncode} {r.stderr!r}")

    topts = dict(tiles=4, tile_margin=4)
    tiled = csi.reconstruct(pos, val, GRID, variance=var, **topts)
    plain = csi.reconstruct(pos, val, GRID, **topts).image[:, :, 0].ravel()
    tv = tiled.image[:, :, 0].ravel()
    check(tiled.info["tiles"] == 4, f"tiles: {tiled.info['tiles']}")
    check(abs(float(tv[noise]) - float(want_noise)) <= 1e-6 * float(want_noise),
          f"tiled: the noisy peak {tv[noise]}, want the neighbours' median {want_noise}")
    check(np.flatnonzero(tv != plain).tolist() == [noise], f"tiled: pixels changed {np.flatnonzero(tv != plain).tolist()}")
    parts = []
    for i in (2, 0, 3):
        t = csi.reconstruct_tile(pos, val, GRID, i, variance=var, **topts)
        parts.append(os.path.join(T, f"t{i}.csip"))
        t.write_partial(parts[-1], "s.csid")
    parts.append(os.path.join(T, "t1.csip"))
    r = subprocess.run([os.path.join(BUILD, "csi-reconstruct"), os.path.join(T, "s.csid"), "--tile", "1/4",
                        "--tile-margin", "4", "--variance", os.path.join(T, "s.variance.csid"), "-o", parts[-1], "-q"])
    m = csi.merge_partials(parts)
    check(r.returncode == 0 and m.stats["image_fnv1a64"] == tiled.stats["image_fnv1a64"],
          f"merged tiles {m.stats['image_fnv1a64']} vs in-process tiles {tiled.stats['image_fnv1a64']}")
    # csi-reconstruct takes s.variance.csid beside s.csid by default: the same tile; a tile run
    # without them (--variance none) is another run's, and the merge refuses it
    auto, none = os.path.join(T, "t1a.csip"), os.path.join(T, "t1n.csip")
    for path, extra in ((auto, []), (none, ["--variance", "none"])):
        r = subprocess.run([os.path.join(BUILD, "csi-reconstruct"), os.path.join(T, "s.csid"), "--tile", "1/4",
                            "--tile-margin", "4", "-o", path, "-q"] + extra)
        check(r.returncode == 0, f"csi-reconstruct --tile 1/4 {extra}: exit {r.returncode}")
    m = csi.merge_partials(parts[:-1] + [auto])
    check(m.stats["image_fnv1a64"] == tiled.stats["image_fnv1a64"], "the variances beside the dump: another tile")
    try:
        csi.merge_partials(parts[:-1] + [none])
        check(False, "tiles with and without the variances merged")
    except csi.CsiError as e:
        check("input" in str(e) or "another" in str(e) or "differ" in str(e), f"the merge's refusal: {e}")

pos, val, var = samples(2, 5)
pix = (pos[:, 1] // F) * OW + pos[:, 0] // F
p2 = 12 * OW + 17
i, j = np.flatnonzero(pix == p2)[:2]
val[i], var[i] = 20.0, 400.0  # a peak its own noise explains, against the pixel's other sample
a = csi.reconstruct(pos, val, GRID, variance=var).image[:, :, 0].ravel()
b = csi.reconstruct(pos, val, GRID).image[:, :, 0].ravel()
check(a[p2] == val[j, 0], f"2 samples per pixel: the noisy sample's pixel {a[p2]}, want the other sample {val[j, 0]}")
check(np.flatnonzero(a != b).tolist() == [p2], f"2 samples per pixel: pixels changed {np.flatnonzero(a != b).tolist()}")

sys.exit(done())
