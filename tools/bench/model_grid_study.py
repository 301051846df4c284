#!/usr/bin/env python3
"""Where a coarser model grid (--model-sigma-min) loses against the exact one, per dump (issue 13).

For every dump of bench_cost.py's quality sets (or those whose name contains --only), runs
csi-reconstruct in each configuration of --config (NAME:ARGS, repeatable; the first is the
reference configuration, default: the exact grid and `--model-sigma-min 0.75`, each also with
a tight last stage), and reports per dump: D, steps, the MSE against the reference of each
configuration over the first's (and the ratios of --ratio A/B), and where each other
configuration's extra error sits against the first's:
  - edge / flat: the change of the squared error summed over the reference's edge pixels
    (bench_common.edge_mask) and over the others, as fractions of the first configuration's
    total squared error (their sum is the MSE ratio minus 1);
  - hi: the share of the two images' difference energy above half the output's Nyquist
    frequency (|f| > 1/4 cycle per pixel on either axis).
  - with --fold-cv, a rule that would choose between the first two configurations from the
    samples alone: each pixel's samples split in two folds (csi_cv_folds' rule), each fold
    reconstructed in both with the whole dump's filter width and tau, and z = sum D_p /
    sqrt(sum D_p^2), D_p the second configuration's squared error against the other fold's
    pixel mean minus the first's, summed over both directions and the channels (> 0: the
    second loses on the held-out means); dumps under 2 samples per pixel get none.
The tight stop shows whether a configuration's loss is a bias of its model or where the
default stop happened to end: the default stop is early (an objective change of 3e-3), and its
result moves by a few % with any change of the steps' path.
Usage (from a worktree root, after building):
  .venv/bin/python tools/bench/model_grid_study.py --work /tmp/q --md q.md
  .venv/bin/python tools/bench/model_grid_study.py --work /tmp/q --quality-sets mitsuba --only thin
"""
import argparse
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bench_common as bc  # noqa: E402
import bench_cost  # noqa: E402

DEFAULT_CONFIGS = ("exact:", "coarse:--model-sigma-min 0.75",
                   "exact-tight:--tol 1e-4 --max-iter 1000",
                   "coarse-tight:--model-sigma-min 0.75 --tol 1e-4 --max-iter 1000")
DEFAULT_RATIOS = ("coarse/exact", "coarse-tight/exact-tight", "exact-tight/exact")


def hi_share(d):
    """Share of the energy of d (H, W, c) above a quarter cycle per pixel on either axis."""
    F = np.fft.fft2(d.astype(np.float64), axes=(0, 1))
    fy = np.abs(np.fft.fftfreq(d.shape[0]))[:, None]
    fx = np.abs(np.fft.fftfreq(d.shape[1]))[None, :]
    e = np.abs(F) ** 2
    tot = e.sum()
    return float(e[(fy > 0.25) | (fx > 0.25)].sum() / tot) if tot > 0 else 0.0


def study(args, bins, dump, ref, configs):
    out = {}
    imgs = {}
    for name, extra in configs:
        exr, js = os.path.join(args.work, "mg_v.exr"), os.path.join(args.work, "mg_v.json")
        _, _, st = bench_cost.reconstruct(args.build, dump, exr, js, extra)
        img = bc.read_exr(exr)
        imgs[name] = img
        out[name] = dict(mse=bc.mse(img, ref), D=st.get("model_grid_factor", 1),
                         steps=[c["iterations"] for c in st["channels"].values() if c.get("t_total_s", 1) > 0])
    base = configs[0][0]
    e0 = ((imgs[base].astype(np.float64) - ref) ** 2)
    mask = bc.edge_mask(ref if ref.shape[-1] == 3 else np.repeat(ref[..., :1], 3, axis=-1))
    for name, _ in configs[1:]:
        e1 = ((imgs[name].astype(np.float64) - ref) ** 2)
        de = (e1 - e0).sum(axis=-1) if e1.ndim == 3 else e1 - e0
        tot = e0.sum()
        out[name].update(edge=float(de[mask].sum() / tot), flat=float(de[~mask].sum() / tot),
                         hi=hi_share(imgs[name] - imgs[base]))
    out["edge_pixels"] = float(mask.mean())
    return out


def _write_subset(src, dst, mask):
    """A dump of the records of src selected by mask (the header's words kept, the count set)."""
    with open(src, "rb") as f:
        head, body = f.read(64), f.read()
    h = np.frombuffer(head, "<u4").copy()
    c, n = int(h[7]), int(h[8]) | (int(h[9]) << 32)
    rec = np.frombuffer(body, dtype=[("p", "<u4", 3), ("v", "<f4", c)], count=n)[mask]
    h[8], h[9] = len(rec) & 0xFFFFFFFF, len(rec) >> 32
    with open(dst, "wb") as f:
        f.write(h.tobytes())
        f.write(rec.tobytes())


def fold_cv(args, dump, configs):
    """The two-fold cross-validation of configs[1] against configs[0] (the module's docstring)."""
    hdr, pos, val = bc.read_dump(dump)
    ow, oh, c = hdr["out_w"], hdr["out_h"], hdr["channels"]
    npx = ow * oh
    if len(val) < 2 * npx:
        return None
    bw, bh = hdr["grid_w"] // ow, hdr["grid_h"] // oh
    p = (pos[:, 1] // bh).astype(np.int64) * ow + pos[:, 0] // bw
    k = np.ceil(np.sqrt(np.bincount(p, minlength=npx)[p])).astype(np.int64)
    fold = ((pos[:, 0] % bw).astype(np.int64) * k // bw + (pos[:, 1] % bh).astype(np.int64) * k // bh) & 1
    means, cnts = [], []
    for f in (0, 1):
        m = fold == f
        cnt = np.bincount(p[m], minlength=npx)
        cnts.append(cnt)
        means.append(np.stack([np.bincount(p[m], weights=val[m, j].astype(np.float64), minlength=npx)
                               for j in range(c)], -1) / np.maximum(cnt, 1)[:, None])
    both = (cnts[0] > 0) & (cnts[1] > 0)
    # the whole dump's filter width (sigma-spacing x sqrt(k / n)) and tau (3e-3 / spp) in a fold
    # of about half the samples: csi-reconstruct's rules at the whole's density
    same = ["--sigma-spacing", f"{0.8 * np.sqrt(0.5):.6f}", "--tau", f"{max(3e-3 * npx / len(val), 1e-5):.6g}"]
    err = {}
    for f in (0, 1):
        fd = os.path.join(args.work, "mg_fold.csid")
        _write_subset(dump, fd, fold == f)
        for name, extra in configs[:2]:
            exr, js = os.path.join(args.work, "mg_f.exr"), os.path.join(args.work, "mg_f.json")
            bench_cost.reconstruct(args.build, fd, exr, js, [*extra, *same])
            img = bc.read_exr(exr).astype(np.float64).reshape(npx, -1)[:, :c]
            err[name] = err.get(name, 0) + ((img - means[1 - f]) ** 2).sum(axis=-1)
    d = (err[configs[1][0]] - err[configs[0][0]])[both]
    return dict(z=float(d.sum() / np.sqrt((d ** 2).sum())) if (d ** 2).sum() > 0 else 0.0,
                rel=float(d.sum() / err[configs[0][0]][both].sum()))


def markdown(rows, configs, ratios):
    """A table of the dumps where the configurations' D differ, and each ratio's range."""
    first = configs[0]
    rows = [r for r in rows if len({r[c]["D"] for c in configs}) > 1]
    lines = []
    for a, b in ratios:
        v = np.array([r[a]["mse"] / r[b]["mse"] for r in rows])
        if len(v):
            lines.append(f"- MSE {a} / {b} over {len(v)} dumps: {v.min():.4f}-{v.max():.4f}, geometric mean "
                         f"{np.exp(np.log(v).mean()):.4f}, above 1.02 on {int((v > 1.02).sum())}")
    lines += ["", "| samples | D | MSE " + first + " | " + " | ".join(f"{a} / {b}" for a, b in ratios) +
              " | " + " | ".join(f"{c}: edge, flat" for c in configs[1:2]) + " |",
              "|" + "---|" * (4 + len(ratios))]
    for r in rows:
        lines.append(f"| {r['name']} | {' / '.join(str(r[c]['D']) for c in configs[:2])} | {r[first]['mse']:.4e} | " +
                     " | ".join(f"{r[a]['mse'] / r[b]['mse']:.4f}" for a, b in ratios) + " | " +
                     " | ".join(f"{r[c]['edge']:+.4f}, {r[c]['flat']:+.4f}" for c in configs[1:2]) + " |")
    return "\n".join(lines) + "\n" + fold_cv_markdown(rows, configs)


def fold_cv_markdown(rows, configs):
    """The --fold-cv rule against the MSE: a table and the dumps where its sign is wrong."""
    cv = [r for r in rows if r.get("fold_cv")]
    if not cv:
        return ""
    a, b = configs[1], configs[0]
    wrong = [r["name"] for r in cv if (r["fold_cv"]["z"] <= 0) != (r[a]["mse"] <= r[b]["mse"])]
    lines = ["", f"- fold-cv: z <= 0 (the rule would take {a}) on {sum(r['fold_cv']['z'] <= 0 for r in cv)} of "
             f"{len(cv)} dumps; {a}'s MSE <= {b}'s on {sum(r[a]['mse'] <= r[b]['mse'] for r in cv)}; "
             f"the sign disagrees on {len(wrong)}", "",
             f"| samples | {a} / {b} MSE | fold-cv z |", "|---|---|---|"]
    lines += [f"| {r['name']} | {r[a]['mse'] / r[b]['mse']:.4f} | {r['fold_cv']['z']:+.2f} |" for r in cv]
    return "\n".join(lines) + "\n"


def emit(text, md_path):
    print(text, end="")
    if md_path:
        with open(md_path, "w") as f:
            f.write(text)
    return 0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default=os.path.join(bc.ROOT, "build"))
    ap.add_argument("--work", default="/tmp/csi-model-grid-study", help="dumps, references, scratch (kept)")
    ap.add_argument("--quality-sets", default="bundled256,bundled,analytic,mitsuba")
    ap.add_argument("--quality-spp", default="1,4", type=lambda v: tuple(int(x) for x in v.split(",")))
    ap.add_argument("--mitsuba-data", default="/work/data/mitsuba")
    ap.add_argument("--only", action="append", default=[], help="dumps whose name contains this (repeatable)")
    ap.add_argument("--config", action="append", default=[], metavar="NAME:ARGS",
                    help="a configuration: its name and csi-reconstruct arguments (repeatable; the first is "
                    "the reference) [" + ", ".join(DEFAULT_CONFIGS) + "]")
    ap.add_argument("--ratio", action="append", default=[], metavar="A/B",
                    help="also report config A's MSE over config B's [" + ", ".join(DEFAULT_RATIOS) +
                    " with the default configurations]")
    ap.add_argument("--fold-cv", action="store_true",
                    help="also the two-fold cross-validation of the second configuration against the first")
    for flag, what in (("--json", "every figure (rewritten after each dump)"), ("--md", "the table as markdown"),
                       ("--from-json", "no runs: the table of an earlier --json")):
        ap.add_argument(flag, help=what)
    args = ap.parse_args(argv)
    bad = [c for c in args.config if ":" not in c or not c.split(":", 1)[0]]
    if bad:
        ap.error(f"--config {bad[0]}: not NAME:ARGS")
    configs = [(c.split(":", 1)[0], c.split(":", 1)[1].split()) for c in (args.config or DEFAULT_CONFIGS)]
    names = [c for c, _ in configs]
    ratios = [tuple(r.split("/", 1)) for r in (args.ratio or ([] if args.config else DEFAULT_RATIOS))]
    for a, b in ratios:
        if a not in names or b not in names:
            ap.error(f"--ratio {a}/{b}: not the names of two configurations ({', '.join(names)})")
    if args.from_json:
        try:
            with open(args.from_json) as f:
                rows = json.load(f)["rows"]
            missing = {c for r in rows for c in names if c not in r}
        except (OSError, ValueError, KeyError, TypeError) as e:
            ap.error(f"{args.from_json}: not a --json of this tool ({e})")
        if missing:
            ap.error(f"{args.from_json}: no configuration {sorted(missing)[0]} in it (use its --config names)")
        return emit(markdown(rows, names, ratios), args.md)
    os.makedirs(args.work, exist_ok=True)
    bins = bc.binaries(args.build)
    rows = []
    for name, dump, ref in bench_cost.quality_dumps(args, bins):
        if args.only and not any(o in name for o in args.only):
            continue
        r = study(args, bins, dump, ref.astype(np.float64), configs)
        if args.fold_cv and r[configs[0][0]]["D"] != r[configs[1][0]]["D"]:
            r["fold_cv"] = fold_cv(args, dump, configs)
        rows.append(dict(name=name, **r))
        b = r[configs[0][0]]
        bc.log(f"{name}: D {b['D']}, MSE {b['mse']:.4e}, steps {b['steps']}; " + "; ".join(
            f"{c} D {r[c]['D']} {r[c]['mse'] / b['mse']:.4f} steps {r[c]['steps']} edge {r[c]['edge']:+.4f} "
            f"flat {r[c]['flat']:+.4f} hi {r[c]['hi']:.2f}" for c, _ in configs[1:]))
        if args.json:
            with open(args.json, "w") as f:
                json.dump(dict(configs=names, rows=rows), f, indent=1)
    return emit(markdown(rows, names, ratios), args.md)


if __name__ == "__main__":
    sys.exit(main())
